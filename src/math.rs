//! Small math kit: rays, boxes, frames, colour helpers, and robust ray-origin offsetting.

pub use glam::{Affine3A, Mat3, Vec2, Vec3, Vec3A};

/// Linear RGB radiance or reflectance.
pub type Rgb = Vec3;

/// A ray o + t d. `d` need not be unit length: hit distances are in units of |d|.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction.
    pub d: Vec3,
}

impl Ray {
    /// A ray from `o` along `d`.
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray { o, d }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }

    /// This ray mapped by an affine transform (direction not re-normalised, so `t` is preserved).
    pub fn transformed(&self, m: &Affine3A) -> Ray {
        Ray {
            o: m.transform_point3(self.o),
            d: m.transform_vector3(self.d),
        }
    }
}

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (union identity).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// This box enlarged to contain `p`.
    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The union of two boxes.
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the surface area (the SAH only needs proportional areas).
    pub fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// Whether the box contains nothing.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// The box of this box's eight corners mapped by `m`.
    pub fn transformed(&self, m: &Affine3A) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        let mut b = Aabb::EMPTY;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            b = b.grow(m.transform_point3(c));
        }
        b
    }

    /// Slab test: the entry distance if the ray meets the box within (t_min, t_max).
    ///
    /// A ray lying in the plane of a slab's face (zero direction component, origin on the
    /// face) gives 0·∞ = NaN there; that slab then does not limit the interval (the origin is
    /// inside it), as in pbrt's scalar test.
    #[inline]
    pub fn hit(&self, o: Vec3, inv_d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let t0 = (self.min - o) * inv_d;
        let t1 = (self.max - o) * inv_d;
        let mut near = t_min;
        let mut far = t_max;
        for k in 0..3 {
            let (a, b) = (t0[k], t1[k]);
            if a.is_nan() || b.is_nan() {
                continue;
            }
            near = near.max(a.min(b));
            far = far.min(a.max(b));
        }
        // Scale `far` up by 1 + 2γ₃ (pbrt-v4 §6.8.2) so rounding never culls a box the ray touches.
        (near <= far * 1.000_000_4).then_some(near)
    }
}

/// An orthonormal frame around a unit normal (Duff et al. 2017, "Building an Orthonormal Basis,
/// Revisited").
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// Normal (z axis of the local frame).
    pub n: Vec3,
}

impl Frame {
    /// The frame whose z axis is `n` (unit length).
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// [`from_normal`](Self::from_normal) in every lane, with its operations in its order (so
    /// its bits): the axes s, t and n.
    #[inline(always)]
    pub fn from_normal_lanes<const W: usize>(n: crate::lanes::V3s<W>) -> [crate::lanes::V3s<W>; 3] {
        use crate::lanes::{F32s, V3s};
        let sign = F32s::splat(1.0).copysign(n.z);
        let a = F32s::splat(-1.0) / (sign + n.z);
        let b = n.x * n.y * a;
        let s = V3s {
            x: F32s::splat(1.0) + sign * n.x * n.x * a,
            y: sign * b,
            z: -sign * n.x,
        };
        let t = V3s {
            x: b,
            y: sign + n.y * n.y * a,
            z: -n.y,
        };
        [s, t, n]
    }

