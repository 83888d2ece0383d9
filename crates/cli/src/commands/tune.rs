//! `tune`: sweep gain combinations in parallel (rayon), one row per candidate.
//!
//! Each candidate is the whole scenario simulated without recording its time series. The rows
//! come out in candidate order whatever the number of threads, so a sweep is reproducible and
//! `--shard K/N` slices concatenate (`cat`) to the full sweep: only slice 1 carries the header.

use crate::app::formats::plots::{HeatMap, plot_heat_map, tick};
use crate::app::output::{ensure_dir, write_atomic};
use crate::app::setup::conditions::Trial;
use crate::app::setup::file::Setup;
use crate::app::studies::plan::plan_scenario;
use crate::app::studies::simulate::{
    ControllerName, DefaultGains, GivenGains, TRANSIENT_S, controller_specs, ensure_tracked, pawn_events,
};
use crate::cli::{Metric, OneController, TuneArgs};
use anyhow::{Context, Result, bail};
use chessarm_chess::notation::GameRecord;
use chessarm_chess::play::{Game, Mover, PlaySettings};
use chessarm_core::arm::model::JointVector;
use chessarm_core::control::JointState;
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::control::gains::Gains;
use chessarm_core::control::servo_host::ServoCommand;
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sense::Conditions;
use chessarm_core::sim::batch::{LaneCount, LaneRun, SimdLevel, simulate_lanes};
use chessarm_core::sim::{Integrator, PayloadEvent, Plant, SimConfig, SimError, SimSummary};
use rayon::prelude::*;
use serde_json::json;
use std::time::Instant;

/// What one candidate is simulated on: a scenario, or a whole game played by the arm.
#[derive(Debug)]
pub enum Study {
    Scenario(ScenarioStudy),
    Game(GameRecord),
}

/// A scenario's trajectory with its payload events.
#[derive(Debug)]
pub struct ScenarioStudy {
    pub trajectory: JointTrajectory,
    pub events: Vec<PayloadEvent>,
    /// Grip and release instants, s.
    pub marks: Vec<f64>,
    pub initial: Option<JointState<4>>,
}

/// What one candidate runs: a torque controller's gains, or servos' P register under a host
/// strategy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Setting {
    Torque(Gains<4>),
    Servo { command: ServoCommand, p_gain: f64 },
}

/// One candidate's gains and metrics (SI, tip errors in mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    pub index: usize,
    pub kp: f64,
    pub kd: f64,
    pub ki: f64,
    /// A servo candidate's host strategy and P register (`None`, NaN for torque controllers).
    pub servo_command: Option<ServoCommand>,
    pub p_gain: f64,
    /// "ok", or why the run failed (e.g. it diverged).
    pub status: String,
    pub max_tip_error_mm: f64,
    pub rms_tip_error_mm: f64,
    pub place_error_mm: f64,
    pub rms_joint_error_rad: f64,
    pub max_joint_error_rad: f64,
    pub peak_torque_nm: f64,
    /// Largest peak |τ| / torque limit over the joints.
    pub peak_torque_ratio: f64,
    pub saturated_samples: usize,
    /// Pieces off their squares at the end (games only).
    pub misplaced: usize,
}

pub const CSV_HEADER: &str = "index,kp,kd,ki,status,max_tip_error_mm,rms_tip_error_mm,place_error_mm,rms_joint_error_rad,max_joint_error_rad,peak_torque_nm,peak_torque_ratio,saturated_samples,misplaced";
/// A servo sweep's columns: the host strategy and the P register instead of the gains;
/// `saturated_samples` counts the servos' duty at its limit (a servo's normal state on a fast
/// move, not a failure).
pub const SERVO_CSV_HEADER: &str = "index,servo_command,p_gain,status,max_tip_error_mm,rms_tip_error_mm,place_error_mm,rms_joint_error_rad,max_joint_error_rad,peak_torque_nm,peak_torque_ratio,saturated_samples,misplaced";

impl Candidate {
    pub fn metric(&self, metric: Metric) -> f64 {
        match metric {
            Metric::MaxTipError => self.max_tip_error_mm,
            Metric::RmsJointError => self.rms_joint_error_rad,
            Metric::PeakTorque => self.peak_torque_ratio,
            Metric::PlaceError => self.place_error_mm,
        }
    }

    /// Finished, never hit a torque limit and left no piece misplaced (a servo's duty at its
    /// limit is how it moves fast, not a torque limit hit: its stalls show as errors).
    pub fn respects_limits(&self) -> bool {
        self.status == "ok" && (self.saturated_samples == 0 || self.servo_command.is_some()) && self.misplaced == 0
    }

