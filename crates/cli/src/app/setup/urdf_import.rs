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

use anyhow::{Context, Result, anyhow, bail};
use chessarm_core::arm::bodies::{Bodies, BodyShape, Shape};
use chessarm_core::arm::chain::{ChainError, ChainJoint, SerialChain, isometry_from_xyz_rpy, model_from_chain};
use chessarm_core::arm::kinematics::Pose;
use chessarm_core::arm::model::{ArmModel, Friction, Inertial, JointLimits, REPORT_GRAVITY};
use chessarm_core::nalgebra::{Matrix3, Vector3};
use roxmltree::{Document, Node};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

/// Bodies lighter than this (kg) fixed to a moving link are markers, not mass.
pub const MARKER_MASS: f64 = 1e-6;

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

/// Where a node is, for messages: `line L: <joint name="x">`.
fn at(node: &Node<'_, '_>) -> String {
    let position = node.document().text_pos_at(node.range().start);
    match node.attribute("name") {
        Some(name) => format!("line {}: <{} name=\"{name}\">", position.row, node.tag_name().name()),
        None => format!("line {}: <{}>", position.row, node.tag_name().name()),
    }
}

fn child<'a, 'input>(node: &Node<'a, 'input>, tag: &str) -> Option<Node<'a, 'input>> {
    node.children().find(|n| n.has_tag_name(tag))
}

/// Attribute `name` of `node` as a finite number.
fn number(node: &Node<'_, '_>, name: &str) -> Result<Option<f64>> {
    let Some(text) = node.attribute(name) else { return Ok(None) };
    match text.trim().parse::<f64>() {
        Ok(value) if value.is_finite() => Ok(Some(value)),
        _ => bail!("{}: {name}=\"{text}\" is not a finite number", at(node)),
    }
}

fn required(node: &Node<'_, '_>, name: &str, meaning: &str) -> Result<f64> {
    number(node, name)?.ok_or_else(|| anyhow!("{}: needs {name}=\"…\" ({meaning})", at(node)))
}

/// Attribute `name` as exactly three finite numbers, or `default` when absent.
fn triple(node: &Node<'_, '_>, name: &str, default: [f64; 3]) -> Result<[f64; 3]> {
    let Some(text) = node.attribute(name) else { return Ok(default) };
    let values: Vec<f64> = text.split_whitespace().filter_map(|v| v.parse().ok()).collect();
    if values.len() != 3 || text.split_whitespace().count() != 3 || values.iter().any(|v| !v.is_finite()) {
        bail!("{}: {name}=\"{text}\" needs three finite numbers", at(node));
    }
    Ok([values[0], values[1], values[2]])
}

/// The `<origin>` child of `node` (identity when absent).
fn origin(node: &Node<'_, '_>) -> Result<Pose> {
    match child(node, "origin") {
        None => Ok(Pose::identity()),
        Some(origin) => Ok(isometry_from_xyz_rpy(triple(&origin, "xyz", [0.0; 3])?, triple(&origin, "rpy", [0.0; 3])?)),
    }
}

