//! `chessarm.Simulator`: the closed loop one step at a time, so that a user's own controller
//! runs in chessarm's plant (`step_torque`), or chessarm's controller follows a user's
//! reference (`step`). It takes the steps of the core's closed loop (`sim::closed_loop`) in
//! the same order with the same operations: the plant evaluated at the state, the controller
//! sampled every control period (with the plant's terms when its model is the plant's and the
//! state exact, else through the sensors and the estimator), its torque clipped to the limits
//! and held, the motors' lag, one step of the integrator, the same divergence check.

use crate::common::{self, non_negative, positive, pythonic};
use crate::errors::{DynamicsError, SimulationError};
use crate::setup::PySetup;
use crate::simulate::{Conditions, given_gains, initial_angles, specs};
use chessarm::app::setup::file::Setup;
use chessarm::app::studies::simulate::{DefaultGains, gripped_pawn};
use chessarm::cli::IntegratorChoice;
use chessarm_core::arm::dynamics::DynamicsTerms;
use chessarm_core::arm::mass_matrix::MassMatrixFactor;
use chessarm_core::arm::model::JointVector;
use chessarm_core::control::{Controller, JointState, Reference};
use chessarm_core::sense::Feedback;
use chessarm_core::sim::{Integrator, Plant};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::sync::{Arc, Mutex};

/// `raw` clipped to `±limit` by the closed loop's steps (`f64::clamp`'s, without its check of
/// the bounds), so that a clipped torque is the closed loop's to the bit.
fn limit_torque(raw: f64, limit: f64) -> f64 {
    let mut torque = raw;
    if torque < -limit {
        torque = -limit;
    }
    if torque > limit {
        torque = limit;
    }
    torque
}

/// What a [`Simulator`] steps (behind a mutex: a controller is `Send`, not `Sync`).
#[derive(Debug)]
struct Loop {
    plant: Plant<4>,
    controller: Option<Box<dyn Controller<4>>>,
    /// The sensors and estimator, made afresh from `conditions` at every reset (their noise
    /// then starts over from its seed, as in a run of `simulate`).
    conditions: chessarm_core::sense::Conditions<4>,
    feedback: Feedback<4>,
    exact: bool,
    /// Whether the controller's model is the plant's (it then takes the plant's terms).
    shares_terms: bool,
    dt: f64,
    control_period: f64,
    steps_per_sample: usize,
    integrator: Integrator,
    torque_limits: JointVector<4>,
    runaway_speed: f64,
    lag_decay: JointVector<4>,
    lag_mean: JointVector<4>,
    has_lag: bool,
    step: usize,
    state: JointState<4>,
    estimate: JointState<4>,
    applied_acceleration: JointVector<4>,
    /// The clipped command held until the next sample, and the motors' torque (with a lag).
    command: JointVector<4>,
    motor_torque: JointVector<4>,
    saturated_samples: usize,
    /// Whether the controller was told of the payload gripped now.
    told: bool,
}

impl Loop {
    fn time(&self) -> f64 {
        self.step as f64 * self.dt
    }

    /// One closed-loop step towards `desired` (the model's convention): the torque applied.
    fn step(&mut self, desired: &Reference<4>) -> Result<JointVector<4>, String> {
        let t = self.time();
        let state = self.state;
        let at_state = self.plant.evaluate(&state).map_err(|e| format!("at t = {t:.4} s: {e}"))?;
        if self.step.is_multiple_of(self.steps_per_sample) {
            let controller = self.controller.as_mut().ok_or("the simulator has no controller")?;
            let raw = if self.exact && self.shares_terms {
                self.estimate = state;
                controller.command_with_terms(&state, desired, self.control_period, at_state.terms())
            } else {
                if self.exact {
                    self.estimate = state;
                } else {
                    self.estimate = self.feedback.observe(&state, &self.applied_acceleration);
                }
                controller.command(&self.estimate, desired, self.control_period)
            };
            let mut command = JointVector::<4>::zeros();
            let mut clipped = false;
            for j in 0..4 {
                if !raw[j].is_finite() {
                    return Err(format!(
                        "the simulation diverged at t = {t:.4} s: joint {} torque command = {:.4e} (runaway or NaN); lower the gains or the time step",
                        j + 1,
                        raw[j]
                    ));
                }
                command[j] = limit_torque(raw[j], self.torque_limits[j]);
                clipped |= command[j] != raw[j];
            }
            self.command = command;
            self.saturated_samples += usize::from(clipped);
            if !self.exact {
                // The estimator's input for the coming sample: the controller's own
                // acceleration, or its model's M̂⁻¹(τ − N̂) of a clipped command.
                let controller = self.controller.as_ref().expect("sampled above");
                let commanded = controller.commanded_acceleration().unwrap_or_else(JointVector::zeros);
                self.applied_acceleration = match (clipped, controller.dynamics_model()) {
                    (true, Some(model)) => {
                        let terms = DynamicsTerms::new(model, &self.estimate.q, &self.estimate.qd);
                        MassMatrixFactor::new(&terms.mass_matrix)
                            .map_or(commanded, |factor| factor.solve(&(command - terms.bias)))
                    }
                    _ => commanded,
                };
            }
        }
        let torque = self.lagged(self.command);
        self.advance(&torque)?;
        Ok(torque)
    }

