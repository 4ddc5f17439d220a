//! [`Node8`]: a BVH node of up to eight children whose boxes are stored structure-of-arrays (and
//! [`Node4`], its half-size form for nodes of at most four children), and the two ways of
//! testing a ray against all eight boxes: [`Sse`], two 4-wide halves in the
//! baseline x86-64 instruction set (SSE2), and [`Avx2`], one 8-wide test (selected at run time
//! when the CPU has AVX2). Both compute each lane with the same operations in the same order
//! (subtract, multiply, min/max, compare; no fused multiply-add), so they give bit-identical
//! entry distances and masks, and a traversal visits the same nodes in the same order with
//! either.

use glam::Vec4;

use crate::geometry::triangle_bvh::TriRay;
use crate::math::Aabb;

/// Reference of an unused child slot (its box is empty, so it is never entered).
pub(crate) const EMPTY: u32 = u32::MAX;

/// The far distance of a box is scaled up by 1 + 2γ₃ (pbrt-v4 §6.8.2) so that rounding never
/// culls a box the ray touches.
pub(crate) const FAR_SCALE: f32 = 1.000_000_4;

/// A node of up to eight children: `planes[p]` holds plane p of `[lo x, hi x, lo y, hi y, lo z,
/// hi z]` for children 0–3 (`[p][0]`) and 4–7 (`[p][1]`); `child[i]` references child i. 256
/// bytes: four cache lines.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct Node8 {
    pub(crate) planes: [[Vec4; 2]; 6],
    pub(crate) child: [u32; 8],
}

impl Node8 {
    /// No children: empty boxes (lower corner +∞, upper −∞) meet no ray.
    pub(crate) const EMPTY: Node8 = Node8 {
        planes: [
            [Vec4::INFINITY; 2],
            [Vec4::NEG_INFINITY; 2],
            [Vec4::INFINITY; 2],
            [Vec4::NEG_INFINITY; 2],
            [Vec4::INFINITY; 2],
            [Vec4::NEG_INFINITY; 2],
        ],
        child: [EMPTY; 8],
    };

    /// Sets child `lane` (0–7) to box `b` and reference `child`.
    pub(crate) fn set_child(&mut self, lane: usize, b: Aabb, child: u32) {
        for axis in 0..3 {
            self.planes[2 * axis][lane / 4][lane % 4] = b.min[axis];
            self.planes[2 * axis + 1][lane / 4][lane % 4] = b.max[axis];
        }
        self.child[lane] = child;
    }
}

/// A node of at most four children (most nodes near the leaves: their binary subtrees offer no
/// more), half the bytes of a [`Node8`]: `planes[p]` holds plane p for children 0–3. Tested as
/// lanes 0–3 of a [`Node8`] would be, with the same arithmetic.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct Node4 {
    pub(crate) planes: [Vec4; 6],
    pub(crate) child: [u32; 4],
}

impl Node4 {
    /// No children.
    pub(crate) const EMPTY: Node4 = Node4 {
        planes: [
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
            Vec4::INFINITY,
            Vec4::NEG_INFINITY,
        ],
        child: [EMPTY; 4],
    };

    /// Sets child `lane` (0–3) to box `b` and reference `child`.
    pub(crate) fn set_child(&mut self, lane: usize, b: Aabb, child: u32) {
        for axis in 0..3 {
            self.planes[2 * axis][lane] = b.min[axis];
            self.planes[2 * axis + 1][lane] = b.max[axis];
        }
        self.child[lane] = child;
    }
}

/// The slab test of four boxes (`p[i]`: their plane i) in SSE lanes: see [`BoxTest`].
#[inline(always)]
fn hit4<const ROBUST: bool>(
    p: &[Vec4; 6],
    org: &[Vec4; 3],
    inv: &[Vec4; 3],
    negative: &[usize; 3],
    t_min: f32,
    t_max: f32,
) -> (Vec4, u32) {
    let (nx, fx) = slab4::<ROBUST>(p, org, inv, 0, negative[0]);
    let (ny, fy) = slab4::<ROBUST>(p, org, inv, 1, negative[1]);
    let (nz, fz) = slab4::<ROBUST>(p, org, inv, 2, negative[2]);
    let near = nx.max(ny).max(nz.max(Vec4::splat(t_min)));
    let far = fx.min(fy).min(fz.min(Vec4::splat(t_max)));
    (near, near.cmple(far * Vec4::splat(FAR_SCALE)).bitmask())
}

