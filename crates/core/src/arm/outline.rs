//! A piece's outline: a solid of revolution about an upright axis, given as rings (height
//! above the base, radius) from the base up, each pair of neighbouring rings bounding a
//! frustum, and an optional block on top (a chess knight's head). Fixed-size, so that a hand
//! holding a piece stays a plain value.

use nalgebra::{Matrix3, Vector3};

/// The most rings an outline has.
pub const OUTLINE_RINGS: usize = 16;

/// A box standing on the top ring, centred on the axis: a knight's head. Its length runs along
/// the way the piece faces, its width across it, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    /// Height of its top above the piece's base, m.
    pub top: f64,
    /// Half its length (along the way it faces), m.
    pub half_length: f64,
    /// Half its width, m.
    pub half_width: f64,
}

/// Why rings do not make an outline.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OutlineError {
    #[error("an outline needs 2 to {OUTLINE_RINGS} rings, not {0}")]
    Rings(usize),
    #[error("ring {index}: ({z}, {radius}) is not finite, or its radius is negative")]
    Value { index: usize, z: f64, radius: f64 },
    #[error("ring {index} at {z} lies below the ring before it: rings go from the base up")]
    Order { index: usize, z: f64 },
    #[error("the first ring is at {0}, not at the base (0)")]
    Base(f64),
    #[error("the outline has no height")]
    Flat,
    #[error("the outline holds no volume (every radius 0 and no block)")]
    Empty,
    #[error("the block's top {top} is not above the last ring ({last}), or a half size is not > 0")]
    Block { top: f64, last: f64 },
}

/// A solid of revolution (rings of `[height above the base, radius]`, m) with an optional
/// [`Block`] on top.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outline {
    rings: [[f64; 2]; OUTLINE_RINGS],
    len: usize,
    block: Option<Block>,
}

impl Outline {
    /// The outline of `rings` (`[z, r]`, m: the first at `z = 0`, heights never falling, radii
    /// ≥ 0; two rings at one height are a step) and `block` on top.
    pub fn new(rings: &[[f64; 2]], block: Option<Block>) -> Result<Self, OutlineError> {
        if !(2..=OUTLINE_RINGS).contains(&rings.len()) {
            return Err(OutlineError::Rings(rings.len()));
        }
        for (index, &[z, radius]) in rings.iter().enumerate() {
            if !(z.is_finite() && radius.is_finite() && radius >= 0.0) {
                return Err(OutlineError::Value { index, z, radius });
            }
            if index > 0 && z < rings[index - 1][0] {
                return Err(OutlineError::Order { index, z });
            }
        }
        if rings[0][0] != 0.0 {
            return Err(OutlineError::Base(rings[0][0]));
        }
        let last = rings[rings.len() - 1][0];
        if let Some(b) = block
            && !(b.top.is_finite()
                && b.top > last
                && b.half_length.is_finite()
                && b.half_length > 0.0
                && b.half_width.is_finite()
                && b.half_width > 0.0)
        {
            return Err(OutlineError::Block { top: b.top, last });
        }
        if last <= 0.0 && block.is_none() {
            return Err(OutlineError::Flat);
        }
        let mut all = [[0.0; 2]; OUTLINE_RINGS];
        all[..rings.len()].copy_from_slice(rings);
        let outline = Self { rings: all, len: rings.len(), block };
        // A solid of no volume has no density, so no payload (the rings are finite, so is it).
        if outline.volume() <= 0.0 {
            return Err(OutlineError::Empty);
        }
        Ok(outline)
    }

    /// An upright cylinder of `radius` and `height`, m.
    pub fn cylinder(radius: f64, height: f64) -> Self {
        let mut rings = [[0.0; 2]; OUTLINE_RINGS];
        rings[0] = [0.0, radius];
        rings[1] = [height, radius];
        Self { rings, len: 2, block: None }
    }

    /// `[radius, height]` when the outline is one upright cylinder (two rings of one radius,
    /// no block).
    pub fn as_cylinder(&self) -> Option<[f64; 2]> {
        let ([z0, r0], [z1, r1]) = (self.rings[0], self.rings[1]);
        (self.len == 2 && self.block.is_none() && z0 == 0.0 && r0 == r1).then_some([r0, z1])
    }

    /// The rings, `[z, r]`, m.
    pub fn rings(&self) -> &[[f64; 2]] {
        &self.rings[..self.len]
    }