    /// World to local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local to world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// a × b, each product rounded before the subtraction: the bits of glam's `Vec3A::cross` in a
/// build for baseline x86-64, whatever the build targets. glam fuses that product and
/// subtraction into one FMA where the build has FMA (`-C target-cpu=native` on any x86-64 of the
/// last decade), which would make lumo's images depend on how lumo was compiled; `clippy.toml`
/// therefore disallows glam's functions that do so, and these stand in for them.
#[inline]
pub fn cross(a: Vec3A, b: Vec3A) -> Vec3A {
    Vec3A::new(
        a.y * b.z - b.y * a.z,
        a.z * b.x - b.z * a.x,
        a.x * b.y - b.x * a.y,
    )
}

/// The determinant of `m`, with glam's operations and [`cross`] (see there).
#[inline]
pub fn determinant(m: &glam::Mat3A) -> f32 {
    m.x_axis.dot(cross(m.y_axis, m.z_axis))
}

/// The inverse of the invertible `m`, with glam's operations and [`cross`] (see there).
pub fn inverse(m: &glam::Mat3A) -> glam::Mat3A {
    let tmp0 = cross(m.y_axis, m.z_axis);
    let tmp1 = cross(m.z_axis, m.x_axis);
    let tmp2 = cross(m.x_axis, m.y_axis);
    let inv_det = Vec3A::splat(1.0 / m.x_axis.dot(tmp0));
    glam::Mat3A::from_cols(tmp0 * inv_det, tmp1 * inv_det, tmp2 * inv_det).transpose()
}

/// The inverse of the invertible affine map `a`, with glam's operations and [`cross`] (see
/// there).
pub fn inverse_affine(a: &Affine3A) -> Affine3A {
    let matrix3 = inverse(&a.matrix3);
    Affine3A {
        matrix3,
        translation: -(matrix3 * a.translation),
    }
}

/// Moves a surface point off the surface along the geometric normal `n` (towards the side `w`
/// points to) by a bound on its floating-point error, so that a ray spawned there does not hit
/// the same surface again. Method of Wächter and Binder, "A Fast and Robust Method for Avoiding
/// Self-Intersection", Ray Tracing Gems ch. 6 (2019): far from the origin the offset is a fixed
/// number of ulps of each coordinate (it scales with the coordinate's magnitude), near the origin
/// a tiny absolute offset.
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let n = if n.dot(w) < 0.0 { -n } else { n };
    #[cfg(target_arch = "x86_64")]
    {
        offset_towards_sse2(p, n)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        offset_towards(p, n)
    }
}

/// [`offset_origin`] in every lane, with the same operations per coordinate as
/// [`offset_towards`] (its branches as selects), so the same bits.
#[inline(always)]
pub fn offset_origin_lanes<const W: usize>(
    p: crate::lanes::V3s<W>,
    n: crate::lanes::V3s<W>,
    w: crate::lanes::V3s<W>,
) -> crate::lanes::V3s<W> {
    let n = crate::lanes::V3s::select(n.dot(w).lt(crate::lanes::F32s::splat(0.0)), -n, n);
    crate::lanes::V3s {
        x: offset_towards_lanes(p.x, n.x),
        y: offset_towards_lanes(p.y, n.y),
        z: offset_towards_lanes(p.z, n.z),
    }
}

/// One coordinate of [`offset_towards`] in every lane.
#[inline(always)]
fn offset_towards_lanes<const W: usize>(
    p: crate::lanes::F32s<W>,
    n: crate::lanes::F32s<W>,
) -> crate::lanes::F32s<W> {
    use crate::lanes::{F32s, I32s};
    let nudged = p + F32s::splat(OFFSET_FLOAT_SCALE) * n;
    let of = (F32s::splat(OFFSET_INT_SCALE) * n).to_i32();
    let bits = p.to_bits().cast_i32();
    let of_abs = I32s::select(of.lt(I32s::splat(0)), I32s::splat(0) - of, of);
    let down = p.lt(F32s::splat(0.0)) ^ of.lt(I32s::splat(0));
    let moved = F32s::from_bits(I32s::select(down, bits - of_abs, bits + of_abs).cast_u32());
    F32s::select(p.abs().lt(F32s::splat(OFFSET_ORIGIN)), nudged, moved)
}

/// Bound of [`offset_origin`]: below this magnitude a coordinate moves by an absolute amount.
const OFFSET_ORIGIN: f32 = 1.0 / 32.0;
/// [`offset_origin`]'s absolute offset near the origin, per unit of the normal.
const OFFSET_FLOAT_SCALE: f32 = 1.0 / 65536.0;
/// [`offset_origin`]'s offset in ulps elsewhere, per unit of the normal.
const OFFSET_INT_SCALE: f32 = 256.0;

/// [`offset_origin`] along `n` (already facing the side to move to), one coordinate at a time
/// (on x86-64 the reference its SSE2 version is tested against).
#[cfg(any(test, not(target_arch = "x86_64")))]
fn offset_towards(p: Vec3, n: Vec3) -> Vec3 {
    let step = |p: f32, n: f32| -> f32 {
        if p.abs() < OFFSET_ORIGIN {
            return p + OFFSET_FLOAT_SCALE * n;
        }
        let of = (OFFSET_INT_SCALE * n) as i32;
        let bits = p.to_bits() as i32;
        // Moving the bit pattern up increases |p|; pick the direction that moves along n.
        let moved = if (p < 0.0) ^ (of < 0) {
            bits - of.abs()
        } else {
            bits + of.abs()
        };
        f32::from_bits(moved as u32)
    };
    Vec3::new(step(p.x, n.x), step(p.y, n.y), step(p.z, n.z))
}

