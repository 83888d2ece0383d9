//! `robustness`: Monte Carlo over randomised trials. Each trial draws the true arm (link
//! masses, centres of mass, inertia rotations, friction), the pieces' true masses and the
//! sensors' noise from its own seed, then runs every controller on the same draws (common
//! random numbers: the controllers are compared on identical arms and identical noise). One
//! CSV row per trial and controller; the rows come out in trial order whatever the number of
//! threads, and `--shard K/N` slices concatenate to the whole study.

use crate::app::formats::plots::{Panel, Series, Style, plot_panels};
use crate::app::output::{ensure_dir, remove_stale, write_atomic, write_json};
use crate::app::setup::conditions::{Study, Trial};
use crate::app::setup::file::Setup;
use crate::app::studies::plan::{Plan, plan_scenario};
use crate::app::studies::simulate::{DefaultGains, controller_specs, pawn_events, placement_error};
use crate::cli::RobustnessArgs;
use anyhow::{Context, Result};
use chessarm_chess::notation::GameRecord;
use chessarm_chess::play::{Game, Mover, PlaySettings};
use chessarm_core::control::choice::ControllerSpec;
use chessarm_core::sense::rng::derive_seed;
use chessarm_core::sim::batch::{LaneCount, LaneRun, SimdLevel, simulate_lanes};
use chessarm_core::sim::{Integrator, PayloadEvent, Plant, SimConfig, SimSummary};
use rayon::prelude::*;
use serde_json::json;
use std::time::Instant;

/// What every trial runs.
#[derive(Debug)]
pub enum Work {
    Scenario { plan: Plan, payload_mass: f64 },
    Game(GameRecord),
}

/// One controller's result in one trial (SI; tip and placement errors in mm).
#[derive(Debug, Clone)]
pub struct TrialRow {
    pub trial: usize,
    pub trial_seed: u64,
    pub controller: String,
    /// "ok", or why the run failed.
    pub status: String,
    /// Largest distance of a placed piece from its square centre, mm (NaN if it failed).
    pub place_error_mm: f64,
    pub pieces: usize,
    /// Pieces placed further than the tolerance.
    pub misplaced: usize,
    pub max_tip_error_mm: f64,
    pub rms_tip_error_mm: f64,
    pub peak_torque_nm: f64,
    pub peak_torque_ratio: f64,
    pub saturated_samples: usize,
    /// RMS over the joints and samples of the rate estimate's error, rad/s.
    pub rms_rate_estimate_error: f64,
    /// Robot time of the run (a game's moves, fine points' waits included), s.
    pub robot_time_s: f64,
    /// Robot moves simulated (1 for the scenario).
    pub plies: usize,
    /// Moves whose simulated motion touched a piece, the table or the arm itself, and the
    /// smallest clearance of the simulated motion, mm (at least: see `Executed`).
    pub contacts: usize,
    pub clearance_mm: f64,
    /// The trial's drawn parameters.
    pub drawn: Vec<(String, f64)>,
}

impl TrialRow {
    /// Every piece within the tolerance, and the run finished.
    /// Every piece placed and nothing touched.
    pub fn success(&self) -> bool {
        self.status == "ok" && self.misplaced == 0 && self.contacts == 0
    }
}

/// Metrics over one or more simulations of a trial.
#[derive(Default)]
struct Totals {
    samples: f64,
    squared_tip: f64,
    squared_rate: f64,
    max_tip: f64,
    peak_torque: f64,
    peak_ratio: f64,
    saturated: usize,
    places: Vec<f64>,
    robot_time: f64,
    moves: usize,
    /// Moves whose simulated motion touched a piece, the table or the arm itself.
    contacts: usize,
    /// The smallest clearance of the simulated motion over the trial, m (a lower bound where
    /// the move's was bounded, not measured).
    clearance: Option<f64>,
}

impl Totals {
    fn add(&mut self, summary: &SimSummary<4>, limits: &chessarm_core::arm::model::JointVector<4>) {
        let samples = summary.tracked_steps as f64;
        self.samples += samples;
        self.squared_tip += summary.rms_tip_error.powi(2) * samples;
        self.squared_rate += summary.rms_rate_estimate_error.norm_squared() / 4.0 * samples;
        self.max_tip = self.max_tip.max(summary.max_tip_error);
        self.peak_torque = self.peak_torque.max(summary.peak_torque.max());
        self.peak_ratio = self.peak_ratio.max(summary.peak_torque.component_div(limits).max());
        self.saturated += summary.saturated_samples;
        self.robot_time += summary.duration;
        self.moves += 1;
    }
}

