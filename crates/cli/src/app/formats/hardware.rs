//! Trajectories for real hardware (`hardware/` of `play` and `plan`): per robot move, the
//! *planned* joint motion at `--export-rate` Hz with the gripper's commands, in two layouts.
//!
//! - `NNN-<uci>.json`: `{"trajectory": …, "gripper": […], "move": {…}, "rate_hz": …}` where
//!   `trajectory` has exactly the fields of ROS 2's `trajectory_msgs/msg/JointTrajectory`
//!   (`header`, `joint_names`, `points[]` with `positions` rad, `velocities` rad/s,
//!   `accelerations` rad/s², `effort` (empty), `time_from_start` {`sec`, `nanosec`}), so
//!   `rosidl_runtime_py.set_message_fields(JointTrajectory(), data["trajectory"])` fills the
//!   message; `gripper` lists the commands (`close`/`open`, the instant, the piece and where);
//!   `finger_opening_m` is how far each finger stands off a piece when open (the setup's
//!   `[gripper] finger_opening`, or less where the clearance check narrowed it for this move).
//! - `NNN-<uci>.csv`: `t` s, `q1..q4` rad, `qd1..qd4` rad/s, `qdd1..qdd4` rad/s², `q_<name>`
//!   per held joint (its position, rad or m), `gripper` (`open`/`closed`), `piece` (the piece
//!   held, empty when open): one row per sample, to stream to servos row by row at the times in
//!   `t`.
//!
//! With `--urdf`, `joint_names` lists every moving joint of the file: the four arm joints in the
//! file's own sense (a base yaw about −z included), then every held joint (`--lock`, gripper
//! joints, their `<mimic>` followers) at its value, a gripper joint at its open or close value
//! as the gripper is at that sample (the limit further from zero opens), so a ROS 2 driver of
//! the real arm takes the message as it is. Where the file's fingers slide on prismatic joints,
//! their joints go instead to the values that open the fingers around the piece (its width and
//! `finger_opening_m` a side) and close them on it, the followers by their `<mimic>`.
//!
//! Times are from the move's start; each move starts where the previous one ended, at rest.

use crate::app::output::{numbered, write_atomic};
use anyhow::{Context, Result};
use chessarm_core::plan::hardware::{GripperCommand, HardwarePoint};
use chessarm_core::plan::path::GripperAction;
use serde_json::{Value, json};
use std::path::Path;

/// ROS 2's `builtin_interfaces/Duration` of `t` s: whole seconds and nanoseconds.
pub fn ros_duration(t: f64) -> Value {
    let total = (t * 1e9).round() as i64;
    json!({"sec": total.div_euclid(1_000_000_000), "nanosec": total.rem_euclid(1_000_000_000)})
}

/// `v` with a negative zero made zero (no "-0.0" in the files).
fn plain(v: f64) -> f64 {
    v + 0.0
}

/// What one move's export says about the move.
#[derive(Debug, Clone)]
pub struct MoveLabel<'a> {
    pub ply: usize,
    pub san: &'a str,
    pub uci: &'a str,
    /// Per grip, in order: the piece and where it goes ("white pawn from e2 to e4").
    pub grips: Vec<String>,
    /// Per gripper command, in order, the tool tip it waits to be at (m), and the condition
    /// (a fine point: `None` where the commands go by the clock, or for a plan alone).
    pub fine_points: Vec<chessarm_core::nalgebra::Vector3<f64>>,
    pub in_position: Option<chessarm_core::plan::fine_point::InPosition>,
    /// How far each finger stands off a piece when open, m (`None`: not known).
    pub finger_opening: Option<f64>,
    /// Per grip, in order: the piece's width where the gripper holds it, m (empty: not known;
    /// the gripper's joints then go to their limits).
    pub widths: Vec<f64>,
}

/// The gap between the fingers at the point `p` (m) for the pick-and-places of `commands` of
/// pieces `widths` wide, each finger `opening` off a piece it opens around, as the clearance
/// check has it: closed on the piece held; open around the next piece to grip and the one just
/// released (the wider of the two); after the last release, around the piece released. `None`
/// when the widths or the opening are not known.
fn gap_at(p: &HardwarePoint, commands: &[GripperCommand], widths: &[f64], opening: Option<f64>) -> Option<f64> {
    if p.gripper_closed {
        return p.grip.and_then(|g| widths.get(g)).copied();
    }
    let opening = opening?;
    // The grips before this point: the next one is theirs in number.
    let done = commands.iter().filter(|c| c.action == GripperAction::Grip && c.time < p.t).count();
    let open = |k: usize| widths.get(k).map(|w| w + 2.0 * opening);
    match (open(done), done.checked_sub(1).and_then(open)) {
        (Some(next), Some(last)) => Some(next.max(last)),
        (next, last) => next.or(last),
    }
}

