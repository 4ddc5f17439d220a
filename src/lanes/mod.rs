//! Values in SIMD lanes: width-generic types whose every operation is lane-wise IEEE-754.
//!
//! A sample must be a function of (seed, pixel, sample index) alone, whatever the lane width W
//! a thread runs (1, 4, 8 or 16, chosen at run time), the CPU's features or the thread count:
//! images, checkpoints and the exact merges of partial films depend on it. So every value a
//! path computes in lanes is computed lane by lane with operations whose result IEEE-754 fixes
//! bit for bit, and W = 16 gives in each lane the bits W = 1 gives. The rules:
//!
//! * **Exactly rounded operations only**: + − × ÷ and √ (correctly rounded, round to nearest
//!   even), comparisons, conversions, bit operations. No fused multiply-add: Rust never
//!   contracts `a * b + c` by itself, and nothing here calls `mul_add`, so a product is rounded
//!   before the sum on every CPU, with or without FMA units. No approximate reciprocal or
//!   reciprocal square root instructions (`rcpps`, `rsqrtps`, whose bits differ between CPUs).
//! * **One NaN rule for min and max**: `min(a, b) = if a < b { a } else { b }` and
//!   `max(a, b) = if a > b { a } else { b }`, so a NaN in either argument gives `b` (the rule
//!   of x86's `minps`/`maxps`). The scalar [`min`] and [`max`] follow it too; `f32::min`, which
//!   ignores a NaN, does not, and code that must give the lanes' bits uses these.
//! * **No libm**: the transcendental functions are lumo's own ([`math`]), written once for
//!   every W, with no branch that depends on other lanes' values.
//! * **NaN payloads are not part of the result**: when two NaNs meet, which payload survives
//!   may depend on the operand order the compiler picks. The functions of [`math`] return the
//!   canonical quiet NaN (`0x7fc0_0000`) for every NaN result, so their bits are fixed too.
//!
//! Each type wraps a plain array (`#[repr(C)]`, `Copy`); each operation is an
//! `#[inline(always)]` loop over it, which LLVM turns into vector instructions when the caller
//! is compiled for a vector ISA (for instance inside `#[target_feature(enable = "avx512f")]`)
//! and into scalar ones at W = 1. The mask type [`Mask`] holds 0 or !0 per lane, the same
//! size as the data lanes, so that comparisons and selects stay in vector registers.
//!
//! The types align only as their lanes do (4 bytes), so that a 4-lane array takes 16 bytes.
//! The structures that hold many of them (a wave's paths and samplers, the kernels' inputs and
//! outputs) are `#[repr(C, align(64))]` with their lane arrays first and smaller fields last:
//! every W-lane array then starts on a 4W-byte boundary and no vector load or store splits a
//! cache line, which made the Cornell box 3 % faster at W = 16 and 5 % at W = 8.

pub mod math;
#[cfg(test)]
mod tests;
mod vec3s;

pub use vec3s::V3s;
#[cfg(test)]
mod tests_f64;

use std::ops::{
    Add, AddAssign, BitAnd, BitOr, BitXor, Div, DivAssign, Index, IndexMut, Mul, MulAssign, Neg,
    Not, Shl, Shr, Sub, SubAssign,
};
use std::sync::atomic::{AtomicU8, Ordering};

/// W lanes of `f32`.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct F32s<const W: usize>(pub [f32; W]);

/// W lanes of `f64` (for the steps of [`math`] that need more precision than `f32`).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct F64s<const W: usize>(pub [f64; W]);

/// W lanes of `i32` (wrapping arithmetic).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct I32s<const W: usize>(pub [i32; W]);

/// W lanes of `u32` (wrapping arithmetic).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct U32s<const W: usize>(pub [u32; W]);

/// W lanes of `u64` (wrapping arithmetic).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct U64s<const W: usize>(pub [u64; W]);

/// W lanes of truth values, each 0 (false) or !0 (true).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Mask<const W: usize>([u32; W]);

/// The lane widths the render loop runs, narrowest first.
pub const WIDTHS: [usize; 4] = [1, 4, 8, 16];

/// Whether the CPU has the AVX-512 the 16-lane code is compiled for: the foundation with the
/// byte and word (BW), doubleword and quadword (DQ) and vector length (VL) extensions, as every
/// AVX-512 CPU since Skylake-SP and Zen 4 has (Embree's AVX-512 level). BW and DQ give the
/// integer lanes (the samplers' hashes and bit reversals) byte shuffles and 64-bit multiplies.
///
/// Found once and kept in one flag: every dispatch of a wave's stages asks, and four feature
/// lookups per call showed in the profile.
#[cfg(target_arch = "x86_64")]
#[inline]
pub fn has_avx512() -> bool {
    static FOUND: AtomicU8 = AtomicU8::new(UNKNOWN);
    found_once(&FOUND, || {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512bw")
            && std::arch::is_x86_feature_detected!("avx512dq")
            && std::arch::is_x86_feature_detected!("avx512vl")
    })
}

/// Whether the CPU has AVX2, the 8-lane code's instructions: found once and kept in one flag,
/// as [`has_avx512`].
#[cfg(target_arch = "x86_64")]
#[inline]
pub fn has_avx2() -> bool {
    static FOUND: AtomicU8 = AtomicU8::new(UNKNOWN);
    found_once(&FOUND, || std::arch::is_x86_feature_detected!("avx2"))
}

/// Whether the CPU has BMI2's bit deposit (`pdep`); `false` off x86-64. Found once, as
/// [`has_avx512`].
#[inline]
pub fn has_bmi2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        static FOUND: AtomicU8 = AtomicU8::new(UNKNOWN);
        found_once(&FOUND, || std::arch::is_x86_feature_detected!("bmi2"))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether the CPU has GFNI, whose affine byte transform reverses the bits of every byte in
/// one instruction: the samplers' lanes reverse the bits of three 32-bit words per number
/// drawn, in two instructions each with it instead of seven (`widest!(gfni; …)`). Found once,
/// as [`has_avx512`]. Unit tests can turn it off (`forget_gfni`) to run the copies without it.
#[cfg(target_arch = "x86_64")]
#[inline]
pub fn has_gfni() -> bool {
    #[cfg(test)]
    if GFNI_FORGOTTEN.load(Ordering::Relaxed) {
        return false;
    }
    static FOUND: AtomicU8 = AtomicU8::new(UNKNOWN);
    found_once(&FOUND, || std::arch::is_x86_feature_detected!("gfni"))
}

