//! Facts about the STEVAL-MKI062V2 "iNEMO" V2 board, from ST's board support code and the
//! parts' datasheets. Every pin, address and constant of the board lives here.

/// I²C2 clock on PB10 (SCL) and data on PB11 (SDA). Shared by the LSM303DLH, the LPS001DL
/// barometer and the STLM75 thermometer.
pub const I2C_PINS: &str = "I2C2: SCL PB10, SDA PB11";
/// I²C bus clock, Hz: the default of the setting `i2c.clock` (the firmware runs the highest
/// clock at or below it that the divider reproduces exactly,
/// `supervision::i2c_bus::bus_clock`). 300 kHz, not the 400 kHz every device on the bus
/// supports: ST's own firmware for this board runs I²C2 at 300 kHz (`LSM_I2C_Speed 300000`,
/// `LSM_A_I2C_Speed` and `LSM_M_I2C_Speed` likewise, in its `HAL_LSM303DLH.h`, V2.2, 01/11/2011),
/// which leaves a longer byte (30 µs, 33 % more than at 400 kHz) for the software events of
/// ES0340 §2.13.2.
pub const I2C_FREQUENCY_HZ: u32 = 300_000;
/// LSM303DLH accelerometer 7-bit I²C address (SA0_A pulled high on the board).
pub const LSM303DLH_ACCEL_ADDR: u8 = 0x19;
/// LSM303DLH magnetometer 7-bit I²C address (fixed).
pub const LSM303DLH_MAG_ADDR: u8 = 0x1E;

/// ADC1 channel of the LPR430AL X (roll) rate output, 4× amplified: PC0.
pub const ADC_CH_GYRO_X: u8 = 10;
/// ADC1 channel of the LPR430AL Y (pitch) rate output, 4× amplified: PC1.
pub const ADC_CH_GYRO_Y: u8 = 11;
/// ADC1 channel of the LPR430AL reference voltage: PC2.
pub const ADC_CH_GYRO_XY_REF: u8 = 12;
/// ADC1 channel of the LY330ALH Z (yaw) rate output: PC4.
pub const ADC_CH_GYRO_Z: u8 = 14;
/// ADC1 channel of the LY330ALH reference voltage: PC5.
pub const ADC_CH_GYRO_Z_REF: u8 = 15;
/// ADC1 channel of the external depth (pressure) sensor: PA1 (ADC123_IN1). PA1 is not used by
/// ST's board code and is free on the board's extension connector; the SICK PBT's 0–10 V or
/// 4–20 mA output must be scaled into 0–3.3 V externally (divider or shunt).
pub const ADC_CH_DEPTH: u8 = 1;

/// ADC1 channel of the internal reference VREFINT (RM0008 §11.12; enabled by ADC_CR2.TSVREFE).
pub const ADC_CH_VREFINT: u8 = 17;
/// VREFINT, V: 1.20 typ., 1.16–1.26 over −40…105 °C (STM32F103xC/D/E datasheet
/// DS5792, "Embedded internal reference voltage"). VDDA = VREFINT · 4095 / counts. The default
/// of the setting `adc.vrefint`, which holds a calibrated board's own value; the boot's rank
/// check keeps this nominal value (`adc::check_ranks`).
pub const VREFINT_V: f32 = 1.20;
/// VDDA range in which the ADC works (DS5792: 2.4–3.6 V): a VREFINT reading that gives a VDDA
/// outside it is not a VREFINT reading (a wrong rank) and is not used.
pub const VDDA_MIN_V: f32 = 2.4;
/// Upper end of [`VDDA_MIN_V`]'s range.
pub const VDDA_MAX_V: f32 = 3.6;

/// LPR430AL sensitivity on the 4× outputs, V per °/s (3.33 mV/dps).
pub const LPR430AL_SENSITIVITY_V_PER_DPS: f32 = 3.33e-3;
/// LY330ALH sensitivity, V per °/s (3.752 mV/dps).
pub const LY330ALH_SENSITIVITY_V_PER_DPS: f32 = 3.752e-3;
/// Full scale of both gyros, °/s.
pub const GYRO_RANGE_DPS: f32 = 300.0;
/// ADC reference (VDDA = VREF+ = 3.3 V on the board), V: the nominal value, used when no
/// VREFINT measurement is at hand (the firmware measures it in every scan, `adc::AdcScale`).
pub const ADC_VREF: f32 = 3.3;
/// ADC full-scale count (12 bit).
pub const ADC_FULL_SCALE: u16 = 4095;

