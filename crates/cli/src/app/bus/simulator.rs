//! A simulated servo bus: the arm's four joint servos (and a gripper servo, if the setup names
//! one) answering either protocol on a pseudo-terminal, with the actuator model behind them.
//!
//! The joints are the setup's arm under its servos ([`Actuators::plant_model`]: gears,
//! friction, back-EMF) driven by the servos' firmware ([`PositionBank`]), integrated in real
//! time (1 ms steps, caught up to the wall clock before each packet is answered): a goal
//! written over the bus moves the simulated joint as the servo would, and a present position
//! read back is where it is, in whole ticks. A long silence is not integrated step by step:
//! the first seconds after the last packet are (the servos' transient), the rest is skipped,
//! the arm holding where it settled ([`SimulatedBus::advance_to`]). While every joint's torque is off the arm rests
//! where it is (it stands on its stops: falling is not simulated); a joint whose torque goes off
//! while others hold it gets no drive torque.
//!
//! Faults can be injected to test a driver: a servo that stops answering, or one that reports
//! an overload (and turns its torque off, as the servos' own protection does), each after a
//! given number of goal packets. Every instruction received is logged (time and bytes).
//!
//! Bytes are read as a servo reads them: a packet cut short (stray bytes, a cable pulled
//! mid-packet) is dropped once the line stays silent for [`INTER_BYTE_TIMEOUT`]
//! ([`SimulatedBus::expire`]), so the next whole packet is answered.

use super::Protocol;
use crate::app::bus::mapping::ServoBus;
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::control::JointState;
use chessarm_core::sim::actuator::{Actuators, PositionBank};
use chessarm_core::sim::{Integrator, Plant};
use std::io::Write;
use std::time::Instant;

/// Plant time step, s.
const DT: f64 = 1e-3;

/// Plant time integrated step by step after a silence before the rest of it is skipped, s
/// (while the arm still moves, up to [`CATCH_UP_MAX`]). A servo's transient after its last
/// goal is over well within it: the STS3215's and XM430's models reach a 200-tick step in
/// 0.3 s and rest within their deadband after 1 s, and the longest move a driver sends as one
/// goal, across a joint's range at the firmware's speed, takes about as long.
const CATCH_UP: f64 = 2.0;

/// The most plant time integrated step by step in one catch-up, s: a servo hunting inside its
/// deadband never comes to rest (the default arm's STS3215s do not, after a 100-tick step), and
/// the work of answering a packet must stay bounded: 5000 steps took 9 ms on a busy 2-core
/// machine (an optimised build), a tenth of a driver's 100 ms reply timeout.
const CATCH_UP_MAX: f64 = 5.0;

/// Joint speeds under which the arm counts as at rest when a silence is skipped, rad/s: a
/// tick of a 4096-tick servo (1.5 mrad) every 15 s.
const AT_REST: f64 = 1e-4;

/// Silence on the line after which the bytes of a packet cut short are dropped, s. At 1 Mbaud
/// a byte takes 10 µs and the longest packet (259 bytes) 2.6 ms, and a packet's bytes come
/// back to back; over a pseudo-terminal a driver's packet is one write and arrives at once.
/// 20 ms leaves a busy machine's scheduler room to deliver a write in pieces, and is a fifth
/// of a driver's 100 ms reply timeout: stray bytes are gone before a driver sends again.
pub const INTER_BYTE_TIMEOUT: f64 = 0.020;

/// A fault to inject: servo `id` misbehaves from the `after`-th goal packet on (1-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fault {
    pub id: u8,
    pub after: usize,
}

/// Faults to inject ([`Fault`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Faults {
    /// The servo stops answering (any packet).
    pub lose_reply: Option<Fault>,
    /// The servo reports an overload and turns its torque off.
    pub overload: Option<Fault>,
}

