//! A person plays the arm (`play --human`), end to end, with the real-arm driver on the
//! simulated servo bus (`bus-sim` on a pseudo-terminal): typed moves on the SO-101's Feetech
//! bus, board occupancy on the OpenManipulator-X's Dynamixel bus; every packet the servos
//! received checked against the arms' URDF limits; the PGN read back by python-chess; a lost
//! reply, an overload and Ctrl-C mid-move stop the arm (torque off, nothing sent after it).

#![allow(clippy::unwrap_used)] // tests

mod common;

use chessarm::app::bus::Protocol;
use chessarm_chess::shakmaty::{Chess, Position};
use common::{BusSim, chessarm, json_file};
use serde_json::Value;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The 20-move games run in real time against a simulated bus in another process: one at a
/// time, so that on a 2-core machine they (and Chromium) do not starve each other's servos.
static REAL_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The reply timeout the games give the driver: the simulated servos are a process that a busy
/// 2-core machine may not run for longer than a real servo's 100 ms (the timeout itself is
/// tested by the lost-reply test, with the default).
const GAME_REPLY_TIMEOUT_MS: &str = "1000";

/// A real arm as a maker runs it: its URDF, its fitted board with needle fingers, its servos
/// with feedforward goals, the bus's addresses (and the gripper's servo).
struct Arm {
    urdf: PathBuf,
    board: PathBuf,
    actuator: &'static str,
    protocol: Protocol,
    extra: Vec<String>,
}

impl Arm {
    fn setup(&self) -> Vec<String> {
        let mut args = vec!["--urdf".to_string(), self.urdf.display().to_string()];
        args.extend(self.extra.iter().cloned());
        args.extend(
            ["--arm", self.board.to_str().unwrap(), "--actuator", self.actuator, "--servo-command", "feedforward"]
                .map(String::from),
        );
        args
    }
}

fn fitted(dir: &Path, urdf: &str, lock: &[&str], actuator: &'static str, protocol: Protocol) -> Arm {
    let urdf = Path::new(common::REAL_ARMS).join(urdf);
    let board = dir.join(format!("{actuator}.toml"));
    common::fit_board(&urdf, lock, &board);
    let mut text = std::fs::read_to_string(&board).unwrap();
    text.push_str(
        "\n[servo_bus]\nids = [11, 12, 13, 14]\ndirections = [1, 1, -1, 1]\nzero_ticks = [2048, 2048, 2048, 2048]\n\
         gripper_id = 16\ngripper_open_ticks = 2500\ngripper_closed_ticks = 2100\n",
    );
    std::fs::write(&board, text).unwrap();
    Arm { urdf, board, actuator, protocol, extra: lock.iter().map(|s| s.to_string()).collect() }
}

fn so101(dir: &Path) -> Arm {
    fitted(dir, "so101_new_calib.urdf", &["--lock", "wrist_roll=0"], "sts3215-12v", Protocol::Feetech)
}

fn open_manipulator(dir: &Path) -> Arm {
    fitted(dir, "open_manipulator_x.urdf", &[], "xm430", Protocol::Dynamixel)
}

fn strs(args: &[String]) -> Vec<&str> {
    args.iter().map(String::as_str).collect()
}

