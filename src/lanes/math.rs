//! lumo's own elementary functions, written once for every lane width: sin, cos, tan, asin,
//! acos, atan, atan2, exp, ln and powf on [`F32s<W>`] (as methods), and their scalar entry
//! points ([`sin`], [`cos`], …: the W = 1 instance) for code that runs one path at a time.
//!
//! No lane's result depends on another lane: the special cases (NaN, ±∞, ±0, out-of-domain
//! arguments) are handled with `select`, and the only branch (sin/cos/tan's reduction of
//! |x| ≥ 2²⁴) skips work that no lane needs, each lane still choosing its own path by its own
//! |x|. So W = 1, 4, 8 and 16 give the same bits, and the tests check it over every f32.
//! Every NaN result is the canonical quiet NaN.
//!
//! Error bounds in ulp of the exactly rounded result. For the functions of one argument they
//! are the largest errors over all 2³² f32 inputs (the exhaustive test of `tests.rs`, rounded
//! up), so they hold everywhere; for atan2 and powf, over 2³² pairs spanning every sign,
//! exponent and leading mantissa bits, and the sampled tests' ranges. libm's are below 1 ulp.
//!
//! | function | bound (ulp) | largest seen | domain |
//! | --- | --- | --- | --- |
//! | sin, cos, sin_cos | 1.05 | 1.020 | every finite x (Payne–Hanek reduction from 2²⁴) |
//! | tan | 2.1 | 2.090 | every finite x (−1/tan r in odd quadrants adds a rounding) |
//! | asin | 1.5 | 1.449 | [−1, 1]; NaN outside |
//! | acos | 1.2 | 1.153 | [−1, 1]; NaN outside |
//! | atan | 1.5 | 1.466 | everywhere |
//! | atan2 | 2 | 1.803 | everywhere, with C99's special cases |
//! | exp | 1 | 0.990 | everywhere (0 below −103.97, ∞ above 88.72) |
//! | ln | 0.9 | 0.846 | everywhere (−∞ at ±0, NaN below 0) |
//! | powf | 1 | 0.500 | everywhere, with C99's special cases |
//!
//! The `f64` sin, cos, sin_cos, asin, acos, atan and atan2 on [`F64s<W>`] (and their scalar
//! entry points [`sin_f64`], …) follow Sun's fdlibm with its cases chosen by select. Their
//! arguments are too many for an exhaustive test: the bounds below are from ≥ 2²⁰ sampled
//! arguments per function in CI and 2²⁴ more in the ignored test of `tests_f64.rs`, against a
//! double-double reference, and rounded up to the next ulp (fdlibm's own claim for these
//! functions is below 1 ulp).
//!
//! | `f64` function | bound (ulp) | largest seen | domain |
//! | --- | --- | --- | --- |
//! | sin, cos, sin_cos | 1 | 0.782 | \|x\| ≤ 2²⁰·π/2 ([`TRIG_F64_DOMAIN`]), NaN at ±∞ |
//! | asin | 1 | 0.876 | [−1, 1]; NaN outside |
//! | acos | 1 | 0.889 | [−1, 1]; NaN outside |
//! | atan | 1 | 0.809 | everywhere |
//! | atan2 | 2 | 1.487 | everywhere, with C99's special cases |
//!
//! Methods (every function cites its own):
//!
//! * Argument reduction after Cody and Waite, *Software Manual for the Elementary Functions*
//!   (1980): x − k·C with C split into parts whose products with k are exact. sin, cos and tan
//!   reduce by π/2 in `f64` with a three-part π/2 (so the remainder keeps its relative
//!   precision even next to a multiple of π/2), and arguments of magnitude ≥ 2²⁴ by the method
//!   of Payne and Hanek, "Radian reduction for trigonometric functions" (SIGNUM Newsletter 18,
//!   1983): only the bits of 2/π that can reach the fraction of x·2/π take part.
//! * The polynomials of sin, cos, tan, asin, atan, exp and ln are the single-precision minimax
//!   fits of S. L. Moshier's Cephes library (*Methods and Programs for Mathematical
//!   Functions*, 1989), which Dr.Jit's `math.h` also uses; evaluated by Horner's rule with a
//!   separate multiply and add (no FMA), plus the low part of the reduced argument where it
//!   pays. ln's mantissa in [√½, √2) is found with integer arithmetic on the bits, as in
//!   FreeBSD's and musl's `logf`.
//! * powf = 2^(y·log₂|x|) in `f64`: log₂ by the atanh series of (m − 1)/(m + 1) and 2^f by the
//!   exponential series, both with ample terms, so the only rounding that matters is the last
//!   one to `f32`. SLEEF (Shibata and Petrogalli, IEEE TPDS 2020) was read for how a
//!   vectorised libm handles the special cases branch-free.

use super::{F32s, F64s, I32s, Mask, U32s, U64s};

/// 1.5·2⁵²: adding and subtracting it rounds an `f64` below 2⁵¹ in magnitude to an integer,
/// and the sum's low bits hold that integer in two's complement.
const ROUND_F64: f64 = 6_755_399_441_055_744.0;
/// 1.5·2²³: the same for an `f32` below 2²² in magnitude.
const ROUND_F32: f32 = 12_582_912.0;

/// π/2 in three parts for the reduction of |x| < 2²⁴ (k < 2²⁴): the first two have 29
/// significant bits each, so k times either is exact in `f64`; together they carry π/2 to
/// 111 bits.
const HALF_PI_1: f64 = 1.570_796_325_802_803;
const HALF_PI_2: f64 = 9.920_935_774_287_987e-10;
const HALF_PI_3: f64 = 2.251_741_774_156_217_6e-18;
/// Arguments at least this large in magnitude are reduced by Payne–Hanek.
const LARGE_TRIG_ARGUMENT: f32 = 16_777_216.0;

/// π, π/2 and π/4 as the nearest `f32` (`HI`) and the `f32` nearest the rest (`LO`).
const PI_HI: f32 = std::f32::consts::PI;
const PI_LO: f32 = -8.742_278e-8;
const HALF_PI_HI: f32 = std::f32::consts::FRAC_PI_2;
const HALF_PI_LO: f32 = -4.371_139e-8;
const QUARTER_PI_HI: f32 = std::f32::consts::FRAC_PI_4;
const QUARTER_PI_LO: f32 = -2.185_569_4e-8;
const THREE_QUARTER_PI_HI: f32 = 2.356_194_5;
const THREE_QUARTER_PI_LO: f32 = -5.962_440_3e-9;

