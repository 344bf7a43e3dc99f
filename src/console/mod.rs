//! The two consoles (issue #27 point 2): USART2, the ROV tether's port, and the USB serial
//! port (CDC-ACM) on the board's USB connector, for the bench. Both carry the same sentences and
//! take the same commands; this module is the part of that which does not need the board, so
//! that it is tested on the host (the RTIC glue in `src/app/usb.rs` and `src/main.rs` only
//! moves bytes between the peripherals and these types):
//!
//! - **Input**: one [`PortLines`] per port (each its own [`LineAssembler`], so a partial line on
//!   one port never mixes with a line on the other); a complete line comes out as a
//!   [`Received`] that remembers its port.
//! - **Replies**: [`Replies`] keeps a queue per port. A command's reply goes to the port the
//!   command came from ([`Received::reply_route`]); replies that answer no line (the boot's
//!   self-test report, the end of a calibration reported by a later filter cycle) go to both
//!   ([`Route::Both`]).
//! - **Output**: [`fan_out`] hands every cycle's sentences to both ports: to the USART's batch
//!   exactly as before (sentences, then the USART's replies while they fit the period's byte
//!   budget), and to [`UsbOut`], a byte queue the USB task drains into the serial port. The USB
//!   side never waits: while the device is not configured by a host its sentences and replies
//!   are dropped and counted; when the queue is full (a host that has not opened the port
//!   reads nothing) a sentence that does not fit is dropped (counted) and a reply waits for the
//!   next cycle. A change of DTR (a program opening or closing the port on Linux or macOS)
//!   empties the queue, so that the program starts with fresh sentences. Nothing the USB side
//!   does changes what the USART sends.
//!
//! Why configured rather than DTR gates the output: `ahrs-tool` opens ports through the
//! `serialport` crate, which on Windows opens them with DTR off (Linux raises DTR on every
//! open); gating on DTR would leave a Windows host without output.

use heapless::Deque;

use crate::command::{LineAssembler, LineEvent};
use crate::nmea::Sentence;

#[cfg(test)]
mod tests;

/// A console port.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Port {
    /// USART2 (PA2/PA3, 115200 8N1): the ROV tether.
    Usart,
    /// The USB serial port (CDC-ACM): the bench.
    Usb,
}

/// Where a reply goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Route {
    /// USART2 only.
    Usart,
    /// The USB port only.
    Usb,
    /// Both ports: replies that answer no command line.
    Both,
}

impl Route {
    /// True when a reply on this route goes to `port`.
    pub const fn reaches(self, port: Port) -> bool {
        matches!(
            (self, port),
            (Route::Both, _) | (Route::Usart, Port::Usart) | (Route::Usb, Port::Usb)
        )
    }
}

impl From<Port> for Route {
    fn from(port: Port) -> Route {
        match port {
            Port::Usart => Route::Usart,
            Port::Usb => Route::Usb,
        }
    }
}

/// A received line (or a too-long line's event) and the port it came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Received {
    /// The port the line came in on.
    pub from: Port,
    /// The line, for [`crate::command::Device::handle`].
    pub event: LineEvent,
}

impl Received {
    /// Where the reply to this line goes: back to the port it came from.
    pub const fn reply_route(&self) -> Route {
        match self.from {
            Port::Usart => Route::Usart,
            Port::Usb => Route::Usb,
        }
    }
}

/// One port's line assembly: its own [`LineAssembler`], and the port every line it completes
/// is tagged with.
pub struct PortLines {
    port: Port,
    assembler: LineAssembler,
}

impl PortLines {
    /// An empty assembler for `port`.
    pub const fn new(port: Port) -> Self {
        PortLines { port, assembler: LineAssembler::new() }
    }

    /// The port.
    pub const fn port(&self) -> Port {
        self.port
    }

    /// Feeds one received byte; a completed line comes back with its port.
    pub fn push(&mut self, byte: u8) -> Option<Received> {
        self.assembler.push(byte).map(|event| Received { from: self.port, event })
    }
}

