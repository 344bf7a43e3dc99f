//! Checking a received sentence.

use super::error::NmeaError;
use super::sentence::{checksum, is_body_byte, MAX_SENTENCE_LEN};

fn hex_value(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'A'..=b'F' => Some(b - b'A' + 10),
        b'a'..=b'f' => Some(b - b'a' + 10),
        _ => None,
    }
}

/// Check one line as an NMEA 0183 sentence and return its body (the text between `$` and
/// `*`, e.g. `PRDID,+1.23,-0.45,359.99`).
///
/// The line is `$`, the body, `*`, two hex digits (either case accepted) and optionally a
/// line end (`\r\n`, or a lone `\n` or `\r` as terminals send). It may be at most 82
/// characters counted with a `\r\n` line end; the body may hold only printable ASCII other
/// than `$ * ! \ ^ ~`; the checksum must be the XOR of the body's bytes.
pub fn verify(line: &[u8]) -> Result<&str, NmeaError> {
    let line = line
        .strip_suffix(b"\r\n")
        .or_else(|| line.strip_suffix(b"\n"))
        .or_else(|| line.strip_suffix(b"\r"))
        .unwrap_or(line);
    if line.len() + 2 > MAX_SENTENCE_LEN {
        return Err(NmeaError::TooLong);
    }
    let Some(rest) = line.strip_prefix(b"$") else {
        return Err(NmeaError::MissingStart);
    };
    let (body, received) = match rest {
        [body @ .., b'*', hi, lo] => match (hex_value(*hi), hex_value(*lo)) {
            (Some(hi), Some(lo)) => (body, (hi << 4) | lo),
            _ => return Err(NmeaError::MissingChecksum),
        },
        _ => return Err(NmeaError::MissingChecksum),
    };
    if !body.iter().all(|&b| is_body_byte(b)) {
        return Err(NmeaError::InvalidChar);
    }
    let computed = checksum(body);
    if computed != received {
        return Err(NmeaError::BadChecksum { computed, received });
    }
    core::str::from_utf8(body).map_err(|_| NmeaError::InvalidChar)
}

#[cfg(test)]
mod tests {
    use super::*;

    const GGA: &[u8] = b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47";

    #[test]
    fn published_gga_checks() {
        let body = "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,";
        assert_eq!(verify(GGA), Ok(body));
        let mut crlf = GGA.to_vec();
        crlf.extend_from_slice(b"\r\n");
        assert_eq!(verify(&crlf), Ok(body));
        let mut lf = GGA.to_vec();
        lf.push(b'\n');
        assert_eq!(verify(&lf), Ok(body));
        // Lowercase hex digits are accepted on input.
        assert_eq!(verify(b"$JP*1a"), Ok("JP"));
    }

    #[test]
    fn errors() {
        let mut bad = GGA.to_vec();
        *bad.last_mut().unwrap() = b'8';
        assert_eq!(verify(&bad), Err(NmeaError::BadChecksum { computed: 0x47, received: 0x48 }));
        assert_eq!(verify(&GGA[1..]), Err(NmeaError::MissingStart));
        assert_eq!(verify(&GGA[..GGA.len() - 1]), Err(NmeaError::MissingChecksum));
        assert_eq!(verify(&GGA[..GGA.len() - 3]), Err(NmeaError::MissingChecksum));
        assert_eq!(verify(b"$A*4G"), Err(NmeaError::MissingChecksum));
        assert_eq!(verify(b"$*"), Err(NmeaError::MissingChecksum));
        assert_eq!(verify(b""), Err(NmeaError::MissingStart));
        assert_eq!(verify(b"$A\tB*00"), Err(NmeaError::InvalidChar));
        assert_eq!(verify(b"$A$B*00"), Err(NmeaError::InvalidChar));
        assert_eq!(verify(b"$*00"), Ok(""));
        // 80 characters before the line end is the limit; 81 is too long.
        let mut long = [b'A'; 80];
        long[0] = b'$';
        long[77] = b'*';
        let body_cs = checksum(&long[1..77]);
        long[78] = super::super::sentence::hex_digit(body_cs >> 4);
        long[79] = super::super::sentence::hex_digit(body_cs);
        assert!(verify(&long).is_ok());
        let mut longer = long.to_vec();
        longer.insert(1, b'A');
        assert_eq!(verify(&longer), Err(NmeaError::TooLong));
    }
}
