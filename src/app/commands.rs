//! The command path's shared state: received lines (USART2 RX interrupt → command task),
//! and the [`Device`] with the replies and actions waiting for the filter task.
//!
//! Both queues are fixed rings; when one is full the new item is dropped and counted.

use inemo_ahrs::command::{Action, Device, LineEvent};
use inemo_ahrs::nmea::Sentence;

/// Lines the RX interrupt can queue before the command task takes them.
pub const LINE_SLOTS: usize = 4;
/// Replies waiting for the transmitter.
pub const REPLY_SLOTS: usize = 4;

/// A bounded FIFO of `N` items; a push to a full ring drops the item and counts it.
pub struct Ring<T, const N: usize> {
    items: [Option<T>; N],
    head: usize,
    len: usize,
    /// Items dropped because the ring was full.
    pub dropped: u32,
}

impl<T, const N: usize> Default for Ring<T, N> {
    fn default() -> Self {
        Ring { items: core::array::from_fn(|_| None), head: 0, len: 0, dropped: 0 }
    }
}

impl<T, const N: usize> Ring<T, N> {
    /// Appends `item`, or drops it (counted) when full.
    pub fn push(&mut self, item: T) {
        if self.len >= N {
            self.dropped = self.dropped.saturating_add(1);
            return;
        }
        if let Some(slot) = self.items.get_mut((self.head + self.len) % N) {
            *slot = Some(item);
            self.len += 1;
        }
    }

    /// The oldest item.
    pub fn peek(&self) -> Option<&T> {
        self.items.get(self.head).and_then(Option::as_ref)
    }

    /// Removes the oldest item.
    pub fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        let item = self.items.get_mut(self.head).and_then(Option::take);
        self.head = (self.head + 1) % N;
        self.len -= 1;
        item
    }

    /// True when nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Lines from the RX interrupt, with its error count.
#[derive(Default)]
pub struct RxLines {
    /// Complete lines (or overflows) not yet executed.
    pub lines: Ring<LineEvent, LINE_SLOTS>,
    /// USART receive errors (overrun, framing, noise, parity).
    pub errors: u32,
}

/// What the filter task must do at its next cycle for the commands executed since its last.
#[derive(Clone, Copy, Debug, Default)]
pub struct Pending {
    /// `pipeline.apply_settings(*device.settings())`; `Some(true)` when the filter rate
    /// changed too.
    pub apply: Option<bool>,
    /// Set the yaw, rad.
    pub yaw: Option<f32>,
}

impl Pending {
    /// Adds an action (several settings changes merge into one).
    pub fn add(&mut self, action: Action) {
        match action {
            Action::ApplySettings { filter_rate_changed } => {
                self.apply = Some(self.apply.unwrap_or(false) | filter_rate_changed)
            }
            Action::SetYaw(yaw) => self.yaw = Some(yaw),
        }
    }
}

/// Shared by the command task and the filter task.
pub struct CommandState {
    /// The device: settings in use, calibrations, raw mode.
    pub device: Device,
    /// Actions for the filter task.
    pub pending: Pending,
    /// Replies for the transmitter (sent by the filter task with its sentences).
    pub replies: Ring<Sentence, REPLY_SLOTS>,
}

impl CommandState {
    /// The state for a freshly booted `device`.
    pub fn new(device: Device) -> Self {
        CommandState { device, pending: Pending::default(), replies: Ring::default() }
    }

    /// Queues a reply and records an action, as a command or a cycle produced them.
    pub fn record(&mut self, reply: Option<Sentence>, action: Option<Action>) {
        if let Some(r) = reply {
            self.replies.push(r);
        }
        if let Some(a) = action {
            self.pending.add(a);
        }
    }
}