/// Runs one controller on one trial of a game. `tolerance` in m.
fn run_trial(
    setup: &Setup,
    record: &GameRecord,
    spec: &ControllerSpec,
    trial: &Trial,
    study: &Study,
    options: &TrialOptions,
) -> (String, Totals) {
    let mut totals = Totals::default();
    let limits = setup.arm.torque_limits();
    let outcome: Result<()> = (|| {
        let mut settings = PlaySettings::new(spec.name.clone(), spec.gains);
        settings.controller = spec.clone();
        crate::app::setup::servos::drive(setup, &mut settings);
        settings.pieces = setup.pieces;
        settings.clearance = Some(setup.clearance.clone());
        settings.limits = setup.motion;
        settings.limits.tracking = study.tracking(
            setup,
            &spec.gains,
            options.payload_feedforward && crate::app::setup::servos::cancels_inertia(&spec.kind),
            options.controller_knows_payload,
        );
        settings.timing = setup.timing;
        settings.record_every = 0;
        settings.controller_knows_payload = options.controller_knows_payload;
        settings.payload_feedforward = options.payload_feedforward;
        settings.in_position = options.in_position;
        settings.integrator = options.integrator;
        settings.tolerance = options.tolerance;
        trial.apply_to(&mut settings);
        let mut game = Game::new(setup.arm, setup.board, record.start.clone(), settings)?;
        for mv in &record.moves {
            let report = game.play(mv, Mover::Robot)?;
            if let Some(summary) = &report.summary {
                totals.add(summary, &limits);
            }
            totals.places.extend(&report.place_errors);
            if let Some(executed) = &report.executed_clearance {
                totals.contacts += usize::from(executed.is_contact());
                totals.clearance = Some(totals.clearance.map_or(executed.distance(), |c| c.min(executed.distance())));
            }
        }
        Ok(())
    })();
    let status = match outcome {
        Ok(()) => "ok".to_string(),
        Err(error) => format!("failed: {}", crate::app::text::one_line(&error)),
    };
    (status, totals)
}

fn row(
    trial_index: usize,
    trial: &Trial,
    spec: &ControllerSpec,
    status: String,
    totals: &Totals,
    tolerance: f64,
) -> TrialRow {
    let ok = status == "ok";
    let worst = totals.places.iter().copied().fold(0.0f64, f64::max);
    TrialRow {
        trial: trial_index,
        trial_seed: trial.seed,
        controller: spec.name.clone(),
        place_error_mm: if ok { worst * 1e3 } else { f64::NAN },
        pieces: totals.places.len(),
        misplaced: totals.places.iter().filter(|e| **e > tolerance).count(),
        max_tip_error_mm: totals.max_tip * 1e3,
        rms_tip_error_mm: (totals.squared_tip / totals.samples.max(1.0)).sqrt() * 1e3,
        peak_torque_nm: totals.peak_torque,
        peak_torque_ratio: totals.peak_ratio,
        saturated_samples: totals.saturated,
        rms_rate_estimate_error: (totals.squared_rate / totals.samples.max(1.0)).sqrt(),
        robot_time_s: if ok { totals.robot_time } else { f64::NAN },
        plies: totals.moves,
        contacts: totals.contacts,
        clearance_mm: totals.clearance.map_or(f64::NAN, |c| c * 1e3),
        drawn: trial.columns(),
        status,
    }
}

const HEADER: &str = "trial,trial_seed,controller,status,success,place_error_mm,pieces,misplaced,max_tip_error_mm,rms_tip_error_mm,peak_torque_nm,peak_torque_ratio,saturated_samples,rms_rate_estimate_error_rad_per_s,robot_time_s,plies,contacts,clearance_mm";

fn csv_line(row: &TrialRow) -> String {
    let mut line = format!(
        "{},{},{},{},{},{:?},{},{},{:?},{:?},{:?},{:?},{},{:?},{:?},{},{},{:?}",
        row.trial,
        row.trial_seed,
        row.controller,
        row.status.replace(',', ";"),
        row.success(),
        row.place_error_mm,
        row.pieces,
        row.misplaced,
        row.max_tip_error_mm,
        row.rms_tip_error_mm,
        row.peak_torque_nm,
        row.peak_torque_ratio,
        row.saturated_samples,
        row.rms_rate_estimate_error,
        row.robot_time_s,
        row.plies,
        row.contacts,
        row.clearance_mm
    );
    for (_, value) in &row.drawn {
        line.push_str(&format!(",{value:?}"));
    }
    line
}

/// The `q`-quantile (0–1) of sorted `values` by linear interpolation between order statistics.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let position = q * (sorted.len() - 1) as f64;
    let (low, high) = (position.floor() as usize, position.ceil() as usize);
    if sorted[high].is_infinite() {
        return f64::INFINITY;
    }
    sorted[low] + (sorted[high] - sorted[low]) * (position - low as f64)
}

