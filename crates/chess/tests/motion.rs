//! Time-optimal moves: clearance along the blended paths (tall kings beside them), continuity
//! of the motion across a whole ply, the limits checked independently of the planner, and
//! errors that name the move, the limit and the value.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::motion::{MoveMotion, PlannedMove, TimingMode, plan_move};
use chessarm_chess::notation::parse_fen;
use chessarm_chess::pieces::PieceSet;
use chessarm_chess::play::home_tool;
use chessarm_chess::shakmaty::uci::UciMove;
use chessarm_chess::shakmaty::{Chess, Move};
use chessarm_chess::table::Table;
use chessarm_chess::tasks::MotionLimits;
use chessarm_core::arm::dynamics::inverse_dynamics;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::plan::trajectory::{ToolMotion, joint_motion_at};

fn parse(fen: &str, uci: &str) -> (Chess, Move) {
    let position = parse_fen(fen).unwrap();
    let mv = uci.parse::<UciMove>().unwrap().to_move(&position).unwrap();
    (position, mv)
}

fn plan(position: &Chess, mv: &Move, limits: &MotionLimits) -> (Table, PlannedMove) {
    let board = BoardGeometry::default();
    let table = Table::from_position(board, position);
    let pieces = PieceSet::default();
    let tool = home_tool(&board, &pieces, limits);
    let planned =
        plan_move(tool, position, mv, &table, &pieces, limits, &report_arm(), TimingMode::Optimal, 1e-3).unwrap();
    (table, planned)
}

/// Kings (the tallest pieces) on every square beside the path of a knight from b1 to c3 and
/// beside its target: the carried knight's base must clear every king under it by the margin
/// at every millisecond of the move, except over the squares it leaves and lands on.
#[test]
fn blended_paths_keep_the_clearance_over_tall_kings_beside_them() {
    // The knight leaves b1 between the white king (a1) and queen (a2) and lands on c3 between
    // the black king (c4) and two black queens (b3, d3): the tallest pieces of the set.
    let (position, mv) = parse("8/8/8/8/2k5/1q1q4/Q7/KN6 w - - 0 1", "b1c3");
    let limits = MotionLimits::default();
    let (table, planned) = plan(&position, &mv, &limits);
    let pieces = PieceSet::default();
    let motion = &planned.motion;
    let task = planned.tasks[0];
    let carried = pieces.dimensions(task.task.piece.role);
    let (pick, place) = (table.piece_at(task.task.from).unwrap().position, table.nominal_position(task.task.to));
    let radius = 0.5 * (carried.base_diameter + pieces.widest());
    let mut lowest_margin = f64::INFINITY;
    let mut samples = 0;
    let dt = 1e-3;
    let steps = (motion.duration() / dt) as usize;
    for k in 0..=steps {
        let t = k as f64 * dt;
        if t <= task.plan.grip_time || t >= task.plan.release_time {
            continue;
        }
        let tip = motion.sample(t).position;
        let xy = tip.xy();
        if (xy - pick).norm() <= radius || (xy - place).norm() <= radius {
            continue;
        }
        let bottom = tip.z - table.geometry().surface_height - carried.grip_height;
        let top = table
            .pieces()
            .iter()
            .filter(|p| p.location != task.task.from && (p.position - xy).norm() <= radius)
            .map(|p| pieces.dimensions(p.piece.role).height)
            .fold(0.0, f64::max);
        lowest_margin = lowest_margin.min(bottom - top);
        samples += 1;
    }
    assert!(samples > 50, "{samples} samples checked");
    assert!(lowest_margin >= limits.clearance_margin - 1e-9, "clearance {lowest_margin} m");
    // The corners are blended nonetheless: one leg to the grip, one carrying, one rising.
    let MoveMotion::Optimal(timed) = motion else { panic!("not optimal") };
    assert_eq!(planned.legs.len(), 3, "{} legs", planned.legs.len());
    assert!(timed.stretches().len() >= 5);
}

#[test]
fn a_whole_ply_is_continuous_in_velocity_and_keeps_every_limit_when_checked_independently() {
    let planned = check_capture(&MotionLimits::default());
    assert!(planned.usage.as_ref().unwrap().share > 0.99);
}

