//! Numbers that are one `f64` or `L` of them side by side (SIMD lanes), for kernels written
//! once and run on a single simulation or on `L` independent ones at a time.
//!
//! Every operation of [`Lanes`] is the same IEEE-754 operation on each lane as on a lone `f64`
//! (`+ − × ÷`, no fused multiply–add: Rust never contracts `a * b + c`, whatever the target's
//! features), so a lane's result equals, bit for bit, the scalar kernel's for the same inputs,
//! at any SIMD width the compiler picks. The sines and cosines are computed here too
//! ([`sin_cos`]), by a polynomial in those operations, rather than by the C library, whose
//! result may depend on the CPU it dispatches to.

use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// `[f(0), f(1), f(2), f(3)]`, always inlined (`std::array::from_fn` is not always).
#[inline(always)]
pub fn array4<S>(f: impl Fn(usize) -> S) -> [S; 4] {
    [f(0), f(1), f(2), f(3)]
}

/// `[f(0), f(1), f(2)]`, always inlined.
#[inline(always)]
pub fn array3<S>(f: impl Fn(usize) -> S) -> [S; 3] {
    [f(0), f(1), f(2)]
}

/// A number the kernels compute with: `f64` (one run) or [`Lanes`] (`L` runs).
pub trait Real:
    Copy
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
{
    /// How many runs side by side.
    const LANES: usize;
    /// The same value in every lane.
    fn splat(value: f64) -> Self;
    /// Lane `i` of `LANES`.
    fn lane(&self, i: usize) -> f64;
    /// Lane `i` is `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    /// `(sin x, cos x)` by [`sin_cos`], lane by lane.
    fn sin_cos(self) -> (Self, Self);
    /// `ln x` by [`ln`], lane by lane.
    fn ln(self) -> Self;
    /// `x` to the nearest whole number, halves away from zero, by [`round`], lane by lane.
    #[inline(always)]
    fn round(self) -> Self {
        self.each(round)
    }
    /// The lanes where `f` of the lane pair holds, bit `i` for lane `i`: all lanes at once,
    /// without branches, so that the comparisons vectorise.
    fn lanes_where2(self, other: Self, f: impl Fn(f64, f64) -> bool) -> u64;
    /// The lanes where `f` holds, bit `i` for lane `i` ([`Real::lanes_where2`]).
    #[inline(always)]
    fn lanes_where(self, f: impl Fn(f64) -> bool) -> u64 {
        self.lanes_where2(self, |a, _| f(a))
    }
    /// `f` of each lane (one IEEE operation of `f64`'s for a result equal bit for bit).
    #[inline(always)]
    fn each(self, f: impl Fn(f64) -> f64) -> Self {
        Self::from_fn(|i| f(self.lane(i)))
    }
    /// `f(a, b)` of each lane pair.
    #[inline(always)]
    fn each2(self, other: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        Self::from_fn(|i| f(self.lane(i), other.lane(i)))
    }
    /// `|x|`, lane by lane.
    #[inline(always)]
    fn abs(self) -> Self {
        self.each(f64::abs)
    }
    /// `√x` (IEEE, correctly rounded), lane by lane.
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.each(f64::sqrt)
    }
    /// `f64::max` of each lane pair (a NaN loses to a number).
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        self.each2(other, f64::max)
    }
    /// `a` where `a ≥ b`, else `b`, lane by lane: nalgebra's `sup` (a NaN in `a` gives `b`,
    /// in `b` gives `b`; `+0` against `−0` keeps `a`), which the scalar metrics use.
    #[inline(always)]
    fn sup(self, other: Self) -> Self {
        self.each2(other, |a, b| if a >= b { a } else { b })
    }
    /// `(sin δ, cos δ)` of a small angle by [`small_angle_sin_cos`] (|δ| ≤ 0.05 rad).
    fn small_sin_cos(self) -> (Self, Self) {
        let c = Self::splat;
        // Estrin's scheme in δ²: the two halves of each polynomial side by side.
        let d2 = self * self;
        let d4 = d2 * d2;
        let sin_tail = (c(-1.0 / 6.0) + d2 * c(1.0 / 120.0)) + d4 * (c(-1.0 / 5040.0) + d2 * c(1.0 / 362_880.0));
        let cos_tail = (c(-0.5) + d2 * c(1.0 / 24.0)) + d4 * (c(-1.0 / 720.0) + d2 * c(1.0 / 40_320.0));
        (self + (self * d2) * sin_tail, c(1.0) + d2 * cos_tail)
    }
}

impl Real for f64 {
    const LANES: usize = 1;

    #[inline(always)]
    fn splat(value: f64) -> Self {
        value
    }

