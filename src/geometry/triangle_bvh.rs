//! [`TriangleBvh`]: triangles in an 8-wide BVH whose leaves are packets of four triangles, the
//! layout of Embree on AVX2 machines (Wald, Woop, Benthin, Johnson and Ernst, "Embree: A Kernel
//! Framework for Efficient CPU Ray Tracing", ACM TOG 33(4), 2014).
//!
//! A binary SAH tree, priced for leaves tested four triangles at a time and for the cheap traversal
//! steps of wide nodes ([`LeafCost::PACKET4`]), is collapsed into nodes of up to eight children by
//! repeatedly opening the child with the largest surface area. A node (`Node8`) stores its
//! children's boxes structure-of-arrays, so one ray meets all eight with a few SIMD instructions:
//! one 8-wide AVX2 test when the CPU has AVX2 (detected at run time; the crate is built for
//! baseline x86-64), else two 4-wide SSE tests, with bit-identical results, so both visit the same
//! nodes in the same order. In large sets (`COMPACT_TRIANGLES`) nodes of at most four children are
//! stored as half-size `Node4`s, tested as lanes 0–3 of a `Node8` would be. A leaf is one packet of
//! up to four triangles whose corners are stored structure-of-arrays and tested together by the
//! watertight test of Woop, Benthin and Wald ("Watertight Ray/Triangle Intersection", JCGT 2(1),
//! 2013) in SIMD lanes. Each lane computes exactly the products and sums of the scalar test in
//! [`triangle::intersect`](super::triangle::intersect), including its double-precision fallback on
//! edges, so the two agree bit for bit.
//!
//! Sets of a million triangles or more ([`INDEXED_TRIANGLES`]) keep no packets: their leaves name
//! their triangles (vertex indices and a source index, 16 bytes each) in a [`TriangleSource`],
//! and a query gathers a leaf's packet as it meets it, as Embree's compact mode and pbrt-v4 do.
//! That halves the memory of a big mesh's start for a slower traversal; the answers are the same
//! bits.

use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{BVec4A, Mat4, Vec3A, Vec4};
use rayon::prelude::*;

use crate::bvh::pop_nearer;
use crate::bvh::{Arena, Bvh, LeafCost};
#[cfg(target_arch = "x86_64")]
use crate::geometry::node8::Avx2;
use crate::geometry::node8::{self, avx2_available, BoxTest, Node4, Node8, Sse};
use crate::geometry::triangle::{edge_functions_f64, shear_axes, TriHit};
use crate::geometry::triangle_source::TriangleSource;
use crate::lanes::{F32s, Mask, V3s};
use crate::math::{Aabb, Vec3};

/// A ray prepared for [`TriangleBvh`] queries: the box-test and the watertight-shear constants.
#[derive(Debug, Clone, Copy)]
pub struct TriRay {
    /// Origin.
    pub(crate) org: [f32; 3],
    /// Reciprocal direction per axis (±∞ for zero components).
    pub(crate) inv: [f32; 3],
    /// Bit `axis` set when the ray runs towards −axis (its near box plane is then the upper one).
    pub(crate) negative: u32,
    /// Whether a direction component is zero: box tests must then handle 0·∞.
    robust: bool,
    /// The shear's axis permutation (kx, ky, kz): kz is the direction's dominant axis.
    k: [u8; 3],
    /// The origin's coordinates on axes kx, ky, kz in all lanes.
    org_k: [Vec4; 3],
    /// The shear constants d[kx]/d[kz], d[ky]/d[kz], 1/d[kz] in all lanes.
    shear: [Vec4; 3],
}

impl TriRay {
    /// Prepares the ray o + t d. The divisions are done in SIMD lanes; each lane is the
    /// correctly rounded quotient the scalar division gives, so the constants are those of
    /// [`RayShear`](super::triangle::RayShear).
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> TriRay {
        let inv = Vec3A::ONE / Vec3A::from(d);
        let [kx, ky, kz] = shear_axes(d);
        let (oa, da) = (o.to_array(), d.to_array());
        let s = Vec3A::new(da[kx], da[ky], 1.0) / Vec3A::splat(da[kz]);
        TriRay::assemble(oa, inv, [kx, ky, kz], s.to_array())
    }

    /// The ray from its origin, its direction's reciprocals, the shear's axes (kx, ky, kz) and
    /// the shear's constants d[kx]/d[kz], d[ky]/d[kz], 1/d[kz].
    #[inline(always)]
    fn assemble(org: [f32; 3], inv: Vec3A, [kx, ky, kz]: [usize; 3], shear: [f32; 3]) -> TriRay {
        TriRay {
            org,
            inv: inv.to_array(),
            negative: inv.cmplt(Vec3A::ZERO).bitmask(),
            robust: !inv.is_finite(),
            k: [kx as u8, ky as u8, kz as u8],
            org_k: [
                Vec4::splat(org[kx]),
                Vec4::splat(org[ky]),
                Vec4::splat(org[kz]),
            ],
            shear: shear.map(Vec4::splat),
        }
    }
}

/// The [`TriRay`]s of a wave's rays, their constants computed for all lanes at once: the same
/// divisions and comparisons as [`TriRay::new`], so the same bits. One ray at a time, the
/// shear's dominant axis took unpredictable branches and its divisions waited on them, before
/// each walk of a large mesh could start (a third of the time between a 327k-triangle
/// icosphere's shadow-ray walks).
#[repr(C, align(64))]
pub struct TriRayLanes<const W: usize> {
    org: V3s<W>,
    inv: V3s<W>,
    /// Where d[kz] < 0: there kx and ky are swapped.
    flip: Mask<W>,
    /// d[kx] / d[kz], d[ky] / d[kz] and 1 / d[kz].
    shear: V3s<W>,
    /// The dominant axis kz (0, 1 or 2) of each lane's direction.
    kz: [u8; W],
}

impl<const W: usize> TriRayLanes<W> {
    /// The rays o + t d of every lane, compiled for the widest vector instructions the CPU has
    /// that suit W lanes.
    pub fn new(o: &V3s<W>, d: &V3s<W>) -> Self {
        crate::lanes::widest!(
            W,
            (o: &V3s<W>, d: &V3s<W>) => TriRayLanes<W>,
            (o, d),
            TriRayLanes::new_here(o, d)
        )
    }

    #[inline(always)]
    fn new_here(o: &V3s<W>, d: &V3s<W>) -> Self {
        let (zero, one) = (F32s::splat(0.0), F32s::splat(1.0));
        let a = V3s {
            x: d.x.abs(),
            y: d.y.abs(),
            z: d.z.abs(),
        };
        // As `shear_axes`: x where |dx| ≥ |dy| and |dx| ≥ |dz|, else y where |dy| ≥ |dz|,
        // else z; then the two axes after kz, swapped where d[kz] < 0.
        let x_major = a.x.ge(a.y) & a.x.ge(a.z);
        let y_major = a.y.ge(a.z).and_not(x_major);
        // (No closure: it would not inherit the caller's target features.)
        macro_rules! pick {
            ($x:expr, $y:expr, $z:expr) => {
                F32s::select(x_major, $x, F32s::select(y_major, $y, $z))
            };
        }
        let (dkz, after, second) = (
            pick!(d.x, d.y, d.z),
            pick!(d.y, d.z, d.x),
            pick!(d.z, d.x, d.y),
        );
        let flip = dkz.lt(zero);
        let (dkx, dky) = (
            F32s::select(flip, second, after),
            F32s::select(flip, after, second),
        );
        let kz = pick!(zero, one, F32s::splat(2.0));
        TriRayLanes {
            org: *o,
            inv: V3s {
                x: one / d.x,
                y: one / d.y,
                z: one / d.z,
            },
            kz: std::array::from_fn(|i| kz[i] as u8),
            flip,
            shear: V3s {
                x: dkx / dkz,
                y: dky / dkz,
                z: one / dkz,
            },
        }
    }

    /// Lane `i`'s ray, as [`TriRay::new`] prepares it.
    #[inline]
    pub fn lane(&self, i: usize) -> TriRay {
        /// The two axes after axis k, in turn.
        const AFTER: [[usize; 2]; 3] = [[1, 2], [2, 0], [0, 1]];
        let kz = usize::from(self.kz[i]);
        let [kx, ky] = match (AFTER[kz], self.flip.lane(i)) {
            ([a, b], false) => [a, b],
            ([a, b], true) => [b, a],
        };
        let (org, inv) = (self.org.lane(i).to_array(), Vec3A::from(self.inv.lane(i)));
        TriRay::assemble(org, inv, [kx, ky, kz], self.shear.lane(i).to_array())
    }
}

/// Child reference bit marking a leaf (the rest is a packet index).
const LEAF: u32 = 1 << 31;
/// Child reference bit marking a [`Node4`] (the rest is its index).
const NARROW: u32 = 1 << 30;
/// Trees up to this depth traverse with a stack on the call stack; deeper ones allocate.
const INLINE_DEPTH: usize = 32;
/// Children per node.
const WIDTH: usize = 8;

/// Up to four triangles, corners structure-of-arrays: `v[3 * corner + axis]`, and their ids.
/// Lanes past `count` repeat lane 0 (a repeated triangle changes no answer, and lane 0 wins
/// ties). The ids sit beside the corners, as in Embree's leaves: a hit's id is then in the lines
/// its test has just read (kept in an array of their own, the id of the closest hit cost one
/// more cache miss per incoherent ray, 13 % of the closest-hit time on a 327k-triangle mesh).
/// 192 bytes, aligned to whole cache lines: three of them.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Packet {
    v: [Vec4; 9],
    ids: [[u32; 2]; 4],
    /// How many lanes hold triangles of their own (the rest repeat lane 0).
    count: u32,
}

// Three whole cache lines, as the packet's documentation says (and the prefetch assumes).
const _: () = assert!(std::mem::size_of::<Packet>() == 192 && std::mem::align_of::<Packet>() == 64);

/// The lanes of a packet a ray hits within (t_min, t_max), with what is needed to finish a hit.
struct PacketHits {
    mask: u32,
    /// Hit distances, +∞ in lanes without a hit.
    t: Vec4,
    v: Vec4,
    w: Vec4,
    inv_det: Vec4,
}

impl PacketHits {
    /// The hit in `lane` (one of `mask`'s).
    #[inline(always)]
    fn hit(&self, lane: usize) -> TriHit {
        let inv = self.inv_det[lane];
        TriHit {
            t: self.t[lane],
            b1: self.v[lane] * inv,
            b2: self.w[lane] * inv,
        }
    }
}

impl Packet {
    /// The corners of the triangle in `lane`.
    #[inline(always)]
    fn corners(&self, lane: usize) -> [Vec3; 3] {
        // Spelled out: a closure (as in `[0, 1, 2].map`) does not inherit the AVX2 target
        // feature of the traversal, and its calls are not inlined into it.
        let v = &self.v;
        [
            Vec3::new(v[0][lane], v[1][lane], v[2][lane]),
            Vec3::new(v[3][lane], v[4][lane], v[5][lane]),
            Vec3::new(v[6][lane], v[7][lane], v[8][lane]),
        ]
    }

    /// The lanes holding triangles of their own (not repeating lane 0), as a mask.
    #[inline(always)]
    fn own_lanes(&self) -> u32 {
        (1u32 << self.count) - 1
    }

