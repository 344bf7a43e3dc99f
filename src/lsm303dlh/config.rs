//! Configuration of the accelerometer and the magnetometer: full scale, output data rate, gain.

/// Accelerometer full scale (`CTRL_REG4_A` FS1..0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AccelScale {
    /// ±2 g, 1 mg per LSB (FS = 00, the reset value).
    G2,
    /// ±4 g, 2 mg per LSB (FS = 01).
    G4,
    /// ±8 g, 3.9 mg per LSB (FS = 11).
    G8,
}

impl AccelScale {
    /// Value of the FS1..0 field.
    pub const fn bits(self) -> u8 {
        match self {
            AccelScale::G2 => 0b00,
            AccelScale::G4 => 0b01,
            AccelScale::G8 => 0b11,
        }
    }

    /// Sensitivity in mg per LSB of the 12-bit sample (after the `>> 4`).
    pub const fn mg_per_lsb(self) -> f32 {
        match self {
            AccelScale::G2 => 1.0,
            AccelScale::G4 => 2.0,
            AccelScale::G8 => 3.9,
        }
    }

    /// Full-scale range, ± g.
    pub const fn range_g(self) -> u8 {
        match self {
            AccelScale::G2 => 2,
            AccelScale::G4 => 4,
            AccelScale::G8 => 8,
        }
    }
}

/// Accelerometer output data rate in normal mode (`CTRL_REG1_A` DR1..0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AccelRate {
    /// 50 Hz (DR = 00).
    Hz50,
    /// 100 Hz (DR = 01).
    Hz100,
    /// 400 Hz (DR = 10).
    Hz400,
    /// 1000 Hz (DR = 11).
    Hz1000,
}

impl AccelRate {
    /// Value of the DR1..0 field.
    pub const fn bits(self) -> u8 {
        match self {
            AccelRate::Hz50 => 0b00,
            AccelRate::Hz100 => 0b01,
            AccelRate::Hz400 => 0b10,
            AccelRate::Hz1000 => 0b11,
        }
    }

    /// Output data rate, Hz.
    pub const fn hz(self) -> u16 {
        match self {
            AccelRate::Hz50 => 50,
            AccelRate::Hz100 => 100,
            AccelRate::Hz400 => 400,
            AccelRate::Hz1000 => 1000,
        }
    }
}

/// Magnetometer data output rate in continuous mode (`CRA_REG_M` DO2..0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MagRate {
    /// 0.75 Hz (DO = 000).
    Hz0_75,
    /// 1.5 Hz (DO = 001).
    Hz1_5,
    /// 3.0 Hz (DO = 010).
    Hz3,
    /// 7.5 Hz (DO = 011).
    Hz7_5,
    /// 15 Hz (DO = 100, the reset value).
    Hz15,
    /// 30 Hz (DO = 101).
    Hz30,
    /// 75 Hz (DO = 110), the fastest.
    Hz75,
}

impl MagRate {
    /// Value of the DO2..0 field.
    pub const fn bits(self) -> u8 {
        match self {
            MagRate::Hz0_75 => 0b000,
            MagRate::Hz1_5 => 0b001,
            MagRate::Hz3 => 0b010,
            MagRate::Hz7_5 => 0b011,
            MagRate::Hz15 => 0b100,
            MagRate::Hz30 => 0b101,
            MagRate::Hz75 => 0b110,
        }
    }

    /// Output data rate, Hz.
    pub const fn hz(self) -> f32 {
        match self {
            MagRate::Hz0_75 => 0.75,
            MagRate::Hz1_5 => 1.5,
            MagRate::Hz3 => 3.0,
            MagRate::Hz7_5 => 7.5,
            MagRate::Hz15 => 15.0,
            MagRate::Hz30 => 30.0,
            MagRate::Hz75 => 75.0,
        }
    }
}

/// Magnetometer gain and range (`CRB_REG_M` GN2..0), with the LSM303DLH's (not the DLHC's)
/// sensitivities. Z is less sensitive than X and Y at every setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MagGain {
    /// ±1.3 gauss: 1055 LSB/gauss on X and Y, 950 on Z (GN = 001, the reset value).
    Gauss1_3,
    /// ±1.9 gauss: 795 / 710 LSB/gauss (GN = 010).
    Gauss1_9,
    /// ±2.5 gauss: 635 / 570 LSB/gauss (GN = 011).
    Gauss2_5,
    /// ±4.0 gauss: 430 / 385 LSB/gauss (GN = 100).
    Gauss4_0,
    /// ±4.7 gauss: 375 / 335 LSB/gauss (GN = 101).
    Gauss4_7,
    /// ±5.6 gauss: 320 / 285 LSB/gauss (GN = 110).
    Gauss5_6,
    /// ±8.1 gauss: 230 / 205 LSB/gauss (GN = 111).
    Gauss8_1,
}

