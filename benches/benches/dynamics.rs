//! Dynamics and simulation: per-call costs and the whole scenario.

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::scenario::queens_gambit;
use chessarm_core::arm::dynamics::{bias_torques, forward_dynamics, gravity_torques, inverse_dynamics, mass_matrix};
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::computed_torque::ComputedTorque;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use chessarm_core::control::{Controller, JointState};
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sim::{Integrator, NoObserver, Plant, SimConfig, simulate};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn per_call(c: &mut Criterion) {
    let model = report_arm();
    let q = JointVector::<4>::new(1.67, 0.90, -2.09, -0.37);
    let qd = JointVector::<4>::new(0.3, -0.2, 0.4, 0.1);
    let qdd = JointVector::<4>::new(1.0, -2.0, 0.5, 3.0);
    let tau = inverse_dynamics(&model, &q, &qd, &qdd);
    // The structured path (the report's arm is of the yaw–pitch family) and the general
    // recursive algorithms on the same arm, side by side.
    for (path, model) in [("", model), (" (general)", model.with_general_dynamics())] {
        c.bench_function(&format!("mass matrix M(q){path}"), |b| b.iter(|| mass_matrix(&model, black_box(&q))));
        c.bench_function(&format!("bias C(q,qd)qd + g(q){path}"), |b| {
            b.iter(|| bias_torques(&model, black_box(&q), &qd))
        });
        c.bench_function(&format!("gravity g(q){path}"), |b| b.iter(|| gravity_torques(&model, black_box(&q))));
        c.bench_function(&format!("inverse dynamics{path}"), |b| {
            b.iter(|| inverse_dynamics(&model, black_box(&q), &qd, &qdd))
        });
        c.bench_function(&format!("forward dynamics{path}"), |b| {
            b.iter(|| forward_dynamics(&model, black_box(&q), &qd, &tau))
        });
    }
    let mut plant = Plant::new(model);
    let mut controller =
        ComputedTorque::new("pd", model, Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).expect("valid"));
    // Two states in turn: the plant keeps its evaluation of the last state it stepped from, so
    // stepping from one state over and over would time a step without its first stage.
    let states = [JointState { q, qd }, JointState { q: q * 0.9, qd: -qd }];
    let reference = chessarm_core::control::Reference { q, qd, qdd };
    let mut turn = 0;
    c.bench_function("closed-loop step: controller + RK4", |b| {
        b.iter(|| {
            turn ^= 1;
            let state = &states[turn];
            let torque = controller.command(black_box(state), &reference, 1e-3);
            plant.rk4_step(state, &torque, 1e-3)
        })
    });
}

fn scenario(c: &mut Criterion) {
    let model = report_arm();
    let board = BoardGeometry::default();
    let path = queens_gambit(&board).path(&board).expect("valid");
    let trajectory = JointTrajectory::from_path(&model, &path, 1e-3).expect("feasible");
    let gains = Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).expect("valid");
    let runs = Integrator::ALL.map(|integrator| (integrator, model, ""));
    let general = (Integrator::RungeKuttaNystrom4, model.with_general_dynamics(), " (general)");
    for (integrator, model, path) in runs.into_iter().chain([general]) {
        let name = format!("queens-gambit 13 s at 1 kHz, PD, one core, {}{path}", integrator.name());
        c.bench_function(&name, |b| {
            b.iter(|| {
                let mut plant = Plant::new(model);
                let mut controller = ComputedTorque::new("pd", model, gains);
                let config = SimConfig { integrator, ..SimConfig::new(&plant) };
                simulate(&mut plant, &mut controller, &trajectory, None, &[], &[], &config, &mut NoObserver)
                    .expect("stable")
            })
        });
    }
}

criterion_group!(benches, per_call, scenario);
criterion_main!(benches);
