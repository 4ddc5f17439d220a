//! The `f64` functions of [`math`] checked: every width gives the bits of W = 1 (also the
//! W = 16 instance compiled for AVX-512 and for AVX2), and each stays within its stated error,
//! measured against a double-double reference (about 100 significant bits; see [`Dd`]).
//!
//! The sampled tests run over ≥ 2²⁰ arguments per function: edge values (±0, ±∞, NaNs,
//! subnormals, powers of two, fdlibm's breakpoints and their neighbours, multiples of π/4 and of
//! π/2 up to 2²⁰ with their neighbours, the ends of each domain) and a stratified sweep of
//! mantissas in every exponent of the function's domain, both signs. The ignored test
//! (`nice cargo test --release -p lumo --lib lanes::tests_f64::sampled_widely -- --ignored
//! --nocapture`) runs 2²⁴ pseudo-random arguments per function (pairs for atan2), W = 16
//! compiled for AVX-512 against W = 1, and also measures glibc's `f64` functions against the
//! same reference, which checks the reference. Its run of 2026-12-02 on the Zen 5 machine:
//!
//! ```text
//! sin       max 0.773 ulp at 3.4454734138474937e3 (0x40aaeaf2634cc0eb), glibc 0.515, 0 lanes differ, 20 s
//! cos       max 0.782 ulp at -4.6474449091720843e5 (0xc11c5da1f6b3002d), glibc 0.515, 0 lanes differ, 193 s
//! asin      max 0.876 ulp at -5.075910189465597e-1 (0xbfe03e2f8543cd21), glibc 0.515, 0 lanes differ, 34 s
//! acos      max 0.889 ulp at -5.247245049298618e-1 (0xbfe0ca8b0b82ac6b), glibc 0.520, 0 lanes differ, 42 s
//! atan      max 0.809 ulp at -6.754710158498509e-1 (0xbfe59d75644f127e), glibc 0.513, 0 lanes differ, 13 s
//! atan2     max 1.481 ulp at (267296696.7268018, 2130783540.0026743), 0 lanes differ, 14 s
//! ```
//!
//! (cos's 193 s ran beside a build.) glibc's largest errors, about half an ulp, show the
//! reference is good to far better than the bounds need.

use super::math::{self, TRIG_F64_DOMAIN};
use super::*;

/// A double-double hi + lo (|lo| ≤ ulp(hi)/2), after Dekker (1971) and the QD library of Hida,
/// Li and Bailey (2001). Products use `mul_add` for their exact error term (this is the test's
/// reference, not lane code).
#[derive(Clone, Copy, Debug)]
struct Dd(f64, f64);

impl Dd {
    fn new(x: f64) -> Self {
        Dd(x, 0.0)
    }

    fn two_sum(a: f64, b: f64) -> Self {
        let s = a + b;
        let bb = s - a;
        Dd(s, (a - (s - bb)) + (b - bb))
    }

    fn quick_two_sum(a: f64, b: f64) -> Self {
        let s = a + b;
        Dd(s, b - (s - a))
    }

    fn two_prod(a: f64, b: f64) -> Self {
        let p = a * b;
        Dd(p, a.mul_add(b, -p))
    }

    fn add(self, b: Dd) -> Dd {
        let s = Dd::two_sum(self.0, b.0);
        let t = Dd::two_sum(self.1, b.1);
        let s = Dd::quick_two_sum(s.0, s.1 + t.0);
        Dd::quick_two_sum(s.0, s.1 + t.1)
    }

    fn neg(self) -> Dd {
        Dd(-self.0, -self.1)
    }

    fn sub(self, b: Dd) -> Dd {
        self.add(b.neg())
    }

    fn mul(self, b: Dd) -> Dd {
        let p = Dd::two_prod(self.0, b.0);
        Dd::quick_two_sum(p.0, p.1 + (self.0 * b.1 + self.1 * b.0))
    }

    fn div(self, b: Dd) -> Dd {
        let q1 = self.0 / b.0;
        let r = self.sub(b.mul(Dd::new(q1)));
        let q2 = r.0 / b.0;
        let r = r.sub(b.mul(Dd::new(q2)));
        let q3 = r.0 / b.0;
        Dd::quick_two_sum(q1, q2).add(Dd::new(q3))
    }
}

/// π/2 in four parts (QD's `qd_real::_pi2`, 1.570796326794896558e0, 6.123233995736766036e-17,
/// −1.497384904859169833e-33, 5.562271104316826408e-50: 212 bits).
const HALF_PI_PARTS: [f64; 4] = [
    f64::from_bits(0x3FF9_21FB_5444_2D18),
    f64::from_bits(0x3C91_A626_3314_5C07),
    f64::from_bits(0xB91F_1976_B7ED_8FBC),
    f64::from_bits(0x35B4_CF98_E804_177D),
];