/// The mean over the finished runs of robot seconds per simulated move (NaN without one).
fn seconds_per_ply(rows: &[&TrialRow]) -> f64 {
    let finished: Vec<f64> = rows
        .iter()
        .filter(|r| r.robot_time_s.is_finite() && r.plies > 0)
        .map(|r| r.robot_time_s / r.plies as f64)
        .collect();
    finished.iter().sum::<f64>() / finished.len() as f64
}

/// Per controller: the study's statistics. A failed run counts as an infinite placement
/// error (JSON null), so a median, p95 or largest error over failures is not a number.
/// `replay` is the command that re-runs a trial without its controller, seed and folder; the
/// worst trial's replay writes to `out/worst-CONTROLLER`, its own folder (not the default
/// one another run may be using); `selector` is the flag that picks the controller
/// (`--controller`, or `--servo-command` for a servo host).
fn statistics(rows: &[TrialRow], name: &str, replay: &str, selector: &str, out: &std::path::Path) -> serde_json::Value {
    let mine: Vec<&TrialRow> = rows.iter().filter(|r| r.controller == name).collect();
    let mut errors: Vec<f64> =
        mine.iter().map(|r| if r.place_error_mm.is_finite() { r.place_error_mm } else { f64::INFINITY }).collect();
    errors.sort_by(f64::total_cmp);
    let worst = mine
        .iter()
        .filter(|r| r.place_error_mm.is_finite())
        .max_by(|a, b| a.place_error_mm.total_cmp(&b.place_error_mm));
    let successes = mine.iter().filter(|r| r.success()).count();
    let failed = mine.iter().filter(|r| r.status != "ok").count();
    json!({
        "controller": name,
        "trials": mine.len(),
        "success_rate": successes as f64 / mine.len().max(1) as f64,
        "failed_runs": failed,
        "place_error_mm": {
            "median": quantile(&errors, 0.5),
            "p95": quantile(&errors, 0.95),
            "max": errors.last().copied().unwrap_or(f64::NAN),
        },
        "trials_with_contacts": mine.iter().filter(|r| r.contacts > 0).count(),
        "contacts": mine.iter().map(|r| r.contacts).sum::<usize>(),
        "smallest_clearance_mm": mine.iter().map(|r| r.clearance_mm).filter(|c| c.is_finite()).fold(f64::INFINITY, f64::min),
        "peak_torque_nm": mine.iter().map(|r| r.peak_torque_nm).fold(0.0f64, f64::max),
        "peak_torque_ratio": mine.iter().map(|r| r.peak_torque_ratio).fold(0.0f64, f64::max),
        "trials_with_saturation": mine.iter().filter(|r| r.saturated_samples > 0).count(),
        // Mean over the finished trials of the robot time per simulated move, s.
        "seconds_per_ply": seconds_per_ply(&mine),
        "rms_rate_estimate_error_rad_per_s": mine.iter().map(|r| r.rms_rate_estimate_error).sum::<f64>() / mine.len().max(1) as f64,
        "worst_trial_seed": worst.map(|r| r.trial_seed),
        "replay_worst_trial": worst.map(|r| {
            let folder = out.join(format!("worst-{name}"));
            let folder = crate::app::output::shell_word(&folder.display().to_string());
            format!("chessarm {replay} {selector} {name} --trial-seed {} --out {folder}", r.trial_seed)
        }),
    })
}

/// Settings every trial shares.
#[derive(Debug, Clone, Copy)]
pub struct TrialOptions {
    /// The study's seed: trial `k` has the seed `derive_seed(seed, k)`.
    pub seed: u64,
    pub integrator: Integrator,
    pub controller_knows_payload: bool,
    /// A game's controllers are told the nominal mass of the piece kind they grip.
    pub payload_feedforward: bool,
    /// A game's fine points (`None`: the gripper goes by the clock).
    pub in_position: Option<chessarm_core::plan::fine_point::InPosition>,
    /// A piece further than this from its square centre is misplaced, m.
    pub tolerance: f64,
}