/// Set by [`forget_gfni`].
#[cfg(all(test, target_arch = "x86_64"))]
static GFNI_FORGOTTEN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Makes [`has_gfni`] answer `false` from now on in this test process, so that the copies
/// compiled without GFNI run (they give the same bits, so other tests running meanwhile are
/// not disturbed).
#[cfg(all(test, target_arch = "x86_64"))]
pub(crate) fn forget_gfni() {
    GFNI_FORGOTTEN.store(true, Ordering::Relaxed);
}

/// A CPU feature flag not looked up yet (then 1 for present, 2 for absent).
const UNKNOWN: u8 = 0;

/// `flag`'s answer, from `find` the first time it is asked.
#[inline]
fn found_once(flag: &AtomicU8, find: impl FnOnce() -> bool) -> bool {
    match flag.load(Ordering::Relaxed) {
        1 => true,
        2 => false,
        _ => {
            let has = find();
            flag.store(if has { 1 } else { 2 }, Ordering::Relaxed);
            has
        }
    }
}

/// The widest lanes this CPU runs in one register: 16 with AVX-512 ([`has_avx512`]), 8 with
/// AVX2, 4 with SSE2 (every x86-64) or NEON (every AArch64), and 1 elsewhere.
pub fn native_width() -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        if has_avx512() {
            16
        } else if std::arch::is_x86_feature_detected!("avx2") {
            8
        } else {
            4
        }
    }
    #[cfg(target_arch = "aarch64")]
    {
        4
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    {
        1
    }
}

/// The environment variable that forces a lane width (for tests and benchmarks): `1`, `4`, `8`
/// or `16`. Images are the same bits at every width; only the speed differs.
pub const WIDTH_VARIABLE: &str = "LUMO_SIMD";

/// The lane width `LUMO_SIMD` asks for: `Ok(None)` when it is unset or empty, an error naming
/// the allowed values when it is anything but 1, 4, 8 or 16.
pub fn width_from_env() -> Result<Option<usize>, String> {
    match std::env::var(WIDTH_VARIABLE) {
        Err(_) => Ok(None),
        Ok(v) if v.trim().is_empty() => Ok(None),
        Ok(v) => match v.trim().parse::<usize>() {
            Ok(w) if WIDTHS.contains(&w) => Ok(Some(w)),
            _ => Err(format!(
                "{WIDTH_VARIABLE}={v:?} is not a lane width: use 1, 4, 8 or 16 (or unset it for \
                 this CPU's widest, {})",
                native_width()
            )),
        },
    }
}

/// The lane width renders use unless told otherwise: `LUMO_SIMD` when it names a width, else
/// [`native_width`] (an invalid `LUMO_SIMD` is the command line's to report; see
/// [`width_from_env`]).
pub fn default_width() -> usize {
    static WIDTH: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *WIDTH.get_or_init(|| width_from_env().ok().flatten().unwrap_or_else(native_width))
}

/// The body of a function of W lanes, `$body` (an expression of `$arg: &$ty`), run compiled
/// for the widest vector instructions the CPU has that suit W: AVX-512 for W ≥ 16, AVX2 for
/// W ≥ 8 (by `#[target_feature]` copies of it), else the baseline. Every copy performs the same
/// lane operations, so gives the same bits.
///
/// `widest!(gfni; …)` adds a 16-lane copy that also uses GFNI (see [`has_gfni`]), run where the
/// CPU has it: for the samplers' bit reversals, which LLVM then compiles to GFNI's affine
/// transform. The wave loop has such a copy too, so that the samplers' draws inline into it.
macro_rules! widest {
    ($w:ident, $arg:ident: &$ty:ty => $out:ty, $value:expr, $body:expr) => {
        $crate::lanes::widest!($w, ($arg: &$ty) => $out, ($value), $body)
    };
    (gfni; $w:ident, ($($arg:ident: $ty:ty),+) => $out:ty, ($($value:expr),+), $body:expr) => {{
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl,gfni")]
            #[inline]
            unsafe fn avx512_gfni<const $w: usize>($($arg: $ty),+) -> $out {
                $body
            }
            if $w >= 16 && $crate::lanes::has_avx512() && $crate::lanes::has_gfni() {
                // SAFETY: the CPU has AVX-512 (F, BW, DQ, VL) and GFNI.
                return unsafe { avx512_gfni::<$w>($($value),+) };
            }
        }
        $crate::lanes::widest!($w, ($($arg: $ty),+) => $out, ($($value),+), $body)
    }};
    // Several arguments: `($a: A, $b: B, …) => Out, ($x, $y, …)`.
    ($w:ident, ($($arg:ident: $ty:ty),+) => $out:ty, ($($value:expr),+), $body:expr) => {{
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
            #[inline]
            unsafe fn avx512<const $w: usize>($($arg: $ty),+) -> $out {
                $body
            }
            #[target_feature(enable = "avx2")]
            #[inline]
            unsafe fn avx2<const $w: usize>($($arg: $ty),+) -> $out {
                $body
            }
            if $w >= 16 && $crate::lanes::has_avx512() {
                // SAFETY: the CPU has AVX-512 (F, BW, DQ, VL).
                return unsafe { avx512::<$w>($($value),+) };
            }
            if $w >= 8 && $crate::lanes::has_avx2() {
                // SAFETY: the CPU has AVX2.
                return unsafe { avx2::<$w>($($value),+) };
            }
        }
        let ($($arg,)+): ($($ty,)+) = ($($value,)+);
        $body
    }};
}
pub(crate) use widest;

