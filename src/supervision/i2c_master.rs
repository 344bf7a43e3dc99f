//! The STM32F1 I²C peripheral as a master, step by step (RM0008 §26.3.3 "Master receiver"),
//! with the steps that must be done before the current byte ends masked completely (issue #27
//! point 6).
//!
//! ES0340 §2.13.2 ("Some software events must be managed before the current byte is being
//! transferred"): after ADDR is cleared (1 and 2 bytes) or DataN−2 is read (3 bytes or more),
//! the peripheral clocks the next byte at once, and the software's next step (STOP, or ACK
//! cleared) must land before that byte ends, or it reads an extra byte, NACKs the wrong one or
//! misses the STOP. The errata's workaround is to mask interrupts there. Which steps, as ST's
//! own code for the STM32F1 does it (its HAL's `HAL_I2C_Master_Receive` and AN2824's
//! examples: "Disable all active IRQs around ADDR clearing and STOP programming because the
//! EV6_3 software sequence must complete before the current byte end of transfer"):
//!
//! | bytes | masked (every interrupt: PRIMASK) | then |
//! |---|---|---|
//! | 1 | clear ADDR (SR1, SR2), STOP | wait RxNE, read the byte |
//! | 2 | (POS set before, ACK on) clear ADDR, ACK off | wait BTF; masked: STOP, read byte 1; read byte 2 |
//! | N ≥ 3 | (after BTF with DataN−2 and DataN−1 held, ACK off) read DataN−2, STOP, read DataN−1 | wait RxNE, read DataN |
//!
//! Every other step happens while the peripheral stretches SCL (ADDR, BTF or RxNE pending), so
//! an interrupt there only delays the transfer. Each masked section is a handful of register
//! accesses: its length in cycles is stated in `docs/firmware.md` (from the disassembly); the
//! time it must fit in is one byte on the bus, [`byte_cycles`].

/// An SR1 event waited on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flag {
    /// SB: START sent.
    Sb,
    /// ADDR: address acknowledged.
    Addr,
    /// TxE: data register empty.
    Txe,
    /// BTF: byte transfer finished (SCL stretched).
    Btf,
    /// RxNE: data register not empty.
    Rxne,
}

/// The peripheral's register steps (the firmware: I2C2's registers; the tests: a log).
pub trait Regs {
    /// A failed wait: an error flag (BERR, ARLO, AF, OVR) or a timeout.
    type Error;
    /// CR1.START (after clearing SR1's error flags).
    fn start(&mut self);
    /// CR1.STOP.
    fn stop(&mut self);
    /// CR1.ACK.
    fn set_ack(&mut self, on: bool);
    /// CR1.POS.
    fn set_pos(&mut self, on: bool);
    /// Writes DR.
    fn write_dr(&mut self, byte: u8);
    /// Reads DR.
    fn read_dr(&mut self) -> u8;
    /// Reads SR1 then SR2: clears ADDR.
    fn clear_addr(&mut self);
    /// Waits (bounded) for `flag`.
    fn wait(&mut self, flag: Flag) -> Result<(), Self::Error>;
    /// Waits (bounded) until the peripheral has sent the STOP (CR1.STOP cleared).
    fn wait_stop(&mut self) -> Result<(), Self::Error>;
    /// The error is a missing acknowledge (AF).
    fn is_nack(e: &Self::Error) -> bool;
    /// Resets and re-initialises the peripheral (a START that never came).
    fn reset(&mut self);
}

/// Runs a closure with every interrupt masked (the firmware: `cortex_m::interrupt::free`).
pub trait Critical {
    /// `f` with PRIMASK set.
    fn free<R>(&mut self, f: impl FnOnce() -> R) -> R;
}

/// Core cycles of one byte on the bus (8 data bits and the acknowledge: 9 SCL periods) at
/// `bus_hz`, rounded down: the time in which a masked section's steps must be done.
pub fn byte_cycles(sysclk_hz: u32, bus_hz: u32) -> u32 {
    (u64::from(sysclk_hz) * 9 / u64::from(bus_hz.max(1))) as u32
}