/// One servo on the bus: its control table and state.
#[derive(Debug, Clone)]
struct Servo {
    id: u8,
    /// The arm joint it drives (`None`: the gripper's servo, which simply goes to its goal).
    joint: Option<usize>,
    memory: Vec<u8>,
    torque: bool,
    silent: bool,
    /// The status error byte it answers with.
    error: u8,
}

/// Bytes of a simulated control table (both series' registers used here lie below 256).
const TABLE: usize = 256;

/// The simulated servos and the arm they drive.
pub struct SimulatedBus {
    protocol: Protocol,
    servos: Vec<Servo>,
    bus: ServoBus,
    signs: [f64; 4],
    plant: Plant<4>,
    bank: PositionBank<4>,
    state: JointState<4>,
    lower: JointVector<4>,
    upper: JointVector<4>,
    /// Simulated time, s, and the plant steps taken.
    time: f64,
    step: usize,
    /// Bytes received that hold no whole packet yet, and when the last byte came (s, the
    /// bus's clock).
    pending: Vec<u8>,
    last_byte: f64,
    goal_packets: usize,
    faults: Faults,
    started: Instant,
    log: Option<Box<dyn Write + Send>>,
}

impl std::fmt::Debug for SimulatedBus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimulatedBus")
            .field("protocol", &self.protocol)
            .field("time", &self.time)
            .finish_non_exhaustive()
    }
}

impl SimulatedBus {
    /// The bus of `arm` (the model's sense) driven by `actuators` (servos or steppers on every
    /// joint), addressed and scaled by `bus` (`signs` the setup's joint convention), resting at
    /// `q` (rad, the model's sense); `gripper` a gripper servo's ID and its resting tick.
    ///
    /// # Errors
    ///
    /// A joint has a torque motor, or the model with the servos' gears is invalid.
    pub fn new(
        protocol: Protocol,
        arm: &ArmModel<4>,
        actuators: &Actuators<4>,
        bus: ServoBus,
        signs: [f64; 4],
        q: JointVector<4>,
        gripper: Option<(u8, i64)>,
    ) -> anyhow::Result<Self> {
        let model = actuators.plant_model(arm)?;
        let bank = PositionBank::holding(actuators, DT, &model, &q, &q)
            .ok_or_else(|| anyhow::anyhow!("the simulated bus needs a servo on every joint (--actuator)"))?;
        let lower = JointVector::<4>::from_fn(|j, _| arm.link(j).limits.lower);
        let upper = JointVector::<4>::from_fn(|j, _| arm.link(j).limits.upper);
        let mut servos: Vec<Servo> = (0..4)
            .map(|j| Servo {
                id: bus.ids[j],
                joint: Some(j),
                memory: vec![0; TABLE],
                torque: false,
                silent: false,
                error: 0,
            })
            .collect();
        if let Some((id, _)) = gripper {
            servos.push(Servo { id, joint: None, memory: vec![0; TABLE], torque: false, silent: false, error: 0 });
        }
        let mut sim = Self {
            protocol,
            servos,
            bus,
            signs,
            plant: Plant::new(model),
            bank,
            state: JointState::at_rest(q),
            lower,
            upper,
            time: 0.0,
            step: 0,
            pending: Vec::new(),
            last_byte: 0.0,
            goal_packets: 0,
            faults: Faults::default(),
            started: Instant::now(),
            log: None,
        };
        for index in 0..sim.servos.len() {
            sim.identify(index);
        }
        sim.refresh();
        if let Some((id, tick)) = gripper {
            let at = sim.protocol.present_position() as usize;
            let bytes = sim.protocol.encode_position(tick);
            let goal = sim.protocol.goal_position() as usize;
            if let Some(servo) = sim.servos.iter_mut().find(|s| s.id == id) {
                servo.memory[at..at + bytes.len()].copy_from_slice(&bytes);
                servo.memory[goal..goal + bytes.len()].copy_from_slice(&bytes);
            }
        }
        Ok(sim)
    }

    /// Injects `faults`.
    pub fn with_faults(mut self, faults: Faults) -> Self {
        self.faults = faults;
        self
    }

