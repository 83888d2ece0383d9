//! The simulated arm: true dynamics (the plant's own model, with payload and friction) and
//! fixed-step integrators of `ẋ = (q̇, q̈(q, q̇, τ))` (Nyström's fourth-order Runge–Kutta by
//! default).

use super::integrator::Integrator;
use crate::arm::dynamics::{ConfigurationDynamics, DynamicsError, DynamicsTerms, from_array, from_rows, to_array};
use crate::arm::kinematics::JointTrig;
use crate::arm::mass_matrix::MassMatrix;
use crate::arm::model::{ArmModel, JointVector, ModelError, Payload};
use crate::control::JointState;
use crate::lanes::SimdLevel;
use crate::sim::structured::{self, Failures, Start, State};
use nalgebra::Vector3;

/// The physical arm being simulated: its model (with the gripped payload) and the scratch its
/// integrators fill in place every step (frames, mass matrices and their factors or inverses
/// at the step's start and at its stage configurations), so a step allocates and moves
/// nothing large.
///
/// An arm of the yaw–pitch family steps on the structured dynamics
/// ([`crate::arm::yaw_pitch`], [`super::structured`]), compiled for the simulations' SIMD level
/// ([`SimdLevel::for_one_run`]; [`Plant::with_simd_level`] picks another; the results are the
/// same bits at every level); any other arm on the general recursive algorithms.
#[derive(Debug, Clone)]
pub struct Plant<const N: usize> {
    model: ArmModel<N>,
    /// The dynamics at the start of the step; valid for `evaluated_at`.
    start: StateDynamics<N>,
    /// The state `start` holds, `None` when stale (never evaluated, or the payload changed).
    evaluated_at: Option<JointState<N>>,
    /// The general path's configuration at the start and at the stage configurations inside
    /// the step (the middle one of Nyström's method, the end).
    general_start: ConfigurationDynamics<N>,
    middle: ConfigurationDynamics<N>,
    end: ConfigurationDynamics<N>,
    /// The structured path's dynamics at the start, valid with `evaluated_at` when the model
    /// has the structure.
    structured_start: Option<Start<f64>>,
    /// The instructions the structured path's kernels run with.
    simd: SimdLevel,
}

impl<const N: usize> Plant<N> {
    pub fn new(model: ArmModel<N>) -> Self {
        // Placeholders until the first evaluation; `evaluated_at = None` marks them stale.
        let configuration = ConfigurationDynamics::placeholder(&model);
        Self {
            model,
            start: StateDynamics {
                tip: Vector3::zeros(),
                terms: DynamicsTerms { mass_matrix: MassMatrix::identity(), bias: JointVector::zeros() },
            },
            evaluated_at: None,
            general_start: configuration.clone(),
            middle: configuration.clone(),
            end: configuration,
            structured_start: None,
            simd: SimdLevel::for_one_run(),
        }
    }

    /// The same plant with the structured path's kernels run at `level` (the baseline's where
    /// the CPU lacks it): for comparing the levels, which give the same results.
    pub fn with_simd_level(mut self, level: SimdLevel) -> Self {
        self.simd = level;
        self
    }

    pub fn simd_level(&self) -> SimdLevel {
        self.simd
    }

    pub fn model(&self) -> &ArmModel<N> {
        &self.model
    }

    /// Grips (`Some`) or releases (`None`) a payload at the tool.
    pub fn set_payload(&mut self, payload: Option<Payload>) -> Result<(), ModelError> {
        self.model = self.model.with_payload(payload)?;
        self.evaluated_at = None;
        Ok(())
    }

