//! `chessarm.simulate(setup, …)` in memory: each controller along a scenario's plan in the
//! setup's plant (`app::studies::simulate`), every step kept as NumPy arrays, with the metrics.

use crate::common;
use crate::common::{bad_value, column, non_negative, optional_per_joint, positive, pythonic, rows};
use crate::errors::SimulationError;
use crate::plan::{Plan, Planned, check_scenario};
use crate::setup::PySetup;
use chessarm::app::resources::show;
use chessarm::app::setup::conditions::{ConditionOptions, EstimatorChoice, Study};
use chessarm::app::setup::file::Setup;
use chessarm::app::studies::plan::{Plan as ScenarioPlan, plan_scenario};
use chessarm::app::studies::simulate::{
    ControllerName, ControllerRun, DefaultGains, GivenGains, RunOptions, controller_specs, ensure_tracked,
    placement_error, run_controller,
};
use chessarm::cli::IntegratorChoice;
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::sim::StepRecord;
use pyo3::exceptions::{PyAttributeError, PyMemoryError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;

/// The sensors, estimator and model errors of a study as Python gives them, as the command
/// line's `ConditionOptions`.
#[derive(Debug, Default)]
pub struct Conditions {
    pub args: ConditionOptions,
}

impl Conditions {
    /// `controller_knows_friction`: `None` is the command line's default (yes with a URDF).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        sensors: Option<PathBuf>,
        estimator: Option<&str>,
        seed: u64,
        trial_seed: Option<u64>,
        torque_lag: Option<&Bound<'_, PyAny>>,
        plant: Option<PathBuf>,
        uncertainty: Option<PathBuf>,
        controller_knows_friction: Option<bool>,
        kalman_acceleration_noise: Option<f64>,
        lowpass_time_constant: Option<f64>,
    ) -> PyResult<Self> {
        let estimator = estimator.map(|e| common::choice::<EstimatorChoice>("estimator", e)).transpose()?;
        if let Some(noise) = kalman_acceleration_noise {
            positive("kalman_acceleration_noise", noise)?;
        }
        if let Some(time) = lowpass_time_constant {
            non_negative("lowpass_time_constant", time)?;
        }
        Ok(Self {
            args: ConditionOptions {
                sensors: sensors.map(|s| s.to_string_lossy().into_owned()),
                estimator,
                kalman_acceleration_noise,
                lowpass_time_constant,
                torque_lag: optional_per_joint("torque_lag", torque_lag)?,
                controller_knows_friction: controller_knows_friction == Some(true),
                controller_ignores_friction: controller_knows_friction == Some(false),
                plant,
                uncertainty,
                seed,
                trial_seed,
            },
        })
    }

    /// The study the conditions describe for `setup`, its errors in Python's words (they are
    /// about the arguments: a profile, an estimator, a file).
    pub fn study(&self, setup: &Setup, control_period: f64) -> PyResult<Study> {
        Study::new(setup, &self.args, control_period).map_err(|e| PyValueError::new_err(pythonic(&e)))
    }
}

/// The controllers a study asks for: with servos, the setup's host strategies (as the command
/// line's, `servos::servo_hosts`, its note in `notes`); else the named ones with the given
/// gains, `defaults` filling the rest.
pub fn specs(
    setup: &Setup,
    controller: &Bound<'_, PyAny>,
    gains: GivenGains,
    defaults: DefaultGains,
    knows_friction: bool,
    notes: &mut Vec<String>,
) -> PyResult<Vec<ControllerSpec>> {
    let mut specs = match chessarm::app::setup::servos::servo_hosts(setup) {
        Some((hosts, note)) => {
            notes.push(common::flags_as_arguments(note.trim_end()));
            hosts
        }
        None => {
            let names = common::names("controller", controller)?
                .iter()
                .map(|name| common::choice::<ControllerName>("controller", name))
                .collect::<PyResult<Vec<_>>>()?;
            controller_specs(&names, &gains, defaults).map_err(|e| PyValueError::new_err(pythonic(&e)))?
        }
    };
    for spec in &mut specs {
        spec.knows_friction = knows_friction;
    }
    Ok(specs)
}

