//! `tune`: sweep gain combinations in parallel, one row per candidate: the sweep is the
//! study's ([`crate::app::studies::tune`]); this writes `tune.csv` and the heat map and prints
//! the best candidates.

use crate::app::formats::tune::{draw_heat_map, write_csv};
use crate::app::output::ensure_dir;
use crate::app::setup::file::Setup;
use crate::app::studies::tune::{Candidate, Metric, Prepared, TuneOptions, Tuned, edge_warning};
use crate::app::text::tick;
use crate::cli::TuneArgs;
use anyhow::Result;
use serde_json::json;

/// The sweep the flags describe.
pub fn options(args: &TuneArgs) -> Result<TuneOptions> {
    Ok(TuneOptions {
        game: match &args.game_file {
            Some(path) => Some(crate::app::formats::pgn::read_pgn_game(path, args.game)?),
            None => None,
        },
        scenario: args.scenario.clone(),
        controller: args.controller.into(),
        kp: args.kp,
        kd: args.kd,
        ki: args.ki,
        p_gain: args.p_gain,
        payload_mass: args.payload_mass,
        controller_knows_payload: args.controller_knows_payload,
        conditions: args.conditions.options(),
        placement: args.placement.options(),
        q0: args.q0,
        tracking_from: args.tracking_from,
        shard: args.shard,
        integrator: args.integrator.integrator(),
        threads: args.threads,
    })
}

pub fn run(setup: &Setup, args: &TuneArgs) -> Result<()> {
    let setup = &args.motion.apply(setup)?;
    let options = options(args)?;
    let sweep = Prepared::new(setup, &options)?;
    if setup.actuators.take_positions() {
        // The host strategies replace the torque controllers (said once on the terminal).
        crate::servo_hosts(setup);
    }
    if let (Some(q0), None) = (&options.q0, &options.game) {
        crate::warn_outside_limits(setup, "--q0", q0);
    }
    ensure_dir(&args.out)?;
    // An earlier sweep's files must not pass for this one's (a failed heat map, a changed range).
    let (csv_path, heat_map_path) = (args.out.join("tune.csv"), args.out.join("tune.png"));
    crate::app::output::remove_stale(&[csv_path.clone(), heat_map_path.clone()])?;
    let bar = crate::progress::bar(sweep.len() as u64, "tuning");
    let tuned = sweep.run(Some(&|n| bar.inc(n)), &crate::cancelled)?;
    bar.finish_and_clear();

    let with_header = args.shard.is_none_or(|(k, _)| k == 1);
    write_csv(&csv_path, &tuned, with_header)?;
    draw_heat_map(setup, &options, &tuned, args.metric, &heat_map_path)?;

    let best = tuned.best(args.metric, args.top);
    if tuned.tracking_from > 0.0 && matches!(args.metric, Metric::MaxTipError | Metric::RmsJointError) {
        crate::tell(&format!(
            "tracking metrics from t = {} s on (the default after --q0; --tracking-from S changes it): the start \
             from rest off the trajectory is left out\n",
            crate::app::resources::show(tuned.tracking_from)
        ));
    }
    let mut human = String::new();
    crate::tell_or_keep(&best_table(&best, args.metric), &mut human);
    if let Some(warning) = edge_warning(&options, best.first().copied()) {
        crate::tell_or_keep(&format!("warning: {warning}\n"), &mut human);
    }
    let (failed, saturated) = tuned.failed_and_saturated();
    let wall_time_s = tuned.wall_time_s;
    let Tuned { candidates, sweep_size, .. } = &tuned;
    human.push_str(&format!(
        "{} candidates ({failed} failed, {saturated} saturated a motor) in {wall_time_s:.2} s\n{}",
        candidates.len(),
        crate::files_text(&[csv_path.display().to_string(), heat_map_path.display().to_string()])
    ));
    crate::emit(
        &human,
        &json!({
            "candidates": candidates.len(),
            "sweep_size": sweep_size,
            "shard": args.shard.map(|(k, n)| format!("{k}/{n}")),
            "failed": failed,
            "saturated": saturated,
            "wall_time_s": wall_time_s,
            "candidates_per_second": candidates.len() as f64 / wall_time_s,
            "metric": format!("{:?}", args.metric),
            "tracking_metrics_from_s": tuned.tracking_from,
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

fn best_table(best: &[&Candidate], metric: Metric) -> String {
    if best.first().is_some_and(|c| c.servo_command.is_some()) {
        let mut table = format!("{:>6} {:>12} {:>12} {:>30}\n", "rank", "host", "P register", metric.label());
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
    let mut table = format!("{:>6} {:>12} {:>12} {:>12} {:>30}\n", "rank", "kp", "kd", "ki", metric.label());
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