/// [`offset_towards`] in the lanes of one SSE2 register: the same operations per coordinate
/// (the branches become selects), so the same bits for every unit normal `n` (where
/// `256·n` truncates to an integer as Rust's `as i32` does). A third of the scalar version's
/// instructions, which the path tracer spends at every vertex and shadow ray.
#[cfg(target_arch = "x86_64")]
#[inline]
fn offset_towards_sse2(p: Vec3, n: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of the x86-64 baseline.
    unsafe {
        let pv = _mm_set_ps(0.0, p.z, p.y, p.x);
        let nv = _mm_set_ps(0.0, n.z, n.y, n.x);
        let of = _mm_cvttps_epi32(_mm_mul_ps(_mm_set1_ps(OFFSET_INT_SCALE), nv));
        let of_negative = _mm_srai_epi32::<31>(of);
        let of_abs = _mm_sub_epi32(_mm_xor_si128(of, of_negative), of_negative);
        // All ones where the bit pattern moves down: p < 0 xor of < 0.
        let down = _mm_xor_si128(
            _mm_castps_si128(_mm_cmplt_ps(pv, _mm_setzero_ps())),
            of_negative,
        );
        let step = _mm_sub_epi32(_mm_xor_si128(of_abs, down), down);
        let moved = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(pv), step));
        let magnitude = _mm_andnot_ps(_mm_set1_ps(-0.0), pv);
        let near_origin = _mm_cmplt_ps(magnitude, _mm_set1_ps(OFFSET_ORIGIN));
        let nudged = _mm_add_ps(pv, _mm_mul_ps(_mm_set1_ps(OFFSET_FLOAT_SCALE), nv));
        let out = _mm_or_ps(
            _mm_and_ps(near_origin, nudged),
            _mm_andnot_ps(near_origin, moved),
        );
        let mut lanes = [0.0f32; 4];
        _mm_storeu_ps(lanes.as_mut_ptr(), out);
        Vec3::new(lanes[0], lanes[1], lanes[2])
    }
}

/// Relative luminance of linear sRGB/Rec.709 primaries.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// sRGB transfer function: encoded value → linear.
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        crate::lanes::math::powf((v + 0.055) / 1.055, 2.4)
    }
}

/// [`srgb_to_linear`] of every 8-bit value k/255, for [`srgb8_to_linear`].
pub fn srgb8_table() -> &'static [f32; 256] {
    static TABLE: std::sync::LazyLock<[f32; 256]> =
        std::sync::LazyLock::new(|| std::array::from_fn(|k| srgb_to_linear(k as f32 / 255.0)));
    &TABLE
}

/// k/255 for every 8-bit value k: the linear decoding of 8-bit texels (the value image decoding
/// to floats gives).
pub fn unorm8_table() -> &'static [f32; 256] {
    static TABLE: std::sync::LazyLock<[f32; 256]> =
        std::sync::LazyLock::new(|| std::array::from_fn(|k| k as f32 / 255.0));
    &TABLE
}

/// [`srgb_to_linear`] of an 8-bit channel value `c` = k/255 by table lookup (the same bits as
/// the formula: the table holds its values); other values go through the formula. Decoding a
/// texture this way costs a lookup per channel instead of a `powf` (a 2048² texture has 12.6 M).
#[inline]
pub fn srgb8_to_linear(c: f32, table: &[f32; 256]) -> f32 {
    // Truncating cast, not `round` (a library call without SSE4.1); negative and NaN give 0.
    let k = (c * 255.0 + 0.5) as u32;
    if k <= 255 && k as f32 / 255.0 == c {
        table[k as usize]
    } else {
        srgb_to_linear(c)
    }
}

