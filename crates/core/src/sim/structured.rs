//! The integrators of [`super::plant`] on the structured dynamics of
//! [`crate::arm::yaw_pitch`], written once over [`Real`]: a single run steps with `S = f64`
//! ([`super::Plant`]), a batch with `S = Lanes<L>` ([`super::batch`]), the same operations in the
//! same order, so each lane's step equals the scalar step bit for bit.

use crate::arm::yaw_pitch::{Angles, Configuration, YawPitch};
use crate::lanes::{Real, array4};
use crate::sim::integrator::Integrator;

/// A joint state of one run or of `L`: angles (rad) and rates (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State<S> {
    pub q: [S; 4],
    pub qd: [S; 4],
}

/// The dynamics at a step's starting state, and the scratch of the stages inside the step,
/// refilled in place every step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Start<S> {
    pub configuration: Configuration<S>,
    /// `C q̇ + g` at the start.
    pub bias: [S; 4],
    /// The stage configurations (the middle one, the end).
    middle: Configuration<S>,
    end: Configuration<S>,
}

impl<S: Real> Start<S> {
    #[inline(always)]
    pub fn new(model: &YawPitch<S>, state: &State<S>) -> Self {
        let configuration = Configuration::new(model, Angles::new(model, &state.q));
        let bias = configuration.bias(model, &state.qd);
        Self { configuration, bias, middle: configuration, end: configuration }
    }

    /// [`Start::new`] in place. Returns the lanes whose `M` is not positive definite
    /// ([`crate::arm::yaw_pitch::Inverse::set`]).
    #[inline(always)]
    pub fn set(&mut self, model: &YawPitch<S>, state: &State<S>) -> u64 {
        self.configuration.angles.set(model, &state.q);
        let failed = self.configuration.refresh(model);
        self.bias = self.configuration.bias(model, &state.qd);
        failed
    }

    /// [`Start::set`] without the inverse of `M` (left as it was): `M` and the bias alone, for
    /// a controller's terms; not a start to [`step`] from.
    #[inline(always)]
    pub fn set_terms(&mut self, model: &YawPitch<S>, state: &State<S>) {
        self.configuration.angles.set(model, &state.q);
        self.configuration.refresh_mass_matrix(model);
        self.bias = self.configuration.bias(model, &state.qd);
    }
}

/// Lanes whose mass matrix was not positive definite at a stage, with the configuration (rad) of the
/// first such stage: bit `i` of `lanes` for lane `i`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Failures<const L: usize> {
    pub lanes: u64,
    pub at: [[f64; 4]; L],
}

#[inline(always)]
fn axpy<S: Real>(x: &[S; 4], a: &[S; 4], h: f64) -> [S; 4] {
    let h = S::splat(h);
    array4(|j| x[j] + a[j] * h)
}

#[inline(always)]
fn difference<S: Real>(a: &[S; 4], b: &[S; 4]) -> [S; 4] {
    array4(|j| a[j] - b[j])
}

/// Fills `scratch` with the configuration at `at` (rad) inside the step, its angles moved from
/// the start's.
#[inline(always)]
fn stage<S: Real, const L: usize>(
    model: &YawPitch<S>,
    start: &Configuration<S>,
    scratch: &mut Configuration<S>,
    q: &[S; 4],
    at: &[S; 4],
    failures: &mut Failures<L>,
) {
    start.angles.shift_into(model, &difference(at, q), &mut scratch.angles);
    let new = scratch.refresh(model) & !failures.lanes;
    if new != 0 {
        for lane in (0..S::LANES).filter(|lane| new & (1 << lane) != 0) {
            failures.at[lane] = at.map(|v| v.lane(lane));
        }
        failures.lanes |= new;
    }
}

/// `stage(k)` for `k` in `1..=stages`, written out three times where `unrolled` (`stages` is
/// then 3): `stage` is inlined at each call, compiled with its `k` known. (`stage` must be an
/// `#[inline(always)]` closure: a plain one was compiled on its own, for the baseline's
/// instructions.)
#[inline(always)]
fn each_stage(stages: usize, unrolled: bool, mut stage: impl FnMut(usize)) {
    if unrolled {
        stage(1);
        stage(2);
        stage(3);
    } else {
        for k in 1..=stages {
            stage(k);
        }
    }
}

/// One step of `dt` seconds from `state` with `torque` held, by `integrator`, from the
/// dynamics at the start (`start`, computed at `state`). The formulas are [`Integrator`]'s;
/// `L` is the number of lanes of `S` (1 for `f64`).
#[inline(always)]
pub fn step<S: Real, const L: usize>(
    model: &YawPitch<S>,
    start: &mut Start<S>,
    state: &State<S>,
    torque: &[S; 4],
    dt: f64,
    integrator: Integrator,
    failures: &mut Failures<L>,
) -> State<S> {
    step_with(
        model,
        start,
        state,
        #[inline(always)]
        |_: &[S; 4], _: &[S; 4]| *torque,
        dt,
        integrator,
        failures,
    )
}

