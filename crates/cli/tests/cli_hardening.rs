//! Hardening findings, each as a regression test: output that cannot be written, runaway
//! work, files chessarm must not touch, silently accepted input and messages.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;
use common::{assert_one_line_error, chessarm};

use std::process::{Command, Stdio};

/// Runs chessarm with its standard output on `stdout`.
fn with_stdout(args: &[&str], stdout: Stdio) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_chessarm")).args(args).stdout(stdout).stderr(Stdio::piped()).output().unwrap()
}

/// Standard output on a pipe whose reader is already closed, so the first write fails with
/// EPIPE whatever the timing.
fn with_closed_stdout(args: &[&str]) -> std::process::Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    with_stdout(args, Stdio::from(writer))
}

/// Standard output on `/dev/full` (every write fails with ENOSPC).
fn with_full_stdout(args: &[&str]) -> std::process::Output {
    with_stdout(args, Stdio::from(std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap()))
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
        &["--dt 1e-7", "--control-rate 1e7", "GB"],
    );
    // Absurd steps: an error naming the flags, not an overflow panic.
    assert_one_line_error(
        &chessarm(&["simulate", "--dt", "1e-30", "--control-rate", "1e30", "--out", out]),
        &["--dt 1e-30 with --control-rate 1e30"],
    );
    assert_one_line_error(&chessarm(&["plan", "--dt", "1e308", "--out", out]), &["--dt 1e308", "longer than the 13 s"]);
    assert_one_line_error(&chessarm(&["simulate", "--tracking-from", "1e6", "--out", out]), &["--tracking-from 1e6"]);
    assert_one_line_error(
        &chessarm(&["tune", "--kp", "100..200:2", "--kd", "10..20:2", "--tracking-from", "13", "--out", out]),
        &["--tracking-from 13", "past the end"],
    );
    // Refused from the estimate, not after trying: far below the time to fill gigabytes.
    assert!(started.elapsed().as_secs_f64() < 20.0);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "nothing written");
}

#[test]
fn limits_far_too_low_or_fine_are_refused_before_the_planner_allocates() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("game");
    let out = out.to_str().unwrap();
    let started = std::time::Instant::now();
    let play = |extra: &[&str]| chessarm(&[&["play", "--moves", "e4", "--out", out][..], extra].concat());
    // Each aborted (SIGABRT) on an allocation of gigabytes before.
    assert_one_line_error(&play(&["--grid-step", "1e-7"]), &["grid_step = 1e-7", "at least 1e-4 m"]);
    assert_one_line_error(
        &play(&["--carry-acceleration", "1e-9"]),
        &["move e4", "would last 45762 s", "tool acceleration while carrying limit"],
    );
    assert_one_line_error(&play(&["--tool-speed", "1e-9"]), &["move e4", "tool speed limit"]);
    assert_one_line_error(&play(&["--timing", "lspb", "--traverse-acceleration", "1e-9"]), &["move e4", "LSPB"]);
    // What makes it long is named, in short numbers.
    assert_one_line_error(&play(&["--grip-dwell", "1e8"]), &["grip_dwell = 1e8", "at most 60 s"]);
    assert_one_line_error(&play(&["--jerk", "1e-12"]), &["jerk limit is far too low"]);
    assert_one_line_error(&play(&["--timing", "lspb", "--pause", "1e8"]), &["pause = 1e8", "at most 60 s"]);
    // A move of over ten minutes (here 1.5 h): refused by the estimate too.
    assert_one_line_error(&play(&["--tool-speed", "1e-4"]), &["move e4", "would last", "tool speed limit"]);
    assert_one_line_error(&play(&["--tool-speed", "1e-100"]), &["would last 2.086e99 s", "tool speed limit"]);
    let setup = dir.path().join("fine.toml");
    std::fs::write(&setup, "[motion]\ngrid_step = 1e-9\n").unwrap();
    assert_one_line_error(
        &chessarm(&["--arm", setup.to_str().unwrap(), "play", "--moves", "e4", "--out", out]),
        &["motion.grid_step = 1e-9"],
    );
    // Refused from the estimate, before sampling anything.
    assert!(started.elapsed().as_secs_f64() < 20.0);
}

