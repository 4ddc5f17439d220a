//! A bounding volume hierarchy built with the binned surface area heuristic (Wald 2007,
//! "On fast Construction of SAH-based Bounding Volume Hierarchies"), stored as a flat array of
//! 32-byte nodes with siblings adjacent, traversed front to back with a small stack.
//!
//! The BVH knows only boxes: primitives are indices, and the caller supplies the leaf test, so
//! the same structure serves triangles inside a mesh and instances at the top level.

use crate::math::{Aabb, Vec3};

/// One node: a box and either two children (`count == 0`, children at `first` and `first + 1`)
/// or a leaf of `count` primitives starting at `first` in [`Bvh::prims`].
#[derive(Debug, Clone, Copy)]
#[repr(C)]
pub struct Node {
    /// Lower corner of the box.
    pub min: [f32; 3],
    /// Index of the first child (interior) or first primitive (leaf).
    pub first: u32,
    /// Upper corner of the box.
    pub max: [f32; 3],
    /// Number of primitives; 0 marks an interior node.
    pub count: u32,
}

impl Node {
    #[inline]
    fn aabb(&self) -> Aabb {
        Aabb { min: Vec3::from(self.min), max: Vec3::from(self.max) }
    }
}

/// A built hierarchy.
#[derive(Debug, Clone, Default)]
pub struct Bvh {
    /// Nodes; the root is node 0.
    pub nodes: Vec<Node>,
    /// Primitive indices in leaf order.
    pub prims: Vec<u32>,
}

const BINS: usize = 16;
const MAX_LEAF: usize = 4;
/// Cost of one traversal step relative to one primitive test, for the SAH.
const TRAVERSAL_COST: f32 = 1.0;

impl Bvh {
    /// Builds a hierarchy over primitives with the given boxes. Primitives with empty or
    /// non-finite boxes are left out (they cannot be hit).
    pub fn build(boxes: &[Aabb]) -> Bvh {
        let mut prims: Vec<u32> = (0..boxes.len() as u32)
            .filter(|&i| {
                let b = boxes[i as usize];
                !b.is_empty() && b.min.is_finite() && b.max.is_finite()
            })
            .collect();
        let centers: Vec<Vec3> = boxes.iter().map(Aabb::center).collect();
        let mut nodes = Vec::with_capacity(2 * prims.len() / MAX_LEAF + 1);
        if prims.is_empty() {
            nodes.push(Node { min: [f32::INFINITY; 3], first: 0, max: [f32::NEG_INFINITY; 3], count: 0 });
            return Bvh { nodes, prims };
        }
        nodes.push(Node { min: [0.0; 3], first: 0, max: [0.0; 3], count: 0 });
        let n = prims.len();
        build_node(&mut nodes, 0, &mut prims, 0, n, boxes, &centers);
        Bvh { nodes, prims }
    }

    /// Bounds of everything in the hierarchy.
    pub fn bounds(&self) -> Aabb {
        self.nodes[0].aabb()
    }