    fn csv_line(&self) -> String {
        let setting = match self.servo_command {
            Some(command) => format!("{},{:?}", command.name(), self.p_gain),
            None => format!("{:?},{:?},{:?}", self.kp, self.kd, self.ki),
        };
        format!(
            "{},{setting},{},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{},{}",
            self.index,
            self.status.replace(',', ";"),
            self.max_tip_error_mm,
            self.rms_tip_error_mm,
            self.place_error_mm,
            self.rms_joint_error_rad,
            self.max_joint_error_rad,
            self.peak_torque_nm,
            self.peak_torque_ratio,
            self.saturated_samples,
            self.misplaced
        )
    }
}

/// A candidate with its gains (or servo setting) and no results yet.
fn blank_candidate(index: usize, setting: &Setting) -> Candidate {
    let (gains, servo_command, p_gain) = match setting {
        Setting::Torque(gains) => ([gains.kp[0], gains.kd[0], gains.ki[0]], None, f64::NAN),
        Setting::Servo { command, p_gain } => ([f64::NAN; 3], Some(*command), *p_gain),
    };
    Candidate {
        index,
        kp: gains[0],
        kd: gains[1],
        ki: gains[2],
        servo_command,
        p_gain,
        status: "ok".into(),
        max_tip_error_mm: f64::NAN,
        rms_tip_error_mm: f64::NAN,
        place_error_mm: f64::NAN,
        rms_joint_error_rad: f64::NAN,
        max_joint_error_rad: f64::NAN,
        peak_torque_nm: f64::NAN,
        peak_torque_ratio: f64::NAN,
        saturated_samples: 0,
        misplaced: 0,
    }
}

/// Metrics accumulated over one or more simulations.
#[derive(Default)]
struct Totals {
    samples: f64,
    squared_tip: f64,
    squared_joint: f64,
    max_tip: f64,
    max_joint: f64,
    peak_torque: f64,
    peak_ratio: f64,
    saturated: usize,
}

impl Totals {
    fn add(&mut self, summary: &SimSummary<4>, limits: &JointVector<4>) {
        let samples = summary.tracked_steps as f64;
        self.samples += samples;
        self.squared_tip += summary.rms_tip_error.powi(2) * samples;
        self.squared_joint += summary.rms_joint_error.norm_squared() / 4.0 * samples;
        self.max_tip = self.max_tip.max(summary.max_tip_error);
        self.max_joint = self.max_joint.max(summary.max_joint_error.max());
        self.peak_torque = self.peak_torque.max(summary.peak_torque.max());
        self.peak_ratio = self.peak_ratio.max(summary.peak_torque.component_div(limits).max());
        self.saturated += summary.saturated_samples;
    }

    fn fill(&self, candidate: &mut Candidate, place_error: f64) {
        candidate.max_tip_error_mm = self.max_tip * 1e3;
        candidate.rms_tip_error_mm = (self.squared_tip / self.samples).sqrt() * 1e3;
        candidate.place_error_mm = place_error * 1e3;
        candidate.rms_joint_error_rad = (self.squared_joint / self.samples).sqrt();
        candidate.max_joint_error_rad = self.max_joint;
        candidate.peak_torque_nm = self.peak_torque;
        candidate.peak_torque_ratio = self.peak_ratio;
        candidate.saturated_samples = self.saturated;
    }
}

/// Plays one candidate through the game `record` (1 ms steps of `options.integrator`, 1 kHz
/// control, torque limits of the model); a scenario's candidates go to
/// [`scenario_candidates`].
fn game_candidate(
    setup: &Setup,
    record: &GameRecord,
    options: &CandidateOptions,
    index: usize,
    setting: &Setting,
) -> Candidate {
    let mut candidate = blank_candidate(index, setting);
    let limits = setup.arm.torque_limits();
    let mut totals = Totals::default();
    let drive = Drive::of(setup, options, setting);
    let mut settings = PlaySettings::new("candidate", drive.gains);
    settings.controller.kind = drive.kind;
    settings.pieces = setup.pieces;
    settings.clearance = Some(setup.clearance.clone());
    settings.limits = setup.motion;
    settings.limits.tracking = drive.tracking(setup);
    settings.limits.tracking.mass_error = options.mass_error;
    settings.timing = setup.timing;
    if let Some(trial) = &options.trial {
        trial.apply_to(&mut settings);
    }
    if setup.actuators.take_positions() {
        settings.actuators = drive.actuators;
        settings.true_actuators = Some(drive.true_actuators);
        settings.control_period = drive.control_period;
    }
    settings.record_every = 0;
    settings.controller_knows_payload = options.controller_knows_payload;
    // The fine points' band with this candidate's servos (their stiffness is swept).
    let resolution = crate::app::setup::conditions::Resolution {
        holding_band: drive.actuators.holding_band(&setup.arm),
        ..options.resolution
    };
    options.placement.apply(&mut settings, chessarm_chess::play::DEFAULT_TOLERANCE, resolution);
    settings.integrator = options.integrator;
    let played = Game::new(setup.arm, setup.board, record.start.clone(), settings).and_then(|mut game| {
        let mut place = 0.0f64;
        for mv in &record.moves {
            let report = game.play(mv, Mover::Robot)?;
            if let Some(summary) = &report.summary {
                totals.add(summary, &limits);
            }
            place = report.place_errors.iter().fold(place, |a, b| a.max(*b));
        }
        Ok((place, game.misplaced().len()))
    });
    match played {
        Ok((place, misplaced)) => {
            totals.fill(&mut candidate, place);
            candidate.misplaced = misplaced;
        }
        Err(error) => candidate.status = format!("failed: {error}"),
    }
    candidate
}