/// The gains given (`kp`, `kd`, `ki`: one number for every joint or four).
pub fn given_gains(
    kp: Option<&Bound<'_, PyAny>>,
    kd: Option<&Bound<'_, PyAny>>,
    ki: Option<&Bound<'_, PyAny>>,
) -> PyResult<GivenGains> {
    Ok(GivenGains {
        kp: optional_per_joint("kp", kp)?,
        kd: optional_per_joint("kd", kd)?,
        ki: optional_per_joint("ki", ki)?,
    })
}

/// Refuses a control rate whose period is not a whole number of time steps (as `simulate`'s
/// `--control-rate` and `--dt`).
pub fn check_rates(dt: f64, control_rate: f64) -> PyResult<()> {
    positive("dt", dt)?;
    positive("control_rate", control_rate)?;
    let period = 1.0 / control_rate;
    if !period.is_finite() {
        return Err(PyValueError::new_err(format!(
            "control_rate={control_rate}: its sample period 1/{control_rate} s is not a finite number"
        )));
    }
    let ratio = period / dt;
    if ratio.round() < 1.0 || (ratio - ratio.round()).abs() > 1e-9 * ratio {
        return Err(PyValueError::new_err(format!(
            "control_rate={} Hz (a sample every {} s) must be a whole multiple of the time step dt={} s: the controller samples every k-th step (e.g. control_rate={} for k = 1)",
            show(control_rate),
            show(period),
            show(dt),
            show(1.0 / dt)
        )));
    }
    Ok(())
}

/// Joint angles `q0` (rad, the user's convention): finite, sines accurate; a warning for each
/// outside its joint's limits (often degrees typed for radians).
pub fn initial_angles(py: Python<'_>, setup: &Setup, name: &str, q0: &Bound<'_, PyAny>) -> PyResult<[f64; 4]> {
    let q = common::numbers::<4>(name, q0)?;
    let limit = chessarm_core::lanes::SIN_COS_LIMIT;
    if q.iter().any(|v| v.abs() > limit) {
        return Err(bad_value(name, q0, &format!("an angle is beyond ±{limit:e} rad")));
    }
    for (j, value) in q.iter().enumerate() {
        let (lower, upper) = setup.user_limits(j);
        if !(lower..=upper).contains(value) {
            common::warn(
                py,
                &format!(
                    "{name} joint {} = {} rad is outside its limits [{lower:.4}, {upper:.4}] rad; angles are read in radians (if {} was meant in degrees, that is {:.4} rad)",
                    j + 1,
                    show(*value),
                    show(*value),
                    value.to_radians()
                ),
            )?;
        }
    }
    Ok(q)
}