/// 2/π in binary, 32 bits a word from the binary point (enough for the largest f32 exponent:
/// bit 210 is the last one Payne–Hanek reads).
const TWO_OVER_PI_BITS: [u32; 7] = [
    0xA2F9_836E,
    0x4E44_1529,
    0xFC27_57D1,
    0xF534_DDC0,
    0xDB62_9599,
    0x3C43_9041,
    0xFE51_63AB,
];

/// Bits `first` … `first + 26` of 2/π (bit 1 is the first after the binary point; bits at 0 and
/// before are 0) as an integer.
const fn two_over_pi_bits(first: i32) -> u64 {
    let mut v = 0u64;
    let mut k = first;
    while k < first + 27 {
        let bit = if k < 1 {
            0
        } else {
            let i = (k - 1) as usize;
            ((TWO_OVER_PI_BITS[i / 32] >> (31 - i % 32)) & 1) as u64
        };
        v = (v << 1) | bit;
        k += 1;
    }
    v
}

/// For x = m·2ᵉ (m a 24-bit integer, e = 1 … 104: every f32 ≥ 2²⁴), 2ᵉ·(2/π) mod 4 in four
/// `f64` parts of 27 bits each (weights 2¹ … 2⁻¹⁰⁶), so that m times each part is exact. Row
/// e − 1.
static PAYNE_HANEK: [[f64; 4]; 104] = {
    let mut table = [[0.0; 4]; 104];
    let mut e = 1;
    while e <= 104 {
        let mut part = 0;
        while part < 4 {
            // Bit k of 2/π weighs 2^(e − k) in 2ᵉ·(2/π); weights above 2¹ are multiples of 4.
            let first = e - 1 + 27 * part;
            let lowest_weight = f64::from_bits(((1023 - 25 - 27 * part) as u64) << 52);
            table[(e - 1) as usize][part as usize] = two_over_pi_bits(first) as f64 * lowest_weight;
            part += 1;
        }
        e += 1;
    }
    table
};

/// Horner's rule, highest coefficient first, with a separate multiply and add.
#[inline(always)]
fn horner<const W: usize, const N: usize>(x: F32s<W>, coefficients: [f32; N]) -> F32s<W> {
    let mut p = F32s::splat(coefficients[0]);
    for &c in &coefficients[1..] {
        p = p * x + c;
    }
    p
}

/// [`horner`] in `f64`.
#[inline(always)]
fn horner_f64<const W: usize, const N: usize>(x: F64s<W>, coefficients: [f64; N]) -> F64s<W> {
    let mut p = F64s::splat(coefficients[0]);
    for &c in &coefficients[1..] {
        p = p * x + c;
    }
    p
}

#[inline(always)]
fn nan<const W: usize>() -> F32s<W> {
    F32s::splat(f32::NAN)
}

/// x = k·π/2 + r: r as the nearest `f32` and the `f32` nearest the rest, and k mod 4.
#[inline(always)]
fn reduce_half_pi<const W: usize>(x: F32s<W>) -> (F32s<W>, F32s<W>, U32s<W>) {
    let xd = x.to_f64();
    let shifted = xd * std::f64::consts::FRAC_2_PI + ROUND_F64;
    let k = shifted - ROUND_F64;
    // k·HALF_PI_1 and k·HALF_PI_2 are exact and x − k·HALF_PI_1 cancels exactly, so the only
    // roundings are relative to the remainder itself.
    let mut r = ((xd - k * HALF_PI_1) - k * HALF_PI_2) - k * HALF_PI_3;
    let mut quadrant = shifted.to_bits().low_u32();
    let large = x.abs().ge(F32s::splat(LARGE_TRIG_ARGUMENT)) & x.is_finite();
    if large.any() {
        let (r_large, k_large) = reduce_large(x.abs());
        let negative = x.sign_bit();
        r = F64s::select(large & negative, -r_large, F64s::select(large, r_large, r));
        quadrant = U32s::select(
            large & negative,
            U32s::splat(0) - k_large,
            U32s::select(large, k_large, quadrant),
        );
    }
    let hi = r.to_f32();
    let lo = (r - hi.to_f64()).to_f32();
    (hi, lo, quadrant & 3)
}

/// Payne–Hanek reduction of a ≥ 2²⁴ (other lanes give meaningless values): a = k·π/2 + r with
/// |r| ≤ π/4, r in `f64` to about 2⁻⁵² relative, and k mod 4 in the low bits.
///
/// With a = m·2ᵉ, a·(2/π) mod 4 = m·(2ᵉ·(2/π) mod 4) = m·(t₀ + t₁ + t₂ + t₃): every product
/// m·tᵢ is exact, m·t₀ mod 4 is exact, and the integer k nearest m·t₀ + m·t₁ leaves a fraction
/// (m·t₀ − k) + m·t₁ that is exact too (52 bits); m·t₂ and m·t₃ (below 2⁻²⁸) add one rounding
/// relative to the fraction, and the bits of 2/π left out weigh below 2⁻⁸².
#[inline(always)]
fn reduce_large<const W: usize>(a: F32s<W>) -> (F64s<W>, U32s<W>) {
    let bits = a.to_bits();
    let row = ((bits >> 23).cast_i32() - 151)
        .max(I32s::splat(0))
        .min(I32s::splat(103));
    let m = ((bits & 0x007f_ffff) | 0x0080_0000)
        .cast_i32()
        .to_f32()
        .to_f64();
    let part = |p: usize| F64s::from_fn(|i| PAYNE_HANEK[row[i] as usize][p]);
    let p0 = m * part(0);
    let p0 = p0 - 4.0 * (p0 * 0.25).floor();
    let p1 = m * part(1);
    let shifted = (p0 + p1) + ROUND_F64;
    let k = shifted - ROUND_F64;
    let fraction = ((p0 - k) + p1) + (m * part(2) + m * part(3));
    (
        fraction * std::f64::consts::FRAC_PI_2,
        shifted.to_bits().low_u32(),
    )
}

/// Cephes' `sinf` and `cosf` polynomials on |r| ≤ π/4: sin(r + r_lo) and cos(r + r_lo), the
/// low part entering to first order.
#[inline(always)]
fn sin_cos_poly<const W: usize>(r: F32s<W>, r_lo: F32s<W>) -> (F32s<W>, F32s<W>) {
    let z = r * r;
    let ps = horner(z, [-1.951_529_6e-4, 8.332_161e-3, -1.666_665_5e-1]);
    let sin = r + (r * z * ps + r_lo);
    let pc = horner(z, [2.443_315_7e-5, -1.388_731_6e-3, 4.166_664_6e-2]);
    let cos = 1.0 - (0.5 * z - (z * z * pc - r * r_lo));
    (sin, cos)
}

