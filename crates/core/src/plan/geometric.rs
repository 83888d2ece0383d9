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

use super::path::{CartesianSample, GripperAction, PathEvent, PitchLaw};
use super::topp::Timing;
use crate::arm::task::TOOL_DOWN;
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
    #[error("the path doubles back on itself at ({}, {}, {}) m", .0[0], .0[1], .0[2])]
    Reversal([f64; 3]),
    #[error("corner {corner}: blend cut {cut} m must be finite and > 0")]
    Cut { corner: usize, cut: f64 },
}

/// Lines and blends, parameterised by `s ∈ [0, length]`, and the tool's pitch along them.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometricPath {
    pieces: Vec<PathPiece>,
    /// `s` at the start of each piece.
    starts: Vec<f64>,
    pitch: PitchLaw,
}

impl GeometricPath {
    /// The polyline through `points` (points closer than [`MIN_LINE`] to the previous one and
    /// collinear interior points dropped, see [`Self::corners`]) with corner `k` (the `k`-th remaining interior point,
    /// and the `k`-th blend piece) blended at cut `cut(k)` m from the corner along both lines,
    /// clamped to half of the shorter line so that blends never meet.
    pub fn polyline(points: &[Vector3<f64>], cut: impl Fn(usize) -> f64) -> Result<Self, GeometryError> {
        let corners = Self::corners(points)?;
        let mut pieces = Vec::with_capacity(2 * corners.len());
        let mut from = corners[0];
        for k in 1..corners.len() - 1 {
            let (before, corner, after) = (corners[k - 1], corners[k], corners[k + 1]);
            let (incoming, outgoing) = ((corner - before).normalize(), (after - corner).normalize());
            let max = 0.5 * (corner - before).norm().min((after - corner).norm());
            let d = cut(k - 1);
            if !(d.is_finite() && d > 0.0) {
                return Err(GeometryError::Cut { corner: k - 1, cut: d });
            }
            let d = d.min(max);
            let start = corner - incoming * d;
            pieces.push(PathPiece::Line { from, to: start });
            pieces.push(PathPiece::Blend { start, incoming, outgoing, cut: d });
            from = corner + outgoing * d;
        }
        pieces.push(PathPiece::Line { from, to: corners[corners.len() - 1] });
        // A line left this short between two blends (each cut to half of it) is rounding.
        pieces.retain(|p| p.length() > 1e-9);
        let mut starts = Vec::with_capacity(pieces.len());
        let mut s = 0.0;
        for piece in &pieces {
            starts.push(s);
            s += piece.length();
        }
        Ok(Self { pieces, starts, pitch: PitchLaw::constant(TOOL_DOWN) })
    }

    /// The same path with the tool's pitch following `pitch` along it (the polyline's is
    /// [`TOOL_DOWN`] all along).
    pub fn with_pitch(self, pitch: PitchLaw) -> Self {
        Self { pitch, ..self }
    }

    /// The tool's pitch along the path.
    pub fn pitch(&self) -> PitchLaw {
        self.pitch
    }

