//! Rigid-body dynamics of the chain: `τ = M(q) q̈ + C(q, q̇) q̇ + g(q)`.
//!
//! An arm of the yaw–pitch family (a base yaw, parallel pitch joints, a vertical gravity: the
//! arms chessarm supports; [`super::yaw_pitch::YawPitch::new`] says which) takes the closed
//! form of [`super::yaw_pitch`]: Lagrange's equations in the yaw frame and the cumulative pitch
//! angles, where the pitch chain is planar. The free functions here pick it by themselves
//! whenever [`ArmModel::yaw_pitch`] is `Some`; the general path below serves every other arm,
//! [`ArmModel::with_general_dynamics`], and the tests as the oracle (the two agree to 1e-12).
//!
//! The general path is recursive and works in the base frame:
//! - inverse dynamics by the recursive Newton–Euler algorithm (RNEA), gravity entering as a base
//!   acceleration `−g₀`;
//! - the mass matrix by the composite-rigid-body algorithm (CRBA):
//!   `M_ij = S_iᵀ I^c_max(i,j) S_j`, with joint motion `S_j = (z_j, p_j × z_j)` and `I^c_j` the
//!   spatial inertia of bodies `j..N` about the base origin;
//! - forward dynamics `q̈ = M⁻¹(τ − C q̇ − g)` by an `L D Lᵀ` factorisation
//!   ([`MassMatrixFactor`]).
//!
//! Rotor inertia (armature) adds `diag(I_rotor)` to `M`. Everything lives on the stack: no call
//! allocates, but to report an error. [`crate::arm::lagrange`] holds the independent
//! Jacobian/Christoffel formulation the tests compare against.

use super::kinematics::{JointTrig, compose_frames};
use super::link::COULOMB_SMOOTHING;
use super::mass_matrix::{MassMatrix, MassMatrixFactor};
use super::model::{ArmModel, JointVector};
use super::yaw_pitch::{Angles, Configuration, YawPitch};
use crate::lanes::SimdLevel;
use nalgebra::{Matrix3, Vector3};

/// A symmetric 3×3 matrix stored by its six distinct entries: inertia tensors, kg·m².
/// Products and sums touch each distinct entry once (a full `Matrix3` would do 9).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SymmetricMatrix3 {
    pub xx: f64,
    pub yy: f64,
    pub zz: f64,
    pub xy: f64,
    pub xz: f64,
    pub yz: f64,
}

impl SymmetricMatrix3 {
    /// `R I Rᵀ`: a tensor given in a frame rotated by `rotation`, expressed in the outer axes.
    /// When `I` is diagonal (the body frame is a principal frame, as for every body of the
    /// report's arm and for an upright payload), `(R I Rᵀ)_ab = Σ_k I_kk R_ak R_bk`, about half
    /// the flops of the general product.
    #[inline(always)]
    pub fn rotated(rotation: &Matrix3<f64>, inertia: &Matrix3<f64>) -> Self {
        let is_diagonal = inertia[(0, 1)] == 0.0
            && inertia[(0, 2)] == 0.0
            && inertia[(1, 2)] == 0.0
            && inertia[(1, 0)] == 0.0
            && inertia[(2, 0)] == 0.0
            && inertia[(2, 1)] == 0.0;
        // `turned = R I`; for diagonal I its columns are R's scaled by I_kk.
        let turned = if is_diagonal {
            Matrix3::from_columns(&[
                rotation.column(0) * inertia[(0, 0)],
                rotation.column(1) * inertia[(1, 1)],
                rotation.column(2) * inertia[(2, 2)],
            ])
        } else {
            rotation * inertia
        };
        let entry = |a: usize, b: usize| {
            turned[(a, 0)] * rotation[(b, 0)] + turned[(a, 1)] * rotation[(b, 1)] + turned[(a, 2)] * rotation[(b, 2)]
        };
        Self { xx: entry(0, 0), yy: entry(1, 1), zz: entry(2, 2), xy: entry(0, 1), xz: entry(0, 2), yz: entry(1, 2) }
    }

