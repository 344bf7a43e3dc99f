//! Link set-up of the firmware binary on bare-metal targets: cortex-m-rt's `link.x` (which
//! includes `link/memory.x`, the STM32F103RE's map) and defmt's `defmt.x`.
//!
//! Here rather than as `rustflags` under `[target.thumbv7m-none-eabi]` in `.cargo/config.toml`:
//! those would apply to every crate built for the target — `ekf-emu` and `cycle-bench` add
//! `-Tlink.x` in their own build scripts (a second copy redefines the memory regions) and do
//! not link defmt (no `defmt.x` on their search path). `rustc-link-arg-bins` reaches only this
//! package's binary; host builds and builds without the `board` feature get nothing.
//!
//! The soft-float routines: libgcc's when found (`tools/soft_float.rs`), as `cycle-bench` and
//! `ekf-emu` link them, so the cycles measured are the cycles flashed.
//!
//! The `dfu` feature (issue #27, `scripts/dfu-image`): the image that ST's USB DFU bootloader
//! loads at 0x0800_3000 and starts; its memory layout is `tools/memory_layout.rs`'s.
//!
//! Where VTOR is set (the `dfu` feature turns on cortex-m-rt's `set-vtor` and `set-sp`): by
//! the first instructions of cortex-m-rt's `Reset`, in assembly, before `.bss`/`.data` are
//! initialised and before any Rust runs. Not in RTIC's `init`: a HardFault or NMI before it
//! (RAM initialisation, RTIC's prologue) would still go through the bootloader's table at
//! 0x0800_0000. Not with `#[pre_init]`: deprecated in cortex-m-rt 0.7, and Rust code before
//! RAM initialisation is undefined behaviour. ST's bootloader may set VTOR and MSP itself
//! before it jumps; the image does not rely on it.
use std::{env, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let bare_metal = env::var("CARGO_CFG_TARGET_OS").is_ok_and(|os| os == "none");
    let board = env::var_os("CARGO_FEATURE_BOARD").is_some();
    let dfu = env::var_os("CARGO_FEATURE_DFU").is_some();
    if bare_metal && board {
        let root = PathBuf::from(
            env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"),
        );
        link_memory_layout(&root, dfu);
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
        link_soft_float();
    }
}

include!("tools/soft_float.rs");
include!("tools/memory_layout.rs");
