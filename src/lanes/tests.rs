//! The lanes' promises, checked: every width gives the bits of W = 1 (also when the W = 16
//! instance is compiled for AVX-512 or AVX2), and every function of [`math`] stays within its
//! stated error of the exactly rounded result (`f64` std as the reference).
//!
//! The sampled tests run over ≥ 2²⁰ arguments per function: edge values (±0, ±∞, NaNs,
//! subnormals, powers of two, multiples of π/4 and their neighbours, the ends of each
//! domain) and a stratified sweep of 2048 mantissas in every exponent of both signs.
//!
//! The exhaustive test (`nice cargo test --release -p lumo --lib lanes::tests::exhaustive --
//! --ignored --nocapture`) runs every f32 bit pattern through each function of one argument
//! (and 2³² pairs spanning every sign, exponent and leading mantissa bits for atan2 and
//! powf), W = 16 compiled for AVX-512 against W = 1 bit for bit, and reports each one's
//! largest error. Its run of 2026-12-01 on the Zen 5 machine (AVX-512), 2 threads at nice 19
//! beside other builds, 2,206 s in all:
//!
//! ```text
//! sin       max 1.019 ulp at 2.6132747e22 (0x64b11517), 0 lanes differ, 481 s
//! cos       max 1.020 ulp at 3.7100857e18 (0x5e4df37d), 0 lanes differ, 290 s
//! tan       max 2.090 ulp at 1.0990394e4 (0x462bb993), 0 lanes differ, 605 s
//! asin      max 1.449 ulp at 5.3356254e-1 (0x3f08978e), 0 lanes differ, 169 s
//! acos      max 1.153 ulp at -5.0026697e-1 (0xbf00117f), 0 lanes differ, 132 s
//! atan      max 1.466 ulp at 4.1440994e-1 (0x3ed42d8a), 0 lanes differ, 127 s
//! exp       max 0.990 ulp at 7.04031e1 (0x428cce63), 0 lanes differ, 123 s
//! ln        max 0.846 ulp at 7.05924e-1 (0x3f34b76f), 0 lanes differ, 48 s
//! atan2     max 1.803 ulp at (-8.883565e-6, 7.0808666e-5), 0 lanes differ, 90 s
//! powf      max 0.500 ulp at (8.4210986e23, 1.45324), 0 lanes differ, 140 s
//! ```

use super::math;
use super::*;

/// A function of one argument under test.
trait Unary: Sync {
    const NAME: &'static str;
    /// Maximum error in ulp of the correctly rounded result (the bound `math` states).
    const BOUND: f64;
    fn lanes<const W: usize>(x: F32s<W>) -> F32s<W>;
    fn scalar(x: f32) -> f32;
    fn reference(x: f64) -> f64;
}

/// A function of two arguments under test.
trait Binary: Sync {
    const NAME: &'static str;
    const BOUND: f64;
    fn lanes<const W: usize>(a: F32s<W>, b: F32s<W>) -> F32s<W>;
    fn scalar(a: f32, b: f32) -> f32;
    fn reference(a: f64, b: f64) -> f64;
}

macro_rules! unary {
    ($name:ident, $method:ident, $bound:expr, $reference:expr) => {
        struct $name;
        impl Unary for $name {
            const NAME: &'static str = stringify!($method);
            const BOUND: f64 = $bound;
            #[inline(always)]
            fn lanes<const W: usize>(x: F32s<W>) -> F32s<W> {
                x.$method()
            }
            fn scalar(x: f32) -> f32 {
                math::$method(x)
            }
            fn reference(x: f64) -> f64 {
                $reference(x)
            }
        }
    };
}

unary!(Sin, sin, 1.05, f64::sin);
unary!(Cos, cos, 1.05, f64::cos);
unary!(Tan, tan, 2.1, f64::tan);
unary!(Asin, asin, 1.5, f64::asin);
unary!(Acos, acos, 1.2, f64::acos);
unary!(Atan, atan, 1.5, f64::atan);
unary!(Exp, exp, 1.0, f64::exp);
unary!(Ln, ln, 0.9, f64::ln);

