//! Built-in servos with published parameters, each number with its source.
//!
//! The gearmotor of each is the DC model of [`super::servo`], fitted where an identification
//! exists (Rhoban's BAM for the STS3215) and otherwise taken from the datasheet's two points,
//! the no-load speed and the stall torque at the rated voltage: `kt = u V / ω₀` (back-EMF
//! constant, from the speed at the largest duty `u`) and `R = kt u V / τ_stall` (so that duty at
//! rest gives the stall torque). That pair reproduces the datasheet's torque–speed line; the winding current it
//! implies is lower than the datasheet's stall current, the gear's losses being lumped into the
//! two constants. Figures marked *estimate* have no published value; they are chosen from the
//! nearest published servo and said so in [`Profile::sources`].
//!
//! The position gain is given as the firmware's register (what a maker writes on the bus) and
//! converted here: Feetech STS, duty per rad = P × 0.166 (BAM's oscilloscope measurement of the
//! STS3215); Dynamixel X, duty per rad = P/128 × 4096/2π / 885 = P × 0.0057548 (ROBOTIS
//! e-manual: `KPP = P/128`, error in pulses, PWM in units of 1/885).

use super::Actuator;
use super::servo::ServoSpec;
use super::stepper::StepperSpec;

/// Feetech STS: PWM duty per rad of error per unit of the P register (BAM,
/// `bam/feetech/actuator.py`: `error_gain = 0.166`, measured with an oscilloscope).
pub const FEETECH_DUTY_PER_RAD_PER_P: f64 = 0.166;
/// Dynamixel X (Protocol 2.0): `(1/128) · (4096/2π) / 885` duty per rad per unit of Position P
/// Gain (ROBOTIS e-manual, Position PID Gain: `KPP = P/128`; PWM Limit 885 = 100 %).
pub const DYNAMIXEL_DUTY_PER_RAD_PER_P: f64 = 4096.0 / std::f64::consts::TAU / 128.0 / 885.0;

/// A built-in servo: its name (as `--actuator` and `[[links]] actuator` spell it), what it is,
/// its P register's default and conversion, its parameters, and the source of each.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    pub name: &'static str,
    pub description: &'static str,
    /// The P gain register's factory value, and duty per rad of error per unit of it.
    pub p_register: f64,
    pub duty_per_rad_per_p: f64,
    /// The servo with the factory P gain.
    pub spec: ServoSpec,
    /// Where each number comes from.
    pub sources: &'static str,
}

impl Profile {
    /// The servo with the P register set to `p` (register units).
    pub fn with_p_register(&self, p: f64) -> ServoSpec {
        ServoSpec { kp: p * self.duty_per_rad_per_p, ..self.spec }
    }
}

const DEGREE: f64 = std::f64::consts::PI / 180.0;
/// Feetech STS3215's internal target speed limit: 3400 counts/s (BAM's default `max_velocity`,
/// fitted 5.10–5.29 rad/s).
const STS3215_TARGET_SPEED: f64 = 3400.0 * std::f64::consts::TAU / 4096.0;
/// STS3215 rotor inertia behind its 345:1 gear (BAM's fitted armature 0.0261 kg·m² / 345²),
/// kg·m²: the estimate for the Dynamixels' armature, which ROBOTIS does not publish.
const SMALL_ROTOR_INERTIA: f64 = 0.0261 / (345.0 * 345.0);

/// The 7.4 V STS3215 (numbers and sources in its profile); the 12 V one has its gear train and
/// firmware.
const STS3215: ServoSpec = ServoSpec {
    supply_voltage: 7.4,
    resistance: 2.48,
    torque_constant: 1.178,
    max_torque: 1.91,
    armature: 0.0261,
    coulomb_friction: 0.0515,
    viscous_friction: 0.0599,
    backlash: 1.0 * DEGREE,
    counts_per_revolution: 4096.0,
    period: 1e-3,
    kp: 32.0 * FEETECH_DUTY_PER_RAD_PER_P,
    ki: 0.0,
    kd: 0.0,
    max_duty: 0.97,
    deadband: std::f64::consts::TAU / 4096.0,
    max_target_speed: STS3215_TARGET_SPEED,
    max_target_acceleration: 0.0,
};

/// The XL430-W250 (numbers and sources in its profile); the XM430 has its firmware and its
/// estimates of the friction and the backlash.
const XL430: ServoSpec = ServoSpec {
    supply_voltage: 11.1,
    // kt = 11.1 V / 5.97 rad/s; R = kt · 11.1 V / 1.4 N·m.
    resistance: 14.74,
    torque_constant: 1.859,
    max_torque: 1.4,
    armature: SMALL_ROTOR_INERTIA * 258.5 * 258.5,
    coulomb_friction: 0.0515,
    viscous_friction: 0.0599,
    backlash: 0.25 * DEGREE,
    counts_per_revolution: 4096.0,
    period: 1e-3,
    kp: 640.0 * DYNAMIXEL_DUTY_PER_RAD_PER_P,
    ki: 0.0,
    kd: 0.0,
    max_duty: 1.0,
    deadband: 0.0,
    max_target_speed: 0.0,
    max_target_acceleration: 0.0,
};