/// The entry and exit distances of four boxes' slabs of `axis` (`neg`: whether the ray runs
/// towards −axis). A function rather than a closure, so that it inlines into the AVX2
/// traversal (a closure does not inherit its target feature).
#[inline(always)]
fn slab4<const ROBUST: bool>(
    p: &[Vec4; 6],
    org: &[Vec4; 3],
    inv: &[Vec4; 3],
    axis: usize,
    neg: usize,
) -> (Vec4, Vec4) {
    let near = (p[2 * axis + (neg & 1)] - org[axis]) * inv[axis];
    let far = (p[2 * axis + (!neg & 1)] - org[axis]) * inv[axis];
    if ROBUST {
        (
            Vec4::select(near.is_nan_mask(), Vec4::NEG_INFINITY, near),
            Vec4::select(far.is_nan_mask(), Vec4::INFINITY, far),
        )
    } else {
        (near, far)
    }
}

/// A way of testing a ray against a [`Node8`]'s eight boxes.
///
/// `hit` returns the entry distances into the eight boxes and the bit mask of boxes the ray
/// meets within (t_min, t_max): the slab test (Kay and Kajiya 1986) with the near plane per axis
/// chosen by the direction's sign, and the far distance scaled by [`FAR_SCALE`]. Empty lanes
/// give +∞ entry and −∞ exit distances. When `ROBUST` is set (a zero direction component,
/// infinite reciprocal), the NaNs of 0·∞ — the ray lies in a slab's plane — become "this slab
/// does not limit", as in the binary [`Bvh`](crate::bvh::Bvh); without it the lanes are known
/// to be NaN-free.
pub(crate) trait BoxTest {
    /// The ray's box-test constants in this test's registers.
    type Ray: Copy;

    /// # Safety
    /// The CPU must support the instruction set of the implementation.
    unsafe fn ray(r: &TriRay) -> Self::Ray;

    /// # Safety
    /// As for [`BoxTest::ray`].
    unsafe fn hit<const ROBUST: bool>(
        node: &Node8,
        r: &Self::Ray,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 8], u32);

    /// The same for a [`Node4`] (lanes 0–3 of the result; in SSE lanes for both tests).
    ///
    /// # Safety
    /// As for [`BoxTest::ray`].
    unsafe fn hit4<const ROBUST: bool>(
        node: &Node4,
        r: &Self::Ray,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 8], u32);
}

/// The baseline test: the eight boxes as two groups of four in SSE registers (glam's `Vec4`).
pub(crate) struct Sse;

/// Box-test constants in SSE lanes.
#[derive(Clone, Copy)]
pub(crate) struct SseRay {
    org: [Vec4; 3],
    inv: [Vec4; 3],
    negative: [usize; 3],
}

impl BoxTest for Sse {
    type Ray = SseRay;

    #[inline(always)]
    unsafe fn ray(r: &TriRay) -> SseRay {
        SseRay {
            org: r.org.map(Vec4::splat),
            inv: r.inv.map(Vec4::splat),
            negative: [0, 1, 2].map(|axis| (r.negative >> axis) as usize & 1),
        }
    }

    #[inline(always)]
    unsafe fn hit<const ROBUST: bool>(
        node: &Node8,
        r: &SseRay,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 8], u32) {
        let half = |h: usize| -> [Vec4; 6] { std::array::from_fn(|i| node.planes[i][h]) };
        let (n0, m0) = hit4::<ROBUST>(&half(0), &r.org, &r.inv, &r.negative, t_min, t_max);
        let (n1, m1) = hit4::<ROBUST>(&half(1), &r.org, &r.inv, &r.negative, t_min, t_max);
        let mut near = [0.0; 8];
        near[..4].copy_from_slice(&n0.to_array());
        near[4..].copy_from_slice(&n1.to_array());
        (near, m0 | (m1 << 4))
    }

    #[inline(always)]
    unsafe fn hit4<const ROBUST: bool>(
        node: &Node4,
        r: &SseRay,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 8], u32) {
        let (n, m) = hit4::<ROBUST>(&node.planes, &r.org, &r.inv, &r.negative, t_min, t_max);
        let mut near = [0.0; 8];
        near[..4].copy_from_slice(&n.to_array());
        (near, m)
    }
}

/// The 8-wide test in AVX registers; only for CPUs with AVX2 (see [`avx2_available`]).
#[cfg(target_arch = "x86_64")]
pub(crate) struct Avx2;

/// Box-test constants in AVX lanes.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Avx2Ray {
    org: [std::arch::x86_64::__m256; 3],
    inv: [std::arch::x86_64::__m256; 3],
    negative: [usize; 3],
    /// Origin and reciprocal in four lanes, for [`Node4`]s.
    org4: [Vec4; 3],
    inv4: [Vec4; 3],
}

#[cfg(target_arch = "x86_64")]
impl BoxTest for Avx2 {
    type Ray = Avx2Ray;

