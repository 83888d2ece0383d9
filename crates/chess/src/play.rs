//! Playing chess with the simulated arm: each robot move becomes pick-and-place tasks, a tool
//! path, a joint trajectory and a closed-loop simulation in which the gripped piece is a payload
//! of the plant; every piece is put down where the simulated tool actually releases it, and the
//! table is checked against the rules after every move.
//!
//! Moves of the side the robot does not play are made by the opponent's hand: their pieces go
//! exactly to their squares.

use crate::board::BoardGeometry;
use crate::clearance::moves::{Carry, ClearanceCheck, MIN_OPENING, MoveClearance, check_move};
use crate::clearance::{Rules, Scratch, reach_bound};
use crate::motion::{PhaseTimes, PlannedMove, TimingMode, plan_move};
use crate::outcome::{GameOutcome, outcome, position_key};
use crate::pieces::PieceSet;
use crate::table::{Location, Misplaced, Table, TableError};
use crate::tasks::{MotionLimits, MoveKind, PlannedTask, TaskError, classify, move_tasks};
use chessarm_core::arm::bodies::{Hand, Held};
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::arm::task::{IkError, held_turn, inverse_kinematics};
use chessarm_core::control::JointState;
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::control::gains::Gains;
use chessarm_core::nalgebra::{Rotation2, Vector2, Vector3};
use chessarm_core::plan::fine_point::{InPosition, Wait};
use chessarm_core::plan::hardware::{ExportError, GripperCommand, HardwarePoint, hardware_points};
use chessarm_core::plan::trajectory::{PlanError, ToolMotion};
use chessarm_core::sense::{Conditions, Feedback, SenseError};
use chessarm_core::sim::actuator::{Actuators, PositionBank};
use chessarm_core::sim::{
    Integrator, Observer, PayloadEvent, Plant, SimConfig, SimError, SimSummary, StepRecord, Told, simulate_fine_points,
};
use shakmaty::fen::Fen;
use shakmaty::san::SanPlus;
use shakmaty::uci::UciMove;
use shakmaty::{CastlingMode, Chess, Color, EnPassantMode, Move, Position};

/// How far from its place a piece may stand and still count as placed, m (5 mm).
pub const DEFAULT_TOLERANCE: f64 = 0.005;

/// Settings of a game.
#[derive(Debug, Clone)]
pub struct PlaySettings {
    pub pieces: PieceSet,
    pub limits: MotionLimits,
    /// How the motions are timed (default: time-optimal).
    pub timing: TimingMode,
    /// The controller (its model is the game's arm).
    pub controller: ControllerSpec,
    /// Whether the controller's model is told about gripped pieces (their true masses).
    pub controller_knows_payload: bool,
    /// Whether the controller's model takes the nominal mass and shape of the piece kind it
    /// grips (`pieces`'), as a robot that knows which piece it carries does (default: yes).
    /// Without it, and without [`PlaySettings::controller_knows_payload`], it is told nothing.
    pub payload_feedforward: bool,
    /// The fine point of every grip and release: the gripper waits until the arm is in
    /// position ([`chessarm_core::plan::fine_point`]); `None`: it closes and opens by the clock.
    pub in_position: Option<InPosition>,
    /// The true arm, when it differs from the controller's model (the game's arm).
    pub plant: Option<ArmModel<4>>,
    /// The pieces' true masses and shapes, when they differ from `pieces` (which the planner
    /// and a controller told the payload use).
    pub true_pieces: Option<PieceSet>,
    /// Sensors, estimator and motor lag between the controller and the arm (default: ideal).
    /// The sensors' noise runs on through the game, seeded once.
    pub conditions: Conditions<4>,
    /// Largest accepted distance of a piece from its square centre, m (default 5 mm).
    pub tolerance: f64,
    /// Integration step and controller period, s.
    pub dt: f64,
    pub control_period: f64,
    /// How the plant is integrated (default: Nyström's fourth-order Runge–Kutta).
    pub integrator: Integrator,
    /// Keep every n-th simulation step in the move reports (0: keep none).
    pub record_every: usize,
    /// Sample every robot move's planned motion for hardware at this rate, Hz (`None`: not).
    pub export_rate: Option<f64>,
    /// What drives the joints (default: torque motors). With servos, `controller` is their
    /// host ([`ControllerKind::ServoHost`]) and `control_period` its bus period.
    pub actuators: Actuators<4>,
    /// The true servos or steppers of the plant, drawn around `actuators` (`None`: exactly
    /// `actuators`). The host computes its goals from `actuators`.
    pub true_actuators: Option<Actuators<4>>,
    /// How every robot move is kept clear of the pieces, the table and the arm itself
    /// ([`crate::clearance`]): its plan is checked and changed (or refused) before it runs,
    /// and the simulated motion is checked after. `None`: no check (for measuring its cost).
    pub clearance: Option<ClearanceCheck>,
    /// Whether [`Game::new`] checks the board's columns with `clearance`
    /// ([`crate::clearance::columns`]), so that no move can meet a neighbour at a grip: on; off
    /// only to study the planner's own changes (narrowed fingers, raised traverses) and
    /// refusals on a board the check would refuse.
    pub check_columns: bool,
    /// The tool's pitch (rad) a pre-flight of this arm, board, pieces, limits and clearance
    /// already found ([`crate::reach::check_table`]): [`Game::new`] takes it instead of
    /// checking again (a campaign plays many games on one board). `None`: checked.
    pub checked_pitch: Option<f64>,
    /// Whether a robot move whose simulated motion (the servos' or motors' tracking, the
    /// sensors, the carried piece) comes nearer than the clearance margin is run again slower
    /// ([`PACE_STEP`] at a time, at most [`PACE_TRIES`] times), so no `--pace` is needed for a
    /// clean game: on; off where the pace itself is studied (robustness, tuning).
    pub choose_pace: bool,
}

/// Each retry of a move too near in simulation runs at this fraction of the last one's pace.
pub const PACE_STEP: f64 = 0.7;
/// How many times a move is slowed at most (down to `0.7⁴ ≈ 0.24` of its pace).
pub const PACE_TRIES: usize = 4;

