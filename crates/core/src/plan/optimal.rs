//! Time-optimal legs and their check.
//!
//! A leg is a [`GeometricPath`] from rest to rest: it is cut into a grid (every piece boundary,
//! steps of at most `step`), each grid point is taken to joint space (`q = IK(p)`,
//! `q' = J⁻¹ p'`, `q'' = J⁻¹ (p'' − J̇(q, q') q')`), the constraints give rows in `(s̈, ṡ²)`,
//! [`time_optimal`] times it, and the duration is stretched up to a whole number of control
//! periods so that gripper events fall on samples (a uniform slow-down by `k ≥ 1` scales
//! velocities by `1/k` and accelerations by `1/k²`: torques become a convex combination of the
//! planned ones and the gravity torques, so every limit still holds).
//!
//! [`check_motion`] samples a planned motion and compares every limit with the values computed
//! from the samples themselves (inverse dynamics with the carried piece, tool acceleration by
//! the path's own derivatives), independently of the rows the planner used.

use super::constraints::{PathConstraint, PathPoint, TrackingBudget, constraint_table};
use super::geometric::{GeometricPath, TimedLeg};
use super::path::{CartesianSample, sample_times};
use super::topp::{ConstraintTable, LimitId, Timing, ToppError, time_optimal};
use super::trajectory::{PlanError, ToolMotion, joint_motion_at};
use crate::arm::dynamics::{friction_torques, inverse_dynamics};
use crate::arm::model::ArmModel;

pub use super::constraints::GRID_SLACK;

/// Why a leg cannot be timed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LegError {
    #[error(transparent)]
    Path(#[from] PlanError),
    #[error(
        "no motion within the limits at ({:.4}, {:.4}, {:.4}) m: {reason}", .position[0], .position[1], .position[2]
    )]
    Infeasible { position: [f64; 3], reason: String },
    #[error(transparent)]
    Topp(#[from] ToppError),
    #[error("the path leaves the arm's reach at ({:.4}, {:.4}, {:.4}) m: {reason}", .position[0], .position[1], .position[2])]
    Unreachable { position: [f64; 3], reason: String },
}

/// A timed leg with what was used to time it (for phase-plane plots and reports).
#[derive(Debug, Clone, PartialEq)]
pub struct LegPlan {
    pub leg: TimedLeg,
    pub points: Vec<PathPoint<4>>,
    pub table: ConstraintTable,
    /// Names of the limits, indexed by [`LimitId`].
    pub names: Vec<String>,
}

impl LegPlan {
    /// Time (s, before the stretch to whole periods) each limit was the binding one.
    pub fn time_per_limit(&self) -> Vec<(String, f64)> {
        let mut totals = vec![0.0; self.names.len()];
        let timing = &self.leg.timing;
        for (i, active) in timing.active.iter().enumerate() {
            if let Some(LimitId(k)) = active
                && let Some(total) = totals.get_mut(*k as usize)
            {
                *total += timing.t[i + 1] - timing.t[i];
            }
        }
        self.names.iter().cloned().zip(totals).collect()
    }
}

/// The path points of `path` at `grid`, at the path's own pitch.
pub fn path_points(model: &ArmModel<4>, path: &GeometricPath, grid: &[f64]) -> Result<Vec<PathPoint<4>>, LegError> {
    grid.iter()
        .map(|&s| {
            let (tip, dtip, ddtip) = path.eval(s);
            let (pitch, pitch_rate, pitch_acceleration) = path.eval_pitch(s);
            let sample = CartesianSample {
                t: 0.0,
                position: tip,
                velocity: dtip,
                acceleration: ddtip,
                pitch,
                pitch_rate,
                pitch_acceleration,
            };
            let joint = joint_motion_at(model, &sample).map_err(|error| {
                // The sample's time means nothing here (the path is not timed yet): say where.
                let reason = match error {
                    PlanError::Ik { source, .. } => source.to_string(),
                    PlanError::Singular { determinant, .. } => {
                        format!("the arm is singular there (|det J| = {determinant:.3e})")
                    }
                    other => other.to_string(),
                };
                LegError::Unreachable { position: tip.into(), reason }
            })?;
            Ok(PathPoint { s, q: joint.q, dq: joint.qd, ddq: joint.qdd, tip, dtip, ddtip })
        })
        .collect()
}

