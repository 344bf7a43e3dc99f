//! The transfer steps against a log of the register accesses, each marked with whether every
//! interrupt was masked then; the sequences by hand from RM0008 §26.3.3 and ST's STM32F1 code
//! (the module's table).

use core::cell::Cell;
use std::rc::Rc;

use super::*;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Op {
    Start,
    Stop,
    Ack(bool),
    Pos(bool),
    Write(u8),
    Read,
    ClearAddr,
    Wait(Flag),
    WaitStop,
    Reset,
}

/// A step and whether it ran masked.
type Step = (Op, bool);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fail {
    Nack,
    Timeout,
}

struct Log {
    masked: Rc<Cell<bool>>,
    steps: Vec<Step>,
    /// The data bytes the slave sends.
    data: Vec<u8>,
    next: usize,
    /// The wait (by its index among the waits) that fails, and how.
    fail_wait: Option<(usize, Fail)>,
    waits: usize,
}

impl Log {
    fn new(data: &[u8]) -> (Self, Mask) {
        let masked = Rc::new(Cell::new(false));
        let log = Log {
            masked: masked.clone(),
            steps: Vec::new(),
            data: data.to_vec(),
            next: 0,
            fail_wait: None,
            waits: 0,
        };
        (log, Mask { masked })
    }
    fn push(&mut self, op: Op) {
        self.steps.push((op, self.masked.get()));
    }
}

impl Regs for Log {
    type Error = Fail;
    fn start(&mut self) {
        self.push(Op::Start);
    }
    fn stop(&mut self) {
        self.push(Op::Stop);
    }
    fn set_ack(&mut self, on: bool) {
        self.push(Op::Ack(on));
    }
    fn set_pos(&mut self, on: bool) {
        self.push(Op::Pos(on));
    }
    fn write_dr(&mut self, byte: u8) {
        self.push(Op::Write(byte));
    }
    fn read_dr(&mut self) -> u8 {
        self.push(Op::Read);
        self.next += 1;
        self.data[self.next - 1]
    }
    fn clear_addr(&mut self) {
        self.push(Op::ClearAddr);
    }
    fn wait(&mut self, flag: Flag) -> Result<(), Fail> {
        self.push(Op::Wait(flag));
        self.waits += 1;
        match self.fail_wait {
            Some((i, f)) if i + 1 == self.waits => Err(f),
            _ => Ok(()),
        }
    }
    fn wait_stop(&mut self) -> Result<(), Fail> {
        self.push(Op::WaitStop);
        Ok(())
    }
    fn is_nack(e: &Fail) -> bool {
        *e == Fail::Nack
    }
    fn reset(&mut self) {
        self.push(Op::Reset);
    }
}

struct Mask {
    masked: Rc<Cell<bool>>,
}

impl Critical for Mask {
    fn free<R>(&mut self, f: impl FnOnce() -> R) -> R {
        assert!(!self.masked.get(), "nested");
        self.masked.set(true);
        let r = f();
        self.masked.set(false);
        r
    }
}

const A: u8 = 0x19;
/// Address byte for a read from 0x19: 0x19 << 1 | 1.
const AR: u8 = 0x33;

use Op::*;

/// Unmasked steps.
fn u(ops: &[Op]) -> Vec<Step> {
    ops.iter().map(|&o| (o, false)).collect()
}
/// Masked steps.
fn m(ops: &[Op]) -> Vec<Step> {
    ops.iter().map(|&o| (o, true)).collect()
}

fn read_log(data: &[u8]) -> (Vec<u8>, Vec<Step>) {
    let (mut log, mut mask) = Log::new(data);
    let mut buf = vec![0; data.len()];
    read(&mut log, &mut mask, A, &mut buf, 3).unwrap();
    (buf, log.steps)
}