/// The sign bit flipped in the lanes where `flip` (a `u32` of 0 or 2) is 2.
#[inline(always)]
fn flip_sign_by<const W: usize>(v: F32s<W>, flip: U32s<W>) -> F32s<W> {
    F32s::from_bits(v.to_bits() ^ (flip << 30))
}

/// |x| below this: sin x and tan x round to x (and keep the sign of ±0).
const SIN_IS_X: f32 = 2.441_406_3e-4; // 2⁻¹²

/// atan(ay / ax) for ay, ax ≥ 0 (either may be 0 or ∞; both 0 give 0, both ∞ π/4), or
/// π − atan(ay / ax) in the lanes of `reflect`, as Cephes' `atanf`: the quotient v is brought
/// into |t| ≤ tan(π/8) by atan v = π/2 + atan(−1/v) above tan(3π/8) and
/// π/4 + atan((v − 1)/(v + 1)) above tan(π/8). t is one `f64` quotient (its numerator and
/// denominator are exact in `f64`), so it carries a single rounding; the constant part (0, π/4,
/// π/2, 3π/4 or π) is added last, in two parts.
#[inline(always)]
fn atan_of_quotient<const W: usize>(ay: F32s<W>, ax: F32s<W>, reflect: Mask<W>) -> F32s<W> {
    let inf = F32s::splat(f32::INFINITY);
    let steep = ay.gt(ax * 2.414_213_5);
    let both_infinite = ay.eq(inf) & ax.eq(inf);
    let middle = ay.gt(ax * 0.414_213_57).and_not(steep) | both_infinite;
    let (dy, dx) = (ay.to_f64(), ax.to_f64());
    let num = F64s::select(steep, -dx, F64s::select(middle, dy - dx, dy));
    let den = F64s::select(steep, dy, F64s::select(middle, dy + dx, dx));
    let num = F64s::select(both_infinite, F64s::splat(0.0), num);
    let degenerate = both_infinite | (ay.eq(F32s::splat(0.0)) & ax.eq(F32s::splat(0.0)));
    let den = F64s::select(degenerate, F64s::splat(1.0), den);
    let t = (num / den).to_f32();
    let z = t * t;
    let p = horner(
        z,
        [
            8.053_744_5e-2,
            -1.387_768_6e-1,
            1.997_771_1e-1,
            -3.333_295e-1,
        ],
    );
    let atan_t = t * z * p + t;
    let pick = |zero: f32, quarter: f32, half: f32, three_quarters: f32, whole: f32| {
        let direct = F32s::select(
            steep,
            F32s::splat(half),
            F32s::select(middle, F32s::splat(quarter), F32s::splat(zero)),
        );
        let reflected = F32s::select(
            steep,
            F32s::splat(half),
            F32s::select(middle, F32s::splat(three_quarters), F32s::splat(whole)),
        );
        F32s::select(reflect, reflected, direct)
    };
    let base_hi = pick(0.0, QUARTER_PI_HI, HALF_PI_HI, THREE_QUARTER_PI_HI, PI_HI);
    let base_lo = pick(0.0, QUARTER_PI_LO, HALF_PI_LO, THREE_QUARTER_PI_LO, PI_LO);
    base_hi + (base_lo + F32s::select(reflect, -atan_t, atan_t))
}

/// asin |x| by Cephes' `asinf`: for |x| ≤ 1/2 the odd polynomial in x; above,
/// asin a = π/2 − 2·asin √((1 − a)/2), whose argument is again ≤ 1/2. Returns the polynomial's
/// value p (of |x| or of √((1 − a)/2)) and the lanes where the second form applies.
#[inline(always)]
fn asin_poly<const W: usize>(a: F32s<W>) -> (F32s<W>, Mask<W>) {
    let upper = a.gt(F32s::splat(0.5));
    // 1 − a is exact for a ∈ [1/2, 1].
    let z = F32s::select(upper, 0.5 * (1.0 - a), a * a);
    // √z to f32 and the rest: the upper range's result loses a bit to π/2 − 2p, so p is kept
    // within about half an ulp.
    let root = z.to_f64().sqrt();
    let s = F32s::select(upper, root.to_f32(), a);
    let s_lo = F32s::select(upper, (root - s.to_f64()).to_f32(), F32s::splat(0.0));
    let p = horner(
        z,
        [
            4.216_32e-2,
            2.418_131e-2,
            4.547_002_6e-2,
            7.495_300_3e-2,
            1.666_675_2e-1,
        ],
    );
    (s + (s * z * p + s_lo), upper)
}

/// log₂ a for `f64` lanes holding non-negative f32 values (−∞ at 0, ∞ at ∞), to about 2⁻⁴⁰
/// relative: a = m·2ᵉ with m ∈ [√½, √2), and ln m = 2 atanh s with s = (m − 1)/(m + 1),
/// |s| ≤ 0.1716, by the series 2s (1 + s²/3 + s⁴/5 + … + s¹⁴/15) (truncation below 2⁻⁴⁰).
#[inline(always)]
fn log2_f64<const W: usize>(a: F64s<W>) -> F64s<W> {
    const SQRT_HALF_BITS: u64 = 0x3fe6_a09e_667f_3bcd;
    let ix = a.to_bits() + (0x3ff0_0000_0000_0000 - SQRT_HALF_BITS);
    let e = ((ix >> 52).low_u32().cast_i32() - 1023).to_f32().to_f64();
    let m = F64s::from_bits((ix & 0x000f_ffff_ffff_ffff) + SQRT_HALF_BITS);
    let s = (m - 1.0) / (m + 1.0);
    let z = s * s;
    let series = horner_f64(
        z,
        [
            2.0 / 15.0,
            2.0 / 13.0,
            2.0 / 11.0,
            2.0 / 9.0,
            2.0 / 7.0,
            2.0 / 5.0,
            2.0 / 3.0,
            2.0,
        ],
    );
    let l = e + s * series * std::f64::consts::LOG2_E;
    let inf = F64s::splat(f64::INFINITY);
    F64s::select(
        a.eq(F64s::splat(0.0)),
        -inf,
        F64s::select(a.eq(inf), inf, l),
    )
}

/// 1/10!, 1/9!, …, 1/1!, 1/0!: the exponential series for [`exp2_f64`], highest power first.
const INVERSE_FACTORIALS: [f64; 11] = {
    let mut c = [1.0; 11];
    let mut k = 1;
    while k < 11 {
        c[10 - k] = c[11 - k] / k as f64;
        k += 1;
    }
    c
};

