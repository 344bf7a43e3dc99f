//! The painted stack: [`paint`] in `init`, [`used`] for the high-water mark (the scan is the
//! library's [`stack::used_bytes`](inemo_ahrs::supervision::stack::used_bytes), host-tested).

use core::ptr::{addr_of, read_volatile, write_volatile};

use inemo_ahrs::supervision::stack::{used_bytes, PAINT};

extern "C" {
    /// cortex-m-rt's `link.x`: the end of the static data, the lowest address the stack may
    /// reach.
    static _stack_end: u32;
    /// The top of the stack (the end of RAM).
    static _stack_start: u32;
}

/// Words kept clear below the stack pointer while painting (this function's own frame).
const MARGIN_WORDS: usize = 64;

fn bottom() -> usize {
    // Only the symbol's address is taken.
    addr_of!(_stack_end) as usize
}

/// Paints the free stack from `_stack_end` up to a little below the stack pointer.
pub fn paint() {
    let sp = cortex_m::register::msp::read() as usize;
    let top = sp.saturating_sub(4 * MARGIN_WORDS) & !3;
    let mut a = bottom();
    while a < top {
        // SAFETY: between the static data and the stack pointer (minus a margin): memory
        // nothing uses yet.
        unsafe { write_volatile(a as *mut u32, PAINT) };
        a += 4;
    }
}

/// The deepest the stack has been since [`paint`], bytes (from the top of RAM).
pub fn used() -> u32 {
    // Only the symbol's address is taken.
    let top = addr_of!(_stack_start) as usize;
    let base = bottom();
    let words = top.saturating_sub(base) / 4;
    // SAFETY: aligned reads of RAM between the static data and the top of the stack.
    let read = |i: usize| unsafe { read_volatile((base + 4 * i) as *const u32) };
    used_bytes(words, read) as u32
}