/// Runs trials `range` of every controller on the current rayon pool, in trial order. A
/// scenario's trials run on the batch simulator, a batch of trials per task (their runs side
/// by side, see [`crate::app::resources::batching`]); a game's trial by trial.
///
/// # Errors
///
/// [`crate::interrupted`], when the run was cancelled; a bad `CHESSARM_LANES` or
/// `CHESSARM_SIMD`.
pub fn run_trials(
    setup: &Setup,
    work: &Work,
    specs: &[ControllerSpec],
    study: &Study,
    options: &TrialOptions,
    range: std::ops::Range<usize>,
    progress: Option<&indicatif::ProgressBar>,
) -> Result<Vec<TrialRow>> {
    let batching = crate::app::resources::batching()?;
    let indices: Vec<usize> = range.collect();
    let per_task = match work {
        Work::Scenario { .. } => {
            crate::app::resources::per_task(indices.len(), rayon::current_num_threads(), batching.0)
        }
        Work::Game(_) => 1,
    };
    let rows: Result<Vec<Vec<TrialRow>>> = indices
        .par_chunks(per_task)
        .map(|chunk| {
            if crate::cancelled() {
                return Err(crate::interrupted());
            }
            let drawn: Vec<Drawn> = chunk
                .iter()
                .map(|&index| {
                    let seed = derive_seed(options.seed, index as u64);
                    Drawn { index, seed, trial: study.trial(seed) }
                })
                .collect();
            let rows = match work {
                Work::Scenario { plan, payload_mass } => {
                    scenario_rows(setup, plan, *payload_mass, specs, &drawn, options, batching)
                }
                Work::Game(record) => drawn
                    .iter()
                    .flat_map(|drawn| match &drawn.trial {
                        Ok(trial) => specs
                            .iter()
                            .map(|spec| {
                                let (status, totals) = run_trial(setup, record, spec, trial, study, options);
                                row(drawn.index, trial, spec, status, &totals, options.tolerance)
                            })
                            .collect(),
                        Err(error) => vec![failed_draw(drawn, error)],
                    })
                    .collect(),
            };
            if let Some(bar) = progress {
                bar.inc(chunk.len() as u64);
            }
            Ok(rows)
        })
        .collect();
    Ok(rows?.into_iter().flatten().collect())
}

/// A trial's index, seed and drawn arm, pieces and sensors (or why they could not be drawn).
struct Drawn {
    index: usize,
    seed: u64,
    trial: Result<Trial>,
}

/// The row of a trial whose draw failed.
fn failed_draw(drawn: &Drawn, error: &anyhow::Error) -> TrialRow {
    TrialRow {
        trial: drawn.index,
        trial_seed: drawn.seed,
        controller: "-".into(),
        status: format!("failed: {}", crate::app::text::one_line(error)),
        place_error_mm: f64::NAN,
        pieces: 0,
        misplaced: 0,
        max_tip_error_mm: f64::NAN,
        rms_tip_error_mm: f64::NAN,
        peak_torque_nm: f64::NAN,
        peak_torque_ratio: f64::NAN,
        saturated_samples: 0,
        rms_rate_estimate_error: f64::NAN,
        robot_time_s: f64::NAN,
        plies: 0,
        contacts: 0,
        clearance_mm: f64::NAN,
        drawn: Vec::new(),
    }
}

/// One controller on one trial of the scenario, as a run of the batch simulator.
fn scenario_run<'a>(
    setup: &Setup,
    plan: &'a Plan,
    trial: &Trial,
    spec: &ControllerSpec,
    events: &'a [PayloadEvent],
    marks: &'a [f64],
    integrator: Integrator,
) -> Result<LaneRun<'a>> {
    let controller = spec.build_for(setup.arm, &setup.actuators)?;
    // Servos' gears are part of the true plant; their host samples at the bus rate.
    let plant = trial.actuators.plant_model(&trial.plant)?;
    let control_period = crate::app::setup::servos::control_period(setup, 1e-3);
    let feedback = trial.conditions.feedback(control_period)?;
    let config = SimConfig {
        integrator,
        torque_lag: trial.conditions.torque_lag,
        actuators: trial.actuators,
        control_period,
        ..SimConfig::new(&Plant::new(plant))
    };
    Ok(LaneRun { plant, feedback, controller, reference: &plan.joint, initial: None, events, marks, config })
}

