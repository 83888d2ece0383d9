//! `chessarm.Setup`: the setup resolved once, as the command line resolves its global flags
//! (`app::setup::resolve`): the setup file, a URDF with its locks and tool, the actuators.

use crate::Arm;
use crate::common::{numbers, pythonic, rows, warn};
use crate::errors::ModelError;
use chessarm::app::setup::file::Setup;
use chessarm::app::setup::{SetupOptions, resolve};
use chessarm_core::control::servo_host::ServoCommand;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;

/// The arm, board, pieces, motion limits and actuators of a study, resolved once.
#[pyclass(module = "chessarm", name = "Setup", frozen)]
#[derive(Debug)]
pub struct PySetup {
    pub(crate) setup: Arc<Setup>,
    pub(crate) notes: Vec<String>,
    pub(crate) options: SetupOptions,
}

/// Everything [`resolve`] takes, read from Python's arguments.
#[allow(clippy::too_many_arguments)]
fn options(
    arm: Option<PathBuf>,
    urdf: Option<PathBuf>,
    lock: Option<std::collections::BTreeMap<String, f64>>,
    tool: Option<String>,
    tool_offset: Option<&Bound<'_, PyAny>>,
    actuator: Option<&Bound<'_, PyAny>>,
    servo_command: Option<&Bound<'_, PyAny>>,
    bus_rate: Option<f64>,
) -> PyResult<SetupOptions> {
    if urdf.is_none() && (lock.is_some() || tool.is_some() || tool_offset.is_some_and(|t| !t.is_none())) {
        return Err(PyValueError::new_err(
            "lock, tool and tool_offset are for the arm of a URDF: give urdf= with them",
        ));
    }
    let lock: Vec<(String, f64)> = lock.unwrap_or_default().into_iter().collect();
    if let Some((name, value)) = lock.iter().find(|(_, v)| !v.is_finite()) {
        return Err(PyValueError::new_err(format!("lock={{{name:?}: {value}}}: the value must be finite")));
    }
    let tool_offset = tool_offset.filter(|t| !t.is_none()).map(|t| numbers::<3>("tool_offset", t)).transpose()?;
    let actuator = actuator.filter(|a| !a.is_none()).map(|a| crate::common::names("actuator", a)).transpose()?;
    if let Some(names) = &actuator
        && !(names.len() == 1 || names.len() == 4)
    {
        return Err(PyValueError::new_err(format!(
            "actuator={names:?}: give one name for every joint or 4, one per joint"
        )));
    }
    let servo_command = servo_command
        .filter(|s| !s.is_none())
        .map(|given| {
            crate::common::names("servo_command", given)?
                .iter()
                .map(|name| {
                    ServoCommand::from_name(name).ok_or_else(|| {
                        PyValueError::new_err(format!(
                            "servo_command={name:?}: not one of {}",
                            ServoCommand::ALL.map(ServoCommand::name).join(", ")
                        ))
                    })
                })
                .collect::<PyResult<Vec<_>>>()
        })
        .transpose()?;
    if let Some(rate) = bus_rate {
        crate::common::positive("bus_rate", rate)?;
    }
    Ok(SetupOptions { arm, urdf, lock, tool, tool_offset, actuator, servo_command, bus_rate })
}

impl PySetup {
    /// Resolves `options` (the GIL released: a URDF's meshes may take a moment); its notes and
    /// warnings become Python warnings.
    fn resolved(py: Python<'_>, options: SetupOptions) -> PyResult<Self> {
        let given = options.clone();
        let resolved = py.detach(|| resolve(&given)).map_err(|e| ModelError::new_err(pythonic(&e)))?;
        for note in &resolved.notes {
            warn(py, note)?;
        }
        Ok(Self { setup: Arc::new(resolved.setup), notes: resolved.notes, options })
    }
}

