//! `chessarm._chessarm`: the compiled part of the Python package `chessarm`.
//!
//! A thin layer: every number comes from `chessarm-core` (and the CLI library's setup-file and
//! URDF readers), so Python sees what the `chessarm` command prints. Arrays are NumPy `float64`
//! in SI units (rad, rad/s, rad/s², N·m, m). A function of a state takes one state (shape
//! `(4,)`) or many (shape `(n, 4)`, one per row); many states are computed in Rust with the
//! GIL released.
//!
//! On the application layer (`chessarm::app`), in memory, MuJoCo's way (the model and the data
//! are objects): [`setup::PySetup`] (`chessarm.Setup`, resolved as the command line resolves its
//! global flags), [`plan::plan`] → [`plan::Plan`], [`simulate::simulate`] →
//! [`simulate::Simulation`] of [`simulate::Run`]s, [`play::play`] → [`play::Game`] of
//! [`play::Ply`]s, and [`simulator::Simulator`], the closed loop a step at a time. No argument
//! list, no files, no process-wide state; the GIL is released while they compute.

mod common;
mod errors;
mod plan;
mod play;
mod setup;
mod simulate;
mod simulator;
mod sweeps;

use chessarm::app::setup::file::Setup;
use chessarm_core::arm::dynamics::{
    forward_dynamics, friction_torques, gravity_torques, inverse_dynamics, mass_matrix,
};
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::lagrange::coriolis_matrix;
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::arm::task::{TOOL_DOWN, inverse_kinematics, tool_point};
use chessarm_core::nalgebra::Vector3;
use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{AllowTypeChange, IntoPyArray, PyArrayDyn, PyArrayLikeDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;
use std::path::PathBuf;

pub use errors::{
    ChessarmWarning, CommandError, DynamicsError, Error, GameError, ModelError, PlanError, SimulationError,
    UnreachableError,
};

/// Runs `chessarm ARGS --json` in this process on a thread of its own, the GIL released:
/// `(stdout, stderr)` of the command (its result's JSON is stdout). Bad arguments raise
/// `ValueError` with the CLI's message naming the flag; a failed command raises `CommandError`
/// (with what it said before on stderr). Ctrl-C (any Python signal handler that raises) stops a
/// sweep, campaign or game at its next candidate, trial or ply and raises here.
#[pyfunction]
fn run_cli(py: Python<'_>, args: Vec<String>) -> PyResult<(String, String)> {
    let id = chessarm::run_id();
    let (done, result) = std::sync::mpsc::channel();
    // Behind a mutex so the wait can leave the GIL (a receiver is not shared between threads).
    let result = std::sync::Mutex::new(result);
    let worker = std::thread::Builder::new()
        .name("chessarm-command".into())
        .spawn(move || {
            let _ = done.send(chessarm::run_captured(&args, id));
        })
        .map_err(|e| Error::new_err(format!("cannot start the command's thread: {e}")))?;
    // A signal's exception, once raised: the run is cancelled, and its end awaited (signals
    // still checked, so the wait never blocks Python for good).
    let mut interrupted: Option<PyErr> = None;
    let outcome = loop {
        let wait = || {
            let receiver = result.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            receiver.recv_timeout(std::time::Duration::from_millis(50))
        };
        match py.detach(wait) {
            Ok(outcome) => break outcome,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                if let Err(signal) = py.check_signals() {
                    chessarm::cancel(id);
                    interrupted.get_or_insert(signal);
                }
            }
            // The thread ended without an answer: it panicked (the panic stays in Rust).
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(Error::new_err("the command stopped on an internal error (a panic in chessarm)"));
            }
        }
    };
    let _ = py.detach(|| worker.join());
    if let Some(signal) = interrupted {
        return Err(signal);
    }
    match outcome {
        Ok(captured) => Ok((captured.stdout, captured.stderr)),
        Err(chessarm::RunError::Usage(message)) => Err(PyValueError::new_err(message)),
        Err(chessarm::RunError::Failed { message, stderr }) => {
            Err(CommandError::new_err(if stderr.trim().is_empty() {
                message
            } else {
                format!("{message}\n{}", stderr.trim_end())
            }))
        }
    }
}

/// The message of an error and its causes on one line, as the CLI prints it.
fn message(error: &anyhow::Error) -> String {
    error.chain().map(ToString::to_string).collect::<Vec<_>>().join(": ")
}