#[test]
fn a_jerk_limited_ply_keeps_every_limit_and_its_jerk_on_every_vertical_line() {
    // 200 m/s³: 4 % of the default's acceleration steps' spread per millisecond.
    let jerk = 200.0;
    let limits = MotionLimits { jerk, ..MotionLimits::default() };
    let planned = check_capture(&limits);
    let unlimited = check_capture(&MotionLimits::default());
    // The smoothing costs time (each leg's window, and the slow-downs that keep the limits)...
    assert!(planned.motion.duration() > unlimited.motion.duration());
    // ...and on the rises and descents (the tool's jerk is the law's there) the jerk, by
    // finite differences every 0.1 ms, is within the limit; without it the acceleration steps.
    let largest = |planned: &PlannedMove| {
        let (motion, dt) = (&planned.motion, 1e-4);
        let mut previous = motion.sample(0.0);
        let mut largest: f64 = 0.0;
        for k in 1..=(motion.duration() / dt) as usize {
            let sample = motion.sample(k as f64 * dt);
            let vertical = (sample.position.xy() - previous.position.xy()).norm() < 1e-12
                && (sample.position.z - previous.position.z).abs() > 0.0;
            if vertical {
                largest = largest.max((sample.acceleration - previous.acceleration).norm() / dt);
            }
            previous = sample;
        }
        largest
    };
    let (smooth, steps) = (largest(&planned), largest(&unlimited));
    // 1e-6 relative: the law's jerk is exactly within the limit; the samples' rounding is not.
    assert!(smooth <= jerk * (1.0 + 1e-6), "largest vertical jerk {smooth} m/s³ against {jerk}");
    assert!(smooth > 0.3 * jerk, "{smooth}");
    assert!(steps > 10.0 * jerk, "without the limit the acceleration steps: {steps} m/s³");
}

/// Plans a capture (two tasks, five legs, grips and releases in between) under `limits` and
/// checks its continuity and every limit every 0.1 ms, independently of the planner.
fn check_capture(limits: &MotionLimits) -> PlannedMove {
    let (position, mv) = parse("rnbqkbnr/ppp1pppp/8/3p4/4P3/8/PPPP1PPP/RNBQKBNR w KQkq - 0 2", "e4d5");
    let limits = *limits;
    let (_, planned) = plan(&position, &mv, &limits);
    let arm = report_arm();
    let pieces = PieceSet::default();
    let motion = &planned.motion;
    let dt = 1e-4;
    let steps = (motion.duration() / dt) as usize;
    let mut previous = motion.sample(0.0);
    let mut largest_jump: f64 = 0.0;
    for k in 1..=steps {
        let sample = motion.sample(k as f64 * dt);
        // The tool's acceleration is bounded (joint accelerations ≤ 20 rad/s²), so between two
        // samples 0.1 ms apart its velocity changes by well under 1 mm/s: no jump anywhere.
        largest_jump = largest_jump.max((sample.velocity - previous.velocity).norm());
        // Torques from the planned motion by inverse dynamics, with the carried piece.
        let t = sample.t;
        let carrying = planned.tasks.iter().find(|p| t >= p.plan.grip_time && t < p.plan.release_time);
        let model = match carrying {
            Some(task) => arm.with_payload(Some(pieces.payload(task.task.piece.role))).unwrap(),
            None => arm,
        };
        let joint = joint_motion_at(&arm, &sample).unwrap();
        let torque = inverse_dynamics(&model, &joint.q, &joint.qd, &joint.qdd);
        for j in 0..4 {
            let limit = limits.torque_margin * arm.link(j).limits.torque;
            assert!(torque[j].abs() <= limit * (1.0 + 1e-6), "t {t}: joint {} torque {}", j + 1, torque[j]);
            assert!(joint.qd[j].abs() <= arm.link(j).limits.velocity * (1.0 + 1e-6));
            assert!(
                joint.qdd[j].abs() <= limits.joint_acceleration[j] * (1.0 + 1e-6),
                "t {t}: q̈{} {}",
                j + 1,
                joint.qdd[j]
            );
        }
        assert!(sample.velocity.norm() <= limits.tool_speed * (1.0 + 1e-6));
        if carrying.is_some() {
            assert!(sample.acceleration.norm() <= limits.carry_acceleration * (1.0 + 1e-6), "t {t}");
        }
        previous = sample;
    }
    assert!(largest_jump < 1e-3, "velocity jumps by {largest_jump} m/s");
    assert_eq!(planned.tasks.len(), 2);
    // Phases add up to the duration and there are no pauses.
    let p = planned.phases;
    assert!((p.travel + p.vertical + p.grip + p.pause - motion.duration()).abs() < 1e-9);
    assert_eq!(p.pause, 0.0);
    assert!((p.grip - 2.0 * (limits.grip_dwell + limits.release_dwell)).abs() < 1e-12);
    planned
}

