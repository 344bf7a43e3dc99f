//! `replay --config settings.toml`: a TOML file overriding fields of the estimator settings.
//!
//! Every key is optional; a key that is given replaces the default. Unknown sections or keys
//! are an error. Names and units are exactly those of the Rust structs in `ekf-core`
//! (angles in rad, rates in rad/s, variances in (rad/s)² or g², times in s; a 3-vector is an
//! array `[x, y, z]` in body FRD):
//!
//! | section | struct | keys |
//! |---|---|---|
//! | `[noise]` | `settings::NoiseSettings` | `gyro_var` (3 numbers), `gyro_ref_rate_hz`, `accel_var` |
//! | `[init]` | `settings::InitSettings` | `window_s`, `initial_yaw`, `estimate_gyro_bias`, `gyro_bias` (3 numbers) |
//! | `[gate]` | `settings::GateSettings` | `norm_tolerance`, `jump_g`, `innovation_chi2`, `holdoff_s`, `reacquire_s`, `long_reject_s` |
//! | `[limits]` | `settings::LimitSettings` | `gyro_range`, `gyro_abs_max`, `accel_abs_max_g`, `accel_min_g`, `max_gap_s` |
//! | `[rest]` | `settings::RestSettings` | `enabled`, `block_s`, `min_blocks`, `rate_threshold`, `gyro_var_factor`, `accel_std_max_g`, `bias_meas_floor`, `yaw_hold` |
//! | `[mag]` | `settings::MagSettings` | `enabled`, `field_ut`, `dip`, `declination`, `norm_tolerance`, `dip_tolerance`, `heading_sigma` |
//! | `[ekf]` | `settings::EkfSettings` | `yaw_split`, `accel_var_scale`, `bias_random_walk`, `yaw_drift_rate`, `initial_tilt_sigma`, `initial_yaw_sigma`, `initial_bias_sigma` |
//! | `[ukf]` | `ukf::UkfParams` | `alpha`, `kappa`, `beta`, `accel_var_scale`, `bias_random_walk`, `initial_tilt_sigma`, `initial_yaw_sigma`, `initial_bias_sigma` |
//! | `[ssukf]` | `ssukf::SsUkfParams` | `w0`, `alpha`, `beta`, `accel_var_scale`, `bias_random_walk`, `initial_tilt_sigma`, `initial_yaw_sigma`, `initial_bias_sigma` |
//! | `[complementary]` | `complementary::ComplementaryParams` | `gain`, `gain_rate_hz`, `lerp_below` |
//! | `[conditioning]` | `conditioning::ConditioningSettings` | `gyro_offset` (3 numbers, rad/s), `accel_calibration` (4×3 array of rows, the source's X matrix), `gyro_axes`, `accel_axes`, `mag_axes` (each `{ source = [i, j, k], sign = [±1, ±1, ±1] }`, `body[i] = sign[i] · raw[source[i]]`) |
//! | `[lever_arm]` | `lever_arm::LeverArm` | `r` (3 numbers, m), `centripetal`, `tangential`, `tangential_time_constant` |
//!
//! Example:
//! ```toml
//! [init]
//! estimate_gyro_bias = false
//! gyro_bias = [0.028257, 0.060039, 0.000873]
//!
//! [ekf]
//! accel_var_scale = 20
//!
//! [lever_arm]
//! tangential = true
//! ```

use ekf_core::axis_map::AxisMap;
use ekf_core::complementary::ComplementaryParams;
use ekf_core::conditioning::ConditioningSettings;
use ekf_core::lever_arm::LeverArm;
use ekf_core::ssukf::SsUkfParams;
use ekf_core::ukf::UkfParams;
use ekf_core::{settings, Settings, Vec3};
use serde::Deserialize;

/// Everything a replay is configured with.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReplayConfig {
    /// Estimator settings (shared by every filter).
    pub settings: Settings,
    /// UKF tuning.
    pub ukf: UkfParams,
    /// SS-UKF tuning.
    pub ssukf: SsUkfParams,
    /// Complementary-filter tuning.
    pub complementary: ComplementaryParams,
    /// Conditioning (identity axis maps, Seahog lever arm by default).
    pub conditioning: ConditioningSettings,
}

/// A TOML value convertible into a settings field.
trait IntoField<T> {
    fn into_field(self) -> T;
}

impl IntoField<f32> for f32 {
    fn into_field(self) -> f32 {
        self
    }
}

impl IntoField<bool> for bool {
    fn into_field(self) -> bool {
        self
    }
}

impl IntoField<u8> for u8 {
    fn into_field(self) -> u8 {
        self
    }
}

impl IntoField<Vec3> for [f32; 3] {
    fn into_field(self) -> Vec3 {
        Vec3::from_array(self)
    }
}

macro_rules! section {
    ($(#[$m:meta])* $name:ident => $target:ty { $($field:ident : $ty:ty),* $(,)? }) => {
        $(#[$m])*
        #[derive(Clone, Debug, Default, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            $(
                #[allow(missing_docs)]
                pub $field: Option<$ty>,
            )*
        }

        impl $name {
            fn apply(&self, target: &mut $target) {
                $(
                    if let Some(v) = self.$field {
                        target.$field = v.into_field();
                    }
                )*
            }
        }
    };
}