    /// The torque the motors exert over the coming step for the held `command` (their lag's mean
    /// over the step, as the closed loop gives the plant).
    fn lagged(&mut self, command: JointVector<4>) -> JointVector<4> {
        if !self.has_lag {
            return command;
        }
        let gap = self.motor_torque - command;
        self.motor_torque = command + gap.component_mul(&self.lag_decay);
        command + gap.component_mul(&self.lag_mean)
    }

    /// One integrator step with `torque` held, the state checked as the closed loop checks it.
    fn advance(&mut self, torque: &JointVector<4>) -> Result<(), String> {
        let t = self.time();
        let next = self
            .plant
            .step(&self.state, torque, self.dt, self.integrator)
            .map_err(|e| format!("at t = {t:.4} s: {e}"))?;
        for j in 0..4 {
            let (quantity, value) = if !next.q[j].is_finite() {
                ("angle", next.q[j])
            } else if next.qd[j].is_nan() || next.qd[j].abs() > self.runaway_speed {
                ("rate", next.qd[j])
            } else {
                continue;
            };
            return Err(format!(
                "the simulation diverged at t = {:.4} s: joint {} {quantity} = {value:.4e} (runaway or NaN); lower the gains or the time step",
                t + self.dt,
                j + 1
            ));
        }
        self.state = next;
        self.step += 1;
        Ok(())
    }
}

/// The arm's closed loop one step at a time: `step_torque(tau)` applies a torque for one time
/// step in chessarm's plant and integrator (your own controller), `step(q_des, qd_des,
/// qdd_des)` runs chessarm's controller (sampled every control period, clipped, through the
/// sensors and the estimator) towards a reference. Every angle, rate and torque is in the
/// setup's joint convention.
#[pyclass(module = "chessarm")]
#[derive(Debug)]
pub struct Simulator {
    setup: Arc<Setup>,
    inner: Mutex<Loop>,
    /// The controller's name (None: only `step_torque`).
    #[pyo3(get)]
    controller: Option<String>,
}