fn half_pi() -> Dd {
    Dd::quick_two_sum(HALF_PI_PARTS[0], HALF_PI_PARTS[1])
}

fn pi() -> Dd {
    Dd::quick_two_sum(2.0 * HALF_PI_PARTS[0], 2.0 * HALF_PI_PARTS[1])
}

/// (sin x, cos x) for |x| < 2²¹: x − k·π/2 with π/2 to 212 bits (every k·part exact as a
/// double-double), then the Taylor series to the 29th power on |r| ≤ π/4 (truncation below
/// 2⁻¹⁰⁵ relative).
fn dd_sin_cos(x: Dd) -> (Dd, Dd) {
    assert!(x.0.abs() < 2_097_152.0, "reference reduction out of range");
    let k = (x.0 * std::f64::consts::FRAC_2_PI).round();
    let mut r = x;
    for part in HALF_PI_PARTS {
        r = r.sub(Dd::two_prod(k, part));
    }
    let r2 = r.mul(r);
    // 1/n! for n = 0 … 29, computed once.
    static INVERSE_FACTORIALS: std::sync::OnceLock<[Dd; 30]> = std::sync::OnceLock::new();
    let inverse = INVERSE_FACTORIALS.get_or_init(|| {
        let mut inverse = [Dd::new(1.0); 30];
        for n in 1..30 {
            inverse[n] = inverse[n - 1].div(Dd::new(n as f64));
        }
        inverse
    });
    let series = |first: usize| {
        let mut s = Dd::new(0.0);
        for n in (first..30).step_by(2).rev() {
            let c = if (n / 2) % 2 == 0 {
                inverse[n]
            } else {
                inverse[n].neg()
            };
            s = s.mul(r2).add(c);
        }
        s
    };
    let sin = series(1).mul(r);
    let cos = series(0);
    match (k as i64).rem_euclid(4) {
        0 => (sin, cos),
        1 => (cos, sin.neg()),
        2 => (sin.neg(), cos.neg()),
        _ => (cos.neg(), sin),
    }
}

/// asin x: one Newton step on sin y = x from glibc's asin (quadratic: from 2⁻⁵² to below
/// 2⁻⁷⁸ even at 1 − 2⁻⁵³, where cos y ≈ 1.5·10⁻⁸ slows it most).
fn dd_asin(x: f64) -> Dd {
    if x.abs() == 1.0 {
        return Dd(HALF_PI_PARTS[0].copysign(x), HALF_PI_PARTS[1].copysign(x));
    }
    let y0 = x.asin();
    let (s, c) = dd_sin_cos(Dd::new(y0));
    Dd::new(y0).sub(s.sub(Dd::new(x)).div(c))
}

/// acos x: one Newton step on cos y = x from glibc's acos.
fn dd_acos(x: f64) -> Dd {
    if x == 1.0 {
        return Dd::new(0.0);
    }
    if x == -1.0 {
        return pi();
    }
    let y0 = x.acos();
    let (s, c) = dd_sin_cos(Dd::new(y0));
    Dd::new(y0).add(c.sub(Dd::new(x)).div(s))
}

/// The angle θ ∈ [0, π/2] of (x, y), x, y ≥ 0 finite and not both 0: one Newton step on
/// y cos θ − x sin θ = 0 from glibc's atan2, after scaling both by one power of two; for
/// ratios beyond 2⁶⁰ the series' first two terms (y/x, or π/2 − x/y).
fn dd_angle(y: f64, x: f64) -> Dd {
    if y == 0.0 {
        return Dd::new(0.0);
    }
    if x == 0.0 {
        return half_pi();
    }
    let small = 2f64.powi(-60);
    if y < x * small {
        return Dd::new(y).div(Dd::new(x));
    }
    if x < y * small {
        return half_pi().sub(Dd::new(x).div(Dd::new(y)));
    }
    let e = x.max(y).log2().floor() as i32;
    let scale = 2f64.powi(-e.clamp(-1000, 1000));
    let (y, x) = (y * scale, x * scale);
    let (y, x) = if !(-1000..=1000).contains(&e) {
        let s = 2f64.powi(-(e - e.clamp(-1000, 1000)));
        (y * s, x * s)
    } else {
        (y, x)
    };
    let t0 = y.atan2(x);
    let (s, c) = dd_sin_cos(Dd::new(t0));
    let (y, x) = (Dd::new(y), Dd::new(x));
    let f = y.mul(c).sub(x.mul(s));
    let df = y.mul(s).add(x.mul(c));
    Dd::new(t0).add(f.div(df))
}

