//! Time-optimal timing (TOPP-RA): closed-form optima, an independent dense-grid solver on a
//! real pick-and-place path, blend geometry, and every limit checked between grid points.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::dynamics::mass_matrix;
use chessarm_core::arm::model::{ArmModel, JointVector, Payload};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::task::{TOOL_DOWN, tool_point};
use chessarm_core::nalgebra::Vector3;
use chessarm_core::plan::constraints::{
    JointAcceleration, JointSpeed, JointTorque, PathConstraint, PathPoint, ToolAcceleration, ToolSpeed,
    constraint_table,
};
use chessarm_core::plan::geometric::{GeometricPath, PathPiece, Stretch, TimedMotion};
use chessarm_core::plan::optimal::{MotionCheck, check_motion, path_points, time_leg};
use chessarm_core::plan::path::PitchLaw;
use chessarm_core::plan::topp::{ConstraintTable, LimitId, ToppError, acceleration_bounds, project, time_optimal};
use chessarm_core::plan::trajectory::joint_motion_at;

const G: f64 = 9.81;

/// A straight 1-D motion of length `length` under |s̈| ≤ a and ṡ ≤ v, on `n` grid points.
fn kinematic_table(length: f64, v: f64, a: f64, n: usize) -> ConstraintTable {
    let mut table = ConstraintTable::new();
    for k in 0..n {
        table.push_point(length * k as f64 / (n - 1) as f64);
        table.push_row(0.0, 1.0 / (v * v), 1.0, LimitId(0));
        table.push_row(1.0 / a, 0.0, 1.0, LimitId(1));
        table.push_row(-1.0 / a, 0.0, 1.0, LimitId(1));
    }
    table
}

/// The bang–bang (triangle) or bang–coast–bang (trapezoid) optimum of a rest-to-rest move.
fn trapezoid_time(length: f64, v: f64, a: f64) -> f64 {
    if length <= v * v / a { 2.0 * (length / a).sqrt() } else { length / v + v / a }
}

#[test]
fn rest_to_rest_kinematic_limits_match_the_bang_bang_optimum() {
    // The discretised optimum converges to the continuous one as the grid is refined; at 200
    // points it is within 1 % (the target), on both a trapezoid and a triangle.
    for (length, v, a) in [(0.4, 0.5, 2.0), (0.05, 1.0, 2.0), (1.3, 3.0, 85.0)] {
        let exact = trapezoid_time(length, v, a);
        let timing = time_optimal(&kinematic_table(length, v, a, 200), 0.0, 0.0).unwrap();
        let error = (timing.duration() - exact).abs() / exact;
        assert!(
            error < 0.01,
            "L {length} v {v} a {a}: {} s against {exact} s ({:.3} %)",
            timing.duration(),
            100.0 * error
        );
        // The timing never breaks the limits it was given.
        for (i, &u) in timing.u.iter().enumerate() {
            assert!(u.abs() <= a * (1.0 + 1e-9), "stage {i}: s̈ = {u}");
            assert!(timing.x[i] <= v * v * (1.0 + 1e-9));
        }
        assert_eq!(timing.x[0], 0.0);
        assert_eq!(*timing.x.last().unwrap(), 0.0);
    }
}

#[test]
fn projection_and_bounds_are_exact_on_a_known_polygon() {
    use chessarm_core::plan::topp::Row;
    let row = |alpha, beta, gamma| Row { alpha, beta, gamma, limit: LimitId(0) };
    // u ≤ 2 − x, u ≥ x − 4, x ≤ 5: the projection is x ≤ 3 (where 2 − x = x − 4).
    let rows = [row(1.0, 1.0, 2.0), row(-1.0, 1.0, 4.0), row(0.0, 1.0, 5.0)];
    let (lo, hi) = project(rows.iter().copied()).unwrap();
    assert_eq!(lo, 0.0);
    assert!((hi - 3.0).abs() < 1e-15);
    let (low, high) = acceleration_bounds(rows.iter().copied(), 1.0);
    assert!((low - -3.0).abs() < 1e-15 && (high - 1.0).abs() < 1e-15);
    // Contradictory rows: empty.
    assert!(project([row(1.0, 0.0, -1.0), row(-1.0, 0.0, -1.0)].into_iter()).is_none());
}

