//! The sweep of `chessarm tune --kp 100..900:40 --kd 10..60:40` (1600 PD candidates, each
//! the 13 s scenario at 1 kHz), on all cores and, as the naive baseline, on one thread.
//! About 8 s and 16 s per sweep on the 2-core development machine: `--bench sweep` alone takes
//! a few minutes.

use chessarm::app::setup::file::Setup;
use chessarm::app::studies::never;
use chessarm::app::studies::tune::{GainRange, Prepared, TuneOptions};
use criterion::{Criterion, criterion_group, criterion_main};

fn sweeps(c: &mut Criterion) {
    let setup = Setup::load(None).expect("built-in setup");
    let range = |from, to| GainRange { from, to, count: 40 };
    let options = TuneOptions::new(range(100.0, 900.0), range(10.0, 60.0));
    let mut group = c.benchmark_group("tune 40x40 PD sweep, 13 s scenario at 1 kHz");
    group.sample_size(10);
    for (name, threads) in [("all cores", None), ("one thread (baseline)", Some(1))] {
        let options = TuneOptions { threads, ..options.clone() };
        group.bench_function(name, |b| {
            b.iter(|| {
                let tuned = Prepared::new(&setup, &options).expect("valid sweep").run(None, &never).expect("ran");
                assert_eq!(tuned.candidates.len(), 1600);
                tuned
            })
        });
    }
    group.finish();
}

criterion_group!(benches, sweeps);
criterion_main!(benches);