impl Simulator {
    fn inner(&mut self) -> &mut Loop {
        self.inner.get_mut().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn model(&self, values: [f64; 4]) -> JointVector<4> {
        JointVector::from(self.setup.convention.user(values))
    }

    fn user(&self, values: JointVector<4>) -> [f64; 4] {
        self.setup.convention.user(values)
    }
}

#[pymethods]
impl Simulator {
    /// A simulator of the setup's arm with time step `dt` (s) and `integrator`, the controller
    /// (`pd`, `pid`, `pid-plain`, `adaptive`, `dob`, or None) with `kp`, `kd`, `ki` (the
    /// report's by default), sampled at `control_rate` Hz (every step by default), seeing the
    /// arm through `sensors` and `estimator` (exact by default). At rest at `q0` (zeros by
    /// default) until `reset`.
    #[new]
    #[pyo3(signature = (
        setup, *, dt = 0.001, controller = Some("pd".to_string()), kp = None, kd = None, ki = None,
        control_rate = None, integrator = "rkn4", sensors = None, estimator = None, seed = 0,
        torque_lag = None, plant = None, uncertainty = None, controller_knows_friction = None,
        kalman_acceleration_noise = None, lowpass_time_constant = None, q0 = None
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        setup: &Bound<'_, PySetup>,
        dt: f64,
        controller: Option<String>,
        kp: Option<&Bound<'_, PyAny>>,
        kd: Option<&Bound<'_, PyAny>>,
        ki: Option<&Bound<'_, PyAny>>,
        control_rate: Option<f64>,
        integrator: &str,
        sensors: Option<std::path::PathBuf>,
        estimator: Option<&str>,
        seed: u64,
        torque_lag: Option<&Bound<'_, PyAny>>,
        plant: Option<std::path::PathBuf>,
        uncertainty: Option<std::path::PathBuf>,
        controller_knows_friction: Option<bool>,
        kalman_acceleration_noise: Option<f64>,
        lowpass_time_constant: Option<f64>,
        q0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let setup = setup.get().setup.clone();
        if setup.actuators.take_positions() {
            return Err(PyValueError::new_err(format!(
                "setup: its joints have servos or steppers ({}): the Simulator drives torque motors; chessarm.simulate and chessarm.play simulate servos",
                setup.actuator_names.join(", ")
            )));
        }
        positive("dt", dt)?;
        let control_rate = control_rate.unwrap_or(1.0 / dt);
        crate::simulate::check_rates(dt, control_rate)?;
        let control_period = 1.0 / control_rate;
        let integrator = common::choice::<IntegratorChoice>("integrator", integrator)?.integrator();
        let conditions = Conditions::new(
            sensors,
            estimator,
            seed,
            None,
            torque_lag,
            plant,
            uncertainty,
            controller_knows_friction,
            kalman_acceleration_noise,
            lowpass_time_constant,
        )?;
        let study = conditions.study(&setup, control_period)?;
        let trial = study.trial(conditions.args.run_seed()).map_err(|e| SimulationError::new_err(pythonic(&e)))?;
        let ideal = study.is_ideal(&setup);
        let plant_arm = if ideal { setup.arm } else { trial.plant };
        let plant_model =
            setup.actuators.plant_model(&plant_arm).map_err(|e| SimulationError::new_err(e.to_string()))?;
        let plant = Plant::new(plant_model);
        let (controller, name) = match controller {
            None => (None, None),
            Some(name) => {
                let given = pyo3::types::PyString::new(py, &name).into_any();
                if name == "both" {
                    return Err(PyValueError::new_err("controller=\"both\": the Simulator runs one controller"));
                }
                let spec = specs(
                    &setup,
                    &given,
                    given_gains(kp, kd, ki)?,
                    DefaultGains::Report,
                    conditions.args.knows_friction(&setup),
                    &mut Vec::new(),
                )?
                .remove(0);
                let built = spec
                    .build_for(setup.arm, &setup.actuators)
                    .map_err(|e| PyValueError::new_err(format!("controller={name:?}: {e}")))?;
                (Some(built), Some(spec.name))
            }
        };
        if controller.is_none() && (kp.is_some() || kd.is_some() || ki.is_some()) {
            return Err(PyValueError::new_err("kp, kd and ki are a controller's: give controller= with them"));
        }
        let conditions = if ideal { chessarm_core::sense::Conditions::ideal() } else { trial.conditions };
        let feedback = conditions.feedback(control_period).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let exact = feedback.is_exact();
        let lag = conditions.torque_lag;
        let steps_per_sample = (control_period / dt).round() as usize;
        let shares_terms = controller.as_ref().and_then(|c| c.dynamics_model()) == Some(plant.model());
        let torque_limits = plant.model().torque_limits();
        let mut simulator = Self {
            setup: setup.clone(),
            controller: name,
            inner: Mutex::new(Loop {
                plant,
                controller,
                conditions,
                feedback,
                exact,
                shares_terms,
                dt,
                control_period,
                steps_per_sample,
                integrator,
                torque_limits,
                runaway_speed: 100.0,
                lag_decay: lag.map(|lag| if lag > 0.0 { (-dt / lag).exp() } else { 0.0 }),
                lag_mean: lag.map(|lag| if lag > 0.0 { lag / dt * (1.0 - (-dt / lag).exp()) } else { 0.0 }),
                has_lag: lag.iter().any(|lag| *lag > 0.0),
                step: 0,
                state: JointState::at_rest(JointVector::zeros()),
                estimate: JointState::at_rest(JointVector::zeros()),
                applied_acceleration: JointVector::zeros(),
                command: JointVector::zeros(),
                motor_torque: JointVector::zeros(),
                saturated_samples: 0,
                told: false,
            }),
        };
        let q0 = q0.filter(|q| !q.is_none()).map(|q| initial_angles(py, &setup, "q0", q)).transpose()?;
        simulator.restart(q0.unwrap_or([0.0; 4]), [0.0; 4])?;
        Ok(simulator)
    }