    /// Logs every instruction received to `log`, one JSON line each: `{"t": s, "packet": hex}`.
    pub fn with_log(mut self, log: Box<dyn Write + Send>) -> Self {
        self.log = Some(log);
        self
    }

    /// The model number and firmware a servo reports (STS3215: 777; XM430-W350: 1020).
    fn identify(&mut self, index: usize) {
        let servo = &mut self.servos[index];
        let id = servo.id;
        match self.protocol {
            Protocol::Feetech => {
                let at = super::feetech::MODEL_NUMBER as usize;
                servo.memory[at..at + 2].copy_from_slice(&777u16.to_le_bytes());
                servo.memory[5] = id;
            }
            Protocol::Dynamixel => {
                servo.memory[..2].copy_from_slice(&1020u16.to_le_bytes());
                servo.memory[super::dynamixel::FIRMWARE_VERSION as usize] = 45;
                servo.memory[7] = id;
            }
        }
    }

    /// The bus's clock: the wall clock's time since the bus started, s.
    pub fn now(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// Integrates the arm up to the wall clock's time since the bus started.
    pub fn catch_up(&mut self) -> anyhow::Result<()> {
        self.advance_to(self.now())
    }

    /// Integrates the arm up to simulated time `t` (s).
    ///
    /// At most [`CATCH_UP`] s of it step by step (longer while a joint still moves, up to
    /// [`CATCH_UP_MAX`]); the rest is skipped with the state as it is. The servos' goals
    /// change only with a packet, so after their transient the arm holds still (a servo at
    /// rest within its deadband, on its gears' friction): the state is stationary and skipping
    /// time is integrating it exactly. A servo still hunting at the cap is left in its cycle's
    /// phase, which no driver can tell from another. With every joint's torque off the arm
    /// rests on its stops and the whole interval is skipped.
    ///
    /// # Errors
    ///
    /// The dynamics failed (a mass matrix not positive definite).
    pub fn advance_to(&mut self, t: f64) -> anyhow::Result<()> {
        let held: [bool; 4] = std::array::from_fn(|j| self.servos[j].torque);
        let settling = (CATCH_UP / DT).round() as usize;
        let most = (CATCH_UP_MAX / DT).round() as usize;
        let mut taken = 0;
        while self.time + DT <= t {
            let at_rest = self.state.qd.amax() < AT_REST;
            if !held.iter().any(|h| *h) || (taken >= settling && at_rest) || taken >= most {
                if !held.iter().any(|h| *h) {
                    self.state.qd = JointVector::zeros();
                }
                // Whole steps, so that the clock stays on the plant's grid.
                self.time += ((t - self.time) / DT).floor() * DT;
                break;
            }
            self.bank.update(self.step, &self.state.q, &self.state.qd, DT);
            let bank = &self.bank;
            let next = self.plant.step_with(
                &self.state,
                |q, qd| {
                    let drive = bank.torque_at(q, qd);
                    JointVector::<4>::from_fn(|j, _| if held[j] { drive[j] } else { 0.0 })
                },
                DT,
                Integrator::RungeKutta4,
            )?;
            self.bank.after_step(&next.q);
            self.state = next;
            self.step += 1;
            taken += 1;
            self.time += DT;
        }
        self.refresh();
        Ok(())
    }

    /// The joints' present positions written into their control tables.
    fn refresh(&mut self) {
        let at = self.protocol.present_position() as usize;
        for index in 0..self.servos.len() {
            let Some(j) = self.servos[index].joint else { continue };
            let user = self.signs[j] * self.state.q[j];
            let tick = self.bus.ticks(j, user) as i64;
            let bytes = self.protocol.encode_position(tick);
            self.servos[index].memory[at..at + bytes.len()].copy_from_slice(&bytes);
        }
    }

    /// Takes `bytes` received at `at` (s, the bus's clock) and answers the instruction packets
    /// they complete, the replies appended to `output`; each packet is answered with the arm
    /// integrated up to `at`. A packet cut short waits for its rest (or for [`Self::expire`]);
    /// a damaged one is dropped, as a servo drops it.
    ///
    /// # Errors
    ///
    /// The dynamics failed, or the log could not be written.
    pub fn receive(&mut self, at: f64, bytes: &[u8], output: &mut Vec<u8>) -> anyhow::Result<()> {
        use super::PacketError;
        if !bytes.is_empty() {
            self.pending.extend_from_slice(bytes);
            self.last_byte = at;
        }
        loop {
            match self.protocol.parse_instruction(&self.pending) {
                Ok(packet) => {
                    let bytes: Vec<u8> = self.pending.drain(..packet.consumed).skip(packet.start).collect();
                    if let Some(log) = &mut self.log {
                        let hex: String = bytes.iter().map(|b| format!("{b:02X}")).collect();
                        writeln!(log, "{{\"t\": {at:.6}, \"packet\": \"{hex}\"}}")?;
                        log.flush()?;
                    }
                    self.advance_to(at)?;
                    self.handle(packet.id, packet.error, &packet.params, output);
                }
                Err(PacketError::Short { .. }) => return Ok(()),
                Err(PacketError::NoHeader(_)) => {
                    // Keep a possible header's first bytes.
                    let keep = self.pending.len().min(3);
                    self.pending.drain(..self.pending.len() - keep);
                    return Ok(());
                }
                Err(PacketError::Checksum { .. } | PacketError::Malformed(_)) => {
                    // Past this header: the next one is looked for.
                    let at = self.pending.iter().position(|b| *b == 0xFF).unwrap_or(0);
                    self.pending.drain(..=at.min(self.pending.len().saturating_sub(1)));
                }
            }
        }
    }

    /// At `at` (s, the bus's clock), with the line silent since the last byte received: the
    /// bytes of a packet cut short are dropped if that silence has lasted
    /// [`INTER_BYTE_TIMEOUT`], as a servo's receiver drops them. The bytes dropped, if any.
    ///
    /// Only a silence seen on the line counts (the caller waited and nothing came): the time
    /// between two reads is not one, as a busy machine may leave this program unscheduled
    /// while the rest of a packet arrives.
    pub fn expire(&mut self, at: f64) -> Option<Vec<u8>> {
        (!self.pending.is_empty() && at - self.last_byte >= INTER_BYTE_TIMEOUT)
            .then(|| std::mem::take(&mut self.pending))
    }

    /// How long the line may stay silent from `at` (s) before [`Self::expire`] drops the bytes
    /// waiting, s (`None`: none wait).
    pub fn expires_in(&self, at: f64) -> Option<f64> {
        (!self.pending.is_empty()).then(|| (INTER_BYTE_TIMEOUT - (at - self.last_byte)).max(0.0))
    }

    fn handle(&mut self, id: u8, instruction: u8, params: &[u8], output: &mut Vec<u8>) {
        // Instruction codes are the same in both protocols.
        use super::feetech::{PING, READ, SYNC_READ, SYNC_WRITE, WRITE};
        let protocol = self.protocol;
        match instruction {
            PING => {
                if let Some(servo) = self.answering(id) {
                    let params = match protocol {
                        Protocol::Feetech => Vec::new(),
                        Protocol::Dynamixel => {
                            vec![servo.memory[0], servo.memory[1], servo.memory[6]]
                        }
                    };
                    output.extend(protocol.status(id, servo.error, &params));
                }
            }
            READ => {
                let Some((address, length)) = self.address_length(params) else { return };
                if let Some(servo) = self.answering(id) {
                    let data = servo.memory.get(address..address + length).map(<[u8]>::to_vec);
                    output.extend(match data {
                        Some(data) => protocol.status(id, servo.error, &data),
                        // Dynamixel's data range error; an STS answers what it has.
                        None => protocol.status(id, 4, &[]),
                    });
                }
            }
            WRITE => {
                let header = self.header_bytes();
                if params.len() < header {
                    return;
                }
                let address = self.address(params);
                let data = params[header..].to_vec();
                let ids: Vec<u8> =
                    if id == Protocol::BROADCAST { self.servos.iter().map(|s| s.id).collect() } else { vec![id] };
                for target in ids {
                    self.write_memory(target, address, &data);
                }
                self.count_goal(address, data.len());
                if id != Protocol::BROADCAST
                    && let Some(servo) = self.answering(id)
                {
                    output.extend(protocol.status(id, servo.error, &[]));
                }
            }
            SYNC_WRITE => {
                let Some((address, length)) = self.address_length(params) else { return };
                let header = 2 * self.header_bytes();
                if length == 0 {
                    return;
                }
                for chunk in params[header..].chunks_exact(length + 1) {
                    self.write_memory(chunk[0], address, &chunk[1..]);
                }
                self.count_goal(address, length);
            }
            SYNC_READ => {
                let Some((address, length)) = self.address_length(params) else { return };
                let header = 2 * self.header_bytes();
                // Each servo answers once, in its turn: an ID listed again gets no second reply
                // (a packet listing one ID thousands of times would otherwise be answered
                // thousands of times).
                let mut answered = Vec::new();
                for &target in &params[header..] {
                    if answered.contains(&target) {
                        continue;
                    }
                    answered.push(target);
                    if let Some(servo) = self.answering(target)
                        && let Some(data) = servo.memory.get(address..address + length)
                    {
                        output.extend(protocol.status(target, servo.error, data));
                    }
                }
            }
            _ => {
                if protocol == Protocol::Dynamixel && self.answering(id).is_some() {
                    output.extend(protocol.status(id, 2, &[]));
                }
            }
        }
    }

    /// Bytes of an address (and of a length) in this protocol's parameters.
    fn header_bytes(&self) -> usize {
        match self.protocol {
            Protocol::Feetech => 1,
            Protocol::Dynamixel => 2,
        }
    }

    fn address(&self, params: &[u8]) -> usize {
        match self.protocol {
            Protocol::Feetech => params[0] as usize,
            Protocol::Dynamixel => u16::from_le_bytes([params[0], params[1]]) as usize,
        }
    }

    /// A read's or sync packet's address and length (`None` for a length no status packet can
    /// carry: an STS answers at most 250 bytes of data).
    fn address_length(&self, params: &[u8]) -> Option<(usize, usize)> {
        let n = self.header_bytes();
        if params.len() < 2 * n {
            return None;
        }
        let length = match self.protocol {
            Protocol::Feetech => params[1] as usize,
            Protocol::Dynamixel => u16::from_le_bytes([params[2], params[3]]) as usize,
        };
        (length <= 250).then(|| (self.address(params), length))
    }

    /// The servo `id` if it is on the bus and answers.
    fn answering(&self, id: u8) -> Option<&Servo> {
        self.servos.iter().find(|s| s.id == id && !s.silent)
    }

    /// A goal packet (one touching the goal position) counted, and the faults due after it.
    fn count_goal(&mut self, address: usize, length: usize) {
        let goal = self.protocol.goal_position() as usize;
        if !(address <= goal && goal < address + length) {
            return;
        }
        self.goal_packets += 1;
        if let Some(fault) = self.faults.lose_reply
            && self.goal_packets >= fault.after
            && let Some(servo) = self.servos.iter_mut().find(|s| s.id == fault.id)
        {
            servo.silent = true;
        }
        if let Some(fault) = self.faults.overload
            && self.goal_packets >= fault.after
            && let Some(index) = self.servos.iter().position(|s| s.id == fault.id)
        {
            let servo = &mut self.servos[index];
            servo.torque = false;
            let torque = self.protocol.torque_enable() as usize;
            servo.memory[torque] = 0;
            match self.protocol {
                Protocol::Feetech => servo.error |= 0x20,
                Protocol::Dynamixel => {
                    servo.error |= super::dynamixel::ALERT;
                    servo.memory[super::dynamixel::HARDWARE_ERROR_STATUS as usize] |= 0x20;
                }
            }
        }
    }

    /// `data` written at `address` of servo `id`, with its effects: torque on (the goal
    /// becomes the present position, as both series do), torque off, a new goal.
    fn write_memory(&mut self, id: u8, address: usize, data: &[u8]) {
        let Some(index) = self.servos.iter().position(|s| s.id == id) else { return };
        if address + data.len() > TABLE {
            return;
        }
        let torque_at = self.protocol.torque_enable() as usize;
        let goal_at = self.protocol.goal_position() as usize;
        let present_at = self.protocol.present_position() as usize;
        let width = self.protocol.position_bytes() as usize;
        let servo = &mut self.servos[index];
        // An overloaded servo keeps its torque off until its error is cleared (not simulated).
        let overloaded = servo.error != 0;
        servo.memory[address..address + data.len()].copy_from_slice(data);
        if (address..address + data.len()).contains(&torque_at) {
            let on = data[torque_at - address] != 0 && !overloaded;
            servo.memory[torque_at] = u8::from(on);
            if on && !servo.torque {
                let present = servo.memory[present_at..present_at + width].to_vec();
                servo.memory[goal_at..goal_at + width].copy_from_slice(&present);
            }
            servo.torque = on;
        }
        if servo.joint.is_none() {
            // The gripper's servo goes straight to its goal.
            let goal = servo.memory[goal_at..goal_at + width].to_vec();
            servo.memory[present_at..present_at + width].copy_from_slice(&goal);
            return;
        }
        self.send_goals();
    }

    /// Every joint's goal register handed to its servo's firmware.
    fn send_goals(&mut self) {
        let goal_at = self.protocol.goal_position() as usize;
        let width = self.protocol.position_bytes() as usize;
        let mut goal = self.state.q;
        for servo in &self.servos {
            if let Some(j) = servo.joint
                && servo.torque
                && let Some(tick) = self.protocol.decode_position(&servo.memory[goal_at..goal_at + width])
            {
                goal[j] = self.signs[j] * self.bus.angle(j, tick as f64);
            }
        }
        self.bank.send(&goal, &self.lower, &self.upper);
    }

    /// Puts the arm at `q` (rad, the model's sense) at rest, as a person's hand would move it:
    /// only while every joint's torque is off (a held joint cannot be moved by hand). Whether
    /// it was moved.
    pub fn move_by_hand(&mut self, q: JointVector<4>) -> bool {
        if self.servos.iter().any(|s| s.joint.is_some() && s.torque) {
            return false;
        }
        self.state = JointState::at_rest(q);
        // The firmware's targets start again where the joints now are.
        if let Some(bank) = PositionBank::holding(&self.bank.actuators(), DT, self.plant.model(), &q, &q) {
            self.bank = bank;
        }
        self.refresh();
        true
    }

    /// Serves the bus on `terminal` until `stop()` says so; angles from `hand` (rad, the
    /// model's sense) move the arm by hand ([`SimulatedBus::move_by_hand`]).
    ///
    /// # Errors
    ///
    /// The terminal failed, or the dynamics.
    pub fn serve(
        &mut self,
        terminal: &mut super::port::PseudoTerminal,
        stop: impl Fn() -> bool,
        hand: Option<&std::sync::mpsc::Receiver<JointVector<4>>>,
        say: &dyn Fn(&str),
    ) -> anyhow::Result<()> {
        use std::io::Read;
        let mut output = Vec::new();
        let mut chunk = [0u8; 1024];
        while !stop() {
            while let Some(q) = hand.and_then(|h| h.try_recv().ok()) {
                self.catch_up()?;
                if !self.move_by_hand(q) {
                    say("bus-sim: not moved: a joint's torque is on\n");
                }
            }
            // While a packet is cut short, wait no longer than its bytes may stay.
            let idle = 0.020;
            let wait = self.expires_in(self.now()).map_or(idle, |left| left.min(idle));
            if !super::port::wait_readable(&terminal.controller, std::time::Duration::from_secs_f64(wait))? {
                if let Some(dropped) = self.expire(self.now()) {
                    let hex: String = dropped.iter().map(|b| format!("{b:02X}")).collect();
                    say(&format!(
                        "bus-sim: dropped {} bytes of a packet cut short (no byte for {} ms): {hex}\n",
                        dropped.len(),
                        INTER_BYTE_TIMEOUT * 1e3
                    ));
                }
                continue;
            }
            let n = match terminal.controller.read(&mut chunk) {
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            };
            self.receive(self.now(), &chunk[..n], &mut output)?;
            if !output.is_empty() {
                terminal.controller.write_all(&output)?;
                terminal.controller.flush()?;
                output.clear();
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default setup's arm on STS3215 servos, its bus resting at the pose a game starts
    /// from (as `bus-sim --actuator sts3215` starts).
    fn sts_bus() -> SimulatedBus {
        let mut setup = crate::app::setup::file::Setup::load(None).unwrap();
        setup.actuators =
            crate::app::setup::actuators::resolve(&["sts3215".to_string()], &setup.actuator_tables, "--actuator")
                .unwrap();
        setup.actuator_names = std::array::from_fn(|_| "sts3215".to_string());
        let bus = ServoBus::of(&setup).unwrap();
        let q = chessarm_chess::play::home_pose(
            &setup.arm,
            &setup.board,
            &setup.pieces,
            &setup.motion.validated().unwrap(),
        )
        .unwrap();
        SimulatedBus::new(Protocol::Feetech, &setup.arm, &setup.actuators, bus, setup.convention.signs, q, None)
            .unwrap()
    }

    /// The present positions of servos 1 to 4 read over the bus at `at`, ticks.
    fn present(sim: &mut SimulatedBus, at: f64) -> [i64; 4] {
        let protocol = Protocol::Feetech;
        std::array::from_fn(|j| {
            let mut out = Vec::new();
            let read = protocol.read(sim.bus.ids[j], protocol.present_position(), 2);
            sim.receive(at, &read, &mut out).unwrap();
            let status = protocol.parse_status(&out).unwrap();
            protocol.decode_position(&status.params).unwrap()
        })
    }

    /// Torque on and a goal 100 ticks from the start on joint 2 at `at`.
    fn hold_and_move(sim: &mut SimulatedBus, at: f64) -> [i64; 4] {
        let protocol = Protocol::Feetech;
        let mut out = Vec::new();
        let start = present(sim, at);
        for &id in &sim.bus.ids.clone() {
            sim.receive(at, &protocol.write(id, protocol.torque_enable(), &[1]), &mut out).unwrap();
        }
        let mut goal = start;
        goal[1] += 100;
        let data: Vec<Vec<u8>> = goal.iter().map(|t| protocol.encode_position(*t)).collect();
        let ids = sim.bus.ids;
        let goals: Vec<(u8, &[u8])> = ids.iter().zip(&data).map(|(id, d)| (*id, d.as_slice())).collect();
        sim.receive(at, &protocol.sync_write(protocol.goal_position(), &goals), &mut out).unwrap();
        goal
    }

    /// After a long silence with the torque held, answering the next packet takes bounded
    /// work: at most `CATCH_UP_MAX` of plant steps, not one per millisecond of the silence
    /// (1000 s were a million steps, which made the driver's 100 ms reply timeout run out
    /// after some 200 s of thinking). The arm is then where it settles: the same ticks as an
    /// arm integrated step by step for 5 s after the same goal (the transient is over within
    /// 1 s), within a tick for the rounding of a position resting on a tick's edge.
    #[test]
    fn a_long_silence_with_the_torque_held_costs_bounded_work() {
        let mut sim = sts_bus();
        hold_and_move(&mut sim, 0.0);
        let mut reference = sts_bus();
        hold_and_move(&mut reference, 0.0);
        // 1 ms packets for 5 s: every step integrated.
        for k in 1..=5000 {
            reference.advance_to(f64::from(k) * 1e-3).unwrap();
        }
        let settled = present(&mut reference, 5.0);

        let before = sim.step;
        sim.advance_to(1000.0).unwrap();
        let steps = sim.step - before;
        assert!(steps <= (CATCH_UP_MAX / DT) as usize, "{steps} plant steps for 1000 s of silence");
        assert!(sim.time > 1000.0 - DT && sim.time <= 1000.0, "{}", sim.time);
        let after = present(&mut sim, 1000.0);
        for j in 0..4 {
            assert!((after[j] - settled[j]).abs() <= 1, "joint {}: {after:?} against {settled:?}", j + 1);
        }
        // And the next packet, a millisecond later, takes a step, not a catch-up.
        let before = sim.step;
        present(&mut sim, 1000.001);
        // (Two: the skipped clock may sit a step's rounding short of 1000 s.)
        assert!(sim.step - before <= 2, "{}", sim.step - before);
    }

    /// With every torque off a silence is skipped whole, the arm where it rested.
    #[test]
    fn a_long_silence_with_the_torque_off_takes_no_steps() {
        let mut sim = sts_bus();
        let start = present(&mut sim, 0.0);
        sim.advance_to(86_400.0).unwrap();
        assert_eq!(sim.step, 0);
        assert_eq!(present(&mut sim, 86_400.0), start);
    }

    /// Four stray bytes (`FF FF 01 FF`: a header, ID 1 and a length of 255) once held every
    /// later packet as the rest of theirs. Dropped after `INTER_BYTE_TIMEOUT` of silence, the
    /// next ping is answered; bytes of a packet split in two reads close together are not
    /// dropped.
    #[test]
    fn a_packet_cut_short_is_dropped_after_a_silence() {
        let protocol = Protocol::Feetech;
        let mut sim = sts_bus();
        let mut out = Vec::new();
        sim.receive(1.0, &[0xFF, 0xFF, 0x01, 0xFF], &mut out).unwrap();
        assert!(out.is_empty());
        // Not yet: half the timeout of silence.
        assert_eq!(sim.expire(1.0 + INTER_BYTE_TIMEOUT / 2.0), None);
        assert_eq!(sim.expire(1.0 + INTER_BYTE_TIMEOUT), Some(vec![0xFF, 0xFF, 0x01, 0xFF]));
        sim.receive(1.1, &protocol.ping(1), &mut out).unwrap();
        let status = protocol.parse_status(&out).unwrap();
        assert_eq!((status.id, status.error, status.consumed), (1, 0, out.len()));

        // A ping in two pieces 1 ms apart: answered, nothing to drop.
        out.clear();
        let ping = protocol.ping(2);
        sim.receive(2.0, &ping[..3], &mut out).unwrap();
        // Within 1e-9 s: the clock's readings differ from 0.5 ms by their rounding.
        let left = sim.expires_in(2.0005).unwrap();
        assert!((left - (INTER_BYTE_TIMEOUT - 0.0005)).abs() < 1e-9, "{left}");
        sim.receive(2.001, &ping[3..], &mut out).unwrap();
        assert_eq!(protocol.parse_status(&out).unwrap().id, 2);
        assert_eq!(sim.expire(3.0), None);
    }

    /// A sync read listing a servo three times gets its one reply, not three.
    #[test]
    fn a_sync_read_answers_each_servo_once() {
        let protocol = Protocol::Feetech;
        let mut sim = sts_bus();
        let mut out = Vec::new();
        sim.receive(0.0, &protocol.sync_read(protocol.present_position(), 2, &[1, 1, 2, 1]), &mut out).unwrap();
        let first = protocol.parse_status(&out).unwrap();
        let second = protocol.parse_status(&out[first.consumed..]).unwrap();
        assert_eq!((first.id, second.id, first.consumed + second.consumed), (1, 2, out.len()));
    }
}