/// sin from [`F32s::sin_cos`] (must be sin's bits).
struct SinOfSinCos;
impl Unary for SinOfSinCos {
    const NAME: &'static str = "sin_cos.0";
    const BOUND: f64 = 1.05;
    #[inline(always)]
    fn lanes<const W: usize>(x: F32s<W>) -> F32s<W> {
        x.sin_cos().0
    }
    fn scalar(x: f32) -> f32 {
        math::sin_cos(x).0
    }
    fn reference(x: f64) -> f64 {
        x.sin()
    }
}

/// cos from [`F32s::sin_cos`].
struct CosOfSinCos;
impl Unary for CosOfSinCos {
    const NAME: &'static str = "sin_cos.1";
    const BOUND: f64 = 1.05;
    #[inline(always)]
    fn lanes<const W: usize>(x: F32s<W>) -> F32s<W> {
        x.sin_cos().1
    }
    fn scalar(x: f32) -> f32 {
        math::sin_cos(x).1
    }
    fn reference(x: f64) -> f64 {
        x.cos()
    }
}

struct Atan2;
impl Binary for Atan2 {
    const NAME: &'static str = "atan2";
    const BOUND: f64 = 2.0;
    #[inline(always)]
    fn lanes<const W: usize>(y: F32s<W>, x: F32s<W>) -> F32s<W> {
        y.atan2(x)
    }
    fn scalar(y: f32, x: f32) -> f32 {
        math::atan2(y, x)
    }
    fn reference(y: f64, x: f64) -> f64 {
        y.atan2(x)
    }
}

struct Powf;
impl Binary for Powf {
    const NAME: &'static str = "powf";
    const BOUND: f64 = 1.0;
    #[inline(always)]
    fn lanes<const W: usize>(x: F32s<W>, y: F32s<W>) -> F32s<W> {
        x.powf(y)
    }
    fn scalar(x: f32, y: f32) -> f32 {
        math::powf(x, y)
    }
    fn reference(x: f64, y: f64) -> f64 {
        x.powf(y)
    }
}

