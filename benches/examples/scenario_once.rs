//! Runs of the queens-gambit scenario (13 s at 1 kHz, PD), for instruction counts:
//! `valgrind --tool=callgrind target/release/examples/scenario_once [N] [LEVEL] [INTEGRATOR]`
//! (N runs, 1 by default; the level `avx512`, `avx2` or `sse2`, a single run's by default; the
//! integrator as the CLI names it, `rkn4` by default). Prints the fastest run's time and the
//! median (the upper middle one for an even N). An argument it does not know, or a level this
//! CPU lacks, stops it.

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::scenario::queens_gambit;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::computed_torque::ComputedTorque;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sim::batch::SimdLevel;
use chessarm_core::sim::{Integrator, NoObserver, Plant, SimConfig, simulate};

fn main() {
    let argument = |i: usize| std::env::args_os().nth(i).map(|typed| typed.to_string_lossy().into_owned());
    let refuse = |what: &str, typed: &str| -> ! {
        eprintln!("scenario_once: {typed:?} is not {what}; see the file's first lines");
        std::process::exit(2)
    };
    let runs: usize = argument(1).map_or(1, |n| {
        n.parse().ok().filter(|&runs: &usize| runs > 0).unwrap_or_else(|| refuse("a count of runs (1 or more)", &n))
    });
    let level = argument(2).map_or_else(SimdLevel::for_one_run, |name| {
        SimdLevel::from_name(&name)
            .filter(|level| level.available())
            .unwrap_or_else(|| refuse("a SIMD level this CPU has", &name))
    });
    let integrator = argument(3).map_or_else(Integrator::default, |name| {
        Integrator::ALL.into_iter().find(|i| i.name() == name).unwrap_or_else(|| refuse("an integrator", &name))
    });
    let model = report_arm();
    let board = BoardGeometry::default();
    let path = queens_gambit(&board).path(&board).expect("valid scenario");
    let trajectory = JointTrajectory::from_path(&model, &path, 1e-3).expect("feasible");
    let gains = Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).expect("valid gains");
    let mut times = Vec::new();
    let mut last_error = 0.0;
    for _ in 0..runs {
        let mut plant = Plant::new(model).with_simd_level(level);
        let mut controller = ComputedTorque::new("pd", model, gains);
        let mut config = SimConfig::new(&plant);
        config.integrator = integrator;
        let started = std::time::Instant::now();
        let summary = simulate(&mut plant, &mut controller, &trajectory, None, &[], &[], &config, &mut NoObserver)
            .expect("stable");
        times.push(started.elapsed().as_secs_f64());
        last_error = summary.max_tip_error;
    }
    times.sort_by(f64::total_cmp);
    let (fastest, median) = (times[0], times[times.len() / 2]);
    println!(
        "{runs} runs, fastest {:.3} ms, median {:.3} ms, max tip error {last_error:.3e} m",
        fastest * 1e3,
        median * 1e3
    );
}
