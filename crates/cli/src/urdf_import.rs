//! `--urdf FILE`: the user's own arm from URDF.
//!
//! The file must describe one chain from its root link: four revolute (or continuous) joints,
//! a base yaw followed by three parallel pitch joints, then one or more fixed joints to the tool
//! link, whose origin is the tool tip. Fixed joints may also sit anywhere between (their
//! links' masses join the moving link they are fixed to). Joint origins may be anywhere and
//! turned any way: the chain is converted to standard DH by
//! [`chessarm_core::arm::chain::model_from_chain`]. Every element chessarm cannot use is an
//! error naming it, its line, and why.
//!
//! What URDF leaves out: gravity is `(0, 0, −9.8)` m/s² unless the file carries chessarm's
//! `<mujoco><option gravity="x y z"/></mujoco>` extension (which `chessarm urdf` writes);
//! motor masses and rotor inertias are 0; a continuous joint's range is `[−π, π]`; bodies of
//! less than [`MARKER_MASS`] after fixed joints are frame markers and are left out (so
//! `chessarm urdf`'s tool marker does not add its trace of mass).

use anyhow::{Context, Result, anyhow, bail};
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
}

/// Reads the arm of the URDF file at `path`.
///
/// # Errors
///
/// The file cannot be read, is not XML, or describes something chessarm cannot model; the
/// message names the file, the element and its line.
pub fn load(path: &Path) -> Result<ImportedArm> {
    let text = crate::input::read_text("URDF file", path, crate::input::MAX_URDF_BYTES)?;
    from_urdf(&text).with_context(|| format!("URDF file {}", path.display()))
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

/// One `<joint>` read from the file.
struct JointElement<'a, 'input> {
    node: Node<'a, 'input>,
    name: String,
    kind: String,
    child: String,
}

/// The arm described by URDF `text`.
///
/// # Errors
///
/// As [`load`], without the file name.
pub fn from_urdf(text: &str) -> Result<ImportedArm> {
    let document =
        Document::parse(text).map_err(|e| anyhow!("not valid XML: {}", crate::escape_controls(&e.to_string())))?;
    let robot = document.root_element();
    if !robot.has_tag_name("robot") {
        bail!("{}: the root element must be <robot>", at(&robot));
    }
    let mut links = BTreeMap::new();
    for link in robot.children().filter(|n| n.has_tag_name("link")) {
        let name = link.attribute("name").ok_or_else(|| anyhow!("{}: a link needs a name", at(&link)))?;
        if name.trim().is_empty() {
            bail!("{}: a link's name must not be empty", at(&link));
        }
        // Every link's inertial is checked, the base's and the fixed ones' too, though only
        // the moving links' enter the model.
        inertial(&link)?;
        if links.insert(name.to_string(), link).is_some() {
            bail!("{}: a second link named '{name}'", at(&link));
        }
    }
    let mut children: BTreeMap<String, Vec<JointElement<'_, '_>>> = BTreeMap::new();
    // Each joint's element, for the messages (its line is found only when one is needed: finding
    // it counts lines from the start, which for every joint would be quadratic in the file).
    let mut places = BTreeMap::new();
    let mut has_parent = BTreeMap::new();
    for joint in robot.children().filter(|n| n.has_tag_name("joint")) {
        let name = joint.attribute("name").ok_or_else(|| anyhow!("{}: a joint needs a name", at(&joint)))?.to_string();
        // The names become the exported trajectories' joint_names (ROS), which must be unique.
        if name.trim().is_empty() {
            bail!("{}: a joint's name must not be empty", at(&joint));
        }
        if let Some(first) = places.get(&name) {
            bail!("{}: a second joint named '{name}' (the first at {})", at(&joint), at(first));
        }
        let kind = joint.attribute("type").ok_or_else(|| anyhow!("{}: a joint needs a type", at(&joint)))?.to_string();
        let link_of = |tag: &str| -> Result<String> {
            let element = child(&joint, tag).ok_or_else(|| anyhow!("{}: needs a <{tag} link=\"…\"/>", at(&joint)))?;
            let link = element.attribute("link").ok_or_else(|| anyhow!("{}: <{tag}> needs link=\"…\"", at(&joint)))?;
            if !links.contains_key(link) {
                bail!("{}: <{tag} link=\"{link}\"> names no link of the file", at(&joint));
            }
            Ok(link.to_string())
        };
        let (parent, child_link) = (link_of("parent")?, link_of("child")?);
        if let Some(other) = has_parent.insert(child_link.clone(), name.clone()) {
            bail!("{}: link '{child_link}' is already the child of joint '{other}'", at(&joint));
        }
        places.insert(name.clone(), joint);
        children.entry(parent).or_default().push(JointElement { node: joint, name, kind, child: child_link });
    }
    let roots: Vec<&String> = links.keys().filter(|name| !has_parent.contains_key(*name)).collect();
    let root = match roots.as_slice() {
        [root] => (*root).clone(),
        [] if links.is_empty() => bail!("{}: the robot has no links", at(&robot)),
        [] => bail!("every link is some joint's child: the joints form a loop, not a chain from a base"),
        many => bail!(
            "links {} have no parent joint: the file must describe one chain from a single base link",
            many.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ")
        ),
    };

    // Walk the chain from the root.
    let mut moving: Vec<ChainJoint> = Vec::new();
    // The pose of the current link in the frame of the last moving joint's link (or the base).
    let mut fixed = Pose::identity();
    let base_link = root.clone();
    let mut current = root;
    let mut path = vec![current.clone()];
    // Fixed joints after the last moving one (to the tool).
    let mut tool_joints = 0;
    loop {
        let joints = children.get(&current).map_or(&[][..], Vec::as_slice);
        let joint = match joints {
            [] => break,
            [joint] => joint,
            many => bail!(
                "{}: link '{current}' has {} child joints ({}): chessarm needs a single chain, not a branching tree",
                at(&many[0].node),
                many.len(),
                many.iter().map(|j| format!("'{}'", j.name)).collect::<Vec<_>>().join(", ")
            ),
        };
        let pose = fixed * origin(&joint.node)?;
        let child_node = links[&joint.child];
        match joint.kind.as_str() {
            "fixed" => {
                fixed = pose;
                tool_joints += 1;
                if let Some(body) = inertial(&child_node)?
                    && let Some(last) = moving.last_mut()
                    && body.mass >= MARKER_MASS
                {
                    chessarm_core::arm::model::validate_inertial("its <inertial>", &body, true)
                        .map_err(|e| anyhow!("{}: {e}", at(&child_node)))?;
                    last.body = last.body.combine(&body.transformed(&fixed));
                }
            }
            "revolute" | "continuous" => {
                if moving.len() == 4 {
                    bail!(
                        "{}: a fifth moving joint; chessarm's arm has four (a base yaw and three pitch joints)",
                        at(&joint.node)
                    );
                }
                let body = inertial(&child_node)?.ok_or_else(|| {
                    anyhow!(
                        "{}: has no <inertial>; chessarm needs the mass, centre of mass and inertia of every link a \
                         joint moves (this one is moved by joint '{}')",
                        at(&child_node),
                        joint.name
                    )
                })?;
                if body.mass <= 0.0 {
                    bail!("{}: <mass value=\"{}\">: a moving link needs a mass > 0", at(&child_node), body.mass);
                }
                let axis = match child(&joint.node, "axis") {
                    Some(axis) => Vector3::from(triple(&axis, "xyz", [1.0, 0.0, 0.0])?),
                    None => Vector3::x(),
                };
                moving.push(ChainJoint {
                    name: joint.name.clone(),
                    origin: pose,
                    axis,
                    limits: limits(&joint.node, &joint.kind)?,
                    friction: friction(&joint.node)?,
                    body,
                });
                fixed = Pose::identity();
                tool_joints = 0;
            }
            other => bail!(
                "{}: type=\"{other}\": chessarm's arm has revolute joints only (a {other} joint cannot be modelled)",
                at(&joint.node)
            ),
        }
        current = joint.child.clone();
        path.push(current.clone());
    }
    let on_path: std::collections::HashSet<&String> = path.iter().collect();
    if let Some((name, node)) = links.iter().find(|(name, _)| !on_path.contains(name)) {
        bail!(
            "{}: link '{name}' is not on the chain from '{base_link}': chessarm needs one chain, not a second tree",
            at(node)
        );
    }
    let count = moving.len();
    let Ok(joints) = <[ChainJoint; 4]>::try_from(moving) else {
        bail!(
            "the chain {} has {count} moving joint{}; chessarm's arm has four (a base yaw and three pitch joints)",
            path.join(" → "),
            if count == 1 { "" } else { "s" }
        );
    };
    if tool_joints == 0 {
        let last = path.last().map_or("", String::as_str);
        bail!(
            "{}: the chain ends at link '{last}', moved by joint '{}': add a fixed joint to a tool link whose origin \
             is the tool tip",
            links.get(last).map_or_else(String::new, at),
            joints[3].name
        );
    }
    let joint_names = joints.clone().map(|joint| joint.name);
    let chain = SerialChain { joints, tool: fixed, gravity: gravity(&robot)? };
    let model = model_from_chain(&chain).map_err(|error| {
        let joint = match &error {
            ChainError::Shape { joint, .. } | ChainError::Model { joint, .. } => joint,
        };
        match places.get(joint) {
            Some(place) => anyhow!("{}: {}", at(place), error.to_string().split_once(": ").map_or("", |(_, why)| why)),
            None => anyhow!("{error}"),
        }
    })?;
    Ok(ImportedArm { model, joint_names, base_link })
}

/// A joint's `<limit>`: lower, upper (rad), effort (N·m), velocity (rad/s).
fn limits(joint: &Node<'_, '_>, kind: &str) -> Result<JointLimits> {
    let element = child(joint, "limit").ok_or_else(|| {
        anyhow!("{}: has no <limit>; chessarm needs lower, upper (rad), effort (N·m) and velocity (rad/s)", at(joint))
    })?;
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
        if value <= 0.0 {
            bail!("{}: <limit {name}=\"{value}\">: must be > 0", at(joint));
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