#[test]
fn a_torque_limit_near_the_largest_number_plots_instead_of_hanging() {
    // The torque plot's limit lines at ±1e308 made its axis span infinite, and its ticks never
    // ended; now they lie off the axis.
    let dir = tempfile::tempdir().unwrap();
    let setup = dir.path().join("strong.toml");
    std::fs::write(&setup, "[[links]]\ntorque_limit = 1e308\n[[links]]\n[[links]]\n[[links]]\n").unwrap();
    let out = dir.path().join("sim");
    let output = chessarm(&["--arm", setup.to_str().unwrap(), "simulate", "--out", out.to_str().unwrap()]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    for plot in ["pd_torques.png", "pid_torques.png", "tip_error.png"] {
        assert!(out.join(plot).metadata().is_ok_and(|m| m.len() > 10_000), "{plot}");
    }
}

#[test]
fn threads_are_bounded_and_the_flag_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let sweep = ["tune", "--kp", "100..200:2", "--kd", "20..30:2", "--out", out, "--threads"];
    assert_one_line_error(&chessarm(&[&sweep[..], &["4294967295"]].concat()), &["--threads 4294967295", "per core"]);
    assert_one_line_error(&chessarm(&[&sweep[..], &["0"]].concat()), &["--threads 0"]);
    // A search depth that would not finish in a lifetime.
    assert_one_line_error(&chessarm(&["play", "--depth", "64"]), &["'64'", "--depth", "1..=10"]);
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

#[test]
fn play_removes_only_the_files_an_earlier_run_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("game");
    let out_text = out.to_str().unwrap();
    let moves = out.join("moves");
    let names = common::file_names;
    // A user's file in moves/ is left alone; one where chessarm would write is refused, untouched.
    std::fs::create_dir_all(&moves).unwrap();
    std::fs::write(moves.join("notes.txt"), "my notes").unwrap();
    std::fs::write(moves.join("001-e2e4.csv"), "my own analysis").unwrap();
    assert_one_line_error(
        &chessarm(&["play", "--moves", "e4", "--out", out_text]),
        &["001-e2e4.csv exists and was not written by chessarm", "nothing was changed"],
    );
    assert_eq!(std::fs::read_to_string(moves.join("001-e2e4.csv")).unwrap(), "my own analysis");
    std::fs::remove_file(moves.join("001-e2e4.csv")).unwrap();

    assert!(chessarm(&["play", "--moves", "e4 e5", "--out", out_text]).status.success());
    assert_eq!(names(&moves), [".chessarm-lock", ".chessarm-written", "001-e2e4.csv", "002-e7e5.csv", "notes.txt"]);
    // The next game removes the earlier game's CSVs, and only those.
    assert!(chessarm(&["play", "--moves", "d4", "--out", out_text]).status.success());
    assert_eq!(names(&moves), [".chessarm-lock", ".chessarm-written", "001-d2d4.csv", "notes.txt"]);
    assert_eq!(std::fs::read_to_string(moves.join("notes.txt")).unwrap(), "my notes");
}

#[test]
fn result_files_of_the_user_are_never_replaced_or_removed() {
    let dir = tempfile::tempdir().unwrap();
    // game.json, summary.json, pd.csv, tune.png that the user put in the output folder.
    for (command, file) in [
        (&["play", "--moves", "e4"][..], "game.json"),
        (&["simulate", "--controller", "pd"], "summary.json"),
        (&["simulate", "--controller", "pd"], "pd.csv"),
        (&["tune", "--kp", "100..200:2", "--kd", "10..20:2"], "tune.png"),
        (&["plan"], "joint.xlsx"),
    ] {
        let out = dir.path().join(file.replace('.', "-"));
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(out.join(file), "the user's").unwrap();
        let output = chessarm(&[command, &["--out", out.to_str().unwrap()]].concat());
        assert_one_line_error(&output, &[file, "not written by chessarm"]);
        assert_eq!(std::fs::read_to_string(out.join(file)).unwrap(), "the user's", "{command:?}");
    }
    // A list that is a symbolic link is not written through.
    let out = dir.path().join("linked");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(dir.path().join("precious.txt"), "precious").unwrap();
    std::os::unix::fs::symlink(dir.path().join("precious.txt"), out.join(".chessarm-written")).unwrap();
    assert_one_line_error(&chessarm(&["plan", "--out", out.to_str().unwrap()]), &["symbolic link"]);
    assert_eq!(std::fs::read_to_string(dir.path().join("precious.txt")).unwrap(), "precious");
}

#[test]
fn temporaries_of_dead_runs_are_swept_and_live_ones_kept() {
    let dir = tempfile::tempdir().unwrap();
    // Left by runs that are gone: nobody holds their lock.
    let dead = dir.path().join(".chessarm-4000000000-abc.part");
    let older = dir.path().join(".chessarm-Xy12zz.part.png");
    // Held by a live run (this test holds its lock), and a file of the user's.
    let alive = dir.path().join(".chessarm-1-def.part");
    let user = dir.path().join("mine.part");
    for file in [&dead, &older, &alive, &user] {
        std::fs::write(file, "x").unwrap();
    }
    let held = std::fs::File::open(&alive).unwrap();
    held.lock().unwrap();
    assert!(chessarm(&["plan", "--out", dir.path().to_str().unwrap()]).status.success());
    assert!(!dead.exists() && !older.exists(), "stale temporaries left");
    assert!(alive.exists() && user.exists(), "files of a live run or of the user removed");
    drop(held);
}

/// Sends `signal` (e.g. "INT") to `pid`.
fn kill(signal: &str, pid: u32) {
    let status = Command::new("kill").arg(format!("-{signal}")).arg(pid.to_string()).status().unwrap();
    assert!(status.success());
}

#[test]
fn a_signal_during_a_write_leaves_no_temporary_and_no_partial_file() {
    for signal in ["INT", "TERM"] {
        let dir = tempfile::tempdir().unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_chessarm"))
            .args(["plan", "--out", dir.path().to_str().unwrap()])
            .env("CHESSARM_TEST_SLOW_WRITES_MS", "3000")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Wait (bounded) until the first temporary file exists, then interrupt the write.
        let temporaries = || {
            std::fs::read_dir(dir.path())
                .map(|entries| {
                    // A temporary being written (`.chessarm-<pid>-….part`), not the folder's lock,
                    // which is taken before any write.
                    entries
                        .flatten()
                        .filter(|e| {
                            let name = e.file_name().to_string_lossy().into_owned();
                            name.starts_with(".chessarm-") && name.contains(".part")
                        })
                        .count()
                })
                .unwrap_or(0)
        };
        let started = std::time::Instant::now();
        while temporaries() == 0 {
            assert!(started.elapsed().as_secs() < 60, "no temporary file appeared");
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        kill(signal, child.id());
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(130), "{signal}: {status:?}");
        // Only the list of what chessarm writes there and the folder's lock (released by the
        // kernel with the process): no temporary, no partial result.
        assert_eq!(common::file_names(dir.path()), [".chessarm-lock", ".chessarm-written"], "{signal}");
    }
}

