//! The live loop under bad input, as an attacker or a careless user gives it: the live page
//! driven by other sites or out of turn, input that never ends a line, endless refused lines,
//! control characters, the typed words at every prompt, a take-back's record, the input socket
//! after a signal, and input flags without `--human`. Each case ends with a clear one-line
//! error or the right behaviour; the report's arm with its torque motors (no bus) keeps them
//! quick.

#![allow(clippy::unwrap_used)] // tests

mod common;

use chessarm_chess::shakmaty::{Chess, Position, fen::Fen, uci::UciMove};
use common::{chessarm, json_file};
use serde_json::Value;
use std::io::{Read, Write};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `play` with `args` (and `--json`) and `input` on standard input; killed (and the test
/// failed) if it runs longer than `limit` — a loop that never ends must not hang the suite.
fn play_with_input(args: &[&str], input: &[u8], limit: Duration) -> Output {
    let mut child = common::spawn(&[args, &["--json"]].concat(), Stdio::piped());
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    // Written on a thread: the child may stop reading (and the pipe fill) before the end.
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&input);
    });
    let output = wait_within(child, limit);
    let _ = writer.join();
    output
}

fn wait_within(mut child: Child, limit: Duration) -> Output {
    let started = Instant::now();
    let stdout = child.stdout.take();
    let stderr = child.stderr.take();
    let out = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut stdout) = stdout {
            stdout.read_to_end(&mut bytes).unwrap();
        }
        bytes
    });
    let err = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut stderr) = stderr {
            stderr.read_to_end(&mut bytes).unwrap();
        }
        bytes
    });
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > limit {
            child.kill().unwrap();
            let _ = child.wait();
            panic!("still running after {limit:?}: {}", String::from_utf8_lossy(&err.join().unwrap()));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Output { status, stdout: out.join().unwrap(), stderr: err.join().unwrap() }
}

/// Exit code 2 and the last line on standard error an error holding every `needle` (the
/// prompts come before it).
fn assert_error_last(output: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    let last = stderr.trim_end().lines().last().unwrap_or("");
    assert!(last.starts_with("error: "), "{stderr}");
    for needle in needles {
        assert!(last.contains(needle), "'{needle}' missing from: {stderr}");
    }
}

/// The occupancy (a `0x` bitboard, a1 the lowest bit) after `uci` in the position `fen`.
fn reading_after(fen: &str, uci: &str) -> String {
    let mut position: Chess =
        fen.parse::<Fen>().unwrap().into_position(chessarm_chess::shakmaty::CastlingMode::Standard).unwrap();
    let m = uci.parse::<UciMove>().unwrap().to_move(&position).unwrap();
    position.play_unchecked(m);
    format!("0x{:016x}", u64::from(position.board().occupied()))
}

/// A file of zeros (no line end) and a stream of endless lines end the game with exit 2, the
/// game saved; well within a minute (they never ended before).
#[test]
fn input_that_never_ends_a_line_stops_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("zero");
    let output = play_with_input(
        &["play", "--human", "white", "--input-file", "/dev/zero", "--out", out.to_str().unwrap()],
        b"",
        Duration::from_secs(120),
    );
    assert_error_last(&output, &["line of over 4096 bytes", "\\0\\0"]);
    // The moves so far (none) are saved, to go on with.
    assert!(out.join("game.pgn").is_file());
    // A line of megabytes from standard input: the same.
    let out = dir.path().join("long");
    let long = vec![b'e'; 3_000_000];
    let output =
        play_with_input(&["play", "--human", "white", "--out", out.to_str().unwrap()], &long, Duration::from_secs(120));
    assert_error_last(&output, &["line of over 4096 bytes"]);
    // A line of exactly 4096 bytes is a line (refused as no move, the game goes on).
    let out = dir.path().join("exact");
    let exact = format!("{}\nquit\n", "e".repeat(4096));
    let output = play_with_input(
        &["play", "--human", "white", "--out", out.to_str().unwrap()],
        exact.as_bytes(),
        Duration::from_secs(120),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
}

