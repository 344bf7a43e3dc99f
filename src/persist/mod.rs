//! Persistent settings: a versioned, CRC-protected record in one of two alternating flash
//! pages, written so that a reset or power cut at any moment of a save leaves the last good
//! record readable.
//!
//! # Record layout (little-endian, offsets in bytes from the start of the page)
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 2 | commit word [`COMMIT`] = 0x5AA5, programmed LAST |
//! | 2 | 2 | format version [`FORMAT_VERSION`] |
//! | 4 | 4 | sequence number (wraps; the newer of two records is the one `b − a` (mod 2³²) < 2³¹ ahead) |
//! | 8 | 2 | payload length L, bytes |
//! | 10 | 2 | number of entries |
//! | 12 | L, padded to even | payload: entries `id: u16, len: u8, value: len bytes` ([`Setting::encode`](crate::registry::Setting::encode)) |
//! | 12 + L' | 4 | CRC-32 of bytes 2 .. 12 + L' (everything but the commit word) |
//!
//! A record is valid when the commit word is 0x5AA5, the version is known, the length fits
//! the page and the CRC matches. Entries carry the registry's stable ids, so a record written
//! by older or newer firmware stays readable: unknown ids and values that do not decode or
//! are out of range are skipped (counted in [`Loaded::skipped`]), settings without an entry
//! keep their defaults (counted in [`Loaded::missing`]).
//!
//! # Save
//! [`save`] writes to the page that does NOT hold the newest valid record: erase it, program
//! the header, payload and CRC half-word by half-word, then the commit word, then read the
//! record back. Until the commit word is written the new record is invalid and the newest
//! valid record (in the other page, untouched) is the one [`load`] returns; after it, the
//! new record has the higher sequence number. No write step touches the other page.
//!
//! # Load
//! [`load`] reads both pages and takes the valid record with the higher sequence number; if
//! neither is valid it returns the defaults and [`Source::Defaults`].
//!
//! # Flash
//! The store runs on any [`Flash`]: on the board [`f103::F103Flash`], the register-level
//! driver of the STM32F103RE's flash controller (host-tested against a model of it); in the
//! tests and the emulated firmware [`SimFlash`], in RAM.

mod crc;
pub mod f103;
mod flash;

pub use crc::{crc32, Crc32};
pub use flash::{Flash, FlashError, Page, SimFlash, SIM_PAGE_SIZE};

use crate::registry::SETTINGS;
use crate::settings::PipelineSettings;

/// Commit word: the record is complete.
pub const COMMIT: u16 = 0x5AA5;
/// Format version of the record written by this firmware.
pub const FORMAT_VERSION: u16 = 1;
/// Header size, bytes (commit, version, sequence, length, count).
pub const HEADER_LEN: usize = 12;
/// CRC size, bytes.
pub const CRC_LEN: usize = 4;
/// Largest value encoding, bytes (a vector of three `f32`).
const MAX_VALUE_LEN: usize = 12;

/// Where the settings in use came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Neither page holds a valid record: the defaults.
    Defaults,
    /// A valid record.
    Flash {
        /// The page holding it.
        page: Page,
        /// Its sequence number.
        seq: u32,
    },
}

/// Result of [`load`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loaded {
    /// The settings: the record's values over the defaults.
    pub settings: PipelineSettings,
    /// Where they came from.
    pub source: Source,
    /// Entries of the record that were skipped (unknown id, bad length, out of range).
    pub skipped: u16,
    /// Registry settings the record has no entry for (they keep their defaults).
    pub missing: u16,
}

/// Where [`save`] wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Saved {
    /// The page written.
    pub page: Page,
    /// The new record's sequence number.
    pub seq: u32,
}

/// Why [`save`] failed. The previous record is still valid in every case.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SaveError {
    /// A flash operation failed.
    Flash(FlashError),
    /// The record does not fit the page.
    TooLarge,
    /// The record read back is not valid.
    Verify,
}

impl From<FlashError> for SaveError {
    fn from(e: FlashError) -> Self {
        SaveError::Flash(e)
    }
}

/// True when sequence number `a` is newer than `b` (wrap-around safe).
pub const fn is_newer(a: u32, b: u32) -> bool {
    let d = a.wrapping_sub(b);
    d != 0 && d < 0x8000_0000
}

/// Header of a valid record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Header {
    seq: u32,
    len: usize,
    count: u16,
}

fn padded(len: usize) -> usize {
    len + (len & 1)
}

/// The header of `page` if it holds a valid record (commit word, version, length, CRC).
fn valid_header<F: Flash>(flash: &F, page: Page) -> Option<Header> {
    let mut h = [0u8; HEADER_LEN];
    flash.read(page, 0, &mut h).ok()?;
    let commit = u16::from_le_bytes([h[0], h[1]]);
    let version = u16::from_le_bytes([h[2], h[3]]);
    let seq = u32::from_le_bytes([h[4], h[5], h[6], h[7]]);
    let len = usize::from(u16::from_le_bytes([h[8], h[9]]));
    let count = u16::from_le_bytes([h[10], h[11]]);
    if commit != COMMIT || version != FORMAT_VERSION {
        return None;
    }
    let body_end = HEADER_LEN + padded(len);
    if body_end + CRC_LEN > flash.page_size() {
        return None;
    }
    let mut crc = Crc32::new();
    crc.update(&h[2..]);
    let mut chunk = [0u8; 32];
    let mut off = HEADER_LEN;
    while off < body_end {
        let n = (body_end - off).min(chunk.len());
        let part = chunk.get_mut(..n)?;
        flash.read(page, off, part).ok()?;
        crc.update(part);
        off += n;
    }
    let mut stored = [0u8; CRC_LEN];
    flash.read(page, body_end, &mut stored).ok()?;
    (crc.value() == u32::from_le_bytes(stored)).then_some(Header { seq, len, count })
}

