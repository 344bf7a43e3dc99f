//! [`ReplayConfig`]: everything a replay is configured with. The command line sets it in the
//! device's settings language (`replay --set NAME=VALUE`, `--settings FILE`: the
//! [`crate::settings`] module).

use ekf_core::complementary::ComplementaryParams;
use ekf_core::conditioning::ConditioningSettings;
use ekf_core::ssukf::SsUkfParams;
use ekf_core::ukf::UkfParams;
use ekf_core::Settings;

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