    /// Inertia of a point mass `mass` at `position` about the origin: `m (|c|² E − c cᵀ)`.
    pub fn point_mass(mass: f64, position: &Vector3<f64>) -> Self {
        let weighted = position * mass;
        let (x, y, z) = (position.x, position.y, position.z);
        Self {
            xx: weighted.y * y + weighted.z * z,
            yy: weighted.x * x + weighted.z * z,
            zz: weighted.x * x + weighted.y * y,
            xy: -weighted.x * y,
            xz: -weighted.x * z,
            yz: -weighted.y * z,
        }
    }

    /// The matrix–vector product `S v`.
    pub fn mul_vector(&self, v: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            self.xx * v.x + self.xy * v.y + self.xz * v.z,
            self.xy * v.x + self.yy * v.y + self.yz * v.z,
            self.xz * v.x + self.yz * v.y + self.zz * v.z,
        )
    }
}

impl std::ops::Add for SymmetricMatrix3 {
    type Output = Self;
    fn add(self, other: Self) -> Self {
        Self {
            xx: self.xx + other.xx,
            yy: self.yy + other.yy,
            zz: self.zz + other.zz,
            xy: self.xy + other.xy,
            xz: self.xz + other.xz,
            yz: self.yz + other.yz,
        }
    }
}

/// World-frame quantities of every body at one configuration, shared by RNEA and CRBA.
#[derive(Debug, Clone, Copy)]
pub struct BodyFrames<const N: usize> {
    /// Axis of joint j (unit, world).
    pub axis: [Vector3<f64>; N],
    /// A point on joint j's axis: the origin of DH frame j, m.
    pub joint_point: [Vector3<f64>; N],
    /// `p_j × z_j`, m: the linear part of joint j's unit motion `S_j = (z_j, p_j × z_j)` about
    /// the base origin.
    pub axis_moment: [Vector3<f64>; N],
    /// Centre of mass of body j, m.
    pub com: [Vector3<f64>; N],
    /// Inertia of body j about its COM in world axes, kg·m².
    pub inertia: [SymmetricMatrix3; N],
    /// The tool tip, origin of the last DH frame, m (in the base frame, [`ArmModel::base`]
    /// included; every other field is relative to DH frame 0, which only translations part).
    pub tip: Vector3<f64>,
}

impl<const N: usize> BodyFrames<N> {
    pub fn new(model: &ArmModel<N>, q: &JointVector<N>) -> Self {
        Self::from_trig(model, &JointTrig::new(model, q))
    }

    /// At the configuration whose joint sines and cosines are `trig`.
    pub fn from_trig(model: &ArmModel<N>, trig: &JointTrig<N>) -> Self {
        let mut frames = Self {
            axis: [Vector3::zeros(); N],
            joint_point: [Vector3::zeros(); N],
            axis_moment: [Vector3::zeros(); N],
            com: [Vector3::zeros(); N],
            inertia: [SymmetricMatrix3::default(); N],
            tip: Vector3::zeros(),
        };
        frames.set_from_trig(model, trig);
        frames
    }

