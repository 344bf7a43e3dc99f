//! Host tools for `ekf-core`: the iNEMO V2 sensor simulator ([`sim`]), the trace CSV format
//! ([`trace`], `shared/trace-format.md`), trace replay through the estimators with RMSE
//! ([`replay`], [`config`], set in the device's settings language: [`settings`]), plots ([`plot`]) and progress on a terminal ([`progress`]). The `host-tests` binary exposes them as the
//! `simulate`, `replay` and `plot` commands; [`accuracy`] is the evaluation behind the
//! accuracy benchmark and its regression tests (`docs/accuracy.md`).
//!
//! Conventions are those of `ekf-core`: body FRD, reference NED, SI units, scalar-first
//! Hamilton quaternion rotating body → NED, Z-Y-X Euler angles (degrees in files), the
//! accelerometer reads specific force (a level, still board reads (0, 0, −9.81) m/s²).
// No `unsafe` here: the thread CPU clock comes from the `cpu-time` crate (issue #30).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod accuracy;
pub mod allan;
pub mod config;
pub mod handheld;
pub mod lenient;
pub mod output;
pub mod plot;
pub mod progress;
pub mod real;
pub mod replay;
pub mod rng;
pub mod settings;
pub mod sim;
pub mod trace;