/// Path points of joint 1 alone turning from −1 to +1 rad (the other joints fixed).
fn base_turn_points(rest: [f64; 3], n: usize) -> Vec<PathPoint<4>> {
    (0..n)
        .map(|k| {
            let s = 2.0 * k as f64 / (n - 1) as f64;
            let q = JointVector::<4>::new(-1.0 + s, rest[0], rest[1], rest[2]);
            let unit = JointVector::<4>::new(1.0, 0.0, 0.0, 0.0);
            let zero = Vector3::zeros();
            PathPoint { s, q, dq: unit, ddq: JointVector::zeros(), tip: zero, dtip: zero, ddtip: zero }
        })
        .collect()
}

#[test]
fn a_base_turn_under_its_torque_and_speed_limits_is_the_closed_form_trapezoid() {
    // Joint 1 (the base yaw) alone: τ₁ = M₁₁ q̈₁ (M₁₁ does not depend on q₁ and gravity does
    // not act about the vertical axis), so |q̈₁| ≤ 0.85·τ_max/M₁₁, and q̇₁ ≤ 3 rad/s.
    let model = report_arm();
    let rest = [0.6, -1.2, -0.9];
    let points = base_turn_points(rest, 300);
    let torque = JointTorque { model, margin: 0.85, max_speed: [3.0; 4] };
    let speed = JointSpeed { max: [3.0; 4] };
    let constraints: [&dyn PathConstraint<4>; 2] = [&torque, &speed];
    let (table, names) = constraint_table(&points, &constraints);
    let timing = time_optimal(&table, 0.0, 0.0).unwrap();
    let m11 = mass_matrix(&model, &points[0].q)[(0, 0)];
    let a = 0.85 * model.link(0).limits.torque / m11;
    let exact = trapezoid_time(2.0, 3.0, a);
    let error = (timing.duration() - exact).abs() / exact;
    assert!(error < 0.01, "{} s against {exact} s ({:.3} %)", timing.duration(), 100.0 * error);
    // The other joints carry gravity and the centrifugal load of the turn well inside their
    // limits, so the closed form is the whole story: only joint 1's limits bind.
    for active in timing.active.iter().flatten() {
        let name = &names[active.0 as usize];
        assert!(name == "joint 1 torque" || name == "joint 1 speed", "binding: {name}");
    }
}

/// Rise, traverse and descend between two squares of the report's board, corners blended.
fn pick_and_place(cut: f64) -> GeometricPath {
    let (h, z) = (0.13, 0.025);
    let points = [
        Vector3::new(0.09, 0.21, z),
        Vector3::new(0.09, 0.21, h),
        Vector3::new(-0.15, 0.45, h),
        Vector3::new(-0.15, 0.45, z),
    ];
    GeometricPath::polyline(&points, |_| cut).unwrap()
}