    /// [`BodyFrames::from_trig`] in place, for scratch reused every integration step: straight
    /// from the forward-kinematics composition, without storing the frames' poses.
    #[inline(always)]
    pub fn set_from_trig(&mut self, model: &ArmModel<N>, trig: &JointTrig<N>) {
        // Joint 0 turns about the base z axis through the base origin.
        self.axis[0] = Vector3::z();
        self.joint_point[0] = Vector3::zeros();
        self.axis_moment[0] = Vector3::zeros();
        compose_frames(model, trig, |i, rotation, origin| {
            let body = model.body(i);
            self.com[i] = rotation * body.com + origin;
            self.inertia[i] = SymmetricMatrix3::rotated(rotation, &body.inertia);
            // Frame i + 1 carries joint i + 1's axis (its z) through its origin.
            if i + 1 < N {
                let axis = rotation.column(2).into_owned();
                self.axis[i + 1] = axis;
                self.joint_point[i + 1] = *origin;
                self.axis_moment[i + 1] = origin.cross(&axis);
            } else {
                self.tip = model.base() + origin;
            }
        });
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
    recursive_newton_euler(model, frames, qd, Some(qdd), gravity)
}

/// The bias torques `C(q, q̇) q̇ + g(q)` on precomputed frames: RNEA with `q̈ = 0`, N·m.
#[inline(always)]
pub fn bias_with_frames<const N: usize>(
    model: &ArmModel<N>,
    frames: &BodyFrames<N>,
    qd: &JointVector<N>,
) -> JointVector<N> {
    recursive_newton_euler(model, frames, qd, None, &model.gravity())
}

/// RNEA in the base frame. `qdd = None` means `q̈ = 0`: the terms in `q̈` are left out rather
/// than multiplied by zero (a compiler may not drop `0 · x` for floats), the integrator's case.
///
/// Forward, for each body j: `ω_j = ω_{j−1} + z_j q̇_j`,
/// `ω̇_j = ω̇_{j−1} + z_j q̈_j + q̇_j ω_{j−1} × z_j`, the acceleration of joint point `p_j` from
/// the previous body's rigid motion, and of the COM: `a_c = a_p + ω̇ × (c − p) + ω × (ω × (c − p))`.
/// Each body's inertial force `F_j = m_j a_c` and moment about the base origin
/// `N_j = c_j × F_j + I_j ω̇_j + ω_j × I_j ω_j` follow at once. Backward, the sums over the
/// bodies a joint carries give `τ_j = z_j · Σ_{k≥j} N_k + (p_j × z_j) · Σ_{k≥j} F_k` (the moment
/// about `p_j` projected on `z_j`, with the joint's unit motion `S_j = (z_j, p_j × z_j)`), plus
/// the armature term `I_rotor,j q̈_j`.
#[inline(always)]
fn recursive_newton_euler<const N: usize>(
    model: &ArmModel<N>,
    frames: &BodyFrames<N>,
    qd: &JointVector<N>,
    qdd: Option<&JointVector<N>>,
    gravity: &Vector3<f64>,
) -> JointVector<N> {
    let mut body_force = [Vector3::zeros(); N];
    let mut body_moment = [Vector3::zeros(); N];
    let (mut omega, mut alpha) = (Vector3::<f64>::zeros(), Vector3::<f64>::zeros());
    // Acceleration of the current joint point, as a point of the previous body.
    let mut point_acceleration = -gravity;
    for j in 0..N {
        let axis = frames.axis[j];
        if j > 0 {
            let lever = frames.joint_point[j] - frames.joint_point[j - 1];
            point_acceleration += alpha.cross(&lever) + omega.cross(&omega.cross(&lever));
        }
        alpha += omega.cross(&axis) * qd[j];
        if let Some(qdd) = qdd {
            alpha += axis * qdd[j];
        }
        omega += axis * qd[j];
        let body = model.body(j);
        let lever = frames.com[j] - frames.joint_point[j];
        let com_acceleration = point_acceleration + alpha.cross(&lever) + omega.cross(&omega.cross(&lever));
        let inertia = &frames.inertia[j];
        body_force[j] = com_acceleration * body.mass;
        body_moment[j] =
            frames.com[j].cross(&body_force[j]) + inertia.mul_vector(&alpha) + omega.cross(&inertia.mul_vector(&omega));
    }
    let mut torque = JointVector::<N>::zeros();
    let (mut force, mut moment) = (Vector3::zeros(), Vector3::zeros());
    for j in (0..N).rev() {
        force += body_force[j];
        moment += body_moment[j];
        torque[j] = frames.axis[j].dot(&moment) + frames.axis_moment[j].dot(&force);
        if let Some(qdd) = qdd {
            torque[j] += model.link(j).rotor_inertia * qdd[j];
        }
    }
    torque
}

/// CRBA on precomputed frames: the joint-space mass matrix, armature included.
pub fn mass_matrix_with_frames<const N: usize>(model: &ArmModel<N>, frames: &BodyFrames<N>) -> MassMatrix<N> {
    let axis_moment = &frames.axis_moment;
    // Composite inertia of bodies j..N about the base origin: mass, first moment h = Σ m c and
    // rotational inertia Ī = Σ (I_c + m(|c|² E − c cᵀ)).
    let mut mass = 0.0;
    let mut first_moment = Vector3::zeros();
    let mut rotational = SymmetricMatrix3::default();
    let mut matrix = MassMatrix::<N>::zeros();
    for j in (0..N).rev() {
        let body = model.body(j);
        let c = frames.com[j];
        mass += body.mass;
        first_moment += c * body.mass;
        rotational = rotational + frames.inertia[j] + SymmetricMatrix3::point_mass(body.mass, &c);
        // Spatial force F = I^c S_j for the unit motion of joint j.
        let omega = frames.axis[j];
        let velocity = axis_moment[j];
        let force = velocity * mass - first_moment.cross(&omega);
        let moment = rotational.mul_vector(&omega) + first_moment.cross(&velocity);
        // `0..j + 1`, not `0..=j`: an inclusive range keeps the loop from being unrolled.
        for i in 0..j + 1 {
            let value = frames.axis[i].dot(&moment) + axis_moment[i].dot(&force);
            matrix[(i, j)] = value;
            matrix[(j, i)] = value;
        }
        matrix[(j, j)] += model.link(j).rotor_inertia;
    }
    matrix
}

/// Joint-space mass matrix `M(q)`, symmetric positive definite.
pub fn mass_matrix<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>) -> MassMatrix<N> {
    match model.yaw_pitch() {
        Some(fast) => from_rows(&yaw_pitch_at(
            fast,
            q,
            #[inline(always)]
            |at| at.mass_matrix,
        )),
        None => mass_matrix_with_frames(model, &BodyFrames::new(model, q)),
    }
}

