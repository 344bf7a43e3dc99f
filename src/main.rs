//! The iNEMO V2 firmware: an RTIC 2 application for the STM32F103RE that moves data between
//! the board's peripherals and the library's [`Pipeline`](inemo_ahrs::pipeline::Pipeline).
//!
//! Tasks (priority: higher preempts lower):
//!
//! | task | kind | prio | does |
//! |---|---|---|---|
//! | `adc_frame` | hardware, DMA1_CHANNEL1 | 3 | copies the finished ADC frame (1 kHz) into the shared `Averager` |
//! | `usart2_rx` | hardware, USART2 (RXNE) | 4 | received bytes → `LineAssembler`; complete lines queued for `command` |
//! | `filter` | async, every 1/filter_rate_hz (SysTick monotonic) | 2 | applies pending command actions, reads the LSM303DLH, takes the ADC mean, runs `Pipeline::step` and `Device::on_cycle`, starts the USART DMA (sentences + queued replies), feeds the watchdog |
//! | `usb_console`, `usb_console_hp` | hardware, USB_LP_CAN_RX0, USB_HP_CAN_TX | 1 | polls the USB device (enumeration, CDC-ACM requests); received bytes → its own `LineAssembler`, complete lines queued for `command`; the waiting output → the serial port |
//! | `command` | async, spawned per received line | 1 | `Device::handle` (may write the settings flash), queues the reply for the port the line came from, and the action |
//! | `blink` | async, 50 ms slots | 1 | LED pattern from the status the filter reported |
//!
//! Messages: `adc_frame` → `filter` through the shared [`AdcShared`](app::AdcShared) (frames
//! averaged in place, lost frames and DMA errors counted); `filter` → `blink` through the
//! shared [`Health`](app::led::Health) (union of the cycles' status words and a cycle count);
//! `usart2_rx` and `usb_console` → `command` through an `rtic-sync` channel of received lines,
//! each tagged with its port; `command` → `filter` through the shared
//! [`CommandState`](app::commands::CommandState) (the `Device`, the replies waiting for each
//! port and the pending actions); `filter` → `usb_console` through the shared
//! [`UsbQueue`](app::usb::UsbQueue) (the sentences and replies for the USB port, filled by the
//! fan-out of `inemo_ahrs::console`, drained into the serial port by `usb_console`, which
//! `filter` pends when there is something to send).
//!
//! `usb_console` runs at priority 1, below the filter, which preempts it at once. Its locks on
//! the shared queue (ceiling 2) last a copy of at most 64 bytes; the serial port's writes and
//! the device's requests run outside them. (`stm32-usbd` masks all interrupts around each of
//! its register and packet-memory accesses, a 64-byte packet copy at most: `docs/firmware.md`.) The USB device answers
//! the host with NAKs until its task runs, so a few milliseconds of waiting behind the filter
//! or the command task cost the host retries, not errors.
//! TIM3 triggers the ADC scans in hardware; DMA1 channel 7 sends the sentences without the CPU.
//! The independent watchdog is fed only at the end of a healthy filter cycle (see `filter`).
//!
//! Nothing on the running path unwraps or panics: sensor and bus errors become status bits
//! (`$PINAH` bits 16–19) and LED patterns. `panic!` appears only in `init`, for programming
//! errors (a task spawned twice, an impossible timer rate), with plain messages (no `core::fmt`).
//!
//! On the host this builds to a stub that says how to build the firmware.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(all(target_os = "none", not(feature = "board")))]
compile_error!("the firmware needs the `board` feature (on by default)");

#[cfg(all(target_os = "none", feature = "board"))]
mod app;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "inemo-ahrs is firmware for the STM32F103RE (iNEMO V2 board): build it for \
         thumbv7m-none-eabi with `scripts/cargo-thumb build --release`"
    );
    std::process::exit(1);
}

#[cfg(all(target_os = "none", feature = "board"))]
use defmt_rtt as _;

#[cfg(all(target_os = "none", feature = "board"))]
#[rtic::app(device = stm32f1xx_hal::pac, dispatchers = [UART4, UART5])]
mod firmware {
    use core::num::NonZeroU32;

