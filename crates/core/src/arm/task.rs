//! Task space of the 4-DOF chess arm: tool-tip position (x, y, z) in m and tool pitch in rad,
//! its Jacobian, and the closed-form inverse kinematics (report section "Inverse Kinematics",
//! with ERRATA items 1–3 fixed).
//!
//! The arm must be of the yaw + three-pitch family: joint 1 turns about the vertical base axis
//! (`a1 = 0`, `α1 = +90°`, `d1 = l1`), joints 2–4 are parallel horizontal axes (`α = 0`,
//! `d = 0`) with link lengths `l2, l3, l4`, and no angle offsets. The tool pitch is the angle of
//! the tool's x axis above the horizontal: `pitch = q2 + q3 + q4`; the tool points straight down
//! at `pitch = −π/2` ([`TOOL_DOWN`]).

use super::kinematics::{ChainVelocities, FrameChain};
use super::model::{ArmModel, JointVector};
use nalgebra::{Matrix4, RowVector4, Vector3, Vector4};
use std::f64::consts::FRAC_PI_2;

/// Tool pitch with the gripper pointing straight down, rad.
pub const TOOL_DOWN: f64 = -FRAC_PI_2;

/// Task-space coordinates `(x, y, z, pitch)`: m, m, m, rad.
pub type TaskVector = Vector4<f64>;

/// Link lengths of a yaw + three-pitch arm, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarGeometry {
    /// Shoulder height above the base.
    pub l1: f64,
    /// Upper arm.
    pub l2: f64,
    /// Forearm.
    pub l3: f64,
    /// Wrist to tool tip.
    pub l4: f64,
}

/// Why inverse kinematics has no solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IkError {
    #[error("target {} is not a finite point", show(.target))]
    NotFinite { target: [f64; 3] },
    #[error("target {} lies on the base axis (x = y = 0), where the base angle is undefined", show(.target))]
    OnBaseAxis { target: [f64; 3] },
    #[error("target {} is out of reach: {}", show(.target), reach_problem(*.needed, *.min, *.max))]
    OutOfReach { target: [f64; 3], needed: f64, min: f64, max: f64 },
    #[error(
        "target {} needs joint {joint} at {value:.4} rad ({:.1}°), outside its limits [{lower:.4}, {upper:.4}] rad",
        show(.target), .value.to_degrees()
    )]
    JointLimit { target: [f64; 3], joint: usize, value: f64, lower: f64, upper: f64 },
    #[error("closed-form IK needs a yaw + three-pitch arm: {0}")]
    UnsupportedModel(String),
}

/// What is wrong with a wrist `needed` m from the shoulder when the arm reaches `min`…`max` m:
/// too far or too close, and by how much (in scientific form when tiny, so a miss of a few
/// nanometres does not read as "0.6096 m beyond 0.6096 m").
fn reach_problem(needed: f64, min: f64, max: f64) -> String {
    let by = |gap: f64| if gap >= 1e-4 { format!("{} m", metres(gap)) } else { format!("{gap:.2e} m") };
    if needed > max {
        format!(
            "the wrist would be {} m from the shoulder, {} beyond the arm's full stretch of {max:.4} m",
            metres(needed),
            by(needed - max)
        )
    } else {
        format!(
            "the wrist would be {} m from the shoulder, {} closer than the folded arm's least reach of {min:.4} m",
            metres(needed),
            by(min - needed)
        )
    }
}

fn show(target: &[f64; 3]) -> String {
    let [x, y, z] = target.map(metres);
    format!("({x}, {y}, {z}) m")
}

/// A length for a message: to 0.1 mm when moderate, in short scientific form when huge.
fn metres(value: f64) -> String {
    if value.abs() < 1e6 { format!("{value:.4}") } else { crate::short_number(value) }
}

impl PlanarGeometry {
    /// Extracts `l1..l4` from a model, or says which DH parameter breaks the arm family.
    pub fn of(model: &ArmModel<4>) -> Result<Self, IkError> {
        let links = model.links();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        if !close(links[0].dh.a, 0.0) || !close(links[0].dh.alpha, FRAC_PI_2) {
            return Err(IkError::UnsupportedModel(format!(
                "link 1 needs a = 0 and alpha = +90°, has a = {} m, alpha = {} rad",
                links[0].dh.a, links[0].dh.alpha
            )));
        }
        for (i, link) in links.iter().enumerate() {
            if !close(link.dh.theta_offset, 0.0) {
                return Err(IkError::UnsupportedModel(format!(
                    "link {} has theta_offset = {} rad, needs 0",
                    i + 1,
                    link.dh.theta_offset
                )));
            }
            if i > 0 && (!close(link.dh.alpha, 0.0) || !close(link.dh.d, 0.0)) {
                return Err(IkError::UnsupportedModel(format!(
                    "link {} needs alpha = 0 and d = 0, has alpha = {} rad, d = {} m",
                    i + 1,
                    link.dh.alpha,
                    link.dh.d
                )));
            }
        }
        Ok(Self { l1: links[0].dh.d, l2: links[1].dh.a, l3: links[2].dh.a, l4: links[3].dh.a })
    }

    /// Shortest and longest shoulder-to-wrist distance, m.
    pub fn wrist_reach(&self) -> (f64, f64) {
        ((self.l2 - self.l3).abs(), self.l2 + self.l3)
    }
}

