//! `bus-sim`: the setup's servos on a simulated bus ([`crate::app::bus::simulator`]) on a
//! pseudo-terminal, for a driver (`play --port`, `calibrate --port`) or a vendor's SDK to talk
//! to. A line `pose Q1,Q2,Q3,Q4` on its standard input (rad, the setup's sense) moves the arm by
//! hand while its torque is off.

use crate::app::bus::port::PseudoTerminal;
use crate::app::bus::simulator::{Faults, SimulatedBus};
use crate::app::setup::file::Setup;
use crate::cli::BusSimArgs;
use anyhow::{Context, Result, bail};
use chessarm_core::arm::model::JointVector;

pub fn run(setup: &Setup, args: &BusSimArgs) -> Result<()> {
    if !setup.actuators.take_positions() {
        bail!(
            "bus-sim simulates servos: give them with --actuator (e.g. --actuator sts3215) or the setup's [actuators]"
        );
    }
    let bus = crate::app::setup::servos::ServoBus::of(setup)?;
    // A fault for a servo not on the bus would never fire: refused before the bus starts.
    let on_bus: Vec<u8> = bus.ids.iter().copied().chain(bus.gripper.map(|g| g.id)).collect();
    for (flag, fault) in [("--lose-reply", args.lose_reply), ("--overload", args.overload)] {
        if let Some(fault) = fault
            && !on_bus.contains(&fault.id)
        {
            let ids: Vec<String> = on_bus.iter().map(u8::to_string).collect();
            bail!(
                "{flag} {}@{}: servo {} is not on the bus (its servos: {})",
                fault.id,
                fault.after,
                fault.id,
                ids.join(", ")
            );
        }
    }
    let Some(protocol) = args.protocol.or(bus.protocol) else {
        bail!(
            "bus-sim: the servos ({}) speak neither Feetech's nor Dynamixel's protocol; give --protocol or [servo_bus] protocol",
            setup.actuator_names.join(", ")
        );
    };
    let q = match args.start {
        Some(user) => JointVector::<4>::from(setup.convention.user(user)),
        None => chessarm_chess::play::home_pose(&setup.arm, &setup.board, &setup.pieces, &setup.motion.validated()?)?,
    };
    let gripper = bus.gripper.map(|g| (g.id, g.open));
    let mut sim = SimulatedBus::new(protocol, &setup.arm, &setup.actuators, bus, setup.convention.signs, q, gripper)?
        .with_faults(Faults { lose_reply: args.lose_reply, overload: args.overload });
    if let Some(path) = &args.log {
        // A new file only: nothing there is replaced (and no folder is locked for the bus's
        // whole life, as a result folder would be).
        let file = std::fs::OpenOptions::new().write(true).create_new(true).open(path).with_context(|| {
            format!(
                "--log {}: cannot create it (a file already there is not replaced: give a new path)",
                path.display()
            )
        })?;
        sim = sim.with_log(Box::new(std::io::BufWriter::new(file)));
    }
    let mut terminal = PseudoTerminal::open().context("cannot open a pseudo-terminal for the simulated bus")?;
    // The device's path is the one line on standard output: a script reads it.
    println!("{}", terminal.device_path);
    crate::tell(&format!(
        "simulated {} bus on {} (servos {:?}{}); Ctrl-C ends it\n",
        protocol.name(),
        terminal.device_path,
        bus.ids,
        bus.gripper.map(|g| format!(", gripper {}", g.id)).unwrap_or_default()
    ));
    // `pose Q1,Q2,Q3,Q4` lines on standard input (rad, the setup's sense) move the arm by hand
    // while its torque is off (calibration's tests touch squares so).
    let (sender, receiver) = std::sync::mpsc::channel();
    let signs = setup.convention.signs;
    std::thread::spawn(move || {
        use std::io::BufRead;
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            let Some(angles) = line.trim().strip_prefix("pose ") else { continue };
            match crate::args::angles(angles) {
                Ok(user) => {
                    let q = JointVector::<4>::from(std::array::from_fn::<f64, 4, _>(|j| signs[j] * user[j]));
                    if sender.send(q).is_err() {
                        break;
                    }
                }
                Err(e) => crate::tell(&format!("bus-sim: pose {angles}: {e}\n")),
            }
        }
    });
    sim.serve(&mut terminal, crate::cancelled, Some(&receiver), &|line| crate::tell(line))
}
