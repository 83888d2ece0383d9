//! The planned motion for real hardware: joint positions, rates and accelerations at a rate the
//! driver chooses, with the gripper's state, from the plan (not from a simulation).
//!
//! Samples lie at `t_k = k / rate` for `k = 0, 1, …` up to the motion's duration, plus the
//! duration itself and every gripper command's instant (so a driver sees each command at its
//! exact time). At each instant `q = IK(p(t))`, `q̇ = J⁻¹ ṗ`, `q̈ = J⁻¹ (p̈ − J̇ q̇)` with the
//! tool at the motion's pitch ([`super::trajectory::joint_motion_at`]). The gripper is closed from
//! a grip command (inclusive) to the next release command (exclusive).

use super::path::GripperAction;
use super::trajectory::{PlanError, ToolMotion, joint_motion_at};
use crate::arm::model::{ArmModel, JointVector};

/// Highest sample rate of an export, Hz (a 10 kHz stream is beyond any hobby servo bus).
pub const MAX_EXPORT_RATE: f64 = 10_000.0;

/// Lowest sample rate of an export, Hz: a driver interpolates between samples, and below one a
/// second it would cut straight across the board.
pub const MIN_EXPORT_RATE: f64 = 1.0;

/// Instants closer than this (s) are the same sample.
const SAME_INSTANT: f64 = 1e-9;

/// A gripper command at an instant of the motion, s from its start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GripperCommand {
    pub time: f64,
    pub action: GripperAction,
}

/// One sample for the hardware.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HardwarePoint {
    /// s from the motion's start.
    pub t: f64,
    /// rad.
    pub q: JointVector<4>,
    /// rad/s.
    pub qd: JointVector<4>,
    /// rad/s².
    pub qdd: JointVector<4>,
    /// Whether the gripper is closed.
    pub gripper_closed: bool,
    /// While closed: which grip (0-based, in the order of the grip commands) holds the piece.
    pub grip: Option<usize>,
}

/// Why no export: the rate, or the plan's joint motion at an instant.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExportError {
    #[error("{0} Hz: the rate must be a finite number in [{MIN_EXPORT_RATE}, {MAX_EXPORT_RATE}] Hz")]
    Rate(f64),
    #[error(transparent)]
    Plan(#[from] PlanError),
}

/// The sample instants of [`hardware_points`]: the grid, the end and the commands, sorted.
fn instants(duration: f64, rate: f64, commands: &[GripperCommand]) -> Vec<f64> {
    let steps = (duration * rate + SAME_INSTANT).floor() as usize;
    let mut times: Vec<f64> = (0..=steps).map(|k| k as f64 / rate).collect();
    times.push(duration);
    times.extend(commands.iter().map(|c| c.time.clamp(0.0, duration)));
    times.sort_by(f64::total_cmp);
    times.dedup_by(|later, earlier| *later - *earlier < SAME_INSTANT);
    times
}

/// The planned `motion` sampled at `rate` Hz and at every gripper command.
pub fn hardware_points(
    arm: &ArmModel<4>,
    motion: &impl ToolMotion,
    commands: &[GripperCommand],
    rate: f64,
) -> Result<Vec<HardwarePoint>, ExportError> {
    if !(rate.is_finite() && (MIN_EXPORT_RATE..=MAX_EXPORT_RATE).contains(&rate)) {
        return Err(ExportError::Rate(rate));
    }
    let mut commands = commands.to_vec();
    commands.sort_by(|a, b| a.time.total_cmp(&b.time));
    let duration = motion.duration();
    let mut points = Vec::new();
    for t in instants(duration, rate, &commands) {
        let sample = joint_motion_at(arm, &motion.sample(t))?;
        // The last command at or before t decides; grips are counted in order.
        let mut closed = false;
        let mut grips = 0;
        for command in commands.iter().take_while(|c| c.time <= t + SAME_INSTANT) {
            closed = command.action == GripperAction::Grip;
            if closed {
                grips += 1;
            }
        }
        points.push(HardwarePoint {
            t,
            q: sample.q,
            qd: sample.qd,
            qdd: sample.qdd,
            gripper_closed: closed,
            grip: closed.then(|| grips - 1),
        });
    }
    super::trajectory::check_continuity(arm, points.iter().map(|p| (p.t, &p.q)))?;
    Ok(points)
}
