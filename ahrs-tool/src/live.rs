//! `ahrs-tool live`: one line per output update (a cycle's `$PRDID` and `$PINAH` together),
//! refreshed in place on a terminal, one line each when piped; a closed pipe (`live ... |
//! head`) ends it quietly.

use std::{
    io::{self, IsTerminal, Write},
    sync::atomic::Ordering,
    time::{Duration, Instant},
};

use inemo_ahrs::status::Status;

use crate::link::Link;

/// Groups the sentences of one output update. A cycle sends each enabled sentence once, so a
/// sentence kind seen again starts the next update; once the set of kinds one update holds is
/// known (after the first), an update is complete, and shown, as soon as it has them all.
#[derive(Default)]
pub struct Updates {
    /// Kinds of the update being assembled.
    frame: Vec<String>,
    /// Kinds a complete update holds (learned from the previous one).
    known: Vec<String>,
    /// The current update was shown already.
    shown: bool,
}

impl Updates {
    /// A sentence of `kind` arrived (its fields are kept by the caller). Returns how many
    /// updates to show now: 0, 1, or, when it starts a new update, the previous one not yet
    /// shown (its line must be printed from the fields before this sentence's).
    pub fn push(&mut self, kind: &str) -> Push {
        let mut push = Push::default();
        if self.frame.iter().any(|k| k == kind) {
            push.previous = !self.shown;
            self.known = std::mem::take(&mut self.frame);
            self.shown = false;
        }
        self.frame.push(kind.to_string());
        if !self.shown
            && !self.known.is_empty()
            && self.known.iter().all(|k| self.frame.contains(k))
        {
            self.shown = true;
            push.current = true;
        }
        push
    }
}

/// What [`Updates::push`] says to show.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Push {
    /// The previous update, before this sentence is taken in.
    pub previous: bool,
    /// The current update, with this sentence.
    pub current: bool,
}

/// One display line from the latest `$PRDID` and `$PINAH` fields.
pub fn live_line(prdid: Option<&[String]>, pinah: Option<&[String]>) -> String {
    let get = |f: Option<&[String]>, i: usize| {
        f.and_then(|f| f.get(i)).filter(|s| !s.is_empty()).cloned().unwrap_or_else(|| "-".into())
    };
    match pinah {
        // $PINAH,<roll>,<pitch>,<yaw>,<qw>,<qx>,<qy>,<qz>,<depth>,<status>,<cycle>; the
        // status word's bits 20–21 are the heading reference.
        Some(_) => {
            let status = get(pinah, 9);
            let word = u32::from_str_radix(&status, 16).ok();
            let reference = match word.map(|s| (s >> 20) & 3) {
                Some(0) => "relative",
                Some(1) => "true (YAW)",
                Some(2) => "true (magnetometer)",
                _ => "-",
            };
            // The bits in words (docs/troubleshooting.md's names); "-" when none is set.
            let words = word.map_or_else(String::new, |w| {
                let names: Vec<&str> = Status(w).names().collect();
                if names.is_empty() {
                    " (-)".to_string()
                } else {
                    format!(" ({})", names.join(", "))
                }
            });
            format!(
                "roll {:>8}  pitch {:>7}  yaw {:>8}  depth {:>6} m  status {}{}  heading {}",
                get(pinah, 1),
                get(pinah, 2),
                get(pinah, 3),
                get(pinah, 8),
                status,
                words,
                reference
            )
        }
        // $PRDID,<pitch>,<roll>,<heading>
        None => format!(
            "roll {:>8}  pitch {:>7}  heading {:>8}",
            get(prdid, 2),
            get(prdid, 1),
            get(prdid, 3)
        ),
    }
}

/// Stop quietly on a closed output (`Ok(false)`), or pass other errors on.
fn shown(r: io::Result<()>) -> io::Result<bool> {
    match r {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(false),
        Err(e) => Err(e),
    }
}

