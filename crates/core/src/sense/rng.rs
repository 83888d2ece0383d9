//! The seeded random numbers of sensor noise and model draws: xoshiro256++ (Blackman & Vigna,
//! "Scrambled linear pseudorandom number generators", 2021) seeded through SplitMix64, and
//! standard normal deviates by the Box–Muller transform. Small, fast, and the same sequence on
//! every thread count: a run's randomness is a function of its seed alone. The transform's
//! logarithm, sine and cosine are [`crate::lanes::ln`] and [`crate::lanes::sin_cos`], not the
//! C library's (which picks its code by the CPU): the same bits on every machine, and in SIMD
//! lanes ([`RngLanes`]: `L` generators side by side) as one at a time.

use crate::lanes::{Lanes, Real, TWO_52};

/// SplitMix64's output function on `state` (Steele, Lea & Flood 2014): a bijective mix of 64
/// bits, used to seed xoshiro and to derive the seed of trial `k` from a study's seed.
pub fn split_mix(state: u64) -> u64 {
    let mut z = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of item `index` (a trial, a stream) of a study seeded with `seed`: independent of
/// how the items are split between threads or shards.
pub fn derive_seed(seed: u64, index: u64) -> u64 {
    split_mix(split_mix(seed) ^ split_mix(index.wrapping_add(0x6A09_E667_F3BC_C909)))
}

/// xoshiro256++ with a cached second Box–Muller deviate.
#[derive(Debug, Clone, PartialEq)]
pub struct SeededRng {
    state: [u64; 4],
    spare_normal: Option<f64>,
}

impl SeededRng {
    /// A generator whose whole sequence is fixed by `seed`.
    pub fn new(seed: u64) -> Self {
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            split_mix(s.wrapping_sub(0x9E37_79B9_7F4A_7C15))
        };
        Self { state: [next(), next(), next(), next()], spare_normal: None }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let [s0, s1, s2, s3] = &mut self.state;
        xoshiro_step(s0, s1, s2, s3)
    }

    /// Uniform on [0, 1), 53 random bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform on [low, high).
    pub fn uniform(&mut self, low: f64, high: f64) -> f64 {
        low + (high - low) * self.unit()
    }

    /// A standard normal deviate (mean 0, σ 1): Box–Muller, `√(−2 ln u₁) (cos, sin)(2π u₂)`
    /// with `u₁ ∈ (0, 1]`; the second of each pair is kept for the next call.
    pub fn normal(&mut self) -> f64 {
        if let Some(spare) = self.spare_normal.take() {
            return spare;
        }
        let u1 = 1.0 - self.unit();
        let u2 = self.unit();
        let (first, second) = box_muller(u1, u2);
        self.spare_normal = Some(second);
        first
    }
}

/// One step of xoshiro256++ on its four words of state: returns the output and advances them.
#[inline(always)]
fn xoshiro_step(s0: &mut u64, s1: &mut u64, s2: &mut u64, s3: &mut u64) -> u64 {
    let result = s0.wrapping_add(*s3).rotate_left(23).wrapping_add(*s0);
    let t = *s1 << 17;
    *s2 ^= *s0;
    *s3 ^= *s1;
    *s1 ^= *s2;
    *s0 ^= *s3;
    *s2 ^= t;
    *s3 = s3.rotate_left(45);
    result
}

/// Two independent standard normal deviates from two uniform ones, `u₁ ∈ (0, 1]` and
/// `u₂ ∈ [0, 1)`: `√(−2 ln u₁) (cos 2πu₂, sin 2πu₂)` (Box & Muller 1958).
#[inline(always)]
fn box_muller<S: Real>(u1: S, u2: S) -> (S, S) {
    let radius = (S::splat(-2.0) * u1.ln()).sqrt();
    let (sin, cos) = (S::splat(std::f64::consts::TAU) * u2).sin_cos();
    (radius * cos, radius * sin)
}

/// `L` [`SeededRng`]s side by side, each lane's sequence its generator's, bit for bit: for
/// `L` runs that draw the same number of deviates at each step (a batch's sensors).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RngLanes<const L: usize> {
    state: [[u64; L]; 4],
    /// The lanes' second Box–Muller deviates, where they have one (all or none: the lanes draw
    /// alike).
    spare_normal: Option<Lanes<L>>,
}

impl<const L: usize> RngLanes<L> {
    /// The generators side by side, if their spare deviates are all there or all not.
    pub fn of(generators: [&SeededRng; L]) -> Option<Self> {
        let spare = generators[0].spare_normal.is_some();
        if generators.iter().any(|g| g.spare_normal.is_some() != spare) {
            return None;
        }
        Some(Self {
            state: std::array::from_fn(|k| generators.map(|g| g.state[k])),
            spare_normal: spare.then(|| Lanes(generators.map(|g| g.spare_normal.unwrap_or(0.0)))),
        })
    }