#[test]
fn the_builtin_engine_plays_the_same_game_whatever_the_time_settings() {
    let dir = tempfile::tempdir().unwrap();
    let game = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        // A middlegame, where a depth-3 search takes milliseconds (a 1 ms cap used to cut it).
        let fen = "r1bq1rk1/pp2bppp/2n1pn2/2pp4/3P4/2PBPN2/PP1N1PPP/R1BQ1RK1 w - - 0 9";
        let args = ["play", "--fen", fen, "--plies", "4", "--out", out.to_str().unwrap()];
        let output = chessarm(&[&args[..], extra].concat());
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let game: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("game.json")).unwrap()).unwrap();
        let sans: Vec<String> =
            game["moves"].as_array().unwrap().iter().map(|m| m["san"].as_str().unwrap().to_owned()).collect();
        (sans, game["deterministic"].as_bool().unwrap(), game["machine_dependent_because"].clone())
    };
    // --movetime is a UCI engine's thinking time: 1 ms and 500 ms give the built-in engine's
    // depth-3 game, which is a function of the position alone.
    let (fast, fast_deterministic, _) = game("fast", &["--movetime", "1"]);
    let (slow, slow_deterministic, _) = game("slow", &["--movetime", "500"]);
    assert_eq!(fast.len(), 4);
    assert_eq!(fast, slow);
    assert!(fast_deterministic && slow_deterministic);
    // A wall-time cap is allowed, and named as making the game machine-dependent.
    let (_, capped_deterministic, because) = game("capped", &["--builtin-movetime", "50"]);
    assert!(!capped_deterministic);
    assert!(because[0].as_str().unwrap().contains("--builtin-movetime 50"), "{because}");
}

#[test]
fn the_spreadsheet_is_the_same_bytes_on_every_run() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str| {
        let out = dir.path().join(name);
        assert!(chessarm(&["plan", "--xlsx", "--out", out.to_str().unwrap()]).status.success());
        std::fs::read(out.join("joint.xlsx")).unwrap()
    };
    let first = run("a");
    // The creation time had one-second resolution: a run in another second wrote other bytes.
    std::thread::sleep(std::time::Duration::from_millis(1100));
    assert!(first == run("b"), "joint.xlsx differs between runs");
}

/// Loads `text` as a setup file and prints it back (the full setup, defaults filled in).
fn printed_setup(text: &str) -> std::process::Output {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("arm.toml");
    std::fs::write(&path, text).unwrap();
    chessarm(&["--arm", path.to_str().unwrap(), "arm"])
}

/// The default setup as printed, with `old` replaced by `new` once (which must be there).
fn default_with(old: &str, new: &str) -> String {
    let text = String::from_utf8(chessarm(&["arm"]).stdout).unwrap();
    assert!(text.contains(old), "{old} not in the default setup");
    text.replacen(old, new, 1)
}

#[test]
fn every_field_of_every_table_may_be_left_out() {
    let cases = [
        ("gravity = [0, 0, -9.81]\n", ("-9.8,\n]", "-9.81,\n]")),
        ("[board]\ncenter = [0.0, 0.33]\n", ("center = [\n    0.0,\n    0.33,", "center = [\n    0.0,\n    0.33,")),
        ("[board]\nsquare_size = 0.05\n", ("square_size = 0.06", "square_size = 0.05")),
        ("[pieces.pawn]\nmass = 0.2\n", ("mass = 0.03\n", "mass = 0.2\n")),
        ("[pieces.king]\ngrip_height = 0.07\n", ("grip_height = 0.07600000000000001", "grip_height = 0.07")),
        // Four [[links]] tables, only the second says something: its mass.
        ("[[links]]\n[[links]]\nmass = 0.6\n[[links]]\n[[links]]\n", ("mass = 0.5261671", "mass = 0.6")),
    ];
    for (file, (old, new)) in cases {
        let output = printed_setup(file);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{file:?}: {stderr}");
        assert_eq!(String::from_utf8(output.stdout).unwrap(), default_with(old, new), "{file:?}");
    }
}

#[test]
fn arrays_of_the_wrong_length_are_refused_naming_the_field() {
    for (file, needles) in [
        ("gravity = [0, 0, -9.8, 1]\n", &["gravity has 4 numbers", "exactly 3"][..]),
        ("gravity = [0, 0, -9.8, \"junk\"]\n", &["line 1", "junk"]),
        ("[board]\ncenter = [0, 0.33, 0]\n", &["board.center has 3 numbers", "exactly 2"]),
        ("[[links]]\n[[links]]\ncom = [0, 0]\n[[links]]\n[[links]]\n", &["link 2 com has 2 numbers"]),
        (
            "[[links]]\ninertia = [[1, 0, 0], [0, 1, 0]]\n[[links]]\n[[links]]\n[[links]]\n",
            &["link 1 inertia has 2 rows"],
        ),
        (
            "[[links]]\ninertia = [[1, 0, 0], [0, 1, 0], [0, 0, 1, 5]]\n[[links]]\n[[links]]\n[[links]]\n",
            &["link 1 inertia[2] has 4 numbers"],
        ),
        ("[[links]]\n[[links]]\n[[links]]\ninertia_rpy = [nan, 0, 0]\n[[links]]\n", &["link 3 inertia_rpy[0] = NaN"]),
        ("[pieces.rook]\nheight = inf\n", &["pieces.rook.height = inf"]),
    ] {
        assert_one_line_error(&printed_setup(file), needles);
    }
}

