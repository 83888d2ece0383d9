//! The batch simulator of issue 15: eight runs of the 13 s seed scenario at 1 kHz (PD,
//! computed torque, the default integrator, no time series) at 1, 4 and 8 lanes and at every
//! SIMD level this CPU has; the throughput is in run-steps, so its inverse is the cost of one
//! run's step at that lane count and level.

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::scenario::queens_gambit;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::task::TOOL_DOWN;
use chessarm_core::control::computed_torque::ComputedTorque;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sense::Feedback;
use chessarm_core::sim::batch::{LaneCount, LaneRun, SimdLevel, simulate_lanes};
use chessarm_core::sim::{Plant, SimConfig};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const RUNS: usize = 8;

fn lanes(c: &mut Criterion) {
    let model = report_arm();
    let board = BoardGeometry::default();
    let path = queens_gambit(&board).path(&board).expect("valid scenario");
    let trajectory = JointTrajectory::from_path(&model, &path, 1e-3, TOOL_DOWN).expect("feasible");
    let config = SimConfig::new(&Plant::new(model));
    let make = || -> Vec<LaneRun<'_>> {
        (0..RUNS)
            .map(|i| {
                let gains = Gains::uniform(REPORT_PD.0 * (1.0 + 0.01 * i as f64), REPORT_PD.1, 0.0).expect("gains");
                LaneRun {
                    plant: model,
                    feedback: Feedback::ideal(),
                    controller: Box::new(ComputedTorque::new("pd", model, gains)),
                    reference: &trajectory,
                    initial: None,
                    events: &[],
                    marks: &[],
                    config,
                }
            })
            .collect()
    };
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