/// The rows of the scenario trials `drawn`, every controller of each, their runs side by side.
fn scenario_rows(
    setup: &Setup,
    plan: &Plan,
    payload_mass: f64,
    specs: &[ControllerSpec],
    drawn: &[Drawn],
    options: &TrialOptions,
    (lanes, level): (LaneCount, SimdLevel),
) -> Vec<TrialRow> {
    let limits = setup.arm.torque_limits();
    let marks: Vec<f64> = plan.path.events().iter().map(|e| e.time).collect();
    let events: Vec<Vec<PayloadEvent>> = drawn
        .iter()
        .map(|d| match &d.trial {
            Ok(trial) => pawn_events(setup, Some(trial), &plan.path, payload_mass, options.controller_knows_payload),
            Err(_) => Vec::new(),
        })
        .collect();
    // The rows in order, those of runs still to simulate empty until they have run.
    let mut rows: Vec<Option<TrialRow>> = Vec::new();
    let mut runs = Vec::new();
    let mut pending = Vec::new();
    for (d, events) in drawn.iter().zip(&events) {
        let trial = match &d.trial {
            Ok(trial) => trial,
            Err(error) => {
                rows.push(Some(failed_draw(d, error)));
                continue;
            }
        };
        for (k, spec) in specs.iter().enumerate() {
            match scenario_run(setup, plan, trial, spec, events, &marks, options.integrator) {
                Ok(run) => {
                    pending.push((k, (rows.len(), d.index, trial, spec)));
                    runs.push(run);
                    rows.push(None);
                }
                Err(error) => {
                    let status = format!("failed: {}", crate::app::text::one_line(&error));
                    rows.push(Some(row(d.index, trial, spec, status, &Totals::default(), options.tolerance)));
                }
            }
        }
    }
    // One controller's runs side by side (its trials in order): a batch of runs of one
    // computed-torque controller computes its laws in lanes. A run's result does not depend on
    // its batch, so neither do the rows.
    let mut side_by_side: Vec<_> = pending.into_iter().zip(runs).collect();
    side_by_side.sort_by_key(|((controller, _), _)| *controller);
    let (pending, mut runs): (Vec<_>, Vec<_>) = side_by_side.into_iter().map(|((_, row), run)| (row, run)).unzip();
    for ((slot, index, trial, spec), result) in pending.into_iter().zip(simulate_lanes(&mut runs, lanes, level)) {
        let mut totals = Totals::default();
        let status = match result {
            Ok(summary) => {
                totals.add(&summary, &limits);
                totals.places.extend(placement_error(plan, &summary));
                "ok".to_string()
            }
            Err(error) => format!("failed: {}", crate::app::text::one_line(&anyhow::Error::from(error))),
        };
        rows[slot] = Some(row(index, trial, spec, status, &totals, options.tolerance));
    }
    rows.into_iter().map(|row| row.unwrap_or_else(|| unreachable!("every row is filled"))).collect()
}

