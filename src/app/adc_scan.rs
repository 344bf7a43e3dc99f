//! ADC1 scan of the six analog channels and VREFINT, triggered by TIM3 and moved by DMA1
//! channel 1.
//!
//! TIM3 overflows at [`FRAME_HZ`] and its update event is the trigger output (TRGO) that
//! starts one regular-group scan of [`SCAN_CHANNELS`] (ADC1 EXTSEL = TIM3_TRGO). Every
//! conversion's end raises a DMA request; DMA1 channel 1 runs circularly over a buffer of two
//! frames, so its half-transfer interrupt marks frame 0 complete and its transfer-complete
//! interrupt frame 1. The interrupt handler ([`AdcScan::service`]) copies the finished frame
//! out while the DMA fills the other one.
//!
//! Timing (sample time 239.5 cycles + 12.5 conversion = 252 ADC cycles per channel; VREFINT
//! needs ≥ 17.1 µs of sampling, DS5792, and gets 20 µs): one scan of seven channels
//! takes 147 µs at the 12 MHz ADC clock (165 µs at 10.67 MHz from HSI), well inside the 1 ms
//! frame period. The frame rate is exactly [`FRAME_HZ`] = 1 kHz: 20 frames per 50 Hz filter
//! cycle, 5 per 200 Hz cycle.
//!
//! The depth input's probe (issue #27 point 4; the decision is the library's
//! [`DepthProbe`], host-tested): before the timer runs, in `init`, three software scans
//! instead of one. The first with PA1 switched to an input with its pull-down, the second with
//! its pull-up (each pull on 1 ms before and during the scan), the third with PA1 back in
//! analog mode — the frame the rank check reads. A floating PA1 follows each pull to its rail;
//! a sensor's output does not move. Done once, at boot: the filter's gyro scans are not
//! touched (the timer starts after the probe), and the running scan's depth readings never see
//! a pull. A sensor connected after boot is seen at the next reset. The pin mode is switched
//! through GPIOA's registers (PA1's field in GPIOA_CRL, its ODR bit choosing the pull): the
//! HAL's typed pin is inside the scan's DMA payload by then.
//!
//! The HAL's `CircBuffer` is not used: on an overrun (both halves complete before the handler
//! ran) it reports an error without clearing either flag, which would keep the interrupt
//! pending for good. The DMA is never stopped once running, because restarting it in the
//! middle of a scan would shift every later frame by the channels already converted.

use core::sync::atomic::{compiler_fence, Ordering};

use inemo_ahrs::adc::{check_ranks, AdcFrame, RankCheck, SCAN_CHANNELS, SCAN_LEN};
use inemo_ahrs::supervision::depth_probe::DepthProbe;
use stm32f1xx_hal::{
    adc::{Adc, AdcDma, ChannelTimeSequence, SampleTime, Scan, SetChannels},
    dma::{dma1, Event, TransferPayload},
    gpio::{Analog, PA1, PC0, PC1, PC2, PC4, PC5},
    pac,
    rcc::Rcc,
    time::Hertz,
    timer::{CounterHz, Timer},
};

/// Scan (frame) rate, Hz.
pub const FRAME_HZ: u32 = 1_000;
/// Sample time of every channel: the longest, for the gyros' amplifier outputs and a depth
/// sensor behind a divider alike.
const SAMPLE_TIME: SampleTime = SampleTime::T_239;
/// DMA1 channel 1 is index 0 in the DMA's ISR/IFCR flag arrays.
const DMA_INDEX: u8 = 0;

/// The analog pins: PC0, PC1, PC2, PC4, PC5 (gyros), PA1 (depth); the scan order is
/// [`SCAN_CHANNELS`] (with VREFINT, internal).
pub struct AdcPins(
    pub PC0<Analog>,
    pub PC1<Analog>,
    pub PC2<Analog>,
    pub PC4<Analog>,
    pub PC5<Analog>,
    pub PA1<Analog>,
);