/// 2ʷ in `f64` for w ∈ [−160, 130] (clamped there, beyond the f32 range either way), to about
/// 2⁻⁴² relative: w = n + f with n an integer and |f| ≤ 1/2 (exact), 2ᶠ = e^(f ln 2) by its
/// series to the 10th power (truncation below 2⁻⁴²), 2ⁿ built from its exponent bits.
#[inline(always)]
fn exp2_f64<const W: usize>(w: F64s<W>) -> F64s<W> {
    let w = w.max(F64s::splat(-160.0)).min(F64s::splat(130.0));
    let shifted = w + ROUND_F64;
    let n = shifted - ROUND_F64;
    let u = (w - n) * std::f64::consts::LN_2;
    let series = horner_f64(u, INVERSE_FACTORIALS);
    // The low 12 bits of `shifted` are n mod 2¹²; moved into the exponent field and biased.
    let scale = F64s::from_bits((shifted.to_bits() << 52) + U64s::splat(1023 << 52));
    series * scale
}

impl<const W: usize> F32s<W> {
    /// sin x and cos x from one reduction (see [`sin`](Self::sin) and [`cos`](Self::cos)).
    #[inline(always)]
    pub fn sin_cos(self) -> (Self, Self) {
        let (r, r_lo, quadrant) = reduce_half_pi(self);
        let (s, c) = sin_cos_poly(r, r_lo);
        // sin(kπ/2 + r) = s, c, −s, −c and cos(kπ/2 + r) = c, −s, −c, s for k mod 4 = 0 … 3.
        let odd = (quadrant & 1).ne(U32s::splat(0));
        let sin = flip_sign_by(F32s::select(odd, c, s), quadrant & 2);
        let cos = flip_sign_by(F32s::select(odd, s, c), (quadrant + 1) & 2);
        let sin = F32s::select(self.abs().lt(F32s::splat(SIN_IS_X)), self, sin);
        let finite = self.is_finite();
        (
            F32s::select(finite, sin, nan()),
            F32s::select(finite, cos, nan()),
        )
    }

    /// sin x within 1.05 ulp for every finite x (NaN for ±∞ and NaN; sin ±0 = ±0).
    #[inline(always)]
    pub fn sin(self) -> Self {
        self.sin_cos().0
    }

    /// cos x within 1.05 ulp for every finite x (NaN for ±∞ and NaN).
    #[inline(always)]
    pub fn cos(self) -> Self {
        self.sin_cos().1
    }

    /// tan x within 2.1 ulp for every finite x (NaN for ±∞ and NaN; tan ±0 = ±0), by Cephes'
    /// `tanf` polynomial on |r| ≤ π/4 and tan(r + π/2) = −1/tan r.
    #[inline(always)]
    pub fn tan(self) -> Self {
        let (r, r_lo, quadrant) = reduce_half_pi(self);
        let z = r * r;
        let p = horner(
            z,
            [
                9.385_402e-3,
                3.119_922_3e-3,
                2.443_013_5e-2,
                5.341_128e-2,
                1.333_879_9e-1,
                3.333_315_7e-1,
            ],
        );
        let t = r + (r * z * p + r_lo);
        let odd = (quadrant & 1).ne(U32s::splat(0));
        let t = F32s::select(odd, -1.0 / t, t);
        let t = F32s::select(self.abs().lt(F32s::splat(SIN_IS_X)), self, t);
        F32s::select(self.is_finite(), t, nan())
    }

    /// asin x ∈ [−π/2, π/2] within 1.5 ulp on [−1, 1] (NaN outside; asin ±0 = ±0).
    #[inline(always)]
    pub fn asin(self) -> Self {
        let a = self.abs();
        let (p, upper) = asin_poly(a);
        let r = F32s::select(upper, 2.0 * ((QUARTER_PI_HI - p) + QUARTER_PI_LO), p);
        F32s::select(a.le(F32s::splat(1.0)), r.copysign(self), nan())
    }

    /// acos x ∈ [0, π] within 1.2 ulp on [−1, 1] (NaN outside): π/2 − asin x for |x| ≤ 1/2,
    /// 2 asin √((1 − x)/2) above and π − 2 asin √((1 + x)/2) below.
    #[inline(always)]
    pub fn acos(self) -> Self {
        let a = self.abs();
        let (p, upper) = asin_poly(a);
        let centre = HALF_PI_HI - (p.copysign(self) - HALF_PI_LO);
        let right = 2.0 * p;
        let left = 2.0 * ((HALF_PI_HI - p) + HALF_PI_LO);
        let r = F32s::select(upper, F32s::select(self.sign_bit(), left, right), centre);
        F32s::select(a.le(F32s::splat(1.0)), r, nan())
    }

    /// atan x ∈ [−π/2, π/2] within 1.5 ulp everywhere (atan ±∞ = ±π/2, atan ±0 = ±0).
    #[inline(always)]
    pub fn atan(self) -> Self {
        let a = atan_of_quotient(self.abs(), F32s::splat(1.0), Mask::splat(false)).copysign(self);
        F32s::select(self.is_nan(), nan(), a)
    }

    /// atan2(self, x) (self is y, as in `f32::atan2`) ∈ [−π, π] within 2 ulp everywhere, with
    /// C99's special cases: atan2(±0, +0) = ±0, atan2(±0, −0) = ±π, atan2(±∞, +∞) = ±π/4,
    /// atan2(±∞, −∞) = ±3π/4; NaN if either is NaN.
    #[inline(always)]
    pub fn atan2(self, x: Self) -> Self {
        let a = atan_of_quotient(self.abs(), x.abs(), x.sign_bit());
        F32s::select(self.is_nan() | x.is_nan(), nan(), a.copysign(self))
    }

    /// eˣ within 1 ulp everywhere (subnormal results rounded once, 0 below −103.97, ∞ above
    /// 88.72), by Cephes' `expf`: x = n ln 2 + r with ln 2 in two parts (n·0.693359375 exact),
    /// e^r = 1 + r + r²·P(r) on |r| ≤ ln 2 / 2, and 2ⁿ applied as two factors so that both are
    /// normal numbers.
    #[inline(always)]
    pub fn exp(self) -> Self {
        let x = self.max(F32s::splat(-104.0)).min(F32s::splat(89.0));
        let shifted = x * std::f32::consts::LOG2_E + ROUND_F32;
        let n = shifted - ROUND_F32;
        let r = (x - n * 0.693_359_4) - n * -2.121_944_4e-4;
        let p = horner(
            r,
            [
                1.987_569_1e-4,
                1.398_199_9e-3,
                8.333_452e-3,
                4.166_579_6e-2,
                1.666_666_5e-1,
                0.5,
            ],
        );
        let y = (p * (r * r) + r) + 1.0;
        let n = (shifted.to_bits() - ROUND_F32.to_bits()).cast_i32();
        let half = n >> 1;
        let two_to = |k: I32s<W>| F32s::from_bits(((k + 127) << 23).cast_u32());
        let e = (y * two_to(half)) * two_to(n - half);
        F32s::select(self.is_nan(), nan(), e)
    }