#[test]
fn limits_that_cannot_be_kept_name_the_move_the_limit_and_the_value() {
    let (position, mv) = parse("rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1", "e2e4");
    let board = BoardGeometry::default();
    let table = Table::from_position(board, &position);
    let pieces = PieceSet::default();
    let weak_grip = MotionLimits { grip_strength: 8.0, ..MotionLimits::default() };
    let tool = home_tool(&board, &pieces, &weak_grip);
    let error = plan_move(tool, &position, &mv, &table, &pieces, &weak_grip, &report_arm(), TimingMode::Optimal, 1e-3)
        .unwrap_err()
        .to_string();
    assert!(error.starts_with("move e4 (e2e4)") && error.contains("grip") && error.contains("8 m/s²"), "{error}");

    let arm = report_arm();
    let mut links = *arm.links();
    links[1].limits.torque = 0.5;
    let weak = arm.with_links(links).unwrap();
    let limits = MotionLimits::default();
    let error = plan_move(tool, &position, &mv, &table, &pieces, &limits, &weak, TimingMode::Optimal, 1e-3)
        .unwrap_err()
        .to_string();
    assert!(error.starts_with("move e4 (e2e4)") && error.contains("joint 2") && error.contains("0.5 N·m"), "{error}");

    let bad = MotionLimits { torque_margin: 1.2, ..MotionLimits::default() };
    let error = plan_move(tool, &position, &mv, &table, &pieces, &bad, &arm, TimingMode::Optimal, 1e-3)
        .unwrap_err()
        .to_string();
    assert!(error.contains("torque_margin") && error.contains("1.2"), "{error}");
}

#[test]
fn blends_can_be_turned_off_and_then_every_corner_is_a_stop() {
    let (position, mv) = parse("rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1", "g1f3");
    let blended = plan(&position, &mv, &MotionLimits::default()).1;
    let sharp = plan(&position, &mv, &MotionLimits { blend: 0.0, ..MotionLimits::default() }).1;
    // Without blends each line is its own leg from rest to rest: slower.
    assert!(sharp.legs.len() > blended.legs.len(), "{} vs {}", sharp.legs.len(), blended.legs.len());
    assert!(sharp.motion.duration() > blended.motion.duration() + 0.1);
}

#[test]
fn a_tracking_budget_bounds_the_carried_pieces_tracking_error_at_every_tenth_of_a_millisecond() {
    use chessarm_chess::tasks::Tracking;
    use chessarm_core::arm::kinematics::FrameChain;
    use chessarm_core::arm::lagrange::mass_matrix;
    use chessarm_core::control::gains::Gains;
    // The report's PD gains (soft: the budget binds) and every piece ±20 g off its nominal
    // mass; 0.3 mm of tracking error allowed while carrying.
    let gains = Gains::uniform(400.0, 20.0, 0.0).unwrap();
    let tracking = Tracking { budget: 3e-4, mass_error: [0.02; 6], ..Tracking::default() }.with_gains(&gains);
    assert_eq!(tracking.overshoot, 1.0 + (-std::f64::consts::PI * 0.5 / 0.75f64.sqrt()).exp());
    let limits = MotionLimits { tracking, carry_acceleration: 50.0, ..MotionLimits::default() };
    let (position, mv) = parse("rnbqkbnr/ppp1pppp/8/3p4/4P3/8/PPPP1PPP/RNBQKBNR w KQkq - 0 2", "e4d5");
    let (_, planned) = plan(&position, &mv, &limits);
    let (_, free) = plan(&position, &mv, &MotionLimits { carry_acceleration: 50.0, ..MotionLimits::default() });
    assert!(planned.limit_times.iter().any(|(name, t)| name == "tracking budget (carried piece)" && *t > 0.05));
    assert!(planned.motion.duration() > free.motion.duration() + 0.05);
    // Independently of the planner: the tip Jacobian by central differences of the forward
    // kinematics, the inertia by the Lagrangian formulation, the piece's nominal mass in it.
    let arm = report_arm();
    let pieces = PieceSet::default();
    let (motion, dt) = (&planned.motion, 1e-4);
    let mut largest: f64 = 0.0;
    for k in 0..=(motion.duration() / dt) as usize {
        let sample = motion.sample(k as f64 * dt);
        let t = sample.t;
        let Some(task) = planned.tasks.iter().find(|p| t >= p.plan.grip_time && t < p.plan.release_time) else {
            continue;
        };
        let model = arm.with_payload(Some(pieces.payload(task.task.piece.role))).unwrap();
        let joint = joint_motion_at(&arm, &sample).unwrap();
        let mut jacobian = chessarm_core::nalgebra::Matrix3x4::<f64>::zeros();
        for j in 0..4 {
            let mut step = chessarm_core::arm::model::JointVector::<4>::zeros();
            step[j] = 1e-6;
            let difference =
                FrameChain::new(&arm, &(joint.q + step)).tip() - FrameChain::new(&arm, &(joint.q - step)).tip();
            jacobian.set_column(j, &(difference / 2e-6));
        }
        let inverse = mass_matrix(&model, &joint.q).try_inverse().unwrap();
        let w = jacobian * inverse * jacobian.transpose() / 400.0;
        let error = 0.02 * tracking.overshoot * (w * sample.acceleration).norm();
        largest = largest.max(error);
    }
    // Central differences and the other formulation agree to ~1e-8 relative; the polygon
    // keeps the plan inside the disc: 1e-6 relative is rounding.
    assert!(largest <= 3e-4 * (1.0 + 1e-6), "tracking error {largest} m against the 0.3 mm budget");
    assert!(largest > 0.9 * 3e-4, "the budget binds: {largest} m");
}
