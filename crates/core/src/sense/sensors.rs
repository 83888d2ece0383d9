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

use super::rng::{RngLanes, SeededRng};
use super::{Measurement, SenseError, invalid};
use crate::arm::model::JointVector;
use crate::control::JointState;
use crate::lanes::{Lanes, Real, array4};
use crate::short_number as short;
use std::f64::consts::TAU;

/// Longest measurement delay a profile may have, samples.
pub const MAX_DELAY_SAMPLES: usize = 64;

/// Largest σ of a rate sensor, rad/s: 1000 rad/s is ten thousand revolutions a minute, faster
/// than any joint turns; the Kalman filter's Riccati equation squares it.
pub const MAX_RATE_NOISE: f64 = 1.0e3;

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
                return Err(invalid(field(j, "noise_counts"), short(encoder.noise_counts), "must be finite and >= 0"));
            }
            if let Some(counts) = encoder.counts_per_rev
                && encoder.noise_counts > counts
            {
                return Err(invalid(
                    field(j, "noise_counts"),
                    short(encoder.noise_counts),
                    format!("a σ beyond one turn ({} counts) says nothing of the angle", short(counts)),
                ));
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
            return Err(invalid(field(j, "rate_noise"), short(*value), "must be finite and >= 0"));
        }
        if let Some(noise) = &self.rate_noise
            && let Some((j, value)) = noise.iter().enumerate().find(|(_, v)| **v > MAX_RATE_NOISE)
        {
            return Err(invalid(
                field(j, "rate_noise"),
                short(*value),
                format!("a σ beyond {} rad/s is faster than any joint turns", short(MAX_RATE_NOISE)),
            ));
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
                    // Ours, not `f64::round` (a library call on x86-64): the same bits.
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

/// One sample's readings of `L` runs' sensors side by side: the angles (rad) and the rates
/// (rad/s; NaN without a velocity sensor).
pub(crate) type ReadingLanes<const L: usize> = ([Lanes<L>; 4], [Lanes<L>; 4]);

/// The sensors of `L` runs side by side, for a batch whose runs' sensors draw alike: the same
/// delay, the same joints quantised and noisy, a velocity sensor on all or none, with the same
/// joints noisy. The counts, noise levels, offsets and seeds are each lane's own. Each lane
/// reads what its run's [`Sensors`] would, bit for bit: the same operations in the same order,
/// its generator's deviates ([`RngLanes`]).
#[derive(Debug, Clone)]
pub(crate) struct SensorLanes<const L: usize> {
    /// Per joint, whether the encoder quantises, and whether it adds noise before.
    quantised: [bool; 4],
    noisy: [bool; 4],
    /// Per joint, whether the velocity sensor adds noise; `None`: no velocity sensor.
    noisy_rate: Option<[bool; 4]>,
    /// Per joint, one count (rad), the noise σ (counts), the calibration offset (rad) and the
    /// velocity sensor's σ (rad/s).
    resolution: [Lanes<L>; 4],
    noise_counts: [Lanes<L>; 4],
    offset: [Lanes<L>; 4],
    rate_noise: [Lanes<L>; 4],
    rng: RngLanes<L>,
    /// The last `delay_samples + 1` readings, oldest at `head` ([`Sensors`]' line).
    line: Vec<ReadingLanes<L>>,
    head: usize,
}

impl<const L: usize> SensorLanes<L> {
    /// The sensors of `sensors` side by side (lane `i` is `sensors[i]`; a lane without copies
    /// the first's, and its readings are not read), if there is one and they draw alike, are
    /// at the same place in their delay lines, and their generators hold a spare deviate in all
    /// or none ([`RngLanes::of`]).
    pub fn of(sensors: [Option<&Sensors<4>>; L]) -> Option<Self> {
        let first = *sensors.iter().flatten().next()?;
        let shape = |s: &Sensors<4>| {
            let profile = &s.profile;
            (
                profile.delay_samples,
                s.head,
                profile.encoders.map(|e| (e.counts_per_rev.is_some(), e.noise_counts > 0.0)),
                profile.rate_noise.map(|noise| noise.map(|v| v > 0.0)),
            )
        };
        let (delay, head, encoders, noisy_rate) = shape(first);
        if sensors.iter().flatten().any(|s| shape(s) != (delay, head, encoders, noisy_rate)) {
            return None;
        }
        let lane = |i: usize| sensors[i].unwrap_or(first);
        let rng = RngLanes::of(std::array::from_fn(|i| &lane(i).rng))?;
        let lanes = |f: &dyn Fn(&Sensors<4>, usize) -> f64| array4(|j| Lanes(std::array::from_fn(|i| f(lane(i), j))));
        let line = (0..=delay)
            .map(|k| {
                let reading = |i: usize| &lane(i).line[k];
                (
                    array4(|j| Lanes(std::array::from_fn(|i| reading(i).q[j]))),
                    array4(|j| Lanes(std::array::from_fn(|i| reading(i).qd.map_or(f64::NAN, |qd| qd[j])))),
                )
            })
            .collect();
        Some(Self {
            quantised: encoders.map(|(quantised, _)| quantised),
            noisy: encoders.map(|(_, noisy)| noisy),
            noisy_rate: noisy_rate.map(Into::into),
            resolution: lanes(&|s, j| s.resolution[j]),
            noise_counts: lanes(&|s, j| s.profile.encoders[j].noise_counts),
            offset: lanes(&|s, j| s.profile.encoders[j].offset),
            rate_noise: lanes(&|s, j| s.profile.rate_noise.map_or(0.0, |noise| noise[j])),
            rng,
            line,
            head,
        })
    }

    /// One sample of every lane: reads `(q, qd)` now (rad, rad/s) and returns the readings of
    /// `delay_samples` samples ago ([`Sensors::measure`]).
    #[inline(always)]
    pub fn measure(&mut self, (q, qd): (&[Lanes<L>; 4], &[Lanes<L>; 4])) -> ReadingLanes<L> {
        let delay = self.line.len() - 1;
        let reading = self.read(q, qd);
        self.line[self.head] = reading;
        if delay == 0 {
            return reading;
        }
        self.head = if self.head == delay { 0 } else { self.head + 1 };
        self.line[self.head]
    }

    /// Every lane's reading of `(q, qd)` now, without delay ([`Sensors`]' `read_into`: the
    /// angles joint by joint, then the rates, each drawing its deviates in that order).
    #[inline(always)]
    fn read(&mut self, q: &[Lanes<L>; 4], qd: &[Lanes<L>; 4]) -> ReadingLanes<L> {
        let mut angles = [Lanes::splat(0.0); 4];
        for j in 0..4 {
            let angle = q[j] + self.offset[j];
            angles[j] = if self.quantised[j] {
                let noise = if self.noisy[j] { self.noise_counts[j] * self.rng.normal() } else { Lanes::splat(0.0) };
                self.resolution[j] * (angle / self.resolution[j] + noise).round()
            } else {
                angle
            };
        }
        let rates = match self.noisy_rate {
            None => [Lanes::splat(f64::NAN); 4],
            Some(noisy) => {
                let mut rates = *qd;
                for j in 0..4 {
                    if noisy[j] {
                        rates[j] += self.rate_noise[j] * self.rng.normal();
                    }
                }
                rates
            }
        };
        (angles, rates)
    }

    /// Hands lane `i`'s generator and delay line back to `sensors` (its run's), as they would
    /// be had it read alone.
    pub fn hand_back(&self, i: usize, sensors: &mut Sensors<4>) {
        sensors.rng = self.rng.lane(i);
        sensors.head = self.head;
        for (slot, (q, qd)) in sensors.line.iter_mut().zip(&self.line) {
            *slot = Measurement {
                q: JointVector::from_fn(|j, _| q[j].get(i)),
                qd: self.noisy_rate.map(|_| JointVector::from_fn(|j, _| qd[j].get(i))),
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Profiles of every shape (exact, quantised, noisy encoders; no, exact and noisy rate
    /// sensors; delays 0 to 3), each lane with its own counts, noise, offsets and seed: the
    /// lanes read what each lane's sensors read alone, sample by sample, and hand back the state
    /// those are left in. Sensors that do not draw alike are refused.
    #[test]
    fn lanes_read_what_each_lanes_sensors_read() {
        let mut rng = SeededRng::new(9);
        for case in 0..24 {
            let delay = case % 4;
            let kinds: [usize; 4] = std::array::from_fn(|j| (case / 4 + j) % 3);
            let rates = match case % 3 {
                0 => None,
                1 => Some([0.0; 4]),
                _ => Some([0.02, 0.0, 0.01, 0.03]),
            };
            let mut alone: Vec<Sensors<4>> = (0..8u32)
                .map(|i| {
                    let scale = 1.0 + 0.3 * f64::from(i);
                    let encoders = std::array::from_fn(|j| match kinds[j] {
                        0 => EncoderSpec { offset: 1e-3 * scale, ..EncoderSpec::EXACT },
                        1 => EncoderSpec { offset: -2e-4 * scale, ..EncoderSpec::counts(1024.0 * scale.round(), 0.0) },
                        _ => EncoderSpec::counts(4096.0, 0.2 * scale),
                    });
                    let profile = SensorProfile {
                        name: format!("case {case}"),
                        encoders,
                        delay_samples: delay,
                        rate_noise: rates.map(|r| JointVector::from(r) * scale),
                    };
                    Sensors::new(profile, 100 * case as u64 + u64::from(i)).unwrap()
                })
                .collect();
            let start = JointState { q: JointVector::from([0.1, -0.4, 1.2, 0.3]), qd: JointVector::repeat(0.2) };
            for sensors in &mut alone {
                sensors.reset(&start);
            }
            let mut lanes = SensorLanes::<8>::of(std::array::from_fn(|i| Some(&alone[i]))).unwrap();
            for sample in 0..300 {
                let states: Vec<JointState<4>> = (0..8)
                    .map(|_| JointState {
                        q: JointVector::from_fn(|_, _| rng.uniform(-3.0, 3.0)),
                        qd: JointVector::from_fn(|_, _| rng.uniform(-2.0, 2.0)),
                    })
                    .collect();
                let q = array4(|j| Lanes(std::array::from_fn(|i| states[i].q[j])));
                let qd = array4(|j| Lanes(std::array::from_fn(|i| states[i].qd[j])));
                let (angles, rates) = lanes.measure((&q, &qd));
                for (i, sensors) in alone.iter_mut().enumerate() {
                    let reading = sensors.measure(&states[i]);
                    for j in 0..4 {
                        assert_eq!(angles[j].get(i).to_bits(), reading.q[j].to_bits(), "case {case}, sample {sample}");
                        let rate = reading.qd.map_or(f64::NAN, |qd| qd[j]);
                        assert_eq!(rates[j].get(i).to_bits(), rate.to_bits(), "case {case}, sample {sample}");
                    }
                }
            }
            for (i, sensors) in alone.iter().enumerate() {
                let mut handed = Sensors::new(sensors.profile.clone(), 0).unwrap();
                lanes.hand_back(i, &mut handed);
                assert_eq!(format!("{handed:?}"), format!("{sensors:?}"), "case {case}, lane {i}");
            }
        }
        // Shapes that differ: a delay, a noisy encoder against a quiet one, a velocity sensor
        // against none, a noisy rate against an exact one, the place in the delay line.
        let base = SensorProfile::<4>::hobby();
        let sensors = |edit: &dyn Fn(&mut SensorProfile<4>)| {
            let mut profile = base.clone();
            edit(&mut profile);
            Sensors::new(profile, 1).unwrap()
        };
        let a = sensors(&|_| {});
        let with_rate = sensors(&|p| p.rate_noise = Some(JointVector::repeat(0.01)));
        let others =
            [sensors(&|p| p.delay_samples = 2), sensors(&|p| p.encoders[2].noise_counts = 0.0), with_rate.clone()];
        for other in &others {
            assert!(SensorLanes::<4>::of([Some(&a), None, Some(other), None]).is_none());
        }
        let exact_rate = sensors(&|p| p.rate_noise = Some(JointVector::from([0.01, 0.0, 0.01, 0.01])));
        assert!(SensorLanes::<4>::of([Some(&with_rate), Some(&exact_rate), None, None]).is_none());
        let mut moved = a.clone();
        moved.measure(&JointState::at_rest(JointVector::zeros()));
        assert!(SensorLanes::<4>::of([Some(&a), Some(&moved), None, None]).is_none());
        assert!(
            SensorLanes::<4>::of([None, Some(&a), None, Some(&sensors(&|p| p.encoders[0].offset = 0.1))]).is_some()
        );
        assert!(SensorLanes::<4>::of([None; 4]).is_none());
    }
}