/// A robot move's planned motion for hardware ([`chessarm_core::plan::hardware`]).
#[derive(Debug, Clone, PartialEq)]
pub struct HardwareExport {
    pub points: Vec<HardwarePoint>,
    pub commands: Vec<GripperCommand>,
    /// Per grip, in order: the piece and where it goes ("white pawn from e2 to e4").
    pub grips: Vec<String>,
    /// Per grip, in order: the piece's width where the gripper holds it (its grip width), m.
    pub widths: Vec<f64>,
    /// Per gripper command, in order: the planned tool tip it waits to be at (m), and the
    /// condition it waits for (`None`: it goes by the clock).
    pub fine_points: Vec<Vector3<f64>>,
    pub in_position: Option<InPosition>,
    /// With servos or steppers: every goal the host sent in the simulated move, at the bus
    /// rate, waits included (the stream that placed the pieces); empty with torque motors.
    pub servo_goals: Vec<ServoGoal>,
}

impl PlaySettings {
    /// The plant's time step unless told otherwise, s.
    pub const DEFAULT_DT: f64 = 1e-3;

    /// Report-style defaults with the given controller.
    pub fn new(controller: impl Into<String>, gains: Gains<4>) -> Self {
        Self {
            pieces: PieceSet::default(),
            limits: MotionLimits::default(),
            timing: TimingMode::default(),
            controller: ControllerSpec {
                name: controller.into(),
                kind: ControllerKind::ComputedTorque,
                gains,
                knows_friction: false,
            },
            controller_knows_payload: false,
            payload_feedforward: true,
            // Sensors of unknown resolution: the coarsest default band (a tenth of the
            // tolerance); `InPosition::for_sensors` for known ones.
            in_position: Some(InPosition::for_tolerance(DEFAULT_TOLERANCE)),
            plant: None,
            true_pieces: None,
            conditions: Conditions::ideal(),
            tolerance: DEFAULT_TOLERANCE,
            dt: Self::DEFAULT_DT,
            control_period: 1e-3,
            integrator: Integrator::default(),
            record_every: 10,
            export_rate: None,
            actuators: Actuators::torque(),
            true_actuators: None,
            clearance: Some(ClearanceCheck::default()),
            check_columns: true,
            checked_pitch: None,
            choose_pace: true,
        }
    }
}

/// Why a game cannot go on.
#[derive(Debug, thiserror::Error)]
pub enum PlayError {
    #[error("cannot take back {plies} plies: {played} were played")]
    TakeBack { plies: usize, played: usize },
    #[error(transparent)]
    Task(#[from] TaskError),
    #[error("move {mv}: {source}")]
    Plan { mv: String, source: PlanError },
    #[error("move {mv}: the hardware trajectory: {source}")]
    Export { mv: String, source: ExportError },
    #[error("move {mv}: {source}")]
    Simulation { mv: String, source: SimError },
    #[error("move {mv}: {source}")]
    Table { mv: String, source: TableError },
    #[error("the arm's home position is unreachable: {0}")]
    Home(IkError),
    #[error("the table cannot be served by this arm: {0}; `chessarm board --fit` finds a board it serves")]
    Reach(crate::reach::ReachError),
    #[error("tolerance {0} m must be finite and > 0")]
    Tolerance(f64),
    #[error("gripper.{field} = {value}: {reason}")]
    Gripper { field: &'static str, value: f64, reason: &'static str },
    #[error("the clearance margin {0} m must be finite and >= 0")]
    ClearanceMargin(f64),
    /// No change of the plan keeps the move clear.
    #[error(
        "move {mv}: {part} would come {:.1} mm from {obstacle} {time:.2} s into the move (at least {} mm needed){tried}; \
         nothing was run",
        distance * 1e3,
        chessarm_core::short_number(margin * 1e3)
    )]
    Contact { mv: String, part: String, obstacle: String, distance: f64, time: f64, margin: f64, tried: String },
    #[error(transparent)]
    Sensing(#[from] SenseError),
    #[error("controller {name}: {source}")]
    Controller { name: String, source: chessarm_core::control::choice::BuildError },
}

/// Who moves the pieces of a move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mover {
    /// The simulated arm.
    Robot,
    /// The opponent's hand (pieces land exactly on their squares).
    Opponent,
}

/// What happened in one move.
#[derive(Debug, Clone)]
pub struct MoveReport {
    /// 1-based half-move number.
    pub ply: usize,
    pub san: String,
    pub uci: String,
    pub kind: MoveKind,
    pub mover: Mover,
    /// The pick-and-place tasks, described.
    pub tasks: Vec<String>,
    /// Robot time of the move, s (0 for the opponent's).
    pub duration: f64,
    /// Largest tool-tip error during the move, m (robot moves only).
    pub max_tip_error: Option<f64>,
    /// Per task: distance of the released piece from its target's centre, m.
    pub place_errors: Vec<f64>,
    /// Discrepancies first seen after this move.
    pub new_misplaced: Vec<Misplaced>,
    /// Sampled simulation steps, times from the start of the move.
    pub records: Vec<StepRecord<4>>,
    /// Metrics of the move's simulation (robot moves only).
    pub summary: Option<SimSummary<4>>,
    /// Time of the move's start in the game's robot time, s.
    pub start_time: f64,
    /// Planned duration of the robot's motion, s (0 for the opponent's).
    pub planned_duration: f64,
    /// The planned time by phase (robot moves only).
    pub phases: PhaseTimes,
    /// Time-optimal moves: the limit binding longest and for how long, s.
    pub longest_limit: Option<(String, f64)>,
    /// LSPB moves: how many times the limits were scaled by 0.7 for the joint speeds.
    pub slowdowns: usize,
    /// Every piece the move moved, in the order moved.
    pub handled: Vec<Handling>,
    /// The planned motion for hardware (robot moves, when [`PlaySettings::export_rate`] is set).
    pub hardware: Option<HardwareExport>,
    /// Per gripper command, in order: its wait at the fine point (robot moves with
    /// [`PlaySettings::in_position`]).
    pub waits: Vec<Wait>,
    /// Robot moves with [`PlaySettings::clearance`]: the closest approach of the plan that
    /// ran, and of the simulated motion ([`Executed`]).
    pub clearance: Option<MoveClearance>,
    pub executed_clearance: Option<Executed>,
    /// What the planner changed to keep the move clear, for people ("clearance margin raised
    /// to 5 cm: link 4 came 1.2 mm from the white king from e1").
    pub adjustments: Vec<String>,
    /// The fingers' gap beside a piece when open, m (the gripper's, or less if narrowed).
    pub opening: Option<f64>,
    /// Robot moves: the pace the move ran at, as a fraction of the limits' own (1, or less
    /// where [`PlaySettings::choose_pace`] slowed it), and the simulated clearance (m, 0: a
    /// contact) of each try that came nearer than the margin, in order (empty when the first
    /// kept it).
    pub pace: f64,
    pub too_near_at: Vec<f64>,
}

