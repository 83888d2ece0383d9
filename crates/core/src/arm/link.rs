//! One link of the chain and the joint that drives it: Denavit–Hartenberg parameters, mass
//! properties, limits, friction. Plain numbers, checked where a model is built; they stand
//! here, below the model and the yaw–pitch closed form, which both read them.
//!
//! All quantities are SI: metres, radians, kilograms, kg·m², N·m, seconds.
//! A link's inertial parameters are expressed in its own DH frame `i` (the frame at the distal
//! joint of link `i`), as in the report.

use nalgebra::{Matrix3, Vector3};

/// Standard Denavit–Hartenberg parameters of one joint/link:
/// `A_i = Rz(θ_i + theta_offset) · Tz(d) · Tx(a) · Rx(alpha)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DhParameters {
    /// Link length along x_i, m.
    pub a: f64,
    /// Link twist about x_i, rad.
    pub alpha: f64,
    /// Link offset along z_{i-1}, m.
    pub d: f64,
    /// Constant added to the joint angle, rad.
    pub theta_offset: f64,
}

/// Mass properties of a rigid body, expressed in a body-fixed frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertial {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in the body frame, m.
    pub com: Vector3<f64>,
    /// Inertia tensor about the centre of mass, axes of the body frame, kg·m².
    pub inertia: Matrix3<f64>,
}

impl Inertial {
    /// A body with no mass.
    pub fn zero() -> Self {
        Self { mass: 0.0, com: Vector3::zeros(), inertia: Matrix3::zeros() }
    }

    /// A point mass at `position` (body frame).
    pub fn point(mass: f64, position: Vector3<f64>) -> Self {
        Self { mass, com: position, inertia: Matrix3::zeros() }
    }

    /// The rigid union of two bodies expressed in the same frame, by the parallel-axis rule:
    /// `c = (m₁c₁ + m₂c₂)/(m₁+m₂)`, `I = Σ I_k + m_k (‖d_k‖² E − d_k d_kᵀ)` with `d_k = c_k − c`.
    pub fn combine(&self, other: &Inertial) -> Inertial {
        let mass = self.mass + other.mass;
        if mass <= 0.0 {
            return Inertial::zero();
        }
        let com = (self.com * self.mass + other.com * other.mass) / mass;
        let shifted = |body: &Inertial| {
            let d = body.com - com;
            body.inertia + (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * body.mass
        };
        Inertial { mass, com, inertia: shifted(self) + shifted(other) }
    }
}

/// Limits of one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits {
    /// Lowest joint angle, rad.
    pub lower: f64,
    /// Highest joint angle, rad.
    pub upper: f64,
    /// Largest |joint speed|, rad/s.
    pub velocity: f64,
    /// Largest |torque| the motor delivers, N·m. The simulator saturates at this value.
    pub torque: f64,
}

/// Smoothing speed of Coulomb friction, rad/s: `τ_c · tanh(q̇ / COULOMB_SMOOTHING)` replaces
/// `τ_c · sign(q̇)` so the plant's right-hand side stays smooth for RK4.
pub const COULOMB_SMOOTHING: f64 = 1e-3;

/// Joint friction acting in the plant: `τ_f = −(viscous·q̇ + coulomb·tanh(q̇/COULOMB_SMOOTHING))`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Friction {
    /// Viscous coefficient, N·m·s/rad.
    pub viscous: f64,
    /// Coulomb friction torque, N·m.
    pub coulomb: f64,
}

/// One link of the chain and the joint that drives it (joint `i` moves link `i`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    pub dh: DhParameters,
    /// Mass properties of the link in its DH frame `i`.
    pub inertial: Inertial,
    /// Mass of the motor driving joint `i`, kg, modelled as a point mass on the joint axis at
    /// the origin of frame `i−1`, carried by link `i−1` (the motor of joint 1 sits on the fixed
    /// base and does not move). Default 0: the report gives no values (ERRATA item 10).
    pub motor_mass: f64,
    /// Rotor inertia reflected through the gearbox, kg·m², added to `M_ii` (armature).
    pub rotor_inertia: f64,
    pub limits: JointLimits,
    pub friction: Friction,
}
