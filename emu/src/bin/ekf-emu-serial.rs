//! `ekf-emu-serial`: the firmware library behind a real serial port, for QEMU's `netduino2`
//! (STM32F205, Cortex-M3). The serial firmware of `ekf_emu::serial` (pipeline over the
//! embedded trace, command layer, settings persistence) talks through the STM32F2 USART2
//! (0x4000_4400, the second `-serial` of QEMU; the board's output port is USART2 too), is
//! paced at the filter rate by SysTick on the 120 MHz core clock (QEMU's virtual clock, which
//! follows the host's without `-icount`), and keeps its settings "flash" (two 2 KiB pages,
//! `SimFlash`) in SRAM above the firmware's 64 KiB, which survives QEMU's `system_reset`.
//!
//! ```sh
//! qemu-system-arm -M netduino2 -nographic -monitor stdio -serial null -serial pty \
//!   -kernel target/thumbv7m-none-eabi/release/ekf-emu-serial
//! ```
//! See `docs/host-tool.md`. On the host this binary only explains itself.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "ekf-emu-serial runs on the Cortex-M3 under QEMU (netduino2): build it with \
         scripts/cargo-thumb build -p ekf-emu --bin ekf-emu-serial --release; see docs/host-tool.md"
    );
    std::process::exit(2);
}

#[cfg(target_os = "none")]
mod target {
    use core::{
        ptr,
        sync::atomic::{AtomicU32, Ordering},
    };

    use cortex_m::peripheral::{syst::SystClkSource, SYST};
    use cortex_m_rt::{entry, exception};
    use ekf_emu::serial::{SerialFirmware, Tx};
    use inemo_ahrs::persist::SimFlash;

    /// Core clock of QEMU's netduino2 (STM32F205 SYSCLK), Hz: SysTick's clock source.
    const CORE_HZ: u32 = 120_000_000;
    /// SysTick interrupts per second: the time base and the polling period of the receiver.
    const TICK_HZ: u32 = 1000;
    const RELOAD: u32 = CORE_HZ / TICK_HZ - 1;

    /// STM32F2 USART2: status, data, baud rate, control 1.
    const USART2: usize = 0x4000_4400;
    const SR: usize = USART2;
    const DR: usize = USART2 + 0x04;
    const BRR: usize = USART2 + 0x08;
    const CR1: usize = USART2 + 0x0C;
    const SR_TXE: u32 = 1 << 7;
    const SR_RXNE: u32 = 1 << 5;
    const CR1_UE: u32 = 1 << 13;
    const CR1_TE: u32 = 1 << 3;
    const CR1_RE: u32 = 1 << 2;

    /// The settings flash: SRAM above the firmware's 64 KiB (`memory.x`; the STM32F205 has
    /// 128 KiB), which neither the program image nor its start-up code writes, so it keeps
    /// its content over a system reset. A magic word tells a warm start from a cold one.
    const BACKUP: usize = 0x2001_0000;
    const MAGIC: u32 = 0x5E77_1265;

    #[repr(C)]
    struct Backup {
        magic: u32,
        flash: SimFlash,
    }

    /// Milliseconds since boot (SysTick interrupts).
    static TICKS: AtomicU32 = AtomicU32::new(0);

    #[exception]
    fn SysTick() {
        TICKS.fetch_add(1, Ordering::Relaxed);
    }

    fn read(addr: usize) -> u32 {
        // SAFETY: a memory-mapped USART register of the netduino2.
        unsafe { ptr::read_volatile(addr as *const u32) }
    }

    fn write(addr: usize, value: u32) {
        // SAFETY: a memory-mapped USART register of the netduino2.
        unsafe { ptr::write_volatile(addr as *mut u32, value) }
    }

    /// USART2's transmitter, polled.
    struct Usart;

    impl Tx for Usart {
        fn send(&mut self, bytes: &[u8]) {
            for &b in bytes {
                // QEMU sends synchronously (TXE is set again at once); the bound only keeps a
                // model that never sets it from hanging the firmware.
                let mut spins = 0u32;
                while read(SR) & SR_TXE == 0 && spins < 100_000 {
                    spins += 1;
                }
                write(DR, u32::from(b));
            }
        }
    }

    /// Microseconds since boot (wraps after 71 minutes).
    fn now_us() -> u32 {
        loop {
            let ms = TICKS.load(Ordering::Relaxed);
            let left = SYST::get_current();
            if TICKS.load(Ordering::Relaxed) == ms {
                let into = (RELOAD - left.min(RELOAD)) / (CORE_HZ / 1_000_000);
                return ms.wrapping_mul(1000).wrapping_add(into);
            }
        }
    }

