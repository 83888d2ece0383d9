//! Rigid-body dynamics of the chain: `τ = M(q) q̈ + C(q, q̇) q̇ + g(q)`.
//!
//! The fast path is recursive and works in the base frame:
//! - inverse dynamics by the recursive Newton–Euler algorithm (RNEA), gravity entering as a base
//!   acceleration `−g₀`;
//! - the mass matrix by the composite-rigid-body algorithm (CRBA):
//!   `M_ij = S_iᵀ I^c_max(i,j) S_j`, with joint motion `S_j = (z_j, p_j × z_j)` and `I^c_j` the
//!   spatial inertia of bodies `j..N` about the base origin;
//! - forward dynamics `q̈ = M⁻¹(τ − C q̇ − g)` by Cholesky.
//!
//! Rotor inertia (armature) adds `diag(I_rotor)` to `M`. Everything lives on the stack: no call
//! allocates. [`crate::arm::lagrange`] holds the independent Jacobian/Christoffel formulation the
//! tests compare against.

use super::kinematics::FrameChain;
use super::model::{ArmModel, JointVector};
use nalgebra::{Cholesky, Const, Matrix3, SMatrix, Vector3};

/// `M(q)`, kg·m² (N·m·s²/rad).
pub type MassMatrix<const N: usize> = SMatrix<f64, N, N>;

/// Smoothing speed of Coulomb friction, rad/s: `τ_c · tanh(q̇ / COULOMB_SMOOTHING)` replaces
/// `τ_c · sign(q̇)` so the plant's right-hand side stays smooth for RK4.
pub const COULOMB_SMOOTHING: f64 = 1e-3;

/// World-frame quantities of every body at one configuration, shared by RNEA and CRBA.
#[derive(Debug, Clone, Copy)]
pub struct BodyFrames<const N: usize> {
    /// Axis of joint j (unit, world).
    pub axis: [Vector3<f64>; N],
    /// A point on joint j's axis: the origin of DH frame j, m.
    pub joint_point: [Vector3<f64>; N],
    /// Centre of mass of body j, m.
    pub com: [Vector3<f64>; N],
    /// Inertia of body j about its COM in world axes, kg·m².
    pub inertia: [Matrix3<f64>; N],
}

impl<const N: usize> BodyFrames<N> {
    pub fn new(model: &ArmModel<N>, q: &JointVector<N>) -> Self {
        Self::from_chain(model, &FrameChain::new(model, q))
    }

    pub fn from_chain(model: &ArmModel<N>, chain: &FrameChain<N>) -> Self {
        let mut frames = Self {
            axis: [Vector3::zeros(); N],
            joint_point: [Vector3::zeros(); N],
            com: [Vector3::zeros(); N],
            inertia: [Matrix3::zeros(); N],
        };
        for j in 0..N {
            let (axis, point) = chain.joint_axis(j);
            let body = model.body(j);
            let rotation = chain.body_pose(j).rotation.matrix();
            frames.axis[j] = axis;
            frames.joint_point[j] = point;
            frames.com[j] = chain.point_on_body(j, &body.com);
            frames.inertia[j] = rotation * body.inertia * rotation.transpose();
        }
        frames
    }

    /// Where joint `j + 1` sits (origin of DH frame j + 1), or the tool tip for the last body.
    fn next_point(&self, j: usize) -> Option<Vector3<f64>> {
        (j + 1 < N).then(|| self.joint_point[j + 1])
    }
}