/// A link's `<inertial>` in the link frame (`None` when it has none).
fn inertial(link: &Node<'_, '_>) -> Result<Option<Inertial>> {
    let Some(element) = child(link, "inertial") else { return Ok(None) };
    let mass =
        child(&element, "mass").ok_or_else(|| anyhow!("{}: <inertial> needs a <mass value=\"…\"/>", at(link)))?;
    let mass = required(&mass, "value", "kg")?;
    if mass < 0.0 {
        bail!("{}: <mass value=\"{mass}\"> is negative", at(link));
    }
    let tensor = child(&element, "inertia")
        .ok_or_else(|| anyhow!("{}: <inertial> needs an <inertia ixx=… iyy=… izz=… ixy=… ixz=… iyz=…/>", at(link)))?;
    let get = |name: &str| -> Result<f64> { Ok(number(&tensor, name)?.unwrap_or(0.0)) };
    let (ixx, iyy, izz) =
        (required(&tensor, "ixx", "kg·m²")?, required(&tensor, "iyy", "kg·m²")?, required(&tensor, "izz", "kg·m²")?);
    let (ixy, ixz, iyz) = (get("ixy")?, get("ixz")?, get("iyz")?);
    let body =
        Inertial { mass, com: Vector3::zeros(), inertia: Matrix3::new(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz) };
    Ok(Some(body.transformed(&origin(&element)?)))
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

/// Names that mark a tool frame, as whole words of a link's name (`ee_gripper_link`,
/// `end_effector_link`, `gripper_frame_link`, `tcp`).
pub const TOOL_WORDS: [&[&str]; 7] =
    [&["tool"], &["tcp"], &["ee"], &["eef"], &["tip"], &["end", "effector"], &["gripper", "frame"]];

fn well_known_tool(name: &str) -> bool {
    let last = name.rsplit('/').next().unwrap_or(name).to_ascii_lowercase();
    let words: Vec<&str> = last.split(['_', '-', '.']).filter(|w| !w.is_empty()).collect();
    TOOL_WORDS.iter().any(|pattern| words.windows(pattern.len()).any(|w| w == *pattern))
}

/// A joint's motion at `value`: a turn about `axis` (rad) or a slide along it (m).
fn motion(kind: &str, axis: &Vector3<f64>, value: f64) -> Pose {
    let unit = chessarm_core::nalgebra::Unit::new_normalize(*axis);
    if kind == "prismatic" {
        Pose::from_parts((axis.normalize() * value).into(), chessarm_core::nalgebra::Rotation3::identity())
    } else {
        Pose::from_parts(Vector3::zeros().into(), chessarm_core::nalgebra::Rotation3::from_axis_angle(&unit, value))
    }
}

/// A joint's `<axis xyz>` (URDF's default `1 0 0`), refused when it has no direction.
fn axis_of(joint: &Node<'_, '_>) -> Result<Vector3<f64>> {
    let axis = match child(joint, "axis") {
        Some(axis) => Vector3::from(triple(&axis, "xyz", [1.0, 0.0, 0.0])?),
        None => Vector3::x(),
    };
    if axis.norm() == 0.0 {
        bail!("{}: <axis xyz=\"0 0 0\"> has no direction", at(joint));
    }
    Ok(axis)
}

/// `<mimic joint multiplier offset>`: this joint's value is `multiplier·leader + offset`.
fn mimic(joint: &Node<'_, '_>) -> Result<Option<(String, f64, f64)>> {
    let Some(element) = child(joint, "mimic") else { return Ok(None) };
    let leader = element.attribute("joint").ok_or_else(|| anyhow!("{}: <mimic> needs joint=\"…\"", at(joint)))?;
    Ok(Some((
        leader.to_string(),
        number(&element, "multiplier")?.unwrap_or(1.0),
        number(&element, "offset")?.unwrap_or(0.0),
    )))
}

/// A joint held at one value: locked by the user, a gripper joint at its default, or a joint
/// that follows another (`<mimic>`).
#[derive(Debug, Clone, PartialEq)]
pub struct LockedJoint {
    pub name: String,
    /// `revolute`, `continuous` or `prismatic`.
    pub kind: String,
    /// The value it is held at in the model, rad or m (the URDF's convention).
    pub value: f64,
    /// For a joint after the arm's last joint with limits (a gripper's): the value that opens
    /// the gripper and the one that closes it (the limit further from zero opens).
    pub gripper: Option<[f64; 2]>,
}

impl LockedJoint {
    /// Its value with the gripper closed or open (a gripper joint's close or open value; any
    /// other joint's held value).
    pub fn at(&self, closed: bool) -> f64 {
        match self.gripper {
            Some([open, close]) => {
                if closed {
                    close
                } else {
                    open
                }
            }
            None => self.value,
        }
    }
}

/// One joint of the file.
struct JointElement<'a, 'input> {
    node: Node<'a, 'input>,
    name: String,
    kind: String,
    parent: String,
    child: String,
}

/// What a link is carried by: the base (0) or arm joint `k`'s link (`k`, 1-based), and its
/// pose in that link's frame.
type Carried = (usize, Pose);

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
            anyhow!("not valid XML: {}", crate::app::text::escape_controls(&e.to_string()))
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
    let tool_link = choose_tool(options, &links, &joints, &children, &root, &mut notes)?;
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

/// The tool link: `--tool`, else a leaf reached by a fixed joint with a tool's name (or the
/// only such leaf); the choice goes to `notes`.
fn choose_tool(
    options: &ImportOptions,
    links: &BTreeMap<String, Node<'_, '_>>,
    joints: &[JointElement<'_, '_>],
    children: &BTreeMap<String, Vec<usize>>,
    root: &str,
    notes: &mut Vec<String>,
) -> Result<String> {
    let leaves: Vec<&JointElement<'_, '_>> =
        joints.iter().filter(|j| j.kind == "fixed" && !children.contains_key(&j.child)).collect();
    let listed = |names: &[&str]| names.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ");
    if let Some(tool) = &options.tool {
        if !links.contains_key(tool) {
            let names: Vec<&str> = leaves.iter().map(|j| j.child.as_str()).collect();
            bail!(
                "--tool {tool}: the file has no link '{tool}' (links at the end of a fixed joint: {})",
                listed(&names)
            );
        }
        if tool == root {
            bail!("--tool {tool}: that is the base link");
        }
        return Ok(tool.clone());
    }
    let named: Vec<&str> = leaves.iter().map(|j| j.child.as_str()).filter(|n| well_known_tool(n)).collect();
    let all: Vec<&str> = leaves.iter().map(|j| j.child.as_str()).collect();
    let (tool, why) = match (named.as_slice(), all.as_slice()) {
        ([one], _) => (*one, "its name marks a tool frame"),
        ([], [one]) => (*one, "the only link at the end of a fixed joint"),
        ([], []) => bail!(
            "no tool frame: no link hangs from a fixed joint at the end of the tree; add a fixed joint to a link whose \
             origin is the tool tip, or give --tool LINK (and --tool-offset X,Y,Z in its frame, m)"
        ),
        ([], many) | (many, _) => bail!(
            "which link is the tool? candidates: {}; give --tool LINK (and --tool-offset X,Y,Z, m, for a point in its \
             frame)",
            listed(many)
        ),
    };
    notes.push(format!("tool frame: link '{tool}' ({why}; --tool LINK to choose another)"));
    Ok(tool.to_string())
}

/// The value of a `<mimic>` joint: `multiplier·leader + offset`, the leader held or itself a
/// follower (chains of followers up to the number of joints).
fn mimic_value(
    j: usize,
    joints: &[JointElement<'_, '_>],
    by_name: &BTreeMap<String, usize>,
    values: &BTreeMap<usize, f64>,
    arm: &std::collections::HashSet<usize>,
    depth: usize,
) -> Result<f64> {
    let joint = &joints[j];
    let Some((leader, multiplier, offset)) = mimic(&joint.node)? else {
        return Ok(values.get(&j).copied().unwrap_or(0.0));
    };
    let Some(&l) = by_name.get(&leader) else {
        bail!("{}: <mimic joint=\"{leader}\"> names no joint of the file", at(&joint.node));
    };
    if arm.contains(&l) {
        bail!(
            "{}: follows the arm's joint '{leader}' (<mimic>): chessarm's arm has four independent joints",
            at(&joint.node)
        );
    }
    if depth > joints.len() {
        bail!("{}: its <mimic> joints follow each other in a loop", at(&joint.node));
    }
    let lead = match values.get(&l) {
        Some(value) => *value,
        None if mimic(&joints[l].node)?.is_some() => mimic_value(l, joints, by_name, values, arm, depth + 1)?,
        None => default_hold(lock_range(&joints[l].node, &joints[l].kind)?),
    };
    Ok(multiplier * lead + offset)
}

/// Where a joint nobody holds is held: the file's zero pose, or the limit nearest it when 0 is
/// outside `range`.
fn default_hold(range: Option<(f64, f64)>) -> f64 {
    match range {
        Some((lower, _)) if lower > 0.0 => lower,
        Some((_, upper)) if upper < 0.0 => upper,
        _ => 0.0,
    }
}

/// A held joint's range: `<limit lower upper>` of a revolute or prismatic joint (`None` for a
/// continuous one or one without a limit).
fn lock_range(joint: &Node<'_, '_>, kind: &str) -> Result<Option<(f64, f64)>> {
    if kind == "continuous" {
        return Ok(None);
    }
    let Some(element) = child(joint, "limit") else { return Ok(None) };
    match (number(&element, "lower")?, number(&element, "upper")?) {
        (Some(lower), Some(upper)) if lower <= upper => Ok(Some((lower, upper))),
        (Some(lower), Some(upper)) => {
            bail!("{}: <limit lower=\"{lower}\" upper=\"{upper}\">: lower above upper", at(joint))
        }
        _ => Ok(None),
    }
}

/// Why the way to the tool does not have four moving joints, with the `--lock` that fixes it
/// when one exists.
fn wrong_count(
    joints: &[JointElement<'_, '_>],
    path: &[usize],
    arm: &[usize],
    values: &BTreeMap<usize, f64>,
    tool: &str,
    root: &str,
) -> Result<String> {
    let names: Vec<String> = arm.iter().map(|j| format!("'{}'", joints[*j].name)).collect();
    let mut route = vec![root.to_string()];
    route.extend(path.iter().map(|j| joints[*j].child.clone()));
    let count = arm.len();
    let head = format!(
        "the way from '{root}' to the tool link '{tool}' ({}) has {count} moving joint{}{}{}; chessarm's arm has four \
         (a base yaw and three pitch joints)",
        route.join(" → "),
        if count == 1 { "" } else { "s" },
        if names.is_empty() { "" } else { ": " },
        names.join(", ")
    );
    if count < 4 {
        return Ok(head);
    }
    // Which joints to hold so that the rest is a yaw and three parallel pitches: every choice
    // of `count − 4` of them, tried at 0 (or the nearest limit) on the geometry alone.
    let mut fixes = Vec::new();
    let extra = count - 4;
    // One or two joints too many (a wrist roll, a second wrist): every choice is tried; beyond
    // that no suggestion (the choices grow as the binomial coefficient).
    let choices: Vec<Vec<usize>> = if extra <= 2 { combinations(count, extra) } else { Vec::new() };
    for choice in &choices {
        let held: Vec<usize> = choice.iter().map(|i| arm[*i]).collect();
        let kept: Vec<usize> = arm.iter().copied().filter(|j| !held.contains(j)).collect();
        if geometry_fits(joints, path, &kept, values, &held)? {
            let locks: Vec<String> = held
                .iter()
                .map(|j| {
                    let value = lock_range(&joints[*j].node, &joints[*j].kind).map(default_hold).unwrap_or(0.0);
                    format!("{}={}", joints[*j].name, chessarm_core::short_number(value))
                })
                .collect();
            fixes.push(format!("--lock {}", locks.join(",")));
        }
    }
    Ok(match fixes.as_slice() {
        [] if extra > 2 => format!(
            "{head}: hold the {extra} that are not the base yaw and the three pitch joints with --lock NAME=VALUE each"
        ),
        [] => format!("{head}; no choice of joints to lock leaves that shape"),
        [one] => format!("{head}: hold the other with {one} (any value within its limits)"),
        many => format!("{head}: hold the others, e.g. {}", many.join(" or ")),
    })
}

/// Every way to choose `k` of `n` indices, in order.
fn combinations(n: usize, k: usize) -> Vec<Vec<usize>> {
    let mut all = Vec::new();
    let mut current = Vec::new();
    fn go(start: usize, n: usize, k: usize, current: &mut Vec<usize>, all: &mut Vec<Vec<usize>>) {
        if current.len() == k {
            all.push(current.clone());
            return;
        }
        for i in start..n {
            current.push(i);
            go(i + 1, n, k, current, all);
            current.pop();
        }
    }
    go(0, n, k, &mut current, &mut all);
    all
}

/// Whether the joints `kept` of `path`, with `held` (and the user's locks) at 0, make a yaw and
/// three parallel pitch joints (geometry only: unit masses, placeholder limits).
fn geometry_fits(
    joints: &[JointElement<'_, '_>],
    path: &[usize],
    kept: &[usize],
    values: &BTreeMap<usize, f64>,
    held: &[usize],
) -> Result<bool> {
    let mut pose = Pose::identity();
    let mut chain = Vec::new();
    for &j in path {
        let joint = &joints[j];
        let at_joint = pose * origin(&joint.node)?;
        if kept.contains(&j) {
            let mut axis = axis_of(&joint.node)?;
            if chain.is_empty() && (at_joint.rotation * axis).z < 0.0 {
                axis = -axis;
            }
            chain.push(ChainJoint {
                name: joint.name.clone(),
                origin: at_joint,
                axis,
                limits: JointLimits { lower: -PI, upper: PI, velocity: 1.0, torque: 1.0 },
                friction: Friction::default(),
                body: Inertial::point(1.0, Vector3::zeros()),
            });
            pose = Pose::identity();
        } else if joint.kind == "fixed" {
            pose = at_joint;
        } else {
            let value = if held.contains(&j) {
                lock_range(&joint.node, &joint.kind).map(default_hold).unwrap_or(0.0)
            } else {
                values.get(&j).copied().unwrap_or(0.0)
            };
            pose = at_joint * motion(&joint.kind, &axis_of(&joint.node)?, value);
        }
    }
    let Ok(joints) = <[ChainJoint; 4]>::try_from(chain) else { return Ok(false) };
    // A tool point off the last axis (any point will do for the shape).
    let tool = Pose::from_parts(Vector3::new(0.05, 0.0, 0.05).into(), chessarm_core::nalgebra::Rotation3::identity());
    let chain = SerialChain { joints, tool: pose * tool, gravity: Vector3::new(0.0, 0.0, -REPORT_GRAVITY) };
    Ok(!matches!(model_from_chain(&chain), Err(ChainError::Shape { .. })))
}

/// Values that look like a URDF's placeholders rather than the arm's physics: torque limits
/// far above what holding the arm against gravity needs (more than [`PLACEHOLDER_TORQUE_RATIO`]
/// times the largest gravity torque of the pitch joints over their ranges), and links whose
/// inertia means a radius of gyration beyond the whole arm's reach: (the efforts', the links').
fn placeholder_warnings(
    model: &ArmModel<4>,
    names: &[String; 4],
    joints: &[JointElement<'_, '_>],
    links: &BTreeMap<String, Node<'_, '_>>,
    by_name: &BTreeMap<String, usize>,
    arm: &[usize],
) -> (Vec<String>, Vec<String>) {
    let mut efforts = Vec::new();
    let mut warnings = Vec::new();
    let need = gravity_need(model);
    let largest = need.iter().copied().fold(0.0, f64::max);
    for (k, name) in names.iter().enumerate() {
        let torque = model.link(k).limits.torque;
        // The yaw holds no weight: it is compared with the largest pitch need.
        let reference = if k == 0 { largest } else { need[k] };
        if reference > 0.0 && torque > PLACEHOLDER_TORQUE_RATIO * reference {
            let node = by_name.get(name).map(|j| at(&joints[*j].node)).unwrap_or_default();
            efforts.push(format!(
                "{node}: effort=\"{}\" N·m is {:.0}× the {:.3} N·m gravity asks of it at worst: a placeholder? The \
                 planner and the controllers take it as the motor's limit (give the servo's stall torque)",
                chessarm_core::short_number(torque),
                torque / reference,
                reference
            ));
        }
    }
    let reach: f64 = model.links().iter().map(|l| l.dh.a.abs() + l.dh.d.abs()).sum::<f64>() + model.base().norm();
    let _ = arm;
    for (name, node) in links {
        let Ok(Some(body)) = inertial(node) else { continue };
        if body.mass <= 0.0 {
            continue;
        }
        let largest_moment = body.inertia.symmetric_eigenvalues().max();
        let gyration = (largest_moment.max(0.0) / body.mass).sqrt();
        if gyration > reach {
            warnings.push(format!(
                "{}: link '{name}' of {} kg has an inertia of {} kg·m², as if its mass were {:.2} m from its centre, \
                 beyond the arm's reach of {:.2} m: a placeholder? It is taken as given",
                at(node),
                chessarm_core::short_number(body.mass),
                chessarm_core::short_number(largest_moment),
                gyration,
                reach
            ));
        }
    }
    (efforts, warnings)
}

/// A torque limit more than this many times the largest gravity torque is a placeholder.
pub const PLACEHOLDER_TORQUE_RATIO: f64 = 20.0;

/// The largest gravity torque of each joint over a grid of its pitch joints' ranges, N·m.
fn gravity_need(model: &ArmModel<4>) -> [f64; 4] {
    let mut need = [0.0; 4];
    let steps = 7;
    let value = |k: usize, i: usize| {
        let limits = model.link(k).limits;
        limits.lower + (limits.upper - limits.lower) * i as f64 / (steps - 1) as f64
    };
    for a in 0..steps {
        for b in 0..steps {
            for c in 0..steps {
                let q = chessarm_core::arm::model::JointVector::<4>::new(0.0, value(1, a), value(2, b), value(3, c));
                let torque = chessarm_core::arm::dynamics::gravity_torques(model, &q);
                for k in 0..4 {
                    need[k] = f64::max(need[k], torque[k].abs());
                }
            }
        }
    }
    need
}

/// A joint's `<limit>`: lower, upper (rad), effort (N·m), velocity (rad/s).
/// A continuous joint without `<limit>` has the range ±π and no speed or torque limit of its
/// own (0: the caller takes the other arm joints'); a speed or torque limit of 0 means the same
/// (CAD exporters write 0 for "not given").
fn limits(joint: &Node<'_, '_>, kind: &str) -> Result<JointLimits> {
    let Some(element) = child(joint, "limit") else {
        if kind == "continuous" {
            return Ok(JointLimits { lower: -PI, upper: PI, velocity: 0.0, torque: 0.0 });
        }
        bail!(
            "{}: has no <limit>; chessarm needs {}effort (N·m) and velocity (rad/s): add <limit {}effort=\"…\" \
             velocity=\"…\"/> with the servo's stall torque and top speed",
            at(joint),
            if kind == "continuous" { "" } else { "lower, upper (rad), " },
            if kind == "continuous" { "" } else { "lower=\"…\" upper=\"…\" " }
        )
    };
    let range = |name: &str, default: f64| -> Result<f64> {
        match (kind, number(&element, name)?) {
            ("continuous", _) => Ok(default),
            (_, Some(value)) => Ok(value),
            (_, None) => bail!("{}: <limit> of a revolute joint needs {name}=\"…\" (rad)", at(joint)),
        }
    };
    let limits = JointLimits {
        lower: range("lower", -PI)?,
        upper: range("upper", PI)?,
        velocity: required(&element, "velocity", "rad/s")?,
        torque: required(&element, "effort", "N·m")?,
    };
    if limits.lower >= limits.upper {
        bail!(
            "{}: <limit lower=\"{}\" upper=\"{}\">: lower must be below upper",
            at(joint),
            limits.lower,
            limits.upper
        );
    }
    for (name, value) in [("velocity", limits.velocity), ("effort", limits.torque)] {
        if value < 0.0 {
            bail!("{}: <limit {name}=\"{value}\">: must be >= 0 (0: not given)", at(joint));
        }
    }
    Ok(limits)
}

/// A joint's `<dynamics damping friction>` (0 when absent).
fn friction(joint: &Node<'_, '_>) -> Result<Friction> {
    let Some(element) = child(joint, "dynamics") else { return Ok(Friction::default()) };
    let friction = Friction {
        viscous: number(&element, "damping")?.unwrap_or(0.0),
        coulomb: number(&element, "friction")?.unwrap_or(0.0),
    };
    if friction.viscous < 0.0 || friction.coulomb < 0.0 {
        bail!("{}: <dynamics> damping and friction must be >= 0", at(joint));
    }
    Ok(friction)
}

/// Gravity from chessarm's `<mujoco><option gravity>` extension, else the report's.
fn gravity(robot: &Node<'_, '_>) -> Result<Vector3<f64>> {
    let option = child(robot, "mujoco").and_then(|m| child(&m, "option"));
    match option {
        Some(option) if option.attribute("gravity").is_some() => {
            let gravity = Vector3::from(triple(&option, "gravity", [0.0; 3])?);
            // The base yaw turns about z, the board lies in the xy plane: gravity is along −z.
            if !(gravity.z < 0.0 && gravity.xy().norm() <= 1e-9 * gravity.norm()) {
                bail!("{}: gravity must point along −z (the base yaw's axis is +z)", at(&option));
            }
            Ok(gravity)
        }
        _ => Ok(Vector3::new(0.0, 0.0, -REPORT_GRAVITY)),
    }
}

/// The file's tree, as [`from_urdf_in`] reads it.
struct Tree<'t, 'a, 'input> {
    /// Links from the root, parents first.
    order: &'t [String],
    carried: &'t BTreeMap<String, Carried>,
    links: &'t BTreeMap<String, Node<'a, 'input>>,
    parent_joint: &'t BTreeMap<String, usize>,
    joints: &'t [JointElement<'a, 'input>],
}

