//! The seeded random numbers of sensor noise and model draws: xoshiro256++ (Blackman & Vigna,
//! "Scrambled linear pseudorandom number generators", 2021) seeded through SplitMix64, and
//! standard normal deviates by the Box–Muller transform. Small, fast, and the same sequence on
//! every thread count: a run's randomness is a function of its seed alone. The transform's
//! sine and cosine are [`crate::lanes::sin_cos`] (the same bits on every machine); its
//! logarithm is the C library's, correctly rounded in glibc's current versions but not promised
//! to give the same bits on every machine.

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
        let s = &mut self.state;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
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
        let radius = (-2.0 * u1.ln()).sqrt();
        // Our own sine and cosine (the same bits on every machine; the C library's pick their
        // code by the CPU) and faster than the C library's here.
        let (sin, cos) = crate::lanes::sin_cos(std::f64::consts::TAU * u2);
        self.spare_normal = Some(radius * sin);
        radius * cos
    }
}
