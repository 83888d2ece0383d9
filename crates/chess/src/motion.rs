//! A move's whole motion, planned one of two ways:
//!
//! - **LSPB** (the report's): every straight move of every task stops at its end, with fixed
//!   Cartesian limits and pauses ([`crate::tasks::append_move_path`]). A move whose joint
//!   speeds exceed the arm's limits (near the base axis joint 1 turns at `v/r`) is replanned
//!   with every limit × 0.7, up to 8 times: kept as it was, so that `--timing lspb` reproduces
//!   the earlier timings exactly.
//! - **Time-optimal**: the move is cut into legs at the grips and releases (where the tool must
//!   stop); each leg is the polyline of the tasks' waypoints (rise, traverse, descend) with its
//!   corners blended and is timed by TOPP-RA ([`chessarm_core::plan::optimal::time_leg`]) under
//!   the arm's joint speed limits, the joint acceleration limits, the motors' torque limits
//!   times the margin (with the carried piece in the dynamics), the tool speed limit, and, while
//!   carrying, the carry acceleration and the grip's strength. A blend is kept only where the
//!   tool (empty) or the carried piece's base clears every piece under it by the margin, checked
//!   every millimetre along it (see `clears`); otherwise its cut is halved, and below 1 mm the
//!   corner becomes a stop. The grips and releases stay vertical (they are the ends of legs). Every leg is then
//!   checked against every limit at every control period and at least twice per planning
//!   stage, and timed again on a finer grid if a limit is exceeded between grid points.

use crate::pieces::PieceSet;
use crate::table::{PhysicalPiece, Table};
use crate::tasks::{
    MAX_MOVE_DURATION, MAX_MOVE_SAMPLES, MotionLimits, PlannedTask, Task, TaskError, TaskGeometry, TaskPlan,
    append_move_path, check_segment, describe_move, move_tasks, task_geometry,
};
use chessarm_core::arm::model::ArmModel;
use chessarm_core::arm::task::held_turn;
use chessarm_core::nalgebra::{Vector2, Vector3};
use chessarm_core::plan::constraints::{
    JointAcceleration, JointSpeed, JointTorque, PathConstraint, ToolAcceleration, ToolSpeed, TrackingBudget,
};
use chessarm_core::plan::geometric::{GeometricPath, MIN_LINE, PathPiece, Stretch, TimedMotion};
use chessarm_core::plan::optimal::{LegPlan, MotionCheck, Usage, check_motion_at, time_leg};
use chessarm_core::plan::path::sample_times;
use chessarm_core::plan::path::{CartesianPath, CartesianSample, GripperAction, PitchLaw, Segment};
use chessarm_core::plan::trajectory::{JointTrajectory, PlanError, ToolMotion};
use shakmaty::{Chess, Move};

/// How a move's motion is timed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TimingMode {
    /// Time-optimal legs with blended corners (TOPP-RA).
    #[default]
    Optimal,
    /// The report's straight LSPB moves with stops and pauses.
    Lspb,
}

/// A planned motion of either kind.
#[derive(Debug, Clone, PartialEq)]
pub enum MoveMotion {
    Lspb(CartesianPath),
    Optimal(TimedMotion),
}

impl ToolMotion for MoveMotion {
    fn duration(&self) -> f64 {
        match self {
            MoveMotion::Lspb(path) => path.duration(),
            MoveMotion::Optimal(motion) => motion.duration(),
        }
    }
    fn sample(&self, t: f64) -> CartesianSample {
        match self {
            MoveMotion::Lspb(path) => path.sample(t),
            MoveMotion::Optimal(motion) => motion.sample(t),
        }
    }
}

impl MoveMotion {
    pub fn end(&self) -> Vector3<f64> {
        match self {
            MoveMotion::Lspb(path) => path.end(),
            MoveMotion::Optimal(motion) => motion.end(),
        }
    }
}

/// Planned time of a move by phase, s.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PhaseTimes {
    /// Horizontal moves and (time-optimal) blends.
    pub travel: f64,
    /// Rises and descents.
    pub vertical: f64,
    /// Gripper closing and opening (the dwells).
    pub grip: f64,
    /// Rests between LSPB moves.
    pub pause: f64,
}

