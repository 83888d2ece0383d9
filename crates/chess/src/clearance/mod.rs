//! How far the arm stays from the standing pieces, the table and itself: distances between the
//! arm's solids ([`chessarm_core::arm::bodies`]) and the pieces, each an upright cylinder of its
//! kind's base radius and height standing on the board, computed by parry3d's GJK on the convex
//! shapes; the table is the plane of the board's surface; pairs of the arm's own solids are
//! checked where their bodies are not neighbours (and do not already touch at rest, as the
//! motor housings of a wrist whose joints meet do).
//!
//! A motion is checked continuously, not only at samples, by conservative advancement: at time
//! `t` the arm is `d(t)` from the nearest obstacle, and no point of the arm moves faster than
//! `v̄ = Σ_j |q̇_j|max · ρ_j` (`ρ_j` the farthest any solid can be from joint `j`'s axis:
//! [`reach_bound`], the chain's lengths beyond it, at any angles), so no contact with a still
//! obstacle can happen before `t + d(t) / v̄` (`2 v̄` between two of the arm's own solids, which
//! both move): the next check is there. A contact between two samples of a fixed grid is not
//! stepped over; one shorter than the smallest step is seen as a distance of at most
//! `v̄ · min_step` (the sweep's `resolution`).

pub mod columns;
pub mod moves;

use chessarm_core::arm::bodies::{ArmSolid, Bodies, Hand, Part, Solid, solids_into};
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::arm::outline::Outline;
use chessarm_core::nalgebra::{Matrix3, Point3, Vector2, Vector3};
use parry3d_f64::math::{Matrix, Pose, Rotation, Vector};
use parry3d_f64::query;
use parry3d_f64::shape::{Ball, Cuboid, Cylinder, Shape, SupportMap};
use std::sync::Arc;

/// A standing piece as solids: its outline (m, rings from its base up) standing upright with
/// its base centred on `base` (on the board's surface); a block on top (a knight's head) faces
/// along `facing` (a unit vector on the table: the board's ranks).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StandingPiece {
    pub base: Vector3<f64>,
    pub outline: Outline,
    pub facing: Vector2<f64>,
}

impl StandingPiece {
    /// An upright cylinder of `radius` and `height` (m) on `base`.
    pub fn cylinder(base: Vector3<f64>, radius: f64, height: f64) -> Self {
        Self { base, outline: Outline::cylinder(radius, height), facing: Vector2::x() }
    }
}

/// What the arm comes close to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Obstacle {
    /// A standing piece, by its index in the list checked.
    Piece(usize),
    /// The table (the board's surface).
    Table,
    /// Another part of the arm.
    Arm(Part),
}

/// The closest approach of the arm to an obstacle: the distance (m, 0 when they touch or
/// overlap), the arm's part and the obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    pub distance: f64,
    pub part: Part,
    pub obstacle: Obstacle,
}

/// One of parry's convex shapes, without a box on the heap, or a convex hull's points.
#[derive(Debug, Clone)]
enum Convex {
    Cylinder(Cylinder),
    Frustum(Frustum),
    Ball(Ball),
    Cuboid(Cuboid),
    Hull(HullPoints),
    /// Convex solids together (a piece's sections): not convex itself, so measured part by
    /// part.
    Parts(Arc<[Placed]>),
}

/// A frustum about the local y axis (as parry's cylinders), its end faces discs at `y = ∓h/2`
/// of radii `r_low` and `r_high`: the convex hull of the two discs, whose support point in a
/// direction is the farther of the discs' (a disc's is its centre plus `r` along the
/// direction's part across the axis).
#[derive(Debug, Clone, Copy)]
struct Frustum {
    half_height: f64,
    r_low: f64,
    r_high: f64,
}

impl SupportMap for Frustum {
    fn local_support_point(&self, dir: Vector) -> Vector {
        let across = (dir.x * dir.x + dir.z * dir.z).sqrt();
        let (ux, uz) = if across > 0.0 { (dir.x / across, dir.z / across) } else { (0.0, 0.0) };
        let disc = |y: f64, r: f64| (y * dir.y + r * across, Vector::new(r * ux, y, r * uz));
        let (low, high) = (disc(-self.half_height, self.r_low), disc(self.half_height, self.r_high));
        if high.0 >= low.0 { high.1 } else { low.1 }
    }
}

/// A convex hull as its points, for GJK: the support point in a direction is the point
/// farthest along it (a scan; a mesh's hull has tens to a few hundred vertices).
#[derive(Debug, Clone)]
struct HullPoints(Arc<[Vector3<f64>]>);

impl SupportMap for HullPoints {
    fn local_support_point(&self, dir: Vector) -> Vector {
        // From the first point, so that even a direction of NaN gives a point of the hull.
        let first = self.0.first().map_or(Vector::ZERO, |p| Vector::new(p.x, p.y, p.z));
        let mut best = (f64::NEG_INFINITY, first);
        for p in self.0.iter() {
            let dot = p.x * dir.x + p.y * dir.y + p.z * dir.z;
            if dot > best.0 {
                best = (dot, Vector::new(p.x, p.y, p.z));
            }
        }
        best.1
    }
}

impl Convex {
    /// The shape for parry's dispatcher (`None` for a hull, which it does not know).
    fn shape(&self) -> Option<&dyn Shape> {
        match self {
            Convex::Cylinder(s) => Some(s),
            Convex::Ball(s) => Some(s),
            Convex::Cuboid(s) => Some(s),
            Convex::Frustum(_) | Convex::Hull(_) | Convex::Parts(_) => None,
        }
    }

    /// The support map of a convex shape (`None` for parts together).
    fn support(&self) -> Option<&dyn SupportMap> {
        match self {
            Convex::Cylinder(s) => Some(s),
            Convex::Frustum(s) => Some(s),
            Convex::Ball(s) => Some(s),
            Convex::Cuboid(s) => Some(s),
            Convex::Hull(s) => Some(s),
            Convex::Parts(_) => None,
        }
    }
}

/// A solid as parry sees it, with its axis-aligned bounding box and a capsule that holds it
/// (a segment and a radius), m.
#[derive(Debug, Clone)]
pub struct Placed {
    pose: Pose,
    shape: Convex,
    low: Vector3<f64>,
    high: Vector3<f64>,
    capsule: (Vector3<f64>, Vector3<f64>, f64),
}