/// Joint states from an argument: one (`(4,)`) or many (`(n, 4)`).
struct States {
    rows: Vec<[f64; 4]>,
    single: bool,
}

fn states(name: &str, array: &PyArrayLikeDyn<'_, f64, AllowTypeChange>) -> PyResult<States> {
    let shape = array.shape().to_vec();
    let view = array.as_array();
    let count = match shape.as_slice() {
        [4] => 1,
        [n, 4] => *n,
        _ => {
            return Err(PyValueError::new_err(format!(
                "{name}: shape {shape:?}; a joint state has shape (4,), many states (n, 4)"
            )));
        }
    };
    let mut rows: Vec<[f64; 4]> = reserved(name, count, 4)?;
    if shape.len() == 1 {
        rows.push(std::array::from_fn(|j| view[[j]]));
    } else {
        rows.extend((0..count).map(|i| std::array::from_fn(|j| view[[i, j]])));
    }
    if let Some((i, row)) = rows.iter().enumerate().find(|(_, row)| row.iter().any(|v| !v.is_finite())) {
        return Err(PyValueError::new_err(format!("{name}[{i}] = {row:?} is not finite")));
    }
    // Joint angles beyond ±1.6e6 rad would give NaN sines in the kinematics and dynamics.
    let limit = chessarm_core::lanes::SIN_COS_LIMIT;
    if name == "q"
        && let Some((i, row)) = rows.iter().enumerate().find(|(_, row)| row.iter().any(|v| v.abs() > limit))
    {
        return Err(PyValueError::new_err(format!("{name}[{i}] = {row:?} rad: an angle is beyond ±{limit:e} rad")));
    }
    Ok(States { rows, single: shape.len() == 1 })
}

/// An empty vector with room for `count` items of `numbers` f64 each, or `MemoryError` naming
/// `what` and the bytes it would take (Rust would abort the interpreter on a failed allocation).
fn reserved<T>(what: &str, count: usize, numbers: usize) -> PyResult<Vec<T>> {
    let mut values = Vec::new();
    values.try_reserve_exact(count).map_err(|_| {
        let bytes = (count as f64) * (numbers * 8) as f64;
        PyMemoryError::new_err(format!(
            "{what}: {count} states need {} GB, more than this machine can give; pass fewer at a time",
            chessarm_core::short_number(bytes / 1e9)
        ))
    })?;
    Ok(values)
}

/// The arguments' states, all one or all many of the same count.
fn matched(arguments: &[(&str, &PyArrayLikeDyn<'_, f64, AllowTypeChange>)]) -> PyResult<(Vec<Vec<[f64; 4]>>, bool)> {
    let mut all = Vec::new();
    let mut single = None;
    let mut count = None;
    for (name, array) in arguments {
        let given = states(name, array)?;
        if single.is_some_and(|s| s != given.single) || count.is_some_and(|c| c != given.rows.len()) {
            let shape = |single: bool, rows: usize| if single { "(4,)".to_string() } else { format!("({rows}, 4)") };
            return Err(PyValueError::new_err(format!(
                "{name}: shape {} where {} has shape {}: give every argument the same shape",
                shape(given.single, given.rows.len()),
                arguments[0].0,
                shape(single.unwrap_or(true), count.unwrap_or(0))
            )));
        }
        single = Some(given.single);
        count = Some(given.rows.len());
        all.push(given.rows);
    }
    Ok((all, single.unwrap_or(true)))
}

/// An array of `shape` per state (stacked along a first axis unless `single`).
fn output<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    count: usize,
    shape: &[usize],
    single: bool,
) -> Bound<'py, PyArrayDyn<f64>> {
    let mut full = if single { Vec::new() } else { vec![count] };
    full.extend_from_slice(shape);
    ArrayD::from_shape_vec(IxDyn(&full), values).expect("the values fill the shape").into_pyarray(py)
}

/// A 4×4 matrix's entries row by row.
fn row_major(m: &chessarm_core::nalgebra::Matrix4<f64>) -> [f64; 16] {
    std::array::from_fn(|k| m[(k / 4, k % 4)])
}

/// A 4-DOF arm: base yaw and three pitch joints, in standard DH, with its links' masses.
#[pyclass(module = "chessarm", frozen)]
struct Arm {
    pub(crate) model: ArmModel<4>,
    pub(crate) joint_names: [String; 4],
    /// Per joint, ±1: the user's angles, rates and torques are `sign ·` the model's (a URDF's
    /// base yaw about −z is −1), so every array in or out is in the file's own sense.
    pub(crate) signs: [f64; 4],
}