    #[inline(always)]
    fn lane(&self, _i: usize) -> f64 {
        *self
    }

    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
        f(0)
    }

    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        sin_cos(self)
    }

    #[inline(always)]
    fn ln(self) -> Self {
        ln(self)
    }

    #[inline(always)]
    fn lanes_where2(self, other: Self, f: impl Fn(f64, f64) -> bool) -> u64 {
        u64::from(f(self, other))
    }
}

/// `(sin δ, cos δ)` for a small angle δ (rad) by their Taylor series up to δ⁹ and δ⁸, by
/// Estrin's scheme in δ² (multiplications only; two products deep where Horner's form is four:
/// every integrator stage waits for it). For |δ| ≤ 0.05 rad the first omitted terms, δ¹¹/11!
/// and δ¹⁰/10!, are below 3·10⁻²⁰: exact to rounding.
#[inline(always)]
pub fn small_angle_sin_cos(d: f64) -> (f64, f64) {
    d.small_sin_cos()
}

/// `L` numbers side by side, one per independent run.
///
/// Aligned to 64 bytes, a cache line: an AVX-512 register of 8 lanes then loads and stores
/// within one line. At the default 8-byte alignment most of the kernels' 512-bit stores
/// split across two lines; measured on a 2-vCPU Xeon (Emerald Rapids), a 16 × 16 sweep on one
/// thread took 834 ms split and 689 ms aligned, and the AVX2 batches of 4 lanes (padded to
/// 64 bytes) 848 and 836 ms. The arithmetic, and so every result, is the same.
#[derive(Clone, Copy, PartialEq)]
#[repr(align(64))]
pub struct Lanes<const L: usize>(pub [f64; L]);

impl<const L: usize> std::fmt::Debug for Lanes<L> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl<const L: usize> Lanes<L> {
    /// Lane `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> f64 {
        self.0[i]
    }

    /// Each lane through `f`.
    #[inline(always)]
    pub fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Self(self.0.map(f))
    }
}

macro_rules! lane_op {
    ($trait:ident, $method:ident, $assign_trait:ident, $assign:ident, $op:tt) => {
        impl<const L: usize> $trait for Lanes<L> {
            type Output = Self;
            #[inline(always)]
            #[allow(clippy::assign_op_pattern)] // one macro for the three operators
            fn $method(self, other: Self) -> Self {
                let mut out = self.0;
                for (a, b) in out.iter_mut().zip(other.0) {
                    *a = *a $op b;
                }
                Self(out)
            }
        }
        impl<const L: usize> $assign_trait for Lanes<L> {
            #[inline(always)]
            #[allow(clippy::assign_op_pattern)] // this is the assign operation
            fn $assign(&mut self, other: Self) {
                *self = *self $op other;
            }
        }
    };
}

lane_op!(Add, add, AddAssign, add_assign, +);
lane_op!(Sub, sub, SubAssign, sub_assign, -);
lane_op!(Mul, mul, MulAssign, mul_assign, *);

impl<const L: usize> Div for Lanes<L> {
    type Output = Self;
    #[inline(always)]
    fn div(self, other: Self) -> Self {
        let mut out = self.0;
        for (a, b) in out.iter_mut().zip(other.0) {
            *a /= b;
        }
        Self(out)
    }
}

impl<const L: usize> Neg for Lanes<L> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self(self.0.map(|a| -a))
    }
}

impl<const L: usize> Real for Lanes<L> {
    const LANES: usize = L;

    #[inline(always)]
    fn splat(value: f64) -> Self {
        Self([value; L])
    }

    #[inline(always)]
    fn lane(&self, i: usize) -> f64 {
        self.0[i]
    }

    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
        // A loop rather than `std::array::from_fn`, which is not always inlined.
        let mut out = [0.0; L];
        for (i, slot) in out.iter_mut().enumerate() {
            *slot = f(i);
        }
        Self(out)
    }

    #[inline(always)]
    fn lanes_where2(self, other: Self, f: impl Fn(f64, f64) -> bool) -> u64 {
        // Each lane's bit in a lane of its own, then one OR over the lanes: the comparisons,
        // shifts and the reduction vectorise (a loop that ORs into one word does not).
        let mut bits = [0u64; L];
        for (i, bit) in bits.iter_mut().enumerate() {
            *bit = u64::from(f(self.0[i], other.0[i])) << i;
        }
        bits.into_iter().fold(0, |all, bit| all | bit)
    }

    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        // The same steps as the scalar `sin_cos`, the polynomial on all lanes at once.
        let mut quadrant = [0u64; L];
        let mut reduced = self.0;
        for i in 0..L {
            let k;
            (k, quadrant[i]) = quadrant_of(self.0[i]);
            reduced[i] = reduce(self.0[i], k);
        }
        let (sin, cos) = reduced_sin_cos(Self(reduced));
        let (mut out_sin, mut out_cos) = (sin.0, cos.0);
        for i in 0..L {
            (out_sin[i], out_cos[i]) = within_limit(self.0[i], by_quadrant(sin.0[i], cos.0[i], quadrant[i]));
        }
        (Self(out_sin), Self(out_cos))
    }

    #[inline(always)]
    fn ln(self) -> Self {
        // The same steps as the scalar `ln`, the polynomial on all lanes at once.
        let (mut k, mut f) = (self.0, self.0);
        for i in 0..L {
            (k[i], f[i]) = log_parts(self.0[i]);
        }
        let log = log_of_parts(Self(k), Self(f));
        let mut out = log.0;
        for (out, x) in out.iter_mut().zip(self.0) {
            *out = log_special(x, *out);
        }
        Self(out)
    }
}

