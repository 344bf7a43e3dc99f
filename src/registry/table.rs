//! The table itself. Ids are grouped by tens per section; an id is never reused.

use super::slot::Slot;
use super::{unit_index, Kind, Scale, Setting};
use crate::settings::PipelineSettings;

/// rad/s → °/s (and rad → °).
const DEG: f64 = Scale::Deg.factor();
/// (rad/s)² → (°/s)².
const DEG2: f64 = Scale::Deg2.factor();
/// rad/s → °/h.
const DEG_H: f64 = Scale::DegH.factor();

/// A scaled number field (`f32`).
macro_rules! num {
    ($id:literal, $name:literal, $unit:literal, $scale:expr, $min:expr, $max:expr, $($rest:tt)*) => {
        Setting {
            id: $id,
            name: $name,
            kind: Kind::F32,
            unit: unit_index($unit),
            scale: Scale::of($scale),
            min: $min,
            max: $max,
        }
    };
}

/// A scaled three-component field (`Vec3` or `[f32; 3]`).
macro_rules! vec3 {
    ($id:literal, $name:literal, $unit:literal, $scale:expr, $min:expr, $max:expr, $($rest:tt)*) => {
        Setting {
            id: $id,
            name: $name,
            kind: Kind::Vec3,
            unit: unit_index($unit),
            scale: Scale::of($scale),
            min: $min,
            max: $max,
        }
    };
}

/// A `bool` field.
macro_rules! flag {
    ($id:literal, $name:literal, $($rest:tt)*) => {
        Setting {
            id: $id,
            name: $name,
            kind: Kind::Bool,
            unit: 0,
            scale: Scale::One,
            min: 0.0,
            max: 1.0,
        }
    };
}

/// An unsigned integer field (`u16` or `u8`; the range keeps `u8` fields in range).
macro_rules! uint {
    ($id:literal, $name:literal, $unit:literal, $min:expr, $max:expr, $($rest:tt)*) => {
        Setting {
            id: $id,
            name: $name,
            kind: Kind::U16,
            unit: unit_index($unit),
            scale: Scale::One,
            min: $min,
            max: $max,
        }
    };
}

/// A talker-identifier field (two characters, stored as a `u16`).
macro_rules! talker {
    ($id:literal, $name:literal, $($rest:tt)*) => {
        Setting {
            id: $id,
            name: $name,
            kind: Kind::Talker,
            unit: 0,
            scale: Scale::One,
            min: 0.0,
            max: 0.0,
        }
    };
}

/// An axis-map field.
macro_rules! axes {
    ($id:literal, $name:literal, $($rest:tt)*) => {
        Setting {
            id: $id,
            name: $name,
            kind: Kind::Axes,
            unit: 0,
            scale: Scale::One,
            min: 0.0,
            max: 0.0,
        }
    };
}

/// The storage of a row: its last tokens are `|s| <field path>`.
macro_rules! slot_of {
    ($settings:ident; |$s:ident| $field:expr) => {{
        let $s = $settings;
        Slot::from(&mut $field)
    }};
    ($settings:ident; $skip:tt $($rest:tt)*) => {
        slot_of!($settings; $($rest)*)
    };
}

/// The help text of a row: the literal before `|s| <field path>`.
macro_rules! help_of {
    ($help:literal, |$s:ident| $field:expr) => {
        $help
    };
    ($skip:tt $($rest:tt)*) => {
        help_of!($($rest)*)
    };
}

/// Flash id of `adc.vref`.
const ADC_VREF: u16 = 90;
/// Flash id of `adc.vrefint`.
const ADC_VREFINT: u16 = 93;

/// What a write to the setting `id` changes besides its slot: `adc.vref` and `adc.vrefint`
/// are the reference of the depth channel and of the gyro conversion alike.
pub(super) fn after_write(s: &mut PipelineSettings, id: u16) {
    match id {
        ADC_VREF => s.gyro.scale.vref_v = s.adc.vref_v,
        ADC_VREFINT => s.gyro.scale.vrefint_v = s.adc.vrefint_v,
        _ => {}
    }
}