impl SetChannels<AdcPins> for Adc<pac::ADC1> {
    fn set_samples(&mut self) {
        for channel in SCAN_CHANNELS {
            ChannelTimeSequence::set_channel_sample_time(self, channel, SAMPLE_TIME);
        }
    }

    fn set_sequence(&mut self) {
        ChannelTimeSequence::set_regular_sequence(self, &SCAN_CHANNELS);
        // One scan per trigger.
        ChannelTimeSequence::set_continuous_mode(self, false);
    }
}

/// What one DMA interrupt delivered.
#[derive(Clone, Copy, Debug, Default)]
pub struct Serviced {
    /// The frame completed since the last interrupt, if it could be read safely.
    pub frame: Option<AdcFrame>,
    /// Frames lost: the handler was too late to read them before the DMA came round again.
    pub lost: u32,
    /// The DMA reported a transfer error (it then disables the channel: the ADC stops).
    pub error: bool,
}

/// The running scan: the DMA channel, its two-frame buffer and the trigger timer.
pub struct AdcScan {
    dma: AdcDma<pac::ADC1, AdcPins, Scan, dma1::C1>,
    buf: &'static mut [[u16; SCAN_LEN]; 2],
    calibrated: bool,
    ranks: RankCheck,
    depth_probe: DepthProbe,
    _trigger: CounterHz<pac::TIM3>,
}