pub fn run(setup: &Setup, args: &RobustnessArgs) -> Result<()> {
    crate::app::resources::batching()?;
    let setup = &args.motion.apply(setup)?;
    let defaults = if args.game_file.is_some() { DefaultGains::Game } else { DefaultGains::Report };
    let mut specs = match crate::servo_hosts(setup) {
        Some(hosts) => hosts,
        None => controller_specs(&args.controller, &args.gains.given(), defaults)?,
    };
    for spec in &mut specs {
        spec.knows_friction = args.conditions.options().knows_friction(setup);
    }
    let study = Study::for_trials(setup, &args.conditions.options(), 1e-3)?;
    if args.conditions.trial_seed.is_some() {
        anyhow::bail!(
            "--trial-seed runs one trial: use it with simulate or play; robustness draws --trials trials from --seed"
        );
    }
    let work = match &args.game_file {
        Some(path) => {
            if args.payload_mass.is_some() {
                anyhow::bail!("--payload-mass goes with a scenario; a game grips its real pieces");
            }
            Work::Game(crate::app::formats::pgn::read_pgn_game(path, args.game)?)
        }
        None => {
            let plan = plan_scenario(setup, &args.scenario, 1e-3, "the trials")?;
            Work::Scenario { plan, payload_mass: args.payload_mass.unwrap_or(setup.pieces.pawn.mass) }
        }
    };
    if let Some(paces) = &args.paces {
        let Work::Game(_) = &work else {
            anyhow::bail!("--paces sweeps a game's motion: give a PGN file (a scenario keeps its own LSPB path)");
        };
        if args.shard.is_some() {
            anyhow::bail!("--paces runs every trial at every pace: it does not take --shard");
        }
        return frontier(setup, args, &work, &specs, &study, paces);
    }
    let range = crate::app::resources::shard_range(args.trials, args.shard);
    // Every row (with its drawn parameters' names and values) is held until the CSV is written.
    crate::app::resources::ensure_fits(
        &format!("--trials {} with {} controllers", args.trials, specs.len()),
        "trial rows",
        range.len() as f64 * specs.len() as f64,
        (std::mem::size_of::<TrialRow>() + 46 * 64) as f64,
    )?;
    let threads = crate::app::resources::worker_threads(args.threads)?;
    let pool =
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("cannot start the worker threads")?;
    ensure_dir(&args.out)?;
    remove_stale(&[
        args.out.join("robustness.csv"),
        args.out.join("robustness.png"),
        args.out.join("robustness.json"),
    ])?;
    let bar = crate::progress::bar(range.len() as u64, "trials");
    let started = Instant::now();
    let options = trial_options(args, study.resolution(setup));
    let rows = pool.install(|| run_trials(setup, &work, &specs, &study, &options, range.clone(), Some(&bar)))?;
    let wall_time_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let csv_path = args.out.join("robustness.csv");
    let with_header = args.shard.is_none_or(|(k, _)| k == 1);
    let drawn_names: Vec<String> = rows
        .iter()
        .find(|r| !r.drawn.is_empty())
        .map_or(Vec::new(), |r| r.drawn.iter().map(|(n, _)| n.clone()).collect());
    write_atomic(&csv_path, |writer| {
        if with_header {
            let mut header = HEADER.to_string();
            for name in &drawn_names {
                header.push(',');
                header.push_str(name);
            }
            writeln!(writer, "{header}")?;
        }
        for row in &rows {
            writeln!(writer, "{}", csv_line(row))?;
        }
        Ok(())
    })?;
    let plot_path = args.out.join("robustness.png");
    draw_cdf(&rows, &specs, args.tolerance_mm, &plot_path)?;
    let knows = if args.controller_knows_payload { " --controller-knows-payload" } else { "" };
    // The replay names the setup file, and takes the model errors from its [uncertainty] table
    // when they came from there.
    let word = |path: &std::path::Path| crate::app::output::shell_word(&path.display().to_string());
    let mut arm = setup.path.as_ref().map_or(String::new(), |p| format!("--arm {} ", word(p)));
    if let Some(path) = &setup.urdf_path {
        arm.push_str(&format!("--urdf {} ", word(path)));
        let locks: Vec<String> =
            setup.urdf.as_ref().map(|u| &u.lock).into_iter().flatten().map(|(j, v)| format!("{j}={v}")).collect();
        if !locks.is_empty() {
            arm.push_str(&format!("--lock {} ", crate::app::output::shell_word(&locks.join(","))));
        }
    }
    if setup.actuators.take_positions() {
        let names: Vec<String> = setup.actuator_names.iter().map(|n| crate::app::output::shell_word(n)).collect();
        let same = names.iter().all(|n| *n == names[0]);
        arm.push_str(&format!("--actuator {} ", if same { names[0].clone() } else { names.join(",") }));
        if setup.bus_rate != crate::app::setup::file::DEFAULT_BUS_RATE {
            arm.push_str(&format!("--bus-rate {} ", setup.bus_rate));
        }
    }
    let from_setup = match (&args.conditions.uncertainty, &setup.path, &setup.uncertainty) {
        (None, Some(path), Some(_)) => format!(" --uncertainty {}", word(path)),
        _ => String::new(),
    };
    let replay = match &work {
        Work::Scenario { payload_mass, .. } => format!(
            "{arm}simulate --scenario {} --payload-mass {payload_mass}{knows}{}{from_setup}",
            args.scenario,
            args.conditions.options().flags()
        ),
        Work::Game(_) => format!(
            "{arm}play {} --game {}{knows}{}{from_setup}",
            args.game_file.as_ref().map_or(String::new(), |p| word(p)),
            args.game,
            args.conditions.options().flags()
        ),
    };
    let stats: Vec<serde_json::Value> =
        specs.iter().map(|spec| statistics(&rows, &spec.name, &replay, selector(setup), &args.out)).collect();
    let summary = json!({
        "work": match &args.game_file { Some(path) => json!({ "game_file": path.display().to_string(), "game": args.game }), None => json!({ "scenario": args.scenario }) },
        "trials": args.trials,
        "shard": args.shard.map(|(k, n)| format!("{k}/{n}")),
        "trials_run": range.len(),
        "seed": args.conditions.seed,
        "tolerance_mm": args.tolerance_mm,
        "conditions": study.describe(),
        "controllers": stats,
        "wall_time_s": wall_time_s,
        "threads": threads,
    });
    let json_path = args.out.join("robustness.json");
    write_json(&json_path, &summary)?;
    let mut human = String::new();
    crate::tell_or_keep(&table(&stats, range.len(), args.tolerance_mm), &mut human);
    for s in &stats {
        if let Some(command) = s["replay_worst_trial"].as_str() {
            human.push_str(&format!(
                "{}'s worst trial, replayed (with its replay.html): {command}\n",
                s["controller"].as_str().unwrap_or("?")
            ));
        }
    }
    let files = [csv_path.display().to_string(), plot_path.display().to_string(), json_path.display().to_string()];
    human.push_str(&crate::files_text(&files));
    crate::emit(&human, &json!({ "summary": summary, "files": files }))?;
    Ok(())
}

/// The flag that picks a run's controller: `--servo-command` for servos' hosts.
fn selector(setup: &Setup) -> &'static str {
    if setup.actuators.take_positions() { "--servo-command" } else { "--controller" }
}

fn trial_options(args: &RobustnessArgs, resolution: crate::app::setup::conditions::Resolution) -> TrialOptions {
    let tolerance = args.tolerance_mm / 1e3;
    TrialOptions {
        seed: args.conditions.seed,
        integrator: args.integrator.integrator(),
        controller_knows_payload: args.controller_knows_payload,
        payload_feedforward: !args.placement.no_payload_feedforward,
        in_position: args.placement.in_position(tolerance, resolution),
        tolerance,
    }
}

