//! The driver of the real arm: the goal positions the simulation proved, sent to the servos at
//! the bus rate, every one checked on the wire first.
//!
//! A move's goal stream is checked whole before any of it is sent: every goal inside the
//! joints' limits, and from one period to the next no faster than their speed limits allow (a
//! stream that fails is refused; the servos keep holding where they are). Then each bus period
//! the driver reads the four joints' present positions (one `SYNC_READ`), checks every servo's
//! status (an overload, overheat or voltage error stops the arm), checks that the period's goal
//! is no further than `max_step` from where the joint is, and only then sends it (one
//! `SYNC_WRITE`). Anything wrong while the arm moves (a servo that does not answer within the
//! reply timeout, a fault flag, a goal too far, Ctrl-C) turns the torque off on every servo (one
//! broadcast write, nothing else sent after it) and is a [`DriverError`] naming the joint, the
//! servo and the values. A dry run opens nothing: it logs the packets it would send, the joints
//! taken to be at their last goals.

use super::port::SerialLine;
use super::{PacketError, Protocol, Status};
use std::io::Write;
use std::time::{Duration, Instant};

/// The line: every request and its replies go out and come back holding this lock, so that the
/// signal handler's torque-off never collides with a servo's answer on the half-duplex bus and
/// nothing is sent after it (the handler keeps the lock until the process exits).
static WIRE: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The running driver's line (its own handle) and torque-off packet, for the signal handler.
static EMERGENCY: std::sync::Mutex<Option<(std::fs::File, Vec<u8>)>> = std::sync::Mutex::new(None);

/// Called by the signal handler before the process exits: torque off on the running driver's
/// servos (nothing if none runs), sent twice, once the request on the line has had its replies
/// (at most 300 ms: a line blocked longer gets the torque-off anyway); no packet of the driver
/// follows it.
pub fn torque_off_before_exit() {
    let deadline = Instant::now() + Duration::from_millis(300);
    let wire = loop {
        match WIRE.try_lock() {
            Ok(guard) => break Some(guard),
            Err(std::sync::TryLockError::Poisoned(poisoned)) => break Some(poisoned.into_inner()),
            Err(std::sync::TryLockError::WouldBlock) if Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(1));
            }
            Err(std::sync::TryLockError::WouldBlock) => break None,
        }
    };
    if let Ok(mut emergency) = EMERGENCY.try_lock()
        && let Some((file, packet)) = emergency.as_mut()
    {
        for _ in 0..2 {
            let _ = file.write_all(packet);
        }
        let _ = file.flush();
    }
    // Held until the process exits.
    std::mem::forget(wire);
}

/// What stopped the arm. The torque is off when one of these is returned.
#[derive(Debug, thiserror::Error)]
pub enum DriverError {
    #[error("servo {id} ({joint}) did not answer within {waited_ms} ms; torque off")]
    NoReply { id: u8, joint: String, waited_ms: u64 },
    #[error("servo {id} ({joint}) reports {what}; torque off")]
    Fault { id: u8, joint: String, what: String },
    #[error("servo {id} ({joint}): a damaged reply ({error}); torque off")]
    BadReply { id: u8, joint: String, error: PacketError },
    #[error(
        "{joint}'s goal at t = {t:.3} s is tick {goal}, outside its limits {lower}..{upper} (the setup's joint limits); the move was not started, the arm holds where it is"
    )]
    OutOfLimits { joint: String, t: f64, goal: i64, lower: i64, upper: i64 },
    #[error(
        "{joint}'s goal at t = {t:.3} s is tick {goal}, {distance} ticks from where it is ({present}); the largest step (--max-step-deg) is {max} ticks; nothing sent, torque off"
    )]
    TooFar { joint: String, t: f64, goal: i64, present: i64, distance: i64, max: i64 },
    #[error(
        "{joint}'s goal at t = {t:.3} s moves {change} ticks in one bus period; its speed limit allows {max}; the move was not started, the arm holds where it is"
    )]
    TooFast { joint: String, t: f64, change: i64, max: i64 },
    #[error("interrupted; torque off")]
    Interrupted,
    #[error("the serial line failed: {0}; torque off was attempted")]
    Io(#[from] std::io::Error),
}

/// The checks on every goal, in ticks of each joint's servo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WireLimits {
    /// The joint limits, lowest and highest tick.
    pub lower: [i64; 4],
    pub upper: [i64; 4],
    /// The largest distance of a goal from the joint's present position.
    pub max_step: [i64; 4],
    /// The largest change of a goal from the last one, per bus period.
    pub max_change: [i64; 4],
}