    use cortex_m::peripheral::DWT;
    use ekf_core::ImuSample;
    use inemo_ahrs::supervision::{
        clock_check::HseCheck,
        flash_stall,
        i2c_bus::bus_clock,
        led::{self, Health},
        selftest,
        watchdog::{FeedPolicy, Verdict},
    };
    use inemo_ahrs::{
        adc::SCAN_LEN,
        board,
        nmea::{self, Sentence, Status},
        pipeline::{Inputs, Pipeline},
    };
    // The types of the command layer's local resources are named in both variants (RTIC's
    // generated code names them even when their `#[cfg]` is off).
    use inemo_ahrs::console::{self, Port, PortLines};
    use inemo_ahrs::{
        command::Device,
        persist::{self, Source},
    };
    use rtic_monotonics::{fugit::MonotonicTimerInstant, systick::prelude::*};
    use stm32f1xx_hal::{
        dma::DmaExt,
        gpio::{GpioExt, Output, PinState, PushPull, PB9},
        i2c::{BlockingI2c, DutyCycle, Mode},
        pac::Interrupt,
        serial::{Config, Serial},
        time::{Bps, Hertz},
        usb::UsbBusType,
    };
    use stm32f1xx_hal::{pac::USART2, serial::Rx};

    use crate::app::commands::{CommandState, Received, RxStats, LINE_SLOTS, REPLY_SLOTS};
    use crate::app::settings_flash::SettingsFlash;
    use crate::app::{
        adc_scan::{self, AdcPins, AdcScan},
        clocks,
        imu::{self, Imu},
        uart_tx::{DmaTx, TX_BUF_LEN},
        usb::{UsbConsole, UsbQueue, CHUNK},
        watchdog::Watchdog,
        AdcShared,
    };
    use inemo_ahrs::console::{Replies, Route};
    use rtic_sync::channel::{Receiver, Sender};
    use rtic_sync::make_channel;
    use usb_device::bus::UsbBusAllocator;

    /// SysTick rate of the monotonic, Hz (the literal in `systick_monotonic!` must match).
    const MONO_HZ: u32 = 10_000;
    systick_monotonic!(Mono, 10_000);
    type Instant = MonotonicTimerInstant<u32, 10_000>;

    /// Time the gyros get after leaving power-down before the filter starts (LPR430AL and
    /// LY330ALH turn-on time is a few hundred ms); ADC frames of that time are discarded.
    const GYRO_SETTLE_MS: u32 = 500;

    /// Reads of the USART per RX interrupt at most (one byte is normally waiting).
    const RX_READS_PER_IRQ: u8 = 4;

    #[shared]
    struct Shared {
        adc: AdcShared,
        health: Health,
        rx: RxStats,
        cmd: CommandState,
        usb_out: UsbQueue,
        // Only the two USB interrupts' tasks, both at priority 1, touch these.
        #[lock_free]
        usb: Option<UsbConsole>,
        #[lock_free]
        usb_lines: Sender<'static, Received, LINE_SLOTS>,
    }

    #[local]
    struct Local {
        adc_scan: AdcScan,
        imu: Imu,
        pipeline: Pipeline,
        tx: DmaTx,
        led: PB9<Output<PushPull>>,
        led_state: led::Led,
        sysclk_hz: u32,
        board: selftest::Inputs,
        serial_rx: Rx<USART2>,
        lines: Sender<'static, Received, LINE_SLOTS>,
        flash: SettingsFlash,
        watchdog: Watchdog,
    }

    #[init(local = [
        adc_buf: [[u16; SCAN_LEN]; 2] = [[0; SCAN_LEN]; 2],
        tx_buf: [u8; TX_BUF_LEN] = [0; TX_BUF_LEN],
        usb_bus: Option<UsbBusAllocator<UsbBusType>> = None,
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let mut core = cx.core;
        let dp = cx.device;
        // The previous run's fault record (RAM kept across the reset), then the stack painted
        // for the high-water mark.
        let fault = crate::app::fault::take();
        crate::app::stack::paint();

        // The cycle counter: filter timing, and BlockingI2c's timeouts depend on it.
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();

        let reset = clocks::take_reset_cause(&dp.RCC);
        // From here a hang resets the MCU (first feed at the end of the first healthy cycle).
        let watchdog = crate::app::watchdog::start(dp.IWDG, &dp.DBGMCU);
        let (mut rcc, source, flash, hse_check) = clocks::freeze(dp.RCC, dp.FLASH);

        // The settings: the newest valid flash record, else the defaults.
        let (flash, loaded, device, settings) = {
            let flash = crate::app::settings_flash::take(flash);
            let loaded = persist::load(&flash);
            let device = Device::new(&loaded, reset.tag());
            let settings = *device.settings();
            (flash, loaded, device, settings)
        };
        // Without the command layer: `PipelineSettings::default()` (50 Hz filter, 10 Hz
        // output). Set `filter_rate_hz` here for another rate (up to 200 Hz).
        let clocks = rcc.clocks;
        let sysclk_hz = clocks.sysclk().raw();
        // Asserts that SYSCLK is a multiple of the tick rate: 72 and 64 MHz both are, so a
        // failure is a programming error.
        Mono::start(core.SYST, sysclk_hz);