/// The replies waiting for each port's transmitter. A reply that finds its port's queue full
/// is dropped and counted for that port only.
pub struct Replies<const N: usize> {
    usart: Deque<Sentence, N>,
    usb: Deque<Sentence, N>,
    /// Replies dropped because USART2's queue was full.
    pub usart_dropped: u32,
    /// Replies for the USB port dropped: its queue was full, or no host had the port open
    /// when [`fan_out`] took them.
    pub usb_dropped: u32,
}

impl<const N: usize> Default for Replies<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Replies<N> {
    /// Empty queues.
    pub const fn new() -> Self {
        Replies { usart: Deque::new(), usb: Deque::new(), usart_dropped: 0, usb_dropped: 0 }
    }

    /// Queues `reply` for the ports of `route`.
    pub fn push(&mut self, reply: Sentence, route: Route) {
        if route.reaches(Port::Usb) && self.usb.push_back(reply.clone()).is_err() {
            self.usb_dropped = self.usb_dropped.saturating_add(1);
        }
        if route.reaches(Port::Usart) && self.usart.push_back(reply).is_err() {
            self.usart_dropped = self.usart_dropped.saturating_add(1);
        }
    }

    /// Replies waiting for `port`.
    pub fn waiting(&self, port: Port) -> usize {
        match port {
            Port::Usart => self.usart.len(),
            Port::Usb => self.usb.len(),
        }
    }

    /// Replies dropped for either port.
    pub fn dropped(&self) -> u32 {
        self.usart_dropped.saturating_add(self.usb_dropped)
    }
}

/// The USART side of a cycle's output: the application's DMA batch (`src/app/uart_tx.rs`).
pub trait UsartBatch {
    /// Bytes in the batch so far.
    fn len(&self) -> usize;
    /// True when nothing was added.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Appends `part` if it fits the buffer (else leaves the batch as it is: false).
    fn push(&mut self, part: &[u8]) -> bool;
    /// Counts a sentence that was not added.
    fn count_dropped(&mut self);
}

/// What [`UsbOut::offer`] did with a part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Offer {
    /// Queued whole.
    Queued,
    /// No host has configured the device: dropped.
    Closed,
    /// Not enough room: nothing of it queued.
    Full,
}

/// The bytes waiting for the USB serial port: a ring of `N` bytes that takes whole sentences
/// only (a host never sees half a sentence because the queue was full), filled by the filter
/// task through [`fan_out`] and drained by the USB task ([`UsbOut::peek`], [`UsbOut::consume`]).
pub struct UsbOut<const N: usize> {
    buf: [u8; N],
    head: usize,
    len: usize,
    open: bool,
    dtr: bool,
    /// Sentences dropped because no host had configured the device.
    pub dropped_closed: u32,
    /// Sentences dropped because the queue was full (a host has the port open but does not
    /// read it, or reads it slower than the output rate).
    pub dropped_full: u32,
}

impl<const N: usize> Default for UsbOut<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> UsbOut<N> {
    /// An empty queue, the port closed.
    pub const fn new() -> Self {
        UsbOut {
            buf: [0; N],
            head: 0,
            len: 0,
            open: false,
            dtr: false,
            dropped_closed: 0,
            dropped_full: 0,
        }
    }

    /// What the USB task sees of the host: whether it has configured the device, and DTR.
    /// Output is queued while configured. Losing the configuration (unplugged, reset,
    /// suspended) or a change of DTR (a program opened or closed the port) discards what was
    /// waiting, so that the next reader starts with fresh sentences. Returns true when a
    /// configured port's DTR changed: the packet the USB task may have armed for the old
    /// reader is stale too, and must be taken back (`app::usb`); without a configuration the
    /// endpoint has none.
    pub fn set_host(&mut self, configured: bool, dtr: bool) -> bool {
        let dtr = dtr && configured;
        let changed = configured && self.open && dtr != self.dtr;
        if !configured || dtr != self.dtr {
            self.head = 0;
            self.len = 0;
        }
        self.open = configured;
        self.dtr = dtr;
        changed
    }

    /// True while a host has configured the device: output is queued.
    pub const fn is_open(&self) -> bool {
        self.open
    }