/// 900 refused lines of 4 000 bytes each: the record keeps the first 100, cut short, and
/// counts them all; game.json stays small (it held every line, 162 MB for 20 000, before).
/// Lines that never give a move end the game after 1 000 in a row (random bytes wrote 500 MB
/// of refusals to the terminal in 10 s).
#[test]
fn refused_input_is_kept_within_bounds() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let line = format!("{}\n", "z".repeat(3999));
    let input = line.repeat(900) + "quit\n";
    let output = play_with_input(
        &["play", "--human", "white", "--out", out.to_str().unwrap()],
        input.as_bytes(),
        Duration::from_secs(300),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let game = json_file(&out.join("game.json"));
    let human = &game["human"];
    assert_eq!(human["refused_lines"], 900);
    assert_eq!(human["refused_bytes"], 900 * 3999);
    let kept = human["refused_input"].as_array().unwrap();
    assert_eq!(kept.len(), 100);
    assert!(kept.iter().all(|k| k.as_str().unwrap().chars().count() <= 200));
    let size = std::fs::metadata(out.join("game.json")).unwrap().len();
    assert!(size < 200_000, "game.json is {size} bytes");
    let endless = dir.path().join("endless");
    let output = play_with_input(
        &["play", "--human", "white", "--out", endless.to_str().unwrap()],
        "zz\n".repeat(5000).as_bytes(),
        Duration::from_secs(300),
    );
    assert_error_last(&output, &["no move in 1000 lines in a row", "'zz'"]);
    let said = String::from_utf8_lossy(&output.stderr).lines().filter(|l| l.starts_with("not played")).count();
    assert_eq!(said, 1000);
}

/// Escape sequences, a bell and NULs typed are shown escaped, never sent to the terminal.
#[test]
fn control_characters_in_the_input_are_shown_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // (The last, U+202E, turns the rest of a line around on a terminal that honours it.)
    let input = b"\x1b[2J\x1b]0;owned\x07e9\0\x9b\xe2\x80\xaeabc\nquit\n";
    let output =
        play_with_input(&["play", "--human", "white", "--out", out.to_str().unwrap()], input, Duration::from_secs(120));
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("not played"), "{stderr}");
    for raw in [b'\x1b', b'\x07', b'\0'] {
        assert!(!output.stderr.contains(&raw), "raw {raw:#x} on the terminal: {stderr}");
    }
    assert!(stderr.contains("\\u{1b}[2J") && stderr.contains("\\u{202e}abc"), "{stderr}");
    assert!(!stderr.contains('\u{202e}'), "{stderr}");
    let game = json_file(&out.join("game.json"));
    let kept = game["human"]["refused_input"][0].as_str().unwrap();
    assert!(!kept.contains('\x1b') && kept.contains("\\u{1b}"), "{kept}");
}