    /// ln x within 0.9 ulp everywhere (−∞ at ±0, ∞ at ∞, NaN below 0), by Cephes' `logf`:
    /// x = m·2ᵉ with m ∈ [√½, √2), ln x = f − f²/2 + f³·P(f) + e ln 2 with f = m − 1 (exact) and
    /// ln 2 in two parts.
    #[inline(always)]
    pub fn ln(self) -> Self {
        const SQRT_HALF_BITS: u32 = 0x3f35_04f3;
        let subnormal = self.lt(F32s::splat(f32::MIN_POSITIVE));
        let x = F32s::select(subnormal, self * 8_388_608.0, self);
        let ix = x.to_bits() + (0x3f80_0000 - SQRT_HALF_BITS);
        let e = (ix >> 23).cast_i32()
            - I32s::select(subnormal, I32s::splat(127 + 23), I32s::splat(127));
        let m = F32s::from_bits((ix & 0x007f_ffff) + SQRT_HALF_BITS);
        let f = m - 1.0;
        let z = f * f;
        let p = horner(
            f,
            [
                7.037_683_6e-2,
                -1.151_461e-1,
                1.167_699_9e-1,
                -1.242_014_1e-1,
                1.424_932_3e-1,
                -1.666_805_8e-1,
                2.000_071_5e-1,
                -2.499_999_4e-1,
                3.333_333e-1,
            ],
        );
        let fe = e.to_f32();
        let y = ((f * z * p + fe * -2.121_944_4e-4) - 0.5 * z) + f;
        let l = y + fe * 0.693_359_4;
        let zero = F32s::splat(0.0);
        let inf = F32s::splat(f32::INFINITY);
        let l = F32s::select(self.eq(inf), inf, l);
        let l = F32s::select(self.eq(zero), -inf, l);
        F32s::select(self.lt(zero) | self.is_nan(), nan(), l)
    }

    /// selfʸ within 1 ulp everywhere, as 2^(y·log₂|x|) in `f64` (see [`log2_f64`] and
    /// [`exp2_f64`]), with C99's special cases: x⁰ = 1 and 1ʸ = 1 even for NaN, a negative x
    /// gives NaN for a non-integer y and the sign of its odd integer powers, (−1)^±∞ = 1,
    /// ±0 to a negative power is ∞.
    #[inline(always)]
    pub fn powf(self, y: Self) -> Self {
        let x = self;
        let magnitude = exp2_f64(y.to_f64() * log2_f64(x.abs().to_f64())).to_f32();
        let integer = y.round_ties_even().eq(y);
        let odd =
            integer & y.abs().lt(F32s::splat(16_777_216.0)) & (y.to_i32() & 1).eq(I32s::splat(1));
        let negative = x.sign_bit();
        let r = F32s::select(negative & odd, -magnitude, magnitude);
        let zero = F32s::splat(0.0);
        let r = F32s::select(
            (x.lt(zero) & x.is_finite()).and_not(integer) | x.is_nan() | y.is_nan(),
            nan(),
            r,
        );
        let one = F32s::splat(1.0);
        let unit =
            y.eq(zero) | x.eq(one) | (x.abs().eq(one) & y.abs().eq(F32s::splat(f32::INFINITY)));
        F32s::select(unit, one, r)
    }
}

/// sin x (the W = 1 instance of [`F32s::sin`]).
#[inline]
pub fn sin(x: f32) -> f32 {
    F32s([x]).sin().0[0]
}

/// cos x (the W = 1 instance of [`F32s::cos`]).
#[inline]
pub fn cos(x: f32) -> f32 {
    F32s([x]).cos().0[0]
}

/// (sin x, cos x) (the W = 1 instance of [`F32s::sin_cos`]).
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let (s, c) = F32s([x]).sin_cos();
    (s.0[0], c.0[0])
}

/// tan x (the W = 1 instance of [`F32s::tan`]).
#[inline]
pub fn tan(x: f32) -> f32 {
    F32s([x]).tan().0[0]
}

/// asin x (the W = 1 instance of [`F32s::asin`]).
#[inline]
pub fn asin(x: f32) -> f32 {
    F32s([x]).asin().0[0]
}

/// acos x (the W = 1 instance of [`F32s::acos`]).
#[inline]
pub fn acos(x: f32) -> f32 {
    F32s([x]).acos().0[0]
}

/// atan x (the W = 1 instance of [`F32s::atan`]).
#[inline]
pub fn atan(x: f32) -> f32 {
    F32s([x]).atan().0[0]
}

/// atan2(y, x) (the W = 1 instance of [`F32s::atan2`]).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    F32s([y]).atan2(F32s([x])).0[0]
}

/// eˣ (the W = 1 instance of [`F32s::exp`]).
#[inline]
pub fn exp(x: f32) -> f32 {
    F32s([x]).exp().0[0]
}

/// ln x (the W = 1 instance of [`F32s::ln`]).
#[inline]
pub fn ln(x: f32) -> f32 {
    F32s([x]).ln().0[0]
}

/// xʸ (the W = 1 instance of [`F32s::powf`]).
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    F32s([x]).powf(F32s([y])).0[0]
}

// ---------------------------------------------------------------------------------------------
// f64: sin, cos, sin_cos, asin, acos, atan and atan2 on `F64s<W>`.
//
// The algorithms and coefficients are those of Sun's fdlibm (1993; the versions in FreeBSD's
// msun and musl): the medium-range π/2 reduction of `__ieee754_rem_pio2`, the kernels
// `__kernel_sin` and `__kernel_cos`, the rational approximation of `__ieee754_asin` and
// `__ieee754_acos`, and `atan`'s four breakpoints. fdlibm chooses between their cases with
// branches; here every case a lane may need is computed and the lane's own case is selected,
// and the reduction always runs all three of fdlibm's rounds (which fdlibm takes only when the
// first ones cancel), so that no lane's result depends on another lane's value.
// ---------------------------------------------------------------------------------------------

