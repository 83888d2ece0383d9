//! The actuators between a controller's command and the plant's joint torques, one per joint:
//! today's torque motor (the command is the torque, clipped to the joint's limit and passed
//! through its lag), or a position servo that runs its own firmware loop on goal positions
//! ([`servo`]). Built-in servos with published parameters are in [`profiles`].

pub mod profiles;
pub mod servo;

use crate::arm::dynamics::gravity_torques;
use crate::arm::model::{ArmModel, Friction, JointVector, ModelError};
use crate::control::CommandInterface;
pub use servo::{ServoSpec, ServoState};

/// What drives one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Actuator {
    /// A torque motor: the controller's torque, clipped to the joint's limit (and through the
    /// run's motor lag, [`crate::sim::SimConfig::torque_lag`]).
    Torque,
    /// A position servo on goal angles.
    Servo(ServoSpec),
}

/// The actuators of an arm's `N` joints: all torque motors, or all position servos (a
/// controller sends one kind of command).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Actuators<const N: usize> {
    pub joints: [Actuator; N],
}

impl<const N: usize> Default for Actuators<N> {
    fn default() -> Self {
        Self::torque()
    }
}

/// Why a set of actuators is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ActuatorError {
    #[error("joint {joint} servo {field} = {value}: {reason}")]
    InvalidField { joint: usize, field: &'static str, value: f64, reason: &'static str },
    #[error(
        "joint {servo} has a servo and joint {torque} a torque motor: a controller sends either torques or goal positions, so all joints need the same kind"
    )]
    Mixed { servo: usize, torque: usize },
    #[error("joint {joint} servo period {period} s must be a whole multiple of the time step {dt} s")]
    Period { joint: usize, period: f64, dt: f64 },
}

impl<const N: usize> Actuators<N> {
    /// Torque motors on every joint: today's plant.
    pub fn torque() -> Self {
        Self { joints: [Actuator::Torque; N] }
    }

    /// A servo on each joint.
    pub fn servos(specs: [ServoSpec; N]) -> Self {
        Self { joints: specs.map(Actuator::Servo) }
    }

    /// The servos, if every joint has one.
    pub fn servo_specs(&self) -> Option<[ServoSpec; N]> {
        let mut specs = [None; N];
        for (spec, joint) in specs.iter_mut().zip(&self.joints) {
            if let Actuator::Servo(s) = joint {
                *spec = Some(*s);
            }
        }
        if specs.iter().all(Option::is_some) { Some(specs.map(|s| s.expect("checked"))) } else { None }
    }

    /// The command these actuators take.
    pub fn interface(&self) -> CommandInterface {
        if self.joints.iter().any(|a| matches!(a, Actuator::Servo(_))) {
            CommandInterface::Position
        } else {
            CommandInterface::Torque
        }
    }

    /// Checks every servo's numbers, that the joints share one kind, and (for a run with time
    /// step `dt`, s) that each firmware period is a whole number of steps.
    pub fn validate(&self, dt: f64) -> Result<(), ActuatorError> {
        let servo = self.joints.iter().position(|a| matches!(a, Actuator::Servo(_)));
        let torque = self.joints.iter().position(|a| matches!(a, Actuator::Torque));
        if let (Some(servo), Some(torque)) = (servo, torque) {
            return Err(ActuatorError::Mixed { servo: servo + 1, torque: torque + 1 });
        }
        for (j, joint) in self.joints.iter().enumerate() {
            if let Actuator::Servo(spec) = joint {
                if let Some((field, value, reason)) = spec.invalid_field() {
                    return Err(ActuatorError::InvalidField { joint: j + 1, field, value, reason });
                }
                let ratio = spec.period / dt;
                if ratio.round() < 1.0 || (ratio - ratio.round()).abs() > 1e-9 * ratio {
                    return Err(ActuatorError::Period { joint: j + 1, period: spec.period, dt });
                }
            }
        }
        Ok(())
    }

    /// `model` with each servo's gear in its joint: the armature as the rotor inertia, the gear's
    /// viscous friction plus the back-EMF's damping `kt²/R` and the gear's Coulomb friction as
    /// the joint's friction (replacing the link's own: the servo is the joint's drive), and the
    /// stall torque as the torque limit. A torque motor's joint is left as it is.
    pub fn plant_model(&self, model: &ArmModel<N>) -> Result<ArmModel<N>, ModelError> {
        if self.interface() == CommandInterface::Torque {
            return Ok(*model);
        }
        let mut links = *model.links();
        for (link, joint) in links.iter_mut().zip(&self.joints) {
            if let Actuator::Servo(spec) = joint {
                link.rotor_inertia = spec.armature;
                link.friction = Friction {
                    viscous: spec.viscous_friction + spec.back_emf_damping(),
                    coulomb: spec.coulomb_friction,
                };
                link.limits.torque = spec.stall_torque();
            }
        }
        model.with_links(links)
    }
}