/// Sixteen records of sixteen 32-bit fields as sixteen lanes of each field: lane i of
/// `columns[f]` is `rows[i][f]`, moved in AVX-512 registers (16 loads and 64 shuffles) instead
/// of one scalar store per lane and field. The bits move untouched.
///
/// # Safety
/// The CPU must have AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn transpose_16x16(rows: [&[f32; 16]; 16]) -> [std::arch::x86_64::__m512; 16] {
    use std::arch::x86_64::*;
    let r: [__m512; 16] = std::array::from_fn(|i| _mm512_loadu_ps(rows[i].as_ptr()));
    // Pairs of rows interleaved: within each 128-bit block, t[2k] holds fields 0, 1 and
    // t[2k + 1] fields 2, 3 of rows 2k and 2k + 1.
    let t: [__m512; 16] = std::array::from_fn(|j| {
        let (a, b) = (r[j & !1], r[j | 1]);
        if j & 1 == 0 {
            _mm512_unpacklo_ps(a, b)
        } else {
            _mm512_unpackhi_ps(a, b)
        }
    });
    // u[4g + e]: within 128-bit block k, field 4k + e of rows 4g … 4g + 3.
    let u: [__m512; 16] = std::array::from_fn(|j| {
        let (g, e) = (j / 4, j % 4);
        let (a, b) = (t[4 * g + e / 2], t[4 * g + 2 + e / 2]);
        if e % 2 == 0 {
            _mm512_shuffle_ps::<0x44>(a, b)
        } else {
            _mm512_shuffle_ps::<0xEE>(a, b)
        }
    });
    let mut columns = [_mm512_setzero_ps(); 16];
    for e in 0..4 {
        let (a, b, c, d) = (u[e], u[4 + e], u[8 + e], u[12 + e]);
        // Blocks (a0 a1 b0 b1), (a2 a3 b2 b3), (c0 c1 d0 d1), (c2 c3 d2 d3); then field 4k + e is
        // (ak bk ck dk).
        let (x0, x1) = (
            _mm512_shuffle_f32x4::<0x44>(a, b),
            _mm512_shuffle_f32x4::<0xEE>(a, b),
        );
        let (y0, y1) = (
            _mm512_shuffle_f32x4::<0x44>(c, d),
            _mm512_shuffle_f32x4::<0xEE>(c, d),
        );
        columns[e] = _mm512_shuffle_f32x4::<0x88>(x0, y0);
        columns[4 + e] = _mm512_shuffle_f32x4::<0xDD>(x0, y0);
        columns[8 + e] = _mm512_shuffle_f32x4::<0x88>(x1, y1);
        columns[12 + e] = _mm512_shuffle_f32x4::<0xDD>(x1, y1);
    }
    columns
}

/// Stores the `lanes` (bits) of `v` into those of `dst`, leaving its other lanes.
///
/// # Safety
/// The CPU must have AVX-512 F.
///
/// # Panics
/// Unless W is 16.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn store_lanes_16<const W: usize>(
    dst: &mut F32s<W>,
    lanes: u16,
    v: std::arch::x86_64::__m512,
) {
    assert_eq!(W, 16);
    // SAFETY: dst holds 16 f32 (W = 16).
    std::arch::x86_64::_mm512_mask_storeu_ps(dst.0.as_mut_ptr(), lanes, v);
}

/// The narrowest wave whose stages run their vector kernels (the path tracer's light and BSDF
/// samples, the surfaces of mesh hits). Narrower waves (W = 1) take the scalar code for every
/// lane: it computes the same bits, with none of the kernels' gathering, and
/// `tests/lane_widths.rs`, which requires W = 4, 8 and 16 to give W = 1's films, so checks
/// every kernel against the scalar code it stands for on every scene it renders.
pub const KERNELS_FROM: usize = 4;

/// `if a < b { a } else { b }`: the lanes' minimum (a NaN in either argument gives `b`).
#[inline(always)]
pub fn min(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `if a > b { a } else { b }`: the lanes' maximum (a NaN in either argument gives `b`).
#[inline(always)]
pub fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// What every lane type has: construction, lane access and `select`.
macro_rules! lanes_common {
    ($ty:ident, $elem:ty) => {
        impl<const W: usize> $ty<W> {
            /// Every lane `v`.
            #[inline(always)]
            pub fn splat(v: $elem) -> Self {
                Self([v; W])
            }

            /// Lane `i` is `f(i)`.
            #[inline(always)]
            pub fn from_fn(f: impl FnMut(usize) -> $elem) -> Self {
                Self(std::array::from_fn(f))
            }

            /// The lanes as an array.
            #[inline(always)]
            pub fn to_array(self) -> [$elem; W] {
                self.0
            }

            /// `if_true` in the lanes where `mask` holds, `if_false` in the others.
            #[inline(always)]
            pub fn select(mask: Mask<W>, if_true: Self, if_false: Self) -> Self {
                if sse2::chunked::<W>() && std::mem::size_of::<$elem>() == 4 {
                    let mut out = if_false;
                    for k in 0..W / 4 {
                        // SAFETY: SSE2 is part of x86-64 (`chunked` holds only there), lanes
                        // 4k..4k + 4 lie within arrays of W lanes, and the values are 4 bytes.
                        unsafe {
                            sse2::select32(&mask.0, &if_true.0, &if_false.0, &mut out.0, 4 * k)
                        };
                    }
                    return out;
                }
                // A select per lane (no store under a branch), which vectorises as a blend.
                let mut out = if_false;
                for i in 0..W {
                    out.0[i] = if mask.0[i] != 0 {
                        if_true.0[i]
                    } else {
                        out.0[i]
                    };
                }
                out
            }
        }

        impl<const W: usize> Default for $ty<W> {
            #[inline(always)]
            fn default() -> Self {
                Self([<$elem>::default(); W])
            }
        }

        impl<const W: usize> From<[$elem; W]> for $ty<W> {
            #[inline(always)]
            fn from(a: [$elem; W]) -> Self {
                Self(a)
            }
        }

        impl<const W: usize> Index<usize> for $ty<W> {
            type Output = $elem;
            #[inline(always)]
            fn index(&self, i: usize) -> &$elem {
                &self.0[i]
            }
        }

        impl<const W: usize> IndexMut<usize> for $ty<W> {
            #[inline(always)]
            fn index_mut(&mut self, i: usize) -> &mut $elem {
                &mut self.0[i]
            }
        }
    };
}

/// A lane-wise binary operator `$ty op $ty`, `$ty op $elem` and `$elem op $ty` (the scalar
/// stands for every lane), with its assigning forms when `$assign` is given.
macro_rules! lanes_binop {
    ($ty:ident, $elem:ty, $trait:ident, $method:ident, |$a:ident, $b:ident| $body:expr
        $(, $assign:ident, $assign_method:ident)? $(; sse2 $sse:ident)?) => {
        impl<const W: usize> $trait for $ty<W> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, rhs: Self) -> Self {
                let mut out = self;
                $(
                    if sse2::chunked::<W>() {
                        for k in 0..W / 4 {
                            // SAFETY: SSE2 is part of x86-64 (`chunked` holds only there), and
                            // lanes 4k..4k + 4 lie within arrays of W lanes, a multiple of 4.
                            unsafe { sse2::$sse(&self.0, &rhs.0, &mut out.0, 4 * k) };
                        }
                        return out;
                    }
                )?
                for i in 0..W {
                    let ($a, $b): ($elem, $elem) = (self.0[i], rhs.0[i]);
                    out.0[i] = $body;
                }
                out
            }
        }

        impl<const W: usize> $trait<$elem> for $ty<W> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, rhs: $elem) -> Self {
                self.$method(Self::splat(rhs))
            }
        }

        impl<const W: usize> $trait<$ty<W>> for $elem {
            type Output = $ty<W>;
            #[inline(always)]
            fn $method(self, rhs: $ty<W>) -> $ty<W> {
                $ty::splat(self).$method(rhs)
            }
        }

        $(
            impl<const W: usize> $assign for $ty<W> {
                #[inline(always)]
                fn $assign_method(&mut self, rhs: Self) {
                    *self = self.$method(rhs);
                }
            }

            impl<const W: usize> $assign<$elem> for $ty<W> {
                #[inline(always)]
                fn $assign_method(&mut self, rhs: $elem) {
                    *self = self.$method(rhs);
                }
            }
        )?
    };
}