        let mut gpioa = dp.GPIOA.split(&mut rcc);
        let mut gpiob = dp.GPIOB.split(&mut rcc);
        let mut gpioc = dp.GPIOC.split(&mut rcc);

        // Gyros out of power-down, self-test off. The pins keep their mode when dropped.
        let _lpr_pd = gpiob.pb5.into_push_pull_output_with_state(&mut gpiob.crl, PinState::Low);
        let _ly_pd = gpiob.pb15.into_push_pull_output_with_state(&mut gpiob.crh, PinState::Low);
        let _lpr_st = gpiob.pb1.into_push_pull_output_with_state(&mut gpiob.crl, PinState::Low);
        let _ly_st = gpiob.pb14.into_push_pull_output_with_state(&mut gpiob.crh, PinState::Low);
        let led = gpiob.pb9.into_push_pull_output_with_state(&mut gpiob.crh, PinState::High);
        // The USB D+ pull-up off (PA10 low) from here: a host sees the device only once it is
        // ready, at the end of init, and sees a new device after every reset.
        let usb_pull_up =
            gpioa.pa10.into_push_pull_output_with_state(&mut gpioa.crh, PinState::Low);

        let dma1 = dp.DMA1.split(&mut rcc);

        // USART2: TX PA2 by DMA1 channel 7; RX PA3 (commands) by the RXNE interrupt.
        let usart2_dr = dp.USART2.dr().as_ptr() as u32;
        let serial = Serial::new(
            dp.USART2,
            // RX with the internal pull-up: an open RX line (no cable) idles high instead of
            // floating into noise that the receiver would take for bytes (framing errors).
            (
                gpioa.pa2.into_alternate_push_pull(&mut gpioa.crl),
                gpioa.pa3.into_pull_up_input(&mut gpioa.crl),
            ),
            Config::default().baudrate(Bps(board::USART_BAUD)),
            &mut rcc,
        );
        let (tx, serial_rx) = {
            let (tx, mut serial_rx) = serial.split();
            serial_rx.listen();
            (tx, serial_rx)
        };
        let mut tx = DmaTx::new(tx.with_dma(dma1.7), cx.local.tx_buf, usart2_dr);

        // I²C2 (PB10 SCL, PB11 SDA), fast mode, every transfer bounded in time.
        // The clock of the setting `i2c.clock` (read here only: a change takes `SAVE` and a
        // reset), at or below it and exact (`bus_clock`).
        let i2c_clock = bus_clock(clocks.pclk1().raw(), settings.i2c_clock_khz);
        let i2c_hz = i2c_clock.hz;
        let i2c_mode = if i2c_clock.fast {
            Mode::fast(Hertz::from_raw(i2c_hz), DutyCycle::Ratio2to1)
        } else {
            Mode::standard(Hertz::from_raw(i2c_hz))
        };
        let i2c = BlockingI2c::new(
            dp.I2C2,
            (gpiob.pb10, gpiob.pb11),
            i2c_mode,
            &mut rcc,
            imu::START_TIMEOUT_US,
            imu::START_RETRIES,
            imu::ADDR_TIMEOUT_US,
            imu::DATA_TIMEOUT_US,
        );
        // Every transfer with the ADC's interrupt and below masked, the reads' errata windows
        // with every interrupt (ES0340 §2.13.2; `imu::Masked`, `imu::Primask`); the bus cleared now (a slave
        // may still be in a transfer the reset cut short) and after repeated failures.
        let bus = imu::Bus::new(imu::HalBus::new(i2c, sysclk_hz), imu::Masked);
        let bus_clear = bus.counters.last_clear;
        let mut imu = Imu::new(bus, settings.filter_rate_hz);
        // A failure here is not fatal: the filter retries once per second meanwhile.
        let imu_result = imu.configure();
        let mag_id_ok = match &imu_result {
            Ok(None) => Some(true),
            Ok(Some(_)) => Some(false),
            Err(_) => None,
        };

        // ADC1 scan of the six channels, TIM3-triggered, by DMA1 channel 1.
        let pins = AdcPins(
            gpioc.pc0.into_analog(&mut gpioc.crl),
            gpioc.pc1.into_analog(&mut gpioc.crl),
            gpioc.pc2.into_analog(&mut gpioc.crl),
            gpioc.pc4.into_analog(&mut gpioc.crl),
            gpioc.pc5.into_analog(&mut gpioc.crl),
            gpioa.pa1.into_analog(&mut gpioa.crl),
        );
        let adc_scan = adc_scan::start(dp.ADC1, dp.TIM3, pins, dma1.1, cx.local.adc_buf, &mut rcc);

