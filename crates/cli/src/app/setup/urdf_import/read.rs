//! The XML of a URDF file: the document (xacro refused), the tree of its links and joints
//! ([`FileTree`]), and element by element, attributes as numbers and triples, origins,
//! inertials, axes, `<mimic>`, limits, friction and gravity. Every error names the element, its
//! line, and the value as written.

use anyhow::{Result, anyhow, bail};
use chessarm_core::arm::chain::isometry_from_xyz_rpy;
use chessarm_core::arm::kinematics::Pose;
use chessarm_core::arm::link::{Friction, Inertial, JointLimits};
use chessarm_core::arm::model::REPORT_GRAVITY;
use chessarm_core::nalgebra::{Matrix3, Vector3};
use roxmltree::{Document, Node};
use std::collections::{BTreeMap, HashSet};
use std::f64::consts::PI;

/// The XML document of URDF `text`, refused when it is not XML or is xacro (a template of URDF).
pub(super) fn document(text: &str) -> Result<Document<'_>> {
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
    Ok(document)
}

/// The file's tree as written: its links and joints, and how they hang together.
pub(super) struct FileTree<'a, 'input> {
    /// The `<robot>` element.
    pub(super) robot: Node<'a, 'input>,
    /// Every link, by name.
    pub(super) links: BTreeMap<String, Node<'a, 'input>>,
    /// The links whose `<inertial>` is wrong (among the problems already).
    pub(super) bad_inertial: HashSet<String>,
    /// Every joint, in the file's order.
    pub(super) joints: Vec<JointElement<'a, 'input>>,
    /// Each joint's index by name.
    pub(super) by_name: BTreeMap<String, usize>,
    /// Each link's parent joint.
    pub(super) parent_joint: BTreeMap<String, usize>,
    /// Each link's child joints.
    pub(super) children: BTreeMap<String, Vec<usize>>,
    /// The root link, the base.
    pub(super) root: String,
    /// Links from the root, parents first.
    pub(super) order: Vec<String>,
}

/// The tree of `document`'s `<robot>`: links and joints named once, each joint of a kind
/// chessarm takes and between links of the file, one root that reaches every link. Every
/// link's `<inertial>` is checked, a wrong one told in `problems`.
pub(super) fn tree<'a, 'input>(
    document: &'a Document<'input>,
    problems: &mut Vec<String>,
) -> Result<FileTree<'a, 'input>> {
    let robot = document.root_element();
    if !robot.has_tag_name("robot") {
        bail!("{}: the root element must be <robot>", at(&robot));
    }
    let (links, bad_inertial) = links(&robot, problems)?;
    let Joints { joints, by_name, parent_joint, children } = joints(&robot, &links)?;
    let root = root(&robot, &links, &parent_joint)?;
    let order = order(&root, &links, &joints, &children)?;
    Ok(FileTree { robot, links, bad_inertial, joints, by_name, parent_joint, children, root, order })
}

/// The links of `robot` by name, and those whose `<inertial>` is wrong (each told in `problems`).
fn links<'a, 'input>(
    robot: &Node<'a, 'input>,
    problems: &mut Vec<String>,
) -> Result<(BTreeMap<String, Node<'a, 'input>>, HashSet<String>)> {
    let mut links = BTreeMap::new();
    let mut bad_inertial = HashSet::new();
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
    Ok((links, bad_inertial))
}

/// The joints of the file, and how they join its links.
struct Joints<'a, 'input> {
    joints: Vec<JointElement<'a, 'input>>,
    by_name: BTreeMap<String, usize>,
    parent_joint: BTreeMap<String, usize>,
    children: BTreeMap<String, Vec<usize>>,
}

/// The joints of `robot`, each named once, of a kind chessarm takes, between two of `links`,
/// and no link the child of two joints.
fn joints<'a, 'input>(
    robot: &Node<'a, 'input>,
    links: &BTreeMap<String, Node<'a, 'input>>,
) -> Result<Joints<'a, 'input>> {
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
    Ok(Joints { joints, by_name, parent_joint, children })
}

/// The one link that is no joint's child: the base.
fn root(
    robot: &Node<'_, '_>,
    links: &BTreeMap<String, Node<'_, '_>>,
    parent_joint: &BTreeMap<String, usize>,
) -> Result<String> {
    let roots: Vec<&String> = links.keys().filter(|name| !parent_joint.contains_key(*name)).collect();
    Ok(match roots.as_slice() {
        [root] => (*root).clone(),
        [] if links.is_empty() => bail!("{}: the robot has no links", at(robot)),
        [] => bail!("every link is some joint's child: the joints form a loop, not a tree from a base"),
        many => bail!(
            "links {} have no parent joint: the file must describe one tree from a single base link",
            many.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ")
        ),
    })
}

