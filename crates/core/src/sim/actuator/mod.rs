//! The actuators between a controller's command and the plant's joint torques, one per joint:
//! today's torque motor (the command is the torque, clipped to the joint's limit and passed
//! through its lag), or a position servo that runs its own firmware loop on goal positions
//! ([`servo`]). Built-in servos with published parameters are in [`profiles`].

pub mod profiles;
pub mod servo;
pub mod spread;
pub mod stepper;

use crate::arm::dynamics::gravity_torques;
use crate::arm::link::Friction;
use crate::arm::model::{ArmModel, JointVector, ModelError};
use crate::control::CommandInterface;
use crate::control::servo_host::Drives;
pub use servo::{ServoSpec, ServoState};
pub use spread::{ActuatorSpread, DrawnActuators};
pub use stepper::{StepperSpec, StepperState};

/// The first of `positive` that is not finite and > 0, else the first of `non_negative` that is
/// not finite and ≥ 0: its name, its value and why.
fn out_of_range(
    positive: &[(&'static str, f64)],
    non_negative: &[(&'static str, f64)],
) -> Option<(&'static str, f64, &'static str)> {
    if let Some(&(name, value)) = positive.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
        return Some((name, value, "must be finite and > 0"));
    }
    non_negative
        .iter()
        .find(|(_, v)| !(v.is_finite() && *v >= 0.0))
        .map(|&(name, value)| (name, value, "must be finite and >= 0"))
}

/// What drives one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Actuator {
    /// A torque motor: the controller's torque, clipped to the joint's limit (and through the
    /// run's motor lag, [`crate::sim::SimConfig::torque_lag`]).
    Torque,
    /// A position servo on goal angles.
    Servo(ServoSpec),
    /// A geared stepper on goal angles, driven open loop by a step generator.
    Stepper(StepperSpec),
}

impl Actuator {
    /// The counts per output revolution the host can command and read: a servo's encoder
    /// counts, a stepper's microsteps; `None` for a torque motor.
    pub fn counts_per_revolution(&self) -> Option<f64> {
        match self {
            Actuator::Torque => None,
            Actuator::Servo(spec) => Some(spec.counts_per_revolution),
            Actuator::Stepper(spec) => Some(std::f64::consts::TAU / spec.resolution()),
        }
    }

    /// The goal offset (rad) that has this actuator deliver `torque` (N·m) at the speed `qd`
    /// (rad/s): a servo's `(u(τ, q̇) + kd q̇) / kp`; a stepper's lag `asin(τ / τ_max(q̇)) / n`
    /// (clamped to its pull-out torque); 0 for a torque motor, which takes no goal.
    pub fn goal_offset(&self, torque: f64, qd: f64) -> f64 {
        match self {
            Actuator::Torque => 0.0,
            Actuator::Servo(spec) => (spec.duty_for(torque, qd) + spec.kd * qd) / spec.kp,
            Actuator::Stepper(spec) => {
                let ratio = (torque / spec.pull_out_torque(qd)).clamp(-1.0, 1.0);
                ratio.asin() / spec.electrical_per_output()
            }
        }
    }

    /// The gear: armature (kg·m²), viscous (N·m·s/rad) and Coulomb (N·m) friction; none for a
    /// torque motor.
    pub fn gear(&self) -> (f64, f64, f64) {
        match self {
            Actuator::Torque => (0.0, 0.0, 0.0),
            Actuator::Servo(spec) => (spec.armature, spec.viscous_friction, spec.coulomb_friction),
            Actuator::Stepper(spec) => (spec.armature, spec.viscous_friction, spec.coulomb_friction),
        }
    }
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
    #[error("joint {joint}'s actuator: {field} = {value}: {reason}")]
    InvalidField { joint: usize, field: &'static str, value: f64, reason: &'static str },
    #[error(
        "joint {servo} has a servo or stepper and joint {torque} a torque motor: a controller sends either torques or goal positions, so all joints need the same kind"
    )]
    Mixed { servo: usize, torque: usize },
    #[error("joint {joint}'s actuator: its period {period} s must be a whole multiple of the time step {dt} s (--dt)")]
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

    /// The command these actuators take: goal positions if any joint has a servo or a stepper.
    pub fn interface(&self) -> CommandInterface {
        if self.joints.iter().any(|a| !matches!(a, Actuator::Torque)) {
            CommandInterface::Position
        } else {
            CommandInterface::Torque
        }
    }

    /// Whether the joints take goal positions (servos, steppers).
    pub fn take_positions(&self) -> bool {
        self.interface() == CommandInterface::Position
    }

    /// The largest torque each joint's actuator holds, N·m: a servo's stall torque, a stepper's
    /// holding torque; infinite for a torque motor (its limit is the joint's).
    pub fn torque_limits(&self) -> [f64; N] {
        self.joints.map(|a| match a {
            Actuator::Torque => f64::INFINITY,
            Actuator::Servo(spec) => spec.stall_torque(),
            Actuator::Stepper(spec) => spec.holding_torque,
        })
    }

    /// Checks every actuator's numbers, that no joint has a torque motor beside a position
    /// actuator, and (for a run with time step `dt`, s) that each update period is a whole
    /// number of steps.
    pub fn validate(&self, dt: f64) -> Result<(), ActuatorError> {
        let servo = self.joints.iter().position(|a| !matches!(a, Actuator::Torque));
        let torque = self.joints.iter().position(|a| matches!(a, Actuator::Torque));
        if let (Some(servo), Some(torque)) = (servo, torque) {
            return Err(ActuatorError::Mixed { servo: servo + 1, torque: torque + 1 });
        }
        for (j, joint) in self.joints.iter().enumerate() {
            let (invalid, period) = match joint {
                Actuator::Torque => continue,
                Actuator::Servo(spec) => (spec.invalid_field(), spec.period),
                Actuator::Stepper(spec) => (spec.invalid_field(), spec.period),
            };
            if let Some((field, value, reason)) = invalid {
                return Err(ActuatorError::InvalidField { joint: j + 1, field, value, reason });
            }
            let ratio = period / dt;
            if ratio.round() < 1.0 || (ratio - ratio.round()).abs() > 1e-9 * ratio {
                return Err(ActuatorError::Period { joint: j + 1, period, dt });
            }
        }
        Ok(())
    }

    /// How far from its goal the tool tip of `model` may come to rest, m: per joint the angle a
    /// servo holds still off its target — its deadband, one count of its encoder, and the
    /// error its loop's stiffness leaves against its gear's Coulomb friction,
    /// `deadband + 2π/counts + τ_c / (kp kt V / R)` — or a stepper's microstep, times the
    /// joint's longest lever to the tip ([`crate::arm::kinematics::longest_levers`]), summed. 0 with torque motors. A host that waits for the arm to be at a fine point can
    /// ask no better of these actuators: the tip settles anywhere within this of its goal.
    pub fn holding_band(&self, model: &ArmModel<N>) -> f64 {
        let levers = crate::arm::kinematics::longest_levers(model);
        (0..N)
            .map(|j| {
                let angle = match self.joints[j] {
                    Actuator::Torque => 0.0,
                    Actuator::Servo(spec) => {
                        spec.deadband + spec.resolution() + spec.coulomb_friction / spec.stiffness()
                    }
                    Actuator::Stepper(spec) => spec.resolution(),
                };
                angle * levers[j]
            })
            .sum()
    }

    /// `model` with each servo's gear in its joint: the armature as the rotor inertia, the gear's
    /// viscous friction plus the back-EMF's damping `kt²/R` and the gear's Coulomb friction as
    /// the joint's friction (replacing the link's own: the servo is the joint's drive), and the
    /// stall torque as the torque limit; a stepper's rotor, friction and holding torque alike.
    /// A torque motor's joint is left as it is.
    pub fn plant_model(&self, model: &ArmModel<N>) -> Result<ArmModel<N>, ModelError> {
        if self.interface() == CommandInterface::Torque {
            return Ok(*model);
        }
        let mut links = *model.links();
        for (link, joint) in links.iter_mut().zip(&self.joints) {
            match joint {
                Actuator::Torque => {}
                Actuator::Servo(spec) => {
                    link.rotor_inertia = spec.armature;
                    link.friction = Friction {
                        viscous: spec.viscous_friction + spec.back_emf_damping(),
                        coulomb: spec.coulomb_friction,
                    };
                    link.limits.torque = spec.stall_torque();
                }
                Actuator::Stepper(spec) => {
                    link.rotor_inertia = spec.armature;
                    link.friction = Friction { viscous: spec.viscous_friction, coulomb: spec.coulomb_friction };
                    link.limits.torque = spec.holding_torque;
                }
            }
        }
        model.with_links(links)
    }
}