    /// The packet of slots `first..first + count` (at most four), `corners(slot)` and
    /// `id(slot)` giving each slot's triangle and id.
    fn new(
        corners: impl Fn(usize) -> [Vec3A; 3],
        id: impl Fn(usize) -> [u32; 2],
        first: usize,
        count: usize,
    ) -> Packet {
        debug_assert!((1..=4).contains(&count));
        // Each triangle read once; the lanes past `count` copy lane 0.
        let mut tris = [corners(first); 4];
        let mut ids = [id(first); 4];
        for lane in 1..count {
            tris[lane] = corners(first + lane);
            ids[lane] = id(first + lane);
        }
        Packet::of_lanes(&tris, ids, count)
    }

    /// The packet of triangles `tris` with ids `ids`, `count` of them its own (the lanes past
    /// it repeat lane 0).
    #[inline(always)]
    fn of_lanes(tris: &[[Vec3A; 3]; 4], ids: [[u32; 2]; 4], count: usize) -> Packet {
        // Each corner's four lanes transposed from rows (x, y, z) to one vector per axis.
        let axes = |c: usize| {
            Mat4::from_cols(
                tris[0][c].extend(0.0),
                tris[1][c].extend(0.0),
                tris[2][c].extend(0.0),
                tris[3][c].extend(0.0),
            )
            .transpose()
        };
        let (a, b, c) = (axes(0), axes(1), axes(2));
        Packet {
            v: [
                a.x_axis, a.y_axis, a.z_axis, b.x_axis, b.y_axis, b.z_axis, c.x_axis, c.y_axis,
                c.z_axis,
            ],
            ids,
            count: count as u32,
        }
    }

    /// The watertight test on four triangles at once. Per lane the operations are those of the
    /// scalar test: corners relative to the origin, sheared so the ray runs along +z; edge
    /// functions u, v, w in 2D, recomputed in f64 when one is exactly zero (a hit exactly on an
    /// edge), so neighbouring triangles agree; a hit when all three have one sign.
    #[inline(always)]
    fn hits(&self, r: &TriRay, t_min: f32, t_max: f32) -> PacketHits {
        let [kx, ky, kz] = r.k.map(usize::from);
        let [sx, sy, sz] = r.shear;
        let [ox, oy, oz] = r.org_k;
        debug_assert!(kx < 3 && ky < 3 && kz < 3);
        // SAFETY: c < 3 and each k < 3 (`TriRay::new` makes them axes), so 3c + k < 9.
        // Unchecked: the checks (or `% 3` to prove them) cost 20 instructions per packet.
        let at = |c: usize, k: usize| unsafe { *self.v.get_unchecked(3 * c + k) };
        let corner = |c: usize| {
            let z = at(c, kz) - oz;
            let x = (at(c, kx) - ox) - sx * z;
            let y = (at(c, ky) - oy) - sy * z;
            (x, y, sz * z)
        };
        let (ax, ay, az) = corner(0);
        let (bx, by, bz) = corner(1);
        let (cx, cy, cz) = corner(2);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        let zero = u.cmpeq(Vec4::ZERO) | v.cmpeq(Vec4::ZERO) | w.cmpeq(Vec4::ZERO);
        if zero.any() {
            let m = zero.bitmask();
            let (mut ua, mut va, mut wa) = (u.to_array(), v.to_array(), w.to_array());
            for lane in (0..4).filter(|l| m & (1 << l) != 0) {
                [ua[lane], va[lane], wa[lane]] = edge_functions_f64(
                    [ax[lane], ay[lane]],
                    [bx[lane], by[lane]],
                    [cx[lane], cy[lane]],
                );
            }
            (u, v, w) = (
                Vec4::from_array(ua),
                Vec4::from_array(va),
                Vec4::from_array(wa),
            );
        }
        let negative = u.cmplt(Vec4::ZERO) | v.cmplt(Vec4::ZERO) | w.cmplt(Vec4::ZERO);
        let positive = u.cmpgt(Vec4::ZERO) | v.cmpgt(Vec4::ZERO) | w.cmpgt(Vec4::ZERO);
        let det = u + v + w;
        let inside = !(negative & positive) & det.cmpne(Vec4::ZERO);
        if !inside.any() {
            // Most packets a ray reaches it passes by: no lane needs its distance (nor the
            // division for it).
            return PacketHits {
                mask: 0,
                t: Vec4::INFINITY,
                v,
                w,
                inv_det: Vec4::ZERO,
            };
        }
        let t_scaled = u * az + v * bz + w * cz;
        let inv_det = Vec4::ONE / det;
        let t = t_scaled * inv_det;
        let in_range: BVec4A = t.cmpgt(Vec4::splat(t_min)) & t.cmplt(Vec4::splat(t_max));
        let hit = inside & in_range;
        PacketHits {
            mask: hit.bitmask(),
            t: Vec4::select(hit, t, Vec4::INFINITY),
            v,
            w,
            inv_det,
        }
    }
}

/// Leaves that name their triangles in a [`TriangleSource`] instead of holding their corners
/// ([`TriangleBvh::build_indexed`]). A leaf's reference holds its first slot and its triangle
/// count less one (2 bits); a query gathers the leaf's packet from the source as it meets it.
#[derive(Debug, Clone)]
struct Indexed {
    /// Each slot's triangle ([`TriangleSource::entry`]: its corners' vertex indices and its
    /// source index), the leaves' slots in order. With the vertex indices here a leaf's
    /// corners are one dependent load away, not two (16 bytes a triangle instead of 4; the
    /// array is made after the build's peak).
    slots: Vec<[u32; 4]>,
    source: TriangleSource,
}

impl Indexed {
    /// The most slots a tree with indexed leaves may have: a reference keeps 29 bits for its
    /// leaf's first slot.
    const MAX_SLOTS: usize = 1 << 29;

    /// The reference to the leaf of `count` (1 to 4) slots from `first`.
    fn reference(first: u32, count: u32) -> u32 {
        debug_assert!((1..=4).contains(&count) && (first as usize) < Self::MAX_SLOTS);
        LEAF | first << 2 | (count - 1)
    }

    /// The packet of leaf `reference`, as the build would have made it.
    #[inline(always)]
    fn packet(&self, reference: u32) -> Packet {
        let leaf = reference & !LEAF;
        let (first, count) = ((leaf >> 2) as usize, (leaf & 3) as usize + 1);
        let slots = &self.slots[first..first + count];
        // Spelled out, as in `Packet::corners`: closures would not inline into the traversal.
        let (corners, id) = self.source.entry_triangle(slots[0]);
        let mut tris = [corners; 4];
        let mut ids = [id; 4];
        for lane in 1..count {
            (tris[lane], ids[lane]) = self.source.entry_triangle(slots[lane]);
        }
        Packet::of_lanes(&tris, ids, count)
    }
}

/// What a traversal does with the packets it reaches.
trait Leaf {
    /// Tests packet `p` (the leaf `reference` names) within (t_min, *t_max), shrinking `*t_max`
    /// on a closer hit; `true` stops the traversal.
    fn visit(&mut self, p: &Packet, reference: u32, t_max: &mut f32) -> bool;
}

/// The culling bound after a closest hit at `t`: a little beyond t, so that boxes and shapes
/// holding hits at exactly t are still visited and their hits compared with the best one
/// (ties go to the lowest id), even where a box's computed entry distance rounds a few ulps
/// above the triangle's computed t. Hits in the slack are found and rejected as farther.
#[inline(always)]
pub(crate) fn tie_bound(t: f32) -> f32 {
    /// 2⁻¹⁶: far above the rounding of either distance, far below any real gap to matter.
    const SLACK: f32 = 1.0 / 65536.0;
    (t * (1.0 + SLACK)).max(t.next_up())
}

/// Closest-hit queries: keeps the nearest hit (its triangle's id and the hit). Of hits at the
/// same distance (a ray through coincident triangles) the lowest id wins, so the answer does
/// not depend on the order the traversal meets them in: after a hit at t the bound becomes
/// [`tie_bound`]`(t)`, which lets later hits at t through to the comparison.
struct Closest<'a, const CORNERS: bool> {
    ray: &'a TriRay,
    t_min: f32,
    best: Option<([u32; 2], TriHit)>,
    /// Where `CORNERS`: the leaf and lane of the best hit, whose corners are read once the walk
    /// is over (not at every closer hit on the way).
    found_in: Option<(u32, usize)>,
}

/// Whether a hit at distance `t` on the primitive named `key` comes before one at `other_t` on
/// `other`: nearer, or as near with a lower key. The one order of closest hits, here and over
/// a scene's instances (`geometry::keep`).
#[inline(always)]
pub(crate) fn comes_before<K: PartialOrd>(t: f32, key: K, other_t: f32, other: K) -> bool {
    t < other_t || (t == other_t && key < other)
}

/// Whether a hit at `t` on triangle `id` comes before `best` (any hit comes before none).
#[inline(always)]
fn precedes(t: f32, id: [u32; 2], best: &Option<([u32; 2], TriHit)>) -> bool {
    best.as_ref()
        .is_none_or(|(b, bh)| comes_before(t, id, bh.t, *b))
}

impl<const CORNERS: bool> Leaf for Closest<'_, CORNERS> {
    #[inline(always)]
    fn visit(&mut self, p: &Packet, reference: u32, t_max: &mut f32) -> bool {
        let h = p.hits(self.ray, self.t_min, *t_max);
        if h.mask != 0 {
            let nearest = h.t.min_element();
            let mut ties = h.t.cmpeq(Vec4::splat(nearest)).bitmask() & h.mask;
            let mut lane = ties.trailing_zeros() as usize;
            ties &= ties - 1;
            while ties != 0 {
                let l = ties.trailing_zeros() as usize;
                ties &= ties - 1;
                if p.ids[l] < p.ids[lane] {
                    lane = l;
                }
            }
            // A hit in the slack beyond the best one leaves both it and the bound as they are.
            if precedes(nearest, p.ids[lane], &self.best) {
                self.best = Some((p.ids[lane], h.hit(lane)));
                *t_max = tie_bound(nearest);
                if CORNERS {
                    self.found_in = Some((reference, lane));
                }
            }
        }
        false
    }
}

/// Closest-hit queries that keep only the hits `accept` takes (given the triangle's id and the
/// hit): the nearest accepted hit, ties to the lowest id as in [`Closest`]. Within a packet the
/// hits are offered nearest first (the lower id first at equal distances) until one is
/// accepted; each triangle is offered once per packet (the lanes repeating lane 0 are left
/// out), and none that could not replace the best hit so far.
struct ClosestAccepted<'a> {
    ray: &'a TriRay,
    t_min: f32,
    accept: &'a mut dyn FnMut([u32; 2], &TriHit) -> bool,
    best: Option<([u32; 2], TriHit)>,
}

impl Leaf for ClosestAccepted<'_> {
    #[inline(always)]
    fn visit(&mut self, p: &Packet, _: u32, t_max: &mut f32) -> bool {
        let h = p.hits(self.ray, self.t_min, *t_max);
        let mut mask = h.mask & p.own_lanes();
        while mask != 0 {
            let mut lane = mask.trailing_zeros() as usize;
            let mut rest = mask & (mask - 1);
            while rest != 0 {
                let l = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                if comes_before(h.t[l], p.ids[l], h.t[lane], p.ids[lane]) {
                    lane = l;
                }
            }
            let id = p.ids[lane];
            if !precedes(h.t[lane], id, &self.best) {
                // Offered in order: no later lane of this packet precedes the best either.
                break;
            }
            let hit = h.hit(lane);
            if (self.accept)(id, &hit) {
                *t_max = tie_bound(hit.t);
                self.best = Some((id, hit));
                break;
            }
            mask &= !(1 << lane);
        }
        false
    }
}

/// Any-hit queries that count only the hits `accept` takes: stop at the first of them.
struct AnyAccepted<'a> {
    ray: &'a TriRay,
    t_min: f32,
    accept: &'a mut dyn FnMut([u32; 2], &TriHit) -> bool,
}