impl MoveReport {
    /// The waits that took time: their count, total and longest (s), and how many timed out.
    pub fn wait_totals(&self) -> WaitTotals {
        WaitTotals::of(&self.waits)
    }
}

/// What the fine points' waits of a move or a game added up to.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WaitTotals {
    /// Gripper commands that waited (longer than zero).
    pub count: usize,
    /// s.
    pub total: f64,
    /// s.
    pub longest: f64,
    /// Waits that gave up at the timeout.
    pub timed_out: usize,
}

impl WaitTotals {
    pub fn of<'a>(waits: impl IntoIterator<Item = &'a Wait>) -> Self {
        let mut totals = Self::default();
        for wait in waits {
            if wait.duration > 0.0 {
                totals.count += 1;
                totals.total += wait.duration;
                totals.longest = totals.longest.max(wait.duration);
            }
            totals.timed_out += usize::from(wait.timed_out);
        }
        totals
    }
}

/// One piece moved by a move: carried by the arm from its grip to its release, or put on its
/// new place by the opponent's hand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Handling {
    /// Index of the piece in [`Table::pieces`], the same for the whole game.
    pub piece: usize,
    pub from: Location,
    pub to: Location,
    /// Grip and release instants in the game's robot time, s (both the move's start for the
    /// opponent's hand).
    pub grip_time: f64,
    pub release_time: f64,
    /// Where the piece stood before it was moved and where it was put down (x, y, m).
    pub standing: Vector2<f64>,
    pub placed: Vector2<f64>,
    /// The simulated tool tip at the grip instant, m (`None` for the hand). While gripped the
    /// piece moves rigidly with the tool: its base is at `standing + tip(t) − grip_tip`.
    pub grip_tip: Option<Vector3<f64>>,
}

/// Keeps every n-th step.
struct Sampler {
    every: usize,
    seen: usize,
    records: Vec<StepRecord<4>>,
    /// Steps per bus period when the goals sent to servos are kept (0: not kept).
    bus_steps: usize,
    goals: Vec<ServoGoal>,
    /// Steps between the joint angles kept for the clearance check (0: not kept).
    path_steps: usize,
    path: Vec<(f64, JointVector<4>)>,
    /// Each joint's largest distance from its reference, rad (with the path kept).
    deviation: [f64; 4],
}

impl Observer<4> for Sampler {
    fn observe(&mut self, record: &StepRecord<4>) {
        if self.every > 0 && self.seen.is_multiple_of(self.every) {
            self.records.push(*record);
        }
        // The host sends a goal at every bus period's first step (the run's steps go on
        // through fine points' waits, so they stay on the bus's clock).
        if self.bus_steps > 0
            && self.seen.is_multiple_of(self.bus_steps)
            && let Some(servo) = &record.servo
        {
            self.goals.push(ServoGoal { t: record.t, goal: servo.goal.into() });
        }
        if self.path_steps > 0 {
            if self.seen.is_multiple_of(self.path_steps) {
                self.path.push((record.t, record.state.q));
            }
            for j in 0..4 {
                self.deviation[j] = self.deviation[j].max((record.state.q[j] - record.reference.q[j]).abs());
            }
        }
        self.seen += 1;
    }
}

/// A goal the host sent to the servos (or the stepper drivers): when, s from the move's start,
/// and the four joints' goal angles, rad (the model's sense; whole counts of each servo).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoGoal {
    pub t: f64,
    pub goal: [f64; 4],
}

/// A game in progress: rules position, physical table and the simulated arm.
#[derive(Debug)]
pub struct Game {
    arm: ArmModel<4>,
    settings: PlaySettings,
    position: Chess,
    table: Table,
    /// Planned tool tip at the end of the last robot move, m.
    tool: Vector3<f64>,
    /// The arm's actual state at the end of the last robot move.
    state: JointState<4>,
    /// The servos' and steppers' state at the end of the last robot move (their targets,
    /// backlash and step counts carry over, as on the robot); `None` before the first.
    actuators: Option<PositionBank<4>>,
    ply: usize,
    robot_time: f64,
    misplaced: Vec<(usize, String, Misplaced)>,
    /// [`position_key`] of every position so far, the start first and the current one last.
    history: Vec<u64>,
    /// The sensors and estimator, carried from move to move.
    feedback: Feedback<4>,
    /// With [`PlaySettings::clearance`]: which parts are checked against what, and the
    /// sweeps' buffers.
    rules: Option<Rules>,
    scratch: Scratch,
}

/// The game's state a robot move changes ([`Game::execute`]'s tries start from it).
#[derive(Debug, Clone)]
struct Snapshot {
    feedback: Feedback<4>,
    table: Table,
    tool: Vector3<f64>,
    state: JointState<4>,
    actuators: Option<PositionBank<4>>,
    robot_time: f64,
}

