//! `ekf-emu`'s library: the embedded sensor trace (what the board's hardware tasks would
//! deliver, packed by `build.rs`) and the serial firmware of `ekf-emu-serial` (the firmware
//! library's pipeline, command layer and settings persistence behind a byte-oriented serial
//! port), shared by the host and the Cortex-M3 builds.
#![no_std]

pub mod serial;
pub mod trace;
