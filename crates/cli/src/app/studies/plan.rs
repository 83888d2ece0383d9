//! Planning without simulating: a built-in scenario's path and joint trajectory
//! ([`plan_scenario`]), or a list of chess moves each turned into pick-and-place tasks, a
//! path, its time-optimal (or trapezoidal) timing and the joints' trajectory ([`plan_moves`]).

use crate::app::setup::file::{Setup, checked_limits};
use anyhow::{Result, anyhow, bail};
use chessarm_chess::motion::{PlannedMove, plan_move};
use chessarm_chess::notation::{parse_fen, parse_move_list};
use chessarm_chess::play::home_tool;
use chessarm_chess::scenario::{SCENARIOS, scenario};
use chessarm_chess::shakmaty::san::SanPlus;
use chessarm_chess::shakmaty::uci::UciMove;
use chessarm_chess::shakmaty::{CastlingMode, Chess, Position};
use chessarm_chess::table::Table;
use chessarm_chess::tasks::classify;
use chessarm_core::nalgebra::Vector2;
use chessarm_core::plan::path::sample_times;
use chessarm_core::plan::path::{CartesianPath, CartesianSample};
use chessarm_core::plan::trajectory::ToolMotion;
use chessarm_core::plan::trajectory::{JointSample, JointTrajectory};

/// A planned scenario: its path, samples and joint trajectory.
#[derive(Debug)]
pub struct Plan {
    pub name: String,
    pub path: CartesianPath,
    pub cartesian: Vec<CartesianSample>,
    pub joint: JointTrajectory,
    /// Where the scenario's piece stands and the centre of its target square (board plane, m).
    pub placement: Option<(Vector2<f64>, Vector2<f64>)>,
    /// Where the arm's base axis stands (x, y, m): a gripped piece turns about it.
    pub base: Vector2<f64>,
}

/// Bytes one planned sample takes in memory: the Cartesian and joint samples and the points of
/// the plots drawn from them (3 × 3 Cartesian and 3 × 4 joint series of (t, value) pairs).
const BYTES_PER_PLAN_SAMPLE: usize = std::mem::size_of::<CartesianSample>()
    + std::mem::size_of::<JointSample>()
    + 21 * std::mem::size_of::<(f64, f64)>();

/// Plans a built-in scenario sampled every `dt` s. `cause` names the options that set `dt` (as
/// typed), for the error when the samples would not fit in memory.
///
/// # Errors
///
/// An unknown scenario, a `dt` longer than the scenario or too short to hold in memory, a path
/// the arm cannot follow.
pub fn plan_scenario(setup: &Setup, name: &str, dt: f64, cause: &str) -> Result<Plan> {
    let scenario = scenario(name, &setup.board)
        .ok_or_else(|| anyhow!("unknown scenario '{name}' (known: {})", SCENARIOS.join(", ")))?;
    let path = scenario.path(&setup.board)?;
    if dt > path.duration() {
        bail!(
            "{cause}: a sample every {} s is longer than the {:.0} s scenario",
            crate::app::resources::show(dt),
            path.duration()
        );
    }
    let samples = (path.duration() / dt).ceil() + 1.0;
    crate::app::resources::ensure_fits(
        cause,
        &format!("samples of the {:.0} s scenario", path.duration()),
        samples,
        BYTES_PER_PLAN_SAMPLE as f64,
    )?;
    let cartesian = path.sample_uniform(dt)?;
    let joint = JointTrajectory::from_path(&setup.arm, &path, dt)
        .map_err(|e| anyhow!("scenario '{name}' cannot be followed: {e}"))?;
    let placement = Some((setup.board.square_center(scenario.from).xy(), setup.board.square_center(scenario.to).xy()));
    Ok(Plan { name: name.to_string(), path, cartesian, joint, placement, base: setup.arm.base().xy() })
}

/// The control period moves are planned for, s (as `play` simulates them).
pub const CONTROL_PERIOD: f64 = 1e-3;

/// One move of a [`MovesPlan`]: its names, where it starts on the plan's clock and its plan.
#[derive(Debug)]
pub struct PlannedPly {
    /// 1 for the first move of the list.
    pub ply: usize,
    pub san: String,
    pub uci: String,
    /// The kind of move (quiet, capture, castling, en passant, promotion).
    pub kind: &'static str,
    /// When the move starts, s from the first move's start.
    pub start: f64,
    pub planned: PlannedMove,
}

/// A list of moves planned one after the other from a position: each move's plan, and the
/// Cartesian and joint samples of them all on one clock.
#[derive(Debug)]
pub struct MovesPlan {
    pub plies: Vec<PlannedPly>,
    pub cartesian: Vec<CartesianSample>,
    pub joint: Vec<JointSample>,
    /// The moves' durations added, s.
    pub duration: f64,
    /// The sample period, s.
    pub dt: f64,
}

/// Plans `moves` (SAN or UCI, separated by spaces; move numbers allowed) from `fen` (the
/// starting position when `None`), every move from where the last one left the tool, sampled
/// every `dt` s. The table is checked first as `play` checks it before its first move.
///
/// # Errors
///
/// A bad FEN or move, a table the arm cannot serve, pieces the file's fingers cannot hold, a
/// move the planner cannot make.
pub fn plan_moves(setup: &Setup, fen: Option<&str>, moves: &str, dt: f64) -> Result<MovesPlan> {
    let start = match fen {
        Some(fen) => parse_fen(fen)?,
        None => Chess::default(),
    };
    let record = parse_move_list(moves, start)?;
    let mut limits = checked_limits(setup.motion, "motion", "gripper")?;
    let mut table = Table::from_position(setup.board, &record.start);
    crate::app::setup::gripper::check_file_fingers(setup)?;
    let columns = Some(&setup.clearance);
    limits.pitch = chessarm_chess::reach::check_table(&setup.arm, &setup.board, &setup.pieces, &limits, columns)
        .map_err(|e| {
            anyhow!("the table cannot be served by this arm: {e}; `chessarm board --fit` finds a board it serves")
        })?;
    let mut tool = home_tool(&setup.board, &setup.pieces, &limits);
    let mut position = record.start.clone();
    let mut plan = MovesPlan { plies: Vec::new(), cartesian: Vec::new(), joint: Vec::new(), duration: 0.0, dt };
    for (index, mv) in record.moves.iter().enumerate() {
        let san = SanPlus::from_move(position.clone(), *mv).to_string();
        let uci = UciMove::from_move(*mv, CastlingMode::Standard).to_string();
        let planned =
            plan_move(tool, &position, mv, &table, &setup.pieces, &limits, &setup.arm, setup.timing, CONTROL_PERIOD)?;
        let motion = &planned.motion;
        let duration = motion.duration();
        let offset = plan.duration;
        let sampled = JointTrajectory::from_path(&setup.arm, motion, dt).map_err(|e| anyhow!("move {san}: {e}"))?;
        plan.cartesian
            .extend(sample_times(duration, dt)?.map(|t| CartesianSample { t: t + offset, ..motion.sample(t) }));
        plan.joint.extend(sampled.samples().iter().map(|s| JointSample { t: s.t + offset, ..*s }));
        for task in &planned.tasks {
            let target = table.nominal_position(task.task.to);
            table.relocate(task.task.from, task.task.to, target).map_err(|e| anyhow!("move {san}: {e}"))?;
        }
        tool = motion.end();
        let kind = classify(&position, mv).name();
        position.play_unchecked(*mv);
        plan.duration += duration;
        plan.plies.push(PlannedPly { ply: index + 1, san, uci, kind, start: offset, planned });
    }
    Ok(plan)
}