    /// `(φ, φ', φ'')` at `s` (rad, rad/m, rad/m²).
    pub fn eval_pitch(&self, s: f64) -> (f64, f64, f64) {
        self.pitch.eval(s.clamp(0.0, self.length()))
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
    /// `refinement` r divides the step by 2^r and multiplies the blends' fewest intervals by
    /// 2^r (a planner that finds a limit exceeded between grid points times again finer).
    pub fn grid(&self, step: f64, refinement: u32) -> Vec<f64> {
        let mut grid = Vec::new();
        let factor = f64::from(1u32 << refinement.min(16));
        for (piece, start) in self.pieces.iter().zip(&self.starts) {
            let blend = matches!(piece, PathPiece::Blend { .. });
            let step = if blend { 0.5 * step } else { step } / factor;
            // A leg from rest to rest needs an interior grid point to move at all.
            let fewest = if blend { MIN_BLEND_INTERVALS * factor } else { 2.0 };
            let n = (piece.length() / step).ceil().max(fewest) as usize;
            for k in 0..n {
                let s = start + piece.length() * k as f64 / n as f64;
                if grid.last().is_none_or(|&last| s > last) {
                    grid.push(s);
                }
            }
        }
        let end = self.length();
        if grid.last().is_none_or(|&last| end > last) {
            grid.push(end);
        }
        grid
    }
}

impl GeometricPath {
    /// The waypoints without points closer than [`MIN_LINE`] to the previous one (the last
    /// point replaces an interior one) and without collinear interior points (same
    /// direction); at least 2. A reversal (a line doubling back on itself) is an error: it cannot be
    /// blended and would need a stop.
    pub fn corners(points: &[Vector3<f64>]) -> Result<Vec<Vector3<f64>>, GeometryError> {
        corner_points(points)
    }
}

/// Fewest grid intervals on a blend. Its curvature `∝ 6τ(1 − τ)` (zero at both ends, 1.5 in
/// the middle) is what the limits see at speed (`q̈ ∋ q'' ṡ²`); between grid points `δ` apart
/// in `τ` the planner sees it linearly interpolated, off by up to `δ²·12/8`, i.e. `δ²` of the
/// peak: 1.6 % with 8 intervals (measured: joint 2's acceleration 2 % over on a 13 mm blend),
/// 0.1 % with 32, inside the planner's slack ([`super::optimal::GRID_SLACK`]).
pub const MIN_BLEND_INTERVALS: f64 = 32.0;

/// Lines shorter than this are merged into their neighbours, m: a corner that close to
/// another could only be blended at a tiny cut, which is a sharp bend the arm must crawl
/// through (a piece placed 0.3 mm off its square's centre and picked up again, say).
pub const MIN_LINE: f64 = 0.001;

fn corner_points(points: &[Vector3<f64>]) -> Result<Vec<Vector3<f64>>, GeometryError> {
    if let Some(p) = points.iter().find(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(GeometryError::Waypoint([p.x, p.y, p.z]));
    }
    let mut kept: Vec<Vector3<f64>> = Vec::with_capacity(points.len());
    for (index, p) in points.iter().enumerate() {
        let last_point = index + 1 == points.len();
        if let Some(last) = kept.last()
            && (p - last).norm() < MIN_LINE
        {
            if !last_point {
                continue;
            }
            // The ends stay exact: the final point replaces interior ones close to it.
            while kept.len() > 1 && kept.last().is_some_and(|last| (p - last).norm() < MIN_LINE) {
                kept.pop();
            }
        }
        while kept.len() >= 2 {
            let (a, b) = (kept[kept.len() - 2], kept[kept.len() - 1]);
            let (d1, d2) = ((b - a).normalize(), (p - b).normalize());
            if d1.dot(&d2) > 1.0 - 1e-12 {
                kept.pop();
            } else if d1.dot(&d2) < -1.0 + 1e-9 {
                return Err(GeometryError::Reversal([b.x, b.y, b.z]));
            } else {
                break;
            }
        }
        kept.push(*p);
    }
    if kept.len() < 2 || (kept[kept.len() - 1] - kept[0]).norm() == 0.0 && kept.len() == 2 {
        return Err(GeometryError::TooShort);
    }
    Ok(kept)
}

/// A timed geometric path: the time law `s_b(t) = s(t/scale)` of a [`Timing`], stretched by
/// `scale ≥ 1` (a uniform slow-down keeps every limit: velocities scale by `1/scale`,
/// accelerations by `1/scale²`), then, with a window `T > 0`, smoothed by a moving average
/// (a FIR filter of the time law, as CNC and industrial controllers smooth their moves):
///
/// `s̃(t) = (1/T) ∫_{t−T}^{t} s_b(τ) dτ`, so `ṡ̃ = (s_b(t) − s_b(t−T))/T`,
/// `s̈̃ = (ṡ_b(t) − ṡ_b(t−T))/T` and `s⃛̃ = (s̈_b(t) − s̈_b(t−T))/T`,
///
/// with `s_b` held at its ends outside `[0, D]`. The smoothed law runs from rest to rest in
/// `D + T`, its acceleration is continuous, and its jerk is bounded by
/// `(max s̈_b − min s̈_b)/T`: [`Self::smoothed_for_jerk`] picks `T` from a jerk limit. The
/// path is unchanged (only its timing is); its speed and acceleration along the path are
/// averages of the base law's over the window, taken at a point the window passed through,
/// so the limits hold up to how fast they vary along the path (checked afterwards, see
/// `check_motion`).
#[derive(Debug, Clone, PartialEq)]
pub struct TimedLeg {
    pub path: GeometricPath,
    pub timing: Timing,
    pub scale: f64,
    /// The smoothing window `T`, s (0: none).
    window: f64,
    /// `∫₀^{t_i} s dt` of the unstretched law at the timing's points (m·s).
    area: Vec<f64>,
}

impl TimedLeg {
    /// The leg timed by `timing`, stretched by `scale`, unsmoothed.
    pub fn new(path: GeometricPath, timing: Timing, scale: f64) -> Self {
        let mut area = Vec::with_capacity(timing.t.len());
        let mut total = 0.0;
        area.push(0.0);
        for i in 0..timing.u.len() {
            let h = timing.t[i + 1] - timing.t[i];
            let (s, v, u) = (timing.s[i], timing.x[i].sqrt(), timing.u[i]);
            total += h * (s + h * (0.5 * v + h * u / 6.0));
            area.push(total);
        }
        Self { path, timing, scale, window: 0.0, area }
    }

