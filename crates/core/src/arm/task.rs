//! Task space of the 4-DOF chess arm: tool-tip position (x, y, z) in m and tool pitch in rad,
//! its Jacobian, and the closed-form inverse kinematics (report section "Inverse Kinematics",
//! with ERRATA items 1–3 fixed, extended to offsets).
//!
//! The arm must be of the yaw + three-pitch family: joint 1 turns about the vertical base axis
//! (`α1 = ±90°`, any `a1 ≥ 0`, `d1`, offset), joints 2–4 turn about parallel horizontal axes
//! (`α2, α3 ∈ {0, π}`; any `a`, `d`, angle offsets; `α4` is free, it only turns the tool frame
//! about its x axis). The tool pitch is the angle of the tool's x axis (from the last pitch
//! axis to the tip) above the horizontal: `pitch = e·Σ_{k=2..4} σ_k (q_k + o_k)` with
//! `e = sin α1` and `σ_k = ±1` the direction of joint k's axis along frame 1's z; for the
//! report's arm (`e = σ = 1`, no offsets) `pitch = q2 + q3 + q4`, and the tool points straight
//! down at `pitch = −π/2` ([`TOOL_DOWN`]).

use super::kinematics::{ChainVelocities, FrameChain};
use super::model::{ArmModel, JointVector};
use nalgebra::{Matrix4, RowVector4, Vector3, Vector4};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Tool pitch with the gripper pointing straight down, rad.
pub const TOOL_DOWN: f64 = -FRAC_PI_2;

/// Task-space coordinates `(x, y, z, pitch)`: m, m, m, rad.
pub type TaskVector = Vector4<f64>;

/// How close (rad) a twist must be to the family's `±90°` or `0, π` to count as it.
const TWIST_TOLERANCE: f64 = 1e-12;

/// The geometry of a yaw + three-pitch arm, from its DH parameters.
///
/// In frame 1 (after the yaw) the pitch joints form a planar chain in the plane through frame
/// 1's origin normal to its z axis, shifted `lateral` m along that z; the tip lies at
/// `(a1 + X) u(θ) + e·lateral·v(θ) + (d1 + e·Y) ẑ` with `θ = q1 + o1`, `u = (cos θ, sin θ, 0)`,
/// `v = (sin θ, −cos θ, 0)`, and `(X, Y) = Σ_k a_k (cos ψ_k, sin ψ_k)`,
/// `ψ_k = Σ_{j≤k} σ_j (q_j + o_j)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarGeometry {
    /// Height of frame 1's origin (the shoulder) above the base, m (`d1`).
    pub l1: f64,
    /// Upper arm, m (`a2`).
    pub l2: f64,
    /// Forearm, m (`a3`).
    pub l3: f64,
    /// Last pitch axis to tool tip, m (`a4`).
    pub l4: f64,
    /// Horizontal distance of the shoulder axis from the base axis, m (`a1`).
    pub shoulder_offset: f64,
    /// Offset of the pitch plane along frame 1's z, m (`Σ σ_k d_k`, k = 2..4).
    pub lateral: f64,
    /// `sin α1`: +1 when frame 1's y points up, −1 when down.
    pub up: f64,
    /// Joint angle offsets `o1..o4`, rad.
    pub offsets: [f64; 4],
    /// `σ2..σ4`: +1 where the joint's axis points along frame 1's z, −1 against it.
    pub signs: [f64; 3],
}