#[pymethods]
impl PySetup {
    /// A setup as the command line's global flags make it: `arm` a setup file (TOML, `--arm`),
    /// `urdf` a URDF (`--urdf`) with `lock`, `tool`, `tool_offset`; `actuator` one name for
    /// every joint or four (`--actuator`); `servo_command` and `bus_rate` for servos.
    #[new]
    #[pyo3(signature = (arm = None, urdf = None, *, lock = None, tool = None, tool_offset = None, actuator = None, servo_command = None, bus_rate = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        arm: Option<PathBuf>,
        urdf: Option<PathBuf>,
        lock: Option<std::collections::BTreeMap<String, f64>>,
        tool: Option<String>,
        tool_offset: Option<&Bound<'_, PyAny>>,
        actuator: Option<&Bound<'_, PyAny>>,
        servo_command: Option<&Bound<'_, PyAny>>,
        bus_rate: Option<f64>,
    ) -> PyResult<Self> {
        let options = options(arm, urdf, lock, tool, tool_offset, actuator, servo_command, bus_rate)?;
        Self::resolved(py, options)
    }

    /// The report's arm, board and pieces (the CLI's default), with torque motors unless
    /// `actuator` names others.
    #[staticmethod]
    #[pyo3(signature = (*, actuator = None, servo_command = None, bus_rate = None))]
    fn default(
        py: Python<'_>,
        actuator: Option<&Bound<'_, PyAny>>,
        servo_command: Option<&Bound<'_, PyAny>>,
        bus_rate: Option<f64>,
    ) -> PyResult<Self> {
        let options = options(None, None, None, None, None, actuator, servo_command, bus_rate)?;
        Self::resolved(py, options)
    }

    /// The setup of a setup file (TOML), as `chessarm --arm FILE`.
    #[staticmethod]
    #[pyo3(signature = (path, *, actuator = None, servo_command = None, bus_rate = None))]
    fn from_file(
        py: Python<'_>,
        path: PathBuf,
        actuator: Option<&Bound<'_, PyAny>>,
        servo_command: Option<&Bound<'_, PyAny>>,
        bus_rate: Option<f64>,
    ) -> PyResult<Self> {
        let options = options(Some(path), None, None, None, None, actuator, servo_command, bus_rate)?;
        Self::resolved(py, options)
    }

    /// The arm of a URDF (`chessarm --urdf FILE`): `lock` holds joints at values (rad, m for a
    /// prismatic joint), `tool` names the tool link, `tool_offset` the tool point in its frame
    /// (m); `arm` a setup file for the board, pieces and its `[urdf]` table (the arguments win).
    #[staticmethod]
    #[pyo3(signature = (path, *, lock = None, tool = None, tool_offset = None, actuator = None, arm = None, servo_command = None, bus_rate = None))]
    #[allow(clippy::too_many_arguments)]
    fn from_urdf(
        py: Python<'_>,
        path: PathBuf,
        lock: Option<std::collections::BTreeMap<String, f64>>,
        tool: Option<String>,
        tool_offset: Option<&Bound<'_, PyAny>>,
        actuator: Option<&Bound<'_, PyAny>>,
        arm: Option<PathBuf>,
        servo_command: Option<&Bound<'_, PyAny>>,
        bus_rate: Option<f64>,
    ) -> PyResult<Self> {
        let options = options(arm, Some(path), lock, tool, tool_offset, actuator, servo_command, bus_rate)?;
        Self::resolved(py, options)
    }

    /// The arm's kinematics and dynamics (`chessarm.Arm`), in this setup's joint convention.
    #[getter]
    fn arm(&self) -> Arm {
        Arm { model: self.setup.arm, joint_names: self.setup.joint_names.clone(), signs: self.setup.convention.signs }
    }

    /// The joints' names (the URDF's, or joint1…joint4).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.setup.joint_names.to_vec()
    }

    /// What drives each joint: `torque` (a torque motor) or a servo's or stepper's name.
    #[getter]
    fn actuator_names(&self) -> Vec<String> {
        self.setup.actuator_names.to_vec()
    }

    /// Whether the joints take goal positions (servos, steppers) rather than torques.
    #[getter]
    fn servos(&self) -> bool {
        self.setup.actuators.take_positions()
    }

    /// With servos: the host's goal strategies (`plain`, `sag`, `feedforward`).
    #[getter]
    fn servo_commands(&self) -> Vec<&'static str> {
        self.setup.servo_commands.iter().map(|c| c.name()).collect()
    }

    /// With servos: the bus's rate, Hz.
    #[getter]
    fn bus_rate(&self) -> f64 {
        self.setup.bus_rate
    }

    /// Each joint's torque limit, N·m (with servos or steppers their stall torques): shape (4,).
    #[getter]
    fn torque_limits(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        crate::common::column(py, self.setup.arm.torque_limits().iter().copied())
    }

    /// Each joint's speed limit, rad/s: shape (4,).
    #[getter]
    fn velocity_limits(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        crate::common::column(py, self.setup.arm.links().iter().map(|l| l.limits.velocity))
    }

    /// Each joint's (lower, upper) angle limits in the user's convention, rad: shape (4, 2).
    #[getter]
    fn joint_limits(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        rows(py, (0..4).map(|j| <[f64; 2]>::from(self.setup.user_limits(j))))
    }

    /// Distance between neighbouring square centres, m.
    #[getter]
    fn square_size(&self) -> f64 {
        self.setup.board.square_size
    }

    /// The board: `square_size`, `center` (x, y), `surface_height`, `yaw` (rad),
    /// `base_clearance`, m, and `squares_turned` (the squares half a turn on the table).
    #[getter]
    fn board<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let board = &self.setup.board;
        let dict = PyDict::new(py);
        dict.set_item("square_size", board.square_size)?;
        dict.set_item("center", (board.center.x, board.center.y))?;
        dict.set_item("surface_height", board.surface_height)?;
        dict.set_item("yaw", board.yaw)?;
        dict.set_item("base_clearance", board.base_clearance)?;
        dict.set_item("squares_turned", board.squares_turned)?;
        Ok(dict)
    }

    /// The pieces by kind (`pawn` … `king`): `height`, `base_diameter`, `grip_height` (m),
    /// `mass` (kg), `outline` (the Staunton profile's rings `[height, radius]` in m, base up)
    /// and `head_block` (a knight's head `[top, half length, half width]` in m, or `None`).
    #[getter]
    fn pieces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let pieces = &self.setup.pieces;
        let dict = PyDict::new(py);
        for (name, piece) in [
            ("pawn", pieces.pawn),
            ("knight", pieces.knight),
            ("bishop", pieces.bishop),
            ("rook", pieces.rook),
            ("queen", pieces.queen),
            ("king", pieces.king),
        ] {
            let one = PyDict::new(py);
            one.set_item("height", piece.height)?;
            one.set_item("base_diameter", piece.base_diameter)?;
            one.set_item("grip_height", piece.grip_height)?;
            one.set_item("mass", piece.mass)?;
            let outline = piece.outline();
            one.set_item("outline", outline.rings().to_vec())?;
            one.set_item("head_block", outline.block().map(|b| vec![b.top, b.half_length, b.half_width]))?;
            dict.set_item(name, one)?;
        }
        Ok(dict)
    }

    /// The centre of a square (`"e4"`) on the board's surface, m: shape (3,).
    fn square_center(&self, py: Python<'_>, square: &str) -> PyResult<Py<PyAny>> {
        let parsed = chessarm_chess::board::parse_square(square)
            .map_err(|e| PyValueError::new_err(format!("square={square:?}: {e}")))?;
        crate::common::column(py, self.setup.board.square_center(parsed).iter().copied())
    }

    /// The sensor profiles `sensors=` takes by name: the built-in ones and the setup file's.
    #[getter]
    fn sensor_profiles(&self) -> Vec<String> {
        let mut names: Vec<String> =
            chessarm_core::sense::SensorProfile::<4>::NAMES.iter().map(|s| s.to_string()).collect();
        names.extend(self.setup.sensor_profiles.keys().cloned());
        names
    }

    /// The built-in scenarios `plan` and `simulate` take.
    #[getter]
    fn scenarios(&self) -> Vec<&'static str> {
        chessarm_chess::scenario::SCENARIOS.to_vec()
    }

    /// The setup file this setup was read from (`None`: the built-in one).
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.setup.path.clone()
    }

    /// The URDF the arm was read from, if any.
    #[getter]
    fn urdf_path(&self) -> Option<PathBuf> {
        self.setup.urdf_path.clone()
    }

    /// The base frame's name (the URDF's root link, or `base_link`).
    #[getter]
    fn base_link(&self) -> String {
        self.setup.base_link.clone()
    }

    /// What resolving the setup said (a URDF's notes and warnings), one line each; each was
    /// also given as a `chessarm.ChessarmWarning`.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// The setup as a setup file (TOML), as `chessarm arm` prints it.
    fn to_toml(&self) -> PyResult<String> {
        self.setup.to_toml().map_err(|e| ModelError::new_err(pythonic(&e)))
    }

    fn __repr__(&self) -> String {
        let mut parts = Vec::new();
        if let Some(path) = &self.options.arm {
            parts.push(format!("arm={:?}", path.display().to_string()));
        }
        if let Some(path) = &self.options.urdf {
            parts.push(format!("urdf={:?}", path.display().to_string()));
        }
        if parts.is_empty() {
            parts.push("default".into());
        }
        format!(
            "Setup({}, joints={:?}, actuators={:?}, square_size={} m)",
            parts.join(", "),
            self.setup.joint_names,
            self.setup.actuator_names,
            self.setup.board.square_size
        )
    }
}
