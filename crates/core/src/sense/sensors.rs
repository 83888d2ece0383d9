//! Joint sensors sampled at the control rate.
//!
//! Each joint has an encoder of `counts_per_rev` counts per revolution (resolution
//! `Δ = 2π / counts_per_rev` rad). At a sample the encoder reads the true angle plus its
//! calibration `offset`, adds Gaussian noise of σ = `noise_counts` counts, and rounds to the
//! nearest count: `q̃ = Δ · round((q + offset)/Δ + σ n)`, `n ~ N(0, 1)`; the reported angle lies
//! on the grid `Δ ℤ`. The reading reaches the controller `delay_samples` samples later (bus
//! transfer, a drive's internal cycle). A velocity sensor (a tachometer, a drive's rate output)
//! exists only where the profile gives one: `q̇̃ = q̇ + σ_rate n`.
//!
//! The named profiles (`SensorProfile::named`):
//!
//! | profile | encoder | Δ (mrad) | noise | delay | rate sensor |
//! |---|---|---|---|---|---|
//! | `ideal` | exact | 0 | 0 | 0 | exact |
//! | `hobby` | 12-bit magnetic (AS5600 class), 4096 counts/rev | 1.534 | σ = 0.5 count | 1 sample | none |
//! | `servo` | 17-bit absolute, 131 072 counts/rev | 0.0479 | σ = 0.5 count | 0 | none |

use super::rng::SeededRng;
use super::{Measurement, SenseError, invalid};
use crate::arm::model::JointVector;
use crate::control::JointState;
use std::f64::consts::TAU;

/// Longest measurement delay a profile may have, samples.
pub const MAX_DELAY_SAMPLES: usize = 64;

/// One joint's angle sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderSpec {
    /// Counts per revolution (a whole number > 0); `None`: the exact angle (no quantisation).
    pub counts_per_rev: Option<f64>,
    /// σ of the Gaussian noise added before rounding, counts (0: none). Needs `counts_per_rev`.
    pub noise_counts: f64,
    /// Calibration error: the encoder reads `q + offset`, rad.
    pub offset: f64,
}

impl EncoderSpec {
    /// The exact angle.
    pub const EXACT: EncoderSpec = EncoderSpec { counts_per_rev: None, noise_counts: 0.0, offset: 0.0 };

    /// An encoder of `counts_per_rev` counts with `noise_counts` σ and no offset.
    pub fn counts(counts_per_rev: f64, noise_counts: f64) -> Self {
        Self { counts_per_rev: Some(counts_per_rev), noise_counts, offset: 0.0 }
    }

    /// One count, rad (0 for an exact encoder).
    pub fn resolution(&self) -> f64 {
        self.counts_per_rev.map_or(0.0, |counts| TAU / counts)
    }

    /// σ of the reported angle about the true one, rad: rounding (uniform over one count,
    /// variance Δ²/12) and noise (σ² counts²) combined, `Δ √(1/12 + σ²)`. The measurement
    /// noise a Kalman filter assumes.
    pub fn angle_std(&self) -> f64 {
        self.resolution() * (1.0 / 12.0 + self.noise_counts * self.noise_counts).sqrt()
    }
}

/// What the controller's sensors are.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorProfile<const N: usize> {
    /// Name for reports ("ideal", "hobby", "servo", or the setup file's).
    pub name: String,
    pub encoders: [EncoderSpec; N],
    /// Samples between a reading and its use by the controller.
    pub delay_samples: usize,
    /// σ of a velocity sensor's noise, rad/s, per joint; `None`: no velocity sensor.
    pub rate_noise: Option<JointVector<N>>,
}

impl<const N: usize> SensorProfile<N> {
    /// The exact state: today's closed loop.
    pub fn ideal() -> Self {
        Self {
            name: "ideal".into(),
            encoders: [EncoderSpec::EXACT; N],
            delay_samples: 0,
            rate_noise: Some(JointVector::zeros()),
        }
    }

    /// 12-bit magnetic encoders on the joints: 4096 counts/rev, σ = 0.5 count, 1 sample delay,
    /// no velocity sensor.
    pub fn hobby() -> Self {
        Self {
            name: "hobby".into(),
            encoders: [EncoderSpec::counts(4096.0, 0.5); N],
            delay_samples: 1,
            rate_noise: None,
        }
    }

    /// 17-bit absolute encoders: 131 072 counts/rev, σ = 0.5 count, no delay, no velocity sensor.
    pub fn servo() -> Self {
        Self {
            name: "servo".into(),
            encoders: [EncoderSpec::counts(131_072.0, 0.5); N],
            delay_samples: 0,
            rate_noise: None,
        }
    }

