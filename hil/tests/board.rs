//! On-target tests of the firmware's board glue on a real iNEMO V2 (run: `scripts/hil`).
//!
//! Each test runs after a reset (embedded-test), from `init`: the clock tree as the firmware
//! sets it (with the crystal check), then the part under test through the firmware's own
//! modules (`src/app/`, included by path):
//! - the crystal measures 8 MHz and the PLL runs from it;
//! - the I²C bus clear frees the bus and the LSM303DLH identifies, reads about 1 g at rest and
//!   an Earth-like field, every transfer masked (the library's `GuardedBus`);
//! - the ADC scan's first frame has its ranks in place and VDDA reads 3.0–3.6 V;
//! - the settings pages: a record saved reads back, then the board's own record is restored;
//! - the output: a sentence goes out through USART2's DMA;
//! - the self-test grades the whole board without a failure.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("on-target tests: run them on the board with scripts/hil");
    std::process::exit(2);
}

#[cfg(target_os = "none")]
use defmt_rtt as _;

#[cfg(target_os = "none")]
#[path = "../../src/app/adc_scan.rs"]
#[allow(dead_code)]
mod adc_scan;
#[cfg(target_os = "none")]
#[path = "../../src/app/clocks.rs"]
#[allow(dead_code)]
mod clocks;
#[cfg(target_os = "none")]
#[path = "../../src/app/imu.rs"]
#[allow(dead_code)]
mod imu;
#[cfg(target_os = "none")]
#[path = "../../src/app/settings_flash.rs"]
#[allow(dead_code)]
mod settings_flash;
#[cfg(target_os = "none")]
#[path = "../../src/app/uart_tx.rs"]
#[allow(dead_code)]
mod uart_tx;

#[cfg(target_os = "none")]
#[embedded_test::tests]
mod tests {
    use super::{adc_scan, clocks, imu, settings_flash, uart_tx};
    use inemo_ahrs::{
        adc::SCAN_LEN,
        board,
        lsm303dlh::{AccelConfig, Lsm303dlh, MagConfig},
        persist::{self, Source},
        pipeline::PipelineSettings,
        supervision::{clock_check::HseCheck, i2c_bus::Clear, selftest},
    };
    use stm32f1xx_hal::{
        dma::DmaExt,
        gpio::{GpioExt, PinState},
        i2c::{BlockingI2c, DutyCycle, Mode},
        pac,
        rcc::Rcc,
        serial::{Config, Serial},
        time::{Bps, Hertz},
    };

    /// The board after the firmware's clock set-up.
    struct Board {
        dp: Parts,
        rcc: Rcc,
        hse: HseCheck,
        flash: stm32f1xx_hal::flash::Parts,
    }

    /// The device peripherals the tests use (the RCC and FLASH went to the clock set-up).
    struct Parts {
        gpioa: pac::GPIOA,
        gpiob: pac::GPIOB,
        gpioc: pac::GPIOC,
        i2c2: pac::I2C2,
        adc1: pac::ADC1,
        tim3: pac::TIM3,
        dma1: pac::DMA1,
        usart2: pac::USART2,
    }

    fn norm(v: [f32; 3]) -> f32 {
        ekf_sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    }

    fn ekf_sqrt(x: f32) -> f32 {
        // Newton's iteration: enough for a plausibility range.
        let mut r = if x > 1.0 { x } else { 1.0 };
        for _ in 0..20 {
            r = 0.5 * (r + x / r);
        }
        r
    }

