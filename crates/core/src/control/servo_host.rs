//! What the robot's computer sends to position servos: goal angles at the bus rate, by one of
//! three strategies ([`ServoCommand`]). The servos' own loops ([`crate::sim::actuator::servo`])
//! do the rest; the host sends its goals without reading the servos back.
//!
//! A servo at rest holding a load torque `τ` settles where its P loop's duty drives `τ`:
//! `kp e = u` with `u = τ R / (kt V)`, the error `e = τ / (kp kt V / R)`. Moving at `q̇` its motor
//! also needs `kt q̇ / V` of duty against its back-EMF, and a derivative gain `kd` on the
//! measured speed takes `kd q̇` more. So to have the servo deliver `τ` at `(q, q̇)` the host
//! sends `goal = q + (u(τ, q̇) + kd q̇) / kp`, `u(τ, q̇) = (τ R / kt + kt q̇) / V` (clamped to the
//! duty the servo has).

use super::{CommandInterface, Controller, JointState, Reference};
use crate::arm::dynamics::{gravity_torques, inverse_dynamics};
use crate::arm::link::COULOMB_SMOOTHING;
use crate::arm::model::{ArmModel, JointVector, ModelError, Payload};

/// The slowest goal rate simulated, Hz: a goal every 0.1 s is already coarse beside a move's
/// 0.2-1 s phases (hobby servos take 50 Hz pulses; bus servos 100-1000 goals a second), and
/// slower goals stretch each move's simulation by whole periods (at 10⁻⁴ Hz, hours of
/// simulated waiting and gigabytes of records per move).
pub const MIN_BUS_RATE: f64 = 10.0;
/// The fastest goal rate, Hz: a sync write to four servos is ~30 bytes, 0.3 ms at 1 Mbaud and
/// 0.07 ms at the fastest buses' 4.5 Mbaud, so no bus carries more than ~10 000 a second.
pub const MAX_BUS_RATE: f64 = 10_000.0;

/// How the host computes the goals it sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ServoCommand {
    /// The planned angles: what most makers send. The servos sag under gravity and lag.
    #[default]
    Plain,
    /// The planned angles offset so that each servo's loop holds the planned angle against
    /// gravity `g(q)` (with the gripped piece the host is told of): gravity pre-compensation by
    /// goal offsets, for servos without a torque input.
    Sag,
    /// The planned angles offset by the whole inverse dynamics of the plan
    /// `M(q) q̈ + C(q, q̇) q̇ + g(q)`, the gears' armature and friction and the motors' back-EMF,
    /// sent half a bus period ahead so the held goal is centred on the plan.
    Feedforward,
}

impl ServoCommand {
    pub const ALL: [ServoCommand; 3] = [ServoCommand::Plain, ServoCommand::Sag, ServoCommand::Feedforward];

    /// As the command line spells it.
    pub fn name(self) -> &'static str {
        match self {
            ServoCommand::Plain => "plain",
            ServoCommand::Sag => "sag",
            ServoCommand::Feedforward => "feedforward",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// The drives of a servo arm's `N` joints, as the host knows them: which command they take,
/// the goal offset that has each deliver a torque, and each one's gear. The actuators beside
/// the plant are such drives; the host needs no more of them than this, so the controllers
/// stay below the simulation that runs them.
pub trait Drives<const N: usize>: Copy + std::fmt::Debug + Send + 'static {
    /// What the drives take: goal positions (servos, steppers) or joint torques (torque motors).
    fn interface(&self) -> CommandInterface;
    /// The goal offset (rad) that has joint `j`'s drive deliver `torque` (N·m) at the speed `qd`
    /// (rad/s); 0 for a torque motor.
    fn goal_offset(&self, j: usize, torque: f64, qd: f64) -> f64;
    /// Joint `j`'s gear: armature (kg·m²), viscous (N·m·s/rad) and Coulomb (N·m) friction;
    /// none for a torque motor.
    fn gear(&self, j: usize) -> (f64, f64, f64);
}

/// The host computer of a servo arm: a [`Controller`] whose commands are goal angles.
#[derive(Debug, Clone)]
pub struct ServoHost<const N: usize, D> {
    strategy: ServoCommand,
    /// The arm as the host knows it (without the servos' gears, which `drives` describe), with
    /// the payload it is told of.
    model: ArmModel<N>,
    drives: D,
}

impl<const N: usize, D: Drives<N>> ServoHost<N, D> {
    /// A host sending goals by `strategy` to the servos and steppers of `drives`, knowing the
    /// arm as `model` (its joints' rotor inertia and friction are the drives': the host takes
    /// them from `drives`). A joint with a torque motor is sent its planned angle.
    pub fn new(strategy: ServoCommand, model: ArmModel<N>, drives: D) -> Result<Self, ModelError> {
        let mut links = *model.links();
        for link in &mut links {
            link.rotor_inertia = 0.0;
            link.friction = Default::default();
        }
        Ok(Self { strategy, model: model.with_links(links)?, drives })
    }

    pub fn strategy(&self) -> ServoCommand {
        self.strategy
    }

    /// The goals for `reference`, `period` (s) the bus period.
    pub fn goals(&self, reference: &Reference<N>, period: f64) -> JointVector<N> {
        match self.strategy {
            ServoCommand::Plain => reference.q,
            ServoCommand::Sag => {
                let g = gravity_torques(&self.model, &reference.q);
                JointVector::from_fn(|j, _| reference.q[j] + self.drives.goal_offset(j, g[j], 0.0))
            }
            ServoCommand::Feedforward => {
                // Half a bus period ahead: q + q̇ h + q̈ h²/2, q̇ + q̈ h, h = T/2.
                let h = period / 2.0;
                let q = reference.q + reference.qd * h + reference.qdd * (h * h / 2.0);
                let qd = reference.qd + reference.qdd * h;
                let rigid = inverse_dynamics(&self.model, &q, &qd, &reference.qdd);
                JointVector::from_fn(|j, _| {
                    let (armature, viscous, coulomb) = self.drives.gear(j);
                    let gear =
                        armature * reference.qdd[j] + viscous * qd[j] + coulomb * (qd[j] / COULOMB_SMOOTHING).tanh();
                    q[j] + self.drives.goal_offset(j, rigid[j] + gear, qd[j])
                })
            }
        }
    }
}

impl<const N: usize, D: Drives<N>> Controller<N> for ServoHost<N, D> {
    fn name(&self) -> &str {
        self.strategy.name()
    }

    fn reset(&mut self) {}

    fn command(&mut self, _state: &JointState<N>, reference: &Reference<N>, period: f64) -> JointVector<N> {
        self.goals(reference, period)
    }

    fn interface(&self) -> CommandInterface {
        CommandInterface::Position
    }

    fn set_payload(&mut self, payload: Option<Payload>) -> Result<(), ModelError> {
        self.model = self.model.with_payload(payload)?;
        Ok(())
    }
}
