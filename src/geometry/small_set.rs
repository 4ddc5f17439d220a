//! Scenes of a few dozen triangles, tested against all of a wave's rays at once.
//!
//! A BVH walk pays per ray for every node it opens, in branches that depend on the ray. When a
//! scene is a few dozen triangles (a Cornell box is 36), testing each triangle against a whole
//! wave of rays costs less: the wave's rays sit in SIMD lanes (16 per instruction with
//! AVX-512, 8 with AVX2, 4 with SSE2), each triangle is broadcast to every lane, and a lane
//! never waits on another lane's branch. Each distinct corner is sheared into every lane's
//! frame once per wave, and each triangle then reads its three. Culling by boxes would seldom
//! skip anything: a wave's rays go in all directions, so some lane enters nearly every box.
//!
//! Every lane computes the operations of the scalar watertight test
//! ([`triangle::intersect_a`](super::triangle::intersect_a), and the BVH's leaf test that
//! matches it bit for bit), including the per-ray axis permutation (each lane picks its
//! corners' coordinates by its own axes) and the double-precision fallback on edges. The set
//! is stored in (instance, primitive) order and a triangle replaces a lane's best hit only when
//! strictly nearer, so of equally near hits the lowest (instance, primitive) wins, as in the
//! BVH. So each lane's hit is the BVH's, bit for bit.

// The kernels run on x86-64 only; elsewhere the BVH answers every query.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use std::mem::MaybeUninit;

use glam::Vec3A;

#[cfg(doc)]
use crate::geometry::triangle::shear_axes;
use crate::geometry::triangle::{edge_functions_f64, TriHit};
use crate::geometry::SegmentLanes;
use crate::lanes::{F32s, Mask, U32s};

/// Scenes of at most this many triangles (and nothing else) are tested by [`SmallSet`] in
/// waves of four lanes or more. On variants of the Cornell box the kernels beat the BVH by a
/// quarter at 36 triangles and a fifth at 60, and lose at 132 (`docs/performance.md`,
/// 2026-12-03): 64 keeps a margin.
pub const SMALL_SET_MAX: usize = 64;

/// The most distinct corners a [`SmallSet`] holds (sets with more are left to the BVH).
pub const MAX_VERTICES: usize = 96;

/// The instruction sets the kernels run on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Isa {
    /// 16 lanes per instruction.
    Avx512,
    /// 8 lanes per instruction.
    Avx2,
    /// 4 lanes per instruction (every x86-64).
    Sse2,
}

/// A few triangles in world space, in (instance, primitive) order, with their ids.
#[derive(Debug, Clone)]
pub struct SmallSet {
    /// The triangles' distinct corners, (x, y, z, 0) each (at most [`MAX_VERTICES`]).
    vertices: Vec<[f32; 4]>,
    /// Each triangle's corners as byte offsets into the kernels' array of sheared vertices
    /// (`[V; 3]` per vertex), for vectors of 4, 8 and 16 lanes, with its slot: the kernels'
    /// loop over triangles then computes no addresses (scaling indices took 10 of its ~60
    /// instructions per triangle).
    corner_bytes: [Vec<Corners>; 3],
    /// Each triangle's (instance, primitive), increasing.
    ids: Vec<[u32; 2]>,
    /// The widest instruction set this CPU has.
    isa: Isa,
}

/// A triangle as the kernels' loop reads it: its corners as byte offsets into the array of
/// sheared vertices, and its slot in the set as a float (exact: slots are small integers),
/// which a lane that takes the triangle as its best hit copies straight from here.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
struct Corners {
    bytes: [u32; 3],
    slot: f32,
}

/// A wave's rays, structure-of-arrays: origins, directions, and the end of the segment looked
/// along (0 for idle lanes, which then hit nothing).
#[repr(C, align(64))]
struct WaveRays<'a, const W: usize> {
    d: [[f32; W]; 3],
    t_max: [f32; W],
    /// The segments' origins, as they are (not copied).
    o: [&'a [f32; W]; 3],
}

impl<'a, const W: usize> WaveRays<'a, W> {
    /// The segments of `segments`' live lanes.
    #[inline(always)]
    fn of_segments(segments: &'a SegmentLanes<W>) -> WaveRays<'a, W> {
        let live = segments.live;
        let (o, d) = (&segments.o, segments.d);
        // Idle lanes look along +z over nothing.
        let (zero, one) = (F32s::splat(0.0), F32s::splat(1.0));
        WaveRays {
            o: [&o.x.0, &o.y.0, &o.z.0],
            d: [
                F32s::select(live, d.x, zero).0,
                F32s::select(live, d.y, zero).0,
                F32s::select(live, d.z, one).0,
            ],
            t_max: F32s::select(live, segments.t_max, zero).0,
        }
    }
}

/// A wave's closest hits on a [`SmallSet`], lane by lane.
#[repr(C, align(64))]
pub struct SlotHits<const W: usize> {
    /// The lanes with a hit.
    pub hit: Mask<W>,
    /// The slot of the triangle hit (0 in lanes without a hit).
    pub slot: U32s<W>,
    /// The hit's distance.
    pub t: F32s<W>,
    /// Its barycentric coordinate of corner 1.
    pub b1: F32s<W>,
    /// Its barycentric coordinate of corner 2.
    pub b2: F32s<W>,
}

impl<const W: usize> SlotHits<W> {
    /// Lane `i`'s hit (one of [`hit`](Self::hit)'s lanes) as the BVH reports it.
    #[inline]
    pub fn tri_hit(&self, i: usize) -> TriHit {
        TriHit {
            t: self.t[i],
            b1: self.b1[i],
            b2: self.b2[i],
        }
    }
}

/// The best hits of a wave's lanes: distance, barycentrics of corners 1 and 2, and the slot
/// of the triangle in the set (−1 for none).
#[repr(C, align(64))]
struct WaveHits<const W: usize> {
    t: [f32; W],
    b1: [f32; W],
    b2: [f32; W],
    slot: [f32; W],
}

impl SmallSet {
    /// The set of triangles `corners(i)` named `ids(i)` for i < `count` (at most
    /// [`SMALL_SET_MAX`]), with ids increasing; `None` where no vector kernel runs (outside
    /// x86-64) or the triangles have more than [`MAX_VERTICES`] distinct corners, so the BVH
    /// answers.
    pub fn new(
        count: usize,
        corners: impl Fn(usize) -> [Vec3A; 3],
        ids: impl Fn(usize) -> [u32; 2],
    ) -> Option<SmallSet> {
        let isa = detect()?;
        debug_assert!(count <= SMALL_SET_MAX);
        let ids: Vec<[u32; 2]> = (0..count).map(ids).collect();
        debug_assert!(ids.windows(2).all(|p| p[0] < p[1]));
        // Corners with the same bits are one vertex: the kernel shears each vertex once per
        // wave, and a corner's sheared coordinates depend on its bits alone.
        let mut vertices: Vec<[f32; 4]> = Vec::new();
        let mut index = std::collections::HashMap::new();
        let triangles: Vec<[usize; 3]> = (0..count)
            .map(|i| {
                corners(i).map(|c| {
                    let v = [c.x, c.y, c.z, 0.0];
                    *index.entry(v.map(f32::to_bits)).or_insert_with(|| {
                        vertices.push(v);
                        vertices.len() - 1
                    })
                })
            })
            .collect();
        if vertices.len() > MAX_VERTICES {
            return None;
        }
        let bytes = |lanes: usize| {
            let vertex_bytes = 3 * lanes * std::mem::size_of::<f32>();
            triangles
                .iter()
                .enumerate()
                .map(|(slot, t)| Corners {
                    bytes: t.map(|v| (v * vertex_bytes) as u32),
                    slot: slot as f32,
                })
                .collect()
        };
        Some(SmallSet {
            vertices,
            corner_bytes: [bytes(4), bytes(8), bytes(16)],
            ids,
            isa,
        })
    }

