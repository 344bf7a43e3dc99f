//! Register map of the LSM303DLH (datasheet Doc ID 16941): I²C addresses, register
//! sub-addresses and the bit fields the driver uses.
//!
//! This is the DLH, not the LSM303DLHC: the DLH's magnetometer outputs X, Y, Z (the DLHC's X, Z,
//! Y), its gains differ, its accelerometer `CTRL_REG1_A` has a power-mode field instead of the
//! DLHC's ODR nibble and its accelerometer output is 12 bit.

/// Accelerometer 7-bit I²C address (SA0_A pulled high on the iNEMO V2 board).
pub const ACCEL_ADDR: u8 = crate::board::LSM303DLH_ACCEL_ADDR;
/// Magnetometer 7-bit I²C address (fixed).
pub const MAG_ADDR: u8 = crate::board::LSM303DLH_MAG_ADDR;

// --- Accelerometer --------------------------------------------------------------------------

/// Accelerometer control register 1: power mode, output data rate, axis enables.
pub const CTRL_REG1_A: u8 = 0x20;
/// Accelerometer control register 2: high-pass filter (left at its reset value).
pub const CTRL_REG2_A: u8 = 0x21;
/// Accelerometer control register 3: interrupt pins (left at its reset value).
pub const CTRL_REG3_A: u8 = 0x22;
/// Accelerometer control register 4: block data update, endianness, full scale.
pub const CTRL_REG4_A: u8 = 0x23;
/// Accelerometer control register 5: sleep-to-wake (left at its reset value).
pub const CTRL_REG5_A: u8 = 0x24;
/// Accelerometer status register.
pub const STATUS_REG_A: u8 = 0x27;
/// First accelerometer output register (X low byte); X, Y, Z follow as little-endian pairs up
/// to `OUT_Z_H_A` (0x2D).
pub const OUT_X_L_A: u8 = 0x28;
/// Last accelerometer output register (Z high byte).
pub const OUT_Z_H_A: u8 = 0x2D;
/// Set in an accelerometer sub-address to auto-increment it over a multi-byte read.
pub const AUTO_INCREMENT: u8 = 0x80;

/// `CTRL_REG1_A` power mode PM2..0 = 001: normal mode (bits 7:5).
pub const CTRL1_PM_NORMAL: u8 = 0b001 << 5;
/// `CTRL_REG1_A` output data rate DR1..0 field position (bits 4:3).
pub const CTRL1_DR_SHIFT: u8 = 3;
/// `CTRL_REG1_A` Zen | Yen | Xen: all three axes enabled (bits 2:0).
pub const CTRL1_XYZ_EN: u8 = 0b111;
/// `CTRL_REG4_A` BDU: output registers are not updated between the reads of a sample's low and
/// high bytes (bit 7).
pub const CTRL4_BDU: u8 = 1 << 7;
/// `CTRL_REG4_A` BLE: big-endian output when set; the driver keeps it clear (bit 6).
pub const CTRL4_BLE: u8 = 1 << 6;
/// `CTRL_REG4_A` full scale FS1..0 field position (bits 5:4).
pub const CTRL4_FS_SHIFT: u8 = 4;
/// `STATUS_REG_A` ZYXDA: a new X, Y and Z sample is available (bit 3).
pub const STATUS_A_ZYXDA: u8 = 1 << 3;

// --- Magnetometer ---------------------------------------------------------------------------

/// Magnetometer configuration register A: data output rate, measurement configuration.
pub const CRA_REG_M: u8 = 0x00;
/// Magnetometer configuration register B: gain.
pub const CRB_REG_M: u8 = 0x01;
/// Magnetometer mode register.
pub const MR_REG_M: u8 = 0x02;
/// X output high byte: the start of the six output bytes, big-endian, in X, Y, Z order on the
/// DLH. The magnetometer's address pointer advances by itself (no auto-increment bit).
pub const OUT_X_H_M: u8 = 0x03;
/// X output low byte.
pub const OUT_X_L_M: u8 = 0x04;
/// Y output high byte (on the DLH; the DLHC has Z here).
pub const OUT_Y_H_M: u8 = 0x05;
/// Y output low byte.
pub const OUT_Y_L_M: u8 = 0x06;
/// Z output high byte (on the DLH; the DLHC has Y here).
pub const OUT_Z_H_M: u8 = 0x07;
/// Z output low byte.
pub const OUT_Z_L_M: u8 = 0x08;
/// Magnetometer status register.
pub const SR_REG_M: u8 = 0x09;
/// Identification register A (followed by IRB at 0x0B and IRC at 0x0C).
pub const IRA_REG_M: u8 = 0x0A;
/// Identification register B.
pub const IRB_REG_M: u8 = 0x0B;
/// Identification register C.
pub const IRC_REG_M: u8 = 0x0C;

/// `CRA_REG_M` data output rate DO2..0 field position (bits 4:2).
pub const CRA_DO_SHIFT: u8 = 2;
/// `CRA_REG_M` measurement configuration MS1..0 = 00: normal (no bias), bits 1:0.
pub const CRA_MS_NORMAL: u8 = 0b00;
/// `CRB_REG_M` gain GN2..0 field position (bits 7:5).
pub const CRB_GN_SHIFT: u8 = 5;
/// `MR_REG_M` MD1..0 = 00: continuous conversion.
pub const MR_CONTINUOUS: u8 = 0b00;
/// `MR_REG_M` MD1..0 = 01: single conversion.
pub const MR_SINGLE: u8 = 0b01;
/// `MR_REG_M` MD1..0 = 11: sleep.
pub const MR_SLEEP: u8 = 0b11;
/// `SR_REG_M` DRDY: a new X, Y and Z sample is available (bit 0).
pub const SR_M_DRDY: u8 = 1 << 0;

/// Contents of IRA, IRB and IRC: ASCII "H43".
pub const MAG_ID: [u8; 3] = *b"H43";
/// A magnetometer output that reads this value has overflowed on that axis (0xF000).
pub const MAG_OVERFLOW: i16 = -4096;
