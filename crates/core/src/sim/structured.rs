//! The integrators of [`super::plant`] on the structured dynamics of
//! [`crate::arm::yaw_pitch`], written once over [`Real`]: a single run steps with `S = f64`
//! ([`super::Plant`]), a batch with `S = Lanes<L>` ([`super::batch`]), the same operations in the
//! same order, so each lane's step equals the scalar step bit for bit.

use crate::arm::yaw_pitch::{Angles, Configuration, YawPitch};
use crate::lanes::Real;
use crate::sim::plant::Integrator;

/// A joint state of one run or of `L`: angles (rad) and rates (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State<S> {
    pub q: [S; 4],
    pub qd: [S; 4],
}

/// The dynamics at a step's starting state: the configuration and `C q̇ + g` there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Start<S> {
    pub configuration: Configuration<S>,
    pub bias: [S; 4],
}

impl<S: Real> Start<S> {
    #[inline(always)]
    pub fn new(model: &YawPitch<S>, state: &State<S>) -> Self {
        let configuration = Configuration::new(model, Angles::new(model, &state.q));
        let bias = configuration.bias(model, &state.qd);
        Self { configuration, bias }
    }
}

/// Lanes whose mass matrix failed to factorise at a stage, with the configuration (rad) of the
/// first such stage: bit `i` of `lanes` for lane `i`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Failures<const L: usize> {
    pub lanes: u64,
    pub at: [[f64; 4]; L],
}

#[inline(always)]
fn axpy<S: Real>(x: &[S; 4], a: &[S; 4], h: f64) -> [S; 4] {
    let h = S::splat(h);
    std::array::from_fn(|j| x[j] + a[j] * h)
}

#[inline(always)]
fn difference<S: Real>(a: &[S; 4], b: &[S; 4]) -> [S; 4] {
    std::array::from_fn(|j| a[j] - b[j])
}

/// The configuration at `at` (rad) inside the step, its angles moved from the start's.
#[inline(always)]
fn stage<S: Real, const L: usize>(
    model: &YawPitch<S>,
    start: &Configuration<S>,
    q: &[S; 4],
    at: &[S; 4],
    failures: &mut Failures<L>,
) -> Configuration<S> {
    let configuration = Configuration::new(model, start.angles.shifted(model, &difference(at, q)));
    for lane in 0..S::LANES {
        if failures.lanes & (1 << lane) == 0 && !configuration.factor.positive_definite(lane) {
            failures.lanes |= 1 << lane;
            failures.at[lane] = at.map(|v| v.lane(lane));
        }
    }
    configuration
}

/// One step of `dt` seconds from `state` with `torque` held, by `integrator`, from the
/// dynamics at the start (`start`, computed at `state`). The formulas are [`Integrator`]'s;
/// `L` is the number of lanes of `S` (1 for `f64`).
#[inline(always)]
pub fn step<S: Real, const L: usize>(
    model: &YawPitch<S>,
    start: &Start<S>,
    state: &State<S>,
    torque: &[S; 4],
    dt: f64,
    integrator: Integrator,
    failures: &mut Failures<L>,
) -> State<S> {
    let (q, qd) = (&state.q, &state.qd);
    let q1dd = start.configuration.acceleration_with_bias(model, qd, torque, &start.bias);
    let c = S::splat;
    match integrator {
        Integrator::RungeKutta4 => {
            let s2 = State { q: axpy(q, qd, dt / 2.0), qd: axpy(qd, &q1dd, dt / 2.0) };
            let middle = stage(model, &start.configuration, q, &s2.q, failures);
            let q2dd = middle.acceleration(model, &s2.qd, torque);
            let s3 = State { q: axpy(q, &s2.qd, dt / 2.0), qd: axpy(qd, &q2dd, dt / 2.0) };
            let middle = stage(model, &start.configuration, q, &s3.q, failures);
            let q3dd = middle.acceleration(model, &s3.qd, torque);
            let s4 = State { q: axpy(q, &s3.qd, dt), qd: axpy(qd, &q3dd, dt) };
            let end = stage(model, &start.configuration, q, &s4.q, failures);
            let q4dd = end.acceleration(model, &s4.qd, torque);
            let sixth = c(dt / 6.0);
            State {
                q: std::array::from_fn(|j| q[j] + (qd[j] + s2.qd[j] * c(2.0) + s3.qd[j] * c(2.0) + s4.qd[j]) * sixth),
                qd: std::array::from_fn(|j| qd[j] + (q1dd[j] + q2dd[j] * c(2.0) + q3dd[j] * c(2.0) + q4dd[j]) * sixth),
            }
        }
        Integrator::RungeKuttaNystrom4 => {
            let at = axpy(&axpy(q, qd, dt / 2.0), &q1dd, dt * dt / 8.0);
            let middle = stage(model, &start.configuration, q, &at, failures);
            let q2dd = middle.acceleration(model, &axpy(qd, &q1dd, dt / 2.0), torque);
            let q3dd = middle.acceleration(model, &axpy(qd, &q2dd, dt / 2.0), torque);
            let at = axpy(&axpy(q, qd, dt), &q3dd, dt * dt / 2.0);
            let end = stage(model, &start.configuration, q, &at, failures);
            let q4dd = end.acceleration(model, &axpy(qd, &q3dd, dt), torque);
            let (h, h2) = (c(dt), c(dt * dt / 6.0));
            let sixth = c(dt / 6.0);
            State {
                q: std::array::from_fn(|j| q[j] + qd[j] * h + (q1dd[j] + q2dd[j] + q3dd[j]) * h2),
                qd: std::array::from_fn(|j| qd[j] + (q1dd[j] + q2dd[j] * c(2.0) + q3dd[j] * c(2.0) + q4dd[j]) * sixth),
            }
        }
        Integrator::Midpoint => {
            let halfway = State { q: axpy(q, qd, dt / 2.0), qd: axpy(qd, &q1dd, dt / 2.0) };
            let middle = stage(model, &start.configuration, q, &halfway.q, failures);
            let halfway_qdd = middle.acceleration(model, &halfway.qd, torque);
            State { q: axpy(q, &halfway.qd, dt), qd: axpy(qd, &halfway_qdd, dt) }
        }
        Integrator::SemiImplicitEuler => {
            let qd = axpy(qd, &q1dd, dt);
            State { q: axpy(q, &qd, dt), qd }
        }
    }
}
