//! The Jacobian/Christoffel formulation of the report (MAE547 method), corrected (ERRATA 7–9):
//!
//! - `M(q) = Σ_i m_i J_P⁽ⁱ⁾ᵀ J_P⁽ⁱ⁾ + J_O⁽ⁱ⁾ᵀ R_i I_i R_iᵀ J_O⁽ⁱ⁾` (+ armature), with the COM
//!   Jacobians `J_P⁽ⁱ⁾` columns `z_j × (c_i − p_j)` and `J_O⁽ⁱ⁾` columns `z_j`, `j ≤ i`;
//! - `c_ijk = ½ (∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i)` (minus on the last term), `C_ij = Σ_k c_ijk q̇_k`;
//! - `g(q) = −Σ_i m_i J_P⁽ⁱ⁾ᵀ g₀` (a vector).
//!
//! `∂M/∂q_k` is analytic: the Jacobians' derivatives along the unit rate `e_k`, and
//! `∂(R I Rᵀ)/∂q_k = [z_k]× R I Rᵀ − R I Rᵀ [z_k]×` for bodies moved by joint k.
//! This is O(N⁴) and meant for verification and for users who want the matrix `C` itself;
//! simulation uses [`crate::arm::dynamics`].

use super::kinematics::{ChainVelocities, FrameChain};
use super::mass_matrix::MassMatrix;
use super::model::{ArmModel, JointVector};
use nalgebra::{Matrix3, SMatrix};

type Jacobian<const N: usize> = SMatrix<f64, 3, N>;

/// Linear and angular Jacobians of every body's centre of mass, and its world inertia.
fn com_jacobians<const N: usize>(
    model: &ArmModel<N>,
    chain: &FrameChain<N>,
) -> [(Jacobian<N>, Jacobian<N>, Matrix3<f64>); N] {
    std::array::from_fn(|i| {
        let com = chain.point_on_body(i, &model.body(i).com);
        let (linear, angular) = chain.point_jacobian(&com, i);
        let rotation = chain.body_pose(i).rotation.matrix();
        (linear, angular, rotation * model.body(i).inertia * rotation.transpose())
    })
}

/// `M(q)` by the Jacobian method.
pub fn mass_matrix<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>) -> MassMatrix<N> {
    let chain = FrameChain::new(model, q);
    let mut matrix = MassMatrix::<N>::from_diagonal(&model.rotor_inertias());
    for (i, (linear, angular, inertia)) in com_jacobians(model, &chain).iter().enumerate() {
        matrix += linear.transpose() * linear * model.body(i).mass + angular.transpose() * inertia * angular;
    }
    matrix
}

/// `Ṁ(q, q̇) = Σ_k ∂M/∂q_k q̇_k`, analytic.
pub fn mass_matrix_rate<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>, qd: &JointVector<N>) -> MassMatrix<N> {
    let chain = FrameChain::new(model, q);
    let velocities = ChainVelocities::new(&chain, qd);
    let mut rate = MassMatrix::<N>::zeros();
    for (i, (linear, angular, inertia)) in com_jacobians(model, &chain).iter().enumerate() {
        let com = chain.point_on_body(i, &model.body(i).com);
        let (linear_rate, angular_rate) = velocities.point_jacobian_derivative(&chain, &com, i);
        let spin = velocities.body_angular[i].cross_matrix();
        let inertia_rate = spin * inertia - inertia * spin;
        let linear_part = linear_rate.transpose() * linear;
        let angular_part = angular_rate.transpose() * inertia * angular;
        rate += (linear_part + linear_part.transpose()) * model.body(i).mass
            + angular_part
            + angular_part.transpose()
            + angular.transpose() * inertia_rate * angular;
    }
    rate
}

/// `∂M/∂q_k` for every k.
pub fn mass_matrix_partials<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>) -> [MassMatrix<N>; N] {
    std::array::from_fn(|k| {
        let mut unit = JointVector::<N>::zeros();
        unit[k] = 1.0;
        mass_matrix_rate(model, q, &unit)
    })
}

/// The Coriolis matrix `C(q, q̇)` from Christoffel symbols of the first kind; `Ṁ − 2C` is
/// skew-symmetric and `C q̇` equals the centrifugal and Coriolis torques.
pub fn coriolis_matrix<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>, qd: &JointVector<N>) -> MassMatrix<N> {
    let partials = mass_matrix_partials(model, q);
    MassMatrix::<N>::from_fn(|i, j| {
        (0..N).map(|k| 0.5 * (partials[k][(i, j)] + partials[j][(i, k)] - partials[i][(j, k)]) * qd[k]).sum()
    })
}

/// `g(q) = −Σ m_i J_P⁽ⁱ⁾ᵀ g₀`, N·m.
pub fn gravity_torques<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>) -> JointVector<N> {
    let chain = FrameChain::new(model, q);
    let gravity = model.gravity();
    com_jacobians(model, &chain)
        .iter()
        .enumerate()
        .map(|(i, (linear, _, _))| -(linear.transpose() * gravity) * model.body(i).mass)
        .sum()
}

/// Kinetic energy `½ q̇ᵀ M q̇` and potential energy `−Σ m_i g₀ · c_i` (zero at the base
/// origin's height), J.
pub fn energy<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>, qd: &JointVector<N>) -> (f64, f64) {
    let kinetic = 0.5 * qd.dot(&(mass_matrix(model, q) * qd));
    let chain = FrameChain::new(model, q);
    let potential =
        (0..N).map(|i| -model.body(i).mass * model.gravity().dot(&chain.point_on_body(i, &model.body(i).com))).sum();
    (kinetic, potential)
}
