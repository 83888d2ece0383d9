//! `chessarm.tune(setup, …)` and `chessarm.robustness(setup, …)` in memory: the gain sweep and
//! the Monte Carlo campaign of the application layer (`app::studies::tune`, `…::robustness`),
//! their rows as NumPy arrays (SI: errors in m), the numbers of `chessarm tune` and
//! `chessarm robustness` with the same options.

use crate::common::{self, bad_value, column, non_negative, positive, pythonic};
use crate::errors::SimulationError;
use crate::play::pgn_record;
use crate::setup::PySetup;
use crate::simulate::{Conditions, given_gains};
use chessarm::app::setup::file::Setup;
use chessarm::app::studies::placement::Placement;
use chessarm::app::studies::robustness::{self as campaign, RobustnessOptions};
use chessarm::app::studies::simulate::ControllerName;
use chessarm::app::studies::tune::{self as sweep, GainRange, Metric, TuneOptions};
use chessarm::app::studies::{Progress, Stop};
use chessarm::cli::IntegratorChoice;
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

/// A range of gains: `"A..B:N"` (the command line's) or `(A, B, N)`.
fn gain_range(name: &str, value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<GainRange>> {
    let Some(value) = value.filter(|v| !v.is_none()) else { return Ok(None) };
    if let Ok(text) = value.extract::<String>() {
        return GainRange::parse(&text).map(Some).map_err(|e| bad_value(name, value, &e));
    }
    let (from, to, count): (f64, f64, usize) =
        value.extract().map_err(|_| bad_value(name, value, "a range \"A..B:N\" or (A, B, N)"))?;
    GainRange::parse(&format!("{from}..{to}:{count}")).map(Some).map_err(|e| bad_value(name, value, &e))
}

/// A piece's mass, kg: not negative, and not beyond the model's largest (a typo in units), as
/// `simulate`'s `payload_mass`.
fn payload(name: &str, mass: f64) -> PyResult<f64> {
    non_negative(name, mass)?;
    if mass > chessarm_core::arm::model::MAX_MASS {
        return Err(PyValueError::new_err(format!(
            "{name}={mass}: beyond {} kg, a typo in units",
            chessarm_core::arm::model::MAX_MASS
        )));
    }
    Ok(mass)
}

/// A shard `(K, N)`, 1 ≤ K ≤ N.
fn checked_shard(value: Option<(usize, usize)>) -> PyResult<Option<(usize, usize)>> {
    match value {
        Some((k, n)) if k == 0 || n == 0 || k > n => {
            Err(PyValueError::new_err(format!("shard=({k}, {n}): needs 1 <= K <= N")))
        }
        other => Ok(other),
    }
}

/// Worker threads: at least one.
fn checked_threads(value: Option<usize>) -> PyResult<Option<usize>> {
    if value == Some(0) {
        return Err(PyValueError::new_err("threads=0: at least one worker thread"));
    }
    Ok(value)
}

/// Runs `study` on a thread of its own while this one, holding the GIL a moment every 50 ms,
/// checks Python's signals: Ctrl-C asks the study to stop at its next candidate or trial and
/// raises `KeyboardInterrupt` once it has.
fn interruptible<T: Send>(
    py: Python<'_>,
    study: impl FnOnce(Option<Progress<'_>>, Stop<'_>) -> anyhow::Result<T> + Send,
) -> PyResult<anyhow::Result<T>> {
    let stop = AtomicBool::new(false);
    let asked = |_| ();
    std::thread::scope(|scope| {
        let handle = scope.spawn(|| study(Some(&asked), &|| stop.load(Ordering::SeqCst)));
        let mut signal = None;
        while !handle.is_finished() {
            py.detach(|| std::thread::sleep(std::time::Duration::from_millis(50)));
            if signal.is_none()
                && let Err(error) = py.check_signals()
            {
                stop.store(true, Ordering::SeqCst);
                signal = Some(error);
            }
        }
        let result = handle.join().map_err(|_| SimulationError::new_err("the study's thread panicked"))?;
        match signal {
            Some(error) => Err(error),
            None => Ok(result),
        }
    })
}

/// A sweep's candidates, one entry per candidate in sweep order (SI: tip errors in m).
#[pyclass(module = "chessarm", frozen)]
#[derive(Debug)]
pub struct Tuning {
    /// Each candidate's index in the whole sweep.
    #[pyo3(get)]
    index: Py<PyAny>,
    /// Outer-loop gains, 1/s², 1/s, 1/s³ (NaN for servo candidates).
    #[pyo3(get)]
    kp: Py<PyAny>,
    #[pyo3(get)]
    kd: Py<PyAny>,
    #[pyo3(get)]
    ki: Py<PyAny>,
    /// A servo candidate's host strategy (None for torque controllers) and P register (NaN).
    #[pyo3(get)]
    servo_command: Vec<Option<String>>,
    #[pyo3(get)]
    p_gain: Py<PyAny>,
    /// "ok", or why the candidate's run failed.
    #[pyo3(get)]
    status: Vec<String>,
    /// Largest and RMS tool-tip error, m; largest at the grips and releases, m.
    #[pyo3(get)]
    max_tip_error: Py<PyAny>,
    #[pyo3(get)]
    rms_tip_error: Py<PyAny>,
    #[pyo3(get)]
    place_error: Py<PyAny>,
    /// RMS and largest joint error, rad.
    #[pyo3(get)]
    rms_joint_error: Py<PyAny>,
    #[pyo3(get)]
    max_joint_error: Py<PyAny>,
    /// Largest |τ|, N·m, and largest |τ| / limit over the joints.
    #[pyo3(get)]
    peak_torque: Py<PyAny>,
    #[pyo3(get)]
    peak_torque_ratio: Py<PyAny>,
    /// Samples at a torque (or a servo's duty) limit; pieces off their squares (games).
    #[pyo3(get)]
    saturated_samples: Vec<usize>,
    #[pyo3(get)]
    misplaced: Vec<usize>,
    /// Candidates in the whole sweep, and whether they are servos' P registers.
    #[pyo3(get)]
    sweep_size: usize,
    #[pyo3(get)]
    servos: bool,
    /// Start of the tracking metrics, s; the sweep's wall time, s.
    #[pyo3(get)]
    tracking_from: f64,
    #[pyo3(get)]
    wall_time: f64,
    /// The study's result, for `best` and `edge_warning`.
    tuned: sweep::Tuned,
    options: TuneOptions,
}

#[pymethods]
impl Tuning {
    /// The positions (in these arrays) of the `top` best candidates by `metric`
    /// (max_tip_error, rms_joint_error, peak_torque or place_error) among those that finished
    /// within the limits, best first (ties by sweep order), as `chessarm tune` ranks them.
    #[pyo3(signature = (metric = "max-tip-error", top = 5))]
    fn best(&self, metric: &str, top: usize) -> PyResult<Vec<usize>> {
        let metric = common::choice::<Metric>("metric", &metric.replace('_', "-"))?;
        let first = self.tuned.candidates.first().map_or(0, |c| c.index);
        Ok(self.tuned.best(metric, top).iter().map(|c| c.index - first).collect())
    }

    /// The warning `chessarm tune` prints when the best candidate by `metric` lies on the edge
    /// of a swept range (None when it does not).
    #[pyo3(signature = (metric = "max-tip-error"))]
    fn edge_warning(&self, metric: &str) -> PyResult<Option<String>> {
        let metric = common::choice::<Metric>("metric", &metric.replace('_', "-"))?;
        Ok(sweep::edge_warning(&self.options, self.tuned.best(metric, 1).first().copied())
            .map(|w| common::flags_as_arguments(&w)))
    }

    fn __len__(&self) -> usize {
        self.tuned.candidates.len()
    }

    fn __repr__(&self) -> String {
        let (failed, saturated) = self.tuned.failed_and_saturated();
        format!(
            "Tuning({} candidates of {}, {failed} failed, {saturated} saturated, {:.2} s)",
            self.tuned.candidates.len(),
            self.sweep_size,
            self.wall_time
        )
    }
}

/// Sweeps a torque controller's gains (`kp`, `kd` and for pid `ki`: ranges `"A..B:N"` or
/// `(A, B, N)`) or, with servos, their P register (`p_gain`) under each of the setup's host
/// strategies, each candidate the whole scenario or game (`pgn=`), with the command line's
/// `tune` options as arguments; the numbers of `chessarm tune` with the same options.
#[pyfunction]
#[pyo3(signature = (
    setup, *, kp = None, kd = None, ki = None, p_gain = None, controller = "pd", scenario = None,
    pgn = None, game = 1, payload_mass = 0.0, controller_knows_payload = false, q0 = None,
    tracking_from = None, sensors = None, estimator = None, seed = 0, torque_lag = None, plant = None,
    uncertainty = None, controller_knows_friction = None, kalman_acceleration_noise = None,
    lowpass_time_constant = None, integrator = "rkn4", shard = None, threads = None
))]
#[allow(clippy::too_many_arguments)]
pub fn tune(
    py: Python<'_>,
    setup: &Bound<'_, PySetup>,
    kp: Option<&Bound<'_, PyAny>>,
    kd: Option<&Bound<'_, PyAny>>,
    ki: Option<&Bound<'_, PyAny>>,
    p_gain: Option<&Bound<'_, PyAny>>,
    controller: &str,
    scenario: Option<String>,
    pgn: Option<&Bound<'_, PyAny>>,
    game: usize,
    payload_mass: f64,
    controller_knows_payload: bool,
    q0: Option<&Bound<'_, PyAny>>,
    tracking_from: Option<f64>,
    sensors: Option<PathBuf>,
    estimator: Option<&str>,
    seed: u64,
    torque_lag: Option<&Bound<'_, PyAny>>,
    plant: Option<PathBuf>,
    uncertainty: Option<PathBuf>,
    controller_knows_friction: Option<bool>,
    kalman_acceleration_noise: Option<f64>,
    lowpass_time_constant: Option<f64>,
    integrator: &str,
    shard: Option<(usize, usize)>,
    threads: Option<usize>,
) -> PyResult<Tuning> {
    let py_setup = setup.get();
    // A servo sweep without a strategy named sweeps every host strategy, as `chessarm tune` does.
    let mut every_strategy = None;
    if py_setup.options.servo_command.is_none() && py_setup.setup.actuators.take_positions() {
        let mut all = (*py_setup.setup).clone();
        all.servo_commands = chessarm_core::control::servo_host::ServoCommand::ALL.to_vec();
        every_strategy = Some(all);
    }
    let setup: &Setup = every_strategy.as_ref().unwrap_or(&py_setup.setup);
    payload("payload_mass", payload_mass)?;
    if let Some(from) = tracking_from {
        non_negative("tracking_from", from)?;
    }
    let named = common::choice::<ControllerName>("controller", controller)?;
    if !matches!(named, ControllerName::Pd | ControllerName::Pid | ControllerName::Adaptive | ControllerName::Dob) {
        let given = pyo3::types::PyString::new(py, controller).into_any();
        return Err(bad_value("controller", &given, "tune sweeps one of pd, pid, adaptive, dob"));
    }
    let controller = named;
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
    let options = TuneOptions {
        game: pgn.filter(|p| !p.is_none()).map(|p| pgn_record(p, game)).transpose()?,
        scenario: scenario.unwrap_or_else(|| "queens-gambit".into()),
        controller,
        kp: gain_range("kp", kp)?,
        kd: gain_range("kd", kd)?,
        ki: gain_range("ki", ki)?,
        p_gain: gain_range("p_gain", p_gain)?,
        payload_mass,
        controller_knows_payload,
        conditions: conditions.args,
        placement: Placement::default(),
        q0: q0.filter(|q| !q.is_none()).map(|q| crate::simulate::initial_angles(py, setup, "q0", q)).transpose()?,
        tracking_from,
        shard: checked_shard(shard)?,
        integrator: common::choice::<IntegratorChoice>("integrator", integrator)?.integrator(),
        threads: checked_threads(threads)?,
    };
    // The checks and the scenario's plan, with the GIL released; what they refuse is an argument.
    let prepared = py
        .detach(|| sweep::Prepared::new(setup, &options))
        .map_err(|e| PyValueError::new_err(common::flags_as_arguments(&pythonic(&e))))?;
    let tuned = interruptible(py, |progress, stop| prepared.run(progress, stop))?
        .map_err(|e| SimulationError::new_err(pythonic(&e)))?;
    let candidates = &tuned.candidates;
    let of = |f: &dyn Fn(&sweep::Candidate) -> f64| column(py, candidates.iter().map(f));
    Ok(Tuning {
        index: of(&|c| c.index as f64)?,
        kp: of(&|c| c.kp)?,
        kd: of(&|c| c.kd)?,
        ki: of(&|c| c.ki)?,
        servo_command: candidates.iter().map(|c| c.servo_command.map(|s| s.name().to_string())).collect(),
        p_gain: of(&|c| c.p_gain)?,
        status: candidates.iter().map(|c| c.status.clone()).collect(),
        max_tip_error: of(&|c| c.max_tip_error_mm / 1e3)?,
        rms_tip_error: of(&|c| c.rms_tip_error_mm / 1e3)?,
        place_error: of(&|c| c.place_error_mm / 1e3)?,
        rms_joint_error: of(&|c| c.rms_joint_error_rad)?,
        max_joint_error: of(&|c| c.max_joint_error_rad)?,
        peak_torque: of(&|c| c.peak_torque_nm)?,
        peak_torque_ratio: of(&|c| c.peak_torque_ratio)?,
        saturated_samples: candidates.iter().map(|c| c.saturated_samples).collect(),
        misplaced: candidates.iter().map(|c| c.misplaced).collect(),
        sweep_size: tuned.sweep_size,
        servos: tuned.servos,
        tracking_from: tuned.tracking_from,
        wall_time: tuned.wall_time_s,
        tuned,
        options,
    })
}

