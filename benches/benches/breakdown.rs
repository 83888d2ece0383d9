//! Where a closed-loop step spends its time.

use chessarm_core::arm::dynamics::{BodyFrames, ConfigurationDynamics, mass_matrix_with_frames, rnea_with_frames};
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::mass_matrix::MassMatrixFactor;
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::nalgebra::{Cholesky, Const, Vector3};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn breakdown(c: &mut Criterion) {
    let model = report_arm();
    let q = JointVector::<4>::new(1.67, 0.90, -2.09, -0.37);
    let qd = JointVector::<4>::new(0.3, -0.2, 0.4, 0.1);
    let chain = FrameChain::new(&model, &q);
    let frames = BodyFrames::from_trig(&model, chain.trig());
    let m = mass_matrix_with_frames(&model, &frames);
    c.bench_function("fk chain", |b| b.iter(|| FrameChain::new(&model, black_box(&q))));
    c.bench_function("body frames from trig (FK composed in)", |b| {
        b.iter(|| BodyFrames::from_trig(&model, black_box(chain.trig())))
    });
    c.bench_function("crba from frames", |b| b.iter(|| mass_matrix_with_frames(&model, black_box(&frames))));
    c.bench_function("rnea from frames", |b| {
        b.iter(|| {
            rnea_with_frames(&model, black_box(&frames), &qd, &JointVector::zeros(), &Vector3::new(0.0, 0.0, -9.8))
        })
    });
    c.bench_function("cholesky solve 4x4 (nalgebra)", |b| {
        b.iter(|| Cholesky::<f64, Const<4>>::new(black_box(m)).map(|ch| ch.solve(&qd)))
    });
    c.bench_function("LDLt factor + solve 4x4 (MassMatrixFactor)", |b| {
        b.iter(|| MassMatrixFactor::new(black_box(&m)).map(|f| f.solve(&qd)))
    });
    let factor = MassMatrixFactor::new(&m).expect("positive definite");
    c.bench_function("LDLt solve 4x4", |b| b.iter(|| black_box(&factor).solve(&qd)));
    c.bench_function("configuration dynamics (FK, frames, CRBA, LDLt)", |b| {
        b.iter(|| ConfigurationDynamics::new(&model, black_box(&q)))
    });
    let configuration = ConfigurationDynamics::new(&model, &q).expect("positive definite");
    c.bench_function("acceleration at a configuration (RNEA, solve)", |b| {
        b.iter(|| configuration.acceleration(&model, black_box(&qd), &qd))
    });
    let delta = JointVector::<4>::new(1e-3, -2e-3, 5e-4, 1e-4);
    c.bench_function("joint trig shifted", |b| b.iter(|| chain.trig().shifted(black_box(&delta))));
    c.bench_function("fk chain from shifted trig", |b| {
        b.iter(|| FrameChain::from_trig(&model, chain.trig().shifted(black_box(&delta))))
    });
    c.bench_function("4 sin_cos", |b| b.iter(|| black_box(q).map(|v| v.sin_cos().0 + v.sin_cos().1)));
}

criterion_group!(benches, breakdown);
criterion_main!(benches);