/// 2/π to the nearest `f64`.
const INV_HALF_PI_F64: f64 = f64::from_bits(0x3FE4_5F30_6DC9_C883);
/// π/2 in fdlibm's parts for the medium-range reduction: `PIO2_1`, `PIO2_2` and `PIO2_3` have
/// 33 significant bits each, so k·`PIO2_i` is exact for |k| < 2²⁰, and `PIO2_3T` is the rest
/// (their sum is π/2 to 151 bits).
const PIO2_1: f64 = f64::from_bits(0x3FF9_21FB_5440_0000);
const PIO2_2: f64 = f64::from_bits(0x3DD0_B461_1A60_0000);
const PIO2_3: f64 = f64::from_bits(0x3BA3_198A_2E00_0000);
const PIO2_3T: f64 = f64::from_bits(0x397B_839A_2520_49C1);
/// π/2 as the nearest `f64` and the `f64` nearest the rest.
const PIO2_HI: f64 = f64::from_bits(0x3FF9_21FB_5444_2D18);
const PIO2_LO: f64 = f64::from_bits(0x3C91_A626_3314_5C07);
/// π as the nearest `f64` and the `f64` nearest the rest.
const PI_HI_F64: f64 = f64::from_bits(0x4009_21FB_5444_2D18);
const PI_LO_F64: f64 = f64::from_bits(0x3CA1_A626_3314_5C07);
/// The largest |x| the `f64` sin and cos reduce exactly: 2²⁰·π/2, below which k·`PIO2_i` is
/// exact (fdlibm's medium range).
pub const TRIG_F64_DOMAIN: f64 = 1_647_099.330_150_694;

/// x = k·π/2 + (y₀ + y₁) for |x| ≤ [`TRIG_F64_DOMAIN`], with y₀ + y₁ a double-double to about
/// 2⁻¹⁰⁰ relative, and k mod 4. fdlibm's medium case with all three of its rounds taken: the
/// first subtraction x − k·`PIO2_1` is exact (k·`PIO2_1` is exact and within a factor 2 of x,
/// or k = 0), and the next two subtract k·`PIO2_2` and k·`PIO2_3` with their rounding errors
/// kept exactly by Knuth's TwoSum (fdlibm's Fast2Sum needs |t| ≥ |w|, which a branch-free
/// reduction cannot assume) and added, with k·`PIO2_3T`, to the low part.
#[inline(always)]
fn reduce_half_pi_f64<const W: usize>(x: F64s<W>) -> (F64s<W>, F64s<W>, U32s<W>) {
    /// a − b and its rounding error e (a − b = s + e exactly).
    #[inline(always)]
    fn two_difference<const W: usize>(a: F64s<W>, b: F64s<W>) -> (F64s<W>, F64s<W>) {
        let s = a - b;
        let a_part = s + b;
        let b_part = s - a_part;
        (s, (a - a_part) - (b + b_part))
    }
    let shifted = x * INV_HALF_PI_F64 + ROUND_F64;
    let k = shifted - ROUND_F64;
    let r1 = x - k * PIO2_1;
    let (r2, e2) = two_difference(r1, k * PIO2_2);
    let (r3, e3) = two_difference(r2, k * PIO2_3);
    // r3 + (e2 + e3) − k·PIO2_3T: π/2 = PIO2_1 + PIO2_2 + PIO2_3 + PIO2_3T to 151 bits.
    let w = k * PIO2_3T - (e2 + e3);
    let y0 = r3 - w;
    let y1 = (r3 - y0) - w;
    (y0, y1, shifted.to_bits().low_u32() & 3)
}

/// fdlibm's `__kernel_sin` and `__kernel_cos` on |x + y| ≤ π/4 (y the low part, |y| ≤ ulp(x)/2):
/// degree-13 and degree-14 minimax polynomials, sin to within 2⁻⁵⁸ and cos within 2⁻⁵⁸ relative
/// before the last roundings, with y entering to first order. cos adds 1 − z/2 as a rounded
/// part w and its exact rounding error ((1 − w) − z/2).
#[inline(always)]
fn sin_cos_kernel_f64<const W: usize>(x: F64s<W>, y: F64s<W>) -> (F64s<W>, F64s<W>) {
    const S1: f64 = f64::from_bits(0xBFC5_5555_5555_5549);
    const S2: f64 = f64::from_bits(0x3F81_1111_1110_F8A6);
    const S3: f64 = f64::from_bits(0xBF2A_01A0_19C1_61D5);
    const S4: f64 = f64::from_bits(0x3EC7_1DE3_57B1_FE7D);
    const S5: f64 = f64::from_bits(0xBE5A_E5E6_8A2B_9CEB);
    const S6: f64 = f64::from_bits(0x3DE5_D93A_5ACF_D57C);
    const C1: f64 = f64::from_bits(0x3FA5_5555_5555_554C);
    const C2: f64 = f64::from_bits(0xBF56_C16C_16C1_5177);
    const C3: f64 = f64::from_bits(0x3EFA_01A0_19CB_1590);
    const C4: f64 = f64::from_bits(0xBE92_7E4F_809C_52AD);
    const C5: f64 = f64::from_bits(0x3E21_EE9E_BDB4_B1C4);
    const C6: f64 = f64::from_bits(0xBDA8_FAE9_BE88_38D4);
    let z = x * x;
    let w = z * z;
    let rs = (S2 + z * (S3 + z * S4)) + z * w * (S5 + z * S6);
    let v = z * x;
    let sin = x - ((z * (0.5 * y - v * rs) - y) - v * S1);
    let rc = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
    let hz = 0.5 * z;
    let one_minus = 1.0 - hz;
    let cos = one_minus + (((1.0 - one_minus) - hz) + (z * rc - x * y));
    (sin, cos)
}

/// fdlibm's R(z) = z·P(z)/Q(z) for asin √z·(1 + R): a rational minimax fit on z ∈ [0, 1/4],
/// error below 2⁻⁵⁸.
#[inline(always)]
fn asin_rational_f64<const W: usize>(z: F64s<W>) -> F64s<W> {
    const PS0: f64 = f64::from_bits(0x3FC5_5555_5555_5555);
    const PS1: f64 = f64::from_bits(0xBFD4_D612_03EB_6F7D);
    const PS2: f64 = f64::from_bits(0x3FC9_C155_0E88_4455);
    const PS3: f64 = f64::from_bits(0xBFA4_8228_B568_8F3B);
    const PS4: f64 = f64::from_bits(0x3F49_EFE0_7501_B288);
    const PS5: f64 = f64::from_bits(0x3F02_3DE1_0DFD_F709);
    const QS1: f64 = f64::from_bits(0xC003_3A27_1C8A_2D4B);
    const QS2: f64 = f64::from_bits(0x4000_2AE5_9C59_8AC8);
    const QS3: f64 = f64::from_bits(0xBFE6_066C_1B8D_0159);
    const QS4: f64 = f64::from_bits(0x3FB3_B8C5_B12E_9282);
    let p = z * horner_f64(z, [PS5, PS4, PS3, PS2, PS1, PS0]);
    let q = horner_f64(z, [QS4, QS3, QS2, QS1, 1.0]);
    p / q
}