impl Game {
    /// Sets up `start` on the table; the arm rests above the middle of rank 1 at the highest
    /// traverse height. Checks every square and slot is reachable.
    pub fn new(
        arm: ArmModel<4>,
        board: BoardGeometry,
        start: Chess,
        settings: PlaySettings,
    ) -> Result<Self, PlayError> {
        if !(settings.tolerance.is_finite() && settings.tolerance > 0.0) {
            return Err(PlayError::Tolerance(settings.tolerance));
        }
        let mut settings = settings;
        let limits = settings.limits.validated()?;
        let table = Table::from_position(board, &start);
        // The pitch nearest straight down that serves the whole board, for the whole game.
        let columns = settings.clearance.as_ref().filter(|_| settings.check_columns);
        let pitch = match settings.checked_pitch {
            Some(pitch) => pitch,
            None => {
                crate::reach::check_table(&arm, &board, &settings.pieces, &limits, columns).map_err(PlayError::Reach)?
            }
        };
        settings.limits.pitch = pitch;
        if let Some(check) = settings.clearance.as_mut() {
            check.held_turn = held_turn(&arm, pitch);
        }
        let limits = settings.limits;
        let tool = home_tool(&board, &settings.pieces, &limits);
        let q = home_pose(&arm, &board, &settings.pieces, &limits)?;
        let misplaced =
            table.verify(start.board(), settings.tolerance).into_iter().map(|m| (0, "start".to_string(), m)).collect();
        let history = vec![position_key(&start)];
        let feedback = settings.conditions.feedback(settings.control_period)?;
        let rules = match &settings.clearance {
            Some(check) => {
                let check = check.clone().validated().map_err(|(field, value, reason)| match field {
                    "arm_clearance" => PlayError::ClearanceMargin(value),
                    _ => PlayError::Gripper { field, value, reason },
                })?;
                let gripper = check.gripper;
                let hand = Hand { gripper, gap: gripper.open_gap(settings.pieces.widest()), held: None };
                Some(Rules::for_arm(&arm, &hand, &check.bodies, &q, board.surface_height))
            }
            None => None,
        };
        Ok(Self {
            arm,
            settings,
            position: start,
            table,
            tool,
            state: JointState::at_rest(q),
            actuators: None,
            ply: 0,
            robot_time: 0.0,
            misplaced,
            history,
            feedback,
            rules,
            scratch: Scratch::default(),
        })
    }

    pub fn position(&self) -> &Chess {
        &self.position
    }

    /// The tool's pitch for the whole game, rad ([`crate::reach::check_table`]'s choice).
    pub fn pitch(&self) -> f64 {
        self.settings.limits.pitch
    }

    /// The board the game is played on.
    pub fn board(&self) -> &BoardGeometry {
        self.table.geometry()
    }

    pub fn table(&self) -> &Table {
        &self.table
    }

    /// How the game has ended after the moves played so far (checkmate, stalemate, insufficient
    /// material, threefold repetition or the fifty-move rule), or `None` if it goes on. The start
    /// position counts for repetitions, and a FEN start's halfmove clock for the fifty-move rule.
    /// See [`crate::outcome::outcome`].
    pub fn outcome(&self) -> Option<GameOutcome> {
        outcome(&self.position, &self.history)
    }

    /// Where the tool rests now (planned tip at the end of the last robot move), m.
    pub fn tool(&self) -> Vector3<f64> {
        self.tool
    }

    /// The arm's state now: at rest at the home pose before the first robot move, then the
    /// simulated state at the end of the last one.
    pub fn state(&self) -> JointState<4> {
        self.state
    }

    /// The fine points' condition of the game's grips and releases (`None`: by the clock).
    pub fn in_position(&self) -> Option<&InPosition> {
        self.settings.in_position.as_ref()
    }

    /// Total robot time so far, s.
    pub fn robot_time(&self) -> f64 {
        self.robot_time
    }

    /// Every discrepancy still on the table with the ply and SAN of the move that caused it.
    pub fn misplaced(&self) -> &[(usize, String, Misplaced)] {
        &self.misplaced
    }

    /// FEN of the rules' position.
    pub fn fen_rules(&self) -> String {
        Fen::from_position(&self.position, EnPassantMode::Legal).to_string()
    }

    /// The rules' FEN with its piece placement replaced by what stands on the table, each
    /// piece snapped to the square under it.
    pub fn fen_physical(&self) -> String {
        let rules = self.fen_rules();
        let rest = rules.split_once(' ').map_or("", |(_, rest)| rest);
        format!("{} {rest}", self.table.snapped_board().0)
    }

    /// Plays a legal move: the robot executes it (simulated) or the opponent's hand does.
    pub fn play(&mut self, mv: &Move, mover: Mover) -> Result<MoveReport, PlayError> {
        let san = SanPlus::from_move(self.position.clone(), *mv).to_string();
        let uci = UciMove::from_move(*mv, CastlingMode::Standard).to_string();
        let name = format!("{} {san} ({uci})", self.move_number());
        let kind = classify(&self.position, mv);
        let mut report = MoveReport {
            ply: self.ply + 1,
            san: san.clone(),
            uci,
            kind,
            mover,
            tasks: Vec::new(),
            duration: 0.0,
            max_tip_error: None,
            place_errors: Vec::new(),
            new_misplaced: Vec::new(),
            records: Vec::new(),
            hardware: None,
            summary: None,
            start_time: self.robot_time,
            planned_duration: 0.0,
            phases: PhaseTimes::default(),
            longest_limit: None,
            slowdowns: 0,
            handled: Vec::new(),
            waits: Vec::new(),
            clearance: None,
            executed_clearance: None,
            adjustments: Vec::new(),
            opening: None,
            pace: 1.0,
            too_near_at: Vec::new(),
        };
        match mover {
            Mover::Opponent => {
                for task in move_tasks(&self.position, mv, &self.table)? {
                    let target = self.table.nominal_position(task.to);
                    if let Some(piece) = self.table.index_at(task.from) {
                        report.handled.push(Handling {
                            piece,
                            from: task.from,
                            to: task.to,
                            grip_time: self.robot_time,
                            release_time: self.robot_time,
                            standing: self.table.pieces()[piece].position,
                            placed: target,
                            grip_tip: None,
                        });
                    }
                    self.relocate(&name, task.from, task.to, target)?;
                    report.tasks.push(task.to_string());
                    report.place_errors.push(0.0);
                }
            }
            Mover::Robot => self.execute(mv, &name, &mut report)?,
        }
        self.position.play_unchecked(*mv);
        self.history.push(position_key(&self.position));
        self.ply += 1;
        let before: Vec<String> = self.misplaced.iter().map(|(_, _, m)| m.reason.clone()).collect();
        let now = self.table.verify(self.position.board(), self.settings.tolerance);
        self.misplaced.retain(|(_, _, m)| now.iter().any(|n| n.reason == m.reason));
        for discrepancy in now {
            if !before.contains(&discrepancy.reason) {
                report.new_misplaced.push(discrepancy.clone());
                self.misplaced.push((report.ply, san.clone(), discrepancy));
            }
        }
        Ok(report)
    }