        defmt::println!(
            "inemo-ahrs {=str}: {} SYSCLK {=u32} Hz, reset {=str}, I2C {=u32} Hz, filter {=u16} Hz, ADC {=u32} Hz",
            env!("CARGO_PKG_VERSION"),
            source,
            sysclk_hz,
            reset.tag(),
            i2c_hz,
            settings.filter_rate_hz,
            adc_scan::FRAME_HZ
        );
        if let Some(found) = bus_clear {
            if !matches!(found, inemo_ahrs::supervision::i2c_bus::Clear::Freed { .. }) {
                defmt::error!("I2C bus clear at boot: {=str}", found.name());
            }
        }
        match imu_result {
            Ok(wrong_id) => {
                if let Some(id) = wrong_id {
                    defmt::warn!("LSM303DLH: magnetometer identifies as {=[u8]:a}", &id[..]);
                }
                defmt::println!(
                    "LSM303DLH configured: accel {=u16} Hz",
                    imu.accel_config().rate.hz()
                )
            }
            Err(e) => defmt::error!("LSM303DLH configuration failed: {=str}", imu::describe(&e)),
        }
        if !adc_scan.calibrated() {
            defmt::error!("ADC calibration did not complete");
        }
        let ranks = adc_scan.ranks();
        // What the self-test grades (`SELFTEST`, and the report after the first cycle): the
        // boot's findings; the filter task keeps the live readings current.
        let bus = imu.bus().counters;
        let board = selftest::Inputs {
            hse: Some(hse_check),
            // The rank check's VDDA is from the nominal VREFINT: rescaled to the board's.
            vdda_v: ranks.vdda_v.map(|v| v * settings.adc.vrefint_v / board::VREFINT_V),
            ranks_aligned: ranks.aligned(),
            mag_id_ok,
            xy_ref_v: Some(ranks.xy_ref_v),
            z_ref_v: Some(ranks.z_ref_v),
            depth_v: Some((ranks.depth_v, false)),
            depth_connected: Some(adc_scan.depth_probe().connected()),
            bus_clears: bus.clears,
            last_clear: bus.last_clear,
            settings_from_flash: matches!(loaded.source, Source::Flash { .. }),
            fault: fault.map(|(kind, _)| kind),
            ..selftest::Inputs::default()
        };
        if let Some((kind, regs)) = fault {
            defmt::error!(
                "the last run ended in {=str} ({=str}): PC {=u32:#010x}, LR {=u32:#010x}, CFSR {=u32:#010x}, HFSR {=u32:#010x}, line {=u32}",
                kind.name(),
                inemo_ahrs::supervision::fault_record::cause(&regs),
                regs.pc,
                regs.lr,
                regs.cfsr,
                regs.hfsr,
                regs.line
            );
        }
        if !ranks.aligned() {
            defmt::error!(
                "ADC ranks do not read like their channels: VREFINT gives VDDA {=?}, gyro references {=f32} V and {=f32} V",
                ranks.vdda_v,
                ranks.xy_ref_v,
                ranks.z_ref_v
            );
        }
        match hse_check {
            HseCheck::Ok(hz) => defmt::println!("HSE measured at {=u32} Hz", hz),
            HseCheck::Unmeasured => defmt::warn!("HSE running, its frequency not measured"),
            HseCheck::WrongFrequency(hz) => {
                defmt::error!("HSE runs at {=u32} Hz, not 8 MHz: running from HSI at 64 MHz", hz)
            }
            HseCheck::NotStarted => defmt::error!("HSE did not start: running from HSI at 64 MHz"),
        }
        match loaded.source {
            Source::Flash { page, seq } => defmt::println!(
                "settings: flash page {=str}, sequence {=u32}, {=u16} entries skipped, {=u16} settings missing",
                page.name(),
                seq,
                loaded.skipped,
                loaded.missing
            ),
            Source::Defaults => defmt::println!("settings: no valid flash record, defaults"),
        }
        // The USB serial console: its 48 MHz clock is PLL/1.5, valid only with the PLL at
        // 72 MHz (the crystal); running from HSI at 64 MHz there is no USB (D+ stays off).
        let mut usb = if clocks.usbclk_valid() {
            Some(UsbConsole::new(dp.USB, gpioa.pa11, gpioa.pa12, usb_pull_up, cx.local.usb_bus))
        } else {
            defmt::warn!("no USB console: the USB clock needs the crystal (SYSCLK 72 MHz)");
            None
        };

