//! A serial chain given joint by joint, as URDF describes one (each joint's frame placed in its
//! parent link's frame, any axis), converted to the standard-DH model of the yaw + three-pitch
//! family.
//!
//! At the zero configuration the joint frames are `W_k = W_{k−1} · origin_k` (base frame
//! `W_0 = I`), joint `k` turns about the line through `p_k = W_k·0` along `u_k = R(W_k)·axis_k`,
//! and the tool point is `W_4 · tool`. DH frame 0 keeps the base frame's axes and stands on the
//! base axis at the base frame's height, `b = (p_1x, p_1y, 0)` ([`ArmModel::with_base`]); every
//! point below is relative to it. The DH frames follow from those lines:
//! - `z_{k−1} = u_k` (so the DH joint angle is the chain's, sign included);
//! - frame 1: `x1 = ±(ẑ × u2)` (the common normal of the vertical base axis and the shoulder
//!   axis, pointing from the base axis to the shoulder axis, or where they meet, to the side
//!   the tool reaches at q = 0), `a1 = p2·x1`, `d1 = p2·ẑ`, `α1 = ±90°`, `o1 = atan2(x1·ŷ, x1·x̂)`;
//! - frames 2, 3 (parallel axes): `x_k` along the perpendicular from frame `k−1`'s origin to
//!   axis `k+1` (so `d_k = 0`), `a_k` its length, `α_k = 0` or `π`, `o_k` the angle from `x_{k−1}`
//!   to `x_k` about `z_{k−1}`;
//! - frame 4 (the tool): `z4 = z3`, `d4` the tool point's distance along `z3` from frame 3's
//!   origin, `a4` its distance from axis 4 and `x4` that direction (so the tool's pitch is the
//!   angle of the line from the last pitch axis to the tool point).
//!
//! Each link's mass properties move from its chain frame `W_k` to DH frame `k` (`F_k`), both
//! fixed to link `k`: `X = F_k⁻¹ W_k`, `c' = X·c`, `I' = R_X I R_Xᵀ`.

use super::kinematics::{Pose, dh_transform};
use super::link::{DhParameters, Friction, Inertial, JointLimits, Link};
use super::model::{ArmModel, ModelError};
use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};
use std::f64::consts::{FRAC_PI_2, PI};

/// How far (rad) an axis may be from the family's directions and still count as them: CAD
/// exports round angles (π/2 written as 1.5708 is 3.7·10⁻⁶ off). Axes within it are made exact.
pub const AXIS_TOLERANCE: f64 = 1e-5;

/// How close (m) two lines or points must be to count as meeting.
const LENGTH_TOLERANCE: f64 = 1e-9;

/// One revolute joint and the link it moves.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainJoint {
    /// The joint's name (for messages).
    pub name: String,
    /// The joint frame in its parent link's frame at zero joint angle.
    pub origin: Pose,
    /// The rotation axis in the joint frame (any length > 0; the positive sense of the angle).
    pub axis: Vector3<f64>,
    pub limits: JointLimits,
    pub friction: Friction,
    /// The moved link's mass properties (with everything fixed to it) in the joint frame.
    pub body: Inertial,
}

/// A base, four revolute joints and a tool frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SerialChain {
    pub joints: [ChainJoint; 4],
    /// The tool frame in the last joint's frame (only its origin, the tool point, is used).
    pub tool: Pose,
    /// Gravitational acceleration in the base frame, m/s².
    pub gravity: Vector3<f64>,
}

/// Why a chain is not of the supported shape, naming the joint.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChainError {
    #[error("joint '{joint}': {reason}")]
    Shape { joint: String, reason: String },
    #[error("joint '{joint}': {source}")]
    Model { joint: String, source: ModelError },
}

fn shape(joint: &ChainJoint, reason: String) -> ChainError {
    ChainError::Shape { joint: joint.name.clone(), reason }
}

fn show(v: &Vector3<f64>) -> String {
    let [x, y, z] = [v.x, v.y, v.z].map(|c| (c * 1e6).round() / 1e6 + 0.0);
    format!("({x}, {y}, {z})")
}

/// The angle from `from` to `to` about `axis` (all unit, `from`, `to` ⊥ `axis`), rad.
fn angle_about(from: &Vector3<f64>, to: &Vector3<f64>, axis: &Vector3<f64>) -> f64 {
    from.cross(to).dot(axis).atan2(from.dot(to))
}