/// Sets up and starts the scan. Call with interrupts masked (RTIC `init`); the first frames
/// are handled once `init` returns.
pub fn start(
    adc1: pac::ADC1,
    tim3: pac::TIM3,
    pins: AdcPins,
    channel: dma1::C1,
    buf: &'static mut [[u16; SCAN_LEN]; 2],
    rcc: &mut Rcc,
) -> AdcScan {
    let sysclk = rcc.clocks.sysclk().raw();
    let dr = adc1.dr().as_ptr() as u32;

    // Powers up and calibrates the ADC; then the trigger, the sequence and the DMA request.
    let mut adc = Adc::new(adc1, rcc);
    adc.set_external_trigger(pac::adc1::cr2::EXTSEL::Tim3trgo);
    // SAFETY: ADC1's registers, owned by `adc` and then by `dma` (the HAL keeps the `Adc`
    // private in its payload); accessed here only, in `init` with interrupts masked, before
    // the DMA channel is enabled and the trigger timer runs.
    let regs = unsafe { &*pac::ADC1::ptr() };
    // VREFINT (channel 17) on: it measures VDDA in every scan (`AdcScale::for_mean`). Its
    // start-up (DS5792: 10 µs) passes long before the first scan.
    regs.cr2().modify(|_, w| w.tsvrefe().set_bit());
    let mut dma = adc.with_scan_dma(pins, channel);
    // `with_scan_dma` powered the ADC down and up again (ADON 0 → 1) with CR2.DMA set, after
    // the HAL's calibration in `Adc::new`; RM0008 recommends calibrating after each power-up.
    // The calibration leaves its code in ADC_DR (RM0008 §11.4): with DMA requests on, the DMA
    // could take it for the first conversion and shift every frame by one rank. So: DMA
    // requests off, wait t_STAB (1 µs) and two ADC clocks, calibrate, read ADC_DR out, and
    // only then DMA requests on. (A CR2 write that changes a bit besides ADON starts no
    // conversion, RM0008 §11.12.3.)
    regs.cr2().modify(|_, w| w.dma().clear_bit());
    cortex_m::asm::delay(sysclk / 100_000);
    let calibrated = calibrate(regs);
    // Anything converted meanwhile (a conversion takes < 25 µs, a scan < 150 µs) is drained
    // too, so the channel starts aligned with the scan's first rank.
    cortex_m::asm::delay(sysclk / 5_000);
    let _ = regs.dr().read();
    regs.cr2().modify(|_, w| w.dma().set_bit());

    let ch = &mut dma.channel;
    ch.set_peripheral_address(dr, false);
    ch.set_memory_address(buf.as_mut_ptr() as u32, true);
    ch.set_transfer_length(2 * SCAN_LEN);
    compiler_fence(Ordering::Release);
    ch.ch().cr().modify(|_, w| {
        w.mem2mem().clear_bit();
        w.pl().high();
        w.msize().bits16();
        w.psize().bits16();
        w.circ().set_bit();
        w.dir().clear_bit();
        w.teie().set_bit()
    });
    ch.listen(Event::HalfTransfer);
    ch.listen(Event::TransferComplete);
    // The depth probe (module documentation): PA1 pulled down, then up, one scan each; then
    // analog again for the scan the rank check reads. Each scan is read once it is complete
    // (< 170 µs) and before another starts.
    // SAFETY (the volatile reads): a frame of the 'static buffer, complete; the DMA is idle
    // between the scans started here until the timer runs.
    let ms = sysclk / 1_000;
    let scan_time = sysclk / 2_000;
    pa1_pull(Some(false));
    cortex_m::asm::delay(ms);
    // Enables the channel, then rewrites ADON, which starts one software scan: it lands,
    // aligned, in frame 0.
    dma.start();
    cortex_m::asm::delay(scan_time);
    let pulled_down = AdcFrame::from_scan(unsafe { core::ptr::read_volatile(&buf[0]) }).depth;
    pa1_pull(Some(true));
    cortex_m::asm::delay(ms);
    // ADON written again, no other bit changed, starts the next scan (RM0008 §11.12.3): frame 1.
    regs.cr2().modify(|_, w| w.adon().set_bit());
    cortex_m::asm::delay(scan_time);
    let pulled_up = AdcFrame::from_scan(unsafe { core::ptr::read_volatile(&buf[1]) }).depth;
    pa1_pull(None);
    cortex_m::asm::delay(ms);
    // The third scan, PA1 in analog mode as it stays: frame 0 again.
    regs.cr2().modify(|_, w| w.adon().set_bit());
    cortex_m::asm::delay(scan_time);
    let first = unsafe { core::ptr::read_volatile(&buf[0]) };
    let depth_probe = DepthProbe { pulled_down, pulled_up };
    // Three scans moved the DMA to frame 1, where the timer's first scan lands; the flags of
    // the probe's frames are cleared, so the first interrupt hands over that frame.
    dma.channel.ifcr().write(|w| {
        w.chtif(DMA_INDEX).set_bit();
        w.ctcif(DMA_INDEX).set_bit()
    });
    // The boot check on the last frame: do the ranks read like what they should be?
    let ranks = check_ranks(&AdcFrame::from_scan(first));

    let mut timer = Timer::new(tim3, rcc);
    timer.set_master_mode(pac::tim2::cr2::MMS::Update);
    let mut trigger = timer.counter_hz();
    // A programming error only (the rate fits TIM3's 16-bit prescaler and reload at every
    // clock this firmware configures). A `panic!` with a plain message: `expect` would
    // format the error with `core::fmt`.
    if trigger.start(Hertz::from_raw(FRAME_HZ)).is_err() {
        panic!("TIM3 cannot run at the ADC frame rate");
    }

    AdcScan { dma, buf, calibrated, ranks, depth_probe, _trigger: trigger }
}

/// PA1's mode: `Some(false)` input with pull-down, `Some(true)` input with pull-up, `None`
/// analog (RM0008 §9.2.2: CNF1/MODE1 in GPIOA_CRL bits 4–7, 0b1000 input with pull-up/down,
/// 0b0000 analog; ODR bit 1 selects up (1) or down (0)). Only in `init`, interrupts masked:
/// nothing else writes GPIOA_CRL then.
fn pa1_pull(pull: Option<bool>) {
    // SAFETY: GPIOA's registers; only PA1's field of CRL and its own BSRR/BRR bit are changed.
    let gpioa = unsafe { &*pac::GPIOA::ptr() };
    match pull {
        Some(up) => {
            if up {
                gpioa.bsrr().write(|w| w.bs1().set_bit());
            } else {
                gpioa.brr().write(|w| w.br1().set_bit());
            }
            gpioa.crl().modify(|r, w| unsafe { w.bits((r.bits() & !0xF0) | 0x80) });
        }
        None => {
            gpioa.crl().modify(|r, w| unsafe { w.bits(r.bits() & !0xF0) });
            gpioa.brr().write(|w| w.br1().set_bit());
        }
    }
}

