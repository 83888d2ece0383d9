//! `chessarm.play(setup, …)` in memory: a game of chess with the simulated arm, ply by ply
//! (the chess crate's `Game`), set up as the command line's `play` sets it up, nothing written.

use crate::common;
use crate::common::{bad_value, column, non_negative, positive, pythonic, rows};
use crate::errors::GameError;
use crate::plan::motion_args;
use crate::setup::PySetup;
use crate::simulate::{Conditions, given_gains};
use chessarm::app::setup::file::Setup;
use chessarm::app::studies::placement::Placement;
use chessarm::app::studies::play::{GameResult, PlayOptions, Played, RobotSide, game_result};
use chessarm::app::studies::simulate::ControllerName;
use chessarm::cli::IntegratorChoice;
use chessarm_chess::notation::GameRecord;
use chessarm_chess::opponent::{BuiltinEngine, Opponent, UciEngine};
use chessarm_chess::play::{Game as ChessGame, MoveReport, Mover};
use chessarm_chess::shakmaty::{Chess, Move, Position};
use pyo3::exceptions::{PyFileNotFoundError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// One ply of a game: who moved, how, and for a robot move how well (SI: m, s, N·m).
#[pyclass(module = "chessarm", frozen)]
#[derive(Debug)]
pub struct Ply {
    /// 1-based half-move number.
    #[pyo3(get)]
    ply: usize,
    #[pyo3(get)]
    san: String,
    #[pyo3(get)]
    uci: String,
    /// quiet, capture, en-passant, castle-kingside, castle-queenside, promotion, promotion-capture.
    #[pyo3(get)]
    kind: String,
    /// "robot" (the simulated arm) or "hand" (the opponent's hand puts the pieces exactly).
    #[pyo3(get)]
    by: &'static str,
    /// The pick-and-place tasks, described.
    #[pyo3(get)]
    tasks: Vec<String>,
    /// When the move started on the game's robot clock, its robot time and planned time, s.
    #[pyo3(get)]
    start: f64,
    #[pyo3(get)]
    duration: f64,
    #[pyo3(get)]
    planned_duration: f64,
    /// Largest tool-tip error during the move, m (robot moves).
    #[pyo3(get)]
    max_tip_error: Option<f64>,
    /// Per piece placed: its distance from its target's centre, m; and the largest.
    #[pyo3(get)]
    place_errors: Vec<f64>,
    #[pyo3(get)]
    placement_error: Option<f64>,
    /// The planned motion's smallest clearance to the pieces, the table and the arm itself, m,
    /// the arm's part and what it came near; the simulated motion's (a lower bound when it
    /// was not measured), and whether it touched.
    #[pyo3(get)]
    clearance: Option<f64>,
    #[pyo3(get)]
    clearance_part: Option<String>,
    #[pyo3(get)]
    clearance_obstacle: Option<String>,
    #[pyo3(get)]
    executed_clearance: Option<f64>,
    #[pyo3(get)]
    contact: bool,
    /// What the planner changed to keep the move clear.
    #[pyo3(get)]
    clearance_adjustments: Vec<String>,
    /// Robot moves: the pace the move ran at (1, or less where its simulated motion came
    /// nearer than the margin and it was run again slower), and each too-near try's simulated
    /// clearance, m (0: a contact).
    #[pyo3(get)]
    pace: Option<f64>,
    #[pyo3(get)]
    too_near_tries: Vec<f64>,
    /// Pieces found off their squares after this move (descriptions).
    #[pyo3(get)]
    misplaced: Vec<String>,
    /// The fine points' waits of the gripper: count, total s, longest s, timed out.
    #[pyo3(get)]
    waits: (usize, f64, f64, usize),
    /// Controller samples that clipped a torque; peak |τ| per joint (N·m, robot moves).
    #[pyo3(get)]
    saturated_samples: Option<usize>,
    #[pyo3(get)]
    peak_torque: Option<Py<PyAny>>,
    /// Robot moves: every 10th simulated step, as the command line's moves/NNN-uci.csv
    /// (`t` on the game's robot clock s; `q`, `q_des` rad (n, 4); `tip`, `tip_desired` m (n, 3)).
    #[pyo3(get)]
    t: Option<Py<PyAny>>,
    #[pyo3(get)]
    q: Option<Py<PyAny>>,
    #[pyo3(get)]
    q_des: Option<Py<PyAny>>,
    #[pyo3(get)]
    tau: Option<Py<PyAny>>,
    #[pyo3(get)]
    tip: Option<Py<PyAny>>,
    #[pyo3(get)]
    tip_desired: Option<Py<PyAny>>,
}

impl Ply {
    fn new(py: Python<'_>, setup: &Setup, report: &MoveReport) -> PyResult<Self> {
        let robot = report.mover == Mover::Robot;
        let records = &report.records;
        let user = |v: chessarm_core::arm::model::JointVector<4>| setup.convention.user(v);
        let series = |f: &dyn Fn(&chessarm_core::sim::StepRecord<4>) -> [f64; 4]| -> PyResult<Option<Py<PyAny>>> {
            robot.then(|| rows(py, records.iter().map(f))).transpose()
        };
        let series3 = |f: &dyn Fn(&chessarm_core::sim::StepRecord<4>) -> [f64; 3]| -> PyResult<Option<Py<PyAny>>> {
            robot.then(|| rows(py, records.iter().map(f))).transpose()
        };
        let waits = report.wait_totals();
        Ok(Self {
            ply: report.ply,
            san: report.san.clone(),
            uci: report.uci.clone(),
            kind: report.kind.name().to_string(),
            by: if robot { "robot" } else { "hand" },
            tasks: report.tasks.clone(),
            start: report.start_time,
            duration: report.duration,
            planned_duration: report.planned_duration,
            max_tip_error: report.max_tip_error,
            place_errors: report.place_errors.clone(),
            placement_error: report.place_errors.iter().copied().reduce(f64::max),
            clearance: report.clearance.as_ref().map(|c| c.distance),
            clearance_part: report.clearance.as_ref().map(|c| c.part.to_string()),
            clearance_obstacle: report.clearance.as_ref().map(|c| c.obstacle_name.clone()),
            executed_clearance: report.executed_clearance.as_ref().map(|e| e.distance()),
            contact: report.executed_clearance.as_ref().is_some_and(|e| e.is_contact()),
            clearance_adjustments: report.adjustments.clone(),
            pace: robot.then_some(report.pace),
            too_near_tries: report.too_near_at.clone(),
            misplaced: report.new_misplaced.iter().map(|m| m.reason.clone()).collect(),
            waits: (waits.count, waits.total, waits.longest, waits.timed_out),
            saturated_samples: report.summary.as_ref().map(|s| s.saturated_samples),
            peak_torque: report
                .summary
                .as_ref()
                .map(|s| column(py, user(s.peak_torque).iter().map(|v| v.abs())))
                .transpose()?,
            t: robot.then(|| column(py, records.iter().map(|r| report.start_time + r.t))).transpose()?,
            q: series(&|r| user(r.state.q))?,
            q_des: series(&|r| user(r.reference.q))?,
            tau: series(&|r| user(r.torque))?,
            tip: series3(&|r| r.tip.into())?,
            tip_desired: series3(&|r| r.tip_desired.into())?,
        })
    }
}

#[pymethods]
impl Ply {
    fn __repr__(&self) -> String {
        format!(
            "Ply({} {:?} by {}, {:.2} s, placement error {}, clearance {})",
            self.ply,
            self.san,
            self.by,
            self.duration,
            self.placement_error.map_or("-".into(), |e| format!("{:.3} mm", e * 1e3)),
            self.clearance.map_or("-".into(), |c| format!("{:.1} mm", c * 1e3)),
        )
    }
}

/// A game played with the simulated arm.
#[pyclass(module = "chessarm", frozen)]
#[derive(Debug)]
pub struct Game {
    /// "1-0", "0-1", "1/2-1/2" or "*", and why.
    #[pyo3(get)]
    result: String,
    #[pyo3(get)]
    result_reason: String,
    /// Every ply, in order.
    #[pyo3(get)]
    plies: Vec<Py<Ply>>,
    /// The pieces still off their places at the end: dicts of `ply`, `san`, `square`, `offset`
    /// (m) and `reason`.
    #[pyo3(get)]
    misplaced: Py<PyAny>,
    /// The rules' position at the end, and the table's (each piece snapped to the square under it).
    #[pyo3(get)]
    final_fen_rules: String,
    #[pyo3(get)]
    final_fen_physical: String,
    /// Every piece on the table at the end: dicts of `piece`, `location`, `x`, `y` (m).
    #[pyo3(get)]
    final_table: Py<PyAny>,
    /// The robot's time in all, s; the computation's, s.
    #[pyo3(get)]
    robot_time: f64,
    #[pyo3(get)]
    wall_time: f64,
    /// The controller (or the servos' host strategy).
    #[pyo3(get)]
    controller: String,
    /// What the command line would have said on the terminal, one line each.
    #[pyo3(get)]
    notes: Vec<String>,
}

#[pymethods]
impl Game {
    /// The robot moves' placement errors, m: shape (k,), one per piece placed.
    #[getter]
    fn placement_errors(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let mut all = Vec::new();
        for ply in &self.plies {
            all.extend(ply.get().place_errors.iter().copied());
        }
        column(py, all)
    }

    fn __len__(&self) -> usize {
        self.plies.len()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "Game({} ({}), {} plies, robot time {:.1} s, {} misplaced)",
            self.result,
            self.result_reason,
            self.plies.len(),
            self.robot_time,
            self.misplaced.bind(py).len()?
        ))
    }
}