/// A scenario candidate as a run of the batch simulator (1 ms steps of `options.integrator`,
/// 1 kHz control, torque limits of the model), or its status saying why it cannot start.
fn scenario_run<'a>(
    setup: &Setup,
    scenario: &'a ScenarioStudy,
    options: &CandidateOptions,
    setting: &Setting,
) -> Result<LaneRun<'a>, String> {
    let failed = |error: &dyn std::fmt::Display| format!("failed: {error}");
    let trial = options.trial.as_ref();
    let drive = Drive::of(setup, options, setting);
    // Servos' gears are part of the true plant.
    let plant = drive.true_actuators.plant_model(&trial.map_or(setup.arm, |t| t.plant)).map_err(|e| failed(&e))?;
    let spec = ControllerSpec {
        name: "candidate".into(),
        kind: drive.kind,
        gains: drive.gains,
        knows_friction: options.knows_friction,
    };
    let controller = spec.build_for(setup.arm, &drive.actuators).map_err(|error| failed(&error))?;
    let conditions = trial.map_or_else(Conditions::ideal, |t| t.conditions.clone());
    let feedback = conditions.feedback(drive.control_period).map_err(|error| failed(&error))?;
    let config = SimConfig {
        integrator: options.integrator,
        tracking_from: options.tracking_from,
        torque_lag: conditions.torque_lag,
        actuators: drive.true_actuators,
        control_period: drive.control_period,
        ..SimConfig::new(&Plant::new(plant))
    };
    Ok(LaneRun {
        plant,
        feedback,
        controller,
        reference: &scenario.trajectory,
        initial: scenario.initial,
        events: &scenario.events,
        marks: &scenario.marks,
        config,
    })
}

/// `candidate` with the metrics of its scenario run.
fn scenario_candidate(setup: &Setup, mut candidate: Candidate, result: Result<SimSummary<4>, SimError>) -> Candidate {
    match result {
        Ok(summary) => {
            let mut totals = Totals::default();
            totals.add(&summary, &setup.arm.torque_limits());
            let place = summary.tip_error_at_marks.iter().fold(0.0f64, |a, b| a.max(*b));
            totals.fill(&mut candidate, place);
        }
        Err(error) => candidate.status = format!("failed: {error}"),
    }
    candidate
}

/// The scenario candidates `indices`, `lanes` runs side by side at SIMD level `level`, in order.
fn scenario_candidates(
    setup: &Setup,
    scenario: &ScenarioStudy,
    options: &CandidateOptions,
    settings: &[Setting],
    indices: &[usize],
    (lanes, level): (LaneCount, SimdLevel),
) -> Vec<Candidate> {
    let mut out: Vec<Option<Candidate>> = vec![None; indices.len()];
    let mut runs = Vec::with_capacity(indices.len());
    let mut slots = Vec::with_capacity(indices.len());
    for (slot, &index) in indices.iter().enumerate() {
        let blank = blank_candidate(index, &settings[index]);
        match scenario_run(setup, scenario, options, &settings[index]) {
            Ok(run) => {
                runs.push(run);
                slots.push((slot, blank));
            }
            Err(status) => out[slot] = Some(Candidate { status, ..blank }),
        }
    }
    for ((slot, blank), result) in slots.into_iter().zip(simulate_lanes(&mut runs, lanes, level)) {
        out[slot] = Some(scenario_candidate(setup, blank, result));
    }
    out.into_iter().map(|candidate| candidate.unwrap_or_else(|| unreachable!("every slot is filled"))).collect()
}