/// How a result turns with the joints' signs `S`.
#[derive(Clone, Copy)]
enum Turn {
    /// Not at all (poses, tool points).
    None,
    /// Per joint (`S v`).
    Joints,
    /// Rows and columns (`S M S`, 4×4).
    Both,
    /// Columns (a Jacobian, rows × 4).
    Columns,
}

impl Arm {
    /// `f(states…) → values` over every state, without the GIL; one state's values have `shape`.
    fn map<'py, const K: usize>(
        &self,
        py: Python<'py>,
        arguments: &[(&str, &PyArrayLikeDyn<'_, f64, AllowTypeChange>)],
        (shape, turn): (&[usize], Turn),
        f: impl Fn(&ArmModel<4>, &[JointVector<4>]) -> Result<[f64; K], String> + Send + Sync,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        debug_assert_eq!(shape.iter().product::<usize>(), K);
        // Every argument's copy and the result, estimated before anything is allocated: a batch
        // the machine cannot hold is a MemoryError, as the CLI refuses it from the same estimate.
        if let Some((name, first)) = arguments.first()
            && let [rows, 4] = first.shape()
        {
            let numbers = (4 * arguments.len() + K) as f64;
            chessarm::app::resources::ensure_fits(
                &format!("{name} of shape ({rows}, 4)"),
                "numbers",
                *rows as f64 * numbers,
                8.0,
            )
            .map_err(|e| PyMemoryError::new_err(e.to_string()))?;
        }
        let (all, single) = matched(arguments)?;
        let count = all[0].len();
        let model = self.model;
        let mut values: Vec<[f64; K]> = reserved("the result", count, K)?;
        let at = |i: usize, e: String| if count > 1 { format!("state {i}: {e}") } else { e };
        let names: Vec<&str> = arguments.iter().map(|(name, _)| *name).collect();
        py.detach(|| {
            let mut state = Vec::with_capacity(all.len());
            for i in 0..count {
                state.clear();
                let signs = JointVector::<4>::from(self.signs);
                state.extend(all.iter().map(|rows| JointVector::<4>::from(rows[i]).component_mul(&signs)));
                let mut one = f(&model, &state).map_err(|e| DynamicsError::new_err(at(i, e)))?;
                let columns = if K >= 4 { K / shape[0].max(1) } else { 0 };
                for (k, value) in one.iter_mut().enumerate() {
                    *value *= match turn {
                        Turn::None => 1.0,
                        Turn::Joints => signs[k],
                        Turn::Both => signs[k / 4] * signs[k % 4],
                        Turn::Columns => signs[k % columns.max(1)],
                    };
                    *value += 0.0;
                }
                // The CLI refuses what overflows; so does Python, rather than return inf or NaN.
                if one.iter().any(|v| !v.is_finite()) {
                    let given = names
                        .iter()
                        .zip(&state)
                        .map(|(name, v)| {
                            format!(
                                "{name} = [{}]",
                                v.iter().map(|x| chessarm_core::short_number(*x)).collect::<Vec<_>>().join(", ")
                            )
                        })
                        .collect::<Vec<_>>()
                        .join(", ");
                    return Err(PyValueError::new_err(at(
                        i,
                        format!("the result at {given} is not a finite number (it overflows); give smaller values"),
                    )));
                }
                values.push(one);
            }
            Ok(())
        })?;
        Ok(output(py, values.into_flattened(), count, shape, single))
    }
}

#[pymethods]
impl Arm {
    /// The report's arm (the CLI's default).
    #[staticmethod]
    fn default() -> Self {
        let setup = Setup::default();
        Self { model: setup.arm, joint_names: setup.joint_names, signs: [1.0; 4] }
    }

    /// The arm of a setup file (TOML, as `chessarm --arm FILE`).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        let setup = Setup::load(Some(&path)).map_err(|e| ModelError::new_err(message(&e)))?;
        if setup.urdf.is_some() {
            return Err(ModelError::new_err(format!(
                "{}: its [urdf] table is for the arm of a URDF: use Arm.from_urdf(…) (and the file with the CLI's --urdf)",
                path.display()
            )));
        }
        Ok(Self { model: setup.arm, joint_names: setup.joint_names, signs: [1.0; 4] })
    }

