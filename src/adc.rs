//! Conversion of the board's analog channels: the LPR430AL (X, Y) and LY330ALH (Z) rate gyros
//! and the external depth (pressure) sensor.
//!
//! The firmware runs a timer-triggered ADC1 scan of six channels at 1 kHz or more, moved by
//! DMA; each scan is one [`AdcFrame`] of raw 12-bit counts. An [`Averager`] sums the frames
//! between two filter cycles and [`Averager::take`] hands the cycle an [`AdcMean`] (mean counts
//! per channel, the number of frames and which channels touched a rail). [`GyroConversion`]
//! turns the mean into angular rates ([`GyroReading`], rad/s in the gyros' own axes) and
//! [`DepthCalibration`] turns the depth channel into pressure and depth ([`DepthReading`]).
//!
//! Scan order (the DMA buffer's layout, [`SCAN_CHANNELS`]): gyro XY reference, depth, gyro Z
//! reference, gyro X, gyro Y, gyro Z, VREFINT (VDDA measured in every scan: [`AdcScale::for_mean`];
//! the order checked at boot: [`check_ranks`]).
//!
//! Units: counts are ADC codes 0–4095 (right-aligned 12 bit), volts are V at the ADC pin,
//! rates are rad/s, pressure is Pa (absolute, as the depth calibration yields it), depth is m,
//! positive down.

mod averager;
mod depth;
mod frame;
mod gyro;
mod ranks;
mod scale;

pub use averager::{AdcMean, Averager};
pub use depth::{DepthCalibration, DepthReading};
pub use frame::{at_rail, AdcFrame, Rails, RAIL_HIGH, RAIL_LOW, SCAN_CHANNELS, SCAN_LEN};
pub use gyro::{GyroConversion, GyroReading};
pub use ranks::{check_ranks, RankCheck, REF_MAX_V, REF_MIN_V};
pub use scale::{vdda_from_vrefint, AdcScale};
