//! `chessarm.plan(setup, …)` in memory: a scenario's or a list of moves' path and joint
//! trajectory (`app::studies::plan`), as NumPy arrays.

use crate::common::{bad_value, column, positive, pythonic, rows};
use crate::errors::{PlanError, UnreachableError};
use crate::setup::PySetup;
use chessarm::app::studies::plan::{MovesPlan, Plan as ScenarioPlan, plan_moves, plan_scenario};
use chessarm::cli::{MotionArgs, TimingChoice};
use chessarm_core::arm::model::ArmModel;
use chessarm_core::plan::path::{CartesianSample, GripperAction};
use chessarm_core::plan::trajectory::{JointSample, ToolMotion};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;

/// The motion limits `motion={…}` may change (`[motion]` and `[gripper]` of a setup file, the
/// command line's motion flags).
const MOTION_KEYS: [&str; 18] = [
    "tool_speed",
    "joint_acceleration",
    "torque_margin",
    "carry_acceleration",
    "grip_strength",
    "grip_dwell",
    "release_dwell",
    "blend",
    "clearance_margin",
    "grid_step",
    "pace",
    "jerk",
    "tracking_budget",
    "traverse_speed",
    "traverse_acceleration",
    "vertical_speed",
    "vertical_acceleration",
    "pause",
];

/// The motion options as the command line's flags would give them: `timing` (`optimal` or
/// `lspb`) and `motion`, a dict of limits by name (`{"tool_speed": 0.5}`).
pub fn motion_args(timing: Option<&str>, motion: Option<&Bound<'_, PyDict>>) -> PyResult<MotionArgs> {
    let timing = match timing {
        None | Some("optimal") => TimingChoice::Optimal,
        Some("lspb") => TimingChoice::Lspb,
        Some(other) => return Err(PyValueError::new_err(format!("timing={other:?}: not one of optimal, lspb"))),
    };
    let mut args = MotionArgs {
        timing,
        tool_speed: None,
        joint_acceleration: None,
        torque_margin: None,
        carry_acceleration: None,
        grip_strength: None,
        grip_dwell: None,
        release_dwell: None,
        blend: None,
        clearance_margin: None,
        grid_step: None,
        pace: None,
        jerk: None,
        tracking_budget: None,
        traverse_speed: None,
        traverse_acceleration: None,
        vertical_speed: None,
        vertical_acceleration: None,
        pause: None,
    };
    let Some(motion) = motion else { return Ok(args) };
    for (key, value) in motion.iter() {
        let key: String = key.extract().map_err(|_| PyValueError::new_err("motion: its keys are names"))?;
        let name = format!("motion[{key:?}]");
        if key == "joint_acceleration" {
            let values = match value.extract::<f64>() {
                Ok(one) => vec![one],
                Err(_) => crate::common::numbers::<4>(&name, &value)?.to_vec(),
            };
            for v in &values {
                positive(&name, *v)?;
            }
            args.joint_acceleration = Some(values);
            continue;
        }
        let number: f64 = value.extract().map_err(|_| bad_value(&name, &value, "needs a number"))?;
        // As the flags check them: positive speeds and accelerations, shares in (0, 1], times ≥ 0.
        let zero_allowed =
            matches!(key.as_str(), "grip_dwell" | "release_dwell" | "blend" | "jerk" | "tracking_budget" | "pause");
        if zero_allowed {
            crate::common::non_negative(&name, number)?;
        } else {
            positive(&name, number)?;
        }
        if key == "torque_margin" && number > 1.0 {
            return Err(PyValueError::new_err(format!("{name}={number}: a share in (0, 1]")));
        }
        let field = match key.as_str() {
            "tool_speed" => &mut args.tool_speed,
            "torque_margin" => &mut args.torque_margin,
            "carry_acceleration" => &mut args.carry_acceleration,
            "grip_strength" => &mut args.grip_strength,
            "grip_dwell" => &mut args.grip_dwell,
            "release_dwell" => &mut args.release_dwell,
            "blend" => &mut args.blend,
            "clearance_margin" => &mut args.clearance_margin,
            "grid_step" => &mut args.grid_step,
            "pace" => &mut args.pace,
            "jerk" => &mut args.jerk,
            "tracking_budget" => &mut args.tracking_budget,
            "traverse_speed" => &mut args.traverse_speed,
            "traverse_acceleration" => &mut args.traverse_acceleration,
            "vertical_speed" => &mut args.vertical_speed,
            "vertical_acceleration" => &mut args.vertical_acceleration,
            "pause" => &mut args.pause,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "motion: no limit named {key:?} (known: {})",
                    MOTION_KEYS.join(", ")
                )));
            }
        };
        *field = Some(number);
    }
    Ok(args)
}