/// START (up to `tries` times, the peripheral reset after each that did not come), then the
/// address (for a read with ACK on and POS off); a NACK of the address sends a STOP.
pub fn start<R: Regs>(regs: &mut R, addr: u8, read: bool, tries: u8) -> Result<(), R::Error> {
    let mut tries = tries.max(1);
    loop {
        regs.start();
        match regs.wait(Flag::Sb) {
            Ok(()) => break,
            Err(e) => {
                regs.reset();
                tries -= 1;
                if tries == 0 {
                    return Err(e);
                }
            }
        }
    }
    if read {
        // ACK on, POS off for the data bytes, whatever a reset of the peripheral left (as
        // ST's HAL does before every reception).
        regs.set_pos(false);
        regs.set_ack(true);
    }
    regs.write_dr((addr << 1) | u8::from(read));
    regs.wait(Flag::Addr).inspect_err(|e| {
        if R::is_nack(e) {
            regs.stop();
        }
    })
}

/// START, address + W, `bytes` (at least one), no STOP: the bus is held (BTF) for a repeated
/// START or a STOP. A NACK sends a STOP.
pub fn write_no_stop<R: Regs>(
    regs: &mut R,
    addr: u8,
    bytes: &[u8],
    tries: u8,
) -> Result<(), R::Error> {
    start(regs, addr, false, tries)?;
    regs.clear_addr();
    let r = (|| {
        for (i, byte) in bytes.iter().enumerate() {
            if i > 0 {
                regs.wait(Flag::Txe)?;
            }
            regs.write_dr(*byte);
        }
        regs.wait(Flag::Btf)
    })();
    r.inspect_err(|e| {
        if R::is_nack(e) {
            regs.stop();
        }
    })
}

/// START, address + R, `buf.len()` bytes, STOP, with the masked sections of the module's table.
/// Ends with ACK on and POS off, as the peripheral's initialisation leaves them.
pub fn read<R: Regs, C: Critical>(
    regs: &mut R,
    critical: &mut C,
    addr: u8,
    buf: &mut [u8],
    tries: u8,
) -> Result<(), R::Error> {
    let r = start(regs, addr, true, tries).and_then(|()| receive(regs, critical, buf));
    regs.set_pos(false);
    regs.set_ack(true);
    r
}

fn receive<R: Regs, C: Critical>(
    regs: &mut R,
    critical: &mut C,
    buf: &mut [u8],
) -> Result<(), R::Error> {
    match buf {
        [] => {
            regs.clear_addr();
            regs.stop();
        }
        [only] => {
            regs.set_ack(false);
            critical.free(|| {
                regs.clear_addr();
                regs.stop();
            });
            regs.wait(Flag::Rxne)?;
            *only = regs.read_dr();
        }
        [first, second] => {
            // POS: the ACK cleared after ADDR applies to the second byte (RM0008 §26.3.3).
            regs.set_pos(true);
            critical.free(|| {
                regs.clear_addr();
                regs.set_ack(false);
            });
            regs.wait(Flag::Btf)?;
            *first = critical.free(|| {
                regs.stop();
                regs.read_dr()
            });
            *second = regs.read_dr();
        }
        [head @ .., n2, n1, n] => {
            regs.clear_addr();
            for byte in head {
                regs.wait(Flag::Rxne)?;
                *byte = regs.read_dr();
            }
            // DataN−2 in DR, DataN−1 in the shift register, SCL stretched.
            regs.wait(Flag::Btf)?;
            regs.set_ack(false);
            (*n2, *n1) = critical.free(|| {
                let a = regs.read_dr();
                regs.stop();
                (a, regs.read_dr())
            });
            regs.wait(Flag::Rxne)?;
            *n = regs.read_dr();
        }
    }
    regs.wait_stop()
}

#[cfg(test)]
#[path = "i2c_master_tests.rs"]
mod tests;
