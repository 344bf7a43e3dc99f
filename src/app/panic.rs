//! The panic handler. Nothing on the running path panics (the library has no reachable panic
//! on the filter's path, `init` only panics on programming errors); should one happen, this logs
//! where over defmt and stops the core with a HardFault, which a debugger (`probe-rs run`)
//! reports. Without a debugger the watchdog then resets the MCU (reset cause `IWDG`).
//!
//! It replaces `panic-probe`'s handler to keep `core::fmt` out of the firmware (≈ 3 KiB of
//! flash): only the file and line are printed, not the message.

use core::panic::PanicInfo;

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    match info.location() {
        Some(at) => defmt::error!("panic at {=str}:{=u32}", at.file(), at.line()),
        None => defmt::error!("panic"),
    }
    // An undefined instruction: UsageFault is not enabled, so it escalates to HardFault.
    cortex_m::asm::udf()
}