/// The built-in servos.
pub const PROFILES: [Profile; 5] = [
    Profile {
        name: "sts3215",
        description: "Feetech STS3215 (7.4 V, 1:345), the SO-100/SO-101's servo",
        p_register: 32.0,
        duty_per_rad_per_p: FEETECH_DUTY_PER_RAD_PER_P,
        spec: STS3215,
        sources: "R 2.48 Ω, kt 1.178 N·m/A, armature 0.0261 kg·m², Coulomb 0.0515 N·m, viscous 0.0599 N·m·s/rad: \
                  Rhoban BAM's identification (bam/params/feetech_sts3215_7_4V/m1.json); P 32 (factory; LeRobot writes 16) \
                  × 0.166 duty/rad, max duty 0.97, target speed 3400 counts/s: BAM bam/feetech/actuator.py; stall 1.91 N·m \
                  (19.5 kg·cm at 7.4 V) and 4096 counts: Feetech/Waveshare ST3215 datasheet — the fitted winding gives 3.41 N·m \
                  at full duty, so the datasheet's figure is the firmware's current protection, modelled as max_torque; \
                  backlash 1°: measured on the 12 V STS3215 (robonine.com test, SO-ARM100 issue 134; datasheet ≤ 0.5°); \
                  period 1 ms: estimate (the STS3250's datasheet: 1 ms position update); deadband 1 count: estimate \
                  (CW/CCW dead zone registers); D and I 0 (LeRobot's D 32 has no published scale).",
    },
    Profile {
        name: "sts3215-12v",
        description: "Feetech STS3215-C018 (12 V, 1:345), the SO-101 follower's servo",
        p_register: 32.0,
        duty_per_rad_per_p: FEETECH_DUTY_PER_RAD_PER_P,
        spec: ServoSpec {
            supply_voltage: 12.0,
            // kt = 0.97·12 V / 4.71 rad/s; R = kt·0.97·12 V / 3.43 N·m (the measured stall).
            resistance: 8.38,
            torque_constant: 2.47,
            max_torque: 2.94,
            coulomb_friction: 0.114,
            ..STS3215
        },
        sources: "no-load 45 rpm (4.71 rad/s) and stall 30 kg·cm (2.94 N·m, max_torque) at 12 V: Feetech C018 datasheet via \
                  robonine.com's test, which measured 35 kg·cm (3.43 N·m) at stall and ~1° backlash; kt = 0.97·12/4.71 and \
                  R from the measured stall (datasheet method of this module); Coulomb 0.114 N·m: K-Scale's identification \
                  of the 12 V STS3215 (frictionloss); armature and viscous friction: the 7.4 V STS3215's BAM fit (same gear \
                  train; estimate); firmware as sts3215.",
    },
    Profile {
        name: "xl430",
        description: "ROBOTIS Dynamixel XL430-W250-T (11.1 V, 258.5:1), the Interbotix arms' servo",
        p_register: 640.0,
        duty_per_rad_per_p: DYNAMIXEL_DUTY_PER_RAD_PER_P,
        spec: XL430,
        sources: "stall 1.4 N·m and no-load 57 rpm (5.97 rad/s) at 11.1 V, 258.5:1, 4096 pulses, Position P 640, PWM limit \
                  885 (duty 1), profile velocity and acceleration 0 (unlimited): ROBOTIS e-manual XL430-W250; kt and R by \
                  this module's datasheet method; armature: the STS3215's rotor (BAM) behind 258.5:1 (estimate: not \
                  published); friction: the STS3215's (estimate); backlash 0.25°: ROBOTIS's figure for the X series' \
                  larger XM540 (estimate); period 1 ms: estimate; D 4000 left out (its time base is unpublished; the \
                  XM430's factory D is 0).",
    },
    Profile {
        name: "xm430",
        description: "ROBOTIS Dynamixel XM430-W350-T (12 V, 353.5:1), the OpenManipulator-X's servo",
        p_register: 800.0,
        duty_per_rad_per_p: DYNAMIXEL_DUTY_PER_RAD_PER_P,
        spec: ServoSpec {
            supply_voltage: 12.0,
            // kt = 12 V / 4.82 rad/s; R = kt · 12 V / 4.1 N·m.
            resistance: 7.287,
            torque_constant: 2.490,
            max_torque: 4.1,
            armature: SMALL_ROTOR_INERTIA * 353.5 * 353.5,
            kp: 800.0 * DYNAMIXEL_DUTY_PER_RAD_PER_P,
            ..XL430
        },
        sources: "stall 4.1 N·m and no-load 46 rpm (4.82 rad/s) at 12 V, 353.5:1, 4096 pulses, Position P 800, I 0, D 0, PWM \
                  limit 885: ROBOTIS e-manual XM430-W350; kt and R by this module's datasheet method; armature: the STS3215's \
                  rotor (BAM) behind 353.5:1 (estimate); friction: the STS3215's (estimate); backlash 0.25°: ROBOTIS's XM540 \
                  figure (estimate); period 1 ms: estimate.",
    },
    Profile {
        name: "mg996r",
        description: "TowerPro MG996R analog hobby servo (6 V), on 1000–2000 µs pulses",
        p_register: 1.0,
        duty_per_rad_per_p: 11.5,
        spec: ServoSpec {
            supply_voltage: 6.0,
            // kt = 6 V / 7.48 rad/s; R = kt · 6 V / 1.08 N·m.
            resistance: 4.456,
            torque_constant: 0.802,
            max_torque: 1.08,
            armature: 0.003,
            coulomb_friction: 0.03,
            viscous_friction: 0.02,
            backlash: 1.5 * DEGREE,
            // 1 µs of the 1000 µs pulse range over its 120°: 3000 counts a turn.
            counts_per_revolution: 3000.0,
            period: 0.02,
            kp: 11.5,
            ki: 0.0,
            kd: 0.0,
            max_duty: 1.0,
            deadband: 0.6 * DEGREE,
            max_target_speed: 0.0,
            max_target_acceleration: 0.0,
        },
        sources: "stall 11 kg·cm (1.08 N·m) and 0.14 s/60° (7.48 rad/s) at 6 V, 5 µs deadband (0.6° over its ~120° for \
                  1000 µs), 50 Hz pulses: TowerPro MG996R datasheet; kt and R by this module's datasheet method; an analog \
                  servo drives its motor once per pulse frame (period 20 ms); the pot's reading and the host's 1 µs pulse \
                  steps as 3000 counts a turn; gain 11.5 duty/rad (full power at 5°), armature 0.003 kg·m², friction \
                  0.03 N·m + 0.02 N·m·s/rad and backlash 1.5°: estimates (no published values).",
    },
];