/// Comparisons of one lane type, each giving a [`Mask`].
macro_rules! lanes_compare {
    ($ty:ident, $elem:ty $(; sse2 $f32:ident)?) => {
        impl<const W: usize> $ty<W> {
            #[inline(always)]
            fn compare(self, rhs: Self, op: Comparison) -> Mask<W> {
                let mut out = Mask([0; W]);
                $(
                    // (`$f32` only marks the f32 lanes, which SSE2 compares four at a time.)
                    let _ = sse2::$f32::<W>;
                    if sse2::chunked::<W>() {
                        for k in 0..W / 4 {
                            // SAFETY: as for the binary operators.
                            unsafe { sse2::compare_ps(op, &self.0, &rhs.0, &mut out.0, 4 * k) };
                        }
                        return out;
                    }
                )?
                // A loop writing every lane (not `from_fn`), which LLVM vectorises.
                for i in 0..W {
                    out.0[i] = if op.holds(self.0[i], rhs.0[i]) { !0 } else { 0 };
                }
                out
            }

            /// Lanes where `self < rhs` (false where either is NaN).
            #[inline(always)]
            pub fn lt(self, rhs: Self) -> Mask<W> {
                self.compare(rhs, Comparison::Lt)
            }

            /// Lanes where `self <= rhs` (false where either is NaN).
            #[inline(always)]
            pub fn le(self, rhs: Self) -> Mask<W> {
                self.compare(rhs, Comparison::Le)
            }

            /// Lanes where `self > rhs` (false where either is NaN).
            #[inline(always)]
            pub fn gt(self, rhs: Self) -> Mask<W> {
                self.compare(rhs, Comparison::Gt)
            }

            /// Lanes where `self >= rhs` (false where either is NaN).
            #[inline(always)]
            pub fn ge(self, rhs: Self) -> Mask<W> {
                self.compare(rhs, Comparison::Ge)
            }

            /// Lanes where `self == rhs` (false where either is NaN; −0 equals +0).
            #[inline(always)]
            pub fn eq(self, rhs: Self) -> Mask<W> {
                self.compare(rhs, Comparison::Eq)
            }

            /// Lanes where `self != rhs` (true where either is NaN).
            #[inline(always)]
            pub fn ne(self, rhs: Self) -> Mask<W> {
                !self.eq(rhs)
            }
        }
    };
}

/// A comparison of two lanes' values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Comparison {
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
}

impl Comparison {
    /// Whether `a` compares to `b` so.
    #[inline(always)]
    fn holds<T: PartialOrd>(self, a: T, b: T) -> bool {
        match self {
            Comparison::Lt => a < b,
            Comparison::Le => a <= b,
            Comparison::Gt => a > b,
            Comparison::Ge => a >= b,
            Comparison::Eq => a == b,
        }
    }
}

/// The f32 lanes' operations in SSE2 registers (part of every x86-64) when W = 4: the same
/// IEEE-754 operations, so the same bits, in vector instructions whatever LLVM's vectoriser
/// makes of the lane loops (at W = 4 in baseline code it leaves some lanes of long expressions
/// scalar). Wider waves keep the plain loops: inside the kernels compiled for AVX2 or AVX-512
/// (`widest!`) LLVM turns them into `ymm` or `zmm` instructions, while it never joins SSE2
/// chunks into wider registers (the W = 16 light kernel ran 2,071 of its 2,092 instructions on
/// `xmm` registers in chunks; `docs/performance.md`, 2026-12-03).
mod sse2 {
    /// Whether the operations run in SSE2 chunks.
    #[inline(always)]
    pub(super) const fn chunked<const W: usize>() -> bool {
        cfg!(target_arch = "x86_64") && W == 4
    }

    #[cfg(target_arch = "x86_64")]
    use std::arch::x86_64::*;

    /// Binary operations on lanes `k..k + 4`.
    macro_rules! binary {
        ($($name:ident = $intrinsic:ident),*) => {$(
            /// Lanes `k..k + 4` of `out` from those of `a` and `b`.
            ///
            /// # Safety
            /// `k + 4 <= W`, on x86-64 only.
            #[inline(always)]
            pub(super) unsafe fn $name<const W: usize>(
                a: &[f32; W],
                b: &[f32; W],
                out: &mut [f32; W],
                k: usize,
            ) {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: the caller keeps k + 4 within the arrays.
                unsafe {
                    let r = $intrinsic(_mm_loadu_ps(a.as_ptr().add(k)), _mm_loadu_ps(b.as_ptr().add(k)));
                    _mm_storeu_ps(out.as_mut_ptr().add(k), r);
                }
                #[cfg(not(target_arch = "x86_64"))]
                unreachable!("{a:?}{b:?}{out:?}{k}");
            }
        )*};
    }
    binary!(
        add_ps = _mm_add_ps,
        sub_ps = _mm_sub_ps,
        mul_ps = _mm_mul_ps,
        div_ps = _mm_div_ps
    );

