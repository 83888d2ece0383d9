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

mod bodies;
mod check;
mod read;
mod reduce;

pub use bodies::MARKER_MASS;
pub use check::PLACEHOLDER_TORQUE_RATIO;
pub use reduce::{LockedJoint, TOOL_WORDS};

use anyhow::{Context, Result, anyhow, bail};
use bodies::{Frames, Tree, collision_bodies};
use check::placeholder_warnings;
use chessarm_core::arm::bodies::Bodies;
use chessarm_core::arm::chain::{ChainError, ChainJoint, SerialChain, model_from_chain};
use chessarm_core::arm::kinematics::Pose;
use chessarm_core::arm::model::{ArmModel, Friction, Inertial, JointLimits};
use chessarm_core::nalgebra::Vector3;
use read::{JointElement, at, axis_of, child, friction, gravity, inertial, limits, lock_range, mimic, origin};
use reduce::{Carried, choose_tool, default_hold, mimic_value, motion, wrong_count};
use roxmltree::{Document, Node};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

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
    let text = crate::app::formats::pgn::read_text("URDF file", path, crate::app::formats::pgn::MAX_URDF_BYTES)?;
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
    // A xacro element, or a `${…}` / `$(…)` substitution left in an attribute (an expanded
    // file may keep the namespace declaration: that alone is no sign).
    let xacro = || {
        anyhow!(
            "this is a xacro file (a template of URDF), not URDF: expand it first, e.g. `xacro FILE.urdf.xacro > \
             arm.urdf` (pip install xacro, or ROS 2: `ros2 run xacro xacro FILE.urdf.xacro > arm.urdf`)"
        )
    };
    let document = Document::parse(text).map_err(|e| {
        // A xacro element whose prefix is not declared is not XML either; it is still xacro.
        if text.contains("<xacro:") {
            xacro()
        } else {
            anyhow!("not valid XML: {}", crate::escape_controls(&e.to_string()))
        }
    })?;
    // A xacro element, or a `${…}` or `$(…)` substitution left in an attribute (an expanded file
    // may keep the namespace declaration, and xacro in its comments: those alone are no sign).
    let is_xacro = |n: &Node<'_, '_>| {
        n.tag_name().namespace().is_some_and(|ns| ns.contains("xacro"))
            || n.attributes().any(|a| a.value().contains("${") || a.value().contains("$("))
    };
    if document.descendants().any(|n| n.is_element() && is_xacro(&n)) {
        return Err(xacro());
    }
    let robot = document.root_element();
    if !robot.has_tag_name("robot") {
        bail!("{}: the root element must be <robot>", at(&robot));
    }
    let mut links = BTreeMap::new();
    // Problems that edits fix, gathered to be told at once after the shape is known.
    let mut problems: Vec<String> = Vec::new();
    let mut bad_inertial = std::collections::HashSet::new();
    for link in robot.children().filter(|n| n.has_tag_name("link")) {
        let name = link.attribute("name").ok_or_else(|| anyhow!("{}: a link needs a name", at(&link)))?;
        if name.trim().is_empty() {
            bail!("{}: a link's name must not be empty", at(&link));
        }
        // Every link's inertial is checked, the base's too, though it does not move.
        if let Err(e) = inertial(&link) {
            problems.push(e.to_string());
            bad_inertial.insert(name.to_string());
        }
        if links.insert(name.to_string(), link).is_some() {
            bail!("{}: a second link named '{name}'", at(&link));
        }
    }
    let mut joints: Vec<JointElement<'_, '_>> = Vec::new();
    // Each joint's index by name; each link's parent joint; each link's child joints.
    let mut by_name: BTreeMap<String, usize> = BTreeMap::new();
    let mut parent_joint: BTreeMap<String, usize> = BTreeMap::new();
    let mut children: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for joint in robot.children().filter(|n| n.has_tag_name("joint")) {
        let name = joint.attribute("name").ok_or_else(|| anyhow!("{}: a joint needs a name", at(&joint)))?.to_string();
        // The names become the exported trajectories' joint_names (ROS), which must be unique.
        if name.trim().is_empty() {
            bail!("{}: a joint's name must not be empty", at(&joint));
        }
        if let Some(first) = by_name.get(&name) {
            bail!("{}: a second joint named '{name}' (the first at {})", at(&joint), at(&joints[*first].node));
        }
        let kind = joint.attribute("type").ok_or_else(|| anyhow!("{}: a joint needs a type", at(&joint)))?.to_string();
        if !matches!(kind.as_str(), "fixed" | "revolute" | "continuous" | "prismatic") {
            bail!(
                "{}: type=\"{kind}\": chessarm takes revolute, continuous, prismatic (locked) and fixed joints; a \
                 {kind} joint cannot be modelled",
                at(&joint)
            );
        }
        let link_of = |tag: &str| -> Result<String> {
            let element = child(&joint, tag).ok_or_else(|| anyhow!("{}: needs a <{tag} link=\"…\"/>", at(&joint)))?;
            let link = element.attribute("link").ok_or_else(|| anyhow!("{}: <{tag}> needs link=\"…\"", at(&joint)))?;
            if !links.contains_key(link) {
                bail!("{}: <{tag} link=\"{link}\"> names no link of the file", at(&joint));
            }
            Ok(link.to_string())
        };
        let (parent, child_link) = (link_of("parent")?, link_of("child")?);
        let index = joints.len();
        if let Some(other) = parent_joint.insert(child_link.clone(), index) {
            bail!("{}: link '{child_link}' is already the child of joint '{}'", at(&joint), joints[other].name);
        }
        by_name.insert(name.clone(), index);
        children.entry(parent.clone()).or_default().push(index);
        joints.push(JointElement { node: joint, name, kind, parent, child: child_link });
    }
    let roots: Vec<&String> = links.keys().filter(|name| !parent_joint.contains_key(*name)).collect();
    let root = match roots.as_slice() {
        [root] => (*root).clone(),
        [] if links.is_empty() => bail!("{}: the robot has no links", at(&robot)),
        [] => bail!("every link is some joint's child: the joints form a loop, not a tree from a base"),
        many => bail!(
            "links {} have no parent joint: the file must describe one tree from a single base link",
            many.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ")
        ),
    };
    // Every link is reached from the root (no loop hides behind a second root).
    let mut order: Vec<String> = Vec::with_capacity(links.len());
    let mut stack = vec![root.clone()];
    while let Some(link) = stack.pop() {
        for &j in children.get(&link).map_or(&[][..], Vec::as_slice).iter().rev() {
            stack.push(joints[j].child.clone());
        }
        order.push(link);
    }
    if order.len() != links.len() {
        let reached: std::collections::HashSet<&String> = order.iter().collect();
        let (name, node) =
            links.iter().find(|(name, _)| !reached.contains(name)).map_or(("", None), |(n, l)| (n, Some(l)));
        bail!(
            "{}: link '{name}' is not reached from '{root}': its joints form a loop",
            node.map_or_else(String::new, at)
        );
    }

    let mut notes = Vec::new();
    let tool_link = choose_tool(options.tool.as_deref(), &links, &joints, &children, &root, &mut notes)?;
    // The joints from the root to the tool link, in order.
    let mut path = Vec::new();
    let mut link = tool_link.clone();
    while let Some(&j) = parent_joint.get(&link) {
        path.push(j);
        link = joints[j].parent.clone();
    }
    path.reverse();
    let on_path: std::collections::HashSet<usize> = path.iter().copied().collect();

    // Locks the user gave, checked.
    let mut values: BTreeMap<usize, f64> = BTreeMap::new();
    for (name, value) in &options.locks {
        let Some(&j) = by_name.get(name) else {
            let movable: Vec<String> =
                joints.iter().filter(|j| j.kind != "fixed").map(|j| format!("'{}'", j.name)).collect();
            bail!("--lock {name}={value}: the file has no joint '{name}' (its moving joints: {})", movable.join(", "));
        };
        let joint = &joints[j];
        if joint.kind == "fixed" {
            bail!("--lock {name}={value}: {} is a fixed joint already", at(&joint.node));
        }
        if let Some((leader, ..)) = mimic(&joint.node)? {
            bail!("--lock {name}={value}: {} follows '{leader}' (<mimic>): lock '{leader}' instead", at(&joint.node));
        }
        if values.insert(j, *value).is_some() {
            bail!("--lock {name}: given twice");
        }
    }
    // The arm's joints: the moving joints on the way to the tool that are not locked and follow
    // no other (a <mimic> follower moves with its leader: held with it below, and refused there
    // when its leader is one of the arm's joints, as in a parallel linkage).
    let mut followers = std::collections::HashSet::new();
    for &j in &path {
        if mimic(&joints[j].node)?.is_some() {
            followers.insert(j);
        }
    }
    let arm: Vec<usize> = path
        .iter()
        .copied()
        .filter(|j| joints[*j].kind != "fixed" && !values.contains_key(j) && !followers.contains(j))
        .collect();
    if let Some(&j) = arm.iter().find(|j| joints[**j].kind == "prismatic") {
        bail!(
            "{}: a prismatic joint on the way to the tool: chessarm's arm turns, it does not slide; hold it with --lock \
             {}=VALUE (m)",
            at(&joints[j].node),
            joints[j].name
        );
    }
    if arm.len() != 4 {
        bail!("{}", wrong_count(&joints, &path, &arm, &values, &tool_link, &root)?);
    }

    // Every other moving joint is held: at the user's value, its leader's (mimic), or a default.
    let mut locked = Vec::new();
    let arm_set: std::collections::HashSet<usize> = arm.iter().copied().collect();
    let after_arm = |j: usize| -> bool {
        // Whether joint j lies after the arm's last joint (a gripper's).
        let mut link = joints[j].parent.clone();
        loop {
            match parent_joint.get(&link) {
                Some(&p) if p == arm[3] => return true,
                Some(&p) if arm_set.contains(&p) => return false,
                Some(&p) => link = joints[p].parent.clone(),
                None => return false,
            }
        }
    };
    let mut defaults = Vec::new();
    let user_locked: std::collections::HashSet<usize> = values.keys().copied().collect();
    for (j, joint) in joints.iter().enumerate() {
        if joint.kind == "fixed" || arm_set.contains(&j) {
            continue;
        }
        let range = lock_range(&joint.node, &joint.kind).unwrap_or_else(|e| {
            problems.push(e.to_string());
            None
        });
        let value = match (values.get(&j), mimic(&joint.node)?) {
            (Some(value), _) => *value,
            (None, Some(_)) => mimic_value(j, &joints, &by_name, &values, &arm_set, 0)?,
            (None, None) => {
                let value = default_hold(range);
                if on_path.contains(&j) {
                    unreachable!("a moving joint on the path is either the arm's or locked");
                }
                defaults.push(format!("{} = {}", joint.name, chessarm_core::short_number(value)));
                value
            }
        };
        if let Some((lower, upper)) = range
            && !(lower - 1e-12..=upper + 1e-12).contains(&value)
        {
            problems.push(format!(
                "{}: held at {} {}, outside its <limit lower=\"{lower}\" upper=\"{upper}\">",
                at(&joint.node),
                chessarm_core::short_number(value),
                if joint.kind == "prismatic" { "m" } else { "rad" }
            ));
        }
        values.insert(j, value);
        // A gripper's joint: off the way to the tool, after the arm, not held by the user.
        let gripper = match range {
            Some((lower, upper)) if after_arm(j) && !on_path.contains(&j) && !user_locked.contains(&j) => {
                Some(if upper.abs() >= lower.abs() { [upper, lower] } else { [lower, upper] })
            }
            _ => None,
        };
        locked.push(LockedJoint { name: joint.name.clone(), kind: joint.kind.clone(), value, gripper });
    }
    // A <mimic> follower opens and closes with its leader: multiplier·leader + offset (its own
    // limits, if any, do not decide it).
    for index in 0..locked.len() {
        let Some(&j) = by_name.get(&locked[index].name) else { continue };
        let Some((leader, multiplier, offset)) = mimic(&joints[j].node)? else { continue };
        // With its leader held still (no open and close values), it is held still too.
        locked[index].gripper = locked
            .iter()
            .find(|l| l.name == leader)
            .and_then(|l| l.gripper)
            .map(|[open, close]| [multiplier * open + offset, multiplier * close + offset]);
    }
    if !defaults.is_empty() {
        notes.push(format!(
            "held for the dynamics at the file's zero pose (or the nearest limit): {} (--lock NAME=VALUE to choose)",
            defaults.join(", ")
        ));
    }

    // Every link's carrier (the base or an arm joint's link) and pose in its frame, root first.
    let mut carried: BTreeMap<String, Carried> = BTreeMap::new();
    carried.insert(root.clone(), (0, Pose::identity()));
    for link in order.iter().skip(1) {
        let j = parent_joint[link];
        let joint = &joints[j];
        let (carrier, parent_pose) = carried[&joint.parent];
        let at_joint = parent_pose * origin(&joint.node)?;
        let entry = match arm.iter().position(|a| *a == j) {
            Some(k) => (k + 1, Pose::identity()),
            None if joint.kind == "fixed" => (carrier, at_joint),
            None => (carrier, at_joint * motion(&joint.kind, &axis_of(&joint.node)?, values[&j])),
        };
        carried.insert(link.clone(), entry);
    }

    let mut bodies = [Inertial::zero(); 4];
    let mut own_inertial = [false; 4];
    for link in &order {
        let (carrier, pose) = carried[link];
        if carrier == 0 {
            continue;
        }
        let node = links[link];
        let moved_link = parent_joint.get(link).is_some_and(|j| arm.get(carrier - 1) == Some(j));
        // (A link whose <inertial> is wrong is among the problems already.)
        let Ok(Some(body)) = inertial(&node) else { continue };
        if moved_link {
            own_inertial[carrier - 1] = true;
        } else if body.mass < MARKER_MASS {
            continue;
        }
        if let Err(e) = chessarm_core::arm::model::validate_inertial("its <inertial>", &body, true) {
            problems.push(format!("{}: {e}", at(&node)));
            continue;
        }
        bodies[carrier - 1] = bodies[carrier - 1].combine(&body.transformed(&pose));
    }
    for (k, &j) in arm.iter().enumerate() {
        let moved = &joints[j].child;
        if bodies[k].mass <= 0.0 && !bad_inertial.contains(moved) {
            problems.push(if own_inertial[k] {
                format!("{}: <mass value=\"0\">: a moving link needs a mass > 0", at(&links[moved.as_str()]))
            } else {
                format!(
                    "{}: has no <inertial>; chessarm needs the mass, centre of mass and inertia of every link a joint \
                     moves (this one is moved by joint '{}')",
                    at(&links[moved.as_str()]),
                    joints[j].name
                )
            });
        }
    }
    let (tool_carrier, tool_pose) = carried[&tool_link];
    if tool_carrier != 4 {
        bail!(
            "{}: the tool link '{tool_link}' is not moved by the arm's last joint '{}': give the link at the tool tip \
             with --tool LINK",
            at(&links[tool_link.as_str()]),
            joints[arm[3]].name
        );
    }
    let tool = tool_pose * Pose::from_parts(options.tool_offset.into(), chessarm_core::nalgebra::Rotation3::identity());

    // The chain: each arm joint's frame in the previous arm joint's link frame.
    let mut signs = [1.0; 4];
    let mut chain_joints = Vec::with_capacity(4);
    for (k, &j) in arm.iter().enumerate() {
        let joint = &joints[j];
        let (_, parent_pose) = carried[&joint.parent];
        let mut axis = axis_of(&joint.node)?;
        let joint_origin = parent_pose * origin(&joint.node)?;
        let mut joint_limits = match limits(&joint.node, &joint.kind) {
            Ok(limits) => limits,
            Err(e) => {
                problems.push(e.to_string());
                JointLimits { lower: -PI, upper: PI, velocity: 1.0, torque: 1.0 }
            }
        };
        if k == 0 {
            // A base yaw about −z (the SO-101's): the model turns about +z, so its angle is
            // the URDF's negated, and the limits swap.
            let up = (joint_origin.rotation * axis).normalize();
            if up.z < 0.0 && up.xy().norm() < chessarm_core::arm::chain::AXIS_TOLERANCE {
                axis = -axis;
                signs[0] = -1.0;
                joint_limits = JointLimits { lower: -joint_limits.upper, upper: -joint_limits.lower, ..joint_limits };
                notes.push(format!(
                    "joint '{}' turns about −z: chessarm's model turns its base about +z, and every angle, rate and \
                     torque of it you give or read stays in the file's sense",
                    joint.name
                ));
            }
        }
        chain_joints.push(ChainJoint {
            name: joint.name.clone(),
            origin: joint_origin,
            axis,
            limits: joint_limits,
            friction: friction(&joint.node).unwrap_or_else(|e| {
                problems.push(e.to_string());
                Friction::default()
            }),
            body: bodies[k],
        });
    }
    // Speed and torque limits not given (a continuous joint without <limit>, or 0): the other
    // arm joints' smallest, said as a warning; none given at all is a problem.
    let mut filled = Vec::new();
    for k in 0..chain_joints.len() {
        for (name, pick) in [("velocity", 0), ("effort", 1)] {
            let get = |l: &JointLimits| if pick == 0 { l.velocity } else { l.torque };
            if get(&chain_joints[k].limits) > 0.0 {
                continue;
            }
            let others = chain_joints.iter().map(|j| get(&j.limits)).filter(|v| *v > 0.0).fold(f64::INFINITY, f64::min);
            let node = at(&joints[arm[k]].node);
            if others.is_finite() {
                let limits = &mut chain_joints[k].limits;
                if pick == 0 {
                    limits.velocity = others
                } else {
                    limits.torque = others
                }
                filled.push(format!(
                    "{node}: no {name} limit given (missing or 0): taken as {} {}, the smallest of the other arm joints'",
                    chessarm_core::short_number(others),
                    if pick == 0 { "rad/s" } else { "N·m" }
                ));
            } else {
                problems.push(format!("{node}: no arm joint gives a {name} limit: add <limit {name}=\"…\"/>"));
            }
        }
    }
    let Ok(chain_joints) = <[ChainJoint; 4]>::try_from(chain_joints) else { unreachable!("four arm joints") };
    let chain = SerialChain { joints: chain_joints, tool, gravity: gravity(&robot)? };
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
    let model = model_from_chain(&chain).map_err(|error| anyhow!("{}", located(error)))?;
    let joint_names = chain.joints.clone().map(|joint| joint.name);
    let (effort_warnings, mut warnings) = placeholder_warnings(&model, &joint_names, &joints, &links, &by_name, &arm);
    warnings.extend(filled);
    let links_of =
        Tree { order: &order, carried: &carried, links: &links, parent_joint: &parent_joint, joints: &joints };
    let in_dh = chessarm_core::arm::chain::chain_frames_in_dh(&chain, &model);
    // A shape reaching farther from its link than twice the whole chain is long is a unit slip.
    let chain_length: f64 = model.links().iter().map(|l| l.dh.a.hypot(l.dh.d)).sum();
    let frames = Frames { in_dh: &in_dh, farthest: 2.0 * chain_length.max(0.1) };
    let bodies = collision_bodies(&links_of, &arm, &locked, &frames, folder, &mut notes, &mut warnings)?;
    Ok(ImportedArm {
        model,
        joint_names,
        base_link: root,
        signs,
        locked,
        tool_link,
        notes,
        warnings,
        effort_warnings,
        bodies,
    })
}