// π/2 in three parts of 33 bits each (fdlibm's `pio2_1`, `pio2_2`, `pio2_3`): `k · part` is
// exact for |k| < 2²⁰, so the reduced angle is accurate to ~10⁻²¹ rad there.
const PIO2_1: f64 = 1.570_796_326_734_125_6;
const PIO2_2: f64 = 6.077_100_506_303_966e-11;
const PIO2_3: f64 = 2.022_266_248_711_166_5e-21;

/// 1.5 · 2⁵²: adding and subtracting it rounds a float below 2⁵¹ in magnitude to the nearest
/// integer (ties to even), in two additions (`round_ties_even` is a library call on x86-64's
/// baseline, which has no rounding instruction).
const ROUNDER: f64 = 6_755_399_441_055_744.0;

/// The nearest multiple `k` of π/2 to `x`, as a float, and `y = x·2/π + 1.5·2⁵²`, whose bits
/// hold `k` (two's complement) in the low bits of its significand for |k| < 2⁵¹: `y` lies in
/// [2⁵², 2⁵³), where the significand's unit is 1, so `y = 2⁵² + 2⁵¹ + k` exactly.
#[inline(always)]
fn quadrant_of(x: f64) -> (f64, u64) {
    let y = x * std::f64::consts::FRAC_2_PI + ROUNDER;
    (y - ROUNDER, y.to_bits())
}

/// `x − k π/2`, |result| ≤ π/4 (+ rounding), by Cody and Waite's three-part subtraction.
#[inline(always)]
fn reduce(x: f64, k: f64) -> f64 {
    ((x - k * PIO2_1) - k * PIO2_2) - k * PIO2_3
}

/// `(sin r, cos r)` for |r| ≤ π/4 by Taylor polynomials to r¹⁷ and r¹⁶ in `z = r²`, evaluated
/// by Estrin's scheme (pairs, then pairs of pairs with `z²`, `z⁴`): three products deep where
/// Horner's form is seven (one run ~1.5 % faster with both polynomials so, near this VM's
/// noise). The first omitted terms are below 10⁻¹⁹ and 2·10⁻¹⁸ there.
#[inline(always)]
fn reduced_sin_cos<S: Real>(r: S) -> (S, S) {
    let c = S::splat;
    let z = r * r;
    let z2 = z * z;
    let z4 = z2 * z2;
    let sin_tail = ((c(-1.0 / 6.0) + z * c(1.0 / 120.0)) + z2 * (c(-1.0 / 5040.0) + z * c(1.0 / 362_880.0)))
        + z4 * ((c(-1.0 / 39_916_800.0) + z * c(1.0 / 6_227_020_800.0))
            + z2 * (c(-1.0 / 1_307_674_368_000.0) + z * c(1.0 / 355_687_428_096_000.0)));
    let cos_tail = ((c(1.0 / 24.0) + z * c(-1.0 / 720.0)) + z2 * (c(1.0 / 40_320.0) + z * c(-1.0 / 3_628_800.0)))
        + z4 * ((c(1.0 / 479_001_600.0) + z * c(-1.0 / 87_178_291_200.0)) + z2 * c(1.0 / 20_922_789_888_000.0));
    let sin = r + (r * z) * sin_tail;
    let cos = (c(1.0) - z * c(0.5)) + z2 * cos_tail;
    (sin, cos)
}