    /// Unary operations on lanes `k..k + 4`.
    macro_rules! unary {
        ($($name:ident = |$v:ident| $body:expr),*) => {$(
            /// Lanes `k..k + 4` of `out` from those of `a`.
            ///
            /// # Safety
            /// `k + 4 <= W`, on x86-64 only.
            #[inline(always)]
            pub(super) unsafe fn $name<const W: usize>(a: &[f32; W], out: &mut [f32; W], k: usize) {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: the caller keeps k + 4 within the arrays.
                unsafe {
                    let $v = _mm_loadu_ps(a.as_ptr().add(k));
                    _mm_storeu_ps(out.as_mut_ptr().add(k), $body);
                }
                #[cfg(not(target_arch = "x86_64"))]
                unreachable!("{a:?}{out:?}{k}");
            }
        )*};
    }
    unary!(
        neg_ps = |v| _mm_xor_ps(v, _mm_set1_ps(-0.0)),
        abs_ps = |v| _mm_andnot_ps(_mm_set1_ps(-0.0), v),
        sqrt_ps = |v| _mm_sqrt_ps(v)
    );

    /// Lanes `k..k + 4` of `out`: all ones where `a op b`, zero elsewhere.
    ///
    /// # Safety
    /// `k + 4 <= W`, on x86-64 only.
    #[inline(always)]
    pub(super) unsafe fn compare_ps<const W: usize>(
        op: super::Comparison,
        a: &[f32; W],
        b: &[f32; W],
        out: &mut [u32; W],
        k: usize,
    ) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the caller keeps k + 4 within the arrays.
        unsafe {
            let (a, b) = (
                _mm_loadu_ps(a.as_ptr().add(k)),
                _mm_loadu_ps(b.as_ptr().add(k)),
            );
            let r = match op {
                super::Comparison::Lt => _mm_cmplt_ps(a, b),
                super::Comparison::Le => _mm_cmple_ps(a, b),
                super::Comparison::Gt => _mm_cmpgt_ps(a, b),
                super::Comparison::Ge => _mm_cmpge_ps(a, b),
                super::Comparison::Eq => _mm_cmpeq_ps(a, b),
            };
            _mm_storeu_ps(out.as_mut_ptr().add(k).cast(), r);
        }
        #[cfg(not(target_arch = "x86_64"))]
        unreachable!("{op:?}{a:?}{b:?}{out:?}{k}");
    }

    /// Lanes `k..k + 4` of 32-bit values: `t` where `mask` is all ones, `f` where it is zero.
    ///
    /// # Safety
    /// `k + 4 <= W`, on x86-64 only; `T` is 4 bytes.
    #[inline(always)]
    pub(super) unsafe fn select32<T: Copy + std::fmt::Debug, const W: usize>(
        mask: &[u32; W],
        t: &[T; W],
        f: &[T; W],
        out: &mut [T; W],
        k: usize,
    ) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the caller keeps k + 4 within the arrays of 4-byte values.
        unsafe {
            let m = _mm_loadu_si128(mask.as_ptr().add(k).cast());
            let t = _mm_loadu_si128(t.as_ptr().add(k).cast());
            let f = _mm_loadu_si128(f.as_ptr().add(k).cast());
            let r = _mm_or_si128(_mm_and_si128(m, t), _mm_andnot_si128(m, f));
            _mm_storeu_si128(out.as_mut_ptr().add(k).cast(), r);
        }
        #[cfg(not(target_arch = "x86_64"))]
        unreachable!("{mask:?}{t:?}{f:?}{out:?}{k}");
    }

    /// Lanes `k..k + 4` of masks combined bit by bit: `a & b`, `a | b`, `a ^ b`, `!a`.
    macro_rules! logic {
        ($($name:ident = |$a:ident, $b:ident| $body:expr),*) => {$(
            /// Lanes `k..k + 4` of `out` from those of `a` and `b`.
            ///
            /// # Safety
            /// `k + 4 <= W`, on x86-64 only.
            #[inline(always)]
            pub(super) unsafe fn $name<const W: usize>(
                a: &[u32; W],
                b: &[u32; W],
                out: &mut [u32; W],
                k: usize,
            ) {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: the caller keeps k + 4 within the arrays.
                unsafe {
                    let $a = _mm_loadu_si128(a.as_ptr().add(k).cast());
                    let $b = _mm_loadu_si128(b.as_ptr().add(k).cast());
                    _mm_storeu_si128(out.as_mut_ptr().add(k).cast(), $body);
                }
                #[cfg(not(target_arch = "x86_64"))]
                unreachable!("{a:?}{b:?}{out:?}{k}");
            }
        )*};
    }
    logic!(
        and = |a, b| _mm_and_si128(a, b),
        or = |a, b| _mm_or_si128(a, b),
        xor = |a, b| _mm_xor_si128(a, b),
        and_not = |a, b| _mm_andnot_si128(b, a)
    );
}