/// The error of `got` in units in the last place of the f32 nearest `want` (0 where `got` is
/// that f32, the same infinity, or a NaN for a NaN; ∞ where a NaN is wrong or missing).
fn ulp_error(got: f32, want: f64) -> f64 {
    if want.is_nan() || got.is_nan() {
        return if want.is_nan() && got.is_nan() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    if got.to_bits() == (want as f32).to_bits() {
        return 0.0;
    }
    if want.is_infinite() {
        return f64::INFINITY;
    }
    // An infinite result stands for 2¹²⁸, the next power of two after f32::MAX.
    let got = if got.is_infinite() {
        2f64.powi(128).copysign(f64::from(got))
    } else {
        f64::from(got)
    };
    let exponent = ((want.to_bits() >> 52) & 0x7ff) as i32 - 1023;
    let ulp = 2f64.powi(exponent.clamp(-126, 127) - 23);
    (got - want).abs() / ulp
}

/// A well-mixed 64-bit hash (SplitMix64's finaliser), for reproducible pseudo-random inputs.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Edge values: zeros, infinities, NaNs, subnormals, powers of two, the ends of each
/// function's domain, and multiples of π/4 with their neighbours.
fn edge_values() -> Vec<f32> {
    let mut v = vec![
        0.0,
        f32::INFINITY,
        f32::NAN,
        f32::from_bits(0x7f80_0001), // signalling NaN
        f32::from_bits(0x7fff_ffff),
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        f32::from_bits(0x007f_ffff),
        f32::MAX,
        1.0,
        0.5,
        88.722_83,
        88.722_84,
        89.0,
        -87.336_55,
        -103.972_08,
        -103.972_09,
        -104.0,
        16_777_216.0,
        16_777_215.0,
        1e-4,
        2.441_406_3e-4,
    ];
    for e in -149..=127 {
        v.push(2f32.powi(e));
    }
    for k in 1..4096 {
        let m = k as f64 * std::f64::consts::FRAC_PI_4;
        let x = m as f32;
        for d in -2..=2i32 {
            v.push(f32::from_bits(x.to_bits().wrapping_add_signed(d)));
        }
    }
    for k in [1e4, 1e5, 1e6, 1e7, 1e8, 1e10, 1e20, 1e30] {
        let x = (k * std::f64::consts::FRAC_PI_2) as f32;
        v.push(x);
    }
    let mut with_signs: Vec<f32> = v.iter().flat_map(|&x| [x, -x]).collect();
    for x in [1.0f32, 0.5] {
        for d in 1..4 {
            with_signs.push(f32::from_bits(x.to_bits() - d));
            with_signs.push(-f32::from_bits(x.to_bits() + d));
        }
    }
    with_signs
}

/// The sampled arguments: [`edge_values`] and 2048 mantissas (strata of 4096, a pseudo-random
/// point in each) in each of the 256 exponents of both signs: 2²⁰ plus the edges.
fn sweep() -> Vec<f32> {
    let mut v = edge_values();
    for sign in [0u32, 1] {
        for exponent in 0..256u32 {
            for stratum in 0..2048u32 {
                let seed = u64::from(sign << 20 | exponent << 11 | stratum);
                let mantissa = stratum * 4096 + (mix(seed) as u32 & 4095);
                v.push(f32::from_bits(sign << 31 | exponent << 23 | mantissa));
            }
        }
    }
    v
}

/// Pairs for the functions of two arguments: the sweep against itself reordered, and the
/// ranges the renderer uses (angles on the circle at radii 10⁻³⁰ … 10³⁰; powers of [0, 4]
/// to exponents in [−40, 40] and in [0.5, 1000], the sRGB curve's 2.4 and 1/2.4).
fn sweep_pairs() -> Vec<(f32, f32)> {
    let a = sweep();
    let n = a.len();
    let mut pairs: Vec<(f32, f32)> = (0..n)
        .map(|i| (a[i], a[(i as u64 * 0x9e37_79b9 % n as u64) as usize]))
        .collect();
    let edges = edge_values();
    for &x in edges.iter().step_by(61) {
        for &y in edges.iter().step_by(53) {
            pairs.push((x, y));
        }
    }
    for k in 0..200_000u64 {
        let u = |i: u64| (mix(k * 4 + i) >> 40) as f64 / (1u64 << 24) as f64;
        let angle = std::f64::consts::TAU * u(0) - std::f64::consts::PI;
        let r = 10f64.powi((k % 61) as i32 - 30);
        pairs.push(((r * angle.sin()) as f32, (r * angle.cos()) as f32));
        let x = (4.0 * u(1)) as f32;
        pairs.push((x, (80.0 * u(2) - 40.0) as f32));
        pairs.push((x * 0.25, (0.5 + 999.5 * u(3)) as f32));
        pairs.push((x * 0.25, if k % 2 == 0 { 2.4 } else { 1.0 / 2.4 }));
    }
    pairs
}

/// A unary function's bits over `xs` at width W.
#[inline(always)]
fn bits_unary<F: Unary, const W: usize>(xs: &[f32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(xs.len());
    for chunk in xs.chunks(W) {
        let lanes = F32s::<W>::from_fn(|i| chunk.get(i).copied().unwrap_or(0.0));
        out.extend_from_slice(&F::lanes(lanes).to_bits().0[..chunk.len()]);
    }
    out
}

/// A binary function's bits over `pairs` at width W.
#[inline(always)]
fn bits_binary<F: Binary, const W: usize>(pairs: &[(f32, f32)]) -> Vec<u32> {
    let mut out = Vec::with_capacity(pairs.len());
    for chunk in pairs.chunks(W) {
        let a = F32s::<W>::from_fn(|i| chunk.get(i).map_or(0.0, |p| p.0));
        let b = F32s::<W>::from_fn(|i| chunk.get(i).map_or(0.0, |p| p.1));
        out.extend_from_slice(&F::lanes(a, b).to_bits().0[..chunk.len()]);
    }
    out
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn bits_unary_avx512<F: Unary>(xs: &[f32]) -> Vec<u32> {
    bits_unary::<F, 16>(xs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bits_unary_avx2<F: Unary>(xs: &[f32]) -> Vec<u32> {
    bits_unary::<F, 16>(xs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn bits_binary_avx512<F: Binary>(pairs: &[(f32, f32)]) -> Vec<u32> {
    bits_binary::<F, 16>(pairs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bits_binary_avx2<F: Binary>(pairs: &[(f32, f32)]) -> Vec<u32> {
    bits_binary::<F, 16>(pairs)
}

/// The first argument at which `other` differs from `reference`, if any.
fn first_difference(reference: &[u32], other: &[u32]) -> Option<usize> {
    reference.iter().zip(other).position(|(a, b)| a != b)
}

/// Every width's bits (and the AVX-512 and AVX2 builds' where the CPU has them) against
/// W = 1's, and W = 1's against the scalar entry point's; returns W = 1's bits.
fn check_widths_unary<F: Unary>(xs: &[f32]) -> Vec<u32> {
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
    for (name, bits) in others {
        if let Some(i) = first_difference(&one, &bits) {
            panic!(
                "{}: {name} differs from W=1 at x = {:e} ({:#010x}): {:#010x} against {:#010x}",
                F::NAME,
                xs[i],
                xs[i].to_bits(),
                bits[i],
                one[i]
            );
        }
    }
    one
}

/// [`check_widths_unary`] for a function of two arguments.
fn check_widths_binary<F: Binary>(pairs: &[(f32, f32)]) -> Vec<u32> {
    let one = bits_binary::<F, 1>(pairs);
    let mut others = vec![
        ("W=4", bits_binary::<F, 4>(pairs)),
        ("W=8", bits_binary::<F, 8>(pairs)),
        ("W=16", bits_binary::<F, 16>(pairs)),
        (
            "scalar",
            pairs
                .iter()
                .map(|&(a, b)| F::scalar(a, b).to_bits())
                .collect(),
        ),
    ];
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            others.push(("avx512f W=16", unsafe { bits_binary_avx512::<F>(pairs) }));
        }
        if is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            others.push(("avx2 W=16", unsafe { bits_binary_avx2::<F>(pairs) }));
        }
    }
    for (name, bits) in others {
        if let Some(i) = first_difference(&one, &bits) {
            let (a, b) = pairs[i];
            panic!(
                "{}: {name} differs from W=1 at ({a:e}, {b:e}): {:#010x} against {:#010x}",
                F::NAME,
                bits[i],
                one[i]
            );
        }
    }
    one
}

/// The largest error in ulp over `xs` and the argument where it occurs.
fn worst_unary<F: Unary>(xs: &[f32], bits: &[u32]) -> (f64, f32) {
    xs.iter()
        .zip(bits)
        .map(|(&x, &b)| (ulp_error(f32::from_bits(b), F::reference(f64::from(x))), x))
        .fold((0.0, 0.0), |w, e| if e.0 > w.0 { e } else { w })
}

/// [`worst_unary`] for a function of two arguments.
fn worst_binary<F: Binary>(pairs: &[(f32, f32)], bits: &[u32]) -> (f64, (f32, f32)) {
    pairs
        .iter()
        .zip(bits)
        .map(|(&(a, b), &r)| {
            (
                ulp_error(f32::from_bits(r), F::reference(f64::from(a), f64::from(b))),
                (a, b),
            )
        })
        .fold((0.0, (0.0, 0.0)), |w, e| if e.0 > w.0 { e } else { w })
}

fn check_unary<F: Unary>() {
    let xs = sweep();
    assert!(xs.len() >= 1 << 20);
    let bits = check_widths_unary::<F>(&xs);
    let (worst, at) = worst_unary::<F>(&xs, &bits);
    println!(
        "{}: {worst:.3} ulp at {at:e} over {} arguments",
        F::NAME,
        xs.len()
    );
    assert!(
        worst <= F::BOUND,
        "{}: {worst:.3} ulp at {at:e} ({:#010x}), above the bound {}",
        F::NAME,
        at.to_bits(),
        F::BOUND
    );
}

fn check_binary<F: Binary>() {
    let pairs = sweep_pairs();
    assert!(pairs.len() >= 1 << 20);
    let bits = check_widths_binary::<F>(&pairs);
    let (worst, at) = worst_binary::<F>(&pairs, &bits);
    println!(
        "{}: {worst:.3} ulp at {at:?} over {} pairs",
        F::NAME,
        pairs.len()
    );
    assert!(
        worst <= F::BOUND,
        "{}: {worst:.3} ulp at {at:?}, above the bound {}",
        F::NAME,
        F::BOUND
    );
}

#[test]
fn sin_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Sin>();
}

#[test]
fn cos_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Cos>();
}

#[test]
fn sin_cos_gives_sin_and_cos_bits() {
    check_unary::<SinOfSinCos>();
    check_unary::<CosOfSinCos>();
    for x in sweep() {
        let (s, c) = math::sin_cos(x);
        assert_eq!(s.to_bits(), math::sin(x).to_bits(), "{x:e}");
        assert_eq!(c.to_bits(), math::cos(x).to_bits(), "{x:e}");
    }
}

#[test]
fn tan_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Tan>();
}

#[test]
fn asin_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Asin>();
}

#[test]
fn acos_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Acos>();
}

#[test]
fn atan_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Atan>();
}