/// The servos of a run: their specifications, states, and how many plant steps each firmware
/// period spans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoBank<const N: usize> {
    specs: [ServoSpec; N],
    states: [ServoState; N],
    steps_per_period: [usize; N],
}

/// What the servos did at one plant step (for plots and the observers).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoRecord<const N: usize> {
    /// Goal angles the host sent, rad (whole counts).
    pub goal: JointVector<N>,
    /// The firmware's internal targets, rad.
    pub target: JointVector<N>,
    /// PWM duties, in [−1, 1].
    pub duty: JointVector<N>,
    /// Backlash gaps `θ − q`, rad.
    pub gap: JointVector<N>,
}

impl<const N: usize> ServoBank<N> {
    /// The servos of `specs` for a run with time step `dt` (s; validated by
    /// [`Actuators::validate`]), holding `goal` (rad) at rest at `q` (rad) under the plant
    /// `model`'s gravity.
    pub fn holding(
        specs: [ServoSpec; N],
        dt: f64,
        model: &ArmModel<N>,
        goal: &JointVector<N>,
        q: &JointVector<N>,
    ) -> Self {
        let load = gravity_torques(model, q);
        let mut j = 0;
        let states = specs.map(|spec| {
            let state = ServoState::holding(&spec, goal[j], q[j], load[j]);
            j += 1;
            state
        });
        let steps_per_period = specs.map(|spec| ((spec.period / dt).round() as usize).max(1));
        Self { specs, states, steps_per_period }
    }

    /// Where servos sent `goal` would come to rest under `model`'s gravity, rad: the output
    /// angles `q` with `stiffness · (goal − q) = g(q)` per joint (the load clamped to the stall
    /// torque), by fixed-point iteration from the goal (a contraction: `g` changes by far less
    /// than a servo's stiffness per rad). Counts and the deadband are ignored.
    pub fn settled(specs: &[ServoSpec; N], model: &ArmModel<N>, goal: &JointVector<N>) -> JointVector<N> {
        let mut q = *goal;
        for _ in 0..50 {
            let load = gravity_torques(model, &q);
            let next = JointVector::<N>::from_fn(|j, _| {
                let spec = &specs[j];
                let held = load[j].clamp(-spec.stall_torque(), spec.stall_torque());
                goal[j] - held / spec.stiffness()
            });
            let change = (next - q).amax();
            q = next;
            if change < 1e-12 {
                break;
            }
        }
        q
    }

    pub fn specs(&self) -> &[ServoSpec; N] {
        &self.specs
    }

    pub fn states(&self) -> &[ServoState; N] {
        &self.states
    }

    /// Takes the host's goal angles (rad): each clamped to `[lower, upper]` of its joint and
    /// rounded to whole counts, as the bus carries them. Returns the goals taken.
    pub fn send(&mut self, goal: &JointVector<N>, lower: &JointVector<N>, upper: &JointVector<N>) -> JointVector<N> {
        for j in 0..N {
            let spec = &self.specs[j];
            // Rounded inside the limits: a limit between two counts takes the count inside.
            let clamped = goal[j].clamp(lower[j], upper[j]);
            let mut counted = spec.quantise(clamped);
            if counted > upper[j] {
                counted -= spec.resolution();
            } else if counted < lower[j] {
                counted += spec.resolution();
            }
            self.states[j].goal = counted;
        }
        JointVector::from_fn(|j, _| self.states[j].goal)
    }

    /// The torques on the outputs over plant step `step` (of `dt` seconds) from the outputs'
    /// angles `q` (rad) and speeds `qd` (rad/s), each firmware running at the steps that start
    /// its periods; and the joints whose firmware ran and saturated (bit `j`).
    pub fn torque(&mut self, step: usize, q: &JointVector<N>, qd: &JointVector<N>, dt: f64) -> (JointVector<N>, u64) {
        let mut saturated = 0;
        let mut torque = JointVector::<N>::zeros();
        for j in 0..N {
            let (spec, state) = (&self.specs[j], &mut self.states[j]);
            if step.is_multiple_of(self.steps_per_period[j]) {
                state.firmware(spec, q[j]);
                if state.saturated {
                    saturated |= 1 << j;
                }
            }
            torque[j] = state.torque(spec, qd[j], dt);
        }
        (torque, saturated)
    }

    /// The servos' goals, targets, duties and gaps now.
    pub fn record(&self) -> ServoRecord<N> {
        ServoRecord {
            goal: JointVector::from_fn(|j, _| self.states[j].goal),
            target: JointVector::from_fn(|j, _| self.states[j].target),
            duty: JointVector::from_fn(|j, _| self.states[j].duty),
            gap: JointVector::from_fn(|j, _| self.states[j].gap),
        }
    }
}
