//! Geometric tool paths (no timing): straight lines joined by smooth corner blends, and their
//! timing by [`super::topp`] into a [`TimedMotion`].
//!
//! A corner at `C` between unit directions `u₁` (in) and `u₂` (out) is cut at distance `d` on
//! both sides: from `A = C − d u₁` to `B = C + d u₂` the tangent turns as
//! `p'(σ) = (1 − w) u₁ + w u₂`, `w = 3τ² − 2τ³`, `τ = σ/(2d)`, `σ ∈ [0, 2d]`, so
//! `p(σ) = A + u₁ (σ − W) + u₂ W` with `W = 2d (τ³ − τ⁴/2)` (`W(2d) = d` puts the end on `B`)
//! and `p'' = (u₂ − u₁) (6τ − 6τ²)/(2d)`. The curvature is zero at both ends, so `p''` (and
//! with it the joint accelerations at a given `ṡ`) is continuous along the path. The blend
//! stays in the triangle `A C B`. On lines the parameter is the arc length; on blends it is
//! `σ`, with `|p'| ≥ cos(θ/2)` for a turn of `θ`.

use super::path::{CartesianSample, GripperAction, PathEvent};
use super::topp::Timing;
use nalgebra::Vector3;

/// One piece of a geometric path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathPiece {
    Line {
        from: Vector3<f64>,
        to: Vector3<f64>,
    },
    /// The corner blend of the module docs, starting at `start` (= `A`).
    Blend {
        start: Vector3<f64>,
        incoming: Vector3<f64>,
        outgoing: Vector3<f64>,
        cut: f64,
    },
}

impl PathPiece {
    /// Length of its parameter range.
    pub fn length(&self) -> f64 {
        match self {
            PathPiece::Line { from, to } => (to - from).norm(),
            PathPiece::Blend { cut, .. } => 2.0 * cut,
        }
    }

    /// `(p, p', p'')` at local parameter `sigma`.
    pub fn eval(&self, sigma: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        match *self {
            PathPiece::Line { from, to } => {
                let length = (to - from).norm();
                let direction = if length > 0.0 { (to - from) / length } else { Vector3::zeros() };
                (from + direction * sigma, direction, Vector3::zeros())
            }
            PathPiece::Blend { start, incoming, outgoing, cut } => {
                let tau = (sigma / (2.0 * cut)).clamp(0.0, 1.0);
                let w = tau * tau * (3.0 - 2.0 * tau);
                let big_w = 2.0 * cut * tau * tau * tau * (1.0 - 0.5 * tau);
                let p = start + incoming * (2.0 * cut * tau - big_w) + outgoing * big_w;
                let dp = incoming * (1.0 - w) + outgoing * w;
                let ddp = (outgoing - incoming) * (6.0 * tau * (1.0 - tau) / (2.0 * cut));
                (p, dp, ddp)
            }
        }
    }

    /// Whether it is a straight vertical line (a rise or a descent).
    pub fn is_vertical(&self) -> bool {
        match self {
            PathPiece::Line { from, to } => from.xy() == to.xy() && from.z != to.z,
            PathPiece::Blend { .. } => false,
        }
    }
}

/// Why a geometric path cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    #[error("a path needs at least 2 distinct waypoints")]
    TooShort,
    #[error("waypoint ({}, {}, {}) m must be finite", .0[0], .0[1], .0[2])]
    Waypoint([f64; 3]),
    #[error("corner {corner}: blend cut {cut} m must be finite, > 0 and at most half of each adjacent line ({max} m)")]
    Cut { corner: usize, cut: f64, max: f64 },
}

/// Lines and blends, parameterised by `s ∈ [0, length]`.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometricPath {
    pieces: Vec<PathPiece>,
    /// `s` at the start of each piece.
    starts: Vec<f64>,
}