/// The standard-DH model of `chain`, or what keeps it out of the family.
pub fn model_from_chain(chain: &SerialChain) -> Result<ArmModel<4>, ChainError> {
    let joints = &chain.joints;
    // Joint frames, axes and points at q = 0, in the base frame.
    let mut frames = [Pose::identity(); 4];
    let mut axes = [Vector3::zeros(); 4];
    for (k, joint) in joints.iter().enumerate() {
        frames[k] = if k == 0 { joint.origin } else { frames[k - 1] * joint.origin };
        let norm = joint.axis.norm();
        if !(norm.is_finite() && norm > 0.0) {
            return Err(shape(joint, format!("axis {} has no direction", show(&joint.axis))));
        }
        axes[k] = frames[k].rotation * (joint.axis / norm);
    }
    let points = frames.map(|frame| frame.translation.vector);
    let tool = (frames[3] * chain.tool).translation.vector;
    let up = Vector3::z();

    // Joint 1: the base yaw, about the vertical through the base origin.
    let first = &joints[0];
    if axes[0].dot(&up) < 0.0 && axes[0].cross(&up).norm() < AXIS_TOLERANCE {
        return Err(shape(
            first,
            "turns about −z: chessarm's base yaw turns about +z (give axis 0 0 1 and swap and negate its limits)"
                .into(),
        ));
    }
    if axes[0].cross(&up).norm() > AXIS_TOLERANCE {
        return Err(shape(
            first,
            format!(
                "turns about {} in the base frame; the first joint must be a base yaw about the vertical z \
                 (the direction of gravity)",
                show(&axes[0])
            ),
        ));
    }
    // The base axis need not pass through the base frame's origin (a URDF's root link may sit
    // behind it): DH frame 0 is put on it, at the base frame's height, with the base frame's
    // axes ([`ArmModel::with_base`]); every point below is taken from there.
    let base = Vector3::new(points[0].x, points[0].y, 0.0);
    let points = points.map(|p| p - base);
    let tool = tool - base;
    // Joints 2–4: horizontal and parallel.
    if axes[1].dot(&up).abs() > AXIS_TOLERANCE {
        return Err(shape(
            &joints[1],
            format!(
                "turns about {} in the base frame at q = 0; the second joint must be a pitch joint with a \
                 horizontal axis",
                show(&axes[1])
            ),
        ));
    }
    let z1 = Vector3::new(axes[1].x, axes[1].y, 0.0).normalize();
    let mut z = [up, z1, z1, z1];
    for k in 2..4 {
        if axes[k].cross(&z1).norm() > AXIS_TOLERANCE {
            return Err(shape(
                &joints[k],
                format!(
                    "turns about {} in the base frame at q = 0, not parallel to joint '{}' ({}): a wrist roll \
                     or tilted joint, which the closed-form IK of a yaw + pitch arm cannot use",
                    show(&axes[k]),
                    joints[1].name,
                    show(&z1)
                ),
            ));
        }
        z[k] = if axes[k].dot(&z1) > 0.0 { z1 } else { -z1 };
    }

    // Frame 1.
    let normal = up.cross(&z1);
    let side = normal.dot(&points[1]);
    let sense = if side.abs() > LENGTH_TOLERANCE {
        side.signum()
    } else if normal.dot(&tool).abs() > LENGTH_TOLERANCE {
        normal.dot(&tool).signum()
    } else {
        1.0
    };
    let mut x = [Vector3::x(); 5];
    let mut origins = [Vector3::zeros(); 5];
    let mut dh = [DhParameters { a: 0.0, alpha: 0.0, d: 0.0, theta_offset: 0.0 }; 4];
    x[1] = normal * sense;
    dh[0] = DhParameters {
        a: points[1].dot(&x[1]).max(0.0),
        alpha: sense * FRAC_PI_2,
        d: points[1].z,
        theta_offset: x[1].y.atan2(x[1].x),
    };
    origins[1] = x[1] * dh[0].a + up * dh[0].d;
    // Frames 2 and 3: the perpendicular from the previous origin to the next axis; frame 4:
    // to the tool point.
    for k in 2..5 {
        let axis = z[k - 1];
        let target = if k < 4 { points[k] } else { tool };
        let offset = target - origins[k - 1];
        let along = offset.dot(&axis);
        let across = offset - axis * along;
        let length = across.norm();
        let name = |j: usize| joints[j.min(3)].name.as_str();
        if length < LENGTH_TOLERANCE && k < 4 {
            return Err(shape(
                &joints[k],
                format!(
                    "its axis is the same line as joint '{}''s: the pitch joints need a link length between them",
                    name(k - 1)
                ),
            ));
        }
        if length < LENGTH_TOLERANCE {
            return Err(shape(
                &joints[3],
                "the tool point lies on this joint's axis: the tool's direction (its pitch) is undefined; put the \
                 tool frame's origin at the tool tip"
                    .into(),
            ));
        }
        x[k] = across / length;
        let z_next = if k < 4 { z[k] } else { axis };
        dh[k - 1] = DhParameters {
            a: length,
            alpha: if z_next.dot(&axis) > 0.0 { 0.0 } else { PI },
            d: if k < 4 { 0.0 } else { along },
            theta_offset: angle_about(&x[k - 1], &x[k], &axis),
        };
        origins[k] = origins[k - 1] + axis * dh[k - 1].d + x[k] * length;
    }

    let in_dh = chain_in_dh(&frames, &dh, &base);
    let mut links = [Link {
        dh: dh[0],
        inertial: Inertial::zero(),
        motor_mass: 0.0,
        rotor_inertia: 0.0,
        limits: joints[0].limits,
        friction: joints[0].friction,
    }; 4];
    for (k, (link, joint)) in links.iter_mut().zip(joints).enumerate() {
        link.dh = dh[k];
        link.limits = joint.limits;
        link.friction = joint.friction;
        link.inertial = joint.body.transformed(&in_dh[k]);
    }
    ArmModel::new(links, chain.gravity).and_then(|model| model.with_base(base)).map_err(|source| {
        let joint = match &source {
            ModelError::InvalidField { field, .. } => {
                let number = field.split_whitespace().nth(1).and_then(|n| n.trim_matches(['(', ')']).parse().ok());
                number.and_then(|n: usize| joints.get(n.wrapping_sub(1))).map_or("", |j| j.name.as_str())
            }
        };
        ChainError::Model { joint: joint.to_string(), source }
    })
}