/// A move planned: its motion, the joint trajectory at the control period, its tasks, and
/// what took the time.
#[derive(Debug, Clone)]
pub struct PlannedMove {
    pub motion: MoveMotion,
    pub trajectory: JointTrajectory,
    pub tasks: Vec<PlannedTask>,
    pub phases: PhaseTimes,
    /// Time-optimal only: per limit, the time it was the binding one, s.
    pub limit_times: Vec<(String, f64)>,
    /// Time-optimal only: every leg as timed (for phase-plane plots).
    pub legs: Vec<LegPlan>,
    /// Time-optimal only: the largest share of a limit used and which (checked every control
    /// period).
    pub usage: Option<Usage>,
    /// LSPB only: how many times the limits were scaled by 0.7.
    pub slowdowns: usize,
}

impl PlannedMove {
    /// The gripper's commands: per task a grip at its grip time and a release at its release
    /// time, s from the move's start.
    pub fn gripper_commands(&self) -> Vec<chessarm_core::plan::hardware::GripperCommand> {
        use chessarm_core::plan::hardware::GripperCommand;
        use chessarm_core::plan::path::GripperAction;
        self.tasks
            .iter()
            .flat_map(|task| {
                [
                    GripperCommand { time: task.plan.grip_time, action: GripperAction::Grip },
                    GripperCommand { time: task.plan.release_time, action: GripperAction::Release },
                ]
            })
            .collect()
    }

    /// The limit that was binding longest, with its time (s).
    pub fn longest_limit(&self) -> Option<(&str, f64)> {
        self.limit_times
            .iter()
            .filter(|(_, t)| *t > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(name, t)| (name.as_str(), *t))
    }
}

/// How many times an LSPB move is replanned slower before its joint-speed violation is an error.
const SLOWDOWN_ATTEMPTS: usize = 8;

/// The limits with every LSPB speed and acceleration scaled by 0.7.
fn slower(limits: &MotionLimits) -> MotionLimits {
    MotionLimits {
        traverse_speed: 0.7 * limits.traverse_speed,
        traverse_acceleration: 0.7 * limits.traverse_acceleration,
        vertical_speed: 0.7 * limits.vertical_speed,
        vertical_acceleration: 0.7 * limits.vertical_acceleration,
        ..*limits
    }
}

/// Plans a legal move from the tool at rest at `start` (m): tasks, motion and joint trajectory
/// sampled every `period` s. The planner's pieces (`pieces`) give the carried payloads. Errors
/// name the move.
#[allow(clippy::too_many_arguments)]
pub fn plan_move(
    start: Vector3<f64>,
    position: &Chess,
    mv: &Move,
    table: &Table,
    pieces: &PieceSet,
    limits: &MotionLimits,
    arm: &ArmModel<4>,
    mode: TimingMode,
    period: f64,
) -> Result<PlannedMove, TaskError> {
    let limits = limits.validated()?;
    let wrap = |source: TaskError| TaskError::Move { mv: describe_move(position, mv), source: Box::new(source) };
    match mode {
        TimingMode::Lspb => {
            let mut current = limits;
            let mut slowdowns = 0;
            loop {
                let mut path = CartesianPath::pitched(start, current.pitch);
                let tasks = append_move_path(&mut path, position, mv, table, pieces, &current, arm)?;
                fits(path.duration(), period, || {
                    let phases = lspb_phases(&path);
                    if phases.pause >= phases.grip.max(phases.travel + phases.vertical) {
                        "the pause between moves is far too long".to_string()
                    } else if phases.grip >= phases.travel + phases.vertical {
                        "the grip or release dwell is far too long".to_string()
                    } else {
                        "an LSPB speed or acceleration is far too low".to_string()
                    }
                })
                .map_err(wrap)?;
                match JointTrajectory::from_path(arm, &path, period) {
                    Ok(trajectory) => {
                        let phases = lspb_phases(&path);
                        return Ok(PlannedMove {
                            motion: MoveMotion::Lspb(path),
                            trajectory,
                            tasks,
                            phases,
                            limit_times: Vec::new(),
                            legs: Vec::new(),
                            usage: None,
                            slowdowns,
                        });
                    }
                    Err(PlanError::VelocityLimit { .. }) if slowdowns < SLOWDOWN_ATTEMPTS => {
                        slowdowns += 1;
                        current = slower(&current);
                    }
                    Err(source) => return Err(wrap(TaskError::Trajectory(source))),
                }
            }
        }
        TimingMode::Optimal => plan_optimal(start, position, mv, table, pieces, &limits, arm, period).map_err(wrap),
    }
}