/// Times `path` from rest to rest under `constraints` on the grid [`GeometricPath::grid`] of
/// steps ≤ `step` (units of the path parameter, m) at `refinement`, stretched to a whole number
/// of `period`s (s).
pub fn time_leg(
    model: &ArmModel<4>,
    path: &GeometricPath,
    constraints: &[&dyn PathConstraint<4>],
    step: f64,
    refinement: u32,
    period: f64,
) -> Result<LegPlan, LegError> {
    let grid = path.grid(step, refinement);
    let points = path_points(model, path, &grid)?;
    let (mut table, names) = constraint_table(&points, constraints);
    table.tighten(GRID_SLACK);
    let timing: Timing = match time_optimal(&table, 0.0, 0.0) {
        Ok(timing) => timing,
        Err(ToppError::Infeasible { index, limit, .. }) => {
            let point = &points[index];
            let reason = match limit {
                Some(LimitId(k)) => explain(constraints, point, k as usize),
                None => "the limits leave no speed from which the arm can still stop in time".to_string(),
            };
            return Err(LegError::Infeasible { position: point.tip.into(), reason });
        }
        Err(ToppError::Stuck { s }) => {
            let (position, _, _) = path.eval(s);
            let reason = "every limit allows only rest there".to_string();
            return Err(LegError::Infeasible { position: position.into(), reason });
        }
        Err(other) => return Err(other.into()),
    };
    let duration = timing.duration();
    let periods = (duration / period - 1e-9).ceil().max(1.0);
    let scale = periods * period / duration;
    Ok(LegPlan { leg: TimedLeg::new(path.clone(), timing, scale), points, table, names })
}

/// The description of limit `k` (counted over all constraints) at `point`.
fn explain(constraints: &[&dyn PathConstraint<4>], point: &PathPoint<4>, mut k: usize) -> String {
    for c in constraints {
        if k < c.parts() {
            return c.explain(point, k);
        }
        k -= c.parts();
    }
    "unknown limit".to_string()
}

/// Limits a planned motion must keep, checked by [`check_motion`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionCheck {
    /// Largest |q̇_j|, rad/s.
    pub joint_speed: [f64; 4],
    /// Largest |q̈_j|, rad/s² (∞ for none).
    pub joint_acceleration: [f64; 4],
    /// Largest |τ_j| as a share of each motor's limit.
    pub torque_margin: f64,
    /// Largest tool speed, m/s (∞ for none).
    pub tool_speed: f64,
    /// While carrying: largest |p̈|, m/s², and largest |p̈ − g| the grip holds, m/s².
    pub carry_acceleration: f64,
    pub grip_strength: f64,
    /// While carrying: the tracking budget (its `model` is replaced by the carried interval's
    /// model, the arm with the nominal piece), if any.
    pub tracking: Option<TrackingBudget<4>>,
}

/// A limit a planned motion exceeds.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("at t = {time:.3} s the planned {limit} reaches {value:.4} {unit}, above its {max:.4} {unit}")]
pub struct Violation {
    pub time: f64,
    /// E.g. "joint 2 torque".
    pub limit: String,
    pub value: f64,
    pub max: f64,
    pub unit: &'static str,
}

/// The most-used limit of a checked motion.
#[derive(Debug, Clone, PartialEq)]
pub struct Usage {
    /// Largest value over limit seen, e.g. 0.998.
    pub share: f64,
    pub limit: String,
    pub time: f64,
}

/// Names of the per-joint limits, as the constraints name them.
const JOINT_SPEED: [&str; 4] = ["joint 1 speed", "joint 2 speed", "joint 3 speed", "joint 4 speed"];
const JOINT_ACCELERATION: [&str; 4] =
    ["joint 1 acceleration", "joint 2 acceleration", "joint 3 acceleration", "joint 4 acceleration"];