/// The servo host sees the actuators through this.
impl<const N: usize> Drives<N> for Actuators<N> {
    fn interface(&self) -> CommandInterface {
        Actuators::interface(self)
    }

    fn goal_offset(&self, j: usize, torque: f64, qd: f64) -> f64 {
        self.joints[j].goal_offset(torque, qd)
    }

    fn gear(&self, j: usize) -> (f64, f64, f64) {
        self.joints[j].gear()
    }
}

/// One position actuator of a run: its specification and state.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Drive {
    Servo(ServoSpec, ServoState),
    Stepper(StepperSpec, StepperState),
}

/// The position actuators of a run (servos, steppers, one per joint): their specifications,
/// states, and how many plant steps each one's update period spans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionBank<const N: usize> {
    drives: [Drive; N],
    steps_per_period: [usize; N],
    /// Per joint, the torque held over the current plant step (a servo's drive; unused for a
    /// stepper, whose torque is evaluated at every stage).
    held: [f64; N],
}

/// What the position actuators did at one plant step (for plots and the observers).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoRecord<const N: usize> {
    /// Goal angles the host sent, rad (whole counts or microsteps).
    pub goal: JointVector<N>,
    /// The firmware's internal targets (a stepper's commanded angle), rad.
    pub target: JointVector<N>,
    /// PWM duties in [−1, 1] (a stepper's torque as a share of its pull-out torque).
    pub duty: JointVector<N>,
    /// Backlash gaps `θ − q`, rad (0 for a stepper).
    pub gap: JointVector<N>,
}