    /// Visits, front to back, the leaves whose boxes the ray meets within (t_min, *t_max), and
    /// calls `leaf(prim, t_max)` for each primitive in them. `leaf` shrinks `*t_max` when it
    /// finds a closer hit, and returns `true` to stop the traversal (any-hit queries). Returns
    /// whether it was stopped.
    #[inline]
    pub fn traverse(&self, o: Vec3, d: Vec3, t_min: f32, t_max: &mut f32, mut leaf: impl FnMut(u32, &mut f32) -> bool) -> bool {
        if self.prims.is_empty() {
            return false;
        }
        let inv_d = d.recip();
        let mut stack = [0u32; 64];
        let mut sp = 0usize;
        let mut node = 0u32;
        if self.nodes[0].aabb().hit(o, inv_d, t_min, *t_max).is_none() {
            return false;
        }
        loop {
            let n = &self.nodes[node as usize];
            if n.count > 0 {
                for &p in &self.prims[n.first as usize..(n.first + n.count) as usize] {
                    if leaf(p, t_max) {
                        return true;
                    }
                }
            } else {
                let (a, b) = (n.first, n.first + 1);
                let ha = self.nodes[a as usize].aabb().hit(o, inv_d, t_min, *t_max);
                let hb = self.nodes[b as usize].aabb().hit(o, inv_d, t_min, *t_max);
                match (ha, hb) {
                    (Some(ta), Some(tb)) => {
                        let (near, far) = if ta <= tb { (a, b) } else { (b, a) };
                        if sp < stack.len() {
                            stack[sp] = far;
                            sp += 1;
                            node = near;
                            continue;
                        }
                        // Stack full (degenerate trees deeper than 64): finish `far` recursively.
                        let sub = Bvh::sub_traverse(self, far, o, inv_d, t_min, t_max, &mut leaf);
                        if sub {
                            return true;
                        }
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = a;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = b;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the next node that is still in range.
            loop {
                if sp == 0 {
                    return false;
                }
                sp -= 1;
                node = stack[sp];
                if self.nodes[node as usize].aabb().hit(o, inv_d, t_min, *t_max).is_some() {
                    break;
                }
            }
        }
    }

    fn sub_traverse(&self, start: u32, o: Vec3, inv_d: Vec3, t_min: f32, t_max: &mut f32, leaf: &mut impl FnMut(u32, &mut f32) -> bool) -> bool {
        let n = self.nodes[start as usize];
        if n.aabb().hit(o, inv_d, t_min, *t_max).is_none() {
            return false;
        }
        if n.count > 0 {
            for &p in &self.prims[n.first as usize..(n.first + n.count) as usize] {
                if leaf(p, t_max) {
                    return true;
                }
            }
            return false;
        }
        self.sub_traverse(n.first, o, inv_d, t_min, t_max, leaf) || self.sub_traverse(n.first + 1, o, inv_d, t_min, t_max, leaf)
    }
}

fn build_node(nodes: &mut Vec<Node>, index: usize, prims: &mut [u32], start: usize, end: usize, boxes: &[Aabb], centers: &[Vec3]) {
    let slice = &mut prims[start..end];
    let bounds = slice.iter().fold(Aabb::EMPTY, |b, &p| b.union(boxes[p as usize]));
    let cbounds = slice.iter().fold(Aabb::EMPTY, |b, &p| b.grow(centers[p as usize]));
    let count = end - start;
    let make_leaf = |nodes: &mut Vec<Node>| {
        nodes[index] = Node { min: bounds.min.into(), first: start as u32, max: bounds.max.into(), count: count as u32 };
    };
    if count <= 1 {
        return make_leaf(nodes);
    }
    let extent = cbounds.max - cbounds.min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z { 0 } else if extent.y >= extent.z { 1 } else { 2 };
    let (lo, span) = (cbounds.min[axis], extent[axis]);
    let mut split = None;
    if span > 0.0 {
        // Bin the centroids and sweep for the cheapest split (SAH).
        let scale = BINS as f32 / span;
        let bin_of = |p: u32| (((centers[p as usize][axis] - lo) * scale) as usize).min(BINS - 1);
        let mut bin_box = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for &p in slice.iter() {
            let b = bin_of(p);
            bin_box[b] = bin_box[b].union(boxes[p as usize]);
            bin_count[b] += 1;
        }
        let mut right_area = [0.0f32; BINS];
        let mut acc = Aabb::EMPTY;
        let mut acc_n = 0;
        let mut right_n = [0usize; BINS];
        for i in (1..BINS).rev() {
            acc = acc.union(bin_box[i]);
            acc_n += bin_count[i];
            right_area[i] = acc.half_area();
            right_n[i] = acc_n;
        }
        let mut left = Aabb::EMPTY;
        let mut left_n = 0;
        let mut best = (f32::INFINITY, 0);
        for i in 0..BINS - 1 {
            left = left.union(bin_box[i]);
            left_n += bin_count[i];
            if left_n == 0 || right_n[i + 1] == 0 {
                continue;
            }
            let cost = left.half_area() * left_n as f32 + right_area[i + 1] * right_n[i + 1] as f32;
            if cost < best.0 {
                best = (cost, i);
            }
        }
        let leaf_cost = bounds.half_area() * count as f32;
        let split_cost = TRAVERSAL_COST * bounds.half_area() + best.0;
        if best.0.is_finite() && (split_cost < leaf_cost || count > MAX_LEAF) {
            let threshold = best.1;
            split = Some(partition(slice, |p| bin_of(p) <= threshold));
        }
    }
    let mid = match split {
        Some(m) if m > 0 && m < count => m,
        _ if count <= MAX_LEAF => return make_leaf(nodes),
        // All centroids coincide (or binning failed): split by index to keep leaves small.
        _ => count / 2,
    };
    let first = nodes.len();
    nodes.push(Node { min: [0.0; 3], first: 0, max: [0.0; 3], count: 0 });
    nodes.push(Node { min: [0.0; 3], first: 0, max: [0.0; 3], count: 0 });
    nodes[index] = Node { min: bounds.min.into(), first: first as u32, max: bounds.max.into(), count: 0 };
    build_node(nodes, first, prims, start, start + mid, boxes, centers);
    build_node(nodes, first + 1, prims, start + mid, end, boxes, centers);
}

/// Reorders `s` so elements satisfying `pred` come first; returns their number.
fn partition(s: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..s.len() {
        if pred(s[j]) {
            s.swap(i, j);
            i += 1;
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(state: &mut u64) -> f32 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*state >> 40) as f32) / (1u64 << 24) as f32
    }

    /// The BVH must report exactly the boxes a brute-force scan reports (the oracle).
    #[test]
    fn closest_box_matches_brute_force() {
        let mut s = 7u64;
        let boxes: Vec<Aabb> = (0..2000)
            .map(|_| {
                let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 10.0;
                let e = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 0.3;
                Aabb { min: c - e, max: c + e }
            })
            .collect();
        let bvh = Bvh::build(&boxes);
        for _ in 0..2000 {
            let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 14.0 - 2.0;
            let d = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            let inv = d.recip();
            let brute = boxes
                .iter()
                .enumerate()
                .filter_map(|(i, b)| b.hit(o, inv, 0.0, f32::INFINITY).map(|t| (t, i)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let mut t_max = f32::INFINITY;
            let mut found = None;
            bvh.traverse(o, d, 0.0, &mut t_max, |p, t_max| {
                if let Some(t) = boxes[p as usize].hit(o, inv, 0.0, *t_max) {
                    if found.is_none_or(|(ft, _)| t < ft) {
                        found = Some((t, p as usize));
                        *t_max = t;
                    }
                }
                false
            });
            assert_eq!(found.map(|f| f.1), brute.map(|b| b.1));
        }
    }
}