const JOINT_TORQUE: [&str; 4] = ["joint 1 torque", "joint 2 torque", "joint 3 torque", "joint 4 torque"];

/// Relative excess over a limit accepted as rounding (planner and check compute the same
/// quantities in different orders).
pub const CHECK_TOLERANCE: f64 = 1e-6;

/// Samples `motion` every `dt` s and checks it against `limits`: `model` is the arm without a
/// piece; during `carrying` intervals `[grip, release)` (s) the arm carries the interval's
/// model (its payload is the piece) and the tool and grip limits apply. Returns the first
/// violation, and otherwise the most-used limit.
pub fn check_motion(
    model: &ArmModel<4>,
    motion: &impl ToolMotion,
    carrying: &[(f64, f64, ArmModel<4>)],
    limits: &MotionCheck,
    dt: f64,
) -> Result<Result<Usage, Violation>, PlanError> {
    check_motion_at(model, motion, carrying, limits, sample_times(motion.duration(), dt)?)
}

/// [`check_motion`] at the given instants (s).
pub fn check_motion_at(
    model: &ArmModel<4>,
    motion: &impl ToolMotion,
    carrying: &[(f64, f64, ArmModel<4>)],
    limits: &MotionCheck,
    times: impl Iterator<Item = f64>,
) -> Result<Result<Usage, Violation>, PlanError> {
    let mut largest = Usage { share: 0.0, limit: String::new(), time: 0.0 };
    for t in times {
        let sample = motion.sample(t);
        let joint = joint_motion_at(model, &sample)?;
        let carried = carrying.iter().find(|(grip, release, _)| t >= *grip && t < *release).map(|(_, _, m)| m);
        let arm = carried.unwrap_or(model);
        let torque = inverse_dynamics(arm, &joint.q, &joint.qd, &joint.qdd) - friction_torques(arm, &joint.qd);
        // (limit, value, largest allowed, unit): no allocation per sample; the name becomes a
        // String only in what is returned.
        let carry = carried.map_or((0.0, 0.0), |_| {
            let a = sample.acceleration;
            (a.norm(), (a - model.gravity()).norm())
        });
        let (carry_max, grip_max) = match carried {
            Some(_) => (limits.carry_acceleration, limits.grip_strength),
            None => (f64::INFINITY, f64::INFINITY),
        };
        let tracking = match (carried, &limits.tracking) {
            (Some(model), Some(budget)) => {
                let budget = TrackingBudget { model: *model, ..*budget };
                let error =
                    budget.mass_error * budget.overshoot * (budget.compliance(&joint.q) * sample.acceleration).norm();
                (error, budget.budget)
            }
            _ => (0.0, f64::INFINITY),
        };
        let mut checks = [("", 0.0, 0.0, ""); 16];
        for j in 0..4 {
            checks[3 * j] = (JOINT_SPEED[j], joint.qd[j].abs(), limits.joint_speed[j], "rad/s");
            checks[3 * j + 1] = (JOINT_ACCELERATION[j], joint.qdd[j].abs(), limits.joint_acceleration[j], "rad/s²");
            let max = limits.torque_margin * model.link(j).limits.torque;
            checks[3 * j + 2] = (JOINT_TORQUE[j], torque[j].abs(), max, "N·m");
        }
        checks[12] = ("tool speed", sample.velocity.norm(), limits.tool_speed, "m/s");
        checks[13] = ("tool acceleration while carrying", carry.0, carry_max, "m/s²");
        checks[14] = ("grip", carry.1, grip_max, "m/s²");
        checks[15] = ("tracking budget (carried piece)", tracking.0, tracking.1, "m");
        for (limit, value, max, unit) in checks {
            if value > max * (1.0 + CHECK_TOLERANCE) {
                return Ok(Err(Violation { time: t, limit: limit.to_string(), value, max, unit }));
            }
            if max.is_finite() && max > 0.0 && value / max > largest.share {
                largest = Usage { share: value / max, limit: limit.to_string(), time: t };
            }
        }
    }
    Ok(Ok(largest))
}