/// The built-in engine's game against itself from the start, 40 plies (its moves are a function
/// of the position alone, so it answers the person's moves the same way): the UCI moves.
fn engine_game(dir: &Path) -> Vec<String> {
    let out = dir.join("reference");
    let output = chessarm(&["play", "--plies", "40", "--out", out.to_str().unwrap()]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let game: Value = serde_json::from_slice(&std::fs::read(out.join("game.json")).unwrap()).unwrap();
    game["moves"].as_array().unwrap().iter().map(|m| m["uci"].as_str().unwrap().to_string()).collect()
}

/// `play --human white` with `setup`, the port of `sim`, `extra` flags, `input` on stdin.
fn play_human(arm: &Arm, sim: &BusSim, out: &Path, extra: &[&str], input: &str) -> std::process::Output {
    let mut args = arm.setup();
    args.extend(["play", "--human", "white", "--port", &sim.device, "--out", out.to_str().unwrap()].map(String::from));
    args.extend(extra.iter().map(|s| s.to_string()));
    let mut child = common::spawn(&args, Stdio::piped());
    child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
    child.wait_with_output().unwrap()
}

/// The URDF's limits of the four arm joints (rad, rad/s), in chain order.
fn urdf_limits(urdf: &Path, names: &[String]) -> Vec<(f64, f64, f64)> {
    let robot = urdf_rs::read_file(urdf).unwrap();
    names
        .iter()
        .map(|name| {
            let joint = robot.joints.iter().find(|j| &j.name == name).unwrap();
            (joint.limit.lower, joint.limit.upper, joint.limit.velocity)
        })
        .collect()
}

/// Every goal packet the simulated servos received, decoded: the joints' goal ticks in the
/// order of `ids`, the time received (s).
fn goal_packets(protocol: Protocol, received: &[(f64, Vec<u8>)], ids: &[u8; 4]) -> Vec<(f64, [i64; 4])> {
    let width = protocol.position_bytes() as usize;
    let mut goals = Vec::new();
    for (t, bytes) in received {
        let packet = protocol.parse_instruction(bytes).unwrap();
        if packet.error != 0x83 {
            continue;
        }
        let (address, length, rest) = match protocol {
            Protocol::Feetech => (packet.params[0] as u16, packet.params[1] as usize, &packet.params[2..]),
            Protocol::Dynamixel => (
                u16::from_le_bytes([packet.params[0], packet.params[1]]),
                u16::from_le_bytes([packet.params[2], packet.params[3]]) as usize,
                &packet.params[4..],
            ),
        };
        if address != protocol.goal_position() {
            continue;
        }
        assert_eq!(length, width);
        let mut ticks = [i64::MIN; 4];
        for chunk in rest.chunks_exact(width + 1) {
            if let Some(j) = ids.iter().position(|i| *i == chunk[0]) {
                ticks[j] = protocol.decode_position(&chunk[1..]).unwrap();
            }
        }
        assert!(ticks.iter().all(|t| *t != i64::MIN), "a goal packet without every joint: {bytes:02X?}");
        goals.push((*t, ticks));
    }
    goals
}

/// Every goal the servos received is within the URDF's joint limits, and between two goals of
/// a bus period a joint moves no faster than its URDF velocity limit allows (plus a tick of
/// rounding): checked from the bus's own description (hardware/servo_bus.json) and the URDF,
/// not the driver's code.
fn check_goals_within_limits(arm: &Arm, out: &Path, goals: &[(f64, [i64; 4])]) -> (usize, [f64; 4]) {
    let bus: Value = serde_json::from_slice(&std::fs::read(out.join("hardware/servo_bus.json")).unwrap()).unwrap();
    let joints = bus["joints"].as_array().unwrap();
    let names: Vec<String> = joints.iter().map(|j| j["joint"].as_str().unwrap().to_string()).collect();
    let limits = urdf_limits(&arm.urdf, &names);
    let period = 1.0 / bus["bus_rate_hz"].as_f64().unwrap();
    let angle = |j: usize, tick: i64| {
        let joint = &joints[j];
        let count = std::f64::consts::TAU / joint["counts_per_revolution"].as_f64().unwrap();
        joint["direction"].as_f64().unwrap() * (tick as f64 - joint["zero_ticks"].as_f64().unwrap()) * count
    };
    let mut fastest = [0.0f64; 4];
    for (k, (t, ticks)) in goals.iter().enumerate() {
        for j in 0..4 {
            let count = std::f64::consts::TAU / joints[j]["counts_per_revolution"].as_f64().unwrap();
            let q = angle(j, ticks[j]);
            let (lower, upper, velocity) = limits[j];
            assert!(q >= lower - count && q <= upper + count, "{} goal {q} rad outside [{lower}, {upper}]", names[j]);
            if k > 0 {
                let change = (q - angle(j, goals[k - 1].1[j])).abs();
                // Over the time between the two goals as the servos received them (a bus period
                // within a move; longer between moves), with the driver's allowance over the
                // joint's speed limit for the host's offsets and a tick of rounding. The driver
                // sends one goal a period and never two closer (a late one slides the rest), so
                // the time is at least the period: the simulated bus logs a goal when it reads
                // it, some milliseconds late on a busy machine, which shortens the next gap.
                let dt = (t - goals[k - 1].0).max(period);
                let allowed = chessarm::app::bus::arm::GOAL_SPEED_ALLOWANCE * velocity * dt + count;
                assert!(change <= allowed, "{}: {change} rad in {dt} s (limit {velocity} rad/s)", names[j]);
                fastest[j] = fastest[j].max((change - count).max(0.0) / dt / velocity);
            }
        }
    }
    (goals.len(), fastest)
}

/// The game.pgn read by python-chess: its moves (UCI), comments and errors.
fn python_chess_reading(out: &Path) -> Value {
    let python = common::python_with("chess").expect("CHESSARM_PYTHON with python-chess");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/live/read_pgn.py");
    let output =
        Command::new(python).args([script.to_str().unwrap(), out.join("game.pgn").to_str().unwrap()]).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).unwrap()
}