#[test]
fn blends_are_smooth_and_stay_inside_their_corner() {
    let path = pick_and_place(0.04);
    assert_eq!(path.pieces().len(), 5);
    let starts = path.piece_starts();
    // p, p' and p'' are continuous across every piece boundary (p'' is zero on lines and at
    // the ends of blends).
    for &s in &starts[1..] {
        let (a, da, dda) = path.eval(s - 1e-9);
        let (b, db, ddb) = path.eval(s + 1e-9);
        assert!((a - b).norm() < 1e-8 && (da - db).norm() < 1e-6, "at s = {s}");
        // 1e-9 into a blend of cut d, |p''| = |u₂ − u₁|·6τ/(2d) with τ = 1e-9/(2d): ≈ 1.3e-6 here.
        assert!(dda.norm() < 1e-5 && ddb.norm() < 1e-5, "curvature at s = {s}: {dda} {ddb}");
    }
    // p' and p'' are the derivatives of p (central differences, error O(h²)).
    let h = 1e-5;
    for k in 1..200 {
        let s = path.length() * k as f64 / 200.0;
        let (_, dp, ddp) = path.eval(s);
        let (before, dp0, _) = path.eval(s - h);
        let (after, dp1, _) = path.eval(s + h);
        assert!(((after - before) / (2.0 * h) - dp).norm() < 1e-6, "p' at s = {s}");
        assert!(((dp1 - dp0) / (2.0 * h) - ddp).norm() < 1e-3, "p'' at s = {s}");
    }
    // Each blend lies in the triangle A–C–B (A = C − d u₁, B = C + d u₂). In the corner's own
    // coordinates a = (p − A)·u₁/d, b = (p − A)·u₂/d (u₁ ⊥ u₂ here) the triangle is
    // A = (0, 0), C = (1, 0), B = (1, 1), i.e. 0 ≤ b ≤ a ≤ 1, and the curve stays in its plane.
    for piece in path.pieces() {
        if let PathPiece::Blend { start, incoming, outgoing, cut } = *piece {
            assert!(incoming.dot(&outgoing).abs() < 1e-12);
            for k in 0..=100 {
                let (p, _, _) = piece.eval(piece.length() * k as f64 / 100.0);
                let offset = p - start;
                let (a, b) = (offset.dot(&incoming) / cut, offset.dot(&outgoing) / cut);
                let out_of_plane = (offset - incoming * (a * cut) - outgoing * (b * cut)).norm();
                assert!(out_of_plane < 1e-12, "{out_of_plane}");
                assert!((-1e-12..=1.0 + 1e-12).contains(&b) && b <= a + 1e-12 && a <= 1.0 + 1e-12, "a {a} b {b}");
            }
        }
    }
    assert!((path.start() - Vector3::new(0.09, 0.21, 0.025)).norm() < 1e-12);
    assert!((path.end() - Vector3::new(-0.15, 0.45, 0.025)).norm() < 1e-12);
}

#[test]
fn a_straight_line_under_tool_speed_and_acceleration_limits_is_the_trapezoid() {
    let model = report_arm();
    let line =
        GeometricPath::polyline(&[Vector3::new(0.15, 0.2, 0.1), Vector3::new(-0.15, 0.4, 0.1)], |_| 0.0).unwrap();
    let (v, a) = (0.4, 1.5);
    let speed = ToolSpeed { max: v };
    let acceleration = ToolAcceleration { max: a, gravity: Vector3::zeros(), label: "tool acceleration".into() };
    let constraints: [&dyn PathConstraint<4>; 2] = [&speed, &acceleration];
    let plan = time_leg(&model, &line, &constraints, line.length() / 200.0, 0, 1e-9).unwrap();
    let exact = trapezoid_time(line.length(), v, a);
    let error = (plan.leg.timing.duration() - exact).abs() / exact;
    assert!(error < 0.01, "{} s against {exact} s", plan.leg.timing.duration());
}

/// A slow, obviously correct solver: on a dense grid, integrate the phase plane backward from
/// the end at the largest deceleration and forward from the start at the largest
/// acceleration, each capped by the maximum velocity curve and the forward one by the backward
/// one (the classical numerical-integration method).
fn dense_grid_time(points: &[PathPoint<4>], constraints: &[&dyn PathConstraint<4>]) -> f64 {
    let (table, _) = constraint_table(points, constraints);
    let n = table.len();
    let s = table.grid().to_vec();
    // The maximum velocity curve by this file's own Fourier–Motzkin elimination, not the
    // planner's projection.
    let mvc: Vec<f64> = (0..n).map(|i| fourier_motzkin(table.rows(i)).map_or(0.0, |(_, hi)| hi)).collect();
    let mut backward = vec![0.0; n];
    for i in (0..n - 1).rev() {
        let (low, _) = acceleration_bounds(table.rows(i + 1).iter().copied(), backward[i + 1]);
        backward[i] = (backward[i + 1] - 2.0 * (s[i + 1] - s[i]) * low).min(mvc[i]);
    }
    let mut x = vec![0.0; n];
    let mut time = 0.0;
    for i in 0..n - 1 {
        let (_, high) = acceleration_bounds(table.rows(i).iter().copied(), x[i]);
        x[i + 1] = (x[i] + 2.0 * (s[i + 1] - s[i]) * high).min(backward[i + 1]).max(0.0);
        time += 2.0 * (s[i + 1] - s[i]) / (x[i].sqrt() + x[i + 1].sqrt());
    }
    time
}

