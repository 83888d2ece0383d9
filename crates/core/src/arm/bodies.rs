//! The arm's solids: what it is made of in space, for drawing it (the URDF export, the replay)
//! and for keeping it clear of the pieces, the table and itself.
//!
//! Every joint has a motor housing, a cylinder of [`JOINT_RADIUS`] and [`JOINT_LENGTH`] about
//! its axis centred on the axis' point `p_j` of its DH frame; every link a cylinder of
//! [`LINK_RADIUS`] from its joint's point to the next frame's origin (none where they
//! coincide), the last one ending at the gripper's palm; a pedestal of twice the joint radius
//! stands under the base. The gripper ([`Gripper`]) has two fingers, boxes that hang from the
//! palm along the tool's approach axis `x_N` (the last frame's x: from the last joint's axis to
//! the tip, straight down when the tool points down) past the tool tip, and close along the
//! last joint's axis `z_{N−1}` (the wrist's pitch axis): their inner faces are `gap / 2` either
//! side of the tip. A carried piece is an upright cylinder hanging from the tip by its grip
//! height. All positions are in the base frame, m.
//!
//! An arm described by its maker ([`Bodies::Described`], e.g. a URDF's `<collision>` shapes)
//! has those shapes in place of the pedestal, housings and link cylinders, each fixed to a
//! body (0 the base, `k` link `k`, placed in DH frame `k`); the fingers and a held piece are
//! chessarm's unless the maker describes fingers on a prismatic joint ([`Mount::Finger`]),
//! which then slide to the opening the gripper's command asks for. A described shape may be
//! a jaw fixed to the last link ([`Part::Jaw`]), which grips the piece beside the fingers.

use crate::arm::kinematics::{FrameChain, Pose};
use crate::arm::model::{ArmModel, JointVector};
use crate::arm::outline::{OUTLINE_RINGS, Outline};
use nalgebra::{Matrix3, Point3, Translation3, Vector3};
use std::sync::Arc;

/// Radius of the links' cylinders, m.
pub const LINK_RADIUS: f64 = 0.015;
/// Radius and length of the joints' motor housings, m.
pub const JOINT_RADIUS: f64 = 0.022;
pub const JOINT_LENGTH: f64 = 0.05;
/// Radius of the tool's marker sphere in drawings (the URDF export, the replay), m. It is not
/// a solid: the gripper's fingers are.
pub const TOOL_RADIUS: f64 = 0.008;

/// A parallel gripper's fingers, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gripper {
    /// From the palm to the fingers' ends along the approach axis.
    pub finger_length: f64,
    /// How far the fingers' ends reach past the tool tip (the grip point, where the pads'
    /// middle holds a piece).
    pub finger_reach: f64,
    /// A finger's thickness along the closing direction.
    pub finger_thickness: f64,
    /// A finger's width across the closing direction.
    pub finger_width: f64,
    /// The gap between each finger and a piece when the gripper is open around it, per side.
    pub finger_opening: f64,
}

impl Default for Gripper {
    /// Printed or sheet fingers of a hobby parallel gripper: 45 mm long, reaching 5 mm past
    /// the grip point, 6 mm thick, 14 mm wide, opened 6 mm beyond the piece on each side.
    fn default() -> Self {
        Self {
            finger_length: 0.045,
            finger_reach: 0.005,
            finger_thickness: 0.006,
            finger_width: 0.014,
            finger_opening: 0.006,
        }
    }
}

impl Gripper {
    /// Checks every size is finite and > 0 (the opening ≥ 0) and the fingers reach past the
    /// tip: the first field that is not, with what is required.
    pub fn validated(self) -> Result<Self, (&'static str, f64, &'static str)> {
        for (field, value) in [
            ("finger_length", self.finger_length),
            ("finger_thickness", self.finger_thickness),
            ("finger_width", self.finger_width),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err((field, value, "must be finite and > 0"));
            }
        }
        for (field, value) in [("finger_reach", self.finger_reach), ("finger_opening", self.finger_opening)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err((field, value, "must be finite and >= 0"));
            }
        }
        if self.finger_reach >= self.finger_length {
            return Err(("finger_reach", self.finger_reach, "must be shorter than finger_length"));
        }
        Ok(self)
    }

    /// The gap between the fingers when open around a piece of base `diameter`, m.
    pub fn open_gap(&self, diameter: f64) -> f64 {
        diameter + 2.0 * self.finger_opening
    }

    /// How far the palm is behind the tool tip along the approach axis, m.
    pub fn palm_depth(&self) -> f64 {
        self.finger_length - self.finger_reach
    }
}