/// Why inverse kinematics has no solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IkError {
    #[error("target {} is not a finite point", show(.target))]
    NotFinite { target: [f64; 3] },
    #[error("target {} lies on the base axis, where the base angle is undefined", show(.target))]
    OnBaseAxis { target: [f64; 3] },
    #[error(
        "target {} lies {} m from the base axis, within the arm's sideways offset of {} m, which no base angle reaches",
        show(.target), metres(*.distance), metres(*.offset)
    )]
    InsideOffset { target: [f64; 3], distance: f64, offset: f64 },
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
    /// Reads the geometry from a model, or says which DH parameter breaks the arm family.
    pub fn of(model: &ArmModel<4>) -> Result<Self, IkError> {
        let links = model.links();
        let (sin1, cos1) = model.twist_trig(0);
        if cos1.abs() > TWIST_TOLERANCE {
            return Err(IkError::UnsupportedModel(format!(
                "link 1 needs alpha = ±90° (a vertical base axis, horizontal pitch axes), has alpha = {} rad",
                links[0].dh.alpha
            )));
        }
        let mut signs = [1.0; 3];
        for i in 1..3 {
            let (sin, cos) = model.twist_trig(i);
            if sin.abs() > TWIST_TOLERANCE {
                return Err(IkError::UnsupportedModel(format!(
                    "link {} needs alpha = 0 or 180° (joint {}'s axis parallel to joint {}'s), has alpha = {} rad",
                    i + 1,
                    i + 2,
                    i + 1,
                    links[i].dh.alpha
                )));
            }
            signs[i] = signs[i - 1] * cos.signum();
        }
        let lateral = (1..4).map(|k| signs[k - 1] * links[k].dh.d).sum();
        Ok(Self {
            l1: links[0].dh.d,
            l2: links[1].dh.a,
            l3: links[2].dh.a,
            l4: links[3].dh.a,
            shoulder_offset: links[0].dh.a,
            lateral,
            up: sin1.signum(),
            offsets: links.map(|link| link.dh.theta_offset),
            signs,
        })
    }

    /// Shortest and longest shoulder-to-wrist distance, m.
    pub fn wrist_reach(&self) -> (f64, f64) {
        ((self.l2 - self.l3).abs(), self.l2 + self.l3)
    }

    /// Tool pitch above the horizontal for joint angles `q`, rad: `e·Σ σ_k (q_k + o_k)`.
    pub fn pitch(&self, q: &JointVector<4>) -> f64 {
        let [_, o2, o3, o4] = self.offsets;
        let [s2, s3, s4] = self.signs;
        self.up * (s2 * (q[1] + o2) + s3 * (q[2] + o3) + s4 * (q[3] + o4))
    }

    /// `∂pitch/∂q`: `e·[0, σ2, σ3, σ4]`.
    fn pitch_row(&self) -> RowVector4<f64> {
        let [s2, s3, s4] = self.signs;
        RowVector4::new(0.0, s2, s3, s4) * self.up
    }
}

/// The angle (rad) about the tool frame's z axis (the last pitch axis) from the tool's x axis
/// (where it points) to the world's down, with the tool at `pitch`: 0 with the tool pointing
/// down. A piece gripped upright at this pitch and carried at it (the base turning under it,
/// the pitch joints holding the sum) stays upright, its axis at this angle in the tool frame.
/// Exactly 0 at [`TOOL_DOWN`]; else read from the tool frame of a configuration at `pitch`
/// (any: a yaw and the way the pitch is shared among the joints do not change it).
pub fn held_turn(model: &ArmModel<4>, pitch: f64) -> f64 {
    if pitch == TOOL_DOWN {
        return 0.0;
    }
    let mut q = JointVector::<4>::zeros();
    let now = tool_pitch(model, &q);
    // The pitch row is e·σ4 for the last joint: turning it alone sets the pitch.
    q[3] = (pitch - now) * pitch_row(model)[3];
    let frame = FrameChain::new(model, &q).body_pose(3).rotation;
    let down = -Vector3::z();
    let (x, y) = (frame * Vector3::x(), frame * Vector3::y());
    y.dot(&down).atan2(x.dot(&down))
}

/// Whether the tool frame's z axis is the last pitch axis (the last DH `alpha` 0 or π): the
/// axis [`held_turn`] turns a held piece about. Where it is not, a planner keeps the tool
/// straight down.
pub fn tool_z_is_pitch_axis(model: &ArmModel<4>) -> bool {
    let chain = FrameChain::new(model, &JointVector::<4>::zeros());
    let tool_z = chain.body_pose(3).rotation * Vector3::z();
    (tool_z.dot(&chain.joint_axis(3).0).abs() - 1.0).abs() < 1e-9
}

/// Tool-tip position (m) and pitch (rad) for joint angles `q`.
pub fn tool_point(model: &ArmModel<4>, q: &JointVector<4>) -> TaskVector {
    let tip = FrameChain::new(model, q).tip();
    TaskVector::new(tip.x, tip.y, tip.z, tool_pitch(model, q))
}