/// 20 moves typed by a person (SAN, a mistyped one, an illegal one, a take-back and its move
/// again) against the built-in engine, the SO-101 answering over its Feetech bus: every piece
/// placed, no contact, every goal the servos received within the URDF's limits, the PGN as
/// python-chess reads it the game played (the take-back gone), each arm's move commented.
#[test]
#[cfg_attr(not(tool_python), ignore = "needs CHESSARM_PYTHON, a Python with python-chess; see docs/testing.md")]
fn a_person_types_twenty_moves_and_the_so101_answers_on_its_feetech_bus() {
    let dir = tempfile::tempdir().unwrap();
    let arm = so101(dir.path());
    let reference = engine_game(dir.path());
    let mut position = Chess::default();
    let mut lines = Vec::new();
    for (ply, uci) in reference.iter().enumerate() {
        let m = chessarm_chess::notation::parse_move(uci, &position).unwrap();
        if ply % 2 == 0 {
            let san = chessarm_chess::shakmaty::san::San::from_move(&position, m).to_string();
            match ply {
                2 => lines.extend(["Ke5".to_string(), "hello".to_string()]),
                // The person's 4th move, taken back and played again.
                6 => lines.extend([san.clone(), "undo".to_string()]),
                _ => {}
            }
            lines.push(if ply == 8 { uci.clone() } else { san });
        }
        position.play_unchecked(m);
    }
    let sim = BusSim::start(dir.path(), &strs(&arm.setup()), &[]);
    let out = dir.path().join("game");
    let _one_at_a_time = REAL_TIME.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let output = play_human(
        &arm,
        &sim,
        &out,
        &["--pace", "0.3", "--reply-timeout-ms", GAME_REPLY_TIMEOUT_MS],
        &(lines.join("\n") + "\n"),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let game = json_file(&out.join("game.json"));
    assert_eq!(game["misplaced"].as_array().unwrap().len(), 0, "{}", game["misplaced"]);
    assert_eq!(game["clearance"]["contacts"], 0);
    assert_eq!(game["result"], "*");
    let human = &game["human"];
    // 20 replies kept; the one taken back leaves the arm's timings with its move, though the
    // real arm made it (21 moves on the bus below).
    assert_eq!(human["robot_moves"].as_array().unwrap().len(), 20);
    assert_eq!(human["taken_back"].as_array().unwrap().len(), 2, "{}", human["taken_back"]);
    let refused: Vec<&str> = human["refused_input"].as_array().unwrap().iter().map(|r| r.as_str().unwrap()).collect();
    assert!(refused.len() == 2 && refused[0].contains("Ke5") && refused[1].contains("hello"), "{refused:?}");
    let real = &game["real_arm"];
    assert_eq!(real["moves"], 21);
    // The servos received every goal the driver sent, each within the URDF's limits.
    let goals = goal_packets(arm.protocol, &sim.received(), &[11, 12, 13, 14]);
    // The driver's goals, and the one that holds the joints where they are as the torque goes on.
    assert_eq!(goals.len(), (real["periods"].as_u64().unwrap() + real["ramp_periods"].as_u64().unwrap()) as usize + 1);
    let (count, fastest) = check_goals_within_limits(&arm, &out, &goals);
    eprintln!("{count} goal packets; fastest goal change per joint {fastest:?} of its speed limit; {real}");
    // The PGN: python-chess plays the same 40 plies, without the take-back.
    let read = python_chess_reading(&out);
    assert_eq!(read["errors"].as_array().unwrap().len(), 0, "{read}");
    let played: Vec<&str> = read["uci"].as_array().unwrap().iter().map(|m| m.as_str().unwrap()).collect();
    assert_eq!(played, reference.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(read["headers"]["Result"], "*");
    assert_eq!(read["headers"]["White"], "person");
    let comments = read["comments"].as_array().unwrap();
    for (ply, comment) in comments.iter().enumerate() {
        assert_eq!(
            comment.as_str().is_some_and(|c| c.starts_with("robot ")),
            ply % 2 == 1,
            "ply {}: {comment}",
            ply + 1
        );
    }
    assert_eq!(read["final_fen"], game["final_fen_rules"]);
}

/// The board's readings after each of the person's 20 moves, written by a reader program into
/// the socket chessarm listens on (`--input-socket`), the OpenManipulator-X answering over its
/// Dynamixel bus: a reading no legal move gives is refused (nothing played) and the right one
/// then taken; the same reading sent twice is no move; 0 misplaced, every goal within the
/// URDF's limits, the PGN as python-chess reads it the game played.
#[test]
#[cfg_attr(not(tool_python), ignore = "needs CHESSARM_PYTHON, a Python with python-chess; see docs/testing.md")]
fn a_boards_occupancy_through_a_socket_plays_twenty_moves_on_the_dynamixel_bus() {
    use chessarm_chess::occupancy::reading_of;
    let dir = tempfile::tempdir().unwrap();
    let arm = open_manipulator(dir.path());
    let reference = engine_game(dir.path());
    let mut position = Chess::default();
    let mut lines = Vec::new();
    for (ply, uci) in reference.iter().enumerate() {
        let m = chessarm_chess::notation::parse_move(uci, &position).unwrap();
        if ply == 4 {
            // A piece put down on a square it cannot reach: the from-square emptied and h5 filled.
            let mut wrong = position.board().clone();
            let piece = wrong.remove_piece_at(m.from().unwrap()).unwrap();
            wrong.set_piece_at(chessarm_chess::shakmaty::Square::H5, piece);
            lines.push(reading_of(&wrong));
        }
        let before = reading_of(position.board());
        if ply % 2 == 0 && m.is_capture() {
            // The reader sends the board as the person takes the captured piece off.
            let mut lifted = position.board().clone();
            let _ = lifted.remove_piece_at(m.to());
            lines.push(reading_of(&lifted));
        }
        position.play_unchecked(m);
        if ply % 2 == 0 {
            if ply == 10 {
                // The board's reader repeats the position before the move: nothing moved.
                lines.push(before);
            }
            lines.push(reading_of(position.board()));
        }
    }
    let sim = BusSim::start(dir.path(), &strs(&arm.setup()), &[]);
    let out = dir.path().join("game");
    let socket = dir.path().join("board.sock");
    let mut args = arm.setup();
    args.extend(
        [
            "play",
            "--human",
            "white",
            "--human-input",
            "occupancy",
            "--input-socket",
            socket.to_str().unwrap(),
            "--port",
            &sim.device,
            "--reply-timeout-ms",
            GAME_REPLY_TIMEOUT_MS,
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from),
    );
    let _one_at_a_time = REAL_TIME.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let child = common::spawn(&args, Stdio::null());
    // The reader program connects once chessarm has made its socket.
    let started = std::time::Instant::now();
    let mut stream = loop {
        match std::os::unix::net::UnixStream::connect(&socket) {
            Ok(stream) => break stream,
            Err(_) if started.elapsed().as_secs() < 60 => std::thread::sleep(std::time::Duration::from_millis(50)),
            Err(e) => panic!("chessarm made no socket at {}: {e}", socket.display()),
        }
    };
    stream.write_all((lines.join("\n") + "\n").as_bytes()).unwrap();
    drop(stream);
    let output = child.wait_with_output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    // The socket was chessarm's: removed at the end.
    assert!(!socket.exists());
    let stderr = String::from_utf8_lossy(&output.stderr);
    let game = json_file(&out.join("game.json"));
    assert_eq!(game["misplaced"].as_array().unwrap().len(), 0, "{}", game["misplaced"]);
    assert_eq!(game["clearance"]["contacts"], 0);
    let human = &game["human"];
    assert_eq!(human["input"], "occupancy");
    assert_eq!(human["robot_moves"].as_array().unwrap().len(), 20, "{stderr}");
    let refused: Vec<&str> = human["refused_input"].as_array().unwrap().iter().map(|r| r.as_str().unwrap()).collect();
    assert_eq!(refused.len(), 1, "{refused:?}");
    assert!(refused[0].contains("h5 filled") && refused[0].contains("legal from"), "{refused:?}\n{stderr}");
    let goals = goal_packets(arm.protocol, &sim.received(), &[11, 12, 13, 14]);
    let real = &game["real_arm"];
    assert_eq!(goals.len(), (real["periods"].as_u64().unwrap() + real["ramp_periods"].as_u64().unwrap()) as usize + 1);
    let (count, fastest) = check_goals_within_limits(&arm, &out, &goals);
    eprintln!(
        "{count} goal packets; fastest goal change per joint {fastest:?} of its speed limit; {}",
        game["real_arm"]
    );
    let read = python_chess_reading(&out);
    assert_eq!(read["errors"].as_array().unwrap().len(), 0, "{read}");
    let played: Vec<&str> = read["uci"].as_array().unwrap().iter().map(|m| m.as_str().unwrap()).collect();
    assert_eq!(played, reference.iter().map(String::as_str).collect::<Vec<_>>());
}

/// A servo that stops answering, and one that reports an overload, in the middle of the arm's
/// first move: the game stops with an error naming the servo and the joint, the last packet the
/// servos received is the torque-off broadcast (nothing sent after it), and game.pgn holds the
/// person's move only, so the game can be resumed.
#[test]
fn a_lost_reply_or_an_overload_mid_move_turns_the_torque_off_and_sends_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    for (arm, fault, needles) in [
        (so101(dir.path()), "--lose-reply", vec!["servo 13 (joint 3", "did not answer within 100 ms", "torque off"]),
        (open_manipulator(dir.path()), "--overload", vec!["servo 12 (joint 2", "overload", "torque off"]),
    ] {
        let id = if fault == "--lose-reply" { "13@120" } else { "12@120" };
        let sim = BusSim::start(dir.path(), &strs(&arm.setup()), &[fault, id]);
        let out = dir.path().join(format!("game{fault}"));
        let output = play_human(&arm, &sim, &out, &[], "e4\nd4\n");
        assert!(!output.status.success());
        let stderr = String::from_utf8_lossy(&output.stderr);
        for needle in &needles {
            assert!(stderr.contains(needle), "{fault}: {needle:?} in\n{stderr}");
        }
        let received = sim.received();
        let protocol = arm.protocol;
        let torque_off = protocol.write(Protocol::BROADCAST, protocol.torque_enable(), &[0]);
        assert_eq!(received.last().unwrap().1, torque_off, "{fault}: the last packet is not the torque-off");
        let goals = goal_packets(protocol, &received, &[11, 12, 13, 14]);
        // Mid-move: the fault came at the 120th goal packet, and the driver stopped at the next.
        assert!((120..=122).contains(&goals.len()), "{fault}: {} goal packets", goals.len());
        let read = std::fs::read_to_string(out.join("game.pgn")).unwrap();
        assert!(read.contains("1. e4 *"), "{fault}: {read}");
        let game = json_file(&out.join("game.json"));
        assert_eq!(game["complete"], false);
    }
}

/// Ctrl-C while the arm moves: torque off is the last packet the servos receive, and the exit
/// code is the signal's (130).
#[test]
fn ctrl_c_mid_move_turns_the_torque_off_last() {
    let dir = tempfile::tempdir().unwrap();
    let arm = so101(dir.path());
    let sim = BusSim::start(dir.path(), &strs(&arm.setup()), &[]);
    let out = dir.path().join("game");
    let mut args = arm.setup();
    args.extend(["play", "--human", "white", "--port", &sim.device, "--out", out.to_str().unwrap()].map(String::from));
    let mut child = Command::new(env!("CARGO_BIN_EXE_chessarm"))
        .args(&args)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"e4\n").unwrap();
    // Wait until goals flow, then interrupt.
    let started = std::time::Instant::now();
    while goal_packets(arm.protocol, &sim.received(), &[11, 12, 13, 14]).len() < 50 {
        assert!(started.elapsed().as_secs() < 120, "no goals reached the servos");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    // The simulated bus logs what reached it: give it a moment to read the last bytes.
    std::thread::sleep(std::time::Duration::from_millis(300));
    let received = sim.received();
    let protocol = arm.protocol;
    let torque_off = protocol.write(Protocol::BROADCAST, protocol.torque_enable(), &[0]);
    assert_eq!(received.last().unwrap().1, torque_off);
    drop(stdin);
}

/// A dry run opens no port: it logs the packets the arm would be sent (sync reads and writes
/// at the bus rate) in bus.jsonl, and the game is played as without it.
#[test]
fn a_dry_run_logs_the_packets_and_opens_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let arm = so101(dir.path());
    let out = dir.path().join("game");
    let mut args = arm.setup();
    args.extend(["play", "--moves", "e4 e5", "--dry-run", "--out", out.to_str().unwrap()].map(String::from));
    let output = chessarm(&strs(&args));
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let game = json_file(&out.join("game.json"));
    assert_eq!(game["real_arm"]["dry_run"], true);
    assert_eq!(game["real_arm"]["moves"], 2);
    let log = std::fs::read_to_string(out.join("bus.jsonl")).unwrap();
    let sent: Vec<Vec<u8>> = log
        .lines()
        .map(|line| {
            let value: Value = serde_json::from_str(line).unwrap();
            let hex = value["sent"].as_str().unwrap();
            (0..hex.len()).step_by(2).map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap()).collect()
        })
        .collect();
    let periods =
        (game["real_arm"]["periods"].as_u64().unwrap() + game["real_arm"]["ramp_periods"].as_u64().unwrap()) as usize;
    // Per period a sync read and a sync write (the ramp's too); the torque going on (a read, a
    // sync write, a write per servo, the gripper's too).
    assert_eq!(sent.len(), 2 * periods + 2 + 5);
    let goals: Vec<(f64, Vec<u8>)> = sent.iter().map(|s| (0.0, s.clone())).collect();
    assert_eq!(goal_packets(arm.protocol, &goals, &[11, 12, 13, 14]).len(), periods + 1);
}

