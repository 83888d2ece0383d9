//! A position servo as its firmware and its gearmotor make it behave (Feetech STS, Dynamixel X,
//! analog hobby servos).
//!
//! Every quantity is at the output shaft (through the gear) and SI: angles in rad, torques in
//! N·m, the winding's torque constant in N·m/A (equal to its back-EMF constant in V·s/rad).
//!
//! **Firmware**, every `period` seconds:
//! 1. the internal target moves toward the goal, at most `max_target_speed` (rad/s) and, where
//!    set, changing speed by at most `max_target_acceleration` (rad/s²), braking so as to stop
//!    on the goal (`|v| ≤ √(2 a |goal − target|)`); 0 means unlimited: the target is the goal;
//! 2. the encoder reads the output angle rounded to its counts, `q̂ = round(q / r) r` with
//!    `r = 2π / counts_per_revolution`;
//! 3. the error `e = target − q̂` gives the PWM duty
//!    `u = clamp(kp e + ki Σ e T − kd (q̂ − q̂₋) / T, ±max_duty)`, zero where `|e| ≤ deadband`
//!    (the integral stops while the duty is clamped: no wind-up).
//!
//! **Gearmotor** (a DC motor driven by the duty, as Rhoban's BAM models these servos): the
//! torque on the output is `τ = (kt/R) (u V − kt q̇)`, the winding's current `(u V − kt q̇)/R`
//! limited so that `|τ| ≤ max_torque` (the firmware's current protection, which sets the
//! datasheet's stall torque where the winding alone would give more). Over each plant step the
//! plant integrates the back-EMF's `−(kt²/R) q̇` (with the gear's Coulomb and viscous friction
//! and the rotor's inertia reflected through the gear, the armature:
//! [`super::Actuators::plant_model`]), and the servo holds the rest,
//! `clamp((kt/R)(u V − kt q̇₀), ±max_torque) + (kt²/R) q̇₀` at the step's starting speed `q̇₀`:
//! below the current limit exactly `(kt/R) u V`.
//!
//! **Backlash** of width `b` between the motor side and the output (the encoder is on the
//! output): the gap `δ = θ − q` (motor side less output) lies in `[−b/2, b/2]`. Engaged on a
//! side (`δ = ±b/2`), the motor drives the output while its push `(kt/R)(u V − kt q̇)` points
//! into that side; once it pulls away, the output runs free (no motor torque, the back-EMF's
//! damping on it cancelled) and the motor side, light next to the reflected load, turns at its
//! no-load speed for the duty, `θ̇ = u V / kt`, until the gap closes on either side. Between
//! reversals of the load the output hangs on one side, and the hysteresis between motor side
//! and output is the band `b`. Approximation: the armature stays with the output during a
//! crossing (its inertia is the plant's).

use std::f64::consts::TAU;

/// A position servo's gearmotor, gear and firmware (see the module's documentation). Angles at
/// the output, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoSpec {
    /// Supply voltage, V.
    pub supply_voltage: f64,
    /// Winding resistance, Ω.
    pub resistance: f64,
    /// Torque constant at the output (motor constant × gear ratio), N·m/A = V·s/rad.
    pub torque_constant: f64,
    /// Largest drive torque the firmware lets through (its current protection), N·m.
    pub max_torque: f64,
    /// Rotor inertia reflected through the gear, kg·m².
    pub armature: f64,
    /// Gear friction at the output: Coulomb, N·m, and viscous, N·m·s/rad (the back-EMF's
    /// damping `kt²/R` is apart).
    pub coulomb_friction: f64,
    pub viscous_friction: f64,
    /// Gear backlash, full width, rad.
    pub backlash: f64,
    /// Encoder (and goal) counts per output revolution.
    pub counts_per_revolution: f64,
    /// Firmware control period, s.
    pub period: f64,
    /// Position loop: PWM duty per rad of error, per rad·s of its integral, per rad/s of the
    /// output's measured speed.
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
    /// Largest PWM duty, in (0, 1].
    pub max_duty: f64,
    /// Error below which the firmware drives nothing, rad.
    pub deadband: f64,
    /// Internal target's speed (rad/s) and acceleration (rad/s²) limits; 0: unlimited.
    pub max_target_speed: f64,
    pub max_target_acceleration: f64,
}

impl ServoSpec {
    /// Drive torque per unit of duty at rest, `kt V / R`, N·m.
    pub fn torque_per_duty(&self) -> f64 {
        self.torque_constant * self.supply_voltage / self.resistance
    }