/// A gripper servo: its ID and its goal ticks open and closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GripperServo {
    pub id: u8,
    pub open: i64,
    pub closed: i64,
}

/// One period's goal: when (s from the move's start), the joints' ticks, and the gripper's
/// state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickGoal {
    pub t: f64,
    pub ticks: [i64; 4],
    pub gripper_closed: bool,
}

/// The line the driver talks on.
#[derive(Debug)]
pub enum Wire {
    Serial(SerialLine),
    /// Nothing opened: packets are only logged.
    DryRun,
}

/// What a followed move measured.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Followed {
    pub periods: usize,
    /// The largest |goal − present| per joint, ticks.
    pub largest_lead: [i64; 4],
    /// The largest |goal − last goal| per joint, ticks.
    pub largest_change: [i64; 4],
    /// How far the stream slid behind the plan's clock because the machine was late, s (the
    /// goals then go out later, never in a burst).
    pub slid: f64,
}

/// The driver: a wire, the servos' addresses, the checks and a log of every packet.
pub struct Driver {
    wire: Wire,
    protocol: Protocol,
    ids: [u8; 4],
    names: [String; 4],
    gripper: Option<GripperServo>,
    limits: WireLimits,
    period: f64,
    reply_timeout: Duration,
    log: Box<dyn Write + Send>,
    started: Instant,
    last_goal: Option<[i64; 4]>,
    gripper_closed: Option<bool>,
    /// The joints' positions the dry run takes them to be at.
    assumed: [i64; 4],
    pub packets_sent: usize,
    /// Goals of the ramp to the plan's start when the torque went on ([`Driver::enable`]).
    pub ramp_periods: usize,
}

impl Drop for Driver {
    fn drop(&mut self) {
        if !self.is_dry_run() {
            *EMERGENCY.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = None;
        }
    }
}

impl std::fmt::Debug for Driver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Driver").field("protocol", &self.protocol).field("ids", &self.ids).finish_non_exhaustive()
    }
}

