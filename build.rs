//! Link set-up of the firmware binary on bare-metal targets: cortex-m-rt's `link.x` (which
//! includes this directory's `memory.x`, the STM32F103RE's map) and defmt's `defmt.x`.
//!
//! Here rather than as `rustflags` under `[target.thumbv7m-none-eabi]` in `.cargo/config.toml`:
//! those would apply to every crate built for the target — `ekf-emu` and `cycle-bench` add
//! `-Tlink.x` in their own build scripts (a second copy redefines the memory regions) and do
//! not link defmt (no `defmt.x` on their search path). `rustc-link-arg-bins` reaches only this
//! package's binary; host builds and builds without the `board` feature get nothing.
//!
//! The soft-float routines: libgcc's when found (`tools/soft_float.rs`), as `cycle-bench` and
//! `ekf-emu` link them, so the cycles measured are the cycles flashed.
use std::{env, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=memory.x");
    let bare_metal = env::var("CARGO_CFG_TARGET_OS").is_ok_and(|os| os == "none");
    let board = env::var_os("CARGO_FEATURE_BOARD").is_some();
    if bare_metal && board {
        let dir = PathBuf::from(
            env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"),
        );
        println!("cargo:rustc-link-search={}", dir.display());
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
        link_soft_float();
    }
}

include!("tools/soft_float.rs");