/// The table from its rows: [`SETTINGS`], the help texts (only the documentation uses them, so
/// they are not in the firmware) and the accessor [`slot`].
macro_rules! settings_table {
    ($($kind:ident!($id:literal, $($row:tt)*)),* $(,)?) => {
        /// Every setting, in documentation order.
        pub static SETTINGS: [Setting; [$($id),*].len()] = [$($kind!($id, $($row)*)),*];

        /// `(id, help)` of every setting, in the order of [`SETTINGS`].
        pub(super) static HELP: [(u16, &str); SETTINGS.len()] = [$(($id, help_of!($($row)*))),*];

        /// The storage of the setting with id `id`.
        pub(super) fn slot(settings: &mut PipelineSettings, id: u16) -> Option<Slot<'_>> {
            Some(match id {
                $($id => slot_of!(settings; $($row)*),)*
                _ => return None,
            })
        }
    };
}

settings_table! {
    // Noise model.
    vec3!(
        1,
        "noise.gyro_var",
        "(deg/s)2",
        DEG2,
        1e-6,
        100.0,
        "gyro white-noise variance per sample at `noise.gyro_ref_rate`, body x, y, z",
        |s| s.filter.noise.gyro_var
    ),
    num!(
        2,
        "noise.gyro_ref_rate",
        "Hz",
        1.0,
        1.0,
        1000.0,
        "sample rate at which `noise.gyro_var` was measured",
        |s| s.filter.noise.gyro_ref_rate_hz
    ),
    num!(
        3,
        "noise.accel_var",
        "g2",
        1.0,
        1e-12,
        1.0,
        "accelerometer white-noise variance per axis and sample at `noise.accel_ref_rate`",
        |s| s.filter.noise.accel_var
    ),
    num!(
        4,
        "noise.accel_ref_rate",
        "Hz",
        1.0,
        1.0,
        1000.0,
        "sample rate at which `noise.accel_var` holds (constant density: the per-sample variance scales with the rate)",
        |s| s.filter.noise.accel_ref_rate_hz
    ),
    // Initialisation window.
    num!(
        10,
        "init.window",
        "s",
        1.0,
        0.0,
        600.0,
        "initialisation window (tilt and gyro bias averaged over it); 0 starts at once",
        |s| s.filter.init.window_s
    ),
    num!(
        11,
        "init.yaw0",
        "deg",
        DEG,
        -180.0,
        180.0,
        "initial yaw (the `YAW0` command sets it too)",
        |s| s.filter.init.initial_yaw
    ),
    flag!(
        12,
        "init.estimate_bias",
        "take the gyro bias from the window (the vehicle must be still)",
        |s| s.filter.init.estimate_gyro_bias
    ),
    vec3!(
        13,
        "init.gyro_bias",
        "deg/s",
        DEG,
        -50.0,
        50.0,
        "gyro bias used when not estimated, body FRD",
        |s| s.filter.init.gyro_bias
    ),
    num!(
        14,
        "init.moving_bias_sigma",
        "deg/s",
        DEG,
        0.01,
        50.0,
        "standard deviation of `init.gyro_bias` after a window that was not still (started at once from it)",
        |s| s.filter.init.moving_bias_sigma
    ),
    // The source's accelerometer gate (the EKF's only gate setting; issue #36 retired the rest).
    num!(
        20,
        "gate.norm_tolerance",
        "",
        1.0,
        0.001,
        1.0,
        "skip the tilt update when the accelerometer norm differs from 1 g by more (fraction; the source's gate: 0.05)",
        |s| s.filter.gate.norm_tolerance
    ),
    // Plausibility limits.
    num!(
        30,
        "limits.gyro_range",
        "deg/s",
        DEG,
        1.0,
        10000.0,
        "gyro full scale: at or beyond, the sample is flagged saturated",
        |s| s.filter.limits.gyro_range
    ),
    num!(
        31,
        "limits.gyro_abs_max",
        "deg/s",
        DEG,
        1.0,
        100000.0,
        "a gyro sample beyond this is absurd and rejected",
        |s| s.filter.limits.gyro_abs_max
    ),
    num!(
        32,
        "limits.accel_abs_max",
        "g",
        1.0,
        0.5,
        1000.0,
        "an accelerometer norm beyond this is absurd and rejected",
        |s| s.filter.limits.accel_abs_max_g
    ),
    num!(
        33,
        "limits.accel_min",
        "g",
        1.0,
        0.0,
        1.0,
        "an accelerometer norm below this has no usable direction",
        |s| s.filter.limits.accel_min_g
    ),
    num!(
        34,
        "limits.max_gap",
        "s",
        1.0,
        0.001,
        60.0,
        "longest time step integrated with the sample's rate",
        |s| s.filter.limits.max_gap_s
    ),
    // Rest detection.
    flag!(40, "rest.enabled", "rest detection (bias re-estimation, yaw hold)", |s| s
        .filter
        .rest
        .enabled),
    num!(41, "rest.block", "s", 1.0, 0.1, 600.0, "length of one detection block", |s| s
        .filter
        .rest
        .block_s),
    uint!(42, "rest.min_blocks", "", 1.0, 255.0, "consecutive still blocks before rest", |s| s
        .filter
        .rest
        .min_blocks),
    num!(
        43,
        "rest.rate_threshold",
        "deg/s",
        DEG,
        0.0,
        10.0,
        "largest bias-corrected mean rate of a still block (plus 3 standard errors)",
        |s| s.filter.rest.rate_threshold
    ),
    num!(
        44,
        "rest.gyro_var_factor",
        "",
        1.0,
        1.0,
        10000.0,
        "largest variance of a still block's 8 segment mean rates, times the configured noise's",
        |s| s.filter.rest.gyro_var_factor
    ),
    num!(
        45,
        "rest.accel_std_max",
        "g",
        1.0,
        0.0,
        1.0,
        "largest standard deviation per axis of a still block's 8 segment mean accelerations",
        |s| s.filter.rest.accel_std_max_g
    ),
    flag!(47, "rest.yaw_hold", "undo the yaw integrated over still blocks", |s| s
        .filter
        .rest
        .yaw_hold),
    // Magnetometer.
    flag!(50, "mag.enabled", "use the magnetometer for heading", |s| s.filter.mag.enabled),
    num!(51, "mag.field", "uT", 1.0, 1.0, 1000.0, "expected field strength", |s| s
        .filter
        .mag
        .field_ut),
    num!(52, "mag.dip", "deg", DEG, -90.0, 90.0, "expected dip, positive down", |s| s
        .filter
        .mag
        .dip),
    num!(
        53,
        "mag.declination",
        "deg",
        DEG,
        -180.0,
        180.0,
        "magnetic north east of true north",
        |s| s.filter.mag.declination
    ),
    num!(
        54,
        "mag.norm_tolerance",
        "",
        1.0,
        0.0,
        1.0,
        "reject when the field norm is off by more than this fraction",
        |s| s.filter.mag.norm_tolerance
    ),
    num!(
        55,
        "mag.dip_tolerance",
        "deg",
        DEG,
        0.0,
        90.0,
        "reject when the dip is off by more",
        |s| s.filter.mag.dip_tolerance
    ),
    num!(
        56,
        "mag.heading_sigma",
        "deg",
        DEG,
        0.01,
        180.0,
        "heading measurement standard deviation",
        |s| s.filter.mag.heading_sigma
    ),
    // EKF tuning.
    flag!(60, "ekf.yaw_split", "accelerometer corrections never change yaw", |s| s
        .filter
        .ekf
        .yaw_split),
    num!(62, "ekf.bias_random_walk", "(deg/s)2/s", DEG2, 0.0, 1.0, "gyro-bias random walk", |s| s
        .filter
        .ekf
        .bias_random_walk),
    num!(
        63,
        "ekf.yaw_drift_rate",
        "deg/h",
        DEG_H,
        -3600.0,
        3600.0,
        "constant yaw drift subtracted from the yaw integral",
        |s| s.filter.ekf.yaw_drift_rate
    ),
    num!(
        64,
        "ekf.initial_tilt_sigma",
        "deg",
        DEG,
        0.01,
        180.0,
        "tilt standard deviation after initialisation",
        |s| s.filter.ekf.initial_tilt_sigma
    ),
    num!(
        66,
        "ekf.initial_bias_sigma",
        "deg/s",
        DEG,
        0.001,
        100.0,
        "gyro-bias standard deviation after initialisation",
        |s| s.filter.ekf.initial_bias_sigma
    ),
    num!(
        67,
        "ekf.accel_time_constant",
        "s",
        1.0,
        0.0,
        60.0,
        "longest delay of the accelerometer low-pass in NED (2nd-order Butterworth; shorter when the motion allows); 0: raw samples",
        |s| s.filter.ekf.accel_time_constant
    ),
    // The ekf section's tens (60–69) are full: its later settings take the free ids below.
    // Retired ids, never to be reused (records of older firmware hold them; `load` skips
    // them): 58 `ekf.vib_time_constant`, 59 `ekf.vib_rate`, 68 `ekf.motion_scale`,
    // 69 `ekf.motion_time_constant`.
    num!(
        57,
        "ekf.gyro_scale_error",
        "",
        1.0,
        0.0,
        0.5,
        "gyro rate error proportional to the rate (scale factor, misalignment): attitude process noise (k·|ω|)²·τ; shorter low-pass in a turn",
        |s| s.filter.ekf.gyro_scale_error
    ),
    // Sensor conditioning.
    axes!(70, "axes.gyro", "gyro axes (LPR430AL X, Y, LY330ALH Z outputs) to body FRD", |s| s
        .conditioning
        .gyro_axes),
    axes!(71, "axes.accel", "accelerometer axes (LSM303DLH) to body FRD", |s| s
        .conditioning
        .accel_axes),
    axes!(72, "axes.mag", "magnetometer axes (LSM303DLH) to body FRD", |s| s.conditioning.mag_axes),
    vec3!(
        73,
        "gyro.offset",
        "deg/s",
        DEG,
        -50.0,
        50.0,
        "static gyro bias subtracted after the axis map, body FRD (`GBIAS` sets it)",
        |s| s.conditioning.gyro_offset
    ),
    vec3!(
        74,
        "accel_cal.x",
        "",
        1.0,
        -2.0,
        2.0,
        "row 1 of the calibration matrix X (weights of raw x), sensor axes",
        |s| s.conditioning.accel_calibration.x[0]
    ),
    vec3!(75, "accel_cal.y", "", 1.0, -2.0, 2.0, "row 2 of X (weights of raw y)", |s| s
        .conditioning
        .accel_calibration
        .x[1]),
    vec3!(76, "accel_cal.z", "", 1.0, -2.0, 2.0, "row 3 of X (weights of raw z)", |s| s
        .conditioning
        .accel_calibration
        .x[2]),
    vec3!(77, "accel_cal.o", "g", 1.0, -1.0, 1.0, "row 4 of X: the offset, sensor axes", |s| s
        .conditioning
        .accel_calibration
        .x[3]),
    vec3!(
        78,
        "lever.r",
        "m",
        1.0,
        -10.0,
        10.0,
        "IMU position from the rotation centre, body FRD",
        |s| s.conditioning.lever_arm.r
    ),
    flag!(79, "lever.centripetal", "remove the centripetal acceleration", |s| s
        .conditioning
        .lever_arm
        .centripetal),
    flag!(
        80,
        "lever.tangential",
        "remove the tangential acceleration (differentiated gyro)",
        |s| s.conditioning.lever_arm.tangential
    ),
    num!(
        81,
        "lever.tangential_tau",
        "s",
        1.0,
        0.0,
        10.0,
        "low-pass time constant of the differentiated gyro",
        |s| s.conditioning.lever_arm.tangential_time_constant
    ),
    // ADC and gyro conversion.
    // Also the gyro conversion's reference: see `after_write`.
    num!(
        90,
        "adc.vref",
        "V",
        1.0,
        1.0,
        5.0,
        "ADC reference voltage (gyro and depth channels)",
        |s| s.adc.vref_v
    ),
    // Also the gyro conversion's: see `after_write`. (Id 93: the section's next free one.)
    num!(
        93,
        "adc.vrefint",
        "V",
        1.0,
        1.16,
        1.26,
        "this part's internal reference VREFINT, from which VDDA and so the gyro and depth scales are measured (STM32F103 datasheet DS5792: 1.20 typ., 1.16–1.26); set once per board from a multimeter's VDDA (docs/bring-up.md)",
        |s| s.adc.vrefint_v
    ),
    vec3!(
        91,
        "gyro.sensitivity",
        "mV/(deg/s)",
        1000.0,
        0.01,
        1000.0,
        "gyro sensitivity of the x, y, z outputs",
        |s| s.gyro.sensitivity_v_per_dps
    ),
    num!(
        92,
        "gyro.range",
        "deg/s",
        1.0,
        1.0,
        10000.0,
        "gyro full scale: the conversion flags rates at or beyond it",
        |s| s.gyro.range_dps
    ),
    // Depth.
    num!(
        100,
        "depth.pa_per_volt",
        "Pa/V",
        1.0,
        1.0,
        1e9,
        "depth sensor calibration slope (pressure per volt at the ADC pin)",
        |s| s.depth.pa_per_volt
    ),
    num!(
        101,
        "depth.offset",
        "Pa",
        1.0,
        -1e8,
        1e8,
        "depth sensor calibration offset (pressure at 0 V)",
        |s| s.depth.offset_pa
    ),
    num!(
        102,
        "depth.density",
        "kg/m3",
        1.0,
        500.0,
        2000.0,
        "water density (seawater 1025, fresh water 998)",
        |s| s.depth.water_density_kg_m3
    ),
    num!(103, "depth.gravity", "m/s2", 1.0, 9.7, 9.9, "local gravity", |s| s.depth.gravity_m_s2),
    num!(
        104,
        "depth.surface_pressure",
        "Pa",
        1.0,
        -1e7,
        1e7,
        "pressure at zero depth (`ZERO` sets it)",
        |s| s.depth.surface_pressure_pa
    ),
    // Rates and output.
    uint!(110, "filter.rate", "Hz", 10.0, 200.0, "filter rate", |s| s.filter_rate_hz),
    uint!(111, "output.rate", "Hz", 1.0, 50.0, "output rate (at most the filter rate)", |s| s
        .output_rate_hz),
    flag!(112, "output.prdid", "send `$PRDID`", |s| s.sentences.prdid),
    flag!(113, "output.pinah", "send `$PINAH`", |s| s.sentences.pinah),
    talker!(114, "output.talker", "talker of the standard sentences (`HC`: heading, compass)", |s| s
        .sentences
        .talker),
    flag!(115, "output.hdt", "send `$--HDT` (true heading, while referenced to north)", |s| s
        .sentences
        .hdt),
    flag!(116, "output.hdg", "send `$--HDG` (magnetic heading, variation; magnetometer on)", |s| s
        .sentences
        .hdg),
    flag!(117, "output.hdm", "send `$--HDM` (magnetic heading; magnetometer on)", |s| s
        .sentences
        .hdm),
    flag!(118, "output.rot", "send `$--ROT` (rate of turn)", |s| s.sentences.rot),
    flag!(119, "output.xdr", "send `$--XDR` (pitch, roll, depth)", |s| s.sentences.xdr),
    // The I²C bus.
    uint!(
        120,
        "i2c.clock",
        "kHz",
        100.0,
        400.0,
        "I2C2 clock (the LSM303DLH's bus); 300: ST's own firmware for this board (its HAL_LSM303DLH.h), a longer byte for the errata's software events (ES0340 2.13.2). Read at boot: SAVE and reset to apply",
        |s| s.i2c_clock_khz
    ),
}
