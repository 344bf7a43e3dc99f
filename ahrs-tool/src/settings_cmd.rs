//! `ahrs-tool settings get|put`: a device's settings to a settings file and back, in the
//! device's own language (`NAME=VALUE` lines, `host_tests::settings`), which `host-tests
//! replay --settings` reads too; and the settings a log records in its header.

use std::{io::Write, path::Path, time::Duration};

use host_tests::output::write_atomically;
use host_tests::settings::{read_settings_file, LOG_CONDITIONED, META_CONDITIONED, META_SETTING};

use crate::link::{Link, Reply};

/// Send `body`, require an OK reply (retried once: the line may be lost).
fn ok_reply(link: &mut Link, body: &str) -> Result<Reply, String> {
    for _ in 0..2 {
        match link.command(body, Duration::from_secs(2)).map_err(|e| e.to_string())? {
            Some(r) if r.ok => return Ok(r),
            Some(r) => return Err(format!("{body}: the device replied {}", r.line)),
            None => continue,
        }
    }
    Err(format!("no reply to {body}"))
}

/// Every setting of the device, `(name, value)` as it prints them, in its `LIST` order.
pub fn read_device(link: &mut Link) -> Result<Vec<(String, String)>, String> {
    Ok(list_device(link)?.into_iter().map(|r| (r.name, r.value)).collect())
}

/// One setting as `LIST` and `GET` describe it.
#[derive(Clone, Debug, PartialEq)]
pub struct Listed {
    pub name: String,
    pub value: String,
    pub unit: String,
    /// The accepted range in `unit` (`LIST`'s `<min>,<max>`), empty for non-numbers.
    pub min: String,
    pub max: String,
}

/// Every setting of the device with its value, unit and range, in its `LIST` order.
pub fn list_device(link: &mut Link) -> Result<Vec<Listed>, String> {
    // OK,LIST,<i>,<count>,<name>,<type>,<unit>,<min>,<max>
    let first = ok_reply(link, "LIST,0")?;
    let count: usize = first
        .fields
        .get(1)
        .and_then(|c| c.parse().ok())
        .ok_or_else(|| format!("unexpected reply {}", first.line))?;
    let mut out = Vec::with_capacity(count);
    for i in 0..count {
        let r = if i == 0 { first.clone() } else { ok_reply(link, &format!("LIST,{i}"))? };
        let field = |k: usize| r.fields.get(k).cloned().unwrap_or_default();
        let name = field(2);
        if name.is_empty() {
            return Err(format!("unexpected reply {}", r.line));
        }
        let g = ok_reply(link, &format!("GET,{name}"))?;
        if g.fields.len() < 2 {
            return Err(format!("unexpected reply {}", g.line));
        }
        out.push(Listed {
            value: g.fields[1..].join(","),
            unit: field(4),
            // A device older than the range fields sends none: shown empty.
            min: field(5),
            max: field(6),
            name,
        });
    }
    Ok(out)
}

/// `send <port> LIST` (no index): every setting as a table, name, value, unit and range.
pub fn print_list(link: &mut Link) -> Result<(), String> {
    let rows = list_device(link)?;
    let w =
        |f: fn(&Listed) -> usize, head: &str| rows.iter().map(f).max().unwrap_or(0).max(head.len());
    let (wn, wv, wu) = (
        w(|r| r.name.len(), "name"),
        w(|r| r.value.chars().count(), "value"),
        w(|r| r.unit.chars().count(), "unit"),
    );
    let mut out = String::new();
    out.push_str(&format!("{:wn$}  {:wv$}  {:wu$}  range\n", "name", "value", "unit"));
    for r in &rows {
        let range = if r.min.is_empty() && r.max.is_empty() {
            String::new()
        } else {
            format!("{} … {}", r.min, r.max)
        };
        let line = format!("{:wn$}  {:wv$}  {:wu$}  {range}", r.name, r.value, r.unit);
        out.push_str(line.trim_end());
        out.push('\n');
    }
    print!("{out}");
    Ok(())
}