/// A piece held by the gripper: its outline upright (along the tool's approach when the tool
/// points down), its base `grip_height` below the tip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held {
    pub outline: Outline,
    pub grip_height: f64,
    /// The angle (rad) about the tool frame's z axis from where the tool points to the piece's
    /// axis (down): 0 with the tool gripping straight down, else
    /// [`crate::arm::task::held_turn`] of the grip's pitch.
    pub turn: f64,
}

/// What the hand does: the gap between the fingers' inner faces (m) and the piece it holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hand {
    pub gripper: Gripper,
    pub gap: f64,
    pub held: Option<Held>,
}

/// A convex shape in a frame of its own, m (a URDF `<geometry>`).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A box of half sizes `half` along the frame's axes, centred on its origin.
    Cuboid {
        half: Vector3<f64>,
    },
    /// A cylinder about the frame's z, centred on its origin.
    Cylinder {
        radius: f64,
        length: f64,
    },
    Sphere {
        radius: f64,
    },
    /// The convex hull of `points` (a mesh's vertices, or only the hull's).
    Hull {
        points: Arc<[Vector3<f64>]>,
    },
}

/// A shape fixed to one of the arm's bodies: 0 the base (`pose` in the base frame), `k` link
/// `k` (`pose` in DH frame `k`, the frame body `k` carries), and how it rides there.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyShape {
    pub body: usize,
    pub pose: Pose,
    pub shape: Shape,
    pub mount: Mount,
}

/// How a described shape rides on its body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mount {
    /// Fixed to it, a part of the link.
    Fixed,
    /// A jaw of the gripper fixed to the last link (a [`Part::Jaw`]: beside the piece it
    /// grips, not an obstacle to it).
    Jaw,
    /// A finger of the gripper on a prismatic joint of the last link (a [`Part::Finger`]):
    /// `pose` is its place with the gripper's joint at the value the file is held at, and it
    /// slides with the gap the hand asks for.
    Finger(Slide),
}

/// How a finger on a prismatic joint moves with the gripper's joint (its leader, the joint
/// the others follow by `<mimic>`), in DH frame `N` (the tool tip at its origin, the approach
/// along x). At the leader's value `v` the finger stands `at_zero + v · travel` (m) from
/// `pose`; its inner face, the nearest of its points to the tool's axis along the way it
/// opens, is `face + v · rate` from that axis (m; `rate` > 0, m per unit of `v`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slide {
    /// The finger's number, 1, 2, … (a finger of several shapes has one number).
    pub finger: usize,
    pub travel: Vector3<f64>,
    pub at_zero: Vector3<f64>,
    pub face: f64,
    pub rate: f64,
    /// The leader's range (its limits), m.
    pub range: [f64; 2],
    /// Across the tool tip (the plane of the grip): how thick the finger is along the way it
    /// opens, and how far it reaches either side of the closing line, m.
    pub thickness: f64,
    pub half_width: f64,
}

/// The value of the gripper's joint (its leader's, m) that opens the fingers of `shapes` to
/// `gap` (m between their inner faces, each at least `gap / 2` from the tool's axis), within
/// the joint's range; `None` when no shape is a sliding finger.
pub fn finger_value(shapes: &[BodyShape], gap: f64) -> Option<f64> {
    let mut value: Option<f64> = None;
    let mut range = [f64::NEG_INFINITY, f64::INFINITY];
    for shape in shapes {
        if let Mount::Finger(slide) = &shape.mount {
            let needed = (0.5 * gap - slide.face) / slide.rate;
            value = Some(value.map_or(needed, |v| v.max(needed)));
            range = [range[0].max(slide.range[0]), range[1].min(slide.range[1])];
        }
    }
    value.map(|v| {
        if v < range[0] {
            range[0]
        } else if v > range[1] {
            range[1]
        } else {
            v
        }
    })
}

/// What the arm's pedestal, housings and links are made of.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Bodies {
    /// chessarm's own solids from the kinematic chain (see the module's documentation).
    #[default]
    Drawn,
    /// Shapes given per body, e.g. a URDF's `<collision>` elements.
    Described(Arc<[BodyShape]>),
}