/// Floating-point lanes: arithmetic, min/max, and the IEEE-exact functions.
macro_rules! lanes_float {
    ($ty:ident, $elem:ident, $bits_ty:ident
        $(; sse2 $add:ident, $sub:ident, $mul:ident, $div:ident, $neg:ident, $abs:ident,
        $sqrt:ident)?) => {
        lanes_common!($ty, $elem);
        lanes_compare!($ty, $elem $(; sse2 $add)?);
        lanes_binop!($ty, $elem, Add, add, |a, b| a + b, AddAssign, add_assign $(; sse2 $add)?);
        lanes_binop!($ty, $elem, Sub, sub, |a, b| a - b, SubAssign, sub_assign $(; sse2 $sub)?);
        lanes_binop!($ty, $elem, Mul, mul, |a, b| a * b, MulAssign, mul_assign $(; sse2 $mul)?);
        lanes_binop!($ty, $elem, Div, div, |a, b| a / b, DivAssign, div_assign $(; sse2 $div)?);

        impl<const W: usize> Neg for $ty<W> {
            type Output = Self;
            #[inline(always)]
            fn neg(self) -> Self {
                $(
                    if sse2::chunked::<W>() {
                        let mut out = self;
                        for k in 0..W / 4 {
                            // SAFETY: as for the binary operators.
                            unsafe { sse2::$neg(&self.0, &mut out.0, 4 * k) };
                        }
                        return out;
                    }
                )?
                Self(self.0.map(|a| -a))
            }
        }

        impl<const W: usize> $ty<W> {
            /// |x| (the sign bit cleared, NaN included).
            #[inline(always)]
            pub fn abs(self) -> Self {
                $(
                    if sse2::chunked::<W>() {
                        let mut out = self;
                        for k in 0..W / 4 {
                            // SAFETY: as for the binary operators.
                            unsafe { sse2::$abs(&self.0, &mut out.0, 4 * k) };
                        }
                        return out;
                    }
                )?
                Self(self.0.map(|a| a.abs()))
            }

            /// √x, correctly rounded (NaN below −0; √−0 = −0).
            #[inline(always)]
            pub fn sqrt(self) -> Self {
                $(
                    if sse2::chunked::<W>() {
                        let mut out = self;
                        for k in 0..W / 4 {
                            // SAFETY: as for the binary operators.
                            unsafe { sse2::$sqrt(&self.0, &mut out.0, 4 * k) };
                        }
                        return out;
                    }
                )?
                Self(self.0.map(|a| a.sqrt()))
            }

            /// `if self < rhs { self } else { rhs }` per lane: a NaN in either gives `rhs`.
            #[inline(always)]
            pub fn min(self, rhs: Self) -> Self {
                Self::select(self.lt(rhs), self, rhs)
            }

            /// `if self > rhs { self } else { rhs }` per lane: a NaN in either gives `rhs`.
            #[inline(always)]
            pub fn max(self, rhs: Self) -> Self {
                Self::select(self.gt(rhs), self, rhs)
            }

            /// Lanes holding a NaN.
            #[inline(always)]
            pub fn is_nan(self) -> Mask<W> {
                self.ne(self)
            }

            /// Lanes that are neither infinite nor NaN.
            #[inline(always)]
            pub fn is_finite(self) -> Mask<W> {
                self.abs().lt(Self::splat($elem::INFINITY))
            }

            /// Lanes whose sign bit is set (−0 and negative NaNs included).
            #[inline(always)]
            pub fn sign_bit(self) -> Mask<W> {
                Mask::from_fn(|i| self.0[i].is_sign_negative())
            }

            /// |self| with the sign bit of `sign`.
            #[inline(always)]
            pub fn copysign(self, sign: Self) -> Self {
                Self::from_fn(|i| self.0[i].copysign(sign.0[i]))
            }

            /// The lanes' bit patterns.
            #[inline(always)]
            pub fn to_bits(self) -> $bits_ty<W> {
                $bits_ty(self.0.map($elem::to_bits))
            }

            /// The floats with bit patterns `bits`.
            #[inline(always)]
            pub fn from_bits(bits: $bits_ty<W>) -> Self {
                Self(bits.0.map($elem::from_bits))
            }
        }
    };
}

lanes_float!(F32s, f32, U32s; sse2 add_ps, sub_ps, mul_ps, div_ps, neg_ps, abs_ps, sqrt_ps);
lanes_float!(F64s, f64, U64s);

impl<const W: usize> F32s<W> {
    /// The nearest integer, ties to even (exact; ±0, ±∞ and NaN unchanged, as every float of
    /// magnitude ≥ 2²³, already an integer). Adding and subtracting 2²³ rounds |x| < 2²³ to an
    /// integer in the current (nearest-even) mode: no library call, no SSE4.1.
    #[inline(always)]
    pub fn round_ties_even(self) -> Self {
        const TWO_23: f32 = 8_388_608.0;
        let a = self.abs();
        let rounded = ((a + TWO_23) - TWO_23).copysign(self);
        Self::select(a.lt(Self::splat(TWO_23)), rounded, self)
    }

    /// The largest integer ≤ x (exact; ±0, ±∞ and NaN unchanged).
    #[inline(always)]
    pub fn floor(self) -> Self {
        let r = self.round_ties_even();
        Self::select(r.gt(self), r - 1.0, r)
    }

    /// Lane-wise `x as i32`: toward zero, saturating at the `i32` range, NaN → 0.
    #[inline(always)]
    pub fn to_i32(self) -> I32s<W> {
        // `a as i32` saturates, which LLVM leaves scalar. At W = 4, SSE2's truncation and two
        // fix-ups give the same values; wider waves take the loop below.
        let mut out = I32s([0; W]);
        #[cfg(target_arch = "x86_64")]
        if sse2::chunked::<W>() {
            const TWO_31: f32 = 2_147_483_648.0;
            use std::arch::x86_64::*;
            for c in 0..W / 4 {
                // SAFETY: SSE2 is part of x86-64; each load and store covers lanes 4c..4c + 4 of
                // arrays of W lanes, W a multiple of 4.
                unsafe {
                    let a = _mm_loadu_ps(self.0.as_ptr().add(4 * c));
                    // 0x8000_0000 (i32::MIN) for NaN and out-of-range lanes …
                    let t = _mm_cvttps_epi32(a);
                    // … which becomes i32::MAX at and above 2³¹ and 0 for NaN, as `as i32` does.
                    let big = _mm_castps_si128(_mm_cmpge_ps(a, _mm_set1_ps(TWO_31)));
                    let nan = _mm_castps_si128(_mm_cmpunord_ps(a, a));
                    let r = _mm_andnot_si128(nan, _mm_xor_si128(t, big));
                    _mm_storeu_si128(out.0.as_mut_ptr().add(4 * c).cast(), r);
                }
            }
            return out;
        }
        // `as i32` spelled out so that LLVM vectorises it: truncation of the lanes known to be
        // in range (the others truncate 0), then the saturated ends; NaN fails both tests.
        const TWO_31: f32 = 2_147_483_648.0;
        for (o, &a) in out.0.iter_mut().zip(&self.0) {
            let (high, low) = (a >= TWO_31, a < -TWO_31);
            // Both tests, not `contains`'s short circuit, which LLVM leaves scalar.
            #[allow(clippy::manual_range_contains)]
            let in_range = if (a >= -TWO_31) & (a < TWO_31) {
                a
            } else {
                0.0
            };
            // SAFETY: `in_range` lies in [−2³¹, 2³¹), so its truncation is an i32.
            let t: i32 = unsafe { in_range.to_int_unchecked() };
            let t = if high { i32::MAX } else { t };
            *o = if low { i32::MIN } else { t };
        }
        out
    }

