//! The setup's servos in a study: the hosts that replace the torque controllers, the bus's
//! period against the simulation's step, the P register a sweep varies, and `[servo_bus]`
//! checked into the servos' addresses and register mapping.

pub use crate::app::bus::mapping::ServoBus;
use crate::app::setup::file::Setup;
use anyhow::{Result, bail};
use chessarm_core::control::choice::{ControllerKind, ControllerSpec};
use chessarm_core::sim::actuator::{Actuator, Actuators, profiles};

/// With servos, the hosts the setup's `--servo-command` asks for (their gains unused) and a
/// note for the person that they replace the torque controllers; `None` with torque motors.
pub fn servo_hosts(setup: &Setup) -> Option<(Vec<ControllerSpec>, String)> {
    setup.actuators.take_positions().then_some(())?;
    let note = format!(
        "servos ({}): the host sends goal positions at {} Hz ({}); the torque controllers are not used\n",
        setup.actuator_names.join(", "),
        setup.bus_rate,
        setup.servo_commands.iter().map(|c| c.name()).collect::<Vec<_>>().join(", ")
    );
    let hosts = Some(
        setup
            .servo_commands
            .iter()
            .map(|command| ControllerSpec {
                name: command.name().to_string(),
                kind: ControllerKind::ServoHost(*command),
                gains: chessarm_core::control::gains::Gains::uniform(1.0, 1.0, 0.0).expect("positive gains"),
                knows_friction: false,
            })
            .collect(),
    );
    hosts.map(|hosts| (hosts, note))
}

/// Whether a controller of `kind` cancels the inertia of the piece it is told of: every torque
/// controller and the `feedforward` host do; the `plain` host ignores the piece and `sag` only
/// its weight, so a carried piece's whole mass is their tracking budget's mass error.
pub fn cancels_inertia(kind: &ControllerKind) -> bool {
    !matches!(
        kind,
        ControllerKind::ServoHost(
            chessarm_core::control::servo_host::ServoCommand::Plain
                | chessarm_core::control::servo_host::ServoCommand::Sag
        )
    )
}

/// The controller's period: with servos, the bus's (`1 / --bus-rate`); else `torque_period`, s.
pub fn control_period(setup: &Setup, torque_period: f64) -> f64 {
    if setup.actuators.take_positions() { 1.0 / setup.bus_rate } else { torque_period }
}

/// Refuses, before any work, a bus period (`1 / --bus-rate`) that is not a whole number of the
/// simulation's time steps `dt` (`dt_flag` the flag that gave it, if one did): the simulated servos take
/// their goals at whole steps, and the simulation would refuse at its first move.
///
/// # Errors
///
/// The period is not a whole multiple of `dt`, naming both flags as typed.
pub fn check_bus_period(setup: &Setup, dt: f64, dt_flag: &str) -> anyhow::Result<()> {
    if !setup.actuators.take_positions() {
        return Ok(());
    }
    let period = 1.0 / setup.bus_rate;
    let ratio = period / dt;
    if ratio.round() < 1.0 || (ratio - ratio.round()).abs() > 1e-9 * ratio {
        let show = crate::app::resources::show;
        anyhow::bail!(
            "--bus-rate {} Hz (a goal every {} s) must be a whole multiple of the simulation's time step{dt_flag} {} s: \
             e.g. --bus-rate {}, or a smaller time step",
            show(setup.bus_rate),
            show(period),
            show(dt),
            show(1.0 / (ratio.round().max(1.0) * dt))
        );
    }
    Ok(())
}

/// `settings` driving the setup's servos or steppers (their host at the bus's period); left
/// as they are with torque motors.
pub fn drive(setup: &Setup, settings: &mut chessarm_chess::play::PlaySettings) {
    if setup.actuators.take_positions() {
        settings.actuators = setup.actuators;
        settings.control_period = 1.0 / setup.bus_rate;
    }
}

/// Each joint's servo's P register conversion, duty per rad per unit of the register: a
/// built-in servo's, or the `base`'s of a user's table (`None`: a torque motor, a stepper, or
/// a table without a base, whose P has no register to sweep).
pub fn p_register_conversions(setup: &Setup) -> [Option<f64>; 4] {
    std::array::from_fn(|j| {
        let name = &setup.actuator_names[j];
        let base = match setup.actuator_tables.get(name) {
            Some(table) => table.base.as_deref()?,
            None => name.as_str(),
        };
        profiles::profile(base).map(|p| p.duty_per_rad_per_p)
    })
}

/// `actuators` with every servo's P loop at the register value `p` (`conversions` from
/// [`p_register_conversions`]).
pub fn with_p_register(actuators: &Actuators<4>, conversions: &[Option<f64>; 4], p: f64) -> Actuators<4> {
    let mut out = *actuators;
    for (joint, conversion) in out.joints.iter_mut().zip(conversions) {
        if let (Actuator::Servo(spec), Some(conversion)) = (joint, conversion) {
            spec.kp = p * conversion;
        }
    }
    out
}

