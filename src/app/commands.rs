//! The command path's shared state: the received lines go from the USART2 RX interrupt and
//! the USB task to the command task through one `rtic-sync` channel ([`LINE_SLOTS`] deep,
//! created in `init`), each tagged with its port ([`Received`]); the [`Device`], with the
//! replies (a queue per port, [`Replies`]) and actions waiting for the filter task, is shared
//! between the command and filter tasks. A line or reply that finds its queue full is dropped
//! and counted.

use inemo_ahrs::command::{Action, Device};
use inemo_ahrs::console::{Replies, Route};
use inemo_ahrs::nmea::Sentence;

/// What the command channel carries.
pub use inemo_ahrs::console::Received;

/// Lines the RX interrupt can queue before the command task takes them.
pub const LINE_SLOTS: usize = 4;
/// Replies waiting for each port's transmitter.
pub const REPLY_SLOTS: usize = 4;

/// The RX interrupt's counters.
#[derive(Clone, Copy, Debug, Default)]
pub struct RxStats {
    /// USART receive errors (overrun, framing, noise, parity).
    pub errors: u32,
    /// Lines (from either port) dropped because the command task's channel was full.
    pub dropped: u32,
}

/// What the filter task must do at its next cycle for the commands executed since its last.
#[derive(Clone, Copy, Debug, Default)]
pub struct Pending {
    /// `pipeline.apply_settings(*device.settings())`; `Some(true)` when the filter rate
    /// changed too.
    pub apply: Option<bool>,
    /// Restart the estimator (`RAW,2`), before the yaw.
    pub restart: bool,
    /// Set the yaw, rad (after the restart: a yaw that came before a restart is dropped).
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
            Action::RestartEstimator => {
                self.restart = true;
                self.yaw = None;
            }
        }
    }
}

/// Shared by the command task and the filter task.
pub struct CommandState {
    /// The device: settings in use, calibrations, raw mode.
    pub device: Device,
    /// Actions for the filter task.
    pub pending: Pending,
    /// Replies for the transmitters (sent by the filter task with its sentences).
    pub replies: Replies<REPLY_SLOTS>,
}

impl CommandState {
    /// The state for a freshly booted `device`.
    pub fn new(device: Device) -> Self {
        CommandState { device, pending: Pending::default(), replies: Replies::new() }
    }

    /// Queues a reply for the ports of `route` and records an action, as a command or a
    /// cycle produced them.
    pub fn record(&mut self, reply: Option<Sentence>, route: Route, action: Option<Action>) {
        if let Some(r) = reply {
            self.replies.push(r, route);
        }
        if let Some(a) = action {
            self.pending.add(a);
        }
    }
}
