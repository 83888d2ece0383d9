//! The tree to the chain: the tool link ([`choose_tool`]), the joints from the base to it, which
//! of them are the arm's and how every other moving joint is held ([`LockedJoint`]: the user's
//! locks, `<mimic>` followers, a gripper's joints at their defaults), and, when the way to the
//! tool has not four moving joints, why, with the `--lock` that fixes it ([`wrong_count`]).

use super::read::{JointElement, at, axis_of, lock_range, mimic, origin};
use anyhow::{Result, bail};
use chessarm_core::arm::chain::{ChainError, ChainJoint, SerialChain, model_from_chain};
use chessarm_core::arm::kinematics::Pose;
use chessarm_core::arm::model::{Friction, Inertial, JointLimits, REPORT_GRAVITY};
use chessarm_core::nalgebra::Vector3;
use roxmltree::Node;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Names that mark a tool frame, as whole words of a link's name (`ee_gripper_link`,
/// `end_effector_link`, `gripper_frame_link`, `tcp`).
pub const TOOL_WORDS: [&[&str]; 7] =
    [&["tool"], &["tcp"], &["ee"], &["eef"], &["tip"], &["end", "effector"], &["gripper", "frame"]];

pub(super) fn well_known_tool(name: &str) -> bool {
    let last = name.rsplit('/').next().unwrap_or(name).to_ascii_lowercase();
    let words: Vec<&str> = last.split(['_', '-', '.']).filter(|w| !w.is_empty()).collect();
    TOOL_WORDS.iter().any(|pattern| words.windows(pattern.len()).any(|w| w == *pattern))
}

/// The tool link: `--tool`, else a leaf reached by a fixed joint with a tool's name (or the
/// only such leaf); the choice goes to `notes`.
pub(super) fn choose_tool(
    tool: Option<&str>,
    links: &BTreeMap<String, Node<'_, '_>>,
    joints: &[JointElement<'_, '_>],
    children: &BTreeMap<String, Vec<usize>>,
    root: &str,
    notes: &mut Vec<String>,
) -> Result<String> {
    let leaves: Vec<&JointElement<'_, '_>> =
        joints.iter().filter(|j| j.kind == "fixed" && !children.contains_key(&j.child)).collect();
    let listed = |names: &[&str]| names.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ");
    if let Some(tool) = tool {
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
        return Ok(tool.to_string());
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

/// The value of a `<mimic>` joint: `multiplier·leader + offset`, the leader held or itself a
/// follower (chains of followers up to the number of joints).
pub(super) fn mimic_value(
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
pub(super) fn default_hold(range: Option<(f64, f64)>) -> f64 {
    match range {
        Some((lower, _)) if lower > 0.0 => lower,
        Some((_, upper)) if upper < 0.0 => upper,
        _ => 0.0,
    }
}

/// What a link is carried by: the base (0) or arm joint `k`'s link (`k`, 1-based), and its
/// pose in that link's frame.
pub(super) type Carried = (usize, Pose);

/// A joint's motion at `value`: a turn about `axis` (rad) or a slide along it (m).
pub(super) fn motion(kind: &str, axis: &Vector3<f64>, value: f64) -> Pose {
    let unit = chessarm_core::nalgebra::Unit::new_normalize(*axis);
    if kind == "prismatic" {
        Pose::from_parts((axis.normalize() * value).into(), chessarm_core::nalgebra::Rotation3::identity())
    } else {
        Pose::from_parts(Vector3::zeros().into(), chessarm_core::nalgebra::Rotation3::from_axis_angle(&unit, value))
    }
}

/// Why the way to the tool does not have four moving joints, with the `--lock` that fixes it
/// when one exists.
pub(super) fn wrong_count(
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
pub(super) fn combinations(n: usize, k: usize) -> Vec<Vec<usize>> {
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
pub(super) fn geometry_fits(
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