impl Bodies {
    /// Most solids [`solids_into`] makes with these bodies for an arm of `n` joints (two
    /// fingers and a held piece included).
    pub fn most_solids(&self, n: usize) -> usize {
        match self {
            Bodies::Drawn => 2 * n + 3 + OUTLINE_RINGS,
            Bodies::Described(shapes) => shapes.len() + 2 + OUTLINE_RINGS,
        }
    }
}

/// The narrowest and the widest gap the fingers of `shapes` reach within their joint's range,
/// m (between their inner faces, twice the nearer face's distance from the tool's axis);
/// `None` when no shape is a sliding finger.
pub fn finger_gaps(shapes: &[BodyShape]) -> Option<[f64; 2]> {
    let slides: Vec<&Slide> =
        shapes.iter().filter_map(|s| if let Mount::Finger(slide) = &s.mount { Some(slide) } else { None }).collect();
    let low = slides.iter().map(|s| s.range[0]).fold(f64::NEG_INFINITY, f64::max);
    let high = slides.iter().map(|s| s.range[1]).fold(f64::INFINITY, f64::min);
    let gap = |v: f64| slides.iter().map(|s| 2.0 * (s.face + s.rate * v)).fold(f64::INFINITY, f64::min);
    (!slides.is_empty()).then(|| [gap(low), gap(high)])
}

/// The thickest and widest of the sliding fingers of `shapes` across the tool tip: their
/// thickness along the way they open and their half width across it, m; `None` without.
pub fn finger_section(shapes: &[BodyShape]) -> Option<(f64, f64)> {
    shapes.iter().filter_map(|s| if let Mount::Finger(slide) = &s.mount { Some(slide) } else { None }).fold(
        None,
        |most: Option<(f64, f64)>, s| {
            Some(most.map_or((s.thickness, s.half_width), |(t, w)| (t.max(s.thickness), w.max(s.half_width))))
        },
    )
}

/// A convex solid in the base frame, m.
#[derive(Debug, Clone, PartialEq)]
pub enum Solid {
    /// A cylinder of `radius` whose end faces are centred on `a` and `b`.
    Cylinder { a: Vector3<f64>, b: Vector3<f64>, radius: f64 },
    /// A frustum (a cone cut flat at both ends) whose end faces are discs of `radius_a` about
    /// `a` and `radius_b` about `b`: a section of a piece's outline.
    Frustum { a: Vector3<f64>, b: Vector3<f64>, radius_a: f64, radius_b: f64 },
    /// A sphere of `radius` about `centre`.
    Sphere { centre: Vector3<f64>, radius: f64 },
    /// A box about `centre` with half sizes `half` along the columns of `axes` (a rotation).
    Cuboid { centre: Vector3<f64>, axes: Matrix3<f64>, half: Vector3<f64> },
    /// The convex hull of `points` (in the solid's frame) placed at `pose`.
    Hull { pose: Pose, points: Arc<[Vector3<f64>]> },
}

impl Solid {
    /// The lowest height any point of the solid reaches, m: `min(a_z, b_z) − r √(1 − u_z²)`
    /// for a cylinder of axis `u`, `c_z − r` for a sphere, `c_z − Σ_k |R_zk| h_k` for a box.
    pub fn lowest(&self) -> f64 {
        match self {
            Solid::Cylinder { a, b, radius } => {
                let length = (b - a).norm();
                let uz = if length > 0.0 { (b.z - a.z) / length } else { 1.0 };
                a.z.min(b.z) - radius * (1.0 - uz * uz).max(0.0).sqrt()
            }
            Solid::Frustum { a, b, radius_a, radius_b } => {
                let length = (b - a).norm();
                let uz = if length > 0.0 { (b.z - a.z) / length } else { 1.0 };
                let tilt = (1.0 - uz * uz).max(0.0).sqrt();
                (a.z - radius_a * tilt).min(b.z - radius_b * tilt)
            }
            Solid::Sphere { centre, radius } => centre.z - radius,
            Solid::Cuboid { centre, axes, half } => {
                centre.z - (0..3).map(|k| axes[(2, k)].abs() * half[k]).sum::<f64>()
            }
            Solid::Hull { pose, points } => {
                points.iter().map(|p| (pose * Point3::from(*p)).z).fold(f64::INFINITY, f64::min)
            }
        }
    }

