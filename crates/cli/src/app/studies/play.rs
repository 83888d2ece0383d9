//! Playing a game with the simulated arm: the game's settings from the setup and the options
//! (the controller or the servos' host, the conditions, the placement), whose side the arm
//! plays, and the result the rules (or the game's record) give.

use crate::app::setup::conditions::{ConditionOptions, Study, Trial};
use crate::app::setup::file::Setup;
use crate::app::studies::placement::Placement;
use crate::app::studies::simulate::{ControllerName, DefaultGains, GivenGains, controller_specs};
use anyhow::{Result, bail};
use chessarm_chess::notation::GameRecord;
use chessarm_chess::outcome::OutcomeReason;
use chessarm_chess::play::{Game, PlaySettings};
use chessarm_chess::shakmaty::Color;
use chessarm_core::sim::Integrator;

/// Which side the arm plays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RobotSide {
    White,
    Black,
    Both,
}

impl RobotSide {
    /// Whether the arm makes the move of the side to move, `turn`.
    pub fn moves(self, turn: Color) -> bool {
        matches!(
            (self, turn),
            (RobotSide::Both, _) | (RobotSide::White, Color::White) | (RobotSide::Black, Color::Black)
        )
    }
}

/// How a game is played, as the `play` command's flags give it (SI: `tolerance` m, `dt` s).
#[derive(Debug, Clone)]
pub struct PlayOptions {
    /// The torque controller (with servos, the setup's one host strategy instead).
    pub controller: ControllerName,
    pub gains: GivenGains,
    /// Sensors, estimator, lag and the true arm.
    pub conditions: ConditionOptions,
    pub placement: Placement,
    /// A piece further than this from its square centre is misplaced, m.
    pub tolerance: f64,
    /// Integration step, s.
    pub dt: f64,
    pub integrator: Integrator,
    /// Rate of the hardware export's samples, Hz.
    pub export_rate: f64,
    pub controller_knows_payload: bool,
    /// Every move at the limits' pace, none slowed where its simulated motion comes too near
    /// ([`PlaySettings::choose_pace`] off).
    pub keep_pace: bool,
}

/// A game's settings made ready: what [`Game::new`] takes, the study of its conditions and its
/// trial, and the notes to tell the person (the conditions, friction the controller does not
/// know), each a line as the terminal shows it.
#[derive(Debug)]
pub struct Prepared {
    pub settings: PlaySettings,
    /// The controller's name (pd, pid, …; with servos the host's strategy).
    pub controller: String,
    pub study: Study,
    pub trial: Trial,
    /// No sensors' noise, lag or model errors: the trial is not applied.
    pub ideal: bool,
    /// With servos: that their host replaces the torque controllers.
    pub servo_note: Option<String>,
    pub notes: Vec<String>,
}

/// The settings of a game on `setup` (its motion limits and timing as the game's) with
/// `options`; with servos, their host ([`crate::app::setup::servos::servo_hosts`]: the setup
/// names one strategy).
///
/// # Errors
///
/// Pieces the file's fingers cannot hold ([`crate::app::setup::gripper::check_file_fingers`]), more than one host
/// strategy, bad gains or conditions, a trial that cannot be drawn.
pub fn prepare(setup: &Setup, options: &PlayOptions) -> Result<Prepared> {
    crate::app::setup::gripper::check_file_fingers(setup)?;
    let (hosts, servo_note) = match crate::app::setup::servos::servo_hosts(setup) {
        Some((hosts, note)) => (Some(hosts), Some(note)),
        None => (None, None),
    };
    if hosts.as_ref().is_some_and(|h| h.len() > 1) {
        bail!("--servo-command: play sends one kind of goal; give one of plain, sag, feedforward");
    }
    let mut spec = match hosts {
        Some(mut hosts) => hosts.remove(0),
        None => controller_specs(&[options.controller], &options.gains, DefaultGains::Game)?.remove(0),
    };
    spec.knows_friction = options.conditions.knows_friction(setup);
    let controller = spec.name.clone();
    let mut settings = PlaySettings::new(spec.name.clone(), spec.gains);
    settings.controller = spec;
    crate::app::setup::servos::drive(setup, &mut settings);
    let study = Study::new(setup, &options.conditions, settings.control_period)?;
    let trial = study.trial(options.conditions.run_seed())?;
    let ideal = study.is_ideal(setup);
    let mut notes = Vec::new();
    if !ideal {
        notes.push(study.note(options.conditions.run_seed()));
        trial.apply_to(&mut settings);
    }
    if let Some(note) = study.friction_note() {
        notes.push(note);
    }
    settings.pieces = setup.pieces;
    settings.clearance = Some(setup.clearance.clone());
    settings.limits = setup.motion;
    settings.timing = setup.timing;
    settings.export_rate = Some(options.export_rate);
    settings.controller_knows_payload = options.controller_knows_payload;
    options.placement.apply(&mut settings, options.tolerance, study.resolution(setup));
    settings.integrator = options.integrator;
    settings.dt = options.dt;
    settings.tolerance = options.tolerance;
    settings.choose_pace = !options.keep_pace;
    settings.limits.tracking = study.tracking(
        setup,
        &settings.controller.gains,
        settings.payload_feedforward && crate::app::setup::servos::cancels_inertia(&settings.controller.kind),
        settings.controller_knows_payload,
    );
    Ok(Prepared { settings, controller, study, trial, ideal, servo_note, notes })
}

/// Where a game's moves came from, for its result.
#[derive(Debug, Clone, Copy)]
pub enum Played<'a> {
    /// Given moves or a PGN's game (whose `Result` tag stands where the rules say nothing).
    Record(&'a GameRecord),
    /// Engines, stopped after `plies` half-moves at the most.
    Engines { plies: usize },
    /// A person against the arm.
    Person,
}

/// The game's result as PGN writes it (`1-0`, `0-1`, `1/2-1/2`, `*`) and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GameResult {
    pub result: String,
    pub reason: String,
}

/// What the rules say of the final position; a replayed game that is not over there keeps the
/// result its PGN records; otherwise `*` and why the game stopped (`played` plies).
pub fn game_result(game: &Game, source: Played<'_>, played: usize) -> GameResult {
    let outcome = game.outcome();
    // Threefold repetition and the fifty-move rule are draws a player may claim: a replayed
    // game whose PGN records another result was played on, so its record stands.
    let claimable =
        outcome.is_some_and(|o| matches!(o.reason, OutcomeReason::ThreefoldRepetition | OutcomeReason::FiftyMoveRule));
    let recorded = match source {
        Played::Record(record) => record.header("Result").filter(|r| ["1-0", "0-1", "1/2-1/2"].contains(r)),
        Played::Engines { .. } | Played::Person => None,
    };
    if let Some(outcome) = outcome
        && !(claimable && recorded.is_some())
    {
        return GameResult { result: outcome.result.to_string(), reason: outcome.reason.to_string() };
    }
    let (result, reason) = match source {
        Played::Record(_) => match (recorded, outcome) {
            (Some(recorded), Some(outcome)) => {
                (recorded.to_string(), format!("as the PGN records it ({} could have been claimed)", outcome.reason))
            }
            (Some(recorded), None) => {
                (recorded.to_string(), "as the PGN records it (the final position is not over by the rules)".into())
            }
            (None, _) => ("*".into(), "the given moves end; the game is not over".into()),
        },
        Played::Engines { plies } => {
            ("*".into(), format!("stopped after --plies {plies} ({played} played); the game is not over"))
        }
        Played::Person => ("*".into(), "the game is not over".into()),
    };
    GameResult { result, reason }
}