/// Settings every candidate shares.
#[derive(Debug, Clone)]
pub struct CandidateOptions {
    pub controller_knows_payload: bool,
    /// How a game's pieces are put down.
    pub placement: crate::cli::PlacementArgs,
    /// Which controller the gains are for.
    pub kind: ControllerKind,
    /// Whether the controller compensates its model's friction.
    pub knows_friction: bool,
    /// Sensors, estimator, lag and the true arm (`None`: ideal, the setup's arm); every
    /// candidate runs the same trial (the same draws and sensor noise).
    pub trial: Option<Trial>,
    pub integrator: Integrator,
    /// Start of the tracking metrics, s (see [`SimConfig::tracking_from`]).
    pub tracking_from: f64,
    /// A game's pieces' largest mass errors for the tracking budget, per kind (see
    /// [`crate::app::setup::conditions::Study::tracking`]), kg.
    pub mass_error: [f64; 6],
    /// What the fine points' band can resolve: the sensors' and the servos' counts.
    pub resolution: crate::app::setup::conditions::Resolution,
    /// Each joint's servo's P register conversion ([`crate::app::setup::servos::p_register_conversions`]).
    pub p_conversions: [Option<f64>; 4],
}

/// What drives a candidate's joints: its controller (a torque controller with its gains, or
/// a servo host), the actuators the host knows and the true ones, and the control period.
struct Drive {
    kind: ControllerKind,
    gains: Gains<4>,
    actuators: chessarm_core::sim::actuator::Actuators<4>,
    true_actuators: chessarm_core::sim::actuator::Actuators<4>,
    control_period: f64,
}

impl Drive {
    fn of(setup: &Setup, options: &CandidateOptions, setting: &Setting) -> Self {
        let true_actuators = options.trial.as_ref().map_or(setup.actuators, |t| t.actuators);
        match setting {
            Setting::Torque(gains) => Self {
                kind: options.kind,
                gains: *gains,
                actuators: setup.actuators,
                true_actuators,
                control_period: 1e-3,
            },
            Setting::Servo { command, p_gain } => {
                let with_p = |a| crate::app::setup::servos::with_p_register(a, &options.p_conversions, *p_gain);
                Self {
                    kind: ControllerKind::ServoHost(*command),
                    // A host has no gains; the number is not used.
                    gains: Gains::uniform(1.0, 1.0, 0.0).unwrap_or_else(|_| unreachable!("positive gains")),
                    actuators: with_p(&setup.actuators),
                    true_actuators: with_p(&true_actuators),
                    control_period: 1.0 / setup.bus_rate,
                }
            }
        }
    }

    /// The tracking budget of a game's carried pieces for this drive.
    fn tracking(&self, setup: &Setup) -> chessarm_chess::tasks::Tracking {
        setup.motion.tracking.for_actuators(&self.gains, &self.actuators, &setup.arm)
    }
}

/// The start of the tracking metrics for `args`, s: with `--q0` unless `--tracking-from` is
/// given, after the start-up transient ([`TRANSIENT_S`]), since the start-up jump (530 mm at
/// t = 0 from q = 0) would be every candidate's largest error.
pub fn tracking_from(args: &TuneArgs) -> f64 {
    args.tracking_from.unwrap_or(if args.q0.is_some() { TRANSIENT_S } else { 0.0 })
}

/// Most candidates one sweep may describe.
pub const MAX_CANDIDATES: usize = 10_000_000;

/// The kp and kd ranges of a torque controller's sweep (clap asks for them unless --p-gain
/// is given, which `run` sends to the servos' sweep).
fn torque_ranges(args: &TuneArgs) -> Result<(crate::args::GainRange, crate::args::GainRange)> {
    match (args.kp, args.kd) {
        (Some(kp), Some(kd)) => Ok((kp, kd)),
        _ => bail!("tune sweeps a torque controller's --kp and --kd ranges (or servos' --p-gain with --actuator)"),
    }
}

/// The gains of every candidate, in sweep order: kp outermost, then kd, then ki.
pub fn candidate_gains(args: &TuneArgs) -> Result<Vec<Gains<4>>> {
    let (kp_range, kd_range) = torque_ranges(args)?;
    let pid = args.controller == OneController::Pid;
    if args.ki.is_some() && !pid {
        bail!(
            "--ki given with --controller {}: only pid has an integral term",
            ControllerName::from(args.controller).name()
        );
    }
    if kp_range.from <= 0.0 {
        bail!("kp range starts at {}: kp must be > 0", kp_range.from);
    }
    let ki_values = match (&args.ki, pid) {
        (Some(range), _) => range.values(),
        (None, true) => bail!("--controller pid needs a --ki range"),
        (None, false) => vec![0.0],
    };
    let count = kp_range.count as f64 * kd_range.count as f64 * ki_values.len() as f64;
    if count > MAX_CANDIDATES as f64 {
        bail!("the sweep has {count:e} candidates, more than {MAX_CANDIDATES}; split it with fewer values or --shard");
    }
    // Every candidate's gains, its row of results and its CSV line are held at once.
    let ranges =
        |flag: &str, range: &crate::args::GainRange| format!("{flag} {}..{}:{}", range.from, range.to, range.count);
    let mut cause = format!("{} {}", ranges("--kp", &kp_range), ranges("--kd", &kd_range));
    if let Some(ki) = &args.ki {
        cause.push_str(&format!(" {}", ranges("--ki", ki)));
    }
    crate::app::resources::ensure_fits(
        &cause,
        "candidates",
        count,
        (std::mem::size_of::<Gains<4>>() + std::mem::size_of::<Candidate>() + 160) as f64,
    )?;
    let mut all = Vec::new();
    for kp in kp_range.values() {
        for kd in kd_range.values() {
            for &ki in &ki_values {
                all.push(Gains::uniform(kp, kd, ki)?);
            }
        }
    }
    Ok(all)
}

