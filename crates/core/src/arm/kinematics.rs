//! Forward kinematics, geometric Jacobians and their time derivatives for a revolute DH chain.
//!
//! Frames: frame 0 is the base (origin at the arm's base on the board plane, z up); frame `i`
//! is the DH frame at the distal end of link `i`; the last frame is the tool frame, its origin
//! the tool tip. Joint `j` (0-based here) turns about the z axis of frame `j` through the
//! origin of frame `j`.

use super::link::DhParameters;

use super::model::{ArmModel, JointVector};
use crate::lanes::{sin_cos, small_angle_sin_cos};
use nalgebra::{IsometryMatrix3, Matrix3, Rotation3, SMatrix, Translation3, Vector3};

/// A rigid transform: rotation matrix and translation (m).
pub type Pose = IsometryMatrix3<f64>;

/// `A = Rz(θ) · Tz(d) · Tx(a) · Rx(α)`, the standard DH transform from frame `i−1` to `i`.
pub fn dh_transform(dh: &DhParameters, joint_angle: f64) -> Pose {
    let (sa, ca) = sin_cos(dh.alpha);
    let (st, ct) = sin_cos(joint_angle + dh.theta_offset);
    let rotation = Matrix3::new(ct, -st * ca, st * sa, st, ct * ca, -ct * sa, 0.0, sa, ca);
    Pose::from_parts(Translation3::new(dh.a * ct, dh.a * st, dh.d), Rotation3::from_matrix_unchecked(rotation))
}

/// `(sin, cos)` of every joint's DH angle `θ_i = q_i + theta_offset_i`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointTrig<const N: usize> {
    angle: [f64; N],
    sin_cos: [(f64, f64); N],
}

/// Largest angle step (rad) [`JointTrig::shifted`] takes by series; beyond it calls `sin_cos`.
const SERIES_STEP: f64 = 0.05;

/// `(sin(θ + δ), cos(θ + δ))` from `(sin θ, cos θ)` and `(sin δ, cos δ)` by angle addition:
/// `sin(θ+δ) = sin θ cos δ + cos θ sin δ`, `cos(θ+δ) = cos θ cos δ − sin θ sin δ`.
#[inline(always)]
fn add_angles((s, c): (f64, f64), (sin_d, cos_d): (f64, f64)) -> (f64, f64) {
    (s * cos_d + c * sin_d, c * cos_d - s * sin_d)
}

impl<const N: usize> JointTrig<N> {
    pub fn new(model: &ArmModel<N>, q: &JointVector<N>) -> Self {
        let angle = std::array::from_fn(|i| q[i] + model.link(i).dh.theta_offset);
        Self { angle, sin_cos: angle.map(sin_cos) }
    }

    /// The same for the angles moved by `delta` (rad), by angle addition with
    /// `small_angle_sin_cos` of each step: exact to rounding, at a fraction of the cost of
    /// `sin_cos`. Steps beyond 0.05 rad call `sin_cos`.
    ///
    /// An integrator's stages move the joints by `dt·q̇`, micro-radians to milliradians.
    pub fn shifted(&self, delta: &JointVector<N>) -> Self {
        let mut shifted = *self;
        for i in 0..N {
            let d = delta[i];
            shifted.angle[i] = self.angle[i] + d;
            shifted.sin_cos[i] = if d.abs() <= SERIES_STEP {
                add_angles(self.sin_cos[i], small_angle_sin_cos(d))
            } else {
                sin_cos(shifted.angle[i])
            };
        }
        shifted
    }

    /// `(sin θ_i, cos θ_i)`.
    pub fn get(&self, i: usize) -> (f64, f64) {
        self.sin_cos[i]
    }
}