/// RNEA on precomputed frames: joint torques for `(q̇, q̈)` under base acceleration
/// `−gravity` (pass zero gravity for `C q̇` alone). Includes the armature term.
pub fn rnea_with_frames<const N: usize>(
    model: &ArmModel<N>,
    frames: &BodyFrames<N>,
    qd: &JointVector<N>,
    qdd: &JointVector<N>,
    gravity: &Vector3<f64>,
) -> JointVector<N> {
    let mut omega = [Vector3::zeros(); N];
    let mut alpha = [Vector3::zeros(); N];
    let mut com_acceleration = [Vector3::zeros(); N];
    let (mut previous_omega, mut previous_alpha) = (Vector3::zeros(), Vector3::zeros());
    // Acceleration of the current joint point, as a point of the previous body.
    let mut point_acceleration = -gravity;
    for j in 0..N {
        let axis = frames.axis[j];
        if j > 0 {
            let lever = frames.joint_point[j] - frames.joint_point[j - 1];
            point_acceleration += previous_alpha.cross(&lever) + previous_omega.cross(&previous_omega.cross(&lever));
        }
        omega[j] = previous_omega + axis * qd[j];
        alpha[j] = previous_alpha + axis * qdd[j] + previous_omega.cross(&axis) * qd[j];
        let lever = frames.com[j] - frames.joint_point[j];
        com_acceleration[j] = point_acceleration + alpha[j].cross(&lever) + omega[j].cross(&omega[j].cross(&lever));
        previous_omega = omega[j];
        previous_alpha = alpha[j];
    }
    let mut torque = JointVector::<N>::zeros();
    let (mut force, mut moment) = (Vector3::zeros(), Vector3::zeros());
    for j in (0..N).rev() {
        let body = model.body(j);
        let inertial_force = com_acceleration[j] * body.mass;
        let point = frames.joint_point[j];
        // Moment about this joint's point of what the next body pulls on this one.
        let transmitted = match frames.next_point(j) {
            Some(next) => moment + (next - point).cross(&force),
            None => moment,
        };
        moment = transmitted
            + (frames.com[j] - point).cross(&inertial_force)
            + frames.inertia[j] * alpha[j]
            + omega[j].cross(&(frames.inertia[j] * omega[j]));
        force += inertial_force;
        torque[j] = frames.axis[j].dot(&moment) + model.link(j).rotor_inertia * qdd[j];
    }
    torque
}

/// CRBA on precomputed frames: the joint-space mass matrix, armature included.
pub fn mass_matrix_with_frames<const N: usize>(model: &ArmModel<N>, frames: &BodyFrames<N>) -> MassMatrix<N> {
    // Composite inertia of bodies j..N about the base origin: mass, first moment h = Σ m c and
    // rotational inertia Ī = Σ (I_c + m(|c|² E − c cᵀ)).
    let mut mass = 0.0;
    let mut first_moment = Vector3::zeros();
    let mut rotational = Matrix3::zeros();
    let mut matrix = MassMatrix::<N>::zeros();
    for j in (0..N).rev() {
        let body = model.body(j);
        let c = frames.com[j];
        mass += body.mass;
        first_moment += c * body.mass;
        rotational += frames.inertia[j] + (Matrix3::identity() * c.norm_squared() - c * c.transpose()) * body.mass;
        // Spatial force F = I^c S_j for the unit motion of joint j.
        let omega = frames.axis[j];
        let velocity = frames.joint_point[j].cross(&omega);
        let force = velocity * mass - first_moment.cross(&omega);
        let moment = rotational * omega + first_moment.cross(&velocity);
        for i in 0..=j {
            let value = frames.axis[i].dot(&moment) + frames.joint_point[i].cross(&frames.axis[i]).dot(&force);
            matrix[(i, j)] = value;
            matrix[(j, i)] = value;
        }
        matrix[(j, j)] += model.link(j).rotor_inertia;
    }
    matrix
}

/// Joint-space mass matrix `M(q)`, symmetric positive definite.
pub fn mass_matrix<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>) -> MassMatrix<N> {
    mass_matrix_with_frames(model, &BodyFrames::new(model, q))
}

/// Inverse dynamics `τ = M q̈ + C q̇ + g`, N·m.
pub fn inverse_dynamics<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    qd: &JointVector<N>,
    qdd: &JointVector<N>,
) -> JointVector<N> {
    rnea_with_frames(model, &BodyFrames::new(model, q), qd, qdd, &model.gravity())
}

/// Gravity torques `g(q)`, N·m: the torques that hold the arm still.
pub fn gravity_torques<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>) -> JointVector<N> {
    let zero = JointVector::<N>::zeros();
    inverse_dynamics(model, q, &zero, &zero)
}