/// The links from `root`, parents first, refused when a link is not reached (a loop).
fn order(
    root: &str,
    links: &BTreeMap<String, Node<'_, '_>>,
    joints: &[JointElement<'_, '_>],
    children: &BTreeMap<String, Vec<usize>>,
) -> Result<Vec<String>> {
    // Every link is reached from the root (no loop hides behind a second root).
    let mut order: Vec<String> = Vec::with_capacity(links.len());
    let mut stack = vec![root.to_string()];
    while let Some(link) = stack.pop() {
        for &j in children.get(&link).map_or(&[][..], Vec::as_slice).iter().rev() {
            stack.push(joints[j].child.clone());
        }
        order.push(link);
    }
    if order.len() != links.len() {
        let reached: HashSet<&String> = order.iter().collect();
        let (name, node) =
            links.iter().find(|(name, _)| !reached.contains(name)).map_or(("", None), |(n, l)| (n, Some(l)));
        bail!(
            "{}: link '{name}' is not reached from '{root}': its joints form a loop",
            node.map_or_else(String::new, at)
        );
    }
    Ok(order)
}

/// Where a node is, for messages: `line L: <joint name="x">`.
pub(super) fn at(node: &Node<'_, '_>) -> String {
    let position = node.document().text_pos_at(node.range().start);
    match node.attribute("name") {
        Some(name) => format!("line {}: <{} name=\"{name}\">", position.row, node.tag_name().name()),
        None => format!("line {}: <{}>", position.row, node.tag_name().name()),
    }
}

pub(super) fn child<'a, 'input>(node: &Node<'a, 'input>, tag: &str) -> Option<Node<'a, 'input>> {
    node.children().find(|n| n.has_tag_name(tag))
}

/// Attribute `name` of `node` as a finite number.
pub(super) fn number(node: &Node<'_, '_>, name: &str) -> Result<Option<f64>> {
    let Some(text) = node.attribute(name) else { return Ok(None) };
    match text.trim().parse::<f64>() {
        Ok(value) if value.is_finite() => Ok(Some(value)),
        _ => bail!("{}: {name}=\"{text}\" is not a finite number", at(node)),
    }
}

pub(super) fn required(node: &Node<'_, '_>, name: &str, meaning: &str) -> Result<f64> {
    number(node, name)?.ok_or_else(|| anyhow!("{}: needs {name}=\"…\" ({meaning})", at(node)))
}

/// Attribute `name` as exactly three finite numbers, or `default` when absent.
pub(super) fn triple(node: &Node<'_, '_>, name: &str, default: [f64; 3]) -> Result<[f64; 3]> {
    let Some(text) = node.attribute(name) else { return Ok(default) };
    let values: Vec<f64> = text.split_whitespace().filter_map(|v| v.parse().ok()).collect();
    if values.len() != 3 || text.split_whitespace().count() != 3 || values.iter().any(|v| !v.is_finite()) {
        bail!("{}: {name}=\"{text}\" needs three finite numbers", at(node));
    }
    Ok([values[0], values[1], values[2]])
}

/// The `<origin>` child of `node` (identity when absent).
pub(super) fn origin(node: &Node<'_, '_>) -> Result<Pose> {
    match child(node, "origin") {
        None => Ok(Pose::identity()),
        Some(origin) => Ok(isometry_from_xyz_rpy(triple(&origin, "xyz", [0.0; 3])?, triple(&origin, "rpy", [0.0; 3])?)),
    }
}

/// A link's `<inertial>` in the link frame (`None` when it has none).
pub(super) fn inertial(link: &Node<'_, '_>) -> Result<Option<Inertial>> {
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

/// A joint's `<axis xyz>` (URDF's default `1 0 0`), refused when it has no direction.
pub(super) fn axis_of(joint: &Node<'_, '_>) -> Result<Vector3<f64>> {
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
pub(super) fn mimic(joint: &Node<'_, '_>) -> Result<Option<(String, f64, f64)>> {
    let Some(element) = child(joint, "mimic") else { return Ok(None) };
    let leader = element.attribute("joint").ok_or_else(|| anyhow!("{}: <mimic> needs joint=\"…\"", at(joint)))?;
    Ok(Some((
        leader.to_string(),
        number(&element, "multiplier")?.unwrap_or(1.0),
        number(&element, "offset")?.unwrap_or(0.0),
    )))
}

/// One joint of the file.
pub(super) struct JointElement<'a, 'input> {
    pub(super) node: Node<'a, 'input>,
    pub(super) name: String,
    pub(super) kind: String,
    pub(super) parent: String,
    pub(super) child: String,
}

/// A held joint's range: `<limit lower upper>` of a revolute or prismatic joint (`None` for a
/// continuous one or one without a limit).
pub(super) fn lock_range(joint: &Node<'_, '_>, kind: &str) -> Result<Option<(f64, f64)>> {
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

/// A joint's `<limit>`: lower, upper (rad), effort (N·m), velocity (rad/s).
/// A continuous joint without `<limit>` has the range ±π and no speed or torque limit of its
/// own (0: the caller takes the other arm joints'); a speed or torque limit of 0 means the same
/// (CAD exporters write 0 for "not given").
pub(super) fn limits(joint: &Node<'_, '_>, kind: &str) -> Result<JointLimits> {
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
pub(super) fn friction(joint: &Node<'_, '_>) -> Result<Friction> {
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
pub(super) fn gravity(robot: &Node<'_, '_>) -> Result<Vector3<f64>> {
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