    /// The person takes back the last `plies` moves, which moved pieces by `moved` (each
    /// move's relocations, from and to, in the order they were made): every such piece is put
    /// back by hand on its earlier place's centre, last relocation first, and the rules'
    /// position becomes the one before those moves. The arm stays where it is and robot time
    /// goes on; the ply count goes back, so that the next move has the ply it has in the game.
    /// Returns the hand's handlings (for the replay).
    ///
    /// # Errors
    ///
    /// `plies` is more than were played, or a relocation does not match the table.
    pub fn take_back(
        &mut self,
        plies: usize,
        moved: &[(Location, Location)],
        position: Chess,
    ) -> Result<Vec<Handling>, PlayError> {
        if plies == 0 || plies >= self.history.len() {
            return Err(PlayError::TakeBack { plies, played: self.history.len() - 1 });
        }
        let mut handled = Vec::with_capacity(moved.len());
        for (from, to) in moved.iter().rev() {
            let target = self.table.nominal_position(*from);
            if let Some(piece) = self.table.index_at(*to) {
                handled.push(Handling {
                    piece,
                    from: *to,
                    to: *from,
                    grip_time: self.robot_time,
                    release_time: self.robot_time,
                    standing: self.table.pieces()[piece].position,
                    placed: target,
                    grip_tip: None,
                });
            }
            self.relocate("take-back", *to, *from, target)?;
        }
        self.history.truncate(self.history.len() - plies);
        self.ply = self.ply.saturating_sub(plies);
        self.position = position;
        self.misplaced.retain(|(_, _, m)| {
            self.table.verify(self.position.board(), self.settings.tolerance).iter().any(|n| n.reason == m.reason)
        });
        Ok(handled)
    }

    fn move_number(&self) -> String {
        let number = self.position.fullmoves().get();
        match self.position.turn() {
            Color::White => format!("{number}."),
            Color::Black => format!("{number}..."),
        }
    }

    fn relocate(&mut self, name: &str, from: Location, to: Location, at: Vector2<f64>) -> Result<(), PlayError> {
        self.table.relocate(from, to, at).map_err(|source| PlayError::Table { mv: name.to_string(), source })
    }

    /// Plans a robot move that keeps clear of the pieces, the table and the arm itself: the
    /// plan is checked ([`check_move`]); where it comes nearer than the margin, a finger beside
    /// a piece is first opened less (halved down to 1 mm a side), then the clearance margin of
    /// the traverses is raised (by 2 cm, up to three times), and a move still too near is
    /// refused. Returns the plan, its clearance, what was changed and the hand's gripper.
    fn plan_clear(&mut self, mv: &Move, name: &str, limits: MotionLimits) -> Result<ClearPlan, PlayError> {
        let settings = &self.settings;
        let mut limits = limits;
        let mut check = settings.clearance.clone();
        let mut adjustments = Vec::new();
        let mut raised = 0;
        // The last plan's nearest approach and its margin, when it was too near.
        let mut last: Option<(MoveClearance, f64)> = None;
        // Whether opening the fingers less may still help, and the distance before it was tried.
        let mut narrowing = true;
        let mut narrowed: Option<f64> = None;
        loop {
            let planned = plan_move(
                self.tool,
                &self.position,
                mv,
                &self.table,
                &settings.pieces,
                &limits,
                &self.arm,
                settings.timing,
                settings.control_period,
            );
            let plan = match (planned, &last) {
                (Ok(plan), _) => plan,
                // Raised beyond what the arm can do: the contact it was raised for stands.
                (Err(error), Some((near, margin))) => {
                    let why = format!("raising the traverses further fails: {}", first_line(&error.to_string()));
                    return Err(contact(name, near, *margin, &adjustments, Some(why)));
                }
                (Err(error), None) => return Err(error.into()),
            };
            let (Some(clear), Some(rules)) = (check.clone(), &self.rules) else {
                return Ok(ClearPlan { plan, clearance: None, adjustments, check: None });
            };
            let samples: Vec<(f64, JointVector<4>)> = plan.trajectory.samples().iter().map(|s| (s.t, s.q)).collect();
            let carries = planned_carries(&self.table, &plan.tasks);
            let found = check_move(
                &self.arm,
                &clear,
                rules,
                &self.table,
                &settings.pieces,
                &samples,
                &carries,
                &mut self.scratch,
            );
            // The fingers must not touch the piece they open around (its gap is the gripper's
            // opening, which may be narrower than the margin); everything else keeps the margin.
            let Some(near) = found.clone().filter(|c| c.distance < clear.margin || c.is_contact()) else {
                return Ok(ClearPlan { plan, clearance: found, adjustments, check });
            };
            last = Some((near.clone(), clear.margin));
            let mm = |m: f64| chessarm_core::short_number(m * 1e3);
            let why = format!("{} came {:.1} mm from {}", near.part, near.distance * 1e3, near.obstacle_name);
            let finger = matches!(near.part, chessarm_core::arm::bodies::Part::Finger(_));
            // Opening the fingers less that did not take them farther from the piece: the
            // gripper's opening back, and the traverses raised instead.
            if narrowed.is_some_and(|before| near.distance <= before) {
                narrowing = false;
                check = settings.clearance.clone();
                adjustments.retain(|a| !a.starts_with("fingers opened"));
                adjustments.push(format!("fingers opened less (down to {} mm): no nearer to clear", MIN_OPENING * 1e3));
            }
            let clear = check.clone().unwrap_or(clear);
            if narrowing && finger && near.piece.is_some() && clear.gripper.finger_opening > MIN_OPENING {
                narrowed = Some(near.distance);
                let mut narrower = clear.clone();
                narrower.gripper.finger_opening = (0.5 * clear.gripper.finger_opening).max(MIN_OPENING);
                adjustments.push(format!(
                    "fingers opened {} mm beside the piece instead of {}: {why}",
                    mm(narrower.gripper.finger_opening),
                    mm(clear.gripper.finger_opening)
                ));
                check = Some(narrower);
            } else if raised < RAISES {
                narrowed = None;
                raised += 1;
                limits.clearance_margin += RAISE;
                adjustments.push(format!(
                    "traverses raised: clearance margin {} cm: {why}",
                    chessarm_core::short_number(limits.clearance_margin * 1e2)
                ));
            } else {
                return Err(contact(name, &near, clear.margin, &adjustments, None));
            }
        }
    }