/// The vertices of the convex hull of `points` (m), for a [`Solid::Hull`]: a mesh's thousands
/// of vertices become the hull's tens to hundreds, which GJK scans. `Err` with the reason when
/// the points span no volume (fewer than four, or all in a plane).
pub fn hull_of(points: &[Vector3<f64>]) -> Result<Vec<Vector3<f64>>, String> {
    // A mesh repeats each vertex in every triangle that has it (six times on average): once is
    // enough for the hull.
    let mut unique: Vec<[u64; 3]> = points.iter().map(|p| [p.x, p.y, p.z].map(|c| (c + 0.0).to_bits())).collect();
    unique.sort_unstable();
    unique.dedup();
    let input: Vec<Vector> =
        unique.iter().map(|p| Vector::new(f64::from_bits(p[0]), f64::from_bits(p[1]), f64::from_bits(p[2]))).collect();
    let (vertices, faces) = parry3d_f64::transformation::try_convex_hull(&input)
        .map_err(|_| "no convex hull could be made of its points".to_string())?;
    // The volume by the divergence theorem, `Σ v₀ · (v₁ × v₂) / 6` over the faces, against
    // the cube of the extent: a flat hull (a plane's points, both faces) has none.
    let volume: f64 =
        faces.iter().map(|f| f.map(|i| vertices[i as usize])).map(|[a, b, c]| a.dot(b.cross(c)) / 6.0).sum();
    let (low, high) = vertices.iter().fold((vertices[0], vertices[0]), |(l, h), v| (l.min(*v), h.max(*v)));
    if faces.len() < 4 || volume.abs() <= 1e-9 * (high - low).max_element().powi(3) {
        return Err("its points span no volume (they lie in a plane or on a line)".into());
    }
    let mut used = vec![false; vertices.len()];
    faces.iter().flatten().for_each(|&i| used[i as usize] = true);
    Ok(vertices.iter().zip(used).filter(|(_, u)| *u).map(|(v, _)| Vector3::new(v.x, v.y, v.z)).collect())
}

/// The shortest distance between the segments `p1 q1` and `p2 q2`, m: the closest points'
/// parameters clamped to the segments in turn (Ericson, Real-Time Collision Detection 5.1.9).
pub fn segment_distance(p1: &Vector3<f64>, q1: &Vector3<f64>, p2: &Vector3<f64>, q2: &Vector3<f64>) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    let tiny = 1e-18;
    let (s, t) = if a <= tiny && e <= tiny {
        (0.0, 0.0)
    } else if a <= tiny {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= tiny {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denominator = a * e - b * b;
            let mut s = if denominator > tiny { ((b * f - c * e) / denominator).clamp(0.0, 1.0) } else { 0.0 };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + d1 * s) - (p2 + d2 * t)).norm()
}