/// One byte: ACK off before ADDR is cleared; masked: ADDR cleared and STOP (EV6_3); the byte
/// after RxNE.
#[test]
fn one_byte_masks_addr_clear_and_stop() {
    let (buf, steps) = read_log(&[0x33]);
    assert_eq!(buf, [0x33]);
    let want = [
        u(&[Start, Wait(Flag::Sb), Pos(false), Ack(true), Write(AR), Wait(Flag::Addr), Ack(false)]),
        m(&[ClearAddr, Stop]),
        u(&[Wait(Flag::Rxne), Read, WaitStop, Pos(false), Ack(true)]),
    ]
    .concat();
    assert_eq!(steps, want);
}

/// No byte (an address probe): ADDR cleared and STOP at once, then the wait for the STOP to
/// go out — a read that sent no STOP would leave the bus held (issue #39 point 5: passed
/// before).
#[test]
fn no_byte_clears_addr_and_stops() {
    let (buf, steps) = read_log(&[]);
    assert!(buf.is_empty());
    let want = [
        u(&[Start, Wait(Flag::Sb), Pos(false), Ack(true), Write(AR), Wait(Flag::Addr)]),
        u(&[ClearAddr, Stop, WaitStop, Pos(false), Ack(true)]),
    ]
    .concat();
    assert_eq!(steps, want);
}

/// Two bytes: POS on (ACK on since the address); masked: ADDR cleared and ACK off
/// (EV6_1); after BTF masked: STOP and the first byte; then the second.
#[test]
fn two_bytes_mask_addr_clear_and_ack_off_then_stop_and_first_read() {
    let (buf, steps) = read_log(&[1, 2]);
    assert_eq!(buf, [1, 2]);
    let want = [
        u(&[Start, Wait(Flag::Sb), Pos(false), Ack(true), Write(AR), Wait(Flag::Addr), Pos(true)]),
        m(&[ClearAddr, Ack(false)]),
        u(&[Wait(Flag::Btf)]),
        m(&[Stop, Read]),
        u(&[Read, WaitStop, Pos(false), Ack(true)]),
    ]
    .concat();
    assert_eq!(steps, want);
}

/// Six bytes (the LSM303DLH's samples): three read on RxNE with ACK; after BTF, ACK off, then
/// masked: DataN−2, STOP, DataN−1; DataN on RxNE.
#[test]
fn n_bytes_mask_the_last_three_byte_window() {
    let (buf, steps) = read_log(&[1, 2, 3, 4, 5, 6]);
    assert_eq!(buf, [1, 2, 3, 4, 5, 6]);
    let want = [
        u(&[Start, Wait(Flag::Sb), Pos(false), Ack(true), Write(AR), Wait(Flag::Addr), ClearAddr]),
        u(&[Wait(Flag::Rxne), Read, Wait(Flag::Rxne), Read, Wait(Flag::Rxne), Read]),
        u(&[Wait(Flag::Btf), Ack(false)]),
        m(&[Read, Stop, Read]),
        u(&[Wait(Flag::Rxne), Read, WaitStop, Pos(false), Ack(true)]),
    ]
    .concat();
    assert_eq!(steps, want);
    // Three bytes: no RxNE reads before BTF.
    let (buf, steps) = read_log(&[7, 8, 9]);
    assert_eq!(buf, [7, 8, 9]);
    assert_eq!(steps.iter().filter(|s| s.1).count(), 3);
    assert_eq!(steps[6..9], u(&[ClearAddr, Wait(Flag::Btf), Ack(false)]));
}

/// Every masked section holds only register steps, never a wait (a masked wait would hold
/// every interrupt off for up to a timeout).
#[test]
fn no_wait_is_ever_masked() {
    for n in 0..8 {
        let data: Vec<u8> = (0..n).collect();
        let (_, steps) = read_log(&data);
        for (op, masked) in steps {
            assert!(!(masked && matches!(op, Wait(_) | WaitStop | Start | Reset)), "{n}: {op:?}");
        }
    }
}

/// A write without STOP (the register address before a repeated START): TxE between bytes, BTF
/// at the end, nothing masked.
#[test]
fn write_no_stop_waits_for_btf() {
    let (mut log, _) = Log::new(&[]);
    write_no_stop(&mut log, A, &[0xA8, 0x01], 3).unwrap();
    let want = u(&[
        Start,
        Wait(Flag::Sb),
        Write(0x32),
        Wait(Flag::Addr),
        ClearAddr,
        Write(0xA8),
        Wait(Flag::Txe),
        Write(0x01),
        Wait(Flag::Btf),
    ]);
    assert_eq!(log.steps, want);
}