    /// Plans, simulates and applies one robot move.
    /// Plans and runs a robot move ([`Self::attempt`]); with [`PlaySettings::choose_pace`], a
    /// move whose simulated motion comes nearer than the clearance margin (measured, not a
    /// bound) is run again from the same state (the arm's, the servos', the sensors' noise, the
    /// table, the robot time) at [`PACE_STEP`] of the last pace, up to [`PACE_TRIES`] times:
    /// the first try that keeps the margin stands, else the one that came least near (the
    /// faster of equals: a sagging servo is no nearer its goal slower, so its move is not
    /// slowed in vain).
    fn execute(&mut self, mv: &Move, name: &str, report: &mut MoveReport) -> Result<(), PlayError> {
        if !self.settings.choose_pace || self.settings.clearance.is_none() {
            return self.attempt(mv, name, report, self.settings.limits);
        }
        let margin = self.settings.clearance.as_ref().map_or(0.0, |c| c.margin);
        let start = (self.snapshot(), report.clone());
        let mut pace = 1.0;
        let mut too_near = Vec::new();
        // The nearest approach of the best try so far, its pace, the game and report after it.
        let mut best: Option<(f64, f64, Snapshot, MoveReport)> = None;
        for tries in 0..=PACE_TRIES {
            match self.attempt(mv, name, report, self.settings.limits.at_pace(pace)) {
                Ok(()) => {}
                Err(error) if tries == 0 => return Err(error),
                // A slower try the planner refuses (or that fails) leaves the best one so far,
                // which ran: restored below.
                Err(_) => break,
            }
            // Nearer than the margin to anything but the piece the fingers open around (whose
            // gap is the gripper's opening), or touching anything.
            let near = match &report.executed_clearance {
                Some(Executed::Measured(m)) if m.distance < margin || m.is_contact() => {
                    if m.is_contact() {
                        0.0
                    } else {
                        m.distance
                    }
                }
                _ => {
                    best = None;
                    break;
                }
            };
            too_near.push(near);
            // The faster of two tries that come as near.
            if best.as_ref().is_none_or(|(nearest, ..)| near > *nearest) {
                best = Some((near, pace, self.snapshot(), report.clone()));
            }
            if tries == PACE_TRIES {
                break;
            }
            pace *= PACE_STEP;
            self.restore(&start.0);
            *report = start.1.clone();
        }
        // A try that kept the margin stands as it ran; else the one that came least near.
        if let Some((_, best_pace, after, best_report)) = best {
            self.restore(&after);
            *report = best_report;
            pace = best_pace;
        }
        report.pace = pace;
        report.too_near_at = too_near;
        Ok(())
    }

    /// What a robot move changes in the game, to run it again.
    fn snapshot(&self) -> Snapshot {
        Snapshot {
            feedback: self.feedback.clone(),
            table: self.table.clone(),
            tool: self.tool,
            state: self.state,
            actuators: self.actuators,
            robot_time: self.robot_time,
        }
    }

    fn restore(&mut self, snapshot: &Snapshot) {
        self.feedback = snapshot.feedback.clone();
        self.table = snapshot.table.clone();
        self.tool = snapshot.tool;
        self.state = snapshot.state;
        self.actuators = snapshot.actuators;
        self.robot_time = snapshot.robot_time;
    }