    /// The farthest any point of the solid is from the point `p`, m (a bound for a cylinder:
    /// its ends' distances plus its radius).
    pub fn farthest_from(&self, p: &Vector3<f64>) -> f64 {
        match self {
            Solid::Cylinder { a, b, radius } => (a - p).norm().max((b - p).norm()) + radius,
            Solid::Frustum { a, b, radius_a, radius_b } => ((a - p).norm() + radius_a).max((b - p).norm() + radius_b),
            Solid::Sphere { centre, radius } => (centre - p).norm() + radius,
            Solid::Cuboid { centre, half, .. } => (centre - p).norm() + half.norm(),
            Solid::Hull { pose, points } => {
                points.iter().map(|v| ((pose * Point3::from(*v)).coords - p).norm()).fold(0.0, f64::max)
            }
        }
    }
}

/// The part of the arm a solid belongs to (joints and links 1-based, as the report counts them;
/// fingers 1 and 2 on the negative and positive side of the closing axis).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Part {
    Pedestal,
    Housing(usize),
    Link(usize),
    Finger(usize),
    /// A jaw of a described gripper fixed to the last link (the SO-101's fixed jaw): it grips
    /// the piece as a finger does, so it is kept apart from that piece as a finger is, and is
    /// an obstacle to every other one.
    Jaw(usize),
    /// The piece the gripper holds.
    Held,
}

impl Part {
    /// The rigid body the part moves with: 0 the base, `i` link `i`, and `n + 1` (`n` the
    /// arm's joint count) for the fingers and a held piece: they ride on the last link, but
    /// counting them one body further keeps them checked against the link and housing before
    /// it (a carried piece swinging into the forearm). A housing moves with the link before
    /// its joint (it is round about the joint's axis, so either side would do). A jaw fixed to
    /// the last link moves with it.
    pub fn body(&self, n: usize) -> usize {
        match *self {
            Part::Pedestal => 0,
            Part::Housing(j) => j - 1,
            Part::Link(i) => i,
            Part::Jaw(_) => n,
            Part::Finger(_) | Part::Held => n + 1,
        }
    }
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Part::Pedestal => write!(f, "pedestal"),
            Part::Housing(j) => write!(f, "joint {j}'s housing"),
            Part::Link(i) => write!(f, "link {i}"),
            Part::Finger(k) => write!(f, "finger {k}"),
            Part::Jaw(k) => write!(f, "jaw {k}"),
            Part::Held => write!(f, "held piece"),
        }
    }
}

/// One solid of the arm and the part it belongs to.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmSolid {
    pub part: Part,
    pub solid: Solid,
}

/// `shape` placed at `pose` (base frame) as a solid.
pub fn place(shape: &Shape, pose: &Pose) -> Solid {
    match shape {
        Shape::Cuboid { half } => {
            Solid::Cuboid { centre: pose.translation.vector, axes: *pose.rotation.matrix(), half: *half }
        }
        Shape::Cylinder { radius, length } => {
            let half = pose.rotation * Vector3::new(0.0, 0.0, 0.5 * length);
            let centre = pose.translation.vector;
            Solid::Cylinder { a: centre - half, b: centre + half, radius: *radius }
        }
        Shape::Sphere { radius } => Solid::Sphere { centre: pose.translation.vector, radius: *radius },
        Shape::Hull { points } => Solid::Hull { pose: *pose, points: Arc::clone(points) },
    }
}