impl<const N: usize> PositionBank<N> {
    /// The position actuators of `actuators` (validated by [`Actuators::validate`], every joint
    /// a servo or a stepper) for a run with time step `dt` (s), holding `goal` (rad) at rest at
    /// `q` (rad) under the plant `model`'s gravity. `None` if a joint has a torque motor.
    pub fn holding(
        actuators: &Actuators<N>,
        dt: f64,
        model: &ArmModel<N>,
        goal: &JointVector<N>,
        q: &JointVector<N>,
    ) -> Option<Self> {
        let load = gravity_torques(model, q);
        // Placeholders, each replaced below.
        let mut drives = [Drive::Stepper(profiles::NEMA17.spec, StepperState::holding(&profiles::NEMA17.spec, 0.0)); N];
        let mut steps_per_period = [1; N];
        for j in 0..N {
            let (drive, period) = match actuators.joints[j] {
                Actuator::Torque => return None,
                Actuator::Servo(spec) => {
                    (Drive::Servo(spec, ServoState::holding(&spec, goal[j], q[j], load[j])), spec.period)
                }
                Actuator::Stepper(spec) => (Drive::Stepper(spec, StepperState::holding(&spec, goal[j])), spec.period),
            };
            drives[j] = drive;
            steps_per_period[j] = ((period / dt).round() as usize).max(1);
        }
        Some(Self { drives, steps_per_period, held: [0.0; N] })
    }