/// Whether the motion options change anything.
fn motion_given(timing: Option<&str>, motion: Option<&Bound<'_, PyDict>>) -> bool {
    timing.is_some() || motion.is_some_and(|m| !m.is_empty())
}

/// One move of a plan of moves.
#[pyclass(module = "chessarm", frozen, get_all)]
#[derive(Debug)]
pub struct PlannedMove {
    /// 1 for the first move of the list.
    pub ply: usize,
    pub san: String,
    pub uci: String,
    /// quiet, capture, en-passant, castle-kingside, castle-queenside, promotion, promotion-capture.
    pub kind: String,
    /// When the move starts on the plan's clock, s.
    pub start: f64,
    /// s.
    pub duration: f64,
    /// The gripper's commands, (time on the plan's clock s, "grip" or "release").
    pub events: Vec<(f64, String)>,
    /// Time-optimal timing: the limit binding longest and for how long (s).
    pub longest_limit: Option<(String, f64)>,
    /// The planned time by phase (travel, vertical, grip, pause), s.
    pub phases: std::collections::BTreeMap<String, f64>,
}

impl PlannedMove {
    fn of(ply: &chessarm::app::studies::plan::PlannedPly, events: Vec<(f64, String)>) -> Self {
        let phases = &ply.planned.phases;
        Self {
            ply: ply.ply,
            san: ply.san.clone(),
            uci: ply.uci.clone(),
            kind: ply.kind.to_string(),
            start: ply.start,
            duration: ply.planned.motion.duration(),
            events,
            longest_limit: ply.planned.longest_limit().map(|(name, t)| (name.to_string(), t)),
            phases: [
                ("travel".to_string(), phases.travel),
                ("vertical".to_string(), phases.vertical),
                ("grip".to_string(), phases.grip),
                ("pause".to_string(), phases.pause),
            ]
            .into(),
        }
    }
}

#[pymethods]
impl PlannedMove {
    fn __repr__(&self) -> String {
        format!(
            "PlannedMove(ply={}, san={:?}, uci={:?}, start={:.3}, duration={:.3})",
            self.ply, self.san, self.uci, self.start, self.duration
        )
    }
}

/// What a [`Plan`] holds of the study's result, for `simulate`.
#[derive(Debug, Clone)]
pub enum Planned {
    Scenario(Arc<ScenarioPlan>),
    Moves(Arc<MovesPlan>),
}