impl GeometricPath {
    /// The polyline through `points` (consecutive duplicates and collinear interior points
    /// dropped) with corner `k` (the `k`-th remaining interior point) blended at cut `cut(k)`
    /// (m from the corner along both lines; at most half of each line, so blends never meet).
    pub fn polyline(points: &[Vector3<f64>], cut: impl Fn(usize) -> f64) -> Result<Self, GeometryError> {
        let corners = corner_points(points)?;
        let mut pieces = Vec::with_capacity(2 * corners.len());
        let mut from = corners[0];
        for k in 1..corners.len() - 1 {
            let (before, corner, after) = (corners[k - 1], corners[k], corners[k + 1]);
            let (incoming, outgoing) = ((corner - before).normalize(), (after - corner).normalize());
            let max = 0.5 * (corner - before).norm().min((after - corner).norm());
            let d = cut(k - 1);
            if !(d.is_finite() && d > 0.0 && d <= max * (1.0 + 1e-12)) {
                return Err(GeometryError::Cut { corner: k - 1, cut: d, max });
            }
            let d = d.min(max);
            let start = corner - incoming * d;
            pieces.push(PathPiece::Line { from, to: start });
            pieces.push(PathPiece::Blend { start, incoming, outgoing, cut: d });
            from = corner + outgoing * d;
        }
        pieces.push(PathPiece::Line { from, to: corners[corners.len() - 1] });
        pieces.retain(|p| p.length() > 0.0);
        let mut starts = Vec::with_capacity(pieces.len());
        let mut s = 0.0;
        for piece in &pieces {
            starts.push(s);
            s += piece.length();
        }
        Ok(Self { pieces, starts })
    }

    pub fn pieces(&self) -> &[PathPiece] {
        &self.pieces
    }

    /// `s` at the start of each piece.
    pub fn piece_starts(&self) -> &[f64] {
        &self.starts
    }

    /// Length of the parameter range.
    pub fn length(&self) -> f64 {
        self.starts.last().zip(self.pieces.last()).map_or(0.0, |(s, p)| s + p.length())
    }

    /// The piece at `s` and the local parameter.
    pub fn locate(&self, s: f64) -> (usize, f64) {
        let index = (self.starts.partition_point(|&start| start <= s).max(1) - 1).min(self.pieces.len() - 1);
        (index, (s - self.starts[index]).clamp(0.0, self.pieces[index].length()))
    }

    /// `(p, p', p'')` at `s` (clamped to the path).
    pub fn eval(&self, s: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let (index, sigma) = self.locate(s);
        self.pieces[index].eval(sigma)
    }

    pub fn start(&self) -> Vector3<f64> {
        self.eval(0.0).0
    }

    pub fn end(&self) -> Vector3<f64> {
        self.eval(self.length()).0
    }

    /// A grid over `[0, length]` with every piece boundary, steps of at most `step` on lines
    /// and half that on blends (where the joint path bends fastest: measured on the report's
    /// arm, 5 mm steps on a 4 cm blend let the limits drift 0.11 % between grid points, 2.5 mm
    /// keep them within the planner's slack).
    pub fn grid(&self, step: f64) -> Vec<f64> {
        let mut grid = Vec::new();
        for (piece, start) in self.pieces.iter().zip(&self.starts) {
            let step = if matches!(piece, PathPiece::Blend { .. }) { 0.5 * step } else { step };
            let n = (piece.length() / step).ceil().max(1.0) as usize;
            grid.extend((0..n).map(|k| start + piece.length() * k as f64 / n as f64));
        }
        grid.push(self.length());
        grid
    }
}

/// The waypoints with duplicates and collinear interior points removed (at least 2).
fn corner_points(points: &[Vector3<f64>]) -> Result<Vec<Vector3<f64>>, GeometryError> {
    if let Some(p) = points.iter().find(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(GeometryError::Waypoint([p.x, p.y, p.z]));
    }
    let mut kept: Vec<Vector3<f64>> = Vec::with_capacity(points.len());
    for p in points {
        if kept.last().is_some_and(|last| (p - last).norm() <= 1e-12) {
            continue;
        }
        if kept.len() >= 2 {
            let (a, b) = (kept[kept.len() - 2], kept[kept.len() - 1]);
            let (d1, d2) = ((b - a).normalize(), (p - b).normalize());
            if d1.dot(&d2) > 1.0 - 1e-12 {
                kept.pop();
            }
        }
        kept.push(*p);
    }
    if kept.len() < 2 {
        return Err(GeometryError::TooShort);
    }
    Ok(kept)
}

