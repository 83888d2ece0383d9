//! The real arm in the live loop: each robot move's goal stream — the one the simulation
//! proved, at the bus rate, fine points' waits included — converted to the servos' ticks
//! (`[servo_bus]`) and sent by the [`Driver`], every goal checked on the wire.

use crate::app::bus::driver::{Driver, DriverError, Followed, TickGoal, Wire, WireLimits};
use crate::app::bus::mapping::ServoBus;
use crate::app::bus::port::{BAUD_RATE, SerialLine};
use anyhow::{Result, bail};
use chessarm_chess::play::{Handling, ServoGoal};
use std::path::Path;
use std::time::Duration;

/// The driven arm: its driver and how angles become ticks.
#[derive(Debug)]
pub struct RealArm {
    driver: Driver,
    bus: ServoBus,
    signs: [f64; 4],
    enabled: bool,
    /// Per robot move: what following it measured.
    pub followed: Vec<Followed>,
}

/// The arm's servos as the driver needs them: their addresses and ticks, the joints' names,
/// the sense of each joint (`signs`: the setup's angle = sign × the model's), the joints'
/// limits in the setup's sense (rad) and speed limits (rad/s), and the bus rate (Hz). Made
/// from a setup by `app::setup::servos::wiring`.
#[derive(Debug, Clone)]
pub struct Wiring {
    pub bus: ServoBus,
    pub protocol: crate::app::bus::Protocol,
    pub joint_names: [String; 4],
    pub signs: [f64; 4],
    pub limits: [(f64, f64); 4],
    pub velocity_limits: [f64; 4],
    pub bus_rate: f64,
}

/// How the driver is set up from the command line.
#[allow(missing_debug_implementations)]
pub struct ArmOptions<'a> {
    /// The serial device (`None` with `dry_run`).
    pub port: Option<&'a Path>,
    pub dry_run: bool,
    /// The largest distance of a goal from a joint's present position, rad.
    pub max_step: f64,
    pub reply_timeout: Duration,
    /// Where every packet is logged (JSON lines): opens the log file, once the port is open.
    pub log: Box<dyn FnOnce() -> Result<std::fs::File> + 'a>,
}

/// How much faster than a joint's speed limit its goals may change: sag and feedforward goals
/// are the plan offset by the load over the servo's stiffness, and that offset changes with
/// the plan's acceleration, so the goals outrun the joint's speed limit where the plan
/// accelerates hardest (the OpenManipulator-X's base in a castling, measured: 1.4 times; the
/// SO-101 at `--pace 0.3`: 0.2 times); the joint itself keeps to the limit (the plan's, proved
/// by the simulation). A goal faster still is a jump the plan never makes.
pub const GOAL_SPEED_ALLOWANCE: f64 = 1.5;

/// The checks on the wire for the joints of `wiring`: their limits, `max_step` (rad) and speed
/// limits over one bus period, in ticks of its bus.
pub fn wire_limits(wiring: &Wiring, max_step: f64) -> WireLimits {
    let bus = &wiring.bus;
    let period = 1.0 / wiring.bus_rate;
    let count = |j: usize| std::f64::consts::TAU / bus.counts_per_revolution[j];
    let mut limits = WireLimits { lower: [0; 4], upper: [0; 4], max_step: [0; 4], max_change: [0; 4] };
    for j in 0..4 {
        let (lower, upper) = wiring.limits[j];
        let (a, b) = (bus.ticks(j, lower) as i64, bus.ticks(j, upper) as i64);
        limits.lower[j] = a.min(b);
        limits.upper[j] = a.max(b);
        limits.max_step[j] = (max_step / count(j)).floor() as i64;
        // The joint's speed limit over a period with the allowance for the host's offsets, and
        // a tick for the goals' rounding.
        limits.max_change[j] = (GOAL_SPEED_ALLOWANCE * wiring.velocity_limits[j] * period / count(j)).ceil() as i64 + 1;
    }
    limits
}

impl RealArm {
    /// The driver for the servos of `wiring` on `options.port` (or a dry run).
    ///
    /// # Errors
    ///
    /// The port or the log cannot be opened.
    pub fn open(wiring: &Wiring, options: ArmOptions<'_>) -> Result<Self> {
        let wire = match (options.port, options.dry_run) {
            (_, true) => Wire::DryRun,
            (Some(port), false) => Wire::Serial(SerialLine::open(port, BAUD_RATE)?),
            (None, false) => bail!("give --port DEVICE or --dry-run"),
        };
        let log = (options.log)()?;
        let driver = Driver::new(
            wire,
            wiring.protocol,
            wiring.bus.ids,
            wiring.joint_names.clone(),
            wiring.bus.gripper,
            wire_limits(wiring, options.max_step),
            1.0 / wiring.bus_rate,
            options.reply_timeout,
            Box::new(std::io::BufWriter::new(log)),
        );
        Ok(Self { driver, bus: wiring.bus, signs: wiring.signs, enabled: false, followed: Vec::new() })
    }

    /// A goal (rad, the model's sense) in ticks.
    fn ticks(&self, goal: &[f64; 4]) -> [i64; 4] {
        std::array::from_fn(|j| self.bus.ticks(j, self.signs[j] * goal[j]) as i64)
    }

    /// Sends a robot move's goal stream (`goals`, s from the move's start, which began at
    /// robot time `start`), the gripper closed between each of `handled`'s grip and release.
    /// The torque goes on before the first move, holding where the joints are, refused unless
    /// they are within the largest step of the stream's first goal. `stop` is asked between
    /// goals (a Ctrl-C): when it says yes the torque goes off and the move ends.
    ///
    /// # Errors
    ///
    /// Any [`DriverError`] (the torque is then off).
    pub fn execute(
        &mut self,
        goals: &[ServoGoal],
        start: f64,
        handled: &[Handling],
        stop: &dyn Fn() -> bool,
    ) -> Result<Followed, DriverError> {
        let Some(first) = goals.first() else { return Ok(Followed::default()) };
        if !self.enabled {
            self.driver.enable(self.ticks(&first.goal))?;
            self.enabled = true;
        }
        let closed = |t: f64| {
            handled.iter().any(|h| h.grip_tip.is_some() && start + t >= h.grip_time && start + t < h.release_time)
        };
        let stream: Vec<TickGoal> = goals
            .iter()
            .map(|g| TickGoal { t: g.t, ticks: self.ticks(&g.goal), gripper_closed: closed(g.t) })
            .collect();
        let followed = self.driver.follow(&stream, stop)?;
        self.followed.push(followed);
        Ok(followed)
    }

    /// The joints' angles now, rad (the setup's sense), read over the bus.
    ///
    /// # Errors
    ///
    /// Any [`DriverError`] of the bus.
    pub fn read_angles(&mut self) -> Result<[f64; 4], DriverError> {
        let ticks = self.driver.read_joints()?;
        Ok(std::array::from_fn(|j| self.bus.angle(j, ticks[j] as f64)))
    }

    /// Torque off on every servo (the person moves the arm by hand).
    ///
    /// # Errors
    ///
    /// The line failed.
    pub fn torque_off(&mut self) -> std::io::Result<()> {
        self.enabled = false;
        self.driver.torque_off()
    }

    /// Goals of the ramp to the first move's start when the torque went on.
    pub fn ramp_periods(&self) -> usize {
        self.driver.ramp_periods
    }

    pub fn packets_sent(&self) -> usize {
        self.driver.packets_sent
    }

    pub fn is_dry_run(&self) -> bool {
        self.driver.is_dry_run()
    }
}
