//! The firmware's fault record and painted stack (`src/app/fault.rs`, `src/app/stack.rs`,
//! included by path) on a Cortex-M3 under QEMU (`scripts/qemu-fault-record`):
//! 1. first boot: no record; the stack is painted, a call 2 KiB deep is made, the high-water
//!    mark is printed; then an undefined instruction: the HardFault handler stores the record
//!    and resets the machine (SYSRESETREQ);
//! 2. second boot: the record survived the reset (`.uninit`), is reported once (PC of the
//!    faulting instruction, the fault status registers) and is gone on the next `take`.
//!
//! Output through semihosting; on the host it only type-checks.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("fault-record runs on a Cortex-M3: scripts/qemu-fault-record");
}

#[cfg(target_os = "none")]
use ekf_emu as _;

#[cfg(target_os = "none")]
#[path = "../../../src/app/fault.rs"]
mod fault;
#[cfg(target_os = "none")]
#[path = "../../../src/app/stack.rs"]
mod stack;

#[cfg(target_os = "none")]
mod target {
    use core::hint::black_box;

    use cortex_m_semihosting::{debug, hprintln};
    use inemo_ahrs::supervision::fault_record::cause;

    /// Uses 2 KiB of stack.
    #[inline(never)]
    fn deep() -> u32 {
        let buf = black_box([0x5Au8; 2048]);
        black_box(&buf).iter().map(|&b| u32::from(b)).sum()
    }

    /// The instruction that faults (its address is the record's PC).
    #[inline(never)]
    fn fault_here() -> ! {
        cortex_m::asm::udf()
    }

    #[cortex_m_rt::entry]
    fn main() -> ! {
        match super::fault::take() {
            None => {
                super::stack::paint();
                let before = super::stack::used();
                black_box(deep());
                let after = super::stack::used();
                hprintln!(
                    "boot 1: no fault record; stack used {} B, after a 2 KiB call {} B",
                    before,
                    after
                );
                hprintln!("fault_here at {:#010x}", fault_here as *const () as u32 & !1);
                fault_here()
            }
            Some((kind, regs)) => {
                hprintln!(
                    "boot 2: {} pc={:#010x} lr={:#010x} cfsr={:#010x} hfsr={:#010x} cause={}",
                    kind.name(),
                    regs.pc,
                    regs.lr,
                    regs.cfsr,
                    regs.hfsr,
                    cause(&regs)
                );
                let again = super::fault::take().is_some();
                hprintln!("reported again: {}", again);
                debug::exit(debug::EXIT_SUCCESS);
                loop {
                    cortex_m::asm::wfi();
                }
            }
        }
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        debug::exit(debug::EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    }
}