/// atan x.
fn dd_atan(x: f64) -> Dd {
    let a = dd_angle(x.abs(), 1.0);
    if x < 0.0 {
        a.neg()
    } else {
        a
    }
}

/// atan2(y, x), with C99's special cases taken from the platform's atan2.
fn dd_atan2(y: f64, x: f64) -> Dd {
    if y.is_nan() || x.is_nan() || y == 0.0 || x.is_infinite() || y.is_infinite() {
        return Dd::new(y.atan2(x));
    }
    let a = dd_angle(y.abs(), x.abs());
    let a = if x.is_sign_negative() { pi().sub(a) } else { a };
    if y < 0.0 {
        a.neg()
    } else {
        a
    }
}

/// The error of `got` in ulp of the f64 nearest `want` (0 where `got` is that f64, the same
/// infinity, or a NaN for a NaN; ∞ where a NaN is wrong or missing). The ulp is that of the
/// binade holding the exact value (the one below when hi is a power of two and lo < 0).
fn ulp_error(got: f64, want: Dd) -> f64 {
    if want.0.is_nan() || got.is_nan() {
        return if want.0.is_nan() && got.is_nan() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    if want.0.is_infinite() || got.is_infinite() {
        return if got == want.0 { 0.0 } else { f64::INFINITY };
    }
    let bits = want.0.abs().to_bits();
    let mut exponent = ((bits >> 52) & 0x7ff) as i32 - 1023;
    if bits & 0x000f_ffff_ffff_ffff == 0 && want.1 != 0.0 && want.1.signum() != want.0.signum() {
        exponent -= 1;
    }
    let ulp = pow2(exponent.max(-1022) - 52);
    ((got - want.0) - want.1).abs() / ulp
}

/// 2ᵉ for e = −1074 … 1023, from its bits (`powi` divides by 2⁻ᵉ, which overflows below
/// −1023).
fn pow2(e: i32) -> f64 {
    assert!((-1074..=1023).contains(&e));
    if e >= -1022 {
        f64::from_bits(((e + 1023) as u64) << 52)
    } else {
        f64::from_bits(1 << (e + 1074))
    }
}

/// A well-mixed 64-bit hash (SplitMix64's finaliser), for reproducible pseudo-random inputs.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn neighbours(x: f64, n: i64, out: &mut Vec<f64>) {
    for d in -n..=n {
        out.push(f64::from_bits(x.to_bits().wrapping_add_signed(d)));
    }
}

/// Edge values, both signs: zeros, infinities, NaNs, subnormals, powers of two, the
/// breakpoints of fdlibm's cases and the ends of the domains with their neighbours, and
/// multiples of π/4 (k < 4096) and of π/2 (pseudo-random k < 2²⁰) with their neighbours.
fn edge_values() -> Vec<f64> {
    let mut v = vec![
        0.0,
        f64::INFINITY,
        f64::NAN,
        f64::from_bits(0x7ff0_0000_0000_0001), // signalling NaN
        f64::from_bits(0x7fff_ffff_ffff_ffff),
        f64::MIN_POSITIVE,
        f64::from_bits(1),
        f64::from_bits(0x000f_ffff_ffff_ffff),
        f64::MAX,
        TRIG_F64_DOMAIN,
    ];
    for e in -1074..=1023 {
        v.push(pow2(e));
    }
    for b in [
        1.0,
        0.5,
        0.975,
        0.4375,
        0.6875,
        1.1875,
        2.4375,
        1.0 / 67_108_864.0,
        2f64.powi(-27),
        2f64.powi(66),
    ] {
        neighbours(b, 3, &mut v);
    }
    for k in 1..4096 {
        neighbours(k as f64 * std::f64::consts::FRAC_PI_4, 2, &mut v);
    }
    for i in 0..4096 {
        let k = (mix(i) >> 44) as f64;
        neighbours(k * std::f64::consts::FRAC_PI_2, 1, &mut v);
    }
    v.iter().flat_map(|&x| [x, -x]).collect()
}

/// [`edge_values`] and `per_exponent` mantissas (strata, a pseudo-random point in each) in
/// each biased exponent 0 … `top_exponent` of both signs.
fn sweep(top_exponent: u64, per_exponent: u64) -> Vec<f64> {
    let mut v = edge_values();
    let stratum = (1u64 << 52) / per_exponent;
    for sign in [0u64, 1] {
        for exponent in 0..=top_exponent {
            for s in 0..per_exponent {
                let seed = sign << 62 | exponent << 30 | s;
                let mantissa = s * stratum + mix(seed) % stratum;
                v.push(f64::from_bits(sign << 63 | exponent << 52 | mantissa));
            }
        }
    }
    v
}