/// Tool-tip position (m) and pitch (rad) for joint angles `q`.
pub fn tool_point(model: &ArmModel<4>, q: &JointVector<4>) -> TaskVector {
    let tip = FrameChain::new(model, q).tip();
    TaskVector::new(tip.x, tip.y, tip.z, tool_pitch(q))
}

/// Tool pitch above the horizontal, rad: `q2 + q3 + q4`.
pub fn tool_pitch(q: &JointVector<4>) -> f64 {
    q[1] + q[2] + q[3]
}

/// Task Jacobian `J(q)` with `[ẋ ẏ ż pitch˙]ᵀ = J q̇`: the tip's linear geometric Jacobian
/// over the pitch row `[0 1 1 1]`.
pub fn task_jacobian(model: &ArmModel<4>, q: &JointVector<4>) -> Matrix4<f64> {
    let chain = FrameChain::new(model, q);
    let (linear, _) = chain.point_jacobian(&chain.tip(), 3);
    stack_task_rows(&linear, RowVector4::new(0.0, 1.0, 1.0, 1.0))
}

/// `J̇(q, q̇)`, the time derivative of [`task_jacobian`] along `q̇`, analytic (no finite
/// differences). The pitch row is constant, so its derivative is zero.
pub fn task_jacobian_derivative(model: &ArmModel<4>, q: &JointVector<4>, qd: &JointVector<4>) -> Matrix4<f64> {
    let chain = FrameChain::new(model, q);
    let velocities = ChainVelocities::new(&chain, qd);
    let (linear, _) = velocities.point_jacobian_derivative(&chain, &chain.tip(), 3);
    stack_task_rows(&linear, RowVector4::zeros())
}

fn stack_task_rows(linear: &nalgebra::SMatrix<f64, 3, 4>, pitch_row: RowVector4<f64>) -> Matrix4<f64> {
    let mut jacobian = Matrix4::zeros();
    jacobian.fixed_view_mut::<3, 4>(0, 0).copy_from(linear);
    jacobian.set_row(3, &pitch_row);
    jacobian
}

/// Relative slack on the reach limits for rounding (64 ulps of 1).
const REACH_ROUNDING: f64 = 64.0 * f64::EPSILON;

/// Closed-form inverse kinematics, elbow up, for the tool tip at `target` (m, base frame) with
/// the given tool `pitch` (rad; [`TOOL_DOWN`] to grip pieces).
///
/// With `θ = atan2(y, x)`, `p = √(x² + y²)`, the wrist sits at `p_w = p − l4 cos(pitch)`,
/// `z_w = z − l4 sin(pitch)`. With `d = √(p_w² + (z_w − l1)²)` and `w = atan2(z_w − l1, p_w)`:
/// `θ1 = θ`, `θ2 = w + acos((l2² + d² − l3²)/(2 l2 d))` (ERRATA 1, 2),
/// forearm angle `φ = atan2(z_w − l1 − l2 sin θ2, p_w − l2 cos θ2)` (ERRATA 3),
/// `θ3 = φ − θ2`, `θ4 = pitch − φ`. Checked against the joint limits.
pub fn inverse_kinematics(model: &ArmModel<4>, target: &Vector3<f64>, pitch: f64) -> Result<JointVector<4>, IkError> {
    let geometry = PlanarGeometry::of(model)?;
    let shown = [target.x, target.y, target.z];
    if !(target.iter().all(|v| v.is_finite()) && pitch.is_finite()) {
        return Err(IkError::NotFinite { target: shown });
    }
    let radial = target.x.hypot(target.y);
    if radial < 1e-9 {
        return Err(IkError::OnBaseAxis { target: shown });
    }
    let PlanarGeometry { l1, l2, l3, l4 } = geometry;
    let (sin_pitch, cos_pitch) = pitch.sin_cos();
    let wrist_radial = radial - l4 * cos_pitch;
    let wrist_height = target.z - l4 * sin_pitch - l1;
    let distance = wrist_radial.hypot(wrist_height);
    let (min, max) = geometry.wrist_reach();
    // Within [min, max] the law of cosines gives |cos| ≤ 1 exactly; rounding can put the
    // distance and the cosine a few ulps outside at the boundary (the arm fully stretched or
    // folded), which is still reachable: a slack of REACH_ROUNDING·max (≈ 9e-15 m here) covers
    // the rounding of the wrist distance from a target and is far below any physical tolerance.
    let slack = REACH_ROUNDING * max;
    let cos_elbow = ((l2 * l2 + distance * distance - l3 * l3) / (2.0 * l2 * distance)).clamp(-1.0, 1.0);
    if !(distance >= min - slack && distance <= max + slack && cos_elbow.is_finite()) {
        return Err(IkError::OutOfReach { target: shown, needed: distance, min, max });
    }
    let base = target.y.atan2(target.x);
    let shoulder = wrist_height.atan2(wrist_radial) + cos_elbow.acos();
    let forearm = (wrist_height - l2 * shoulder.sin()).atan2(wrist_radial - l2 * shoulder.cos());
    let q = JointVector::<4>::new(base, shoulder, wrap_angle(forearm - shoulder), wrap_angle(pitch - forearm));
    match model.first_limit_violation(&q) {
        Some((joint, value, lower, upper)) => {
            Err(IkError::JointLimit { target: shown, joint: joint + 1, value, lower, upper })
        }
        None => Ok(q),
    }
}

/// The same angle in `(−π, π]`, rad.
pub fn wrap_angle(angle: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let wrapped = (angle + PI).rem_euclid(TAU) - PI;
    if wrapped <= -PI { wrapped + TAU } else { wrapped }
}
