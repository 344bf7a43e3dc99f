//! Embeds the sensor trace (CSV in the project's trace format, path from `EKF_EMU_TRACE`,
//! default `trace.csv` beside this file) as little-endian f32 records
//! `dt, gx, gy, gz, ax, ay, az`, and, for bare-metal targets, links with the firmware's own
//! memory map (the workspace root's `memory.x`, STM32F103RE). QEMU's `netduino2` machine
//! (STM32F205, Cortex-M3, flash at 0x0800_0000, SRAM at 0x2000_0000) runs that layout.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("manifest dir"));
    println!("cargo:rerun-if-env-changed=EKF_EMU_TRACE");
    let trace =
        env::var("EKF_EMU_TRACE").map(PathBuf::from).unwrap_or_else(|_| manifest.join("trace.csv"));
    println!("cargo:rerun-if-changed={}", trace.display());
    let text = fs::read_to_string(&trace)
        .unwrap_or_else(|e| panic!("cannot read trace {}: {e}", trace.display()));
    fs::write(out.join("trace.bin"), pack(&text)).expect("write trace.bin");

    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let root = manifest.parent().expect("workspace root");
        println!("cargo:rustc-link-search={}", root.display());
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    }
}

/// Columns t, gx, gy, gz, ax, ay, az by name; `#` and empty lines skipped. The trace is
/// produced by `host-tests simulate`, which validates it; errors here name the line.
fn pack(text: &str) -> Vec<u8> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, header) = lines.next().expect("trace has no header");
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |n: &str| {
        names.iter().position(|h| *h == n).unwrap_or_else(|| panic!("trace lacks column {n}"))
    };
    let idx: Vec<usize> =
        ["t", "gx", "gy", "gz", "ax", "ay", "az"].iter().map(|n| col(n)).collect();
    let mut bytes = Vec::new();
    let mut prev_t: Option<f64> = None;
    for (i, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let v: Vec<f64> = idx
            .iter()
            .map(|&c| {
                cells.get(c).and_then(|s| s.parse().ok()).unwrap_or_else(|| {
                    panic!("trace line {}: column {} unreadable", i + 1, names[c])
                })
            })
            .collect();
        let dt = prev_t.map(|p| v[0] - p).unwrap_or(0.02);
        prev_t = Some(v[0]);
        for x in std::iter::once(dt).chain(v[1..].iter().copied()) {
            bytes.extend_from_slice(&(x as f32).to_le_bytes());
        }
    }
    bytes
}