    /// The block on top, if any.
    pub fn block(&self) -> Option<Block> {
        self.block
    }

    /// The same outline with heights × `kz` and radii (and the block's half sizes) × `kr`.
    pub fn scaled(&self, kz: f64, kr: f64) -> Self {
        let mut out = *self;
        for ring in &mut out.rings[..out.len] {
            *ring = [ring[0] * kz, ring[1] * kr];
        }
        out.block = self.block.map(|b| Block {
            top: b.top * kz,
            half_length: b.half_length * kr,
            half_width: b.half_width * kr,
        });
        out
    }

    /// Height of its top above its base, m.
    pub fn height(&self) -> f64 {
        self.block.map_or(self.rings[self.len - 1][0], |b| b.top)
    }

    /// The largest radius anywhere: of the rings, and half the block's diagonal (the room the
    /// block takes turned any way about the axis), m.
    pub fn widest(&self) -> f64 {
        self.widest_above(f64::NEG_INFINITY)
    }

    /// The block's radius about the axis, turned any way: half its diagonal, m (0 without one).
    pub fn block_radius(&self) -> f64 {
        self.block.map_or(0.0, |b| b.half_length.hypot(b.half_width))
    }

    /// The radius at height `z` (the larger at a step; 0 outside the rings), m.
    pub fn radius_at(&self, z: f64) -> f64 {
        let mut best: f64 = 0.0;
        for pair in self.rings().windows(2) {
            let ([z0, r0], [z1, r1]) = (pair[0], pair[1]);
            if z >= z0 && z <= z1 {
                let r = if z1 > z0 { r0 + (r1 - r0) * (z - z0) / (z1 - z0) } else { r0.max(r1) };
                best = best.max(r);
            }
        }
        best
    }

    /// The largest radius at or above height `z`, m: what fingers coming down from above must
    /// open around to reach down to `z` (the block turned any way).
    pub fn widest_above(&self, z: f64) -> f64 {
        self.widest_between(z, f64::INFINITY)
    }

    /// The largest radius between heights `low` and `high`, m (the block turned any way).
    pub fn widest_between(&self, low: f64, high: f64) -> f64 {
        let mut best = self.radius_at(low).max(self.radius_at(high));
        for &[z, r] in self.rings() {
            if z >= low && z <= high {
                best = best.max(r);
            }
        }
        let base = self.rings[self.len - 1][0];
        if self.block.is_some_and(|b| b.top >= low && base <= high) {
            best = best.max(self.block_radius());
        }
        best
    }

