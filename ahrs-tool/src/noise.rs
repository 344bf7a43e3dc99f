//! `ahrs-tool noise TRACE [--out FILE] [--from S] [--to S]`: the noise settings measured from
//! a still recording (`host_tests::allan`): `noise.gyro_var`, `noise.accel_var` (per sample at
//! the recording's rate) and `ekf.bias_random_walk`, with the mean rate as `init.gyro_bias`, as
//! a settings file that `ahrs-tool settings put` sends to the device and `host-tests replay
//! --settings` reads.

use std::io::Write;
use std::path::Path;

use host_tests::allan::{analyse, RecordingNoise, FLICKER_AVAR_PER_B2};
use host_tests::output::{refuse_overwriting_inputs, write_atomically};
use host_tests::settings::parse_assignment;
use host_tests::trace::read_trace_file;

const DEG: f64 = 180.0 / core::f64::consts::PI;

/// The settings text for `r` (from `source`): a comment header with each axis's figures, then
/// `NAME=VALUE` lines, each checked against the registry (a value out of its range is left as
/// a comment that says so).
pub fn settings_text(r: &RecordingNoise, source: &str) -> String {
    let mut t = format!(
        "# noise settings measured by ahrs-tool noise from {source}: {:.0} s still at {:.2} Hz\n\
         # Allan variance fit per axis (IEEE Std 952): white noise N, bias instability B (the flat\n\
         # part of the Allan deviation is 0.664 B), rate random walk K (0: not resolved)\n",
        r.duration_s, r.rate_hz
    );
    for (a, f) in r.gyro.iter().enumerate() {
        t.push_str(&format!(
            "# gyro {}: N {:.4} deg/s/sqrt(Hz), B {:.4} deg/s, K {:.5} deg/s/sqrt(s)\n",
            ["x", "y", "z"][a],
            f.white * DEG,
            f.instability * DEG,
            f.walk * DEG
        ));
    }
    for (a, f) in r.accel.iter().enumerate() {
        t.push_str(&format!(
            "# accelerometer {}: N {:.3e} g/sqrt(Hz), B {:.2e} g\n",
            ["x", "y", "z"][a],
            f.white,
            f.instability
        ));
    }
    // The reference rate is the recording's (the registry takes 1–1000 Hz; 50 Hz outside it:
    // the per-sample variance is the density times the rate either way).
    let rate = if (1.0..=1000.0).contains(&r.rate_hz) {
        (r.rate_hz * 100.0).round() / 100.0
    } else {
        50.0
    };
    let gyro: Vec<String> =
        r.gyro.iter().map(|f| format!("{:.4e}", (f.white * DEG).powi(2) * rate)).collect();
    let accel = r.accel.iter().map(|f| f.white * f.white * rate).sum::<f64>() / 3.0;
    // The bias at rest, as the trace has the rates (after `gyro.offset`): what a start in
    // motion assumes.
    let bias: Vec<String> = r.gyro_mean.iter().map(|b| format!("{:.4}", b * DEG)).collect();
    let mut lines = vec![
        format!("init.gyro_bias={}", bias.join(",")),
        format!("noise.gyro_var={}", gyro.join(",")),
        format!("noise.gyro_ref_rate={rate}"),
        format!("noise.accel_var={accel:.4e}"),
        format!("noise.accel_ref_rate={rate}"),
    ];
    // One random walk for the three axes: the largest resolved (a filter that assumes less
    // walk than an axis has is overconfident on that axis).
    let walk = r.gyro.iter().map(|f| f.walk).fold(0.0f64, f64::max);
    if walk > 0.0 {
        lines.push(format!("ekf.bias_random_walk={:.4e}", (walk * DEG).powi(2)));
    } else {
        let bound = r.gyro.iter().map(|f| f.walk_bound).fold(0.0f64, f64::max);
        let tau = r.gyro.iter().map(|f| f.tau_max).fold(0.0f64, f64::max);
        t.push_str(&format!(
            "# ekf.bias_random_walk not measured: no rate random walk shows up to tau = {tau:.0} s\n\
             # (the curve allows at most {:.2e} (deg/s)2/s); record an hour or more still for it\n",
            (bound * DEG).powi(2)
        ));
    }
    let flicker = r.gyro.iter().map(|f| f.instability).fold(0.0f64, f64::max);
    if flicker > 0.0 {
        t.push_str(&format!(
            "# the largest bias instability, B {:.4} deg/s (Allan floor {:.4} deg/s), is not a setting:\n\
             # rest detection re-measures the bias while the vehicle is still\n",
            flicker * DEG,
            flicker * FLICKER_AVAR_PER_B2.sqrt() * DEG
        ));
    }
    for l in lines {
        match parse_assignment(&l) {
            Ok(_) => t.push_str(&format!("{l}\n")),
            Err(e) => t.push_str(&format!("# {l}: not applied: {e}\n")),
        }
    }
    t
}

