//! The Python package (`crates/python`, installed with `pip install ./crates/python`): its
//! pytest suite, run against this build of the `chessarm` binary (`CHESSARM_BIN`), so the
//! Python numbers are checked against the CLI's. CI installs the package into its virtual
//! environment (`CHESSARM_PYTHON`); without it the test harness counts this test as ignored.

#![allow(clippy::unwrap_used)]

use std::path::Path;
use std::process::Command;

/// The Python that has the `chessarm` package and pytest (CI's `CHESSARM_PYTHON`).
fn python_with_chessarm() -> Option<String> {
    let candidates = std::env::var("CHESSARM_PYTHON").into_iter().chain(["python3".to_string()]);
    candidates.into_iter().find(|python| {
        Command::new(python).args(["-c", "import chessarm, pytest"]).output().is_ok_and(|o| o.status.success())
    })
}

#[test]
#[cfg_attr(not(tool_python), ignore = "needs CHESSARM_PYTHON, a Python with the chessarm package; see docs/testing.md")]
fn the_python_packages_tests_pass_against_this_cli() {
    let python = python_with_chessarm().expect("CHESSARM_PYTHON (or python3) with the chessarm package and pytest");
    let tests = Path::new(env!("CARGO_MANIFEST_DIR")).join("../python/tests");
    let output = Command::new(&python)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "-rs"])
        .arg(&tests)
        .env("CHESSARM_BIN", env!("CARGO_BIN_EXE_chessarm"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "pytest failed:\n{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    // Every test ran: none skipped (CHESSARM_BIN is set here).
    assert!(!stdout.contains("skipped"), "{stdout}");
    assert!(stdout.contains(" passed"), "{stdout}");
}
