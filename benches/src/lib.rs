//! What the benchmarks and their examples share.

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::scenario::queens_gambit;
use chessarm_core::arm::model::ArmModel;
use chessarm_core::control::computed_torque::ComputedTorque;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sense::Feedback;
use chessarm_core::sim::batch::LaneRun;
use chessarm_core::sim::{Plant, SimConfig};

/// The seed scenario's joint trajectory at 1 kHz for `model`.
pub fn scenario_trajectory(model: &ArmModel<4>) -> JointTrajectory {
    let board = BoardGeometry::default();
    let path = queens_gambit(&board).path(&board).expect("valid scenario");
    JointTrajectory::from_path(model, &path, 1e-3).expect("feasible")
}

/// `runs` PD candidates of the scenario for the batch simulator (the report's gains, kp
/// 1 % higher for each next one), ideal sensors, the default settings.
pub fn pd_scenario_runs<'a>(model: ArmModel<4>, trajectory: &'a JointTrajectory, runs: usize) -> Vec<LaneRun<'a>> {
    let config = SimConfig::new(&Plant::new(model));
    (0..runs)
        .map(|i| {
            let gains = Gains::uniform(REPORT_PD.0 * (1.0 + 0.01 * i as f64), REPORT_PD.1, 0.0).expect("valid gains");
            LaneRun {
                plant: model,
                feedback: Feedback::ideal(),
                controller: Box::new(ComputedTorque::new("pd", model, gains)),
                reference: trajectory,
                initial: None,
                events: &[],
                marks: &[],
                config,
            }
        })
        .collect()
}
