//! The trace reader under libFuzzer: a standard header (`t,gx,gy,gz,ax,ay,az`) and the input as
//! the rows. The oracle: no panic; an error names its line; every row read is the file's line
//! split, trimmed and parsed by a second implementation here, bit for bit (the reader parses
//! numbers with `str::parse` too since issue #14, so this pins its line, comment and cell
//! rules).
#![no_main]

use std::io::Cursor;

use host_tests::trace::TraceReader;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut file = b"t,gx,gy,gz,ax,ay,az\n".to_vec();
    file.extend_from_slice(data);
    let Ok(mut reader) = TraceReader::new(Cursor::new(&file[..])) else { return };
    // The data lines that are not comments or blank, in order, as the reader should see them.
    let text = String::from_utf8_lossy(data);
    let mut lines = text.split('\n').map(|l| l.trim_end_matches('\r')).filter(|l| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('#')
    });
    loop {
        match reader.next_row() {
            Ok(Some(row)) => {
                let Some(line) = lines.next() else { panic!("a row without a line: {row:?}") };
                let f: Vec<&str> = line.split(',').map(str::trim).collect();
                assert_eq!(f.len(), 7, "{line:?} read as {row:?}");
                let t: f64 = f[0].parse().expect("t parses");
                assert_eq!(row.t.to_bits(), t.to_bits(), "t of {line:?}");
                for i in 0..3 {
                    let g: f32 = f[1 + i].parse().expect("gyro parses");
                    let a: f32 = f[4 + i].parse().expect("accel parses");
                    assert_eq!(row.gyro[i].to_bits(), g.to_bits(), "gyro {i} of {line:?}");
                    assert_eq!(row.accel[i].to_bits(), a.to_bits(), "accel {i} of {line:?}");
                }
            }
            Ok(None) => break,
            Err(e) => {
                let msg = e.to_string();
                assert!(msg.starts_with("line ") || msg.contains("line"), "{msg}");
                break;
            }
        }
    }
});