impl ServoBus {
    /// The setup's bus: its `[servo_bus]` table over the defaults, checked.
    pub fn of(setup: &Setup) -> Result<Self> {
        let counts_per_revolution = setup.actuators.joints.map(|a| a.counts_per_revolution().unwrap_or(f64::NAN));
        let file = setup.servo_bus.clone().unwrap_or_default();
        let four = |field: &str, n: usize| -> Result<()> {
            if n != 4 {
                bail!("servo_bus.{field} has {n} values; give one per arm joint (4)");
            }
            Ok(())
        };
        let ids: [u8; 4] = match &file.ids {
            Some(ids) => {
                four("ids", ids.len())?;
                std::array::from_fn(|j| ids[j])
            }
            None => [1, 2, 3, 4],
        };
        for (j, id) in ids.iter().enumerate() {
            if *id > 252 || ids[..j].contains(id) {
                bail!("servo_bus.ids = {ids:?}: IDs must be distinct and 0–252 (253–254 are the buses' own)");
            }
        }
        let directions: [f64; 4] = match &file.directions {
            Some(d) => {
                four("directions", d.len())?;
                if let Some(bad) = d.iter().find(|v| **v != 1 && **v != -1) {
                    bail!("servo_bus.directions = {d:?}: {bad} is not 1 or -1");
                }
                std::array::from_fn(|j| f64::from(d[j]))
            }
            None => [1.0; 4],
        };
        let zero_ticks: [f64; 4] = match &file.zero_ticks {
            Some(z) => {
                four("zero_ticks", z.len())?;
                if let Some(bad) = z.iter().find(|v| !(v.is_finite() && v.fract() == 0.0)) {
                    bail!("servo_bus.zero_ticks = {z:?}: {bad} is not a whole number of ticks");
                }
                std::array::from_fn(|j| z[j])
            }
            None => counts_per_revolution.map(|c| (c / 2.0).round()),
        };
        let protocol = file.protocol.or_else(|| {
            let of = |name: &String| {
                crate::app::bus::Protocol::of_servo(name).or_else(|| {
                    setup
                        .actuator_tables
                        .get(name)
                        .and_then(|t| t.base.as_deref())
                        .and_then(crate::app::bus::Protocol::of_servo)
                })
            };
            let each: Vec<Option<crate::app::bus::Protocol>> = setup.actuator_names.iter().map(of).collect();
            each[0].filter(|p| each.iter().all(|e| *e == Some(*p)))
        });
        let gripper = match (file.gripper_id, file.gripper_open_ticks, file.gripper_closed_ticks) {
            (None, None, None) => None,
            (Some(id), Some(open), Some(closed)) => {
                if id > 252 || ids.contains(&id) {
                    bail!("servo_bus.gripper_id = {id}: give an ID 0–252 that no joint's servo has ({ids:?})");
                }
                // The gripper's servo is taken to have both vendors' 12-bit register.
                for (field, tick) in [("gripper_open_ticks", open), ("gripper_closed_ticks", closed)] {
                    if !(0..=4095).contains(&tick) {
                        bail!("servo_bus.{field} = {tick}: a gripper servo's goal is a tick 0–4095");
                    }
                }
                Some(crate::app::bus::driver::GripperServo { id, open, closed })
            }
            _ => bail!("servo_bus: give gripper_id, gripper_open_ticks and gripper_closed_ticks together (or none)"),
        };
        let bus = Self { ids, directions, zero_ticks, counts_per_revolution, protocol, gripper };
        // Every angle the joint may take must be a tick of its servo's register (a joint that
        // turns a whole turn, ±π, may end on the register's wrap: each goal sent is checked too).
        for j in 0..4 {
            let (lower, upper) = setup.user_limits(j);
            let ticks = [bus.ticks(j, lower), bus.ticks(j, upper)];
            if let Some(tick) = ticks.iter().find(|t| !(**t >= 0.0 && **t <= counts_per_revolution[j])) {
                bail!(
                    "servo_bus.zero_ticks = {}: joint {}'s limits [{lower:.4}, {upper:.4}] rad reach tick {tick}, outside its \
                     servo's 0–{}; give the tick of the joint's zero",
                    zero_ticks[j],
                    j + 1,
                    counts_per_revolution[j] - 1.0
                );
            }
        }
        Ok(bus)
    }
}

/// The servo columns of a run's CSV (simulate's and play's): the goals and internal targets
/// (rad), duties (−1…1) and backlash gaps (rad) per joint.
pub fn servo_columns() -> impl Iterator<Item = String> {
    ["goal", "target", "duty", "gap"].into_iter().flat_map(|prefix| crate::app::output::numbered(prefix, 4))
}

/// Appends a record's [`servo_columns`] values (in the setup's sense), if servos drive it.
pub fn push_servo_values(
    row: &mut Vec<f64>,
    record: &chessarm_core::sim::StepRecord<4>,
    convention: &crate::app::setup::file::JointConvention,
) {
    if let Some(servo) = &record.servo {
        for part in [servo.goal, servo.target, servo.duty, servo.gap] {
            row.extend(convention.user(part));
        }
    }
}

/// The wiring of the setup's servos for the real arm's driver.
///
/// # Errors
///
/// The joints have no servos, or servos of no protocol chessarm speaks; a bad `[servo_bus]`.
pub fn wiring(setup: &Setup) -> Result<crate::app::bus::arm::Wiring> {
    if !setup.actuators.take_positions() {
        bail!(
            "--port and --dry-run drive servos: give them with --actuator (e.g. sts3215 for the SO-101, xm430 for the OpenManipulator-X)"
        );
    }
    let bus = ServoBus::of(setup)?;
    let Some(protocol) = bus.protocol else {
        bail!(
            "the servos ({}) speak neither Feetech's nor Dynamixel's protocol; give [servo_bus] protocol",
            setup.actuator_names.join(", ")
        );
    };
    Ok(crate::app::bus::arm::Wiring {
        bus,
        protocol,
        joint_names: setup.joint_names.clone(),
        signs: setup.convention.signs,
        limits: std::array::from_fn(|j| setup.user_limits(j)),
        velocity_limits: std::array::from_fn(|j| setup.arm.link(j).limits.velocity),
        bus_rate: setup.bus_rate,
    })
}