#[test]
fn exp_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Exp>();
}

#[test]
fn ln_is_the_same_at_every_width_and_within_its_bound() {
    check_unary::<Ln>();
}

#[test]
fn atan2_is_the_same_at_every_width_and_within_its_bound() {
    check_binary::<Atan2>();
}

#[test]
fn powf_is_the_same_at_every_width_and_within_its_bound() {
    check_binary::<Powf>();
}

/// The special values C99 fixes, sign of zero included, and the canonical NaN.
#[test]
fn special_values_are_c99_s() {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let inf = f32::INFINITY;
    let same = |got: f32, want: f32, what: &str| {
        assert_eq!(
            got.to_bits(),
            want.to_bits(),
            "{what}: {got:e} against {want:e}"
        );
    };
    let canonical = f32::NAN.to_bits();
    for x in [f32::NAN, -f32::NAN, f32::from_bits(0x7f80_0001), inf, -inf] {
        for (name, v) in [
            ("sin", math::sin(x)),
            ("cos", math::cos(x)),
            ("tan", math::tan(x)),
        ] {
            assert_eq!(v.to_bits(), canonical, "{name}({x})");
        }
    }
    for x in [f32::NAN, -f32::NAN, 1.5, -1.000_000_1, inf] {
        assert_eq!(math::asin(x).to_bits(), canonical, "asin({x})");
        assert_eq!(math::acos(x).to_bits(), canonical, "acos({x})");
    }
    for z in [0.0f32, -0.0] {
        same(math::sin(z), z, "sin ±0");
        same(math::tan(z), z, "tan ±0");
        same(math::asin(z), z, "asin ±0");
        same(math::atan(z), z, "atan ±0");
        same(math::cos(z), 1.0, "cos ±0");
        same(math::exp(z), 1.0, "exp ±0");
        same(math::ln(z), -inf, "ln ±0");
        same(math::atan2(z, 0.0), z, "atan2(±0, +0)");
        same(math::atan2(z, -0.0), PI.copysign(z), "atan2(±0, −0)");
        same(math::atan2(z, 1.0), z, "atan2(±0, 1)");
        same(math::atan2(z, -1.0), PI.copysign(z), "atan2(±0, −1)");
    }
    same(math::acos(1.0), 0.0, "acos 1");
    same(math::acos(-1.0), PI, "acos −1");
    same(math::asin(1.0), FRAC_PI_2, "asin 1");
    same(math::atan(inf), FRAC_PI_2, "atan ∞");
    same(math::atan(-inf), -FRAC_PI_2, "atan −∞");
    same(math::atan2(inf, inf), FRAC_PI_4, "atan2(∞, ∞)");
    same(math::atan2(-inf, -inf), -3.0 * FRAC_PI_4, "atan2(−∞, −∞)");
    same(math::atan2(1.0, 0.0), FRAC_PI_2, "atan2(1, 0)");
    same(math::atan2(-1.0, -0.0), -FRAC_PI_2, "atan2(−1, −0)");
    same(math::atan2(1.0, -inf), PI, "atan2(1, −∞)");
    same(math::exp(inf), inf, "exp ∞");
    same(math::exp(-inf), 0.0, "exp −∞");
    same(math::exp(89.0), inf, "exp 89");
    same(math::ln(inf), inf, "ln ∞");
    same(math::ln(1.0), 0.0, "ln 1");
    assert_eq!(math::ln(-1.0).to_bits(), canonical);
    assert_eq!(math::ln(-inf).to_bits(), canonical);
    assert_eq!(math::exp(f32::NAN).to_bits(), canonical);
    assert_eq!(math::atan2(f32::NAN, 1.0).to_bits(), canonical);
    assert_eq!(math::atan2(1.0, -f32::NAN).to_bits(), canonical);
    // powf
    same(math::powf(f32::NAN, 0.0), 1.0, "NaN⁰");
    same(math::powf(1.0, f32::NAN), 1.0, "1^NaN");
    same(math::powf(-1.0, inf), 1.0, "(−1)^∞");
    same(math::powf(-1.0, -inf), 1.0, "(−1)^−∞");
    same(math::powf(-2.0, 3.0), -8.0, "(−2)³");
    same(math::powf(-2.0, 2.0), 4.0, "(−2)²");
    same(math::powf(-0.0, 3.0), -0.0, "(−0)³");
    same(math::powf(-0.0, 2.0), 0.0, "(−0)²");
    same(math::powf(-0.0, -3.0), -inf, "(−0)⁻³");
    same(math::powf(0.0, -0.5), inf, "0^−½");
    same(math::powf(0.0, 0.5), 0.0, "0^½");
    same(math::powf(-inf, 3.0), -inf, "(−∞)³");
    same(math::powf(-inf, -3.0), -0.0, "(−∞)⁻³");
    same(math::powf(-inf, 0.5), inf, "(−∞)^½");
    same(math::powf(0.5, inf), 0.0, "½^∞");
    same(math::powf(2.0, inf), inf, "2^∞");
    same(math::powf(0.5, -inf), inf, "½^−∞");
    same(math::powf(4.0, 0.5), 2.0, "4^½");
    same(math::powf(2.0, -149.0), f32::from_bits(1), "2⁻¹⁴⁹");
    same(math::powf(2.0, 128.0), inf, "2¹²⁸");
    assert_eq!(math::powf(-2.0, 0.5).to_bits(), canonical);
    assert_eq!(math::powf(f32::NAN, 1.0).to_bits(), canonical);
}