/// A robustness campaign's rows, one entry per trial and controller in trial order (SI:
/// errors and clearances in m), and per controller its statistics.
#[pyclass(module = "chessarm", frozen)]
#[derive(Debug)]
pub struct Campaign {
    /// The trial's number and seed (`simulate`/`play` with `trial_seed=` replays it).
    #[pyo3(get)]
    trial: Vec<usize>,
    #[pyo3(get)]
    trial_seed: Vec<u64>,
    #[pyo3(get)]
    controller: Vec<String>,
    /// "ok", or why the run failed.
    #[pyo3(get)]
    status: Vec<String>,
    /// Every piece within the tolerance and nothing touched.
    #[pyo3(get)]
    success: Vec<bool>,
    /// Largest distance of a placed piece from its square centre, m (NaN when it failed).
    #[pyo3(get)]
    place_error: Py<PyAny>,
    #[pyo3(get)]
    pieces: Vec<usize>,
    #[pyo3(get)]
    misplaced: Vec<usize>,
    /// Largest and RMS tool-tip error, m.
    #[pyo3(get)]
    max_tip_error: Py<PyAny>,
    #[pyo3(get)]
    rms_tip_error: Py<PyAny>,
    /// Largest |τ|, N·m, and |τ| / limit; samples at a limit.
    #[pyo3(get)]
    peak_torque: Py<PyAny>,
    #[pyo3(get)]
    peak_torque_ratio: Py<PyAny>,
    #[pyo3(get)]
    saturated_samples: Vec<usize>,
    /// RMS of the rate estimate's error, rad/s.
    #[pyo3(get)]
    rms_rate_estimate_error: Py<PyAny>,
    /// Robot time, s, and moves simulated.
    #[pyo3(get)]
    robot_time: Py<PyAny>,
    #[pyo3(get)]
    plies: Vec<usize>,
    /// Moves whose simulated motion touched something, and the smallest clearance, m.
    #[pyo3(get)]
    contacts: Vec<usize>,
    #[pyo3(get)]
    clearance: Py<PyAny>,
    /// The trials' drawn parameters by name, one array each (empty for a failed draw's row).
    #[pyo3(get)]
    drawn: Py<PyDict>,
    /// Per controller (in order) its statistics, as robustness.json's "controllers".
    statistics: serde_json::Value,
    #[pyo3(get)]
    wall_time: f64,
}