    /// Lane `i`'s generator, as it is now.
    pub fn lane(&self, i: usize) -> SeededRng {
        SeededRng { state: self.state.map(|s| s[i]), spare_normal: self.spare_normal.map(|spare| spare.0[i]) }
    }

    /// Every lane's next 53 bits as a uniform on [0, 1) ([`SeededRng::unit`]).
    #[inline(always)]
    fn unit(&mut self) -> Lanes<L> {
        let [s0, s1, s2, s3] = &mut self.state;
        let mut unit = [0.0; L];
        for i in 0..L {
            let result = xoshiro_step(&mut s0[i], &mut s1[i], &mut s2[i], &mut s3[i]);
            unit[i] = whole_53(result >> 11) * (1.0 / (1u64 << 53) as f64);
        }
        Lanes(unit)
    }

    /// Every lane's next standard normal deviate ([`SeededRng::normal`]).
    #[inline(always)]
    pub fn normal(&mut self) -> Lanes<L> {
        if let Some(spare) = self.spare_normal.take() {
            return spare;
        }
        let u1 = Lanes::splat(1.0) - self.unit();
        let u2 = self.unit();
        let (first, second) = box_muller(u1, u2);
        self.spare_normal = Some(second);
        first
    }
}

/// `n as f64` for `n < 2⁵³` (exact, so the same as the conversion), from two halves of 32 and 21
/// bits placed in the significands of 2⁵² and 2⁸⁴: bit operations and two exact subtractions
/// and an exact sum, which vectorise where x86-64 before AVX-512 has no packed conversion.
#[inline(always)]
fn whole_53(n: u64) -> f64 {
    const TWO_84: f64 = 19_342_813_113_834_066_795_298_816.0;
    let low = f64::from_bits(TWO_52.to_bits() | (n & 0xffff_ffff)) - TWO_52;
    let high = f64::from_bits(TWO_84.to_bits() | (n >> 32)) - TWO_84;
    high + low
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_53_is_the_conversion() {
        let mut rng = SeededRng::new(3);
        let edges = [0, 1, (1 << 32) - 1, 1 << 32, (1 << 53) - 1, 1 << 52, 0xffff_ffff_0000_0000 >> 11];
        for n in edges.into_iter().chain((0..100_000).map(|_| rng.next_u64() >> 11)) {
            assert_eq!(whole_53(n).to_bits(), (n as f64).to_bits(), "{n}");
        }
    }

    /// Eight generators side by side draw each lane's own sequence, bit for bit, whether they
    /// start with a spare deviate or not; generators that differ in having one are refused.
    #[test]
    fn lanes_draw_each_generators_sequence() {
        for start_with_spare in [false, true] {
            let mut alone: Vec<SeededRng> = (0..8).map(|seed| SeededRng::new(seed * 77 + 5)).collect();
            if start_with_spare {
                alone.iter_mut().for_each(|g| _ = g.normal());
            }
            let mut lanes = RngLanes::<8>::of(std::array::from_fn(|i| &alone[i])).unwrap();
            for draw in 0..10_001 {
                let side_by_side = lanes.normal();
                for (i, g) in alone.iter_mut().enumerate() {
                    assert_eq!(side_by_side.0[i].to_bits(), g.normal().to_bits(), "draw {draw}, lane {i}");
                }
            }
            for (i, g) in alone.iter().enumerate() {
                assert_eq!(&lanes.lane(i), g);
            }
        }
        let (mut a, b) = (SeededRng::new(1), SeededRng::new(2));
        a.normal();
        assert!(RngLanes::<4>::of([&a, &b, &b, &b]).is_none());
    }

    /// The deviates are standard normal: over 10⁶, mean within 5σ/√n of 0, variance within
    /// 5·√(2/n) of 1, and the fraction beyond ±1.96 within 5 standard errors of 5 %.
    #[test]
    fn deviates_are_standard_normal() {
        let mut rng = SeededRng::new(42);
        let n = 1_000_000;
        let draws: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let nf = n as f64;
        let mean = draws.iter().sum::<f64>() / nf;
        let variance = draws.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / nf;
        let beyond = draws.iter().filter(|x| x.abs() > 1.959_963_984_540_054).count() as f64 / nf;
        assert!(mean.abs() < 5.0 / nf.sqrt(), "mean {mean}");
        assert!((variance - 1.0).abs() < 5.0 * (2.0 / nf).sqrt(), "variance {variance}");
        assert!((beyond - 0.05).abs() < 5.0 * (0.05f64 * 0.95 / nf).sqrt(), "beyond {beyond}");
    }
}