/// One controller's simulated run: every step's arrays and the run's metrics.
#[pyclass(module = "chessarm", frozen)]
#[derive(Debug)]
pub struct Run {
    /// The controller: pd, pid, pid-plain, adaptive, dob (with servos the host's strategy).
    #[pyo3(get)]
    controller: String,
    /// Outer-loop gains per joint (None for a servo host): kp 1/s², kd 1/s, ki 1/s³.
    #[pyo3(get)]
    kp: Option<Py<PyAny>>,
    #[pyo3(get)]
    kd: Option<Py<PyAny>>,
    #[pyo3(get)]
    ki: Option<Py<PyAny>>,
    /// s, shape (n,).
    #[pyo3(get)]
    t: Py<PyAny>,
    /// Joint angles rad and rates rad/s: shape (n, 4), the setup's joint convention.
    #[pyo3(get)]
    q: Py<PyAny>,
    #[pyo3(get)]
    qd: Py<PyAny>,
    /// The reference: angles, rates, accelerations.
    #[pyo3(get)]
    q_des: Py<PyAny>,
    #[pyo3(get)]
    qd_des: Py<PyAny>,
    #[pyo3(get)]
    qdd_des: Py<PyAny>,
    /// The state the controller saw at its latest sample (the estimate; `q`, `qd` with ideal
    /// sensors).
    #[pyo3(get)]
    q_estimate: Py<PyAny>,
    #[pyo3(get)]
    qd_estimate: Py<PyAny>,
    /// Applied torque, N·m: shape (n, 4).
    #[pyo3(get)]
    tau: Py<PyAny>,
    /// Tool tip, actual and desired, m: shape (n, 3).
    #[pyo3(get)]
    tip: Py<PyAny>,
    #[pyo3(get)]
    tip_desired: Py<PyAny>,
    /// With servos: the goals sent and the servos' internal targets, rad, shape (n, 4).
    #[pyo3(get)]
    servo_goal: Option<Py<PyAny>>,
    #[pyo3(get)]
    servo_target: Option<Py<PyAny>>,
    /// RMS and largest tool-tip error over the tracked steps, m.
    #[pyo3(get)]
    rms_tip_error: f64,
    #[pyo3(get)]
    max_tip_error: f64,
    /// RMS and largest joint error per joint over the tracked steps, rad: shape (4,).
    #[pyo3(get)]
    rms_joint_error: Py<PyAny>,
    #[pyo3(get)]
    max_joint_error: Py<PyAny>,
    /// Distance of the scenario's piece from its target square's centre where the tool
    /// released it, m (None without a grip and a release).
    #[pyo3(get)]
    placement_error: Option<f64>,
    /// The tip error at each gripper event: (t s, "grip" or "release", m).
    #[pyo3(get)]
    tip_error_at_events: Vec<(f64, String, f64)>,
    /// Peak |τ| per joint, N·m: shape (4,).
    #[pyo3(get)]
    peak_torque: Py<PyAny>,
    /// Controller samples at which a torque was clipped, in all and per joint.
    #[pyo3(get)]
    saturated_samples: usize,
    #[pyo3(get)]
    saturated_per_joint: [usize; 4],
    /// s, and the count of integration steps.
    #[pyo3(get)]
    duration: f64,
    #[pyo3(get)]
    steps: usize,
    /// Steps the RMS and largest errors count (from `tracking_from` on).
    #[pyo3(get)]
    tracked_steps: usize,
    /// The simulation's own time, s.
    #[pyo3(get)]
    wall_time: f64,
    /// The command line's summary.json entry of this controller (mm for the tip errors).
    summary: serde_json::Value,
}

impl Run {
    fn new(py: Python<'_>, setup: &Setup, run: &ControllerRun, plan: &ScenarioPlan) -> PyResult<Self> {
        let user = |values: chessarm_core::arm::model::JointVector<4>| setup.convention.user(values);
        let records: &[StepRecord<4>] = &run.records;
        let host = matches!(run.spec.kind, ControllerKind::ServoHost(_));
        let gains = &run.spec.gains;
        let gain = |values: &chessarm_core::arm::model::JointVector<4>| -> PyResult<Option<Py<PyAny>>> {
            (!host).then(|| column(py, values.iter().copied())).transpose()
        };
        let servos = records.first().is_some_and(|r| r.servo.is_some());
        let servo =
            |pick: fn(&chessarm_core::sim::actuator::ServoRecord<4>) -> [f64; 4]| -> PyResult<Option<Py<PyAny>>> {
                servos
                    .then(|| {
                        rows(
                            py,
                            records
                                .iter()
                                .map(|r| r.servo.as_ref().map_or([f64::NAN; 4], |s| setup.convention.user(pick(s)))),
                        )
                    })
                    .transpose()
            };
        let summary = &run.summary;
        let events = plan
            .path
            .events()
            .iter()
            .zip(&summary.tip_error_at_marks)
            .map(|(event, error)| {
                let name = match event.action {
                    chessarm_core::plan::path::GripperAction::Grip => "grip",
                    chessarm_core::plan::path::GripperAction::Release => "release",
                };
                (event.time, name.to_string(), *error)
            })
            .collect();
        Ok(Self {
            controller: run.spec.name.clone(),
            kp: gain(&gains.kp)?,
            kd: gain(&gains.kd)?,
            ki: gain(&gains.ki)?,
            t: column(py, records.iter().map(|r| r.t))?,
            q: rows(py, records.iter().map(|r| user(r.state.q)))?,
            qd: rows(py, records.iter().map(|r| user(r.state.qd)))?,
            q_des: rows(py, records.iter().map(|r| user(r.reference.q)))?,
            qd_des: rows(py, records.iter().map(|r| user(r.reference.qd)))?,
            qdd_des: rows(py, records.iter().map(|r| user(r.reference.qdd)))?,
            q_estimate: rows(py, records.iter().map(|r| user(r.estimate.q)))?,
            qd_estimate: rows(py, records.iter().map(|r| user(r.estimate.qd)))?,
            tau: rows(py, records.iter().map(|r| user(r.torque)))?,
            tip: rows(py, records.iter().map(|r| <[f64; 3]>::from(r.tip)))?,
            tip_desired: rows(py, records.iter().map(|r| <[f64; 3]>::from(r.tip_desired)))?,
            servo_goal: servo(|s| s.goal.into())?,
            servo_target: servo(|s| s.target.into())?,
            rms_tip_error: summary.rms_tip_error,
            max_tip_error: summary.max_tip_error,
            rms_joint_error: column(py, summary.rms_joint_error.iter().copied())?,
            max_joint_error: column(py, summary.max_joint_error.iter().copied())?,
            placement_error: placement_error(plan, summary),
            tip_error_at_events: events,
            peak_torque: column(py, setup.convention.user(summary.peak_torque).iter().map(|v| v.abs()))?,
            saturated_samples: summary.saturated_samples,
            saturated_per_joint: summary.saturated_per_joint,
            duration: summary.duration,
            steps: summary.steps,
            tracked_steps: summary.tracked_steps,
            wall_time: run.wall_time_s,
            summary: chessarm::app::formats::simulation::summary_json(run, plan),
        })
    }
}