fn lspb_phases(path: &CartesianPath) -> PhaseTimes {
    let mut phases = PhaseTimes::default();
    let mut time = 0.0;
    let marks: Vec<f64> = path.events().iter().map(|e| e.time).collect();
    for segment in path.segments() {
        let duration = segment.duration();
        match segment {
            Segment::Move { from, to, .. } => {
                if from.xy() == to.xy() {
                    phases.vertical += duration;
                } else {
                    phases.travel += duration;
                }
            }
            Segment::Pause { .. } => {
                if marks.iter().any(|&m| (m - time).abs() < 1e-9) {
                    phases.grip += duration;
                } else {
                    phases.pause += duration;
                }
            }
        }
        time += duration;
    }
    phases
}

/// One leg to time: waypoints from rest to rest, and what the gripper holds.
struct LegSpec {
    points: Vec<Vector3<f64>>,
    /// The task carried on this leg, if any.
    carried: Option<Task>,
    /// The table the leg moves over (the carried piece still on its square).
    table: Table,
    /// What happens at the leg's end.
    action: Option<GripperAction>,
    /// Clearance radius of the task the leg belongs to, m.
    radius: f64,
}

/// Shortest corner cut tried before a corner becomes a stop, m.
const MIN_CUT: f64 = 0.001;

/// Spacing of the clearance checks along a blend, m.
const CLEARANCE_STEP: f64 = 0.001;