/// A planned motion: the joints' trajectory (`t`, `q`, `qd`, `qdd`) and the tool's path
/// (`tool`, `tool_velocity`, `tool_acceleration`), sampled every `dt`. A plan of moves holds each
/// move's samples in turn (as `joint.csv`): a move's last and the next one's first share an instant.
#[pyclass(module = "chessarm", frozen)]
#[derive(Debug)]
pub struct Plan {
    pub(crate) planned: Planned,
    /// The arm it was planned for (simulate refuses it for another).
    pub(crate) arm: ArmModel<4>,
    /// "scenario" or "moves".
    #[pyo3(get)]
    kind: &'static str,
    /// The scenario's name, or the moves as given.
    #[pyo3(get)]
    name: String,
    /// The starting position of moves (FEN; `None`: the initial position or a scenario).
    #[pyo3(get)]
    fen: Option<String>,
    /// The sample period, s.
    #[pyo3(get)]
    pub(crate) dt: f64,
    /// s.
    #[pyo3(get)]
    duration: f64,
    /// s, shape (n,).
    #[pyo3(get)]
    t: Py<PyAny>,
    /// Desired joint angles rad, rates rad/s, accelerations rad/s²: shape (n, 4), in the
    /// setup's joint convention.
    #[pyo3(get)]
    q: Py<PyAny>,
    #[pyo3(get)]
    qd: Py<PyAny>,
    #[pyo3(get)]
    qdd: Py<PyAny>,
    /// The tool tip's path: position m, velocity m/s, acceleration m/s², shape (n, 3).
    #[pyo3(get)]
    tool: Py<PyAny>,
    #[pyo3(get)]
    tool_velocity: Py<PyAny>,
    #[pyo3(get)]
    tool_acceleration: Py<PyAny>,
    /// The gripper's commands: (t s, "grip" or "release"), in order.
    #[pyo3(get)]
    events: Vec<(f64, String)>,
    /// Moves only: each move's names, start and duration.
    #[pyo3(get)]
    plies: Vec<Py<PlannedMove>>,
}

fn action_name(action: GripperAction) -> String {
    match action {
        GripperAction::Grip => "grip".into(),
        GripperAction::Release => "release".into(),
    }
}

impl Plan {
    /// The Python object of a planned scenario or moves.
    pub(crate) fn new(
        py: Python<'_>,
        setup: &PySetup,
        planned: Planned,
        fen: Option<String>,
        dt: f64,
    ) -> PyResult<Self> {
        let user = |values: [f64; 4]| setup.setup.convention.user(values);
        let (joint, cartesian): (&[JointSample], &[CartesianSample]) = match &planned {
            Planned::Scenario(plan) => (plan.joint.samples(), &plan.cartesian),
            Planned::Moves(plan) => (&plan.joint, &plan.cartesian),
        };
        let (name, kind, duration) = match &planned {
            Planned::Scenario(plan) => (plan.name.clone(), "scenario", plan.path.duration()),
            Planned::Moves(plan) => (String::new(), "moves", plan.duration),
        };
        let mut events = Vec::new();
        let mut plies = Vec::new();
        match &planned {
            Planned::Scenario(plan) => {
                events.extend(plan.path.events().iter().map(|e| (e.time, action_name(e.action))));
            }
            Planned::Moves(plan) => {
                for ply in &plan.plies {
                    let move_events: Vec<(f64, String)> = ply
                        .planned
                        .gripper_commands()
                        .iter()
                        .map(|c| (ply.start + c.time, action_name(c.action)))
                        .collect();
                    events.extend(move_events.iter().cloned());
                    plies.push(Py::new(py, PlannedMove::of(ply, move_events))?);
                }
            }
        }
        Ok(Self {
            arm: setup.setup.arm,
            kind,
            name,
            fen,
            dt,
            duration,
            t: column(py, joint.iter().map(|s| s.t))?,
            q: rows(py, joint.iter().map(|s| user(s.q.into())))?,
            qd: rows(py, joint.iter().map(|s| user(s.qd.into())))?,
            qdd: rows(py, joint.iter().map(|s| user(s.qdd.into())))?,
            tool: rows(py, cartesian.iter().map(|s| <[f64; 3]>::from(s.position)))?,
            tool_velocity: rows(py, cartesian.iter().map(|s| <[f64; 3]>::from(s.velocity)))?,
            tool_acceleration: rows(py, cartesian.iter().map(|s| <[f64; 3]>::from(s.acceleration)))?,
            events,
            plies,
            planned,
        })
    }
}