struct Limits {
    torque_carrying: JointTorque<4>,
    speed: JointSpeed<4>,
    acceleration: JointAcceleration<4>,
    tool: ToolSpeed,
    carry: ToolAcceleration,
    grip: ToolAcceleration,
}

fn limits(model: &ArmModel<4>) -> Limits {
    let payload = Payload::upright_cylinder(0.1, 0.08, 0.014, 0.05);
    let gravity = model.gravity();
    Limits {
        torque_carrying: JointTorque {
            model: model.with_payload(Some(payload)).unwrap(),
            margin: 0.85,
            max_speed: [3.0; 4],
        },
        speed: JointSpeed { max: [3.0; 4] },
        acceleration: JointAcceleration { max: [20.0; 4] },
        tool: ToolSpeed { max: 1.0 },
        carry: ToolAcceleration {
            max: 5.0,
            gravity: Vector3::zeros(),
            label: "tool acceleration while carrying".into(),
        },
        grip: ToolAcceleration { max: 2.0 * G, gravity, label: "grip".into() },
    }
}

impl Limits {
    fn carrying(&self) -> [&dyn PathConstraint<4>; 6] {
        [&self.torque_carrying, &self.speed, &self.acceleration, &self.tool, &self.carry, &self.grip]
    }
}

#[test]
fn the_pick_and_place_optimum_matches_a_dense_grid_integration_within_one_percent() {
    let model = report_arm();
    let limits = limits(&model);
    let path = pick_and_place(0.04);
    let constraints = limits.carrying();
    let plan = time_leg(&model, &path, &constraints, 0.005, 0, 1e-9).unwrap();
    let dense = path_points(&model, &path, &path.grid(0.0002, 0)).unwrap();
    let reference = dense_grid_time(&dense, &constraints);
    let duration = plan.leg.timing.duration();
    let error = (duration - reference).abs() / reference;
    assert!(error < 0.01, "TOPP-RA {duration} s against the dense grid's {reference} s ({:.3} %)", 100.0 * error);
    // The carried piece's acceleration limit binds longest on this move (5 m/s² is low for
    // this arm), and the stages' binding limits account for the whole duration.
    let binding = plan.time_per_limit();
    let (name, longest) = binding.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert_eq!(name, "tool acceleration while carrying", "{binding:?}");
    assert!(*longest > 0.3 * duration, "{binding:?}");
    let total: f64 = binding.iter().map(|(_, t)| t).sum();
    assert!((total - duration).abs() < 1e-9, "{total} against {duration}");
}

fn motion_of(plan: &chessarm_core::plan::optimal::LegPlan) -> TimedMotion {
    let mut motion = TimedMotion::new(plan.leg.path.start());
    motion.push(Stretch::Leg(plan.leg.clone()));
    motion
}

/// The motion check at the report's limits (`limits`'s, without a tracking budget).
fn report_check() -> MotionCheck {
    MotionCheck {
        joint_speed: [3.0; 4],
        joint_acceleration: [20.0; 4],
        torque_margin: 0.85,
        tool_speed: 1.0,
        carry_acceleration: 5.0,
        grip_strength: 2.0 * G,
        tracking: None,
    }
}

#[test]
fn every_limit_holds_at_ten_times_the_planning_grid() {
    let model = report_arm();
    let limits = limits(&model);
    let path = pick_and_place(0.04);
    let plan = time_leg(&model, &path, &limits.carrying(), 0.005, 0, 1e-3).unwrap();
    let motion = motion_of(&plan);
    let stages = plan.leg.timing.u.len() as f64;
    let dt = motion.duration() / (10.0 * stages);
    let check = report_check();
    let carried = model.with_payload(Some(Payload::upright_cylinder(0.1, 0.08, 0.014, 0.05))).unwrap();
    let result = check_motion(&model, &motion, &[(0.0, f64::INFINITY, carried)], &check, dt).unwrap();
    let largest = result.unwrap();
    // The plan uses its limits to the full (a time-optimal plan touches at least one).
    assert!(largest.share > 0.99, "largest share of a limit used: {largest:?}");
    // The duration is a whole number of control periods.
    let periods = motion.duration() / 1e-3;
    assert!((periods - periods.round()).abs() < 1e-6, "{periods}");
}