#[pymethods]
impl Run {
    /// The command line's summary.json entry of this controller (tip errors in mm), as a dict.
    #[getter]
    fn summary(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        common::json_to_python(py, &self.summary)
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        self.t.bind(py).len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Run({:?}, {} steps, rms tip error {:.4} mm, max {:.4} mm, placement error {}, {} saturated samples)",
            self.controller,
            self.steps + 1,
            self.rms_tip_error * 1e3,
            self.max_tip_error * 1e3,
            self.placement_error.map_or("-".to_string(), |e| format!("{:.4} mm", e * 1e3)),
            self.saturated_samples
        )
    }
}

/// A scenario simulated with one or more controllers: `runs` by controller, the `plan`
/// followed; with one controller its arrays and metrics are the simulation's own
/// (`sim.q` is `sim.runs["pd"].q`).
#[pyclass(module = "chessarm", frozen)]
#[derive(Debug)]
pub struct Simulation {
    /// The controllers' runs by name, in the order asked.
    #[pyo3(get)]
    runs: Py<PyDict>,
    /// The controllers' names, in order.
    #[pyo3(get)]
    controllers: Vec<String>,
    /// The plan followed (sampled at the control period).
    #[pyo3(get)]
    plan: Py<Plan>,
    /// The scenario's name.
    #[pyo3(get)]
    scenario: String,
    /// Integration step s, controller rate Hz.
    #[pyo3(get)]
    dt: f64,
    #[pyo3(get)]
    control_rate: f64,
    /// The study's conditions as summary.json has them (None when ideal).
    conditions: serde_json::Value,
    /// What the command line would have said on the terminal (the conditions, unmodelled
    /// friction), one line each.
    #[pyo3(get)]
    notes: Vec<String>,
}

#[pymethods]
impl Simulation {
    /// The study's conditions (sensors, estimator, model errors) as a dict; None when ideal.
    #[getter]
    fn conditions(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        common::json_to_python(py, &self.conditions)
    }

    /// With one controller, its run's attributes (`t`, `q`, `tau`, `max_tip_error`, …).
    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        let runs = self.runs.bind(py);
        if name.starts_with("__") || !Run::ATTRIBUTES.contains(&name) {
            return Err(PyAttributeError::new_err(format!("'Simulation' object has no attribute '{name}'")));
        }
        if runs.len() != 1 {
            return Err(PyAttributeError::new_err(format!(
                "{name}: this simulation has {} controllers ({}): take one run's, e.g. sim.runs[{:?}].{name}",
                runs.len(),
                self.controllers.join(", "),
                self.controllers[0]
            )));
        }
        let (_, run) = runs.iter().next().expect("one run");
        Ok(run.getattr(name)?.unbind())
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulation({:?}, controllers={:?}, dt={} s, control_rate={} Hz)",
            self.scenario, self.controllers, self.dt, self.control_rate
        )
    }
}

