//! Per-part timings of the structured kernels (ns per call), for a quick look without criterion.
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::yaw_pitch::{Angles, Configuration};
use std::hint::black_box;
use std::time::Instant;

fn time(name: &str, n: usize, mut f: impl FnMut(usize)) {
    let start = Instant::now();
    for i in 0..n {
        f(i);
    }
    println!("{name:40} {:8.1} ns", start.elapsed().as_secs_f64() / n as f64 * 1e9);
}

fn main() {
    let model = report_arm();
    let fast = *model.yaw_pitch().expect("family");
    let q = [1.67, 0.90, -2.09, -0.37];
    let qd = [0.3, -0.2, 0.4, 0.1];
    let n = 2_000_000;
    time("sin_cos", n, |i| {
        black_box(chessarm_core::lanes::sin_cos(black_box(0.3 + i as f64 * 1e-7)));
    });
    time("Angles::new", n, |_| {
        black_box(Angles::new(&fast, black_box(&q)));
    });
    let angles = Angles::new(&fast, &q);
    time("Angles::shifted", n, |_| {
        black_box(angles.shifted(&fast, black_box(&[1e-4, 2e-4, -1e-4, 3e-4])));
    });
    time("Configuration::new", n, |_| {
        black_box(Configuration::new(&fast, black_box(angles)));
    });
    let configuration = Configuration::new(&fast, angles);
    time("bias", n, |_| {
        black_box(configuration.bias(&fast, black_box(&qd)));
    });
    time("solve", n, |_| {
        black_box(configuration.inverse.solve(black_box(&qd)));
    });
}