/// `play` into a fresh folder; returns game.json and the terminal's text.
fn play_game(extra: &[&str]) -> (serde_json::Value, String) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("game");
    let output = chessarm(&[&["play", "--out", out.to_str().unwrap()][..], extra].concat());
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{stderr}");
    (serde_json::from_slice(&std::fs::read(out.join("game.json")).unwrap()).unwrap(), stderr)
}

#[test]
fn games_stop_at_their_result_and_record_it() {
    // A back-rank mate in one for the engine: the game ends after one ply, not at --plies.
    let (game, terminal) = play_game(&["--fen", "6k1/5ppp/8/8/8/8/8/R5K1 w - - 0 1", "--plies", "10"]);
    assert_eq!(game["moves"].as_array().unwrap().len(), 1);
    assert_eq!((game["result"].as_str(), game["result_reason"].as_str()), (Some("1-0"), Some("checkmate")));
    assert!(terminal.contains("result 1-0 (checkmate)"), "{terminal}");
    // Fifty moves without a capture or a pawn move: a draw after the next quiet move.
    let (game, _) = play_game(&["--fen", "8/8/8/4k3/8/8/8/R3K3 w - - 99 80", "--plies", "10"]);
    assert_eq!(game["moves"].as_array().unwrap().len(), 1);
    assert_eq!((game["result"].as_str(), game["result_reason"].as_str()), (Some("1/2-1/2"), Some("fifty-move rule")));
    // Bare kings: nothing to play.
    let (game, _) = play_game(&["--fen", "8/8/8/4k3/8/8/8/4K3 w - - 0 1"]);
    assert_eq!(game["moves"].as_array().unwrap().len(), 0);
    assert_eq!(game["result_reason"].as_str(), Some("insufficient material"));
    // A replayed game: the rules' result of its final position.
    let (game, _) = play_game(&["--moves", "f3 e5 g4 Qh4#"]);
    assert_eq!((game["result"].as_str(), game["result_reason"].as_str()), (Some("0-1"), Some("checkmate")));
    let (game, _) = play_game(&["--moves", "Nf3 Nf6 Ng1 Ng8 Nf3 Nf6 Ng1 Ng8"]);
    assert_eq!(game["result_reason"].as_str(), Some("threefold repetition"));
    // A claimable draw does not override the result the PGN records: the game went on.
    let dir = tempfile::tempdir().unwrap();
    let pgn = dir.path().join("claimable.pgn");
    std::fs::write(&pgn, "[Result \"0-1\"]\n\n1. Nf3 Nf6 2. Ng1 Ng8 3. Nf3 Nf6 4. Ng1 Ng8 0-1\n").unwrap();
    let (game, _) = play_game(&[pgn.to_str().unwrap()]);
    assert_eq!(game["result"].as_str(), Some("0-1"));
    assert!(game["result_reason"].as_str().unwrap().contains("threefold repetition could have been claimed"));
    // An engine game cut by --plies says so.
    let (game, _) = play_game(&["--plies", "2"]);
    assert_eq!(game["result"].as_str(), Some("*"));
    assert!(game["result_reason"].as_str().unwrap().contains("--plies 2"), "{}", game["result_reason"]);
}

#[test]
fn a_pgn_that_never_ends_is_refused_after_one_game_s_worth() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let started = std::time::Instant::now();
    assert_one_line_error(&chessarm(&["play", "/dev/zero", "--out", out]), &["/dev/zero", "longer than 4 MiB"]);
    assert_one_line_error(
        &chessarm(&["tune", "/dev/zero", "--kp", "100..200:2", "--kd", "10..20:2", "--out", out]),
        &["/dev/zero", "longer than 4 MiB"],
    );
    assert!(started.elapsed().as_secs_f64() < 30.0);
    // A legal game of a million plies (knight shuffles, no claim): refused before it is played.
    let shuffles = format!("[Event \"shuffle\"]\n\n{} *\n", ["Nf3 Nf6 Ng1 Ng8"; 250_000].join(" "));
    let pgn = dir.path().join("shuffle.pgn");
    std::fs::write(&pgn, shuffles).unwrap();
    assert_one_line_error(
        &chessarm(&["play", pgn.to_str().unwrap(), "--out", out]),
        &["game 1 of", "1000000 plies", "GB of memory"],
    );
}

