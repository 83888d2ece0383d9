//! Issue 10's findings, each as a regression test: output that cannot be written, runaway
//! work, files chessarm must not touch, silently accepted input and messages.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;
use common::{assert_one_line_error, chessarm};

use std::process::{Command, Stdio};

/// Runs chessarm with its standard output on a pipe whose reader is already closed, so the
/// first write fails with EPIPE whatever the timing.
fn with_closed_stdout(args: &[&str]) -> std::process::Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    Command::new(env!("CARGO_BIN_EXE_chessarm"))
        .args(args)
        .stdout(Stdio::from(writer))
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

/// Runs chessarm with its standard output on `/dev/full` (every write fails with ENOSPC).
fn with_full_stdout(args: &[&str]) -> std::process::Output {
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
    Command::new(env!("CARGO_BIN_EXE_chessarm"))
        .args(args)
        .stdout(Stdio::from(full))
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

#[test]
fn a_closed_stdout_ends_quietly() {
    for args in [&["urdf"][..], &["arm"], &["fk", "--q", "0,0,0,0"], &["ik", "--square", "d4"]] {
        let output = with_closed_stdout(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(0), "{args:?}: {stderr}");
        assert!(stderr.is_empty(), "{args:?} said: {stderr}");
    }
}

#[test]
fn a_full_stdout_is_an_error_not_a_panic_nor_a_success() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    let out = out.to_str().unwrap();
    for args in [
        &["urdf"][..],
        &["arm"],
        &["fk", "--q", "0,0,0,0"],
        &["ik", "--square", "d4"],
        &["dynamics", "--q", "0,0.5,0,0"],
        &["plan", "--out", out],
    ] {
        let output = with_full_stdout(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: {stderr}");
        assert!(stderr.contains("cannot write to standard output") && !stderr.contains("panicked"), "{stderr}");
    }
}

#[test]
fn work_that_cannot_fit_in_memory_is_refused_before_it_starts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let started = std::time::Instant::now();
    assert_one_line_error(&chessarm(&["plan", "--dt", "1.3e-7", "--out", out]), &["--dt 1.3e-7", "GB"]);
    assert_one_line_error(
        &chessarm(&["simulate", "--dt", "1e-7", "--control-rate", "1e7", "--out", out]),
        &["--dt 1e-7", "--control-rate 10000000", "GB"],
    );
    // Refused from the estimate, not after trying: far below the time to fill gigabytes.
    assert!(started.elapsed().as_secs_f64() < 20.0);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "nothing written");
}

#[test]
fn threads_are_bounded_and_the_flag_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let sweep = ["tune", "--kp", "100..200:2", "--kd", "20..30:2", "--out", out, "--threads"];
    assert_one_line_error(&chessarm(&[&sweep[..], &["4294967295"]].concat()), &["--threads 4294967295", "per core"]);
    assert_one_line_error(&chessarm(&[&sweep[..], &["0"]].concat()), &["--threads 0"]);
}

#[test]
fn rates_errors_name_the_flags_as_typed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    assert_one_line_error(
        &chessarm(&["simulate", "--dt", "0.01", "--out", out]),
        &["--control-rate 1000", "--dt 0.01"],
    );
    assert_one_line_error(
        &chessarm(&["simulate", "--control-rate", "1e-320", "--out", out]),
        &["--control-rate 1e-320"],
    );
}