    /// Static stiffness of the position loop below saturation, `kp kt V / R`, N·m/rad: a load
    /// torque `τ` held still leaves the error `τ / stiffness` (plus up to a count and the
    /// deadband).
    pub fn stiffness(&self) -> f64 {
        self.kp * self.torque_per_duty()
    }

    /// Largest torque the servo holds still, N·m: `min(max_duty kt V / R, max_torque)`.
    pub fn stall_torque(&self) -> f64 {
        (self.max_duty * self.torque_per_duty()).min(self.max_torque)
    }

    /// Output speed at full duty without load or friction, `max_duty V / kt`, rad/s.
    pub fn no_load_speed(&self) -> f64 {
        self.max_duty * self.supply_voltage / self.torque_constant
    }

    /// The back-EMF's damping at the output, `kt² / R`, N·m·s/rad.
    pub fn back_emf_damping(&self) -> f64 {
        self.torque_constant * self.torque_constant / self.resistance
    }

    /// One count of the encoder, rad.
    pub fn resolution(&self) -> f64 {
        TAU / self.counts_per_revolution
    }

    /// `angle` (rad) as the nearest whole count, rad.
    pub fn quantise(&self, angle: f64) -> f64 {
        (angle / self.resolution()).round() * self.resolution()
    }

    /// The duty (clamped to ±`max_duty`) whose drive is `torque` (N·m) at the output speed
    /// `qd` (rad/s): `u = (τ R / kt + kt q̇) / V` — what a host that knows the motor asks for.
    pub fn duty_for(&self, torque: f64, qd: f64) -> f64 {
        let duty = (torque * self.resistance / self.torque_constant + self.torque_constant * qd) / self.supply_voltage;
        duty.clamp(-self.max_duty, self.max_duty)
    }

    /// The first field that is out of range: its name, its value and why.
    pub fn invalid_field(&self) -> Option<(&'static str, f64, &'static str)> {
        let positive = [
            ("supply_voltage", self.supply_voltage),
            ("resistance", self.resistance),
            ("torque_constant", self.torque_constant),
            ("max_torque", self.max_torque),
            ("counts_per_revolution", self.counts_per_revolution),
            ("period", self.period),
            ("kp", self.kp),
        ];
        let non_negative = [
            ("armature", self.armature),
            ("coulomb_friction", self.coulomb_friction),
            ("viscous_friction", self.viscous_friction),
            ("backlash", self.backlash),
            ("ki", self.ki),
            ("kd", self.kd),
            ("deadband", self.deadband),
            ("max_target_speed", self.max_target_speed),
            ("max_target_acceleration", self.max_target_acceleration),
        ];
        if let Some(invalid) = super::out_of_range(&positive, &non_negative) {
            return Some(invalid);
        }
        if !(self.max_duty > 0.0 && self.max_duty <= 1.0) {
            return Some(("max_duty", self.max_duty, "must be in (0, 1]"));
        }
        if self.counts_per_revolution.fract() != 0.0 {
            return Some(("counts_per_revolution", self.counts_per_revolution, "must be a whole number"));
        }
        if self.backlash >= 0.5 {
            return Some(("backlash", self.backlash, "must be below 0.5 rad"));
        }
        None
    }
}

/// One servo's state between plant steps: its firmware's and its gear's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoState {
    /// Latest goal, rad (whole counts).
    pub goal: f64,
    /// Internal target, rad, and its speed, rad/s.
    pub target: f64,
    pub target_speed: f64,
    /// Σ e T of the position loop, rad·s.
    pub integral: f64,
    /// Encoder reading at the previous firmware period, rad.
    pub measured: f64,
    /// PWM duty held until the next firmware period.
    pub duty: f64,
    /// Whether the latest period's duty was clamped at `max_duty`, and whether the latest
    /// step's current was at its limit (`max_torque`).
    pub saturated: bool,
    pub current_limited: bool,
    /// Backlash gap `θ − q`, rad, and the side engaged: +1, −1, or 0 while crossing.
    pub gap: f64,
    pub engaged: i8,
}