impl MagGain {
    /// Value of the GN2..0 field.
    pub const fn bits(self) -> u8 {
        match self {
            MagGain::Gauss1_3 => 0b001,
            MagGain::Gauss1_9 => 0b010,
            MagGain::Gauss2_5 => 0b011,
            MagGain::Gauss4_0 => 0b100,
            MagGain::Gauss4_7 => 0b101,
            MagGain::Gauss5_6 => 0b110,
            MagGain::Gauss8_1 => 0b111,
        }
    }

    /// Sensitivity of the X and Y axes, LSB per gauss.
    pub const fn lsb_per_gauss_xy(self) -> u16 {
        match self {
            MagGain::Gauss1_3 => 1055,
            MagGain::Gauss1_9 => 795,
            MagGain::Gauss2_5 => 635,
            MagGain::Gauss4_0 => 430,
            MagGain::Gauss4_7 => 375,
            MagGain::Gauss5_6 => 320,
            MagGain::Gauss8_1 => 230,
        }
    }

    /// Sensitivity of the Z axis, LSB per gauss.
    pub const fn lsb_per_gauss_z(self) -> u16 {
        match self {
            MagGain::Gauss1_3 => 950,
            MagGain::Gauss1_9 => 710,
            MagGain::Gauss2_5 => 570,
            MagGain::Gauss4_0 => 385,
            MagGain::Gauss4_7 => 335,
            MagGain::Gauss5_6 => 285,
            MagGain::Gauss8_1 => 205,
        }
    }

    /// Nominal range, ± gauss.
    pub const fn range_gauss(self) -> f32 {
        match self {
            MagGain::Gauss1_3 => 1.3,
            MagGain::Gauss1_9 => 1.9,
            MagGain::Gauss2_5 => 2.5,
            MagGain::Gauss4_0 => 4.0,
            MagGain::Gauss4_7 => 4.7,
            MagGain::Gauss5_6 => 5.6,
            MagGain::Gauss8_1 => 8.1,
        }
    }
}

/// Accelerometer configuration written by `Lsm303dlh::init_accel`.
///
/// The default, 100 Hz and ±2 g, samples at twice the 50 Hz filter rate and gives the finest
/// resolution (1 mg); the filter rejects anything beyond a few hundredths of a g from 1 g for
/// tilt anyway, and an ROV's accelerations stay far below 2 g.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AccelConfig {
    /// Output data rate.
    pub rate: AccelRate,
    /// Full scale.
    pub scale: AccelScale,
}

impl AccelConfig {
    /// The default configuration: 100 Hz, ±2 g.
    pub const fn new() -> Self {
        AccelConfig { rate: AccelRate::Hz100, scale: AccelScale::G2 }
    }

    /// This configuration with output data rate `rate`.
    pub const fn with_rate(self, rate: AccelRate) -> Self {
        AccelConfig { rate, ..self }
    }

    /// This configuration with full scale `scale`.
    pub const fn with_scale(self, scale: AccelScale) -> Self {
        AccelConfig { scale, ..self }
    }
}

impl Default for AccelConfig {
    fn default() -> Self {
        Self::new()
    }
}

/// Magnetometer configuration written by `Lsm303dlh::init_mag` (the magnetometer is then put
/// in continuous conversion).
///
/// The default is 75 Hz, the fastest rate and the only one at or above the 50 Hz filter rate,
/// and ±1.9 gauss rather than the most sensitive ±1.3 gauss: the Earth's field (up to about
/// 0.65 gauss in total) plus the hard-iron offset of the vehicle — thruster motor magnets and
/// their currents close to the board — can come near or beyond 1.3 gauss on one axis, and an
/// overflowed axis (−4096) is useless, while ±1.9 gauss still resolves 0.126 µT per LSB on X/Y,
/// far finer than heading needs. Choose `MagGain::Gauss2_5` or more if
/// `Error::MagOverflow` still shows up near the thrusters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MagConfig {
    /// Data output rate.
    pub rate: MagRate,
    /// Gain (range).
    pub gain: MagGain,
}

impl MagConfig {
    /// The default configuration: 75 Hz, ±1.9 gauss.
    pub const fn new() -> Self {
        MagConfig { rate: MagRate::Hz75, gain: MagGain::Gauss1_9 }
    }

    /// This configuration with data output rate `rate`.
    pub const fn with_rate(self, rate: MagRate) -> Self {
        MagConfig { rate, ..self }
    }

    /// This configuration with gain `gain`.
    pub const fn with_gain(self, gain: MagGain) -> Self {
        MagConfig { gain, ..self }
    }
}

impl Default for MagConfig {
    fn default() -> Self {
        Self::new()
    }
}
