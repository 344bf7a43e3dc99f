//! `scripts/test-summary`, the last line of `scripts/test-all` (issue #30): the counts come from
//! the runners' own result lines, cargo's libtest and Python's unittest, passed, failed and
//! ignored (skipped) alike; a log with no result line is an error, not a pass.

use std::path::PathBuf;
use std::process::Command;

fn summary(logs: &[&str]) -> (Option<i32>, String, String) {
    let dir = tempfile::tempdir().unwrap();
    let paths: Vec<PathBuf> = logs
        .iter()
        .enumerate()
        .map(|(i, text)| {
            let p = dir.path().join(format!("{i}.log"));
            std::fs::write(&p, text).unwrap();
            p
        })
        .collect();
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scripts/test-summary");
    let o = Command::new("bash").arg(script).args(&paths).output().unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (o.status.code(), text(&o.stdout), text(&o.stderr))
}

const CARGO: &str = "\
running 3 tests
test a ... ok
test result: ok. 12 passed; 0 failed; 3 ignored; 0 measured; 0 filtered out; finished in 0.01s

   Doc-tests ekf_core
test result: ok. 0 passed; 0 failed; 0 ignored; 0 measured; 0 filtered out; finished in 0.00s
test result: FAILED. 7 passed; 2 failed; 1 ignored; 0 measured; 0 filtered out; finished in 1s
";

const PYTHON_OK: &str = "\
== cycle model cross-checks
......
----------------------------------------------------------------------
Ran 6 tests in 0.412s

OK
";

const PYTHON_FAILED: &str = "\
Ran 6 tests in 0.412s

FAILED (failures=1, errors=1, skipped=1)
";

#[test]
fn sums_cargo_and_python_passed_failed_and_ignored() {
    let (code, out, _) = summary(&[CARGO, PYTHON_OK]);
    assert_eq!(code, Some(0));
    assert_eq!(
        out.trim_end(),
        "tests: 25 passed, 2 failed, 4 ignored (cargo: 19/2/4; Python unittest: 6/0/0)"
    );
    let (code, out, _) = summary(&[CARGO, PYTHON_FAILED]);
    assert_eq!(code, Some(0));
    assert_eq!(
        out.trim_end(),
        "tests: 22 passed, 4 failed, 5 ignored (cargo: 19/2/4; Python unittest: 3/2/1)"
    );
    let (_, out, _) = summary(&["Ran 2 tests in 0.1s\n\nOK (skipped=1)\n"]);
    assert!(out.starts_with("tests: 1 passed, 0 failed, 1 ignored"), "{out}");
}

#[test]
fn a_log_without_results_is_an_error() {
    let (code, out, err) = summary(&[CARGO, "error: could not compile `ekf-core`\n"]);
    assert_eq!(code, Some(1));
    assert!(out.starts_with("tests: 19 passed, 2 failed, 4 ignored"), "{out}");
    assert!(err.contains("no test result in") && err.contains("1.log"), "{err}");
    let (code, _, err) = summary(&[]);
    assert_eq!(code, Some(2), "{err}");
}