fn vector(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

/// A cylinder's half extent along each world axis: `r √(1 − u_k²)` across plus `|u_k| L / 2`.
fn cylinder_box(a: &Vector3<f64>, b: &Vector3<f64>, radius: f64) -> (Vector3<f64>, Vector3<f64>) {
    let axis = b - a;
    let length = axis.norm();
    let u = if length > 0.0 { axis / length } else { Vector3::z() };
    let half = u.map(|c| radius * (1.0 - c * c).max(0.0).sqrt());
    (a.inf(b) - half, a.sup(b) + half)
}

impl Placed {
    /// The parry shape and pose of `solid` (a parry cylinder's axis is its local y).
    pub fn of(solid: &Solid) -> Self {
        match solid {
            Solid::Cylinder { a, b, radius } => {
                let axis = b - a;
                let length = axis.norm();
                let direction = if length > 0.0 { vector(&(axis / length)) } else { Vector::Y };
                let rotation = Rotation::from_rotation_arc(Vector::Y, direction);
                let (low, high) = cylinder_box(a, b, *radius);
                Self {
                    pose: Pose::from_parts(vector(&((a + b) * 0.5)), rotation),
                    shape: Convex::Cylinder(Cylinder::new(0.5 * length, *radius)),
                    low,
                    high,
                    capsule: (*a, *b, *radius),
                }
            }
            Solid::Frustum { a, b, radius_a, radius_b } => {
                let axis = b - a;
                let length = axis.norm();
                let direction = if length > 0.0 { vector(&(axis / length)) } else { Vector::Y };
                let rotation = Rotation::from_rotation_arc(Vector::Y, direction);
                let ((la, ha), (lb, hb)) = (cylinder_box(a, b, *radius_a), cylinder_box(a, b, *radius_b));
                Self {
                    pose: Pose::from_parts(vector(&((a + b) * 0.5)), rotation),
                    shape: Convex::Frustum(Frustum { half_height: 0.5 * length, r_low: *radius_a, r_high: *radius_b }),
                    low: la.inf(&lb),
                    high: ha.sup(&hb),
                    capsule: (*a, *b, radius_a.max(*radius_b)),
                }
            }
            Solid::Sphere { centre, radius } => Self {
                pose: Pose::from_translation(vector(centre)),
                shape: Convex::Ball(Ball::new(*radius)),
                low: centre.add_scalar(-radius),
                high: centre.add_scalar(*radius),
                capsule: (*centre, *centre, *radius),
            },
            Solid::Cuboid { centre, axes, half } => {
                let columns = [0, 1, 2].map(|k| vector(&axes.column(k).into_owned()));
                let rotation = Rotation::from_mat3(&Matrix::from_cols(columns[0], columns[1], columns[2]));
                let extent = axes.abs() * half;
                // The capsule along the box's longest axis, as thick as the other two's diagonal.
                let long = if half.x >= half.y && half.x >= half.z {
                    0
                } else if half.y >= half.z {
                    1
                } else {
                    2
                };
                let along = axes.column(long) * half[long];
                let across = (half.norm_squared() - half[long] * half[long]).sqrt();
                Self {
                    pose: Pose::from_parts(vector(centre), rotation),
                    shape: Convex::Cuboid(Cuboid::new(vector(half))),
                    low: centre - extent,
                    high: centre + extent,
                    capsule: (centre - along, centre + along, across),
                }
            }
            Solid::Hull { pose, points } => {
                let rotation = pose.rotation.matrix();
                let columns = [0, 1, 2].map(|k| vector(&rotation.column(k).into_owned()));
                let rotation = Rotation::from_mat3(&Matrix::from_cols(columns[0], columns[1], columns[2]));
                let world = |p: &Vector3<f64>| (pose * Point3::from(*p)).coords;
                let (mut low, mut high) = (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY));
                for p in points.iter() {
                    let w = world(p);
                    (low, high) = (low.inf(&w), high.sup(&w));
                }
                // A sphere about the box's centre that holds every point.
                let centre = 0.5 * (low + high);
                let radius = points.iter().map(|p| (world(p) - centre).norm()).fold(0.0, f64::max);
                Self {
                    pose: Pose::from_parts(vector(&pose.translation.vector), rotation),
                    shape: Convex::Hull(HullPoints(Arc::clone(points))),
                    low,
                    high,
                    capsule: (centre, centre, radius),
                }
            }
        }
    }

    /// The convex parts of this solid: itself, or its parts.
    fn parts(&self) -> &[Placed] {
        match &self.shape {
            Convex::Parts(parts) => parts,
            _ => std::slice::from_ref(self),
        }
    }

    /// The nearest pair of convex parts of this solid and `other`, and their distance (m). The
    /// pairs go nearest box first, and stop where a box's gap (a lower bound) reaches the
    /// best distance: most pairs of a finger and a piece's dozen sections are one GJK call.
    fn nearest_parts<'a>(&'a self, other: &'a Placed) -> (f64, &'a Placed, &'a Placed) {
        const MOST: usize = 2 * chessarm_core::arm::outline::OUTLINE_RINGS;
        let (ours, theirs) = (self.parts(), other.parts());
        let mut best = (f64::INFINITY, self, other);
        // One side is a single solid wherever pieces meet the arm; otherwise every pair.
        if ours.len() * theirs.len() > MOST {
            for a in ours {
                for b in theirs {
                    if a.box_gap(b) < best.0 {
                        let d = a.convex_distance(b);
                        if d < best.0 {
                            best = (d, a, b);
                        }
                    }
                }
            }
            return best;
        }
        let mut gaps = [(0.0, 0, 0); MOST];
        let mut n = 0;
        for (i, a) in ours.iter().enumerate() {
            for (k, b) in theirs.iter().enumerate() {
                gaps[n] = (a.box_gap(b), i, k);
                n += 1;
            }
        }
        let gaps = &mut gaps[..n];
        gaps.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
        for &(gap, i, k) in gaps.iter() {
            if gap >= best.0 {
                break;
            }
            let d = ours[i].convex_distance(&theirs[k]);
            if d < best.0 {
                best = (d, &ours[i], &theirs[k]);
            }
        }
        best
    }

    /// The closest points of this solid and `other` (base frame, m): on this one, then on
    /// `other` (by parry's GJK on their support maps, of the nearest parts); where they
    /// overlap, both are the middle of their boxes' overlap. For showing where the nearest
    /// pair is, not for measuring it.
    pub fn closest_points(&self, other: &Placed) -> [Vector3<f64>; 2] {
        let (_, this, other) = self.nearest_parts(other);
        let pos12 = this.pose.inv_mul(&other.pose);
        let supports = this.shape.support().zip(other.shape.support());
        let found =
            supports.map(|(a, b)| query::details::closest_points_support_map_support_map(&pos12, a, b, f64::MAX));
        match found {
            Some(query::ClosestPoints::WithinMargin(p, q)) => {
                [this.pose.transform_point(p), other.pose.transform_point(q)].map(|v| Vector3::new(v.x, v.y, v.z))
            }
            _ => {
                let middle = 0.5 * (this.low.sup(&other.low) + this.high.inf(&other.high));
                [middle, middle]
            }
        }
    }

    /// Its lowest point (base frame, m): the support point along −z (of its lowest part).
    pub fn lowest_point(&self) -> Vector3<f64> {
        let lowest = |p: &Placed| {
            let down = p.pose.rotation.inverse() * Vector::NEG_Z;
            let support = p.shape.support().map_or(Vector::ZERO, |s| s.local_support_point(down));
            let v = p.pose.transform_point(support);
            Vector3::new(v.x, v.y, v.z)
        };
        self.parts().iter().map(lowest).min_by(|a, b| a.z.total_cmp(&b.z)).unwrap_or(self.low)
    }

    /// A piece standing upright: a cylinder or frustum per section of its outline, and its
    /// block (a box facing along `facing`), together.
    pub fn piece(piece: &StandingPiece) -> Self {
        let outline = &piece.outline;
        let at = |z: f64| piece.base + Vector3::new(0.0, 0.0, z);
        let mut parts: Vec<Placed> = outline
            .sections()
            .map(|(z0, r0, z1, r1)| {
                Self::of(&if r0 == r1 {
                    Solid::Cylinder { a: at(z0), b: at(z1), radius: r0 }
                } else {
                    Solid::Frustum { a: at(z0), b: at(z1), radius_a: r0, radius_b: r1 }
                })
            })
            .collect();
        if let Some(block) = outline.block() {
            let bottom = outline.rings().last().map_or(0.0, |r| r[0]);
            let along = Vector3::new(piece.facing.x, piece.facing.y, 0.0).try_normalize(1e-12).unwrap_or(Vector3::x());
            let axes = Matrix3::from_columns(&[along, Vector3::z().cross(&along), Vector3::z()]);
            let half = Vector3::new(block.half_length, block.half_width, 0.5 * (block.top - bottom));
            parts.push(Self::of(&Solid::Cuboid { centre: at(0.5 * (block.top + bottom)), axes, half }));
        }
        if parts.len() == 1 {
            return parts.pop().expect("one part");
        }
        let low = parts.iter().fold(Vector3::repeat(f64::INFINITY), |l, p| l.inf(&p.low));
        let high = parts.iter().fold(Vector3::repeat(f64::NEG_INFINITY), |h, p| h.sup(&p.high));
        // The capsule along the axis as wide as the widest part: it holds every section, and
        // the block turned any way.
        let capsule = (at(0.0), at(outline.height()), outline.widest());
        Self {
            pose: Pose::from_translation(vector(&piece.base)),
            shape: Convex::Parts(parts.into()),
            low,
            high,
            capsule,
        }
    }

    /// Its bounding box, m (lowest and highest corner).
    pub fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.low, self.high)
    }

    /// The distance between the two boxes, m: a lower bound of the solids'.
    fn box_gap(&self, other: &Placed) -> f64 {
        let gap = (self.low - other.high).sup(&(other.low - self.high)).sup(&Vector3::zeros());
        gap.norm()
    }

    /// The distance between the capsules that hold the two solids, m: a lower bound of the
    /// solids' distance (exact for spheres, and for cylinders side by side).
    fn capsule_gap(&self, other: &Placed) -> f64 {
        let ((p1, q1, r1), (p2, q2, r2)) = (&self.capsule, &other.capsule);
        (segment_distance(p1, q1, p2, q2) - r1 - r2).max(0.0)
    }

    /// The distance to `other`, m (0 when they touch or overlap): the least of their convex
    /// parts' ([`Placed::piece`]'s sections).
    pub fn distance(&self, other: &Placed) -> f64 {
        if matches!(self.shape, Convex::Parts(_)) || matches!(other.shape, Convex::Parts(_)) {
            return self.nearest_parts(other).0;
        }
        self.convex_distance(other)
    }

    /// The distance between two convex solids, m. Cylinders, balls and boxes: parry's
    /// dispatcher supports every pair of them, so an error is a bug; a pair with a hull or a
    /// frustum goes to parry's GJK on the two support maps directly.
    fn convex_distance(&self, other: &Placed) -> f64 {
        match (self.shape.shape(), other.shape.shape()) {
            (Some(a), Some(b)) => match query::distance(&self.pose, a, &other.pose, b) {
                Ok(d) => d.distance,
                Err(error) => unreachable!("parry has no distance between convex primitives: {error:?}"),
            },
            _ => match (self.shape.support(), other.shape.support()) {
                (Some(a), Some(b)) => {
                    query::details::distance_support_map_support_map(&self.pose.inv_mul(&other.pose), a, b)
                }
                _ => unreachable!("parts are measured one by one"),
            },
        }
    }
}

