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
    // OK,LIST,<i>,<count>,<name>,<type>,<unit>
    let first = ok_reply(link, "LIST,0")?;
    let count: usize = first
        .fields
        .get(1)
        .and_then(|c| c.parse().ok())
        .ok_or_else(|| format!("unexpected reply {}", first.line))?;
    let mut out = Vec::with_capacity(count);
    for i in 0..count {
        let r = if i == 0 { first.clone() } else { ok_reply(link, &format!("LIST,{i}"))? };
        let name = r.fields.get(2).ok_or_else(|| format!("unexpected reply {}", r.line))?;
        // OK,GET,<name>,<value...>
        let g = ok_reply(link, &format!("GET,{name}"))?;
        if g.fields.len() < 2 {
            return Err(format!("unexpected reply {}", g.line));
        }
        out.push((name.clone(), g.fields[1..].join(",")));
    }
    Ok(out)
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

/// `settings put <port> FILE [--save]`: every line checked here first (nothing is sent if one
/// is refused), then one `SET` each.
pub fn put(port: &str, file: &Path, save: bool) -> Result<(), String> {
    let lines = read_settings_file(file)?;
    let mut link = Link::open(port)?;
    for (line, a) in &lines {
        let text = host_tests::settings::format_assignment(a.setting, &a.value);
        let body = format!("SET,{}", text.replacen('=', ",", 1));
        ok_reply(&mut link, &body).map_err(|e| format!("{} line {line}: {e}", file.display()))?;
    }
    let saved = if save {
        let r = ok_reply(&mut link, "SAVE")?;
        format!("; saved ({})", r.line)
    } else {
        "; not saved (SAVE or --save keeps them)".into()
    };
    eprintln!("{} settings sent to {port}{saved}", lines.len());
    Ok(())
}