/// `quit` at the promotion prompt and `resign` at the "which was it?" prompt end the game as
/// they do at the move prompt (they were taken for bad answers before).
#[test]
fn the_typed_words_work_at_every_prompt() {
    let dir = tempfile::tempdir().unwrap();
    // From `fen`, the board's reading after `uci`, then `word` at the prompt that reading
    // brings: the game ends with `result`, no line refused; the run's stderr.
    let answer = |name: &str, fen: &str, uci: &str, word: &str, result: &str| {
        let out = dir.path().join(name);
        let input = format!("{}\n{word}\n", reading_after(fen, uci));
        let output = play_with_input(
            &["play", "--human", "white", "--human-input", "occupancy", "--fen", fen, "--out", out.to_str().unwrap()],
            input.as_bytes(),
            Duration::from_secs(120),
        );
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let game = json_file(&out.join("game.json"));
        assert_eq!(game["result"], result, "{game}");
        assert_eq!(game["human"]["refused_lines"], 0);
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    // A pawn on a7: the reading after a7a8 asks which piece it became.
    let stderr = answer("promotion", "4k3/P7/8/8/8/8/8/4K3 w - - 0 1", "a7a8q", "quit", "*");
    assert!(stderr.contains("promotion: which piece"), "{stderr}");
    assert!(!stderr.contains("not played"), "quit was refused: {stderr}");
    // The rook on a1 takes on a5 or on e1: only a1 empties, so the board reads alike.
    let stderr = answer("which", "4k3/8/8/p7/8/8/8/R3b1K1 w - - 0 1", "a1a5", "resign", "0-1");
    assert!(stderr.contains("which was it?"), "{stderr}");
}

/// The person sits across from the arm: playing white on the report's board (rank 1 on the
/// arm's side), the squares are turned half a turn on the table so white's first rank is the
/// farthest from the arm, and the arm plays its reply there with every piece in place; playing
/// black, the board stands.
#[test]
fn the_person_sits_across_from_the_arm() {
    let dir = tempfile::tempdir().unwrap();
    let king_y = |game: &Value, square: &str| {
        let table = game["final_table"].as_array().unwrap();
        let king = table.iter().find(|p| p["location"] == square).unwrap_or_else(|| panic!("{square}: {game}"));
        assert!(king["piece"].as_str().unwrap().ends_with("king"), "{king}");
        king["y_m"].as_f64().unwrap()
    };
    for (person, input, turned) in [("white", "e4\nquit\n", true), ("black", "quit\n", false)] {
        let out = dir.path().join(person);
        let output = play_with_input(
            &["play", "--human", person, "--out", out.to_str().unwrap()],
            input.as_bytes(),
            Duration::from_secs(300),
        );
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let stderr = String::from_utf8_lossy(&output.stderr);
        let said = if turned { "seat: the squares turned half a turn" } else { "plays black from across the board" };
        assert!(stderr.contains(said), "{stderr}");
        let game = json_file(&out.join("game.json"));
        assert_eq!(game["board"]["squares_turned"], turned, "{game}");
        // The report's arm stands at the origin, the board along +y: the person's first rank
        // is the farther one.
        let (own, other) = if person == "white" { ("e1", "e8") } else { ("e8", "e1") };
        assert!(king_y(&game, own) > king_y(&game, other) + 0.3, "{person}: {game}");
        // The arm moved (its reply to e4, or white's first move) with every piece in place.
        assert_eq!(game["moves"].as_array().unwrap().len(), if turned { 2 } else { 1 }, "{game}");
        assert_eq!(game["misplaced"].as_array().unwrap().len(), 0, "{game}");
    }
}

/// After a take-back the folder holds one game: moves/ only the played moves' CSVs, game.json
/// the plies game.pgn has (the taken-back ones listed apart), the summary the same count.
#[test]
fn a_take_back_leaves_one_true_record() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let output = play_with_input(
        &["play", "--human", "white", "--out", out.to_str().unwrap()],
        b"e4\nundo\nd4\nquit\n",
        Duration::from_secs(300),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let game = json_file(&out.join("game.json"));
    let moves = game["moves"].as_array().unwrap();
    assert_eq!(moves.len(), 2, "{game}");
    assert_eq!(moves[0]["san"], "d4");
    let pgn = std::fs::read_to_string(out.join("game.pgn")).unwrap();
    assert!(pgn.contains("[PlyCount \"2\"]") && pgn.contains("1. d4"), "{pgn}");
    assert!(!pgn.contains("e4 "), "{pgn}");
    let summary: Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(summary["plies"], 2, "{summary}");
    let taken: Vec<&str> =
        game["human"]["taken_back"].as_array().unwrap().iter().map(|t| t["san"].as_str().unwrap()).collect();
    assert_eq!(taken.len(), 2);
    assert_eq!(taken[0], "e4");
    // The arm's timings: its one reply in the game (ply 2), not the taken-back one.
    let timed: Vec<u64> =
        game["human"]["robot_moves"].as_array().unwrap().iter().map(|m| m["ply"].as_u64().unwrap()).collect();
    assert_eq!(timed, [2]);
    let csvs: Vec<String> =
        common::file_names(&out.join("moves")).into_iter().filter(|n| n.ends_with(".csv")).collect();
    assert_eq!(csvs.len(), 1, "{csvs:?}");
    assert!(csvs[0].starts_with("002-"), "{csvs:?}");
}

/// The input socket goes with the program however it ends: Ctrl-C and SIGTERM included (it
/// stayed, and the next run refused to start, before).
#[test]
fn the_input_socket_is_removed_on_a_signal() {
    let dir = tempfile::tempdir().unwrap();
    for signal in ["INT", "TERM"] {
        let socket = dir.path().join(format!("board-{signal}.sock"));
        let out = dir.path().join(format!("out-{signal}"));
        let child = common::spawn(
            &["play", "--human", "white", "--input-socket", socket.to_str().unwrap(), "--out", out.to_str().unwrap()],
            Stdio::null(),
        );
        let started = Instant::now();
        while !socket.exists() {
            assert!(started.elapsed() < Duration::from_secs(60), "no socket");
            std::thread::sleep(Duration::from_millis(20));
        }
        // A reader connects, as a board would, then the signal comes while the game waits.
        let _board = std::os::unix::net::UnixStream::connect(&socket).unwrap();
        std::thread::sleep(Duration::from_millis(300));
        let killed = Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status().unwrap();
        assert!(killed.success());
        let output = wait_within(child, Duration::from_secs(60));
        assert_eq!(output.status.code(), Some(130), "{}", String::from_utf8_lossy(&output.stderr));
        assert!(!socket.exists(), "SIG{signal} left the socket behind");
    }
    // A socket left by a run that SIGKILL ended (no program can catch it): nobody listens on
    // it, so the next run replaces it; a socket somebody listens on, or a file, stays refused.
    let stale = dir.path().join("stale.sock");
    drop(std::os::unix::net::UnixListener::bind(&stale).unwrap());
    assert!(stale.exists());
    let out = dir.path().join("out-stale");
    let child = common::spawn(
        &["play", "--human", "white", "--input-socket", stale.to_str().unwrap(), "--out", out.to_str().unwrap()],
        Stdio::null(),
    );
    let started = Instant::now();
    // The board connects once chessarm listens on its new socket.
    let mut board = loop {
        if let Ok(stream) = std::os::unix::net::UnixStream::connect(&stale) {
            break stream;
        }
        assert!(started.elapsed() < Duration::from_secs(60), "no socket");
        std::thread::sleep(Duration::from_millis(20));
    };
    board.write_all(b"quit\n").unwrap();
    let output = wait_within(child, Duration::from_secs(60));
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(String::from_utf8_lossy(&output.stderr).contains("replacing a socket nobody listens on"));
    assert!(!stale.exists());
    let live = dir.path().join("live.sock");
    let listening = std::os::unix::net::UnixListener::bind(&live).unwrap();
    let output = chessarm(&[
        "play",
        "--human",
        "white",
        "--input-socket",
        live.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    common::assert_one_line_error(&output, &["--input-socket", "a file is there"]);
    // Told apart without connecting: a connection would have been taken by the run that
    // listens as its board's reader (and ended its game).
    listening.set_nonblocking(true).unwrap();
    assert!(listening.accept().is_err_and(|e| e.kind() == std::io::ErrorKind::WouldBlock));
}

/// Input flags without `--human` are refused, naming the flag (they were ignored before, and
/// `--resume` left an old game.pgn beside a new game.json).
#[test]
fn input_flags_without_a_person_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let socket = dir.path().join("s.sock");
    for flags in [
        vec!["--live", "0"],
        vec!["--input-file", "/dev/null"],
        vec!["--input-socket", socket.to_str().unwrap()],
        vec!["--resume"],
        vec!["--human-input", "occupancy"],
        vec!["--human-input", "typed"],
    ] {
        let mut args = vec!["play", "--moves", "e4", "--out", out];
        args.extend(&flags);
        let output = chessarm(&args);
        common::assert_one_line_error(&output, &[flags[0], "--human"]);
        assert!(!Path::new(out).join("game.json").exists(), "{flags:?} wrote game.json");
    }
    // And the flags of other games with a person's: refused, not ignored.
    for flags in [["--plies", "1"], ["--game", "3"]] {
        let mut args = vec!["play", "--human", "white", "--out", out];
        args.extend(flags);
        let output = chessarm(&args);
        assert_eq!(output.status.code(), Some(2), "{flags:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(flags[0]) && stderr.contains("--human"), "{stderr}");
    }
}

/// Raw HTTP to the live page.
fn exchange(port: u16, text: &str) -> String {
    let mut stream = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    stream.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    stream.write_all(text.as_bytes()).unwrap();
    let mut answer = String::new();
    stream.read_to_string(&mut answer).unwrap();
    answer
}

/// Another site cannot play, resign or stop the game, nor read it by rebinding a name to
/// 127.0.0.1; the page's own second click while the arm moves is refused, not queued.
#[test]
fn only_the_live_page_plays_and_only_in_turn() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let (child, address, rest) =
        common::start_with_live_page(&["play", "--human", "white", "--live", "0", "--out", out.to_str().unwrap()]);
    // The address chessarm prints, with the run's token.
    let (origin, token) = address.split_once("/?token=").unwrap();
    let (port, token): (u16, String) = (origin.rsplit(':').next().unwrap().parse().unwrap(), token.to_string());
    let host = format!("127.0.0.1:{port}");
    let origin = format!("http://{host}");
    let post = |path: &str, body: &str, headers: &str| {
        exchange(
            port,
            &format!(
                "POST {path} HTTP/1.1\r\n{headers}Content-Type: text/plain\r\nContent-Length: {}\r\n\r\n{body}",
                body.len()
            ),
        )
    };
    let plies = |token: &str| -> Value {
        let answer =
            exchange(port, &format!("GET /state HTTP/1.1\r\nHost: {host}\r\nX-Chessarm-Token: {token}\r\n\r\n"));
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        serde_json::from_str(answer.split("\r\n\r\n").nth(1).unwrap()).unwrap()
    };
    // The page: not without the token (another user of the machine cannot read it off the
    // page), and with it the page carries it.
    assert!(exchange(port, &format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n")).starts_with("HTTP/1.1 403"));
    let page = exchange(port, &format!("GET /?token={token} HTTP/1.1\r\nHost: {host}\r\n\r\n"));
    assert!(page.starts_with("HTTP/1.1 200"));
    assert!(page.contains(&format!("name=\"chessarm-token\" content=\"{token}\"")));
    assert_eq!(token.len(), 32, "{token}");
    let started = Instant::now();
    while plies(&token)["plies"].is_null() {
        // The game has not shown its first state yet.
        assert!(started.elapsed() < Duration::from_secs(120));
        std::thread::sleep(Duration::from_millis(50));
    }
    // Now the game waits for the person: what other sites send must change nothing.
    while plies(&token)["your_turn"] != true {
        assert!(started.elapsed() < Duration::from_secs(120));
        std::thread::sleep(Duration::from_millis(50));
    }
    // Another site's form: no token, its own Origin.
    let evil = format!("Host: {host}\r\nOrigin: http://evil.example\r\n");
    assert!(post("/move", "e2e4", &evil).starts_with("HTTP/1.1 403"));
    assert!(post("/command", "quit", &evil).starts_with("HTTP/1.1 403"));
    // DNS rebinding: the page and its state asked for under another name.
    assert!(exchange(port, "GET /state HTTP/1.1\r\nHost: evil.example\r\n\r\n").starts_with("HTTP/1.1 403"));
    assert!(
        exchange(port, &format!("GET / HTTP/1.1\r\nHost: evil.example:{port}\r\n\r\n")).starts_with("HTTP/1.1 403")
    );
    // The page's own undo before the person has moved: nothing to take back (422), nothing done.
    let own_early = format!("Host: {host}\r\nOrigin: {origin}\r\nX-Chessarm-Token: {token}\r\n");
    let undo = post("/command", "undo", &own_early);
    assert!(undo.starts_with("HTTP/1.1 422") && undo.contains("nothing to take back"), "{undo}");
    // Without the token, even naming the page's own origin.
    let tokenless = format!("Host: {host}\r\nOrigin: {origin}\r\n");
    assert!(post("/move", "e2e4", &tokenless).starts_with("HTTP/1.1 403"));
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(plies(&token)["plies"], 0, "a refused request changed the game");
    // The page's own move, then at once a second one: refused while the first is played.
    let own = format!("Host: {host}\r\nOrigin: {origin}\r\nX-Chessarm-Token: {token}\r\n");
    let started = Instant::now();
    let first = loop {
        let answer = post("/move", "e2e4", &own);
        if !answer.contains("not now") {
            break answer;
        }
        // The game had not asked for the person's move yet.
        assert!(started.elapsed() < Duration::from_secs(120), "{answer}");
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(first.starts_with("HTTP/1.1 202"), "{first}");
    let second = post("/move", "g1f3", &own);
    assert!(second.starts_with("HTTP/1.1 409") && second.contains("not now"), "{second}");
    for command in ["undo", "resign", "quit"] {
        assert!(post("/command", command, &own).starts_with("HTTP/1.1 409"), "{command}");
    }
    // The arm's reply, then the person stops the game.
    while plies(&token)["plies"] != 2 || plies(&token)["your_turn"] != true {
        assert!(started.elapsed() < Duration::from_secs(300), "the arm did not answer");
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(post("/command", "quit", &own).starts_with("HTTP/1.1 202"));
    let output = wait_within(child, Duration::from_secs(120));
    let stderr = rest.join().unwrap();
    assert!(output.status.success(), "{stderr}");
    let pgn = std::fs::read_to_string(out.join("game.pgn")).unwrap();
    assert!(pgn.contains("[PlyCount \"2\"]") && pgn.contains("1. e4") && !pgn.contains("Nf3"), "{pgn}");
}
