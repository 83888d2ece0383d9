//! The arm's bodies: the links' masses and inertias gathered on the body that carries them
//! (composite rigid bodies), and the collision bodies the clearance check takes the links to be.

use super::read::{FileTree, JointElement, at, axis_of, child, inertial, mimic, origin, required, triple};
use super::reduce::{Carried, LockedJoint};
use anyhow::{Context, Result, anyhow, bail};
use chessarm_core::arm::bodies::{Bodies, BodyShape, Mount, Shape, Slide};
use chessarm_core::arm::kinematics::Pose;
use chessarm_core::arm::link::Inertial;
use chessarm_core::nalgebra::Vector3;
use roxmltree::Node;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Bodies lighter than this (kg) fixed to a moving link are markers, not mass.
pub const MARKER_MASS: f64 = 1e-6;

/// Each arm link's body: the link's own inertial and those of the links it carries (fixed and
/// held joints), combined in its frame, bodies lighter than [`MARKER_MASS`] left out as markers.
/// A moving link without mass, or an inertial that is not a body's, is told in `problems`.
pub(super) fn composite(
    file: &FileTree<'_, '_>,
    carried: &BTreeMap<String, Carried>,
    arm: &[usize],
    problems: &mut Vec<String>,
) -> [Inertial; 4] {
    let FileTree { links, bad_inertial, joints, parent_joint, order, .. } = file;
    let mut bodies = [Inertial::zero(); 4];
    let mut own_inertial = [false; 4];
    for link in order {
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
    bodies
}

/// The file's tree, as [`from_urdf_in`](super::from_urdf_in) reads it.
pub(super) struct Tree<'t, 'a, 'input> {
    /// Links from the root, parents first.
    pub(super) order: &'t [String],
    pub(super) carried: &'t BTreeMap<String, Carried>,
    pub(super) links: &'t BTreeMap<String, Node<'a, 'input>>,
    pub(super) parent_joint: &'t BTreeMap<String, usize>,
    pub(super) joints: &'t [JointElement<'a, 'input>],
}

/// Where the links' shapes go: each arm link's joint frame in its DH frame, and how far from
/// its frame a shape may reach, m.
pub(super) struct Frames<'a> {
    pub(super) in_dh: &'a [Pose; 4],
    pub(super) farthest: f64,
}

/// How near the tool point may be to a fixed jaw before it is said to lie on the jaw's face,
/// m: the clearance check's resolution, at which a piece beside it counts as touching it.
const JAW_FACE: f64 = chessarm_chess::clearance::moves::RESOLUTION;

/// A convex hull's vertices, m.
type Points = std::sync::Arc<[Vector3<f64>]>;

/// A joint that slides the file's fingers (or leads those that do), by name, with `(m, o)`:
/// its value is `m · v + o` for the gripper's value `v`.
type Driving = (String, f64, f64);

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
pub(super) fn collision_bodies(
    tree: &Tree<'_, '_, '_>,
    arm: &[usize],
    locked: &[LockedJoint],
    frames: &Frames<'_>,
    folder: Option<&Path>,
    notes: &mut Vec<String>,
    warnings: &mut Vec<String>,
) -> Result<(Bodies, Vec<Driving>)> {
    let mut meshes = Meshes {
        folder,
        package_path: crate::app::setup::meshes::package_path(),
        hulls: BTreeMap::new(),
        missing: Vec::new(),
        count: 0,
    };
    let Found { shapes, fingers, sliding, driving, jaws, with_shapes } =
        find_shapes(tree, arm, locked, frames, &mut meshes, warnings)?;
    let stand_in = "chessarm's own solids from the kinematic chain (a pedestal, a housing per joint, a cylinder per \
                    link) stand in for the links in the clearance check";
    if !meshes.missing.is_empty() {
        warnings.push(not_found(&meshes.missing, stand_in));
        return Ok((Bodies::Drawn, Vec::new()));
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
        return Ok((Bodies::Drawn, Vec::new()));
    }
    let mut said = format!(
        "clearance checked against the file's {} <collision> shape{} ({} mesh{} as convex hulls)",
        shapes.len(),
        if shapes.len() == 1 { "" } else { "s" },
        meshes.count,
        if meshes.count == 1 { "" } else { "es" }
    );
    if !sliding.is_empty() {
        said.push_str(&format!(
            "; the fingers are the file's {}, slid on the gripper's joint to open around each piece by [gripper] \
             finger_opening a side and to close on it",
            sliding.join(", ")
        ));
    }
    if !fingers.is_empty() {
        said.push_str(&format!(
            "; the fingers are chessarm's [gripper], whose opening follows the commands (links {} left out)",
            fingers.join(", ")
        ));
    }
    // The tool point on (or in) a fixed jaw: a piece gripped there stands partly inside it.
    let tool = chessarm_chess::clearance::Placed::of(&chessarm_core::arm::bodies::Solid::Sphere {
        centre: Vector3::zeros(),
        radius: 0.0,
    });
    let on_jaw = shapes
        .iter()
        .filter(|s| s.mount == Mount::Jaw)
        .map(|s| {
            chessarm_chess::clearance::Placed::of(&chessarm_core::arm::bodies::place(&s.shape, &s.pose)).distance(&tool)
        })
        .fold(f64::INFINITY, f64::min);
    if on_jaw <= JAW_FACE {
        warnings.push(format!(
            "the tool point is {} mm from the gripper's fixed jaw (on {}): a piece gripped there stands partly inside \
             the jaw, and the clearance check stops the moves that grip it; give --tool-offset X,Y,Z (m, in the tool \
             link's frame) to put the grip point between the jaws",
            chessarm_core::short_number((on_jaw * 1e4).round() / 10.0),
            jaws.join(", ")
        ));
    }
    if !jaws.is_empty() {
        said.push_str(&format!(
            "; the shapes of {} that reach down beside the grip are the gripper's fixed jaw, kept apart from the \
             piece it grips as a finger is",
            jaws.join(", ")
        ));
    }
    notes.push(said);
    Ok((Bodies::Described(shapes.into()), driving))
}

