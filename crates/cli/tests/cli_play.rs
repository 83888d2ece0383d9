//! The binary, end to end: chess games played by the simulated arm.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;
use common::{assert_one_line_error, chessarm};

use serde_json::Value;
use std::path::{Path, PathBuf};

use common::chess_fixture as fixture;

/// Plays and returns game.json, asserting the physical board equals the rules' board.
fn play(dir: &Path, args: &[&str]) -> Value {
    let game = common::play_game(dir, args);
    assert_eq!(game["final_fen_physical"], game["final_fen_rules"], "{}", game["misplaced"]);
    assert_eq!(game["misplaced"].as_array().unwrap().len(), 0, "{}", game["misplaced"]);
    game
}

#[test]
fn special_moves_game_plays_through_and_reports_every_move() {
    let dir = tempfile::tempdir().unwrap();
    let game = play(dir.path(), &[&fixture("special_moves.pgn")]);
    let moves = game["moves"].as_array().unwrap();
    let kinds: Vec<&str> = moves.iter().map(|m| m["kind"].as_str().unwrap()).collect();
    for kind in ["en-passant", "castle-kingside", "castle-queenside", "promotion", "capture"] {
        assert!(kinds.contains(&kind), "no {kind} in {kinds:?}");
    }
    let mut total = 0.0;
    for m in moves {
        for key in [
            "ply",
            "san",
            "uci",
            "kind",
            "tasks",
            "duration_s",
            "planned_duration_s",
            "phases_s",
            "longest_limit",
            "saturated_samples",
            "max_tip_error_mm",
            "place_errors_mm",
        ] {
            assert!(!m[key].is_null(), "{key} missing in {m}");
        }
        for error in m["place_errors_mm"].as_array().unwrap() {
            assert!(error.as_f64().unwrap() < 5.0);
        }
        // The simulation runs the planned motion plus the fine points' waits (to the 1 ms step),
        // and the phases add up to the plan.
        let duration = m["duration_s"].as_f64().unwrap();
        let planned = m["planned_duration_s"].as_f64().unwrap();
        let waited = m["in_position_waits"]["total_s"].as_f64().unwrap();
        assert!((duration - (planned + waited)).abs() < 1.5e-3, "{m}");
        let phases = &m["phases_s"];
        let sum: f64 = ["travel", "vertical", "grip", "pause"].iter().map(|k| phases[k].as_f64().unwrap()).sum();
        assert!((sum - planned).abs() < 1e-6, "phases {sum} s against {planned} s: {m}");
        assert_eq!(phases["pause"].as_f64(), Some(0.0), "the optimal timing has no pauses: {m}");
        assert_eq!(m["saturated_samples"].as_u64(), Some(0), "{m}");
        assert!(m["longest_limit"]["time_s"].as_f64().unwrap() > 0.0);
        total += duration;
    }
    assert!((game["total_robot_time_s"].as_f64().unwrap() - total).abs() < 1e-6);
    assert!(game["wall_time_s"].as_f64().unwrap() > 0.0);
    // One CSV a move, and the list of what chessarm wrote there.
    let csvs = common::file_names(&dir.path().join("moves")).iter().filter(|n| n.ends_with(".csv")).count();
    assert_eq!(csvs, moves.len());
    assert!(dir.path().join("tip_error.png").exists());
}

#[test]
fn move_lists_robot_side_and_fen_start() {
    let dir = tempfile::tempdir().unwrap();
    let game = play(dir.path(), &["--moves", "e4 e5 Nf3 Nc6 Bb5 a6", "--robot", "black"]);
    let by: Vec<&str> = game["moves"].as_array().unwrap().iter().map(|m| m["by"].as_str().unwrap()).collect();
    assert_eq!(by, ["hand", "robot", "hand", "robot", "hand", "robot"]);
    let dir = tempfile::tempdir().unwrap();
    let game = play(dir.path(), &["--fen", "8/1P5k/8/8/8/8/6K1/8 w - - 0 1", "--moves", "b8=N Kg6"]);
    assert_eq!(game["final_fen_rules"], "1N6/8/6k1/8/8/8/6K1/8 w - - 1 2");
}