/// `(sin x, cos x)` from those of `r = x − k π/2`: by `k mod 4` (the low bits of `y`, from
/// [`quadrant_of`]), `(s, c)`, `(c, −s)`, `(−s, −c)`, `(−c, s)`. Integer operations on the
/// bits alone (a swap by masks and two sign flips, as IEEE negation does them, on the sign
/// bit), so that lanes vectorise (x86-64 before AVX-512 has no packed float-to-integer
/// conversion); a NaN or infinite `x` is NaN already.
#[inline(always)]
fn by_quadrant(sin: f64, cos: f64, y: u64) -> (f64, f64) {
    let swap = 0u64.wrapping_sub(y & 1); // all ones for odd k
    let (s, c) = (sin.to_bits(), cos.to_bits());
    let (a, b) = ((s & !swap) | (c & swap), (c & !swap) | (s & swap));
    let sin_sign = (y & 2) << 62;
    let cos_sign = (y.wrapping_add(1) & 2) << 62;
    (f64::from_bits(a ^ sin_sign), f64::from_bits(b ^ cos_sign))
}

/// `(sin x, cos x)` for |x| ≤ [`SIN_COS_LIMIT`] (joint angles are a few radians): within 2 ulp
/// of the C library's where |sin|, |cos| ≥ 0.25, and within 2·2⁻⁵² absolutely nearer their
/// zeros (where ulps are finer: at 3π/2 the cosine is 10 ulp from the rounded value), by
/// Cody–Waite reduction to |r| ≤ π/4 and Taylor polynomials; NaN beyond it (and for NaN and
/// ±∞): there the promise fails (at 10⁷ rad the error is ~10⁻⁹), and past ~3.5·10¹⁵ rad the
/// reduction gives numbers that are not sines at all.
/// Pure `+ − ×` and one rounding: the same bits on every machine, unlike the C library's,
/// which picks its code by the CPU it runs on.
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    let (k, y) = quadrant_of(x);
    let (sin, cos) = reduced_sin_cos(reduce(x, k));
    within_limit(x, by_quadrant(sin, cos, y))
}

/// The largest |x| (rad) [`sin_cos`] reduces: `k · PIO2_1` stays exact for |k| < 2²⁰, i.e.
/// |x| < 2²⁰ π/2 ≈ 1.647·10⁶.
pub const SIN_COS_LIMIT: f64 = 1.6e6;

/// `sin_cos` where |x| ≤ [`SIN_COS_LIMIT`], NaN beyond (a select, so that lanes vectorise).
#[inline(always)]
fn within_limit(x: f64, sin_cos: (f64, f64)) -> (f64, f64) {
    if x.abs() <= SIN_COS_LIMIT { sin_cos } else { (f64::NAN, f64::NAN) }
}

// The natural logarithm, by fdlibm's `__ieee754_log` method (Sun Microsystems, 1993): with
// `x = 2ᵏ (1 + f)`, `1 + f ∈ [√2/2, √2)` and `s = f/(2 + f)`,
// `ln(1 + f) = 2 atanh s = f − f²/2 + s (f²/2 + R)`, where `R = Lg₁z + … + Lg₇z⁷`, `z = s²`,
// is a Remez fit of `(2 atanh s − 2s)/s` over `|s| ≤ 0.1716` (within 2⁻⁵⁸·⁴⁵, fdlibm states);
// `k ln 2` in two parts, the first with 21 trailing zero bits, so that `k · LN2_HI` is exact
// for every `k` an `f64` has (|k| ≤ 1077).
const LN2_HI: f64 = 0.693_147_180_369_123_8; // 0x3fe62e42fee00000
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10; // 0x3dea39ef35793c76
/// fdlibm's `Lg1` … `Lg7` (their bits are tested).
const LG: [f64; 7] = [
    0.666_666_666_666_673_5,
    0.399_999_999_994_094_2,
    0.285_714_287_436_623_9,
    0.222_221_984_321_497_84,
    0.181_835_721_616_180_5,
    0.153_138_376_992_093_73,
    0.147_981_986_051_165_86,
];
/// 2⁵² (from which every `f64` is whole), 2⁵⁴.
pub(crate) const TWO_52: f64 = 4_503_599_627_370_496.0;
const TWO_54: f64 = 18_014_398_509_481_984.0;
const SIGNIFICAND: u64 = (1 << 52) - 1;