/// The shapes of the links' `<collision>` elements, the fingers left out, and the bodies that
/// have shapes.
struct Found {
    shapes: Vec<BodyShape>,
    /// The links behind a gripper's joint left out (chessarm's fingers stand in), quoted.
    fingers: Vec<String>,
    /// The links of the file's fingers that slide with the gripper's opening, quoted.
    sliding: Vec<String>,
    /// The joints that slide them and their leaders, each with `(m, o)`: its value is
    /// `m · v + o` for the gripper's value `v`.
    driving: Vec<Driving>,
    /// The links with shapes that are the gripper's fixed jaws, quoted.
    jaws: Vec<String>,
    /// The bodies (0 the base, k arm link k) that have shapes.
    with_shapes: BTreeSet<usize>,
}

/// The shapes of the links' `<collision>` elements, each placed on the body that carries its
/// link, but those of the links behind a gripper's joint (its fingers); a mesh not found is
/// noted in `meshes` and gives no shape.
fn find_shapes(
    tree: &Tree<'_, '_, '_>,
    arm: &[usize],
    locked: &[LockedJoint],
    frames: &Frames<'_>,
    meshes: &mut Meshes<'_>,
    warnings: &mut Vec<String>,
) -> Result<Found> {
    let gripper_joints: std::collections::HashSet<usize> = tree
        .joints
        .iter()
        .enumerate()
        .filter(|(_, j)| locked.iter().any(|l| l.name == j.name && l.gripper.is_some()))
        .map(|(k, _)| k)
        .collect();
    // How deep along the tool's approach a shape on the last link must reach to be a jaw: past
    // the middle between the gripper's joint nearest the tool tip and the tip (in DH frame 4
    // the tip is the origin and the approach +x), where a fixed jaw reaches down beside the
    // piece and the gripper's servo and the wrist do not.
    let jaw_depth = gripper_joints
        .iter()
        .filter_map(|&g| {
            let joint = &tree.joints[g];
            let (carrier, parent_pose) = *tree.carried.get(&joint.parent)?;
            let at = frames.in_dh[3] * parent_pose * origin(&joint.node).ok()?;
            (carrier == 4).then_some(at.translation.vector.x)
        })
        .fold(None, |deepest: Option<f64>, x| Some(deepest.map_or(x, |d| d.max(x))))
        .filter(|x| *x < 0.0)
        .map(|x| 0.5 * x);
    let mut shapes = Vec::new();
    let mut fingers = Vec::new();
    // The shapes of the fingers on prismatic joints, with the joint, and their links.
    let mut sliding: Vec<(usize, BodyShape)> = Vec::new();
    let mut sliding_links: Vec<String> = Vec::new();
    let mut jaws = Vec::new();
    // The bodies (0 the base, k arm link k) that have shapes.
    let mut with_shapes = BTreeSet::new();
    for link in tree.order {
        let node = tree.links[link.as_str()];
        let elements: Vec<Node<'_, '_>> = node.children().filter(|n| n.has_tag_name("collision")).collect();
        if elements.is_empty() {
            continue;
        }
        // Behind a gripper's joint (before reaching an arm joint): a finger, which slides with
        // the gripper's opening when its joint is prismatic on the last link.
        let mut up = link;
        let mut behind = None;
        while let Some(&j) = tree.parent_joint.get(up) {
            if gripper_joints.contains(&j) {
                behind = Some(j);
                break;
            }
            if arm.contains(&j) {
                break;
            }
            up = &tree.joints[j].parent;
        }
        let (carrier, pose) = tree.carried[link];
        match behind {
            Some(g) if tree.joints[g].kind == "prismatic" && carrier == 4 => sliding_links.push(format!("'{link}'")),
            Some(_) => {
                fingers.push(format!("'{link}'"));
                continue;
            }
            None => {}
        }
        let frame = if carrier == 0 { pose } else { frames.in_dh[carrier - 1] * pose };
        for element in elements {
            let placed = frame * origin(&element)?;
            let geometry = child(&element, "geometry")
                .and_then(|g| g.children().find(Node::is_element))
                .ok_or_else(|| anyhow!("{}: <collision> needs a <geometry> with a shape", at(&node)))?;
            let shape = meshes.shape(&geometry, &node, warnings).map_err(|e| anyhow!("link '{link}': {e:#}"))?;
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
                if let Some(g) = behind {
                    sliding.push((g, BodyShape { body: carrier, pose: placed, shape, mount: Mount::Fixed }));
                    continue;
                }
                let jaw = carrier == 4 && jaw_depth.is_some_and(|depth| deepest(&shape, &placed) >= depth);
                if jaw && !jaws.contains(&format!("'{link}'")) {
                    jaws.push(format!("'{link}'"));
                }
                let mount = if jaw { Mount::Jaw } else { Mount::Fixed };
                shapes.push(BodyShape { body: carrier, pose: placed, shape, mount });
            }
        }
    }
    // The file's fingers stand in for chessarm's when every finger slides on a prismatic joint
    // that closes across the tool's axis; else chessarm's fingers do, and the file's are left
    // out.
    let slides = if fingers.is_empty() { slides(tree, locked, frames, &sliding)? } else { None };
    let mut driving = Vec::new();
    match slides {
        Some((slides, joints)) => {
            driving = joints;
            for ((_, mut shape), slide) in sliding.into_iter().zip(slides) {
                shape.mount = Mount::Finger(slide);
                shapes.push(shape);
            }
        }
        None => fingers.append(&mut sliding_links),
    }
    Ok(Found { shapes, fingers, sliding: sliding_links, driving, jaws, with_shapes })
}