impl Leaf for AnyAccepted<'_> {
    #[inline(always)]
    fn visit(&mut self, p: &Packet, _: u32, t_max: &mut f32) -> bool {
        let h = p.hits(self.ray, self.t_min, *t_max);
        let mut mask = h.mask & p.own_lanes();
        while mask != 0 {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let hit = h.hit(lane);
            if (self.accept)(p.ids[lane], &hit) {
                return true;
            }
        }
        false
    }
}

/// Any-hit queries: stop at the first hit.
struct AnyHit<'a> {
    ray: &'a TriRay,
    t_min: f32,
}

impl Leaf for AnyHit<'_> {
    #[inline(always)]
    fn visit(&mut self, p: &Packet, _: u32, t_max: &mut f32) -> bool {
        p.hits(self.ray, self.t_min, *t_max).mask != 0
    }
}

/// Asks the memory system for the cache line holding `p` (a hint: it never faults, whatever
/// the address).
#[inline(always)]
pub fn prefetch_line<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is only a hint; it never faults, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast::<i8>())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// What a [`TriangleBvh::build`] asks its triangles' source to prefetch, a few leaves ahead of
/// the packets it makes: a triangle's corner indices first, then (once those have arrived) its
/// corners. The packets gather triangles in the tree's order, at random in the mesh: without
/// the hints every triangle waited on a chain of cache and TLB misses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prefetch {
    /// What locates the corners (a mesh's index triple).
    Indices,
    /// The corners themselves.
    Corners,
}

/// How many leaves ahead the packets' gather prefetches the corners (and twice as far their
/// indices).
const PREFETCH_LEAVES: usize = 8;

/// How many triangles ahead the boxes' pass (in the triangles' order) prefetches corners.
const PREFETCH_TRIANGLES: usize = 16;

/// Node arrays reserved at this size or more are not shrunk to their length (see
/// [`TriangleBvh::build`]); their untouched tail is address space, not memory.
const KEEP_RESERVED_BYTES: usize = 4 << 20;

/// Tree levels above this depth collapse their children in parallel.
const PARALLEL_COLLAPSE_DEPTH: usize = 6;

/// The arrays a collapse writes: nodes of five to eight children, and of two to four (when
/// `compact`; else every node is a [`Node8`]).
struct Wide<'a> {
    nodes: &'a Arena<Node8>,
    narrow: &'a Arena<Node4>,
    compact: bool,
}

/// Sets of at least this many triangles store nodes of at most four children as [`Node4`]s
/// (128 bytes, two cache lines, instead of 256): their trees outgrow a core's L2 cache (about
/// 64 bytes per triangle), and incoherent rays are then bounded by cache misses (−19 % of L2
/// misses on a 327k-triangle icosphere, where 70 % of the nodes have at most four children).
/// Smaller trees stay in cache and keep only 8-wide nodes, which take fewer instructions (the
/// narrow test costs +6.6 % on a 5k-triangle mesh). Both give identical hits.
const COMPACT_TRIANGLES: usize = 16_384;

/// Sets of at least this many triangles get indexed leaves ([`TriangleBvh::build_indexed`]):
/// about 55 bytes per triangle at the start's peak instead of 110 (packets take 53), for a
/// slower traversal (each leaf met gathers its corners through the mesh's indices). Below it
/// the packets' speed is kept: a 327,680-triangle mesh's packets fit in 17 MB.
pub const INDEXED_TRIANGLES: usize = 1 << 20;

/// The environment variable that overrides [`INDEXED_TRIANGLES`]: `indexed` or `packets` gives
/// every set that kind of leaf (the two give identical answers; for tests and measurements).
pub const LEAVES_VARIABLE: &str = "LUMO_BVH_LEAVES";

/// Whether a set of `count` triangles gets indexed leaves: from [`LEAVES_VARIABLE`] when it
/// says `indexed` or `packets`, else when `count` ≥ [`INDEXED_TRIANGLES`].
pub fn indexed_leaves(count: usize) -> bool {
    match std::env::var(LEAVES_VARIABLE).as_deref() {
        Ok("indexed") => true,
        Ok("packets") => false,
        _ => count >= INDEXED_TRIANGLES,
    }
}

/// The first slots of a binary tree's leaves, as bits. A left-first walk meets the leaves in
/// slot order, and they tile the slots, so leaf k (and packet k) is the one whose first slot is
/// the k-th set bit: found in parallel over the nodes, with no walk.
struct LeafStarts {
    bits: Vec<u64>,
    /// Set bits in the words before each word.
    before: Vec<u32>,
}

impl LeafStarts {
    /// The leaves of binary tree `nodes` over `slots` slots.
    fn of(nodes: &[crate::bvh::Node], slots: usize) -> LeafStarts {
        let words = slots.div_ceil(64);
        let marks: Vec<AtomicU64> = (0..words).map(|_| AtomicU64::new(0)).collect();
        nodes.par_iter().filter(|n| n.count() > 0).for_each(|n| {
            let first = n.first() as usize;
            marks[first / 64].fetch_or(1 << (first % 64), Ordering::Relaxed);
        });
        let bits: Vec<u64> = marks.into_iter().map(AtomicU64::into_inner).collect();
        let before = bits
            .iter()
            .scan(0, |seen, w| {
                let here = *seen;
                *seen += w.count_ones();
                Some(here)
            })
            .collect();
        LeafStarts { bits, before }
    }

    /// The packet of the leaf whose first slot is `first`.
    fn packet(&self, first: usize) -> u32 {
        let below = self.bits[first / 64] & ((1 << (first % 64)) - 1);
        self.before[first / 64] + below.count_ones()
    }

    /// The leaves in slot order, over `slots` slots.
    fn leaves(&self, slots: usize) -> Leaves {
        let mut firsts = Vec::with_capacity(self.before.last().map_or(0, |&b| b as usize) + 64);
        for (w, &word) in self.bits.iter().enumerate() {
            let mut rest = word;
            while rest != 0 {
                firsts.push((w * 64) as u32 + rest.trailing_zeros());
                rest &= rest - 1;
            }
        }
        Leaves { firsts, slots }
    }
}

/// A binary tree's leaves in slot order, as their first slots alone (4 bytes a leaf): leaf k
/// runs from its first slot to the next leaf's.
struct Leaves {
    firsts: Vec<u32>,
    slots: usize,
}

impl Leaves {
    fn len(&self) -> usize {
        self.firsts.len()
    }

    /// Leaf `k`'s first slot and slot count (`k` < [`Leaves::len`]).
    fn span(&self, k: usize) -> (usize, usize) {
        let first = self.firsts[k] as usize;
        let end = self.firsts.get(k + 1).map_or(self.slots, |&e| e as usize);
        (first, end - first)
    }

    /// [`Leaves::span`], or `None` past the last leaf.
    fn get(&self, k: usize) -> Option<(usize, usize)> {
        (k < self.len()).then(|| self.span(k))
    }
}

/// Turns binary node `index` (and its subtree) into 8-wide nodes written to `out` (a [`Node4`]
/// when there are at most four children); returns its reference and the deepest level of
/// nodes in it (`depth` is this node's level; 0 for a leaf).
fn collapse(
    bin: &Bvh,
    starts: Option<&LeafStarts>,
    out: &Wide,
    index: usize,
    depth: usize,
) -> (u32, usize) {
    let n = bin.nodes[index];
    if n.count() > 0 {
        let reference = match starts {
            Some(starts) => LEAF | starts.packet(n.first() as usize),
            None => Indexed::reference(n.first(), n.count()),
        };
        return (reference, 0);
    }
    // Open the interior child with the largest surface area until there are eight children
    // (the greedy collapse of Wald et al. 2008, "Getting Rid of Packets").
    let mut kids = [0; WIDTH];
    kids[..2].copy_from_slice(&[n.first() as usize, n.first() as usize + 1]);
    let mut len = 2;
    while len < WIDTH {
        let widest = (0..len)
            .filter(|&i| bin.nodes[kids[i]].count() == 0)
            .max_by(|&a, &b| {
                bin.nodes[kids[a]]
                    .aabb()
                    .half_area()
                    .total_cmp(&bin.nodes[kids[b]].aabb().half_area())
            });
        let Some(i) = widest else { break };
        let first = bin.nodes[kids[i]].first() as usize;
        kids[i] = first;
        kids[len] = first + 1;
        len += 1;
    }
    let narrow = out.compact && len <= 4;
    let me = if narrow {
        out.narrow.take(1)
    } else {
        out.nodes.take(1)
    };
    assert!(me < NARROW as usize, "too many BVH nodes");
    let child = |&kid: &usize| collapse(bin, starts, out, kid, depth + 1);
    let mut children = [(0, 0); WIDTH];
    if depth < PARALLEL_COLLAPSE_DEPTH {
        let done: Vec<(u32, usize)> = kids[..len].par_iter().map(child).collect();
        children[..len].copy_from_slice(&done);
    } else {
        for (c, kid) in children.iter_mut().zip(&kids[..len]) {
            *c = child(kid);
        }
    }
    let deepest = children[..len].iter().fold(depth, |m, c| m.max(c.1));
    let lanes = kids[..len].iter().zip(&children).enumerate();
    if narrow {
        let mut node = Node4::EMPTY;
        for (lane, (&kid, &(reference, _))) in lanes {
            node.set_child(lane, bin.nodes[kid].aabb(), reference);
        }
        // SAFETY: `me` was taken by this call alone.
        unsafe { out.narrow.set(me, node) };
        (NARROW | me as u32, deepest)
    } else {
        let mut node = Node8::EMPTY;
        for (lane, (&kid, &(reference, _))) in lanes {
            node.set_child(lane, bin.nodes[kid].aabb(), reference);
        }
        // SAFETY: `me` was taken by this call alone.
        unsafe { out.nodes.set(me, node) };
        (me as u32, deepest)
    }
}

/// A BVH over triangles (see the module documentation). Each triangle carries a caller-defined
/// id (for a mesh, its triangle index; for a scene's world-space set, the instance and the
/// triangle index).
#[derive(Debug, Clone)]
pub struct TriangleBvh {
    /// Nodes of five to eight children.
    nodes: Vec<Node8>,
    /// Nodes of two to four children (references marked [`NARROW`]).
    narrow: Vec<Node4>,
    /// The leaves, unless they are indexed.
    packets: Vec<Packet>,
    /// The leaves, when they name their triangles in a source instead of holding packets.
    indexed: Option<Box<Indexed>>,
    /// Number of triangles.
    triangles: usize,
    /// The root: a node index, or a leaf when there are at most four triangles.
    root: u32,
    /// Levels of nodes on the longest root-to-leaf path.
    depth: usize,
    bounds: Aabb,
    /// Whether queries test boxes with [`Avx2`] (8 lanes) rather than [`Sse`] (2 × 4 lanes).
    avx2: bool,
    /// Whether a traversal prefetches the children it pushes: only when the tree is larger
    /// than [`PREFETCH_BYTES`], so that incoherent rays miss the caches.
    prefetch: bool,
    /// The boxes of the root's children, `[lo x, hi x, lo y, hi y, lo z, hi z]` each (the
    /// tree's bounds when the root is a packet), for [`TriangleBvh::meets_lanes`].
    root_boxes: Vec<[f32; 6]>,
}

/// Trees of more bytes than this (about a core's L2 cache) prefetch pushed children: their
/// loads then overlap the work on the nearer child (measured +10–20 % on incoherent rays in a
/// 327 k-triangle mesh); smaller trees stay in cache, where the prefetches would only cost
/// instructions (−2 % on a 5 k-triangle mesh).
const PREFETCH_BYTES: usize = 1 << 20;