/// The engines of a game against an engine.
#[derive(Debug)]
enum Engine {
    Builtin(BuiltinEngine),
    Uci(Box<UciEngine>),
}

impl Engine {
    fn choose(&mut self, position: &Chess) -> Result<Move, chessarm_chess::opponent::OpponentError> {
        match self {
            Engine::Builtin(engine) => engine.choose_move(position),
            Engine::Uci(engine) => engine.choose_move(position),
        }
    }
}

/// Where the moves come from.
#[derive(Debug)]
enum Source {
    Record(GameRecord),
    Engines { start: Chess, robot: Engine, opponent: Engine, plies: usize },
}

/// A game given as PGN: a path (which must exist) or the PGN text.
pub(crate) fn pgn_record(value: &Bound<'_, PyAny>, number: usize) -> PyResult<GameRecord> {
    let text: Option<String> = value.extract().ok();
    let looks_like_a_path = |line: &str| {
        let line = line.trim();
        !line.contains('\n')
            && !line.is_empty()
            && (line.to_lowercase().ends_with(".pgn")
                || line.contains(std::path::MAIN_SEPARATOR)
                || (!line.contains(' ') && !line.starts_with(|c: char| c.is_ascii_digit())))
    };
    let path: Option<PathBuf> = match &text {
        Some(text) if Path::new(text).is_file() || looks_like_a_path(text) => Some(PathBuf::from(text)),
        Some(_) => None,
        None => Some(value.extract().map_err(|_| bad_value("pgn", value, "a path or PGN text"))?),
    };
    match path {
        Some(path) => {
            if !path.is_file() {
                return Err(PyFileNotFoundError::new_err(format!("pgn: no PGN file {:?}", path.display().to_string())));
            }
            chessarm::app::formats::pgn::read_pgn_game(&path, number).map_err(|e| PyValueError::new_err(pythonic(&e)))
        }
        None => {
            let text = text.unwrap_or_default();
            if text.trim().is_empty() {
                return Err(PyValueError::new_err("pgn: empty PGN text"));
            }
            chessarm_chess::notation::read_game(text.as_bytes(), number)
                .map_err(|e| PyValueError::new_err(format!("pgn: {e}")))
        }
    }
}