/// Forward kinematics, frame by frame: composes `T_0i = A_1 ⋯ A_i` for the configuration whose
/// joint sines and cosines are `trig` and hands `visit(i, R, p)` the world rotation `R` and
/// origin `p` (m) of DH frame `i + 1` (the frame carried by body `i`), in order. The one place
/// the DH chain is composed; [`FrameChain`] stores the poses, the dynamics take only what
/// they need from them.
///
/// Composed column by column rather than by 3×3 products: with `R' = R · Rz(θ)`, two
/// columns mix by (cos θ, sin θ); the translation gains `a·x' + d·z'`; then `Rx(α)` mixes
/// the y and z columns (skipped when α = 0). Same result as multiplying [`dh_transform`]s.
#[inline(always)]
pub fn compose_frames<const N: usize>(
    model: &ArmModel<N>,
    trig: &JointTrig<N>,
    mut visit: impl FnMut(usize, &Matrix3<f64>, &Vector3<f64>),
) {
    let (mut x, mut y, mut z) = (Vector3::<f64>::x(), Vector3::<f64>::y(), Vector3::<f64>::z());
    let mut origin = Vector3::<f64>::zeros();
    for i in 0..N {
        let dh = &model.link(i).dh;
        let (st, ct) = trig.get(i);
        let turned_x = x * ct + y * st;
        let turned_y = y * ct - x * st;
        origin += turned_x * dh.a + z * dh.d;
        let (sa, ca) = model.twist_trig(i);
        x = turned_x;
        (y, z) = if dh.alpha == 0.0 { (turned_y, z) } else { (turned_y * ca + z * sa, z * ca - turned_y * sa) };
        visit(i, &Matrix3::from_columns(&[x, y, z]), &origin);
    }
}

/// Each joint's longest lever to the tool tip, m: the sum of the DH lengths `|a|` from the joint
/// on and `|d|` beyond it, the farthest the tip can be from the joint's axis at any angles. A
/// joint turned by `δ` rad moves the tip by at most `δ` times its lever.
pub fn longest_levers<const N: usize>(model: &ArmModel<N>) -> [f64; N] {
    std::array::from_fn(|j| {
        (j..N).map(|i| model.link(i).dh.a.abs() + if i > j { model.link(i).dh.d.abs() } else { 0.0 }).sum()
    })
}

/// World poses of all DH frames for one joint configuration `q` (rad).
#[derive(Debug, Clone, Copy)]
pub struct FrameChain<const N: usize> {
    poses: [Pose; N],
    trig: JointTrig<N>,
    /// The origin of DH frame 0 (on the base axis), m.
    base: Vector3<f64>,
}

impl<const N: usize> FrameChain<N> {
    /// Forward kinematics: `T_0i = A_1 ⋯ A_i` for every i, placed at the model's base
    /// ([`ArmModel::base`]): every pose is in the base frame.
    pub fn new(model: &ArmModel<N>, q: &JointVector<N>) -> Self {
        Self::from_trig(model, JointTrig::new(model, q))
    }

    /// Forward kinematics at the configuration whose joint sines and cosines are `trig`
    /// ([`compose_frames`]).
    pub fn from_trig(model: &ArmModel<N>, trig: JointTrig<N>) -> Self {
        let mut poses = [Pose::identity(); N];
        let base = model.base();
        compose_frames(model, &trig, |i, rotation, origin| {
            poses[i] = Pose::from_parts(Translation3::from(base + origin), Rotation3::from_matrix_unchecked(*rotation));
        });
        Self { poses, trig, base }
    }

    /// The joint sines and cosines this chain was built from.
    pub fn trig(&self) -> &JointTrig<N> {
        &self.trig
    }

    /// World pose of frame `i + 1` (the frame carried by body `i`, 0-based).
    pub fn body_pose(&self, i: usize) -> &Pose {
        &self.poses[i]
    }

    /// Unit axis `z_j` (world) and a point on it, `p_j` (m), of joint `j` (0-based).
    pub fn joint_axis(&self, j: usize) -> (Vector3<f64>, Vector3<f64>) {
        if j == 0 {
            (Vector3::z(), self.base)
        } else {
            let pose = &self.poses[j - 1];
            (pose.rotation.matrix().column(2).into_owned(), pose.translation.vector)
        }
    }

    /// Tool-tip position in the base frame, m (origin of the last frame).
    pub fn tip(&self) -> Vector3<f64> {
        self.poses[N - 1].translation.vector
    }

