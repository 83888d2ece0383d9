//! The batch simulator: eight runs of the 13 s seed scenario at 1 kHz (PD,
//! computed torque, the default integrator, no time series) at 1, 4 and 8 lanes and at every
//! SIMD level this CPU has; the throughput is in run-steps, so its inverse is the cost of one
//! run's step at that lane count and level.

use chessarm_benches::{pd_scenario_runs, scenario_trajectory};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::sim::batch::{LaneCount, SimdLevel, simulate_lanes};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const RUNS: usize = 8;

fn lanes(c: &mut Criterion) {
    let model = report_arm();
    let trajectory = scenario_trajectory(&model);
    let make = || pd_scenario_runs(model, &trajectory, RUNS);
    let steps: usize = simulate_lanes(&mut make(), LaneCount::One, SimdLevel::Baseline)
        .iter()
        .map(|r| r.as_ref().expect("the scenario runs").steps)
        .sum();
    let mut group = c.benchmark_group("8 scenario runs side by side");
    group.sample_size(10);
    group.throughput(Throughput::Elements(steps as u64));
    for level in SimdLevel::ALL.into_iter().filter(|level| level.available()) {
        for lanes in LaneCount::ALL {
            group.bench_function(format!("{} lanes, {}", lanes.get(), level.name()), |b| {
                b.iter_batched(
                    make,
                    |mut runs| simulate_lanes(&mut runs, lanes, level),
                    criterion::BatchSize::LargeInput,
                )
            });
        }
    }
    group.finish();
}

criterion_group!(benches, lanes);
criterion_main!(benches);