    /// Each triangle's corners as byte offsets into an array of `[V; 3]`, one per vertex.
    #[inline(always)]
    fn corner_bytes<V: Vector>(&self) -> &[Corners] {
        &self.corner_bytes[(V::LANES / 4).trailing_zeros() as usize]
    }

    /// The id (instance, primitive) of the triangle in `slot`.
    pub fn id(&self, slot: u32) -> [u32; 2] {
        self.ids[slot as usize]
    }

    /// The closest hit of each lane's ray over (0, ∞) (`None` lanes are idle), lane by lane:
    /// as [`closest_lanes`](Self::closest_lanes) finds it, with the triangle's slot (its id
    /// is [`id`](Self::id)) instead of its id.
    #[inline(always)]
    pub fn closest_slots<const W: usize>(&self, rays: &SegmentLanes<W>) -> SlotHits<W> {
        let wave = WaveRays::<W>::of_segments(rays);
        let mut hits = WaveHits {
            t: wave.t_max,
            b1: [0.0; W],
            b2: [0.0; W],
            slot: [-1.0; W],
        };
        self.run::<W, true>(&wave, &mut hits, &mut [false; W]);
        let slot = F32s(hits.slot);
        let hit = slot.ge(F32s::splat(0.0));
        SlotHits {
            hit,
            // Lanes without a hit read slot 0, whose values mean nothing there. (Converted in
            // lanes: lane by lane the saturating casts were 7 instructions each.)
            slot: F32s::select(hit, slot, F32s::splat(0.0))
                .to_i32()
                .cast_u32(),
            t: F32s(hits.t),
            b1: F32s(hits.b1),
            b2: F32s(hits.b2),
        }
    }

    /// The closest hit of each lane's ray over (0, ∞) (`None` lanes are idle): the hit
    /// triangle's id and the hit, as [`TriangleBvh::intersect`](super::TriangleBvh::intersect)
    /// finds it.
    pub fn closest_lanes<const W: usize>(
        &self,
        rays: &SegmentLanes<W>,
    ) -> [Option<([u32; 2], TriHit)>; W] {
        let hits = self.closest_slots(rays);
        std::array::from_fn(|i| {
            hits.hit
                .lane(i)
                .then(|| (self.id(hits.slot[i]), hits.tri_hit(i)))
        })
    }

    /// Whether each live lane's segment (over (0, `t_max`)) meets a triangle (idle lanes report
    /// `false`), as [`TriangleBvh::occluded`](super::TriangleBvh::occluded) finds it.
    #[inline(always)]
    pub fn occluded_lanes<const W: usize>(&self, segments: &SegmentLanes<W>) -> [bool; W] {
        let wave = WaveRays::<W>::of_segments(segments);
        let mut hits = WaveHits {
            t: [0.0; W],
            b1: [0.0; W],
            b2: [0.0; W],
            slot: [0.0; W],
        };
        let mut blocked = [false; W];
        self.run::<W, false>(&wave, &mut hits, &mut blocked);
        blocked
    }

    /// Runs the closest-hit (`CLOSEST`) or the occlusion kernel over the wave in chunks of the
    /// widest vectors that divide W.
    #[inline(always)]
    fn run<const W: usize, const CLOSEST: bool>(
        &self,
        wave: &WaveRays<W>,
        hits: &mut WaveHits<W>,
        blocked: &mut [bool; W],
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            use x86::{Avx2, Avx512, Sse2};
            #[target_feature(enable = "avx512f,avx512dq")]
            #[inline]
            unsafe fn avx512<const W: usize, const CLOSEST: bool>(
                set: &SmallSet,
                wave: &WaveRays<W>,
                hits: &mut WaveHits<W>,
                blocked: &mut [bool; W],
            ) {
                for k in (0..W).step_by(16) {
                    // SAFETY: the CPU has AVX-512 F and DQ; lanes k..k + 16 lie within W.
                    unsafe { chunk::<Avx512, W, CLOSEST>(set, wave, hits, blocked, k) };
                }
            }
            #[target_feature(enable = "avx2")]
            #[inline]
            unsafe fn avx2<const W: usize, const CLOSEST: bool>(
                set: &SmallSet,
                wave: &WaveRays<W>,
                hits: &mut WaveHits<W>,
                blocked: &mut [bool; W],
            ) {
                for k in (0..W).step_by(8) {
                    // SAFETY: the CPU has AVX2; lanes k..k + 8 lie within W.
                    unsafe { chunk::<Avx2, W, CLOSEST>(set, wave, hits, blocked, k) };
                }
            }
            if W.is_multiple_of(16) && self.isa == Isa::Avx512 {
                // SAFETY: `isa` is AVX-512 only when the CPU has AVX-512 F, BW, DQ and VL
                // (`native_width`).
                return unsafe { avx512::<W, CLOSEST>(self, wave, hits, blocked) };
            }
            if W.is_multiple_of(8) && self.isa != Isa::Sse2 {
                // SAFETY: `isa` is AVX2 or wider only when the CPU has AVX2.
                return unsafe { avx2::<W, CLOSEST>(self, wave, hits, blocked) };
            }
            if W.is_multiple_of(4) {
                for k in (0..W).step_by(4) {
                    // SAFETY: SSE2 is part of x86-64; lanes k..k + 4 lie within W.
                    unsafe { chunk::<Sse2, W, CLOSEST>(self, wave, hits, blocked, k) };
                }
                return;
            }
        }
        let _ = (wave, hits, blocked);
        unreachable!("the small-set kernels run on x86-64 waves of a multiple of 4 lanes")
    }
}