impl Driver {
    /// A driver on `wire` for servos `ids` (joint names `names`), checking `limits`, one goal
    /// every `period` s, a reply awaited at most `reply_timeout`, every packet logged to `log`
    /// (JSON lines: `t` s, `sent` or `received` bytes in hex).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        wire: Wire,
        protocol: Protocol,
        ids: [u8; 4],
        names: [String; 4],
        gripper: Option<GripperServo>,
        limits: WireLimits,
        period: f64,
        reply_timeout: Duration,
        log: Box<dyn Write + Send>,
    ) -> Self {
        if let Wire::Serial(line) = &wire
            && let Ok(file) = line.try_clone_file()
        {
            let packet = protocol.write(Protocol::BROADCAST, protocol.torque_enable(), &[0]);
            *EMERGENCY.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some((file, packet));
        }
        Self {
            wire,
            protocol,
            ids,
            names,
            gripper,
            limits,
            period,
            reply_timeout,
            log,
            started: Instant::now(),
            last_goal: None,
            gripper_closed: None,
            assumed: [0; 4],
            packets_sent: 0,
            ramp_periods: 0,
        }
    }

    pub fn is_dry_run(&self) -> bool {
        matches!(self.wire, Wire::DryRun)
    }

    fn joint(&self, id: u8) -> String {
        match self.ids.iter().position(|i| *i == id) {
            Some(j) => format!("joint {} ({})", j + 1, self.names[j]),
            None if self.gripper.is_some_and(|g| g.id == id) => "the gripper".to_string(),
            None => "not one of the arm's".to_string(),
        }
    }

    fn note(&mut self, key: &str, bytes: &[u8]) -> std::io::Result<()> {
        let hex: String = bytes.iter().map(|b| format!("{b:02X}")).collect();
        writeln!(self.log, "{{\"t\": {:.6}, \"{key}\": \"{hex}\"}}", self.started.elapsed().as_secs_f64())
    }

    /// Sends `packet` (holding the line), then logs it.
    fn send(&mut self, packet: &[u8]) -> std::io::Result<()> {
        self.packets_sent += 1;
        if let Wire::Serial(line) = &mut self.wire {
            let _line = WIRE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            line.send(packet)?;
        }
        self.note("sent", packet)
    }

    /// Sends `packet` and reads the status packets of `ids` in order, holding the line
    /// throughout (within the reply timeout).
    fn request(&mut self, packet: &[u8], ids: &[u8]) -> Result<Vec<Status>, DriverError> {
        self.packets_sent += 1;
        let Wire::Serial(line) = &mut self.wire else {
            self.note("sent", packet)?;
            return Ok(Vec::new());
        };
        let held = WIRE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        line.send(packet)?;
        let received = self.receive(ids);
        drop(held);
        self.note("sent", packet)?;
        received
    }

    /// `n` status packets, from `ids` in order, within the reply timeout.
    fn receive(&mut self, ids: &[u8]) -> Result<Vec<Status>, DriverError> {
        if self.is_dry_run() {
            return Ok(Vec::new());
        }
        let protocol = self.protocol;
        let mut buffer = Vec::new();
        let mut statuses = Vec::with_capacity(ids.len());
        let deadline = Instant::now() + self.reply_timeout;
        for &id in ids {
            let complete = |b: &[u8]| {
                !matches!(protocol.parse_status(b), Err(PacketError::Short { .. } | PacketError::NoHeader(_)))
            };
            let left = deadline.saturating_duration_since(Instant::now());
            if let Wire::Serial(line) = &mut self.wire {
                line.receive_until(&mut buffer, left, complete)?;
            }
            match protocol.parse_status(&buffer) {
                Ok(status) => {
                    let consumed = status.consumed;
                    let bytes = buffer[..consumed].to_vec();
                    buffer.drain(..consumed);
                    self.note("received", &bytes)?;
                    if status.id != id && ids.contains(&status.id) {
                        // A later servo answered: this one did not.
                        return Err(DriverError::NoReply {
                            id,
                            joint: self.joint(id),
                            waited_ms: self.reply_timeout.as_millis() as u64,
                        });
                    }
                    if status.id != id {
                        return Err(DriverError::BadReply {
                            id,
                            joint: self.joint(id),
                            error: PacketError::Malformed("a reply from another servo"),
                        });
                    }
                    statuses.push(status);
                }
                Err(PacketError::Short { .. } | PacketError::NoHeader(_)) => {
                    if !buffer.is_empty() {
                        self.note("received", &buffer.clone())?;
                    }
                    return Err(DriverError::NoReply {
                        id,
                        joint: self.joint(id),
                        waited_ms: self.reply_timeout.as_millis() as u64,
                    });
                }
                Err(error) => return Err(DriverError::BadReply { id, joint: self.joint(id), error }),
            }
        }
        Ok(statuses)
    }

    /// A status's error byte checked: a fault named (a Dynamixel's hardware error read).
    fn check_status(&mut self, status: &Status) -> Result<(), DriverError> {
        let Some(what) = self.protocol.fault(status.error) else { return Ok(()) };
        let mut what = what;
        if self.protocol == Protocol::Dynamixel && status.error & super::dynamixel::ALERT != 0 {
            let read = self.protocol.read(status.id, super::dynamixel::HARDWARE_ERROR_STATUS, 1);
            if let Ok(reply) = self.request(&read, &[status.id])
                && let Some(byte) = reply.first().and_then(|r| r.params.first())
            {
                what = format!("{what}: {}", Protocol::hardware_error(*byte));
            }
        }
        Err(DriverError::Fault { id: status.id, joint: self.joint(status.id), what })
    }

    /// The servos on the bus: the joints' and the gripper's.
    fn all_ids(&self) -> Vec<u8> {
        let mut ids = self.ids.to_vec();
        ids.extend(self.gripper.map(|g| g.id));
        ids
    }

    /// The present positions of the joints and the gripper's servo, ticks (one `SYNC_READ`,
    /// every servo's status checked; a dry run's: the last goals).
    fn read_all(&mut self) -> Result<([i64; 4], Option<i64>), DriverError> {
        let ids = self.all_ids();
        let packet = self.protocol.sync_read(self.protocol.present_position(), self.protocol.position_bytes(), &ids);
        if self.is_dry_run() {
            self.request(&packet, &ids)?;
            return Ok((self.assumed, self.gripper.map(|g| g.open)));
        }
        let statuses = self.request(&packet, &ids)?;
        let mut present = [0; 4];
        let mut gripper = None;
        for (k, status) in statuses.iter().enumerate() {
            self.check_status(status)?;
            let tick = self.protocol.decode_position(&status.params).ok_or_else(|| DriverError::BadReply {
                id: status.id,
                joint: self.joint(status.id),
                error: PacketError::Malformed("a position of the wrong length"),
            })?;
            if k < 4 {
                present[k] = tick;
            } else {
                gripper = Some(tick);
            }
        }
        Ok((present, gripper))
    }

    fn read_present(&mut self) -> Result<[i64; 4], DriverError> {
        Ok(self.read_all()?.0)
    }

    /// The joints' present positions, ticks, every servo's status checked (calibration reads
    /// the arm a person moved by hand).
    ///
    /// # Errors
    ///
    /// Any [`DriverError`] of the bus.
    pub fn read_joints(&mut self) -> Result<[i64; 4], DriverError> {
        self.read_present()
    }

    /// Torque off on every servo: once the line is quiet (the replies of a request cut short
    /// have come in, or 50 ms passed), one broadcast write, sent twice, no reply awaited; the
    /// log's failure does not keep it from going out.
    pub fn torque_off(&mut self) -> std::io::Result<()> {
        let packet = self.protocol.write(Protocol::BROADCAST, self.protocol.torque_enable(), &[0]);
        if let Wire::Serial(line) = &mut self.wire {
            let _line = WIRE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let until = Instant::now() + Duration::from_millis(50);
            let mut stray = Vec::new();
            while Instant::now() < until {
                let before = stray.len();
                line.receive_until(&mut stray, Duration::from_millis(3), |_| false)?;
                if stray.len() == before {
                    break;
                }
            }
            line.send(&packet)?;
            line.send(&packet)?;
        }
        self.packets_sent += 2;
        let _ = self.note("sent", &packet).and_then(|()| self.note("sent", &packet)).and_then(|()| self.log.flush());
        Ok(())
    }

    /// Runs `step`; on its error, the torque goes off first.
    fn guarded<T>(&mut self, step: impl FnOnce(&mut Self) -> Result<T, DriverError>) -> Result<T, DriverError> {
        match step(self) {
            Ok(value) => Ok(value),
            Err(error) => {
                let _ = self.torque_off();
                Err(error)
            }
        }
    }

    /// Torque on, holding where the joints (and the gripper) are; refused (torque off) unless
    /// every joint is within `max_step` of `start`, the plan's first goal; then, if a joint is
    /// further from it than one period's change, a straight ramp to it at a quarter of the
    /// joints' speed limits, every goal checked as a move's are (the one motion that is not the
    /// simulation's: from where the arm was left to where the plan starts).
    ///
    /// # Errors
    ///
    /// A joint too far from the plan's start, or any [`DriverError`] of the bus.
    pub fn enable(&mut self, start: [i64; 4]) -> Result<[i64; 4], DriverError> {
        if self.is_dry_run() {
            self.assumed = start;
        }
        self.guarded(|driver| {
            let (present, gripper_at) = driver.read_all()?;
            driver.check_step(0.0, &start, &present)?;
            // The goal registers at the present positions, then torque on: nothing jumps.
            let mut data: Vec<(u8, Vec<u8>)> =
                driver.ids.iter().zip(&present).map(|(id, t)| (*id, driver.protocol.encode_position(*t))).collect();
            if let (Some(gripper), Some(at)) = (driver.gripper, gripper_at) {
                data.push((gripper.id, driver.protocol.encode_position(at)));
            }
            let goals: Vec<(u8, &[u8])> = data.iter().map(|(id, d)| (*id, d.as_slice())).collect();
            let packet = driver.protocol.sync_write(driver.protocol.goal_position(), &goals);
            driver.send(&packet)?;
            for id in driver.all_ids() {
                let packet = driver.protocol.write(id, driver.protocol.torque_enable(), &[1]);
                if let Some(status) = driver.request(&packet, &[id])?.first() {
                    driver.check_status(status)?;
                }
            }
            driver.last_goal = Some(present);
            // The ramp to the plan's start, if the joints are not there already.
            let steps = (0..4)
                .map(|j| {
                    let per_period = (driver.limits.max_change[j] / 4).max(1);
                    ((start[j] - present[j]).abs() + per_period - 1) / per_period
                })
                .max()
                .unwrap_or(0);
            if steps > 1 {
                let ramp: Vec<TickGoal> = (1..=steps)
                    .map(|k| TickGoal {
                        t: k as f64 * driver.period,
                        ticks: std::array::from_fn(|j| present[j] + (start[j] - present[j]) * k / steps),
                        gripper_closed: false,
                    })
                    .collect();
                driver.stream(&ramp, &|| false)?;
                driver.ramp_periods += ramp.len();
            }
            Ok(present)
        })
    }

    /// A move's goal stream checked before anything of it is sent: every goal inside the
    /// joints' limits, and from one period to the next no faster than their speed limits allow.
    fn check_stream(&self, goals: &[TickGoal]) -> Result<(), DriverError> {
        let limits = &self.limits;
        let joint = |j: usize| format!("joint {} ({})", j + 1, self.names[j]);
        for (k, goal) in goals.iter().enumerate() {
            for j in 0..4 {
                if goal.ticks[j] < limits.lower[j] || goal.ticks[j] > limits.upper[j] {
                    return Err(DriverError::OutOfLimits {
                        joint: joint(j),
                        t: goal.t,
                        goal: goal.ticks[j],
                        lower: limits.lower[j],
                        upper: limits.upper[j],
                    });
                }
                if k > 0 {
                    let change = (goal.ticks[j] - goals[k - 1].ticks[j]).abs();
                    if change > limits.max_change[j] {
                        return Err(DriverError::TooFast {
                            joint: joint(j),
                            t: goal.t,
                            change,
                            max: limits.max_change[j],
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// A goal about to be sent checked against where the joints are (`present`).
    fn check_step(&self, t: f64, goal: &[i64; 4], present: &[i64; 4]) -> Result<(), DriverError> {
        for j in 0..4 {
            let distance = (goal[j] - present[j]).abs();
            if distance > self.limits.max_step[j] {
                return Err(DriverError::TooFar {
                    joint: format!("joint {} ({})", j + 1, self.names[j]),
                    t,
                    goal: goal[j],
                    present: present[j],
                    distance,
                    max: self.limits.max_step[j],
                });
            }
        }
        Ok(())
    }

    /// Sends `goals` one per bus period (paced by the clock on a serial line), each checked on
    /// the wire first; `cancelled` is asked every period.
    ///
    /// # Errors
    ///
    /// Any [`DriverError`]: the torque is off and nothing else was sent.
    pub fn follow(&mut self, goals: &[TickGoal], cancelled: &dyn Fn() -> bool) -> Result<Followed, DriverError> {
        // Refused whole before it starts: the servos keep holding where they are.
        self.check_stream(goals)?;
        // A move's first goal follows the last move's after a pause: it is held to one period's
        // change from the goal the servos hold (where the joints are, if none was sent yet; a
        // servo holding against gravity rests off its goal by the sag, which the goals carry),
        // the stream's own steps being checked whole.
        if let Some(first) = goals.first() {
            let held = match self.last_goal {
                Some(goal) => goal,
                None => self.guarded(Self::read_present)?,
            };
            for (j, at) in held.iter().enumerate() {
                let change = (first.ticks[j] - at).abs();
                if change > self.limits.max_change[j] {
                    return Err(DriverError::TooFast {
                        joint: format!("joint {} ({})", j + 1, self.names[j]),
                        t: first.t,
                        change,
                        max: self.limits.max_change[j],
                    });
                }
            }
        }
        self.guarded(|driver| driver.stream(goals, cancelled))
    }

    /// Sends `goals` one per bus period (the loop of [`Driver::follow`], unguarded).
    fn stream(&mut self, goals: &[TickGoal], cancelled: &dyn Fn() -> bool) -> Result<Followed, DriverError> {
        let mut followed = Followed::default();
        let start = Instant::now();
        let mut slid = Duration::ZERO;
        for goal in goals {
            if cancelled() {
                return Err(DriverError::Interrupted);
            }
            if !self.is_dry_run() {
                // A period late (the machine busy) slides the rest of the stream: goals are
                // never sent in a burst to catch up, which would make the goal run ahead of
                // the joints by the plan's motion over the delay.
                let due = start + slid + Duration::from_secs_f64(goal.t.max(0.0));
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                } else {
                    slid += now - due;
                }
            }
            let present = self.read_present()?;
            self.check_step(goal.t, &goal.ticks, &present)?;
            let last = self.last_goal;
            for j in 0..4 {
                followed.largest_lead[j] = followed.largest_lead[j].max((goal.ticks[j] - present[j]).abs());
                if let Some(last) = last {
                    followed.largest_change[j] = followed.largest_change[j].max((goal.ticks[j] - last[j]).abs());
                }
            }
            let data: Vec<Vec<u8>> = goal.ticks.iter().map(|t| self.protocol.encode_position(*t)).collect();
            let mut targets: Vec<(u8, &[u8])> = self.ids.iter().zip(&data).map(|(id, d)| (*id, d.as_slice())).collect();
            let gripper_data;
            if let Some(gripper) = self.gripper
                && self.gripper_closed != Some(goal.gripper_closed)
            {
                gripper_data =
                    self.protocol.encode_position(if goal.gripper_closed { gripper.closed } else { gripper.open });
                targets.push((gripper.id, gripper_data.as_slice()));
                self.gripper_closed = Some(goal.gripper_closed);
            }
            let packet = self.protocol.sync_write(self.protocol.goal_position(), &targets);
            self.send(&packet)?;
            self.last_goal = Some(goal.ticks);
            if self.is_dry_run() {
                self.assumed = goal.ticks;
            }
            followed.periods += 1;
        }
        followed.slid = slid.as_secs_f64();
        self.log.flush()?;
        Ok(followed)
    }
}