/// Which of the arm's parts are checked against which obstacles.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Rules {
    /// The table's height (the board's surface), m; `None`: no table check.
    pub table: Option<f64>,
    /// Parts not checked against the table (the pedestal stands on it; a held piece's base
    /// touches it at the grip and the release).
    pub off_table: Vec<Part>,
    /// Pairs of the arm's parts that are not checked against each other (besides parts of
    /// the same or neighbouring bodies): those that touch at rest by construction.
    pub touching: Vec<(Part, Part)>,
    /// Whether the arm's own solids are checked against each other at all.
    pub self_check: bool,
}

impl Rules {
    /// The rules for `model` with `hand`: the table at `table` m; a held piece off it (its base
    /// stands on the table at the grip and the release), and so are the parts that touch the
    /// table at `rest` (the pedestal and the base's housing stand on it), as are the pairs of
    /// non-neighbouring parts that already touch at `rest` off each other (as a setup
    /// assistant marks pairs "always in collision").
    pub fn for_arm<const N: usize>(
        model: &ArmModel<N>,
        hand: &Hand,
        bodies: &Bodies,
        rest: &JointVector<N>,
        table: f64,
    ) -> Self {
        let mut solids = Vec::new();
        solids_into(model, rest, hand, bodies, &mut solids);
        let placed: Vec<Placed> = solids.iter().map(|s| Placed::of(&s.solid)).collect();
        let mut touching = Vec::new();
        for i in 0..solids.len() {
            for k in i + 1..solids.len() {
                if apart(solids[i].part, solids[k].part, N) && placed[i].distance(&placed[k]) <= 0.0 {
                    touching.push((solids[i].part, solids[k].part));
                }
            }
        }
        let mut off_table = vec![Part::Held];
        off_table.extend(solids.iter().filter(|s| s.solid.lowest() <= table).map(|s| s.part));
        Self { table: Some(table), off_table, touching, self_check: true }
    }

    fn pair_checked(&self, a: Part, b: Part, n: usize) -> bool {
        self.self_check && apart(a, b, n) && !self.touching.iter().any(|&(x, y)| (x, y) == (a, b) || (x, y) == (b, a))
    }
}

/// Whether two parts move with bodies that are not the same or neighbours.
fn apart(a: Part, b: Part, n: usize) -> bool {
    a.body(n).abs_diff(b.body(n)) >= 2
}

/// The closest approaches at one instant (`None` without any): to still obstacles (pieces,
/// table), between the arm's own solids, and of the fingers to the pieces they are open
/// around (the one about to be gripped, the one just released: the gap the gripper's opening
/// leaves them, kept apart so that it does not hide the nearest other obstacle).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Nearest {
    pub still: Option<Closest>,
    pub itself: Option<Closest>,
    pub gripped: Option<Closest>,
}

impl Nearest {
    /// The nearer of the still obstacles and the arm itself.
    pub fn overall(&self) -> Option<Closest> {
        match (self.still, self.itself) {
            (Some(a), Some(b)) => Some(if b.distance < a.distance { b } else { a }),
            (a, b) => a.or(b),
        }
    }
}

fn better(best: &mut Option<Closest>, candidate: Closest) {
    if best.is_none_or(|b| candidate.distance < b.distance) {
        *best = Some(candidate);
    }
}

/// The closest approaches of `solids` (placed into `placed`, a buffer kept by the caller) to
/// `pieces` (already placed), the table and each other under `rules`; the fingers' distances
/// to the pieces of index `gripped` go to [`Nearest::gripped`]. Of the pairs of a solid and a
/// piece, only the `candidates` (solid index, piece index) are checked, or all. Exact distances are computed
/// only for pairs whose bounding boxes are nearer than the best so far.
pub fn nearest<const N: usize>(
    solids: &[ArmSolid],
    pieces: &[Placed],
    gripped: &[usize],
    candidates: Option<&[(usize, usize)]>,
    rules: &Rules,
    buffers: &mut NearestBuffers,
) -> Nearest {
    let NearestBuffers { placed, gaps } = buffers;
    placed.clear();
    placed.extend(solids.iter().map(|s| Placed::of(&s.solid)));
    let mut still: Option<Closest> = None;
    if let Some(table) = rules.table {
        for solid in solids.iter().filter(|s| !rules.off_table.contains(&s.part)) {
            better(
                &mut still,
                Closest {
                    distance: (solid.solid.lowest() - table).max(0.0),
                    part: solid.part,
                    obstacle: Obstacle::Table,
                },
            );
        }
    }
    // Every pair's lower bound first (its boxes' and its capsules' gaps); then the exact
    // distance of the pair with the smallest bound of each kind, and of the others only where
    // their bound is below the best.
    gaps.clear();
    let mut piece_pair = |i: usize, k: usize| {
        // The fingers and the jaws open around the pieces of `gripped`: their gap to them is the
        // gripper's opening, kept apart.
        let grips = matches!(solids[i].part, Part::Finger(_) | Part::Jaw(_));
        let kind = if grips && gripped.contains(&k) { GRIPPED } else { STILL };
        gaps.push((placed[i].box_gap(&pieces[k]), kind, i, k));
    };
    match candidates {
        Some(pairs) => pairs.iter().for_each(|&(i, k)| piece_pair(i, k)),
        None => (0..solids.len()).for_each(|i| (0..pieces.len()).for_each(|k| piece_pair(i, k))),
    }
    for i in 0..solids.len() {
        for k in i + 1..solids.len() {
            if rules.pair_checked(solids[i].part, solids[k].part, N) {
                gaps.push((placed[i].box_gap(&placed[k]), ITSELF, i, k));
            }
        }
    }
    let mut found: [Option<Closest>; 3] = [still, None, None];
    let exact = |&(_, kind, i, k): &(f64, u8, usize, usize)| {
        if kind == ITSELF {
            Closest {
                distance: placed[i].distance(&placed[k]),
                part: solids[i].part,
                obstacle: Obstacle::Arm(solids[k].part),
            }
        } else {
            Closest { distance: placed[i].distance(&pieces[k]), part: solids[i].part, obstacle: Obstacle::Piece(k) }
        }
    };
    let other = |&(_, kind, _, k): &(f64, u8, usize, usize)| if kind == ITSELF { &placed[k] } else { &pieces[k] };
    for kind in [STILL, GRIPPED, ITSELF] {
        let least = gaps.iter().filter(|g| g.1 == kind).min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some(pair) = least
            && found[kind as usize].is_none_or(|b| pair.0 < b.distance)
        {
            better(&mut found[kind as usize], exact(pair));
        }
        for pair in gaps.iter().filter(|g| g.1 == kind) {
            // The boxes' gap, then the capsules', then GJK: each only if the last did not rule
            // the pair out. The arm's own pairs are measured exactly only where they may be
            // nearer than the still obstacles (the nearest reported): elsewhere their lower
            // bound stands in, which only shortens the sweep's steps.
            let best = found[kind as usize];
            let still = if kind == ITSELF { found[STILL as usize] } else { None };
            let bound = |b: f64| pair.0 < b && placed[pair.2].capsule_gap(other(pair)) < b;
            if best.is_none_or(|b| bound(b.distance)) {
                if still.is_some_and(|s| !bound(s.distance)) {
                    let distance = placed[pair.2].capsule_gap(other(pair)).max(pair.0);
                    better(
                        &mut found[kind as usize],
                        Closest { distance, part: solids[pair.2].part, obstacle: Obstacle::Arm(solids[pair.3].part) },
                    );
                } else {
                    better(&mut found[kind as usize], exact(pair));
                }
            }
        }
    }
    Nearest { still: found[STILL as usize], itself: found[ITSELF as usize], gripped: found[GRIPPED as usize] }
}