/// The page holding the newest valid record, with its header.
fn newest<F: Flash>(flash: &F) -> Option<(Page, Header)> {
    match (valid_header(flash, Page::A), valid_header(flash, Page::B)) {
        (Some(a), Some(b)) => {
            if is_newer(b.seq, a.seq) {
                Some((Page::B, b))
            } else {
                Some((Page::A, a))
            }
        }
        (Some(a), None) => Some((Page::A, a)),
        (None, Some(b)) => Some((Page::B, b)),
        (None, None) => None,
    }
}

/// Load the settings: the newest valid record over the defaults, or the defaults. Never
/// fails; a read error makes a page invalid.
pub fn load<F: Flash>(flash: &F) -> Loaded {
    let mut loaded = Loaded {
        settings: PipelineSettings::default(),
        source: Source::Defaults,
        skipped: 0,
        missing: 0,
    };
    let Some((page, header)) = newest(flash) else {
        return loaded;
    };
    loaded.source = Source::Flash { page, seq: header.seq };
    let mut seen = [false; SETTINGS.len()];
    let end = HEADER_LEN + header.len;
    let mut off = HEADER_LEN;
    let mut entries = 0u16;
    while off + 3 <= end && entries < header.count {
        let mut eh = [0u8; 3];
        if flash.read(page, off, &mut eh).is_err() {
            break;
        }
        let id = u16::from_le_bytes([eh[0], eh[1]]);
        let len = usize::from(eh[2]);
        off += 3;
        if off + len > end {
            loaded.skipped = loaded.skipped.saturating_add(1);
            break;
        }
        let mut value = [0u8; MAX_VALUE_LEN];
        let decoded = value.get_mut(..len).and_then(|buf| {
            flash.read(page, off, buf).ok()?;
            let (index, setting) = SETTINGS.iter().enumerate().find(|(_, s)| s.id == id)?;
            Some((index, setting, setting.decode(buf)?))
        });
        match decoded {
            Some((index, setting, v)) if setting.set(&mut loaded.settings, v) => {
                if let Some(flag) = seen.get_mut(index) {
                    *flag = true;
                }
            }
            _ => loaded.skipped = loaded.skipped.saturating_add(1),
        }
        off += len;
        entries += 1;
    }
    loaded.missing = seen.iter().filter(|s| !**s).count() as u16;
    loaded
}

/// Writes bytes as half-words from an even offset, feeding a CRC.
struct Writer<'a, F: Flash> {
    flash: &'a mut F,
    page: Page,
    off: usize,
    pending: Option<u8>,
    crc: Crc32,
}

impl<F: Flash> Writer<'_, F> {
    fn bytes(&mut self, bytes: &[u8]) -> Result<(), FlashError> {
        self.crc.update(bytes);
        for &b in bytes {
            match self.pending.take() {
                None => self.pending = Some(b),
                Some(lo) => {
                    self.flash.program(self.page, self.off, u16::from_le_bytes([lo, b]))?;
                    self.off += 2;
                }
            }
        }
        Ok(())
    }

    /// Pad to a half-word with a zero byte (part of the CRC).
    fn pad(&mut self) -> Result<(), FlashError> {
        if self.pending.is_some() {
            self.bytes(&[0])?;
        }
        Ok(())
    }
}

/// The encoded payload length and entry count of `settings`.
fn payload_size(settings: &PipelineSettings) -> (usize, u16) {
    let mut len = 0;
    let mut buf = [0u8; MAX_VALUE_LEN];
    for s in SETTINGS.iter() {
        len += 3 + s.encode(&s.get(settings), &mut buf);
    }
    (len, SETTINGS.len() as u16)
}

/// Save `settings` as a new record in the page not holding the newest valid record (see the
/// module documentation). On error the previous record is still the one [`load`] returns,
/// except for [`SaveError::Verify`] after the commit word was written, where the new record
/// is not valid and the previous one is.
pub fn save<F: Flash>(flash: &mut F, settings: &PipelineSettings) -> Result<Saved, SaveError> {
    let (len, count) = payload_size(settings);
    if HEADER_LEN + padded(len) + CRC_LEN > flash.page_size() || len > usize::from(u16::MAX) {
        return Err(SaveError::TooLarge);
    }
    let (page, seq) = match newest(flash) {
        Some((p, h)) => (p.other(), h.seq.wrapping_add(1)),
        None => (Page::A, 1),
    };
    flash.erase(page)?;
    let mut w = Writer { flash, page, off: 2, pending: None, crc: Crc32::new() };
    w.bytes(&FORMAT_VERSION.to_le_bytes())?;
    w.bytes(&seq.to_le_bytes())?;
    w.bytes(&(len as u16).to_le_bytes())?;
    w.bytes(&count.to_le_bytes())?;
    let mut buf = [0u8; MAX_VALUE_LEN];
    for s in SETTINGS.iter() {
        let n = s.encode(&s.get(settings), &mut buf);
        w.bytes(&s.id.to_le_bytes())?;
        w.bytes(&[n as u8])?;
        w.bytes(buf.get(..n).unwrap_or(&[]))?;
    }
    w.pad()?;
    let crc = w.crc.value().to_le_bytes();
    let off = w.off;
    flash.program(page, off, u16::from_le_bytes([crc[0], crc[1]]))?;
    flash.program(page, off + 2, u16::from_le_bytes([crc[2], crc[3]]))?;
    flash.program(page, 0, COMMIT)?;
    match valid_header(flash, page) {
        Some(h) if h.seq == seq => Ok(Saved { page, seq }),
        _ => Err(SaveError::Verify),
    }
}

#[cfg(test)]
mod tests;