/// The widest instruction set the kernels may use here (the one behind
/// [`native_width`](crate::lanes::native_width)), `None` where they do not run.
fn detect() -> Option<Isa> {
    if !cfg!(target_arch = "x86_64") {
        return None;
    }
    Some(match crate::lanes::native_width() {
        16 => Isa::Avx512,
        8 => Isa::Avx2,
        _ => Isa::Sse2,
    })
}

/// V::LANES lanes of f32 and their operations, each the IEEE-754 operation of the scalar code.
trait Vector: Copy {
    /// Lanes per vector.
    const LANES: usize;
    /// A truth value per lane.
    type Mask: Copy;
    /// An axis (0, 1 or 2) per lane, prepared for [`Vector::pick`].
    type Axis: Copy;

    unsafe fn splat(x: f32) -> Self;
    unsafe fn load(p: *const f32) -> Self;
    unsafe fn store(self, p: *mut f32);
    /// The axes 0.0, 1.0 or 2.0 of the lanes, prepared for [`Vector::pick`].
    unsafe fn axis(self) -> Self::Axis;
    /// |x| (the sign bit cleared).
    unsafe fn abs(self) -> Self;
    /// Ordered `>=`.
    unsafe fn ge(self, o: Self) -> Self::Mask;
    /// Lane i: `corner[axis_i]`.
    unsafe fn pick(corner: &[f32; 4], axis: Self::Axis) -> Self;
    unsafe fn add(self, o: Self) -> Self;
    unsafe fn sub(self, o: Self) -> Self;
    unsafe fn mul(self, o: Self) -> Self;
    unsafe fn div(self, o: Self) -> Self;
    /// Ordered `==` (false with a NaN).
    unsafe fn eq(self, o: Self) -> Self::Mask;
    /// Ordered `<`.
    unsafe fn lt(self, o: Self) -> Self::Mask;
    /// Ordered `>`.
    unsafe fn gt(self, o: Self) -> Self::Mask;
    /// Ordered `<=`.
    unsafe fn le(self, o: Self) -> Self::Mask;
    /// The lesser, as `minps` picks it (the second operand where either is a NaN).
    unsafe fn min(self, o: Self) -> Self;
    /// The greater, as `maxps` picks it (the second operand where either is a NaN).
    unsafe fn max(self, o: Self) -> Self;
    /// `m` and ordered `a > b`.
    #[inline(always)]
    unsafe fn and_gt(m: Self::Mask, a: Self, b: Self) -> Self::Mask {
        // SAFETY: the caller's.
        unsafe { Self::and(m, a.gt(b)) }
    }
    /// `m` and ordered `a < b`.
    #[inline(always)]
    unsafe fn and_lt(m: Self::Mask, a: Self, b: Self) -> Self::Mask {
        // SAFETY: the caller's.
        unsafe { Self::and(m, a.lt(b)) }
    }
    /// Where `a`, `b` or `c` is ±0.
    #[inline(always)]
    unsafe fn any_zero(a: Self, b: Self, c: Self) -> Self::Mask {
        // SAFETY: the caller's.
        unsafe {
            let zero = Self::splat(0.0);
            Self::or(Self::or(a.eq(zero), b.eq(zero)), c.eq(zero))
        }
    }
    /// The lanes of [`any_zero`](Self::any_zero) and perhaps others (a cheaper test where
    /// the instruction set has one).
    #[inline(always)]
    unsafe fn maybe_zero(a: Self, b: Self, c: Self) -> Self::Mask {
        // SAFETY: the caller's.
        unsafe { Self::any_zero(a, b, c) }
    }
    /// Where `a`, `b` and `c` have the same sign bit.
    unsafe fn same_sign(a: Self, b: Self, c: Self) -> Self::Mask;
    unsafe fn or(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    unsafe fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `a & !b`.
    unsafe fn and_not(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// Bit i set where lane i holds.
    unsafe fn bits(m: Self::Mask) -> u32;
    /// Whether no lane of `m` is one of `live`.
    #[inline(always)]
    unsafe fn none_of(m: Self::Mask, live: Self::Mask) -> bool {
        // SAFETY: the caller's.
        unsafe { Self::bits(m) & Self::bits(live) == 0 }
    }
    /// `a` where `m` holds, else `b`.
    unsafe fn select(m: Self::Mask, a: Self, b: Self) -> Self;
}

/// The kernel on lanes `k..k + V::LANES` of a wave: the closest hit of each (`CLOSEST`, into
/// `hits`, whose `t` starts as the lane's bound) or whether anything blocks it (into `blocked`).
///
/// # Safety
/// The CPU runs V's instructions, and `k + V::LANES <= W`.
#[inline(always)]
unsafe fn chunk<V: Vector, const W: usize, const CLOSEST: bool>(
    set: &SmallSet,
    wave: &WaveRays<W>,
    hits: &mut WaveHits<W>,
    blocked: &mut [bool; W],
    k: usize,
) {
    debug_assert!(k + V::LANES <= W);
    // SAFETY: the caller's; every pointer below is to lanes k..k + V::LANES of a [_; W].
    // (No closures here: they would not inherit the caller's target features, and the vector
    // operations inside them would become calls.)
    unsafe {
        let ray = ShearedRay::<V>::new(wave, k);
        let t_max = V::load(wave.t_max.as_ptr().add(k));
        let zero = V::splat(0.0);
        let live = V::gt(t_max, zero);
        let all_live = V::bits(live);
        if all_live == 0 {
            return;
        }
        // Every vertex in every lane's sheared frame, once.
        let mut frame = [MaybeUninit::<[V; 3]>::uninit(); MAX_VERTICES];
        debug_assert!(set.vertices.len() <= MAX_VERTICES);
        for (out, vertex) in frame.iter_mut().zip(&set.vertices) {
            out.write(sheared(&ray, vertex));
        }
        if CLOSEST {
            let mut best = Best::<V>::load(hits, k);
            for corners in set.corner_bytes::<V>() {
                best.take(
                    &candidate(&frame, corners.bytes, live),
                    V::splat(corners.slot),
                );
            }
            best.store(hits, k);
        } else {
            let mut blocked_bits = 0u32;
            for corners in set.corner_bytes::<V>() {
                let c = candidate(&frame, corners.bytes, live);
                blocked_bits |= V::bits(V::and_lt(c.ahead, c.t, t_max));
                if blocked_bits == all_live {
                    break;
                }
            }
            for (i, b) in blocked[k..k + V::LANES].iter_mut().enumerate() {
                *b = blocked_bits & (1 << i) != 0;
            }
        }
    }
}

/// A triangle's test in every lane, but for the bound: the lanes where the ray meets it ahead
/// (t > 0), t, the edge functions v and w, and 1 / det.
struct Candidate<V: Vector> {
    ahead: V::Mask,
    t: V,
    v: V,
    w: V,
    inv_det: V,
}

/// The vertex `bytes` bytes into `frame`.
///
/// # Safety
/// `frame` holds a vertex there.
#[inline(always)]
unsafe fn sheared_vertex<V: Vector>(
    frame: &[MaybeUninit<[V; 3]>; MAX_VERTICES],
    bytes: u32,
) -> [V; 3] {
    // SAFETY: the caller's.
    unsafe {
        frame
            .as_ptr()
            .cast::<u8>()
            .add(bytes as usize)
            .cast::<[V; 3]>()
            .read()
    }
}

/// The test of the triangle `corners` (byte offsets into `frame`, every lane's sheared
/// vertices) in every lane, the edge functions recomputed in f64 where one is ±0 in a lane of
/// `live`.
///
/// # Safety
/// The CPU runs V's instructions, and `frame` holds the vertices `corners` names.
#[inline(always)]
unsafe fn candidate<V: Vector>(
    frame: &[MaybeUninit<[V; 3]>; MAX_VERTICES],
    corners: [u32; 3],
    live: V::Mask,
) -> Candidate<V> {
    // SAFETY: the caller's.
    unsafe {
        let [ax, ay, az] = sheared_vertex(frame, corners[0]);
        let [bx, by, bz] = sheared_vertex(frame, corners[1]);
        let [cx, cy, cz] = sheared_vertex(frame, corners[2]);
        let mut u = cx.mul(by).sub(cy.mul(bx));
        let mut v = ax.mul(cy).sub(ay.mul(cx));
        let mut w = bx.mul(ay).sub(by.mul(ax));
        // The scalar test's "inside": det ≠ 0 and not (some edge function < 0 and some > 0).
        // Where none is a NaN, the second part is min ≥ 0 or max ≤ 0; where one is a NaN, so
        // is t, and no lane hits. Where they have one sign and det = 0, all three are ±0,
        // t = ±0 · (1 / ±0) is a NaN, and no lane hits: det ≠ 0 needs no test. Where no live
        // lane has an edge function of ±0 (nearly always), one sign is one sign bit: two
        // instructions with AVX-512 instead of seven, in a loop bound by its vector
        // instructions. (Lanes that are not live have a bound of 0 and take no hit.)
        let zero = V::splat(0.0);
        let one_sign = if V::none_of(V::maybe_zero(u, v, w), live) {
            V::same_sign(u, v, w)
        } else {
            let on_edge = V::bits(V::any_zero(u, v, w)) & V::bits(live);
            let mut p = [[0.0f32; MAX_LANES]; 6];
            for (array, value) in p.iter_mut().zip([ax, ay, bx, by, cx, cy]) {
                value.store(array.as_mut_ptr());
            }
            let mut e = [[0.0f32; MAX_LANES]; 3];
            for (array, value) in e.iter_mut().zip([u, v, w]) {
                value.store(array.as_mut_ptr());
            }
            if on_edge != 0 {
                edges_in_f64(on_edge, &p, &mut e);
            }
            [u, v, w] = [
                V::load(e[0].as_ptr()),
                V::load(e[1].as_ptr()),
                V::load(e[2].as_ptr()),
            ];
            V::or(u.min(v).min(w).ge(zero), u.max(v).max(w).le(zero))
        };
        let det = u.add(v).add(w);
        let t_scaled = u.mul(az).add(v.mul(bz)).add(w.mul(cz));
        let inv_det = V::splat(1.0).div(det);
        let t = t_scaled.mul(inv_det);
        Candidate {
            ahead: V::and_gt(one_sign, t, zero),
            t,
            v,
            w,
            inv_det,
        }
    }
}

/// Each lane's closest hit so far: its distance, edge functions v and w, 1 / det (its
/// barycentrics are computed once, at the end, with the scalar test's operations: v · (1 / det),
/// w · (1 / det)), and slot (a float, exact: slots are small integers; −1 for none).
#[derive(Clone, Copy)]
struct Best<V: Vector> {
    t: V,
    v: V,
    w: V,
    inv_det: V,
    slot: V,
}

impl<V: Vector> Best<V> {
    /// Lanes `k..k + V::LANES` of `hits`, where a lane's v and w are its barycentrics and
    /// 1 / det is 1.
    ///
    /// # Safety
    /// The CPU runs V's instructions, and `k + V::LANES <= W`.
    #[inline(always)]
    unsafe fn load<const W: usize>(hits: &WaveHits<W>, k: usize) -> Self {
        // SAFETY: the caller's.
        unsafe {
            Best {
                t: V::load(hits.t.as_ptr().add(k)),
                v: V::load(hits.b1.as_ptr().add(k)),
                w: V::load(hits.b2.as_ptr().add(k)),
                inv_det: V::splat(1.0),
                slot: V::load(hits.slot.as_ptr().add(k)),
            }
        }
    }

    /// Takes the triangle in `slot` where it is hit ahead and strictly nearer (so of equally
    /// near hits in slot order, the first stays).
    ///
    /// # Safety
    /// The CPU runs V's instructions.
    #[inline(always)]
    unsafe fn take(&mut self, c: &Candidate<V>, slot: V) {
        // SAFETY: the caller's.
        unsafe {
            let hit = V::and_lt(c.ahead, c.t, self.t);
            self.t = V::select(hit, c.t, self.t);
            self.v = V::select(hit, c.v, self.v);
            self.w = V::select(hit, c.w, self.w);
            self.inv_det = V::select(hit, c.inv_det, self.inv_det);
            self.slot = V::select(hit, slot, self.slot);
        }
    }

    /// Stores lanes `k..k + V::LANES` into `hits`: lanes without a hit keep what they held
    /// (their v and w, times 1).
    ///
    /// # Safety
    /// The CPU runs V's instructions, and `k + V::LANES <= W`.
    #[inline(always)]
    unsafe fn store<const W: usize>(self, hits: &mut WaveHits<W>, k: usize) {
        // SAFETY: the caller's.
        unsafe {
            self.t.store(hits.t.as_mut_ptr().add(k));
            self.v.mul(self.inv_det).store(hits.b1.as_mut_ptr().add(k));
            self.w.mul(self.inv_det).store(hits.b2.as_mut_ptr().add(k));
            self.slot.store(hits.slot.as_mut_ptr().add(k));
        }
    }
}

/// The lanes' rays as [`chunk`] reads them: origins and shear constants on the axes (kx, ky,
/// kz), and the axes.
struct ShearedRay<V: Vector> {
    org: [V; 3],
    shear: [V; 3],
    axes: [V::Axis; 3],
}

impl<V: Vector> ShearedRay<V> {
    /// Lanes `k..k + V::LANES` of `wave`, with the constants of
    /// [`TriRay::new`](super::TriRay::new) (and [`shear_axes`]): kz the dominant axis of the
    /// direction, (kx, ky) the next two cyclically, swapped where d\[kz\] < 0; the origin on
    /// those axes; d\[kx\] / d\[kz\], d\[ky\] / d\[kz\] and 1 / d\[kz\], each the correctly rounded
    /// quotient.
    ///
    /// # Safety
    /// The CPU runs V's instructions, and `k + V::LANES <= W`.
    #[inline(always)]
    unsafe fn new<const W: usize>(wave: &WaveRays<W>, k: usize) -> ShearedRay<V> {
        // SAFETY: the caller's.
        unsafe {
            let [ox, oy, oz] = [
                V::load(wave.o[0].as_ptr().add(k)),
                V::load(wave.o[1].as_ptr().add(k)),
                V::load(wave.o[2].as_ptr().add(k)),
            ];
            let [dx, dy, dz] = [
                V::load(wave.d[0].as_ptr().add(k)),
                V::load(wave.d[1].as_ptr().add(k)),
                V::load(wave.d[2].as_ptr().add(k)),
            ];
            let (ax, ay, az) = (dx.abs(), dy.abs(), dz.abs());
            // As `shear_axes`: x where |dx| ≥ |dy| and |dx| ≥ |dz|, else y where |dy| ≥ |dz|,
            // else z (a NaN fails every comparison, as there).
            let x_major = V::and(ax.ge(ay), ax.ge(az));
            let y_major = V::and_not(ay.ge(az), x_major);
            let [dkx, dky, dkz] = rotate(x_major, y_major, [dx, dy, dz]);
            let [okx, oky, okz] = rotate(x_major, y_major, [ox, oy, oz]);
            let axes = [V::splat(0.0), V::splat(1.0), V::splat(2.0)];
            let [kx, ky, kz] = rotate(x_major, y_major, axes);
            let flip = dkz.lt(V::splat(0.0));
            let (dkx, dky) = swap_where(flip, dkx, dky);
            let (okx, oky) = swap_where(flip, okx, oky);
            let (kx, ky) = swap_where(flip, kx, ky);
            ShearedRay {
                org: [okx, oky, okz],
                shear: [dkx.div(dkz), dky.div(dkz), V::splat(1.0).div(dkz)],
                axes: [V::axis(kx), V::axis(ky), V::axis(kz)],
            }
        }
    }
}

/// Per lane, the values on axes (kx, ky, kz) of `[x, y, z]`: kz is x where `x_major` holds, else
/// y where `y_major` holds, else z, and (kx, ky) the next two axes cyclically.
///
/// # Safety
/// The CPU runs V's instructions.
#[inline(always)]
unsafe fn rotate<V: Vector>(x_major: V::Mask, y_major: V::Mask, [x, y, z]: [V; 3]) -> [V; 3] {
    // SAFETY: the caller's.
    unsafe {
        [
            V::select(x_major, y, V::select(y_major, z, x)),
            V::select(x_major, z, V::select(y_major, x, y)),
            V::select(x_major, x, V::select(y_major, y, z)),
        ]
    }
}

/// (b, a) in the lanes where `flip` holds, (a, b) in the others.
///
/// # Safety
/// The CPU runs V's instructions.
#[inline(always)]
unsafe fn swap_where<V: Vector>(flip: V::Mask, a: V, b: V) -> (V, V) {
    // SAFETY: the caller's.
    unsafe { (V::select(flip, b, a), V::select(flip, a, b)) }
}

/// A corner in each lane's sheared frame: relative to the origin, sheared so the ray runs
/// along +z, z scaled (the operations of `Packet::hits` in the triangle BVH).
///
/// # Safety
/// The CPU runs V's instructions.
#[inline(always)]
unsafe fn sheared<V: Vector>(ray: &ShearedRay<V>, corner: &[f32; 4]) -> [V; 3] {
    let [ox, oy, oz] = ray.org;
    let [sx, sy, sz] = ray.shear;
    let [kx, ky, kz] = ray.axes;
    // SAFETY: the caller's.
    unsafe {
        let z = V::pick(corner, kz).sub(oz);
        let x = V::pick(corner, kx).sub(ox).sub(sx.mul(z));
        let y = V::pick(corner, ky).sub(oy).sub(sy.mul(z));
        [x, y, sz.mul(z)]
    }
}

/// The most lanes of a [`Vector`].
const MAX_LANES: usize = 16;

/// The edge functions (u, v, w) in `uvw` recomputed in f64 in the lanes of `lanes` (a hit
/// exactly on an edge in f32), from the sheared corners `[ax, ay, bx, by, cx, cy]`, as the
/// scalar test does.
#[cold]
#[inline(never)]
fn edges_in_f64(lanes: u32, sheared: &[[f32; MAX_LANES]; 6], uvw: &mut [[f32; MAX_LANES]; 3]) {
    for i in (0..MAX_LANES).filter(|i| lanes & (1 << i) != 0) {
        let [ax, ay, bx, by, cx, cy] = sheared.map(|a| a[i]);
        [uvw[0][i], uvw[1][i], uvw[2][i]] = edge_functions_f64([ax, ay], [bx, by], [cx, cy]);
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! [`Vector`] in SSE2, AVX2 and AVX-512 registers.

    use super::Vector;
    use std::arch::x86_64::*;

    /// Four lanes in SSE2.
    #[derive(Clone, Copy)]
    pub(super) struct Sse2(__m128);

    /// Eight lanes in AVX.
    #[derive(Clone, Copy)]
    pub(super) struct Avx2(__m256);

    /// Sixteen lanes in AVX-512.
    #[derive(Clone, Copy)]
    pub(super) struct Avx512(__m512);

    impl Vector for Sse2 {
        const LANES: usize = 4;
        type Mask = __m128;
        /// Where the axis is 0, and where it is 1.
        type Axis = (__m128, __m128);

        #[inline(always)]
        unsafe fn splat(x: f32) -> Self {
            Sse2(_mm_set1_ps(x))
        }
        #[inline(always)]
        unsafe fn load(p: *const f32) -> Self {
            // SAFETY: the caller's pointer to four lanes.
            Sse2(unsafe { _mm_loadu_ps(p) })
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f32) {
            // SAFETY: the caller's pointer to four lanes.
            unsafe { _mm_storeu_ps(p, self.0) }
        }
        #[inline(always)]
        unsafe fn axis(self) -> Self::Axis {
            (
                _mm_cmpeq_ps(self.0, _mm_set1_ps(0.0)),
                _mm_cmpeq_ps(self.0, _mm_set1_ps(1.0)),
            )
        }
        #[inline(always)]
        unsafe fn abs(self) -> Self {
            Sse2(_mm_andnot_ps(_mm_set1_ps(-0.0), self.0))
        }
        #[inline(always)]
        unsafe fn ge(self, o: Self) -> __m128 {
            _mm_cmpge_ps(self.0, o.0)
        }
        #[inline(always)]
        unsafe fn pick(corner: &[f32; 4], (is_x, is_y): Self::Axis) -> Self {
            let (x, y, z) = (
                _mm_set1_ps(corner[0]),
                _mm_set1_ps(corner[1]),
                _mm_set1_ps(corner[2]),
            );
            // SAFETY: SSE2 is part of x86-64.
            unsafe { Self::select(is_x, Sse2(x), Self::select(is_y, Sse2(y), Sse2(z))) }
        }
        #[inline(always)]
        unsafe fn add(self, o: Self) -> Self {
            Sse2(_mm_add_ps(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn sub(self, o: Self) -> Self {
            Sse2(_mm_sub_ps(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn mul(self, o: Self) -> Self {
            Sse2(_mm_mul_ps(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn div(self, o: Self) -> Self {
            Sse2(_mm_div_ps(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn eq(self, o: Self) -> __m128 {
            _mm_cmpeq_ps(self.0, o.0)
        }
        #[inline(always)]
        unsafe fn lt(self, o: Self) -> __m128 {
            _mm_cmplt_ps(self.0, o.0)
        }
        #[inline(always)]
        unsafe fn gt(self, o: Self) -> __m128 {
            _mm_cmpgt_ps(self.0, o.0)
        }
        #[inline(always)]
        unsafe fn le(self, o: Self) -> __m128 {
            _mm_cmple_ps(self.0, o.0)
        }
        #[inline(always)]
        unsafe fn min(self, o: Self) -> Self {
            Sse2(_mm_min_ps(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn max(self, o: Self) -> Self {
            Sse2(_mm_max_ps(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn same_sign(a: Self, b: Self, c: Self) -> __m128 {
            // SAFETY: SSE2 is part of x86-64. The sign bit of (a ^ b) | (a ^ c) is clear
            // where all three agree: there the integer is > −1.
            unsafe {
                let differ = _mm_or_ps(_mm_xor_ps(a.0, b.0), _mm_xor_ps(a.0, c.0));
                _mm_castsi128_ps(_mm_cmpgt_epi32(
                    _mm_castps_si128(differ),
                    _mm_set1_epi32(-1),
                ))
            }
        }
        #[inline(always)]
        unsafe fn or(a: __m128, b: __m128) -> __m128 {
            _mm_or_ps(a, b)
        }
        #[inline(always)]
        unsafe fn and(a: __m128, b: __m128) -> __m128 {
            _mm_and_ps(a, b)
        }
        #[inline(always)]
        unsafe fn and_not(a: __m128, b: __m128) -> __m128 {
            _mm_andnot_ps(b, a)
        }
        #[inline(always)]
        unsafe fn bits(m: __m128) -> u32 {
            _mm_movemask_ps(m) as u32
        }
        #[inline(always)]
        unsafe fn select(m: __m128, a: Self, b: Self) -> Self {
            Sse2(_mm_or_ps(_mm_and_ps(m, a.0), _mm_andnot_ps(m, b.0)))
        }
    }

    impl Vector for Avx2 {
        const LANES: usize = 8;
        type Mask = __m256;
        type Axis = __m256i;

        #[inline(always)]
        unsafe fn splat(x: f32) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        unsafe fn load(p: *const f32) -> Self {
            // SAFETY: the caller's CPU and pointer to eight lanes.
            Avx2(unsafe { _mm256_loadu_ps(p) })
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f32) {
            // SAFETY: the caller's CPU and pointer to eight lanes.
            unsafe { _mm256_storeu_ps(p, self.0) }
        }
        #[inline(always)]
        unsafe fn axis(self) -> __m256i {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_cvttps_epi32(self.0) }
        }
        #[inline(always)]
        unsafe fn abs(self) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
        }
        #[inline(always)]
        unsafe fn ge(self, o: Self) -> __m256 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn pick(corner: &[f32; 4], axis: __m256i) -> Self {
            // SAFETY: the caller's CPU; `corner` is 16 bytes. `vpermilps` picks, in each lane,
            // the element of its 128-bit half that the low two bits of `axis` name.
            unsafe {
                let c = _mm256_broadcast_ps(&_mm_loadu_ps(corner.as_ptr()));
                Avx2(_mm256_permutevar_ps(c, axis))
            }
        }
        #[inline(always)]
        unsafe fn add(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn sub(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn mul(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn div(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn eq(self, o: Self) -> __m256 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn lt(self, o: Self) -> __m256 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn gt(self, o: Self) -> __m256 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn le(self, o: Self) -> __m256 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn min(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn max(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn any_zero(a: Self, b: Self, c: Self) -> __m256 {
            // SAFETY: the caller's CPU has AVX2. x is ±0 exactly where its bits shifted left by
            // one are 0, and the least of three such (unsigned) is 0 where any is.
            unsafe {
                let (a, b, c) = (
                    _mm256_slli_epi32::<1>(_mm256_castps_si256(a.0)),
                    _mm256_slli_epi32::<1>(_mm256_castps_si256(b.0)),
                    _mm256_slli_epi32::<1>(_mm256_castps_si256(c.0)),
                );
                let least = _mm256_min_epu32(_mm256_min_epu32(a, b), c);
                _mm256_castsi256_ps(_mm256_cmpeq_epi32(least, _mm256_setzero_si256()))
            }
        }
        #[inline(always)]
        unsafe fn same_sign(a: Self, b: Self, c: Self) -> __m256 {
            // SAFETY: the caller's CPU has AVX2. As in SSE2.
            unsafe {
                let differ = _mm256_or_ps(_mm256_xor_ps(a.0, b.0), _mm256_xor_ps(a.0, c.0));
                let differ = _mm256_castps_si256(differ);
                _mm256_castsi256_ps(_mm256_cmpgt_epi32(differ, _mm256_set1_epi32(-1)))
            }
        }
        #[inline(always)]
        unsafe fn or(a: __m256, b: __m256) -> __m256 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_or_ps(a, b) }
        }
        #[inline(always)]
        unsafe fn and(a: __m256, b: __m256) -> __m256 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_and_ps(a, b) }
        }
        #[inline(always)]
        unsafe fn and_not(a: __m256, b: __m256) -> __m256 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_andnot_ps(b, a) }
        }
        #[inline(always)]
        unsafe fn bits(m: __m256) -> u32 {
            // SAFETY: the caller's CPU has AVX2.
            unsafe { _mm256_movemask_ps(m) as u32 }
        }
        #[inline(always)]
        unsafe fn select(m: __m256, a: Self, b: Self) -> Self {
            // SAFETY: the caller's CPU has AVX2.
            Avx2(unsafe { _mm256_blendv_ps(b.0, a.0, m) })
        }
    }

    impl Vector for Avx512 {
        const LANES: usize = 16;
        type Mask = __mmask16;
        type Axis = __m512i;

        #[inline(always)]
        unsafe fn splat(x: f32) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_set1_ps(x) })
        }
        #[inline(always)]
        unsafe fn load(p: *const f32) -> Self {
            // SAFETY: the caller's CPU and pointer to sixteen lanes.
            Avx512(unsafe { _mm512_loadu_ps(p) })
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f32) {
            // SAFETY: the caller's CPU and pointer to sixteen lanes.
            unsafe { _mm512_storeu_ps(p, self.0) }
        }
        #[inline(always)]
        unsafe fn axis(self) -> __m512i {
            // SAFETY: the caller's CPU has AVX-512F.
            unsafe { _mm512_cvttps_epi32(self.0) }
        }
        #[inline(always)]
        unsafe fn abs(self) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_abs_ps(self.0) })
        }
        #[inline(always)]
        unsafe fn ge(self, o: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F.
            unsafe { _mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn pick(corner: &[f32; 4], axis: __m512i) -> Self {
            // SAFETY: the caller's CPU; `corner` is 16 bytes. As in AVX2, per 128-bit quarter.
            unsafe {
                let c = _mm512_broadcast_f32x4(_mm_loadu_ps(corner.as_ptr()));
                Avx512(_mm512_permutevar_ps(c, axis))
            }
        }
        #[inline(always)]
        unsafe fn add(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn sub(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn mul(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn div(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn eq(self, o: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F.
            unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn lt(self, o: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F.
            unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn gt(self, o: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F.
            unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn le(self, o: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F.
            unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        unsafe fn min(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn max(self, o: Self) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        unsafe fn and_gt(m: __mmask16, a: Self, b: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F.
            unsafe { _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(m, a.0, b.0) }
        }
        #[inline(always)]
        unsafe fn and_lt(m: __mmask16, a: Self, b: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F.
            unsafe { _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(m, a.0, b.0) }
        }
        #[inline(always)]
        unsafe fn any_zero(a: Self, b: Self, c: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F. As in AVX2.
            unsafe {
                let (a, b, c) = (
                    _mm512_slli_epi32::<1>(_mm512_castps_si512(a.0)),
                    _mm512_slli_epi32::<1>(_mm512_castps_si512(b.0)),
                    _mm512_slli_epi32::<1>(_mm512_castps_si512(c.0)),
                );
                let least = _mm512_min_epu32(_mm512_min_epu32(a, b), c);
                _mm512_testn_epi32_mask(least, least)
            }
        }
        #[inline(always)]
        unsafe fn maybe_zero(a: Self, b: Self, c: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F. Where one of the three is ±0 their product
            // is ±0, or a NaN (0 · ∞); an underflow or a NaN elsewhere only adds lanes.
            unsafe {
                let product = _mm512_mul_ps(_mm512_mul_ps(a.0, b.0), c.0);
                _mm512_cmp_ps_mask::<_CMP_EQ_UQ>(product, _mm512_setzero_ps())
            }
        }
        #[inline(always)]
        unsafe fn same_sign(a: Self, b: Self, c: Self) -> __mmask16 {
            // SAFETY: the caller's CPU has AVX-512F. One ternary logic instruction computes
            // (a ^ b) | (a ^ c), 0 exactly where the three bits agree (truth table 0x7e: all
            // but 000 and 111); its sign bits then give the mask.
            unsafe {
                let (a, b, c) = (
                    _mm512_castps_si512(a.0),
                    _mm512_castps_si512(b.0),
                    _mm512_castps_si512(c.0),
                );
                let differ = _mm512_ternarylogic_epi32::<0x7e>(a, b, c);
                _mm512_testn_epi32_mask(differ, _mm512_set1_epi32(i32::MIN))
            }
        }
        #[inline(always)]
        unsafe fn or(a: __mmask16, b: __mmask16) -> __mmask16 {
            a | b
        }
        #[inline(always)]
        unsafe fn and(a: __mmask16, b: __mmask16) -> __mmask16 {
            a & b
        }
        #[inline(always)]
        unsafe fn and_not(a: __mmask16, b: __mmask16) -> __mmask16 {
            a & !b
        }
        #[inline(always)]
        unsafe fn bits(m: __mmask16) -> u32 {
            u32::from(m)
        }
        #[inline(always)]
        unsafe fn none_of(m: __mmask16, live: __mmask16) -> bool {
            // SAFETY: the caller's CPU has AVX-512 DQ. One `ktestw` instead of an AND and a test.
            unsafe { _ktestz_mask16_u8(m, live) != 0 }
        }
        #[inline(always)]
        unsafe fn select(m: __mmask16, a: Self, b: Self) -> Self {
            // SAFETY: the caller's CPU has AVX-512F.
            Avx512(unsafe { _mm512_mask_blend_ps(m, b.0, a.0) })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{TriRay, TriangleBvh};
    use crate::math::{Ray, Vec3};

    /// A small random generator (xorshift), for reproducible soups.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn point(&mut self, scale: f32) -> Vec3 {
            Vec3::new(self.next(), self.next(), self.next()) * (2.0 * scale) - scale
        }
    }

    /// Every kernel this CPU runs, forced in turn.
    fn sets(tris: &[[Vec3; 3]], ids: &[[u32; 2]]) -> Vec<SmallSet> {
        let Some(widest) = detect() else {
            return Vec::new();
        };
        let order = [Isa::Avx512, Isa::Avx2, Isa::Sse2];
        let from = order.iter().position(|&i| i == widest).unwrap_or(2);
        order[from..]
            .iter()
            .map(|&isa| SmallSet {
                isa,
                ..SmallSet::new(tris.len(), |i| tris[i].map(Vec3A::from), |i| ids[i])
                    .expect("a set on x86-64 with few enough corners")
            })
            .collect()
    }

    /// Checks every kernel against the BVH over the same triangles on `rays`, at every width.
    fn check(tris: &[[Vec3; 3]], ids: &[[u32; 2]], rays: &[Ray]) {
        let bvh = TriangleBvh::new(
            tris.iter().map(|t| t.map(Vec3A::from)).collect(),
            ids.to_vec(),
        );
        for set in sets(tris, ids) {
            for chunk in rays.chunks(16) {
                let mut wave = [None; 16];
                for (w, r) in wave.iter_mut().zip(chunk) {
                    *w = Some(*r);
                }
                // An idle lane, which must hit nothing.
                wave[5] = None;
                check_wave::<16>(&bvh, &set, &wave);
                check_wave::<8>(&bvh, &set, &std::array::from_fn(|i| wave[i]));
                check_wave::<4>(&bvh, &set, &std::array::from_fn(|i| wave[i + 4]));
            }
        }
    }

    fn check_wave<const W: usize>(bvh: &TriangleBvh, set: &SmallSet, wave: &[Option<Ray>; W]) {
        let got = set.closest_lanes(&SegmentLanes::of_rays(wave));
        for (ray, got) in wave.iter().zip(got) {
            let want = ray.and_then(|r| bvh.intersect(&TriRay::new(r.o, r.d), 0.0, f32::INFINITY));
            let bits = |h: Option<([u32; 2], TriHit)>| {
                h.map(|(id, h)| (id, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits()))
            };
            assert_eq!(bits(got), bits(want), "{:?} on {ray:?}", set.isa);
        }
        // Segments ending before, at and after the closest hit.
        for scale in [0.5f32, 1.0, 1.5] {
            let segments: [Option<(Ray, f32)>; W] = std::array::from_fn(|i| {
                let r = wave[i]?;
                let t = bvh
                    .intersect(&TriRay::new(r.o, r.d), 0.0, f32::INFINITY)
                    .map_or(10.0, |(_, h)| h.t);
                Some((r, t * scale))
            });
            let got = set.occluded_lanes(&SegmentLanes::from_options(&segments));
            for (segment, got) in segments.iter().zip(got) {
                let want = segment
                    .is_some_and(|(r, t_max)| bvh.occluded(&TriRay::new(r.o, r.d), 0.0, t_max));
                assert_eq!(got, want, "{:?} on {segment:?}", set.isa);
            }
        }
    }

    #[test]
    fn random_soups_match_the_bvh_bit_for_bit() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for n in [1, 7, 32, 36, SMALL_SET_MAX] {
            // Separate triangles while their corners fit, then triangles sharing corners (as a
            // mesh's do) drawn from as many points as fit.
            let points: Vec<Vec3> = (0..(3 * n).min(MAX_VERTICES))
                .map(|_| rng.point(1.0))
                .collect();
            let pick = |rng: &mut Rng| points[(rng.next() * points.len() as f32) as usize];
            let tris: Vec<[Vec3; 3]> = (0..n)
                .map(|i| {
                    if 3 * n <= MAX_VERTICES {
                        let c = points[3 * i];
                        [c, c + rng.point(0.4), c + rng.point(0.4)]
                    } else {
                        [pick(&mut rng), pick(&mut rng), pick(&mut rng)]
                    }
                })
                .collect();
            let ids: Vec<[u32; 2]> = (0..n as u32).map(|i| [i / 3, i % 3]).collect();
            let mut rays: Vec<Ray> = (0..4096)
                .map(|_| Ray::new(rng.point(1.5), rng.point(1.0)))
                .collect();
            // Rays aimed at points of edges: their edge functions round to exactly zero in f32
            // often enough to exercise the f64 fallback (where f64 then says otherwise).
            for _ in 0..4096 {
                let tri = tris[(rng.next() * n as f32) as usize % n];
                let (a, b) = (tri[0], tri[1 + (rng.next() < 0.5) as usize]);
                let o = rng.point(1.5);
                rays.push(Ray::new(o, a + (b - a) * rng.next() - o));
            }
            check(&tris, &ids, &rays);
        }
    }

    #[test]
    fn degenerate_triangles_and_extreme_rays_match_the_bvh() {
        // Triangles whose edge functions are all zero (a point, a segment) or overflow (huge
        // corners), beside ordinary ones; rays lying in a triangle's plane, along axes, with
        // directions so short that the shear constants overflow, from far away. Where an edge
        // function is a NaN or ±∞, or all three are zero, the kernels skip the tests the
        // scalar code makes (det ≠ 0, the signs one by one) because t is then a NaN: this
        // checks that they still agree.
        let p = Vec3::new;
        let tris: Vec<[Vec3; 3]> = vec![
            [p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(0.0, 1.0, 0.0)],
            [p(0.2, 0.2, 0.5); 3],
            [p(0.0, 0.0, 1.0), p(0.5, 0.5, 1.0), p(1.0, 1.0, 1.0)],
            [p(-3e38, -3e38, 2.0), p(3e38, -3e38, 2.0), p(0.0, 3e38, 2.0)],
            [p(1e-30, 0.0, -1.0), p(0.0, 1e-30, -1.0), p(0.0, 0.0, -1.0)],
            [p(0.0, 0.0, 3.0), p(0.0, 1.0, 3.0), p(0.0, 0.0, 4.0)],
        ];
        let ids: Vec<[u32; 2]> = (0..tris.len() as u32).map(|i| [0, i]).collect();
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let mut rays = Vec::new();
        let origins = [
            p(0.25, 0.25, -1.0),
            p(0.25, 0.25, 0.0),
            p(0.2, 0.2, 5.0),
            p(-2.0, 0.3, 0.0),
            p(1e20, 1e20, -1e20),
            p(0.0, 0.5, 3.5),
        ];
        let directions = [
            p(0.0, 0.0, 1.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(1e-30, 1e-30, 1e-30),
            p(1e-38, 0.0, 2e-38),
            p(-1e20, -1e20, 1e20),
            p(3e38, 3e38, 3e38),
        ];
        for o in origins {
            for d in directions {
                rays.push(Ray::new(o, d));
                rays.push(Ray::new(o, -d));
                rays.push(Ray::new(o, d + rng.point(1e-6) * d.abs().max_element()));
            }
        }
        check(&tris, &ids, &rays);
    }

    #[test]
    fn coincident_triangles_and_shared_edges_match_the_bvh() {
        // A unit square split along its diagonal, twice in the same place (two instances: ties
        // go to the first) and once behind: rays along the grid meet edges, corners and ties
        // exactly.
        let square = |z: f32| {
            let p = |x: f32, y: f32| Vec3::new(x, y, z);
            [
                [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
                [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
            ]
        };
        let tris: Vec<[Vec3; 3]> = [square(0.0), square(0.0), square(0.5)].concat();
        let ids: Vec<[u32; 2]> = (0..tris.len() as u32).map(|i| [i / 2, i % 2]).collect();
        let mut rays = Vec::new();
        for i in 0..=8 {
            for j in 0..=8 {
                let (x, y) = (i as f32 / 8.0, j as f32 / 8.0);
                for d in [
                    Vec3::Z,
                    -Vec3::Z,
                    Vec3::new(0.0, 1.0, 1.0),
                    Vec3::new(1.0, -1.0, 3.0),
                ] {
                    rays.push(Ray::new(Vec3::new(x, y, 0.0) - d * 2.0, d));
                }
            }
        }
        check(&tris, &ids, &rays);
    }
}