/// Each sliding finger shape's [`Slide`] (`sliding`: the gripper's joint it is behind, and the
/// shape placed in DH frame 4 with the joint at its held value), and the joints that slide
/// them and their leaders with `(m, o)` (the joint's value `m · v + o` for the leader's `v`);
/// `None` when a joint does not close across the tool's axis (it moves only along the
/// approach) or has no range.
fn slides(
    tree: &Tree<'_, '_, '_>,
    locked: &[LockedJoint],
    frames: &Frames<'_>,
    sliding: &[(usize, BodyShape)],
) -> Result<Option<(Vec<Slide>, Vec<Driving>)>> {
    // Per joint, in the order first met: its finger number and how it slides.
    let mut joints: Vec<(usize, Slide)> = Vec::new();
    let mut driving: Vec<Driving> = Vec::new();
    for (g, _) in sliding {
        if joints.iter().any(|(j, _)| j == g) {
            continue;
        }
        let joint = &tree.joints[*g];
        let (_, parent_pose) = tree.carried[&joint.parent];
        let at = frames.in_dh[3] * parent_pose * origin(&joint.node)?;
        let axis = at.rotation * axis_of(&joint.node)?.normalize();
        let (leader, multiplier, offset) = mimic(&joint.node)?.unwrap_or((joint.name.clone(), 1.0, 0.0));
        let Some(held) = locked.iter().find(|l| l.name == joint.name).map(|l| l.value) else { return Ok(None) };
        let Some([a, b]) = locked.iter().find(|l| l.name == leader).and_then(|l| l.gripper) else {
            return Ok(None);
        };
        let travel = multiplier * axis;
        let across = travel - travel.x * Vector3::x();
        if !(across.norm() > 1e-9 && a.is_finite() && b.is_finite()) {
            return Ok(None);
        }
        let opens = across.normalize();
        let at_zero = (offset - held) * axis;
        // The inner face with the joint held: the nearest point of its shapes along `opens`
        // where they hold a piece, across the tool tip; the outer face, the farthest; and how
        // far they reach either side of the closing line.
        let sideways = Vector3::x().cross(&opens);
        let extent = |direction: &Vector3<f64>| {
            sliding
                .iter()
                .filter(|(j, _)| j == g)
                .map(|(_, shape)| face_at_grip(&shape.shape, &shape.pose, direction))
                .fold(f64::INFINITY, f64::min)
        };
        let face_held = extent(&opens);
        let thickness = -extent(&-opens) - face_held;
        let half_width = (-extent(&sideways)).max(-extent(&-sideways));
        let slide = Slide {
            finger: joints.len() + 1,
            travel,
            at_zero,
            face: face_held + at_zero.dot(&opens),
            rate: travel.dot(&opens),
            range: [a.min(b), a.max(b)],
            thickness,
            half_width,
        };
        joints.push((*g, slide));
        for named in [(joint.name.clone(), multiplier, offset), (leader, 1.0, 0.0)] {
            if !driving.iter().any(|(n, ..)| *n == named.0) {
                driving.push(named);
            }
        }
    }
    let slides = sliding
        .iter()
        .map(|(g, _)| joints.iter().find(|(j, _)| j == g).map(|(_, slide)| *slide).unwrap_or_else(|| unreachable!()))
        .collect();
    Ok(Some((slides, driving)))
}

