//! USART2 transmission by DMA1 channel 7, never blocking.
//!
//! The HAL's `WriteDma::write` takes the buffer by value and needs an `embedded-dma` buffer
//! type; a sentence batch is shorter than the buffer, so this drives the channel directly
//! through the HAL's public channel API with one static buffer: [`DmaTx::send`] copies the
//! batch in only when the previous transfer is over, otherwise drops the batch and counts it.

use core::sync::atomic::{compiler_fence, Ordering};

use inemo_ahrs::nmea::MAX_SENTENCE_LEN;
use stm32f1xx_hal::serial::TxDma2;

/// Buffer for one batch: the two sentences of a cycle at their longest.
pub const TX_BUF_LEN: usize = 2 * MAX_SENTENCE_LEN;

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
        if self.busy() {
            let n = parts.into_iter().count() as u32;
            self.dropped = self.dropped.saturating_add(n);
            return false;
        }
        // Channel disabled and its flags cleared: from here the DMA does not touch the buffer.
        self.dma.channel.stop();
        compiler_fence(Ordering::SeqCst);
        let mut len = 0;
        for part in parts {
            match self.buf.get_mut(len..len + part.len()) {
                Some(dst) => {
                    dst.copy_from_slice(part);
                    len += part.len();
                }
                None => self.dropped = self.dropped.saturating_add(1),
            }
        }
        if len == 0 {
            return false;
        }
        let ch = &mut self.dma.channel;
        ch.set_peripheral_address(self.dr, false);
        ch.set_memory_address(self.buf.as_ptr() as u32, true);
        ch.set_transfer_length(len);
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
        self.started = true;
        true
    }
}
