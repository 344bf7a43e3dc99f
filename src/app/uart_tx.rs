//! USART2 transmission by DMA1 channel 7, never blocking.
//!
//! The HAL's `WriteDma::write` takes the buffer by value and needs an `embedded-dma` buffer
//! type; a sentence batch is shorter than the buffer, so this drives the channel directly
//! through the HAL's public channel API with one static buffer: [`DmaTx::send`] copies the
//! batch in only when the previous transfer is over, otherwise drops the batch and counts it.
//! [`DmaTx::begin`] gives a [`Batch`] to fill part by part (the cycle's sentences, then
//! command replies while they fit).

use core::sync::atomic::{compiler_fence, Ordering};

use inemo_ahrs::console::UsartBatch;
use inemo_ahrs::nmea::MAX_SENTENCE_LEN;
use inemo_ahrs::pipeline::MAX_SENTENCES;
use stm32f1xx_hal::serial::TxDma2;

/// Buffer for one batch: the sentences of a cycle at their longest and one command reply.
pub const TX_BUF_LEN: usize = (MAX_SENTENCES + 1) * MAX_SENTENCE_LEN;
const _: () = assert!(TX_BUF_LEN <= u16::MAX as usize, "DMA transfer length is 16 bits");

/// The transmitter and its counters.
pub struct DmaTx {
    dma: TxDma2,
    buf: &'static mut [u8; TX_BUF_LEN],
    /// Address of USART2's data register.
    dr: u32,
    /// A transfer was started and not yet seen complete.
    started: bool,
    /// Sentences dropped because the previous transfer was still running.
    pub dropped: u32,
    /// Transfers ended by a DMA transfer error.
    pub errors: u32,
}

impl DmaTx {
    /// A transmitter on `dma` (USART2 TX with its DMA request enabled) writing to the data
    /// register at `dr`.
    pub fn new(dma: TxDma2, buf: &'static mut [u8; TX_BUF_LEN], dr: u32) -> Self {
        DmaTx { dma, buf, dr, started: false, dropped: 0, errors: 0 }
    }

    /// True while the DMA may still read the buffer.
    pub fn busy(&mut self) -> bool {
        if !self.started {
            return false;
        }
        // A transfer error clears EN in hardware and never sets TCIF.
        if self.dma.channel.ch().cr().read().en().bit_is_clear() {
            self.errors = self.errors.saturating_add(1);
            self.started = false;
            return false;
        }
        if self.dma.channel.in_progress() {
            return true;
        }
        self.started = false;
        false
    }

    /// Starts sending `parts` back to back, or drops them (counted in [`DmaTx::dropped`])
    /// if the previous transfer is still running. Parts that do not fit the buffer are
    /// dropped too. Returns whether the batch was started.
    pub fn send<'a>(&mut self, parts: impl IntoIterator<Item = &'a [u8]>) -> bool {
        let Some(mut batch) = self.begin() else {
            let n = parts.into_iter().count() as u32;
            self.dropped = self.dropped.saturating_add(n);
            return false;
        };
        for part in parts {
            if !batch.push(part) {
                batch.count_dropped();
            }
        }
        batch.start()
    }

    /// A new batch to fill, or `None` while the previous transfer is still running.
    pub fn begin(&mut self) -> Option<Batch<'_>> {
        if self.busy() {
            return None;
        }
        // Channel disabled and its flags cleared: from here the DMA does not touch the buffer.
        self.dma.channel.stop();
        compiler_fence(Ordering::SeqCst);
        Some(Batch { tx: self, len: 0 })
    }
}

/// A batch being copied into the buffer; [`Batch::start`] sends it.
pub struct Batch<'t> {
    tx: &'t mut DmaTx,
    len: usize,
}

/// What the console's fan-out fills (`inemo_ahrs::console::fan_out`).
impl UsartBatch for Batch<'_> {
    fn len(&self) -> usize {
        self.len
    }

    fn push(&mut self, part: &[u8]) -> bool {
        match self.tx.buf.get_mut(self.len..self.len + part.len()) {
            Some(dst) => {
                dst.copy_from_slice(part);
                self.len += part.len();
                true
            }
            None => false,
        }
    }

    fn count_dropped(&mut self) {
        self.tx.dropped = self.tx.dropped.saturating_add(1);
    }
}

impl Batch<'_> {
    /// Starts the transfer (nothing when the batch is empty). Returns whether it started.
    pub fn start(self) -> bool {
        let len = self.len;
        let tx = self.tx;
        if len == 0 {
            return false;
        }
        let ch = &mut tx.dma.channel;
        ch.set_peripheral_address(tx.dr, false);
        ch.set_memory_address(tx.buf.as_ptr() as u32, true);
        // The HAL's `set_transfer_length` unwraps a `u16::try_from` (and pulls `core::fmt` in);
        // `len` ≤ TX_BUF_LEN < 2^16 (asserted at compile time).
        ch.ch().ndtr().write(|w| w.ndt().set(len as u16));
        compiler_fence(Ordering::Release);
        ch.ch().cr().modify(|_, w| {
            w.mem2mem().clear_bit();
            w.pl().medium();
            w.msize().bits8();
            w.psize().bits8();
            w.circ().clear_bit();
            w.dir().set_bit()
        });
        ch.start();
        tx.started = true;
        true
    }
}
