//! Firmware library for the iNEMO V2 board: everything that is not board glue, so that it
//! builds and is tested on the host — the LSM303DLH driver, ADC conversion of the analog gyros
//! and the depth sensor, NMEA 0183 output, and the pipeline that ties sensors, `ekf-core` and
//! the output together. The RTIC application (`src/main.rs`) only moves data between the
//! peripherals and these modules.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod adc;
pub mod board;
pub mod command;
pub mod console;
#[cfg(test)]
mod fault_injection;
pub mod lsm303dlh;
pub mod nmea;
pub mod persist;
pub mod pipeline;
pub mod registry;
pub mod settings;
pub mod status;
pub mod supervision;
#[cfg(test)]
mod test_rng;