#[pymethods]
impl Plan {
    fn __len__(&self) -> usize {
        match &self.planned {
            Planned::Scenario(plan) => plan.joint.samples().len(),
            Planned::Moves(plan) => plan.joint.len(),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "Plan({} {:?}, {} samples every {} s, {:.3} s)",
            self.kind,
            self.name,
            self.__len__(),
            self.dt,
            self.duration
        )
    }
}

/// Plans a built-in scenario (`scenario`, default `queens-gambit`) or a list of moves
/// (`moves="e4 e5"`, SAN or UCI, from `fen` or the initial position), sampled every `dt` s. For
/// moves, `timing` (`optimal`, `lspb`) and `motion` (a dict of limits: `tool_speed`, …) change
/// the motion as the command line's motion flags do.
#[pyfunction]
#[pyo3(signature = (setup, scenario = None, *, moves = None, fen = None, dt = 0.001, timing = None, motion = None))]
#[allow(clippy::too_many_arguments)]
pub fn plan(
    py: Python<'_>,
    setup: &Bound<'_, PySetup>,
    scenario: Option<String>,
    moves: Option<String>,
    fen: Option<String>,
    dt: f64,
    timing: Option<&str>,
    motion: Option<&Bound<'_, PyDict>>,
) -> PyResult<Plan> {
    let setup = setup.get();
    positive("dt", dt)?;
    match (scenario, moves) {
        (Some(_), Some(_)) => Err(PyValueError::new_err("give scenario= or moves=, not both")),
        (scenario, None) => {
            if fen.is_some() {
                return Err(PyValueError::new_err("fen is for moves=: a scenario has its own start"));
            }
            if motion_given(timing, motion) {
                return Err(PyValueError::new_err("timing and motion are for moves=: a scenario keeps its own timing"));
            }
            let name = scenario.unwrap_or_else(|| "queens-gambit".into());
            check_scenario(&name)?;
            let arc = setup.setup.clone();
            let cause = format!("dt={}", chessarm::app::resources::show(dt));
            let planned = py.detach(|| plan_scenario(&arc, &name, dt, &cause)).map_err(|e| plan_error(&e))?;
            Plan::new(py, setup, Planned::Scenario(Arc::new(planned)), None, dt)
        }
        (None, Some(moves)) => {
            let start = match &fen {
                Some(fen) => chessarm_chess::notation::parse_fen(fen)
                    .map_err(|e| PyValueError::new_err(format!("fen={fen:?}: {e}")))?,
                None => chessarm_chess::shakmaty::Chess::default(),
            };
            chessarm_chess::notation::parse_move_list(&moves, start)
                .map_err(|e| PyValueError::new_err(format!("moves={moves:?}: {e}")))?;
            let motion = motion_args(timing, motion)?;
            let moved =
                motion.apply(&setup.setup).map_err(|e| PyValueError::new_err(format!("motion: {}", pythonic(&e))))?;
            let planned = py.detach(|| plan_moves(&moved, fen.as_deref(), &moves, dt)).map_err(|e| plan_error(&e))?;
            let mut plan = Plan::new(py, setup, Planned::Moves(Arc::new(planned)), fen, dt)?;
            plan.name = moves;
            Ok(plan)
        }
    }
}

/// A known scenario's name, or a `ValueError` listing them.
pub fn check_scenario(name: &str) -> PyResult<()> {
    if chessarm_chess::scenario::SCENARIOS.contains(&name) {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "scenario={name:?}: not one of {}",
            chessarm_chess::scenario::SCENARIOS.join(", ")
        )))
    }
}

/// A failed plan: `UnreachableError` when the path leaves the arm's reach, else `PlanError`.
fn plan_error(error: &anyhow::Error) -> PyErr {
    let message = pythonic(error);
    let unreachable = error.chain().any(|cause| cause.downcast_ref::<chessarm_core::arm::task::IkError>().is_some());
    if unreachable { UnreachableError::new_err(message) } else { PlanError::new_err(message) }
}