    #[init]
    fn init() -> Board {
        let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take())
        else {
            defmt::panic!("peripherals taken twice");
        };
        // BlockingI2c's timeouts count DWT cycles.
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
        let (rcc, _source, flash, hse) = clocks::freeze(dp.RCC, dp.FLASH);
        let parts = Parts {
            gpioa: dp.GPIOA,
            gpiob: dp.GPIOB,
            gpioc: dp.GPIOC,
            i2c2: dp.I2C2,
            adc1: dp.ADC1,
            tim3: dp.TIM3,
            dma1: dp.DMA1,
            usart2: dp.USART2,
        };
        Board { dp: parts, rcc, hse, flash }
    }

    /// I²C2 at the firmware's default clock (`supervision::i2c_bus::bus_clock` of the default
    /// `i2c.clock`, `board::I2C_FREQUENCY_HZ`: 300 kHz or the next below that the divider makes
    /// exactly).
    fn i2c_hz(pclk1: u32) -> u32 {
        let ccr = pclk1.div_ceil(3 * board::I2C_FREQUENCY_HZ).max(1);
        pclk1 / (3 * ccr)
    }

    /// What the sensors read, through the firmware's glue.
    struct Measured {
        accel_g: [f32; 3],
        mag_ut: [f32; 3],
        clear: Option<Clear>,
        i2c_errors: u32,
        ranks: inemo_ahrs::adc::RankCheck,
        frames: u32,
        calibrated: bool,
        depth_probe: inemo_ahrs::supervision::depth_probe::DepthProbe,
    }

    /// The LSM303DLH on the guarded bus (cleared at its creation) and the ADC scan, as the
    /// firmware's `init` sets them up.
    fn measure(b: Board) -> Measured {
        static mut BUF: [[u16; SCAN_LEN]; 2] = [[0; SCAN_LEN]; 2];
        let Board { dp, mut rcc, .. } = b;
        let sysclk = rcc.clocks.sysclk().raw();
        let mut gpioa = dp.gpioa.split(&mut rcc);
        let mut gpiob = dp.gpiob.split(&mut rcc);
        let mut gpioc = dp.gpioc.split(&mut rcc);
        // Gyros out of power-down, self-test off (as `init`).
        let _pd = gpiob.pb5.into_push_pull_output_with_state(&mut gpiob.crl, PinState::Low);
        let _pdz = gpiob.pb15.into_push_pull_output_with_state(&mut gpiob.crh, PinState::Low);
        let _st = gpiob.pb1.into_push_pull_output_with_state(&mut gpiob.crl, PinState::Low);
        let _stz = gpiob.pb14.into_push_pull_output_with_state(&mut gpiob.crh, PinState::Low);

        let hz = i2c_hz(rcc.clocks.pclk1().raw());
        let i2c = BlockingI2c::new(
            dp.i2c2,
            (gpiob.pb10, gpiob.pb11),
            Mode::fast(Hertz::from_raw(hz), DutyCycle::Ratio2to1),
            &mut rcc,
            imu::START_TIMEOUT_US,
            imu::START_RETRIES,
            imu::ADDR_TIMEOUT_US,
            imu::DATA_TIMEOUT_US,
        );
        let mut dev = Lsm303dlh::new(imu::Bus::new(imu::HalBus::new(i2c, sysclk), imu::Masked));
        let clear = dev.bus().counters.last_clear;
        defmt::assert!(
            dev.check_mag_id().is_ok(),
            "the magnetometer does not identify as an LSM303DLH"
        );
        defmt::assert!(dev.init_accel(AccelConfig::new()).is_ok(), "accelerometer configuration");
        defmt::assert!(dev.init_mag(MagConfig::new()).is_ok(), "magnetometer configuration");
        // 100 Hz accelerometer, 15 Hz magnetometer; and the gyros' turn-on time: 500 ms.
        cortex_m::asm::delay(sysclk / 2);
        let (Ok(accel_g), Ok(mag_ut)) = (dev.read_accel_g(), dev.read_mag_ut()) else {
            defmt::panic!("LSM303DLH read failed");
        };
        let i2c_errors = dev.bus().counters.errors;

        let pins = adc_scan::AdcPins(
            gpioc.pc0.into_analog(&mut gpioc.crl),
            gpioc.pc1.into_analog(&mut gpioc.crl),
            gpioc.pc2.into_analog(&mut gpioc.crl),
            gpioc.pc4.into_analog(&mut gpioc.crl),
            gpioc.pc5.into_analog(&mut gpioc.crl),
            gpioa.pa1.into_analog(&mut gpioa.crl),
        );
        let dma1 = dp.dma1.split(&mut rcc);
        // SAFETY: the only reference to the buffer, taken once per test run (after a reset).
        let buf = unsafe { &mut *core::ptr::addr_of_mut!(BUF) };
        let mut scan = adc_scan::start(dp.adc1, dp.tim3, pins, dma1.1, buf, &mut rcc);
        // Frames at 1 kHz: the interrupt is not bound here, so poll the flags every 0.5 ms.
        let mut frames = 0;
        for _ in 0..200 {
            cortex_m::asm::delay(sysclk / 2000);
            let s = scan.service();
            defmt::assert!(!s.error, "ADC DMA transfer error");
            frames += u32::from(s.frame.is_some());
        }
        Measured {
            accel_g,
            mag_ut,
            clear,
            i2c_errors,
            ranks: scan.ranks(),
            frames,
            calibrated: scan.calibrated(),
            depth_probe: scan.depth_probe(),
        }
    }

    #[test]
    fn the_crystal_measures_8_mhz(b: Board) {
        let hz = b.hse.measured_hz().unwrap_or(0);
        defmt::info!("HSE {=u32} Hz ({=str})", hz, b.hse.name());
        defmt::assert!(matches!(b.hse, HseCheck::Ok(_)), "crystal check failed");
        defmt::assert_eq!(b.rcc.clocks.sysclk().raw(), board::SYSCLK_HZ);
    }

    #[test]
    fn the_lsm303dlh_answers_on_a_cleared_bus_and_reads_gravity(b: Board) {
        let r = measure(b);
        let (a, m, clear) = (r.accel_g, r.mag_ut, r.clear);
        defmt::assert_eq!(r.i2c_errors, 0, "I2C transfers failed");
        defmt::info!("accel {=[?]} g, mag {=[?]} uT", a, m);
        defmt::assert!(
            matches!(clear, Some(Clear::Freed { .. })),
            "the bus clear did not free the bus"
        );
        let g = norm(a);
        defmt::assert!((0.8..=1.2).contains(&g), "|a| = {=f32} g at rest", g);
        let f = norm(m);
        defmt::assert!((15.0..=100.0).contains(&f), "|m| = {=f32} uT", f);
    }

    #[test]
    fn the_adc_ranks_are_in_place_and_vdda_is_3v3(b: Board) {
        let r = measure(b);
        defmt::assert!(r.calibrated, "ADC calibration did not complete");
        defmt::assert!(r.frames >= 20, "{=u32} frames in 100 ms", r.frames);
        let ranks = r.ranks;
        defmt::info!(
            "VDDA {=?} V, refs {=f32} {=f32} V, depth {=f32} V",
            ranks.vdda_v,
            ranks.xy_ref_v,
            ranks.z_ref_v,
            ranks.depth_v
        );
        defmt::assert!(ranks.aligned(), "the first frame's ranks are not in place");
        let vdda = ranks.vdda_v.unwrap_or(0.0);
        defmt::assert!((3.0..=3.6).contains(&vdda), "VDDA {=f32} V", vdda);
    }

    #[test]
    fn a_settings_record_saved_reads_back(b: Board) {
        let mut flash = settings_flash::take(b.flash);
        let before = persist::load(&flash);
        let mut s = PipelineSettings::default();
        s.filter_rate_hz = 40;
        defmt::assert!(persist::save(&mut flash, &s).is_ok(), "save failed");
        let back = persist::load(&flash);
        defmt::assert!(matches!(back.source, Source::Flash { .. }), "no valid record after a save");
        defmt::assert_eq!(back.settings.filter_rate_hz, 40);
        // The board's own settings back (a new record with them; the defaults if it had none).
        defmt::assert!(persist::save(&mut flash, &before.settings).is_ok(), "restore failed");
    }

    #[test]
    fn a_sentence_goes_out_on_usart2(b: Board) {
        static mut TX: [u8; uart_tx::TX_BUF_LEN] = [0; uart_tx::TX_BUF_LEN];
        let Board { dp, mut rcc, .. } = b;
        let mut gpioa = dp.gpioa.split(&mut rcc);
        let dma1 = dp.dma1.split(&mut rcc);
        let dr = dp.usart2.dr().as_ptr() as u32;
        let serial = Serial::new(
            dp.usart2,
            (
                gpioa.pa2.into_alternate_push_pull(&mut gpioa.crl),
                gpioa.pa3.into_pull_up_input(&mut gpioa.crl),
            ),
            Config::default().baudrate(Bps(board::USART_BAUD)),
            &mut rcc,
        );
        let (tx, _rx) = serial.split();
        // SAFETY: the only reference to the buffer, taken once per test run.
        let buf = unsafe { &mut *core::ptr::addr_of_mut!(TX) };
        let mut tx = uart_tx::DmaTx::new(tx.with_dma(dma1.7), buf, dr);
        defmt::assert!(tx.send([b"$PINAR,OK,HIL*0D\r\n".as_slice()]));
        // 19 bytes at 115,200 baud: 1.7 ms; allow 10 ms.
        let mut done = false;
        for _ in 0..100 {
            cortex_m::asm::delay(rcc.clocks.sysclk().raw() / 10_000);
            if !tx.busy() {
                done = true;
                break;
            }
        }
        defmt::assert!(done, "the DMA transfer did not complete");
        defmt::assert_eq!(tx.errors, 0);
    }

    #[test]
    fn the_self_test_finds_no_failure(b: Board) {
        let hse = b.hse;
        let r = measure(b);
        let (a, m, clear, ranks) = (r.accel_g, r.mag_ut, r.clear, r.ranks);
        let inputs = selftest::Inputs {
            hse: Some(hse),
            vdda_v: ranks.vdda_v,
            ranks_aligned: ranks.aligned(),
            accel_g: Some(a),
            mag_id_ok: Some(true),
            mag_ut: Some(m),
            xy_ref_v: Some(ranks.xy_ref_v),
            z_ref_v: Some(ranks.z_ref_v),
            depth_v: Some((ranks.depth_v, false)),
            depth_connected: Some(r.depth_probe.connected()),
            i2c_errors: r.i2c_errors,
            bus_clears: 1,
            last_clear: clear,
            settings_from_flash: true,
            ..selftest::Inputs::default()
        };
        defmt::info!(
            "depth probe: pulled down {=u16}, up {=u16} counts: connected {=bool}",
            r.depth_probe.pulled_down,
            r.depth_probe.pulled_up,
            r.depth_probe.connected()
        );
        let report = selftest::evaluate(&inputs);
        defmt::info!("self-test {=str} {=u32:05x}", report.overall().name(), report.code());
        defmt::assert!(
            report.overall() != selftest::Grade::Fail,
            "self-test grades {=u32:05x}",
            report.code()
        );
    }
}