/// `(k, f)` with `x = 2ᵏ (1 + f)` and `1 + f ∈ [√2/2, √2)` for a positive finite `x` (a
/// subnormal scaled by 2⁵⁴ first); other `x` give numbers [`log_special`] replaces.
///
/// Adding `1 − √2/2`'s distance in bits to `x`'s bits carries into the exponent field exactly
/// where the significand is `≥ √2`: that field is then `k`'s (biased), and `x`'s bits minus it
/// plus `1`'s exponent are those of `1 + f`, the significand halved where it carried. Integer
/// adds and masks, a float compare and selects, and exact float operations only: lanes
/// vectorise (`k` is built as a float from the field's bits, x86-64 before AVX-512 having no
/// packed integer-to-float conversion; integer compares per lane had left LLVM computing the
/// whole logarithm lane by lane).
#[inline(always)]
fn log_parts(x: f64) -> (f64, f64) {
    const ONE: u64 = 0x3ff0_0000_0000_0000;
    const TO_SQRT2: u64 = ONE - 0x3fe6_a09e_667f_3bcd; // 1.0's bits minus (√2/2)'s
    let subnormal = x < f64::MIN_POSITIVE;
    let scaled = if subnormal { x * TWO_54 } else { x };
    let bits = scaled.to_bits();
    let carried = bits.wrapping_add(TO_SQRT2);
    let exponent = carried & !SIGNIFICAND;
    let one_plus_f = f64::from_bits(bits.wrapping_sub(exponent).wrapping_add(ONE));
    // The biased exponent (and, for a negative `x`, the sign bit above it), exactly, as a
    // float: (2⁵² + e) − 2⁵².
    let biased = f64::from_bits(TWO_52.to_bits() | (carried >> 52)) - TWO_52;
    let k = biased - if subnormal { 1023.0 + 54.0 } else { 1023.0 };
    // Exact (Sterbenz: 1 + f is within a factor 2 of 1).
    (k, one_plus_f - 1.0)
}

/// `ln(2ᵏ (1 + f))` from [`log_parts`].
#[inline(always)]
fn log_of_parts<S: Real>(k: S, f: S) -> S {
    let c = S::splat;
    let s = f / (c(2.0) + f);
    let z = s * s;
    let w = z * z;
    // The odd and even halves of R side by side (fdlibm's split).
    let even = w * (c(LG[1]) + w * (c(LG[3]) + w * c(LG[5])));
    let odd = z * (c(LG[0]) + w * (c(LG[2]) + w * (c(LG[4]) + w * c(LG[6]))));
    let r = odd + even;
    let half_f2 = c(0.5) * f * f;
    k * c(LN2_HI) - ((half_f2 - (s * (half_f2 + r) + k * c(LN2_LO))) - f)
}

/// `log` for a positive finite `x`; otherwise `ln 0 = −∞`, `ln ∞ = ∞`, NaN for a negative `x`
/// or NaN. Selects on single compares, so that lanes vectorise: a branch, or a compound test
/// LLVM reads as a class test of the bits, was computed lane by lane.
#[inline(always)]
fn log_special(x: f64, log: f64) -> f64 {
    let positive = if x == f64::INFINITY { x } else { log };
    let zero_or_not = if x == 0.0 { f64::NEG_INFINITY } else { f64::NAN };
    if x > 0.0 { positive } else { zero_or_not }
}

/// `ln x`, within 1 ulp of the C library's (glibc's, correctly rounded but for rare cases) in
/// tests over ~830 000 values of every exponent, subnormals included; `ln 0 = −∞` (either
/// zero), `ln ∞ = ∞`, NaN for a negative `x` or NaN. Pure `+ − × ÷` and bit operations: the same bits on every machine, and
/// in lanes as in the scalar.
#[inline(always)]
pub fn ln(x: f64) -> f64 {
    let (k, f) = log_parts(x);
    log_special(x, log_of_parts(k, f))
}

/// `x.round()`: to the nearest whole number, halves away from zero, the same bits, without
/// the library call `f64::round` is on x86-64 (whose rounding instructions have no such mode)
/// and in selects that vectorise.
///
/// Below 2⁵² in magnitude, `(|x| + 2⁵²) − 2⁵²` is `|x|` rounded to the nearest whole number,
/// ties to even (the sum lies in [2⁵², 2⁵³), where the spacing is 1), and `|x|` minus it is
/// exact; where that remainder is ½ a tie went down and takes one more. The sign is `x`'s, so
/// −0.3 rounds to −0. From 2⁵² on every `f64` is whole, and ±∞ and NaN are returned as they are.
#[inline(always)]
pub fn round(x: f64) -> f64 {
    let magnitude = x.abs();
    let nearest_even = (magnitude + TWO_52) - TWO_52;
    let up = if magnitude - nearest_even >= 0.5 { 1.0 } else { 0.0 };
    let rounded = (nearest_even + up).copysign(x);
    if magnitude < TWO_52 { rounded } else { x }
}

/// Which SIMD instructions the kernels (a plant's step, a batch's lanes, the dynamics
/// functions) are compiled for; the results are the same at every level, only the speed differs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimdLevel {
    /// x86-64-v4: AVX-512 (8 f64 per register).
    Avx512,
    /// x86-64-v3: AVX2 (4 f64 per register).
    Avx2,
    /// The x86-64 baseline, SSE2 (2 f64 per register), or whatever the target has elsewhere.
    Baseline,
}