/// Gyro power-down pins, driven low to run: PB5 (LPR430AL), PB15 (LY330ALH).
pub const GYRO_POWER_DOWN_PINS: &str = "PB5 (LPR430AL PD), PB15 (LY330ALH PD): low";
/// Gyro self-test pins, driven low for normal operation: PB1 (LPR430AL ST), PB14 (LY330ALH ST).
pub const GYRO_SELF_TEST_PINS: &str = "PB1 (LPR430AL ST), PB14 (LY330ALH ST): low";
/// Status LED: PB9, active high.
pub const LED_PIN: &str = "PB9, active high";

/// Output USART: USART2 on PA2 (TX) and PA3 (RX). USART3's default pins are I²C2's
/// (PB10/PB11) and PA9 (USART1 TX) is the LPS001DL's interrupt line, so USART2 is the one
/// free port.
pub const USART: &str = "USART2: TX PA2, RX PA3";
/// Output baud rate, bit/s.
pub const USART_BAUD: u32 = 115_200;
/// USB (the bench console, CDC-ACM): D− PA11, D+ PA12, and the D+ pull-up switched by PA10,
/// high = connected. Source: ST's iNEMO firmware V3.2.1 (2010), `iNEMO_usb_common.h`
/// (`iNEMO_USB_DISCONNECT` GPIOA, `iNEMO_USB_DISCONNECT_PIN` GPIO_Pin_10) and `virtual_com.c`
/// (`USB_Cable_Config(ENABLE)` sets the pin). Not verified on a board. The firmware names the
/// pin in one place, `app::usb::PullUp`.
pub const USB_PINS: &str = "USB: D- PA11, D+ PA12, D+ pull-up switched by PA10 (high = on)";

/// External crystal, Hz (8 MHz HSE; the firmware falls back to the internal HSI if it fails).
pub const HSE_HZ: u32 = 8_000_000;
/// System clock, Hz (PLL from HSE; 64 MHz when running from HSI/2 × 16).
pub const SYSCLK_HZ: u32 = 72_000_000;

use ekf_core::axis_map::AxisMap;

/// Default accelerometer and magnetometer axis map (LSM303DLH axes → body FRD).
///
/// The source: "the IMU frame and the vehicle's NED body frame differ: +y and +z point the
/// other way" — the chip's axes are x forward, y to port, z up (a flat board face up reads
/// +1 g on z). So `body = (raw.x, −raw.y, −raw.z)`, a 180° rotation about x. (ST's own
/// firmware feeds its AHRS `[Y, X, −Z]` for its board orientation.) Verify with the bench
/// procedure in `docs/operating.md` before trusting it on a new mounting.
pub const ACCEL_AXES: AxisMap = match AxisMap::new([0, 1, 2], [1, -1, -1]) {
    Ok(m) => m,
    Err(_) => AxisMap::IDENTITY,
};

/// Default magnetometer axis map: the LSM303DLH's magnetometer axes are those of its
/// accelerometer, so the same map.
pub const MAG_AXES: AxisMap = ACCEL_AXES;

/// Default gyro axis map (LPR430AL X, Y and LY330ALH Z outputs → body FRD).
///
/// As the accelerometer, except that "the gyro's y axis does not match the board's y axis"
/// (the source; ST's firmware also negates one gyro channel): `body = (raw.x, raw.y, −raw.z)`.
/// That is a reflection, which is what the analog outputs' sign conventions amount to. Verify
/// every sign with the bench procedure before use.
pub const GYRO_AXES: AxisMap = match AxisMap::new([0, 1, 2], [1, 1, -1]) {
    Ok(m) => m,
    Err(_) => AxisMap::IDENTITY,
};

/// Flash address of settings page A (the second-to-last 2 KiB page of the STM32F103RE's
/// 512 KiB; `memory.x` gives code the first 508 KiB only).
pub const SETTINGS_PAGE_A: u32 = 0x0807_F000;
/// Flash address of settings page B (the last 2 KiB page).
pub const SETTINGS_PAGE_B: u32 = 0x0807_F800;
/// Flash page size of the STM32F103RE (high density), bytes.
pub const FLASH_PAGE_SIZE: usize = 2048;
