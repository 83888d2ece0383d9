//! Joint trajectories from Cartesian paths, with analytic derivatives:
//! `q = IK(x)`, `q̇ = J⁻¹ ẋ`, `q̈ = J⁻¹ (ẍ − J̇ q̇)`, where `x = (x, y, z, pitch)`, the pitch
//! and its rate and acceleration the path's own. No finite differences (ERRATA 4, 5).

use super::path::{CartesianPath, CartesianSample, sample_times};
use super::profile::ProfileError;
use crate::arm::model::{ArmModel, JointVector};
use crate::arm::task::{IkError, inverse_kinematics, task_jacobian, task_jacobian_derivative};
use nalgebra::{Vector3, Vector4};

/// Desired joint state at time `t` (s): angles (rad), rates (rad/s), accelerations (rad/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSample {
    pub t: f64,
    /// The tool-tip position this sample puts the arm at, m.
    pub position: Vector3<f64>,
    pub q: JointVector<4>,
    pub qd: JointVector<4>,
    pub qdd: JointVector<4>,
}

/// Why a Cartesian path has no joint trajectory.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    #[error(transparent)]
    Profile(#[from] ProfileError),
    #[error("at t = {time:.3} s: {source}")]
    Ik { time: f64, source: IkError },
    #[error(
        "at t = {time:.3} s the arm is singular at ({:.4}, {:.4}, {:.4}) m (|det J| = {determinant:.3e}): joint rates are unbounded",
        .position[0], .position[1], .position[2]
    )]
    Singular { time: f64, position: [f64; 3], determinant: f64 },
    #[error("at t = {time:.3} s joint {joint} would turn at {rate:.3} rad/s, above its limit {limit:.3} rad/s")]
    VelocityLimit { time: f64, joint: usize, rate: f64, limit: f64 },
    #[error(
        "at t = {time:.3} s joint {joint} would jump from {from:.4} to {to:.4} rad between two samples: the path \
         crosses the joint's limit or its turn (±π), or the arm's posture flips; no motion of the arm follows it"
    )]
    Jump { time: f64, joint: usize, from: f64, to: f64 },
}

/// Checks that consecutive joint samples `(t, q)` move no joint further than a motion can: by
/// more than `max(1 rad, 2·v_max·Δt)`. IK gives each instant's angles on their own; a path across
/// a joint's ±π turn or onto the other base branch would otherwise be followed as a jump.
pub fn check_continuity<'a>(
    model: &ArmModel<4>,
    samples: impl IntoIterator<Item = (f64, &'a JointVector<4>)>,
) -> Result<(), PlanError> {
    let mut previous: Option<(f64, &JointVector<4>)> = None;
    for (t, q) in samples {
        if let Some((t0, q0)) = previous {
            for (j, link) in model.links().iter().enumerate() {
                let allowed = (2.0 * link.limits.velocity * (t - t0)).max(1.0);
                if (q[j] - q0[j]).abs() > allowed {
                    return Err(PlanError::Jump { time: t, joint: j + 1, from: q0[j], to: q[j] });
                }
            }
        }
        previous = Some((t, q));
    }
    Ok(())
}

/// Smallest |det J| (m³/rad) accepted before a configuration counts as singular. The report's
/// arm has |det J| ≈ 0.01–0.05 over the board; 1e-6 is four orders below.
pub const SINGULAR_DETERMINANT: f64 = 1e-6;

/// A tool motion that can be sampled in time: a [`CartesianPath`] of LSPB moves or a
/// time-optimal [`super::geometric::TimedMotion`].
pub trait ToolMotion {
    /// Duration, s.
    fn duration(&self) -> f64;
    /// The tool tip at time `t`, s.
    fn sample(&self, t: f64) -> CartesianSample;
}

impl ToolMotion for CartesianPath {
    fn duration(&self) -> f64 {
        CartesianPath::duration(self)
    }
    fn sample(&self, t: f64) -> CartesianSample {
        CartesianPath::sample(self, t)
    }
}

impl ToolMotion for super::geometric::TimedMotion {
    fn duration(&self) -> f64 {
        super::geometric::TimedMotion::duration(self)
    }
    fn sample(&self, t: f64) -> CartesianSample {
        super::geometric::TimedMotion::sample(self, t)
    }
}

/// The joint state that puts the tool tip on `sample` at its pitch, and checks the joint
/// speed limits.
pub fn joint_state_at(model: &ArmModel<4>, sample: &CartesianSample) -> Result<JointSample, PlanError> {
    let state = joint_motion_at(model, sample)?;
    for (i, link) in model.links().iter().enumerate() {
        if state.qd[i].abs() > link.limits.velocity {
            return Err(PlanError::VelocityLimit {
                time: sample.t,
                joint: i + 1,
                rate: state.qd[i],
                limit: link.limits.velocity,
            });
        }
    }
    Ok(state)
}