/// A NACK of the address or of a byte sends a STOP; a START that does not come resets the
/// peripheral and is tried again, `tries` times in all; a failed read leaves ACK on, POS off.
#[test]
fn failures_stop_retry_and_restore() {
    let (mut log, mut mask) = Log::new(&[]);
    log.fail_wait = Some((1, Fail::Nack)); // the ADDR wait
    assert_eq!(read(&mut log, &mut mask, A, &mut [0; 2], 3), Err(Fail::Nack));
    assert_eq!(
        log.steps,
        u(&[
            Start,
            Wait(Flag::Sb),
            Pos(false),
            Ack(true),
            Write(AR),
            Wait(Flag::Addr),
            Stop,
            Pos(false),
            Ack(true)
        ])
    );
    let (mut log, _) = Log::new(&[]);
    log.fail_wait = Some((2, Fail::Nack)); // the BTF wait after the data byte
    assert_eq!(write_no_stop(&mut log, A, &[1], 3), Err(Fail::Nack));
    assert_eq!(log.steps.last(), Some(&(Stop, false)));
    // START timeouts: a reset after each; the third failure is returned.
    let (mut log, mut mask) = Log::new(&[]);
    assert_eq!(start(&mut FailAll(&mut log), A, true, 3), Err(Fail::Timeout));
    assert_eq!(
        log.steps,
        u(&[
            Start,
            Wait(Flag::Sb),
            Reset,
            Start,
            Wait(Flag::Sb),
            Reset,
            Start,
            Wait(Flag::Sb),
            Reset
        ])
    );
    // A timeout is not a NACK: no STOP.
    let (mut log2, _) = Log::new(&[]);
    log2.fail_wait = Some((1, Fail::Timeout));
    assert_eq!(read(&mut log2, &mut mask, A, &mut [0; 1], 3), Err(Fail::Timeout));
    assert!(!log2.steps.contains(&(Stop, false)));
}

/// A [`Log`] whose every SB wait fails.
struct FailAll<'a>(&'a mut Log);

impl Regs for FailAll<'_> {
    type Error = Fail;
    fn start(&mut self) {
        self.0.start()
    }
    fn stop(&mut self) {
        self.0.stop()
    }
    fn set_ack(&mut self, on: bool) {
        self.0.set_ack(on)
    }
    fn set_pos(&mut self, on: bool) {
        self.0.set_pos(on)
    }
    fn write_dr(&mut self, byte: u8) {
        self.0.write_dr(byte)
    }
    fn read_dr(&mut self) -> u8 {
        self.0.read_dr()
    }
    fn clear_addr(&mut self) {
        self.0.clear_addr()
    }
    fn wait(&mut self, flag: Flag) -> Result<(), Fail> {
        self.0.push(Op::Wait(flag));
        Err(Fail::Timeout)
    }
    fn wait_stop(&mut self) -> Result<(), Fail> {
        self.0.wait_stop()
    }
    fn is_nack(e: &Fail) -> bool {
        *e == Fail::Nack
    }
    fn reset(&mut self) {
        self.0.reset()
    }
}

/// One byte is nine SCL periods: at 72 MHz, 300 kHz gives 9 · 240 = 2,160 cycles (30 µs),
/// 400 kHz 1,620 (22.5 µs), 100 kHz 6,480 (90 µs); from HSI (64 MHz) at 296,296 Hz, 1,944.
#[test]
fn byte_cycles_by_hand() {
    assert_eq!(byte_cycles(72_000_000, 300_000), 2_160);
    assert_eq!(byte_cycles(72_000_000, 400_000), 1_620);
    assert_eq!(byte_cycles(72_000_000, 100_000), 6_480);
    assert_eq!(byte_cycles(64_000_000, 296_296), 1_944);
}
