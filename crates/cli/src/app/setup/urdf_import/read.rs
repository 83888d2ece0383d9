//! The XML of a URDF file, element by element: attributes as numbers and triples, origins,
//! inertials, axes, `<mimic>`, limits, friction and gravity. Every error names the element, its
//! line, and the value as written.

use anyhow::{Result, anyhow, bail};
use chessarm_core::arm::chain::isometry_from_xyz_rpy;
use chessarm_core::arm::kinematics::Pose;
use chessarm_core::arm::model::{Friction, Inertial, JointLimits, REPORT_GRAVITY};
use chessarm_core::nalgebra::{Matrix3, Vector3};
use roxmltree::Node;
use std::f64::consts::PI;

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