    /// World position of a point given in the frame of body `i`.
    pub fn point_on_body(&self, i: usize, local: &Vector3<f64>) -> Vector3<f64> {
        self.poses[i].rotation * local + self.poses[i].translation.vector
    }

    /// Geometric Jacobian of a point fixed to body `body`: linear part `z_j × (x − p_j)` and
    /// angular part `z_j` for joints `j ≤ body`, zero beyond.
    pub fn point_jacobian(&self, point: &Vector3<f64>, body: usize) -> (SMatrix<f64, 3, N>, SMatrix<f64, 3, N>) {
        let mut linear = SMatrix::<f64, 3, N>::zeros();
        let mut angular = SMatrix::<f64, 3, N>::zeros();
        for j in 0..=body {
            let (axis, origin) = self.joint_axis(j);
            linear.set_column(j, &axis.cross(&(point - origin)));
            angular.set_column(j, &axis);
        }
        (linear, angular)
    }
}

/// Velocities of the chain at `(q, q̇)`: angular velocity of every body and linear velocity of
/// every frame origin, in the base frame (rad/s, m/s).
#[derive(Debug, Clone, Copy)]
pub struct ChainVelocities<const N: usize> {
    /// Angular velocity of body `i`: `ω_i = Σ_{j ≤ i} z_j q̇_j`.
    pub body_angular: [Vector3<f64>; N],
    /// Velocity of the origin of frame `i + 1` (fixed to body `i`).
    pub frame_origin: [Vector3<f64>; N],
}

impl<const N: usize> ChainVelocities<N> {
    pub fn new(chain: &FrameChain<N>, qd: &JointVector<N>) -> Self {
        let mut body_angular = [Vector3::zeros(); N];
        let mut frame_origin = [Vector3::zeros(); N];
        let mut omega = Vector3::zeros();
        let mut origin_velocity = Vector3::zeros();
        for j in 0..N {
            let (axis, origin) = chain.joint_axis(j);
            omega += axis * qd[j];
            // p_j lies on joint j's axis, so it moves with body j at this instant.
            origin_velocity += omega.cross(&(chain.body_pose(j).translation.vector - origin));
            body_angular[j] = omega;
            frame_origin[j] = origin_velocity;
        }
        Self { body_angular, frame_origin }
    }

    /// Angular velocity of the body before joint `j` (zero for the base).
    fn omega_before(&self, j: usize) -> Vector3<f64> {
        if j == 0 { Vector3::zeros() } else { self.body_angular[j - 1] }
    }

    /// Velocity of the origin of frame `j` (zero for the base frame).
    fn origin_velocity(&self, j: usize) -> Vector3<f64> {
        if j == 0 { Vector3::zeros() } else { self.frame_origin[j - 1] }
    }

    /// Velocity of a point fixed to body `body` at world position `point`.
    pub fn point_velocity(&self, chain: &FrameChain<N>, point: &Vector3<f64>, body: usize) -> Vector3<f64> {
        let origin = chain.body_pose(body).translation.vector;
        self.frame_origin[body] + self.body_angular[body].cross(&(point - origin))
    }

    /// Time derivative of [`FrameChain::point_jacobian`] along the motion: column `j ≤ body` is
    /// `ż_j × (x − p_j) + z_j × (ẋ − ṗ_j)` (linear) and `ż_j = ω_{j−1} × z_j` (angular).
    pub fn point_jacobian_derivative(
        &self,
        chain: &FrameChain<N>,
        point: &Vector3<f64>,
        body: usize,
    ) -> (SMatrix<f64, 3, N>, SMatrix<f64, 3, N>) {
        let point_velocity = self.point_velocity(chain, point, body);
        let mut linear = SMatrix::<f64, 3, N>::zeros();
        let mut angular = SMatrix::<f64, 3, N>::zeros();
        for j in 0..=body {
            let (axis, origin) = chain.joint_axis(j);
            let axis_rate = self.omega_before(j).cross(&axis);
            let column = axis_rate.cross(&(point - origin)) + axis.cross(&(point_velocity - self.origin_velocity(j)));
            linear.set_column(j, &column);
            angular.set_column(j, &axis_rate);
        }
        (linear, angular)
    }
}