/// The arm's solids at the joint angles `q` (rad) with the hand `hand` and `bodies` into `out`
/// (cleared first; at most [`Bodies::most_solids`], so a buffer kept between calls allocates
/// once): drawn, the pedestal, then per joint its housing and its link; described, each shape
/// on its body (the base's as [`Part::Pedestal`], link `k`'s as [`Part::Link`]`(k)`, a jaw's
/// as [`Part::Jaw`]`(1)`, a finger's as [`Part::Finger`] slid to the hand's gap by
/// [`finger_value`]); then chessarm's fingers (unless the described ones stand in) and the
/// held piece.
pub fn solids_into<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    hand: &Hand,
    bodies: &Bodies,
    out: &mut Vec<ArmSolid>,
) {
    out.clear();
    let chain = FrameChain::new(model, q);
    let tip = chain.tip();
    let tool = chain.body_pose(N - 1).rotation;
    let approach: Vector3<f64> = tool * Vector3::x();
    let mut own_fingers = false;
    match bodies {
        Bodies::Drawn => drawn_into(model, &chain, hand, out),
        Bodies::Described(shapes) => {
            let value = finger_value(shapes, hand.gap);
            own_fingers = value.is_some();
            for shape in shapes.iter() {
                let frame = if shape.body == 0 { Pose::identity() } else { *chain.body_pose(shape.body.min(N) - 1) };
                let (part, pose) = match (shape.body, shape.mount) {
                    (0, _) => (Part::Pedestal, shape.pose),
                    (_, Mount::Jaw) => (Part::Jaw(1), shape.pose),
                    (_, Mount::Finger(slide)) => {
                        let v = value.unwrap_or(0.0);
                        let moved = slide.at_zero + v * slide.travel;
                        (Part::Finger(slide.finger), Translation3::from(moved) * shape.pose)
                    }
                    (k, Mount::Fixed) => (Part::Link(k), shape.pose),
                };
                out.push(ArmSolid { part, solid: place(&shape.shape, &(frame * pose)) });
            }
        }
    }
    let closing = chain.joint_axis(N - 1).0;
    let across = closing.cross(&approach);
    let axes = Matrix3::from_columns(&[closing, approach, across]);
    let g = &hand.gripper;
    let half = Vector3::new(0.5 * g.finger_thickness, 0.5 * g.finger_length, 0.5 * g.finger_width);
    let along = g.finger_reach - 0.5 * g.finger_length;
    // The file's fingers, placed above, stand in for chessarm's.
    let sides: &[(usize, f64)] = if own_fingers { &[] } else { &[(1, -1.0), (2, 1.0)] };
    for &(k, side) in sides {
        let centre = tip + along * approach + side * (0.5 * hand.gap + half.x) * closing;
        out.push(ArmSolid { part: Part::Finger(k), solid: Solid::Cuboid { centre, axes, half } });
    }
    if let Some(held) = hand.held {
        let axis = if held.turn == 0.0 { approach } else { tool * Vector3::new(held.turn.cos(), held.turn.sin(), 0.0) };
        let bottom = tip + held.grip_height * axis;
        let at = |z: f64| bottom - z * axis;
        for (z0, r0, z1, r1) in held.outline.sections() {
            let solid = if r0 == r1 {
                Solid::Cylinder { a: at(z0), b: at(z1), radius: r0 }
            } else {
                Solid::Frustum { a: at(z0), b: at(z1), radius_a: r0, radius_b: r1 }
            };
            out.push(ArmSolid { part: Part::Held, solid });
        }
        // A block (a knight's head) turns with the piece in the fingers: the cylinder it
        // sweeps holds it whichever way it faces.
        if let Some(block) = held.outline.block() {
            let base = held.outline.rings().last().map_or(0.0, |r| r[0]);
            out.push(ArmSolid {
                part: Part::Held,
                solid: Solid::Cylinder { a: at(base), b: at(block.top), radius: held.outline.block_radius() },
            });
        }
    }
}

/// chessarm's own pedestal, housings and links (the module's documentation).
fn drawn_into<const N: usize>(model: &ArmModel<N>, chain: &FrameChain<N>, hand: &Hand, out: &mut Vec<ArmSolid>) {
    let base = model.base();
    out.push(ArmSolid {
        part: Part::Pedestal,
        solid: Solid::Cylinder { a: base - JOINT_LENGTH * Vector3::z(), b: base, radius: 2.0 * JOINT_RADIUS },
    });
    let tip = chain.tip();
    let approach: Vector3<f64> = chain.body_pose(N - 1).rotation * Vector3::x();
    let palm = tip - hand.gripper.palm_depth() * approach;
    for j in 0..N {
        let (axis, point) = chain.joint_axis(j);
        let half = 0.5 * JOINT_LENGTH * axis;
        out.push(ArmSolid {
            part: Part::Housing(j + 1),
            solid: Solid::Cylinder { a: point - half, b: point + half, radius: JOINT_RADIUS },
        });
        let next = if j == N - 1 { palm } else { chain.body_pose(j).translation.vector };
        if (next - point).norm() > 1e-9 {
            out.push(ArmSolid {
                part: Part::Link(j + 1),
                solid: Solid::Cylinder { a: point, b: next, radius: LINK_RADIUS },
            });
        }
    }
}