const STILL: u8 = 0;
const GRIPPED: u8 = 1;
const ITSELF: u8 = 2;

/// Where `closest` (found with the arm at `q` with `hand` and `bodies`) is: its point on the
/// arm and on the obstacle (base frame, m), the obstacle being `piece` (placed) when a piece,
/// the table at `rules.table`, or the arm's own part. The nearest of the part's solids is
/// taken (a described link may have several).
#[allow(clippy::too_many_arguments)]
pub fn witness_points<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    hand: &Hand,
    bodies: &Bodies,
    closest: &Closest,
    piece: Option<&Placed>,
    rules: &Rules,
) -> Option<[Vector3<f64>; 2]> {
    let mut solids = Vec::new();
    solids_into(model, q, hand, bodies, &mut solids);
    let placed: Vec<(Part, Placed)> = solids.iter().map(|s| (s.part, Placed::of(&s.solid))).collect();
    let ours = || placed.iter().filter(|(part, _)| *part == closest.part).map(|(_, p)| p);
    let nearest = |pairs: Vec<(&Placed, &Placed)>| {
        pairs
            .into_iter()
            .min_by(|x, y| x.0.distance(x.1).total_cmp(&y.0.distance(y.1)))
            .map(|(a, b)| a.closest_points(b))
    };
    match closest.obstacle {
        Obstacle::Piece(_) => {
            let piece = piece?;
            nearest(ours().map(|a| (a, piece)).collect())
        }
        Obstacle::Table => {
            let table = rules.table?;
            let low = ours().map(Placed::lowest_point).min_by(|a, b| a.z.total_cmp(&b.z))?;
            Some([low, Vector3::new(low.x, low.y, table)])
        }
        Obstacle::Arm(other) => {
            let theirs: Vec<&Placed> = placed.iter().filter(|(part, _)| *part == other).map(|(_, p)| p).collect();
            nearest(ours().flat_map(|a| theirs.iter().map(move |b| (a, *b))).collect())
        }
    }
}

/// Buffers of [`nearest`], kept between calls: the arm's solids as parry sees them and every
/// pair's bounding-box gap.
#[derive(Debug, Default)]
pub struct NearestBuffers {
    placed: Vec<Placed>,
    gaps: Vec<(f64, u8, usize, usize)>,
}

/// Per joint `j`, the farthest any point of the arm's solids can be from joint `j`'s axis at
/// any angles, m: the lengths of the chain from `p_j` to the tip (the distances between
/// consecutive frame origins, the same at every pose) plus the farthest any solid reaches
/// beyond the frame origin it hangs from (measured at the zero pose: the fingers' and a held
/// piece's reach from the tip, a housing's half-diagonal, a drawn link's radius, a described
/// shape's farthest point from its body's frame origin).
pub fn reach_bound<const N: usize>(model: &ArmModel<N>, hand: &Hand, bodies: &Bodies) -> [f64; N] {
    let zero = JointVector::<N>::zeros();
    let chain = FrameChain::new(model, &zero);
    let origins: Vec<Vector3<f64>> =
        (0..=N).map(|i| if i == 0 { model.base() } else { chain.body_pose(i - 1).translation.vector }).collect();
    let mut solids = Vec::new();
    solids_into(model, &zero, hand, bodies, &mut solids);
    let tip = chain.tip();
    let extent = solids
        .iter()
        .map(|s| match s.part {
            Part::Finger(_) | Part::Held => s.solid.farthest_from(&tip),
            Part::Housing(j) => s.solid.farthest_from(&chain.joint_axis(j - 1).1),
            Part::Jaw(_) => s.solid.farthest_from(&origins[N]),
            Part::Link(k) => match bodies {
                Bodies::Drawn => chessarm_core::arm::bodies::LINK_RADIUS,
                Bodies::Described(_) => s.solid.farthest_from(&origins[k]),
            },
            // The pedestal does not move.
            Part::Pedestal => 0.0,
        })
        .fold(0.0, f64::max);
    std::array::from_fn(|j| (j..N).map(|i| (origins[i + 1] - origins[i]).norm()).sum::<f64>() + extent)
}

/// What a sweep found: the closest approach and when (s), the fingers' closest approach to
/// the pieces they are open around, the number of checks, and the resolution (m): a contact
/// shorter than the smallest step shows as at most this distance.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Swept {
    pub closest: Option<(f64, Closest)>,
    pub gripped: Option<(f64, Closest)>,
    pub checks: usize,
    pub resolution: f64,
}

/// A motion to sweep: joint angles `q(t)` (rad) for `t ∈ [start, end]` (s), a bound of each
/// joint's `|q̇|` over it (rad/s), the hand, constant over it, and the indices of the pieces
/// the fingers are open around.
pub struct Stretch<'a, const N: usize> {
    pub q: &'a dyn Fn(f64) -> JointVector<N>,
    pub start: f64,
    pub end: f64,
    pub rate_bound: [f64; N],
    pub hand: Hand,
    /// What the arm's pedestal, housings and links are made of.
    pub bodies: &'a Bodies,
    pub gripped: &'a [usize],
    /// Every piece left out of the list swept is at least this far from the arm over the
    /// whole motion, m (infinite when none is left out).
    pub beyond: f64,
    /// Whether the instant `end` is left to the motion that follows (checked there).
    pub open_end: bool,
    /// The pairs of a solid (its index in [`solids_into`]'s list) and a piece to check
    /// (`None`: all); the others stay at least `beyond` apart over the motion.
    pub candidates: Option<&'a [(usize, usize)]>,
}

impl<const N: usize> std::fmt::Debug for Stretch<'_, N> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stretch")
            .field("start", &self.start)
            .field("end", &self.end)
            .field("rate_bound", &self.rate_bound)
            .field("hand", &self.hand)
            .finish_non_exhaustive()
    }
}