    /// Where actuators sent `goal` would come to rest under `model`'s gravity, rad: the output
    /// angles `q` at which each holds the load `g(q)` (a servo `stiffness · (goal − q) = g`, the
    /// load clamped to its stall torque; a stepper `τ_hold sin(n (goal − q)) = g`, clamped to its
    /// holding torque), by fixed-point iteration from the goal (a contraction: `g` changes by far
    /// less than the actuators' stiffness per rad). Counts and deadbands are ignored.
    pub fn settled(actuators: &Actuators<N>, model: &ArmModel<N>, goal: &JointVector<N>) -> JointVector<N> {
        let mut q = *goal;
        for _ in 0..50 {
            let load = gravity_torques(model, &q);
            let next = JointVector::<N>::from_fn(|j, _| match actuators.joints[j] {
                Actuator::Torque => goal[j],
                Actuator::Servo(spec) => {
                    let held = load[j].clamp(-spec.stall_torque(), spec.stall_torque());
                    goal[j] - held / spec.stiffness()
                }
                Actuator::Stepper(spec) => {
                    let held = load[j].clamp(-spec.holding_torque, spec.holding_torque);
                    goal[j] - spec.static_lag(held).unwrap_or(0.0)
                }
            });
            let change = (next - q).amax();
            q = next;
            if change < 1e-12 {
                break;
            }
        }
        q
    }

    /// Takes the host's goal angles (rad): each clamped to `[lower, upper]` of its joint and
    /// rounded to whole counts (microsteps), as the bus carries them. Returns the goals taken.
    pub fn send(&mut self, goal: &JointVector<N>, lower: &JointVector<N>, upper: &JointVector<N>) -> JointVector<N> {
        for j in 0..N {
            let resolution = match &self.drives[j] {
                Drive::Servo(spec, _) => spec.resolution(),
                Drive::Stepper(spec, _) => spec.resolution(),
            };
            // Rounded inside the limits: a limit between two counts takes the count inside.
            let clamped = goal[j].clamp(lower[j], upper[j]);
            let mut counted = (clamped / resolution).round() * resolution;
            if counted > upper[j] {
                counted -= resolution;
            } else if counted < lower[j] {
                counted += resolution;
            }
            match &mut self.drives[j] {
                Drive::Servo(_, state) => state.goal = counted,
                Drive::Stepper(_, state) => state.goal = counted,
            }
        }
        JointVector::from_fn(|j, _| self.goal(j))
    }

    fn goal(&self, j: usize) -> f64 {
        match &self.drives[j] {
            Drive::Servo(_, state) => state.goal,
            Drive::Stepper(_, state) => state.goal,
        }
    }

    /// Plant step `step` (of `dt` seconds) begins with the outputs at angles `q` (rad) and
    /// speeds `qd` (rad/s): each servo's firmware and each step generator runs at the steps
    /// that start its periods, and each servo's torque over the step is set. Returns the joints
    /// whose firmware ran and saturated (bit `j`).
    pub fn update(&mut self, step: usize, q: &JointVector<N>, qd: &JointVector<N>, dt: f64) -> u64 {
        let mut saturated = 0;
        for j in 0..N {
            let due = step.is_multiple_of(self.steps_per_period[j]);
            match &mut self.drives[j] {
                Drive::Servo(spec, state) => {
                    if due {
                        state.firmware(spec, q[j]);
                    }
                    self.held[j] = state.torque(spec, qd[j], dt);
                    // Counted once a firmware period: the duty or the current at its limit.
                    if due && (state.saturated || state.current_limited) {
                        saturated |= 1 << j;
                    }
                }
                Drive::Stepper(spec, state) => {
                    if due {
                        state.generate(spec);
                    }
                }
            }
        }
        saturated
    }

