//! Board glue used by the RTIC application in `main.rs` (bare-metal targets only): the clock
//! tree, the ADC scan, USART transmission, the USB serial console, the LSM303DLH's bus, the
//! command queues and the settings flash, the independent watchdog and the panic handler.
//! The decisions (LED pattern, watchdog feeding, reset cause, sensor retries) are the
//! library's `inemo_ahrs::supervision`.

pub mod adc_scan;
pub mod clocks;
pub mod commands;
pub mod fault;
pub mod imu;
mod panic;
pub mod settings_flash;
pub mod stack;
pub mod uart_tx;
pub mod usb;
pub mod watchdog;

use inemo_ahrs::adc::{AdcMean, AdcScale, Averager, Rails};
use inemo_ahrs::supervision::{imu::Reading, selftest};

/// ADC frames the DMA interrupt hands to the filter task.
#[derive(Clone, Debug, Default)]
pub struct AdcShared {
    /// Frames since the filter last took them.
    pub averager: Averager,
    /// Frames lost to late interrupts since then.
    pub lost: u32,
    /// DMA transfer errors since then.
    pub errors: u32,
}

impl AdcShared {
    /// Adds what one DMA interrupt delivered.
    pub fn record(&mut self, serviced: &adc_scan::Serviced) {
        if let Some(frame) = &serviced.frame {
            self.averager.push(frame);
        }
        self.lost = self.lost.saturating_add(serviced.lost);
        if serviced.error {
            self.errors = self.errors.saturating_add(1);
        }
    }

    /// Everything accumulated, leaving this empty (a copy of a few dozen bytes: cheap under
    /// the lock; the mean is computed outside it).
    pub fn take(&mut self) -> AdcShared {
        core::mem::take(self)
    }
}

/// Keeps the self-test's live readings current (every filter cycle): the last samples of the
/// sensors, the ADC channels of this cycle's mean (converted with `adc_scale`, the settings'
/// `adc`: its `vrefint_v` is the board's `adc.vrefint`), the I²C counters.
pub fn update_board<E>(
    b: &mut selftest::Inputs,
    reading: &Reading<E>,
    adc: Option<&AdcMean>,
    adc_scale: &AdcScale,
    imu: &imu::Imu,
) {
    b.accel_g = reading.accel_g;
    if reading.mag_ut.is_some() {
        b.mag_ut = reading.mag_ut;
    }
    b.mag_id_ok = if imu.configured() { b.mag_id_ok.or(Some(true)) } else { None };
    if let Some(m) = adc {
        let scale = adc_scale.for_mean(m);
        b.vdda_v = adc_scale.vdda(m);
        b.xy_ref_v = Some(scale.counts_to_volts(m.gyro_xy_ref));
        b.z_ref_v = Some(scale.counts_to_volts(m.gyro_z_ref));
        b.depth_v = Some((scale.counts_to_volts(m.depth), m.rails.intersects(Rails::DEPTH)));
    }
    b.i2c_errors = imu.counters.i2c_errors;
    let bus = imu.bus().counters;
    b.bus_clears = bus.clears;
    b.last_clear = bus.last_clear;
}
