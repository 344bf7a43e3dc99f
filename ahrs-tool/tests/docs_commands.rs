//! Issue #37 point 2 ("every command complete"): every `ahrs-tool` command the pages show a
//! user — in a code span or a code block of the README and `docs/` — is one the tool accepts.
//! Each is run with its port replaced by one that does not exist, in an empty directory:
//! it must get past the argument parser (fail on the port, or keep running) and never print
//! a usage error. Two `ahrs-tool send SELFTEST` lines without their port, as a newcomer found
//! them on the bring-up page, fail here (the command taken for the port, no command left).
//! Synopses (`[--seconds N]`, `<port>`, `…`, alternatives with `/`) are not commands and are
//! skipped, as are code spans that only name a subcommand in prose (`ahrs-tool log`,
//! `ahrs-tool log --restart`: no positional argument); in a code block every line is a command.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_ahrs-tool");

/// The commands of one page: `(line number, command line, in a code block)`.
fn commands(text: &str) -> Vec<(usize, String, bool)> {
    let mut out = Vec::new();
    let mut fenced = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        let block = fenced || line.starts_with("    ");
        let mut rest = line;
        while let Some(at) = rest.find("ahrs-tool ") {
            let after = &rest[at..];
            // In a code span (an odd number of backticks before it on the line) it ends at the
            // closing backtick; in a code block at the end of the line or a comment.
            let in_span = line[..line.len() - rest.len() + at].matches('`').count() % 2 == 1;
            let end = if in_span {
                after.find('`').unwrap_or(after.len())
            } else if block {
                after.find(" #").unwrap_or(after.len())
            } else {
                rest = &after["ahrs-tool ".len()..];
                continue;
            };
            let cmd = after[..end].trim().to_string();
            out.push((i + 1, cmd, !in_span));
            rest = &after[end..];
        }
    }
    out
}

/// Whether `cmd` is a synopsis or prose rather than a command to type (`block`: it stands on a
/// code block's line).
fn synopsis(cmd: &str, block: bool) -> bool {
    const SUBCOMMANDS: [&str; 7] =
        ["live", "send", "log", "settings", "calibrate", "bridge", "emulate"];
    let mut words = cmd.split_whitespace().skip(1);
    let Some(sub) = words.next() else { return true };
    if sub == "settings" {
        words.next(); // get or put
    }
    let positional = words.any(|w| !w.starts_with('-'));
    !SUBCOMMANDS.contains(&sub)
        || cmd.contains(['[', '<', '|', '…'])
        || cmd.contains("...")
        || cmd.split_whitespace().nth(1).is_some_and(|w| w.contains('/'))
        || (!block && !positional)
}

/// The command's words, with anything that names a serial port replaced by `port`.
fn words(cmd: &str, port: &Path) -> Vec<String> {
    let is_port = |w: &str| {
        w == "PORT"
            || w.starts_with("/dev/")
            || (w.starts_with("COM") && w[3..].chars().all(|c| c.is_ascii_digit()) && w.len() > 3)
    };
    cmd.split_whitespace()
        .skip(1)
        .map(|w| if is_port(w) { port.display().to_string() } else { w.to_string() })
        .collect()
}

/// Runs the tool with `args` in `dir` for at most 3 s: its stderr, and whether it was a usage
/// error (clap's, which prints the usage).
fn usage_error(args: &[String], dir: &Path) -> (bool, String) {
    let mut child = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(3) {
            // Still running (an emulator, a bridge waiting): it parsed.
            child.kill().ok();
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    (err.contains("Usage:"), err)
}

#[test]
fn every_documented_command_is_accepted() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut pages = vec![root.join("README.md")];
    for entry in std::fs::read_dir(root.join("docs")).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "md") {
            pages.push(p);
        }
    }
    pages.sort();
    let dir = std::env::temp_dir().join(format!("ahrs-tool-docs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let port = dir.join("no-such-port");
    let mut checked = 0;
    let mut bad = Vec::new();
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        let name = page.file_name().unwrap().to_string_lossy().to_string();
        for (line, cmd, block) in commands(&text) {
            if synopsis(&cmd, block) {
                continue;
            }
            let args = words(&cmd, &port);
            let (usage, err) = usage_error(&args, &dir);
            checked += 1;
            if usage || err.contains("panicked") {
                bad.push(format!("{name}:{line}: `{cmd}`: {}", err.lines().next().unwrap_or("")));
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    assert!(bad.is_empty(), "documented commands the tool refuses:\n{}", bad.join("\n"));
    // The pages show a few dozen; a scan that finds none checks nothing.
    assert!(checked >= 15, "only {checked} documented commands found");
}

/// The scan itself: a command in a code span and in a code block is found, prose and
/// synopses are not commands, a port is replaced, and a command without its port is a usage
/// error (the newcomer's case).
#[test]
fn the_scan_finds_the_commands_and_catches_a_missing_port() {
    let text = "Run `ahrs-tool send PORT SELFTEST` now.\n\n    ahrs-tool live /dev/ttyACM0   # the attitude\n\nThe tool ahrs-tool in prose, `ahrs-tool log --restart` by name.\n`ahrs-tool send <port> <COMMAND...> [--timeout S]`\n";
    let found = commands(text);
    assert_eq!(
        found,
        vec![
            (1, "ahrs-tool send PORT SELFTEST".to_string(), false),
            (3, "ahrs-tool live /dev/ttyACM0".to_string(), true),
            (5, "ahrs-tool log --restart".to_string(), false),
            (6, "ahrs-tool send <port> <COMMAND...> [--timeout S]".to_string(), false),
        ]
    );
    let skip: Vec<bool> = found.iter().map(|(_, c, b)| synopsis(c, *b)).collect();
    assert_eq!(skip, [false, false, true, true]);
    let dir = std::env::temp_dir();
    let port = dir.join("no-such-port");
    assert_eq!(words(&found[1].1, &port), vec!["live".to_string(), port.display().to_string()]);
    assert!(!usage_error(&words(&found[0].1, &port), &dir).0);
    assert!(usage_error(&words("ahrs-tool send SELFTEST", &port), &dir).0);
}