#[test]
fn control_characters_from_the_input_are_escaped_in_the_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let pgn = dir.path().join("control.pgn");
    std::fs::write(&pgn, b"[Event \"x\"]\n\n1. e4 e5 2. Nf3\x0b\x00\r Nc6 *\n").unwrap();
    let output = chessarm(&["play", pgn.to_str().unwrap(), "--out", dir.path().join("o").to_str().unwrap()]);
    assert_one_line_error(&output, &["Nf3\\u{b}\\0"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    let raw: Vec<char> = stderr.trim_end().chars().filter(|c| c.is_control()).collect();
    assert!(raw.is_empty(), "raw control characters {raw:?} in {stderr:?}");
    // The same for a value clap rejects.
    let output = chessarm(&["fk", "--q", "1,2,3,\r4\u{1}"]);
    assert_one_line_error(&output, &["4\\u{1}"]);
}

#[test]
fn flags_that_would_be_ignored_or_cannot_work_are_refused() {
    assert_one_line_error(&chessarm(&["gains", "--settling-time", "0.3", "--zeta", "0.7"]), &["--zeta"]);
    assert_one_line_error(&chessarm(&["gains", "--wn", "10", "--zeta", "0.7", "--overshoot", "5"]), &["--overshoot"]);
    for command in ["play", "tune"] {
        let help = String::from_utf8(chessarm(&[command, "--help"]).stdout).unwrap();
        let at = help.find("--controller <CONTROLLER>").unwrap();
        let entry: String = help[at..].lines().take_while(|l| !l.trim_start().starts_with("--kp")).collect();
        assert!(entry.contains("pid") && !entry.contains("both"), "{command} --help: {entry}");
        assert_one_line_error(&chessarm(&[command, "--controller", "both"]), &["'both'", "pd, pid"]);
    }
    assert_one_line_error(
        &chessarm(&["dynamics", "--q", "0,0,0,0", "--qd", "1e308,1e308,0,0"]),
        &["overflows", "--qd 1e308,1e308,0,0"],
    );
}

#[test]
fn errors_name_the_flag_as_typed_not_a_derived_value() {
    assert_one_line_error(&chessarm(&["gains", "--settling-time", "1e308"]), &["--settling-time 1e308"]);
    assert_one_line_error(&chessarm(&["gains", "--settling-time", "1e-300"]), &["--settling-time 1e-300"]);
    assert_one_line_error(&chessarm(&["ik", "--xyz", "0,0.9,0.05"]), &["beyond the arm's full stretch of 0.6096 m"]);
}

#[test]
fn huge_inputs_make_short_error_lines() {
    // A 100 kB token is quoted by its start and the count of what is left out.
    let long = "x".repeat(100_000);
    for args in [
        vec!["fk".to_owned(), "--q".to_owned(), format!("1,2,3,{long}")],
        vec![
            "play".to_owned(),
            "--moves".to_owned(),
            format!("e4 {long}"),
            "--out".to_owned(),
            "/tmp/unused".to_owned(),
        ],
        vec!["play".to_owned(), "--fen".to_owned(), long.clone(), "--moves".to_owned(), "e4".to_owned()],
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let output = chessarm(&args);
        assert_one_line_error(&output, &["more bytes)"]);
        assert!(output.stderr.len() < 2000, "{} bytes for {:?}", output.stderr.len(), &args[..2]);
    }
    // Huge numbers in short scientific form, not hundreds of digits.
    assert_one_line_error(&chessarm(&["ik", "--square", "d4", "--height", "1e308"]), &["1e308 m beyond"]);
    assert_one_line_error(
        &chessarm(&["gains", "--settling-time", "0.3", "--overshoot", "1e308"]),
        &["overshoot = 1e308"],
    );
}

#[test]
fn angles_outside_the_joint_limits_are_warned_about() {
    let output = chessarm(&["fk", "--q", "90,0,0,0"]);
    assert!(output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("warning: --q joint 1 = 90 rad is outside its limits") && stderr.contains("1.5708 rad"),
        "{stderr}"
    );
    let quiet = chessarm(&["fk", "--q", "1.5,0.5,0,0"]);
    assert!(quiet.status.success() && quiet.stderr.is_empty());
}

/// A setup printed by `chessarm arm` loads back to the same print, also when a rotated tensor
/// has -0.0 entries (found by the setup-TOML fuzz target).
#[test]
fn the_printed_setup_is_a_fixed_point_with_rotated_tensors() {
    let rotated = printed_setup("[[links]]\n[[links]]\ninertia_rpy = [0.3, 0.2, 0.1]\n[[links]]\n[[links]]\n");
    assert!(rotated.status.success());
    let first = String::from_utf8(rotated.stdout).unwrap();
    assert!(first.contains("-0.0"), "the case needs a negative zero");
    let second = String::from_utf8(printed_setup(&first).stdout).unwrap();
    assert_eq!(first, second);
}

/// The header of a CSV file.
fn header(path: &std::path::Path) -> Vec<String> {
    std::fs::read_to_string(path).unwrap().lines().next().unwrap().split(',').map(String::from).collect()
}

#[test]
fn one_name_is_one_quantity_in_every_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name);
    assert!(chessarm(&["plan", "--out", out("plan").to_str().unwrap()]).status.success());
    assert!(chessarm(&["simulate", "--controller", "pd", "--out", out("sim").to_str().unwrap()]).status.success());
    assert!(chessarm(&["play", "--moves", "e4", "--out", out("play").to_str().unwrap()]).status.success());
    let mut columns: Vec<String> = Vec::new();
    for file in [out("plan/joint.csv"), out("sim/pd.csv"), out("play/moves/001-e2e4.csv")] {
        columns.extend(header(&file));
    }
    // Every column is t, a tip coordinate, or <quantity><joint>, and each quantity is one of
    // these: actual q/qd, desired q_des/qd_des/qdd_des, e = q_des − q, tau.
    let quantities = ["q", "qd", "q_des", "qd_des", "qdd_des", "e", "tau"];
    let other = ["t", "x", "y", "z", "x_des", "y_des", "z_des", "tip_error_mm"];
    for column in &columns {
        let stem = column.trim_end_matches(|c: char| c.is_ascii_digit());
        assert!(
            other.contains(&column.as_str()) || (stem.len() < column.len() && quantities.contains(&stem)),
            "column {column} is not one of the documented names"
        );
    }
    assert!(columns.iter().any(|c| c == "qd_des1") && columns.iter().any(|c| c == "qdd_des1"));
}