    /// The arm of a URDF file (as `chessarm --urdf FILE`): `lock` holds joints at values
    /// (`{"wrist_roll": 0.0}`, as `--lock`), `tool` names the tool link and `tool_offset` the
    /// tool point in its frame (m). Angles in and out are in the file's own sense.
    #[staticmethod]
    #[pyo3(signature = (path, lock = None, tool = None, tool_offset = None))]
    fn from_urdf(
        path: PathBuf,
        lock: Option<std::collections::BTreeMap<String, f64>>,
        tool: Option<String>,
        tool_offset: Option<[f64; 3]>,
    ) -> PyResult<Self> {
        let options = chessarm::app::setup::urdf_import::ImportOptions {
            locks: lock.unwrap_or_default().into_iter().collect(),
            tool,
            tool_offset: Vector3::from(tool_offset.unwrap_or([0.0; 3])),
        };
        if let Some((name, value)) = options.locks.iter().find(|(_, v)| !v.is_finite()) {
            return Err(PyValueError::new_err(format!("lock {name} = {value} is not finite")));
        }
        if options.tool_offset.iter().any(|v| !v.is_finite()) {
            return Err(PyValueError::new_err(format!("tool_offset = {tool_offset:?} is not finite")));
        }
        let imported =
            chessarm::app::setup::urdf_import::load(&path, &options).map_err(|e| ModelError::new_err(message(&e)))?;
        Ok(Self { model: imported.model, joint_names: imported.joint_names, signs: imported.signs })
    }

