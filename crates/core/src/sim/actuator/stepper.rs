//! A stepper motor with a gearbox, driven open loop by a step generator (A4988/TMC2209 style).
//!
//! Angles and torques at the output shaft (through the gear), SI units.
//!
//! **Step generator**, every `period` seconds: the commanded angle moves toward the goal at most
//! `max_speed` (rad/s at the output) and, where set, changing speed by at most
//! `max_acceleration` (rad/s²), braking to stop on the goal; it is a whole number of
//! microsteps, `r = 2π / (steps_per_revolution · microsteps · gear_ratio)` rad each.
//!
//! **Motor**: a hybrid stepper of `p = steps_per_revolution / 4` pole pairs pulls its rotor
//! toward the commanded angle with the torque `τ = τ_max(|q̇|) sin(n (θ_c − q))`, `n = p · gear
//! ratio` electrical radians per output radian, evaluated at every stage of the plant's
//! integrator (its magnetic spring, `n τ_max` N·m/rad, is stiff). The pull-out torque
//! `τ_max(ω)` is the holding torque up to the corner speed, where the driver's voltage stops
//! forcing the rated current through the windings, and falls as `τ_hold ω_c / ω` above it.
//! The rotor's inertia (reflected through the gear) and the gearbox's friction are the plant's.
//!
//! **Lost steps**: the rotor rests in a well of the field every `2π / n` of output angle. When
//! the load pulls it more than half a well from the commanded angle (`|n (θ_c − q)| > π`), it
//! falls into the next: four full steps lost, which the open-loop host does not know. They are
//! counted (per joint, with their sign) as the rotor crosses from well to well.

use std::f64::consts::{PI, TAU};

/// A geared stepper and its driver (see the module's documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepperSpec {
    /// Full steps per motor revolution (200 for a 1.8° motor).
    pub steps_per_revolution: f64,
    /// Microsteps per full step the driver makes.
    pub microsteps: f64,
    /// Motor turns per output turn.
    pub gear_ratio: f64,
    /// Holding torque at the output (motor holding × ratio × the gear's efficiency), N·m.
    pub holding_torque: f64,
    /// Output speed above which the pull-out torque falls as 1/speed, rad/s.
    pub corner_speed: f64,
    /// Rotor inertia reflected through the gear, kg·m².
    pub armature: f64,
    /// Gear friction at the output: Coulomb, N·m, and viscous (with the motor's damping),
    /// N·m·s/rad.
    pub coulomb_friction: f64,
    pub viscous_friction: f64,
    /// The step generator's speed (rad/s) and acceleration (rad/s²) limits at the output, and
    /// its update period, s.
    pub max_speed: f64,
    pub max_acceleration: f64,
    pub period: f64,
}

impl StepperSpec {
    /// Electrical radians per output radian, `n = steps_per_revolution / 4 · gear_ratio`.
    pub fn electrical_per_output(&self) -> f64 {
        self.steps_per_revolution / 4.0 * self.gear_ratio
    }

    /// One microstep at the output, rad.
    pub fn resolution(&self) -> f64 {
        TAU / (self.steps_per_revolution * self.microsteps * self.gear_ratio)
    }

    /// `angle` (rad) as the nearest whole microstep, rad.
    pub fn quantise(&self, angle: f64) -> f64 {
        (angle / self.resolution()).round() * self.resolution()
    }

    /// The pull-out torque at the output speed `speed` (rad/s), N·m.
    pub fn pull_out_torque(&self, speed: f64) -> f64 {
        let speed = speed.abs();
        if speed <= self.corner_speed { self.holding_torque } else { self.holding_torque * self.corner_speed / speed }
    }

    /// The motor's torque at the output for the commanded angle `commanded` and the output's
    /// angle `q` (rad) and speed `qd` (rad/s), N·m.
    #[inline(always)]
    pub fn torque(&self, commanded: f64, q: f64, qd: f64) -> f64 {
        self.pull_out_torque(qd) * (self.electrical_per_output() * (commanded - q)).sin()
    }

    /// The static lag of the output behind the commanded angle holding a load `load` (N·m), rad:
    /// `asin(τ / τ_hold) / n` (`None` beyond the holding torque: the rotor slips).
    pub fn static_lag(&self, load: f64) -> Option<f64> {
        let ratio = load / self.holding_torque;
        (ratio.abs() <= 1.0).then(|| ratio.asin() / self.electrical_per_output())
    }

    /// The first field that is out of range: its name, its value and why.
    pub fn invalid_field(&self) -> Option<(&'static str, f64, &'static str)> {
        let positive = [
            ("steps_per_revolution", self.steps_per_revolution),
            ("microsteps", self.microsteps),
            ("gear_ratio", self.gear_ratio),
            ("holding_torque", self.holding_torque),
            ("corner_speed", self.corner_speed),
            ("max_speed", self.max_speed),
            ("period", self.period),
        ];
        let non_negative = [
            ("armature", self.armature),
            ("coulomb_friction", self.coulomb_friction),
            ("viscous_friction", self.viscous_friction),
            ("max_acceleration", self.max_acceleration),
        ];
        if let Some(invalid) = super::out_of_range(&positive, &non_negative) {
            return Some(invalid);
        }
        if self.steps_per_revolution % 4.0 != 0.0 {
            return Some(("steps_per_revolution", self.steps_per_revolution, "must be a multiple of 4"));
        }
        None
    }
}

/// A stepper's state between plant steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepperState {
    /// Latest goal, rad (whole microsteps).
    pub goal: f64,
    /// Commanded angle (whole microsteps), rad, and its speed, rad/s.
    pub commanded: f64,
    pub speed: f64,
    /// The well of the field the rotor is in, counted from the commanded one at the start.
    pub well: i64,
    /// Full steps lost so far (positive: the output fell behind an increasing command).
    pub lost_steps: i64,
}

impl StepperState {
    /// Holding `goal` (rad) still, the rotor in the commanded well.
    pub fn holding(spec: &StepperSpec, goal: f64) -> Self {
        Self { goal, commanded: spec.quantise(goal), speed: 0.0, well: 0, lost_steps: 0 }
    }

    /// One period of the step generator.
    pub fn generate(&mut self, spec: &StepperSpec) {
        let distance = self.goal - self.commanded;
        self.speed =
            super::servo::next_target_speed(spec.max_speed, spec.max_acceleration, spec.period, distance, self.speed);
        let next = self.commanded + self.speed * spec.period;
        let next = if (self.goal - next) * distance <= 0.0 { self.goal } else { next };
        self.commanded = spec.quantise(next);
    }

    /// After a plant step, with the output at `q` (rad): the well the rotor is in, and the
    /// steps lost if it changed.
    pub fn count_slips(&mut self, spec: &StepperSpec, q: f64) {
        let well = ((spec.electrical_per_output() * (q - self.commanded) + PI) / TAU).floor() as i64;
        if well != self.well {
            // Each well is an electrical period: four full steps.
            self.lost_steps -= 4 * (well - self.well);
            self.well = well;
        }
    }
}
