//! NMEA 0183 output: a fixed-capacity sentence buffer, the checksum, the Teledyne RDI
//! attitude sentence `$PRDID`, the proprietary full-state sentence `$PINAH`, the standard
//! marine sentences `HDT`, `HDG`, `HDM`, `ROT` and `XDR` ([`hdt`] and friends), and a checker
//! for received lines.
//!
//! A sentence is `$`, a body (address and comma-separated fields), `*`, two uppercase hex
//! digits of the XOR of every byte between `$` and `*`, and `\r\n`; at most 82 characters in
//! all. Numbers are printed by a small fixed-point writer ([`Sentence::push_fixed`]: scaled in
//! `f32`, rounded half away from zero by integer arithmetic, so the host and the Cortex-M3 print
//! the same bytes); NaN, infinite or out-of-range values leave their field empty.
//!
//! # `$PRDID` (Teledyne RDI)
//! `$PRDID,<pitch>,<roll>,<heading>*hh`, degrees with 2 decimals, explicit signs on pitch and
//! roll: see [`prdid`].
//!
//! # `$PINAH` (proprietary)
//! `P` = proprietary, `INA` = manufacturer mnemonic for iNEMO AHRS, `H` = sentence.
//!
//! `$PINAH,<roll>,<pitch>,<yaw>,<qw>,<qx>,<qy>,<qz>,<depth>,<status>,<cycle>*hh`
//!
//! 1. roll: °, 2 decimals, (−180, 180]; φ, positive starboard down.
//! 2. pitch: °, 2 decimals, [−90, 90]; θ, positive bow up.
//! 3. yaw: °, 2 decimals, (−180, 180]; ψ, positive clockwise from north (or the initial
//!    reference).
//! 4. qw: 4 decimals, [0, 1]; quaternion scalar part. `q` and `−q` are one attitude: the one
//!    with w ≥ 0 is sent, so w carries no sign.
//! 5. qx, 6. qy, 7. qz: 4 decimals, [−1, 1]; quaternion vector part. `q` rotates body (FRD)
//!    vectors into NED.
//! 8. depth: m, 1 decimal, −9.9 to 999.9; below the zeroed surface, positive down; empty when
//!    unknown.
//! 9. status: 6 uppercase hex digits; bits 0–15 are the cycle's `ekf_core::Flags`, bits 16–19
//!    board bits ([`Status`]: 16 I²C fault, 17 ADC fault, 18 gyro rail, 19 depth rail), bits
//!    20–21 the heading reference (20: true north by the operator's `YAW`, 21: true north by
//!    the magnetometer; neither: relative).
//! 10. cycle: µs, integer, 0–9999; time the filter cycle took (9999: 9999 µs or longer).
//!
//! Signs: `-` only (no `+`). A field is empty when its value is NaN or infinite; a quaternion
//! component beyond ±1.0000 and a depth outside −9.9 to 999.9 m are empty too. Example
//! (level, heading east, 12.3 m, accelerometer used and at rest, 1.234 ms, heading relative):
//! `$PINAH,0.00,0.00,90.00,0.7071,0.0000,0.0000,0.7071,12.3,000300,1234*hh`.
//!
//! The worst case, every field at its widest, is exactly 82 characters:
//! `$PINAH,-179.99,-89.99,-179.99,0.1234,-0.9876,-0.5432,-1.0000,-9.9,2FFFFF,9999*03\r\n`.
//! That budget is why the quaternion has 4 decimals (1e−4 ≈ 0.01° of rotation, the Euler
//! fields' resolution), the depth 1 decimal (the default 400 m sensor resolves about 0.1 m per
//! ADC count) and down to −9.9 m only (the sixth status digit, the heading reference, took
//! the place of the second digit of a negative depth: a depth above the zeroed surface is an
//! offset), and the cycle time 4 digits.

mod error;
mod marine;
mod number;
mod pinab;
mod pinah;
mod prdid;
mod sentence;
mod verify;

pub use crate::status::Status;

/// The field separator, as a predicate for `str::split`: `split(',')` would use `core`'s
/// `CharSearcher`, whose index check the compiler keeps (a panic path for the no-panic proof of
/// `scripts/size-report`); the predicate's searcher has none.
pub fn is_comma(c: char) -> bool {
    c == ','
}
pub use error::NmeaError;
pub use marine::{hdg, hdm, hdt, rot, xdr};
pub use number::{round_scaled, AngleRange, Sign, MAX_DECIMALS};
pub use pinab::pinab;
pub use pinah::{pinah, PinahData, PINAH_CYCLE_MAX_US};
pub use prdid::prdid;
pub use sentence::{checksum, is_body_byte, Sentence, MAX_BODY_LEN, MAX_SENTENCE_LEN};
pub use verify::verify;