    /// Each lane widened to `f64` (exact).
    #[inline(always)]
    pub fn to_f64(self) -> F64s<W> {
        F64s(self.0.map(f64::from))
    }
}

impl<const W: usize> F64s<W> {
    /// The nearest integer, ties to even (exact; ±0, ±∞ and NaN unchanged, as every float of
    /// magnitude ≥ 2⁵², already an integer), by adding and subtracting 2⁵².
    #[inline(always)]
    pub fn round_ties_even(self) -> Self {
        const TWO_52: f64 = 4_503_599_627_370_496.0;
        let a = self.abs();
        let rounded = ((a + TWO_52) - TWO_52).copysign(self);
        Self::select(a.lt(Self::splat(TWO_52)), rounded, self)
    }

    /// The largest integer ≤ x (exact; ±0, ±∞ and NaN unchanged).
    #[inline(always)]
    pub fn floor(self) -> Self {
        let r = self.round_ties_even();
        Self::select(r.gt(self), r - 1.0, r)
    }

    /// Each lane rounded to the nearest `f32` (ties to even; overflow to ±∞, subnormals
    /// rounded once).
    #[inline(always)]
    pub fn to_f32(self) -> F32s<W> {
        F32s(self.0.map(|a| a as f32))
    }
}

/// Integer lanes: wrapping arithmetic, bit operations and shifts.
macro_rules! lanes_int {
    ($ty:ident, $elem:ty) => {
        lanes_common!($ty, $elem);
        lanes_compare!($ty, $elem);
        lanes_binop!(
            $ty,
            $elem,
            Add,
            add,
            |a, b| a.wrapping_add(b),
            AddAssign,
            add_assign
        );
        lanes_binop!(
            $ty,
            $elem,
            Sub,
            sub,
            |a, b| a.wrapping_sub(b),
            SubAssign,
            sub_assign
        );
        lanes_binop!(
            $ty,
            $elem,
            Mul,
            mul,
            |a, b| a.wrapping_mul(b),
            MulAssign,
            mul_assign
        );
        lanes_binop!($ty, $elem, BitAnd, bitand, |a, b| a & b);
        lanes_binop!($ty, $elem, BitOr, bitor, |a, b| a | b);
        lanes_binop!($ty, $elem, BitXor, bitxor, |a, b| a ^ b);

        impl<const W: usize> Not for $ty<W> {
            type Output = Self;
            #[inline(always)]
            fn not(self) -> Self {
                Self(self.0.map(|a| !a))
            }
        }

        /// Each lane shifted left by `n` bits (`n` below the lane's width).
        impl<const W: usize> Shl<u32> for $ty<W> {
            type Output = Self;
            #[inline(always)]
            fn shl(self, n: u32) -> Self {
                Self(self.0.map(|a| a << n))
            }
        }

        /// Each lane shifted right by `n` bits: arithmetic for signed lanes, logical for
        /// unsigned ones (`n` below the lane's width).
        impl<const W: usize> Shr<u32> for $ty<W> {
            type Output = Self;
            #[inline(always)]
            fn shr(self, n: u32) -> Self {
                Self(self.0.map(|a| a >> n))
            }
        }

        impl<const W: usize> $ty<W> {
            /// Each lane's bits in reverse order.
            #[inline(always)]
            pub fn reverse_bits(self) -> Self {
                Self(self.0.map(<$elem>::reverse_bits))
            }

            /// The smaller of each pair of lanes.
            #[inline(always)]
            pub fn min(self, rhs: Self) -> Self {
                Self::select(self.lt(rhs), self, rhs)
            }

            /// The larger of each pair of lanes.
            #[inline(always)]
            pub fn max(self, rhs: Self) -> Self {
                Self::select(self.gt(rhs), self, rhs)
            }
        }
    };
}

lanes_int!(I32s, i32);
lanes_int!(U32s, u32);
lanes_int!(U64s, u64);

impl<const W: usize> I32s<W> {
    /// Each lane converted to the nearest `f32` (exact below 2²⁴ in magnitude).
    #[inline(always)]
    pub fn to_f32(self) -> F32s<W> {
        F32s(self.0.map(|a| a as f32))
    }

    /// The same bits as `u32` lanes.
    #[inline(always)]
    pub fn cast_u32(self) -> U32s<W> {
        U32s(self.0.map(|a| a as u32))
    }
}

impl<const W: usize> U32s<W> {
    /// The same bits as `i32` lanes.
    #[inline(always)]
    pub fn cast_i32(self) -> I32s<W> {
        I32s(self.0.map(|a| a as i32))
    }
}

impl<const W: usize> U64s<W> {
    /// The low 32 bits of each lane.
    #[inline(always)]
    pub fn low_u32(self) -> U32s<W> {
        U32s(self.0.map(|a| a as u32))
    }
}

impl<const W: usize> Mask<W> {
    /// Every lane `b`.
    #[inline(always)]
    pub fn splat(b: bool) -> Self {
        Self([if b { !0 } else { 0 }; W])
    }

