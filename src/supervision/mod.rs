//! Fault handling decisions, host-tested; the RTIC application (`src/main.rs`, `src/app/`)
//! only carries them out on the hardware:
//! - [`reset_cause`]: why the MCU last reset, from the RCC_CSR flags (reported at boot);
//! - [`led`]: which LED pattern (init, running, fault) for what the filter reported;
//! - [`watchdog`]: whether a filter cycle was healthy enough to feed the independent watchdog;
//! - [`clock_reset`]: the clock tree back to its reset state from whatever a bootloader left
//!   (SYSCLK on the PLL at 72 MHz, after ST's DFU bootloader), every wait bounded;
//! - [`clock_check`]: whether the crystal is the 8 MHz one (measured against the HSI through
//!   the LSI at boot), else the HSI;
//! - [`fault_record`]: the HardFault/panic record kept in RAM across a reset (magic, CRC);
//! - [`i2c_bus`]: the I²C bus with every transfer under an interrupt mask, and the bus clear
//!   (nine clocks and a STOP) at boot and after repeated failures;
//! - [`i2c_master`]: the I²C master's transfer steps, the errata's byte-time windows of a
//!   reception masked completely;
//! - [`selftest`]: the bring-up self-test's grades (`SELFTEST`, and at boot);
//! - [`depth_probe`]: whether the depth input is driven or floats (read with each pull);
//! - [`flash_stall`]: the monotonic's ticks a flash erase costs (`SAVE`);
//! - [`stack`]: the measured stack high-water mark (painted stack);
//! - [`imu`]: the LSM303DLH's read schedule with bounded retries, re-configuration after
//!   failures and stuck-data detection.

pub mod clock_check;
pub mod clock_reset;
pub mod depth_probe;
pub mod fault_record;
pub mod flash_stall;
pub mod i2c_bus;
pub mod i2c_master;
pub mod imu;
pub mod led;
pub mod reset_cause;
pub mod selftest;
pub mod stack;
pub mod stuck;
pub mod watchdog;