/// Reused buffers of a sweep (no allocation after the first motions).
#[derive(Debug, Default)]
pub struct Scratch {
    solids: Vec<ArmSolid>,
    buffers: NearestBuffers,
    /// The pairs of a solid and a piece that may come near over a stretch of motion.
    pub pairs: Vec<(usize, usize)>,
}

/// The pairs (solid index, piece index) whose boxes come within `reach` m of each other,
/// the arm's solids taken at `q` with `hand`, into `out`.
#[allow(clippy::too_many_arguments)]
pub fn near_pairs<const N: usize>(
    model: &ArmModel<N>,
    q: &JointVector<N>,
    hand: &Hand,
    bodies: &Bodies,
    pieces: &[Placed],
    reach: f64,
    scratch: &mut Scratch,
    out: &mut Vec<(usize, usize)>,
) {
    out.clear();
    solids_into(model, q, hand, bodies, &mut scratch.solids);
    for (i, solid) in scratch.solids.iter().enumerate() {
        let shape = Placed::of(&solid.solid);
        for (k, piece) in pieces.iter().enumerate() {
            if shape.box_gap(piece) < reach {
                out.push((i, k));
            }
        }
    }
}

/// The closest approach over a motion, checked by conservative advancement (see the module's
/// documentation) against `pieces` (placed), the table and the arm itself under `rules`.
/// `reach` is [`reach_bound`]'s; a step is never shorter than `min_step` (s, > 0; a
/// non-positive one is replaced by a millionth of the motion) nor longer than the rest of it.
pub fn sweep<const N: usize>(
    model: &ArmModel<N>,
    stretch: &Stretch<'_, N>,
    reach: &[f64; N],
    pieces: &[Placed],
    rules: &Rules,
    min_step: f64,
    scratch: &mut Scratch,
) -> Swept {
    let (start, end) = (stretch.start, stretch.end);
    let speed: f64 = stretch.rate_bound.iter().zip(reach).map(|(w, r)| w.abs() * r).sum();
    // A zero step would never advance past a contact.
    let min_step = if min_step > 0.0 { min_step } else { 1e-6 * (end - start).abs().max(1e-9) };
    let mut swept = Swept { resolution: speed * min_step, ..Swept::default() };
    let mut t = start;
    loop {
        solids_into(model, &(stretch.q)(t), &stretch.hand, stretch.bodies, &mut scratch.solids);
        swept.checks += 1;
        let now =
            nearest::<N>(&scratch.solids, pieces, stretch.gripped, stretch.candidates, rules, &mut scratch.buffers);
        if let Some(overall) = now.overall()
            && swept.closest.is_none_or(|(_, b)| overall.distance < b.distance)
        {
            swept.closest = Some((t, overall));
        }
        if let Some(gripped) = now.gripped
            && swept.gripped.is_none_or(|(_, b)| gripped.distance < b.distance)
        {
            swept.gripped = Some((t, gripped));
        }
        if t >= end || (now.overall().is_none() && now.gripped.is_none()) {
            return swept;
        }
        let distance = |c: Option<Closest>| c.map_or(f64::INFINITY, |c| c.distance);
        let nearest =
            distance(now.still).min(distance(now.gripped)).min(0.5 * distance(now.itself)).min(stretch.beyond);
        let step = if speed > 0.0 { nearest / speed } else { end - t };
        let next = t + step.max(min_step);
        if next >= end && stretch.open_end {
            return swept;
        }
        t = next.min(end);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use chessarm_core::arm::bodies::Gripper;
    use chessarm_core::arm::preset::report_arm;

    fn pawn_at(x: f64, y: f64) -> StandingPiece {
        StandingPiece::cylinder(Vector3::new(x, y, 0.0), 0.012, 0.04)
    }

    /// The distance between one solid of the arm and a standing piece, m (0 when they touch).
    fn solid_to_piece(solid: &Solid, piece: &StandingPiece) -> f64 {
        Placed::of(solid).distance(&Placed::piece(piece))
    }

    fn open_hand() -> Hand {
        Hand { gripper: Gripper::default(), gap: 0.04, held: None }
    }

    /// A sphere beside an upright cylinder: the distance from its centre to the axis less both
    /// radii; above it: the height over the top less the sphere's radius.
    #[test]
    fn sphere_to_piece_is_the_closed_form() {
        let piece = pawn_at(0.2, 0.1);
        let side = Solid::Sphere { centre: Vector3::new(0.2 + 0.05, 0.1, 0.02), radius: 0.008 };
        assert!((solid_to_piece(&side, &piece) - (0.05 - 0.012 - 0.008)).abs() < 1e-9);
        let above = Solid::Sphere { centre: Vector3::new(0.2, 0.1, 0.07), radius: 0.008 };
        assert!((solid_to_piece(&above, &piece) - (0.07 - 0.04 - 0.008)).abs() < 1e-9);
        let inside = Solid::Sphere { centre: Vector3::new(0.2, 0.1, 0.02), radius: 0.008 };
        assert_eq!(solid_to_piece(&inside, &piece), 0.0);
    }

    /// Segment distances in known configurations: crossing skew segments (their offset),
    /// parallel ones side by side, end to end along a line, and a point beside a segment; and
    /// the capsule bound never exceeds GJK's distance of the cylinders it holds.
    #[test]
    fn segment_distances_are_the_closed_forms() {
        let v = Vector3::new;
        let zero = Vector3::zeros();
        assert!(
            (segment_distance(&v(-1.0, 0.0, 0.0), &v(1.0, 0.0, 0.0), &v(0.0, -1.0, 0.3), &v(0.0, 1.0, 0.3)) - 0.3)
                .abs()
                < 1e-15
        );
        assert!((segment_distance(&zero, &v(1.0, 0.0, 0.0), &v(0.2, 0.5, 0.0), &v(0.7, 0.5, 0.0)) - 0.5).abs() < 1e-15);
        assert!((segment_distance(&zero, &v(1.0, 0.0, 0.0), &v(1.5, 0.0, 0.0), &v(2.0, 0.0, 0.0)) - 0.5).abs() < 1e-15);
        let point = v(0.5, 0.4, 0.3);
        assert!((segment_distance(&zero, &v(1.0, 0.0, 0.0), &point, &point) - 0.5).abs() < 1e-15);
        let link = Placed::of(&Solid::Cylinder { a: v(-0.1, 0.0, 0.1), b: v(0.1, 0.02, 0.06), radius: 0.015 });
        for x in [-0.08, -0.02, 0.0, 0.03, 0.09] {
            let piece = Placed::piece(&pawn_at(x, 0.03));
            assert!(link.capsule_gap(&piece) <= link.distance(&piece) + 1e-12);
            assert!(link.box_gap(&piece) <= link.distance(&piece) + 1e-12);
        }
    }

    /// A horizontal cylinder crossing above a piece: its underside's height above the top.
    #[test]
    fn a_link_over_a_piece_clears_it_by_its_underside() {
        let piece = pawn_at(0.0, 0.0);
        let link = Solid::Cylinder { a: Vector3::new(-0.1, 0.0, 0.1), b: Vector3::new(0.1, 0.0, 0.1), radius: 0.015 };
        assert!((solid_to_piece(&link, &piece) - (0.1 - 0.015 - 0.04)).abs() < 1e-9);
    }

    /// Two boxes in known poses: face to face, the gap between the faces; a cube turned 45°
    /// about z beside an upright one, its edge's distance `d − h√2 − h`.
    #[test]
    fn box_to_box_is_the_closed_form() {
        use chessarm_core::nalgebra::{Matrix3, Rotation3};
        let half = Vector3::repeat(0.01);
        let cube =
            |x: f64, axes: Matrix3<f64>| Placed::of(&Solid::Cuboid { centre: Vector3::new(x, 0.0, 0.0), axes, half });
        let upright = cube(0.0, Matrix3::identity());
        assert!((upright.distance(&cube(0.05, Matrix3::identity())) - 0.03).abs() < 1e-9);
        let turned = *Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_4).matrix();
        let expected = 0.05 - 0.01 * 2f64.sqrt() - 0.01;
        assert!((upright.distance(&cube(0.05, turned)) - expected).abs() < 1e-9);
        // The bounding boxes' gap is a lower bound.
        assert!(upright.box_gap(&cube(0.05, turned)) <= expected + 1e-12);
    }

    /// A tilted cylinder above the table: its lowest point's height equals parry's distance to
    /// the half-space below the table (the plane's closed form checked by the library).
    #[test]
    fn the_table_distance_is_parrys_half_space_distance() {
        use parry3d_f64::shape::HalfSpace;
        let table = 0.02;
        let link = Solid::Cylinder { a: Vector3::new(0.1, 0.0, 0.09), b: Vector3::new(0.2, 0.05, 0.15), radius: 0.015 };
        let plane = HalfSpace::new(Vector::Z);
        let placed = Placed::of(&link);
        let parry = query::distance(
            &placed.pose,
            placed.shape.shape().expect("a cylinder is parry's"),
            &Pose::from_translation(Vector::new(0.0, 0.0, table)),
            &plane,
        )
        .unwrap()
        .distance;
        assert!((link.lowest() - table - parry).abs() < 1e-9, "{} vs {parry}", link.lowest() - table);
    }

    /// A jaw of the file's gripper beside the piece it grips is kept apart from it as a finger
    /// is (its gap goes to the gripper's, not to the obstacles), and is an obstacle to every
    /// other piece and checked against the table; a link's shape in the same place is an
    /// obstacle to the gripped piece too. Boxes beside upright cylinders: gaps in closed form.
    #[test]
    fn a_jaw_is_kept_apart_from_the_piece_it_grips_and_is_an_obstacle_to_the_others() {
        use chessarm_core::nalgebra::Matrix3;
        let half = Vector3::new(0.001, 0.003, 0.01);
        // A jaw 0.8 mm beside a pawn at the origin (radius 12 mm), a pawn at y = 0.04 beyond.
        let slab = |part: Part, z: f64| ArmSolid {
            part,
            solid: Solid::Cuboid {
                centre: Vector3::new(0.012 + 0.0008 + 0.001, 0.0, z),
                axes: Matrix3::identity(),
                half,
            },
        };
        let pieces = [Placed::piece(&pawn_at(0.0, 0.0)), Placed::piece(&pawn_at(0.0, 0.04))];
        let rules = Rules { table: Some(0.0), ..Rules::default() };
        let mut buffers = NearestBuffers::default();
        // Its lower end 3 mm above the table.
        let jaw = [slab(Part::Jaw(1), 0.013)];
        let near = nearest::<4>(&jaw, &pieces, &[0], None, &rules, &mut buffers);
        let gripped = near.gripped.expect("the gap to the gripped pawn");
        assert_eq!((gripped.part, gripped.obstacle), (Part::Jaw(1), Obstacle::Piece(0)));
        assert!((gripped.distance - 0.0008).abs() < 1e-9, "{gripped:?}");
        let still = near.still.expect("the table and the other pawn");
        assert_eq!(still.obstacle, Obstacle::Table, "{still:?}");
        assert!((still.distance - 0.003).abs() < 1e-9, "{still:?}");
        // Raised 35 mm off the table: the other pawn, from the box's edge at (12.8, 3) mm.
        let raised = [slab(Part::Jaw(1), 0.045)];
        let near = nearest::<4>(&raised, &pieces, &[0], None, &rules, &mut buffers);
        let still = near.still.expect("the other pawn");
        assert_eq!(still.obstacle, Obstacle::Piece(1), "{still:?}");
        assert!((still.distance - (0.0128f64.hypot(0.037) - 0.012)).abs() < 1e-9, "{still:?}");
        // Not gripping anything, the pawn beside it is an obstacle like any other.
        let near = nearest::<4>(&jaw, &pieces, &[], None, &rules, &mut buffers);
        assert!(near.gripped.is_none());
        let still = near.still.unwrap();
        assert_eq!(still.obstacle, Obstacle::Piece(0), "{still:?}");
        assert!((still.distance - 0.0008).abs() < 1e-9, "{still:?}");
        // A link's shape where the jaw was is an obstacle to the pawn being gripped.
        let link = [slab(Part::Link(4), 0.013)];
        let near = nearest::<4>(&link, &pieces, &[0], None, &rules, &mut buffers);
        assert!(near.gripped.is_none());
        assert_eq!(near.still.unwrap().obstacle, Obstacle::Piece(0));
    }

    /// A contact between two samples of a fixed grid: the base yaw sweeps the fingers across
    /// a thin piece that reaches 1 mm above finger 2's lower end only around t = 0.525 s,
    /// midway between the grid's samples at 0.5 and 0.55 s (θ̇ = 1 rad/s; finger 1 passes
    /// the piece ≈ 0.13 s earlier, before the motion starts). The grid sees a clear gap;
    /// conservative advancement finds the contact (a distance of 0).
    #[test]
    fn a_contact_between_two_samples_is_found() {
        let arm = report_arm();
        let hand = open_hand();
        let q = |t: f64| JointVector::<4>::new(-0.5 + t, 0.6, -1.2, -0.9);
        let mut solids = Vec::new();
        solids_into(&arm, &q(0.525), &hand, &Bodies::Drawn, &mut solids);
        let finger = solids.iter().find(|s| s.part == Part::Finger(2)).unwrap().solid.clone();
        let Solid::Cuboid { centre, .. } = &finger else { panic!() };
        let low = finger.lowest();
        let piece = StandingPiece::cylinder(Vector3::new(centre.x, centre.y, 0.0), 0.002, low + 0.001);
        let pieces = [Placed::piece(&piece)];
        let rules = Rules::default();
        let mut placed = NearestBuffers::default();
        let (start, end) = (0.45, 0.6);
        let grid = (0..=3)
            .map(|k| {
                solids_into(&arm, &q(start + 0.05 * k as f64), &hand, &Bodies::Drawn, &mut solids);
                nearest::<4>(&solids, &pieces, &[], None, &rules, &mut placed)
                    .overall()
                    .map_or(f64::INFINITY, |c| c.distance)
            })
            .fold(f64::INFINITY, f64::min);
        assert!(grid > 1e-3, "the grid must miss it: {grid}");
        let reach = reach_bound(&arm, &hand, &Bodies::Drawn);
        let stretch = Stretch {
            q: &q,
            start,
            end,
            rate_bound: [1.0, 0.0, 0.0, 0.0],
            hand,
            bodies: &Bodies::Drawn,
            gripped: &[],
            beyond: f64::INFINITY,
            open_end: false,
            candidates: None,
        };
        let min_step = 1e-4;
        let swept = sweep(&arm, &stretch, &reach, &pieces, &rules, min_step, &mut Scratch::default());
        let (when, closest) = swept.closest.unwrap();
        // The contact lasts ≈ 25 ms, far longer than the smallest step: the sweep lands in it.
        assert!(swept.resolution < 1e-4);
        assert_eq!(closest.distance, 0.0, "{closest:?} at {when}");
        assert!((when - 0.525).abs() < 0.015, "at {when}");
        assert_eq!(closest.part, Part::Finger(2));
        // Far fewer checks than a grid fine enough to see a 1 mm dip.
        assert!(swept.checks < 2000, "{}", swept.checks);
    }

    /// A box as the hull of its corners (plus points inside, which the hull drops) is the box:
    /// GJK on its points gives parry's box distance to pieces about it, 1e-9 m (GJK's own
    /// tolerance on polytopes; the box pair is exact), and the same lowest point; points in a
    /// plane have no hull.
    #[test]
    fn a_hull_of_a_box_s_corners_is_the_box() {
        use chessarm_core::arm::bodies::{Shape, place};
        use chessarm_core::arm::kinematics::Pose;
        use chessarm_core::nalgebra::{Rotation3, Translation3};
        let half = Vector3::new(0.04, 0.015, 0.01);
        let mut points: Vec<Vector3<f64>> = (0..8)
            .map(|i| {
                Vector3::new(half.x, half.y, half.z).component_mul(&Vector3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                ))
            })
            .collect();
        points.extend([Vector3::zeros(), Vector3::new(0.01, 0.0, 0.002)]);
        let hull = hull_of(&points).unwrap();
        assert_eq!(hull.len(), 8);
        let hull = Shape::Hull { points: hull.into() };
        let cuboid = Shape::Cuboid { half };
        let mut rng = chessarm_core::sense::rng::SeededRng::new(3);
        for _ in 0..200 {
            let turn =
                Rotation3::from_euler_angles(rng.uniform(-3.0, 3.0), rng.uniform(-1.5, 1.5), rng.uniform(-3.0, 3.0));
            let pose = Pose::from_parts(Translation3::new(0.0, 0.0, 0.08), turn);
            let piece = Placed::piece(&pawn_at(rng.uniform(-0.07, 0.07), rng.uniform(-0.07, 0.07)));
            let (a, b) = (place(&hull, &pose), place(&cuboid, &pose));
            let (d_hull, d_box) = (Placed::of(&a).distance(&piece), Placed::of(&b).distance(&piece));
            assert!((d_hull - d_box).abs() < 1e-9, "{d_hull} vs {d_box}");
            assert!((a.lowest() - b.lowest()).abs() < 1e-12);
            // The bounds stay below the distance.
            assert!(Placed::of(&a).box_gap(&piece) <= d_hull + 1e-12);
            assert!(Placed::of(&a).capsule_gap(&piece) <= d_hull + 1e-12);
        }
        let flat: Vec<Vector3<f64>> = (0..6).map(|i| Vector3::new(i as f64, (i * i) as f64, 0.0)).collect();
        assert!(hull_of(&flat).is_err());
    }

    /// The reach bound holds at sampled poses: no solid is farther from joint j's axis.
    #[test]
    fn the_reach_bound_holds_at_any_angles() {
        use chessarm_core::arm::bodies::{BodyShape, Mount, Shape};
        use chessarm_core::arm::kinematics::Pose;
        use chessarm_core::nalgebra::{Rotation3, Translation3};
        let arm = report_arm();
        let hand = Hand {
            held: Some(chessarm_core::arm::bodies::Held {
                outline: Outline::cylinder(0.02, 0.095),
                grip_height: 0.076,
                turn: 0.0,
            }),
            ..open_hand()
        };
        // Described bodies: a box and a hull on every link, off its frame's origin and turned.
        let corners: Arc<[Vector3<f64>]> = (0..8)
            .map(|i| Vector3::new((i & 1) as f64 * 0.05, ((i >> 1) & 1) as f64 * 0.02, ((i >> 2) & 1) as f64 * 0.03))
            .collect();
        let shapes: Vec<BodyShape> = (0..=4)
            .flat_map(|body| {
                let pose = Pose::from_parts(
                    Translation3::new(0.03, -0.02 * body as f64, 0.01),
                    Rotation3::from_euler_angles(0.3, 0.1 * body as f64, -0.5),
                );
                [
                    BodyShape {
                        body,
                        pose,
                        shape: Shape::Cuboid { half: Vector3::new(0.02, 0.01, 0.04) },
                        mount: if body == 4 { Mount::Jaw } else { Mount::Fixed },
                    },
                    BodyShape {
                        body,
                        pose: pose.inverse(),
                        shape: Shape::Hull { points: Arc::clone(&corners) },
                        mount: Mount::Fixed,
                    },
                ]
            })
            .collect();
        for bodies in [Bodies::Drawn, Bodies::Described(shapes.into())] {
            let reach = reach_bound(&arm, &hand, &bodies);
            let mut solids = Vec::new();
            let mut rng = chessarm_core::sense::rng::SeededRng::new(7);
            let pi = std::f64::consts::PI;
            for _ in 0..500 {
                let q = JointVector::<4>::from_fn(|_, _| rng.uniform(-pi, pi));
                solids_into(&arm, &q, &hand, &bodies, &mut solids);
                let chain = FrameChain::new(&arm, &q);
                for (j, bound) in reach.iter().enumerate() {
                    let point = chain.joint_axis(j).1;
                    // The solids joint j turns: those of the links after it.
                    for s in solids.iter().filter(|s| s.part.body(4) > j) {
                        let far = s.solid.farthest_from(&point);
                        assert!(far <= *bound + 1e-12, "joint {} part {} {far} > {}", j + 1, s.part, *bound);
                    }
                }
            }
        }
    }
}