/// Per link `k`, its chain frame `W_k` in its DH frame `F_k` (both at q = 0, fixed to link
/// `k`): `X_k = F_k⁻¹ · T(−b) · W_k`, `F_k = A_1(0) ⋯ A_k(0)` from the DH parameters `dh`
/// themselves (so they are the model's), `b` the base. A body given in the chain's frame is
/// `X_k ·` it in the model's.
fn chain_in_dh(frames: &[Pose; 4], dh: &[DhParameters; 4], base: &Vector3<f64>) -> [Pose; 4] {
    let mut dh_frames = [Pose::identity(); 4];
    for k in 0..4 {
        let previous = if k == 0 { Pose::identity() } else { dh_frames[k - 1] };
        dh_frames[k] = previous * dh_transform(&dh[k], 0.0);
    }
    std::array::from_fn(|k| dh_frames[k].inverse() * Translation3::from(-base) * frames[k])
}

/// Per link `k` of `model` (made from `chain` by [`model_from_chain`]), the pose of the
/// chain's joint frame `W_k` in the model's DH frame `k`: what turns a link's collision shape,
/// given in its joint frame, into the model's frame ([`chain_in_dh`]).
pub fn chain_frames_in_dh(chain: &SerialChain, model: &ArmModel<4>) -> [Pose; 4] {
    let mut frames = [Pose::identity(); 4];
    for (k, joint) in chain.joints.iter().enumerate() {
        frames[k] = if k == 0 { joint.origin } else { frames[k - 1] * joint.origin };
    }
    chain_in_dh(&frames, &std::array::from_fn(|k| model.link(k).dh), &model.base())
}

/// An isometry from URDF's `xyz` and `rpy` (fixed-axis roll about x, then pitch about y, then
/// yaw about z: `R = Rz(yaw) Ry(pitch) Rx(roll)`).
pub fn isometry_from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Pose {
    let rotation = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    Pose::from_parts(Translation3::new(xyz[0], xyz[1], xyz[2]), rotation)
}

impl Inertial {
    /// The same body with its tensor made exactly symmetric (`(I + Iᵀ)/2`), after a rotation.
    fn symmetrised(self) -> Self {
        Self { inertia: (self.inertia + self.inertia.transpose()) * 0.5, ..self }
    }

    /// The body expressed in another frame: `pose` maps this body's frame into it.
    pub fn transformed(&self, pose: &Pose) -> Self {
        let rotation: Matrix3<f64> = *pose.rotation.matrix();
        Self {
            mass: self.mass,
            com: (pose * nalgebra::Point3::from(self.com)).coords,
            inertia: rotation * self.inertia * rotation.transpose(),
        }
        .symmetrised()
    }
}