/// The arguments of sin and cos: the sweep of |x| < 2²¹ (exponents up to 1043 + 1), 512
/// mantissas each, and the edges.
fn trig_arguments() -> Vec<f64> {
    sweep(1044, 512)
}

/// The arguments of asin and acos: exponents up to 1023 (|x| < 2), 256 mantissas each, and
/// 2¹⁸ points uniform in [−1, 1] and as many at 1 − 2⁻ᵏ·u.
fn inverse_sine_arguments() -> Vec<f64> {
    let mut v = sweep(1023, 256);
    for i in 0..1u64 << 18 {
        let u = (mix(i) >> 11) as f64 / (1u64 << 53) as f64;
        v.push(2.0 * u - 1.0);
        let k = (mix(i + (1 << 40)) % 53) as i32;
        let w = 1.0 - 2f64.powi(-k) * u;
        v.push(if i % 2 == 0 { w } else { -w });
    }
    v
}

/// The arguments of atan: every exponent, 256 mantissas each, and the edges.
fn atan_arguments() -> Vec<f64> {
    sweep(2047, 256)
}

/// Pairs for atan2: the atan sweep against itself reordered, the edges against each other,
/// and points on circles of radius 10⁻³⁰⁰ … 10³⁰⁰ (the renderer's use: a direction's
/// components).
fn atan2_pairs() -> Vec<(f64, f64)> {
    let a = atan_arguments();
    let n = a.len();
    let mut pairs: Vec<(f64, f64)> = (0..n)
        .map(|i| (a[i], a[(i as u64 * 0x9e37_79b9 % n as u64) as usize]))
        .collect();
    let edges = edge_values();
    for &x in edges.iter().step_by(97) {
        for &y in edges.iter().step_by(89) {
            pairs.push((x, y));
        }
    }
    for k in 0..50_000u64 {
        let u = (mix(k) >> 11) as f64 / (1u64 << 53) as f64;
        let angle = std::f64::consts::TAU * u - std::f64::consts::PI;
        let r = 10f64.powi((k % 61) as i32 * 10 - 300);
        pairs.push((r * angle.sin(), r * angle.cos()));
    }
    pairs
}

/// A function of one argument under test.
trait Unary: Sync {
    const NAME: &'static str;
    /// Maximum error in ulp (the bound `math` states).
    const BOUND: f64;
    fn lanes<const W: usize>(x: F64s<W>) -> F64s<W>;
    fn scalar(x: f64) -> f64;
    fn reference(x: f64) -> Dd;
    fn platform(x: f64) -> f64;
    /// Whether the error bound applies at x (the bits must agree everywhere).
    fn in_domain(x: f64) -> bool;
}

macro_rules! unary {
    ($name:ident, $label:expr, $method:ident, $scalar:path, $bound:expr, $reference:expr, $platform:expr, $domain:expr) => {
        struct $name;
        impl Unary for $name {
            const NAME: &'static str = $label;
            const BOUND: f64 = $bound;
            #[inline(always)]
            fn lanes<const W: usize>(x: F64s<W>) -> F64s<W> {
                $method(x)
            }
            fn scalar(x: f64) -> f64 {
                $scalar(x)
            }
            fn reference(x: f64) -> Dd {
                $reference(x)
            }
            fn platform(x: f64) -> f64 {
                $platform(x)
            }
            fn in_domain(x: f64) -> bool {
                $domain(x)
            }
        }
    };
}

fn trig_domain(x: f64) -> bool {
    x.abs() <= TRIG_F64_DOMAIN || !x.is_finite()
}

fn nan_reference(x: f64) -> Option<Dd> {
    (!x.is_finite()).then_some(Dd::new(f64::NAN))
}

#[inline(always)]
fn lanes_sin<const W: usize>(x: F64s<W>) -> F64s<W> {
    x.sin()
}
#[inline(always)]
fn lanes_cos<const W: usize>(x: F64s<W>) -> F64s<W> {
    x.cos()
}
#[inline(always)]
fn lanes_sin_of_sin_cos<const W: usize>(x: F64s<W>) -> F64s<W> {
    x.sin_cos().0
}
#[inline(always)]
fn lanes_cos_of_sin_cos<const W: usize>(x: F64s<W>) -> F64s<W> {
    x.sin_cos().1
}
#[inline(always)]
fn lanes_asin<const W: usize>(x: F64s<W>) -> F64s<W> {
    x.asin()
}
#[inline(always)]
fn lanes_acos<const W: usize>(x: F64s<W>) -> F64s<W> {
    x.acos()
}
#[inline(always)]
fn lanes_atan<const W: usize>(x: F64s<W>) -> F64s<W> {
    x.atan()
}