/// Writes `<dir>/<stem>.json` and `<dir>/<stem>.csv`; returns their paths.
pub fn write_move(
    dir: &Path,
    stem: &str,
    (base_link, joint_names, convention): (&str, &[String; 4], &crate::app::setup::file::JointConvention),
    points: &[HardwarePoint],
    commands: &[GripperCommand],
    label: &MoveLabel<'_>,
    rate: f64,
) -> Result<Vec<String>> {
    let json_path = dir.join(format!("{stem}.json"));
    let csv_path = dir.join(format!("{stem}.csv"));
    // Every joint of the arm's file: the four arm joints in its sense, then each held one at
    // its value (a gripper joint at its open or close value as the gripper is).
    let names: Vec<&str> =
        joint_names.iter().map(String::as_str).chain(convention.locked.iter().map(|j| j.name.as_str())).collect();
    let whole = |p: &HardwarePoint| -> [Vec<f64>; 3] {
        let gap = gap_at(p, commands, &label.widths, label.finger_opening);
        let zeros = || convention.locked.iter().map(|_| 0.0);
        [
            convention
                .user(p.q)
                .map(plain)
                .into_iter()
                .chain(convention.locked.iter().map(|j| plain(convention.held_value(j, p.gripper_closed, gap))))
                .collect(),
            convention.user(p.qd).map(plain).into_iter().chain(zeros()).collect(),
            convention.user(p.qdd).map(plain).into_iter().chain(zeros()).collect(),
        ]
    };
    let mut grips: usize = 0;
    let gripper: Vec<Value> = commands
        .iter()
        .enumerate()
        .map(|(index, command)| {
            let close = command.action == GripperAction::Grip;
            let piece =
                label.grips.get(if close { grips } else { grips.saturating_sub(1) }).cloned().unwrap_or_default();
            if close {
                grips += 1;
            }
            // A fine point: the driver holds the trajectory here until its own estimate of the
            // tool tip is within the band of this point and slower than the speed band, or
            // the timeout has passed, then sends the command (as the simulation did).
            let wait = label.in_position.zip(label.fine_points.get(index)).map(|(gate, tip)| {
                json!({
                    "tool_tip_m": [tip.x, tip.y, tip.z],
                    "tip_band_m": gate.tip_band,
                    "speed_band_m_per_s": gate.speed_band,
                    "timeout_s": gate.timeout,
                })
            });
            json!({
                "time_from_start": ros_duration(command.time),
                "t": command.time,
                "command": if close { "close" } else { "open" },
                "piece": piece,
                "wait_until_in_position": wait,
            })
        })
        .collect();
    let value = json!({
        "trajectory": {
            "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": base_link},
            "joint_names": names,
            // Written point by point below: a long move at a high rate is millions of points,
            // gigabytes as one JSON tree.
            "points": [],
        },
        "gripper": gripper,
        "finger_opening_m": label.finger_opening,
        "move": {"ply": label.ply, "san": label.san, "uci": label.uci},
        "rate_hz": rate,
        "units": {"positions": "rad", "velocities": "rad/s", "accelerations": "rad/s^2", "t": "s"},
    });
    // One line: a game's moves at 100 Hz would be megabytes of indentation. The points go in
    // where the empty list stands, one at a time, the bytes as the whole tree would print them.
    let text = serde_json::to_string(&value)?;
    let (before, after) = text.split_once("\"points\":[]").ok_or_else(|| anyhow::anyhow!("the trajectory's points"))?;
    write_atomic(&json_path, |out| {
        write!(out, "{before}\"points\":[")?;
        for (k, p) in points.iter().enumerate() {
            if k > 0 {
                write!(out, ",")?;
            }
            let [q, qd, qdd] = whole(p);
            let point = json!({
                "positions": q,
                "velocities": qd,
                "accelerations": qdd,
                "effort": [],
                "time_from_start": ros_duration(p.t),
            });
            serde_json::to_writer(&mut *out, &point)?;
        }
        write!(out, "]{after}")?;
        writeln!(out)?;
        Ok(())
    })?;
    write_atomic(&csv_path, |out| {
        let mut writer = csv::Writer::from_writer(out);
        let mut header = vec!["t".to_string()];
        header.extend(numbered("q", 4).chain(numbered("qd", 4)).chain(numbered("qdd", 4)));
        // Each held joint's position as `q_<name>` (its rates are 0).
        header.extend(convention.locked.iter().map(|j| format!("q_{}", j.name)));
        header.extend(["gripper".to_string(), "piece".to_string()]);
        writer.write_record(&header)?;
        for point in points {
            let mut row: Vec<String> = vec![format!("{:?}", point.t)];
            let [q, qd, qdd] = whole(point);
            row.extend(q[..4].iter().chain(&qd[..4]).chain(&qdd[..4]).chain(&q[4..]).map(|v| format!("{v:?}")));
            row.push(if point.gripper_closed { "closed" } else { "open" }.to_string());
            row.push(point.grip.and_then(|g| label.grips.get(g)).cloned().unwrap_or_default());
            writer.write_record(&row)?;
        }
        writer.flush().context("cannot write the CSV")?;
        Ok(())
    })?;
    Ok(vec![json_path.display().to_string(), csv_path.display().to_string()])
}