#[test]
fn promotions_near_the_base_and_a_second_queen() {
    // Carrying black's spare queen from beside the base to h1 passes 8 cm from the base axis,
    // where the default speed would turn joint 1 faster than 3 rad/s: the move is slowed.
    let dir = tempfile::tempdir().unwrap();
    play(dir.path(), &["--fen", "4k3/8/8/8/8/8/7p/K7 b - - 0 1", "--moves", "h1=Q"]);
    // Two queen promotions: the reserve holds two spare queens.
    let dir = tempfile::tempdir().unwrap();
    let game = play(dir.path(), &["--fen", "4k3/PP6/8/8/8/8/8/3QK3 w - - 0 1", "--moves", "a8=Q Ke7 b8=Q"]);
    assert_eq!(game["final_fen_rules"], "QQ6/4k3/8/8/8/8/8/3QK3 b - - 0 2");
}

#[test]
fn a_game_against_the_builtin_engine() {
    let dir = tempfile::tempdir().unwrap();
    let game = play(dir.path(), &["--plies", "16", "--robot", "white", "--depth", "2"]);
    assert_eq!(game["moves"].as_array().unwrap().len(), 16);
}

fn find_stockfish() -> Option<PathBuf> {
    let on_path = std::env::var_os("PATH")
        .map(|paths| std::env::split_paths(&paths).map(|dir| dir.join("stockfish")).collect::<Vec<_>>())
        .unwrap_or_default();
    on_path.into_iter().chain([PathBuf::from("/usr/games/stockfish")]).find(|p| p.is_file())
}

/// A game against Stockfish with the robot playing `robot` for `plies` plies, in `dir`.
fn stockfish_game(dir: &Path, robot: &str, plies: &str) -> Value {
    let stockfish = find_stockfish().expect("stockfish on PATH or in /usr/games");
    // A generous start-up timeout: the other tests (a browser among them) load this machine.
    let args = ["--engine", stockfish.to_str().unwrap(), "--robot", robot, "--plies", plies, "--movetime", "20"];
    play(dir, &[&args[..], &["--engine-timeout", "60000"]].concat())
}

#[test]
#[cfg_attr(not(tool_stockfish), ignore = "needs Stockfish (apt install stockfish); see docs/testing.md")]
fn a_game_against_stockfish() {
    let dir = tempfile::tempdir().unwrap();
    let game = stockfish_game(dir.path(), "white", "20");
    assert!(game["moves"].as_array().unwrap().len() >= 10);
}

/// Stockfish plays both sides for 80 plies and the arm makes every move: each has its
/// clearance on the record and none touches (planned or simulated), with the smallest
/// clearance per move kind said for the record (Stockfish's moves depend on its clock, so the
/// game differs from run to run; the assertions hold for any game on the report's board).
#[test]
#[cfg_attr(not(tool_stockfish), ignore = "needs Stockfish (apt install stockfish); see docs/testing.md")]
fn a_stockfish_game_touches_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let game = stockfish_game(dir.path(), "both", "80");
    let moves = game["moves"].as_array().unwrap();
    assert!(moves.len() >= 20, "{}", moves.len());
    for m in moves {
        let clearance = &m["clearance"];
        assert!(clearance["smallest_mm"].as_f64().unwrap() >= 2.0 - 1e-9, "{m}");
        assert_eq!(clearance["executed"]["contact"], false, "{m}");
    }
    let summary = &game["clearance"];
    assert_eq!(summary["contacts"], 0, "{summary}");
    eprintln!("stockfish game, {} plies: clearance {summary}", moves.len());
}