/// Inverse dynamics `τ = M q̈ + C q̇ + g`, N·m.
pub fn inverse_dynamics<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    qd: &JointVector<N>,
    qdd: &JointVector<N>,
) -> JointVector<N> {
    match model.yaw_pitch() {
        Some(fast) => from_array(yaw_pitch_at(
            fast,
            q,
            #[inline(always)]
            |at| at.inverse_dynamics(fast, &to_array(qd), &to_array(qdd)),
        )),
        None => rnea_with_frames(model, &BodyFrames::new(model, q), qd, qdd, &model.gravity()),
    }
}

/// Gravity torques `g(q)`, N·m: the torques that hold the arm still.
pub fn gravity_torques<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>) -> JointVector<N> {
    let zero = JointVector::<N>::zeros();
    match model.yaw_pitch() {
        Some(fast) => from_array(yaw_pitch_at(
            fast,
            q,
            #[inline(always)]
            |at| at.bias(fast, &[0.0; 4]),
        )),
        None => inverse_dynamics(model, q, &zero, &zero),
    }
}

/// Centrifugal and Coriolis torques `C(q, q̇) q̇`, N·m.
pub fn coriolis_torques<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    qd: &JointVector<N>,
) -> JointVector<N> {
    match model.yaw_pitch() {
        Some(fast) => {
            let weightless = YawPitch { gravity_z: 0.0, ..*fast };
            from_array(yaw_pitch_at(
                &weightless,
                q,
                #[inline(always)]
                |at| at.bias(&weightless, &to_array(qd)),
            ))
        }
        None => rnea_with_frames(model, &BodyFrames::new(model, q), qd, &JointVector::zeros(), &Vector3::zeros()),
    }
}

