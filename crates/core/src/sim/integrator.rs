//! The integration methods the plant steps with (the general chain's `plant` and the
//! yaw–pitch family's `structured` both take them).

/// How the plant's state advances over one step of `dt` with the torque held (zero-order hold).
/// Costs are in evaluations of the forward dynamics per step; the first one is shared with
/// the controller when its model equals the plant's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Classical fourth-order Runge–Kutta: 4 evaluations, global error O(dt⁴).
    RungeKutta4,
    /// Nyström's fourth-order Runge–Kutta method for second-order systems `q̈ = f(q, q̇)`
    /// (Kreyszig, *Advanced Engineering Mathematics*, §21.3). With `h = dt` and `q̈ᵢ` its stages:
    /// `q̈₁ = f(q, q̇)`; `Q = q + h/2 q̇ + h²/8 q̈₁`; `q̈₂ = f(Q, q̇ + h/2 q̈₁)`;
    /// `q̈₃ = f(Q, q̇ + h/2 q̈₂)`; `q̈₄ = f(q + h q̇ + h²/2 q̈₃, q̇ + h q̈₃)`;
    /// `q⁺ = q + h q̇ + h²/6 (q̈₁ + q̈₂ + q̈₃)`, `q̇⁺ = q̇ + h/6 (q̈₁ + 2q̈₂ + 2q̈₃ + q̈₄)`.
    /// The same updates as RK4 with stages 2 and 3 at one configuration, so the mass matrix,
    /// its factor (its inverse for the yaw–pitch family) and the kinematics are computed 3 times
    /// per step instead of 4; global error O(dt⁴). The default.
    #[default]
    RungeKuttaNystrom4,
    /// Explicit midpoint rule, a second-order Runge–Kutta method:
    /// `x⁺ = x + dt f(x + dt/2 · f(x))`; 2 evaluations, global error O(dt²).
    Midpoint,
    /// Semi-implicit (symplectic) Euler, the default of MuJoCo and most game engines:
    /// `q̇⁺ = q̇ + dt q̈(q, q̇)`, `q⁺ = q + dt q̇⁺`; 1 evaluation, global error O(dt).
    SemiImplicitEuler,
}

impl Integrator {
    pub const ALL: [Integrator; 4] =
        [Integrator::RungeKutta4, Integrator::RungeKuttaNystrom4, Integrator::Midpoint, Integrator::SemiImplicitEuler];

    /// Short name, as the CLI spells it.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::RungeKutta4 => "rk4",
            Integrator::RungeKuttaNystrom4 => "rkn4",
            Integrator::Midpoint => "midpoint",
            Integrator::SemiImplicitEuler => "euler",
        }
    }
}