/// Where the links' shapes go: each arm link's joint frame in its DH frame, and how far from
/// its frame a shape may reach, m.
struct Frames<'a> {
    in_dh: &'a [Pose; 4],
    farthest: f64,
}

/// A convex hull's vertices, m.
type Points = std::sync::Arc<[Vector3<f64>]>;

/// A positive, finite attribute of a `<geometry>` shape.
fn size(node: &Node<'_, '_>, name: &str) -> Result<f64> {
    let value = required(node, name, "m")?;
    if value <= 0.0 {
        bail!("{}: {name}=\"{value}\" must be > 0", at(node));
    }
    Ok(value)
}

/// The arm's collision bodies from the links' `<collision>` elements (boxes, cylinders,
/// spheres; STL meshes as their convex hulls), each placed on the body that carries its link
/// (`in_dh`: each arm link's joint frame in its DH frame). Links behind a gripper's joint
/// (its fingers) are left to chessarm's `[gripper]`, whose opening follows the commands. A
/// file without `<collision>`, or with a mesh that is not found, gets chessarm's own solids,
/// said in `warnings` (with what was missing and where it was looked for) or `notes`.
fn collision_bodies(
    tree: &Tree<'_, '_, '_>,
    arm: &[usize],
    locked: &[LockedJoint],
    frames: &Frames<'_>,
    folder: Option<&Path>,
    notes: &mut Vec<String>,
    warnings: &mut Vec<String>,
) -> Result<Bodies> {
    let gripper_joints: std::collections::HashSet<usize> = tree
        .joints
        .iter()
        .enumerate()
        .filter(|(_, j)| locked.iter().any(|l| l.name == j.name && l.gripper.is_some()))
        .map(|(k, _)| k)
        .collect();
    let package_path = crate::app::setup::meshes::package_path();
    let mut shapes = Vec::new();
    let mut fingers = Vec::new();
    let mut missing: Vec<(String, Vec<std::path::PathBuf>)> = Vec::new();
    // Each mesh file's hull at each scale, read once (an arm repeats its servo's mesh).
    let mut hulls: BTreeMap<(std::path::PathBuf, [u64; 3]), Points> = BTreeMap::new();
    let mut meshes = 0;
    // The bodies (0 the base, k arm link k) that have shapes.
    let mut with_shapes = std::collections::BTreeSet::new();
    for link in tree.order {
        let node = tree.links[link.as_str()];
        let elements: Vec<Node<'_, '_>> = node.children().filter(|n| n.has_tag_name("collision")).collect();
        if elements.is_empty() {
            continue;
        }
        // Behind a gripper's joint (before reaching an arm joint): a finger.
        let mut up = link;
        let mut finger = false;
        while let Some(&j) = tree.parent_joint.get(up) {
            if gripper_joints.contains(&j) {
                finger = true;
                break;
            }
            if arm.contains(&j) {
                break;
            }
            up = &tree.joints[j].parent;
        }
        if finger {
            fingers.push(format!("'{link}'"));
            continue;
        }
        let (carrier, pose) = tree.carried[link];
        let frame = if carrier == 0 { pose } else { frames.in_dh[carrier - 1] * pose };
        for element in elements {
            let placed = frame * origin(&element)?;
            let geometry = child(&element, "geometry")
                .and_then(|g| g.children().find(Node::is_element))
                .ok_or_else(|| anyhow!("{}: <collision> needs a <geometry> with a shape", at(&node)))?;
            let shape = (|| -> Result<Option<Shape>> {
                Ok(Some(match geometry.tag_name().name() {
                    "box" => {
                        let [x, y, z] = triple(&geometry, "size", [f64::NAN; 3])?;
                        if !(x > 0.0 && y > 0.0 && z > 0.0) {
                            bail!(
                                "{}: size=\"{}\" needs three sizes, each > 0 (m)",
                                at(&geometry),
                                geometry.attribute("size").unwrap_or_default()
                            );
                        }
                        Shape::Cuboid { half: Vector3::new(x, y, z) * 0.5 }
                    }
                    "cylinder" => {
                        Shape::Cylinder { radius: size(&geometry, "radius")?, length: size(&geometry, "length")? }
                    }
                    "sphere" => Shape::Sphere { radius: size(&geometry, "radius")? },
                    "mesh" => {
                        let filename = geometry
                            .attribute("filename")
                            .ok_or_else(|| anyhow!("{}: <mesh> needs filename=\"…\"", at(&node)))?;
                        let scale = triple(&geometry, "scale", [1.0; 3])?;
                        let looked = crate::app::setup::meshes::candidates(filename, folder, &package_path);
                        let Some(path) = looked.iter().find(|p| p.is_file()) else {
                            missing.push((filename.to_string(), looked));
                            return Ok(None);
                        };
                        let key = (path.clone(), scale.map(f64::to_bits));
                        let points = match hulls.get(&key) {
                            Some(points) => std::sync::Arc::clone(points),
                            None => {
                                let scale_text = geometry.attribute("scale").unwrap_or("1 1 1");
                                let mesh = crate::app::setup::meshes::read_stl(path, scale, scale_text)
                                    .with_context(|| format!("{}: <mesh filename=\"{filename}\">", at(&node)))?;
                                if let Some((vertices, kept, within)) = mesh.decimated {
                                    warnings.push(format!(
                                        "mesh {} has {vertices} distinct vertices, more than chessarm takes a hull of \
                                         ({}): the hull of {kept} points around them stands in, at most {} mm outside \
                                         the mesh's own hull and never inside it",
                                        path.display(),
                                        crate::app::setup::meshes::MAX_HULL_INPUT,
                                        chessarm_core::short_number((within * 1e4).ceil() / 10.0)
                                    ));
                                }
                                let hull = chessarm_chess::clearance::hull_of(&mesh.points).map_err(|why| {
                                    anyhow!("{}: <mesh filename=\"{filename}\"> ({}): {why}", at(&node), path.display())
                                })?;
                                let points: std::sync::Arc<[Vector3<f64>]> = hull.into();
                                hulls.insert(key, std::sync::Arc::clone(&points));
                                points
                            }
                        };
                        meshes += 1;
                        Shape::Hull { points }
                    }
                    other => bail!(
                        "{}: <collision> with a <{other}>: chessarm takes <box>, <cylinder>, <sphere> and <mesh>",
                        at(&node)
                    ),
                }))
            })()
            .map_err(|e| anyhow!("link '{link}': {e:#}"))?;
            if let Some(shape) = shape {
                let reach = chessarm_core::arm::bodies::place(&shape, &(pose * origin(&element)?))
                    .farthest_from(&Vector3::zeros());
                if reach.is_nan() || reach > frames.farthest {
                    bail!(
                        "link '{link}': its <collision> <{}> reaches {} m from the arm's frame it rides in, more than \
                         twice the whole arm is long ({} m): a mesh drawn in mm needs scale=\"0.001 0.001 0.001\"",
                        geometry.tag_name().name(),
                        chessarm_core::short_number(reach),
                        chessarm_core::short_number(frames.farthest)
                    );
                }
                with_shapes.insert(carrier);
                shapes.push(BodyShape { body: carrier, pose: placed, shape });
            }
        }
    }
    let stand_in = "chessarm's own solids from the kinematic chain (a pedestal, a housing per joint, a cylinder per \
                    link) stand in for the links in the clearance check";
    if !missing.is_empty() {
        let mut names: Vec<String> = Vec::new();
        for (name, _) in &missing {
            if !names.contains(name) {
                names.push(name.clone());
            }
        }
        let shown: Vec<String> = names.iter().take(4).map(|n| format!("'{n}'")).collect();
        let more = if names.len() > 4 { format!(" and {} more", names.len() - 4) } else { String::new() };
        let (first, looked) = &missing[0];
        let places: Vec<String> = looked.iter().take(4).map(|p| p.display().to_string()).collect();
        warnings.push(format!(
            "{} collision mesh file{} not found: {}{more} ('{first}' was looked for at {}); {stand_in} (put the \
             meshes where the file names them, or their package's folder on ROS_PACKAGE_PATH)",
            names.len(),
            if names.len() == 1 { "" } else { "s" },
            shown.join(", "),
            places.join(", ")
        ));
        return Ok(Bodies::Drawn);
    }
    // The clearance check's work grows with the corners of every hull it is given, for every
    // pose of every move: a bound on their sum keeps a game's check in seconds a move.
    let corners: usize =
        shapes.iter().map(|s| if let Shape::Hull { points } = &s.shape { points.len() } else { 8 }).sum();
    if corners > crate::app::setup::meshes::MAX_ARM_HULL_CORNERS {
        bail!(
            "its {} <collision> shapes have {corners} hull corners in all, more than the clearance check takes in \
             reasonable time ({}): give fewer or simpler shapes (a link's mesh once, decimated meshes, boxes)",
            shapes.len(),
            crate::app::setup::meshes::MAX_ARM_HULL_CORNERS
        );
    }
    let bare: Vec<String> = arm
        .iter()
        .enumerate()
        .filter(|(k, _)| !with_shapes.contains(&(k + 1)))
        .map(|(_, j)| format!("'{}'", tree.joints[*j].child))
        .collect();
    if !shapes.is_empty() && !bare.is_empty() {
        warnings.push(format!(
            "links {} (and what they carry) have no <collision> shapes: the clearance check does not see them",
            bare.join(", ")
        ));
    }
    if shapes.is_empty() {
        notes.push(format!("the file gives no <collision> shapes: {stand_in}"));
        return Ok(Bodies::Drawn);
    }
    let mut said = format!(
        "clearance checked against the file's {} <collision> shape{} ({meshes} mesh{} as convex hulls)",
        shapes.len(),
        if shapes.len() == 1 { "" } else { "s" },
        if meshes == 1 { "" } else { "es" }
    );
    if !fingers.is_empty() {
        said.push_str(&format!(
            "; the fingers are chessarm's [gripper], whose opening follows the commands (links {} left out)",
            fingers.join(", ")
        ));
    }
    notes.push(said);
    Ok(Bodies::Described(shapes.into()))
}