        // The boot sentence says where the settings came from.
        let settings_field = Some(match loaded.source {
            Source::Flash { page, .. } => page.name(),
            Source::Defaults => "DEFAULTS",
        });
        let version = env!("CARGO_PKG_VERSION");
        // The boot sentence, and the fault record's report when there is one.
        let fault_report = fault.map(|(kind, regs)| inemo_ahrs::command::fault_reply(kind, &regs));
        match nmea::pinab(source.tag(), reset, imu.configured(), version, settings_field) {
            Ok(s) => {
                match &fault_report {
                    Some(f) => tx.send([s.as_bytes(), f.as_bytes()]),
                    None => tx.send([s.as_bytes()]),
                };
            }
            Err(_) => defmt::error!("boot sentence does not fit"),
        }

        // Each task is spawned exactly once, here; an error is a programming error. (`panic!`
        // with a plain message rather than `expect`, which formats the error with `core::fmt`.)
        if filter::spawn().is_err() {
            panic!("filter task spawned twice");
        }
        if blink::spawn().is_err() {
            panic!("blink task spawned twice");
        }
        // Received lines: the RX interrupt sends, the command task waits on them.
        let (lines, line_rx) = make_channel!(Received, LINE_SLOTS);
        if command::spawn(line_rx).is_err() {
            panic!("command task spawned twice");
        }
        let usb_lines = lines.clone();
        // Last: the host may enumerate the device from now on (its interrupt is unmasked when
        // init returns). D+ was off for all of init above (the I²C and ADC set-up: far more than
        // the few microseconds a hub needs to see a disconnect).
        if let Some(u) = usb.as_mut() {
            u.connect();
        }