/// The study a sweep runs: the PGN game if one is given, else the scenario (whose payload is
/// `trial`'s true pawn, if the sweep runs under realistic conditions).
pub fn study(setup: &Setup, args: &TuneArgs, trial: Option<&Trial>) -> Result<Study> {
    if let Some(path) = &args.game_file {
        if args.payload_mass > 0.0 || args.q0.is_some() {
            bail!("--payload-mass and --q0 go with a scenario; a game grips real pieces from its home position");
        }
        return Ok(Study::Game(crate::app::formats::pgn::read_pgn_game(path, args.game)?));
    }
    scenario_study(setup, args, trial).map(Study::Scenario)
}

/// The scenario study for the tune command.
fn scenario_study(setup: &Setup, args: &TuneArgs, trial: Option<&Trial>) -> Result<ScenarioStudy> {
    let plan = plan_scenario(setup, &args.scenario, 1e-3, "the sweep")?;
    ensure_tracked(tracking_from(args), &plan)?;
    let events = pawn_events(setup, trial, &plan.path, args.payload_mass, args.controller_knows_payload);
    let marks = plan.path.events().iter().map(|e| e.time).collect();
    if let Some(q0) = &args.q0 {
        crate::warn_outside_limits(setup, "--q0", q0);
    }
    let initial = args.q0.map(|q| JointState::at_rest(JointVector::from(setup.convention.user(q))));
    Ok(ScenarioStudy { trajectory: plan.joint, events, marks, initial })
}

/// Runs the candidates `range` on `threads` worker threads (all cores when `None`).
#[allow(clippy::too_many_arguments)]
pub fn sweep(
    setup: &Setup,
    study: &Study,
    options: &CandidateOptions,
    settings: &[Setting],
    range: std::ops::Range<usize>,
    threads: Option<usize>,
    progress: Option<&indicatif::ProgressBar>,
) -> Result<Vec<Candidate>> {
    let threads = crate::app::resources::worker_threads(threads)?;
    let batching = crate::app::resources::batching()?;
    let pool =
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("cannot start the worker threads")?;
    let record = match study {
        Study::Game(record) => record,
        Study::Scenario(scenario) => {
            // A batch of candidates per task: the lanes of one batch simulator.
            let indices: Vec<usize> = range.collect();
            let batches: Result<Vec<Vec<Candidate>>> = pool.install(|| {
                indices
                    .par_chunks(crate::app::resources::per_task(indices.len(), threads, batching.0))
                    .map(|chunk| {
                        if crate::cancelled() {
                            return Err(crate::interrupted());
                        }
                        let candidates = scenario_candidates(setup, scenario, options, settings, chunk, batching);
                        if let Some(bar) = progress {
                            bar.inc(chunk.len() as u64);
                        }
                        Ok(candidates)
                    })
                    .collect()
            });
            return Ok(batches?.into_iter().flatten().collect());
        }
    };
    pool.install(|| {
        range
            .into_par_iter()
            .map(|index| {
                if crate::cancelled() {
                    return Err(crate::interrupted());
                }
                let candidate = game_candidate(setup, record, options, index, &settings[index]);
                if let Some(bar) = progress {
                    bar.inc(1);
                }
                Ok(candidate)
            })
            .collect()
    })
}

