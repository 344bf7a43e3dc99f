//! Gyro integration only: the source's "no filter" baseline. It diverges with any residual
//! bias; it is here to show what every correction buys. It is also the prediction stage of the
//! complementary filter.

use crate::{
    filter::AttitudeFilter,
    gate::AccelGate,
    init::{self, InitStep, Initializer},
    settings::Settings,
    validate, Flags, ImuSample, Quaternion, Vec3,
};

/// Integrates `gyro − bias` (bias from the initialisation window) and nothing else.
#[derive(Clone, Debug)]
pub struct GyroOnly {
    settings: Settings,
    q: Quaternion,
    bias: Vec3,
    init: Option<Initializer>,
    gate: AccelGate,
}

impl GyroOnly {
    /// A new integrator, starting its initialisation window.
    pub fn new(settings: Settings) -> Self {
        GyroOnly {
            settings,
            q: Quaternion::from_yaw(settings.init.initial_yaw),
            bias: settings.init.gyro_bias,
            init: Some(Initializer::new(&settings)),
            gate: AccelGate::new(settings.gate),
        }
    }
}

impl GyroOnly {
    /// The steps shared with the complementary filter: input checks, the initialisation
    /// window, and the gyro integration. `Err(flags)` when the sample ends there (unusable
    /// `dt`, or the window still running), `Ok` with the checked sample otherwise.
    pub(crate) fn propagate(&mut self, sample: &ImuSample) -> Result<validate::Checked, Flags> {
        let c = validate::check(sample, &self.settings.limits).ok_or(Flags::TIME_GAP)?;
        if let Some(init) = self.init.as_mut() {
            match init::feed(init, &mut self.gate, &c) {
                InitStep::Pending(q) => {
                    self.q = q;
                    return Err(c.flags | Flags::INITIALISING);
                }
                // The window's last sample still moves the state (below).
                InitStep::Done(q, b) => self.set_attitude(q, b),
            }
        }
        if let Some(g) = c.gyro {
            let w = g - self.bias;
            self.q = (self.q * Quaternion::from_rotation_vector(w * c.dt_rate)).normalized();
        }
        Ok(c)
    }

    /// The accelerometer gate (the complementary filter uses its first stage).
    pub(crate) fn gate_mut(&mut self) -> &mut AccelGate {
        &mut self.gate
    }

    /// Replace the attitude (normalised here).
    pub(crate) fn set_q(&mut self, q: Quaternion) {
        self.q = q.normalized();
    }
}

impl AttitudeFilter for GyroOnly {
    fn name(&self) -> &'static str {
        "gyro"
    }

    fn update(&mut self, sample: &ImuSample) -> Flags {
        match self.propagate(sample) {
            Ok(c) => c.flags,
            Err(flags) => flags,
        }
    }

    fn attitude(&self) -> Quaternion {
        self.q
    }

    fn gyro_bias(&self) -> Vec3 {
        self.bias
    }

    fn is_initialised(&self) -> bool {
        self.init.is_none()
    }

    fn set_yaw(&mut self, yaw: f32) {
        if !yaw.is_finite() {
            return;
        }
        match self.init.as_mut() {
            Some(init) => init.set_yaw(yaw),
            None => self.q = self.q.with_yaw(yaw),
        }
    }

    fn set_attitude(&mut self, q: Quaternion, bias: Vec3) {
        self.q = q.normalized();
        self.bias = if bias.is_finite() { bias } else { self.settings.init.gyro_bias };
        self.init = None;
        self.gate.reset();
    }

    fn reset(&mut self) {
        *self = GyroOnly::new(self.settings);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{mathf::deg, Euler};

    /// Still through the window with a gyro offset: initialised at its end with the offset as
    /// the bias; `reset` starts a new window from the configured bias.
    #[test]
    fn the_window_measures_the_bias_and_reset_starts_it_again() {
        let mut f = GyroOnly::new(Settings::default());
        assert!(!f.is_initialised());
        let b = Vec3::new(0.002, -0.001, 0.0005);
        let level = Vec3::new(0.0, 0.0, -crate::GRAVITY);
        let mut n = 0;
        while !f.is_initialised() && n < 5000 {
            f.update(&ImuSample::new(0.02, b, level));
            n += 1;
        }
        assert!(f.is_initialised() && n > 1, "{n}");
        assert!((f.gyro_bias() - b).norm() < 1e-6, "{:?}", f.gyro_bias());
        f.reset();
        assert!(!f.is_initialised());
        assert_eq!(f.gyro_bias(), Settings::default().init.gyro_bias);
    }

    #[test]
    fn integrates_a_constant_rate_exactly_and_drifts_with_bias() {
        let mut f = GyroOnly::new(Settings::default());
        assert_eq!(f.name(), "gyro");
        f.set_attitude(Quaternion::IDENTITY, Vec3::ZERO);
        let w = Vec3::new(0.1, -0.2, 0.3);
        for _ in 0..500 {
            f.update(&ImuSample::new(0.02, w, Vec3::new(0.0, 0.0, -9.81)));
        }
        let exact = Quaternion::from_rotation_vector(w * 10.0);
        assert!(f.attitude().angle_to(exact) < 1e-4, "{}", f.attitude().angle_to(exact));
        // A residual bias of 0.01 rad/s on z drifts yaw by 0.1 rad in 10 s.
        let mut f = GyroOnly::new(Settings::default());
        f.set_attitude(Quaternion::IDENTITY, Vec3::ZERO);
        for _ in 0..500 {
            f.update(&ImuSample::new(0.02, Vec3::new(0.0, 0.0, 0.01), Vec3::ZERO));
        }
        assert!((f.euler().yaw - 0.1).abs() < 1e-5);
        f.set_yaw(deg(-45.0));
        // Within two `atan2` errors (the yaw read before the turn and after it).
        assert!((Euler::yaw_of(f.attitude()) - deg(-45.0)).abs() < 5e-6);
    }
}