impl Default for TriangleBvh {
    fn default() -> TriangleBvh {
        TriangleBvh {
            nodes: Vec::new(),
            narrow: Vec::new(),
            packets: Vec::new(),
            indexed: None,
            triangles: 0,
            root: 0,
            depth: 0,
            bounds: Aabb::EMPTY,
            avx2: avx2_available(),
            prefetch: false,
            root_boxes: Vec::new(),
        }
    }
}

impl TriangleBvh {
    /// Builds the BVH over triangles given by their corners and ids. Degenerate or non-finite
    /// triangles are left out (they cannot be hit).
    pub fn new(corners: Vec<[Vec3A; 3]>, ids: Vec<[u32; 2]>) -> TriangleBvh {
        debug_assert_eq!(corners.len(), ids.len());
        TriangleBvh::build(corners.len(), |i| corners[i], |i| ids[i], |_, _| {})
    }

    /// The BVH over `count` triangles of `source`, triangle j being `source`'s triangle
    /// `index(j)`: with indexed leaves when [`indexed_leaves`] says so, else with packets.
    pub fn from_source(
        count: usize,
        source: TriangleSource,
        index: impl Fn(usize) -> u32 + Sync,
    ) -> TriangleBvh {
        TriangleBvh::build_from_source(count, source, index, indexed_leaves(count))
    }

    /// [`TriangleBvh::from_source`] with indexed leaves: a leaf names its triangles (16 bytes
    /// each: vertex indices and source index) and a query reads their corners from the
    /// source, by the operations that make packets, instead of holding them in packets (about
    /// 53 bytes per triangle). Embree's compact mode; the same tree, and the same answers bit
    /// for bit, as with packets. Sets of more than 2²⁹ triangles get packets all the same (a
    /// leaf reference holds its first slot in 29 bits).
    pub fn build_indexed(
        count: usize,
        source: TriangleSource,
        index: impl Fn(usize) -> u32 + Sync,
    ) -> TriangleBvh {
        TriangleBvh::build_from_source(count, source, index, true)
    }

    /// [`TriangleBvh::from_source`], with indexed leaves where `indexed` (and the set fits).
    fn build_from_source(
        count: usize,
        source: TriangleSource,
        index: impl Fn(usize) -> u32 + Sync,
        indexed: bool,
    ) -> TriangleBvh {
        let src = &source;
        let corners = |j: usize| src.corners(index(j));
        let id = |j: usize| src.id(index(j));
        let prefetch = |j: usize, stage: Prefetch| src.prefetch(index(j), stage);
        let indexed = indexed && count <= Indexed::MAX_SLOTS;
        let leaves = indexed.then_some((src, &index as &(dyn Fn(usize) -> u32 + Sync)));
        let (mut tree, slots) = TriangleBvh::build_as(count, corners, id, prefetch, leaves);
        if indexed && !tree.is_empty() {
            tree.indexed = Some(Box::new(Indexed { slots, source }));
        }
        tree
    }

    /// [`TriangleBvh::new`] over `count` triangles whose corners and ids the functions give
    /// (called in parallel, `corners` twice per triangle: once for its box, once for its leaf),
    /// so that no array of corners is made: the build holds 32 bytes per triangle (its box and
    /// index) while it splits, then the binary nodes and the leaf packets (with the ids).
    pub fn build(
        count: usize,
        corners: impl Fn(usize) -> [Vec3A; 3] + Sync,
        id: impl Fn(usize) -> [u32; 2] + Sync,
        prefetch: impl Fn(usize, Prefetch) + Sync,
    ) -> TriangleBvh {
        TriangleBvh::build_as(count, corners, id, prefetch, None).0
    }

    /// [`TriangleBvh::build`] with packets, or, given the source and the triangles' indices in
    /// it, the tree of [`TriangleBvh::build_indexed`] (without its [`Indexed`]) and its slots'
    /// entries ([`TriangleSource::entry`]).
    fn build_as(
        count: usize,
        corners: impl Fn(usize) -> [Vec3A; 3] + Sync,
        id: impl Fn(usize) -> [u32; 2] + Sync,
        prefetch: impl Fn(usize, Prefetch) + Sync,
        indexed: Option<(&TriangleSource, &(dyn Fn(usize) -> u32 + Sync))>,
    ) -> (TriangleBvh, Vec<[u32; 4]>) {
        let mut bin = Bvh::build_transient(
            count,
            |i| {
                // Triangles in their own order: their indices arrive in sequence, their
                // corners (shared with neighbours, but scattered) are asked for ahead.
                prefetch(i + PREFETCH_TRIANGLES, Prefetch::Corners);
                let c = corners(i);
                Aabb {
                    min: c[0].min(c[1]).min(c[2]).into(),
                    max: c[0].max(c[1]).max(c[2]).into(),
                }
            },
            LeafCost::PACKET4,
        );
        if bin.prims.is_empty() {
            return (TriangleBvh::default(), Vec::new());
        }
        crate::phases::mark("bvh: binary SAH tree");
        let prims = std::mem::take(&mut bin.prims);
        let triangles = prims.len();
        // Packets are numbered by their leaves' first slots; indexed leaves hold those slots.
        let starts = indexed
            .is_none()
            .then(|| LeafStarts::of(&bin.nodes, triangles));
        // The wide nodes first, so that the binary tree is freed before the packets are
        // made: the two are never in memory together. A binary tree of n nodes has (n - 1) / 2
        // interior ones; a node of k children takes k - 1 of them.
        let mut root = (0, 0);
        let interior = bin.nodes.len() / 2 + 1;
        let compact = triangles >= COMPACT_TRIANGLES;
        let mut narrow = Vec::new();
        // SAFETY: `collapse` writes every node it takes, in either arena.
        let mut nodes = unsafe {
            Arena::fill(if compact { interior / 4 + 1 } else { interior }, |nodes| {
                narrow = Arena::fill(if compact { interior } else { 0 }, |narrow| {
                    let out = Wide {
                        nodes,
                        narrow,
                        compact,
                    };
                    root = collapse(&bin, starts.as_ref(), &out, 0, 1);
                });
            })
        };
        // Big arrays keep their reserved capacity: the pages past their nodes were never
        // touched, so they hold no memory, and shrinking an array of 64-byte-aligned nodes
        // copies it (Rust's system allocator reallocates over-aligned blocks by allocating,
        // copying and freeing): 22 MB and about 10 ms of a 1.31M-triangle start.
        if nodes.capacity() * size_of::<Node8>() < KEEP_RESERVED_BYTES {
            nodes.shrink_to_fit();
        }
        if narrow.capacity() * size_of::<Node4>() < KEEP_RESERVED_BYTES {
            narrow.shrink_to_fit();
        }
        let (bounds, binary_nodes) = (bin.bounds(), bin.nodes.len());
        let leaves = starts.map(|starts| starts.leaves(triangles));
        drop(bin);
        crate::phases::mark("bvh: 8-wide nodes");
        let (packets, slots): (Vec<Packet>, Vec<[u32; 4]>) = match (indexed, leaves) {
            (Some((source, index)), _) => {
                // Indexed leaves: each slot names its triangle in the source; no packets.
                let slots = prims
                    .par_iter()
                    .map(|&p| source.entry(index(p as usize)))
                    .collect();
                (Vec::new(), slots)
            }
            (None, None) => unreachable!("leaf starts are made for packets"),
            (None, Some(leaves)) => {
                let ahead = |j: usize, stage: Prefetch| {
                    if let Some((first, count)) = leaves.get(j) {
                        for &t in &prims[first..first + count] {
                            prefetch(t as usize, stage);
                        }
                    }
                };
                let packets = (0..leaves.len())
                    .into_par_iter()
                    .map(|j| {
                        let (first, count) = leaves.span(j);
                        ahead(j + 2 * PREFETCH_LEAVES, Prefetch::Indices);
                        ahead(j + PREFETCH_LEAVES, Prefetch::Corners);
                        Packet::new(
                            |slot| corners(prims[slot] as usize),
                            |slot| id(prims[slot] as usize),
                            first,
                            count,
                        )
                    })
                    .collect();
                (packets, Vec::new())
            }
        };
        drop(prims);
        let nodes_bytes = std::mem::size_of_val(&nodes[..]) + std::mem::size_of_val(&narrow[..]);
        let packets_bytes = std::mem::size_of_val(&packets[..]) + std::mem::size_of_val(&slots[..]);
        let mut out = TriangleBvh {
            bounds,
            triangles,
            packets,
            indexed: None,
            nodes,
            narrow,
            root: root.0,
            depth: root.1,
            avx2: avx2_available(),
            prefetch: nodes_bytes + packets_bytes > PREFETCH_BYTES,
            root_boxes: Vec::new(),
        };
        out.root_boxes = out.children_of_root();
        let leaves = match indexed {
            Some(_) => "indexed leaves".to_string(),
            None => format!("{} packets", out.packets.len()),
        };
        crate::phases::mark(&format!(
            "bvh: leaves ({} triangles, depth {}, {binary_nodes} binary nodes, {leaves}, {} 8-wide \
             and {} 4-wide nodes)",
            out.triangles,
            out.depth,
            out.nodes.len(),
            out.narrow.len()
        ));
        (out, slots)
    }

    /// The boxes of the root's children (the tree's bounds when the root is a packet).
    fn children_of_root(&self) -> Vec<[f32; 6]> {
        let root = self.root;
        if root & LEAF != 0 {
            let b = self.bounds;
            vec![[b.min.x, b.max.x, b.min.y, b.max.y, b.min.z, b.max.z]]
        } else if root & NARROW != 0 {
            let n = &self.narrow[(root & !NARROW) as usize];
            (0..4)
                .filter(|&l| n.child[l] != node8::EMPTY)
                .map(|lane| std::array::from_fn(|p| n.planes[p][lane]))
                .collect()
        } else {
            let n = &self.nodes[root as usize];
            (0..WIDTH)
                .filter(|&l| n.child[l] != node8::EMPTY)
                .map(|lane| std::array::from_fn(|p| n.planes[p][lane / 4][lane % 4]))
                .collect()
        }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.triangles
    }