    /// The joints' names (the URDF's, or joint1…joint4).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.joint_names.to_vec()
    }

    /// Standard DH parameters per joint: rows (a m, alpha rad, d m, theta_offset rad).
    #[getter]
    fn dh<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let values = self.model.links().iter().flat_map(|l| [l.dh.a, l.dh.alpha, l.dh.d, l.dh.theta_offset]).collect();
        output(py, values, 4, &[4], false)
    }

    /// The arm as URDF text (as `chessarm urdf`).
    fn to_urdf(&self) -> String {
        chessarm::app::formats::urdf::to_urdf(
            &self.model,
            "chessarm",
            &self.joint_names,
            &self.signs,
            chessarm_core::arm::bodies::Gripper::default().palm_depth(),
        )
    }

    /// Pose of the tool frame (origin at the tool tip): a 4×4 homogeneous transform, m.
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<16>(py, &[("q", &q)], (&[4, 4], Turn::None), |model, s| {
            Ok(row_major(&FrameChain::new(model, &s[0]).body_pose(3).to_homogeneous()))
        })
    }

    /// Tool tip and pitch `(x, y, z, pitch)`: m and rad (−π/2: pointing down).
    fn tool_point<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<4>(py, &[("q", &q)], (&[4], Turn::None), |model, s| Ok(tool_point(model, &s[0]).into()))
    }

    /// Geometric Jacobian of the tool tip, 6×4: rows vx, vy, vz, ωx, ωy, ωz in the base frame
    /// (Pinocchio's LOCAL_WORLD_ALIGNED).
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<24>(py, &[("q", &q)], (&[6, 4], Turn::Columns), |model, s| {
            let chain = FrameChain::new(model, &s[0]);
            let (linear, angular) = chain.point_jacobian(&chain.tip(), 3);
            Ok(std::array::from_fn(|k| {
                let (r, c) = (k / 4, k % 4);
                if r < 3 { linear[(r, c)] } else { angular[(r - 3, c)] }
            }))
        })
    }

    /// Closed-form inverse kinematics (elbow up) for the tool tip at `xyz` (m) with `pitch`
    /// (rad): the joint angles, rad. Raises `UnreachableError` with the reason.
    #[pyo3(signature = (xyz, pitch = TOOL_DOWN), text_signature = "(self, xyz, pitch=-1.5707963267948966)")]
    fn ik<'py>(&self, py: Python<'py>, xyz: [f64; 3], pitch: f64) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        if !pitch.is_finite() {
            return Err(PyValueError::new_err(format!("pitch = {pitch} is not finite")));
        }
        let q = inverse_kinematics(&self.model, &Vector3::from(xyz), pitch)
            .map_err(|e| UnreachableError::new_err(e.to_string()))?;
        let q: Vec<f64> = q.iter().zip(self.signs).map(|(v, sign)| sign * v + 0.0).collect();
        Ok(output(py, q, 1, &[4], true))
    }

    /// Joint-space mass matrix M(q), kg·m².
    fn mass_matrix<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<16>(py, &[("q", &q)], (&[4, 4], Turn::Both), |model, s| Ok(row_major(&mass_matrix(model, &s[0]))))
    }

    /// Inverse dynamics (closed form for the yaw–pitch family, recursive Newton–Euler otherwise):
    /// τ = M(q) a + C(q, v) v + g(q), N·m.
    fn rnea<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        v: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        a: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<4>(py, &[("q", &q), ("v", &v), ("a", &a)], (&[4], Turn::Joints), |model, s| {
            Ok(inverse_dynamics(model, &s[0], &s[1], &s[2]).into())
        })
    }

    /// Forward dynamics, the inverse of `rnea` (as Pinocchio's `aba`, without friction):
    /// a = M(q)⁻¹ (τ − C(q, v) v − g(q)), rad/s².
    fn aba<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        v: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        tau: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<4>(py, &[("q", &q), ("v", &v), ("tau", &tau)], (&[4], Turn::Joints), |model, s| {
            // Friction cancelled: the core's forward dynamics adds τ_friction(v).
            let tau = s[2] - friction_torques(model, &s[1]);
            forward_dynamics(model, &s[0], &s[1], &tau).map(Into::into).map_err(|e| e.to_string())
        })
    }

    /// Forward dynamics of the simulated plant, friction included:
    /// a = M(q)⁻¹ (τ + τ_friction(v) − C(q, v) v − g(q)), rad/s² (`aba` when the arm has none).
    fn forward_dynamics<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        v: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        tau: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<4>(py, &[("q", &q), ("v", &v), ("tau", &tau)], (&[4], Turn::Joints), |model, s| {
            forward_dynamics(model, &s[0], &s[1], &s[2]).map(Into::into).map_err(|e| e.to_string())
        })
    }

    /// Gravity torques g(q), N·m.
    fn gravity<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<4>(py, &[("q", &q)], (&[4], Turn::Joints), |model, s| Ok(gravity_torques(model, &s[0]).into()))
    }

    /// Coriolis matrix C(q, v) (Christoffel symbols; Ṁ − 2C skew-symmetric), N·m·s/rad.
    fn coriolis<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        v: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.map::<16>(py, &[("q", &q), ("v", &v)], (&[4, 4], Turn::Both), |model, s| {
            Ok(row_major(&coriolis_matrix(model, &s[0], &s[1])))
        })
    }

    fn __repr__(&self) -> String {
        let links = self.model.links();
        format!(
            "Arm(joints={:?}, a=[{}], d=[{}] m)",
            self.joint_names,
            links.iter().map(|l| format!("{:.4}", l.dh.a)).collect::<Vec<_>>().join(", "),
            links.iter().map(|l| format!("{:.4}", l.dh.d)).collect::<Vec<_>>().join(", ")
        )
    }
}

#[pymodule]
fn _chessarm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Arm>()?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("ModelError", m.py().get_type::<ModelError>())?;
    m.add("UnreachableError", m.py().get_type::<UnreachableError>())?;
    m.add("DynamicsError", m.py().get_type::<DynamicsError>())?;
    m.add("CommandError", m.py().get_type::<CommandError>())?;
    m.add("PlanError", m.py().get_type::<PlanError>())?;
    m.add("SimulationError", m.py().get_type::<SimulationError>())?;
    m.add("GameError", m.py().get_type::<GameError>())?;
    m.add("ChessarmWarning", m.py().get_type::<ChessarmWarning>())?;
    m.add_function(wrap_pyfunction!(run_cli, m)?)?;
    m.add_class::<setup::PySetup>()?;
    m.add_class::<plan::Plan>()?;
    m.add_class::<plan::PlannedMove>()?;
    m.add_class::<simulate::Simulation>()?;
    m.add_class::<simulate::Run>()?;
    m.add_class::<play::Game>()?;
    m.add_class::<play::Ply>()?;
    m.add_class::<simulator::Simulator>()?;
    m.add_function(wrap_pyfunction!(plan::plan, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(play::play, m)?)?;
    m.add_class::<sweeps::Tuning>()?;
    m.add_class::<sweeps::Campaign>()?;
    m.add_function(wrap_pyfunction!(sweeps::tune, m)?)?;
    m.add_function(wrap_pyfunction!(sweeps::robustness, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