/// [`step`] with the torque a function of the state, `torque(q, q̇)`, evaluated at every stage
/// (a stepper's stiff magnetic spring, which a torque held over the step would excite).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn step_with<S: Real, const L: usize>(
    model: &YawPitch<S>,
    start: &mut Start<S>,
    state: &State<S>,
    torque: impl Fn(&[S; 4], &[S; 4]) -> [S; 4],
    dt: f64,
    integrator: Integrator,
    failures: &mut Failures<L>,
) -> State<S> {
    let (q, qd) = (&state.q, &state.qd);
    let Start { configuration: first, bias, middle, end } = start;
    let (first, bias) = (&*first, &*bias);
    let c = S::splat;
    // A batch's stages after the first in one loop, so that the configuration and acceleration
    // are compiled once (they are most of the code, and it is compiled for every SIMD level
    // and lane count).
    let stages = match integrator {
        Integrator::RungeKutta4 | Integrator::RungeKuttaNystrom4 => 3,
        Integrator::Midpoint => 1,
        Integrator::SemiImplicitEuler => 0,
    };
    // Stage k's acceleration and rate (rad/s², rad/s); stage 0 is the start.
    let mut qdd = [first.acceleration_with_bias(model, qd, &torque(q, qd), bias); 4];
    let mut rates = [*qd; 4];
    // The configuration of the latest stage (Nyström's second stage keeps the first's).
    let mut stage_q = *q;
    // One run's Nyström stages unrolled instead, each compiled with its `k` known: the seed
    // scenario 3.95 → 3.45 ms, fastest of 300 back to back. The loop's profile had its time at
    // the next stage's wide loads of `qdd[k]`, stored entry by entry just before; the unrolled
    // stages still share these arrays (arrays of their own were 1.5–4 % slower), so why the
    // unrolling helps is measured, not pinned down.
    let unrolled = S::LANES == 1 && integrator == Integrator::RungeKuttaNystrom4;
    each_stage(
        stages,
        unrolled,
        #[inline(always)]
        |k: usize| {
            // Where stage k evaluates: its configuration (none: the previous stage's), its rate,
            // and whether its configuration is the step's end.
            let (at, rate, at_end) = match integrator {
                Integrator::RungeKutta4 => {
                    let h = if k == 3 { dt } else { dt / 2.0 };
                    (Some(axpy(q, &rates[k - 1], h)), axpy(qd, &qdd[k - 1], h), k == 3)
                }
                Integrator::RungeKuttaNystrom4 => match k {
                    1 => {
                        (Some(axpy(&axpy(q, qd, dt / 2.0), &qdd[0], dt * dt / 8.0)), axpy(qd, &qdd[0], dt / 2.0), false)
                    }
                    2 => (None, axpy(qd, &qdd[1], dt / 2.0), false),
                    _ => (Some(axpy(&axpy(q, qd, dt), &qdd[2], dt * dt / 2.0)), axpy(qd, &qdd[2], dt), true),
                },
                Integrator::Midpoint | Integrator::SemiImplicitEuler => {
                    (Some(axpy(q, qd, dt / 2.0)), axpy(qd, &qdd[0], dt / 2.0), false)
                }
            };
            let configuration = if at_end { &mut *end } else { &mut *middle };
            if let Some(at) = at {
                stage(model, first, configuration, q, &at, failures);
                stage_q = at;
            }
            qdd[k] = configuration.acceleration(model, &rate, &torque(&stage_q, &rate));
            rates[k] = rate;
        },
    );
    let sixth = c(dt / 6.0);
    match integrator {
        Integrator::RungeKutta4 => State {
            q: array4(|j| q[j] + (qd[j] + rates[1][j] * c(2.0) + rates[2][j] * c(2.0) + rates[3][j]) * sixth),
            qd: array4(|j| qd[j] + (qdd[0][j] + qdd[1][j] * c(2.0) + qdd[2][j] * c(2.0) + qdd[3][j]) * sixth),
        },
        Integrator::RungeKuttaNystrom4 => {
            let (h, h2) = (c(dt), c(dt * dt / 6.0));
            State {
                q: array4(|j| q[j] + qd[j] * h + (qdd[0][j] + qdd[1][j] + qdd[2][j]) * h2),
                qd: array4(|j| qd[j] + (qdd[0][j] + qdd[1][j] * c(2.0) + qdd[2][j] * c(2.0) + qdd[3][j]) * sixth),
            }
        }
        Integrator::Midpoint => State { q: axpy(q, &rates[1], dt), qd: axpy(qd, &qdd[1], dt) },
        Integrator::SemiImplicitEuler => {
            let qd = axpy(qd, &qdd[0], dt);
            State { q: axpy(q, &qd, dt), qd }
        }
    }
}