/// s with the low 32 bits of its mantissa cleared: s·s is then exact, and
/// c = (z − s_hi²)/(s + s_hi) is √z − s_hi to about 2⁻⁵⁰ relative (fdlibm's trick for carrying
/// √z to more than 53 bits).
#[inline(always)]
fn high_half_f64<const W: usize>(s: F64s<W>) -> F64s<W> {
    F64s::from_bits(s.to_bits() & 0xFFFF_FFFF_0000_0000)
}

/// atan t for t ≥ 0 (t = ∞ gives π/2), fdlibm's `atan`: t is brought into |u| ≤ 7/16 by
/// atan t = atan c + atan((t − c)/(1 + c·t)) with c = 1/2, 1, 3/2 or ∞ (breakpoints 7/16,
/// 11/16, 19/16, 39/16), atan c in two parts, and atan u = u − u·(odd and even polynomials
/// in u², degree 22).
#[inline(always)]
fn atan_nonnegative_f64<const W: usize>(t: F64s<W>) -> F64s<W> {
    const AT: [f64; 11] = [
        f64::from_bits(0x3FD5_5555_5555_550D),
        f64::from_bits(0xBFC9_9999_9998_EBC4),
        f64::from_bits(0x3FC2_4924_9200_83FF),
        f64::from_bits(0xBFBC_71C6_FE23_1671),
        f64::from_bits(0x3FB7_45CD_C54C_206E),
        f64::from_bits(0xBFB3_B0F2_AF74_9A6D),
        f64::from_bits(0x3FB1_0D66_A0D0_3D51),
        f64::from_bits(0xBFAD_DE2D_52DE_FD9A),
        f64::from_bits(0x3FA9_7B4B_2476_0DEB),
        f64::from_bits(0xBFA2_B444_2C6A_6C2F),
        f64::from_bits(0x3F90_AD3A_E322_DA11),
    ];
    // atan(1/2), atan 1, atan(3/2), atan ∞ in two parts.
    const HI: [f64; 4] = [
        f64::from_bits(0x3FDD_AC67_0561_BB4F),
        f64::from_bits(0x3FE9_21FB_5444_2D18),
        f64::from_bits(0x3FEF_730B_D281_F69B),
        PIO2_HI,
    ];
    const LO: [f64; 4] = [
        f64::from_bits(0x3C7A_2B7F_222F_65E2),
        f64::from_bits(0x3C81_A626_3314_5C07),
        f64::from_bits(0x3C70_0788_7AF0_CBBD),
        PIO2_LO,
    ];
    let small = t.lt(F64s::splat(0.4375));
    let b0 = t.lt(F64s::splat(0.6875));
    let b1 = t.lt(F64s::splat(1.1875));
    let b2 = t.lt(F64s::splat(2.4375));
    let one = F64s::splat(1.0);
    // Numerator and denominator of u for each case; both are exact or one rounding each,
    // as in fdlibm.
    let num = F64s::select(
        b0,
        2.0 * t - 1.0,
        F64s::select(b1, t - 1.0, F64s::select(b2, t - 1.5, -one)),
    );
    let den = F64s::select(
        b0,
        2.0 + t,
        F64s::select(b1, t + 1.0, F64s::select(b2, 1.0 + 1.5 * t, t)),
    );
    let u = F64s::select(small, t, num / den);
    let z = u * u;
    let w = z * z;
    let s1 = z * (AT[0] + w * (AT[2] + w * (AT[4] + w * (AT[6] + w * (AT[8] + w * AT[10])))));
    let s2 = w * (AT[1] + w * (AT[3] + w * (AT[5] + w * (AT[7] + w * AT[9]))));
    let pick = |table: [f64; 4]| {
        F64s::select(
            b0,
            F64s::splat(table[0]),
            F64s::select(
                b1,
                F64s::splat(table[1]),
                F64s::select(b2, F64s::splat(table[2]), F64s::splat(table[3])),
            ),
        )
    };
    let reduced = pick(HI) - ((u * (s1 + s2) - pick(LO)) - u);
    F64s::select(small, u - u * (s1 + s2), reduced)
}

/// |x| below this: sin x = x and asin x = x, atan x = x after rounding (fdlibm's thresholds).
const SIN_IS_X_F64: f64 = 1.0 / 67_108_864.0; // 2⁻²⁶

impl<const W: usize> F64s<W> {
    /// sin x and cos x from one reduction (see [`sin`](Self::sin) and [`cos`](Self::cos)).
    #[inline(always)]
    pub fn sin_cos(self) -> (Self, Self) {
        let (y0, y1, quadrant) = reduce_half_pi_f64(self);
        let (s, c) = sin_cos_kernel_f64(y0, y1);
        // sin(kπ/2 + r) = s, c, −s, −c and cos(kπ/2 + r) = c, −s, −c, s for k mod 4 = 0 … 3.
        let odd = (quadrant & 1).ne(U32s::splat(0));
        let flip = |v: Self, by: U32s<W>| Self::select(by.ne(U32s::splat(0)), -v, v);
        let sin = flip(Self::select(odd, c, s), quadrant & 2);
        let cos = flip(Self::select(odd, s, c), (quadrant + 1) & 2);
        let sin = Self::select(self.abs().lt(Self::splat(SIN_IS_X_F64)), self, sin);
        let finite = self.is_finite();
        let nan = Self::splat(f64::NAN);
        (
            Self::select(finite, sin, nan),
            Self::select(finite, cos, nan),
        )
    }

    /// sin x within 1 ulp for |x| ≤ [`TRIG_F64_DOMAIN`] (2²⁰·π/2; largest error seen 0.78
    /// ulp); NaN for ±∞ and NaN, sin ±0 = ±0. Beyond the domain the reduction is no longer
    /// exact and the result is not accurate (the same at every width all the same); lumo's
    /// angles lie in [−π, 3π].
    #[inline(always)]
    pub fn sin(self) -> Self {
        self.sin_cos().0
    }

    /// cos x within 1 ulp for |x| ≤ [`TRIG_F64_DOMAIN`] (largest error seen 0.78 ulp); NaN for
    /// ±∞ and NaN (as [`sin`](Self::sin) beyond the domain).
    #[inline(always)]
    pub fn cos(self) -> Self {
        self.sin_cos().1
    }

