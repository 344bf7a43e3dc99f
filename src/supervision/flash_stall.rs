//! What `SAVE`'s flash erase costs the monotonic (issue #27 point 8): its bound, and the loss
//! measured on the board.
//!
//! While the flash controller erases a page the flash cannot be read, so the CPU, which
//! fetches its code from flash, stalls for the whole erase: t_ERASE = 20–40 ms (DS5792,
//! STM32F103xC/D/E datasheet, "Flash memory characteristics"; `persist::f103`). No interrupt
//! is served meanwhile. The monotonic (rtic-monotonics' SysTick monotonic, 10 kHz in
//! `src/main.rs`) counts one tick per SysTick wrap, in the SysTick interrupt or when it is read
//! (COUNTFLAG). SysTick itself keeps counting through the stall, but of the W wraps in it only
//! one is counted afterwards (one pending interrupt, one COUNTFLAG): the monotonic loses
//! W − 1 ticks, with W ≤ ⌈stall · tick rate⌉. Its counter is private to rtic-monotonics (no
//! way to add the lost ticks back), so the loss stays: from then on the monotonic is behind
//! real time by that much.
//!
//! The bound ([`max_ticks_lost`]): a page erase at its longest, 40 ms at 10 kHz, loses at most
//! ⌈400⌉ − 1 = 399 ticks (39.9 ms); a half-word program (t_PROG ≤ 70 µs, DS5792) is shorter
//! than one 100 µs tick and loses none. A `SAVE` erases one page (`persist::save`), so
//! it costs at most 399 ticks. The filter's `dt` comes from the cycle counter and is right; what
//! the monotonic schedules (the filter's next cycle, the LED's slots) is postponed once by the
//! ticks lost: one filter cycle comes up to 39.9 ms late, after which the period is the
//! same (`docs/firmware.md`, `SAVE`).
//!
//! The measure ([`ticks_lost`]): the command task reads the cycle counter (DWT CYCCNT, which
//! runs through the stall) and the monotonic around each command, and logs the difference.

/// Longest page erase, µs (DS5792: t_ERASE max 40 ms).
pub const ERASE_MAX_US: u32 = 40_000;
/// Longest half-word program, µs (DS5792: t_PROG max 70 µs).
pub const PROGRAM_MAX_US: u32 = 70;

/// Ticks a monotonic at `tick_hz` loses at most over one stall of `stall_us`: the SysTick
/// wraps in the stall (at most ⌈stall · rate⌉) but the one it counts afterwards.
pub const fn max_ticks_lost(stall_us: u32, tick_hz: u32) -> u32 {
    let wraps = (stall_us as u64 * tick_hz as u64).div_ceil(1_000_000);
    wraps.saturating_sub(1) as u32
}

/// Ticks the monotonic fell behind the cycle counter over an interval: `elapsed_cycles` of the
/// cycle counter (less than 2³² cycles: 59 s at 72 MHz), `cycles_per_tick` (SysTick's reload
/// plus one), `elapsed_ticks` counted by the monotonic. 0 when none was lost; a loss of L
/// reads L or L − 1 (the ticks are whole, the cycles not).
pub fn ticks_lost(elapsed_cycles: u32, cycles_per_tick: u32, elapsed_ticks: u32) -> u32 {
    (elapsed_cycles / cycles_per_tick.max(1)).saturating_sub(elapsed_ticks)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The firmware's monotonic: 10 kHz, 7200 cycles per tick at 72 MHz.
    const TICK_HZ: u32 = 10_000;
    const CYCLES_PER_TICK: u32 = 72_000_000 / TICK_HZ;

    /// The bound by hand: 40 ms at 10 kHz is 400 wraps, one counted: 399 lost; the shortest
    /// erase (20 ms): 199; a half-word program (70 µs): none; at 1 kHz a 40 ms erase: 39.
    #[test]
    fn an_erase_costs_at_most_399_ticks() {
        assert_eq!(max_ticks_lost(ERASE_MAX_US, TICK_HZ), 399);
        assert_eq!(max_ticks_lost(20_000, TICK_HZ), 199);
        assert_eq!(max_ticks_lost(PROGRAM_MAX_US, TICK_HZ), 0);
        assert_eq!(max_ticks_lost(ERASE_MAX_US, 1_000), 39);
        // A stall of 40.01 ms spans up to 401 wraps.
        assert_eq!(max_ticks_lost(40_010, TICK_HZ), 400);
        assert_eq!(max_ticks_lost(0, TICK_HZ), 0);
    }

    /// Measured: a 40 ms stall (2,880,000 cycles at 72 MHz) after which the monotonic had
    /// counted 1 tick lost 399; 30 ms with 1 tick: 299.
    #[test]
    fn the_loss_is_the_cycles_the_monotonic_did_not_count() {
        assert_eq!(ticks_lost(2_880_000, CYCLES_PER_TICK, 1), 399);
        assert_eq!(ticks_lost(2_160_000, CYCLES_PER_TICK, 1), 299);
        // The same stall inside a longer command (+5 ms counted normally).
        assert_eq!(ticks_lost(2_880_000 + 360_000, CYCLES_PER_TICK, 51), 399);
    }

    /// Without a stall nothing is lost, whatever the phase of the ticks against the cycles.
    #[test]
    fn no_stall_loses_nothing() {
        // 1 ms: 72,000 cycles; the monotonic counted 10 or 11 ticks depending on the phase.
        assert_eq!(ticks_lost(72_000, CYCLES_PER_TICK, 10), 0);
        assert_eq!(ticks_lost(72_000, CYCLES_PER_TICK, 11), 0);
        assert_eq!(ticks_lost(75_000, CYCLES_PER_TICK, 10), 0);
        assert_eq!(ticks_lost(0, CYCLES_PER_TICK, 0), 0);
        // A zero tick length (not configured) does not divide by zero.
        assert_eq!(ticks_lost(5, 0, 5), 0);
    }
}
