//! Linear segment with parabolic blends (LSPB, "trapezoidal velocity profile") between two
//! scalar values over a duration.
//!
//! With start `q0`, end `q1`, duration `T` and cruise velocity `V` (same sign as `q1 − q0`),
//! the blend time is `t_b = (q0 − q1 + V T)/V` and the blend acceleration `a = V/t_b`:
//! `q(t) = q0 + a t²/2` for `t ≤ t_b`, `q(t) = (q0 + q1 − V T)/2 + V t` while cruising, and
//! `q(t) = q1 − a (T − t)²/2` for `t ≥ T − t_b`. Feasible iff `|q1 − q0|/T < |V| ≤ 2|q1 − q0|/T`.

/// Why a profile cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProfileError {
    #[error("duration {0} s must be finite and > 0")]
    Duration(f64),
    #[error("profile end points {0} and {1} must be finite")]
    EndPoints(f64, f64),
    #[error(
        "cruise velocity {velocity} is infeasible for a move of {distance} over {duration} s: |V| must lie in ({min}, {max}] with the sign of the move"
    )]
    CruiseVelocity { velocity: f64, distance: f64, duration: f64, min: f64, max: f64 },
    #[error("sample time {0} s must be finite and > 0")]
    SampleTime(f64),
    #[error("sampling {duration} s every {dt} s needs more than {limit} samples; use a larger time step")]
    TooManySamples { duration: f64, dt: f64, limit: usize },
    #[error("waypoint ({}, {}, {}) m must be finite", .0[0], .0[1], .0[2])]
    Waypoint([f64; 3]),
    #[error("speed limit {velocity} and acceleration limit {acceleration} must be finite and > 0")]
    Limits { velocity: f64, acceleration: f64 },
}

/// Position, velocity and acceleration of a profile at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProfileSample {
    pub position: f64,
    pub velocity: f64,
    pub acceleration: f64,
}

/// An LSPB profile. Units are those of the end points (m, rad, or a path parameter) and s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lspb {
    start: f64,
    end: f64,
    duration: f64,
    cruise_velocity: f64,
    blend_time: f64,
}

/// The report's (and Corke's toolbox's) default: cruise at 1.5 × the average velocity, so each
/// blend lasts a third of the move.
pub const DEFAULT_CRUISE_FACTOR: f64 = 1.5;

impl Lspb {
    /// The report's default profile: `V = 1.5 (q1 − q0)/T`.
    pub fn new(start: f64, end: f64, duration: f64) -> Result<Self, ProfileError> {
        check_duration(duration)?;
        Self::with_cruise_velocity(start, end, duration, DEFAULT_CRUISE_FACTOR * (end - start) / duration)
    }

    /// A profile with an explicit cruise velocity (units per second).
    pub fn with_cruise_velocity(start: f64, end: f64, duration: f64, velocity: f64) -> Result<Self, ProfileError> {
        check_duration(duration)?;
        if !(start.is_finite() && end.is_finite()) {
            return Err(ProfileError::EndPoints(start, end));
        }
        let distance = end - start;
        if distance == 0.0 {
            return Ok(Self { start, end, duration, cruise_velocity: 0.0, blend_time: duration / 2.0 });
        }
        let min = distance.abs() / duration;
        let max = 2.0 * min;
        let feasible = velocity.is_finite()
            && velocity.signum() == distance.signum()
            && velocity.abs() > min
            && velocity.abs() <= max * (1.0 + 1e-12);
        if !feasible {
            return Err(ProfileError::CruiseVelocity { velocity, distance, duration, min, max });
        }
        let blend_time = ((start - end + velocity * duration) / velocity).min(duration / 2.0);
        Ok(Self { start, end, duration, cruise_velocity: velocity, blend_time })
    }

    /// The fastest profile within a speed limit and an acceleration limit (both > 0): a
    /// trapezoid that cruises at `max_velocity`, or a triangle when the move is too short
    /// to reach it (`|Δ| ≤ v²/a`).
    pub fn min_time(start: f64, end: f64, max_velocity: f64, max_acceleration: f64) -> Result<Self, ProfileError> {
        let limits_ok =
            max_velocity.is_finite() && max_velocity > 0.0 && max_acceleration.is_finite() && max_acceleration > 0.0;
        if !limits_ok {
            return Err(ProfileError::Limits { velocity: max_velocity, acceleration: max_acceleration });
        }
        if !(start.is_finite() && end.is_finite()) {
            return Err(ProfileError::EndPoints(start, end));
        }
        let distance = (end - start).abs();
        if distance == 0.0 {
            return Ok(Self { start, end, duration: 0.0, cruise_velocity: 0.0, blend_time: 0.0 });
        }
        let sign = (end - start).signum();
        let (duration, blend_time, velocity) = if distance <= max_velocity * max_velocity / max_acceleration {
            let blend = (distance / max_acceleration).sqrt();
            (2.0 * blend, blend, max_acceleration * blend)
        } else {
            let blend = max_velocity / max_acceleration;
            (distance / max_velocity + blend, blend, max_velocity)
        };
        Ok(Self { start, end, duration, cruise_velocity: sign * velocity, blend_time })
    }

    pub fn duration(&self) -> f64 {
        self.duration
    }
    pub fn blend_time(&self) -> f64 {
        self.blend_time
    }
    /// Signed cruise velocity, units/s.
    pub fn cruise_velocity(&self) -> f64 {
        self.cruise_velocity
    }
    /// Signed acceleration during the first blend, units/s².
    pub fn blend_acceleration(&self) -> f64 {
        if self.blend_time > 0.0 { self.cruise_velocity / self.blend_time } else { 0.0 }
    }
    pub fn start(&self) -> f64 {
        self.start
    }
    pub fn end(&self) -> f64 {
        self.end
    }

    /// The profile at time `t` (s from its start); held at the end points outside `[0, T]`.
    pub fn sample(&self, t: f64) -> ProfileSample {
        let (duration, blend, velocity) = (self.duration, self.blend_time, self.cruise_velocity);
        let acceleration = self.blend_acceleration();
        if t <= 0.0 || velocity == 0.0 {
            let position = if t >= duration && duration > 0.0 { self.end } else { self.start };
            return ProfileSample { position, ..Default::default() };
        }
        if t >= duration {
            return ProfileSample { position: self.end, ..Default::default() };
        }
        if t <= blend {
            ProfileSample {
                position: self.start + 0.5 * acceleration * t * t,
                velocity: acceleration * t,
                acceleration,
            }
        } else if t < duration - blend {
            ProfileSample {
                position: 0.5 * (self.start + self.end - velocity * duration) + velocity * t,
                velocity,
                acceleration: 0.0,
            }
        } else {
            let remaining = duration - t;
            ProfileSample {
                position: self.end - 0.5 * acceleration * remaining * remaining,
                velocity: acceleration * remaining,
                acceleration: -acceleration,
            }
        }
    }
}

fn check_duration(duration: f64) -> Result<(), ProfileError> {
    if duration.is_finite() && duration > 0.0 { Ok(()) } else { Err(ProfileError::Duration(duration)) }
}