/// `ahrs-tool noise TRACE [--out FILE] [--from S] [--to S]`: the settings file to `out`
/// (standard output without it), the figures to standard error; only the rows with a time in
/// `[from, to]` when given.
pub fn run(
    trace: &Path,
    out: Option<&Path>,
    from: Option<f64>,
    to: Option<f64>,
) -> Result<(), String> {
    if let Some(out) = out {
        refuse_overwriting_inputs(out, &[trace]).map_err(|e| e.to_string())?;
    }
    let (_, rows) = read_trace_file(trace).map_err(|e| format!("{}: {e}", trace.display()))?;
    let (lo, hi) = (from.unwrap_or(f64::NEG_INFINITY), to.unwrap_or(f64::INFINITY));
    let rows: Vec<_> = rows.into_iter().filter(|r| r.t >= lo && r.t <= hi).collect();
    let r = analyse(&rows).map_err(|e| format!("{}: {e}", trace.display()))?;
    let mut source = trace.display().to_string();
    if from.is_some() || to.is_some() {
        source.push_str(&format!(" (t = {} to {} s)", rows[0].t, rows[rows.len() - 1].t));
    }
    let text = settings_text(&r, &source);
    match out {
        Some(out) => {
            write_atomically(out, |w| w.write_all(text.as_bytes()))
                .map_err(|e| format!("{}: {e}", out.display()))?;
            eprint!(
                "{}",
                text.lines()
                    .filter(|l| l.starts_with('#'))
                    .map(|l| format!("{l}\n"))
                    .collect::<String>()
            );
            eprintln!("settings written to {}", out.display());
        }
        None => print!("{text}"),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use host_tests::allan::NoiseFit;

    fn fit(white: f64, walk: f64) -> NoiseFit {
        NoiseFit { white, instability: 1e-4, walk, tau_max: 360.0, walk_bound: 5e-5 }
    }

    /// The settings from figures by hand: N = 0.0821 °/s/√Hz at 50 Hz is a per-sample variance
    /// of 0.0821²·50 = 0.337 (°/s)²; K = 0.002 °/s/√s is 4e−6 (°/s)²/s, the largest axis's;
    /// every line passes the registry's checks.
    #[test]
    fn settings_follow_the_figures() {
        let n = 0.337f64.sqrt() / 50f64.sqrt() / DEG;
        let a = (2.376e-6f64 / 50.0).sqrt();
        let r = RecordingNoise {
            rate_hz: 50.0,
            duration_s: 7200.0,
            gyro_mean: [1.619 / DEG, 3.44 / DEG, -0.0042 / DEG],
            gyro: [fit(n, 0.002 / DEG), fit(n, 0.001 / DEG), fit(n / 9.0, 0.0)],
            accel: [NoiseFit {
                white: a,
                instability: 0.0,
                walk: 0.0,
                tau_max: 720.0,
                walk_bound: 0.0,
            }; 3],
        };
        let t = settings_text(&r, "still.csv");
        assert!(t.contains("\nnoise.gyro_var=3.3700e-1,3.3700e-1,4.1605e-3\n"), "{t}");
        assert!(t.contains("\nnoise.gyro_ref_rate=50\n"), "{t}");
        assert!(t.contains("\nnoise.accel_var=2.3760e-6\n"), "{t}");
        assert!(t.contains("\nekf.bias_random_walk=4.0000e-6\n"), "{t}");
        assert!(t.contains("\ninit.gyro_bias=1.6190,3.4400,-0.0042\n"), "{t}");
        for l in t.lines().filter(|l| !l.starts_with('#')) {
            parse_assignment(l).unwrap();
        }
        // No walk resolved: no setting, a comment with the bound.
        let r = RecordingNoise { gyro: [fit(n, 0.0); 3], ..r };
        let t = settings_text(&r, "still.csv");
        assert!(!t.contains("\nekf.bias_random_walk="), "{t}");
        assert!(t.contains("# ekf.bias_random_walk not measured"), "{t}");
    }
}