#[allow(clippy::too_many_arguments)]
fn plan_optimal(
    start: Vector3<f64>,
    position: &Chess,
    mv: &Move,
    table: &Table,
    pieces: &PieceSet,
    limits: &MotionLimits,
    arm: &ArmModel<4>,
    period: f64,
) -> Result<PlannedMove, TaskError> {
    let tasks = move_tasks(position, mv, table)?;
    let mut scratch = table.clone();
    let mut specs = Vec::with_capacity(2 * tasks.len() + 1);
    let mut current = vec![start];
    let mut here = Vector2::new(start.x, start.y);
    let mut last_height = start.z - table.geometry().surface_height;
    let mut geometries = Vec::with_capacity(tasks.len());
    for task in &tasks {
        let geometry = task_geometry(here, task, &scratch, pieces, limits)?;
        let TaskGeometry { traverse_height: h, pick, place, grip_z, surface, radius } = geometry;
        let at = |xy: Vector2<f64>, height: f64| Vector3::new(xy.x, xy.y, surface + height);
        let waypoints = [at(here, h), at(pick, h), at(pick, grip_z), at(pick, h), at(place, h), at(place, grip_z)];
        // A tool already above the piece goes straight down to it: rising to the traverse
        // height first would double back.
        let above = (pick - here).norm() < MIN_LINE;
        let approach: &[Vector3<f64>] = if above { &waypoints[2..3] } else { &waypoints[..3] };
        let mut previous = *current.last().unwrap_or(&start);
        for target in approach.iter().chain(&waypoints[3..]) {
            check_segment(arm, &previous, target, limits.pitch)
                .map_err(|source| TaskError::Unreachable { task: task.to_string(), source })?;
            previous = *target;
        }
        current.extend_from_slice(approach);
        specs.push(LegSpec {
            points: std::mem::take(&mut current),
            carried: None,
            table: scratch.clone(),
            action: Some(GripperAction::Grip),
            radius,
        });
        specs.push(LegSpec {
            points: waypoints[2..].to_vec(),
            carried: Some(*task),
            table: scratch.clone(),
            action: Some(GripperAction::Release),
            radius,
        });
        let target = scratch.nominal_position(task.to);
        scratch
            .relocate(task.from, task.to, target)
            .map_err(|source| TaskError::TaskTable { task: task.to_string(), source })?;
        current.push(at(place, grip_z));
        here = place;
        last_height = h;
        geometries.push(geometry);
    }
    let surface = table.geometry().surface_height;
    let rest = Vector3::new(here.x, here.y, surface + last_height);
    if let Some(from) = current.last() {
        check_segment(arm, from, &rest, limits.pitch).map_err(|source| TaskError::Unreachable {
            task: tasks.last().map_or_else(String::new, |t| t.to_string()),
            source,
        })?;
    }
    current.push(rest);
    let radius = geometries.last().map_or(0.0, |g| g.radius);
    specs.push(LegSpec { points: current, carried: None, table: scratch, action: None, radius });

    let mut motion = TimedMotion::pitched(start, limits.pitch);
    let mut legs = Vec::new();
    let mut phases = PhaseTimes::default();
    let mut marks = Vec::new();
    let mut usage: Option<Usage> = None;
    for spec in &mut specs {
        // Each leg starts where the motion is (a skipped leg's end may lie up to MIN_LINE away).
        spec.points[0] = motion.end();
        let payload_arm = match &spec.carried {
            Some(task) => arm
                .with_payload(Some(pieces.payload(task.piece.role).turned(held_turn(arm, limits.pitch))))
                .map_err(TaskError::Model)?,
            None => *arm,
        };
        // A leg whose points all lie within MIN_LINE of each other needs no motion (a final
        // rise of zero height, say).
        let extent = spec.points.iter().map(|p| (p - spec.points[0]).norm()).fold(0.0, f64::max);
        let paths = if extent < MIN_LINE { Vec::new() } else { blended_paths(spec, pieces, limits)? };
        for path in paths {
            let carried = spec.carried.map(|task| task.piece.role);
            let (plan, used) = time_optimal_leg(&path, &payload_arm, carried, limits, arm, period)?;
            if usage.as_ref().is_none_or(|u| used.share > u.share) {
                usage = Some(used);
            }
            add_phases(&mut phases, &plan);
            motion.push(Stretch::Leg(plan.leg.clone()));
            legs.push(plan);
        }
        if let Some(action) = spec.action {
            motion.mark(action);
            marks.push(motion.duration());
            let dwell = match action {
                GripperAction::Grip => limits.grip_dwell,
                GripperAction::Release => limits.release_dwell,
            };
            if dwell > 0.0 {
                motion.push(Stretch::Dwell { at: motion.end(), pitch: motion.end_pitch(), duration: dwell });
                phases.grip += dwell;
            }
        }
    }
    let mut limit_times: Vec<(String, f64)> = Vec::new();
    for leg in &legs {
        for (name, time) in leg.time_per_limit() {
            match limit_times.iter_mut().find(|(n, _)| *n == name) {
                Some((_, total)) => *total += time * leg.leg.scale,
                None => limit_times.push((name, time * leg.leg.scale)),
            }
        }
    }
    fits(motion.duration(), period, || {
        if phases.grip >= phases.travel + phases.vertical {
            return "the grip or release dwell is far too long".to_string();
        }
        too_low(&limit_times)
    })?;
    let trajectory = JointTrajectory::from_path(arm, &motion, period).map_err(TaskError::Trajectory)?;
    let mut planned = Vec::with_capacity(tasks.len());
    for (k, (task, geometry)) in tasks.iter().zip(&geometries).enumerate() {
        let at = |xy: Vector2<f64>| Vector3::new(xy.x, xy.y, geometry.surface + geometry.grip_z);
        planned.push(PlannedTask {
            task: *task,
            plan: TaskPlan {
                traverse_height: geometry.traverse_height,
                grip_time: marks[2 * k],
                release_time: marks[2 * k + 1],
                release_point: at(geometry.place),
            },
        });
    }
    Ok(PlannedMove {
        motion: MoveMotion::Optimal(motion),
        trajectory,
        tasks: planned,
        phases,
        limit_times,
        legs,
        usage,
        slowdowns: 0,
    })
}

/// Refuses a move of `duration` s whose trajectory at `period` would have more than
/// [`MAX_MOVE_SAMPLES`] samples, or that would last longer than [`MAX_MOVE_DURATION`], naming
/// what binds (`binding`).
fn fits(duration: f64, period: f64, binding: impl Fn() -> String) -> Result<(), TaskError> {
    let samples = duration / period;
    let max = MAX_MOVE_SAMPLES.min((MAX_MOVE_DURATION / period).floor());
    if samples.is_finite() && samples <= max {
        return Ok(());
    }
    Err(TaskError::TooLong { duration, samples, max, binding: binding() })
}

