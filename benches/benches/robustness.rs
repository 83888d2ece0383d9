//! The robustness study's Monte Carlo: trials of the 13 s seed scenario (queens-gambit) at 1 kHz with the
//! `hobby` sensors (12-bit encoders, σ 0.5 count, 1 sample delay) and the Kalman filter, PD
//! control, unknown pawn. The target is 1000 trials in ≤ 3 s on the 2-core machine; the bench
//! runs 100 trials on all cores and reports the time per 100 (× 10 for 1000), and one trial on
//! one thread for the per-trial cost. Also with the model errors of the target (±10 %
//! link masses, the ERRATA inertia rotation, ±50 % piece masses), where the controller's model
//! differs from the plant's and computes its own dynamics terms.

use chessarm::app::setup::conditions::Study;
use chessarm::app::setup::file::Setup;
use chessarm::app::studies::never;
use chessarm::app::studies::plan::plan_scenario;
use chessarm::app::studies::robustness::{TrialOptions, Work, run_trials};
use chessarm::app::studies::simulate::{DefaultGains, controller_specs};
use chessarm::cli::{Cli, Command};
use clap::Parser;
use criterion::{Criterion, criterion_group, criterion_main};

fn trials(c: &mut Criterion) {
    let setup = Setup::load(None).expect("built-in setup");
    let dir = std::env::temp_dir().join(format!("chessarm-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let uncertainty = dir.join("u.toml");
    std::fs::write(&uncertainty, "link_mass = 0.10\ninertia_rotation = \"errata\"\npiece_mass = 0.5\n").expect("write");
    let plan = plan_scenario(&setup, "queens-gambit", 1e-3, "bench").expect("plan");
    let work = Work::Scenario { plan, payload_mass: setup.pieces.pawn.mass };
    // A scenario, not a game: no board to check before the trials.
    let options = TrialOptions {
        pitch: None,
        seed: 1,
        integrator: chessarm_core::sim::Integrator::default(),
        controller_knows_payload: false,
        payload_feedforward: true,
        in_position: Some(chessarm_core::plan::fine_point::InPosition::for_tolerance(0.005)),
        tolerance: 0.005,
    };
    let mut group = c.benchmark_group("robustness, queens-gambit, hobby + Kalman, PD");
    group.sample_size(10);
    for (name, extra) in [("no model errors", None), ("model errors", Some(&uncertainty))] {
        let mut line = vec!["chessarm", "robustness", "--sensors", "hobby", "--controller", "pd"];
        let path = extra.map(|p| p.to_str().expect("utf-8").to_string());
        if let Some(path) = &path {
            line.extend(["--uncertainty", path.as_str()]);
        }
        let cli = Cli::parse_from(line);
        let Some(Command::Robustness(args)) = cli.command else { unreachable!("a robustness command line") };
        let specs = controller_specs(&args.controller, &args.gains.given(), DefaultGains::Report).expect("specs");
        let study = Study::for_trials(&setup, &args.conditions.options(), 1e-3).expect("conditions");
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("pool");
        group.bench_function(format!("{name}: 100 trials, 2 threads"), |b| {
            b.iter(|| {
                pool.install(|| run_trials(&setup, &work, &specs, &study, &options, 0..100, None, &never))
                    .expect("not cancelled")
            })
        });
        let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
        group.bench_function(format!("{name}: 1 trial, 1 thread"), |b| {
            b.iter(|| {
                single
                    .install(|| run_trials(&setup, &work, &specs, &study, &options, 0..1, None, &never))
                    .expect("not cancelled")
            })
        });
    }
    group.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, trials);
criterion_main!(benches);
