//! The seed scenario (13 s at 1 kHz, PD, default integrator) for `RUNS` candidates at 1, 4 or 8
//! lanes: `lanes_once [LANES] [RUNS] [LEVEL]`, for per-lane step costs under callgrind
//! (`valgrind --tool=callgrind target/release/examples/lanes_once 8 8`) or the wall clock.

use chessarm_benches::{pd_scenario_runs, scenario_trajectory};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::sim::batch::{LaneCount, SimdLevel, simulate_lanes};

fn main() {
    let mut args = std::env::args().skip(1);
    let lanes = args.next().and_then(|n| n.parse().ok()).and_then(LaneCount::from_count).unwrap_or_default();
    let runs: usize = args.next().and_then(|n| n.parse().ok()).unwrap_or(8);
    let level =
        args.next().and_then(|name| SimdLevel::from_name(&name)).unwrap_or_else(|| SimdLevel::for_lanes(lanes.get()));
    let model = report_arm();
    let trajectory = scenario_trajectory(&model);
    let mut batch = pd_scenario_runs(model, &trajectory, runs);
    let started = std::time::Instant::now();
    let results = simulate_lanes(&mut batch, lanes, level);
    let elapsed = started.elapsed().as_secs_f64();
    let steps: usize = results.iter().map(|r| r.as_ref().map_or(0, |s| s.steps)).sum();
    println!(
        "{runs} runs at {} lanes ({}): {:.3} ms, {:.1} ns per run-step",
        lanes.get(),
        level.name(),
        elapsed * 1e3,
        elapsed / steps as f64 * 1e9
    );
}