/// Bias torques `C(q, q̇) q̇ + g(q)`, N·m (the report's `N`).
pub fn bias_torques<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>, qd: &JointVector<N>) -> JointVector<N> {
    match model.yaw_pitch() {
        Some(fast) => from_array(yaw_pitch_at(
            fast,
            q,
            #[inline(always)]
            |at| at.bias(fast, &to_array(qd)),
        )),
        None => bias_with_frames(model, &BodyFrames::new(model, q), qd),
    }
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

/// Mass matrix and bias torques at one state: what a computed-torque controller needs.
#[derive(Debug, Clone, Copy)]
pub struct DynamicsTerms<const N: usize> {
    pub mass_matrix: MassMatrix<N>,
    /// `C(q, q̇) q̇ + g(q)`.
    pub bias: JointVector<N>,
}

impl<const N: usize> DynamicsTerms<N> {
    /// From one forward-kinematics pass at `q`.
    pub fn new(model: &ArmModel<N>, q: &JointVector<N>, qd: &JointVector<N>) -> Self {
        if let Some(fast) = model.yaw_pitch() {
            let (mass_matrix, bias) = yaw_pitch_at(
                fast,
                q,
                #[inline(always)]
                |at| (at.mass_matrix, at.bias(fast, &to_array(qd))),
            );
            return Self { mass_matrix: from_rows(&mass_matrix), bias: from_array(bias) };
        }
        let frames = BodyFrames::new(model, q);
        Self { mass_matrix: mass_matrix_with_frames(model, &frames), bias: bias_with_frames(model, &frames, qd) }
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
    match model.yaw_pitch() {
        Some(fast) => {
            let acceleration = yaw_pitch_at(
                fast,
                q,
                #[inline(always)]
                |at| {
                    // No closure inside: it would be compiled apart, for the baseline.
                    if at.inverse.positive_definite(0) {
                        Some(at.acceleration(fast, &to_array(qd), &to_array(torque)))
                    } else {
                        None
                    }
                },
            );
            // The yaw drops out of M, so a non-finite base angle would pass unnoticed: it fails
            // here as it does on the general path (where it makes M NaN).
            match acceleration {
                Some(acceleration) if q[0].is_finite() => Ok(from_array(acceleration)),
                _ => Err(DynamicsError::NotPositiveDefinite(q.iter().copied().collect())),
            }
        }
        None => Ok(ConfigurationDynamics::new(model, q)?.acceleration(model, qd, torque)),
    }
}

/// `f` of the model's configuration at `q` (rad), for the free functions above: both compiled
/// for the CPU's best SIMD level ([`SimdLevel::detect`]: forward dynamics took 53 ns there
/// against 59 ns at AVX2 on the 2-vCPU Intel Xeon, measured with the `L D Lᵀ` factor the
/// inverse replaced, 51 ns with it; the same bits at every level), so `f` must be an
/// `#[inline(always)]` closure.
#[inline(always)]
fn yaw_pitch_at<const N: usize, R>(
    model: &YawPitch<f64>,
    q: &JointVector<N>,
    f: impl FnOnce(&Configuration<f64>) -> R,
) -> R {
    SimdLevel::detect().run(
        #[inline(always)]
        || f(&Configuration::new(model, Angles::new(model, &to_array(q)))),
    )
}

/// The entries of a 4×4 matrix of the closed form as an `N × N` one (`N = 4` whenever the
/// structured path runs).
pub(crate) fn from_rows<const N: usize>(rows: &[[f64; 4]; 4]) -> MassMatrix<N> {
    MassMatrix::<N>::from_fn(|i, j| rows[i][j])
}

/// A joint vector's four entries, as the closed form takes them (`N = 4` whenever the
/// structured path runs).
pub(crate) fn to_array<const N: usize>(v: &JointVector<N>) -> [f64; 4] {
    std::array::from_fn(|j| v[j])
}

/// The closed form's four entries as a joint vector.
pub(crate) fn from_array<const N: usize>(v: [f64; 4]) -> JointVector<N> {
    JointVector::<N>::from_fn(|j, _| v[j])
}

/// Everything about one configuration `q` that forward dynamics needs, whatever the joint
/// rates: the joint sines and cosines, the body frames (forward kinematics), `M(q)` and its
/// `L D Lᵀ` factor. Each joint rate then costs one RNEA and two triangular solves. Scratch in
/// the sense of Pinocchio's `Data`: an integrator keeps one per stage configuration and
/// refills it in place every step ([`ConfigurationDynamics::set_configuration`]), so nothing
/// of several hundred bytes is moved around per step.
#[derive(Debug, Clone)]
pub struct ConfigurationDynamics<const N: usize> {
    trig: JointTrig<N>,
    frames: BodyFrames<N>,
    mass_matrix: MassMatrix<N>,
    mass_factor: MassMatrixFactor<N>,
}

impl<const N: usize> ConfigurationDynamics<N> {
    pub fn new(model: &ArmModel<N>, q: &JointVector<N>) -> Result<Self, DynamicsError> {
        let trig = JointTrig::new(model, q);
        let frames = BodyFrames::from_trig(model, &trig);
        let mass_matrix = mass_matrix_with_frames(model, &frames);
        let mass_factor = MassMatrixFactor::new(&mass_matrix)
            .ok_or_else(|| DynamicsError::NotPositiveDefinite(q.iter().copied().collect()))?;
        Ok(Self { trig, frames, mass_matrix, mass_factor })
    }

    /// Frames at `q = 0` with `M` and its factor the identity: scratch to be filled by
    /// [`ConfigurationDynamics::set_configuration`] before use.
    pub(crate) fn placeholder(model: &ArmModel<N>) -> Self {
        let trig = JointTrig::new(model, &JointVector::zeros());
        Self {
            trig,
            frames: BodyFrames::from_trig(model, &trig),
            mass_matrix: MassMatrix::identity(),
            mass_factor: MassMatrixFactor::identity(),
        }
    }

    /// Moves to configuration `q`, whose joint sines and cosines are `trig`, in place. On an
    /// error the factor is left unusable (every acceleration NaN), never stale.
    #[inline(always)]
    pub fn set_configuration(
        &mut self,
        model: &ArmModel<N>,
        q: &JointVector<N>,
        trig: JointTrig<N>,
    ) -> Result<(), DynamicsError> {
        self.trig = trig;
        self.frames.set_from_trig(model, &self.trig);
        self.mass_matrix = mass_matrix_with_frames(model, &self.frames);
        match MassMatrixFactor::new(&self.mass_matrix) {
            Some(factor) => {
                self.mass_factor = factor;
                Ok(())
            }
            None => {
                self.mass_factor = MassMatrixFactor::unusable();
                Err(DynamicsError::NotPositiveDefinite(q.iter().copied().collect()))
            }
        }
    }

    /// The joint sines and cosines of this configuration.
    pub fn trig(&self) -> &JointTrig<N> {
        &self.trig
    }

    /// The tool tip at this configuration, m (base frame, [`ArmModel::base`] included).
    pub fn tip(&self) -> Vector3<f64> {
        self.frames.tip
    }

    /// `M(q)`, kg·m².
    pub fn mass_matrix(&self) -> &MassMatrix<N> {
        &self.mass_matrix
    }

    /// `C(q, q̇) q̇ + g(q)` at this configuration and rates `qd`, N·m.
    #[inline(always)]
    pub fn bias(&self, model: &ArmModel<N>, qd: &JointVector<N>) -> JointVector<N> {
        bias_with_frames(model, &self.frames, qd)
    }

    /// `q̈ = M⁻¹ (τ + τ_friction(q̇) − C q̇ − g)` at this configuration and rates `qd`, rad/s².
    #[inline(always)]
    pub fn acceleration(&self, model: &ArmModel<N>, qd: &JointVector<N>, torque: &JointVector<N>) -> JointVector<N> {
        self.acceleration_with_bias(model, qd, torque, &self.bias(model, qd))
    }

    /// [`ConfigurationDynamics::acceleration`] with the bias torques at `qd` already known.
    #[inline(always)]
    pub fn acceleration_with_bias(
        &self,
        model: &ArmModel<N>,
        qd: &JointVector<N>,
        torque: &JointVector<N>,
        bias: &JointVector<N>,
    ) -> JointVector<N> {
        let net = if model.has_friction() { torque + friction_torques(model, qd) - bias } else { torque - bias };
        self.mass_factor.solve(&net)
    }
}