    /// The same leg smoothed over `window` s (module docs of [`TimedLeg`]); 0 for none.
    pub fn with_window(self, window: f64) -> Self {
        Self { window: window.max(0.0), ..self }
    }

    /// The window that keeps `|s⃛|` within `jerk` (m/s³ on lines, where `s` is the arc length),
    /// rounded up to whole `period`s so that the leg still lasts whole periods: the smallest
    /// `T` with `(max s̈_b − min s̈_b)/T ≤ jerk`. 0 for an infinite jerk.
    pub fn window_for_jerk(&self, jerk: f64, period: f64) -> f64 {
        if !jerk.is_finite() {
            return 0.0;
        }
        let (low, high) = self.timing.u.iter().fold((0.0_f64, 0.0_f64), |(l, h), &u| (l.min(u), h.max(u)));
        let spread = (high - low) / (self.scale * self.scale);
        let window = spread / jerk;
        if window <= 0.0 { 0.0 } else { (window / period - 1e-9).ceil().max(1.0) * period }
    }

    /// [`Self::with_window`] at [`Self::window_for_jerk`].
    pub fn smoothed_for_jerk(self, jerk: f64, period: f64) -> Self {
        let window = self.window_for_jerk(jerk, period);
        self.with_window(window)
    }

    /// The same leg slowed down uniformly by `k ≥ 1`, window and all: `s(t/k)`, so speeds
    /// scale by `1/k`, accelerations by `1/k²` and the jerk by `1/k³`.
    pub fn stretched(self, k: f64) -> Self {
        Self { scale: self.scale * k, window: self.window * k, ..self }
    }

    /// The smoothing window, s.
    pub fn window(&self) -> f64 {
        self.window
    }

    /// Duration of the stretched law before smoothing, s.
    pub fn base_duration(&self) -> f64 {
        self.timing.duration() * self.scale
    }

    pub fn duration(&self) -> f64 {
        self.base_duration() + self.window
    }

    /// `(s_b, ṡ_b, s̈_b)` of the stretched law at `t`, held at its ends outside `[0, D]`.
    fn base(&self, t: f64) -> (f64, f64, f64) {
        let (s, sd, sdd) = self.timing.sample(t / self.scale);
        (s, sd / self.scale, sdd / (self.scale * self.scale))
    }

    /// `∫₀^t s_b dτ` (m·s), with `s_b` held at its ends outside `[0, D]`.
    fn integral(&self, t: f64) -> f64 {
        let timing = &self.timing;
        let n = timing.s.len();
        let base = t / self.scale;
        if base <= 0.0 {
            return timing.s[0] * t;
        }
        let end = timing.duration();
        if base >= end {
            return self.scale * self.area[n - 1] + timing.s[n - 1] * (t - self.base_duration());
        }
        let i = (timing.t.partition_point(|&ti| ti <= base).max(1) - 1).min(n - 2);
        let h = base - timing.t[i];
        let (s, v, u) = (timing.s[i], timing.x[i].sqrt(), timing.u[i]);
        self.scale * (self.area[i] + h * (s + h * (0.5 * v + h * u / 6.0)))
    }