/// The comment lines (without `# `) a log starts with: the device's `VER` fields, what its
/// samples already had applied
/// (`$PINAW` is the estimator's input: axis maps, calibration and lever arm applied) and its
/// settings.
pub fn log_comments(link: &mut Link) -> Result<Vec<String>, String> {
    let ver = ok_reply(link, "VER")?;
    let mut out = vec![
        format!("device: {}", ver.fields.join(",")),
        format!("{META_CONDITIONED}{}", LOG_CONDITIONED.join(" ")),
    ];
    for (name, value) in read_device(link)? {
        out.push(format!("{META_SETTING}{name}={value}"));
    }
    Ok(out)
}

/// `settings get <port> --out FILE`.
pub fn get(port: &str, out: &Path) -> Result<(), String> {
    let mut link = Link::open(port)?;
    let settings = read_device(&mut link)?;
    let ver = ok_reply(&mut link, "VER").map(|r| r.fields.join(",")).unwrap_or_default();
    let mut text = format!(
        "# settings of {port} ({ver}), by ahrs-tool settings get\n\
         # NAME=VALUE in the device's units; ahrs-tool settings put sends them back,\n\
         # host-tests replay --settings reads them\n"
    );
    for (name, value) in &settings {
        text.push_str(&format!("{name}={value}\n"));
    }
    write_atomically(out, |w| w.write_all(text.as_bytes()))
        .map_err(|e| format!("{}: {e}", out.display()))?;
    eprintln!("{} settings written to {}", settings.len(), out.display());
    Ok(())
}

/// Sets each `(name, fields)` (`fields` as `SET` takes them: `0.1`, `x,y,-z`) in order, after
/// reading what each held (`GET`); when one is refused or gets no reply, those already set are
/// put back, the latest first, before the error returns (issue #39 point 1: a tool that
/// changed the device puts it back). The error is `(index of the failed change, message)`,
/// the message saying what was put back, or what could not be.
pub fn set_all(link: &mut Link, changes: &[(String, String)]) -> Result<(), (usize, String)> {
    let mut before = Vec::with_capacity(changes.len());
    for (k, (name, _)) in changes.iter().enumerate() {
        let g = ok_reply(link, &format!("GET,{name}")).map_err(|e| (k, e))?;
        if g.fields.len() < 2 {
            return Err((k, format!("unexpected reply {}", g.line)));
        }
        before.push(g.fields[1..].join(","));
    }
    for (k, (name, fields)) in changes.iter().enumerate() {
        if let Err(e) = ok_reply(link, &format!("SET,{name},{fields}")) {
            let mut failed = Vec::new();
            for j in (0..k).rev() {
                let (name, old) = (&changes[j].0, &before[j]);
                if ok_reply(link, &format!("SET,{name},{old}")).is_err() {
                    failed.push(format!("{name}={old}"));
                }
            }
            let undo = match (k, failed.is_empty()) {
                (0, _) => "nothing was changed".to_string(),
                (n, true) => format!("the {n} setting(s) set before it were put back"),
                (_, false) => format!(
                    "putting back {} failed: the device may hold a mix of old and new values",
                    failed.join(", ")
                ),
            };
            return Err((k, format!("{e}; {undo}")));
        }
    }
    Ok(())
}

/// `settings put <port> FILE [--save]`: every line checked here first (nothing is sent if one
/// is refused), then one `SET` each ([`set_all`]: put back if one fails).
pub fn put(port: &str, file: &Path, save: bool) -> Result<(), String> {
    let lines = read_settings_file(file)?;
    let mut link = Link::open(port)?;
    let changes: Vec<(String, String)> = lines
        .iter()
        .map(|(_, a)| {
            let text = host_tests::settings::format_assignment(a.setting, &a.value);
            let (name, value) = text.split_once('=').unwrap_or((&text, ""));
            (name.to_string(), value.to_string())
        })
        .collect();
    set_all(&mut link, &changes).map_err(|(k, e)| {
        let line = lines.get(k).map_or(0, |l| l.0);
        format!("{} line {line}: {e}", file.display())
    })?;
    let saved = if save {
        let r = ok_reply(&mut link, "SAVE")?;
        format!("; saved ({})", r.line)
    } else {
        "; not saved (SAVE or --save keeps them)".into()
    };
    eprintln!("{} settings sent to {port}{saved}", lines.len());
    Ok(())
}