/// Run `live` on `port` until `end`, Ctrl-C ([`crate::INTERRUPTED`]) or a closed stdout.
pub fn live(port: &str, end: Option<Instant>) -> Result<(), String> {
    let mut link = Link::open(port)?;
    crate::catch_signals();
    let stdout = io::stdout();
    let tty = stdout.is_terminal();
    let mut out = stdout.lock();
    let show = |out: &mut io::StdoutLock, text: &str| -> io::Result<()> {
        if tty {
            write!(out, "\r\x1b[K{text}")?;
        } else {
            writeln!(out, "{text}")?;
        }
        out.flush()
    };
    let (mut prdid, mut pinah): (Option<Vec<String>>, Option<Vec<String>>) = (None, None);
    let mut updates = Updates::default();
    let mut last_seen = Instant::now();
    let io_err = |e: io::Error| e.to_string();
    while !crate::INTERRUPTED.load(Ordering::SeqCst) && end.is_none_or(|e| Instant::now() < e) {
        let deadline = Instant::now() + Duration::from_millis(200);
        let Some((body, _)) = link.next_sentence(deadline).map_err(io_err)? else {
            if last_seen.elapsed() > Duration::from_secs(2) {
                if !shown(show(&mut out, &format!("no data from {port}"))).map_err(io_err)? {
                    return Ok(());
                }
                last_seen = Instant::now();
            }
            continue;
        };
        let f: Vec<String> = body.split(',').map(str::to_string).collect();
        let kind = f[0].clone();
        if kind != "PINAH" && kind != "PRDID" {
            continue;
        }
        last_seen = Instant::now();
        let push = updates.push(&kind);
        if push.previous {
            let text = live_line(prdid.as_deref(), pinah.as_deref());
            if !shown(show(&mut out, &text)).map_err(io_err)? {
                return Ok(());
            }
        }
        match kind.as_str() {
            "PINAH" => pinah = Some(f),
            _ => prdid = Some(f),
        }
        if push.current {
            let text = live_line(prdid.as_deref(), pinah.as_deref());
            if !shown(show(&mut out, &text)).map_err(io_err)? {
                return Ok(());
            }
        }
    }
    if tty {
        let _ = writeln!(out);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines shown for a sequence of sentence kinds.
    fn shown(kinds: &[&str]) -> usize {
        let mut u = Updates::default();
        kinds
            .iter()
            .map(|k| {
                let p = u.push(k);
                usize::from(p.previous) + usize::from(p.current)
            })
            .sum()
    }

    /// The status word in words, as `docs/troubleshooting.md` reads its examples.
    #[test]
    fn the_status_word_is_shown_in_words() {
        let pinah = |status: &str| -> Vec<String> {
            format!("PINAH,1.0,-2.0,30.0,1,0,0,0,4.5,{status},7")
                .split(',')
                .map(str::to_string)
                .collect()
        };
        let line = live_line(None, Some(&pinah("000300")));
        assert!(
            line.ends_with("status 000300 (accelerometer used, at rest)  heading relative"),
            "{line}"
        );
        let line = live_line(None, Some(&pinah("110010")));
        assert!(
            line.ends_with("status 110010 (accelerometer invalid, I²C fault)  heading true (YAW)"),
            "{line}"
        );
        let line = live_line(None, Some(&pinah("200000")));
        assert!(line.ends_with("status 200000 (-)  heading true (magnetometer)"), "{line}");
        // An unreadable word is shown as it came.
        assert!(live_line(None, Some(&pinah("zz"))).ends_with("status zz  heading -"));
    }

    #[test]
    fn one_line_per_update() {
        // Both sentences every cycle: 5 cycles, 5 lines (the first shown when the second
        // update starts, the others as soon as they are complete).
        let both = ["PRDID", "PINAH"].repeat(5);
        assert_eq!(shown(&both), 5);
        let mut u = Updates::default();
        for k in ["PRDID", "PINAH", "PRDID"] {
            u.push(k);
        }
        assert_eq!(u.push("PINAH"), Push { previous: false, current: true });
        // One sentence kind: one line each.
        assert_eq!(shown(&["PINAH"; 4]), 4);
        // $PINAH switched off half-way (SENT,1,0): still one line per cycle.
        let mut seq = ["PRDID", "PINAH"].repeat(3);
        seq.extend(["PRDID"; 3]);
        // 6 updates, 6 lines (the first $PRDID-only one shown when the next starts).
        assert_eq!(shown(&seq), 6);
    }
}