fn fake_engine(dir: &Path, name: &str, on_go: &str) -> String {
    use std::os::unix::fs::PermissionsExt;
    let path = dir.join(name);
    let script = format!(
        "#!/bin/sh\nwhile read line; do\n  case \"$line\" in\n    uci) echo 'id name fake'; echo uciok ;;\n    isready) echo readyok ;;\n    go*) {on_go} ;;\n    quit) exit 0 ;;\n  esac\ndone\n"
    );
    std::fs::write(&path, script).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    path.display().to_string()
}

#[test]
fn bad_games_and_engines_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    assert_one_line_error(
        &chessarm(&["play", &fixture("illegal_move.pgn"), "--game", "2", "--out", out]),
        &["game 2", "move", "illegal"],
    );
    assert_one_line_error(
        &chessarm(&["play", &fixture("several_games.pgn"), "--game", "9", "--out", out]),
        &["game 9"],
    );
    assert_one_line_error(&chessarm(&["play", "--moves", "e4 e5 Qh9", "--out", out]), &["'Qh9'"]);
    assert_one_line_error(&chessarm(&["play", "--fen", "not a fen", "--moves", "e4", "--out", out]), &["not a fen"]);
    assert_one_line_error(&chessarm(&["play", "/nonexistent/game.pgn", "--out", out]), &["/nonexistent/game.pgn"]);
    assert_one_line_error(
        &chessarm(&["play", "--engine", "/nonexistent/engine", "--out", out]),
        &["/nonexistent/engine"],
    );
    let illegal = fake_engine(dir.path(), "illegal.sh", "echo 'bestmove e2e5'");
    // The robot plays white with its own engine; the fake engine answers for black.
    assert_one_line_error(
        &chessarm(&["play", "--engine", &illegal, "--robot", "black", "--plies", "2", "--out", out]),
        &["e2e5", "illegal"],
    );
    // An engine that hangs after `go`, and one that floods `info` lines, both time out.
    for (name, on_go) in [("hang.sh", "exec sleep 30"), ("flood.sh", "exec yes 'info depth 1 score cp 0'")] {
        let engine = fake_engine(dir.path(), name, on_go);
        let started = std::time::Instant::now();
        let args = [
            "play",
            "--engine",
            &engine,
            "--robot",
            "black",
            "--engine-timeout",
            "300",
            "--movetime",
            "10",
            "--out",
            out,
        ];
        assert_one_line_error(&chessarm(&args), &["within", "ms"]);
        assert!(started.elapsed().as_secs() < 10, "{name} took {:?}", started.elapsed());
    }
    let dying = fake_engine(dir.path(), "die.sh", "exit 3");
    assert_one_line_error(&chessarm(&["play", "--engine", &dying, "--robot", "black", "--out", out]), &["died"]);
    assert_one_line_error(&chessarm(&["play", "--moves", "e4", "--tolerance-mm", "0", "--out", out]), &["0"]);
}

#[test]
fn engines_sending_endless_lines_or_control_characters_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    // 10 MB without a newline: cut off at 64 KiB instead of growing without bound.
    let endless = fake_engine(dir.path(), "endless.sh", "head -c 10000000 /dev/zero | tr '\\0' a");
    let started = std::time::Instant::now();
    assert_one_line_error(
        &chessarm(&["play", "--engine", &endless, "--robot", "black", "--plies", "2", "--out", out]),
        &["sent a line longer than 65536 bytes"],
    );
    assert!(started.elapsed().as_secs_f64() < 20.0);
    // SOH and ESC (a screen clear) in the engine's move: escaped, so the error stays one line
    // and cannot overwrite the terminal.
    let control = fake_engine(dir.path(), "control.sh", "printf 'bestmove e2\\001\\033[2Je4\\n'");
    let output = chessarm(&["play", "--engine", &control, "--robot", "black", "--plies", "2", "--out", out]);
    assert_one_line_error(&output, &["illegal move", "e2\\u{1}\\u{1b}[2Je4"]);
}