    /// Whether there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.triangles == 0
    }

    /// Bounds of all triangles.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Whether queries use the AVX2 box test (when the CPU has AVX2 and the environment
    /// variable `LUMO_BVH_NO_AVX2` is unset).
    pub fn uses_avx2(&self) -> bool {
        self.avx2
    }

    /// This BVH with the AVX2 box test switched on (when the CPU has it) or off: the two give
    /// identical answers; for tests and measurements.
    #[doc(hidden)]
    pub fn with_avx2(mut self, on: bool) -> TriangleBvh {
        #[cfg(target_arch = "x86_64")]
        {
            self.avx2 = on && std::arch::is_x86_feature_detected!("avx2");
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.avx2 = on && false;
        }
        self
    }

    /// The lanes of a wave whose segments from o over (0, `t_max`) along d meet a box the
    /// root of the tree holds (the tree's bounds when its root is a packet): the rays the
    /// other lanes stand for would have ended at the root. The boxes are tested with the
    /// operations of the traversal's box test (Node8's planes, the directions' reciprocals as
    /// correctly rounded quotients, zero components' NaNs as "no limit"), compiled for the
    /// widest vector instructions the CPU has that suit W lanes, so a lane is left out only
    /// where the traversal would find nothing.
    pub fn meets_lanes<const W: usize>(
        &self,
        (o, d): (&V3s<W>, &V3s<W>),
        t_max: F32s<W>,
        live: Mask<W>,
    ) -> Mask<W> {
        if self.is_empty() || !live.any() {
            return Mask::splat(false);
        }
        let boxes = &self.root_boxes[..];
        crate::lanes::widest!(
            W,
            (boxes: &[[f32; 6]], o: &V3s<W>, d: &V3s<W>, t_max: F32s<W>, live: Mask<W>) => Mask<W>,
            (boxes, o, d, t_max, live),
            meets_here(boxes, (o, d), t_max, live)
        )
    }

    /// Closest hit within (t_min, t_max): the triangle's id and the hit.
    #[inline]
    pub fn intersect(&self, ray: &TriRay, t_min: f32, t_max: f32) -> Option<([u32; 2], TriHit)> {
        if self.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is only set when the CPU has AVX2.
            return unsafe { self.intersect_avx2(ray, t_min, t_max) };
        }
        // SAFETY: SSE2 is part of the x86-64 baseline (and `Sse` is plain glam elsewhere).
        unsafe { self.intersect_with::<Sse>(ray, t_min, t_max) }
    }

    /// [`intersect`](Self::intersect), with the hit triangle's corners as the tree stores
    /// them (read from the packet the hit was found in, not from its mesh).
    #[inline]
    pub fn intersect_corners(
        &self,
        ray: &TriRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<([u32; 2], TriHit, [Vec3; 3])> {
        if self.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is only set when the CPU has AVX2.
            return unsafe { self.intersect_corners_avx2(ray, t_min, t_max) };
        }
        // SAFETY: as in `intersect`.
        unsafe { self.closest_with::<Sse, true>(ray, t_min, t_max) }
    }

    /// Whether any triangle is hit within (t_min, t_max).
    #[inline]
    pub fn occluded(&self, ray: &TriRay, t_min: f32, t_max: f32) -> bool {
        if self.is_empty() {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is only set when the CPU has AVX2.
            return unsafe { self.occluded_avx2(ray, t_min, t_max) };
        }
        // SAFETY: as in `intersect`.
        unsafe { self.occluded_with::<Sse>(ray, t_min, t_max) }
    }

    /// [`TriangleBvh::intersect`] keeping only the hits `accept` takes (given the triangle's id
    /// and the hit): the nearest of them. Surfaces cut away by alpha masks are skipped so within
    /// one traversal, instead of tracing a new ray past each (Embree's filter functions, OptiX's
    /// any-hit programs). With an `accept` that takes everything, the same hit as `intersect`.
    pub fn intersect_accepted(
        &self,
        ray: &TriRay,
        t_min: f32,
        t_max: f32,
        accept: &mut dyn FnMut([u32; 2], &TriHit) -> bool,
    ) -> Option<([u32; 2], TriHit)> {
        if self.is_empty() {
            return None;
        }
        let mut leaf = ClosestAccepted {
            ray,
            t_min,
            accept,
            best: None,
        };
        let mut t_max = t_max;
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is only set when the CPU has AVX2.
            unsafe { self.traverse_avx2::<true>(ray, t_min, &mut t_max, &mut leaf) };
            return leaf.best;
        }
        // SAFETY: SSE2 is part of the x86-64 baseline.
        unsafe { self.traverse::<Sse, true>(ray, t_min, &mut t_max, &mut leaf) };
        leaf.best
    }

    /// Whether any triangle hit within (t_min, t_max) is one `accept` takes (see
    /// [`intersect_accepted`](Self::intersect_accepted)).
    pub fn occluded_accepted(
        &self,
        ray: &TriRay,
        t_min: f32,
        t_max: f32,
        accept: &mut dyn FnMut([u32; 2], &TriHit) -> bool,
    ) -> bool {
        if self.is_empty() {
            return false;
        }
        let mut leaf = AnyAccepted { ray, t_min, accept };
        let mut t_max = t_max;
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is only set when the CPU has AVX2.
            return unsafe { self.traverse_avx2::<false>(ray, t_min, &mut t_max, &mut leaf) };
        }
        // SAFETY: SSE2 is part of the x86-64 baseline.
        unsafe { self.traverse::<Sse, false>(ray, t_min, &mut t_max, &mut leaf) }
    }

    /// The traversal with AVX2 box tests, for the queries with an `accept` function.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn traverse_avx2<const ORDERED: bool>(
        &self,
        r: &TriRay,
        t_min: f32,
        t_max: &mut f32,
        leaf: &mut impl Leaf,
    ) -> bool {
        // SAFETY: this function runs only on CPUs with AVX2.
        unsafe { self.traverse::<Avx2, ORDERED>(r, t_min, t_max, leaf) }
    }

    /// [`TriangleBvh::intersect`] compiled for AVX2 (the whole traversal, so that the box test's
    /// intrinsics and the leaf test inline into one loop).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn intersect_avx2(
        &self,
        ray: &TriRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<([u32; 2], TriHit)> {
        // SAFETY: this function runs only on CPUs with AVX2.
        unsafe { self.intersect_with::<Avx2>(ray, t_min, t_max) }
    }

    /// [`TriangleBvh::intersect_corners`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn intersect_corners_avx2(
        &self,
        ray: &TriRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<([u32; 2], TriHit, [Vec3; 3])> {
        // SAFETY: this function runs only on CPUs with AVX2.
        unsafe { self.closest_with::<Avx2, true>(ray, t_min, t_max) }
    }

    /// [`TriangleBvh::occluded`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn occluded_avx2(&self, ray: &TriRay, t_min: f32, t_max: f32) -> bool {
        // SAFETY: this function runs only on CPUs with AVX2.
        unsafe { self.occluded_with::<Avx2>(ray, t_min, t_max) }
    }

    /// Closest hit with box test `B`.
    ///
    /// # Safety
    /// The CPU must support `B`'s instructions.
    #[inline(always)]
    unsafe fn intersect_with<B: BoxTest>(
        &self,
        ray: &TriRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<([u32; 2], TriHit)> {
        // SAFETY: passed on from the caller.
        unsafe { self.closest_with::<B, false>(ray, t_min, t_max) }.map(|(id, h, _)| (id, h))
    }

    /// The closest hit with box test `B`, with its triangle's corners where `CORNERS` (else
    /// zeros).
    ///
    /// # Safety
    /// The CPU must support `B`'s instructions.
    #[inline(always)]
    unsafe fn closest_with<B: BoxTest, const CORNERS: bool>(
        &self,
        ray: &TriRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<([u32; 2], TriHit, [Vec3; 3])> {
        let mut closest = Closest::<CORNERS> {
            ray,
            t_min,
            best: None,
            found_in: None,
        };
        let mut t_max = t_max;
        // SAFETY: passed on from the caller.
        unsafe { self.traverse::<B, true>(ray, t_min, &mut t_max, &mut closest) };
        let corners = match closest.found_in {
            Some((reference, lane)) if CORNERS => match &self.indexed {
                Some(indexed) => indexed.packet(reference).corners(lane),
                // SAFETY: the build references only packets it made.
                None => unsafe { self.packets.get_unchecked((reference & !LEAF) as usize) }
                    .corners(lane),
            },
            _ => [Vec3::ZERO; 3],
        };
        closest.best.map(|(id, h)| (id, h, corners))
    }

    /// Any hit with box test `B`.
    ///
    /// # Safety
    /// The CPU must support `B`'s instructions.
    #[inline(always)]
    unsafe fn occluded_with<B: BoxTest>(&self, ray: &TriRay, t_min: f32, t_max: f32) -> bool {
        let mut t_max = t_max;
        // Any hit ends the search, so the order of children does not matter.
        // SAFETY: passed on from the caller.
        unsafe { self.traverse::<B, false>(ray, t_min, &mut t_max, &mut AnyHit { ray, t_min }) }
    }

    /// Visits the packets whose boxes the ray meets within (t_min, *t_max), nearest box first
    /// when `ORDERED`; `leaf` shrinks `*t_max` on closer hits and returns `true` to stop (any-hit
    /// queries). Returns whether it was stopped.
    ///
    /// # Safety
    /// The CPU must support `B`'s instructions.
    #[inline(always)]
    unsafe fn traverse<B: BoxTest, const ORDERED: bool>(
        &self,
        r: &TriRay,
        t_min: f32,
        t_max: &mut f32,
        leaf: &mut impl Leaf,
    ) -> bool {
        // A node pushes at most seven children, so 7·depth + 1 entries always suffice.
        // Left uninitialised: only entries below the stack pointer are read, each written first.
        // SAFETY (of the calls): passed on from the caller.
        let br = unsafe { B::ray(r) };
        if r.robust && r.inv.iter().any(|x| x.is_nan()) {
            // A direction with a NaN component meets no triangle (every edge function of the
            // triangle test is then a NaN), but the robust box test, which takes a NaN slab
            // for entered, would enter every child slot, empty ones included.
            return false;
        }
        if self.depth <= INLINE_DEPTH {
            let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); (WIDTH - 1) * INLINE_DEPTH + 1];
            // The common case (no zero direction component; for trees without narrow nodes,
            // a loop without their test) gets its own copies of the loop.
            let s = &mut stack;
            unsafe {
                match (r.robust, self.narrow.is_empty(), self.indexed.is_some()) {
                    (false, true, false) => self.traverse_with::<B, false, false, ORDERED, false>(
                        &br, t_min, t_max, leaf, s,
                    ),
                    (false, false, false) => self.traverse_with::<B, false, true, ORDERED, false>(
                        &br, t_min, t_max, leaf, s,
                    ),
                    (true, _, false) => self
                        .traverse_with::<B, true, true, ORDERED, false>(&br, t_min, t_max, leaf, s),
                    (false, _, true) => self
                        .traverse_with::<B, false, true, ORDERED, true>(&br, t_min, t_max, leaf, s),
                    (true, _, true) => self
                        .traverse_with::<B, true, true, ORDERED, true>(&br, t_min, t_max, leaf, s),
                }
            }
        } else {
            let mut stack = vec![MaybeUninit::<(u32, f32)>::uninit(); (WIDTH - 1) * self.depth + 1];
            let s = &mut stack;
            unsafe {
                if self.indexed.is_some() {
                    self.traverse_with::<B, true, true, ORDERED, true>(&br, t_min, t_max, leaf, s)
                } else {
                    self.traverse_with::<B, true, true, ORDERED, false>(&br, t_min, t_max, leaf, s)
                }
            }
        }
    }

    /// Asks the memory system for node or packet `reference` (a child pushed for later), all
    /// its cache lines.
    #[inline(always)]
    fn prefetch(&self, reference: u32) {
        let (p, lines) = if reference & LEAF != 0 {
            if let Some(indexed) = &self.indexed {
                // The leaf's slots: what its triangles' indices are found from.
                let first = (reference & !LEAF) >> 2;
                (
                    indexed
                        .slots
                        .as_ptr()
                        .wrapping_add(first as usize)
                        .cast::<u8>(),
                    2,
                )
            } else {
                let p = self
                    .packets
                    .as_ptr()
                    .wrapping_add((reference & !LEAF) as usize);
                (p.cast::<u8>(), std::mem::size_of::<Packet>().div_ceil(64))
            }
        } else if reference & NARROW != 0 {
            let p = self
                .narrow
                .as_ptr()
                .wrapping_add((reference & !NARROW) as usize);
            (p.cast::<u8>(), std::mem::size_of::<Node4>() / 64)
        } else {
            let p = self.nodes.as_ptr().wrapping_add(reference as usize);
            (p.cast::<u8>(), std::mem::size_of::<Node8>() / 64)
        };
        for line in 0..lines {
            prefetch_line(p.wrapping_add(64 * line));
        }
    }

    /// # Safety
    /// The CPU must support `B`'s instructions.
    #[inline(always)]
    unsafe fn traverse_with<
        B: BoxTest,
        const ROBUST: bool,
        const NARROW_NODES: bool,
        const ORDERED: bool,
        const INDEXED: bool,
    >(
        &self,
        r: &B::Ray,
        t_min: f32,
        t_max: &mut f32,
        leaf: &mut impl Leaf,
        stack: &mut [MaybeUninit<(u32, f32)>],
    ) -> bool {
        let mut sp = 0usize;
        debug_assert!(stack.len() > (WIDTH - 1) * self.depth);
        macro_rules! push {
            ($entry:expr) => {{
                // SAFETY: each level of the path from the root to the current node has pushed at
                // most WIDTH - 1 entries, so `sp` < (WIDTH - 1)·depth + 1 ≤ `stack.len()`.
                let entry: (u32, f32) = $entry;
                unsafe { *stack.get_unchecked_mut(sp) = MaybeUninit::new(entry) };
                sp += 1;
            }};
        }
        // Child `c` of a node (`$node`: its references) and its entry distance; `c` is a bit
        // of the node's hit mask, which has a bit per child lane (4 or 8), no more.
        macro_rules! kid {
            ($node:expr, $near:expr, $c:expr) => {{
                debug_assert!($c < $node.len() && $c < WIDTH);
                // SAFETY: `$c` < the number of lanes, the length of both arrays.
                unsafe { (*$node.get_unchecked($c), *$near.get_unchecked($c)) }
            }};
        }
        let mut cur = self.root;
        loop {
            if cur & LEAF != 0 {
                let stop = if INDEXED {
                    // SAFETY: `INDEXED` traversals run on trees with indexed leaves only.
                    let indexed = unsafe { self.indexed.as_deref().unwrap_unchecked() };
                    leaf.visit(&indexed.packet(cur), cur, t_max)
                } else {
                    // SAFETY: the build references only packets it made.
                    let packet = unsafe { self.packets.get_unchecked((cur & !LEAF) as usize) };
                    leaf.visit(packet, cur, t_max)
                };
                if stop {
                    return true;
                }
            } else {
                // SAFETY: the build references only nodes it made; the box tests' safety is
                // passed on from the caller.
                let (near, mut mask, node) = unsafe {
                    if NARROW_NODES && cur & NARROW != 0 {
                        let n = self.narrow.get_unchecked((cur & !NARROW) as usize);
                        let (near, mask) = B::hit4::<ROBUST>(n, r, t_min, *t_max);
                        (near, mask, &n.child[..])
                    } else {
                        let n = self.nodes.get_unchecked(cur as usize);
                        let (near, mask) = B::hit::<ROBUST>(n, r, t_min, *t_max);
                        (near, mask, &n.child[..])
                    }
                };
                if self.prefetch {
                    // Every child hit, the nearest included, is requested before they are
                    // ordered: its lines arrive while the others are sorted and pushed.
                    let mut m = mask;
                    while m != 0 {
                        let c = m.trailing_zeros() as usize;
                        m &= m - 1;
                        self.prefetch(kid!(node, near, c).0);
                    }
                }
                if mask != 0 {
                    let a = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        cur = kid!(node, near, a).0;
                        continue;
                    }
                    if !ORDERED {
                        // Push all but the first, in any order.
                        while mask != 0 {
                            let c = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            let k = kid!(node, near, c);
                            push!(k);
                        }
                        cur = kid!(node, near, a).0;
                        continue;
                    }
                    let b = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        let (ka, kb) = (kid!(node, near, a), kid!(node, near, b));
                        let (first, second) = if ka.1 <= kb.1 { (ka, kb) } else { (kb, ka) };
                        push!(second);
                        cur = first.0;
                        continue;
                    }
                    // Three or more children: push all but the nearest, farthest first.
                    let mut hits = [(0u32, 0.0f32); WIDTH];
                    hits[0] = kid!(node, near, a);
                    hits[1] = kid!(node, near, b);
                    let mut len = 2;
                    while mask != 0 {
                        let c = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        hits[len] = kid!(node, near, c);
                        len += 1;
                    }
                    for i in 1..len {
                        let mut j = i;
                        while j > 0 && hits[j - 1].1 < hits[j].1 {
                            hits.swap(j - 1, j);
                            j -= 1;
                        }
                    }
                    for &h in &hits[..len - 1] {
                        push!(h);
                    }
                    cur = hits[len - 1].0;
                    continue;
                }
            }
            // SAFETY: entries below `sp` were all written by `push!`.
            match unsafe { pop_nearer(stack, &mut sp, *t_max) } {
                Some(next) => cur = next,
                None => return false,
            }
        }
    }
}