    /// The torques on the outputs at angles `q` (rad) and speeds `qd` (rad/s) inside the
    /// current plant step, N·m: a servo's held drive, a stepper's magnetic pull.
    #[inline(always)]
    pub fn torque_at(&self, q: &JointVector<N>, qd: &JointVector<N>) -> JointVector<N> {
        JointVector::from_fn(|j, _| match &self.drives[j] {
            Drive::Servo(..) => self.held[j],
            Drive::Stepper(spec, state) => spec.torque(state.commanded, q[j], qd[j]),
        })
    }

    /// The motors' torques on the outputs at angles `q` (rad) and speeds `qd` (rad/s), N·m: a
    /// servo's `(kt/R)(u V − kt q̇)` within its current limit (0 while its backlash is open), a
    /// stepper's pull. ([`PositionBank::torque_at`] holds a servo's drive, the plant adding the
    /// back-EMF.)
    pub fn motor_torque(&self, q: &JointVector<N>, qd: &JointVector<N>) -> JointVector<N> {
        JointVector::from_fn(|j, _| match &self.drives[j] {
            Drive::Servo(spec, state) => {
                if spec.backlash > 0.0 && state.engaged == 0 {
                    0.0
                } else {
                    self.held[j] - spec.back_emf_damping() * qd[j]
                }
            }
            Drive::Stepper(spec, state) => spec.torque(state.commanded, q[j], qd[j]),
        })
    }

    /// Whether any joint has a stepper (whose torque changes within a step).
    pub fn has_steppers(&self) -> bool {
        self.drives.iter().any(|d| matches!(d, Drive::Stepper(..)))
    }

    /// After a plant step, with the outputs at `q` (rad): the steppers' lost steps counted.
    pub fn after_step(&mut self, q: &JointVector<N>) {
        for j in 0..N {
            if let Drive::Stepper(spec, state) = &mut self.drives[j] {
                state.count_slips(spec, q[j]);
            }
        }
    }

    /// The actuators this bank runs.
    pub fn actuators(&self) -> Actuators<N> {
        Actuators {
            joints: self.drives.map(|d| match d {
                Drive::Servo(spec, _) => Actuator::Servo(spec),
                Drive::Stepper(spec, _) => Actuator::Stepper(spec),
            }),
        }
    }

    /// This bank for a new run with time step `dt` (s): the actuators' state as it is (goals,
    /// targets, backlash, step counts), the lost steps counted afresh.
    pub fn restarted(mut self, dt: f64) -> Self {
        for j in 0..N {
            let period = match &mut self.drives[j] {
                Drive::Servo(spec, _) => spec.period,
                Drive::Stepper(spec, state) => {
                    state.lost_steps = 0;
                    spec.period
                }
            };
            self.steps_per_period[j] = ((period / dt).round() as usize).max(1);
        }
        self
    }

    /// Full steps each joint's stepper lost (0 for a servo).
    pub fn lost_steps(&self) -> [i64; N] {
        std::array::from_fn(|j| match &self.drives[j] {
            Drive::Servo(..) => 0,
            Drive::Stepper(_, state) => state.lost_steps,
        })
    }

    /// The actuators' goals, targets, duties and gaps at outputs `q`, `qd`.
    pub fn record(&self, q: &JointVector<N>, qd: &JointVector<N>) -> ServoRecord<N> {
        let part = |f: &dyn Fn(&Drive, usize) -> f64| JointVector::<N>::from_fn(|j, _| f(&self.drives[j], j));
        ServoRecord {
            goal: part(&|_, j| self.goal(j)),
            target: part(&|d, _| match d {
                Drive::Servo(_, s) => s.target,
                Drive::Stepper(_, s) => s.commanded,
            }),
            duty: part(&|d, j| match d {
                Drive::Servo(_, s) => s.duty,
                Drive::Stepper(spec, s) => spec.torque(s.commanded, q[j], qd[j]) / spec.pull_out_torque(qd[j]),
            }),
            gap: part(&|d, _| match d {
                Drive::Servo(_, s) => s.gap,
                Drive::Stepper(..) => 0.0,
            }),
        }
    }
}