    /// Lane `i` is `f(i)`.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> bool) -> Self {
        Self(std::array::from_fn(|i| if f(i) { !0 } else { 0 }))
    }

    /// Sets lane `i` to `b`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, b: bool) {
        self.0[i] = if b { !0 } else { 0 };
    }

    /// Whether lane `i` holds.
    #[inline(always)]
    pub fn lane(self, i: usize) -> bool {
        self.0[i] != 0
    }

    /// Whether any lane holds.
    #[inline(always)]
    pub fn any(self) -> bool {
        if cfg!(target_arch = "x86_64") && W.is_multiple_of(4) {
            return self.bits() != 0;
        }
        self.0.iter().fold(0, |acc, &m| acc | m) != 0
    }

    /// Whether every lane holds.
    #[inline(always)]
    pub fn all(self) -> bool {
        self.0.iter().fold(!0, |acc, &m| acc & m) != 0
    }

    /// Lanes where `self` holds and `rhs` does not.
    #[inline(always)]
    pub fn and_not(self, rhs: Self) -> Self {
        self & !rhs
    }

    /// Bit i set where lane i holds (W ≤ 64).
    #[inline(always)]
    pub fn bits(self) -> u64 {
        #[cfg(target_arch = "x86_64")]
        if W.is_multiple_of(4) {
            // Four lanes per instruction (`movmskps` of the lanes' sign bits, which a lane's
            // 0 or !0 sets as its lowest bit), in the baseline instruction set: the wave's
            // scalar loops over lanes start here, and bit by bit it took three instructions
            // per lane.
            let mut bits = 0;
            for k in 0..W / 4 {
                // SAFETY: SSE2 is part of x86-64, and lanes 4k..4k + 4 lie within W.
                let four = unsafe {
                    use std::arch::x86_64::*;
                    let m = _mm_loadu_si128(self.0.as_ptr().add(4 * k).cast());
                    _mm_movemask_ps(_mm_castsi128_ps(m))
                };
                bits |= (four as u64) << (4 * k);
            }
            return bits;
        }
        let mut bits = 0;
        for (i, &m) in self.0.iter().enumerate() {
            bits |= u64::from(m & 1) << i;
        }
        bits
    }

    /// The lanes that hold, in increasing order: a loop over them runs without a branch per
    /// lane on the lanes' values (such branches, taken at random, are what a wave's loops
    /// over its lanes mostly cost).
    #[inline(always)]
    pub fn iter(self) -> SetLanes {
        SetLanes(self.bits())
    }

    /// The mask whose lane i holds where bit i of `bits` is set (W ≤ 64). On x86-64 four lanes
    /// per instruction, written as whole vectors: a mask written lane by lane and then read four
    /// lanes at a time (as [`bits`](Self::bits) reads it) waits for its narrow stores to reach
    /// the cache, as a wider load cannot take its data from several of them.
    #[inline(always)]
    pub fn from_bits(bits: u64) -> Self {
        #[cfg(target_arch = "x86_64")]
        if W.is_multiple_of(4) {
            let mut out = Self::splat(false);
            for k in 0..W / 4 {
                // SAFETY: SSE2 is part of x86-64, and lanes 4k..4k + 4 lie within W.
                unsafe {
                    use std::arch::x86_64::*;
                    let lane_bits = _mm_setr_epi32(1, 2, 4, 8);
                    let four = _mm_set1_epi32(((bits >> (4 * k)) & 0xf) as i32);
                    let m = _mm_cmpeq_epi32(_mm_and_si128(four, lane_bits), lane_bits);
                    _mm_storeu_si128(out.0.as_mut_ptr().add(4 * k).cast(), m);
                }
            }
            return out;
        }
        Self::from_fn(|i| (bits >> i) & 1 != 0)
    }

    /// Whether each lane holds, as an array.
    #[inline(always)]
    pub fn to_bools(self) -> [bool; W] {
        self.0.map(|m| m != 0)
    }

    /// Mask of the lanes `flags` holds.
    #[inline(always)]
    pub fn from_bools(flags: &[bool; W]) -> Self {
        let mut out = Self::splat(false);
        for (m, &b) in out.0.iter_mut().zip(flags) {
            *m = 0u32.wrapping_sub(u32::from(b));
        }
        out
    }

    /// How many lanes hold.
    #[inline(always)]
    pub fn count(self) -> u32 {
        self.bits().count_ones()
    }
}

/// The lanes of a [`Mask`] that hold ([`Mask::iter`]).
#[derive(Clone, Copy, Debug)]
pub struct SetLanes(u64);

impl Iterator for SetLanes {
    type Item = usize;
    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let i = self.0.trailing_zeros() as usize;
        self.0 &= self.0 - 1;
        Some(i)
    }
}

impl<const W: usize> BitAnd for Mask<W> {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, rhs: Self) -> Self {
        let mut out = self;
        if sse2::chunked::<W>() {
            for k in 0..W / 4 {
                // SAFETY: SSE2 is part of x86-64 (`chunked` holds only there), and lanes
                // 4k..4k + 4 lie within arrays of W lanes.
                unsafe { sse2::and(&self.0, &rhs.0, &mut out.0, 4 * k) };
            }
            return out;
        }
        for i in 0..W {
            out.0[i] &= rhs.0[i];
        }
        out
    }
}

impl<const W: usize> BitOr for Mask<W> {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, rhs: Self) -> Self {
        let mut out = self;
        if sse2::chunked::<W>() {
            for k in 0..W / 4 {
                // SAFETY: SSE2 is part of x86-64 (`chunked` holds only there), and lanes
                // 4k..4k + 4 lie within arrays of W lanes.
                unsafe { sse2::or(&self.0, &rhs.0, &mut out.0, 4 * k) };
            }
            return out;
        }
        for i in 0..W {
            out.0[i] |= rhs.0[i];
        }
        out
    }
}

impl<const W: usize> BitXor for Mask<W> {
    type Output = Self;
    #[inline(always)]
    fn bitxor(self, rhs: Self) -> Self {
        let mut out = self;
        if sse2::chunked::<W>() {
            for k in 0..W / 4 {
                // SAFETY: SSE2 is part of x86-64 (`chunked` holds only there), and lanes
                // 4k..4k + 4 lie within arrays of W lanes.
                unsafe { sse2::xor(&self.0, &rhs.0, &mut out.0, 4 * k) };
            }
            return out;
        }
        for i in 0..W {
            out.0[i] ^= rhs.0[i];
        }
        out
    }
}

impl<const W: usize> Not for Mask<W> {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        if sse2::chunked::<W>() {
            let mut out = self;
            for k in 0..W / 4 {
                // SAFETY: as for `&`.
                unsafe { sse2::and_not(&[!0; W], &self.0, &mut out.0, 4 * k) };
            }
            return out;
        }
        Self(self.0.map(|m| !m))
    }
}