#[test]
fn a_grip_weaker_than_gravity_and_a_motor_weaker_than_the_holding_torque_are_named() {
    let model = report_arm();
    let path = pick_and_place(0.04);
    let weak_grip = ToolAcceleration { max: 8.0, gravity: model.gravity(), label: "grip".into() };
    let constraints: [&dyn PathConstraint<4>; 1] = [&weak_grip];
    let error = time_leg(&model, &path, &constraints, 0.005, 0, 1e-3).unwrap_err().to_string();
    let gravity = format!("{:.3}", model.gravity().norm());
    assert!(error.contains("grip") && error.contains(&gravity) && error.contains("8 m/s²"), "{error}");

    let mut links = *model.links();
    links[1].limits.torque = 0.5;
    let weak = model.with_links(links).unwrap();
    let torque = JointTorque { model: weak, margin: 0.85, max_speed: [3.0; 4] };
    let constraints: [&dyn PathConstraint<4>; 1] = [&torque];
    let error = time_leg(&weak, &path, &constraints, 0.005, 0, 1e-3).unwrap_err().to_string();
    assert!(error.contains("joint 2") && error.contains("gravity") && error.contains("0.5 N·m"), "{error}");
}

#[test]
fn bad_grids_and_boundaries_are_errors_not_panics() {
    let mut table = ConstraintTable::new();
    table.push_point(0.0);
    assert_eq!(time_optimal(&table, 0.0, 0.0), Err(ToppError::Grid(1)));
    let table = kinematic_table(1.0, 1.0, 1.0, 10);
    assert!(matches!(time_optimal(&table, -1.0, 0.0), Err(ToppError::Boundary { .. })));
    assert!(matches!(time_optimal(&table, f64::NAN, 0.0), Err(ToppError::Boundary { .. })));
    // Starting faster than the speed limit allows.
    assert!(matches!(time_optimal(&table, 4.0, 0.0), Err(ToppError::Infeasible { index: 0, .. })));
}