    /// The time law `(s, ṡ, s̈)` at local time `t` (smoothed if the leg has a window).
    pub fn law(&self, t: f64) -> (f64, f64, f64) {
        let window = self.window;
        if window <= 0.0 {
            return self.base(t);
        }
        let (first, last) = (self.timing.s[0], self.timing.s[self.timing.s.len() - 1]);
        if t <= 0.0 {
            return (first, 0.0, 0.0);
        }
        if t >= self.duration() {
            return (last, 0.0, 0.0);
        }
        let (now, before) = (self.base(t), self.base(t - window));
        let s = ((self.integral(t) - self.integral(t - window)) / window).clamp(first, last);
        (s, ((now.0 - before.0) / window).max(0.0), (now.1 - before.1) / window)
    }

    /// When the law reaches `s` (s): the base law's time there, plus half the window inside
    /// the leg (the moving average lags its input by `T/2` where the input is about linear),
    /// exact at both ends.
    pub fn time_at(&self, s: f64) -> f64 {
        let timing = &self.timing;
        let n = timing.s.len();
        if s <= timing.s[0] {
            return 0.0;
        }
        if s >= timing.s[n - 1] {
            return self.duration();
        }
        let i = timing.s.partition_point(|&g| g < s - 1e-12).min(n - 1);
        timing.t[i] * self.scale + 0.5 * self.window
    }

    /// Tool position, velocity and acceleration, and pitch with its rate and acceleration, at
    /// local time `t`: `ẋ = x' ṡ`, `ẍ = x' s̈ + x'' ṡ²` for the position and the pitch alike.
    pub fn sample(&self, t: f64) -> CartesianSample {
        let (s, sd, sdd) = self.law(t);
        let (p, dp, ddp) = self.path.eval(s);
        let (pitch, dpitch, ddpitch) = self.path.eval_pitch(s);
        CartesianSample {
            t,
            position: p,
            velocity: dp * sd,
            acceleration: dp * sdd + ddp * (sd * sd),
            pitch,
            pitch_rate: dpitch * sd,
            pitch_acceleration: dpitch * sdd + ddpitch * (sd * sd),
        }
    }
}

/// A part of a timed motion.
#[derive(Debug, Clone, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "a move holds a handful of stretches, read at every sample: a box per leg would buy nothing"
)]
pub enum Stretch {
    Leg(TimedLeg),
    /// Rest at `at` (m) with the tool at `pitch` (rad).
    Dwell {
        at: Vector3<f64>,
        pitch: f64,
        duration: f64,
    },
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
    start_pitch: f64,
    stretches: Vec<Stretch>,
    starts: Vec<f64>,
    events: Vec<PathEvent>,
}

impl TimedMotion {
    /// A motion resting at `start` (m) with the tool pointing down.
    pub fn new(start: Vector3<f64>) -> Self {
        Self::pitched(start, TOOL_DOWN)
    }

    /// A motion resting at `start` (m) with the tool at `pitch` (rad).
    pub fn pitched(start: Vector3<f64>, pitch: f64) -> Self {
        Self { start, start_pitch: pitch, stretches: Vec::new(), starts: Vec::new(), events: Vec::new() }
    }

    /// The tool's pitch where the motion ends, rad.
    pub fn end_pitch(&self) -> f64 {
        match self.stretches.last() {
            Some(Stretch::Leg(leg)) => leg.path.eval_pitch(leg.path.length()).0,
            Some(Stretch::Dwell { pitch, .. }) => *pitch,
            None => self.start_pitch,
        }
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
        let rest = |position: Vector3<f64>, pitch: f64| CartesianSample {
            t,
            position,
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            pitch,
            pitch_rate: 0.0,
            pitch_acceleration: 0.0,
        };
        match self.stretches.get(index) {
            Some(Stretch::Leg(leg)) => CartesianSample { t, ..leg.sample(t - self.starts[index]) },
            Some(Stretch::Dwell { at, pitch, .. }) => rest(*at, *pitch),
            None => rest(self.start, self.start_pitch),
        }
    }
}
