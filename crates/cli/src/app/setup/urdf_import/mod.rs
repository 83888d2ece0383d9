//! `--urdf FILE`: the user's own arm from URDF, as its maker publishes it.
//!
//! The file is a tree from its root link. The tool link is `--tool` (with `--tool-offset`),
//! else a leaf at the end of a fixed joint named like a tool ([`TOOL_WORDS`]), else the only
//! such leaf. The way from the root to it must hold a base yaw (about ±z) and three parallel
//! pitch joints once `--lock` holds the others; every joint off that way is held (fixed,
//! prismatic and continuous gripper joints at 0 or their limit nearest it, `<mimic>` followers
//! at `multiplier·leader + offset`), and every link the arm's joints do not move is carried, with
//! its mass and inertia, by the link it hangs on (composite rigid bodies). Joint origins may be
//! anywhere and turned any way: the chain is converted to standard DH by
//! [`chessarm_core::arm::chain::model_from_chain`], a root off the yaw axis becoming the
//! model's base position, a yaw about −z a joint whose angle is the file's negated
//! ([`ImportedArm::signs`], applied at every edge). The shape is checked first; every other
//! problem comes in one error naming each element, its line, and the fix.
//!
//! What URDF leaves out: gravity is `(0, 0, −9.8)` m/s² unless the file carries chessarm's
//! `<mujoco><option gravity="x y z"/></mujoco>` extension (which `chessarm urdf` writes);
//! motor masses and rotor inertias are 0; a continuous joint's range is `[−π, π]`; bodies of
//! less than [`MARKER_MASS`] after fixed joints are frame markers and are left out (so
//! `chessarm urdf`'s tool marker does not add its trace of mass).
//!
//! [`from_urdf_in`] goes through the rooms in turn: `read` the XML (the document, the tree of
//! links and joints, each element's values), `reduce` the tree to the chain (the tool, the arm's
//! four joints, every other joint held, the links merged onto the ones that carry them), `bodies`
//! (the composite inertias, the collision bodies) and `check` (limits not given, placeholders).

mod bodies;
mod check;
mod read;
mod reduce;

use anyhow::{Context, Result, anyhow, bail};
use bodies::{Frames, Tree};
use chessarm_core::arm::bodies::Bodies;
use chessarm_core::arm::chain::{ChainError, ChainJoint, SerialChain, model_from_chain};
use chessarm_core::arm::link::{Inertial, JointLimits};
use chessarm_core::arm::model::ArmModel;
use chessarm_core::nalgebra::Vector3;
use read::{FileTree, at};
use std::f64::consts::PI;
use std::path::Path;

pub use bodies::MARKER_MASS;
pub use check::PLACEHOLDER_TORQUE_RATIO;
pub use reduce::{LockedJoint, TOOL_WORDS};

/// An arm read from URDF, with the names a driver knows it by.
#[derive(Debug, Clone)]
pub struct ImportedArm {
    pub model: ArmModel<4>,
    /// The four moving joints' names, base to tool.
    pub joint_names: [String; 4],
    /// The root link (the base frame's name).
    pub base_link: String,
    /// Per arm joint, ±1: the file's angle is `sign ·` the model's (−1 for a base yaw about −z).
    pub signs: [f64; 4],
    /// Every other moving joint of the file, held at its value, in the file's order.
    pub locked: Vec<LockedJoint>,
    /// The link whose origin (plus `--tool-offset`) is the tool point.
    pub tool_link: String,
    /// What the import chose for the user (tool frame, held joints), for the terminal.
    pub notes: Vec<String>,
    /// Values that look like placeholders, for the terminal.
    pub warnings: Vec<String>,
    /// Efforts that look like placeholders (said unless servos replace them by their stall
    /// torques).
    pub effort_warnings: Vec<String>,
    /// What the clearance check takes the arm's links to be: the file's `<collision>` shapes,
    /// or chessarm's own solids where the file gives none or a mesh is missing (said in
    /// `notes` or `warnings`).
    pub bodies: Bodies,
}

/// Reads the arm of the URDF file at `path`.
///
/// # Errors
///
/// The file cannot be read, is not XML, or describes something chessarm cannot model; the
/// message names the file, the element and its line.
pub fn load(path: &Path, options: &ImportOptions) -> Result<ImportedArm> {
    let text = crate::app::input::read_text("URDF file", path, crate::app::input::MAX_URDF_BYTES)?;
    let folder = path.parent().map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p });
    from_urdf_in(&text, options, folder).with_context(|| format!("URDF file {}", path.display()))
}

/// How a URDF becomes chessarm's arm: joints to lock and the tool frame (`--lock`, `--tool`,
/// `--tool-offset`).
#[derive(Debug, Clone, Default)]
pub struct ImportOptions {
    /// Joints held at a value (rad, or m for a prismatic joint), by name, as the user gave them.
    pub locks: Vec<(String, f64)>,
    /// The tool link (`None`: a well-known name or the single leaf).
    pub tool: Option<String>,
    /// The tool point in the tool link's frame, m.
    pub tool_offset: Vector3<f64>,
}