section!(
    /// `[noise]`.
    NoiseToml => settings::NoiseSettings {
        gyro_var: [f32; 3], gyro_ref_rate_hz: f32, accel_var: f32,
    }
);
section!(
    /// `[init]`.
    InitToml => settings::InitSettings {
        window_s: f32, initial_yaw: f32, estimate_gyro_bias: bool, gyro_bias: [f32; 3], moving_bias_sigma: f32,
    }
);
section!(
    /// `[gate]`.
    GateToml => settings::GateSettings {
        norm_tolerance: f32, jump_g: f32, innovation_chi2: f32, holdoff_s: f32,
        reacquire_s: f32, long_reject_s: f32,
    }
);
section!(
    /// `[limits]`.
    LimitsToml => settings::LimitSettings {
        gyro_range: f32, gyro_abs_max: f32, accel_abs_max_g: f32, accel_min_g: f32,
        max_gap_s: f32,
    }
);
section!(
    /// `[rest]`.
    RestToml => settings::RestSettings {
        enabled: bool, block_s: f32, min_blocks: u8, rate_threshold: f32,
        gyro_var_factor: f32, accel_std_max_g: f32, bias_meas_floor: f32, yaw_hold: bool,
    }
);
section!(
    /// `[mag]`.
    MagToml => settings::MagSettings {
        enabled: bool, field_ut: f32, dip: f32, declination: f32, norm_tolerance: f32,
        dip_tolerance: f32, heading_sigma: f32,
    }
);
section!(
    /// `[ekf]`.
    EkfToml => settings::EkfSettings {
        yaw_split: bool, accel_var_scale: f32, bias_random_walk: f32, yaw_drift_rate: f32,
        initial_tilt_sigma: f32, initial_yaw_sigma: f32, initial_bias_sigma: f32, accel_time_constant: f32, motion_scale: f32, motion_time_constant: f32,
    }
);
section!(
    /// `[ukf]`.
    UkfToml => UkfParams {
        alpha: f32, kappa: f32, beta: f32, accel_var_scale: f32, bias_random_walk: f32,
        initial_tilt_sigma: f32, initial_yaw_sigma: f32, initial_bias_sigma: f32,
    }
);
section!(
    /// `[ssukf]`.
    SsUkfToml => SsUkfParams {
        w0: f32, alpha: f32, beta: f32, accel_var_scale: f32, bias_random_walk: f32,
        initial_tilt_sigma: f32, initial_yaw_sigma: f32, initial_bias_sigma: f32,
    }
);
section!(
    /// `[complementary]`.
    ComplementaryToml => ComplementaryParams { gain: f32, gain_rate_hz: f32, lerp_below: f32 }
);
section!(
    /// `[lever_arm]`.
    LeverArmToml => LeverArm {
        r: [f32; 3], centripetal: bool, tangential: bool, tangential_time_constant: f32,
    }
);

/// An axis map in TOML: `{ source = [0, 1, 2], sign = [1, 1, 1] }`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisMapToml {
    /// `body[i] = sign[i] · raw[source[i]]`.
    pub source: [u8; 3],
    /// ±1 per body axis.
    pub sign: [i8; 3],
}

/// `[conditioning]`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConditioningToml {
    /// Static gyro bias subtracted after remapping, rad/s.
    pub gyro_offset: Option<[f32; 3]>,
    /// The accelerometer calibration's 4×3 X matrix (rows).
    pub accel_calibration: Option<[[f32; 3]; 4]>,
    /// Gyro axis map.
    pub gyro_axes: Option<AxisMapToml>,
    /// Accelerometer axis map.
    pub accel_axes: Option<AxisMapToml>,
    /// Magnetometer axis map.
    pub mag_axes: Option<AxisMapToml>,
}

/// The whole file.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConfigToml {
    #[allow(missing_docs)]
    pub noise: Option<NoiseToml>,
    #[allow(missing_docs)]
    pub init: Option<InitToml>,
    #[allow(missing_docs)]
    pub gate: Option<GateToml>,
    #[allow(missing_docs)]
    pub limits: Option<LimitsToml>,
    #[allow(missing_docs)]
    pub rest: Option<RestToml>,
    #[allow(missing_docs)]
    pub mag: Option<MagToml>,
    #[allow(missing_docs)]
    pub ekf: Option<EkfToml>,
    #[allow(missing_docs)]
    pub ukf: Option<UkfToml>,
    #[allow(missing_docs)]
    pub ssukf: Option<SsUkfToml>,
    #[allow(missing_docs)]
    pub complementary: Option<ComplementaryToml>,
    #[allow(missing_docs)]
    pub conditioning: Option<ConditioningToml>,
    #[allow(missing_docs)]
    pub lever_arm: Option<LeverArmToml>,
}

