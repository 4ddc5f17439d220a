//! A bounding volume hierarchy built with the binned surface area heuristic (Wald 2007,
//! "On fast Construction of SAH-based Bounding Volume Hierarchies"), stored as a flat array of
//! 32-byte, 32-byte-aligned nodes with siblings adjacent, traversed front to back with a small
//! stack.
//!
//! The BVH knows only boxes: primitives are indices, and the caller supplies the leaf test, so
//! the same structure serves triangles inside a mesh and instances at the top level. Leaves name
//! *slots* (positions in [`Bvh::prims`]), so a caller that copies its primitive data into slot
//! order (as the triangle sets do) reads it sequentially without an index indirection.
//!
//! The builder moves 32-byte primitive records (box + index, Embree's `PrimRef`) and partitions
//! them in place, so it reads memory sequentially; each node's box and centroid box come from its
//! parent's bins. Large builds bin big nodes in parallel chunks and run the two halves of every
//! big node in parallel (`rayon::join`); the result is identical to the sequential build.

use std::mem::MaybeUninit;

use glam::{Vec3A, Vec4};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::math::{Aabb, Vec3};

/// One node: a box and either two children (`count == 0`, children at `first` and `first + 1`)
/// or a leaf of `count` slots starting at `first`. The two integers ride in the `w` lanes of the
/// corners so one node is two aligned 16-byte loads.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
pub struct Node {
    /// Lower corner in `xyz`; `w` holds the bits of `first`.
    lo: Vec4,
    /// Upper corner in `xyz`; `w` holds the bits of `count`.
    hi: Vec4,
}

impl Node {
    fn new(b: &Bx, first: u32, count: u32) -> Node {
        Node {
            lo: b.min.extend(f32::from_bits(first)),
            hi: b.max.extend(f32::from_bits(count)),
        }
    }

    /// First child (interior node) or first slot (leaf).
    #[inline(always)]
    pub fn first(&self) -> u32 {
        self.lo.w.to_bits()
    }

    /// Number of slots in a leaf; 0 for an interior node.
    #[inline(always)]
    pub fn count(&self) -> u32 {
        self.hi.w.to_bits()
    }

    /// The node's box.
    pub fn aabb(&self) -> Aabb {
        Aabb {
            min: self.lo.truncate(),
            max: self.hi.truncate(),
        }
    }

    /// Entry distance of the ray into the box within (t_min, t_max), or +∞ when it misses.
    ///
    /// Slab test (Kay and Kajiya 1986). `far` is scaled up by 1 + 2γ₃ (pbrt-v4 §6.8.2) so
    /// rounding never culls a box the ray touches. When `ROBUST` is set (the ray has an
    /// infinite reciprocal direction component), the NaNs of 0·∞ — a ray lying in a slab's
    /// plane — are replaced so that the slab does not limit the interval, as in pbrt's scalar
    /// test; without it the lanes are known to be NaN-free and the test is a few instructions
    /// shorter.
    #[inline(always)]
    fn hit<const ROBUST: bool>(&self, r: &TraversalRay, t_min: f32, t_max: f32) -> f32 {
        let t0 = (Vec3A::from_vec4(self.lo) - r.o) * r.inv_d;
        let t1 = (Vec3A::from_vec4(self.hi) - r.o) * r.inv_d;
        let (tn, tf) = if ROBUST {
            let nan = t0.is_nan_mask() | t1.is_nan_mask();
            (
                Vec3A::select(nan, Vec3A::NEG_INFINITY, t0.min(t1)),
                Vec3A::select(nan, Vec3A::INFINITY, t0.max(t1)),
            )
        } else {
            (t0.min(t1), t0.max(t1))
        };
        let near = tn.max_element().max(t_min);
        let far = tf.min_element().min(t_max);
        if near <= far * 1.000_000_4 {
            near
        } else {
            f32::INFINITY
        }
    }
}

/// The per-ray constants of box tests.
#[derive(Debug, Clone, Copy)]
pub struct TraversalRay {
    o: Vec3A,
    inv_d: Vec3A,
    robust: bool,
}

impl TraversalRay {
    /// Precomputes the reciprocal direction of the ray o + t d.
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> TraversalRay {
        let inv_d = Vec3A::from(d).recip();
        TraversalRay {
            o: o.into(),
            inv_d,
            robust: !inv_d.is_finite(),
        }
    }
}

/// A built hierarchy.
#[derive(Debug, Clone, Default)]
pub struct Bvh {
    /// Nodes; the root is node 0.
    pub nodes: Vec<Node>,
    /// Primitive index of each slot, in leaf order.
    pub prims: Vec<u32>,
}

const BINS: usize = 16;
/// Nodes of at most this many primitives are split by sorting them ([`split_sorted`]).
const SMALL_NODE: usize = 16;
/// Nodes with more primitives than this build their two halves in parallel.
const PARALLEL_THRESHOLD: usize = 16 * 1024;
/// Depth of the traversal stack; deeper trees fall back to recursion.
const STACK: usize = 64;

/// A box in SIMD layout, for the builder.
#[derive(Debug, Clone, Copy)]
struct Bx {
    min: Vec3A,
    max: Vec3A,
}

