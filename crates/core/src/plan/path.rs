//! Cartesian tool-tip paths made of straight moves and pauses.
//!
//! A move from `A` to `B` follows `p(t) = A + (B − A) s(t)` where `s` is an LSPB profile from
//! 0 to 1. With the report's default profile this equals the report's per-axis LSPB (every axis
//! shares the duration and the 1.5 × average cruise factor, hence the blend time), and the tip
//! moves on the straight segment. Velocity is zero at both ends of every move, so the path is
//! continuous in position and velocity; acceleration steps at blend boundaries.
//!
//! The tool's pitch (its angle above the horizontal in the arm's plane, [`TOOL_DOWN`] with
//! the gripper pointing straight down) moves with the same profile: `φ(t) = φ_A + (φ_B − φ_A) s(t)`.

use super::profile::{Lspb, ProfileError};
use crate::arm::task::TOOL_DOWN;
use nalgebra::Vector3;

/// Position (m), velocity (m/s) and acceleration (m/s²) of the tool tip at time `t` (s), and
/// the tool's pitch (rad), its rate (rad/s) and acceleration (rad/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CartesianSample {
    pub t: f64,
    pub position: Vector3<f64>,
    pub velocity: Vector3<f64>,
    pub acceleration: Vector3<f64>,
    pub pitch: f64,
    pub pitch_rate: f64,
    pub pitch_acceleration: f64,
}

/// The tool's pitch along a path's parameter `s` (m): `from` up to `start`, `to` from `end`
/// on, and between them `φ(s) = from + (to − from) S(u)`, `u = (s − start)/(end − start)`,
/// with the quintic step `S(u) = 10u³ − 15u⁴ + 6u⁵`: `S'` and `S''` vanish at both ends, so
/// the pitch's rate and acceleration are continuous wherever the path's are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PitchLaw {
    pub from: f64,
    pub to: f64,
    pub start: f64,
    pub end: f64,
}

impl PitchLaw {
    /// The same pitch all along (rad).
    pub fn constant(pitch: f64) -> Self {
        Self { from: pitch, to: pitch, start: 0.0, end: 0.0 }
    }

    /// `(φ, dφ/ds, d²φ/ds²)` at `s` (rad, rad/m, rad/m²).
    pub fn eval(&self, s: f64) -> (f64, f64, f64) {
        let span = self.end - self.start;
        let change = self.to - self.from;
        if change == 0.0 || span <= 0.0 {
            return (if s < self.end || change == 0.0 { self.from } else { self.to }, 0.0, 0.0);
        }
        let u = ((s - self.start) / span).clamp(0.0, 1.0);
        let step = u * u * u * (10.0 + u * (-15.0 + 6.0 * u));
        let slope = 30.0 * u * u * (1.0 - u) * (1.0 - u);
        let bend = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u);
        (self.from + change * step, change * slope / span, change * bend / (span * span))
    }
}

/// What the gripper does at a path event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GripperAction {
    Grip,
    Release,
}

/// A gripper action at an instant of the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathEvent {
    /// s from the start of the path.
    pub time: f64,
    pub action: GripperAction,
    /// Where the tip should be then, m.
    pub position: Vector3<f64>,
}

/// One piece of a path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment {
    /// Straight move driven by a path parameter profile `s: 0 → 1`, the pitch turning from
    /// `pitch[0]` to `pitch[1]` (rad) with it.
    Move { from: Vector3<f64>, to: Vector3<f64>, pitch: [f64; 2], profile: Lspb },
    /// Hold still, at `pitch` (rad).
    Pause { at: Vector3<f64>, pitch: f64, duration: f64 },
}

/// Where a segment or path has the tool, and how it moves: `(p, ṗ, p̈)` (m, m/s, m/s²) and
/// `(φ, φ̇, φ̈)` (rad, rad/s, rad/s²).
type ToolState = (Vector3<f64>, Vector3<f64>, Vector3<f64>, f64, f64, f64);

impl Segment {
    pub fn duration(&self) -> f64 {
        match self {
            Segment::Move { profile, .. } => profile.duration(),
            Segment::Pause { duration, .. } => *duration,
        }
    }

    fn sample(&self, local_t: f64) -> ToolState {
        match self {
            Segment::Move { from, to, pitch, profile } => {
                let s = profile.sample(local_t);
                let delta = to - from;
                let turn = pitch[1] - pitch[0];
                (
                    from + delta * s.position,
                    delta * s.velocity,
                    delta * s.acceleration,
                    pitch[0] + turn * s.position,
                    turn * s.velocity,
                    turn * s.acceleration,
                )
            }
            Segment::Pause { at, pitch, .. } => (*at, Vector3::zeros(), Vector3::zeros(), *pitch, 0.0, 0.0),
        }
    }
}

/// A tool-tip path: a start point and timed segments.
#[derive(Debug, Clone, PartialEq)]
pub struct CartesianPath {
    start: Vector3<f64>,
    start_pitch: f64,
    segments: Vec<Segment>,
    /// Start time of each segment, s.
    start_times: Vec<f64>,
    events: Vec<PathEvent>,
}

impl CartesianPath {
    /// An empty path that rests at `start` (m) with the tool pointing down.
    pub fn new(start: Vector3<f64>) -> Self {
        Self::pitched(start, TOOL_DOWN)
    }

    /// An empty path that rests at `start` (m) with the tool at `pitch` (rad).
    pub fn pitched(start: Vector3<f64>, pitch: f64) -> Self {
        Self { start, start_pitch: pitch, segments: Vec::new(), start_times: Vec::new(), events: Vec::new() }
    }