/// What to blame for a motion too long: the limit that was binding longest in `limit_times`
/// (name, s).
fn too_low(limit_times: &[(String, f64)]) -> String {
    let longest = limit_times.iter().max_by(|a, b| a.1.total_cmp(&b.1));
    longest.map_or_else(
        || "a limit is far too low".to_string(),
        |(name, _)| format!("the {name} limit, binding longest, is far too low"),
    )
}

/// Adds a timed leg's time per piece: vertical lines to `vertical`, the rest to `travel`.
fn add_phases(phases: &mut PhaseTimes, plan: &LegPlan) {
    let path = &plan.leg.path;
    for (piece, start) in path.pieces().iter().zip(path.piece_starts()) {
        let duration = plan.leg.time_at(start + piece.length()) - plan.leg.time_at(*start);
        if piece.is_vertical() {
            phases.vertical += duration;
        } else {
            phases.travel += duration;
        }
    }
}

/// How many times a leg's grid is halved when its check finds a limit exceeded between grid
/// points (the rows hold at the grid points only).
const REFINEMENTS: u32 = 3;

/// Times one leg and checks it at every control period against the full limits; a leg that
/// exceeds one between grid points is timed again on a grid twice as fine (up to
/// [`REFINEMENTS`] times).
fn time_optimal_leg(
    path: &GeometricPath,
    model: &ArmModel<4>,
    carried_kind: Option<shakmaty::Role>,
    limits: &MotionLimits,
    arm: &ArmModel<4>,
    period: f64,
) -> Result<(LegPlan, Usage), TaskError> {
    let carrying = carried_kind.is_some();
    let max_speed = arm.links().map(|l| l.limits.velocity);
    let speed = JointSpeed { max: max_speed };
    let acceleration = JointAcceleration { max: limits.joint_acceleration };
    let torque = JointTorque { model: *model, margin: limits.torque_margin, max_speed };
    let tool = ToolSpeed { max: limits.tool_speed };
    let carry = ToolAcceleration {
        max: limits.carry_acceleration,
        gravity: Vector3::zeros(),
        label: "tool acceleration while carrying".to_string(),
    };
    let grip = ToolAcceleration { max: limits.grip_strength, gravity: arm.gravity(), label: "grip".to_string() };
    let tracking = carried_kind.filter(|role| limits.tracking.applies_to(*role)).map(|role| TrackingBudget {
        model: *model,
        kp: limits.tracking.kp,
        overshoot: limits.tracking.overshoot,
        mass_error: limits.tracking.mass_error[role as usize - 1],
        budget: limits.tracking.budget,
        stiffness: limits.tracking.stiffness,
    });
    let mut constraints: Vec<&dyn PathConstraint<4>> = vec![&speed, &acceleration, &torque, &tool];
    if let Some(tracking) = tracking.as_ref() {
        constraints.push(tracking);
    }
    if carrying {
        constraints.push(&carry);
        // |p̈ − g| ≤ |p̈| + |g|: a grip at least that strong is never the binding limit.
        if limits.carry_acceleration + arm.gravity().norm() > limits.grip_strength {
            constraints.push(&grip);
        }
    }
    let check = MotionCheck {
        joint_speed: max_speed,
        joint_acceleration: limits.joint_acceleration,
        torque_margin: limits.torque_margin,
        tool_speed: limits.tool_speed,
        carry_acceleration: if carrying { limits.carry_acceleration } else { f64::INFINITY },
        grip_strength: if carrying { limits.grip_strength } else { f64::INFINITY },
        tracking,
    };
    let carried = [(0.0, f64::INFINITY, *model)];
    let carried: &[(f64, f64, ArmModel<4>)] = if carrying { &carried } else { &[] };
    let mut refinement = 0;
    let mut stretches = 0;
    let mut plan = plan_leg(arm, path, &constraints, limits, refinement, period)?;
    loop {
        // Before anything samples it: a leg longer than a move may be.
        fits(plan.leg.duration(), period, || {
            if plan.leg.window() >= plan.leg.base_duration() {
                return "the jerk limit is far too low (its smoothing window)".to_string();
            }
            too_low(&plan.time_per_limit())
        })?;
        let mut leg = TimedMotion::pitched(path.start(), path.eval_pitch(0.0).0);
        leg.push(Stretch::Leg(plan.leg.clone()));
        // Every control period, and every planning stage at its ends and its middle, as the
        // base law passes them and as the smoothed one does (half a window later) and ends
        // them (a whole window later).
        let timing = &plan.leg.timing;
        let (scale, window) = (plan.leg.scale, plan.leg.window());
        let periods = sample_times(plan.leg.duration(), period).map_err(|e| TaskError::Trajectory(e.into()))?;
        let shifts: &[f64] = if window > 0.0 { &[0.0, 0.5, 1.0] } else { &[0.0] };
        let stages = timing.t.windows(2).flat_map(|w| {
            let instants = [w[0] * scale, 0.5 * (w[0] + w[1]) * scale, w[1] * scale * (1.0 - 1e-12)];
            shifts.iter().flat_map(move |shift| instants.map(|t| t + shift * window))
        });
        let times = periods.chain(stages);
        match check_motion_at(arm, &leg, carried, &check, times).map_err(TaskError::Trajectory)? {
            Ok(usage) => return Ok((plan, usage)),
            // The smoothing averages the law over a stretch of path along which the limits
            // vary, and fills in the speed's dips where the law rides a limit: a smoothed leg
            // over a limit by a share ρ is slowed down as a whole, window and all, by k ≥ ρ
            // (speeds scale by 1/k, accelerations by 1/k², the jerk by 1/k³, the shape is
            // the same) to whole periods, and checked again.
            Err(_) if window > 0.0 && stretches < STRETCHES => {
                stretches += 1;
                // The check stops at the first limit exceeded: the largest share of any limit
                // comes from the same samples against limits LOOSE times wider.
                let loose = MotionCheck {
                    joint_speed: check.joint_speed.map(|v| v * LOOSE),
                    joint_acceleration: check.joint_acceleration.map(|v| v * LOOSE),
                    torque_margin: check.torque_margin * LOOSE,
                    tool_speed: check.tool_speed * LOOSE,
                    carry_acceleration: check.carry_acceleration * LOOSE,
                    grip_strength: check.grip_strength * LOOSE,
                    tracking: check.tracking.map(|t| TrackingBudget { budget: t.budget * LOOSE, ..t }),
                };
                let times = sample_times(plan.leg.duration(), period).map_err(|e| TaskError::Trajectory(e.into()))?;
                let stages = timing.t.windows(2).flat_map(|w| {
                    let instants = [w[0] * scale, 0.5 * (w[0] + w[1]) * scale, w[1] * scale * (1.0 - 1e-12)];
                    shifts.iter().flat_map(move |shift| instants.map(|t| t + shift * window))
                });
                let over = match check_motion_at(arm, &leg, carried, &loose, times.chain(stages))
                    .map_err(TaskError::Trajectory)?
                {
                    Ok(usage) => (usage.share * LOOSE).max(1.0),
                    Err(violation) => return Err(TaskError::Violation(violation)),
                };
                let duration = plan.leg.duration();
                let periods = (duration * over / period - 1e-9).ceil().max((duration / period).round() + 1.0);
                plan.leg = plan.leg.stretched(periods * period / duration);
            }
            Err(_) if window <= 0.0 && refinement < REFINEMENTS => {
                refinement += 1;
                plan = plan_leg(arm, path, &constraints, limits, refinement, period)?;
            }
            Err(violation) => return Err(TaskError::Violation(violation)),
        }
    }
}

