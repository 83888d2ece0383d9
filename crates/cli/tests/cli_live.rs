//! A person plays the arm (`play --human`), end to end, with the real-arm driver on the
//! simulated servo bus (`bus-sim` on a pseudo-terminal): typed moves on the SO-101's Feetech
//! bus, board occupancy on the OpenManipulator-X's Dynamixel bus; every packet the servos
//! received checked against the arms' URDF limits; the PGN read back by python-chess; a lost
//! reply, an overload and Ctrl-C mid-move stop the arm (torque off, nothing sent after it).

#![allow(clippy::unwrap_used)] // tests

mod common;

use chessarm::bus::Protocol;
use chessarm_chess::shakmaty::{Chess, Position};
use common::{BusSim, chessarm};
use serde_json::Value;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const FIXTURES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/real-arms");

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
    let urdf = Path::new(FIXTURES).join(urdf);
    let board = dir.join(format!("{actuator}.toml"));
    let mut args = vec!["--urdf", urdf.to_str().unwrap()];
    args.extend(lock);
    args.extend(["--arm", common::NEEDLE_FINGERS, "board", "--fit", "--save", board.to_str().unwrap()]);
    let fit = chessarm(&args);
    assert!(fit.status.success(), "{}", String::from_utf8_lossy(&fit.stderr));
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
    let mut child = Command::new(env!("CARGO_BIN_EXE_chessarm"))
        .args(&args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
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
    for (k, (_, ticks)) in goals.iter().enumerate() {
        for j in 0..4 {
            let count = std::f64::consts::TAU / joints[j]["counts_per_revolution"].as_f64().unwrap();
            let q = angle(j, ticks[j]);
            let (lower, upper, velocity) = limits[j];
            assert!(q >= lower - count && q <= upper + count, "{} goal {q} rad outside [{lower}, {upper}]", names[j]);
            if k > 0 {
                let change = (q - angle(j, goals[k - 1].1[j])).abs();
                fastest[j] = fastest[j].max(change / period);
                assert!(
                    change <= velocity * period + count,
                    "{}: {change} rad in one period (limit {velocity} rad/s)",
                    names[j]
                );
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

fn json_file(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
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
    let output = play_human(&arm, &sim, &out, &["--pace", "0.3"], &(lines.join("\n") + "\n"));
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let game = json_file(&out.join("game.json"));
    assert_eq!(game["misplaced"].as_array().unwrap().len(), 0, "{}", game["misplaced"]);
    assert_eq!(game["clearance"]["contacts"], 0);
    assert_eq!(game["result"], "*");
    let human = &game["human"];
    // 20 replies, and the one taken back.
    assert_eq!(human["robot_moves"].as_array().unwrap().len(), 21);
    let refused: Vec<&str> = human["refused_input"].as_array().unwrap().iter().map(|r| r.as_str().unwrap()).collect();
    assert!(refused.len() == 2 && refused[0].contains("Ke5") && refused[1].contains("hello"), "{refused:?}");
    let real = &game["real_arm"];
    assert_eq!(real["moves"], 21);
    // The servos received every goal the driver sent, each within the URDF's limits.
    let goals = goal_packets(arm.protocol, &sim.received(), &[11, 12, 13, 14]);
    // The driver's goals, and the one that holds the joints where they are as the torque goes on.
    assert_eq!(goals.len(), real["periods"].as_u64().unwrap() as usize + 1);
    let (count, fastest) = check_goals_within_limits(&arm, &out, &goals);
    eprintln!("{count} goal packets; fastest goal change per joint {fastest:?} rad/s; {real}");
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