    /// One try of a robot move at `limits`: planned clear ([`Self::plan_clear`]), simulated,
    /// the pieces put where the simulation left them; the arm's state, the robot time and the
    /// tool are the game's after it.
    fn attempt(
        &mut self,
        mv: &Move,
        name: &str,
        report: &mut MoveReport,
        limits: MotionLimits,
    ) -> Result<(), PlayError> {
        let ClearPlan { plan, clearance: planned_clearance, adjustments, check } = self.plan_clear(mv, name, limits)?;
        report.clearance = planned_clearance;
        report.adjustments = adjustments;
        report.opening = check.as_ref().map(|c| c.gripper.finger_opening);
        let settings = &self.settings;
        let PlannedMove { motion, trajectory, tasks: planned, phases, .. } = &plan;
        report.planned_duration = motion.duration();
        report.phases = *phases;
        report.longest_limit = plan.longest_limit().map(|(n, t)| (n.to_string(), t));
        report.slowdowns = plan.slowdowns;
        if let Some(rate) = settings.export_rate {
            let commands = plan.gripper_commands();
            let points = hardware_points(&self.arm, motion, &commands, rate)
                .map_err(|source| PlayError::Export { mv: name.to_string(), source })?;
            let grips = planned.iter().map(|step| step.task.to_string()).collect();
            let reach = check
                .as_ref()
                .map_or(chessarm_core::arm::bodies::Gripper::default().finger_reach, |c| c.gripper.finger_reach);
            let widths =
                planned.iter().map(|step| settings.pieces.dimensions(step.task.piece.role).grip_width(reach)).collect();
            let fine_points = commands.iter().map(|c| motion.sample(c.time).position).collect();
            report.hardware = Some(HardwareExport {
                points,
                commands,
                grips,
                widths,
                fine_points,
                in_position: settings.in_position,
                servo_goals: Vec::new(),
            });
        }
        let events = gripper_events(settings, &self.arm, &self.table, planned);
        let marks: Vec<f64> = events.iter().map(|event| event.time).collect();
        let true_actuators = settings.true_actuators.unwrap_or(settings.actuators);
        let plant_model = true_actuators.plant_model(&settings.plant.unwrap_or(self.arm)).map_err(|source| {
            PlayError::Controller { name: settings.controller.name.clone(), source: source.into() }
        })?;
        let mut plant = Plant::new(plant_model);
        let mut controller = settings
            .controller
            .build_for(self.arm, &settings.actuators)
            .map_err(|source| PlayError::Controller { name: settings.controller.name.clone(), source })?;
        let config = SimConfig {
            actuators: true_actuators,
            dt: settings.dt,
            control_period: settings.control_period,
            integrator: settings.integrator,
            torque_lag: settings.conditions.torque_lag,
            actuator_start: self.actuators,
            ..SimConfig::new(&plant)
        };
        let bus_steps = if settings.export_rate.is_some() && true_actuators.take_positions() {
            (settings.control_period / settings.dt).round().max(1.0) as usize
        } else {
            0
        };
        // The simulated joint angles for the clearance check, every millisecond or step.
        let path_steps = if check.is_some() { (1e-3 / settings.dt).round().max(1.0) as usize } else { 0 };
        let mut sampler = Sampler {
            every: settings.record_every,
            seen: 0,
            records: Vec::new(),
            bus_steps,
            goals: Vec::new(),
            path_steps,
            // One pose per millisecond of the planned motion (fine points' waits add a few).
            path: Vec::with_capacity(if path_steps > 0 { trajectory.samples().len() + 1 } else { 0 }),
            deviation: [0.0; 4],
        };
        let (summary, waits) = simulate_fine_points(
            &mut plant,
            &mut self.feedback,
            controller.as_mut(),
            trajectory,
            // The first move of servos or steppers starts as they hold the host's first goal,
            // settled; later ones where the last left the arm.
            if self.actuators.is_none() && settings.actuators.take_positions() { None } else { Some(self.state) },
            &events,
            &marks,
            settings.in_position.as_ref(),
            &config,
            &mut sampler,
        )
        .map_err(|source| PlayError::Simulation { mv: name.to_string(), source })?;
        // When each gripper command went ahead, s from the move's start: the plan's instant
        // plus the waits before it.
        let event_time = |k: usize, planned: f64| {
            waits.iter().find(|w: &&Wait| w.event == k).map_or(planned, |w| w.reached + w.duration)
        };
        let table_before = check.as_ref().map(|_| self.table.clone());
        let mut carries = Vec::with_capacity(planned.len());
        for (index, step) in planned.iter().enumerate() {
            let standing = self
                .table
                .piece_at(step.task.from)
                .map(|p| p.position)
                .unwrap_or_else(|| self.table.nominal_position(step.task.from));
            let placed = placed_position(
                &self.arm.base().xy(),
                &summary.tip_at_marks[2 * index],
                &summary.tip_at_marks[2 * index + 1],
                &standing,
            );
            let target = self.table.nominal_position(step.task.to);
            if let Some(piece) = self.table.index_at(step.task.from) {
                let (grip, release) =
                    (event_time(2 * index, step.plan.grip_time), event_time(2 * index + 1, step.plan.release_time));
                carries.push(Carry { piece, to: step.task.to, grip, release, placed });
                report.handled.push(Handling {
                    piece,
                    from: step.task.from,
                    to: step.task.to,
                    grip_time: self.robot_time + grip,
                    release_time: self.robot_time + release,
                    standing,
                    placed,
                    grip_tip: Some(summary.tip_at_marks[2 * index]),
                });
            }
            self.relocate(name, step.task.from, step.task.to, placed)?;
            report.tasks.push(step.task.to_string());
            report.place_errors.push((placed - target).norm());
        }
        if let (Some(clear), Some(rules), Some(before), Some(planned)) =
            (&check, &self.rules, &table_before, &report.clearance)
        {
            // Every point of the simulated arm is within Σ_j |q_j − q_ref,j| ρ_j of where the
            // plan had it at the same reference instant, and the pieces put down in this
            // move within their placement error of the plan's places.
            let pieces = &self.settings.pieces;
            let largest =
                Held { outline: pieces.envelope(), grip_height: pieces.highest_grip(), turn: clear.held_turn };
            let hand =
                Hand { held: Some(largest), gap: clear.gripper.open_gap(pieces.widest()), gripper: clear.gripper };
            let reach = reach_bound(&self.arm, &hand, &clear.bodies);
            let strayed: f64 = (0..4).map(|j| sampler.deviation[j] * reach[j]).sum();
            let moved = report.place_errors.iter().fold(0.0, |a: f64, b| a.max(*b));
            // The simulated grip holds a piece off the tip's axis by where the tip closed on it.
            let held_off = report
                .handled
                .iter()
                .filter_map(|h| h.grip_tip.map(|tip| (tip.xy() - h.standing).norm()))
                .fold(0.0, f64::max);
            // Two of the arm's own solids may each stray: twice.
            let at_least =
                (planned.distance.min(planned.gripped.unwrap_or(f64::INFINITY)) - 2.0 * strayed - moved - held_off)
                    .max(0.0);
            // The margin is the plan's; the simulated motion is measured where the bound
            // cannot rule out coming nearer (with the pace chosen, nearer than the margin).
            let measure_below = if self.settings.choose_pace { clear.margin } else { 0.0 };
            report.executed_clearance = Some(if at_least > measure_below {
                Executed::AtLeast(at_least)
            } else {
                match check_move(
                    &self.arm,
                    clear,
                    rules,
                    before,
                    &self.settings.pieces,
                    &sampler.path,
                    &carries,
                    &mut self.scratch,
                ) {
                    Some(measured) => Executed::Measured(measured),
                    None => Executed::AtLeast(at_least),
                }
            });
        }
        report.duration = summary.duration;
        report.max_tip_error = Some(summary.max_tip_error);
        report.records = sampler.records;
        if let Some(hardware) = &mut report.hardware {
            hardware.servo_goals = sampler.goals;
        }
        report.summary = Some(summary.clone());
        report.waits = waits;
        self.robot_time += summary.duration;
        self.tool = motion.end();
        self.state = summary.final_state;
        self.actuators = summary.actuators;
        Ok(())
    }
}