/// The lane types' own operations: min/max's NaN rule, rounding, conversions, masks.
#[test]
fn lane_operations_follow_their_rules() {
    let nan = f32::NAN;
    let a = F32s([1.0, nan, 3.0, -0.0]);
    let b = F32s([2.0, 5.0, nan, 0.0]);
    assert_eq!(
        a.min(b).to_bits().0,
        [1.0f32, 5.0, nan, 0.0].map(f32::to_bits)
    );
    assert_eq!(
        a.max(b).to_bits().0,
        [2.0f32, 5.0, nan, 0.0].map(f32::to_bits)
    );
    assert_eq!(min(nan, 1.0), 1.0);
    assert!(min(1.0, nan).is_nan());
    assert_eq!(max(nan, 1.0), 1.0);
    let x = F32s([-2.5f32, -0.5, 0.5, 1.5, 2.5, -0.0, 8_388_609.0, -1e30]);
    assert_eq!(
        x.round_ties_even().to_bits().0,
        [-2.0f32, -0.0, 0.0, 2.0, 2.0, -0.0, 8_388_609.0, -1e30].map(f32::to_bits)
    );
    assert_eq!(
        x.floor().to_bits().0,
        [-3.0f32, -1.0, 0.0, 1.0, 2.0, -0.0, 8_388_609.0, -1e30].map(f32::to_bits)
    );
    for v in sweep().into_iter().step_by(97) {
        let one = F32s([v]);
        assert_eq!(one.floor()[0].to_bits(), v.floor().to_bits(), "floor {v:e}");
        assert_eq!(
            one.round_ties_even()[0].to_bits(),
            v.round_ties_even().to_bits(),
            "round {v:e}"
        );
        let d = f64::from(v);
        assert_eq!(F64s([d]).floor()[0].to_bits(), d.floor().to_bits());
        assert_eq!(one.to_i32()[0], v as i32);
        assert_eq!(one.sqrt()[0].to_bits(), v.sqrt().to_bits());
    }
    // `to_i32` at every width (W = 4 runs SSE2 chunks, the others the vectorised loop),
    // including the saturated ends, NaN and the values either side of ±2³¹.
    let ends = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        2_147_483_648.0,
        2_147_483_520.0,
        -2_147_483_648.0,
        -2_147_483_904.0,
        -0.0,
        0.999_999_9,
        -1.5,
        1e30,
        -1e30,
        7.0,
        -7.9,
        123_456.7,
        -0.5,
    ];
    let edges: Vec<f32> = ends
        .into_iter()
        .chain(sweep().into_iter().step_by(89))
        .collect();
    fn check_to_i32<const W: usize>(values: &[f32]) {
        for chunk in values.chunks_exact(W) {
            let lanes = F32s::<W>(std::array::from_fn(|i| chunk[i])).to_i32();
            for (i, &v) in chunk.iter().enumerate() {
                assert_eq!(lanes[i], v as i32, "{v:e} at W = {W}");
            }
        }
    }
    check_to_i32::<4>(&edges);
    check_to_i32::<8>(&edges);
    check_to_i32::<16>(&edges);
    let m = F32s([1.0f32, 2.0, 3.0, 4.0]).lt(F32s::splat(2.5));
    assert!(m.lane(0) && m.lane(1) && !m.lane(2) && m.any() && !m.all());
    assert_eq!(
        F32s::select(m, F32s::splat(1.0), F32s::splat(0.0)).to_array(),
        [1.0, 1.0, 0.0, 0.0]
    );
    assert_eq!((!m).and_not(m), !m);
    assert_eq!(I32s([-3, 7]).to_f32().to_array(), [-3.0, 7.0]);
    assert_eq!((I32s([-8, 8]) >> 1).0, [-4, 4]);
    assert_eq!((U32s([0x8000_0000]) >> 31).0, [1]);
    assert_eq!((U32s([u32::MAX]) + 1).0, [0]);
}