    /// asin x ∈ [−π/2, π/2] within 1 ulp on [−1, 1] (largest error seen 0.88 ulp; NaN outside;
    /// asin ±0 = ±0), fdlibm's
    /// `asin`: x + x·R(x²) for |x| < 1/2; above, asin a = π/2 − 2 asin √((1 − a)/2) with √ in
    /// two parts (hi + c) below 0.975 and in one part above.
    #[inline(always)]
    pub fn asin(self) -> Self {
        let a = self.abs();
        let inner = self + self * asin_rational_f64(self * self);
        let z = (1.0 - a) * 0.5;
        let s = z.sqrt();
        let r = asin_rational_f64(z);
        let steep = PIO2_HI - (2.0 * (s + s * r) - PIO2_LO);
        let f = high_half_f64(s);
        let c = (z - f * f) / (s + f);
        let quarter = 0.5 * PIO2_HI;
        let middle = quarter - ((2.0 * s * r - (PIO2_LO - 2.0 * c)) - (quarter - 2.0 * f));
        let outer = Self::select(a.ge(Self::splat(0.975)), steep, middle).copysign(self);
        let result = Self::select(a.lt(Self::splat(0.5)), inner, outer);
        let result = Self::select(a.lt(Self::splat(SIN_IS_X_F64)), self, result);
        Self::select(a.le(Self::splat(1.0)), result, Self::splat(f64::NAN))
    }

    /// acos x ∈ [0, π] within 1 ulp on [−1, 1] (largest error seen 0.89 ulp; NaN outside),
    /// fdlibm's `acos`:
    /// π/2 − (x + x·R(x²)) for |x| < 1/2, 2 asin √((1 − x)/2) above (√ in two parts) and
    /// π − 2 asin √((1 + x)/2) below.
    #[inline(always)]
    pub fn acos(self) -> Self {
        let x = self;
        let centre = PIO2_HI - (x - (PIO2_LO - x * asin_rational_f64(x * x)));
        let zl = (1.0 + x) * 0.5;
        let sl = zl.sqrt();
        let left = 2.0 * (PIO2_HI - (sl + (asin_rational_f64(zl) * sl - PIO2_LO)));
        let zr = (1.0 - x) * 0.5;
        let sr = zr.sqrt();
        let df = high_half_f64(sr);
        // (0/0 at x = 1, where the correction is 0.)
        let c = Self::select(zr.eq(Self::splat(0.0)), zr, (zr - df * df) / (sr + df));
        let right = 2.0 * (df + (asin_rational_f64(zr) * sr + c));
        let a = x.abs();
        let side = Self::select(x.sign_bit(), left, right);
        let result = Self::select(a.lt(Self::splat(0.5)), centre, side);
        Self::select(a.le(Self::splat(1.0)), result, Self::splat(f64::NAN))
    }

    /// atan x ∈ [−π/2, π/2] within 1 ulp everywhere (largest error seen 0.81 ulp; atan ±∞ =
    /// ±π/2, atan ±0 = ±0).
    #[inline(always)]
    pub fn atan(self) -> Self {
        let a = atan_nonnegative_f64(self.abs()).copysign(self);
        let a = Self::select(self.abs().lt(Self::splat(SIN_IS_X_F64)), self, a);
        Self::select(self.is_nan(), Self::splat(f64::NAN), a)
    }

    /// atan2(self, x) (self is y, as in `f64::atan2`) ∈ [−π, π] within 2 ulp everywhere
    /// (largest error seen 1.49 ulp),
    /// with C99's special cases: atan2(±0, +0) = ±0, atan2(±0, −0) = ±π, atan2(±∞, +∞) = ±π/4,
    /// atan2(±∞, −∞) = ±3π/4; NaN if either is NaN. atan |y/x| from one rounded quotient
    /// (atan's condition number is at most 1, so the quotient's half ulp stays half an ulp),
    /// then π − atan |y/x| (π in two parts) for x < 0, and y's sign.
    #[inline(always)]
    pub fn atan2(self, x: Self) -> Self {
        let (ay, ax) = (self.abs(), x.abs());
        let inf = Self::splat(f64::INFINITY);
        let zero = Self::splat(0.0);
        let one = Self::splat(1.0);
        let both_zero = ay.eq(zero) & ax.eq(zero);
        let both_infinite = ay.eq(inf) & ax.eq(inf);
        // 0/0 → 0 and ∞/∞ → 1 (atan 1 = π/4 as the nearest f64).
        let num = Self::select(both_infinite, one, Self::select(both_zero, zero, ay));
        let den = Self::select(both_infinite | both_zero, one, ax);
        let z = atan_nonnegative_f64(num / den);
        let reflected = PI_HI_F64 - (z - PI_LO_F64);
        let a = Self::select(x.sign_bit(), reflected, z);
        // |y/x| > 2⁶⁴ (x = ±0 and y = ±∞ with x finite included): π/2 on either side, as
        // fdlibm (π − π/2 would round away from π/2's nearest f64).
        let steep = ay.gt(ax * 18_446_744_073_709_551_616.0) | (ay.eq(inf) & ax.lt(inf));
        let a = Self::select(steep, Self::splat(PIO2_HI), a).copysign(self);
        Self::select(self.is_nan() | x.is_nan(), Self::splat(f64::NAN), a)
    }
}

/// sin x in `f64` (the W = 1 instance of [`F64s::sin`]).
#[inline]
pub fn sin_f64(x: f64) -> f64 {
    F64s([x]).sin().0[0]
}

/// cos x in `f64` (the W = 1 instance of [`F64s::cos`]).
#[inline]
pub fn cos_f64(x: f64) -> f64 {
    F64s([x]).cos().0[0]
}

/// (sin x, cos x) in `f64` (the W = 1 instance of [`F64s::sin_cos`]).
#[inline]
pub fn sin_cos_f64(x: f64) -> (f64, f64) {
    let (s, c) = F64s([x]).sin_cos();
    (s.0[0], c.0[0])
}

/// asin x in `f64` (the W = 1 instance of [`F64s::asin`]).
#[inline]
pub fn asin_f64(x: f64) -> f64 {
    F64s([x]).asin().0[0]
}

/// acos x in `f64` (the W = 1 instance of [`F64s::acos`]).
#[inline]
pub fn acos_f64(x: f64) -> f64 {
    F64s([x]).acos().0[0]
}

/// atan x in `f64` (the W = 1 instance of [`F64s::atan`]).
#[inline]
pub fn atan_f64(x: f64) -> f64 {
    F64s([x]).atan().0[0]
}

/// atan2(y, x) in `f64` (the W = 1 instance of [`F64s::atan2`]).
#[inline]
pub fn atan2_f64(y: f64, x: f64) -> f64 {
    F64s([y]).atan2(F64s([x])).0[0]
}