fn ref_sin(x: f64) -> Dd {
    nan_reference(x).unwrap_or_else(|| dd_sin_cos(Dd::new(x)).0)
}
fn ref_cos(x: f64) -> Dd {
    nan_reference(x).unwrap_or_else(|| dd_sin_cos(Dd::new(x)).1)
}
fn ref_asin(x: f64) -> Dd {
    if x.abs() <= 1.0 {
        dd_asin(x)
    } else {
        Dd::new(f64::NAN)
    }
}
fn ref_acos(x: f64) -> Dd {
    if x.abs() <= 1.0 {
        dd_acos(x)
    } else {
        Dd::new(f64::NAN)
    }
}
fn ref_atan(x: f64) -> Dd {
    if x.is_nan() {
        Dd::new(f64::NAN)
    } else if x.is_infinite() {
        Dd(HALF_PI_PARTS[0].copysign(x), HALF_PI_PARTS[1].copysign(x))
    } else {
        dd_atan(x)
    }
}
fn everywhere(_: f64) -> bool {
    true
}

unary!(
    Sin,
    "sin",
    lanes_sin,
    math::sin_f64,
    1.0,
    ref_sin,
    f64::sin,
    trig_domain
);
unary!(
    Cos,
    "cos",
    lanes_cos,
    math::cos_f64,
    1.0,
    ref_cos,
    f64::cos,
    trig_domain
);
unary!(
    SinOfSinCos,
    "sin_cos.0",
    lanes_sin_of_sin_cos,
    sin_of_sin_cos,
    1.0,
    ref_sin,
    f64::sin,
    trig_domain
);
unary!(
    CosOfSinCos,
    "sin_cos.1",
    lanes_cos_of_sin_cos,
    cos_of_sin_cos,
    1.0,
    ref_cos,
    f64::cos,
    trig_domain
);
unary!(
    Asin,
    "asin",
    lanes_asin,
    math::asin_f64,
    1.0,
    ref_asin,
    f64::asin,
    everywhere
);
unary!(
    Acos,
    "acos",
    lanes_acos,
    math::acos_f64,
    1.0,
    ref_acos,
    f64::acos,
    everywhere
);
unary!(
    Atan,
    "atan",
    lanes_atan,
    math::atan_f64,
    1.0,
    ref_atan,
    f64::atan,
    everywhere
);

fn sin_of_sin_cos(x: f64) -> f64 {
    math::sin_cos_f64(x).0
}
fn cos_of_sin_cos(x: f64) -> f64 {
    math::sin_cos_f64(x).1
}

/// atan2 under test.
struct Atan2;
impl Atan2 {
    const NAME: &'static str = "atan2";
    const BOUND: f64 = 2.0;
}

/// A unary function's bits over `xs` at width W.
#[inline(always)]
fn bits_unary<F: Unary, const W: usize>(xs: &[f64]) -> Vec<u64> {
    let mut out = Vec::with_capacity(xs.len());
    for chunk in xs.chunks(W) {
        let lanes = F64s::<W>::from_fn(|i| chunk.get(i).copied().unwrap_or(0.0));
        out.extend_from_slice(&F::lanes(lanes).to_bits().0[..chunk.len()]);
    }
    out
}

