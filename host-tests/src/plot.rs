//! `plot`: truth vs estimate and the error, per Euler axis, as a PNG (plotters, bitmap
//! backend).
//!
//! Text uses `ab_glyph` with a TrueType font read at run time: the file named by the
//! `HOST_TESTS_FONT` environment variable, else the first of a few common system paths
//! (DejaVu Sans, Liberation Sans, FreeSans). Without a font the figure is drawn without text
//! (`HOST_TESTS_FONT=none` forces that).

use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;

use crate::replay::{truth_euler_deg, wrap_deg};
use crate::trace::{EstimateRow, TraceRow};

/// Font family name the figure uses.
const FAMILY: &str = "sans-serif";

const FONT_PATHS: [&str; 6] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
];

/// Register a font for [`FAMILY`] once; true when text can be drawn.
fn font_available() -> bool {
    static FONT: OnceLock<bool> = OnceLock::new();
    *FONT.get_or_init(|| {
        let candidates: Vec<String> = match std::env::var("HOST_TESTS_FONT") {
            Ok(v) if v == "none" => return false,
            Ok(v) if !v.is_empty() => vec![v],
            _ => FONT_PATHS.iter().map(|s| s.to_string()).collect(),
        };
        for p in candidates {
            if let Ok(bytes) = std::fs::read(&p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font(FAMILY, FontStyle::Normal, bytes).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

type Points = Vec<(f64, f64)>;

/// One line of a chart, decimated for drawing.
struct Series {
    points: Points,
    color: RGBColor,
    label: &'static str,
}

impl Series {
    fn new(points: &[(f64, f64)], color: RGBColor, label: &'static str) -> Self {
        Series { points: decimate(points, 2000), color, label }
    }
}

/// Min/max decimation to about `buckets` buckets: keeps spikes visible.
fn decimate(points: &[(f64, f64)], buckets: usize) -> Vec<(f64, f64)> {
    if points.len() <= 2 * buckets {
        return points.to_vec();
    }
    let size = points.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(2 * buckets + 2);
    for chunk in points.chunks(size) {
        let (mut lo, mut hi) = (0, 0);
        for (i, p) in chunk.iter().enumerate() {
            if p.1 < chunk[lo].1 {
                lo = i;
            }
            if p.1 > chunk[hi].1 {
                hi = i;
            }
        }
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push(chunk[a]);
        if b != a {
            out.push(chunk[b]);
        }
    }
    out
}

fn y_range(series: &[&[(f64, f64)]]) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in series {
        for p in *s {
            lo = lo.min(p.1);
            hi = hi.max(p.1);
        }
    }
    if !lo.is_finite() || !hi.is_finite() {
        return -1.0..1.0;
    }
    let pad = ((hi - lo) * 0.05).max(1e-3);
    (lo - pad)..(hi + pad)
}

/// Draw `trace` (truth, when present) and `est` into a PNG at `out` (written directly; wrap
/// in [`crate::output::produce_atomically`] for all-or-nothing output). Rows are matched by
/// index and must have the same times.
pub fn plot(trace: &[TraceRow], est: &[EstimateRow], out: &Path) -> Result<(), String> {
    if trace.len() != est.len() {
        return Err(format!(
            "the estimate has {} rows but the trace has {} (one estimate row per trace row)",
            est.len(),
            trace.len()
        ));
    }
    if let Some((i, _)) = trace
        .iter()
        .zip(est)
        .enumerate()
        .find(|(_, (a, b))| (a.t - b.t).abs() > 1e-6 * (1.0 + a.t.abs()))
    {
        return Err(format!(
            "row {}: estimate time {} differs from trace time {}",
            i + 1,
            est[i].t,
            trace[i].t
        ));
    }
    if est.is_empty() {
        return Err("no rows to plot".into());
    }
    let text = font_available();
    let names = ["roll", "pitch", "yaw"];
    let mut truth: [Points; 3] = Default::default();
    let mut estimate: [Points; 3] = Default::default();
    let mut error: [Points; 3] = Default::default();
    for (tr, e) in trace.iter().zip(est) {
        for (axis, &v) in estimate.iter_mut().zip(&e.euler_deg) {
            axis.push((e.t, v as f64));
        }
        if let Some(q) = tr.truth {
            let te = truth_euler_deg(q);
            for i in 0..3 {
                truth[i].push((tr.t, te[i]));
                error[i].push((tr.t, wrap_deg(e.euler_deg[i] as f64 - te[i])));
            }
        }
    }
    let x_range = est[0].t..est[est.len() - 1].t.max(est[0].t + 1e-3);

    let draw = || -> Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(out, (1600, 1050)).into_drawing_area();
        root.fill(&WHITE)?;
        let body = if text {
            let (title, body) = root.split_vertically(40);
            title.titled("attitude: truth vs estimate, and error (degrees)", (FAMILY, 24))?;
            body
        } else {
            root.clone()
        };
        let areas = body.split_evenly((3, 2));
        for i in 0..3 {
            for col in 0..2 {
                let area = &areas[2 * i + col];
                let (series, caption) = if col == 0 {
                    (
                        vec![
                            Series::new(&estimate[i], RED, "estimate"),
                            Series::new(&truth[i], BLACK, "truth"),
                        ],
                        format!("{} (deg)", names[i]),
                    )
                } else {
                    (
                        vec![Series::new(&error[i], BLUE, "error")],
                        format!("{} error (deg)", names[i]),
                    )
                };
                let refs: Vec<&[(f64, f64)]> = series.iter().map(|d| d.points.as_slice()).collect();
                let mut builder = ChartBuilder::on(area);
                builder.margin(8);
                if text {
                    builder
                        .caption(caption, (FAMILY, 18))
                        .x_label_area_size(40)
                        .y_label_area_size(60);
                }
                let mut chart = builder.build_cartesian_2d(x_range.clone(), y_range(&refs))?;
                let mut mesh = chart.configure_mesh();
                if text {
                    mesh.x_desc("t (s)").label_style((FAMILY, 14));
                } else {
                    mesh.x_labels(0).y_labels(0);
                }
                mesh.draw()?;
                for Series { points: pts, color, label } in series {
                    let s = chart.draw_series(LineSeries::new(pts, color.stroke_width(1)))?;
                    if text {
                        s.label(label).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                        });
                    }
                }
                if text {
                    chart
                        .configure_series_labels()
                        .label_font((FAMILY, 14))
                        .background_style(WHITE.mix(0.8))
                        .border_style(BLACK)
                        .draw()?;
                }
            }
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("drawing failed: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_extremes() {
        let pts: Vec<(f64, f64)> =
            (0..10_000).map(|k| (k as f64, if k == 5_123 { 50.0 } else { 0.0 })).collect();
        let d = decimate(&pts, 100);
        assert!(d.len() <= 202);
        assert!(d.iter().any(|p| p.1 == 50.0));
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
    }
}
