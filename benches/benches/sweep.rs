//! The issue-5 sweep: `chessarm tune --kp 100..900:40 --kd 10..60:40` (1600 PD candidates, each
//! the 13 s scenario at 1 kHz), on all cores and, as the naive baseline, on one thread.
//! About 8 s and 16 s per sweep on the 2-core development machine: `--bench sweep` alone takes
//! a few minutes.

use chessarm::app::resources::shard_range;
use chessarm::app::setup::file::Setup;
use chessarm::cli::{Cli, Command};
use chessarm::commands::tune::{CandidateOptions, Setting, candidate_gains, study, sweep, tracking_from};
use clap::Parser;
use criterion::{Criterion, criterion_group, criterion_main};

fn sweeps(c: &mut Criterion) {
    let cli = Cli::parse_from(["chessarm", "tune", "--kp", "100..900:40", "--kd", "10..60:40"]);
    let Some(Command::Tune(args)) = cli.command else { unreachable!("a tune command line") };
    let setup = Setup::load(None).expect("built-in setup");
    let study = study(&setup, &args, None).expect("scenario");
    let gains: Vec<Setting> = candidate_gains(&args).expect("valid ranges").into_iter().map(Setting::Torque).collect();
    let range = shard_range(gains.len(), None);
    let options = CandidateOptions {
        controller_knows_payload: args.controller_knows_payload,
        placement: args.placement.clone(),
        kind: chessarm_core::control::choice::ControllerKind::ComputedTorque,
        knows_friction: false,
        trial: None,
        integrator: args.integrator.integrator(),
        tracking_from: tracking_from(&args),
        mass_error: [0.0; 6],
        resolution: chessarm::app::setup::conditions::Resolution::default(),
        p_conversions: [None; 4],
    };
    let mut group = c.benchmark_group("tune 40x40 PD sweep, 13 s scenario at 1 kHz");
    group.sample_size(10);
    for (name, threads) in [("all cores", None), ("one thread (baseline)", Some(1))] {
        group.bench_function(name, |b| {
            b.iter(|| {
                let candidates = sweep(&setup, &study, &options, &gains, range.clone(), threads, None).expect("ran");
                assert_eq!(candidates.len(), 1600);
                candidates
            })
        });
    }
    group.finish();
}

criterion_group!(benches, sweeps);
criterion_main!(benches);
