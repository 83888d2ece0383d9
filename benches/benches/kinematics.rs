//! Kinematics and planning: IK per call, Jacobians, planning the report's whole scenario.

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::scenario::queens_gambit;
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::task::{TOOL_DOWN, inverse_kinematics, task_jacobian, task_jacobian_derivative, tool_point};
use chessarm_core::nalgebra::Vector3;
use chessarm_core::plan::trajectory::JointTrajectory;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn kinematics(c: &mut Criterion) {
    let model = report_arm();
    let target = Vector3::new(-0.03, 0.30, 0.05);
    let q = inverse_kinematics(&model, &target, TOOL_DOWN).expect("reachable");
    let qd = JointVector::<4>::new(0.3, -0.2, 0.4, 0.1);
    c.bench_function("ik per call", |b| b.iter(|| inverse_kinematics(&model, black_box(&target), TOOL_DOWN)));
    c.bench_function("fk tool point", |b| b.iter(|| tool_point(&model, black_box(&q))));
    c.bench_function("task jacobian", |b| b.iter(|| task_jacobian(&model, black_box(&q))));
    c.bench_function("task jacobian derivative", |b| b.iter(|| task_jacobian_derivative(&model, black_box(&q), &qd)));
}

fn planning(c: &mut Criterion) {
    let model = report_arm();
    let board = BoardGeometry::default();
    let scenario = queens_gambit(&board);
    c.bench_function("plan queens-gambit at 5 ms (path + IK + rates, 2601 samples)", |b| {
        b.iter(|| {
            let path = scenario.path(&board).expect("valid");
            JointTrajectory::from_path(&model, &path, black_box(0.005)).expect("feasible")
        })
    });
}

criterion_group!(benches, kinematics, planning);
criterion_main!(benches);