impl SimdLevel {
    pub const ALL: [SimdLevel; 3] = [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Baseline];

    /// The best level this CPU has (found once, then remembered).
    pub fn detect() -> Self {
        static BEST: std::sync::OnceLock<SimdLevel> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| Self::ALL.into_iter().find(|level| level.available()).unwrap_or(SimdLevel::Baseline))
    }

    /// The level for one run (a plant's steps, a batch of 1 or 4 lanes): AVX2 where the CPU has
    /// it, else the best it has. Code whose values fill at most a 256-bit register ran slower
    /// compiled for AVX-512 on the 2-vCPU Intel Xeon VM (the scenario's single run 5.2 ms
    /// against 3.8 ms at AVX2 and at SSE2; 4 lanes 137–143 against 104–111 ns a run-step).
    /// The results are the same bits at every level.
    pub fn for_one_run() -> Self {
        if SimdLevel::Avx2.available() { SimdLevel::Avx2 } else { Self::detect() }
    }

    /// The level for a batch of `lanes` runs side by side: the best the CPU has where the lanes
    /// fill an AVX-512 register (8), else [`SimdLevel::for_one_run`]'s. At 8 lanes on the Xeon
    /// VM: 91–96 against 102–108 ns a run-step at AVX2, the 40 × 40 sweep 0.99–1.01 against
    /// 1.11–1.13 s, a 1000-trial campaign the same within noise. (Before the inverse of `M` and
    /// the stalls fixed in the batch's glue, AVX-512 was the slower of the two there.)
    /// `CHESSARM_SIMD` picks another for `tune` and `robustness`.
    pub fn for_lanes(lanes: usize) -> Self {
        if lanes >= 8 { Self::detect() } else { Self::for_one_run() }
    }

    /// Whether this CPU can run the level.
    pub fn available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => pulp::x86::V4::try_new().is_some(),
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => pulp::x86::V3::try_new().is_some(),
            #[cfg(not(target_arch = "x86_64"))]
            SimdLevel::Avx512 | SimdLevel::Avx2 => false,
            SimdLevel::Baseline => true,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Avx512 => "avx512",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Baseline => "sse2",
        }
    }

    /// From its name (`avx512`, `avx2`, `sse2`).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|level| level.name() == name)
    }

    /// Runs `f` compiled for this level (the baseline when the CPU lacks it). `f` and what it
    /// must vectorise have to be `#[inline(always)]` to be compiled for the level.
    #[inline(always)]
    pub(crate) fn run<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        match self {
            SimdLevel::Avx512 => {
                if let Some(simd) = pulp::x86::V4::try_new() {
                    return simd.vectorize(f);
                }
            }
            SimdLevel::Avx2 => {
                if let Some(simd) = pulp::x86::V3::try_new() {
                    return simd.vectorize(f);
                }
            }
            SimdLevel::Baseline => {}
        }
        f()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two finite floats of the same sign.
    fn ulps(a: f64, b: f64) -> f64 {
        if a == b {
            return 0.0;
        }
        let spacing = f64::EPSILON * a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
        (a - b).abs() / spacing
    }

    /// The largest error of [`sin_cos`] against the C library over `xs`, in ulps. The C library
    /// is within 1 ulp of the exact value; ours must be within 1 more. Near a zero of sin or cos
    /// the relative error is measured against the function's scale 1, as an absolute error of
    /// a few 1e-16.
    fn worst_ulps(xs: impl IntoIterator<Item = f64>) -> f64 {
        let mut worst = 0.0f64;
        for x in xs {
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            for (mine, theirs) in [(s, s0), (c, c0)] {
                let error = if theirs.abs() < 0.25 { (mine - theirs).abs() / f64::EPSILON } else { ulps(mine, theirs) };
                worst = worst.max(error);
            }
        }
        worst
    }

    #[test]
    fn sin_cos_within_two_ulps_of_the_c_library() {
        let worst = worst_ulps((0..200_001).map(|i| -50.0 + 100.0 * f64::from(i) / 200_000.0));
        assert!(worst <= 2.0, "worst {worst} ulps");
    }

    /// The promise holds out to the limit (random angles up to ±1.6·10⁶ rad and the limit
    /// itself), and beyond it the result is NaN, not a number that is no sine (before the
    /// limit was enforced, `sin_cos(1e20)` gave (1.4e34, 3.2e32)), in lanes as in the scalar.
    #[test]
    fn large_angles_within_the_limit_and_nan_beyond() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut xs: Vec<f64> = (0..100_000)
            .map(|_| {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0 * SIN_COS_LIMIT
            })
            .collect();
        xs.extend([SIN_COS_LIMIT, -SIN_COS_LIMIT]);
        let worst = worst_ulps(xs);
        assert!(worst <= 2.0, "worst {worst} ulps");
        let beyond = [SIN_COS_LIMIT.next_up(), -1.7e6, 1e20, -1e300, f64::MAX];
        for x in beyond {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan(), "{x}: ({s}, {c})");
        }
        let (s, c) = Lanes([1e20, 0.5, -SIN_COS_LIMIT, 2e6]).sin_cos();
        assert!(s.get(0).is_nan() && c.get(0).is_nan() && s.get(3).is_nan() && c.get(3).is_nan());
        assert_eq!((s.get(1).to_bits(), c.get(1).to_bits()), (sin_cos(0.5).0.to_bits(), sin_cos(0.5).1.to_bits()));
        let limit = sin_cos(-SIN_COS_LIMIT);
        assert_eq!((s.get(2).to_bits(), c.get(2).to_bits()), (limit.0.to_bits(), limit.1.to_bits()));
    }

    #[test]
    fn quadrants_signs_and_special_values() {
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        let (s, c) = sin_cos(std::f64::consts::FRAC_PI_2);
        assert!((s - 1.0).abs() < 1e-16 && c.abs() < 1e-16);
        let (s, c) = sin_cos(-std::f64::consts::PI);
        assert!(s.abs() < 1e-15 && (c + 1.0).abs() < 1e-16);
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan(), "{x}");
        }
        // Odd and even.
        for x in [0.3, 1.2, 2.9, 4.0, 7.5] {
            let (s, c) = sin_cos(x);
            let (sn, cn) = sin_cos(-x);
            assert_eq!((s, c), (-sn, cn));
        }
    }

    /// The quadrant read from the rounder's bits is `k mod 4` of the integer `k` (what an
    /// integer conversion gives), for angles across ±10⁶ rad, every quadrant's edges and the
    /// last `k` the bits hold.
    #[test]
    fn the_quadrant_in_the_rounders_bits_is_k_mod_4() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut xs: Vec<f64> = (0..20_000).map(|_| (next() - 0.5) * 2e6).collect();
        for k in -9..=9 {
            let edge = (f64::from(k) + 0.5) * std::f64::consts::FRAC_PI_2;
            xs.extend([edge, edge.next_up(), edge.next_down(), f64::from(k) * std::f64::consts::FRAC_PI_2]);
        }
        let last = ((1u64 << 51) - 1) as f64;
        xs.extend([0.0, -0.0, last / std::f64::consts::FRAC_2_PI, -last / std::f64::consts::FRAC_2_PI]);
        for x in xs {
            let (k, y) = quadrant_of(x);
            assert_eq!(k, k.round(), "{x}");
            assert!(k.abs() < 2f64.powi(51), "{x}");
            assert_eq!(y & 3, (k as i64 as u64) & 3, "{x}: k = {k}");
        }
    }

    /// Random `f64`s from random bits (every exponent, subnormals too), `1 − u` for the
    /// uniform `u` of the Box–Muller transform, and the neighbourhoods of 1, √2/2, √2 and the
    /// powers of two: within 1 ulp of the C library's `ln` (glibc's, correctly rounded but for
    /// rare cases: so within ~1.5 ulp of the exact value).
    #[test]
    fn ln_within_one_ulp_of_the_c_library() {
        let mut rng = crate::sense::rng::SeededRng::new(11);
        let mut xs = Vec::new();
        for _ in 0..400_000 {
            xs.push(f64::from_bits(rng.next_u64() >> 1));
            xs.push(1.0 - rng.unit());
        }
        for centre in [1.0, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::SQRT_2, 0.5, 2.0, 1e-300, 5e-324] {
            let (mut up, mut down) = (centre, centre);
            for _ in 0..2000 {
                xs.extend([up, down]);
                (up, down) = (up.next_up(), down.next_down());
            }
        }
        let mut worst = (0.0f64, 0.0);
        let mut differ = 0;
        for &x in xs.iter().filter(|x| **x > 0.0 && x.is_finite()) {
            let (mine, theirs) = (ln(x), x.ln());
            let error = ulps(mine, theirs);
            differ += usize::from(error > 0.0);
            if error > worst.0 {
                worst = (error, x);
            }
        }
        assert!(worst.0 <= 1.0, "worst {} ulps at {:e}", worst.0, worst.1);
        // Not the C library's bits themselves: they differ somewhere (else this test
        // would not say what it measures).
        assert!(differ > 0);
    }

    /// The constants are fdlibm's, bit for bit.
    #[test]
    fn ln_constants_are_fdlibms() {
        let bits = [
            0x3fe5_5555_5555_5593,
            0x3fd9_9999_9997_fa04,
            0x3fd2_4924_9422_9359,
            0x3fcc_71c5_1d8e_78af,
            0x3fc7_4664_96cb_03de,
            0x3fc3_9a09_d078_c69f,
            0x3fc2_f112_df3e_5244,
        ];
        assert_eq!(LG.map(f64::to_bits), bits);
        assert_eq!(LN2_HI.to_bits(), 0x3fe6_2e42_fee0_0000);
        assert_eq!(LN2_LO.to_bits(), 0x3dea_39ef_3579_3c76);
    }

    #[test]
    fn ln_of_special_values() {
        assert_eq!(ln(1.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(ln(0.0), f64::NEG_INFINITY);
        assert_eq!(ln(-0.0), f64::NEG_INFINITY);
        assert_eq!(ln(f64::INFINITY), f64::INFINITY);
        for x in [-1.0, -5e-324, f64::NEG_INFINITY, f64::NAN] {
            assert!(ln(x).is_nan(), "{x}");
        }
        assert_eq!(ln(std::f64::consts::E), 1.0);
        assert_eq!(ln(5e-324), 5e-324f64.ln());
        assert_eq!(ln(f64::MAX), f64::MAX.ln());
        for k in -1074..=1023 {
            let x =
                if k >= -1022 { f64::from_bits(((k + 1023) as u64) << 52) } else { f64::from_bits(1 << (k + 1074)) };
            assert!(ulps(ln(x), x.ln()) <= 1.0, "2^{k}");
        }
    }

    fn same_round(x: f64) {
        assert_eq!(round(x).to_bits(), x.round().to_bits(), "round({x:e})");
    }

    /// Halves, neighbours of halves, signed zeros, the edges of 2⁵² and 2⁶³, ±∞, NaN, and
    /// random values of every magnitude: the same bits as `f64::round`.
    #[test]
    fn round_gives_the_bits_of_the_library_round() {
        for base in [0.0, 0.5, 1.0, 1.5, 2.5, 1e6 + 0.5, 2f64.powi(51) + 0.5, 2f64.powi(52), 2f64.powi(63), 1e300] {
            for x in [base, base.next_up(), base.next_down(), f64::INFINITY, f64::MIN_POSITIVE, 5e-324] {
                same_round(x);
                same_round(-x);
            }
        }
        same_round(0.499_999_999_999_999_94);
        same_round(TWO_52 - 0.5);
        assert!(round(f64::NAN).is_nan());
        let mut rng = crate::sense::rng::SeededRng::new(7);
        for _ in 0..200_000 {
            let x = f64::from_bits(rng.next_u64());
            if !x.is_nan() {
                same_round(x);
            }
            let y = (rng.unit() - 0.5) * 10f64.powi((rng.unit() * 40.0) as i32 - 10);
            same_round(y);
            same_round((y * 2.0).round() / 2.0);
        }
    }

    #[test]
    fn lanes_equal_the_scalar_bit_for_bit() {
        let xs = [0.1, -2.5, 3.2, 1e-9, 100.0, -0.785, f64::NAN, 5.0];
        let (s, c) = Lanes(xs).sin_cos();
        let (ss, sc) = Lanes(xs).small_sin_cos();
        let positive = [0.1, 2.5, 3.2, 1e-9, 1e-310, 0.0, f64::INFINITY, 1.0 - 1e-16];
        let (log, rounded) = (Lanes(positive).ln(), Lanes(xs.map(|x| x * 3.5)).round());
        for (i, x) in xs.iter().enumerate() {
            assert_eq!(log.get(i).to_bits(), ln(positive[i]).to_bits());
            assert_eq!(rounded.get(i).to_bits(), round(x * 3.5).to_bits());
            let (s0, c0) = sin_cos(*x);
            assert_eq!(s.get(i).to_bits(), s0.to_bits());
            assert_eq!(c.get(i).to_bits(), c0.to_bits());
            let (ss0, sc0) = small_angle_sin_cos(*x);
            assert_eq!(ss.get(i).to_bits(), ss0.to_bits());
            assert_eq!(sc.get(i).to_bits(), sc0.to_bits());
        }
        let (a, b) = (Lanes([1.5, -2.0, 3.0, 0.1]), Lanes([0.3, 7.0, -1.0, 3.0]));
        for (i, (x, y)) in a.0.iter().zip(b.0).enumerate() {
            assert_eq!((a + b).get(i), x + y);
            assert_eq!((a - b).get(i), x - y);
            assert_eq!((a * b).get(i), x * y);
            assert_eq!((a / b).get(i), x / y);
            assert_eq!((-a).get(i), -x);
        }
    }
}