    #[entry]
    fn main() -> ! {
        let Some(mut cp) = cortex_m::Peripherals::take() else {
            loop {
                cortex_m::asm::wfi();
            }
        };
        let backup = BACKUP as *mut Backup;
        // SAFETY: the region is RAM owned by nothing else (see `BACKUP`); it is initialised
        // before a reference to it is made, and the magic word is read by pointer first.
        let (flash, cause) = unsafe {
            let warm = ptr::read_volatile(ptr::addr_of!((*backup).magic)) == MAGIC;
            if !warm {
                ptr::write(ptr::addr_of_mut!((*backup).flash), SimFlash::new());
                ptr::write_volatile(ptr::addr_of_mut!((*backup).magic), MAGIC);
            }
            (&mut (*backup).flash, if warm { "PIN" } else { "POR" })
        };

        // 115200 8N1 at 30 MHz APB1 (QEMU ignores the rate).
        write(BRR, 30_000_000 / 115_200);
        write(CR1, CR1_UE | CR1_TE | CR1_RE);

        let syst = &mut cp.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();

        let mut tx = Usart;
        #[cfg(feature = "panic-proof")]
        if core::hint::black_box(false) {
            board_flash::run(&mut tx);
        }
        let mut fw = SerialFirmware::boot(flash, cause);
        let mut rate = u32::from(fw.filter_rate_hz().max(1));
        let mut start = TICKS.load(Ordering::Relaxed);
        let mut k: u32 = 0;
        let mut last_cycle_us = 0;
        loop {
            while read(SR) & SR_RXNE != 0 {
                fw.receive(read(DR) as u8, &mut tx);
            }
            let due = start.wrapping_add((u64::from(k) * 1000 / u64::from(rate)) as u32);
            if (TICKS.load(Ordering::Relaxed).wrapping_sub(due) as i32) < 0 {
                cortex_m::asm::wfi();
                continue;
            }
            let t0 = now_us();
            fw.cycle(last_cycle_us, &mut tx);
            last_cycle_us = now_us().wrapping_sub(t0);
            k += 1;
            let new_rate = u32::from(fw.filter_rate_hz().max(1));
            if new_rate != rate || k == rate * 3600 {
                // A new rate (or an hour gone): the schedule restarts from the current tick.
                start = start.wrapping_add((u64::from(k) * 1000 / u64::from(rate)) as u32);
                rate = new_rate;
                k = 0;
            }
        }
    }

    /// With the `panic-proof` feature: the same cycle over the board's flash driver
    /// (`persist::f103::F103Flash`, on volatile registers at the STM32F103's FPEC addresses),
    /// linked behind a condition the compiler cannot decide and never true here (the netduino2
    /// has no F103 flash controller to run it on), so that the proof covers the driver too.
    #[cfg(feature = "panic-proof")]
    mod board_flash {
        use core::ptr;

        use ekf_emu::serial::{SerialFirmware, Tx};
        use inemo_ahrs::persist::f103::{F103Flash, FpecRegs};

        /// The STM32F103's flash interface (RM0008 §3.4): KEYR, SR, CR, AR.
        const FPEC: usize = 0x4002_2000;
        const KEYR: usize = FPEC + 0x04;
        const SR: usize = FPEC + 0x0C;
        const CR: usize = FPEC + 0x10;
        const AR: usize = FPEC + 0x14;

        fn read(addr: usize) -> u32 {
            // SAFETY: never executed (see the module); on an F103, an FPEC register.
            unsafe { ptr::read_volatile(addr as *const u32) }
        }

        fn write(addr: usize, value: u32) {
            // SAFETY: as `read`.
            unsafe { ptr::write_volatile(addr as *mut u32, value) }
        }

        struct Fpec;

        impl FpecRegs for Fpec {
            fn sr(&mut self) -> u32 {
                read(SR)
            }
            fn write_sr(&mut self, value: u32) {
                write(SR, value);
            }
            fn cr(&mut self) -> u32 {
                read(CR)
            }
            fn write_cr(&mut self, value: u32) {
                write(CR, value);
            }
            fn write_keyr(&mut self, key: u32) {
                write(KEYR, key);
            }
            fn write_ar(&mut self, address: u32) {
                write(AR, address);
            }
            fn write_half(&mut self, address: u32, value: u16) {
                // SAFETY: as `read`; on an F103, a settings page.
                unsafe { ptr::write_volatile(address as usize as *mut u16, value) }
            }
            fn read_byte(&self, address: u32) -> u8 {
                // SAFETY: as `write_half`.
                unsafe { ptr::read_volatile(address as usize as *const u8) }
            }
            fn pause(&mut self) {
                cortex_m::asm::delay(72);
            }
        }

        /// Boot (load), then receive (commands: `SAVE`, `LOAD`) and run cycles, forever.
        #[inline(never)]
        pub fn run(tx: &mut impl Tx) -> ! {
            let mut flash = F103Flash::new(Fpec);
            let mut fw = SerialFirmware::boot(&mut flash, "POR");
            loop {
                fw.receive(core::hint::black_box(0), tx);
                fw.cycle(core::hint::black_box(0), tx);
            }
        }
    }

    /// With the `panic-proof` feature (`scripts/size-report`): the link fails if any panic is
    /// reachable from the firmware's cycle as this program runs it.
    #[cfg(feature = "panic-proof")]
    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        extern "C" {
            /// Deliberately undefined: referencing it makes the link fail.
            fn serial_firmware_cycle_contains_a_reachable_panic() -> !;
        }
        // SAFETY: never executed; the link fails if this handler is reachable at all.
        unsafe { serial_firmware_cycle_contains_a_reachable_panic() }
    }

    /// A panic stops the firmware (the host sees the stream end).
    #[cfg(not(feature = "panic-proof"))]
    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }
}