impl Run {
    /// The attributes a one-controller [`Simulation`] hands on.
    const ATTRIBUTES: [&'static str; 31] = [
        "controller",
        "kp",
        "kd",
        "ki",
        "t",
        "q",
        "qd",
        "q_des",
        "qd_des",
        "qdd_des",
        "q_estimate",
        "qd_estimate",
        "tau",
        "tip",
        "tip_desired",
        "servo_goal",
        "servo_target",
        "rms_tip_error",
        "max_tip_error",
        "rms_joint_error",
        "max_joint_error",
        "placement_error",
        "tip_error_at_events",
        "peak_torque",
        "saturated_samples",
        "saturated_per_joint",
        "duration",
        "steps",
        "wall_time",
        "summary",
        "tracked_steps",
    ];
}

/// Simulates the scenario (or `plan`, a scenario's plan sampled at the control period) under
/// each controller of `controller` (a name or a list: pd, pid, pid-plain, adaptive, dob, both),
/// with the command line's `simulate` options as arguments; the same numbers as `chessarm
/// simulate` with the same options.
#[pyfunction]
#[pyo3(signature = (
    setup, plan = None, *, scenario = None, controller = None, kp = None, kd = None, ki = None,
    sensors = None, estimator = None, seed = 0, trial_seed = None, dt = 0.001, control_rate = None,
    integrator = "rkn4", q0 = None, payload_mass = 0.0, controller_knows_payload = false,
    controller_knows_friction = None, tracking_from = 0.0, torque_lag = None, plant = None,
    uncertainty = None, kalman_acceleration_noise = None, lowpass_time_constant = None
))]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    setup: &Bound<'_, PySetup>,
    plan: Option<Bound<'_, Plan>>,
    scenario: Option<String>,
    controller: Option<&Bound<'_, PyAny>>,
    kp: Option<&Bound<'_, PyAny>>,
    kd: Option<&Bound<'_, PyAny>>,
    ki: Option<&Bound<'_, PyAny>>,
    sensors: Option<PathBuf>,
    estimator: Option<&str>,
    seed: u64,
    trial_seed: Option<u64>,
    dt: f64,
    control_rate: Option<f64>,
    integrator: &str,
    q0: Option<&Bound<'_, PyAny>>,
    payload_mass: f64,
    controller_knows_payload: bool,
    controller_knows_friction: Option<bool>,
    tracking_from: f64,
    torque_lag: Option<&Bound<'_, PyAny>>,
    plant: Option<PathBuf>,
    uncertainty: Option<PathBuf>,
    kalman_acceleration_noise: Option<f64>,
    lowpass_time_constant: Option<f64>,
) -> PyResult<Simulation> {
    let py_setup = setup.get();
    let setup: &Arc<Setup> = &py_setup.setup;
    // The plan given: a scenario's, for this arm; its sample period is the control period
    // unless one is given.
    let given = match &plan {
        Some(plan) => {
            let plan = plan.get();
            let Planned::Scenario(scenario_plan) = &plan.planned else {
                return Err(PyValueError::new_err(
                    "plan: a plan of moves is simulated move by move with its pieces: use chessarm.play(setup, moves=…)",
                ));
            };
            if plan.arm != setup.arm {
                return Err(PyValueError::new_err("plan: it was planned for another arm than this setup's"));
            }
            if scenario.as_ref().is_some_and(|s| *s != scenario_plan.name) {
                return Err(PyValueError::new_err(format!(
                    "scenario={:?} with a plan of {:?}: give one",
                    scenario.as_deref().unwrap_or_default(),
                    scenario_plan.name
                )));
            }
            Some((scenario_plan.clone(), plan.dt))
        }
        None => None,
    };
    let control_rate = control_rate.unwrap_or_else(|| given.as_ref().map_or(1000.0, |(_, dt)| 1.0 / dt));
    check_rates(dt, control_rate)?;
    let control_period = 1.0 / control_rate;
    if let Some((_, plan_dt)) = &given
        && (plan_dt - control_period).abs() > 1e-9 * control_period
    {
        return Err(PyValueError::new_err(format!(
            "plan: sampled every {} s, but the controller samples every {} s (control_rate={} Hz): plan with dt={} or give control_rate={}",
            show(*plan_dt),
            show(control_period),
            show(control_rate),
            show(control_period),
            show(1.0 / plan_dt)
        )));
    }
    chessarm::app::setup::servos::check_bus_period(setup, dt, " dt")
        .map_err(|e| PyValueError::new_err(pythonic(&e)))?;
    non_negative("tracking_from", tracking_from)?;
    non_negative("payload_mass", payload_mass)?;
    if payload_mass > chessarm_core::arm::model::MAX_MASS {
        return Err(PyValueError::new_err(format!(
            "payload_mass={payload_mass}: beyond {} kg, a typo in units",
            chessarm_core::arm::model::MAX_MASS
        )));
    }
    let integrator = common::choice::<IntegratorChoice>("integrator", integrator)?.integrator();
    let q0 = q0.filter(|q| !q.is_none()).map(|q| initial_angles(py, setup, "q0", q)).transpose()?;
    let conditions = Conditions::new(
        sensors,
        estimator,
        seed,
        trial_seed,
        torque_lag,
        plant,
        uncertainty,
        controller_knows_friction,
        kalman_acceleration_noise,
        lowpass_time_constant,
    )?;
    let default_controller = pyo3::types::PyString::new(py, "pd").into_any();
    let controller = controller.unwrap_or(&default_controller);
    let mut notes = Vec::new();
    let specs = specs(
        setup,
        controller,
        given_gains(kp, kd, ki)?,
        DefaultGains::Report,
        conditions.args.knows_friction(setup),
        &mut notes,
    )?;
    let study = conditions.study(setup, control_period)?;
    let run_seed = conditions.args.run_seed();
    let (trial, described) = if study.is_ideal(setup) {
        (None, serde_json::Value::Null)
    } else {
        notes.push(study.note(run_seed).trim_end().to_string());
        let trial = study.trial(run_seed).map_err(|e| SimulationError::new_err(pythonic(&e)))?;
        (Some(trial), study.describe())
    };
    if let Some(note) = study.friction_note() {
        notes.push(common::flags_as_arguments(note.trim_end().trim_start_matches("note: ")));
    }
    let options = RunOptions {
        dt,
        integrator,
        control_period,
        q0,
        payload_mass,
        controller_knows_payload,
        tracking_from,
        rate_flags: format!("dt={} with control_rate={}", show(dt), show(control_rate)),
        trial,
        conditions: described.clone(),
    };
    let (scenario_plan, plan_object) = match (given, plan) {
        (Some((scenario_plan, _)), Some(plan)) => (scenario_plan, plan.unbind()),
        _ => {
            let name = scenario.unwrap_or_else(|| "queens-gambit".into());
            check_scenario(&name)?;
            let arc = setup.clone();
            let cause = options.rate_flags.clone();
            let planned = py
                .detach(|| plan_scenario(&arc, &name, control_period, &cause))
                .map_err(|e| SimulationError::new_err(pythonic(&e)))?;
            let planned = Arc::new(planned);
            let object = Plan::new(py, py_setup, Planned::Scenario(planned.clone()), None, control_period)?;
            (planned, Py::new(py, object)?)
        }
    };
    ensure_tracked(tracking_from, &scenario_plan).map_err(|e| PyValueError::new_err(pythonic(&e)))?;
    // Every step of every controller is kept: refused before it runs if it cannot fit.
    let steps = (scenario_plan.path.duration() / dt).ceil() + 1.0;
    chessarm::app::resources::ensure_fits(
        &options.rate_flags,
        "recorded steps",
        steps * specs.len() as f64,
        (std::mem::size_of::<StepRecord<4>>() + 30 * 8) as f64,
    )
    .map_err(|e| PyMemoryError::new_err(pythonic(&e)))?;
    let runs = PyDict::new(py);
    let mut names = Vec::new();
    for spec in &specs {
        // Ctrl-C between the controllers (each run is short: ~13 000 steps of the scenario).
        py.check_signals()?;
        let run = py
            .detach(|| run_controller(setup, &scenario_plan, spec, &options, None))
            .map_err(|e| SimulationError::new_err(pythonic(&e)))?;
        runs.set_item(&spec.name, Py::new(py, Run::new(py, setup, &run, &scenario_plan)?)?)?;
        names.push(spec.name.clone());
    }
    Ok(Simulation {
        runs: runs.unbind(),
        controllers: names,
        plan: plan_object,
        scenario: scenario_plan.name.clone(),
        dt,
        control_rate,
        conditions: described,
        notes,
    })
}