    /// Starts again at `t = 0` from `q` (rad) moving at `qd` (rad/s), at rest at zeros by
    /// default: the controller's integrators, the sensors' delay line and the estimator reset
    /// (as the closed loop resets them before a run); a gripped payload stays gripped.
    #[pyo3(signature = (q = None, qd = None))]
    fn reset(&mut self, py: Python<'_>, q: Option<&Bound<'_, PyAny>>, qd: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        let setup = self.setup.clone();
        let q = q.filter(|q| !q.is_none()).map(|q| initial_angles(py, &setup, "q", q)).transpose()?;
        let qd = qd.filter(|v| !v.is_none()).map(|v| common::numbers::<4>("qd", v)).transpose()?;
        self.restart(q.unwrap_or([0.0; 4]), qd.unwrap_or([0.0; 4]))
    }

    /// Applies `tau` (N·m, per joint) for one time step in the plant (clipped to the torque
    /// limits unless `clip=False`), with the setup's integrator; the controller, sensors and
    /// motor lag are not involved. Returns the torque applied.
    #[pyo3(signature = (tau, *, clip = true))]
    fn step_torque(&mut self, py: Python<'_>, tau: &Bound<'_, PyAny>, clip: bool) -> PyResult<Py<PyAny>> {
        let given = common::numbers::<4>("tau", tau)?;
        let mut torque = self.model(given);
        let inner = self.inner();
        if clip {
            for j in 0..4 {
                torque[j] = limit_torque(torque[j], inner.torque_limits[j]);
            }
        }
        inner.advance(&torque).map_err(SimulationError::new_err)?;
        common::column(py, self.user(torque))
    }

    /// One step of the closed loop towards the reference `q_des` (rad), `qd_des` (rad/s),
    /// `qdd_des` (rad/s², zeros by default): the controller samples if a sample is due (else
    /// its last command is held), its torque clipped to the limits, the motors' lag, one
    /// integrator step. Returns the torque applied over the step, N·m.
    #[pyo3(signature = (q_des, qd_des = None, qdd_des = None))]
    fn step(
        &mut self,
        py: Python<'_>,
        q_des: &Bound<'_, PyAny>,
        qd_des: Option<&Bound<'_, PyAny>>,
        qdd_des: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        if self.controller.is_none() {
            return Err(PyValueError::new_err(
                "step: this simulator has no controller (controller=None): use step_torque(tau)",
            ));
        }
        let reference = Reference {
            q: self.model(common::numbers::<4>("q_des", q_des)?),
            qd: self.model(
                qd_des
                    .filter(|v| !v.is_none())
                    .map(|v| common::numbers::<4>("qd_des", v))
                    .transpose()?
                    .unwrap_or([0.0; 4]),
            ),
            qdd: self.model(
                qdd_des
                    .filter(|v| !v.is_none())
                    .map(|v| common::numbers::<4>("qdd_des", v))
                    .transpose()?
                    .unwrap_or([0.0; 4]),
            ),
        };
        let torque = self.inner().step(&reference).map_err(SimulationError::new_err)?;
        common::column(py, self.user(torque))
    }

    /// Grips a pawn-sized piece of `mass` kg at the tool (the plant takes it; the controller's
    /// model only if `controller_knows`), as `simulate`'s `payload_mass` does at a grip.
    #[pyo3(signature = (mass, *, controller_knows = false))]
    fn grip(&mut self, mass: f64, controller_knows: bool) -> PyResult<()> {
        non_negative("mass", mass)?;
        let payload = (mass > 0.0).then(|| gripped_pawn(&self.setup, mass));
        self.payload(payload, controller_knows)
    }