/// The simulated motion's closest approach: at least the plan's less how far the simulated arm
/// strayed from it (and the pieces it put down from their planned places), or, where that
/// bound cannot rule out a contact, measured over the simulated motion itself.
#[derive(Debug, Clone, PartialEq)]
pub enum Executed {
    AtLeast(f64),
    Measured(MoveClearance),
}

impl Executed {
    /// The clearance, m (a lower bound for [`Executed::AtLeast`]).
    pub fn distance(&self) -> f64 {
        match self {
            Executed::AtLeast(d) => *d,
            Executed::Measured(m) => m.distance.min(m.gripped.unwrap_or(f64::INFINITY)),
        }
    }

    /// Whether the simulated arm touched (or may have, within the sweep's resolution) a
    /// piece, the table or itself.
    pub fn is_contact(&self) -> bool {
        matches!(self, Executed::Measured(m) if m.is_contact())
    }
}

/// A plan that keeps clear: the plan, its closest approach, what was changed for it and the
/// check it passed (its gripper's opening).
struct ClearPlan {
    plan: PlannedMove,
    clearance: Option<MoveClearance>,
    adjustments: Vec<String>,
    check: Option<ClearanceCheck>,
}

/// The refusal of a move that comes too near, with what was tried.
fn contact(name: &str, near: &MoveClearance, margin: f64, adjustments: &[String], also: Option<String>) -> PlayError {
    let mut tried: Vec<String> = adjustments.iter().map(|a| a.split(':').next().unwrap_or(a).to_string()).collect();
    tried.extend(also);
    PlayError::Contact {
        mv: name.to_string(),
        part: near.part.to_string(),
        obstacle: near.obstacle_name.clone(),
        distance: near.distance,
        time: near.time,
        margin,
        tried: if tried.is_empty() { String::new() } else { format!(" (after {})", tried.join(", ")) },
    }
}

/// The first line of a message.
fn first_line(text: &str) -> &str {
    text.lines().next().unwrap_or(text)
}

/// How much and how many times the planner raises the traverses' clearance margin, m.
const RAISE: f64 = 0.02;
const RAISES: usize = 3;

/// The pick-and-places of a plan as [`Carry`]s: each piece's table index and its place's
/// nominal centre, at the planned grip and release times.
fn planned_carries(table: &Table, planned: &[PlannedTask]) -> Vec<Carry> {
    let mut scratch = table.clone();
    let mut carries = Vec::with_capacity(planned.len());
    for step in planned {
        let placed = scratch.nominal_position(step.task.to);
        if let Some(piece) = scratch.index_at(step.task.from) {
            carries.push(Carry {
                piece,
                to: step.task.to,
                grip: step.plan.grip_time,
                release: step.plan.release_time,
                placed,
            });
        }
        // A plan's tasks were made on this table: each relocation succeeds.
        let _ = scratch.relocate(step.task.from, step.task.to, placed);
    }
    carries
}

/// The payload events of a move's planned tasks, a grip and a release per task: the plant
/// takes the true piece (`true_pieces`, else `pieces`) of the kind that stands on the task's
/// square; the controller's model is told that true piece with
/// [`PlaySettings::controller_knows_payload`], else the nominal piece of that kind (`pieces`)
/// with [`PlaySettings::payload_feedforward`], else nothing. Each piece hangs upright from
/// the tool at the game's pitch on `arm`.
pub fn gripper_events(
    settings: &PlaySettings,
    arm: &ArmModel<4>,
    table: &Table,
    planned: &[PlannedTask],
) -> Vec<PayloadEvent> {
    let mut events = Vec::with_capacity(2 * planned.len());
    let turn = held_turn(arm, settings.limits.pitch);
    for step in planned {
        let piece = table.piece_at(step.task.from).map(|p| p.piece.role).unwrap_or(step.task.piece.role);
        let payload = settings.true_pieces.as_ref().unwrap_or(&settings.pieces).payload(piece).turned(turn);
        let told = if settings.controller_knows_payload {
            Told::Payload(Some(payload))
        } else if settings.payload_feedforward {
            Told::Payload(Some(settings.pieces.payload(piece).turned(turn)))
        } else {
            Told::Nothing
        };
        let released = if told == Told::Nothing { Told::Nothing } else { Told::Payload(None) };
        events.push(PayloadEvent { time: step.plan.grip_time, payload: Some(payload), told });
        events.push(PayloadEvent { time: step.plan.release_time, payload: None, told: released });
    }
    events
}

pub use crate::tasks::home_tool;

/// The joint angles the arm rests at before the first move (rad): the tool down at
/// [`home_tool`]. A driver of the real arm starts from here, and the simulated servo bus too.
///
/// # Errors
///
/// [`PlayError::Home`] if the arm cannot reach it.
pub fn home_pose(
    arm: &ArmModel<4>,
    board: &BoardGeometry,
    pieces: &PieceSet,
    limits: &MotionLimits,
) -> Result<JointVector<4>, PlayError> {
    inverse_kinematics(arm, &home_tool(board, pieces, limits), limits.pitch).map_err(PlayError::Home)
}

/// Where a piece that stood at `standing` (board plane, m) is put down when gripped with the
/// tool tip at `grip_tip` and released at `release_tip`. The piece moves rigidly with the
/// gripper from grip to release: its offset from the tool tip turns with the tool's yaw, which
/// for this arm is the tip's bearing about the base axis (joint 1).
/// The bearing is taken about the base axis, which stands at `base` (x, y, m;
/// [`ArmModel::base`]).
pub fn placed_position(
    base: &Vector2<f64>,
    grip_tip: &Vector3<f64>,
    release_tip: &Vector3<f64>,
    standing: &Vector2<f64>,
) -> Vector2<f64> {
    let (grip, release) = (grip_tip.xy() - base, release_tip.xy() - base);
    let standing = &(standing - base);
    let turn = Rotation2::new(release.y.atan2(release.x) - grip.y.atan2(grip.x));
    base + release + turn * (standing - grip)
}