/// How many times a smoothed leg over a limit is slowed down before it is an error.
const STRETCHES: u32 = 8;

/// How much wider than the limits the check is that finds a smoothed leg's largest share of
/// a limit (a leg this far over is an error).
const LOOSE: f64 = 100.0;

/// The leg timed on the grid refined `refinement` times, smoothed to the jerk limit.
fn plan_leg(
    arm: &ArmModel<4>,
    path: &GeometricPath,
    constraints: &[&dyn PathConstraint<4>],
    limits: &MotionLimits,
    refinement: u32,
    period: f64,
) -> Result<LegPlan, TaskError> {
    let mut plan = time_leg(arm, path, constraints, limits.grid_step, refinement, period).map_err(TaskError::Leg)?;
    if limits.jerk > 0.0 {
        plan.leg = plan.leg.smoothed_for_jerk(limits.jerk, period);
    }
    Ok(plan)
}

/// The leg's polyline with each corner blended at the largest cut (up to `limits.blend`) whose
/// blend keeps the clearance ([`clears`]), found by bisection to 1/64 of the range; a corner
/// whose blend cannot clear even at [`MIN_CUT`] stays sharp, and the leg is split there into
/// paths that each start and end at rest.
fn blended_paths(spec: &LegSpec, pieces: &PieceSet, limits: &MotionLimits) -> Result<Vec<GeometricPath>, TaskError> {
    let corners = GeometricPath::corners(&spec.points).map_err(TaskError::Geometry)?;
    let interior = corners.len().saturating_sub(2);
    let mut cuts = vec![0.0; interior];
    for (k, cut) in cuts.iter_mut().enumerate() {
        let around = [corners[k], corners[k + 1], corners[k + 2]];
        let fits = |d: f64| -> Result<bool, TaskError> {
            let path = GeometricPath::polyline(&around, |_| d).map_err(TaskError::Geometry)?;
            // The pitch is constant along a leg: the blend's clearance below does not depend
            // on it.
            let blend = path.pieces().iter().find(|p| matches!(p, PathPiece::Blend { .. }));
            Ok(blend.is_none_or(|b| clears(b, spec, pieces, limits)))
        };
        if limits.blend < MIN_CUT {
            continue;
        }
        if fits(limits.blend)? {
            *cut = limits.blend;
            continue;
        }
        if !fits(MIN_CUT)? {
            continue;
        }
        let (mut good, mut bad) = (MIN_CUT, limits.blend);
        for _ in 0..BISECTIONS {
            let middle = 0.5 * (good + bad);
            if fits(middle)? {
                good = middle;
            } else {
                bad = middle;
            }
        }
        *cut = good;
    }
    let mut paths = Vec::new();
    let mut first = 0;
    for k in 0..=interior {
        if k == interior || cuts[k] == 0.0 {
            let end = k + 1;
            let section_cuts = &cuts[first..k];
            let path =
                GeometricPath::polyline(&corners[first..=end], |c| section_cuts[c]).map_err(TaskError::Geometry)?;
            paths.push(path.with_pitch(PitchLaw::constant(limits.pitch)));
            first = end;
        }
    }
    Ok(paths)
}