/// The arm described by URDF `text`, as [`ImportOptions`] say, its meshes looked for
/// relative to the working folder.
///
/// # Errors
///
/// As [`from_urdf_in`].
pub fn from_urdf(text: &str, options: &ImportOptions) -> Result<ImportedArm> {
    from_urdf_in(text, options, None)
}

/// The arm described by URDF `text`, as [`ImportOptions`] say, for a file in `folder` (where
/// its relative mesh names start).
///
/// # Errors
///
/// As [`load`], without the file name.
pub fn from_urdf_in(text: &str, options: &ImportOptions, folder: Option<&Path>) -> Result<ImportedArm> {
    let document = read::document(text)?;
    // Problems that edits fix, gathered to be told at once after the shape is known.
    let mut problems: Vec<String> = Vec::new();
    let file = read::tree(&document, &mut problems)?;
    let mut notes = Vec::new();
    let tool_link = reduce::choose_tool(options.tool.as_deref(), &file, &mut notes)?;
    let path = reduce::path_to(&file, &tool_link);
    let mut values = reduce::user_locks(&options.locks, &file)?;
    let arm = reduce::arm_joints(&file, &path, &values, &tool_link)?;
    let locked = reduce::hold_others(&file, &path, &arm, &mut values, &mut problems, &mut notes)?;
    let carried = reduce::carriers(&file, &arm, &values)?;
    let inertias = bodies::composite(&file, &carried, &arm, &mut problems);
    let tool = reduce::tool_frame(&file, &carried, &arm, &tool_link, options.tool_offset)?;
    let (mut chain_joints, signs) = reduce::chain_joints(&file, &carried, &arm, &inertias, &mut problems, &mut notes)?;
    let filled = check::fill_missing_limits(&mut chain_joints, &file.joints, &arm, &mut problems);
    let Ok(chain_joints) = <[ChainJoint; 4]>::try_from(chain_joints) else { unreachable!("four arm joints") };
    let chain = SerialChain { joints: chain_joints, tool, gravity: read::gravity(&file.robot)? };
    let model = model_of(&chain, &file, &problems)?;
    let joint_names = chain.joints.clone().map(|joint| joint.name);
    let (effort_warnings, mut warnings) =
        check::placeholder_warnings(&model, &joint_names, &file.joints, &file.links, &file.by_name, &arm);
    warnings.extend(filled);
    let links_of = Tree {
        order: &file.order,
        carried: &carried,
        links: &file.links,
        parent_joint: &file.parent_joint,
        joints: &file.joints,
    };
    let in_dh = chessarm_core::arm::chain::chain_frames_in_dh(&chain, &model);
    // A shape reaching farther from its link than twice the whole chain is long is a unit slip.
    let chain_length: f64 = model.links().iter().map(|l| l.dh.a.hypot(l.dh.d)).sum();
    let frames = Frames { in_dh: &in_dh, farthest: 2.0 * chain_length.max(0.1) };
    let (bodies, driving) =
        bodies::collision_bodies(&links_of, &arm, &locked, &frames, folder, &mut notes, &mut warnings)?;
    let mut locked = locked;
    for joint in &mut locked {
        joint.finger = driving.iter().find(|(name, ..)| *name == joint.name).map(|&(_, m, o)| (m, o));
    }
    Ok(ImportedArm {
        model,
        joint_names,
        base_link: file.root.clone(),
        signs,
        locked,
        tool_link,
        notes,
        warnings,
        effort_warnings,
        bodies,
    })
}

/// The model of `chain`, its shape checked first (the one refusal no edit of a value fixes),
/// then the `problems` told at once, each error naming its joint's element.
fn model_of(chain: &SerialChain, file: &FileTree<'_, '_>, problems: &[String]) -> Result<ArmModel<4>> {
    let FileTree { joints, by_name, .. } = file;
    let located = |error: ChainError| {
        let joint = match &error {
            ChainError::Shape { joint, .. } | ChainError::Model { joint, .. } => joint.clone(),
        };
        let why = error.to_string().split_once(": ").map_or(String::new(), |(_, why)| why.to_string());
        match by_name.get(&joint) {
            Some(&j) => format!("{}: {why}", at(&joints[j].node)),
            None => error.to_string(),
        }
    };
    // The shape first: the one refusal no edit of a value fixes.
    let mut probe = chain.clone();
    for joint in &mut probe.joints {
        joint.body = Inertial::point(1.0, Vector3::zeros());
        joint.limits = JointLimits { lower: -PI, upper: PI, velocity: 1.0, torque: 1.0 };
    }
    if let Err(error @ ChainError::Shape { .. }) = model_from_chain(&probe) {
        bail!("{}", located(error));
    }
    if !problems.is_empty() {
        if problems.len() == 1 {
            bail!("{}", problems[0]);
        }
        let listed: Vec<String> = problems.iter().enumerate().map(|(i, p)| format!("({}) {p}", i + 1)).collect();
        bail!("{} problems: {}", problems.len(), listed.join("; "));
    }
    model_from_chain(chain).map_err(|error| anyhow!("{}", located(error)))
}
