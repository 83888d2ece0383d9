//! The joint torques of a point-mass payload, linear in its parameters: the regressor of
//! adaptive control.
//!
//! A point mass `m` whose centre lies `c` metres along the tool x axis sits at
//! `p = p_tip + c x̂` (world), with `x̂` the tool frame's x axis. Its acceleration, gravity
//! entering as the base acceleration `−g₀` as in the RNEA, is
//! `a_p = a + c b` with `a = a_tip − g₀` and `b = α × x̂ + ω × (ω × x̂)`, where `ω, α` are the
//! tool's angular velocity and acceleration. The force it needs is `F = m a_p` and joint `j`
//! (axis `z_j` through `o_j`) carries `τ_j = z_j · ((p − o_j) × F)`:
//!
//! `τ_j = m · z_j·(r_j × a) + m c · z_j·(r_j × b + x̂ × a) + m c² · z_j·(x̂ × b)`,
//! `r_j = p_tip − o_j`,
//!
//! so `τ_p = Y(q, q̇, q̈) θ + m c² w(q, q̇, q̈)` with `θ = (m, m c)`, the `N × 2` regressor
//! `Y = [z_j·(r_j × a), z_j·(r_j × b + x̂ × a)]` and `w_j = z_j·(x̂ × b)`. Both are computed
//! exactly from the tool's motion (one forward pass, as the RNEA's). `w` carries no gravity
//! (it comes from `b` alone) and vanishes at rest; with the tool pointing down, `x̂ ∥ g₀` and
//! the second column vanishes at rest as well (the offset along the tool moves no lever arm).

use super::kinematics::{JointTrig, compose_frames};
use super::model::{ArmModel, JointVector};
use nalgebra::{SMatrix, Vector3};

/// `Y(q, q̇, q̈)`: joint torques (N·m) per unit `θ = (m, m c)` (kg, kg·m).
pub type PayloadRegressor<const N: usize> = SMatrix<f64, N, 2>;

/// The torques of a point-mass payload split by parameter: `τ_p = Y θ + m c² w`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PayloadTerms<const N: usize> {
    /// `Y`, columns for `m` (N·m/kg) and `m c` (N/kg).
    pub regressor: PayloadRegressor<N>,
    /// `w`, N/(kg·m): the coefficient of `m c²`.
    pub quadratic: JointVector<N>,
}

impl<const N: usize> PayloadTerms<N> {
    /// `τ_p` of a point mass `mass` kg at `offset` m along the tool x axis, N·m.
    pub fn torque(&self, mass: f64, offset: f64) -> JointVector<N> {
        self.regressor * nalgebra::Vector2::new(mass, mass * offset) + self.quadratic * (mass * offset * offset)
    }
}

/// [`PayloadTerms`] of `model`'s chain (its links' masses play no part) at joint angles `q`
/// (rad), rates `qd` (rad/s) and accelerations `qdd` (rad/s²), gravity included.
pub fn payload_terms<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    qd: &JointVector<N>,
    qdd: &JointVector<N>,
) -> PayloadTerms<N> {
    let trig = JointTrig::new(model, q);
    // Joint axes and points, then the tool's x axis and tip.
    let mut axis = [Vector3::z(); N];
    let mut point = [Vector3::zeros(); N];
    let (mut tool_x, mut tip) = (Vector3::x(), Vector3::zeros());
    compose_frames(model, &trig, |i, rotation, origin| {
        if i + 1 < N {
            axis[i + 1] = rotation.column(2).into_owned();
            point[i + 1] = *origin;
        } else {
            tool_x = rotation.column(0).into_owned();
            tip = *origin;
        }
    });
    // Forward pass as in the RNEA: the acceleration of each joint point (a point of the body
    // before it), the angular velocity and acceleration of each body.
    let (mut omega, mut alpha) = (Vector3::<f64>::zeros(), Vector3::<f64>::zeros());
    let mut point_acceleration = -model.gravity();
    for j in 0..N {
        if j > 0 {
            let lever = point[j] - point[j - 1];
            point_acceleration += alpha.cross(&lever) + omega.cross(&omega.cross(&lever));
        }
        alpha += omega.cross(&axis[j]) * qd[j] + axis[j] * qdd[j];
        omega += axis[j] * qd[j];
    }
    let lever = tip - point[N - 1];
    let a = point_acceleration + alpha.cross(&lever) + omega.cross(&omega.cross(&lever));
    let b = alpha.cross(&tool_x) + omega.cross(&omega.cross(&tool_x));
    let x_cross_a = tool_x.cross(&a);
    let x_cross_b = tool_x.cross(&b);
    let mut regressor = PayloadRegressor::<N>::zeros();
    let mut quadratic = JointVector::<N>::zeros();
    for j in 0..N {
        let r = tip - point[j];
        regressor[(j, 0)] = axis[j].dot(&r.cross(&a));
        regressor[(j, 1)] = axis[j].dot(&(r.cross(&b) + x_cross_a));
        quadratic[j] = axis[j].dot(&x_cross_b);
    }
    PayloadTerms { regressor, quadratic }
}

/// The regressor `Y(q, q̇, q̈)` alone ([`payload_terms`]): `τ_p = Y (m, m c) + O(m c²)`.
pub fn payload_regressor<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    qd: &JointVector<N>,
    qdd: &JointVector<N>,
) -> PayloadRegressor<N> {
    payload_terms(model, q, qd, qdd).regressor
}