/// The `live` lanes whose segments meet one of `boxes` (`[lo x, hi x, lo y, hi y, lo z, hi z]`
/// each), by the box test's operations ([`TriangleBvh::meets_lanes`]).
#[inline(always)]
fn meets_here<const W: usize>(
    boxes: &[[f32; 6]],
    (o, d): (&V3s<W>, &V3s<W>),
    t_max: F32s<W>,
    live: Mask<W>,
) -> Mask<W> {
    let one = F32s::splat(1.0);
    let rays = SlabRays {
        org: [o.x, o.y, o.z],
        inv: [one / d.x, one / d.y, one / d.z],
    };
    let zero = F32s::splat(0.0);
    let meets = if ((d.x.eq(zero) | d.y.eq(zero) | d.z.eq(zero)) & live).any() {
        rays.meets::<true>(boxes, t_max)
    } else {
        rays.meets::<false>(boxes, t_max)
    };
    meets & live
}

/// A wave's rays as [`meets_here`] tests them against boxes: origins and the directions'
/// reciprocals, per axis.
#[repr(C, align(64))]
struct SlabRays<const W: usize> {
    org: [F32s<W>; 3],
    inv: [F32s<W>; 3],
}

impl<const W: usize> SlabRays<W> {
    /// The lanes whose segments over (0, `t_max`) meet one of `boxes` (see
    /// [`slab`](Self::slab) for `ROBUST`).
    #[inline(always)]
    fn meets<const ROBUST: bool>(&self, boxes: &[[f32; 6]], t_max: F32s<W>) -> Mask<W> {
        let mut meets = Mask::splat(false);
        for b in boxes {
            let (mut near, mut far) = (F32s::splat(0.0), t_max);
            for axis in 0..3 {
                let (entry, exit) = self.slab::<ROBUST>(b, axis);
                near = near.max(entry);
                far = far.min(exit);
            }
            meets = meets | near.le(far * F32s::splat(node8::FAR_SCALE));
        }
        meets
    }

    /// The entry and exit distances of box `b`'s slab of `axis`, as the traversal's box test
    /// computes them. With `ROBUST` (a zero direction component in some lane) the entry is
    /// picked by the direction's sign and the NaNs of 0·∞ become "no limit"; without, no NaN
    /// arises and the entry and exit are the two distances' min and max (the ones the sign
    /// picks; where they differ it is only in the sign of a zero, which no compare sees).
    #[inline(always)]
    fn slab<const ROBUST: bool>(&self, b: &[f32; 6], axis: usize) -> (F32s<W>, F32s<W>) {
        let (org, inv) = (self.org[axis], self.inv[axis]);
        let lo = (F32s::splat(b[2 * axis]) - org) * inv;
        let hi = (F32s::splat(b[2 * axis + 1]) - org) * inv;
        if !ROBUST {
            return (lo.min(hi), lo.max(hi));
        }
        let negative = inv.lt(F32s::splat(0.0));
        let (entry, exit) = (
            F32s::select(negative, hi, lo),
            F32s::select(negative, lo, hi),
        );
        (
            F32s::select(entry.is_nan(), F32s::splat(f32::NEG_INFINITY), entry),
            F32s::select(exit.is_nan(), F32s::splat(f32::INFINITY), exit),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::geometry::triangle::{self, RayShear};
    use crate::geometry::triangle_source::SourcePart;
    use crate::math::Affine3A;
    use crate::sampler::test_lcg as lcg;

    fn bvh_of(tris: &[[Vec3; 3]]) -> TriangleBvh {
        let corners = tris.iter().map(|t| t.map(Vec3A::from)).collect();
        TriangleBvh::new(corners, (0..tris.len() as u32).map(|i| [7, i]).collect())
    }

    /// The closest hit by testing every triangle with the scalar test (the oracle).
    fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, t_max: f32) -> Option<(u32, TriHit)> {
        let shear = RayShear::new(o, d);
        let mut best: Option<(u32, TriHit)> = None;
        for (i, [a, b, c]) in tris.iter().enumerate() {
            if let Some(h) =
                triangle::intersect(&shear, *a, *b, *c, 0.0, best.map_or(t_max, |b| b.1.t))
            {
                best = Some((i as u32, h));
            }
        }
        best
    }

    /// `meets_lanes` leaves out only lanes whose segments find nothing in the tree (closest
    /// and any hit), never an idle lane, and keeps some lanes that do find nothing (it culls):
    /// on trees whose root is a node and a packet, with segments of every length and
    /// directions with zero components.
    /// `count` triangles about centres in [−1, 1]³, corners up to `size` / 2 from them.
    fn random_triangles(s: &mut u64, count: usize, size: f32) -> Vec<[Vec3; 3]> {
        (0..count)
            .map(|_| {
                let c = Vec3::new(lcg(s), lcg(s), lcg(s)) * 2.0 - 1.0;
                [0, 1, 2].map(|_| c + (Vec3::new(lcg(s), lcg(s), lcg(s)) - 0.5) * size)
            })
            .collect()
    }

    /// A tree with indexed leaves gives the answers of the tree with packets over the same
    /// triangles, bit for bit, for every kind of query: here over a source of three parts (one
    /// placed by a rotation, scale and translation; coincident triangles among them, whose ties
    /// go to the lowest id), taken through a permutation as a world-space set takes its own.
    #[test]
    fn indexed_leaves_answer_as_packets_do() {
        let mut s = 0x5eed_u64;
        let mut part = |first: u32, tag: u32, count: usize, to_world: Option<Affine3A>| {
            let positions: Vec<Vec3> = (0..count / 2 + 3)
                .map(|_| Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 2.0 - 1.0)
                .collect();
            let n = positions.len() as u32;
            let mut triangles: Vec<[u32; 3]> = (0..count)
                .map(|t| {
                    // Mostly neighbours in the vertex list (small triangles), a few long ones.
                    let a = (t as u32 * 7 + 1) % n;
                    let spread = if t % 50 == 0 { n / 2 } else { 3 };
                    [a, (a + 1) % n, (a + 2 + t as u32 % spread) % n]
                })
                .filter(|[a, b, c]| a != b && b != c && a != c)
                .collect();
            // Coincident copies: hits at equal distances, told apart by id.
            let copies: Vec<[u32; 3]> = triangles.iter().step_by(97).copied().collect();
            triangles.extend(copies);
            SourcePart {
                first,
                tag,
                positions: std::sync::Arc::new(positions),
                triangles: std::sync::Arc::new(triangles),
                to_world,
            }
        };
        let a = part(0, 3, 9_000, None);
        let placed = Affine3A::from_scale_rotation_translation(
            Vec3::new(0.5, 1.5, 1.0),
            glam::Quat::from_rotation_y(0.7),
            Vec3::new(0.3, -0.2, 0.1),
        );
        let b = part(a.triangles.len() as u32, 5, 9_000, Some(placed));
        let c = part(
            (a.triangles.len() + b.triangles.len()) as u32,
            9,
            2_000,
            None,
        );
        let source = TriangleSource::new(vec![a, b, c]);
        let n = source.len();
        assert!(
            n > COMPACT_TRIANGLES,
            "narrow nodes should be exercised too"
        );
        // A permutation of the source (7919 is prime, and n is not a multiple of it).
        assert!(!n.is_multiple_of(7919));
        let index = |j: usize| ((j * 7919) % n) as u32;
        let packets = TriangleBvh::build(
            n,
            |j| source.corners(index(j)),
            |j| source.id(index(j)),
            |_, _| {},
        );
        let indexed = TriangleBvh::build_indexed(n, source.clone(), index);
        assert!(indexed.indexed.is_some() && indexed.packets.is_empty());
        assert!(packets.indexed.is_none());
        assert_eq!(
            (indexed.len(), indexed.bounds()),
            (packets.len(), packets.bounds())
        );
        let bits = |h: &Option<([u32; 2], TriHit)>| {
            h.map(|(id, h)| (id, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits()))
        };
        let odd = |id: [u32; 2], _: &TriHit| id[1] % 2 == 1;
        let mut hits = 0;
        for k in 0..3_000 {
            let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 3.0 - 1.5;
            let mut d = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) - 0.5;
            if k % 10 == 0 {
                d.x = 0.0; // the robust box test
            }
            let ray = TriRay::new(o, d);
            for tree in [&packets, &indexed] {
                assert_eq!(tree.uses_avx2(), packets.uses_avx2());
            }
            let p = packets.intersect(&ray, 0.0, f32::INFINITY);
            let i = indexed.intersect(&ray, 0.0, f32::INFINITY);
            assert_eq!(bits(&p), bits(&i), "ray {o:?} {d:?}");
            hits += usize::from(p.is_some());
            let pc = packets.intersect_corners(&ray, 0.0, f32::INFINITY);
            let ic = indexed.intersect_corners(&ray, 0.0, f32::INFINITY);
            assert_eq!(pc.map(|x| (x.0, x.2)), ic.map(|x| (x.0, x.2)));
            if let Some((_, h)) = p {
                let t_max = h.t * 0.75;
                assert_eq!(
                    packets.occluded(&ray, 0.0, t_max),
                    indexed.occluded(&ray, 0.0, t_max)
                );
            }
            let pa = packets.intersect_accepted(&ray, 0.0, f32::INFINITY, &mut { odd });
            let ia = indexed.intersect_accepted(&ray, 0.0, f32::INFINITY, &mut { odd });
            assert_eq!(bits(&pa), bits(&ia));
            assert_eq!(
                packets.occluded_accepted(&ray, 0.0, 2.0, &mut { odd }),
                indexed.occluded_accepted(&ray, 0.0, 2.0, &mut { odd })
            );
        }
        assert!(hits > 1_000, "only {hits} hits");
    }