/// Fourier–Motzkin elimination of `u`: every pure row bounds `x`, every pair of an upper
/// (`α_p > 0`) and a lower (`α_n < 0`) line needs `(α_p β_n − α_n β_p) x ≤ α_p γ_n − α_n γ_p`.
fn fourier_motzkin(rows: &[chessarm_core::plan::topp::Row]) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (0.0_f64, f64::INFINITY);
    let mut bound = |c: f64, rhs: f64| {
        if c > 0.0 {
            hi = hi.min(rhs / c);
        } else if c < 0.0 {
            lo = lo.max(rhs / c);
        } else if rhs < 0.0 {
            lo = f64::INFINITY;
        }
    };
    for p in rows {
        if p.alpha == 0.0 {
            bound(p.beta, p.gamma);
        }
        for n in rows.iter().filter(|n| n.alpha < 0.0 && p.alpha > 0.0) {
            bound(p.alpha * n.beta - n.alpha * p.beta, p.alpha * n.gamma - n.alpha * p.gamma);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

proptest::proptest! {
    #[test]
    fn the_newton_projection_equals_fourier_motzkin_elimination(
        rows in proptest::collection::vec((-2.0f64..2.0, -2.0f64..2.0, -1.0f64..3.0, 0u8..4), 1..40)
    ) {
        use chessarm_core::plan::topp::Row;
        // A quarter of the rows pure (α = 0), like speed limits.
        let rows: Vec<Row> = rows
            .into_iter()
            .map(|(a, b, c, kind)| Row { alpha: if kind == 0 { 0.0 } else { a }, beta: b, gamma: c, limit: LimitId(0) })
            .collect();
        let fast = project(rows.iter().copied());
        let slow = fourier_motzkin(&rows);
        match (fast, slow) {
            (None, None) => {}
            (Some((a, b)), Some((c, d))) => {
                let close = |x: f64, y: f64| x == y || (x - y).abs() <= 1e-9 * (1.0 + x.abs().max(y.abs()));
                proptest::prop_assert!(close(a, c) && close(b, d), "Newton [{a}, {b}], FM [{c}, {d}]");
            }
            // A projection that is a single point up to rounding may be seen as empty by one.
            (Some((a, b)), None) | (None, Some((a, b))) => {
                proptest::prop_assert!((b - a).abs() <= 1e-9 * (1.0 + b.abs()), "one empty, the other [{a}, {b}]");
            }
        }
    }
}
#[test]
fn steep_nearly_pure_rows_meeting_at_the_root_are_not_taken_for_an_empty_set() {
    use chessarm_core::plan::topp::Row;
    // From a 6.5 mm blend of a real game: a row with α = 1.5e-5 against β = 16.5 makes g so
    // steep (slope 1.1e6) that g at the exact root is 7e-12 of rounding; FM finds [0, 0.0606].
    let raw = [
        (-1.4684060781844366e-5, 16.47577369057041, 0.998),
        (0.12803500768849696, 12.92486112432427, 0.998),
        (-0.12803500768849696, -12.92486112432427, 0.998),
        (0.0008125000000000007, 1.0, 0.06911729194778175),
        (-0.0008125000000000007, -1.0, -0.0),
        (0.0, 0.7363281250000001, 0.998),
    ];
    let rows: Vec<Row> =
        raw.iter().map(|&(alpha, beta, gamma)| Row { alpha, beta, gamma, limit: LimitId(0) }).collect();
    let (lo, hi) = project(rows.iter().copied()).unwrap();
    let (flo, fhi) = fourier_motzkin(&rows).unwrap();
    assert!((lo - flo).abs() < 1e-12 && (hi - fhi).abs() < 1e-9 * fhi, "[{lo}, {hi}] against [{flo}, {fhi}]");
}

#[test]
fn without_an_upper_bound_on_x_the_projection_is_decided_by_the_lines_at_infinity() {
    use chessarm_core::plan::topp::Row;
    let rows = |raw: &[(f64, f64, f64)]| -> Vec<Row> {
        raw.iter().map(|&(alpha, beta, gamma)| Row { alpha, beta, gamma, limit: LimitId(0) }).collect()
    };
    // u ≥ x − 0 and u ≤ (1 − 1e-13) x + 1e-13: feasible for x ≤ 0.9997 only (the lines meet
    // there); a start far out at 1e15 used to accept it all.
    let (lo, hi) = project(rows(&[(-1.0, 1.0, 0.0), (1.0, -(1.0 - 1e-13), 1e-13)]).into_iter()).unwrap();
    assert_eq!(lo, 0.0);
    assert!((hi - 1.0).abs() < 1e-3, "{hi}");
    // u ≤ x and u ≥ x − 1: every x ≥ 0 is feasible.
    assert_eq!(project(rows(&[(1.0, -1.0, 0.0), (-1.0, 1.0, 1.0)]).into_iter()), Some((0.0, f64::INFINITY)));
    // u ≥ 2x + 1 and u ≤ x: nothing for x ≥ 0.
    assert_eq!(project(rows(&[(-1.0, 2.0, -1.0), (1.0, -1.0, 0.0)]).into_iter()), None);
}

#[test]
fn a_smoothed_leg_keeps_its_jerk_limit_on_a_grid_ten_times_finer_than_the_control_period() {
    let model = report_arm();
    let limits = limits(&model);
    let path = pick_and_place(0.04);
    let period = 1e-3;
    let plan = time_leg(&model, &path, &limits.carrying(), 0.005, 0, period).unwrap();
    let base = plan.leg.clone();
    for jerk in [1000.0, 200.0, 50.0] {
        let leg = base.clone().smoothed_for_jerk(jerk, period);
        // The window is the shortest whole number of periods with (max s̈ − min s̈)/T ≤ J.
        let (low, high) = base.timing.u.iter().fold((0.0_f64, 0.0_f64), |(l, h), &u| (l.min(u), h.max(u)));
        let spread = (high - low) / (base.scale * base.scale);
        assert!(leg.window() >= spread / jerk && leg.window() < spread / jerk + period, "{}", leg.window());
        let periods = leg.duration() / period;
        assert!((periods - periods.round()).abs() < 1e-6, "{periods}");
        assert!((leg.duration() - base.duration() - leg.window()).abs() < 1e-12);
        // From rest to rest, from the path's start to its end, never backwards.
        let end = path.length();
        assert_eq!(leg.law(0.0), (0.0, 0.0, 0.0));
        assert_eq!(leg.law(leg.duration()), (end, 0.0, 0.0));
        // Every 0.1 ms: the jerk (finite difference of s̈) within the limit, s̈ continuous (no
        // step larger than the jerk allows in a sample), ṡ the derivative of s.
        let h = period / 10.0;
        let n = (leg.duration() / h).round() as usize;
        let mut previous = leg.law(0.0);
        let mut largest: f64 = 0.0;
        for k in 1..=n + 10 {
            let now = leg.law(k as f64 * h);
            assert!(now.0 >= previous.0 - 1e-15, "s fell at t = {}", k as f64 * h);
            // |s̈(t + h) − s̈(t)| ≤ J h exactly (the law's jerk is piecewise constant, bounded
            // by the spread over the window); 1e-9 relative covers rounding.
            let jerk_here = (now.2 - previous.2).abs() / h;
            largest = largest.max(jerk_here);
            assert!(jerk_here <= jerk * (1.0 + 1e-9), "jerk {jerk_here} m/s³ at t = {} s, limit {jerk}", k as f64 * h);
            // Trapezoid rule on ṡ: exact to O(h³ s⃛) per step.
            let moved = now.0 - previous.0;
            let trapezoid = 0.5 * h * (now.1 + previous.1);
            assert!(
                (moved - trapezoid).abs() <= 1e-9,
                "s and ṡ disagree at t = {}: {moved} vs {trapezoid}",
                k as f64 * h
            );
            previous = now;
        }
        // The limit is used: the largest jerk is within a period's rounding of it.
        assert!(largest > 0.5 * jerk, "largest jerk {largest} against {jerk}");
    }
}

#[test]
fn the_unsmoothed_leg_is_the_time_optimal_law_and_a_stretch_is_a_uniform_slow_down() {
    let model = report_arm();
    let limits = limits(&model);
    let path = pick_and_place(0.04);
    let plan = time_leg(&model, &path, &limits.carrying(), 0.005, 0, 1e-3).unwrap();
    let leg = plan.leg.clone();
    assert_eq!(leg.window(), 0.0);
    // Unsmoothed, the law is the stretched optimal timing itself, bit for bit.
    for i in 0..=1000 {
        let t = leg.duration() * f64::from(i) / 1000.0;
        let (s, sd, sdd) = leg.timing.sample(t / leg.scale);
        assert_eq!(leg.law(t), (s, sd / leg.scale, sdd / (leg.scale * leg.scale)), "t = {t}");
    }
    assert_eq!(leg.clone().smoothed_for_jerk(0.0_f64.recip(), 1e-3).window(), 0.0);
    let smoothed = leg.smoothed_for_jerk(200.0, 1e-3);
    let k = 1.25;
    let slow = smoothed.clone().stretched(k);
    assert!((slow.duration() - k * smoothed.duration()).abs() < 1e-12);
    for i in 0..=100 {
        let t = smoothed.duration() * f64::from(i) / 100.0;
        let (a, b) = (smoothed.law(t), slow.law(k * t));
        assert!((a.0 - b.0).abs() < 1e-12 && (a.1 - k * b.1).abs() < 1e-12 && (a.2 - k * k * b.2).abs() < 1e-9);
    }
}

/// The pick-and-place leg with the tool turning from straight down to `tilt` rad outwards
/// along its traverse (between the ends of the rise and the start of the descent).
fn turning_pick_and_place(tilt: f64) -> GeometricPath {
    let path = pick_and_place(0.04);
    let (rise, descent) = (0.13 - 0.025, 0.13 - 0.025);
    let law = PitchLaw { from: TOOL_DOWN, to: TOOL_DOWN + tilt, start: rise, end: path.length() - descent };
    path.with_pitch(law)
}

#[test]
fn a_leg_whose_tool_turns_keeps_every_limit_and_its_joints_follow_the_pitch() {
    let model = report_arm();
    let limits = limits(&model);
    let path = turning_pick_and_place(0.35);
    let plan = time_leg(&model, &path, &limits.carrying(), 0.005, 0, 1e-3).unwrap();
    let mut motion = TimedMotion::pitched(path.start(), TOOL_DOWN);
    motion.push(Stretch::Leg(plan.leg.clone()));
    assert!((motion.end_pitch() - (TOOL_DOWN + 0.35)).abs() < 1e-12);
    let check = report_check();
    let carried = model.with_payload(Some(Payload::upright_cylinder(0.1, 0.08, 0.014, 0.05))).unwrap();
    let stages = plan.leg.timing.u.len() as f64;
    let dt = motion.duration() / (10.0 * stages);
    let used = check_motion(&model, &motion, &[(0.0, f64::INFINITY, carried)], &check, dt).unwrap().unwrap();
    assert!(used.share > 0.99, "{used:?}");
    // The joints put the tool at the law's pitch, and their rates and accelerations are the
    // differences of the joint path (the pitch's rate and acceleration enter J⁻¹ and J̇).
    let h = 1e-5;
    let joint = |t: f64| joint_motion_at(&model, &motion.sample(t)).unwrap();
    let (mut turning, mut compared) = (0, 0);
    for k in 1..200 {
        let t = motion.duration() * f64::from(k) / 200.0;
        let sample = motion.sample(t);
        let state = joint(t);
        let reached = tool_point(&model, &state.q);
        assert!((reached.xyz() - sample.position).norm() < 1e-9 && (reached.w - sample.pitch).abs() < 1e-9);
        let rate = (joint(t + h).q - joint(t - h).q) / (2.0 * h);
        let acceleration = (joint(t + h).qd - joint(t - h).qd) / (2.0 * h);
        assert!((rate - state.qd).norm() < 1e-6 * (1.0 + state.qd.norm()), "t = {t}: {rate} vs {}", state.qd);
        // The time law's s̈ is constant on each stage and steps between stages: compare
        // accelerations only where both neighbours lie on the same stage.
        if plan.leg.law(t + h).2 == plan.leg.law(t - h).2 {
            compared += 1;
            let tolerance = 1e-4 * (1.0 + state.qdd.norm());
            assert!((acceleration - state.qdd).norm() < tolerance, "t = {t}: {acceleration} vs {}", state.qdd);
        }
        if sample.pitch_rate.abs() > 0.1 {
            turning += 1;
        }
    }
    assert!(turning > 20, "the tool turns over a good part of the leg ({turning} of 199 samples)");
    assert!(compared > 100, "accelerations compared at {compared} of 199 samples");
}

#[test]
fn the_pitch_law_is_a_quintic_step_with_its_derivatives() {
    let law = PitchLaw { from: -1.5, to: -1.0, start: 0.1, end: 0.3 };
    assert_eq!(law.eval(0.05), (-1.5, 0.0, 0.0));
    assert_eq!(law.eval(0.35), (-1.0, 0.0, 0.0));
    assert!((law.eval(0.2).0 + 1.25).abs() < 1e-15, "half-way at the middle");
    let h = 1e-6;
    for k in 1..100 {
        let s = 0.1 + 0.2 * f64::from(k) / 100.0;
        let (_, slope, bend) = law.eval(s);
        let numeric_slope = (law.eval(s + h).0 - law.eval(s - h).0) / (2.0 * h);
        let numeric_bend = (law.eval(s + h).1 - law.eval(s - h).1) / (2.0 * h);
        assert!((numeric_slope - slope).abs() < 1e-6 && (numeric_bend - bend).abs() < 1e-4, "s = {s}");
    }
    // Rate and acceleration vanish at both ends (continuous with the constant pitch outside).
    for s in [0.1, 0.3] {
        let (_, slope, bend) = law.eval(s);
        assert!(slope.abs() < 1e-12 && bend.abs() < 1e-9, "s = {s}: {slope} {bend}");
    }
    assert_eq!(PitchLaw::constant(-0.7).eval(3.0), (-0.7, 0.0, 0.0));
}