/// Bisection steps of a corner's cut between [`MIN_CUT`] and the largest: 1/64 of the range.
const BISECTIONS: usize = 6;

/// Whether the tool (empty) or the carried piece's base clears every piece under it, and the
/// bare table, by the margin along `blend`, sampled every [`CLEARANCE_STEP`]. Over the leg's
/// first and last points (within the clearance radius of them) the tool is coming down onto
/// the table or rising from it: there the piece standing in that column (the one about to be
/// gripped, or just put down) and the table do not count, only other pieces under the tool.
fn clears(blend: &PathPiece, spec: &LegSpec, pieces: &PieceSet, limits: &MotionLimits) -> bool {
    let surface = spec.table.geometry().surface_height;
    let below_tip = spec.carried.map_or(0.0, |task| pieces.dimensions(task.piece.role).grip_height);
    let carried = spec.carried.map(|task| task.from);
    let ends = [spec.points[0].xy(), spec.points[spec.points.len() - 1].xy()];
    let own_square = 0.5 * spec.table.geometry().square_size;
    let n = (blend.length() / CLEARANCE_STEP).ceil().max(1.0) as usize;
    (0..=n).all(|k| {
        let (p, _, _) = blend.eval(blend.length() * k as f64 / n as f64);
        let xy = p.xy();
        let column = ends.iter().find(|end| (xy - **end).norm() <= spec.radius);
        let keep = |piece: &PhysicalPiece| {
            Some(piece.location) != carried && column.is_none_or(|end| (piece.position - end).norm() > own_square)
        };
        let bottom = p.z - surface - below_tip;
        match spec.table.tallest_under_point_where(xy, xy, spec.radius, pieces, keep) {
            Some(top) => bottom >= top + limits.clearance_margin - 1e-12,
            None => column.is_some() || bottom >= limits.clearance_margin - 1e-12,
        }
    })
}
