//! The firmware's settings: everything the pipeline is configured with
//! ([`PipelineSettings`]), as the registry ([`crate::registry`]) reads, writes and saves them.
//! In a module of their own so that the pipeline and the registry both depend on them and not
//! on each other.

use ekf_core::{conditioning::ConditioningSettings, settings::Settings};

use crate::{
    adc::{AdcScale, DepthCalibration, GyroConversion},
    board,
};

/// The internal value of a `registry::Kind::Talker` setting: the two ASCII bytes, big-endian.
pub const fn talker_code(talker: [u8; 2]) -> u16 {
    u16::from_be_bytes(talker)
}

/// True when `code` ([`talker_code`]) is two characters `A`–`Z` or `0`–`9`.
pub const fn talker_valid(code: u16) -> bool {
    let [a, b] = code.to_be_bytes();
    matches!(a, b'A'..=b'Z' | b'0'..=b'9') && matches!(b, b'A'..=b'Z' | b'0'..=b'9')
}

/// Which sentences go out, and the talker of the standard ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SentenceSet {
    /// `$PRDID` (pitch, roll, heading; RDI convention). Default on.
    pub prdid: bool,
    /// `$PINAH` (full state). Default on.
    pub pinah: bool,
    /// `$--HDT` (true heading; only while the heading is referenced to true north). Default
    /// off.
    pub hdt: bool,
    /// `$--HDG` (magnetic heading and variation; only with the magnetometer). Default off.
    pub hdg: bool,
    /// `$--HDM` (magnetic heading; only with the magnetometer). Default off.
    pub hdm: bool,
    /// `$--ROT` (rate of turn). Default off.
    pub rot: bool,
    /// `$--XDR` (pitch, roll, depth). Default off.
    pub xdr: bool,
    /// Talker identifier of the standard sentences ([`talker_code`]). Default `HC`.
    pub talker: u16,
}

impl Default for SentenceSet {
    fn default() -> Self {
        SentenceSet {
            prdid: true,
            pinah: true,
            hdt: false,
            hdg: false,
            hdm: false,
            rot: false,
            xdr: false,
            talker: talker_code(*b"HC"),
        }
    }
}

/// Everything the pipeline needs; `Default` is the iNEMO V2 on the Seahog.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineSettings {
    /// Estimator settings (noise, init window, gate, rest detection, ...).
    pub filter: Settings,
    /// Axis maps, calibration and lever arm. Default: the board's axis maps
    /// ([`board::ACCEL_AXES`], [`board::GYRO_AXES`], [`board::MAG_AXES`]), identity
    /// calibration, the Seahog's lever arm.
    pub conditioning: ConditioningSettings,
    /// ADC counts → volts.
    pub adc: AdcScale,
    /// Gyro volts → rad/s.
    pub gyro: GyroConversion,
    /// Depth sensor volts → pressure → depth.
    pub depth: DepthCalibration,
    /// Filter rate, Hz. Default 50 (the source's); up to 200 supported.
    pub filter_rate_hz: u16,
    /// Output rate, Hz, 1–50 (at most the filter rate). Default 10.
    pub output_rate_hz: u16,
    /// Sentences to send.
    pub sentences: SentenceSet,
    /// I²C2 clock, kHz, 100–400 (setting `i2c.clock`; read at boot only). Default 300
    /// ([`board::I2C_FREQUENCY_HZ`]: ST's firmware for the board).
    pub i2c_clock_khz: u16,
}

impl Default for PipelineSettings {
    // Out of line: the firmware builds the defaults in several places (boot, `RESET`, the
    // flash loader) and one copy of this code is enough.
    #[inline(never)]
    fn default() -> Self {
        PipelineSettings {
            filter: Settings::default(),
            conditioning: ConditioningSettings {
                gyro_axes: board::GYRO_AXES,
                accel_axes: board::ACCEL_AXES,
                mag_axes: board::MAG_AXES,
                ..ConditioningSettings::default()
            },
            adc: AdcScale::default(),
            gyro: GyroConversion::default(),
            depth: DepthCalibration::default(),
            filter_rate_hz: 50,
            output_rate_hz: 10,
            sentences: SentenceSet::default(),
            i2c_clock_khz: (board::I2C_FREQUENCY_HZ / 1000) as u16,
        }
    }
}

impl PipelineSettings {
    /// Filter cycles per output: `filter_rate / output_rate`, at least 1.
    pub fn output_divider(&self) -> u32 {
        let f = u32::from(self.filter_rate_hz.max(1));
        let o = u32::from(self.output_rate_hz.clamp(1, 50));
        // `o` is at least 1, but the compiler does not see it through the clamp: a checked
        // division keeps the panic path out of the cycle (the no-panic proof of size-report).
        f.checked_div(o).unwrap_or(f).max(1)
    }
}