    /// The leaves found from their first slots' bits are the leaves a left-first walk of the
    /// binary tree meets, in its order, with the walk's packet numbers: on sets of 1 to 5,000
    /// triangles, some with coinciding centroids (split by index) and some large enough to be
    /// built in parallel.
    #[test]
    fn leaves_from_their_first_slots_are_the_walks_leaves() {
        let mut s = 11;
        for count in [1, 2, 5, 63, 64, 65, 1000, 5000, 40_000] {
            let mut tris = random_triangles(&mut s, count, 0.05);
            let first = tris[0];
            tris[count / 2..]
                .iter_mut()
                .take(7)
                .for_each(|t| *t = first);
            let boxes: Vec<Aabb> = tris
                .iter()
                .map(|t| Aabb {
                    min: t[0].min(t[1]).min(t[2]),
                    max: t[0].max(t[1]).max(t[2]),
                })
                .collect();
            let bin = Bvh::build_transient(count, |i| boxes[i], LeafCost::PACKET4);
            let (mut walk, mut packet_of) = (Vec::new(), vec![None; bin.nodes.len()]);
            let mut stack = vec![0usize];
            while let Some(i) = stack.pop() {
                let n = bin.nodes[i];
                if n.count() > 0 {
                    packet_of[i] = Some(walk.len() as u32);
                    walk.push((n.first() as usize, n.count() as usize));
                } else {
                    stack.extend([n.first() as usize + 1, n.first() as usize]);
                }
            }
            let starts = LeafStarts::of(&bin.nodes, bin.prims.len());
            let leaves = starts.leaves(bin.prims.len());
            let found: Vec<_> = (0..leaves.len() + 1).map(|k| leaves.get(k)).collect();
            let expected: Vec<_> = walk.iter().copied().map(Some).chain([None]).collect();
            assert_eq!(found, expected, "{count} triangles");
            for (n, packet) in bin.nodes.iter().zip(&packet_of) {
                if let Some(p) = packet {
                    assert_eq!(starts.packet(n.first() as usize), *p, "{count} triangles");
                }
            }
        }
    }