    /// Releases what the tool holds (the controller is told if it was told of the grip).
    fn release(&mut self) -> PyResult<()> {
        let told = self.inner().told;
        self.payload(None, told)
    }

    /// Time, s.
    #[getter]
    fn t(&mut self) -> f64 {
        self.inner().time()
    }

    /// Steps taken since the start.
    #[getter]
    fn steps(&mut self) -> usize {
        self.inner().step
    }

    /// Time step s and control period s.
    #[getter]
    fn dt(&mut self) -> f64 {
        self.inner().dt
    }

    #[getter]
    fn control_period(&mut self) -> f64 {
        self.inner().control_period
    }

    /// The joint state: (q rad, qd rad/s), each of shape (4,).
    #[getter]
    fn state(&mut self, py: Python<'_>) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        let state = self.inner().state;
        Ok((common::column(py, self.user(state.q))?, common::column(py, self.user(state.qd))?))
    }

    /// Joint angles, rad.
    #[getter]
    fn q(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let q = self.inner().state.q;
        common::column(py, self.user(q))
    }

    /// Joint rates, rad/s.
    #[getter]
    fn qd(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let qd = self.inner().state.qd;
        common::column(py, self.user(qd))
    }

    /// What the controller saw at its latest sample: (q, qd) through the sensors and the
    /// estimator (the state itself with ideal sensors).
    #[getter]
    fn estimate(&mut self, py: Python<'_>) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        let estimate = self.inner().estimate;
        Ok((common::column(py, self.user(estimate.q))?, common::column(py, self.user(estimate.qd))?))
    }

    /// The tool tip now, m: shape (3,).
    #[getter]
    fn tip(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let inner = self.inner();
        let state = inner.state;
        let tip = inner.plant.evaluate(&state).map_err(|e| DynamicsError::new_err(e.to_string()))?.tip();
        common::column(py, tip.iter().copied())
    }

    /// The plant's torque limits, N·m: shape (4,).
    #[getter]
    fn torque_limits(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let limits = self.inner().torque_limits;
        common::column(py, limits.iter().copied())
    }

    /// Controller samples whose torque was clipped since the start.
    #[getter]
    fn saturated_samples(&mut self) -> usize {
        self.inner().saturated_samples
    }

    fn __repr__(&mut self) -> String {
        let controller = self.controller.clone().unwrap_or_else(|| "none".into());
        let inner = self.inner();
        format!(
            "Simulator(controller={controller:?}, dt={} s, control period {} s, t={:.4} s)",
            inner.dt,
            inner.control_period,
            inner.time()
        )
    }
}

impl Simulator {
    /// At rest or moving at `(q, qd)` (the user's convention) at `t = 0`, everything reset.
    fn restart(&mut self, q: [f64; 4], qd: [f64; 4]) -> PyResult<()> {
        let state = JointState { q: self.model(q), qd: self.model(qd) };
        let inner = self.inner();
        inner.feedback =
            inner.conditions.feedback(inner.control_period).map_err(|e| PyValueError::new_err(e.to_string()))?;
        inner.state = state;
        inner.estimate = state;
        inner.step = 0;
        inner.command = JointVector::zeros();
        inner.motor_torque = JointVector::zeros();
        inner.applied_acceleration = JointVector::zeros();
        inner.saturated_samples = 0;
        if let Some(controller) = inner.controller.as_mut() {
            controller.reset();
        }
        inner.feedback.reset(&state);
        Ok(())
    }

    /// The plant takes `payload`; the controller's model too if `told`; the controller hears
    /// the gripper (as at a closed loop's payload event).
    fn payload(&mut self, payload: Option<chessarm_core::arm::model::Payload>, told: bool) -> PyResult<()> {
        let inner = self.inner();
        inner.plant.set_payload(payload).map_err(|e| PyValueError::new_err(e.to_string()))?;
        if let Some(controller) = inner.controller.as_mut() {
            if told {
                controller.set_payload(payload).map_err(|e| PyValueError::new_err(e.to_string()))?;
            }
            controller.gripper_changed(payload.is_some());
        }
        inner.told = told && payload.is_some();
        inner.shares_terms = inner.controller.as_ref().and_then(|c| c.dynamics_model()) == Some(inner.plant.model());
        Ok(())
    }
}