/// The least `p · opens` over the points `p` of `shape` placed at `pose` (DH frame 4) that
/// lie in the plane across the tool tip (`x = 0`), m: where the finger's pad holds a piece. A
/// box's or a hull's section by that plane is the hull of the crossings of the segments
/// between its corners on either side (exact); a shape that does not cross it, a cylinder or
/// a sphere is taken whole (its nearest point: never less open than it is).
fn face_at_grip(shape: &Shape, pose: &Pose, opens: &Vector3<f64>) -> f64 {
    let corners: Vec<Vector3<f64>> = match shape {
        Shape::Cuboid { half } => (0..8)
            .map(|i| {
                let sign = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
                Vector3::new(sign(1) * half.x, sign(2) * half.y, sign(4) * half.z)
            })
            .collect(),
        Shape::Hull { points } => points.to_vec(),
        Shape::Cylinder { .. } | Shape::Sphere { .. } => Vec::new(),
    };
    let placed: Vec<Vector3<f64>> =
        corners.iter().map(|p| (pose * chessarm_core::nalgebra::Point3::from(*p)).coords).collect();
    let (below, above): (Vec<&Vector3<f64>>, Vec<&Vector3<f64>>) = placed.iter().partition(|p| p.x <= 0.0);
    let mut least = f64::INFINITY;
    for a in below.iter().filter(|a| a.x == 0.0) {
        least = least.min(a.dot(opens));
    }
    for a in &below {
        for b in &above {
            // b.x > 0 ≥ a.x: the segment crosses x = 0 at a + t (b − a).
            let t = -a.x / (b.x - a.x);
            least = least.min((*a + t * (*b - *a)).dot(opens));
        }
    }
    if least.is_finite() { least } else { nearest_along(shape, pose, opens) }
}

/// The least `p · direction` over the points `p` of `shape` placed at `pose`, m.
fn nearest_along(shape: &Shape, pose: &Pose, direction: &Vector3<f64>) -> f64 {
    // Turned so that `direction` points up: the least is its lowest point.
    let up = chessarm_core::nalgebra::Rotation3::rotation_between(direction, &Vector3::z()).unwrap_or_else(|| {
        chessarm_core::nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    });
    let turn = Pose::from_parts(chessarm_core::nalgebra::Translation3::identity(), up);
    chessarm_core::arm::bodies::place(shape, &(turn * pose)).lowest()
}

/// How far `shape` placed at `pose` (DH frame 4) reaches along the frame's x, m: the tool's
/// approach, from the tip.
fn deepest(shape: &Shape, pose: &Pose) -> f64 {
    // Turned a quarter about y, x points down: its reach is minus its lowest point.
    let turn = Pose::from_parts(
        chessarm_core::nalgebra::Translation3::identity(),
        chessarm_core::nalgebra::Rotation3::from_axis_angle(
            &chessarm_core::nalgebra::Vector3::y_axis(),
            std::f64::consts::FRAC_PI_2,
        ),
    );
    -chessarm_core::arm::bodies::place(shape, &(turn * pose)).lowest()
}

