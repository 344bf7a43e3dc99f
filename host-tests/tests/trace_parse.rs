//! The trace reader through the public API, on files.

use host_tests::trace::{read_estimate_file, read_trace_file, TraceError};

fn write(text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.csv");
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

#[test]
fn reads_a_board_style_trace_with_extras() {
    let (_d, path) = write(
        "# captured on the bench\nseq, t ,ax,ay,az,gx,gy,gz,depth,temp\n\
         1,0.000,0.01,-0.02,-9.79,0.028,0.06,0.0,1.25,21.5\n\
         2,0.020,0.01,-0.02,-9.80,0.028,0.06,0.0,,21.5\n\n\
         3,0.045,0.01,-0.02,-9.81,0.028,0.06,0.0,1.5,21.6\n",
    );
    let (cols, rows) = read_trace_file(&path).unwrap();
    assert!(cols.depth && !cols.mag && !cols.truth);
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[2].t, 0.045);
    assert_eq!(rows[0].accel, [0.01, -0.02, -9.79]);
    assert_eq!(rows[0].gyro, [0.028, 0.06, 0.0]);
    assert_eq!(rows[1].depth, None);
    assert_eq!(rows[2].depth, Some(1.5));
}

#[test]
fn errors_carry_line_and_column() {
    let cases: [(&str, usize, &str); 6] = [
        ("t,gx,gy,gz,ax,ay\n", 1, "az"),
        ("#c\nt,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n0.1,0,0,0,0,1.2.3,0\n", 4, "ay"),
        ("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n0.1,nan,0,0,0,0,0\n", 3, "gx"),
        ("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n-0.1,0,0,0,0,0,0\n", 3, "t"),
        ("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n0.1,0,0,0,0\n", 3, "ay"),
        ("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,-1e39\n", 2, "az"),
    ];
    for (text, line, column) in cases {
        let (_d, path) = write(text);
        let e = read_trace_file(&path).unwrap_err();
        assert_eq!(e.line(), Some(line), "{text:?}: {e}");
        assert_eq!(e.column(), Some(column), "{text:?}: {e}");
        let msg = e.to_string();
        assert!(msg.contains(&format!("line {line}")) && msg.contains(column), "{msg}");
        assert!(!msg.contains('\n'));
    }
    let (_d, path) = write("");
    assert!(matches!(read_trace_file(&path).unwrap_err(), TraceError::NoHeader));
    let missing = std::path::Path::new("/nonexistent/trace.csv");
    assert!(matches!(read_trace_file(missing).unwrap_err(), TraceError::Io(_)));
}

#[test]
fn estimate_files_need_their_columns() {
    let (_d, path) = write("t,qw,qx,qy,qz,roll,pitch\n");
    let e = read_estimate_file(&path).unwrap_err();
    assert_eq!(e.column(), Some("yaw"));
    let (_d, path) = write("t,qw,qx,qy,qz,roll,pitch,yaw\n0,1,0,0,0,0,0,0\n");
    let rows = read_estimate_file(&path).unwrap();
    assert_eq!(rows.len(), 1);
    assert!(rows[0].bias_dps[0].is_nan());
    assert_eq!(rows[0].flags, 0);
}

/// Issue #14: a UTF-8 byte-order mark (Excel's "CSV UTF-8") before the header is not part of
/// the first column's name; a number beyond the f32 range says so.
#[test]
fn a_byte_order_mark_is_not_part_of_the_first_name() {
    let (_d, path) = write("\u{feff}t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,-9.8\n0.02,0,0,0,0,0,-9.8\n");
    let (_, rows) = read_trace_file(&path).unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1].t, 0.02);
    let (_d, path) = write("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1e300\n");
    let e = read_trace_file(&path).unwrap_err().to_string();
    assert!(e.contains("line 2") && e.contains("'az'") && e.contains("f32 range"), "{e}");
}
