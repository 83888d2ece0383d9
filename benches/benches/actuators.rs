//! Servos and steppers against torque motors on the same run: the report's queens-gambit
//! scenario (13 s at 1 kHz) with computed-torque PD on torque motors, and with a servo host
//! (plain and feedforward goals at 100 Hz) on servos strong enough for the report's arm (the
//! XM430's firmware and gear, 48 V, 20 N·m current limit), and on steppers.

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::scenario::queens_gambit;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::computed_torque::ComputedTorque;
use chessarm_core::control::gains::Gains;
use chessarm_core::control::servo_host::{ServoCommand, ServoHost};
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sim::actuator::{Actuator, Actuators, ServoSpec, StepperSpec, profiles};
use chessarm_core::sim::{NoObserver, Plant, SimConfig, simulate};
use criterion::{Criterion, criterion_group, criterion_main};

fn scenario(c: &mut Criterion) {
    let model = report_arm();
    let board = BoardGeometry::default();
    let path = queens_gambit(&board).path(&board).expect("valid");
    let trajectory = JointTrajectory::from_path(&model, &path, 1e-3).expect("feasible");
    let gains = Gains::uniform(400.0, 40.0, 0.0).expect("valid");
    c.bench_function("queens-gambit 13 s, torque motors, PD at 1 kHz", |b| {
        b.iter(|| {
            let mut plant = Plant::new(model);
            let mut controller = ComputedTorque::new("pd", model, gains);
            let config = SimConfig::new(&plant);
            simulate(&mut plant, &mut controller, &trajectory, None, &[], &[], &config, &mut NoObserver)
                .expect("stable")
        })
    });
    let servo =
        ServoSpec { supply_voltage: 48.0, max_torque: 20.0, ..profiles::profile("xm430").expect("built in").spec };
    let stepper = StepperSpec { holding_torque: 8.0, ..profiles::NEMA17.spec };
    let runs = [
        ("servos, plain goals at 100 Hz", Actuators::servos([servo; 4]), ServoCommand::Plain, 1e-3),
        ("servos, feedforward goals at 100 Hz", Actuators::servos([servo; 4]), ServoCommand::Feedforward, 1e-3),
        (
            "steppers, plain goals at 100 Hz, 0.5 ms steps",
            Actuators { joints: [Actuator::Stepper(stepper); 4] },
            ServoCommand::Plain,
            5e-4,
        ),
    ];
    for (name, actuators, command, dt) in runs {
        let plant_model = actuators.plant_model(&model).expect("valid");
        c.bench_function(&format!("queens-gambit 13 s, {name}"), |b| {
            b.iter(|| {
                let mut plant = Plant::new(plant_model);
                let mut host = ServoHost::new(command, model, actuators).expect("valid");
                let config = SimConfig { dt, control_period: 0.01, actuators, ..SimConfig::new(&plant) };
                simulate(&mut plant, &mut host, &trajectory, None, &[], &[], &config, &mut NoObserver).expect("stable")
            })
        });
    }
}

criterion_group!(benches, scenario);
criterion_main!(benches);