/// Resets and runs the ADC calibration, each step bounded (it takes about 90 ADC clocks).
/// Returns whether both steps completed.
fn calibrate(regs: &pac::adc1::RegisterBlock) -> bool {
    const POLLS: u32 = 100_000;
    regs.cr2().modify(|_, w| w.rstcal().set_bit());
    let reset = (0..POLLS).any(|_| regs.cr2().read().rstcal().bit_is_clear());
    regs.cr2().modify(|_, w| w.cal().set_bit());
    let done = (0..POLLS).any(|_| regs.cr2().read().cal().bit_is_clear());
    reset && done
}

impl AdcScan {
    /// Whether the calibration after the last power-up completed.
    pub fn calibrated(&self) -> bool {
        self.calibrated
    }

    /// The boot check of the first frame's ranks (VREFINT, the gyro references).
    pub fn ranks(&self) -> RankCheck {
        self.ranks
    }

    /// The boot's depth-input probe: the depth channel read with PA1 pulled down and up.
    pub fn depth_probe(&self) -> DepthProbe {
        self.depth_probe
    }

    /// Handles DMA1 channel 1's interrupt: clears the flags it saw and copies out the frame
    /// they mark complete. Never blocks.
    pub fn service(&mut self) -> Serviced {
        let isr = self.dma.channel.isr();
        let first = isr.htif(DMA_INDEX).bit_is_set();
        let second = isr.tcif(DMA_INDEX).bit_is_set();
        let error = isr.teif(DMA_INDEX).bit_is_set();
        self.dma.channel.ifcr().write(|w| {
            if first {
                w.chtif(DMA_INDEX).set_bit();
            }
            if second {
                w.ctcif(DMA_INDEX).set_bit();
            }
            if error {
                w.cteif(DMA_INDEX).set_bit();
            }
            w
        });
        let mut out = Serviced { frame: None, lost: 0, error };
        match (first, second) {
            // Both halves completed since the last interrupt: the older one may already be
            // partly overwritten and which is which is unknown. Drop both.
            (true, true) => out.lost = 2,
            (true, false) => self.read_half(0, &mut out),
            (false, true) => self.read_half(1, &mut out),
            (false, false) => {}
        }
        out
    }

    /// Copies frame `half` out, then checks that the DMA did not finish the other frame
    /// meanwhile: only after that could it have started overwriting this one.
    fn read_half(&mut self, half: usize, out: &mut Serviced) {
        compiler_fence(Ordering::Acquire);
        let scan = match self.buf.get(half) {
            // SAFETY: a valid, aligned pointer into the 'static buffer; the DMA writes only
            // the other half until the flag checked below is set, and a volatile read keeps
            // the compiler from assuming the memory is unchanged since an earlier read.
            Some(frame) => unsafe { core::ptr::read_volatile(frame) },
            None => return,
        };
        compiler_fence(Ordering::Acquire);
        let isr = self.dma.channel.isr();
        let other_done = if half == 0 {
            isr.tcif(DMA_INDEX).bit_is_set()
        } else {
            isr.htif(DMA_INDEX).bit_is_set()
        };
        if other_done {
            // Possibly torn: drop it. The other frame's flag is still set and is handled by
            // the interrupt that follows at once.
            out.lost = 1;
        } else {
            out.frame = Some(AdcFrame::from_scan(scan));
        }
    }
}