#[test]
fn values_that_look_like_flags_and_help_output_are_handled() {
    // A negative value reaches the value parser, which names the flag and the value.
    assert_one_line_error(&chessarm(&["simulate", "--tracking-from", "-1"]), &["--tracking-from", "'-1'", ">= 0"]);
    assert_one_line_error(
        &chessarm(&["gains", "--settling-time", "0.3", "--overshoot", "-1"]),
        &["--overshoot", "'-1'"],
    );
    assert_one_line_error(&chessarm(&["play", "x.pgn", "--game", "0"]), &["--game", "counted from 1"]);
    // --help into a full disk is an error too.
    let output = with_full_stdout(&["--help"]);
    assert_eq!(output.status.code(), Some(2));
    assert_eq!(with_closed_stdout(&["--help"]).status.code(), Some(0));
}

#[test]
fn results_are_for_people_unless_json_is_asked_for() {
    let human =
        common::chessarm_human(&["gains", "--settling-time", "0.3", "--overshoot", "5", "--controller", "both"]);
    assert!(human.status.success());
    let text = String::from_utf8(human.stdout).unwrap();
    assert!(serde_json::from_str::<serde_json::Value>(&text).is_err(), "JSON without --json: {text}");
    // A header and four joint rows per controller, with what was promised and measured.
    for name in ["PD:", "PID:"] {
        assert!(text.contains(name), "{text}");
    }
    let rows: Vec<&str> =
        text.lines().filter(|l| l.trim_start().chars().next().is_some_and(|c| c.is_ascii_digit())).collect();
    assert_eq!(rows.len(), 8, "{text}");
    assert!(rows.iter().all(|r| r.matches(" / ").count() >= 3), "{text}");
    assert!(text.contains("closed-loop poles") && text.contains("worst settling"), "{text}");
    let json = common::json_of(&common::chessarm(&[
        "gains",
        "--settling-time",
        "0.3",
        "--overshoot",
        "5",
        "--controller",
        "both",
    ]));
    assert_eq!(json["designs"].as_array().unwrap().len(), 2);
    // Small commands too: fk prints the tip and frames as text, JSON with --json.
    let fk = common::chessarm_human(&["fk", "--q", "0,0,0,0"]);
    let text = String::from_utf8(fk.stdout).unwrap();
    assert!(text.starts_with("tip (") && text.contains("frame4") && !text.contains("-0.000000"), "{text}");
    let json = common::json_of(&common::chessarm(&["fk", "--q", "0,0,0,0"]));
    assert_eq!(json["frames"].as_array().unwrap().len(), 4);
}

#[test]
fn a_best_pick_on_the_edge_of_the_sweep_is_called_out() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tune");
    // Stiffer is better here up to far beyond 300: the best lies at the largest kp swept.
    let output =
        common::chessarm_human(&["tune", "--kp", "100..300:3", "--kd", "20..40:2", "--out", out.to_str().unwrap()]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let text = String::from_utf8(output.stdout).unwrap();
    assert!(text.contains("warning: the best pick") && text.contains("kp at its largest (--kp)"), "{text}");
    // From rest at q = 0 the best tracking after the start-up is inside (kp 300, kd 40): no warning.
    let output = common::chessarm_human(&[
        "tune",
        "--kp",
        "100..500:5",
        "--kd",
        "20..50:4",
        "--q0",
        "0,0,0,0",
        "--out",
        out.to_str().unwrap(),
    ]);
    let text = String::from_utf8(output.stdout).unwrap();
    assert!(text.contains("300.000") && !text.contains("warning"), "{text}");
}

#[test]
fn values_that_would_fail_later_are_refused_at_load_naming_their_field() {
    // Each was accepted and failed seconds later as "NaN", "not positive
    // definite" or a Kalman filter's complaint, without naming what the user wrote.
    let links = |field: &str| format!("[[links]]\n{field}\n[[links]]\n[[links]]\n[[links]]\n");
    for (file, needles) in [
        (links("alpha = 1e308"), &["link 1 (alpha) = 1e308", "one turn"][..]),
        (links("theta_offset = -7"), &["link 1 (theta_offset) = -7"]),
        (links("d = 1e6"), &["link 1 (d) = 1e6", "100 m"]),
        (links("mass = 1e300"), &["link 1 mass = 1e300", "10 000 kg"]),
        (links("com = [0, 1e200, 0]"), &["link 1 com = [0, 1e200, 0]"]),
        (links("motor_mass = 1e9"), &["link 1 (motor_mass) = 1e9"]),
        ("[sensors.mine]\n".into(), &["sensors.mine", "the table is empty"]),
        ("[sensors.mine]\ncounts_per_rev = 4096\nnoise_counts = 1e308\n".into(), &["noise_counts = 1e308", "4096"]),
        ("[sensors.mine]\ncounts_per_rev = 4096\nrate_noise = 1e308\n".into(), &["rate_noise = 1e308", "1000 rad/s"]),
    ] {
        assert_one_line_error(&printed_setup(&file), needles);
    }
    assert_one_line_error(&chessarm(&["simulate", "--payload-mass", "1e308"]), &["--payload-mass", "1e308 kg"]);
    // The largest values allowed still load.
    for file in [links("alpha = 6.28"), links("mass = 1e4"), "[sensors.mine]\nrate_noise = 1000\n".into()] {
        assert!(printed_setup(&file).status.success(), "{file}");
    }
}