pub fn run(setup: &Setup, args: &TuneArgs) -> Result<()> {
    crate::app::resources::batching()?;
    let setup = &args.motion.apply(setup)?;
    let servos = setup.actuators.take_positions();
    let settings: Vec<Setting> = if servos {
        servo_settings(setup, args)?
    } else {
        if args.p_gain.is_some() {
            bail!("--p-gain sweeps servos' P register; the joints have torque motors (give --actuator NAME)");
        }
        candidate_gains(args)?.into_iter().map(Setting::Torque).collect()
    };
    let range = crate::app::resources::shard_range(settings.len(), args.shard);
    let conditions = crate::app::setup::conditions::Study::new(setup, &args.conditions.options(), 1e-3)?;
    let trial =
        if conditions.is_ideal(setup) { None } else { Some(conditions.trial(args.conditions.options().run_seed())?) };
    let study = study(setup, args, trial.as_ref())?;
    let kind =
        controller_specs(&[args.controller.into()], &GivenGains::default(), DefaultGains::Report)?.remove(0).kind;
    if servos {
        // The host strategies replace the torque controllers (said once on the terminal).
        crate::servo_hosts(setup);
    }
    let options = CandidateOptions {
        controller_knows_payload: args.controller_knows_payload,
        placement: args.placement.clone(),
        kind,
        knows_friction: args.conditions.options().knows_friction(setup),
        trial,
        integrator: args.integrator.integrator(),
        tracking_from: tracking_from(args),
        mass_error: conditions.mass_errors(
            setup,
            !args.placement.no_payload_feedforward,
            args.controller_knows_payload,
        ),
        resolution: conditions.resolution(setup),
        p_conversions: crate::app::setup::servos::p_register_conversions(setup),
    };
    if args.game_file.is_some() && args.tracking_from.is_some() {
        bail!("--tracking-from goes with a scenario; a game starts every move on its trajectory");
    }
    ensure_dir(&args.out)?;
    // An earlier sweep's files must not pass for this one's (a failed heat map, a changed range).
    crate::app::output::remove_stale(&[args.out.join("tune.csv"), args.out.join("tune.png")])?;
    let bar = crate::progress::bar(range.len() as u64, "tuning");
    let started = Instant::now();
    let candidates = sweep(setup, &study, &options, &settings, range.clone(), args.threads, Some(&bar))?;
    let wall_time_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let csv_path = args.out.join("tune.csv");
    let with_header = args.shard.is_none_or(|(k, _)| k == 1);
    write_atomic(&csv_path, |writer| {
        if with_header {
            writeln!(writer, "{}", if servos { SERVO_CSV_HEADER } else { CSV_HEADER })?;
        }
        for candidate in &candidates {
            writeln!(writer, "{}", candidate.csv_line())?;
        }
        Ok(())
    })?;
    let heat_map_path = args.out.join("tune.png");
    if servos {
        draw_servo_heat_map(setup, args, &candidates, &heat_map_path)?;
    } else {
        draw_heat_map(args, &candidates, &heat_map_path)?;
    }

    let mut best: Vec<&Candidate> = candidates.iter().filter(|c| c.respects_limits()).collect();
    best.sort_by(|a, b| a.metric(args.metric).total_cmp(&b.metric(args.metric)).then(a.index.cmp(&b.index)));
    best.truncate(args.top);
    if options.tracking_from > 0.0 && matches!(args.metric, Metric::MaxTipError | Metric::RmsJointError) {
        crate::tell(&format!(
            "tracking metrics from t = {} s on (the default after --q0; --tracking-from S changes it): the start \
             from rest off the trajectory is left out\n",
            crate::app::resources::show(options.tracking_from)
        ));
    }
    let mut human = String::new();
    crate::tell_or_keep(&best_table(&best, args.metric), &mut human);
    let warning = if servos {
        servo_edge_warning(args, best.first().copied())
    } else {
        edge_warning(args, best.first().copied())
    };
    if let Some(warning) = warning {
        crate::tell_or_keep(&format!("warning: {warning}\n"), &mut human);
    }
    let failed = candidates.iter().filter(|c| c.status != "ok").count();
    let saturated = candidates.iter().filter(|c| c.status == "ok" && c.saturated_samples > 0).count();
    human.push_str(&format!(
        "{} candidates ({failed} failed, {saturated} saturated a motor) in {wall_time_s:.2} s\n{}",
        candidates.len(),
        crate::files_text(&[csv_path.display().to_string(), heat_map_path.display().to_string()])
    ));
    crate::emit(
        &human,
        &json!({
            "candidates": candidates.len(),
            "sweep_size": settings.len(),
            "shard": args.shard.map(|(k, n)| format!("{k}/{n}")),
            "failed": failed,
            "saturated": saturated,
            "wall_time_s": wall_time_s,
            "candidates_per_second": candidates.len() as f64 / wall_time_s,
            "metric": format!("{:?}", args.metric),
            "tracking_metrics_from_s": options.tracking_from,
            "best": best.iter().map(|c| json!({
                "index": c.index, "kp": c.kp, "kd": c.kd, "ki": c.ki,
                "servo_command": c.servo_command.map(|s| s.name()), "p_gain": c.servo_command.map(|_| c.p_gain),
                "metric": c.metric(args.metric),
                "max_tip_error_mm": c.max_tip_error_mm, "place_error_mm": c.place_error_mm,
                "rms_joint_error_rad": c.rms_joint_error_rad, "peak_torque_nm": c.peak_torque_nm,
            })).collect::<Vec<_>>(),
            "files": [csv_path.display().to_string(), heat_map_path.display().to_string()],
        }),
    )?;
    Ok(())
}