/// Writes `<dir>/<stem>-goals.csv`: every goal the host sent in the simulated move (the stream
/// that placed its pieces, fine points' waits included), one row per bus period: `t` s from the
/// move's start, `goal1..goal4` rad in the setup's sense, `goal1_ticks..goal4_ticks` the same
/// goals in each servo's position register (`bus`). A goal outside the register's range is
/// refused, naming the joint and `[servo_bus] zero_ticks`.
pub fn write_servo_goals(
    dir: &Path,
    stem: &str,
    convention: &crate::app::setup::file::JointConvention,
    bus: &crate::app::setup::servos::ServoBus,
    goals: &[chessarm_chess::play::ServoGoal],
) -> Result<String> {
    let path = dir.join(format!("{stem}-goals.csv"));
    let rows: Vec<([f64; 4], [f64; 4], f64)> = goals
        .iter()
        .map(|goal| {
            let user = convention.user(goal.goal);
            let ticks: [f64; 4] = std::array::from_fn(|j| bus.ticks(j, user[j]));
            for (j, tick) in ticks.iter().enumerate() {
                if *tick < 0.0 || *tick >= bus.counts_per_revolution[j] {
                    anyhow::bail!(
                        "joint {}'s goal {:.4} rad at t = {:.3} s of {stem} is tick {tick}, outside its servo's 0–{}: \
                         set [servo_bus] zero_ticks (now {}) to the tick of the joint's zero",
                        j + 1,
                        user[j],
                        goal.t,
                        bus.counts_per_revolution[j] - 1.0,
                        bus.zero_ticks[j]
                    );
                }
            }
            Ok((user, ticks, goal.t))
        })
        .collect::<Result<_>>()?;
    write_atomic(&path, |out| {
        let mut writer = csv::Writer::from_writer(out);
        let mut header = vec!["t".to_string()];
        header.extend(numbered("goal", 4));
        header.extend((1..=4).map(|j| format!("goal{j}_ticks")));
        writer.write_record(&header)?;
        for (user, ticks, t) in &rows {
            // Times to the microsecond (a bus period is whole milliseconds or more).
            let mut row = vec![format!("{:?}", plain((t * 1e6).round() / 1e6))];
            row.extend(user.iter().map(|v| format!("{:?}", plain(*v))));
            row.extend(ticks.iter().map(|v| format!("{}", *v as i64)));
            writer.write_record(&row)?;
        }
        writer.flush().context("cannot write the CSV")?;
        Ok(())
    })?;
    Ok(path.display().to_string())
}

/// Writes `<dir>/servo_bus.json`: what the goal files' ticks mean (each joint's name, servo,
/// ID, direction, zero tick and counts per turn; the bus rate) for a driver of the real arm.
pub fn write_servo_bus(
    dir: &Path,
    setup: &crate::app::setup::file::Setup,
    bus: &crate::app::setup::servos::ServoBus,
) -> Result<String> {
    let path = dir.join("servo_bus.json");
    let joints: Vec<Value> = (0..4)
        .map(|j| {
            json!({
                "joint": setup.joint_names[j],
                "actuator": setup.actuator_names[j],
                "id": bus.ids[j],
                "direction": bus.directions[j],
                "zero_ticks": bus.zero_ticks[j],
                "counts_per_revolution": bus.counts_per_revolution[j],
            })
        })
        .collect();
    crate::app::output::write_json(
        &path,
        &json!({
            "joints": joints,
            "bus_rate_hz": setup.bus_rate,
            "ticks": "zero_ticks + direction * round(goal / (2 pi / counts_per_revolution)), goal in rad",
        }),
    )?;
    Ok(path.display().to_string())
}