    /// The tool's pitch where the path ends, rad.
    pub fn end_pitch(&self) -> f64 {
        match self.segments.last() {
            Some(Segment::Move { pitch, .. }) => pitch[1],
            Some(Segment::Pause { pitch, .. }) => *pitch,
            None => self.start_pitch,
        }
    }

    /// Where the path ends, m.
    pub fn end(&self) -> Vector3<f64> {
        match self.segments.last() {
            Some(Segment::Move { to, .. }) => *to,
            Some(Segment::Pause { at, .. }) => *at,
            None => self.start,
        }
    }

    pub fn start(&self) -> Vector3<f64> {
        self.start
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        match (self.start_times.last(), self.segments.last()) {
            (Some(t), Some(segment)) => t + segment.duration(),
            _ => 0.0,
        }
    }

    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    pub fn events(&self) -> &[PathEvent] {
        &self.events
    }

    fn push(&mut self, segment: Segment) {
        self.start_times.push(self.duration());
        self.segments.push(segment);
    }

    /// Appends a straight move to `to` lasting `duration` s with the report's default LSPB.
    pub fn move_to(&mut self, to: Vector3<f64>, duration: f64) -> Result<&mut Self, ProfileError> {
        check_waypoint(&to)?;
        let profile = Lspb::new(0.0, 1.0, duration)?;
        Ok(self.move_with_profile(to, profile))
    }

    /// Appends the fastest straight move to `to` within a tip speed limit (m/s) and
    /// acceleration limit (m/s²).
    pub fn move_to_limited(
        &mut self,
        to: Vector3<f64>,
        max_speed: f64,
        max_acceleration: f64,
    ) -> Result<&mut Self, ProfileError> {
        check_waypoint(&to)?;
        let length = (to - self.end()).norm();
        if length == 0.0 {
            return Ok(self);
        }
        // The path parameter runs 0 → 1 over `length` metres.
        let profile = Lspb::min_time(0.0, 1.0, max_speed / length, max_acceleration / length)?;
        Ok(self.move_with_profile(to, profile))
    }

    /// Appends a straight move to `to` whose path parameter follows `profile` from 0 to 1,
    /// at the pitch the path ends with.
    pub fn move_with_profile(&mut self, to: Vector3<f64>, profile: Lspb) -> &mut Self {
        let pitch = self.end_pitch();
        self.turning_move(to, pitch, profile)
    }

    /// Appends a straight move to `to` along which the tool turns to `pitch` (rad), both
    /// following `profile` from 0 to 1.
    pub fn turning_move(&mut self, to: Vector3<f64>, pitch: f64, profile: Lspb) -> &mut Self {
        let from = self.end();
        let pitch = [self.end_pitch(), pitch];
        self.push(Segment::Move { from, to, pitch, profile });
        self
    }

    /// Appends a pause of `duration` s (> 0).
    pub fn pause(&mut self, duration: f64) -> Result<&mut Self, ProfileError> {
        if !(duration.is_finite() && duration > 0.0) {
            return Err(ProfileError::Duration(duration));
        }
        let (at, pitch) = (self.end(), self.end_pitch());
        self.push(Segment::Pause { at, pitch, duration });
        Ok(self)
    }

    /// Records a gripper action at the current end of the path.
    pub fn mark(&mut self, action: GripperAction) -> &mut Self {
        self.events.push(PathEvent { time: self.duration(), action, position: self.end() });
        self
    }

    /// Ends of every segment: `(time s, position m)`, starting with `(0, start)`.
    pub fn waypoints(&self) -> Vec<(f64, Vector3<f64>)> {
        let mut points = vec![(0.0, self.start)];
        for (segment, t0) in self.segments.iter().zip(&self.start_times) {
            if let Segment::Move { to, .. } = segment {
                points.push((t0 + segment.duration(), *to));
            }
        }
        points
    }

    /// The path at time `t` (s), held at its ends outside `[0, T]`.
    pub fn sample(&self, t: f64) -> CartesianSample {
        let index = self.start_times.partition_point(|&start| start <= t).saturating_sub(1);
        let (position, velocity, acceleration, pitch, pitch_rate, pitch_acceleration) = match self.segments.get(index) {
            Some(segment) => segment.sample(t - self.start_times[index]),
            None => (self.start, Vector3::zeros(), Vector3::zeros(), self.start_pitch, 0.0, 0.0),
        };
        CartesianSample { t, position, velocity, acceleration, pitch, pitch_rate, pitch_acceleration }
    }

    /// Samples at `t_k = k·dt` for `k = 0 ..= round(T/dt)`.
    pub fn sample_uniform(&self, dt: f64) -> Result<Vec<CartesianSample>, ProfileError> {
        Ok(sample_times(self.duration(), dt)?.map(|t| self.sample(t)).collect())
    }
}

/// Most samples a path is cut into (10⁸: 13 s at 0.13 µs), so a mistyped sample time is an
/// error rather than an attempt to allocate terabytes.
pub const MAX_SAMPLES: usize = 100_000_000;

/// The instants `k·dt` covering `[0, duration]`, `k = 0 ..= round(duration/dt)`.
pub fn sample_times(duration: f64, dt: f64) -> Result<impl Iterator<Item = f64>, ProfileError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(ProfileError::SampleTime(dt));
    }
    let count = (duration / dt).round();
    if count > MAX_SAMPLES as f64 {
        return Err(ProfileError::TooManySamples { duration, dt, limit: MAX_SAMPLES });
    }
    let count = count as usize;
    Ok((0..=count).map(move |k| k as f64 * dt))
}

fn check_waypoint(point: &Vector3<f64>) -> Result<(), ProfileError> {
    if point.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(ProfileError::Waypoint([point.x, point.y, point.z])) }
}