/// One point of the frontier: a controller's statistics at one pace.
struct FrontierPoint {
    pace: f64,
    stats: serde_json::Value,
}

/// `--paces`: the same trials of the game at every pace, per controller the success rate,
/// the placement error's median, p95 and largest, and the mean robot seconds per ply, in
/// frontier.csv (a row per pace and controller), frontier.png (success rate and p95 against
/// seconds per ply) and frontier.json.
fn frontier(
    setup: &Setup,
    args: &RobustnessArgs,
    work: &Work,
    specs: &[ControllerSpec],
    study: &Study,
    paces: &[f64],
) -> Result<()> {
    let mut paces = paces.to_vec();
    paces.sort_by(f64::total_cmp);
    paces.dedup();
    let paces = paces.as_slice();
    let out = &args.out;
    let (csv_path, plot_path, json_path) =
        (out.join("frontier.csv"), out.join("frontier.png"), out.join("frontier.json"));
    // Each pace's limits are checked before any trial runs.
    let mut setups = Vec::with_capacity(paces.len());
    for &pace in paces {
        let mut paced = setup.clone();
        paced.motion = crate::app::setup::file::checked_limits(setup.motion.at_pace(pace), "motion", "gripper")
            .with_context(|| format!("--paces {}", crate::app::resources::show(pace)))?;
        setups.push(paced);
    }
    crate::app::resources::ensure_fits(
        &format!("--trials {} with {} controllers at {} paces", args.trials, specs.len(), paces.len()),
        "trial rows",
        args.trials as f64 * specs.len() as f64,
        (std::mem::size_of::<TrialRow>() + 46 * 64) as f64,
    )?;
    let threads = crate::app::resources::worker_threads(args.threads)?;
    let pool =
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("cannot start the worker threads")?;
    ensure_dir(out)?;
    remove_stale(&[csv_path.clone(), plot_path.clone(), json_path.clone()])?;
    let bar = crate::progress::bar((args.trials * paces.len()) as u64, "trials");
    let started = Instant::now();
    let options = trial_options(args, study.resolution(setup));
    let mut points = Vec::with_capacity(paces.len() * specs.len());
    for (&pace, paced) in paces.iter().zip(&setups) {
        let rows = pool.install(|| run_trials(paced, work, specs, study, &options, 0..args.trials, Some(&bar)))?;
        for spec in specs {
            points.push(FrontierPoint { pace, stats: statistics(&rows, &spec.name, "", selector(setup), out) });
        }
    }
    let wall_time_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let number = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    write_atomic(&csv_path, |writer| {
        writeln!(writer, "pace,controller,trials,success_rate,failed_runs,median_mm,p95_mm,max_mm,seconds_per_ply")?;
        for p in &points {
            let s = &p.stats;
            writeln!(
                writer,
                "{},{},{},{},{},{},{},{},{}",
                p.pace,
                s["controller"].as_str().unwrap_or("?"),
                s["trials"],
                number(&s["success_rate"]),
                s["failed_runs"],
                number(&s["place_error_mm"]["median"]),
                number(&s["place_error_mm"]["p95"]),
                number(&s["place_error_mm"]["max"]),
                number(&s["seconds_per_ply"]),
            )?;
        }
        Ok(())
    })?;
    draw_frontier(&points, specs, args.tolerance_mm, &plot_path)?;
    let summary = json!({
        "work": { "game_file": args.game_file.as_ref().map(|p| p.display().to_string()), "game": args.game },
        "trials": args.trials,
        "seed": args.conditions.seed,
        "tolerance_mm": args.tolerance_mm,
        "conditions": study.describe(),
        "points": points.iter().map(|p| {
            let mut stats = p.stats.clone();
            if let Some(object) = stats.as_object_mut() {
                object.remove("replay_worst_trial");
                object.insert("pace".into(), json!(p.pace));
            }
            stats
        }).collect::<Vec<_>>(),
        "wall_time_s": wall_time_s,
        "threads": threads,
    });
    write_json(&json_path, &summary)?;
    let mut human = format!(
        "{} trials per pace; success = every piece within {} mm of its square centre\n{:>6} {:<10} {:>9} {:>12} {:>12} {:>8}\n",
        args.trials, args.tolerance_mm, "pace", "control", "success", "median mm", "p95 mm", "s/ply"
    );
    for p in &points {
        let s = &p.stats;
        human.push_str(&format!(
            "{:>6} {:<10} {:>8.1}% {:>12.4} {:>12.4} {:>8.3}\n",
            p.pace,
            s["controller"].as_str().unwrap_or("?"),
            100.0 * number(&s["success_rate"]),
            number(&s["place_error_mm"]["median"]),
            number(&s["place_error_mm"]["p95"]),
            number(&s["seconds_per_ply"]),
        ));
    }
    let files = [csv_path.display().to_string(), plot_path.display().to_string(), json_path.display().to_string()];
    human.push_str(&crate::files_text(&files));
    crate::emit(&human, &json!({ "summary": summary, "files": files }))?;
    Ok(())
}