    /// The names of the built-in profiles.
    pub const NAMES: [&'static str; 3] = ["ideal", "hobby", "servo"];

    /// A built-in profile by name.
    pub fn named(name: &str) -> Option<Self> {
        match name {
            "ideal" => Some(Self::ideal()),
            "hobby" => Some(Self::hobby()),
            "servo" => Some(Self::servo()),
            _ => None,
        }
    }

    /// Whether the controller gets the exact state.
    pub fn is_ideal(&self) -> bool {
        self.encoders.iter().all(|e| *e == EncoderSpec::EXACT)
            && self.delay_samples == 0
            && self.rate_noise == Some(JointVector::zeros())
    }

    /// Whether there is a velocity sensor.
    pub fn measures_rate(&self) -> bool {
        self.rate_noise.is_some()
    }

    /// Checks every number, naming the field (`sensors.<name>.joint 2 counts_per_rev`).
    pub fn validate(&self) -> Result<(), SenseError> {
        let field = |joint: usize, what: &str| format!("sensors.{} joint {} {what}", self.name, joint + 1);
        for (j, encoder) in self.encoders.iter().enumerate() {
            if let Some(counts) = encoder.counts_per_rev
                && !(counts.is_finite() && counts >= 1.0 && counts.fract() == 0.0 && counts <= 2f64.powi(40))
            {
                return Err(invalid(field(j, "counts_per_rev"), counts, "must be a whole number of counts, 1 to 2^40"));
            }
            if !(encoder.noise_counts.is_finite() && encoder.noise_counts >= 0.0) {
                return Err(invalid(field(j, "noise_counts"), encoder.noise_counts, "must be finite and >= 0"));
            }
            if encoder.noise_counts > 0.0 && encoder.counts_per_rev.is_none() {
                return Err(invalid(
                    field(j, "noise_counts"),
                    encoder.noise_counts,
                    "is in counts: give counts_per_rev",
                ));
            }
            if !(encoder.offset.is_finite() && encoder.offset.abs() <= TAU) {
                return Err(invalid(field(j, "offset"), encoder.offset, "must be finite, within ±2π rad"));
            }
        }
        if self.delay_samples > MAX_DELAY_SAMPLES {
            return Err(invalid(
                format!("sensors.{} delay_samples", self.name),
                self.delay_samples,
                format!("must be at most {MAX_DELAY_SAMPLES}"),
            ));
        }
        if let Some(noise) = &self.rate_noise
            && let Some((j, value)) = noise.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(invalid(field(j, "rate_noise"), value, "must be finite and >= 0"));
        }
        Ok(())
    }

    /// σ of each reported angle, rad ([`EncoderSpec::angle_std`]).
    pub fn angle_std(&self) -> JointVector<N> {
        JointVector::from_fn(|j, _| self.encoders[j].angle_std())
    }
}

/// The sensors of a run: the profile, its seeded noise and the delay line.
#[derive(Debug, Clone)]
pub struct Sensors<const N: usize> {
    profile: SensorProfile<N>,
    /// Per joint, the encoder's count, rad ([`EncoderSpec::resolution`]).
    resolution: [f64; N],
    rng: SeededRng,
    /// The last `delay_samples + 1` readings, oldest at `head`.
    line: [Measurement<N>; MAX_DELAY_SAMPLES + 1],
    head: usize,
}

impl<const N: usize> Sensors<N> {
    /// Sensors of `profile` whose noise is drawn from a generator seeded with `seed`.
    pub fn new(profile: SensorProfile<N>, seed: u64) -> Result<Self, SenseError> {
        profile.validate()?;
        Ok(Self::unchecked(profile, seed))
    }

    /// The exact state (the ideal profile).
    pub fn ideal() -> Self {
        Self::unchecked(SensorProfile::ideal(), 0)
    }

    fn unchecked(profile: SensorProfile<N>, seed: u64) -> Self {
        let empty = Measurement { q: JointVector::zeros(), qd: None };
        let resolution = std::array::from_fn(|j| profile.encoders[j].resolution());
        Self { profile, resolution, rng: SeededRng::new(seed), line: [empty; MAX_DELAY_SAMPLES + 1], head: 0 }
    }

    pub fn profile(&self) -> &SensorProfile<N> {
        &self.profile
    }

    /// Fills the delay line with readings of `state`, as if the arm had been there before the
    /// run (noise is drawn for each). Returns a reading of `state`: with a delay, the one
    /// delivered at the first sample (the slot after the one [`Sensors::measure`] fills first).
    pub fn reset(&mut self, state: &JointState<N>) -> Measurement<N> {
        self.head = 0;
        let delay = self.profile.delay_samples;
        for k in 0..=delay {
            self.read_into(state, k);
        }
        self.line[1 % (delay + 1)]
    }

    /// One sample: reads `state` now and returns the reading of `delay_samples` samples ago.
    pub fn measure(&mut self, state: &JointState<N>) -> Measurement<N> {
        let delay = self.profile.delay_samples;
        // The line holds the readings of the last delay + 1 samples: the newest replaces the
        // oldest, and the one after it, `delay` samples old, is the one due now. (Read into
        // its slot in place: a reading returned and then copied there was loaded right after
        // its entries' stores, and waited on them.)
        self.read_into(state, self.head);
        if delay == 0 {
            return self.line[self.head];
        }
        self.head = if self.head == delay { 0 } else { self.head + 1 };
        self.line[self.head]
    }

    /// The reading of `state` now, without delay, into slot `slot` of the line.
    fn read_into(&mut self, state: &JointState<N>, slot: usize) {
        let Self { profile, resolution, rng, line, .. } = self;
        let out = &mut line[slot];
        for j in 0..N {
            let encoder = &profile.encoders[j];
            let angle = state.q[j] + encoder.offset;
            out.q[j] = match encoder.counts_per_rev {
                None => angle,
                Some(_) => {
                    let resolution = resolution[j];
                    let noise = if encoder.noise_counts > 0.0 { encoder.noise_counts * rng.normal() } else { 0.0 };
                    resolution * crate::lanes::round(angle / resolution + noise)
                }
            };
        }
        out.qd = profile.rate_noise.map(|noise| {
            let mut qd = state.qd;
            for j in 0..N {
                if noise[j] > 0.0 {
                    qd[j] += noise[j] * rng.normal();
                }
            }
            qd
        });
    }
}
