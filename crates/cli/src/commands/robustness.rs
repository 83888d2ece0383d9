//! `robustness`: Monte Carlo over randomised trials (the campaign is the study's,
//! [`crate::app::studies::robustness`]; this writes its CSV, plot and summary). Each trial draws the true arm (link
//! masses, centres of mass, inertia rotations, friction), the pieces' true masses and the
//! sensors' noise from its own seed, then runs every controller on the same draws (common
//! random numbers: the controllers are compared on identical arms and identical noise). One
//! CSV row per trial and controller; the rows come out in trial order whatever the number of
//! threads, and `--shard K/N` slices concatenate to the whole study.

use crate::app::formats::plots::{Panel, Series, Style, plot_panels};
use crate::app::formats::robustness::{draw_cdf, write_csv};
use crate::app::output::{ensure_dir, remove_stale, write_atomic, write_json};
use crate::app::setup::file::Setup;
use crate::app::studies::robustness::{
    Campaign, Prepared, RobustnessOptions, Statistics, TrialRow, Work, run_trials, statistics,
};
use crate::cli::RobustnessArgs;
use anyhow::{Context, Result};
use chessarm_core::control::choice::ControllerSpec;
use serde_json::json;
use std::time::Instant;

/// The campaign the flags describe.
pub fn options(args: &RobustnessArgs) -> Result<RobustnessOptions> {
    Ok(RobustnessOptions {
        game: match &args.game_file {
            Some(path) => Some(crate::app::formats::pgn::read_pgn_game(path, args.game)?),
            None => None,
        },
        scenario: args.scenario.clone(),
        controllers: args.controller.clone(),
        gains: args.gains.given(),
        payload_mass: args.payload_mass,
        controller_knows_payload: args.controller_knows_payload,
        conditions: args.conditions.options(),
        placement: args.placement.options(),
        tolerance: args.tolerance_mm / 1e3,
        trials: args.trials,
        shard: args.shard,
        integrator: args.integrator.integrator(),
        threads: args.threads,
    })
}

pub fn run(setup: &Setup, args: &RobustnessArgs) -> Result<()> {
    let setup = &args.motion.apply(setup)?;
    let options = options(args)?;
    // With servos, their hosts replace the torque controllers: said before any other word.
    crate::servo_hosts(setup);
    let campaign = Prepared::new(setup, &options)?;
    if let Some(paces) = &args.paces {
        let Work::Game(_) = &campaign.work else {
            anyhow::bail!("--paces sweeps a game's motion: give a PGN file (a scenario keeps its own LSPB path)");
        };
        if args.shard.is_some() {
            anyhow::bail!("--paces runs every trial at every pace: it does not take --shard");
        }
        return frontier(setup, args, &campaign, paces);
    }
    campaign.ensure_fits()?;
    ensure_dir(&args.out)?;
    remove_stale(&[
        args.out.join("robustness.csv"),
        args.out.join("robustness.png"),
        args.out.join("robustness.json"),
    ])?;
    let trials_run = campaign.range.len();
    let conditions = campaign.study.describe();
    let bar = crate::progress::bar(trials_run as u64, "trials");
    let result = campaign.run(Some(&|n| bar.inc(n)), &crate::cancelled)?;
    bar.finish_and_clear();
    let Campaign { rows, specs, statistics, wall_time_s, threads } = &result;

    let csv_path = args.out.join("robustness.csv");
    let with_header = args.shard.is_none_or(|(k, _)| k == 1);
    write_csv(&csv_path, rows, with_header)?;
    let plot_path = args.out.join("robustness.png");
    draw_cdf(rows, specs, args.tolerance_mm, &plot_path)?;
    let replay = replay_command(setup, args);
    let stats: Vec<serde_json::Value> =
        statistics.iter().map(|s| with_replay(s, &replay, selector(setup), &args.out)).collect();
    let summary = json!({
        "work": match &args.game_file { Some(path) => json!({ "game_file": path.display().to_string(), "game": args.game }), None => json!({ "scenario": args.scenario }) },
        "trials": args.trials,
        "shard": args.shard.map(|(k, n)| format!("{k}/{n}")),
        "trials_run": trials_run,
        "seed": args.conditions.seed,
        "tolerance_mm": args.tolerance_mm,
        "conditions": conditions,
        "controllers": stats,
        "wall_time_s": wall_time_s,
        "threads": threads,
    });
    let json_path = args.out.join("robustness.json");
    write_json(&json_path, &summary)?;
    let mut human = String::new();
    crate::tell_or_keep(&table(&stats, trials_run, args.tolerance_mm), &mut human);
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

/// The command that re-runs one trial, without its controller, seed and folder: the setup
/// file, URDF and servos named, the model errors taken from the setup's [uncertainty] table
/// when they came from there.
fn replay_command(setup: &Setup, args: &RobustnessArgs) -> String {
    let knows = if args.controller_knows_payload { " --controller-knows-payload" } else { "" };
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
    match &args.game_file {
        None => format!(
            "{arm}simulate --scenario {} --payload-mass {}{knows}{}{from_setup}",
            args.scenario,
            args.payload_mass.unwrap_or(setup.pieces.pawn.mass),
            args.conditions.options().flags()
        ),
        // The campaign ran every move at the pace given: so does the replay.
        Some(path) => format!(
            "{arm}play {} --game {} --keep-pace{knows}{}{from_setup}",
            word(path),
            args.game,
            args.conditions.options().flags()
        ),
    }
}

/// A controller's statistics as JSON, with the command that replays its worst trial into
/// `out/worst-CONTROLLER`, its own folder (not the default one another run may be using);
/// `selector` is the flag that picks the controller (`--controller`, or `--servo-command` for
/// a servo host). Without `replay` (a frontier's points), none.
fn with_replay(stats: &Statistics, replay: &str, selector: &str, out: &std::path::Path) -> serde_json::Value {
    let mut value = serde_json::to_value(stats).unwrap_or(serde_json::Value::Null);
    let command = stats.worst_trial_seed.filter(|_| !replay.is_empty()).map(|seed| {
        let folder = out.join(format!("worst-{}", stats.controller));
        let folder = crate::app::output::shell_word(&folder.display().to_string());
        format!("chessarm {replay} {selector} {} --trial-seed {seed} --out {folder}", stats.controller)
    });
    if let Some(object) = value.as_object_mut() {
        object.insert("replay_worst_trial".into(), json!(command));
    }
    value
}

/// The flag that picks a run's controller: `--servo-command` for servos' hosts.
fn selector(setup: &Setup) -> &'static str {
    if setup.actuators.take_positions() { "--servo-command" } else { "--controller" }
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
fn frontier(setup: &Setup, args: &RobustnessArgs, campaign: &Prepared<'_>, paces: &[f64]) -> Result<()> {
    let Prepared { work, specs, study, trial_options: options, .. } = campaign;
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
    let mut points = Vec::with_capacity(paces.len() * specs.len());
    for (&pace, paced) in paces.iter().zip(&setups) {
        let progress = |n| bar.inc(n);
        let rows = pool.install(|| {
            run_trials(paced, work, specs, study, options, 0..args.trials, Some(&progress), &crate::cancelled)
        })?;
        for spec in specs {
            let stats = with_replay(&statistics(&rows, &spec.name), "", selector(setup), out);
            points.push(FrontierPoint { pace, stats });
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