/// Bad input on the live loop's flags: a port that is not there, a port with torque motors, a
/// socket path where a file is, --resume with no game: each a one-line error naming it; the
/// user's file untouched.
#[test]
fn the_live_loops_bad_input_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let arm = so101(dir.path());
    let mut args = arm.setup();
    args.extend(["play", "--moves", "e4", "--port", "/dev/nonexistent-chessarm", "--out", out].map(String::from));
    // (The URDF's notes come first: the error is the last line.)
    let output = chessarm(&strs(&args));
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr
            .trim_end()
            .lines()
            .last()
            .unwrap()
            .starts_with("error: --port /dev/nonexistent-chessarm: cannot open it"),
        "{stderr}"
    );
    common::assert_one_line_error(
        &chessarm(&["play", "--moves", "e4", "--dry-run", "--out", out]),
        &["--port and --dry-run drive servos", "--actuator"],
    );
    let yours = dir.path().join("yours.txt");
    std::fs::write(&yours, "mine").unwrap();
    let output = chessarm(&["play", "--human", "white", "--input-socket", yours.to_str().unwrap(), "--out", out]);
    common::assert_one_line_error(&output, &["--input-socket", "a file is there"]);
    assert_eq!(std::fs::read_to_string(&yours).unwrap(), "mine");
    let fresh = dir.path().join("fresh");
    common::assert_one_line_error(
        &chessarm(&["play", "--human", "black", "--resume", "--out", fresh.to_str().unwrap()]),
        &["--resume", "game.pgn"],
    );
    common::assert_one_line_error(&chessarm(&["bus-sim", "--lose-reply", "3x"]), &["'3x'", "ID@N"]);
}