/// atan2's bits over `pairs` (y, x) at width W.
#[inline(always)]
fn bits_atan2<const W: usize>(pairs: &[(f64, f64)]) -> Vec<u64> {
    let mut out = Vec::with_capacity(pairs.len());
    for chunk in pairs.chunks(W) {
        let y = F64s::<W>::from_fn(|i| chunk.get(i).map_or(0.0, |p| p.0));
        let x = F64s::<W>::from_fn(|i| chunk.get(i).map_or(0.0, |p| p.1));
        out.extend_from_slice(&y.atan2(x).to_bits().0[..chunk.len()]);
    }
    out
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn bits_unary_avx512<F: Unary>(xs: &[f64]) -> Vec<u64> {
    bits_unary::<F, 16>(xs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bits_unary_avx2<F: Unary>(xs: &[f64]) -> Vec<u64> {
    bits_unary::<F, 16>(xs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn bits_atan2_avx512(pairs: &[(f64, f64)]) -> Vec<u64> {
    bits_atan2::<16>(pairs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bits_atan2_avx2(pairs: &[(f64, f64)]) -> Vec<u64> {
    bits_atan2::<16>(pairs)
}

/// Panics naming the first argument where some width's bits differ from W = 1's.
fn assert_same_bits(
    name: &str,
    one: &[u64],
    others: Vec<(&str, Vec<u64>)>,
    at: impl Fn(usize) -> String,
) {
    for (width, bits) in others {
        if let Some(i) = one.iter().zip(&bits).position(|(a, b)| a != b) {
            panic!(
                "{name}: {width} differs from W=1 at {}: {:#018x} against {:#018x}",
                at(i),
                bits[i],
                one[i]
            );
        }
    }
}

/// Every width's bits (and the AVX-512 and AVX2 builds' where the CPU has them) against
/// W = 1's, and W = 1's against the scalar entry point's; returns W = 1's bits.
fn check_widths_unary<F: Unary>(xs: &[f64]) -> Vec<u64> {
    let one = bits_unary::<F, 1>(xs);
    let mut others = vec![
        ("W=4", bits_unary::<F, 4>(xs)),
        ("W=8", bits_unary::<F, 8>(xs)),
        ("W=16", bits_unary::<F, 16>(xs)),
        (
            "scalar",
            xs.iter().map(|&x| F::scalar(x).to_bits()).collect(),
        ),
    ];
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            others.push(("avx512f W=16", unsafe { bits_unary_avx512::<F>(xs) }));
        }
        if is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            others.push(("avx2 W=16", unsafe { bits_unary_avx2::<F>(xs) }));
        }
    }
    assert_same_bits(F::NAME, &one, others, |i| {
        format!("x = {:e} ({:#018x})", xs[i], xs[i].to_bits())
    });
    one
}

/// [`check_widths_unary`] for atan2.
fn check_widths_atan2(pairs: &[(f64, f64)]) -> Vec<u64> {
    let one = bits_atan2::<1>(pairs);
    let mut others = vec![
        ("W=4", bits_atan2::<4>(pairs)),
        ("W=8", bits_atan2::<8>(pairs)),
        ("W=16", bits_atan2::<16>(pairs)),
        (
            "scalar",
            pairs
                .iter()
                .map(|&(y, x)| math::atan2_f64(y, x).to_bits())
                .collect(),
        ),
    ];
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            others.push(("avx512f W=16", unsafe { bits_atan2_avx512(pairs) }));
        }
        if is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            others.push(("avx2 W=16", unsafe { bits_atan2_avx2(pairs) }));
        }
    }
    assert_same_bits(Atan2::NAME, &one, others, |i| format!("{:?}", pairs[i]));
    one
}

/// The largest error in ulp over the arguments in the domain, and where.
fn worst_unary<F: Unary>(xs: &[f64], bits: &[u64]) -> (f64, f64) {
    xs.iter()
        .zip(bits)
        .filter(|(&x, _)| F::in_domain(x))
        .map(|(&x, &b)| (ulp_error(f64::from_bits(b), F::reference(x)), x))
        .fold((0.0, 0.0), |w, e| if e.0 > w.0 { e } else { w })
}

/// [`worst_unary`] for atan2.
fn worst_atan2(pairs: &[(f64, f64)], bits: &[u64]) -> (f64, (f64, f64)) {
    pairs
        .iter()
        .zip(bits)
        .map(|(&(y, x), &r)| (ulp_error(f64::from_bits(r), dd_atan2(y, x)), (y, x)))
        .fold((0.0, (0.0, 0.0)), |w, e| if e.0 > w.0 { e } else { w })
}

fn check_unary<F: Unary>(xs: &[f64]) {
    assert!(xs.iter().filter(|&&x| F::in_domain(x)).count() >= 1 << 20);
    let bits = check_widths_unary::<F>(xs);
    let (worst, at) = worst_unary::<F>(xs, &bits);
    println!(
        "{}: {worst:.3} ulp at {at:e} over {} arguments",
        F::NAME,
        xs.len()
    );
    assert!(
        worst <= F::BOUND,
        "{}: {worst:.3} ulp at {at:e} ({:#018x}), above the bound {}",
        F::NAME,
        at.to_bits(),
        F::BOUND
    );
}

#[test]
fn sin_f64_is_the_same_at_every_width_and_within_its_bound() {
    let xs = trig_arguments();
    check_unary::<Sin>(&xs);
    // sin_cos gives sin's bits and cos's bits.
    assert_eq!(bits_unary::<SinOfSinCos, 1>(&xs), bits_unary::<Sin, 1>(&xs));
}

#[test]
fn cos_f64_is_the_same_at_every_width_and_within_its_bound() {
    let xs = trig_arguments();
    check_unary::<Cos>(&xs);
    assert_eq!(bits_unary::<CosOfSinCos, 1>(&xs), bits_unary::<Cos, 1>(&xs));
}

#[test]
fn sin_cos_f64_is_the_same_at_every_width_beyond_its_domain() {
    // Beyond 2²⁰·π/2 no bound is promised, but the bits must still agree.
    let xs = sweep(2047, 64);
    check_widths_unary::<SinOfSinCos>(&xs);
    check_widths_unary::<CosOfSinCos>(&xs);
}

#[test]
fn asin_f64_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Asin>(&inverse_sine_arguments());
}

