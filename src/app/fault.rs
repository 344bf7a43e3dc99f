//! The fault record in RAM that survives a reset, and the HardFault handler that fills it.
//! The record's format and checks are the library's
//! [`fault_record`](inemo_ahrs::supervision::fault_record) (host-tested); here its place
//! (`.uninit`: neither zeroed nor initialised by the start-up code) and the handlers.

use core::mem::MaybeUninit;
use core::ptr::{addr_of_mut, read_volatile, write_volatile};

use cortex_m::peripheral::{DCB, SCB};
use cortex_m_rt::{exception, ExceptionFrame};
use inemo_ahrs::supervision::fault_record::{FaultKind, FaultRecord, FaultRegs};

#[link_section = ".uninit.FAULT_RECORD"]
static mut RECORD: MaybeUninit<FaultRecord> = MaybeUninit::uninit();

fn record() -> *mut FaultRecord {
    // Only the address is taken; `FaultRecord` is all `u32`, so whatever RAM holds is a value
    // of it (`read` rejects what is not a sealed record).
    addr_of_mut!(RECORD).cast()
}

/// The record the previous run left, if any; clears it. Call first in `init`.
pub fn take() -> Option<(FaultKind, FaultRegs)> {
    // SAFETY: `init` runs with interrupts masked; the handlers below write it only when the
    // firmware stops.
    unsafe {
        let found = read_volatile(record()).read();
        write_volatile(record(), FaultRecord::cleared());
        found
    }
}

/// Seals a record of `kind` with the fault status registers (PM0056 §4.4) and `pc`, `lr`,
/// `line`.
pub fn store(kind: FaultKind, pc: u32, lr: u32, line: u32) {
    // SAFETY: reads of the System Control Block's fault registers.
    let (cfsr, hfsr, mmfar, bfar) = unsafe {
        let scb = &*SCB::PTR;
        (scb.cfsr.read(), scb.hfsr.read(), scb.mmfar.read(), scb.bfar.read())
    };
    let regs = FaultRegs { pc, lr, cfsr, hfsr, mmfar, bfar, line };
    // SAFETY: the firmware stops after this (panic handler, HardFault handler).
    unsafe { write_volatile(record(), FaultRecord::sealed(kind, regs)) };
}

/// Every fault ends here (the configurable ones are not enabled, so they escalate). Keeps a
/// panic's record (the panic handler ends in `udf`, which faults); otherwise records this
/// fault. With a debugger attached it stops at a breakpoint (probe-rs shows the frame);
/// without, it resets at once, and the next boot reports the record.
#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    // SAFETY (the handler's): runs once, nothing else runs meanwhile.
    let earlier = unsafe { read_volatile(record()) }.read();
    if !matches!(earlier, Some((FaultKind::Panic, _))) {
        store(FaultKind::HardFault, ef.pc(), ef.lr(), 0);
    }
    if DCB::is_debugger_attached() {
        cortex_m::asm::bkpt();
    }
    SCB::sys_reset()
}