#[test]
fn a_pgn_variation_left_open_or_closed_twice_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (text, needle) in [
        ("1. e4 (1. d4 e5 2. Nf3\n", "'(' opened after ply 1 is never closed"),
        ("1. e4 e5 ) 2. Nf3 *\n", "a ')' after ply 2 closes no variation"),
    ] {
        let pgn = dir.path().join("game.pgn");
        std::fs::write(&pgn, text).unwrap();
        let out = dir.path().join("out");
        let output = chessarm(&["play", pgn.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        assert_one_line_error(&output, &["game 1", needle]);
        assert!(!out.exists(), "{text}: a refused game wrote {}", out.display());
    }
}

#[test]
fn input_files_are_read_with_a_size_bound() {
    // `--urdf /dev/zero` ate a gigabyte and a 400 MB URDF aborted the XML
    // parser; every input file is now read up to a bound and refused beyond it.
    let dir = tempfile::tempdir().unwrap();
    let big_setup = dir.path().join("big.toml");
    std::fs::write(&big_setup, format!("{}\n", "# comment\n".repeat(110_000))).unwrap();
    let big_urdf = dir.path().join("big.urdf");
    std::fs::write(&big_urdf, format!("<robot name=\"r\">{}</robot>\n", " ".repeat(16_000_001))).unwrap();
    let cases: [(&[&str], &[&str]); 6] = [
        (&["--urdf", "/dev/zero", "arm"], &["URDF file /dev/zero", "longer than 16.0 MB"]),
        (&["--arm", "/dev/zero", "arm"], &["arm file /dev/zero", "longer than 1.0 MB"]),
        (&["--arm", big_setup.to_str().unwrap(), "arm"], &["big.toml", "longer than 1.0 MB"]),
        (&["--urdf", big_urdf.to_str().unwrap(), "arm"], &["big.urdf", "longer than 16.0 MB"]),
        (&["simulate", "--uncertainty", "/dev/zero"], &["--uncertainty /dev/zero", "longer than 1.0 MB"]),
        (&["--arm", dir.path().to_str().unwrap(), "arm"], &["is a folder"]),
    ];
    for (args, needles) in cases {
        assert_one_line_error(&chessarm(args), needles);
    }
    // Text that is not UTF-8 says so, with where.
    let binary = dir.path().join("binary.toml");
    std::fs::write(&binary, b"gravity = [0, 0, -9.8]\n\xff\xfe").unwrap();
    assert_one_line_error(&chessarm(&["--arm", binary.to_str().unwrap(), "arm"]), &["not UTF-8", "byte offset 23"]);
}

#[test]
fn a_second_run_into_a_folder_in_use_stops_naming_the_first() {
    // Two runs into one --out both exited 0 and mixed their files.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("game");
    let out_text = out.to_str().unwrap();
    // The first run pauses 1.5 s at every file it writes (about 15 s in all), holding its folder.
    let first = Command::new(env!("CARGO_BIN_EXE_chessarm"))
        .args(["play", "--moves", "e4 e5", "--out", out_text])
        .env("CHESSARM_TEST_SLOW_WRITES_MS", "1500")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Its lock is taken before any work, and says who holds it.
    let pid = format!("pid {}", first.id());
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while !std::fs::read_to_string(out.join(".chessarm-lock")).is_ok_and(|text| text.contains(&pid)) {
        assert!(std::time::Instant::now() < deadline, "the first run never locked its folder");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let second = chessarm(&["play", "--moves", "d4", "--out", out_text]);
    assert_one_line_error(&second, &[out_text, "is in use by another chessarm run", &pid, "--moves e4 e5"]);
    // The refused run left the first run's lock alone: a third is refused the same way.
    assert!(std::fs::read_to_string(out.join(".chessarm-lock")).unwrap().contains(&pid));
    assert_one_line_error(&chessarm(&["plan", "--out", out_text]), &["is in use", &pid]);
    // A folder inside it is refused too, and not created.
    let inner = out.join("study");
    assert_one_line_error(&chessarm(&["simulate", "--out", inner.to_str().unwrap()]), &[out_text, &pid]);
    assert!(!inner.exists());
    let finished = first.wait_with_output().unwrap();
    assert!(finished.status.success(), "{}", String::from_utf8_lossy(&finished.stderr));
    // The first run's game alone: two plies, nothing of the refused d4.
    let game: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("game.json")).unwrap()).unwrap();
    let plies = game["moves"].as_array().map(Vec::len);
    assert_eq!(plies, Some(2), "{game}");
    // Once it has ended the folder is free again (the kernel dropped the lock with the process).
    let third = chessarm(&["play", "--moves", "d4", "--out", out_text]);
    assert!(third.status.success(), "{}", String::from_utf8_lossy(&third.stderr));
}

#[test]
fn ci_runs_every_test_that_needs_an_outside_tool() {
    // Tests whose tool is missing are counted as ignored (cfgs from the build script); CI
    // installs every tool, so there none may be ignored for want of one.
    if std::env::var("CI").as_deref() == Ok("true") {
        let tools = [
            (cfg!(tool_stockfish), "Stockfish"),
            (cfg!(tool_browser), "Chromium, Node.js and playwright-core"),
            (cfg!(tool_python), "CHESSARM_PYTHON, a Python with the package and mujoco"),
        ];
        let missing: Vec<&str> = tools.iter().filter(|(found, _)| !found).map(|(_, tool)| *tool).collect();
        assert!(missing.is_empty(), "CI must install {missing:?}");
    }
}

