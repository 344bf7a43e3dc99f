//! Commands on the output USART: line assembly, parsing, execution and replies, the
//! calibration state machines and the raw streaming mode. The protocol is documented in
//! `docs/commands.md`.
//!
//! Use from the application:
//! 1. at boot, `persist::load(&flash)` → [`Device::new`] → `Pipeline::new(*device.settings())`;
//! 2. every received byte → [`LineAssembler::push`]; every [`LineEvent`] →
//!    [`Device::handle`] (with the flash), send the reply, act on the [`Action`];
//! 3. every filter cycle, before `Pipeline::step`, `Pipeline::conditioned_sample(&inputs)`,
//!    then `Pipeline::step`, then [`Device::on_cycle`] (with the step's attitude); send its
//!    reply and raw sentences, act on its action.

mod board;
mod calib;
mod device;
mod line;
mod raw;
mod reply;

pub use board::{fault_reply, selftest_reply};
pub use calib::{
    accel_sigma, gyro_sigma, position_by_name, position_name, AccelPositionCal, CalEnd,
    GyroBiasCal, Stats3, POSITION_NAMES,
};
pub use device::{
    verb_names, Action, CycleOutput, Device, RawMode, Response, ACAL_DEFAULT_S, ACAL_RANGE_S,
    DEPTH_MAX_AGE_S, GBIAS_RANGE_S, STATUS_ACAL, STATUS_GBIAS, STATUS_MISSING, STATUS_NO_RECORD,
    STATUS_RAW, STATUS_SKIPPED, STATUS_UNSAVED, VERSION, YAW_RANGE_DEG,
};
pub use line::{Line, LineAssembler, LineEvent, MAX_LINE};
pub use raw::{pinaw, pinax, T_WRAP_S};
pub use reply::{Detail, Reason};

#[cfg(test)]
mod fuzz;
#[cfg(test)]
mod tests;
