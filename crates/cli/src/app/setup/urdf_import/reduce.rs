//! The tree to the chain: the tool link ([`choose_tool`]), the joints from the base to it, which
//! of them are the arm's and how every other moving joint is held ([`LockedJoint`]: the user's
//! locks, `<mimic>` followers, a gripper's joints at their defaults), and, when the way to the
//! tool has not four moving joints, why, with the `--lock` that fixes it ([`wrong_count`]).

use super::read::{FileTree, JointElement, at, axis_of, friction, limits, lock_range, mimic, origin};
use anyhow::{Result, bail};
use chessarm_core::arm::chain::{ChainError, ChainJoint, SerialChain, model_from_chain};
use chessarm_core::arm::kinematics::Pose;
use chessarm_core::arm::link::{Friction, Inertial, JointLimits};
use chessarm_core::arm::model::REPORT_GRAVITY;
use chessarm_core::nalgebra::Vector3;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Names that mark a tool frame, as whole words of a link's name (`ee_gripper_link`,
/// `end_effector_link`, `gripper_frame_link`, `tcp`).
pub const TOOL_WORDS: [&[&str]; 7] =
    [&["tool"], &["tcp"], &["ee"], &["eef"], &["tip"], &["end", "effector"], &["gripper", "frame"]];

fn well_known_tool(name: &str) -> bool {
    let last = name.rsplit('/').next().unwrap_or(name).to_ascii_lowercase();
    let words: Vec<&str> = last.split(['_', '-', '.']).filter(|w| !w.is_empty()).collect();
    TOOL_WORDS.iter().any(|pattern| words.windows(pattern.len()).any(|w| w == *pattern))
}

/// The tool link: `--tool`, else a leaf reached by a fixed joint with a tool's name (or the
/// only such leaf); the choice goes to `notes`.
pub(super) fn choose_tool(tool: Option<&str>, file: &FileTree<'_, '_>, notes: &mut Vec<String>) -> Result<String> {
    let FileTree { links, joints, children, root, .. } = file;
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
        if tool == root.as_str() {
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
    /// For a joint that slides the file's fingers, or leads the joints that do: its value is
    /// `m · v + o` (`(m, o)`) for the gripper's value `v` (the leader's, which opens the
    /// fingers to a gap: [`chessarm_core::arm::bodies::finger_value`]).
    pub finger: Option<(f64, f64)>,
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

/// The joints from the root to the tool link, in order.
pub(super) fn path_to(file: &FileTree<'_, '_>, tool_link: &str) -> Vec<usize> {
    let mut path = Vec::new();
    let mut link = tool_link.to_string();
    while let Some(&j) = file.parent_joint.get(&link) {
        path.push(j);
        link = file.joints[j].parent.clone();
    }
    path.reverse();
    path
}

/// The locks the user gave (`--lock NAME=VALUE`), checked: each joint's value by its index.
pub(super) fn user_locks(locks: &[(String, f64)], file: &FileTree<'_, '_>) -> Result<BTreeMap<usize, f64>> {
    let FileTree { joints, by_name, .. } = file;
    let mut values: BTreeMap<usize, f64> = BTreeMap::new();
    for (name, value) in locks {
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
    Ok(values)
}

/// The arm's joints: the moving joints on the way to the tool (`path`) that are not locked
/// (`values`) and follow no other (a `<mimic>` follower moves with its leader: held with it by
/// [`hold_others`], and refused there when its leader is one of the arm's joints, as in a
/// parallel linkage); refused unless they are four turning joints ([`wrong_count`] says why).
pub(super) fn arm_joints(
    file: &FileTree<'_, '_>,
    path: &[usize],
    values: &BTreeMap<usize, f64>,
    tool_link: &str,
) -> Result<Vec<usize>> {
    let FileTree { joints, root, .. } = file;
    let mut followers = std::collections::HashSet::new();
    for &j in path {
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
        bail!("{}", wrong_count(joints, path, &arm, values, tool_link, root)?);
    }
    Ok(arm)
}

/// Every moving joint that is not the arm's, held ([`LockedJoint`], in the file's order): its
/// value goes into `values`; a wrong `<limit>` or a value outside it is told in `problems`, the
/// defaults chosen in `notes`.
pub(super) fn hold_others(
    file: &FileTree<'_, '_>,
    path: &[usize],
    arm: &[usize],
    values: &mut BTreeMap<usize, f64>,
    problems: &mut Vec<String>,
    notes: &mut Vec<String>,
) -> Result<Vec<LockedJoint>> {
    let FileTree { joints, by_name, parent_joint, .. } = file;
    let on_path: std::collections::HashSet<usize> = path.iter().copied().collect();
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
            (None, Some(_)) => mimic_value(j, joints, by_name, values, &arm_set, 0)?,
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
        locked.push(LockedJoint { name: joint.name.clone(), kind: joint.kind.clone(), value, gripper, finger: None });
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
    Ok(locked)
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

/// What a link is carried by: the base (0) or arm joint `k`'s link (`k`, 1-based), and its
/// pose in that link's frame.
pub(super) type Carried = (usize, Pose);

/// Every link's carrier (the base or an arm joint's link) and pose in its frame, root first:
/// the links of fixed and held joints merged into the link they hang on.
pub(super) fn carriers(
    file: &FileTree<'_, '_>,
    arm: &[usize],
    values: &BTreeMap<usize, f64>,
) -> Result<BTreeMap<String, Carried>> {
    let FileTree { joints, parent_joint, root, order, .. } = file;
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
    Ok(carried)
}

/// The tool point's frame in the last arm link's (`tool_offset` in the tool link's frame),
/// refused when the arm's last joint does not move the tool link.
pub(super) fn tool_frame(
    file: &FileTree<'_, '_>,
    carried: &BTreeMap<String, Carried>,
    arm: &[usize],
    tool_link: &str,
    tool_offset: Vector3<f64>,
) -> Result<Pose> {
    let FileTree { joints, links, .. } = file;
    let (tool_carrier, tool_pose) = carried[tool_link];
    if tool_carrier != 4 {
        bail!(
            "{}: the tool link '{tool_link}' is not moved by the arm's last joint '{}': give the link at the tool tip \
             with --tool LINK",
            at(&links[tool_link]),
            joints[arm[3]].name
        );
    }
    Ok(tool_pose * Pose::from_parts(tool_offset.into(), chessarm_core::nalgebra::Rotation3::identity()))
}

/// The chain's joints, the arm's in order, each with the body it moves (`bodies`), and each
/// one's sign (−1 for a base yaw about −z, turned to +z here); limits or friction that are
/// wrong are told in `problems`.
pub(super) fn chain_joints(
    file: &FileTree<'_, '_>,
    carried: &BTreeMap<String, Carried>,
    arm: &[usize],
    bodies: &[Inertial; 4],
    problems: &mut Vec<String>,
    notes: &mut Vec<String>,
) -> Result<(Vec<ChainJoint>, [f64; 4])> {
    let joints = &file.joints;
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
    Ok((chain_joints, signs))
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