    /// The sections between neighbouring rings of some height: `(z0, r0, z1, r1)`, m.
    pub fn sections(&self) -> impl Iterator<Item = (f64, f64, f64, f64)> + '_ {
        self.rings().windows(2).filter(|p| p[1][0] > p[0][0]).map(|p| (p[0][0], p[0][1], p[1][0], p[1][1]))
    }

    /// Volume, m³: `Σ π h (r0² + r0 r1 + r1²) / 3` over the frustums, plus the block's.
    pub fn volume(&self) -> f64 {
        let frustums: f64 = self
            .sections()
            .map(|(z0, r0, z1, r1)| std::f64::consts::PI * (z1 - z0) * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0)
            .sum();
        frustums + self.block_volume()
    }

    fn block_volume(&self) -> f64 {
        let base = self.rings[self.len - 1][0];
        self.block.map_or(0.0, |b| 4.0 * b.half_length * b.half_width * (b.top - base))
    }

    /// Mass properties of the solid of uniform density and `mass` kg about its base's centre,
    /// axis up (z): centre of mass height (m) and the inertia about the centre of mass, axial
    /// and transverse (kg·m²). Each frustum's moments `∫ π r² z^k dz` and `∫ π r⁴/4 dz` are
    /// integrands of degree ≤ 4 in `z`, so three-point Gauss–Legendre is exact. The block is
    /// a box; its two transverse moments are averaged (it turns with the piece about the axis).
    pub fn mass_properties(&self, mass: f64) -> (f64, f64, f64) {
        const NODES: [(f64, f64); 3] =
            [(-0.774_596_669_241_483_4, 5.0 / 9.0), (0.0, 8.0 / 9.0), (0.774_596_669_241_483_4, 5.0 / 9.0)];
        let pi = std::f64::consts::PI;
        // Volume, its first and second moments in z, and Σ ∫ π r⁴/4 dz (the disc's moment
        // about a diameter, per unit density; twice it is the axial moment).
        let (mut v, mut vz, mut vzz, mut disc) = (0.0, 0.0, 0.0, 0.0);
        for (z0, r0, z1, r1) in self.sections() {
            let (mid, half) = (0.5 * (z0 + z1), 0.5 * (z1 - z0));
            for (x, w) in NODES {
                let z = mid + half * x;
                let r = r0 + (r1 - r0) * (z - z0) / (z1 - z0);
                let area = pi * r * r;
                let dz = w * half;
                v += area * dz;
                vz += area * z * dz;
                vzz += area * z * z * dz;
                disc += 0.25 * pi * r.powi(4) * dz;
            }
        }
        let mut axial = 2.0 * disc;
        let mut transverse_origin = disc + vzz;
        if let Some(b) = self.block {
            let base = self.rings[self.len - 1][0];
            let (h, a, c) = (b.top - base, 2.0 * b.half_length, 2.0 * b.half_width);
            let volume = a * c * h;
            let zc = base + 0.5 * h;
            v += volume;
            vz += volume * zc;
            axial += volume * (a * a + c * c) / 12.0;
            // About a horizontal axis through the block's centre: (side² + h²) / 12, the two
            // sides averaged; then moved to the base by the parallel axes.
            transverse_origin += volume * (0.5 * (a * a + c * c) + h * h) / 12.0 + volume * zc * zc;
        }
        let density = mass / v;
        let com = vz / v;
        let transverse = density * transverse_origin - mass * com * com;
        (com, density * axial, transverse)
    }

    /// The radius at height `z` with the block counted as the cylinder it sweeps turned about
    /// the axis, m.
    fn swept_radius_at(&self, z: f64) -> f64 {
        let base = self.rings[self.len - 1][0];
        let block = self.block.filter(|b| z >= base && z <= b.top).map_or(0.0, |_| self.block_radius());
        self.radius_at(z).max(block)
    }

    /// An outline of rings only that holds every one of `outlines` turned any way about the
    /// axis: at each height of any of their rings (and blocks' tops) the largest radius, joined
    /// by frustums. Between two such heights every radius is linear (or 0), and the largest of
    /// linear functions is convex, so it lies under the chord joining its ends. A block counts as
    /// the cylinder of its half diagonal. `None` without outlines or with more ring heights than
    /// fit.
    pub fn envelope(outlines: &[Outline]) -> Option<Outline> {
        let mut heights: Vec<f64> =
            outlines.iter().flat_map(|o| o.rings().iter().map(|r| r[0]).chain(o.block.map(|b| b.top))).collect();
        heights.sort_by(f64::total_cmp);
        heights.dedup();
        let mut rings: Vec<[f64; 2]> =
            heights.iter().map(|&z| [z, outlines.iter().map(|o| o.swept_radius_at(z)).fold(0.0, f64::max)]).collect();
        // Too many rings: join the neighbouring sections whose join adds the least volume. The
        // joined frustum keeps the outer rings' heights and is lifted until its chord passes the
        // middle ring, so it holds both chords, and the outline under them.
        while rings.len() > OUTLINE_RINGS {
            let joined = |k: usize| {
                let ([z0, r0], [z1, r1], [z2, r2]) = (rings[k - 1], rings[k], rings[k + 1]);
                // The heights are distinct, so `z0 < z1 < z2`.
                let chord = r0 + (r2 - r0) * (z1 - z0) / (z2 - z0);
                let lift = (r1 - chord).max(0.0);
                let (a, b) = (r0 + lift, r2 + lift);
                let volume = |h: f64, x: f64, y: f64| h * (x * x + x * y + y * y);
                let added = volume(z2 - z0, a, b) - volume(z1 - z0, r0, r1) - volume(z2 - z1, r1, r2);
                (added, a, b)
            };
            let (k, (_, a, b)) = (1..rings.len() - 1)
                .map(|k| (k, joined(k)))
                .min_by(|x, y| x.1.0.total_cmp(&y.1.0))
                .expect("more than two rings");
            rings[k - 1][1] = a;
            rings[k + 1][1] = b;
            rings.remove(k);
        }
        Outline::new(&rings, None).ok()
    }
}

/// The inertia of an upright solid about its centre of mass, in the tool frame of a tool
/// pointing down (tool x = −z): axial about x, transverse about y and z.
pub fn upright_inertia(axial: f64, transverse: f64) -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(axial, transverse, transverse))
}