fn axis_map(name: &str, m: AxisMapToml) -> Result<AxisMap, String> {
    AxisMap::new(m.source, m.sign).map_err(|e| format!("conditioning.{name}: {e}"))
}

impl ConfigToml {
    /// Apply the overrides to `cfg`.
    pub fn apply(&self, cfg: &mut ReplayConfig) -> Result<(), String> {
        let s = &mut cfg.settings;
        if let Some(x) = &self.noise {
            x.apply(&mut s.noise);
        }
        if let Some(x) = &self.init {
            x.apply(&mut s.init);
        }
        if let Some(x) = &self.gate {
            x.apply(&mut s.gate);
        }
        if let Some(x) = &self.limits {
            x.apply(&mut s.limits);
        }
        if let Some(x) = &self.rest {
            x.apply(&mut s.rest);
        }
        if let Some(x) = &self.mag {
            x.apply(&mut s.mag);
        }
        if let Some(x) = &self.ekf {
            x.apply(&mut s.ekf);
        }
        if let Some(x) = &self.ukf {
            x.apply(&mut cfg.ukf);
        }
        if let Some(x) = &self.ssukf {
            x.apply(&mut cfg.ssukf);
        }
        if let Some(x) = &self.complementary {
            x.apply(&mut cfg.complementary);
        }
        if let Some(x) = &self.lever_arm {
            x.apply(&mut cfg.conditioning.lever_arm);
        }
        if let Some(c) = &self.conditioning {
            let t = &mut cfg.conditioning;
            if let Some(v) = c.gyro_offset {
                t.gyro_offset = Vec3::from_array(v);
            }
            if let Some(x) = c.accel_calibration {
                t.accel_calibration.x = x;
            }
            if let Some(m) = c.gyro_axes {
                t.gyro_axes = axis_map("gyro_axes", m)?;
            }
            if let Some(m) = c.accel_axes {
                t.accel_axes = axis_map("accel_axes", m)?;
            }
            if let Some(m) = c.mag_axes {
                t.mag_axes = axis_map("mag_axes", m)?;
            }
        }
        Ok(())
    }
}

/// Parse a TOML text and apply it on top of the defaults.
pub fn parse_config(text: &str) -> Result<ReplayConfig, String> {
    let mut cfg = ReplayConfig::default();
    apply_config(text, &mut cfg)?;
    Ok(cfg)
}

/// Apply the TOML `text` on top of `cfg` (`replay --foreign --config`: on top of the foreign
/// configuration instead of the defaults).
pub fn apply_config(text: &str, cfg: &mut ReplayConfig) -> Result<(), String> {
    let file: ConfigToml = toml::from_str(text).map_err(|e| {
        // toml's message spans several lines (with a caret under the error): keep one.
        e.to_string().lines().filter(|l| !l.trim().is_empty()).collect::<Vec<_>>().join(" ")
    })?;
    file.apply(cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_file_is_defaults() {
        assert_eq!(parse_config("").unwrap(), ReplayConfig::default());
    }

    #[test]
    fn overrides_apply() {
        let c = parse_config(
            "[init]\nestimate_gyro_bias = false\ngyro_bias = [0.1, 0.2, 0.3]\n\
             [ekf]\naccel_var_scale = 20\n[rest]\nmin_blocks = 3\n\
             [lever_arm]\ntangential = true\nr = [0, 0, 0]\n\
             [conditioning]\ngyro_axes = { source = [1, 0, 2], sign = [1, 1, -1] }\n\
             [ukf]\nalpha = 0.5\n",
        )
        .unwrap();
        assert!(!c.settings.init.estimate_gyro_bias);
        assert_eq!(c.settings.init.gyro_bias, Vec3::new(0.1, 0.2, 0.3));
        assert_eq!(c.settings.ekf.accel_var_scale, 20.0);
        assert_eq!(c.settings.rest.min_blocks, 3);
        assert!(c.conditioning.lever_arm.tangential);
        assert_eq!(c.conditioning.lever_arm.r, Vec3::ZERO);
        assert_eq!(c.conditioning.gyro_axes, AxisMap::new([1, 0, 2], [1, 1, -1]).unwrap());
        assert_eq!(c.ukf.alpha, 0.5);
        // Untouched fields keep their defaults.
        assert_eq!(c.settings.gate, settings::GateSettings::default());
    }

    #[test]
    fn unknown_keys_and_bad_values_are_errors() {
        let e = parse_config("[ekf]\nyaw_splt = true\n").unwrap_err();
        assert!(e.contains("yaw_splt"), "{e}");
        assert!(parse_config("[ekff]\n").is_err());
        assert!(parse_config("[ekf]\naccel_var_scale = \"x\"\n").is_err());
        let e =
            parse_config("[conditioning]\ngyro_axes = { source = [0, 0, 2], sign = [1, 1, 1] }")
                .unwrap_err();
        // Said in words, not as a Rust value (issue #14).
        assert_eq!(e, "conditioning.gyro_axes: axis map: raw axis 0 is used more than once");
        assert!(!parse_config("[ekf]\nyaw_splt = true\n").unwrap_err().contains('\n'));
    }
}