    /// DTR as last set (false while not configured).
    pub const fn dtr(&self) -> bool {
        self.dtr
    }

    /// Bytes waiting.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True when nothing waits.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Room left, bytes.
    pub const fn free(&self) -> usize {
        N - self.len
    }

    /// Queues `part` whole, or nothing of it (the port closed, or not enough room). Never
    /// waits; the caller counts.
    pub fn offer(&mut self, part: &[u8]) -> Offer {
        if !self.open {
            return Offer::Closed;
        }
        if part.len() > self.free() {
            return Offer::Full;
        }
        let mut tail = (self.head + self.len) % N.max(1);
        for &b in part {
            if let Some(slot) = self.buf.get_mut(tail) {
                *slot = b;
            }
            tail = if tail + 1 == N { 0 } else { tail + 1 };
        }
        self.len += part.len();
        Offer::Queued
    }

    /// Copies the oldest waiting bytes into `out` without taking them (as many as fit, at most
    /// [`UsbOut::len`]); returns how many. With [`UsbOut::consume`], the USB task hands them to
    /// the serial port outside its lock on this queue, so the lock lasts a copy of `out.len()`
    /// bytes, whatever the serial port does.
    pub fn peek(&self, out: &mut [u8]) -> usize {
        let n = out.len().min(self.len);
        let mut at = self.head;
        for slot in out.iter_mut().take(n) {
            *slot = self.buf.get(at).copied().unwrap_or(0);
            at = if at + 1 == N { 0 } else { at + 1 };
        }
        n
    }

    /// Takes the `n` oldest bytes off the queue (those the serial port accepted after a
    /// [`UsbOut::peek`]); more than are waiting empties it.
    pub fn consume(&mut self, n: usize) {
        let n = n.min(self.len);
        self.len -= n;
        self.head = if self.len == 0 { 0 } else { (self.head + n) % N.max(1) };
    }
}

/// One cycle's output to both ports.
///
/// USART2 (when its previous transfer is over, `usart` is `Some`): `sentences`, then its
/// replies while the batch stays within `budget` bytes (what the USART sends in one filter
/// period; one reply always goes when the batch is otherwise empty); the replies that do not
/// fit wait. While the previous transfer runs (`usart` is `None`) its sentences are dropped
/// and their number returned; its replies wait.
///
/// The USB port: first its replies, while they fit [`UsbOut`] (the rest wait; all are dropped
/// and counted while the device is not configured), then `sentences`, each queued whole or
/// dropped and counted. The USB side is done after the USART side and cannot change it.
pub fn fan_out<'a, B, I, const R: usize, const U: usize>(
    usart: Option<&mut B>,
    sentences: I,
    replies: &mut Replies<R>,
    budget: usize,
    usb: &mut UsbOut<U>,
) -> u32
where
    B: UsartBatch,
    I: IntoIterator<Item = &'a Sentence>,
    I::IntoIter: Clone,
{
    let sentences = sentences.into_iter();
    let mut usart_busy = 0u32;
    match usart {
        Some(batch) => {
            for s in sentences.clone() {
                if !batch.push(s.as_bytes()) {
                    batch.count_dropped();
                }
            }
            while let Some(reply) = replies.usart.front() {
                let part = reply.as_bytes();
                let fits = batch.is_empty() || batch.len() + part.len() <= budget;
                if !fits || !batch.push(part) {
                    break;
                }
                replies.usart.pop_front();
            }
        }
        None => usart_busy = sentences.clone().count() as u32,
    }

    while let Some(reply) = replies.usb.front() {
        match usb.offer(reply.as_bytes()) {
            Offer::Queued => {}
            Offer::Closed => replies.usb_dropped = replies.usb_dropped.saturating_add(1),
            Offer::Full => break,
        }
        replies.usb.pop_front();
    }
    for s in sentences {
        match usb.offer(s.as_bytes()) {
            Offer::Queued => {}
            Offer::Closed => usb.dropped_closed = usb.dropped_closed.saturating_add(1),
            Offer::Full => usb.dropped_full = usb.dropped_full.saturating_add(1),
        }
    }
    usart_busy
}