#[test]
fn a_refused_run_removes_only_the_folders_it_made() {
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    // `made/../yours/deeper`: `made` and `deeper` are the run's to remove, `yours` (empty) is not.
    std::fs::create_dir(dir.path().join("yours")).unwrap();
    let out = dir.path().join("made/../yours/deeper");
    let output = chessarm(&["play", "--moves", "e9", "--out", out.to_str().unwrap()]);
    assert_one_line_error(&output, &["'e9'"]);
    assert!(dir.path().join("yours").is_dir(), "the user's folder was removed");
    assert!(!dir.path().join("made").exists() && !dir.path().join("yours/deeper").exists());
    // An argument that is not UTF-8 (a folder name in Latin-1) is recorded in the lock, not a panic.
    let latin = dir.path().join(std::ffi::OsStr::from_bytes(b"caf\xe9"));
    let output = Command::new(env!("CARGO_BIN_EXE_chessarm"))
        .args([std::ffi::OsStr::new("plan"), std::ffi::OsStr::new("--out"), latin.as_os_str()])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(std::fs::read_to_string(latin.join(".chessarm-lock")).unwrap().contains("caf\u{fffd}"));
}

/// A bus rate that would size the work beyond reason (a goal every 10⁹ s hung the clearance
/// sweep; 10⁻⁴ Hz took 2.35 GB in 25 s) or that the simulation cannot step, and a gripper
/// dwell of days, are refused before anything runs, naming the flag and the value as typed.
#[test]
fn rates_and_dwells_that_size_work_are_refused_before_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    for (rate, needle) in [("1e-9", "below 10 Hz"), ("1e-4", "below 10 Hz"), ("20000", "above 10000 Hz")] {
        let output = chessarm(&["--actuator", "sts3215", "--bus-rate", rate, "play", "--moves", "e4", "--out", out]);
        assert_one_line_error(&output, &["--bus-rate", rate, needle]);
    }
    // A period that is not a whole number of the simulation's steps: refused before the game
    // (it stopped at its first move, having written game.json).
    let output = chessarm(&[
        "--actuator",
        "sts3215",
        "--bus-rate",
        "300",
        "play",
        "--moves",
        "e4",
        "--dt",
        "1e-3",
        "--out",
        out,
    ]);
    assert_one_line_error(&output, &["--bus-rate 300 Hz", "--dt 0.001"]);
    assert!(!std::path::Path::new(out).join("game.json").exists());
    // A gripper dwell of days is simulated step by step: refused before the game (it stopped
    // at its first move).
    let output = chessarm(&["play", "--moves", "e4", "--grip-dwell", "1e6", "--out", out]);
    assert_one_line_error(&output, &["grip_dwell", "1e6", "at most 60 s"]);
    assert!(!std::path::Path::new(out).join("game.json").exists());
}

/// What would refuse at the first write is refused before the work: a game.pgn the user wrote
/// given to `--resume` (it replayed the moves, wrote game.json, then refused), a damaged list
/// of chessarm's files (refused after the simulation, leaving empty moves/ and hardware/).
#[test]
fn refusals_come_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mine");
    std::fs::create_dir(&out).unwrap();
    let pgn = "[Event \"mine\"]\n[White \"person\"]\n[Black \"arm\"]\n[Result \"*\"]\n\n1. e4 e5 2. Nf3 Nc6 3. Bb5 a6 4. Ba4 Nf6 *\n";
    std::fs::write(out.join("game.pgn"), pgn).unwrap();
    let output = chessarm(&["play", "--human", "white", "--resume", "--out", out.to_str().unwrap()]);
    assert_one_line_error(&output, &["--resume", "game.pgn", "not written by chessarm"]);
    assert_eq!(std::fs::read_to_string(out.join("game.pgn")).unwrap(), pgn);
    assert!(!out.join("game.json").exists() && !out.join("moves").exists());
    // A list that is not text.
    let damaged = dir.path().join("damaged");
    std::fs::create_dir(&damaged).unwrap();
    std::fs::write(damaged.join(".chessarm-written"), b"game.json\n\xff\xfe\x00junk\n").unwrap();
    let output = chessarm(&["play", "--moves", "e4", "--out", damaged.to_str().unwrap()]);
    assert_one_line_error(&output, &[".chessarm-written", "damaged"]);
    for made in ["moves", "hardware", "game.json"] {
        assert!(!damaged.join(made).exists(), "{made} was made before the refusal");
    }
}

/// `board`'s output flags are checked before the fit, and their errors name them: `--save`
/// on a device (it said "choose another --out"), `--map` not a PNG (a library's debug dump).
#[test]
fn board_outputs_are_refused_naming_their_flag() {
    let output = chessarm(&["board", "--fit", "--save", "/dev/full"]);
    assert_one_line_error(&output, &["--save /dev/full"]);
    assert!(!String::from_utf8_lossy(&output.stderr).contains("--out"));
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("x.txt");
    let output = chessarm(&["board", "--map", map.to_str().unwrap()]);
    assert_one_line_error(&output, &["--map", "x.txt", ".png"]);
    assert!(!map.exists());
    let output = chessarm(&["board", "--fit", "--save", dir.path().to_str().unwrap()]);
    assert_one_line_error(&output, &["--save", "a folder"]);
}