/// An engine by name: `builtin` (searching to `depth`) or a UCI program's path.
fn spawn_engine(name: &str, depth: u32, movetime: u64) -> PyResult<Engine> {
    if name == "builtin" {
        return Ok(Engine::Builtin(BuiltinEngine::new(depth, None)));
    }
    UciEngine::spawn(Path::new(name), movetime, Duration::from_secs(30))
        .map(|e| Engine::Uci(Box::new(e)))
        .map_err(|e| PyValueError::new_err(format!("engine={name:?}: {e}")))
}

/// Plays a game with the simulated arm: `moves` (SAN or UCI, from `fen`), or `pgn` (a path or
/// the PGN text; game number `game`), or, without either, a game against `engine`
/// (`builtin` to `depth`, or a UCI program's path) for up to `plies` half-moves. The arm plays
/// `robot`'s side (`both`, `white`, `black`); the other side's pieces are put by hand. The
/// options are the command line's `play` options, in SI units (`tolerance` m, `dt` s).
#[pyfunction]
#[pyo3(signature = (
    setup, moves = None, *, pgn = None, game = 1, fen = None, engine = None, plies = 120, depth = 3,
    movetime = 100, robot = "both", controller = None, kp = None, kd = None, ki = None, sensors = None,
    estimator = None, seed = 0, trial_seed = None, dt = 0.001, integrator = "rkn4", tolerance = 0.005,
    timing = None, motion = None, controller_knows_payload = false, payload_feedforward = true,
    release_by_clock = false, in_position_band = None, in_position_speed = None, in_position_timeout = None,
    controller_knows_friction = None, torque_lag = None, plant = None, uncertainty = None,
    kalman_acceleration_noise = None, lowpass_time_constant = None, keep_pace = false
))]
#[allow(clippy::too_many_arguments)]
pub fn play(
    py: Python<'_>,
    setup: &Bound<'_, PySetup>,
    moves: Option<String>,
    pgn: Option<&Bound<'_, PyAny>>,
    game: usize,
    fen: Option<String>,
    engine: Option<String>,
    plies: usize,
    depth: u32,
    movetime: u64,
    robot: &str,
    controller: Option<&Bound<'_, PyAny>>,
    kp: Option<&Bound<'_, PyAny>>,
    kd: Option<&Bound<'_, PyAny>>,
    ki: Option<&Bound<'_, PyAny>>,
    sensors: Option<PathBuf>,
    estimator: Option<&str>,
    seed: u64,
    trial_seed: Option<u64>,
    dt: f64,
    integrator: &str,
    tolerance: f64,
    timing: Option<&str>,
    motion: Option<&Bound<'_, PyDict>>,
    controller_knows_payload: bool,
    payload_feedforward: bool,
    release_by_clock: bool,
    in_position_band: Option<f64>,
    in_position_speed: Option<f64>,
    in_position_timeout: Option<f64>,
    controller_knows_friction: Option<bool>,
    torque_lag: Option<&Bound<'_, PyAny>>,
    plant: Option<PathBuf>,
    uncertainty: Option<PathBuf>,
    kalman_acceleration_noise: Option<f64>,
    lowpass_time_constant: Option<f64>,
    keep_pace: bool,
) -> PyResult<Game> {
    let py_setup = setup.get();
    positive("dt", dt)?;
    positive("tolerance", tolerance)?;
    if game == 0 {
        return Err(PyValueError::new_err("game=0: games are numbered from 1"));
    }
    if !(1..=10).contains(&depth) {
        return Err(PyValueError::new_err(format!("depth={depth}: from 1 to 10")));
    }
    for (name, value) in [("in_position_band", in_position_band), ("in_position_speed", in_position_speed)] {
        if let Some(value) = value {
            positive(name, value)?;
        }
    }
    if let Some(timeout) = in_position_timeout {
        non_negative("in_position_timeout", timeout)?;
        if timeout > 60.0 {
            return Err(PyValueError::new_err(format!("in_position_timeout={timeout}: at most 60 s")));
        }
    }
    let robot_side = common::choice::<RobotSide>("robot", robot)?;
    let integrator = common::choice::<IntegratorChoice>("integrator", integrator)?.integrator();
    // The source of the moves, checked before any work.
    let source = match (moves, pgn.filter(|p| !p.is_none()), engine) {
        (Some(_), Some(_), _) => return Err(PyValueError::new_err("give moves= or pgn=, not both")),
        (Some(moves), None, None) => {
            let start = match &fen {
                Some(fen) => chessarm_chess::notation::parse_fen(fen)
                    .map_err(|e| PyValueError::new_err(format!("fen={fen:?}: {e}")))?,
                None => Chess::default(),
            };
            Source::Record(
                chessarm_chess::notation::parse_move_list(&moves, start)
                    .map_err(|e| PyValueError::new_err(format!("moves={moves:?}: {e}")))?,
            )
        }
        (None, Some(pgn), None) => {
            if fen.is_some() {
                return Err(PyValueError::new_err("fen goes with moves= or an engine game; a PGN sets its own start"));
            }
            Source::Record(pgn_record(pgn, game)?)
        }
        (Some(_), None, Some(_)) | (None, Some(_), Some(_)) => {
            return Err(PyValueError::new_err("engine= plays a game of its own: give it without moves= or pgn="));
        }
        (None, None, engine_name) => {
            let start = match &fen {
                Some(fen) => chessarm_chess::notation::parse_fen(fen)
                    .map_err(|e| PyValueError::new_err(format!("fen={fen:?}: {e}")))?,
                None => Chess::default(),
            };
            let name = engine_name.unwrap_or_else(|| "builtin".into());
            Source::Engines {
                start,
                robot: Engine::Builtin(BuiltinEngine::new(depth, None)),
                opponent: spawn_engine(&name, depth, movetime)?,
                plies,
            }
        }
    };
    // The setup as `play` sets it up: the motion options, the controller, the conditions.
    let setup = motion_args(timing, motion)?
        .apply(&py_setup.setup)
        .map_err(|e| PyValueError::new_err(format!("motion: {}", pythonic(&e))))?;
    chessarm::app::setup::servos::check_bus_period(&setup, dt, " dt")
        .map_err(|e| PyValueError::new_err(pythonic(&e)))?;
    let default_controller = pyo3::types::PyString::new(py, "pd").into_any();
    let controller = controller.unwrap_or(&default_controller);
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
    let servos = setup.actuators.take_positions();
    let names = common::names("controller", controller)?;
    if !servos && names.len() != 1 {
        return Err(bad_value("controller", controller, "a game has one controller"));
    }
    let options = PlayOptions {
        controller: common::choice::<ControllerName>("controller", &names[0])?,
        gains: given_gains(kp, kd, ki)?,
        conditions: conditions.args,
        placement: Placement {
            release_by_clock,
            in_position_band,
            in_position_speed,
            in_position_timeout,
            payload_feedforward,
        },
        tolerance,
        dt,
        integrator,
        export_rate: 100.0,
        controller_knows_payload,
        keep_pace,
    };
    // What `prepare` refuses is an argument (the servos' strategy, the gains, the sensors, a
    // plant or uncertainty file): a ValueError, as the other studies' arguments.
    let prepared = chessarm::app::studies::play::prepare(&setup, &options).map_err(|e| {
        let message = pythonic(&e);
        if message.starts_with("servo_command") {
            PyValueError::new_err(
                "servo_command: play sends one kind of goal; give the setup one of plain, sag, feedforward",
            )
        } else {
            PyValueError::new_err(message)
        }
    })?;
    let notes: Vec<String> = prepared
        .servo_note
        .iter()
        .chain(&prepared.notes)
        .map(|note| common::flags_as_arguments(note.trim_end().trim_start_matches("note: ")))
        .collect();
    let controller_name = prepared.controller;
    let settings = prepared.settings;
    let (start, total) = match &source {
        Source::Record(record) => (record.start.clone(), record.moves.len()),
        Source::Engines { start, plies, .. } => (start.clone(), *plies),
    };
    let started = Instant::now();
    let arm = setup.arm;
    let board = setup.board;
    let mut game = py
        .detach(|| ChessGame::new(arm, board, start, settings))
        .map_err(|e| GameError::new_err(common::flags_as_arguments(&e.to_string())))?;
    let mut source = source;
    let mut reports: Vec<Py<Ply>> = Vec::new();
    for ply in 0..total {
        // Ctrl-C between the plies.
        py.check_signals()?;
        if matches!(source, Source::Engines { .. }) && game.outcome().is_some() {
            break;
        }
        let turn = game.position().turn();
        let robot_moves = robot_side.moves(turn);
        let mv = match &mut source {
            Source::Record(record) => record.moves[ply],
            Source::Engines { robot, opponent, .. } => {
                let position = game.position().clone();
                let player = if robot_moves && robot_side != RobotSide::Both { robot } else { opponent };
                py.detach(|| player.choose(&position))
                    .map_err(|e| GameError::new_err(format!("ply {}: {e}", ply + 1)))?
            }
        };
        let mover = if robot_moves { Mover::Robot } else { Mover::Opponent };
        let report = py.detach(|| game.play(&mv, mover)).map_err(|e| {
            GameError::new_err(format!(
                "the game stopped at ply {} ({} played): {}",
                ply + 1,
                reports.len(),
                common::flags_as_arguments(&e.to_string())
            ))
        })?;
        reports.push(Py::new(py, Ply::new(py, &setup, &report)?)?);
    }
    let wall_time = started.elapsed().as_secs_f64();
    let played = match &source {
        Source::Record(record) => Played::Record(record),
        Source::Engines { plies, .. } => Played::Engines { plies: *plies },
    };
    let GameResult { result, reason } = game_result(&game, played, reports.len());
    // The command's `--plies N` is this call's `plies=N`.
    let reason = match played {
        Played::Engines { plies } => reason.replace(&format!("--plies {plies}"), &format!("plies={plies}")),
        _ => reason,
    };
    let misplaced = pyo3::types::PyList::empty(py);
    for (ply, san, m) in game.misplaced() {
        let item = PyDict::new(py);
        item.set_item("ply", ply)?;
        item.set_item("san", san)?;
        item.set_item("square", m.square.map(|s| s.to_string()))?;
        item.set_item("offset", m.offset_m)?;
        item.set_item("reason", &m.reason)?;
        misplaced.append(item)?;
    }
    let table = pyo3::types::PyList::empty(py);
    for piece in game.table().pieces() {
        let item = PyDict::new(py);
        item.set_item("piece", chessarm_chess::pieces::piece_name(piece.piece))?;
        item.set_item("location", piece.location.to_string())?;
        item.set_item("x", piece.position.x)?;
        item.set_item("y", piece.position.y)?;
        table.append(item)?;
    }
    Ok(Game {
        result,
        result_reason: reason,
        plies: reports,
        misplaced: misplaced.into_any().unbind(),
        final_fen_rules: game.fen_rules(),
        final_fen_physical: game.fen_physical(),
        final_table: table.into_any().unbind(),
        robot_time: game.robot_time(),
        wall_time,
        controller: controller_name,
        notes,
    })
}