/// Centrifugal and Coriolis torques `C(q, q̇) q̇`, N·m.
pub fn coriolis_torques<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    qd: &JointVector<N>,
) -> JointVector<N> {
    rnea_with_frames(model, &BodyFrames::new(model, q), qd, &JointVector::zeros(), &Vector3::zeros())
}

/// Bias torques `C(q, q̇) q̇ + g(q)`, N·m (the report's `N`).
pub fn bias_torques<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>, qd: &JointVector<N>) -> JointVector<N> {
    inverse_dynamics(model, q, qd, &JointVector::zeros())
}

/// Joint friction torques acting on the joints (opposing motion), N·m:
/// `−(b q̇ + τ_c tanh(q̇ / COULOMB_SMOOTHING))`.
pub fn friction_torques<const N: usize>(model: &ArmModel<N>, qd: &JointVector<N>) -> JointVector<N> {
    JointVector::from_fn(|j, _| {
        let friction = &model.link(j).friction;
        let coulomb = if friction.coulomb == 0.0 { 0.0 } else { friction.coulomb * (qd[j] / COULOMB_SMOOTHING).tanh() };
        -(friction.viscous * qd[j] + coulomb)
    })
}

/// Why forward dynamics failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    #[error("the mass matrix is not positive definite at q = {0:?}")]
    NotPositiveDefinite(Vec<f64>),
}

/// Mass matrix and bias torques at one state, computed from one forward-kinematics pass.
#[derive(Debug, Clone, Copy)]
pub struct DynamicsTerms<const N: usize> {
    pub mass_matrix: MassMatrix<N>,
    /// `C(q, q̇) q̇ + g(q)`.
    pub bias: JointVector<N>,
}

impl<const N: usize> DynamicsTerms<N> {
    pub fn new(model: &ArmModel<N>, q: &JointVector<N>, qd: &JointVector<N>) -> Self {
        Self::from_chain(model, &FrameChain::new(model, q), qd)
    }

    /// The terms with forward kinematics at `q` already done.
    pub fn from_chain(model: &ArmModel<N>, chain: &FrameChain<N>, qd: &JointVector<N>) -> Self {
        let frames = BodyFrames::from_chain(model, chain);
        Self {
            mass_matrix: mass_matrix_with_frames(model, &frames),
            bias: rnea_with_frames(model, &frames, qd, &JointVector::zeros(), &model.gravity()),
        }
    }
}

/// Forward dynamics `q̈ = M⁻¹ (τ + τ_friction − C q̇ − g)`, rad/s². Friction comes from the
/// model's links (zero by default).
pub fn forward_dynamics<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    qd: &JointVector<N>,
    torque: &JointVector<N>,
) -> Result<JointVector<N>, DynamicsError> {
    forward_dynamics_from_chain(model, &FrameChain::new(model, q), q, qd, torque)
}

/// [`forward_dynamics`] with forward kinematics at `q` already done.
pub fn forward_dynamics_from_chain<const N: usize>(
    model: &ArmModel<N>,
    chain: &FrameChain<N>,
    q: &JointVector<N>,
    qd: &JointVector<N>,
    torque: &JointVector<N>,
) -> Result<JointVector<N>, DynamicsError> {
    DynamicsTerms::from_chain(model, chain, qd).acceleration(model, q, qd, torque)
}

impl<const N: usize> DynamicsTerms<N> {
    /// Forward dynamics with these terms (of `model` at `(q, q̇)`) at hand:
    /// `q̈ = M⁻¹ (τ + τ_friction(q̇) − C q̇ − g)`, rad/s², by Cholesky.
    pub fn acceleration(
        &self,
        model: &ArmModel<N>,
        q: &JointVector<N>,
        qd: &JointVector<N>,
        torque: &JointVector<N>,
    ) -> Result<JointVector<N>, DynamicsError> {
        let rhs = torque + friction_torques(model, qd) - self.bias;
        Cholesky::<f64, Const<N>>::new(self.mass_matrix)
            .map(|cholesky| cholesky.solve(&rhs))
            .ok_or_else(|| DynamicsError::NotPositiveDefinite(q.iter().copied().collect()))
    }
}
