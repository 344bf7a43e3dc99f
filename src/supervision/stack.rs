//! The stack's high-water mark, measured: the free stack is painted with [`PAINT`] at boot,
//! and the deepest the stack has been is where the paint ends.
//!
//! The stack grows down from the top of RAM (`_stack_start`) towards the end of the static
//! data (`_stack_end`, cortex-m-rt's `link.x`). The firmware paints `_stack_end` up to a little
//! below its stack pointer in `init`; [`used_bytes`] scans from `_stack_end` upwards for the
//! first word that is not the paint: everything above it has been stack at some time (a
//! value that happens to equal the paint inside the used part does not matter: the scan stops
//! at the lowest overwritten word).

/// The paint (not a plausible address, pointer or small integer).
pub const PAINT: u32 = 0xACAC_ACAC;

/// Bytes of a stack region of `words` words (index 0 at the lowest address) that have been
/// used: `read(i)` reads word `i`.
pub fn used_bytes(words: usize, mut read: impl FnMut(usize) -> u32) -> usize {
    let untouched = (0..words).take_while(|&i| read(i) == PAINT).count();
    (words - untouched) * 4
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stack region of `n` words painted, then a call chain that went down to word `low`
    /// (writing what a program writes: return addresses, locals; one local equal to the
    /// paint by chance).
    fn stack(n: usize, low: usize) -> Vec<u32> {
        let mut s = vec![PAINT; n];
        for (i, w) in s.iter_mut().enumerate().skip(low) {
            *w = if i == low + 3 { PAINT } else { 0x0800_0000 + i as u32 };
        }
        s
    }

    #[test]
    fn the_deepest_word_written_is_the_mark() {
        let s = stack(1000, 700);
        assert_eq!(used_bytes(s.len(), |i| s[i]), 300 * 4);
        // Only the lowest overwritten word counts, whatever lies above it.
        let s = stack(1000, 10);
        assert_eq!(used_bytes(s.len(), |i| s[i]), 990 * 4);
    }

    #[test]
    fn untouched_and_overflowed_stacks() {
        let s = vec![PAINT; 64];
        assert_eq!(used_bytes(s.len(), |i| s[i]), 0);
        // Down to the static data: all of it used (the stack may have overflowed).
        let s = stack(64, 0);
        assert_eq!(used_bytes(s.len(), |i| s[i]), 256);
        assert_eq!(used_bytes(0, |_| 0), 0);
    }
}