/// The meshes of the file's `<collision>` elements: where they are looked for, their hulls,
/// and the files not found.
struct Meshes<'f> {
    /// The URDF file's folder, where relative mesh names start.
    folder: Option<&'f Path>,
    /// `ROS_PACKAGE_PATH`'s folders, for `package://` names.
    package_path: Vec<std::path::PathBuf>,
    /// Each mesh file's hull at each scale, read once (an arm repeats its servo's mesh).
    hulls: BTreeMap<(std::path::PathBuf, [u64; 3]), Points>,
    /// Each mesh file not found, with the places it was looked for.
    missing: Vec<(String, Vec<std::path::PathBuf>)>,
    /// The meshes taken, as convex hulls.
    count: usize,
}

impl Meshes<'_> {
    /// The shape of a `<geometry>`'s element (of the `<collision>` of link `node`); `None`
    /// when its mesh file is not found (noted in `missing`).
    fn shape(
        &mut self,
        geometry: &Node<'_, '_>,
        node: &Node<'_, '_>,
        warnings: &mut Vec<String>,
    ) -> Result<Option<Shape>> {
        Ok(Some(match geometry.tag_name().name() {
            "box" => {
                let [x, y, z] = triple(geometry, "size", [f64::NAN; 3])?;
                if !(x > 0.0 && y > 0.0 && z > 0.0) {
                    bail!(
                        "{}: size=\"{}\" needs three sizes, each > 0 (m)",
                        at(geometry),
                        geometry.attribute("size").unwrap_or_default()
                    );
                }
                Shape::Cuboid { half: Vector3::new(x, y, z) * 0.5 }
            }
            "cylinder" => Shape::Cylinder { radius: size(geometry, "radius")?, length: size(geometry, "length")? },
            "sphere" => Shape::Sphere { radius: size(geometry, "radius")? },
            "mesh" => match self.hull(geometry, node, warnings)? {
                Some(points) => Shape::Hull { points },
                None => return Ok(None),
            },
            other => bail!(
                "{}: <collision> with a <{other}>: chessarm takes <box>, <cylinder>, <sphere> and <mesh>",
                at(node)
            ),
        }))
    }

    /// The convex hull of a `<mesh>`'s file at its scale (the same file at the same scale read
    /// once), a mesh of too many vertices said in `warnings`; `None` when the file is not found.
    fn hull(
        &mut self,
        geometry: &Node<'_, '_>,
        node: &Node<'_, '_>,
        warnings: &mut Vec<String>,
    ) -> Result<Option<Points>> {
        let filename =
            geometry.attribute("filename").ok_or_else(|| anyhow!("{}: <mesh> needs filename=\"…\"", at(node)))?;
        let scale = triple(geometry, "scale", [1.0; 3])?;
        let looked = crate::app::setup::meshes::candidates(filename, self.folder, &self.package_path);
        let Some(path) = looked.iter().find(|p| p.is_file()) else {
            self.missing.push((filename.to_string(), looked));
            return Ok(None);
        };
        let key = (path.clone(), scale.map(f64::to_bits));
        let points = match self.hulls.get(&key) {
            Some(points) => std::sync::Arc::clone(points),
            None => {
                let scale_text = geometry.attribute("scale").unwrap_or("1 1 1");
                let mesh = crate::app::setup::meshes::read_stl(path, scale, scale_text)
                    .with_context(|| format!("{}: <mesh filename=\"{filename}\">", at(node)))?;
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
                    anyhow!("{}: <mesh filename=\"{filename}\"> ({}): {why}", at(node), path.display())
                })?;
                let points: std::sync::Arc<[Vector3<f64>]> = hull.into();
                self.hulls.insert(key, std::sync::Arc::clone(&points));
                points
            }
        };
        self.count += 1;
        Ok(Some(points))
    }
}

/// What `warnings` say of the mesh files not found: the first few, where the first was looked
/// for, and what stands in (`stand_in`).
fn not_found(missing: &[(String, Vec<std::path::PathBuf>)], stand_in: &str) -> String {
    let mut names: Vec<String> = Vec::new();
    for (name, _) in missing {
        if !names.contains(name) {
            names.push(name.clone());
        }
    }
    let shown: Vec<String> = names.iter().take(4).map(|n| format!("'{n}'")).collect();
    let more = if names.len() > 4 { format!(" and {} more", names.len() - 4) } else { String::new() };
    let (first, looked) = &missing[0];
    let places: Vec<String> = looked.iter().take(4).map(|p| p.display().to_string()).collect();
    format!(
        "{} collision mesh file{} not found: {}{more} ('{first}' was looked for at {}); {stand_in} (put the \
         meshes where the file names them, or their package's folder on ROS_PACKAGE_PATH)",
        names.len(),
        if names.len() == 1 { "" } else { "s" },
        shown.join(", "),
        places.join(", ")
    )
}