    #[inline(always)]
    unsafe fn ray(r: &TriRay) -> Avx2Ray {
        use std::arch::x86_64::{_mm256_castps256_ps128, _mm256_set1_ps};
        // SAFETY: the caller guarantees AVX2 (so AVX) support.
        unsafe {
            let org = r.org.map(|x| _mm256_set1_ps(x));
            let inv = r.inv.map(|x| _mm256_set1_ps(x));
            Avx2Ray {
                org,
                inv,
                negative: [0, 1, 2].map(|axis| (r.negative >> axis) as usize & 1),
                org4: org.map(|x| Vec4::from(_mm256_castps256_ps128(x))),
                inv4: inv.map(|x| Vec4::from(_mm256_castps256_ps128(x))),
            }
        }
    }

    /// The lanes compute what [`Sse::hit`]'s do: `_mm256_max_ps`/`_mm256_min_ps` take their
    /// operands in the order of glam's `max`/`min` (`_mm_max_ps(self, rhs)`), and the compare is
    /// the same ordered `<=`.
    #[inline(always)]
    unsafe fn hit<const ROBUST: bool>(
        node: &Node8,
        r: &Avx2Ray,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 8], u32) {
        use std::arch::x86_64::*;
        // SAFETY: the caller guarantees AVX2 support. The loads read 32 bytes from a plane row
        // `[Vec4; 2]` (32 contiguous bytes, 32-byte aligned as the node is 64-byte aligned and
        // rows are 32 bytes), and the store writes the 32 bytes of `near`.
        unsafe {
            // Helpers as functions, not closures: a closure does not inherit the caller's AVX2
            // target feature, and where it was not inlined every intrinsic in it became a call.
            let p = &node.planes;
            let (nx, fx) = avx2_slab::<ROBUST>(p, r, 0, r.negative[0]);
            let (ny, fy) = avx2_slab::<ROBUST>(p, r, 1, r.negative[1]);
            let (nz, fz) = avx2_slab::<ROBUST>(p, r, 2, r.negative[2]);
            let near = _mm256_max_ps(
                _mm256_max_ps(nx, ny),
                _mm256_max_ps(nz, _mm256_set1_ps(t_min)),
            );
            let far = _mm256_min_ps(
                _mm256_min_ps(fx, fy),
                _mm256_min_ps(fz, _mm256_set1_ps(t_max)),
            );
            let hit =
                _mm256_cmp_ps::<_CMP_LE_OQ>(near, _mm256_mul_ps(far, _mm256_set1_ps(FAR_SCALE)));
            let mut out = [0.0f32; 8];
            _mm256_storeu_ps(out.as_mut_ptr(), near);
            (out, _mm256_movemask_ps(hit) as u32)
        }
    }

    #[inline(always)]
    unsafe fn hit4<const ROBUST: bool>(
        node: &Node4,
        r: &Avx2Ray,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 8], u32) {
        let (n, m) = hit4::<ROBUST>(&node.planes, &r.org4, &r.inv4, &r.negative, t_min, t_max);
        let mut near = [0.0; 8];
        near[..4].copy_from_slice(&n.to_array());
        (near, m)
    }
}

/// The entry and exit distances of the eight boxes' slabs of `axis` (`neg`: whether the ray
/// runs towards −axis), as [`Avx2::hit`] computes them.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn avx2_slab<const ROBUST: bool>(
    p: &[[Vec4; 2]; 6],
    r: &Avx2Ray,
    axis: usize,
    neg: usize,
) -> (std::arch::x86_64::__m256, std::arch::x86_64::__m256) {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees AVX2 support; a plane row `[Vec4; 2]` is 32 contiguous
    // bytes, 32-byte aligned (the node is 64-byte aligned, its rows 32 bytes).
    unsafe {
        let near_plane = _mm256_load_ps(p[2 * axis + (neg & 1)].as_ptr().cast::<f32>());
        let far_plane = _mm256_load_ps(p[2 * axis + (!neg & 1)].as_ptr().cast::<f32>());
        let near = _mm256_mul_ps(_mm256_sub_ps(near_plane, r.org[axis]), r.inv[axis]);
        let far = _mm256_mul_ps(_mm256_sub_ps(far_plane, r.org[axis]), r.inv[axis]);
        if ROBUST {
            let near_nan = _mm256_cmp_ps::<_CMP_UNORD_Q>(near, near);
            let far_nan = _mm256_cmp_ps::<_CMP_UNORD_Q>(far, far);
            (
                _mm256_blendv_ps(near, _mm256_set1_ps(f32::NEG_INFINITY), near_nan),
                _mm256_blendv_ps(far, _mm256_set1_ps(f32::INFINITY), far_nan),
            )
        } else {
            (near, far)
        }
    }
}

/// Whether this CPU can run the [`Avx2`] test, unless the environment variable
/// `LUMO_BVH_NO_AVX2` is set (to compare the two paths, e.g. on renders).
pub(crate) fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
            && std::env::var_os("LUMO_BVH_NO_AVX2").is_none()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