/// The joint state that puts the tool tip on `sample` at its pitch; with a path's `p'`, `p''`
/// (and `φ'`, `φ''`) as the sample's rates and accelerations it gives `q'`, `q''`.
pub fn joint_motion_at(model: &ArmModel<4>, sample: &CartesianSample) -> Result<JointSample, PlanError> {
    let q = inverse_kinematics(model, &sample.position, sample.pitch)
        .map_err(|source| PlanError::Ik { time: sample.t, source })?;
    let jacobian = task_jacobian(model, &q);
    let determinant = jacobian.determinant();
    let lu = jacobian.lu();
    let singular = || PlanError::Singular {
        time: sample.t,
        position: [sample.position.x, sample.position.y, sample.position.z],
        determinant,
    };
    if determinant.abs() < SINGULAR_DETERMINANT {
        return Err(singular());
    }
    let task = |v: &Vector3<f64>, pitch: f64| Vector4::new(v.x, v.y, v.z, pitch);
    let qd = lu.solve(&task(&sample.velocity, sample.pitch_rate)).ok_or_else(singular)?;
    let drift = task_jacobian_derivative(model, &q, &qd) * qd;
    let qdd = lu.solve(&(task(&sample.acceleration, sample.pitch_acceleration) - drift)).ok_or_else(singular)?;
    Ok(JointSample { t: sample.t, position: sample.position, q, qd, qdd })
}

/// A joint trajectory sampled every `dt` seconds from `t = 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectory {
    dt: f64,
    samples: Vec<JointSample>,
}

impl JointTrajectory {
    /// Samples `path` every `dt` s and converts each sample to joint space; a jump between
    /// samples ([`check_continuity`]) is an error.
    pub fn from_path(model: &ArmModel<4>, path: &impl ToolMotion, dt: f64) -> Result<Self, PlanError> {
        let samples = sample_times(path.duration(), dt)?
            .map(|t| joint_state_at(model, &path.sample(t)))
            .collect::<Result<Vec<_>, _>>()?;
        check_continuity(model, samples.iter().map(|s| (s.t, &s.q)))?;
        Ok(Self { dt, samples })
    }

    /// Sample period, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    pub fn samples(&self) -> &[JointSample] {
        &self.samples
    }

    /// Duration, s.
    pub fn duration(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.t)
    }

    /// The sample at or just before `t` (zero-order hold), clamped to the ends.
    pub fn held_at(&self, t: f64) -> &JointSample {
        // The index ⌊t/dt + 10⁻⁹⌋ by the cast's truncation, which is the floor once negatives
        // (and NaN) are 0 (`floor` is a library call on x86-64's baseline).
        let index = ((t / self.dt + 1e-9).max(0.0) as usize).min(self.samples.len() - 1);
        &self.samples[index]
    }

    pub fn first(&self) -> &JointSample {
        &self.samples[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arm::preset::report_arm;

    /// `held_at` finds its sample by the cast's truncation; the oracle is the floor it
    /// replaced, at every sample time, between them, and at times no run passes (negative,
    /// NaN, infinite, huge).
    #[test]
    fn held_at_takes_the_sample_the_floor_gives() {
        let mut path = CartesianPath::new(Vector3::new(0.25, -0.1, 0.12));
        path.move_to(Vector3::new(0.32, 0.12, 0.05), 0.6).unwrap();
        let trajectory = JointTrajectory::from_path(&report_arm(), &path, 1e-3).unwrap();
        let (dt, last) = (trajectory.dt(), trajectory.samples().len() - 1);
        let floor = |t: f64| ((t / dt + 1e-9).floor().max(0.0) as usize).min(last);
        let index = |t: f64| {
            let sample: *const JointSample = trajectory.held_at(t);
            trajectory.samples().iter().position(|s| std::ptr::eq(s, sample)).unwrap()
        };
        let mut times: Vec<f64> = (0..=2 * last + 4).map(|k| k as f64 * dt / 2.0).collect();
        times.extend((0..=last).map(|k| k as f64 * dt));
        times.extend([-1.0, -0.0, -1e-12, f64::NAN, f64::NEG_INFINITY, f64::INFINITY, 1e300, -1e300, 1e19 * dt]);
        for t in times {
            assert_eq!(index(t), floor(t), "t = {t}");
        }
        // Each sample's own time holds it (the 10⁻⁹ covers t = k·dt rounding below k).
        for k in 0..=last {
            assert_eq!(index(k as f64 * dt), k);
        }
    }
}