        (
            Shared {
                adc: AdcShared::default(),
                health: Health::default(),
                rx: RxStats::default(),
                cmd: CommandState::new(device),
                usb_out: UsbQueue::new(),
                usb,
                usb_lines,
            },
            Local {
                adc_scan,
                imu,
                pipeline: Pipeline::new(settings),
                tx,
                led,
                led_state: led::Led::new(matches!(source, clocks::ClockSource::Hsi)),
                sysclk_hz,
                board,
                serial_rx,
                lines,
                flash,
                watchdog,
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// A scan frame is complete (DMA half/full transfer): hand it to the filter.
    #[task(binds = DMA1_CHANNEL1, priority = 3, local = [adc_scan], shared = [adc])]
    fn adc_frame(mut cx: adc_frame::Context) {
        let serviced = cx.local.adc_scan.service();
        cx.shared.adc.lock(|adc| adc.record(&serviced));
    }

    /// Received bytes: into the line assembler; a complete line goes to `command` through the
    /// channel (dropped and counted when it is full).
    #[task(binds = USART2, priority = 4, local = [serial_rx, lines, assembler: PortLines = PortLines::new(Port::Usart)], shared = [rx])]
    fn usart2_rx(mut cx: usart2_rx::Context) {
        for _ in 0..RX_READS_PER_IRQ {
            if !cx.local.serial_rx.is_rx_not_empty() && !rx_error() {
                break;
            }
            match cx.local.serial_rx.read() {
                Ok(byte) => {
                    if let Some(line) = cx.local.assembler.push(byte) {
                        if cx.local.lines.try_send(line).is_err() {
                            cx.shared.rx.lock(|rx| rx.dropped = rx.dropped.saturating_add(1));
                        }
                    }
                }
                Err(_) => cx.shared.rx.lock(|rx| rx.errors = rx.errors.saturating_add(1)),
            }
        }
    }

    /// A receive error flag (overrun, noise, framing, parity) of USART2 is set.
    fn rx_error() -> bool {
        // SAFETY: a read of the status register; the flags are cleared by the read sequence
        // in `Rx::read`, which only `usart2_rx` calls.
        let sr = unsafe { (*USART2::ptr()).sr().read() };
        sr.ore().bit_is_set()
            || sr.ne().bit_is_set()
            || sr.fe().bit_is_set()
            || sr.pe().bit_is_set()
    }

    /// Executes the received command lines as they come: the reply and the action go to the
    /// filter task. `SAVE` writes the flash here (the CPU stalls for the erase, a few filter
    /// cycles late).
    #[task(priority = 1, local = [flash], shared = [cmd])]
    async fn command(mut cx: command::Context, mut lines: Receiver<'static, Received, LINE_SLOTS>) {
        while let Ok(line) = lines.recv().await {
            let flash = &mut *cx.local.flash;
            let (cycles, ticks) = (DWT::cycle_count(), Mono::now().as_ticks());
            cx.shared.cmd.lock(|c| {
                let response = c.device.handle(&line.event, flash);
                // The reply goes back to the port the command came from.
                c.record(response.reply, line.reply_route(), response.action);
            });
            // A flash erase (`SAVE`) stalls SysTick's interrupt: the monotonic's ticks lost,
            // at most 399 (`supervision::flash_stall`).
            let lost = flash_stall::ticks_lost(
                DWT::cycle_count().wrapping_sub(cycles),
                cortex_m::peripheral::SYST::get_reload() + 1,
                Mono::now().as_ticks().wrapping_sub(ticks),
            );
            if lost > 0 {
                defmt::warn!("the monotonic lost {=u32} ticks to a flash stall", lost);
            }
        }
    }

    /// The USB device's low-priority interrupt (every transfer of the control and bulk
    /// endpoints, and the filter's pend when it queued output): [`service_usb`].
    #[task(binds = USB_LP_CAN_RX0, priority = 1, shared = [usb, usb_lines, rx, usb_out])]
    fn usb_console(cx: usb_console::Context) {
        let s = cx.shared;
        service_usb(s.usb, s.usb_lines, s.rx, s.usb_out);
    }

    /// The USB device's high-priority interrupt (RM0008: raised by the isochronous and
    /// double-buffered bulk endpoints' transfers, which this device does not configure; bound,
    /// as ST's firmware and the HAL's interrupt example bind it, so that such an interrupt is
    /// serviced rather than left pending unhandled): the same [`service_usb`], at the same
    /// priority.
    #[task(binds = USB_HP_CAN_TX, priority = 1, shared = [usb, usb_lines, rx, usb_out])]
    fn usb_console_hp(cx: usb_console_hp::Context) {
        let s = cx.shared;
        service_usb(s.usb, s.usb_lines, s.rx, s.usb_out);
    }

    /// Services the USB device, sends received lines to `command` (dropped and counted when
    /// the channel is full), tells the queue what the host did (configured, DTR; a change of
    /// DTR also takes back the packet armed for the old reader), and moves the waiting output
    /// to the IN endpoint, [`CHUNK`] bytes a lock, until it takes no more.
    fn service_usb(
        usb: &mut Option<UsbConsole>,
        lines: &mut Sender<'static, Received, LINE_SLOTS>,
        mut rx: impl rtic::Mutex<T = RxStats>,
        mut usb_out: impl rtic::Mutex<T = UsbQueue>,
    ) {
        let Some(usb) = usb.as_mut() else {
            return;
        };
        let mut dropped = 0u32;
        let (configured, dtr) = usb.poll(|line| {
            if lines.try_send(line).is_err() {
                dropped = dropped.saturating_add(1);
            }
        });
        if dropped > 0 {
            rx.lock(|rx| rx.dropped = rx.dropped.saturating_add(dropped));
        }
        let mut chunk = [0u8; CHUNK];
        let (stale, mut n) = usb_out.lock(|q| (q.set_host(configured, dtr), q.peek(&mut chunk)));
        if stale {
            usb.discard_armed();
        }
        // Bounded: the queue holds USB_OUT_LEN bytes.
        for _ in 0..crate::app::usb::USB_OUT_LEN / CHUNK + 1 {
            if n == 0 {
                break;
            }
            let taken = usb.write(chunk.get(..n).unwrap_or(&[]));
            if taken == 0 {
                break;
            }
            n = usb_out.lock(|q| {
                q.consume(taken);
                q.peek(&mut chunk)
            });
        }
    }

    /// The cycle's output to both ports (`inemo_ahrs::console::fan_out`): to USART2 the
    /// `sentences`, then its queued replies while the batch stays within `budget` bytes (what
    /// the USART sends in one filter period; one reply always goes when the batch is otherwise
    /// empty), its sentences dropped (counted) while the previous transfer runs; to the USB
    /// queue its replies and the sentences, dropped (counted) while no host has configured the
    /// device or when they do not fit. Returns whether the USB task has something to send.
    fn transmit<'a, I>(
        tx: &mut DmaTx,
        sentences: I,
        replies: &mut Replies<REPLY_SLOTS>,
        budget: usize,
        usb: &mut UsbQueue,
    ) -> bool
    where
        I: IntoIterator<Item = &'a Sentence>,
        I::IntoIter: Clone,
    {
        let mut batch = tx.begin();
        let busy = console::fan_out(batch.as_mut(), sentences, replies, budget, usb);
        if let Some(batch) = batch {
            batch.start();
        }
        tx.dropped = tx.dropped.saturating_add(busy);
        usb.is_open() && !usb.is_empty()
    }

    /// Filter timing for a rate: (period in ticks, nominal dt s, cycles between log lines,
    /// USART bytes per period).
    fn timing(rate_hz: u16) -> (u32, f32, NonZeroU32, usize) {
        let rate = u32::from(rate_hz.max(1));
        let period = ((MONO_HZ + rate / 2) / rate).max(1);
        let stats_every = NonZeroU32::new(rate * 10).unwrap_or(NonZeroU32::MIN);
        // 10 bits per byte (8N1).
        let budget = (board::USART_BAUD / 10 / rate) as usize;
        (period, period as f32 / MONO_HZ as f32, stats_every, budget)
    }

    /// True when tick `a` is later than tick `b` (wrap-aware, as the timer queue compares).
    fn later(a: u32, b: u32) -> bool {
        (a.wrapping_sub(b) as i32) > 0
    }

    /// Wait until tick `at`.
    async fn until(at: u32) {
        Mono::delay_until(Instant::from_ticks(at)).await;
    }

    /// The filter: one cycle every 1/filter_rate_hz.
    ///
    /// A cycle is healthy when it runs to its end and the estimator has not reported a health
    /// reset in each of the last `HEALTH_RESET_STORM` cycles (`supervision::watchdog`); only
    /// then is the watchdog fed.
    #[task(priority = 2, local = [imu, pipeline, tx, sysclk_hz, watchdog, board], shared = [adc, health, rx, cmd, usb_out])]
    async fn filter(mut cx: filter::Context) {
        let (mut period, mut nominal_dt, mut stats_every, mut budget) =
            timing(cx.local.pipeline.settings().filter_rate_hz);
        let sysclk = *cx.local.sysclk_hz;
        // Non-zero divisors: no division-by-zero check (and panic path) in the loop.
        let cycles_per_us = NonZeroU32::new(sysclk / 1_000_000).unwrap_or(NonZeroU32::MIN);
        let mut feed_policy = FeedPolicy::default();

        // Let the gyros settle, then drop the frames of that time.
        let mut next = Mono::now().as_ticks().wrapping_add(GYRO_SETTLE_MS * (MONO_HZ / 1000));
        until(next).await;
        cx.shared.adc.lock(|adc| adc.take());
        next = next.wrapping_add(period);

        let mut prev_start: Option<u32> = None;
        let mut last_cycle_us = 0;
        let mut max_cycle_us = 0;
        let mut overruns = 0u32;
        let mut lost_frames = 0u32;
        let mut cycle = 0u32;
        loop {
            until(next).await;
            let start = DWT::cycle_count();
            let dt = match prev_start {
                Some(prev) => start.wrapping_sub(prev) as f32 / sysclk as f32,
                None => nominal_dt,
            };
            prev_start = Some(start);

            // ADC: the frames since the last cycle (the mean is computed outside the lock).
            let mut batch = cx.shared.adc.lock(|adc| adc.take());
            let adc = batch.averager.take();
            let mut board_status = Status::NONE;
            if batch.lost > 0 || batch.errors > 0 || adc.is_some_and(|m| m.dropped > 0) {
                board_status.insert(Status::ADC_FAULT);
            }
            lost_frames = lost_frames.saturating_add(batch.lost);
            if batch.errors > 0 {
                defmt::error!("ADC DMA transfer error: the scan has stopped");
            }

            let reading = cx.local.imu.read();
            let adc_scale = cx.local.pipeline.settings().adc;
            crate::app::update_board(
                cx.local.board,
                &reading,
                adc.as_ref(),
                &adc_scale,
                cx.local.imu,
            );
            if cycle == 0 {
                let report = selftest::evaluate(cx.local.board);
                defmt::println!(
                    "self-test: {=str}, grades {=u32:05x} (docs/bring-up.md)",
                    report.overall().name(),
                    report.code()
                );
                cx.shared.health.lock(|h| h.selftest = Some(report.overall()));
            }
            if let Some(event) = &reading.event {
                imu::log_event(event);
            }
            if reading.fault {
                board_status.insert(Status::I2C_FAULT);
            }

            let inputs = Inputs {
                dt,
                adc,
                accel_g: reading.accel_g,
                mag_ut: reading.mag_ut,
                board: board_status,
                last_cycle_us,
            };

            // What the commands since the last cycle asked for.
            let step = {
                let (pending, settings, raw) = cx.shared.cmd.lock(|c| {
                    (core::mem::take(&mut c.pending), *c.device.settings(), c.device.raw_mode())
                });
                let pipeline = &mut *cx.local.pipeline;
                if let Some(rate_changed) = pending.apply {
                    pipeline.apply_settings(settings);
                    if rate_changed {
                        (period, nominal_dt, stats_every, budget) = timing(settings.filter_rate_hz);
                        cx.local.imu.set_filter_rate(settings.filter_rate_hz);
                        defmt::println!("filter rate {=u16} Hz", settings.filter_rate_hz);
                    }
                }
                if pending.restart {
                    pipeline.restart();
                }
                if let Some(yaw) = pending.yaw {
                    pipeline.set_yaw(yaw);
                }

                let sample =
                    if raw { pipeline.conditioned_sample(&inputs) } else { ImuSample::default() };
                let step = pipeline.step(&inputs);
                let tx = &mut *cx.local.tx;
                let board = *cx.local.board;
                let usb_out = &mut cx.shared.usb_out;
                let usb_pending = cx.shared.cmd.lock(|c| {
                    c.device.set_heading_ref(step.heading_ref);
                    c.device.set_board(board);
                    if cycle == 0 {
                        // The boot's self-test report, as `SELFTEST` replies.
                        // (Both ports: it answers no command.)
                        c.record(
                            Some(inemo_ahrs::command::selftest_reply("SELFTEST", &board).finish()),
                            Route::Both,
                            None,
                        );
                    }
                    let mut out = c.device.on_cycle(&inputs, &sample, step.attitude);
                    // A cycle's reply (the end of a calibration) answers no line: both ports.
                    c.record(out.reply.take(), Route::Both, out.action.take());
                    usb_out.lock(|usb| {
                        if raw {
                            transmit(tx, out.raw_sentences(), &mut c.replies, budget, usb)
                        } else {
                            transmit(tx, step.sentences.iter(), &mut c.replies, budget, usb)
                        }
                    })
                });
                if usb_pending {
                    rtic::pend(Interrupt::USB_LP_CAN_RX0);
                }
                cx.shared.health.lock(|h| h.record(step.status));
                step
            };

            last_cycle_us = DWT::cycle_count().wrapping_sub(start) / cycles_per_us;
            max_cycle_us = max_cycle_us.max(last_cycle_us);
            cycle = cycle.wrapping_add(1);
            if cycle == 1 || cycle % stats_every == 0 {
                // The stack's high-water mark (a scan of the painted stack from the bottom of RAM:
                // about 13,000 words, 0.6 ms at 72 MHz, every 10 s).
                let stack_used = crate::app::stack::used();
                defmt::info!("stack: {=u32} bytes used at most", stack_used);
                cx.shared.cmd.lock(|c| c.device.set_stack_used(stack_used));
            }
            if cycle % stats_every == 0 {
                {
                    let (rx_errors, lines_dropped) =
                        cx.shared.rx.lock(|rx| (rx.errors, rx.dropped));
                    let (usart_replies, usb_replies) =
                        cx.shared.cmd.lock(|c| (c.replies.usart_dropped, c.replies.usb_dropped));
                    let (usb_open, usb_closed, usb_full) =
                        cx.shared.usb_out.lock(|u| (u.is_open(), u.dropped_closed, u.dropped_full));
                    defmt::info!(
                        "commands: rx errors {=u32}, lines dropped {=u32}, replies dropped USART {=u32} USB {=u32}; USB configured {=bool}, sentences dropped unconfigured {=u32} full {=u32}",
                        rx_errors,
                        lines_dropped,
                        usart_replies,
                        usb_replies,
                        usb_open,
                        usb_closed,
                        usb_full
                    );
                }
                defmt::info!(
                    "cycle {=u32}: max {=u32} us, status {=u32:#x}, overruns {=u32}, ADC lost {=u32}, I2C errors {=u32}, bus clears {=u32}, tx dropped {=u32}",
                    cycle,
                    max_cycle_us,
                    step.status.0,
                    overruns,
                    lost_frames,
                    cx.local.imu.counters.i2c_errors,
                    cx.local.imu.bus().counters.clears,
                    cx.local.tx.dropped
                );
                max_cycle_us = 0;
            }

            // The watchdog: fed at the end of a healthy cycle only.
            match feed_policy.cycle_end(step.status) {
                Verdict::Feed => cx.local.watchdog.feed(),
                Verdict::StormStarted => {
                    defmt::error!("estimator health resets in a row: watchdog no longer fed")
                }
                Verdict::Starve => {}
            }

            // Next period; after an overrun start again from now rather than catch up.
            next = next.wrapping_add(period);
            let now = Mono::now().as_ticks();
            if later(now, next) {
                overruns = overruns.saturating_add(1);
                next = now;
            }
        }
    }

    /// The status LED.
    #[task(priority = 1, local = [led, led_state], shared = [health])]
    async fn blink(mut cx: blink::Context) {
        let slot_ticks = led::SLOT_MS * (MONO_HZ / 1000);
        let mut next = Mono::now().as_ticks();
        let mut slot = 0;
        loop {
            if slot == 0 {
                let health = cx.shared.health.lock(core::mem::take);
                let (mode, changed) = cx.local.led_state.frame(health);
                if changed {
                    defmt::println!("status LED: {=str}", mode.name());
                }
            }
            let mode = cx.local.led_state.mode();
            cx.local.led.set_state(PinState::from(led::lit(mode, slot)));
            slot = (slot + 1) % led::SLOTS;
            next = next.wrapping_add(slot_ticks);
            until(next).await;
        }
    }
}