impl ServoState {
    /// Holding `goal` still at the output angle `q` (rad) under the load torque `load` (N·m,
    /// what the servo must deliver to hold): the target on the goal, the gap closed on the
    /// loaded side (open with no load).
    pub fn holding(spec: &ServoSpec, goal: f64, q: f64, load: f64) -> Self {
        let engaged = if spec.backlash == 0.0 || load == 0.0 { 0 } else { load.signum() as i8 };
        let measured = spec.quantise(q);
        let error = goal - measured;
        let duty =
            if error.abs() <= spec.deadband { 0.0 } else { (spec.kp * error).clamp(-spec.max_duty, spec.max_duty) };
        Self {
            goal,
            target: goal,
            target_speed: 0.0,
            integral: 0.0,
            measured,
            duty,
            saturated: false,
            current_limited: false,
            gap: f64::from(engaged) * spec.backlash / 2.0,
            engaged,
        }
    }

    /// One firmware period: the internal target toward the goal, the encoder read at the
    /// output angle `q` (rad), the new duty.
    pub fn firmware(&mut self, spec: &ServoSpec, q: f64) {
        let period = spec.period;
        self.target_speed = next_target_speed(
            spec.max_target_speed,
            spec.max_target_acceleration,
            period,
            self.goal - self.target,
            self.target_speed,
        );
        let next = self.target + self.target_speed * period;
        // On the goal once the step reaches it (no rounding left over).
        self.target = if (self.goal - next) * (self.goal - self.target) <= 0.0 { self.goal } else { next };
        let measured = spec.quantise(q);
        let error = self.target - measured;
        let speed = (measured - self.measured) / period;
        self.measured = measured;
        let (duty, saturated) = if error.abs() <= spec.deadband {
            (0.0, false)
        } else {
            let integral = self.integral + error * period;
            let raw = spec.kp * error + spec.ki * integral - spec.kd * speed;
            let duty = raw.clamp(-spec.max_duty, spec.max_duty);
            if duty == raw {
                self.integral = integral;
            }
            (duty, duty != raw)
        };
        self.duty = duty;
        self.saturated = saturated;
    }

    /// The torque on the output over a plant step of `dt` seconds from the output speed `qd`
    /// (rad/s), N·m, and the backlash gap moved on over the step. See the module's
    /// documentation for the law.
    pub fn torque(&mut self, spec: &ServoSpec, qd: f64, dt: f64) -> f64 {
        // The motor's torque at this speed, its current limited; held as the drive that, with
        // the plant's back-EMF damping, gives it.
        let unlimited = spec.torque_per_duty() * self.duty - spec.back_emf_damping() * qd;
        let push = unlimited.clamp(-spec.max_torque, spec.max_torque);
        self.current_limited = push != unlimited;
        let drive =
            if self.current_limited { push + spec.back_emf_damping() * qd } else { spec.torque_per_duty() * self.duty };
        if spec.backlash == 0.0 {
            return drive;
        }
        let half = spec.backlash / 2.0;
        let still_engaged = match self.engaged {
            1 => push >= 0.0,
            -1 => push <= 0.0,
            _ => false,
        };
        if still_engaged {
            return drive;
        }
        // Free: the motor side at its no-load speed for the duty, the output on its own.
        let motor_speed = self.duty * spec.supply_voltage / spec.torque_constant;
        self.engaged = 0;
        self.gap += (motor_speed - qd) * dt;
        if self.gap >= half {
            self.gap = half;
            self.engaged = 1;
            drive
        } else if self.gap <= -half {
            self.gap = -half;
            self.engaged = -1;
            drive
        } else {
            // The plant's model damps the output by kt²/R; free of the motor it is not.
            spec.back_emf_damping() * qd
        }
    }
}

/// A target generator's speed over the coming `period` (s), rad/s, `distance` (rad) from the
/// goal at `speed` (rad/s): the speed that reaches the goal this period, within `max_speed`
/// (rad/s; 0: none), and within `max_acceleration` (rad/s²; 0: none) of `speed` and of the
/// braking speed `√(2 a |distance|)`.
pub(crate) fn next_target_speed(max_speed: f64, max_acceleration: f64, period: f64, distance: f64, speed: f64) -> f64 {
    let mut wanted = distance / period;
    if max_speed > 0.0 {
        wanted = wanted.clamp(-max_speed, max_speed);
    }
    let a = max_acceleration;
    if a > 0.0 {
        let braking = (2.0 * a * distance.abs()).sqrt();
        wanted = wanted.clamp(-braking, braking);
        wanted = wanted.clamp(speed - a * period, speed + a * period);
    }
    wanted
}