fn metric_label(metric: Metric) -> &'static str {
    match metric {
        Metric::MaxTipError => "max tip error (mm)",
        Metric::RmsJointError => "RMS joint error (rad)",
        Metric::PeakTorque => "peak |τ| / limit",
        Metric::PlaceError => "placement error (mm)",
    }
}

fn best_table(best: &[&Candidate], metric: Metric) -> String {
    if best.first().is_some_and(|c| c.servo_command.is_some()) {
        let mut table = format!("{:>6} {:>12} {:>12} {:>30}\n", "rank", "host", "P register", metric_label(metric));
        for (rank, c) in best.iter().enumerate() {
            table.push_str(&format!(
                "{:>6} {:>12} {:>12} {:>30.6}\n",
                rank + 1,
                c.servo_command.map_or("?", |s| s.name()),
                tick(c.p_gain),
                c.metric(metric)
            ));
        }
        return table;
    }
    let mut table = format!("{:>6} {:>12} {:>12} {:>12} {:>30}\n", "rank", "kp", "kd", "ki", metric_label(metric));
    for (rank, c) in best.iter().enumerate() {
        table.push_str(&format!(
            "{:>6} {:>12.3} {:>12.3} {:>12.3} {:>30.6}\n",
            rank + 1,
            c.kp,
            c.kd,
            c.ki,
            c.metric(metric)
        ));
    }
    if best.is_empty() {
        table.push_str("no candidate finished within the torque limits\n");
    }
    table
}

/// Heat map over kp (x) and kd (y); with a ki sweep each cell shows the best over ki. Failed
/// candidates are grey; the best one within the torque limits is framed.
fn draw_heat_map(args: &TuneArgs, candidates: &[Candidate], path: &std::path::Path) -> Result<()> {
    let (kp_range, kd_range) = torque_ranges(args)?;
    let (kp_values, kd_values) = (kp_range.values(), kd_range.values());
    let per_cell = args.ki.map_or(1, |r| r.count);
    let mut cells = vec![vec![None::<f64>; kp_values.len()]; kd_values.len()];
    let mut best: Option<(f64, (usize, usize))> = None;
    for candidate in candidates {
        let cell = candidate.index / per_cell;
        let (row, column) = (cell % kd_values.len(), cell / kd_values.len());
        let value = candidate.metric(args.metric);
        if candidate.status == "ok" && value.is_finite() {
            let slot = &mut cells[row][column];
            *slot = Some(slot.map_or(value, |v: f64| v.min(value)));
            if candidate.respects_limits() && best.is_none_or(|(b, _)| value < b) {
                best = Some((value, (row, column)));
            }
        }
    }
    let mut title = format!("{} sweep: {}", if per_cell > 1 { "PID" } else { "PD" }, metric_label(args.metric));
    let from = tracking_from(args);
    if from > 0.0 && matches!(args.metric, Metric::MaxTipError | Metric::RmsJointError) {
        title.push_str(&format!(" from t = {} s", crate::app::resources::show(from)));
    }
    plot_heat_map(
        path,
        &HeatMap {
            title: &title,
            x_label: "kp (1/s²)",
            y_label: "kd (1/s)",
            value_label: metric_label(args.metric),
            x_values: &kp_values,
            y_values: &kd_values,
            y_names: None,
            values: &cells,
            marked: best.map(|(_, cell)| cell),
            grey: "failed",
            note: edge_warning(
                args,
                candidates
                    .iter()
                    .filter(|c| c.respects_limits())
                    .min_by(|a, b| a.metric(args.metric).total_cmp(&b.metric(args.metric)).then(a.index.cmp(&b.index))),
            ),
        },
    )
}

/// A warning when the best pick lies on the edge of the swept range of a gain (one swept over
/// more than one value): the optimum may lie beyond it.
pub fn edge_warning(args: &TuneArgs, best: Option<&Candidate>) -> Option<String> {
    let best = best?;
    let (kp_range, kd_range) = torque_ranges(args).ok()?;
    let per_cell = args.ki.map_or(1, |r| r.count);
    let kd_count = kd_range.count;
    let cell = best.index / per_cell;
    let axes = [
        ("kp", "--kp", cell / kd_count, kp_range.count),
        ("kd", "--kd", cell % kd_count, kd_count),
        ("ki", "--ki", best.index % per_cell, per_cell),
    ];
    let edges: Vec<String> = axes
        .iter()
        .filter(|(_, _, index, count)| *count > 1 && (*index == 0 || index + 1 == *count))
        .map(|(name, flag, index, _)| {
            format!("{name} at its {} ({flag})", if *index == 0 { "smallest" } else { "largest" })
        })
        .collect();
    (!edges.is_empty()).then(|| {
        format!(
            "the best pick (kp {}, kd {}{}) lies on the edge of the sweep: {}; widen the range",
            tick(best.kp),
            tick(best.kd),
            if per_cell > 1 { format!(", ki {}", tick(best.ki)) } else { String::new() },
            edges.join(", ")
        )
    })
}