#[test]
fn acos_f64_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Acos>(&inverse_sine_arguments());
}

#[test]
fn atan_f64_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Atan>(&atan_arguments());
}

#[test]
fn atan2_f64_is_the_same_at_every_width_and_within_its_bound() {
    let pairs = atan2_pairs();
    assert!(pairs.len() >= 1 << 20);
    let bits = check_widths_atan2(&pairs);
    let (worst, at) = worst_atan2(&pairs, &bits);
    println!("atan2: {worst:.3} ulp at {at:?} over {} pairs", pairs.len());
    assert!(
        worst <= Atan2::BOUND,
        "atan2: {worst:.3} ulp at {at:?}, above the bound {}",
        Atan2::BOUND
    );
}

#[test]
fn special_values_f64_are_c99_s() {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    let canonical = |a: f64| a.to_bits() == f64::NAN.to_bits();
    for x in [0.0, -0.0, 1e-300, -1e-300, f64::from_bits(1)] {
        assert!(same(math::sin_f64(x), x), "sin {x:e}");
        assert!(same(math::asin_f64(x), x), "asin {x:e}");
        assert!(same(math::atan_f64(x), x), "atan {x:e}");
        assert_eq!(math::cos_f64(x), 1.0, "cos {x:e}");
        assert_eq!(math::acos_f64(x), FRAC_PI_2, "acos {x:e}");
    }
    for x in [f64::INFINITY, f64::NEG_INFINITY, f64::NAN, -f64::NAN] {
        assert!(
            canonical(math::sin_f64(x)) && canonical(math::cos_f64(x)),
            "{x}"
        );
    }
    for x in [1.5, -1.5, f64::INFINITY, f64::NAN, 1.0 + f64::EPSILON] {
        assert!(
            canonical(math::asin_f64(x)) && canonical(math::acos_f64(x)),
            "{x}"
        );
    }
    assert_eq!(math::asin_f64(1.0), FRAC_PI_2);
    assert_eq!(math::asin_f64(-1.0), -FRAC_PI_2);
    assert_eq!(math::acos_f64(1.0), 0.0);
    assert_eq!(math::acos_f64(-1.0), PI);
    assert_eq!(math::atan_f64(f64::INFINITY), FRAC_PI_2);
    assert_eq!(math::atan_f64(f64::NEG_INFINITY), -FRAC_PI_2);
    assert!(canonical(math::atan_f64(f64::NAN)));
    let inf = f64::INFINITY;
    for (y, x, want) in [
        (0.0, 0.0, 0.0),
        (-0.0, 0.0, -0.0),
        (0.0, -0.0, PI),
        (-0.0, -0.0, -PI),
        (0.0, -1.0, PI),
        (-0.0, -1.0, -PI),
        (0.0, 1.0, 0.0),
        (-0.0, 1.0, -0.0),
        (1.0, 0.0, FRAC_PI_2),
        (-1.0, -0.0, -FRAC_PI_2),
        (inf, inf, FRAC_PI_4),
        (-inf, inf, -FRAC_PI_4),
        (inf, -inf, 3.0 * FRAC_PI_4),
        (-inf, -inf, -3.0 * FRAC_PI_4),
        (1.0, inf, 0.0),
        (-1.0, inf, -0.0),
        (1.0, -inf, PI),
        (-1.0, -inf, -PI),
        (inf, 1.0, FRAC_PI_2),
        (-inf, -1.0, -FRAC_PI_2),
        (1e300, 1e-300, FRAC_PI_2),
        (1.0, 1.0, FRAC_PI_4),
    ] {
        let got = math::atan2_f64(y, x);
        assert!(
            same(got, want),
            "atan2({y:e}, {x:e}) = {got:e}, not {want:e}"
        );
    }
    for (y, x) in [(f64::NAN, 1.0), (1.0, f64::NAN), (f64::NAN, f64::NAN)] {
        assert!(canonical(math::atan2_f64(y, x)));
    }
}

