//! The seed scenario (13 s at 1 kHz, PD, default integrator) for `RUNS` candidates at 1, 4 or 8
//! lanes: `lanes_once [LANES] [RUNS] [LEVEL]`, for per-lane step costs under callgrind
//! (`valgrind --tool=callgrind target/release/examples/lanes_once 8 8`) or the wall clock.

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

fn main() {
    let mut args = std::env::args().skip(1);
    let lanes = args.next().and_then(|n| n.parse().ok()).and_then(LaneCount::from_count).unwrap_or_default();
    let runs: usize = args.next().and_then(|n| n.parse().ok()).unwrap_or(8);
    let level = args.next().and_then(|name| SimdLevel::from_name(&name)).unwrap_or_else(SimdLevel::detect);
    let model = report_arm();
    let board = BoardGeometry::default();
    let path = queens_gambit(&board).path(&board).expect("valid scenario");
    let trajectory = JointTrajectory::from_path(&model, &path, 1e-3, TOOL_DOWN).expect("feasible");
    let config = SimConfig::new(&Plant::new(model));
    let mut batch: Vec<LaneRun<'_>> = (0..runs)
        .map(|i| {
            let gains = Gains::uniform(REPORT_PD.0 * (1.0 + 0.01 * i as f64), REPORT_PD.1, 0.0).expect("valid gains");
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
        .collect();
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
