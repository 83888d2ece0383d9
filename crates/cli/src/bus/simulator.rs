//! A simulated servo bus: the arm's four joint servos (and a gripper servo, if the setup names
//! one) answering either protocol on a pseudo-terminal, with the actuator model behind them.
//!
//! The joints are the setup's arm under its servos ([`Actuators::plant_model`]: gears,
//! friction, back-EMF) driven by the servos' firmware ([`PositionBank`]), integrated in real
//! time (1 ms steps, caught up to the wall clock before each packet is answered): a goal
//! written over the bus moves the simulated joint as the servo would, and a present position
//! read back is where it is, in whole ticks. While every joint's torque is off the arm rests
//! where it is (it stands on its stops: falling is not simulated); a joint whose torque goes off
//! while others hold it gets no drive torque.
//!
//! Faults can be injected to test a driver: a servo that stops answering, or one that reports
//! an overload (and turns its torque off, as the servos' own protection does), each after a
//! given number of goal packets. Every instruction received is logged (time and bytes).

use super::Protocol;
use crate::actuators::ServoBus;
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::control::JointState;
use chessarm_core::sim::actuator::{Actuators, PositionBank};
use chessarm_core::sim::{Integrator, Plant};
use std::io::Write;
use std::time::Instant;

/// Plant time step, s.
const DT: f64 = 1e-3;

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

    /// Integrates the arm up to the wall clock's time since the bus started.
    pub fn catch_up(&mut self) -> anyhow::Result<()> {
        self.advance_to(self.started.elapsed().as_secs_f64())
    }

    /// Integrates the arm up to simulated time `t` (s).
    ///
    /// # Errors
    ///
    /// The dynamics failed (a mass matrix not positive definite).
    pub fn advance_to(&mut self, t: f64) -> anyhow::Result<()> {
        let held: [bool; 4] = std::array::from_fn(|j| self.servos[j].torque);
        while self.time + DT <= t {
            if held.iter().any(|h| *h) {
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
            } else {
                self.state.qd = JointVector::zeros();
            }
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

    /// Answers the instruction packets at the front of `input` (consumed from it), the replies
    /// appended to `output`. A packet cut short waits for its rest; a damaged one is dropped, as
    /// a servo drops it.
    ///
    /// # Errors
    ///
    /// The dynamics failed, or the log could not be written.
    pub fn answer(&mut self, input: &mut Vec<u8>, output: &mut Vec<u8>) -> anyhow::Result<()> {
        use super::PacketError;
        loop {
            match self.protocol.parse_instruction(input) {
                Ok(packet) => {
                    let bytes = input[packet.start..packet.consumed].to_vec();
                    input.drain(..packet.consumed);
                    if let Some(log) = &mut self.log {
                        let hex: String = bytes.iter().map(|b| format!("{b:02X}")).collect();
                        writeln!(log, "{{\"t\": {:.6}, \"packet\": \"{hex}\"}}", self.started.elapsed().as_secs_f64())?;
                        log.flush()?;
                    }
                    self.catch_up()?;
                    self.handle(packet.id, packet.error, &packet.params, output);
                }
                Err(PacketError::Short { .. }) => return Ok(()),
                Err(PacketError::NoHeader(_)) => {
                    // Keep a possible header's first bytes.
                    let keep = input.len().min(3);
                    input.drain(..input.len() - keep);
                    return Ok(());
                }
                Err(PacketError::Checksum { .. } | PacketError::Malformed(_)) => {
                    // Past this header: the next one is looked for.
                    let at = input.iter().position(|b| *b == 0xFF).unwrap_or(0);
                    input.drain(..=at.min(input.len().saturating_sub(1)));
                }
            }
        }
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
                for &target in &params[header..] {
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
    ) -> anyhow::Result<()> {
        use std::io::Read;
        let mut input = Vec::new();
        let mut output = Vec::new();
        let mut chunk = [0u8; 1024];
        while !stop() {
            while let Some(q) = hand.and_then(|h| h.try_recv().ok()) {
                self.catch_up()?;
                if !self.move_by_hand(q) {
                    crate::tell("bus-sim: not moved: a joint's torque is on\n");
                }
            }
            if !super::port::wait_readable(&terminal.controller, std::time::Duration::from_millis(20))? {
                continue;
            }
            let n = match terminal.controller.read(&mut chunk) {
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            };
            input.extend_from_slice(&chunk[..n]);
            self.answer(&mut input, &mut output)?;
            if !output.is_empty() {
                terminal.controller.write_all(&output)?;
                terminal.controller.flush()?;
                output.clear();
            }
        }
        Ok(())
    }
}