/// Runs every function over all 2³² f32 bit patterns (pairs for atan2 and powf), W = 16 (the
/// AVX-512 build where the CPU has it) against W = 1 bit for bit, and reports each one's
/// largest error in ulp.
#[test]
#[ignore = "about 40 minutes on two cores"]
fn exhaustive() {
    use rayon::prelude::*;
    use std::time::Instant;
    const BLOCK: u64 = 1 << 16;

    fn block_inputs(block: u64) -> Vec<f32> {
        (block * BLOCK..(block + 1) * BLOCK)
            .map(|b| f32::from_bits(b as u32))
            .collect()
    }

    /// Pattern p as a pair: each argument takes 16 bits of p as its high half (sign,
    /// exponent, 7 mantissa bits) and pseudo-random low bits.
    fn block_pairs(block: u64) -> Vec<(f32, f32)> {
        (block * BLOCK..(block + 1) * BLOCK)
            .map(|p| {
                let h = mix(p);
                let a = ((p >> 16) as u32) << 16 | (h as u32 & 0xffff);
                let b = ((p & 0xffff) as u32) << 16 | ((h >> 32) as u32 & 0xffff);
                (f32::from_bits(a), f32::from_bits(b))
            })
            .collect()
    }

    fn wide_unary<F: Unary>(xs: &[f32]) -> Vec<u32> {
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            return unsafe { bits_unary_avx512::<F>(xs) };
        }
        bits_unary::<F, 16>(xs)
    }

    fn wide_binary<F: Binary>(pairs: &[(f32, f32)]) -> Vec<u32> {
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            return unsafe { bits_binary_avx512::<F>(pairs) };
        }
        bits_binary::<F, 16>(pairs)
    }

    fn run_unary<F: Unary>() -> (String, bool) {
        let start = Instant::now();
        let (worst, at, mismatches) = (0..(1u64 << 32) / BLOCK)
            .into_par_iter()
            .map(|block| {
                let xs = block_inputs(block);
                let one = bits_unary::<F, 1>(&xs);
                let wide = wide_unary::<F>(&xs);
                let mismatches = one.iter().zip(&wide).filter(|(a, b)| a != b).count();
                let (worst, at) = worst_unary::<F>(&xs, &one);
                (worst, at, mismatches)
            })
            .reduce(
                || (0.0, 0.0, 0),
                |a, b| {
                    let w = if b.0 > a.0 { (b.0, b.1) } else { (a.0, a.1) };
                    (w.0, w.1, a.2 + b.2)
                },
            );
        let line = format!(
            "{:<9} max {worst:.3} ulp at {at:e} ({:#010x}), {mismatches} lanes differ, {:.0} s",
            F::NAME,
            at.to_bits(),
            start.elapsed().as_secs_f64()
        );
        println!("{line}");
        (line, mismatches == 0 && worst <= F::BOUND)
    }

    fn run_binary<F: Binary>() -> (String, bool) {
        let start = Instant::now();
        let (worst, at, mismatches) = (0..(1u64 << 32) / BLOCK)
            .into_par_iter()
            .map(|block| {
                let pairs = block_pairs(block);
                let one = bits_binary::<F, 1>(&pairs);
                let wide = wide_binary::<F>(&pairs);
                let mismatches = one.iter().zip(&wide).filter(|(a, b)| a != b).count();
                let (worst, at) = worst_binary::<F>(&pairs, &one);
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
            "{:<9} max {worst:.3} ulp at {at:?}, {mismatches} lanes differ, {:.0} s",
            F::NAME,
            start.elapsed().as_secs_f64()
        );
        println!("{line}");
        (line, mismatches == 0 && worst <= F::BOUND)
    }

    let results = [
        run_unary::<Sin>(),
        run_unary::<Cos>(),
        run_unary::<Tan>(),
        run_unary::<Asin>(),
        run_unary::<Acos>(),
        run_unary::<Atan>(),
        run_unary::<Exp>(),
        run_unary::<Ln>(),
        run_binary::<Atan2>(),
        run_binary::<Powf>(),
    ];
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

/// A mask's bits, and whether any lane holds, are those of its lanes one by one at every
/// width: the four-lane `movmskps` path (W a multiple of 4) and the lane-by-lane one (W = 1),
/// on masks built every way (splat, from booleans, comparisons, logic, from bits).
#[test]
fn mask_bits_are_the_lanes() {
    fn check<const W: usize>(seed: u64) {
        let mut s = seed;
        for _ in 0..2000 {
            s = mix(s);
            let flags: [bool; W] = std::array::from_fn(|i| (s >> (i % 64)) & 1 != 0);
            let a = F32s::<W>::from_fn(|i| ((s >> (2 * i % 64)) & 3) as f32 - 1.0);
            let masks = [
                Mask::<W>::from_bools(&flags),
                Mask::splat(s & 1 != 0),
                a.gt(F32s::splat(0.0)),
                a.le(F32s::splat(0.0)) & !Mask::from_bools(&flags),
                a.eq(F32s::splat(f32::NAN)),
            ];
            // From bits, with bits beyond W set too (they mean nothing).
            let from_bits = Mask::<W>::from_bits(s);
            for i in 0..W {
                assert_eq!(from_bits.lane(i), (s >> i) & 1 != 0, "W = {W}");
            }
            assert_eq!(from_bits, Mask::from_fn(|i| (s >> i) & 1 != 0));
            for m in masks.into_iter().chain([from_bits]) {
                let want = (0..W).fold(0u64, |b, i| b | (u64::from(m.lane(i)) << i));
                assert_eq!(m.bits(), want, "W = {W}");
                assert_eq!(m.any(), want != 0, "W = {W}");
                assert_eq!(
                    m.iter().collect::<Vec<_>>(),
                    (0..W).filter(|&i| m.lane(i)).collect::<Vec<_>>()
                );
            }
        }
    }
    check::<1>(1);
    check::<4>(2);
    check::<8>(3);
    check::<16>(4);
}

#[cfg(target_arch = "x86_64")]
#[test]
fn transpose_16x16_moves_every_field_to_its_lane_and_masked_stores_keep_the_rest() {
    if !crate::lanes::has_avx512() {
        eprintln!("skipped: this CPU has no AVX-512");
        return;
    }
    // Distinct bit patterns, NaNs and signed zeros among them: the fields move untouched.
    let rows: Vec<[f32; 16]> = (0..16u32)
        .map(|i| std::array::from_fn(|f| f32::from_bits(0x7fc0_0000 ^ (i << 8 | f as u32) << 3)))
        .collect();
    let refs: [&[f32; 16]; 16] = std::array::from_fn(|i| &rows[i]);
    // SAFETY: the CPU has AVX-512 F.
    let columns = unsafe { crate::lanes::transpose_16x16(refs) };
    for (f, &column) in columns.iter().enumerate() {
        let mut lanes = crate::lanes::F32s::<16>::splat(0.0);
        // SAFETY: as above; only lanes 0 … 14 are stored, lane 15 keeps its zero.
        unsafe { crate::lanes::store_lanes_16(&mut lanes, 0x7fff, column) };
        for (i, v) in lanes.0.iter().enumerate() {
            let expected = if i == 15 { 0.0 } else { rows[i][f] };
            assert_eq!(v.to_bits(), expected.to_bits(), "field {f} of row {i}");
        }
    }
}