/// Tool pitch above the horizontal, rad ([`PlanarGeometry::pitch`]; `q2 + q3 + q4` for the
/// report's arm). For an arm outside the family, the plain sum `Σ_{k=2..4} (q_k + o_k)`.
pub fn tool_pitch(model: &ArmModel<4>, q: &JointVector<4>) -> f64 {
    match PlanarGeometry::of(model) {
        Ok(geometry) => geometry.pitch(q),
        Err(_) => (1..4).map(|k| q[k] + model.link(k).dh.theta_offset).sum(),
    }
}

/// `∂pitch/∂q` of [`tool_pitch`].
fn pitch_row(model: &ArmModel<4>) -> RowVector4<f64> {
    PlanarGeometry::of(model).map_or(RowVector4::new(0.0, 1.0, 1.0, 1.0), |geometry| geometry.pitch_row())
}

/// Task Jacobian `J(q)` with `[ẋ ẏ ż pitch˙]ᵀ = J q̇`: the tip's linear geometric Jacobian
/// over the pitch row `e·[0 σ2 σ3 σ4]` (`[0 1 1 1]` for the report's arm).
pub fn task_jacobian(model: &ArmModel<4>, q: &JointVector<4>) -> Matrix4<f64> {
    let chain = FrameChain::new(model, q);
    let (linear, _) = chain.point_jacobian(&chain.tip(), 3);
    stack_task_rows(&linear, pitch_row(model))
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
/// `(x, y, z)` is the target relative to the base axis' foot ([`ArmModel::base`]). With
/// `r = √(x² + y²)` and the sideways offset `s` ([`PlanarGeometry::lateral`]), the pitch
/// plane lies `R = √(r² − s²)` m out along `u(θ)` with `θ = atan2(y, x) + atan2(e·s, R)`, so
/// `q1 = θ − o1`. In that plane, with `X = R − a1`, `H = z − d1` (height above the shoulder):
/// the wrist sits at `X_w = X − l4 cos(pitch)`, `H_w = H − l4 sin(pitch)`. With
/// `d = √(X_w² + H_w²)` and `w = atan2(H_w, X_w)`: shoulder elevation
/// `β2 = w + acos((l2² + d² − l3²)/(2 l2 d))` (ERRATA 1, 2), forearm elevation
/// `β3 = atan2(H_w − l2 sin β2, X_w − l2 cos β2)` (ERRATA 3), `β4 = pitch`. The joint angles
/// follow from `ψ_k = e·β_k`: `q2 = σ2 ψ2 − o2`, `q3 = σ3 (ψ3 − ψ2) − o3`,
/// `q4 = σ4 (ψ4 − ψ3) − o4`; for the report's arm `θ2 = β2`, `θ3 = β3 − β2`, `θ4 = pitch − β3`.
/// A joint angle outside its limits is taken a turn (2π) away where that lies inside them. When
/// this solution is out of reach or limits, the other base branch is tried: `R = −√(r² − s²)`,
/// `θ = atan2(y, x) − atan2(−e·s, R)` (the base turned by about π) with
/// `β2 = w − acos(…)` (elbow up again, seen from the other side); the first solution's error
/// stands when both fail.
pub fn inverse_kinematics(model: &ArmModel<4>, target: &Vector3<f64>, pitch: f64) -> Result<JointVector<4>, IkError> {
    let geometry = PlanarGeometry::of(model)?;
    let shown = [target.x, target.y, target.z];
    if !(target.iter().all(|v| v.is_finite()) && pitch.is_finite()) {
        return Err(IkError::NotFinite { target: shown });
    }
    // From here on relative to DH frame 0, on the base axis.
    let target = &(target - model.base());
    let radial = target.x.hypot(target.y);
    if radial < 1e-9 {
        return Err(IkError::OnBaseAxis { target: shown });
    }
    let PlanarGeometry { l1, l2, l3, l4, shoulder_offset, lateral, up, offsets, signs } = geometry;
    // In the plane: how far out along u(θ) (the report's arm: `radial` itself).
    let plane_radial = if lateral == 0.0 {
        radial
    } else if radial > lateral.abs() + 1e-9 {
        (radial * radial - lateral * lateral).sqrt()
    } else {
        return Err(IkError::InsideOffset { target: shown, distance: radial, offset: lateral.abs() });
    };
    let (sin_pitch, cos_pitch) = pitch.sin_cos();
    let [o1, o2, o3, o4] = offsets;
    let [s2, s3, s4] = signs;
    // One branch of the base: the pitch plane's x1 towards the target (`reach > 0`, the
    // report's) or away from it (`reach < 0`: the base turned by about π, the arm reaching back
    // over its shoulder axis, elbow still up).
    let solve = |reach: f64| -> Result<JointVector<4>, IkError> {
        let wrist_radial = reach - shoulder_offset - l4 * cos_pitch;
        let wrist_height = target.z - l4 * sin_pitch - l1;
        let distance = wrist_radial.hypot(wrist_height);
        let (min, max) = geometry.wrist_reach();
        // Within [min, max] the law of cosines gives |cos| ≤ 1 exactly; rounding can put the
        // distance and the cosine a few ulps outside at the boundary (the arm fully stretched
        // or folded), which is still reachable: a slack of REACH_ROUNDING·max (≈ 9e-15 m here)
        // covers the rounding of the wrist distance from a target and is far below any
        // physical tolerance.
        let slack = REACH_ROUNDING * max;
        let cos_elbow = ((l2 * l2 + distance * distance - l3 * l3) / (2.0 * l2 * distance)).clamp(-1.0, 1.0);
        if !(distance >= min - slack && distance <= max + slack && cos_elbow.is_finite()) {
            return Err(IkError::OutOfReach { target: shown, needed: distance, min, max });
        }
        let mut base = target.y.atan2(target.x);
        let shoulder = if reach > 0.0 {
            if lateral != 0.0 {
                base += (up * lateral).atan2(reach);
            }
            wrist_height.atan2(wrist_radial) + cos_elbow.acos()
        } else {
            base -= (-(up * lateral)).atan2(reach);
            wrist_height.atan2(wrist_radial) - cos_elbow.acos()
        };
        let forearm = (wrist_height - l2 * shoulder.sin()).atan2(wrist_radial - l2 * shoulder.cos());
        // `up·β = ψ`; for the report's arm every factor is 1 and every offset 0, which leaves
        // the angles bit for bit as the report's formulas give them.
        let (shoulder, forearm, tool) = (up * shoulder, up * forearm, up * pitch);
        let mut q = JointVector::<4>::new(
            principal(base - o1),
            principal(s2 * shoulder - o2),
            wrap_angle(s3 * (forearm - shoulder) - o3),
            wrap_angle(s4 * (tool - forearm) - o4),
        );
        // A joint whose range reaches beyond ±π may need the same angle a turn away.
        for (j, link) in model.links().iter().enumerate() {
            let limits = &link.limits;
            if (q[j] < limits.lower || q[j] > limits.upper)
                && let Some(turned) =
                    [q[j] + TAU, q[j] - TAU].into_iter().find(|v| *v >= limits.lower && *v <= limits.upper)
            {
                q[j] = turned;
            }
        }
        match model.first_limit_violation(&q) {
            Some((joint, value, lower, upper)) => {
                Err(IkError::JointLimit { target: shown, joint: joint + 1, value, lower, upper })
            }
            None => Ok(q),
        }
    };
    match solve(plane_radial) {
        // The front branch's error stands when the back one fails too.
        Err(front @ (IkError::OutOfReach { .. } | IkError::JointLimit { .. })) => solve(-plane_radial).or(Err(front)),
        result => result,
    }
}

/// `angle` itself when already in `(−π, π]`, else [`wrap_angle`] of it.
fn principal(angle: f64) -> f64 {
    if angle > -PI && angle <= PI { angle } else { wrap_angle(angle) }
}

/// The same angle in `(−π, π]`, rad.
pub fn wrap_angle(angle: f64) -> f64 {
    let wrapped = (angle + PI).rem_euclid(TAU) - PI;
    if wrapped <= -PI { wrapped + TAU } else { wrapped }
}