/// The frontier: per controller, success rate and p95 placement error against mean robot
/// seconds per ply, one point per pace (joined in pace order).
fn draw_frontier(
    points: &[FrontierPoint],
    specs: &[ControllerSpec],
    tolerance_mm: f64,
    path: &std::path::Path,
) -> Result<()> {
    let number = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let series_of = |value: &dyn Fn(&serde_json::Value) -> f64| -> Vec<Series> {
        specs
            .iter()
            .enumerate()
            .map(|(k, spec)| Series {
                label: spec.name.clone(),
                points: points
                    .iter()
                    .filter(|p| p.stats["controller"] == spec.name.as_str())
                    .map(|p| (number(&p.stats["seconds_per_ply"]), value(&p.stats)))
                    .collect(),
                color: k,
                style: Style::Line,
            })
            .collect()
    };
    let success = Panel {
        title: "trials with every piece within the tolerance".into(),
        y_label: "success (%)".into(),
        series: series_of(&|s| 100.0 * number(&s["success_rate"])),
        legend: crate::app::formats::plots::Corner::LowerRight,
        ..Panel::default()
    };
    let p95 = Panel {
        title: "p95 of the largest placement error per trial".into(),
        y_label: "p95 placement error (mm)".into(),
        series: series_of(&|s| number(&s["place_error_mm"]["p95"])),
        levels: vec![crate::app::formats::plots::Level {
            value: tolerance_mm,
            label: format!("tolerance {tolerance_mm} mm"),
            color: specs.len(),
        }],
        ..Panel::default()
    };
    plot_panels(path, "Speed–accuracy frontier (one point per pace)", "mean robot time per ply (s)", &[success, p95])
}

fn table(stats: &[serde_json::Value], trials: usize, tolerance_mm: f64) -> String {
    let mut text = format!(
        "{trials} trials; success = every piece within {tolerance_mm} mm of its square centre\n{:<10} {:>9} {:>12} {:>12} {:>12} {:>8} {:>14} {:>11}\n",
        "control", "success", "median mm", "p95 mm", "max mm", "s/ply", "peak |τ| N·m", "saturated"
    );
    for s in stats {
        let number = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
        text.push_str(&format!(
            "{:<10} {:>8.1}% {:>12.4} {:>12.4} {:>12.4} {:>8.3} {:>14.3} {:>11}\n",
            s["controller"].as_str().unwrap_or("?"),
            100.0 * number(&s["success_rate"]),
            number(&s["place_error_mm"]["median"]),
            number(&s["place_error_mm"]["p95"]),
            number(&s["place_error_mm"]["max"]),
            number(&s["seconds_per_ply"]),
            number(&s["peak_torque_nm"]),
            s["trials_with_saturation"].as_u64().map_or("-".to_string(), |n| n.to_string()),
        ));
    }
    text
}

/// The placement-error distribution of each controller (empirical CDF, mm) with the tolerance.
fn draw_cdf(rows: &[TrialRow], specs: &[ControllerSpec], tolerance_mm: f64, path: &std::path::Path) -> Result<()> {
    let mut series: Vec<Series> = specs
        .iter()
        .enumerate()
        .map(|(k, spec)| {
            let mine: Vec<f64> = rows.iter().filter(|r| r.controller == spec.name).map(|r| r.place_error_mm).collect();
            // Fractions of all trials: failed runs (NaN) are left out of the curve, which then
            // ends below 1.
            let n = mine.len().max(1) as f64;
            let mut errors: Vec<f64> = mine.into_iter().filter(|e| e.is_finite()).collect();
            errors.sort_by(f64::total_cmp);
            Series {
                label: spec.name.clone(),
                points: errors.iter().enumerate().map(|(i, e)| (*e, (i + 1) as f64 / n)).collect(),
                color: k,
                style: Style::Line,
            }
        })
        .collect();
    series.push(Series {
        label: format!("tolerance {tolerance_mm} mm"),
        points: vec![(tolerance_mm, 0.0), (tolerance_mm, 1.0)],
        color: specs.len(),
        style: Style::Dashed,
    });
    let panel = Panel {
        title: "largest placement error per trial".into(),
        y_label: "fraction of trials".into(),
        series,
        ..Panel::default()
    };
    plot_panels(path, "Placement error distribution (CDF)", "placement error (mm)", &[panel])
}