/// The built-in servo called `name`, if any.
pub fn profile(name: &str) -> Option<&'static Profile> {
    PROFILES.iter().find(|p| p.name == name)
}

/// The built-in servos' names, for messages.
pub fn names() -> Vec<&'static str> {
    PROFILES.iter().map(|p| p.name).collect()
}

/// A built-in stepper: its name, what it is, its parameters and their sources.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepperProfile {
    pub name: &'static str,
    pub description: &'static str,
    pub spec: StepperSpec,
    pub sources: &'static str,
}

/// A 1.8° NEMA 17 (17HS4401) behind a 5.18:1 planetary gearbox, on an A4988-class driver at 1/16
/// microsteps and 12 V.
pub const NEMA17: StepperProfile = StepperProfile {
    name: "nema17",
    description: "NEMA 17 stepper (17HS4401, 0.40 N·m) with a 5.18:1 planetary gearbox, 1/16 microsteps at 12 V",
    spec: StepperSpec {
        steps_per_revolution: 200.0,
        microsteps: 16.0,
        gear_ratio: 5.18,
        // 0.40 N·m × 5.18 × 0.9 (the gearbox's efficiency, an estimate).
        holding_torque: 0.40 * 5.18 * 0.9,
        // 1600 full steps/s at the motor (8 rev/s) through 5.18:1.
        corner_speed: 1600.0 / 200.0 * std::f64::consts::TAU / 5.18,
        armature: 5.4e-6 * 5.18 * 5.18,
        coulomb_friction: 0.05,
        // A chopper driver holds the rated current below the corner speed, so the windings'
        // back-EMF damps little there (kt²/R through the gear would be 0.49 N·m·s/rad, 79 % of
        // the holding torque at 3 rad/s); the gearbox's and the driver's losses: an estimate.
        viscous_friction: 0.05,
        max_speed: 3.0,
        max_acceleration: 20.0,
        period: 1e-3,
    },
    sources: "200 steps/rev, 0.40 N·m holding, 1.7 A, 1.5 Ω, 2.8 mH, rotor 54 g·cm²: the 17HS4401 datasheet (MotionKing \
              pattern); 5.18:1 planetary: the common NEMA 17 option (Phidgets' stepper primer); 1/16 microsteps: the \
              A4988's finest; corner speed: where 12 V drives the rated 1.7 A through 2.8 mH (ω_e L I = V, ≈ 1600 full \
              steps/s; estimate); viscous damping 0.05 N·m·s/rad (the driver holds the current, so little back-EMF damping below the \
              corner; an estimate); gearbox efficiency 0.9, Coulomb friction 0.05 N·m, step generator 3 rad/s \
              and 20 rad/s² at the output, 1 ms updates: estimates (no published values).",
};

/// The built-in actuator called `name` (a servo or a stepper), if any.
pub fn actuator(name: &str) -> Option<Actuator> {
    profile(name)
        .map(|p| Actuator::Servo(p.spec))
        .or_else(|| (name == NEMA17.name).then_some(Actuator::Stepper(NEMA17.spec)))
}

/// The built-in actuators' names (servos, then the stepper), for messages.
pub fn all_names() -> Vec<&'static str> {
    let mut names = names();
    names.push(NEMA17.name);
    names
}