    /// The plant's kinematics, mass matrix (factorised or inverted) and bias torques at
    /// `state`: the first stage of every integrator, and what a controller with the same model
    /// needs. Kept for the [`Plant::step`] from `state` that follows.
    pub fn evaluate(&mut self, state: &JointState<N>) -> Result<&StateDynamics<N>, DynamicsError> {
        if self.evaluated_at != Some(*state) {
            self.evaluated_at = None;
            if let Some(fast) = self.model.yaw_pitch() {
                // Converted inside the level's function where the scratch exists (as in
                // `step`); the first evaluation converts outside it.
                let here = || State { q: to_array(&state.q), qd: to_array(&state.qd) };
                let simd = self.simd;
                // Whether `M` is positive definite, tested inside the level's function: read
                // back outside it, the minors (stored one by one) stalled the wider loads.
                let (start, positive_definite) = match &mut self.structured_start {
                    Some(start) => {
                        // `inline(always)`: compiled inside the level's function, with its
                        // instructions.
                        let positive_definite = simd.run(
                            #[inline(always)]
                            || start.set(fast, &here()) == 0,
                        );
                        (start, positive_definite)
                    }
                    // The first evaluation fills the scratch (the same bits at any level).
                    None => {
                        let start = self.structured_start.insert(Start::new(fast, &here()));
                        let positive_definite = start.configuration.inverse.positive_definite(0);
                        (start, positive_definite)
                    }
                };
                if !positive_definite {
                    return Err(DynamicsError::NotPositiveDefinite(state.q.iter().copied().collect()));
                }
                self.start = StateDynamics {
                    tip: Vector3::from(start.configuration.tip_in_base(&fast.base)),
                    terms: DynamicsTerms {
                        mass_matrix: from_rows(&start.configuration.mass_matrix),
                        bias: from_array(start.bias),
                    },
                };
            } else {
                let general = &mut self.general_start;
                general.set_configuration(&self.model, &state.q, JointTrig::new(&self.model, &state.q))?;
                self.start = StateDynamics {
                    tip: general.tip(),
                    terms: DynamicsTerms {
                        mass_matrix: *general.mass_matrix(),
                        bias: general.bias(&self.model, &state.qd),
                    },
                };
            }
            self.evaluated_at = Some(*state);
        }
        Ok(&self.start)
    }

    /// The dynamics the latest successful [`Plant::evaluate`] computed: to read after calling
    /// it (before any, placeholders: `M = I`, zero bias and tip; after a failed one or a
    /// payload change, the previous state's).
    pub fn evaluated(&self) -> &StateDynamics<N> {
        &self.start
    }

    /// One classical RK4 step of `dt` seconds with `torque` held constant (zero-order hold).
    pub fn rk4_step(
        &mut self,
        state: &JointState<N>,
        torque: &JointVector<N>,
        dt: f64,
    ) -> Result<JointState<N>, DynamicsError> {
        self.step(state, torque, dt, Integrator::RungeKutta4)
    }

    /// One step of `dt` seconds from `state` with `torque` held constant, by `integrator`.
    /// The first stage is [`Plant::evaluate`] at `state`, reused when the caller has just
    /// evaluated it (the closed loop needs the tool tip and the controller's terms anyway).
    /// Later stages reuse the start's sines and cosines by angle addition
    /// ([`JointTrig::shifted`]).
    pub fn step(
        &mut self,
        state: &JointState<N>,
        torque: &JointVector<N>,
        dt: f64,
        integrator: Integrator,
    ) -> Result<JointState<N>, DynamicsError> {
        self.step_with(state, |_, _| *torque, dt, integrator)
    }