/// Whether process `pid` is gone (no /proc entry, or a zombie left for init to reap).
fn gone(pid: &str) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        Ok(stat) => stat.rsplit(')').next().is_some_and(|rest| rest.trim_start().starts_with('Z')),
    }
}

#[test]
fn ctrl_c_during_an_engine_game_takes_the_engine_s_helpers_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let pid_file = dir.path().join("helper.pid");
    // On `go` the engine starts a helper (like an engine's worker process) and thinks for long.
    let engine = fake_engine(
        dir.path(),
        "helper.sh",
        &format!("sleep 1000 > /dev/null 2>&1 & echo $! > {}; sleep 30", pid_file.display()),
    );
    let out = dir.path().join("out");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_chessarm"))
        .args(["play", "--engine", &engine, "--robot", "white", "--plies", "4", "--out", out.to_str().unwrap()])
        // The handler pauses between killing the engine and exiting: the main thread sees the
        // engine die meanwhile and must wait for the handler, not exit with "engine died" (2).
        .env("CHESSARM_TEST_SLOW_SIGNAL_MS", "500")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let helper = loop {
        if let Ok(pid) = std::fs::read_to_string(&pid_file)
            && !pid.trim().is_empty()
        {
            break pid.trim().to_owned();
        }
        assert!(started.elapsed().as_secs() < 60, "the engine's helper never started");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert!(!gone(&helper));
    let status = std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(status.success());
    assert_eq!(child.wait().unwrap().code(), Some(130));
    // SIGKILL of the group is immediate; allow the kernel a moment to tear the process down.
    let killed = std::time::Instant::now();
    while !gone(&helper) {
        assert!(killed.elapsed().as_secs() < 5, "the engine's helper {helper} outlived chessarm");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

#[test]
fn a_game_that_stops_part_way_leaves_nothing_that_passes_for_a_whole_game() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // A finished game in the folder first: its game.json must not survive the failed one.
    let first = chessarm(&["play", "--moves", "e4", "--out", out.to_str().unwrap()]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    assert!(out.join("hardware").is_dir());
    // The robot plays white (its own engine); the opponent's engine answers an illegal move at
    // ply 2, after the robot's first move was planned, simulated and exported.
    let illegal = fake_engine(dir.path(), "illegal.sh", "echo 'bestmove e2e5'");
    let output =
        chessarm(&["play", "--engine", &illegal, "--robot", "white", "--plies", "4", "--out", out.to_str().unwrap()]);
    // The moves so far on the terminal (with --json, on stderr), then the error, one line.
    assert_eq!(output.status.code(), Some(2));
    assert!(output.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&output.stderr);
    let last = stderr.trim_end().lines().last().unwrap();
    for needle in ["stopped at ply 2", "1 played", "e2e5"] {
        assert!(last.starts_with("error:") && last.contains(needle), "{needle}: {stderr}");
    }
    let record: Value = serde_json::from_str(&std::fs::read_to_string(out.join("game.json")).unwrap()).unwrap();
    assert_eq!(record["complete"], false, "{record}");
    assert_eq!(record["failed_at_ply"], 2, "{record}");
    assert!(record["error"].as_str().unwrap().contains("e2e5"), "{record}");
    // The trajectories of the move it made are kept aside, where no driver looks for a game.
    assert!(!out.join("hardware").exists());
    let aside: Vec<String> =
        common::file_names(&out.join("hardware-incomplete")).into_iter().filter(|n| n.ends_with(".json")).collect();
    assert_eq!(aside.len(), 1, "{aside:?}");
    assert!(aside[0].starts_with("001-"), "{aside:?}");
    // A whole game says so.
    let whole = chessarm(&["play", "--moves", "e4", "--out", out.to_str().unwrap()]);
    assert!(whole.status.success(), "{}", String::from_utf8_lossy(&whole.stderr));
    let record: Value = serde_json::from_str(&std::fs::read_to_string(out.join("game.json")).unwrap()).unwrap();
    assert_eq!(record["complete"], true);
}
