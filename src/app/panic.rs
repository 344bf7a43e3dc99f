//! The panic handler. Nothing on the running path panics (the library has no reachable panic
//! on the filter's path, `init` only panics on programming errors); should one happen, this logs
//! where over defmt and stops the core with a HardFault, which a debugger (`probe-rs run`)
//! reports. Without a debugger the HardFault handler resets the MCU at once; the next boot
//! reports the panic's line (the fault record, `super::fault`).
//!
//! It replaces `panic-probe`'s handler to keep `core::fmt` out of the firmware (≈ 3 KiB of
//! flash): only the file and line are printed, not the message.

use core::panic::PanicInfo;

use inemo_ahrs::supervision::fault_record::FaultKind;

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    let line = info.location().map_or(0, |at| at.line());
    // The record the next boot reports (`super::fault`): kept by the HardFault handler.
    super::fault::store(FaultKind::Panic, 0, 0, line);
    match info.location() {
        Some(at) => defmt::error!("panic at {=str}:{=u32}", at.file(), at.line()),
        None => defmt::error!("panic"),
    }
    // An undefined instruction: UsageFault is not enabled, so it escalates to HardFault.
    cortex_m::asm::udf()
}