/// 2²⁴ pseudo-random arguments per function (pairs for atan2; for sin and cos inside the
/// domain, for asin and acos in [−1, 1], for atan and atan2 of every exponent), W = 16 (the
/// AVX-512 build where the CPU has it) against W = 1 bit for bit, the largest error of each,
/// and glibc's largest error against the same reference.
#[test]
#[ignore = "a few minutes on two cores"]
fn sampled_widely() {
    use rayon::prelude::*;
    const BLOCK: u64 = 1 << 16;
    const BLOCKS: u64 = (1 << 24) / BLOCK;

    fn wide<F: Unary>(xs: &[f64]) -> Vec<u64> {
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            return unsafe { bits_unary_avx512::<F>(xs) };
        }
        bits_unary::<F, 16>(xs)
    }

    fn run<F: Unary>(argument: fn(u64) -> f64) -> (String, bool) {
        let start = std::time::Instant::now();
        let (worst, at, platform, mismatches) = (0..BLOCKS)
            .into_par_iter()
            .map(|block| {
                let xs: Vec<f64> = (block * BLOCK..(block + 1) * BLOCK)
                    .map(|i| argument(mix(i ^ 0x5eed)))
                    .collect();
                let one = bits_unary::<F, 1>(&xs);
                let mismatches = one
                    .iter()
                    .zip(wide::<F>(&xs))
                    .filter(|(a, b)| **a != *b)
                    .count();
                let (worst, at) = worst_unary::<F>(&xs, &one);
                let platform = xs
                    .iter()
                    .map(|&x| ulp_error(F::platform(x), F::reference(x)))
                    .fold(0.0, f64::max);
                (worst, at, platform, mismatches)
            })
            .reduce(
                || (0.0, 0.0, 0.0, 0),
                |a, b| {
                    let w = if b.0 > a.0 { (b.0, b.1) } else { (a.0, a.1) };
                    (w.0, w.1, a.2.max(b.2), a.3 + b.3)
                },
            );
        let line = format!(
            "{:<9} max {worst:.3} ulp at {at:e} ({:#018x}), glibc {platform:.3}, {mismatches} lanes differ, {:.0} s",
            F::NAME,
            at.to_bits(),
            start.elapsed().as_secs_f64()
        );
        println!("{line}");
        (
            line,
            mismatches == 0 && worst <= F::BOUND && platform <= 1.0,
        )
    }

    /// |x| < 2²⁰·π/2: uniform in x for half, uniform in log |x| for the other half.
    fn trig(h: u64) -> f64 {
        let u = (h >> 11) as f64 / (1u64 << 53) as f64;
        let x = if h & 1 == 0 {
            u * TRIG_F64_DOMAIN
        } else {
            2f64.powf(-60.0 + 80.0 * u).min(TRIG_F64_DOMAIN)
        };
        if h & 2 == 0 {
            x
        } else {
            -x
        }
    }
    fn unit(h: u64) -> f64 {
        let u = (h >> 11) as f64 / (1u64 << 53) as f64;
        let x = if h & 1 == 0 {
            u
        } else {
            1.0 - 2f64.powf(-60.0 * u)
        };
        if h & 2 == 0 {
            x
        } else {
            -x
        }
    }
    fn any(h: u64) -> f64 {
        f64::from_bits(h)
    }

    let mut results = vec![
        run::<Sin>(trig),
        run::<Cos>(trig),
        run::<Asin>(unit),
        run::<Acos>(unit),
        run::<Atan>(any),
    ];
    let start = std::time::Instant::now();
    let (worst, at, mismatches) = (0..BLOCKS)
        .into_par_iter()
        .map(|block| {
            let pairs: Vec<(f64, f64)> = (block * BLOCK..(block + 1) * BLOCK)
                .map(|i| {
                    let h = mix(i ^ 0xa7a2);
                    if i % 2 == 0 {
                        (any(h), any(mix(h)))
                    } else {
                        // A direction's components at a random scale.
                        let angle = trig(h).rem_euclid(std::f64::consts::TAU);
                        let r = 2f64.powi((mix(h) % 200) as i32 - 100);
                        (r * angle.sin(), r * angle.cos())
                    }
                })
                .collect();
            let one = bits_atan2::<1>(&pairs);
            #[cfg(target_arch = "x86_64")]
            let wide = if is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F.
                unsafe { bits_atan2_avx512(&pairs) }
            } else {
                bits_atan2::<16>(&pairs)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let wide = bits_atan2::<16>(&pairs);
            let mismatches = one.iter().zip(&wide).filter(|(a, b)| a != b).count();
            let (worst, at) = worst_atan2(&pairs, &one);
            (worst, at, mismatches)
        })
        .reduce(
            || (0.0, (0.0, 0.0), 0),
            |a, b| {
                let w = if b.0 > a.0 { (b.0, b.1) } else { (a.0, a.1) };
                (w.0, w.1, a.2 + b.2)
            },
        );
    let line = format!(
        "atan2     max {worst:.3} ulp at {at:?}, {mismatches} lanes differ, {:.0} s",
        start.elapsed().as_secs_f64()
    );
    println!("{line}");
    results.push((line, mismatches == 0 && worst <= Atan2::BOUND));
    let failed: Vec<&str> = results
        .iter()
        .filter(|(_, ok)| !ok)
        .map(|(line, _)| line.as_str())
        .collect();
    assert!(
        failed.is_empty(),
        "beyond the bound or not bit-identical:\n{}",
        failed.join("\n")
    );
}