    /// Every constant of a ray prepared in lanes, bit for bit as [`TriRay::new`] prepares it
    /// alone: on random directions and on those whose dominant axis is a tie, with zero and
    /// negative-zero components, infinite and NaN components, at W = 16, 8 and 4.
    #[test]
    fn rays_prepared_in_lanes_are_the_rays_prepared_alone() {
        fn bits(r: &TriRay) -> Vec<u32> {
            let mut b: Vec<u32> = r.org.iter().chain(&r.inv).map(|x| x.to_bits()).collect();
            b.extend([r.negative, u32::from(r.robust)]);
            b.extend(r.k.map(u32::from));
            for v in r.org_k.iter().chain(&r.shear) {
                b.extend(v.to_array().map(f32::to_bits));
            }
            b
        }
        fn check<const W: usize>(rays: &[(Vec3, Vec3)]) {
            for chunk in rays.chunks(W) {
                let o = V3s::<W>::from_fn(|i| chunk[i % chunk.len()].0);
                let d = V3s::<W>::from_fn(|i| chunk[i % chunk.len()].1);
                let lanes = TriRayLanes::new(&o, &d);
                for i in 0..W {
                    let (o, d) = chunk[i % chunk.len()];
                    assert_eq!(bits(&lanes.lane(i)), bits(&TriRay::new(o, d)), "{o} {d}");
                }
            }
        }
        let mut s = 7u64;
        let special = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            f32::INFINITY,
            f32::NAN,
            1e-40,
            -3e38,
        ];
        let mut rays: Vec<(Vec3, Vec3)> = (0..4096)
            .map(|_| {
                let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 4.0 - 2.0;
                let d = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 2.0 - 1.0;
                (o, d)
            })
            .collect();
        for &x in &special {
            for &y in &special {
                for &z in &special {
                    rays.push((Vec3::new(0.25, -1.5, 3.0), Vec3::new(x, y, z)));
                }
            }
        }
        check::<16>(&rays);
        check::<8>(&rays);
        check::<4>(&rays);
    }

    #[test]
    fn rays_with_a_nan_direction_find_nothing() {
        // Trees with empty child slots (counts that leave nodes part full) and one packet.
        let mut s = 29u64;
        for count in [1usize, 9, 300] {
            let bvh = bvh_of(&random_triangles(&mut s, count, 1.0));
            for d in [
                Vec3::new(f32::NAN, 0.0, 1.0),
                Vec3::new(1.0, f32::NAN, 0.0),
                Vec3::new(0.0, 0.0, f32::NAN),
                Vec3::splat(f32::NAN),
            ] {
                let ray = TriRay::new(Vec3::new(0.0, 0.0, -3.0), d);
                assert!(bvh.intersect(&ray, 0.0, f32::INFINITY).is_none(), "{d:?}");
                assert!(bvh.intersect_corners(&ray, 0.0, f32::INFINITY).is_none());
                assert!(!bvh.occluded(&ray, 0.0, f32::INFINITY), "{d:?}");
            }
        }
    }

    #[test]
    fn lanes_left_out_at_the_root_find_nothing() {
        let mut s = 17u64;
        for count in [3usize, 40, 2000] {
            let size = if count < 10 { 2.0 } else { 0.3 };
            let bvh = bvh_of(&random_triangles(&mut s, count, size));
            let (mut culled, mut entered) = (0, 0);
            for round in 0..400 {
                let o = V3s::<16>::from_fn(|_| {
                    Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 6.0 - 3.0
                });
                let d = V3s::<16>::from_fn(|i| {
                    let d = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) - 0.5;
                    // Some directions along a plane or an axis.
                    match (round + i) % 7 {
                        0 => Vec3::new(d.x, 0.0, d.z),
                        1 => Vec3::new(0.0, 0.0, d.z),
                        _ => d,
                    }
                });
                let t_max = F32s::<16>::from_fn(|i| {
                    if i % 3 == 0 {
                        f32::INFINITY
                    } else {
                        lcg(&mut s) * 4.0
                    }
                });
                let live = Mask::<16>::from_bools(&std::array::from_fn(|i| i % 5 != 2));
                let meets = bvh.meets_lanes((&o, &d), t_max, live);
                for i in 0..16 {
                    assert!(live.lane(i) || !meets.lane(i), "idle lane {i} kept");
                    if !live.lane(i) || meets.lane(i) {
                        entered += usize::from(live.lane(i));
                        continue;
                    }
                    culled += 1;
                    let r = TriRay::new(o.lane(i), d.lane(i));
                    assert!(bvh.intersect(&r, 0.0, t_max[i]).is_none());
                    assert!(!bvh.occluded(&r, 0.0, t_max[i]));
                }
            }
            assert!(
                culled > 100 && entered > 100,
                "{culled} culled, {entered} entered"
            );
        }
    }

    fn check(bvh: &TriangleBvh, tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> bool {
        let fast = bvh.intersect(&TriRay::new(o, d), 0.0, f32::INFINITY);
        // The query that also gives the hit triangle's corners finds the same hit, and the
        // corners are that triangle's, bit for bit.
        let with_corners = bvh.intersect_corners(&TriRay::new(o, d), 0.0, f32::INFINITY);
        let bits = |h: &TriHit| (h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits());
        assert_eq!(
            with_corners.map(|(id, h, _)| (id, bits(&h))),
            fast.map(|(id, h)| (id, bits(&h))),
            "ray {o} {d}"
        );
        if let Some((id, _, corners)) = with_corners {
            let want = tris[id[1] as usize].map(|c| c.to_array().map(f32::to_bits));
            assert_eq!(
                corners.map(|c| c.to_array().map(f32::to_bits)),
                want,
                "ray {o} {d}"
            );
        }
        let slow = brute(tris, o, d, f32::INFINITY);
        match (fast, slow) {
            (Some((id, f)), Some((i, s))) => {
                assert_eq!(id[0], 7);
                if id[1] == i {
                    // The same triangle: bit-identical results (the same arithmetic per lane).
                    assert_eq!(
                        (f.t.to_bits(), f.b1.to_bits(), f.b2.to_bits()),
                        (s.t.to_bits(), s.b1.to_bits(), s.b2.to_bits()),
                        "ray {o} {d}"
                    );
                } else {
                    // A tie at a shared edge or vertex may name either neighbour; each
                    // neighbour's distance is computed from its own corners.
                    assert!(
                        (f.t - s.t).abs() <= 1e-6 * s.t.abs(),
                        "ray {o} {d}: {f:?} vs {s:?} (triangles {} and {i})",
                        id[1]
                    );
                }
            }
            (None, None) => {}
            (f, s) => panic!("ray {o} {d}: BVH {f:?}, brute force {s:?}"),
        }
        let occluded = bvh.occluded(&TriRay::new(o, d), 0.0, f32::INFINITY);
        assert_eq!(
            occluded,
            slow.is_some(),
            "any-hit disagrees for ray {o} {d}"
        );
        slow.is_some()
    }

    /// Random triangle soup and random rays: the 8-wide BVH answers exactly as the oracle.
    #[test]
    fn random_soup_matches_brute_force() {
        let mut s = 11u64;
        // 20,000 triangles: a compact tree, with narrow nodes (`COMPACT_TRIANGLES`).
        for n in [1usize, 3, 4, 5, 17, 3000, 20_000] {
            let tris: Vec<[Vec3; 3]> = (0..n)
                .map(|_| {
                    let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 4.0;
                    [0; 3].map(|_| c + Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 0.3)
                })
                .collect();
            let bvh = bvh_of(&tris);
            assert_eq!(bvh.len(), n);
            assert_eq!(!bvh.narrow.is_empty(), n >= COMPACT_TRIANGLES);
            let mut hits = 0;
            for k in 0..2000 {
                let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 6.0 - 1.0;
                // Half the rays aim at a triangle's centroid so that small sets are hit too.
                let d = if k % 2 == 0 {
                    Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5)
                } else {
                    let [a, b, c] = tris[(lcg(&mut s) * n as f32) as usize % n];
                    (a + b + c) / 3.0 - o
                };
                hits += check(&bvh, &tris, o, d) as u32;
            }
            assert!(hits > 0, "{n} triangles: the test must exercise hits");
        }
    }

    /// Traversals that skip rejected hits (alpha masks) find, on both box-test paths, the
    /// nearest hit the predicate accepts, as testing every triangle does, and report
    /// occlusion exactly when there is one; with a predicate that takes everything they equal
    /// the plain queries bit for bit. Each triangle is offered at most once per packet.
    #[test]
    fn accepted_hits_match_brute_force() {
        let mut s = 23u64;
        // Dense soups, so that most rays meet several triangles (layers of leaves).
        for n in [1usize, 3, 5, 40, 3000, 20_000] {
            let tris: Vec<[Vec3; 3]> = (0..n)
                .map(|_| {
                    let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 2.0;
                    [0; 3].map(|_| c + Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 0.6)
                })
                .collect();
            // Rejects about half the triangles, by a hash of the triangle and of the distance
            // (as a blended surface's hash depends on the hit).
            let takes = |i: u32, t: f32| (i.wrapping_mul(0x9e37_79b9) ^ t.to_bits()) % 7 < 4;
            for avx2 in [false, true] {
                if avx2 && !avx2_available() {
                    continue;
                }
                let bvh = bvh_of(&tris).with_avx2(avx2);
                let (mut hits, mut skipped) = (0, 0);
                for k in 0..1500 {
                    let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 4.0 - 1.0;
                    let d = if k % 2 == 0 {
                        Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5)
                    } else {
                        let [a, b, c] = tris[(lcg(&mut s) * n as f32) as usize % n];
                        (a + b + c) / 3.0 - o
                    };
                    let ray = TriRay::new(o, d);
                    // The oracle: every triangle, the nearest accepted hit.
                    let shear = RayShear::new(o, d);
                    let mut slow: Option<(u32, TriHit)> = None;
                    for (i, [a, b, c]) in tris.iter().enumerate() {
                        let t_max = slow.map_or(f32::INFINITY, |b| b.1.t);
                        if let Some(h) = triangle::intersect(&shear, *a, *b, *c, 0.0, t_max) {
                            if takes(i as u32, h.t) {
                                slow = Some((i as u32, h));
                            }
                        }
                    }
                    let mut offered = std::collections::HashMap::new();
                    let fast = bvh.intersect_accepted(&ray, 0.0, f32::INFINITY, &mut |id, h| {
                        *offered.entry((id[1], h.t.to_bits())).or_insert(0u32) += 1;
                        takes(id[1], h.t)
                    });
                    skipped += offered
                        .keys()
                        .filter(|(i, t)| !takes(*i, f32::from_bits(*t)))
                        .count();
                    assert!(
                        offered.values().all(|&c| c == 1),
                        "{n}: a hit offered twice"
                    );
                    match (fast, slow) {
                        (Some((id, f)), Some((i, h))) => {
                            hits += 1;
                            assert_eq!(id[0], 7);
                            if id[1] == i {
                                assert_eq!(
                                    (f.t.to_bits(), f.b1.to_bits()),
                                    (h.t.to_bits(), h.b1.to_bits())
                                );
                            } else {
                                // A tie at a shared edge, as in `check`.
                                assert!((f.t - h.t).abs() <= 1e-6 * h.t.abs(), "{n}: {f:?} {h:?}");
                            }
                        }
                        (None, None) => {}
                        (f, h) => panic!("{n} triangles, ray {o} {d}: {f:?} vs {h:?}"),
                    }
                    let any = bvh.occluded_accepted(&ray, 0.0, f32::INFINITY, &mut |id, h| {
                        takes(id[1], h.t)
                    });
                    assert_eq!(any, slow.is_some(), "{n}: occlusion of ray {o} {d}");
                    // With everything accepted: the plain queries' answers.
                    let all = bvh.intersect_accepted(&ray, 0.0, f32::INFINITY, &mut |_, _| true);
                    let plain = bvh.intersect(&ray, 0.0, f32::INFINITY);
                    let key = |h: Option<([u32; 2], TriHit)>| {
                        h.map(|(id, h)| (id, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits()))
                    };
                    assert_eq!(key(all), key(plain));
                    assert_eq!(
                        bvh.occluded_accepted(&ray, 0.0, f32::INFINITY, &mut |_, _| true),
                        bvh.occluded(&ray, 0.0, f32::INFINITY)
                    );
                }
                if n >= 40 {
                    assert!(
                        hits > 100 && skipped > 100,
                        "{n}: {hits} hits, {skipped} skipped"
                    );
                }
            }
        }
    }

    /// The same soup and rays at tiny and huge scales (1e-15 to 1e15): the box and triangle
    /// tests stay in range and agree with the oracle.
    #[test]
    fn tiny_and_huge_scales_match_brute_force() {
        for scale in [1e-15f32, 1e-6, 1e6, 1e15] {
            let mut s = 21u64;
            let tris: Vec<[Vec3; 3]> = (0..500)
                .map(|_| {
                    let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 4.0;
                    [0; 3].map(|_| {
                        (c + Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 0.5) * scale
                    })
                })
                .collect();
            let bvh = bvh_of(&tris);
            let mut hits = 0;
            for k in 0..1000 {
                let o = (Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 6.0 - 1.0) * scale;
                let [a, b, c] = tris[k % tris.len()];
                let d = (a + b + c) / 3.0 - o;
                hits += check(&bvh, &tris, o, d) as u32;
            }
            assert!(
                hits > 900,
                "scale {scale}: {hits} of 1000 rays aimed at centroids hit"
            );
        }
    }

    /// Axis-aligned grids of squares hit by axis-parallel rays lying in box faces and aimed at
    /// shared edges and corners: zero direction components (no 0·∞ in the box test), flat boxes
    /// and the f64 edge fallback in SIMD lanes, all against the oracle; and no ray aimed at the
    /// inside of the grid slips through it.
    #[test]
    fn axis_parallel_rays_on_a_grid_match_brute_force() {
        let n = 12;
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (i as f32, j as f32);
                let p = |a: f32, b: f32| Vec3::new(a, b, 0.0);
                tris.push([p(x, y), p(x + 1.0, y), p(x + 1.0, y + 1.0)]);
                tris.push([p(x, y), p(x + 1.0, y + 1.0), p(x, y + 1.0)]);
            }
        }
        let bvh = bvh_of(&tris);
        let mut s = 5u64;
        for k in 0..4000 {
            // Targets on lattice points, edges and diagonals (all exactly representable).
            let target = Vec3::new(
                (lcg(&mut s) * 24.0).floor() * 0.5,
                (lcg(&mut s) * 24.0).floor() * 0.5,
                0.0,
            );
            let (o, d) = match k % 4 {
                0 => (target + Vec3::Z * 3.0, Vec3::new(0.0, 0.0, -1.0)),
                1 => (target - Vec3::Z * 2.0, Vec3::new(0.0, -0.0, 1.0)),
                2 => (target + Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.5, -1.0)),
                // In the grid's plane: edge-on, never a hit.
                _ => (Vec3::new(-1.0, target.y, 0.0), Vec3::X),
            };
            let hit = check(&bvh, &tris, o, d);
            let p = o + d * (-o.z / d.z);
            let interior = d.z != 0.0 && p.x > 0.0 && p.y > 0.0 && p.x < n as f32 && p.y < n as f32;
            if interior {
                assert!(hit, "ray {o} {d} slipped through the grid at {p}");
            }
        }
    }

    /// From inside a closed icosphere every ray hits it (watertightness), including rays along
    /// the axes and through vertices.
    #[test]
    fn rays_from_inside_a_closed_mesh_always_hit() {
        let (positions, triangles) = super::super::mesh::icosphere(3);
        let tris: Vec<[Vec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| positions[i as usize]))
            .collect();
        let bvh = bvh_of(&tris);
        let mut s = 9u64;
        let mut dirs: Vec<Vec3> = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        dirs.extend(positions.iter().copied());
        dirs.extend(
            (0..3000).map(|_| Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5)),
        );
        for o in [Vec3::ZERO, Vec3::new(0.1, -0.2, 0.05)] {
            for &d in &dirs {
                assert!(
                    check(&bvh, &tris, o, d),
                    "ray {o} {d} escaped the closed sphere"
                );
            }
        }
    }

    /// The AVX2 box test and the SSE fallback give identical answers (the same triangle, bit
    /// for bit the same hit, the same any-hit result) on many random rays, including rays with
    /// zero direction components (the robust box test), on a soup and on a closed mesh.
    #[test]
    fn avx2_and_fallback_paths_agree() {
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        if !avx2 {
            eprintln!("SKIPPED: this CPU has no AVX2; only the fallback path can run");
            return;
        }
        let mut s = 17u64;
        let soup: Vec<[Vec3; 3]> = (0..5000)
            .map(|_| {
                let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 4.0;
                [0; 3].map(|_| c + Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 0.3)
            })
            .collect();
        let (positions, triangles) = super::super::mesh::icosphere(5);
        let sphere: Vec<[Vec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| positions[i as usize] * 2.0 + Vec3::splat(2.0)))
            .collect();
        for tris in [soup, sphere] {
            let fast = bvh_of(&tris).with_avx2(true);
            let slow = fast.clone().with_avx2(false);
            assert!(fast.uses_avx2() && !slow.uses_avx2());
            let mut hits = 0;
            for k in 0..100_000 {
                let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 8.0 - 2.0;
                let mut d = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
                if k % 7 == 0 {
                    d[k % 3] = 0.0;
                }
                if k % 11 == 0 {
                    d[(k + 1) % 3] = 0.0;
                }
                let t_max = if k % 5 == 0 { 3.0 } else { f32::INFINITY };
                let r = TriRay::new(o, d);
                let a = fast.intersect(&r, 0.0, t_max);
                let b = slow.intersect(&r, 0.0, t_max);
                let bits = |h: Option<([u32; 2], TriHit)>| {
                    h.map(|(id, h)| (id, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits()))
                };
                assert_eq!(bits(a), bits(b), "ray {o} {d}");
                assert_eq!(fast.occluded(&r, 0.0, t_max), slow.occluded(&r, 0.0, t_max));
                hits += a.is_some() as u32;
            }
            assert!(hits > 10_000, "{hits} hits: the test must exercise hits");
        }
    }

    #[test]
    fn empty_set_hits_nothing() {
        let bvh = bvh_of(&[]);
        assert!(bvh.is_empty());
        assert!(bvh
            .intersect(&TriRay::new(Vec3::ZERO, Vec3::X), 0.0, f32::INFINITY)
            .is_none());
        assert!(!bvh.occluded(&TriRay::new(Vec3::ZERO, Vec3::X), 0.0, f32::INFINITY));
    }
}