#[pymethods]
impl Campaign {
    /// Per controller, in order: success rate, placement error's median, p95 and largest (mm,
    /// as robustness.json), contacts, peak torques, seconds per ply, the worst trial's seed.
    #[getter]
    fn statistics(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        common::json_to_python(py, &self.statistics)
    }

    fn __len__(&self) -> usize {
        self.trial.len()
    }

    fn __repr__(&self) -> String {
        let successes = self.success.iter().filter(|s| **s).count();
        format!("Campaign({} runs, {successes} successes, {:.2} s)", self.trial.len(), self.wall_time)
    }
}

/// Runs `trials` trials drawn from the setup's uncertainty (or `uncertainty=`), every
/// controller of `controller` on each, on the scenario or a game (`pgn=`), with the command
/// line's `robustness` options as arguments; the rows of `chessarm robustness` with the same
/// options.
#[pyfunction]
#[pyo3(signature = (
    setup, *, trials = 100, controller = None, kp = None, kd = None, ki = None, scenario = None,
    pgn = None, game = 1, payload_mass = None, controller_knows_payload = false, tolerance = 0.005,
    sensors = None, estimator = None, seed = 0, torque_lag = None, plant = None, uncertainty = None,
    controller_knows_friction = None, kalman_acceleration_noise = None, lowpass_time_constant = None,
    integrator = "rkn4", shard = None, threads = None
))]
#[allow(clippy::too_many_arguments)]
pub fn robustness(
    py: Python<'_>,
    setup: &Bound<'_, PySetup>,
    trials: usize,
    controller: Option<&Bound<'_, PyAny>>,
    kp: Option<&Bound<'_, PyAny>>,
    kd: Option<&Bound<'_, PyAny>>,
    ki: Option<&Bound<'_, PyAny>>,
    scenario: Option<String>,
    pgn: Option<&Bound<'_, PyAny>>,
    game: usize,
    payload_mass: Option<f64>,
    controller_knows_payload: bool,
    tolerance: f64,
    sensors: Option<PathBuf>,
    estimator: Option<&str>,
    seed: u64,
    torque_lag: Option<&Bound<'_, PyAny>>,
    plant: Option<PathBuf>,
    uncertainty: Option<PathBuf>,
    controller_knows_friction: Option<bool>,
    kalman_acceleration_noise: Option<f64>,
    lowpass_time_constant: Option<f64>,
    integrator: &str,
    shard: Option<(usize, usize)>,
    threads: Option<usize>,
) -> PyResult<Campaign> {
    let setup: &Setup = &setup.get().setup;
    if trials == 0 {
        return Err(PyValueError::new_err("trials=0: at least one trial"));
    }
    positive("tolerance", tolerance)?;
    if let Some(mass) = payload_mass {
        payload("payload_mass", mass)?;
    }
    let controllers = match controller.filter(|c| !c.is_none()) {
        Some(names) => common::names("controller", names)?
            .iter()
            .map(|name| common::choice::<ControllerName>("controller", name))
            .collect::<PyResult<Vec<_>>>()?,
        None => RobustnessOptions::new(trials).controllers,
    };
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
    let options = RobustnessOptions {
        game: pgn.filter(|p| !p.is_none()).map(|p| pgn_record(p, game)).transpose()?,
        scenario: scenario.unwrap_or_else(|| "queens-gambit".into()),
        controllers,
        gains: given_gains(kp, kd, ki)?,
        payload_mass,
        controller_knows_payload,
        conditions: conditions.args,
        placement: Placement::default(),
        tolerance,
        trials,
        shard: checked_shard(shard)?,
        integrator: common::choice::<IntegratorChoice>("integrator", integrator)?.integrator(),
        threads: checked_threads(threads)?,
    };
    // The checks and the scenario's plan, with the GIL released; what they refuse is an argument.
    let prepared = py
        .detach(|| campaign::Prepared::new(setup, &options))
        .map_err(|e| PyValueError::new_err(common::flags_as_arguments(&pythonic(&e))))?;
    prepared.ensure_fits().map_err(|e| PyMemoryError::new_err(pythonic(&e)))?;
    let result = interruptible(py, |progress, stop| prepared.run(progress, stop))?
        .map_err(|e| SimulationError::new_err(pythonic(&e)))?;
    let rows = &result.rows;
    let of = |f: &dyn Fn(&campaign::TrialRow) -> f64| column(py, rows.iter().map(f));
    let drawn = PyDict::new(py);
    if let Some(named) = rows.iter().find(|r| !r.drawn.is_empty()) {
        for (k, (name, _)) in named.drawn.iter().enumerate() {
            drawn.set_item(name, of(&|r| r.drawn.get(k).map_or(f64::NAN, |(_, v)| *v))?)?;
        }
    }
    Ok(Campaign {
        trial: rows.iter().map(|r| r.trial).collect(),
        trial_seed: rows.iter().map(|r| r.trial_seed).collect(),
        controller: rows.iter().map(|r| r.controller.clone()).collect(),
        status: rows.iter().map(|r| r.status.clone()).collect(),
        success: rows.iter().map(campaign::TrialRow::success).collect(),
        place_error: of(&|r| r.place_error_mm / 1e3)?,
        pieces: rows.iter().map(|r| r.pieces).collect(),
        misplaced: rows.iter().map(|r| r.misplaced).collect(),
        max_tip_error: of(&|r| r.max_tip_error_mm / 1e3)?,
        rms_tip_error: of(&|r| r.rms_tip_error_mm / 1e3)?,
        peak_torque: of(&|r| r.peak_torque_nm)?,
        peak_torque_ratio: of(&|r| r.peak_torque_ratio)?,
        saturated_samples: rows.iter().map(|r| r.saturated_samples).collect(),
        rms_rate_estimate_error: of(&|r| r.rms_rate_estimate_error)?,
        robot_time: of(&|r| r.robot_time_s)?,
        plies: rows.iter().map(|r| r.plies).collect(),
        contacts: rows.iter().map(|r| r.contacts).collect(),
        clearance: of(&|r| r.clearance_mm / 1e3)?,
        drawn: drawn.unbind(),
        statistics: serde_json::to_value(&result.statistics).unwrap_or(serde_json::Value::Null),
        wall_time: result.wall_time_s,
    })
}