/// Why the browser test cannot run here, if it cannot (Chromium, Node.js, playwright-core).
fn missing_browser() -> Option<String> {
    let chromium = std::env::var("CHESSARM_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    if !Path::new(&chromium).exists() {
        return Some(format!("{chromium} is not installed"));
    }
    let browser = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser/node_modules/playwright-core");
    (!browser.exists()).then(|| "playwright-core is not installed (npm ci in crates/cli/tests/browser)".into())
}

/// 20 moves clicked on the live page in headless Chromium against the built-in engine, the
/// OpenManipulator-X answering on the simulated Dynamixel bus: the page on 127.0.0.1 only,
/// nothing loaded from anywhere else, no page error; after each click the arm's reply on the
/// page's board and move list; the 3D scene of the game loaded; every piece placed; the PGN as
/// python-chess reads it the game played. A second game on the same port is refused, naming it.
#[test]
#[cfg_attr(
    not(all(tool_browser, tool_python)),
    ignore = "needs Chromium, Node.js, playwright-core and CHESSARM_PYTHON with python-chess; see docs/testing.md"
)]
fn twenty_moves_clicked_on_the_live_page_with_the_arm_on_its_bus() {
    if let Some(reason) = missing_browser() {
        panic!("this test needs a browser: {reason} (see docs/testing.md)");
    }
    let dir = tempfile::tempdir().unwrap();
    let arm = open_manipulator(dir.path());
    let reference = engine_game(dir.path());
    let white: Vec<&str> = reference.iter().step_by(2).map(String::as_str).collect();
    let sim = BusSim::start(dir.path(), &strs(&arm.setup()), &[]);
    let out = dir.path().join("game");
    let mut args = arm.setup();
    args.extend(
        ["play", "--human", "white", "--live", "0", "--port", &sim.device, "--out", out.to_str().unwrap()]
            .map(String::from),
    );
    args.extend(["--reply-timeout-ms".to_string(), GAME_REPLY_TIMEOUT_MS.to_string()]);
    let _one_at_a_time = REAL_TIME.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let (mut child, url, rest) = common::start_with_live_page(&args);
    // The same port again: refused, naming it.
    let port = url.split('?').next().unwrap().trim_end_matches('/').rsplit(':').next().unwrap().to_string();
    let again =
        chessarm(&["play", "--human", "white", "--live", &port, "--out", dir.path().join("again").to_str().unwrap()]);
    common::assert_one_line_error(&again, &[&format!("--live {port}"), "127.0.0.1"]);
    let screenshot = dir.path().join("live.png");
    let probe = Command::new("node")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser/live.mjs"))
        .args([&url, screenshot.to_str().unwrap(), &white.join(",")])
        .output()
        .unwrap();
    let status = child.wait().unwrap();
    let stderr_text = rest.join().unwrap();
    assert!(probe.status.success(), "{}", String::from_utf8_lossy(&probe.stderr));
    let report: Value = serde_json::from_slice(&probe.stdout).unwrap();
    assert!(status.success(), "{stderr_text}");
    assert_eq!(report["errors"].as_array().unwrap().len(), 0, "{report}");
    // Only the page's own address (and the blobs the 3D scene makes of its scripts).
    let origin = url.split('?').next().unwrap();
    for request in report["requests"].as_array().unwrap() {
        let request = request.as_str().unwrap();
        assert!(request.starts_with(origin) || request.starts_with(&format!("blob:{origin}")), "{request}");
    }
    assert_eq!(report["clicked"].as_array().unwrap().len(), 20, "{report}");
    let plies: Vec<u64> = report["plies"].as_array().unwrap().iter().map(|p| p.as_u64().unwrap()).collect();
    assert_eq!(plies, (1..=20).map(|k| 2 * k).collect::<Vec<u64>>());
    assert_eq!(report["scene"]["ready"], true);
    assert_eq!(report["scene"]["moves"], 40);
    assert!(report["moves_text"].as_str().unwrap().starts_with("1. "), "{report}");
    let evaluation = report["evaluation_text"].as_str().unwrap();
    assert!(evaluation.parse::<f64>().is_ok(), "{evaluation}");
    let game = json_file(&out.join("game.json"));
    assert_eq!(game["misplaced"].as_array().unwrap().len(), 0, "{}", game["misplaced"]);
    assert_eq!(game["clearance"]["contacts"], 0);
    assert_eq!(game["real_arm"]["moves"], 20);
    let read = python_chess_reading(&out);
    let played: Vec<&str> = read["uci"].as_array().unwrap().iter().map(|m| m.as_str().unwrap()).collect();
    assert_eq!(played, reference.iter().map(String::as_str).collect::<Vec<_>>());
    let copy = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/test-artifacts");
    std::fs::create_dir_all(&copy).unwrap();
    std::fs::copy(&screenshot, copy.join("live-page.png")).unwrap();
}
