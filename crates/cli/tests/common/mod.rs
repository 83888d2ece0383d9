//! Helpers shared by the command-line tests.

#![allow(clippy::unwrap_used, dead_code)] // test helpers; not every test file uses every one

use serde_json::Value;
use std::process::{Command, Output};

/// Runs the `chessarm` binary with `args` and `--json` (the machine-readable result, which
/// these tests read; `--json` is global, so every command takes it).
pub fn chessarm(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_chessarm")).args(args).arg("--json").output().expect("the binary runs")
}

/// Runs the `chessarm` binary with `args` as typed: the summary for people on stdout.
pub fn chessarm_human(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_chessarm")).args(args).output().expect("the binary runs")
}

/// Standard output as JSON, after checking the command succeeded.
pub fn json_of(output: &Output) -> Value {
    assert!(output.status.success(), "stderr: {}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).expect("stdout is JSON")
}

/// A JSON file, read.
pub fn json_file(path: &std::path::Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// The path of the chess crate's test fixture `name` (PGN games).
pub fn chess_fixture(name: &str) -> String {
    format!("{}/../chess/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// The Opera Game (Morphy, 1858), a whole game of 33 plies.
pub const OPERA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../chess/tests/fixtures/opera_game.pgn");

/// `chessarm play <args…> --out <out>`, which must succeed: its game.json.
pub fn play_game(out: &std::path::Path, args: &[&str]) -> Value {
    json_of(&chessarm(&[&["play"], args, &["--out", out.to_str().unwrap()]].concat()));
    json_file(&out.join("game.json"))
}

/// Exit code 2, exactly one line on stderr containing every `needle`, nothing on stdout.
pub fn assert_one_line_error(output: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "stderr: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "not one line: {stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "'{needle}' missing from: {stderr}");
    }
    assert!(output.stdout.is_empty(), "partial output on stdout");
}

/// The names of the files in `dir`, sorted.
pub fn file_names(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

/// Copies the files of the folder `from` into the folder `to` (made, with its parents).
pub fn copy_files(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
    }
}

/// A copy of the repository's `examples/` in `dir`, for commands that name its files.
pub fn copy_examples(dir: &std::path::Path) {
    copy_files(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples"), &dir.join("examples"));
}

/// Starts `chessarm` with `args`, its standard input `stdin`, its output and errors piped (a
/// run that a test talks to or waits on).
pub fn spawn<S: AsRef<std::ffi::OsStr>>(args: &[S], stdin: std::process::Stdio) -> std::process::Child {
    use std::process::Stdio;
    Command::new(env!("CARGO_BIN_EXE_chessarm"))
        .args(args)
        .stdin(stdin)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Starts `chessarm` with `args`, which ask for the live page (`--live 0`), and reads its
/// stderr up to the line with the page's address: the child, that address (with the run's
/// token), and a thread that reads the rest of its stderr (so that the pipe never fills).
pub fn start_with_live_page<S: AsRef<std::ffi::OsStr>>(
    args: &[S],
) -> (std::process::Child, String, std::thread::JoinHandle<String>) {
    let mut child = spawn(args, std::process::Stdio::null());
    let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    let url = loop {
        let mut line = String::new();
        assert!(std::io::BufRead::read_line(&mut stderr, &mut line).unwrap() > 0, "no live page: {seen}");
        seen.push_str(&line);
        if let Some(at) = line.find("http://127.0.0.1:") {
            break line[at..].split_whitespace().next().unwrap().to_string();
        }
    };
    let rest = std::thread::spawn(move || {
        let mut text = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut text).unwrap();
        text
    });
    (child, url, rest)
}

/// A box's 12 triangles, outward, over its 8 corners numbered by their sides: corner `i` is at
/// the far side in x where bit 0 of `i` is set, in y bit 1, in z bit 2.
pub const BOX_FACES: [[usize; 3]; 12] = [
    [0, 2, 1],
    [1, 2, 3],
    [4, 5, 6],
    [5, 7, 6],
    [0, 1, 4],
    [1, 5, 4],
    [2, 6, 3],
    [3, 6, 7],
    [0, 4, 2],
    [2, 4, 6],
    [1, 3, 5],
    [3, 7, 5],
];

/// The numbers of a JSON array.
pub fn numbers(value: &Value) -> Vec<f64> {
    value.as_array().expect("array").iter().map(|v| v.as_f64().expect("number")).collect()
}

/// The SIMD levels this CPU runs, by asking the binary (`CHESSARM_SIMD` refuses a level the CPU
/// lacks); each one it lacks is reported on the terminal as skipped by test `test`.
pub fn simd_levels(test: &str) -> Vec<&'static str> {
    let mut levels = Vec::new();
    for level in ["avx512", "avx2", "sse2"] {
        let probe = Command::new(env!("CARGO_BIN_EXE_chessarm"))
            .args(["tune", "--kp", "100..100:1", "--kd", "10..10:1", "--scenario", "no-such-scenario", "--json"])
            .env("CHESSARM_SIMD", level)
            .output()
            .unwrap();
        if String::from_utf8_lossy(&probe.stderr).contains("does not have it") {
            use std::io::Write as _;
            // Past the harness's capture, so that it shows on the terminal.
            let _ =
                writeln!(std::io::stderr(), "test {test} ... SIMD level {level} SKIPPED (this CPU does not have it)");
        } else {
            levels.push(level);
        }
    }
    levels
}

/// Asserts that `run(name, env)`, a command's CSV with the variables `env` set (`name` naming
/// its output folder), equals `scalar` (its CSV at one lane) at 4 and 8 lanes and every SIMD
/// level this CPU has; test `test` reports the levels it lacks as skipped.
pub fn assert_same_at_every_batching(test: &str, scalar: &str, run: impl Fn(&str, &[(&str, &str)]) -> String) {
    for level in simd_levels(test) {
        for lanes in ["4", "8"] {
            let batched = run(&format!("{lanes}-{level}"), &[("CHESSARM_LANES", lanes), ("CHESSARM_SIMD", level)]);
            assert_eq!(batched, scalar, "{lanes} lanes at {level}");
        }
    }
}

/// The Python with MuJoCo that CI installs (`CHESSARM_PYTHON`), or a `python3` that has it.
#[allow(dead_code)]
pub fn python_with_mujoco() -> Option<String> {
    python_with("mujoco")
}

/// The Python CI installs (`CHESSARM_PYTHON`), or a `python3`, that can import `module`.
#[allow(dead_code)]
pub fn python_with(module: &str) -> Option<String> {
    let candidates = std::env::var("CHESSARM_PYTHON").into_iter().chain(["python3".to_string()]);
    candidates.into_iter().find(|python| {
        std::process::Command::new(python)
            .args(["-c", &format!("import {module}")])
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// Needle fingers for the small boards the real arms serve (see the file).
#[allow(dead_code)]
pub const NEEDLE_FINGERS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/needle_fingers.toml");

/// The repository's example URDF (a 4-joint arm with offsets) and its fitted board's setup.
pub const OFFSET_ARM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/offset-arm.urdf");
pub const OFFSET_ARM_BOARD: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/offset-arm-board.toml");

/// `chessarm --urdf <OFFSET_ARM> --arm <OFFSET_ARM_BOARD> <args…>` (with `--json`).
pub fn on_offset_arm_board(args: &[&str]) -> Output {
    chessarm(&[&["--urdf", OFFSET_ARM, "--arm", OFFSET_ARM_BOARD], args].concat())
}

/// The makers' URDFs of the real arms.
pub const REAL_ARMS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/real-arms");

/// Fits the board to the arm of `urdf` (with the flags `lock`) holding needle fingers, and
/// saves that setup at `board` (`board --fit --save`).
pub fn fit_board(urdf: &std::path::Path, lock: &[&str], board: &std::path::Path) {
    let mut args = vec!["--urdf", urdf.to_str().unwrap()];
    args.extend(lock);
    args.extend(["--arm", NEEDLE_FINGERS, "board", "--fit", "--save", board.to_str().unwrap()]);
    let fit = chessarm(&args);
    assert!(fit.status.success(), "{}", String::from_utf8_lossy(&fit.stderr));
}

/// The SO-101's official URDF (its wrist roll locked) and a setup of the board fitted to it,
/// saved at `dir/board.toml`.
pub fn so101_fitted(dir: &std::path::Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let urdf = std::path::Path::new(REAL_ARMS).join("so101_new_calib.urdf");
    let board = dir.join("board.toml");
    fit_board(&urdf, &["--lock", "wrist_roll=0"], &board);
    (urdf, board)
}

/// `chessarm bus-sim` running: the simulated servo bus on a pseudo-terminal (`device`), its
/// log of every instruction received at `log`; ended (Ctrl-C's signal) when dropped.
#[allow(dead_code)]
pub struct BusSim {
    pub child: std::process::Child,
    pub device: String,
    pub log: std::path::PathBuf,
}

#[allow(dead_code)]
impl BusSim {
    /// Starts `chessarm <setup…> bus-sim --log <dir>/bus-sim.jsonl <extra…>`.
    pub fn start(dir: &std::path::Path, setup: &[&str], extra: &[&str]) -> Self {
        Self::spawn(dir, setup, extra, false)
    }

    /// As [`BusSim::start`], its standard input open for `pose` lines ([`BusSim::say`]).
    pub fn start_with_stdin(dir: &std::path::Path, setup: &[&str], extra: &[&str]) -> Self {
        Self::spawn(dir, setup, extra, true)
    }

    /// A line to bus-sim's standard input.
    pub fn say(&mut self, line: &str) {
        use std::io::Write;
        let stdin = self.child.stdin.as_mut().unwrap();
        stdin.write_all(format!("{line}\n").as_bytes()).unwrap();
        stdin.flush().unwrap();
    }

    fn spawn(dir: &std::path::Path, setup: &[&str], extra: &[&str], stdin: bool) -> Self {
        use std::io::BufRead;
        // A new log each time (bus-sim never replaces a file).
        static STARTED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = STARTED.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        let log = dir.join(format!("bus-sim-{n}.jsonl"));
        let mut args: Vec<&str> = setup.to_vec();
        args.extend(["bus-sim", "--log", log.to_str().unwrap()]);
        args.extend(extra);
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_chessarm"))
            .args(&args)
            .stdin(if stdin { std::process::Stdio::piped() } else { std::process::Stdio::null() })
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let device = line.trim().to_string();
        assert!(device.starts_with("/dev/"), "bus-sim printed {line:?}");
        Self { child, device, log }
    }

    /// The instruction packets the simulated servos received, in order: (time s, bytes).
    pub fn received(&self) -> Vec<(f64, Vec<u8>)> {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        text.lines()
            .map(|line| {
                let value: Value = serde_json::from_str(line).unwrap();
                let hex = value["packet"].as_str().unwrap();
                let bytes =
                    (0..hex.len()).step_by(2).map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap()).collect();
                (value["t"].as_f64().unwrap(), bytes)
            })
            .collect()
    }
}

impl Drop for BusSim {
    fn drop(&mut self) {
        let _ = rustix_kill(self.child.id());
        let _ = self.child.wait();
    }
}

/// SIGTERM to `pid` (the simulated bus ends as on Ctrl-C).
#[allow(dead_code)]
fn rustix_kill(pid: u32) -> std::io::Result<()> {
    std::process::Command::new("kill").arg("-TERM").arg(pid.to_string()).status().map(|_| ())
}
