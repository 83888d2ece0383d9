//! What several test files drive the closed loop with: a joint vector written as an array, a
//! reference that holds still, the first seconds of a trajectory, and PD's predicted steady
//! error with a wrong model. The chess layer's tests take it in too (by path), so that these
//! are written once.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test
#![allow(dead_code)] // each test binary uses a part of it

use chessarm_core::arm::dynamics::{gravity_torques, mass_matrix};
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::control::Reference;
use chessarm_core::plan::trajectory::JointTrajectory;
use chessarm_core::sim::ReferenceSource;

pub fn q(values: [f64; 4]) -> JointVector<4> {
    JointVector::<4>::from(values)
}

/// Holds still at one configuration for a given time.
pub struct Hold {
    pub q: JointVector<4>,
    pub duration: f64,
}

impl ReferenceSource<4> for Hold {
    fn reference(&self, _t: f64) -> Reference<4> {
        Reference::hold(self.q)
    }
    fn duration(&self) -> f64 {
        self.duration
    }
}

/// The first `duration` seconds of a trajectory.
pub struct Prefix<'a> {
    pub trajectory: &'a JointTrajectory,
    pub duration: f64,
}

impl ReferenceSource<4> for Prefix<'_> {
    fn reference(&self, t: f64) -> Reference<4> {
        self.trajectory.reference(t)
    }
    fn duration(&self) -> f64 {
        self.duration
    }
}

/// PD's steady error with a wrong model: at rest `M̂(q) kp e + ĝ(q) = g(q)` at `q = q_d − e`,
/// solved by fixed-point iteration.
pub fn steady_error_prediction(
    plant_model: &ArmModel<4>,
    controller_model: &ArmModel<4>,
    target: &JointVector<4>,
    kp: f64,
) -> JointVector<4> {
    let mut error = JointVector::<4>::zeros();
    for _ in 0..50 {
        let q = target - error;
        let difference = gravity_torques(plant_model, &q) - gravity_torques(controller_model, &q);
        error = mass_matrix(controller_model, &q).cholesky().unwrap().solve(&difference) / kp;
    }
    error
}
