//! Simulation: the plant, fixed-step integrators (fourth-order Runge–Kutta–Nyström by default), and the closed loop with a sampled
//! controller, torque saturation, payload events and metrics.

pub mod actuator;
pub mod batch;
pub mod closed_loop;
pub mod integrator;
mod lane_law;
pub mod metrics;
pub mod plant;
pub mod structured;

pub use closed_loop::{
    NoObserver, Observer, PayloadEvent, ReferenceSource, SimConfig, SimError, SimSummary, StepRecord, Told, simulate,
    simulate_fine_points, simulate_sensed,
};
pub use integrator::Integrator;
pub use plant::{Plant, StateDynamics};