/// sRGB transfer function: linear → encoded value (input clamped to [0, 1]).
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * crate::lanes::math::powf(v, 1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SSE2 offset gives the scalar one's bits for unit normals and points at every scale
    /// (both signs, exact zeros, the near-origin band and its edge).
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn sse2_offset_matches_the_scalar_one() {
        let mut s = 0x5eed_u64;
        let mut uniform = || crate::sampler::test_lcg(&mut s);
        for i in 0..200_000 {
            let n = Vec3::new(uniform(), uniform(), uniform()) * 2.0 - Vec3::ONE;
            let n = if n.length_squared() > 1e-6 {
                n.normalize()
            } else {
                Vec3::Z
            };
            let scale = 10f32.powf(uniform() * 16.0 - 8.0);
            let mut p = Vec3::new(uniform(), uniform(), uniform()) * 2.0 - Vec3::ONE;
            p *= scale;
            match i % 5 {
                0 => p.x = 0.0,
                1 => p.y = -0.0,
                2 => p.z = OFFSET_ORIGIN * if uniform() < 0.5 { 1.0 } else { -1.0 },
                _ => {}
            }
            let (a, b) = (offset_towards(p, n), offset_towards_sse2(p, n));
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits),
                "p {p:?} n {n:?}"
            );
        }
    }

    #[test]
    fn offset_moves_to_the_requested_side_at_every_scale() {
        for scale in [1e-4f32, 1e-2, 1.0, 1e2, 1e4, 1e6] {
            let p = Vec3::new(0.3, -0.7, 0.9) * scale;
            let n = Vec3::new(0.0, 1.0, 0.0);
            let up = offset_origin(p, n, n);
            let down = offset_origin(p, n, -n);
            assert!(up.y > p.y && down.y < p.y, "scale {scale}: {up:?} {down:?}");
            // The offset is tiny relative to the coordinate's magnitude.
            assert!((up.y - p.y).abs() <= 1e-3 * scale.max(1.0));
        }
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!(
                f.s.dot(f.t).abs() < 1e-6 && f.s.dot(n).abs() < 1e-6 && f.t.dot(n).abs() < 1e-6
            );
            assert!((f.s.cross(f.t) - n).length() < 1e-5);
            let v = Vec3::new(0.2, 0.4, -0.3);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
        }
    }

    /// `cross`, `determinant`, `inverse` and `inverse_affine` give the bits of glam's own in a
    /// build without FMA (the default build), so replacing glam's changed no image, and give
    /// them with FMA too (`-C target-cpu=native`), where glam's own differ (then this test
    /// checks only the first: it cannot compare with glam's unfused bits there).
    #[test]
    #[allow(clippy::disallowed_methods)]
    fn cross_and_inverses_have_the_unfused_bits() {
        let mut state = 5u64;
        let mut v = || {
            let mut c = || (crate::sampler::test_lcg(&mut state) - 0.5) * 8.0;
            Vec3A::new(c(), c(), c())
        };
        let fused = cfg!(target_feature = "fma");
        let bits = |v: Vec3A| v.to_array().map(f32::to_bits);
        for _ in 0..10_000 {
            let (a, b) = (v(), v());
            let want = Vec3::from(a).cross(Vec3::from(b));
            assert_eq!(bits(cross(a, b)), bits(want.into()), "{a} × {b}");
            let m = glam::Mat3A::from_cols(v(), v(), v());
            let affine = Affine3A::from_mat3_translation(m.into(), v().into());
            if !fused {
                assert_eq!(bits(cross(a, b)), bits(a.cross(b)));
                assert_eq!(determinant(&m).to_bits(), m.determinant().to_bits());
                let columns = |m: glam::Mat3A| [m.x_axis, m.y_axis, m.z_axis].map(bits);
                assert_eq!(columns(inverse(&m)), columns(m.inverse()));
                let (got, want) = (inverse_affine(&affine), affine.inverse());
                assert_eq!(columns(got.matrix3), columns(want.matrix3));
                assert_eq!(bits(got.translation), bits(want.translation));
            }
        }
    }
}

#[cfg(test)]
mod srgb_tests {
    use super::*;

    #[test]
    fn the_8_bit_table_gives_the_formula_s_bits() {
        for k in 0..=255u8 {
            let c = f32::from(k) / 255.0;
            let got = srgb8_to_linear(c, srgb8_table());
            assert_eq!(got.to_bits(), srgb_to_linear(c).to_bits(), "{k}");
        }
        // 16-bit and float values take the formula.
        for c in [1.0 / 65535.0, 0.5, 0.300_001, 1.5, -0.1] {
            let got = srgb8_to_linear(c, srgb8_table());
            assert_eq!(got.to_bits(), srgb_to_linear(c).to_bits(), "{c}");
        }
    }
}