/// A servo sweep's candidates: every host strategy of `--servo-command` (outer) at every P
/// register value of `--p-gain` (inner). Every joint's servo must have a P register.
fn servo_settings(setup: &Setup, args: &TuneArgs) -> Result<Vec<Setting>> {
    if args.kp.is_some() || args.kd.is_some() || args.ki.is_some() {
        bail!("--kp, --kd and --ki are a torque controller's; with servos (--actuator) sweep --p-gain A..B:N");
    }
    let Some(range) = args.p_gain else {
        bail!("tune with servos sweeps their P register: give --p-gain A..B:N (e.g. 8..64:8)");
    };
    if range.from <= 0.0 {
        bail!("--p-gain range starts at {}: the P register must be > 0", range.from);
    }
    let conversions = crate::app::setup::servos::p_register_conversions(setup);
    if let Some(j) = conversions.iter().position(Option::is_none) {
        bail!(
            "--p-gain: joint {}'s actuator {} has no P register to sweep (a stepper, or an [actuators] table without `base`)",
            j + 1,
            setup.actuator_names[j]
        );
    }
    let count = range.count as f64 * setup.servo_commands.len() as f64;
    if count > MAX_CANDIDATES as f64 {
        bail!("the sweep has {count:e} candidates, more than {MAX_CANDIDATES}; split it with fewer values or --shard");
    }
    Ok(setup
        .servo_commands
        .iter()
        .flat_map(|command| range.values().into_iter().map(move |p_gain| Setting::Servo { command: *command, p_gain }))
        .collect())
}

/// A servo sweep's heat map: the P register (x) against the host strategy (y).
fn draw_servo_heat_map(setup: &Setup, args: &TuneArgs, candidates: &[Candidate], path: &std::path::Path) -> Result<()> {
    let Some(range) = args.p_gain else { bail!("a servo sweep has a --p-gain range") };
    let p_values = range.values();
    let names: Vec<String> = setup.servo_commands.iter().map(|c| c.name().to_string()).collect();
    let rows: Vec<f64> = (0..names.len()).map(|k| k as f64).collect();
    let mut cells = vec![vec![None::<f64>; p_values.len()]; names.len()];
    let mut best: Option<(f64, (usize, usize))> = None;
    for candidate in candidates {
        let (row, column) = (candidate.index / p_values.len(), candidate.index % p_values.len());
        let value = candidate.metric(args.metric);
        if candidate.status == "ok" && value.is_finite() {
            cells[row][column] = Some(value);
            if candidate.respects_limits() && best.is_none_or(|(b, _)| value < b) {
                best = Some((value, (row, column)));
            }
        }
    }
    let mut servos = setup.actuator_names.to_vec();
    servos.dedup();
    let title = format!("servo sweep ({}): {}", servos.join(", "), metric_label(args.metric));
    plot_heat_map(
        path,
        &HeatMap {
            title: &title,
            x_label: "P gain (the servo's register)",
            y_label: "host strategy",
            value_label: metric_label(args.metric),
            x_values: &p_values,
            y_values: &rows,
            y_names: Some(&names),
            values: &cells,
            marked: best.map(|(_, cell)| cell),
            grey: "failed",
            note: servo_edge_warning(
                args,
                candidates
                    .iter()
                    .filter(|c| c.respects_limits())
                    .min_by(|a, b| a.metric(args.metric).total_cmp(&b.metric(args.metric)).then(a.index.cmp(&b.index))),
            ),
        },
    )
}

/// A warning when a servo sweep's best pick has the smallest or largest P register swept.
fn servo_edge_warning(args: &TuneArgs, best: Option<&Candidate>) -> Option<String> {
    let (best, range) = (best?, args.p_gain?);
    let index = best.index % range.count;
    (range.count > 1 && (index == 0 || index + 1 == range.count)).then(|| {
        format!(
            "the best pick ({} at P {}) has the {} P register swept (--p-gain); widen the range",
            best.servo_command.map_or("?", |c| c.name()),
            tick(best.p_gain),
            if index == 0 { "smallest" } else { "largest" }
        )
    })
}
