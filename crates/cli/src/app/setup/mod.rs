//! The setup, resolved once: the setup file ([`file`]), the URDF import ([`urdf_import`]) and
//! its meshes ([`meshes`]), the actuators ([`actuators`]), the file's gripper against the pieces
//! ([`gripper`]), and the sensors and model errors of a study ([`conditions`]), each turned into
//! the core's and the chess crate's types.

pub mod actuators;
pub mod condition_tables;
pub mod conditions;
pub mod file;
pub mod gripper;
pub mod meshes;
pub mod servos;
pub mod urdf_import;

use anyhow::Result;
use chessarm_core::control::servo_host::ServoCommand;
use chessarm_core::nalgebra::Vector3;
use file::Setup;
use std::path::PathBuf;

/// What a setup is made of, as the user gives it (the command line's global flags, Python's
/// `Setup` constructors): all optional, the report's arm with torque motors when nothing is given.
#[derive(Debug, Clone, Default)]
pub struct SetupOptions {
    /// The setup file (TOML); the built-in report arm when absent.
    pub arm: Option<PathBuf>,
    /// A URDF whose chain becomes the arm (its `[urdf]` table in the setup file, if any, applies).
    pub urdf: Option<PathBuf>,
    /// Joints of the URDF held fixed at an angle (rad) or travel (m), over the setup file's.
    pub lock: Vec<(String, f64)>,
    /// The URDF's link the tool point belongs to, over the setup file's.
    pub tool: Option<String>,
    /// The tool point in that link's frame (m), over the setup file's.
    pub tool_offset: Option<[f64; 3]>,
    /// Actuator names, one for all joints or one per joint (built-in profiles or the setup
    /// file's `[actuators.NAME]`); the setup file's choice when absent.
    pub actuator: Option<Vec<String>>,
    /// How the host drives position servos; the one default strategy when absent.
    pub servo_command: Option<Vec<ServoCommand>>,
    /// The servo bus's rate, Hz; [`file::DEFAULT_BUS_RATE`] when absent.
    pub bus_rate: Option<f64>,
}

/// A resolved setup and what the person should be told about it (a URDF's notes and warnings,
/// one line each, the file named).
#[derive(Debug, Clone)]
pub struct Resolved {
    pub setup: Setup,
    pub notes: Vec<String>,
}

/// Resolves a setup once: the setup file (or the report's arm), then a URDF's chain with its
/// locks and tool (the flags over the file's `[urdf]`), then the actuators; with servos or
/// steppers their stall (holding) torques become the joints' torque limits, the limits the
/// planner, the reach check and the plots use.
///
/// # Errors
///
/// An unreadable or invalid setup file or URDF, a setup file's `[urdf]` table without a URDF,
/// an unknown actuator, servo options for torque motors.
pub fn resolve(options: &SetupOptions) -> Result<Resolved> {
    let mut setup = Setup::load(options.arm.as_deref())?;
    let mut notes = Vec::new();
    if options.urdf.is_none() && setup.urdf.is_some() {
        anyhow::bail!(
            "{}: its [urdf] table is for the arm of a URDF: give --urdf FILE with it",
            options.arm.as_ref().map_or(String::new(), |p| p.display().to_string())
        );
    }
    if let Some(path) = &options.urdf {
        // The setup file's [urdf], then the options over it.
        let mut urdf = setup.urdf.clone().unwrap_or_default();
        for (name, value) in &options.lock {
            urdf.lock.insert(name.clone(), *value);
        }
        if let Some(tool) = &options.tool {
            // The file's offset is a point of the file's tool link, not of another one.
            if urdf.tool.as_ref() != Some(tool) {
                urdf.tool_offset = None;
            }
            urdf.tool = Some(tool.clone());
        }
        if let Some(offset) = options.tool_offset {
            urdf.tool_offset = Some(offset.to_vec());
        }
        let offset = urdf.tool_offset.as_deref().unwrap_or(&[0.0; 3]);
        let import = urdf_import::ImportOptions {
            locks: urdf.lock.iter().map(|(name, value)| (name.clone(), *value)).collect(),
            tool: urdf.tool.clone(),
            tool_offset: Vector3::new(offset[0], offset[1], offset[2]),
        };
        setup.urdf = Some(urdf);
        let imported = urdf_import::load(path, &import)?;
        for note in &imported.notes {
            notes.push(format!("{}: {note}", path.display()));
        }
        // Servos' stall torques replace the file's efforts (below): a placeholder effort is then
        // not the limit.
        let servos = options
            .actuator
            .as_ref()
            .map_or(setup.actuators.take_positions(), |names| names.iter().any(|name| name != actuators::TORQUE));
        let efforts = if servos { &[][..] } else { &imported.effort_warnings[..] };
        for warning in efforts.iter().chain(&imported.warnings) {
            notes.push(format!("warning: {}: {warning}", path.display()));
        }
        setup.urdf_path = Some(path.clone());
        setup.take_urdf_arm(imported);
    }
    if let Some(names) = &options.actuator {
        setup.actuators = actuators::resolve(names, &setup.actuator_tables, "--actuator")?;
        setup.actuator_names = std::array::from_fn(|j| names.get(j).unwrap_or(&names[0]).clone());
    }
    if !setup.actuators.take_positions() && (options.servo_command.is_some() || options.bus_rate.is_some()) {
        anyhow::bail!(
            "--servo-command and --bus-rate are for servos; the joints have torque motors (give --actuator NAME)"
        );
    }
    if setup.actuators.take_positions() {
        let mut links = *setup.arm.links();
        for (link, stall) in links.iter_mut().zip(setup.actuators.torque_limits()) {
            link.limits.torque = stall;
        }
        setup.arm = setup.arm.with_links(links)?;
    }
    setup.servo_commands = options.servo_command.clone().unwrap_or_else(|| vec![ServoCommand::default()]);
    setup.bus_rate = options.bus_rate.unwrap_or(file::DEFAULT_BUS_RATE);
    Ok(Resolved { setup, notes })
}