    /// [`Plant::step`] with the torque a function of the state, `torque(q, q̇)` (N·m), evaluated
    /// at every stage of the integrator: for an actuator whose torque follows the joint within
    /// the step (a stepper's magnetic spring).
    #[inline(always)]
    pub fn step_with(
        &mut self,
        state: &JointState<N>,
        torque: impl Fn(&JointVector<N>, &JointVector<N>) -> JointVector<N>,
        dt: f64,
        integrator: Integrator,
    ) -> Result<JointState<N>, DynamicsError> {
        self.evaluate(state)?;
        if let (Some(fast), Some(start)) = (self.model.yaw_pitch(), self.structured_start.as_mut()) {
            let mut failures = Failures::<1> { lanes: 0, at: [[0.0; 4]] };
            // The state and torque converted inside the level's function: one run 3.25 → 3.09 ms
            // (fastest of 300, back to back). Converted before it, the profile put the time at
            // the first wide loads of them, right after their narrower stores (a store that
            // cannot forward, the probable cause).
            let next = self.simd.run(
                #[inline(always)]
                || {
                    let here = State { q: to_array(&state.q), qd: to_array(&state.qd) };
                    structured::step_with(
                        fast,
                        start,
                        &here,
                        #[inline(always)]
                        |q: &[f64; 4], qd: &[f64; 4]| to_array(&torque(&from_array(*q), &from_array(*qd))),
                        dt,
                        integrator,
                        &mut failures,
                    )
                },
            );
            if failures.lanes != 0 {
                return Err(DynamicsError::NotPositiveDefinite(failures.at[0].to_vec()));
            }
            return Ok(JointState { q: from_array(next.q), qd: from_array(next.qd) });
        }
        let Self { model, start, general_start, middle, end, .. } = self;
        let model = &*model;
        let (q, qd) = (&state.q, &state.qd);
        let start_trig = *general_start.trig();
        let q1dd = general_start.acceleration_with_bias(model, qd, &torque(q, qd), &start.terms.bias);
        // The dynamics at configuration `at` (rad) inside the step, filled into `scratch`.
        let move_to = |scratch: &mut ConfigurationDynamics<N>, at: &JointVector<N>| {
            scratch.set_configuration(model, at, start_trig.shifted(&(at - q)))
        };
        Ok(match integrator {
            Integrator::RungeKutta4 => {
                let stage = |qd_k: &JointVector<N>, qdd_k: &JointVector<N>, h: f64| JointState {
                    q: q + qd_k * h,
                    qd: qd + qdd_k * h,
                };
                let s2 = stage(qd, &q1dd, dt / 2.0);
                move_to(middle, &s2.q)?;
                let q2dd = middle.acceleration(model, &s2.qd, &torque(&s2.q, &s2.qd));
                let s3 = stage(&s2.qd, &q2dd, dt / 2.0);
                move_to(middle, &s3.q)?;
                let q3dd = middle.acceleration(model, &s3.qd, &torque(&s3.q, &s3.qd));
                let s4 = stage(&s3.qd, &q3dd, dt);
                move_to(end, &s4.q)?;
                let q4dd = end.acceleration(model, &s4.qd, &torque(&s4.q, &s4.qd));
                JointState {
                    q: q + (qd + s2.qd * 2.0 + s3.qd * 2.0 + s4.qd) * (dt / 6.0),
                    qd: qd + (q1dd + q2dd * 2.0 + q3dd * 2.0 + q4dd) * (dt / 6.0),
                }
            }
            Integrator::RungeKuttaNystrom4 => {
                // Stages 2 and 3 share the configuration q + dt/2 q̇ + dt²/8 q̈₁.
                let middle_q = q + qd * (dt / 2.0) + q1dd * (dt * dt / 8.0);
                move_to(middle, &middle_q)?;
                let rate2 = qd + q1dd * (dt / 2.0);
                let q2dd = middle.acceleration(model, &rate2, &torque(&middle_q, &rate2));
                let rate3 = qd + q2dd * (dt / 2.0);
                let q3dd = middle.acceleration(model, &rate3, &torque(&middle_q, &rate3));
                let end_q = q + qd * dt + q3dd * (dt * dt / 2.0);
                move_to(end, &end_q)?;
                let rate4 = qd + q3dd * dt;
                let q4dd = end.acceleration(model, &rate4, &torque(&end_q, &rate4));
                JointState {
                    q: q + qd * dt + (q1dd + q2dd + q3dd) * (dt * dt / 6.0),
                    qd: qd + (q1dd + q2dd * 2.0 + q3dd * 2.0 + q4dd) * (dt / 6.0),
                }
            }
            Integrator::Midpoint => {
                let halfway = JointState { q: q + qd * (dt / 2.0), qd: qd + q1dd * (dt / 2.0) };
                move_to(middle, &halfway.q)?;
                let halfway_qdd = middle.acceleration(model, &halfway.qd, &torque(&halfway.q, &halfway.qd));
                JointState { q: q + halfway.qd * dt, qd: qd + halfway_qdd * dt }
            }
            Integrator::SemiImplicitEuler => {
                let qd = qd + q1dd * dt;
                JointState { q: q + qd * dt, qd }
            }
        })
    }
}

/// The plant's kinematics and dynamics at one state ([`Plant::evaluate`]).
#[derive(Debug, Clone)]
pub struct StateDynamics<const N: usize> {
    tip: Vector3<f64>,
    /// `M(q)` and `C(q, q̇) q̇ + g(q)`.
    terms: DynamicsTerms<N>,
}

impl<const N: usize> StateDynamics<N> {
    /// The tool tip at the state's configuration, m (base frame).
    pub fn tip(&self) -> Vector3<f64> {
        self.tip
    }

    /// `M(q)` of the plant's model, kg·m².
    pub fn mass_matrix(&self) -> &MassMatrix<N> {
        &self.terms.mass_matrix
    }

    /// `C(q, q̇) q̇ + g(q)` of the plant's model, N·m.
    pub fn bias(&self) -> &JointVector<N> {
        &self.terms.bias
    }

    /// `M(q)` and `C(q, q̇) q̇ + g(q)`, as a controller with the plant's model computes them.
    pub fn terms(&self) -> &DynamicsTerms<N> {
        &self.terms
    }
}