impl Bx {
    const EMPTY: Bx = Bx {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };
    #[inline]
    fn union(self, o: Bx) -> Bx {
        Bx {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
    #[inline]
    fn grow(self, p: Vec3A) -> Bx {
        Bx {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }
    #[inline]
    fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// How the surface area heuristic prices leaves.
#[derive(Debug, Clone, Copy)]
pub struct LeafCost {
    /// Leaves never hold more primitives than this (larger nodes are always split).
    pub max_leaf: usize,
    /// Primitives are tested this many at a time (SIMD packets): a leaf of n primitives costs
    /// ⌈n / block⌉ tests, as in Embree's SAH for 4-wide triangle leaves.
    pub block: usize,
    /// Cost of the traversal step a split adds, relative to one test.
    pub traversal: f32,
}

impl LeafCost {
    /// One primitive test per primitive, at most 4 per leaf.
    pub const SCALAR: LeafCost = LeafCost {
        max_leaf: 4,
        block: 1,
        traversal: 1.0,
    };
    /// Leaves of up to 4 primitives tested together in one SIMD packet.
    ///
    /// For a binary tree collapsed into 8-wide nodes: there a split mostly becomes two lanes of
    /// one wide node instead of one, a few instructions of an 8-box test (≈ 28 for all eight)
    /// against ≈ 80 for a packet test, so a step costs a quarter of a test. Leaves of up to four
    /// triangles then still split where their two halves' boxes are much smaller than the
    /// whole's (two walls of a room meeting at a corner: one box around both is mostly empty),
    /// which a cost of one never allows. On the Cornell box −4.8 % instructions (per closest-hit
    /// ray 2.37 → 1.37 packet and 1.36 → 1.99 node tests); on the 1.31M-triangle icosphere
    /// 0.7 % more packets.
    pub const PACKET4: LeafCost = LeafCost {
        max_leaf: 4,
        block: 4,
        traversal: 0.25,
    };

    #[inline]
    fn tests(&self, n: usize) -> f32 {
        n.div_ceil(self.block) as f32
    }
}

impl Bvh {
    /// Builds a hierarchy over primitives with the given boxes. Primitives with empty or
    /// non-finite boxes are left out (they cannot be hit).
    pub fn build(boxes: &[Aabb]) -> Bvh {
        Bvh::build_with(boxes, LeafCost::SCALAR)
    }

    /// [`Bvh::build`] with a given leaf pricing.
    pub fn build_with(boxes: &[Aabb], leaf_cost: LeafCost) -> Bvh {
        Bvh::build_from(boxes.len(), |i| boxes[i], leaf_cost)
    }

    /// [`Bvh::build_with`] over `count` primitives whose boxes `box_of(i)` gives, so that a
    /// caller need not keep an array of boxes (each box is asked for once, in parallel).
    pub fn build_from(
        count: usize,
        box_of: impl Fn(usize) -> Aabb + Sync,
        leaf_cost: LeafCost,
    ) -> Bvh {
        let mut bvh = Bvh::build_transient(count, box_of, leaf_cost);
        bvh.nodes.shrink_to_fit();
        bvh
    }

    /// [`Bvh::build_from`] for a tree that is read once and dropped (as the binary tree that
    /// [`crate::geometry::TriangleBvh`] collapses): its node array keeps the capacity of the
    /// bound 2n − 1, untouched beyond the nodes written, instead of being shrunk by a copy.
    pub(crate) fn build_transient(
        count: usize,
        box_of: impl Fn(usize) -> Aabb + Sync,
        leaf_cost: LeafCost,
    ) -> Bvh {
        // Written in place (an indexed collect), then the unhittable ones (empty or
        // non-finite boxes) are dropped, in the rare case that there are any.
        let mut refs: Vec<PrimRef> = (0..count as u32)
            .into_par_iter()
            .map(|i| {
                let b = box_of(i as usize);
                PrimRef {
                    lo: b.min.extend(f32::from_bits(i)),
                    hi: b.max.extend(0.0),
                }
            })
            .collect();
        let valid = |r: &PrimRef| {
            let b = Aabb {
                min: r.lo.truncate(),
                max: r.hi.truncate(),
            };
            !b.is_empty() && b.min.is_finite() && b.max.is_finite()
        };
        if !refs.par_iter().all(valid) {
            refs.retain(valid);
        }
        if refs.is_empty() {
            return Bvh {
                nodes: vec![Node::new(&Bx::EMPTY, 0, 0)],
                prims: Vec::new(),
            };
        }
        let range = Range::of_par(&refs);
        // Each leaf writes its slots' primitives as it is made, and each finished subtree
        // gives its records' memory back (see `build_node`): the records (32 bytes per
        // primitive) are never in memory whole beside the whole tree and slot list.
        let n = refs.len();
        let mut nodes = Vec::new();
        // A binary tree over n ≥ 1 primitives has at most 2n − 1 nodes. The array is reserved
        // at that size, but only the pages of the nodes written are ever touched.
        // SAFETY: every slot is taken at once and the leaves, which tile the slots, write them
        // (`build_node`); `build_node` writes the node it is given and every index it takes.
        let prims = unsafe {
            Arena::fill(n, |slots| {
                slots.take(n);
                nodes = Arena::fill(2 * n, |arena| {
                    let root = arena.take(1);
                    build_node(leaf_cost, arena, slots, root, &mut refs, range, 0);
                });
            })
        };
        Bvh { nodes, prims }
    }

    /// Bounds of everything in the hierarchy.
    pub fn bounds(&self) -> Aabb {
        self.nodes[0].aabb()
    }

    /// Visits, front to back, the leaves whose boxes the ray meets within (t_min, *t_max), and
    /// calls `leaf(slot, t_max)` for each slot in them (the primitive is `prims[slot]`). `leaf`
    /// shrinks `*t_max` when it finds a closer hit, and returns `true` to stop the traversal
    /// (any-hit queries). Returns whether it was stopped.
    #[inline]
    pub fn traverse(
        &self,
        ray: &TraversalRay,
        t_min: f32,
        t_max: &mut f32,
        leaf: impl FnMut(u32, &mut f32) -> bool,
    ) -> bool {
        if self.prims.is_empty() {
            return false;
        }
        if ray.robust {
            self.traverse_impl::<true>(ray, t_min, t_max, leaf)
        } else {
            self.traverse_impl::<false>(ray, t_min, t_max, leaf)
        }
    }

    #[inline(always)]
    fn traverse_impl<const ROBUST: bool>(
        &self,
        ray: &TraversalRay,
        t_min: f32,
        t_max: &mut f32,
        mut leaf: impl FnMut(u32, &mut f32) -> bool,
    ) -> bool {
        let nodes = &self.nodes[..];
        // Entries are (node, entry distance): a popped node farther than the current closest
        // hit is skipped without retesting its box.
        // Left uninitialised: zeroing 512 bytes per query cost 2% of a Cornell-box render.
        // Only entries below `sp` are ever read, and each was written before.
        let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); STACK];
        let mut sp = 0usize;
        let mut node = 0usize;
        if nodes[0].hit::<ROBUST>(ray, t_min, *t_max) == f32::INFINITY {
            return false;
        }
        loop {
            let n = &nodes[node];
            let count = n.count();
            if count > 0 {
                let first = n.first();
                for slot in first..first + count {
                    if leaf(slot, t_max) {
                        return true;
                    }
                }
            } else {
                let a = n.first() as usize;
                let ta = nodes[a].hit::<ROBUST>(ray, t_min, *t_max);
                let tb = nodes[a + 1].hit::<ROBUST>(ray, t_min, *t_max);
                if ta != f32::INFINITY || tb != f32::INFINITY {
                    if ta == f32::INFINITY {
                        node = a + 1;
                        continue;
                    }
                    if tb == f32::INFINITY {
                        node = a;
                        continue;
                    }
                    let (near, far, t_far) = if ta <= tb {
                        (a, a + 1, tb)
                    } else {
                        (a + 1, a, ta)
                    };
                    if sp < STACK {
                        stack[sp] = MaybeUninit::new((far as u32, t_far));
                        sp += 1;
                    } else if self.sub_traverse::<ROBUST>(far, ray, t_min, t_max, &mut leaf) {
                        // Stack full (degenerate trees deeper than STACK): recurse instead.
                        return true;
                    }
                    node = near;
                    continue;
                }
            }
            // SAFETY: entries below `sp` were all written by the push above.
            match unsafe { pop_nearer(&stack, &mut sp, *t_max) } {
                Some(next) => node = next as usize,
                None => return false,
            }
        }
    }

    fn sub_traverse<const ROBUST: bool>(
        &self,
        start: usize,
        ray: &TraversalRay,
        t_min: f32,
        t_max: &mut f32,
        leaf: &mut impl FnMut(u32, &mut f32) -> bool,
    ) -> bool {
        let n = self.nodes[start];
        if n.hit::<ROBUST>(ray, t_min, *t_max) == f32::INFINITY {
            return false;
        }
        if n.count() > 0 {
            for slot in n.first()..n.first() + n.count() {
                if leaf(slot, t_max) {
                    return true;
                }
            }
            return false;
        }
        let c = n.first() as usize;
        self.sub_traverse::<ROBUST>(c, ray, t_min, t_max, leaf)
            || self.sub_traverse::<ROBUST>(c + 1, ray, t_min, t_max, leaf)
    }
}

/// Pops traversal-stack entries (node, entry distance) until one may still hold a hit closer
/// than `t_max`; returns its node, or `None` when the stack runs empty.
///
/// # Safety
/// Every entry below `*sp` must have been initialised (the traversals write an entry before
/// they raise `sp` past it).
#[inline(always)]
pub(crate) unsafe fn pop_nearer(
    stack: &[MaybeUninit<(u32, f32)>],
    sp: &mut usize,
    t_max: f32,
) -> Option<u32> {
    while *sp > 0 {
        *sp -= 1;
        // SAFETY: the caller guarantees entries below the initial `*sp` were initialised.
        let (node, t) = unsafe { stack[*sp].assume_init() };
        if t <= t_max {
            return Some(node);
        }
    }
    None
}

/// A primitive as the builder moves it: its box, with the primitive's index in the bits of the
/// lower corner's `w` lane (Embree's `PrimRef`). The builder partitions these 32-byte records in
/// place, so every pass over a node's primitives reads memory sequentially rather than through
/// an index array.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
struct PrimRef {
    lo: Vec4,
    hi: Vec4,
}

impl PrimRef {
    #[inline(always)]
    fn id(&self) -> u32 {
        self.lo.w.to_bits()
    }
    #[inline(always)]
    fn bx(&self) -> Bx {
        Bx {
            min: Vec3A::from_vec4(self.lo),
            max: Vec3A::from_vec4(self.hi),
        }
    }
    #[inline(always)]
    fn center(&self) -> Vec3A {
        (Vec3A::from_vec4(self.lo) + Vec3A::from_vec4(self.hi)) * 0.5
    }
}

/// The box of a node's primitives and the box of their centroids.
#[derive(Debug, Clone, Copy)]
struct Range {
    bounds: Bx,
    cbounds: Bx,
}

impl Range {
    const EMPTY: Range = Range {
        bounds: Bx::EMPTY,
        cbounds: Bx::EMPTY,
    };

    #[inline]
    fn add(self, r: &PrimRef) -> Range {
        Range {
            bounds: self.bounds.union(r.bx()),
            cbounds: self.cbounds.grow(r.center()),
        }
    }

    #[inline]
    fn union(self, o: Range) -> Range {
        Range {
            bounds: self.bounds.union(o.bounds),
            cbounds: self.cbounds.union(o.cbounds),
        }
    }

    fn of(refs: &[PrimRef]) -> Range {
        refs.iter().fold(Range::EMPTY, Range::add)
    }

    fn of_par(refs: &[PrimRef]) -> Range {
        refs.par_chunks(PAR_CHUNK)
            .map(Range::of)
            .reduce(|| Range::EMPTY, Range::union)
    }
}

/// Nodes with more primitives than this bin them in parallel chunks of `PAR_CHUNK`.
const PAR_BINNING: usize = 4 * PAR_CHUNK;
const PAR_CHUNK: usize = 16 * 1024;
/// Nodes of at least this many primitives bin every fourth primitive into one of four sets of
/// bins, merged at the end. Neighbouring primitives mostly fall into the same bin, and with one
/// set each waited for the previous one's store to the bin (a store-to-load chain of the bin's
/// box); with four, four such chains run side by side. A bin's minimum, maximum and count do
/// not depend on the order (but for which zero, −0 or +0, a tie keeps).
const BIN_SETS_FROM: usize = 64;

/// Per-bin boxes, centroid boxes and counts along one axis, `N` bins.
#[derive(Clone, Copy)]
struct Bins<const N: usize> {
    range: [Range; N],
    count: [u32; N],
}

impl<const N: usize> Bins<N> {
    const EMPTY: Bins<N> = Bins {
        range: [Range::EMPTY; N],
        count: [0; N],
    };

    fn merge(mut self, o: Bins<N>) -> Bins<N> {
        for i in 0..N {
            self.range[i] = self.range[i].union(o.range[i]);
            self.count[i] += o.count[i];
        }
        self
    }
}

/// How a node's primitives are to be split.
enum Split {
    Leaf,
    /// The first `mid` primitives go left; the two children's ranges.
    At(usize, Range, Range),
}

/// Decides whether to split `refs` (by binned SAH along the widest centroid axis; `range` is
/// theirs) and, if so, partitions them.
fn split(lc: LeafCost, refs: &mut [PrimRef], range: Range) -> Split {
    let count = refs.len();
    // A leaf tested at once costs one test: no split can cost less when it pays a whole test
    // for its traversal step.
    if count <= 1 || (count <= lc.max_leaf && lc.tests(count) <= 1.0 && lc.traversal >= 1.0) {
        return Split::Leaf;
    }
    let extent = range.cbounds.max - range.cbounds.min;
    // The axis as a constant: the per-primitive loops then read one lane without branching.
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    // Small nodes sort their few primitives instead: the fixed cost of clearing and sweeping
    // bins dominated their split.
    let split = match (axis, count <= SMALL_NODE) {
        (0, false) => split_along::<0, BINS>(lc, refs, range),
        (1, false) => split_along::<1, BINS>(lc, refs, range),
        (_, false) => split_along::<2, BINS>(lc, refs, range),
        (0, true) => split_sorted::<0>(lc, refs, range),
        (1, true) => split_sorted::<1>(lc, refs, range),
        (_, true) => split_sorted::<2>(lc, refs, range),
    };
    if let Some(split) = split {
        return split;
    }
    if count <= lc.max_leaf {
        return Split::Leaf;
    }
    // All centroids coincide (or binning failed): split by index to keep leaves small.
    let mid = count / 2;
    Split::At(mid, Range::of(&refs[..mid]), Range::of(&refs[mid..]))
}

/// [`split`] of a node of at most [`SMALL_NODE`] primitives along axis `AXIS` by SAH over
/// every split between neighbours in centroid order (no bins: sorting a few keys costs less
/// than clearing and sweeping bins, and no two primitives share a bin); `None` when all
/// centroids coincide on the axis.
#[inline(always)]
fn split_sorted<const AXIS: usize>(
    lc: LeafCost,
    refs: &mut [PrimRef],
    range: Range,
) -> Option<Split> {
    let n = refs.len();
    debug_assert!((2..=SMALL_NODE).contains(&n));
    // Twice the centroid along the axis (the order is the same).
    let key = |r: &PrimRef| r.lo.to_array()[AXIS] + r.hi.to_array()[AXIS];
    let mut order = [0u8; SMALL_NODE];
    let mut keys = [0.0f32; SMALL_NODE];
    // Insertion sort, stable: equal keys keep the primitives' order.
    for (i, r) in refs.iter().enumerate() {
        let k = key(r);
        let mut j = i;
        while j > 0 && keys[j - 1] > k {
            keys[j] = keys[j - 1];
            order[j] = order[j - 1];
            j -= 1;
        }
        keys[j] = k;
        order[j] = i as u8;
    }
    if keys[0] == keys[n - 1] {
        return None;
    }
    let mut right_area = [0.0f32; SMALL_NODE];
    let mut acc = Bx::EMPTY;
    for k in (1..n).rev() {
        acc = acc.union(refs[order[k] as usize].bx());
        right_area[k] = acc.half_area();
    }
    let mut left = Bx::EMPTY;
    let mut best = (f32::INFINITY, 0);
    for k in 1..n {
        left = left.union(refs[order[k - 1] as usize].bx());
        // Between equal keys there is no plane to split at.
        if keys[k - 1] == keys[k] {
            continue;
        }
        let cost = left.half_area() * lc.tests(k) + right_area[k] * lc.tests(n - k);
        if cost < best.0 {
            best = (cost, k);
        }
    }
    let area = range.bounds.half_area();
    let split_cost = lc.traversal * area + best.0;
    if !(best.0.is_finite() && (split_cost < area * lc.tests(n) || n > lc.max_leaf)) {
        return None;
    }
    let mid = best.1;
    let mut sorted = [refs[0]; SMALL_NODE];
    for (to, &from) in sorted.iter_mut().zip(&order[..n]) {
        *to = refs[from as usize];
    }
    refs.copy_from_slice(&sorted[..n]);
    Some(Split::At(
        mid,
        Range::of(&refs[..mid]),
        Range::of(&refs[mid..]),
    ))
}

/// [`split`] along axis `AXIS` by binned SAH; `None` when binning finds no split.
#[inline(always)]
fn split_along<const AXIS: usize, const BINS: usize>(
    lc: LeafCost,
    refs: &mut [PrimRef],
    range: Range,
) -> Option<Split> {
    let count = refs.len();
    let Range { bounds, cbounds } = range;
    let (lo, span) = (
        cbounds.min.to_array()[AXIS],
        (cbounds.max - cbounds.min).to_array()[AXIS],
    );
    if span > 0.0 {
        // Bin the centroids and sweep for the cheapest split (SAH).
        let scale = BINS as f32 / span;
        let bin_of = |c: Vec3A| {
            let x = ((c.to_array()[AXIS] - lo) * scale)
                .max(0.0)
                .min((BINS - 1) as f32);
            // SAFETY: clamped to 0..=BINS − 1 (`max` of a NaN and 0 is 0).
            unsafe { x.to_int_unchecked::<u32>() as usize }
        };
        let add = |bins: &mut Bins<BINS>, r: &PrimRef| {
            let b = bin_of(r.center());
            bins.range[b] = bins.range[b].add(r);
            bins.count[b] += 1;
        };
        let bin = |refs: &[PrimRef]| {
            let mut bins = Bins::<BINS>::EMPTY;
            if refs.len() < BIN_SETS_FROM {
                refs.iter().for_each(|r| add(&mut bins, r));
                return bins;
            }
            let [mut b1, mut b2, mut b3] = [Bins::<BINS>::EMPTY; 3];
            let (quads, rest) = refs.as_chunks::<4>();
            for [r, s, t, u] in quads {
                add(&mut bins, r);
                add(&mut b1, s);
                add(&mut b2, t);
                add(&mut b3, u);
            }
            rest.iter().for_each(|r| add(&mut bins, r));
            bins.merge(b1).merge(b2.merge(b3))
        };
        let bins = if count > PAR_BINNING {
            refs.par_chunks(PAR_CHUNK)
                .map(bin)
                .reduce(|| Bins::<BINS>::EMPTY, Bins::merge)
        } else {
            bin(refs)
        };
        let mut right_area = [0.0f32; BINS];
        let mut right_n = [0usize; BINS];
        let mut acc = Bx::EMPTY;
        let mut acc_n = 0;
        for i in (1..BINS).rev() {
            acc = acc.union(bins.range[i].bounds);
            acc_n += bins.count[i] as usize;
            right_area[i] = acc.half_area();
            right_n[i] = acc_n;
        }
        let mut left = Bx::EMPTY;
        let mut left_n = 0;
        let mut best = (f32::INFINITY, 0);
        for i in 0..BINS - 1 {
            left = left.union(bins.range[i].bounds);
            left_n += bins.count[i] as usize;
            if left_n == 0 || right_n[i + 1] == 0 {
                continue;
            }
            let cost =
                left.half_area() * lc.tests(left_n) + right_area[i + 1] * lc.tests(right_n[i + 1]);
            if cost < best.0 {
                best = (cost, i);
            }
        }
        let leaf_cost = bounds.half_area() * lc.tests(count);
        let split_cost = lc.traversal * bounds.half_area() + best.0;
        if best.0.is_finite() && (split_cost < leaf_cost || count > lc.max_leaf) {
            let threshold = best.1;
            // bin_of(c) ≤ threshold, in floats: the bin is x = (c − lo)·scale ≥ 0 truncated, so
            // it is at most `threshold` exactly when x < threshold + 1 (the same x, so
            // the sides agree with the bins whose boxes they get).
            let limit = (threshold + 1) as f32;
            let mid = partition(refs, |r| (r.center().to_array()[AXIS] - lo) * scale < limit);
            let side = |bins: &[Range]| bins.iter().fold(Range::EMPTY, |a, &b| a.union(b));
            if mid > 0 && mid < count {
                return Some(Split::At(
                    mid,
                    side(&bins.range[..=threshold]),
                    side(&bins.range[threshold + 1..]),
                ));
            }
        }
    }
    None
}

/// An array written by many threads at once, as a tree builder fills its node array: each
/// index is handed out once ([`Arena::take`]) and written once, by the thread that took it.
pub(crate) struct Arena<T> {
    ptr: *mut T,
    cap: usize,
    len: AtomicUsize,
}

// SAFETY: threads write disjoint indices (each handed out once by an atomic counter), and the
// array is read only after `fill`'s closure, and so every writer, has returned.
unsafe impl<T: Send> Sync for Arena<T> {}

impl<T> Arena<T> {
    /// Runs `build` over an arena of at most `cap` elements and returns the elements it took,
    /// in a vector of capacity `cap`: the capacity is reserved, but only the pages written are
    /// touched. A caller that keeps the vector shrinks it (for elements aligned to more than 16
    /// bytes, Rust's system allocator shrinks by allocating, copying and freeing).
    ///
    /// # Safety
    /// `build` must write ([`Arena::set`]) every index it takes ([`Arena::take`]).
    pub(crate) unsafe fn fill(cap: usize, build: impl FnOnce(&Arena<T>)) -> Vec<T> {
        let mut v: Vec<T> = Vec::with_capacity(cap);
        let arena = Arena {
            ptr: v.as_mut_ptr(),
            cap,
            len: AtomicUsize::new(0),
        };
        build(&arena);
        let len = arena.len.into_inner();
        // SAFETY: `len` ≤ `cap` (checked by `take`), and the caller guarantees that every
        // index below it, handed out by `take`, was written.
        unsafe { v.set_len(len) };
        v
    }

    /// `n` adjacent fresh indices (siblings), the first returned.
    pub(crate) fn take(&self, n: usize) -> usize {
        let i = self.len.fetch_add(n, Ordering::Relaxed);
        assert!(i + n <= self.cap, "arena overflow");
        i
    }

    /// Writes element `i`.
    ///
    /// # Safety
    /// `i` must come from [`Arena::take`], and no other call may write it.
    pub(crate) unsafe fn set(&self, i: usize, x: T) {
        assert!(i < self.len.load(Ordering::Relaxed));
        // SAFETY: in bounds (below `len` ≤ `cap`); the caller guarantees that no other
        // thread writes `i` and that it was not written before.
        unsafe { self.ptr.add(i).write(x) };
    }
}

/// Writes the primitives of the leaf `refs`, which holds slots `offset..`, to the slot list.
#[inline]
fn write_leaf(slots: &Arena<u32>, offset: usize, refs: &[PrimRef]) {
    for (k, r) in refs.iter().enumerate() {
        // SAFETY: the slots are all taken at once; each belongs to one leaf, written once.
        unsafe { slots.set(offset + k, r.id()) };
    }
}

/// Builds the subtree over `refs` (slots `offset..offset + refs.len()`, their range `range`)
/// with its root at node `index`, its leaves' primitives written to `slots`; nodes of more
/// than [`PARALLEL_THRESHOLD`] primitives build their two halves in parallel. Siblings are
/// adjacent; the numbering depends on the threads' timing, the tree does not. Once a node's
/// subtree is built its records are dead, and the whole huge pages they fill are given back.
fn build_node(
    lc: LeafCost,
    arena: &Arena<Node>,
    slots: &Arena<u32>,
    index: usize,
    refs: &mut [PrimRef],
    range: Range,
    offset: usize,
) {
    if refs.len() <= PARALLEL_THRESHOLD {
        // Built by this thread alone into a local array (root first, then pairs of
        // siblings), then copied into the arena with one `take`: no contended counter per
        // node.
        // At most 2n − 1 nodes: reserved at once, as growing it cost a copy per doubling.
        let mut local = Vec::with_capacity(2 * refs.len());
        local.push(Node::new(&Bx::EMPTY, 0, 0));
        build_sequential(lc, &mut local, slots, 0, refs, range, offset);
        let base = if local.len() > 1 {
            arena.take(local.len() - 1)
        } else {
            0
        };
        // Local node k ≥ 1 goes to base + k − 1; child links move with it.
        let place = |mut n: Node| {
            if n.count() == 0 {
                n.lo.w = f32::from_bits((base + n.first() as usize - 1) as u32);
            }
            n
        };
        // SAFETY: `index` was handed to this call alone, and base.. base + len − 1 were
        // taken by it just above.
        unsafe {
            arena.set(index, place(local[0]));
            for (k, &n) in local.iter().enumerate().skip(1) {
                arena.set(base + k - 1, place(n));
            }
        }
        return;
    }
    let (mid, lr, rr) = match split(lc, refs, range) {
        Split::Leaf => {
            write_leaf(slots, offset, refs);
            let leaf = Node::new(&range.bounds, offset as u32, refs.len() as u32);
            // SAFETY: `index` was handed to this call alone.
            unsafe { arena.set(index, leaf) };
            return;
        }
        Split::At(mid, lr, rr) => (mid, lr, rr),
    };
    let first = arena.take(2);
    // SAFETY: as above.
    unsafe { arena.set(index, Node::new(&range.bounds, first as u32, 0)) };
    let (lp, rp) = refs.split_at_mut(mid);
    rayon::join(
        || build_node(lc, arena, slots, first, lp, lr, offset),
        || build_node(lc, arena, slots, first + 1, rp, rr, offset + mid),
    );
    // SAFETY: the subtree is built; nothing reads these records again (the parent's split is
    // done, and the slot list has their primitives).
    unsafe { crate::alloc::release_unused(refs.as_ptr().cast(), std::mem::size_of_val(refs)) };
}

/// Builds the subtree over `refs` into `nodes`, its root at `nodes[index]`, its leaves' primitives
/// written to `slots`.
fn build_sequential(
    lc: LeafCost,
    nodes: &mut Vec<Node>,
    slots: &Arena<u32>,
    index: usize,
    refs: &mut [PrimRef],
    range: Range,
    offset: usize,
) {
    let (mid, lr, rr) = match split(lc, refs, range) {
        Split::Leaf => {
            write_leaf(slots, offset, refs);
            nodes[index] = Node::new(&range.bounds, offset as u32, refs.len() as u32);
            return;
        }
        Split::At(mid, lr, rr) => (mid, lr, rr),
    };
    let first = nodes.len();
    nodes.push(Node::new(&Bx::EMPTY, 0, 0));
    nodes.push(Node::new(&Bx::EMPTY, 0, 0));
    nodes[index] = Node::new(&range.bounds, first as u32, 0);
    let (lp, rp) = refs.split_at_mut(mid);
    build_sequential(lc, nodes, slots, first, lp, lr, offset);
    build_sequential(lc, nodes, slots, first + 1, rp, rr, offset + mid);
}

/// Reorders `s` so elements satisfying `pred` come first; returns their number. Branch-free
/// (Lomuto's scheme with the swap always made and the boundary moved by the predicate's
/// value): which side a primitive falls on is a coin toss to the branch predictor, and
/// Hoare's scheme mispredicted about once per primitive and level.
fn partition(s: &mut [PrimRef], pred: impl Fn(&PrimRef) -> bool) -> usize {
    let mut j = 0;
    for i in 0..s.len() {
        let goes_first = pred(&s[i]);
        s.swap(i, j);
        j += usize::from(goes_first);
    }
    j
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::sampler::test_lcg as lcg;

    fn random_boxes(n: usize, s: &mut u64) -> Vec<Aabb> {
        (0..n)
            .map(|_| {
                let c = Vec3::new(lcg(s), lcg(s), lcg(s)) * 10.0;
                let e = Vec3::new(lcg(s), lcg(s), lcg(s)) * 0.3;
                Aabb {
                    min: c - e,
                    max: c + e,
                }
            })
            .collect()
    }

    fn closest(bvh: &Bvh, boxes: &[Aabb], o: Vec3, d: Vec3) -> Option<usize> {
        let inv = d.recip();
        let mut t_max = f32::INFINITY;
        let mut found = None;
        bvh.traverse(&TraversalRay::new(o, d), 0.0, &mut t_max, |slot, t_max| {
            let p = bvh.prims[slot as usize] as usize;
            if let Some(t) = boxes[p].hit(o, inv, 0.0, *t_max) {
                if found.is_none_or(|(ft, _)| t < ft) {
                    found = Some((t, p));
                    *t_max = t;
                }
            }
            false
        });
        found.map(|f| f.1)
    }

    fn brute(boxes: &[Aabb], o: Vec3, d: Vec3) -> Option<usize> {
        let inv = d.recip();
        boxes
            .iter()
            .enumerate()
            .filter_map(|(i, b)| b.hit(o, inv, 0.0, f32::INFINITY).map(|t| (t, i)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|b| b.1)
    }

    /// A small node's split is the cheapest by SAH of every split between neighbours in
    /// centroid order, found here by trying each: the primitives reordered (none lost), the
    /// left side's centroids at most the right side's, the sides' ranges theirs; no split
    /// where it does not pay (up to the largest leaf) or every centroid is the same.
    #[test]
    fn small_nodes_split_at_the_cheapest_plane() {
        let mut s = 3u64;
        let lc = LeafCost::PACKET4;
        let mut splits = 0;
        for round in 0..4000 {
            let n = 2 + round % (SMALL_NODE - 1);
            let mut boxes = random_boxes(n, &mut s);
            // Some nodes with coinciding centroids, and some all one.
            if round % 7 == 0 {
                boxes[n - 1] = boxes[0];
            }
            if round % 97 == 0 {
                boxes.iter_mut().for_each(|b| *b = around_origin(*b));
            }
            let mut refs: Vec<PrimRef> = boxes
                .iter()
                .enumerate()
                .map(|(i, b)| PrimRef {
                    lo: b.min.extend(f32::from_bits(i as u32)),
                    hi: b.max.extend(0.0),
                })
                .collect();
            let range = Range::of(&refs);
            let key = |r: &PrimRef| r.lo.x + r.hi.x;
            // Every split between distinct neighbours in centroid order, by brute force.
            let mut sorted = refs.clone();
            sorted.sort_by(|a, b| key(a).total_cmp(&key(b)));
            let cost_at = |k: usize| {
                let side = |r: &[PrimRef]| Range::of(r).bounds.half_area();
                side(&sorted[..k]) * lc.tests(k) + side(&sorted[k..]) * lc.tests(n - k)
            };
            let best = (1..n)
                .filter(|&k| key(&sorted[k - 1]) < key(&sorted[k]))
                .map(cost_at)
                .fold(f32::INFINITY, f32::min);
            let area = range.bounds.half_area();
            let pays = lc.traversal * area + best < area * lc.tests(n) || n > lc.max_leaf;
            match split_sorted::<0>(lc, &mut refs, range) {
                None => assert!(!best.is_finite() || !pays, "n = {n}: a split that pays"),
                Some(Split::Leaf) => unreachable!(),
                Some(Split::At(mid, left, right)) => {
                    splits += 1;
                    assert!(pays);
                    let mut ids: Vec<u32> = refs.iter().map(PrimRef::id).collect();
                    ids.sort_unstable();
                    assert!(ids.iter().copied().eq(0..n as u32));
                    let (l, r) = refs.split_at(mid);
                    let most_left = l.iter().map(key).fold(f32::MIN, f32::max);
                    assert!(r.iter().all(|p| key(p) >= most_left));
                    let cost = Range::of(l).bounds.half_area() * lc.tests(mid)
                        + Range::of(r).bounds.half_area() * lc.tests(n - mid);
                    assert_eq!(cost, best, "n = {n}");
                    assert_eq!(left.bounds.half_area(), Range::of(l).bounds.half_area());
                    assert_eq!(right.bounds.half_area(), Range::of(r).bounds.half_area());
                }
            }
        }
        assert!(splits > 1000, "{splits} splits");
    }

    /// A box around the origin of `b`'s size: every such box has the same centroid.
    fn around_origin(b: Aabb) -> Aabb {
        let e = (b.max - b.min) * 0.5;
        Aabb { min: -e, max: e }
    }

    /// The BVH must report exactly the boxes a brute-force scan reports (the oracle).
    #[test]
    fn closest_box_matches_brute_force() {
        let mut s = 7u64;
        let boxes = random_boxes(2000, &mut s);
        let bvh = Bvh::build(&boxes);
        for _ in 0..2000 {
            let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 14.0 - 2.0;
            let d = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            assert_eq!(closest(&bvh, &boxes, o, d), brute(&boxes, o, d));
        }
    }

    /// Axis-parallel rays (zero direction components, infinite reciprocals) take the robust
    /// box test; rays lying exactly in box faces must still find the boxes.
    #[test]
    fn axis_parallel_rays_in_box_faces_match_brute_force() {
        let mut s = 5u64;
        // Boxes on an integer lattice so that many faces share planes with the ray origins.
        let boxes: Vec<Aabb> = (0..500)
            .map(|_| {
                let c = Vec3::new(
                    (lcg(&mut s) * 10.0).floor(),
                    (lcg(&mut s) * 10.0).floor(),
                    (lcg(&mut s) * 10.0).floor(),
                );
                Aabb {
                    min: c,
                    max: c + Vec3::ONE,
                }
            })
            .collect();
        let bvh = Bvh::build(&boxes);
        let mut hits = 0;
        for i in 0..3000 {
            let o = Vec3::new(
                (lcg(&mut s) * 12.0).floor() - 1.0,
                (lcg(&mut s) * 12.0).floor() - 1.0,
                lcg(&mut s) * 12.0 - 1.0,
            );
            let d = match i % 3 {
                0 => Vec3::Z,
                1 => Vec3::new(0.0, -0.0, -1.0),
                _ => Vec3::new(0.0, 1.0, 0.5),
            };
            let b = brute(&boxes, o, d);
            hits += b.is_some() as u32;
            // Equal entry distances (shared faces) may name either box: compare distances.
            let a = closest(&bvh, &boxes, o, d);
            let dist =
                |k: Option<usize>| k.and_then(|k| boxes[k].hit(o, d.recip(), 0.0, f32::INFINITY));
            assert_eq!(dist(a), dist(b), "ray {o:?} {d:?}");
        }
        assert!(hits > 100, "the test must exercise hits, got {hits}");
    }

    /// A build large enough to give its finished records' memory back while it runs (nodes
    /// whose records span whole 2 MiB blocks) reads no record after giving it back: the slots
    /// hold every primitive once, and each leaf's box is the union of its primitives' boxes.
    #[test]
    fn records_given_back_during_the_build_are_not_read_again() {
        let mut s = 17u64;
        let boxes = random_boxes(16 * PARALLEL_THRESHOLD, &mut s);
        assert!(boxes.len() * std::mem::size_of::<PrimRef>() > 3 * (2 << 20));
        let bvh = Bvh::build(&boxes);
        let mut seen = vec![false; boxes.len()];
        for &p in &bvh.prims {
            assert!(
                !std::mem::replace(&mut seen[p as usize], true),
                "primitive {p} twice"
            );
        }
        assert!(seen.iter().all(|&x| x), "a primitive is missing");
        let mut leaves = 0;
        for n in bvh.nodes.iter().filter(|n| n.count() > 0) {
            let (first, count) = (n.first() as usize, n.count() as usize);
            let union = bvh.prims[first..first + count]
                .iter()
                .fold(Aabb::EMPTY, |b, &p| b.union(boxes[p as usize]));
            assert_eq!(n.aabb(), union, "leaf at slot {first}");
            leaves += 1;
        }
        assert!(leaves > boxes.len() / 16, "{leaves} leaves");
    }

    /// The parallel build (above the threshold) gives the same tree as the sequential one.
    #[test]
    fn parallel_build_equals_sequential_build() {
        let mut s = 9u64;
        let boxes = random_boxes(3 * PARALLEL_THRESHOLD, &mut s);
        let par = Bvh::build(&boxes);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a thread pool");
        let Bvh { nodes: seq, prims } = one.install(|| Bvh::build(&boxes));
        assert_eq!(par.prims, prims);
        assert_eq!(par.nodes.len(), seq.len());
        // Same trees up to node numbering: compare by walking both.
        fn walk(nodes: &[Node], i: usize, out: &mut Vec<(Aabb, u32, u32)>) {
            let n = nodes[i];
            if n.count() > 0 {
                out.push((n.aabb(), n.first(), n.count()));
            } else {
                out.push((n.aabb(), 0, 0));
                walk(nodes, n.first() as usize, out);
                walk(nodes, n.first() as usize + 1, out);
            }
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        walk(&par.nodes, 0, &mut a);
        walk(&seq, 0, &mut b);
        assert_eq!(a, b);
        for _ in 0..500 {
            let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 14.0 - 2.0;
            let d = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            // Dense boxes: origins often lie inside several (ties at t = 0), so compare distances.
            let dist =
                |k: Option<usize>| k.and_then(|k| boxes[k].hit(o, d.recip(), 0.0, f32::INFINITY));
            assert_eq!(dist(closest(&par, &boxes, o, d)), dist(brute(&boxes, o, d)));
        }
    }
}