/// A timed geometric path: `s(t/scale)`, stretched by `scale ≥ 1` (a uniform slow-down keeps
/// every limit: velocities scale by `1/scale`, accelerations by `1/scale²`).
#[derive(Debug, Clone, PartialEq)]
pub struct TimedLeg {
    pub path: GeometricPath,
    pub timing: Timing,
    pub scale: f64,
}

impl TimedLeg {
    pub fn duration(&self) -> f64 {
        self.timing.duration() * self.scale
    }

    /// Tool position, velocity and acceleration at local time `t`.
    pub fn sample(&self, t: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let (s, sd, sdd) = self.timing.sample(t / self.scale);
        let (sd, sdd) = (sd / self.scale, sdd / (self.scale * self.scale));
        let (p, dp, ddp) = self.path.eval(s);
        (p, dp * sd, dp * sdd + ddp * (sd * sd))
    }
}

/// A part of a timed motion.
#[derive(Debug, Clone, PartialEq)]
pub enum Stretch {
    Leg(TimedLeg),
    Dwell { at: Vector3<f64>, duration: f64 },
}

impl Stretch {
    pub fn duration(&self) -> f64 {
        match self {
            Stretch::Leg(leg) => leg.duration(),
            Stretch::Dwell { duration, .. } => *duration,
        }
    }
}

/// Timed legs and dwells one after the other, with gripper events.
#[derive(Debug, Clone, PartialEq)]
pub struct TimedMotion {
    start: Vector3<f64>,
    stretches: Vec<Stretch>,
    starts: Vec<f64>,
    events: Vec<PathEvent>,
}

impl TimedMotion {
    pub fn new(start: Vector3<f64>) -> Self {
        Self { start, stretches: Vec::new(), starts: Vec::new(), events: Vec::new() }
    }

    pub fn duration(&self) -> f64 {
        self.starts.last().zip(self.stretches.last()).map_or(0.0, |(t, s)| t + s.duration())
    }

    pub fn end(&self) -> Vector3<f64> {
        match self.stretches.last() {
            Some(Stretch::Leg(leg)) => leg.path.end(),
            Some(Stretch::Dwell { at, .. }) => *at,
            None => self.start,
        }
    }

    pub fn push(&mut self, stretch: Stretch) {
        self.starts.push(self.duration());
        self.stretches.push(stretch);
    }

    /// Records a gripper action now, at the current end.
    pub fn mark(&mut self, action: GripperAction) {
        self.events.push(PathEvent { time: self.duration(), action, position: self.end() });
    }

    pub fn stretches(&self) -> &[Stretch] {
        &self.stretches
    }

    /// Start time of each stretch, s.
    pub fn stretch_starts(&self) -> &[f64] {
        &self.starts
    }

    pub fn events(&self) -> &[PathEvent] {
        &self.events
    }

    /// The motion at time `t` (s), held at its ends outside `[0, T]`.
    pub fn sample(&self, t: f64) -> CartesianSample {
        let index = self.starts.partition_point(|&start| start <= t).saturating_sub(1);
        let (position, velocity, acceleration) = match self.stretches.get(index) {
            Some(Stretch::Leg(leg)) => leg.sample(t - self.starts[index]),
            Some(Stretch::Dwell { at, .. }) => (*at, Vector3::zeros(), Vector3::zeros()),
            None => (self.start, Vector3::zeros(), Vector3::zeros()),
        };
        CartesianSample { t, position, velocity, acceleration }
    }
}
