//! The unit tests' check of `Display` text, without `alloc`: the text goes into a fixed buffer.

use core::fmt::{self, Display, Write};

struct Buf {
    bytes: [u8; 128],
    len: usize,
}

impl Write for Buf {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let end = self.len + s.len();
        self.bytes.get_mut(self.len..end).ok_or(fmt::Error)?.copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

/// Panics unless `v` displays as exactly `want` (at most 128 bytes).
#[track_caller]
pub fn assert_displays<T: Display>(v: T, want: &str) {
    let mut b = Buf { bytes: [0; 128], len: 0 };
    write!(b, "{v}").expect("the text fits in 128 bytes");
    assert_eq!(core::str::from_utf8(&b.bytes[..b.len]), Ok(want));
}
