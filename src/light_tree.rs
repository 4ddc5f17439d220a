//! A bounding volume hierarchy over the finite lights that picks a light in proportion to an
//! estimate of what it contributes at the shading point, not only to its power.
//!
//! The method is that of Conty Estevez and Kulla (2018), "Importance Sampling of Many Lights with
//! Adaptive Tree Splitting" (HPG), in the form of pbrt-v4's `BVHLightSampler` (Pharr, Jakob and
//! Humphreys, *Physically Based Rendering*, 4th ed., §12.6.3), without the adaptive splitting:
//!
//! * every light gets [`LightBounds`]: a box around it, its intensity `phi`, and a cone of
//!   normals (axis `w`, half-angle θ_o) widened by the spread θ_e of each emitter's emission
//!   about its normal (π/2 for a Lambertian surface);
//! * the tree is built top-down, each node split where the surface area orientation heuristic
//!   (SAOH) is least;
//! * a light is picked by walking from the root, at each node taking a child with probability
//!   proportional to its [`LightBounds::importance`] at the shading point, a conservative
//!   estimate of the irradiance the child's lights could give there; the uniform number is
//!   remapped at each level so that what is left of it samples the point on the light;
//! * the probability of a given light is the product of the same choices along its path, which
//!   each light stores as a bit trail (one bit per level: 0 = first child).
//!
//! Both children of a node are evaluated at once, one per lane of 4-wide vectors
//! (`ChildPair`); [`LightBounds::importance`] is the same arithmetic on one group.
//!
//! Infinite lights (directional, environment) have no position to bound: they stay outside the
//! tree and are chosen first, with their share of the scene's total power (see
//! [`crate::light_sampler::LightSampler`]).
//!
//! Unbiasedness needs the importance of a node to be zero only where none of its lights can
//! contribute: every bound below errs towards larger importance.

use std::f32::consts::PI;

use crate::lanes::math::{acos, cos, sin, sin_cos};
use crate::light::Light;
use crate::math::{luminance, Vec3};
use glam::Vec4;

/// Depth from which the build stops looking for the cheapest split and halves the lights by
/// count: the remaining levels are then at most log2(lights) ≤ 32, so a light's path fits the
/// 64 bits of its trail.
const BALANCED_FROM_DEPTH: u32 = 32;

/// Buckets per axis in which split positions are evaluated.
const BUCKETS: usize = 12;

/// A cone of directions: axis `w` (unit), its half-angle and that angle's cosine (−1: every
/// direction), both kept so that unions need not recompute the angle.
#[derive(Debug, Clone, Copy, PartialEq)]
struct DirectionCone {
    w: Vec3,
    cos_theta: f32,
    theta: f32,
}

impl DirectionCone {
    /// The smallest cone (of this construction) holding both cones: pbrt-v4's
    /// `Union(DirectionCone, DirectionCone)`. With θ_a, θ_b the half-angles and θ_d the angle
    /// between the axes, a cone of half-angle (θ_a + θ_d + θ_b) / 2 whose axis lies on the arc
    /// from `a.w` to `b.w` reaches from a's far edge to b's.
    fn union(a: DirectionCone, b: DirectionCone) -> DirectionCone {
        let whole = DirectionCone {
            w: Vec3::Z,
            cos_theta: -1.0,
            theta: PI,
        };
        // Equal cones (the lights of one flat panel) are common and need no trigonometry.
        if a == b {
            return a;
        }
        let (theta_a, theta_b) = (a.theta, b.theta);
        let theta_d = acos(a.w.dot(b.w).clamp(-1.0, 1.0));
        // One cone already holds the other.
        if (theta_d + theta_b).min(PI) <= theta_a {
            return a;
        }
        if (theta_d + theta_a).min(PI) <= theta_b {
            return b;
        }
        let theta_o = 0.5 * (theta_a + theta_d + theta_b);
        if theta_o >= PI {
            return whole;
        }
        // Turn a's axis towards b's by θ_o − θ_a, in the plane of the two axes.
        let theta_r = theta_o - theta_a;
        let perp = b.w - a.w * a.w.dot(b.w);
        if perp.length_squared() < 1e-12 {
            return whole; // opposite axes: no plane to turn in
        }
        let perp = perp.normalize();
        let (s, c) = sin_cos(theta_r);
        DirectionCone {
            w: (a.w * c + perp * s).normalize(),
            cos_theta: cos(theta_o),
            theta: theta_o,
        }
    }
}

/// What the importance of a light or a group of lights is estimated from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightBounds {
    /// Corners of a box holding every emitting point.
    pub lo: Vec3,
    /// See `lo`.
    pub hi: Vec3,
    /// Intensity (luminance): an upper estimate of the radiant intensity (W/sr) towards a
    /// direction the lights face, so that `phi · cos / d²` estimates irradiance. Area × radiance
    /// for an emitting triangle, π r² × radiance for a sphere, the intensity of a point or spot
    /// light; summed over a group.
    pub phi: f32,
    /// Axis of the cone holding every emitter's normal (spot: its axis).
    pub w: Vec3,
    /// cos θ_o, θ_o the half-angle of that cone (−1 for emitters facing every way).
    pub cos_theta_o: f32,
    /// cos θ_e, θ_e the angle beyond its normal up to which an emitter emits (π/2 for surfaces
    /// and punctual lights, 0 for a spot, whose cone is that of its directions): never
    /// negative, so neither is a nonzero importance.
    pub cos_theta_e: f32,
    /// Whether some emitter emits from both faces (then `w` and −`w` count alike).
    pub two_sided: bool,
    /// θ_o itself (for unions during the build).
    theta_o: f32,
}

/// [`LightBounds`] as the tree walk needs them: what [`LightBounds::importance`] computes from,
/// with what depends only on the bounds computed once.
#[derive(Debug, Clone, Copy)]
struct Cluster {
    /// Centre of the box.
    center: Vec3,
    /// Half the box's diagonal: the radius of a sphere around it.
    radius: f32,
    w: Vec3,
    phi: f32,
    cos_o: f32,
    sin_o: f32,
    cos_e: f32,
    two_sided: bool,
}

impl Cluster {
    fn of(b: &LightBounds) -> Cluster {
        Cluster {
            center: b.centroid(),
            radius: 0.5 * (b.hi - b.lo).length(),
            w: b.w,
            phi: b.phi,
            cos_o: b.cos_theta_o,
            sin_o: (1.0 - b.cos_theta_o * b.cos_theta_o).max(0.0).sqrt(),
            cos_e: b.cos_theta_e,
            two_sided: b.two_sided,
        }
    }

    /// See [`LightBounds::importance`].
    #[inline]
    fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let v = p - self.center;
        let d2 = v.length_squared();
        let r2 = self.radius * self.radius;
        if d2 <= r2 {
            // p is inside the box's bounding sphere: lights may lie in every direction (θ_b = π,
            // so θ' = θ_i' = 0), at a distance taken as the radius.
            return self.phi / r2.max(1e-12);
        }
        // θ_b: half-angle of the cone from p around the bounding sphere, sin θ_b = r / d.
        let inv_d = d2.sqrt().recip();
        let sin_b = self.radius * inv_d;
        let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
        // θ_w: between the axis and the direction from the centre to p.
        let mut cos_w = self.w.dot(v) * inv_d;
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        // θ' = max(0, θ_w − (θ_o + θ_b)); cos and sin of θ_o + θ_b by the sum formulas, and
        // θ' = 0 when θ_o + θ_b reaches π (sin < 0 past it) or θ_w does not exceed it.
        let cos_ob = self.cos_o * cos_b - self.sin_o * sin_b;
        let sin_ob = self.sin_o * cos_b + self.cos_o * sin_b;
        let cos_p = if sin_ob < 0.0 || cos_w >= cos_ob {
            1.0
        } else {
            // cos(θ_w − θ_ob) = cos θ_w cos θ_ob + sin θ_w sin θ_ob.
            let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
            cos_w * cos_ob + sin_w * sin_ob
        };
        // Beyond θ_e of every normal nothing is emitted (exactly at it, only grazing light).
        if cos_p < self.cos_e {
            return 0.0;
        }
        let mut importance = self.phi * cos_p / d2.max(1e-12);
        if n != Vec3::ZERO {
            // θ_i' = max(0, θ_i − θ_b), θ_i between ±n and the direction to the centre.
            let cos_i = n.dot(v).abs() * inv_d;
            if cos_i < cos_b {
                let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
                importance *= cos_i * cos_b + sin_i * sin_b;
            }
        }
        importance
    }
}

impl LightBounds {
    /// The bounds of a finite light; `None` for infinite lights (directional, environment),
    /// which the tree does not hold.
    pub fn of(light: &Light) -> Option<LightBounds> {
        let b = match *light {
            Light::Point {
                position,
                intensity,
            } => LightBounds {
                lo: position,
                hi: position,
                phi: luminance(intensity),
                w: Vec3::Z,
                cos_theta_o: -1.0,
                cos_theta_e: 0.0,
                two_sided: false,
                theta_o: 0.0,
            },
            Light::Spot {
                position,
                axis,
                intensity,
                cos_inner: _,
                cos_outer,
            } => {
                // Light leaves in directions within θ_outer of the axis and nowhere else: the
                // cone of directions is θ_outer wide, with no spread beyond it (θ_e = 0; pbrt
                // puts θ_inner and θ_outer − θ_inner here, which makes cos θ_e negative for
                // wide spots, where a negative cos θ' would then pass the test).
                LightBounds {
                    lo: position,
                    hi: position,
                    phi: luminance(intensity),
                    w: axis,
                    cos_theta_o: cos_outer,
                    cos_theta_e: 1.0,
                    two_sided: false,
                    theta_o: 0.0,
                }
            }
            Light::Triangle {
                v,
                n,
                area,
                emission,
                two_sided,
                ..
            } => LightBounds {
                lo: v[0].min(v[1]).min(v[2]),
                hi: v[0].max(v[1]).max(v[2]),
                phi: area * luminance(emission),
                w: n,
                cos_theta_o: 1.0,
                cos_theta_e: 0.0,
                two_sided,
                theta_o: 0.0,
            },
            Light::Sphere {
                center,
                radius,
                emission,
                ..
            } => LightBounds {
                lo: center - Vec3::splat(radius),
                hi: center + Vec3::splat(radius),
                phi: PI * radius * radius * luminance(emission),
                w: Vec3::Z,
                cos_theta_o: -1.0,
                cos_theta_e: 0.0,
                two_sided: false,
                theta_o: 0.0,
            },
            Light::Directional { .. } | Light::Environment { .. } => return None,
        };
        Some(LightBounds {
            theta_o: acos(b.cos_theta_o.clamp(-1.0, 1.0)),
            ..b
        })
    }

    /// Bounds of both groups of lights.
    pub fn union(&self, o: &LightBounds) -> LightBounds {
        let cone = DirectionCone::union(
            DirectionCone {
                w: self.w,
                cos_theta: self.cos_theta_o,
                theta: self.theta_o,
            },
            DirectionCone {
                w: o.w,
                cos_theta: o.cos_theta_o,
                theta: o.theta_o,
            },
        );
        LightBounds {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
            phi: self.phi + o.phi,
            w: cone.w,
            cos_theta_o: cone.cos_theta,
            cos_theta_e: self.cos_theta_e.min(o.cos_theta_e),
            two_sided: self.two_sided || o.two_sided,
            theta_o: cone.theta,
        }
    }

    fn centroid(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }

    /// An upper estimate of the irradiance the lights give at `p` on a surface of normal `n`
    /// (either side; `n` = 0 for points not on a surface, which leaves out the receiver's
    /// cosine): `phi · cos θ' / d² · cos θ_i'` where, with θ_b the half-angle of the cone from
    /// `p` holding the box,
    ///
    /// * θ' = max(0, θ_w − θ_o − θ_b) bounds from below the angle between any emitter's normal
    ///   and the direction from it to `p` (θ_w is the angle between `w` and the direction from
    ///   the box's centre to `p`; each emitter's normal is within θ_o of `w`, and each emitting
    ///   point within θ_b of the centre seen from `p`): when θ' > θ_e nothing they emit reaches
    ///   `p` and the importance is 0 (at θ' = θ_e = π/2 the light would only graze: 0 too);
    /// * θ_i' = max(0, θ_i − θ_b) bounds the angle at the receiver, θ_i that between `n` and the
    ///   direction to the centre (absolute cosine: light may arrive through a transmissive
    ///   surface);
    /// * d is the distance to the box's centre. Inside the box's bounding sphere (radius r,
    ///   half its diagonal) lights may be in every direction: the importance is then phi / r²
    ///   (so a point inside a large box does not make it infinitely important).
    ///
    /// Zero only where the lights cannot illuminate `p`: behind every one-sided emitter, or
    /// outside every spot's cone.
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        Cluster::of(self).importance(p, n)
    }

    /// The SAOH cost of a group of lights split along axis `dim` of a node's box `node`
    /// (Conty Estevez and Kulla 2018, eq. 3): power × surface area × the orientation measure
    /// M_Ω (the solid angle of the normal cone grown by θ_e, weighted by the cosine), with the
    /// regularisation K_r = longest side / side along `dim` of the node against thin slabs.
    fn cost(&self, node: &LightBounds, dim: usize) -> f32 {
        let theta_o = acos(self.cos_theta_o.clamp(-1.0, 1.0));
        let theta_e = acos(self.cos_theta_e.clamp(-1.0, 1.0));
        let theta_w = (theta_o + theta_e).min(PI);
        let sin_o = sin(theta_o);
        // M_Ω = 2π(1 − cos θ_o) + π/2 (2 θ_w sin θ_o − cos(θ_o − 2θ_w) − 2 θ_o sin θ_o + cos θ_o):
        // the integral of cos(max(0, θ − θ_o)) over the directions within θ_w of the axis.
        let m_omega = 2.0 * PI * (1.0 - self.cos_theta_o)
            + 0.5
                * PI
                * (2.0 * theta_w * sin_o - cos(theta_o - 2.0 * theta_w) - 2.0 * theta_o * sin_o
                    + self.cos_theta_o);
        let diag = node.hi - node.lo;
        let kr = if diag[dim] > 0.0 {
            diag.max_element() / diag[dim]
        } else {
            1.0
        };
        let d = self.hi - self.lo;
        let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        // A group of points (no area) still costs in proportion to power and spread.
        self.phi * m_omega * kr * area.max(1e-12)
    }
}

/// The two children of an inner node side by side, one per lane of 4-wide vectors (lanes 2 and
/// 3 repeat them), so that both importances are computed at once: the same arithmetic as
/// [`Cluster::importance`], branches turned into selections.
#[derive(Debug, Clone, Copy, Default)]
struct ChildPair {
    cx: Vec4,
    cy: Vec4,
    cz: Vec4,
    radius: Vec4,
    wx: Vec4,
    wy: Vec4,
    wz: Vec4,
    phi: Vec4,
    cos_o: Vec4,
    sin_o: Vec4,
    cos_e: Vec4,
    /// 1 for two-sided, 0 for one-sided.
    two_sided: Vec4,
}

impl ChildPair {
    fn of(a: &Cluster, b: &Cluster) -> ChildPair {
        let lanes = |f: &dyn Fn(&Cluster) -> f32| Vec4::new(f(a), f(b), f(a), f(b));
        ChildPair {
            cx: lanes(&|c| c.center.x),
            cy: lanes(&|c| c.center.y),
            cz: lanes(&|c| c.center.z),
            radius: lanes(&|c| c.radius),
            wx: lanes(&|c| c.w.x),
            wy: lanes(&|c| c.w.y),
            wz: lanes(&|c| c.w.z),
            phi: lanes(&|c| c.phi),
            cos_o: lanes(&|c| c.cos_o),
            sin_o: lanes(&|c| c.sin_o),
            cos_e: lanes(&|c| c.cos_e),
            two_sided: lanes(&|c| if c.two_sided { 1.0 } else { 0.0 }),
        }
    }

    /// The importances of both children at `p`, `n` (lanes 0 and 1).
    #[inline(always)]
    fn importance(&self, p: Vec3, n: Vec3) -> Vec4 {
        let one = Vec4::ONE;
        let (vx, vy, vz) = (
            Vec4::splat(p.x) - self.cx,
            Vec4::splat(p.y) - self.cy,
            Vec4::splat(p.z) - self.cz,
        );
        let d2 = vx * vx + vy * vy + vz * vz;
        let r2 = self.radius * self.radius;
        let inside = d2.cmple(r2);
        // In lanes where p is inside the bounding sphere these may be ∞ or NaN; the last
        // selection replaces them.
        let inv_d = d2.sqrt().recip();
        let sin_b = self.radius * inv_d;
        let cos_b = (one - sin_b * sin_b).max(Vec4::ZERO).sqrt();
        let cos_w = (self.wx * vx + self.wy * vy + self.wz * vz) * inv_d;
        let cos_w = Vec4::select(self.two_sided.cmpgt(Vec4::ZERO), cos_w.abs(), cos_w);
        let cos_ob = self.cos_o * cos_b - self.sin_o * sin_b;
        let sin_ob = self.sin_o * cos_b + self.cos_o * sin_b;
        let sin_w = (one - cos_w * cos_w).max(Vec4::ZERO).sqrt();
        let full = sin_ob.cmplt(Vec4::ZERO) | cos_w.cmpge(cos_ob);
        let cos_p = Vec4::select(full, one, cos_w * cos_ob + sin_w * sin_ob);
        let mut importance = self.phi * cos_p / d2.max(Vec4::splat(1e-12));
        if n != Vec3::ZERO {
            let cos_i = (Vec4::splat(n.x) * vx + Vec4::splat(n.y) * vy + Vec4::splat(n.z) * vz)
                .abs()
                * inv_d;
            let sin_i = (one - cos_i * cos_i).max(Vec4::ZERO).sqrt();
            importance *= Vec4::select(cos_i.cmplt(cos_b), cos_i * cos_b + sin_i * sin_b, one);
        }
        let importance = Vec4::select(cos_p.cmplt(self.cos_e), Vec4::ZERO, importance);
        Vec4::select(inside, self.phi / r2.max(Vec4::splat(1e-12)), importance)
    }
}

/// A node of the tree: for an inner node, the index of its second child (the first follows it)
/// and of its children's bounds in `pairs`; for a leaf, the light it holds. (A node's own
/// bounds are only needed beside its sibling's, in its parent's pair.)
#[derive(Debug, Clone)]
struct Node {
    /// Index of the second child, or of the light for a leaf.
    index: u32,
    /// Index into `pairs` (inner nodes).
    pair: u32,
    leaf: bool,
}

/// Where the tree put a light.
#[derive(Debug, Clone, Copy)]
enum Slot {
    /// Not in the tree (infinite, or nothing to emit).
    Outside,
    /// In the tree: its path from the root, one bit per level, least significant first.
    Trail(u64),
}

/// The tree over the finite lights.
#[derive(Debug, Clone, Default)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// For each inner node, its children's bounds side by side.
    pairs: Vec<ChildPair>,
    slots: Vec<Slot>,
}

impl LightTree {
    /// Builds the tree over the finite lights of `lights` that emit; the others are left out
    /// (their pmf is 0). The build is sequential and its choices depend only on the lights and
    /// their order, so the tree is the same on any machine and thread count.
    pub fn new(lights: &[Light]) -> LightTree {
        let mut items: Vec<(u32, LightBounds)> = lights
            .iter()
            .enumerate()
            .filter_map(|(i, l)| {
                let b = LightBounds::of(l)?;
                (b.phi > 0.0 && b.phi.is_finite() && b.lo.is_finite() && b.hi.is_finite())
                    .then_some((i as u32, b))
            })
            .collect();
        let mut tree = LightTree {
            nodes: Vec::with_capacity(2 * items.len()),
            pairs: Vec::with_capacity(items.len()),
            slots: vec![Slot::Outside; lights.len()],
        };
        if !items.is_empty() {
            // Each node's bounds, by node index, while building.
            let mut clusters = Vec::with_capacity(2 * items.len());
            tree.build(&mut items, 0, 0, &mut clusters);
            for at in 0..tree.nodes.len() {
                if !tree.nodes[at].leaf {
                    tree.nodes[at].pair = tree.pairs.len() as u32;
                    let second = tree.nodes[at].index as usize;
                    tree.pairs
                        .push(ChildPair::of(&clusters[at + 1], &clusters[second]));
                }
            }
        }
        tree
    }

    /// Whether the tree holds no light.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Lights in the tree.
    pub fn len(&self) -> usize {
        self.slots
            .iter()
            .filter(|s| matches!(s, Slot::Trail(_)))
            .count()
    }

    /// Mean and largest depth of the lights in the tree (the root at depth 0): how many levels a
    /// pick walks.
    pub fn depths(&self) -> (f32, u32) {
        let (mut sum, mut max, mut leaves) = (0u64, 0u32, 0u64);
        let mut stack = vec![(0usize, 0u32)];
        while let Some((at, d)) = stack.pop() {
            if self.nodes.is_empty() {
                break;
            }
            if self.nodes[at].leaf {
                sum += u64::from(d);
                max = max.max(d);
                leaves += 1;
            } else {
                stack.push((at + 1, d + 1));
                stack.push((self.nodes[at].index as usize, d + 1));
            }
        }
        (sum as f32 / leaves.max(1) as f32, max)
    }

    /// Adds the subtree over `items` (reached from the root by `trail`, `depth` bits long);
    /// returns its root's index.
    fn build(
        &mut self,
        items: &mut [(u32, LightBounds)],
        depth: u32,
        trail: u64,
        clusters: &mut Vec<Cluster>,
    ) -> usize {
        let bounds = items[1..]
            .iter()
            .fold(items[0].1, |acc, (_, b)| acc.union(b));
        let at = self.nodes.len();
        if items.len() == 1 {
            self.nodes.push(Node {
                index: items[0].0,
                pair: 0,
                leaf: true,
            });
            clusters.push(Cluster::of(&bounds));
            self.slots[items[0].0 as usize] = Slot::Trail(trail);
            return at;
        }
        self.nodes.push(Node {
            index: 0,
            pair: 0,
            leaf: false,
        });
        clusters.push(Cluster::of(&bounds));
        let mid = if depth >= BALANCED_FROM_DEPTH {
            None
        } else {
            Self::saoh_split(items, &bounds)
        }
        .unwrap_or_else(|| {
            // Halve by count along the longest axis of the centroids, ties by light index.
            let (clo, chi) = centroid_box(items);
            let dim = (chi - clo).max_position();
            items.sort_by(|a, b| {
                a.1.centroid()[dim]
                    .total_cmp(&b.1.centroid()[dim])
                    .then(a.0.cmp(&b.0))
            });
            items.len() / 2
        });
        let (left, right) = items.split_at_mut(mid);
        self.build(left, depth + 1, trail, clusters);
        let second = self.build(right, depth + 1, trail | (1u64 << depth), clusters);
        self.nodes[at].index = second as u32;
        at
    }

    /// Reorders `items` so that the cheapest SAOH split over [`BUCKETS`] buckets along each
    /// axis of the centroids' box puts the first group first; returns its size, or `None`
    /// when no split separates the lights (all centroids equal).
    fn saoh_split(items: &mut [(u32, LightBounds)], node: &LightBounds) -> Option<usize> {
        let (clo, chi) = centroid_box(items);
        let bucket_of = |b: &LightBounds, dim: usize| {
            let t = (b.centroid()[dim] - clo[dim]) / (chi[dim] - clo[dim]);
            ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
        };
        let mut best: Option<(f32, usize, usize)> = None; // (cost, dim, first bucket on the right)
        for dim in 0..3 {
            if chi[dim] <= clo[dim] {
                continue;
            }
            let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
            for (_, b) in items.iter() {
                let k = bucket_of(b, dim);
                buckets[k] = Some(buckets[k].map_or(*b, |acc| acc.union(b)));
            }
            // Suffix unions, so each split costs one union from each side.
            let mut right: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
            let mut acc: Option<LightBounds> = None;
            for k in (0..BUCKETS).rev() {
                acc = match (acc, buckets[k]) {
                    (Some(a), Some(b)) => Some(a.union(&b)),
                    (a, b) => a.or(b),
                };
                right[k] = acc;
            }
            let mut left: Option<LightBounds> = None;
            for split in 1..BUCKETS {
                left = match (left, buckets[split - 1]) {
                    (Some(a), Some(b)) => Some(a.union(&b)),
                    (a, b) => a.or(b),
                };
                let (Some(l), Some(r)) = (left, right[split]) else {
                    continue;
                };
                let cost = l.cost(node, dim) + r.cost(node, dim);
                if cost.is_finite() && best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, dim, split));
                }
            }
        }
        let (_, dim, split) = best?;
        // Stable partition: the order within each side stays that of the input.
        let (mut l, r): (Vec<_>, Vec<_>) =
            items.iter().partition(|(_, b)| bucket_of(b, dim) < split);
        let mid = l.len();
        l.extend(r);
        items.copy_from_slice(&l);
        (mid > 0 && mid < items.len()).then_some(mid)
    }

    /// Probability of taking the first child of inner node `at` from `p`, `n`: in proportion
    /// to the children's importance. When both are 0 (their bounds, tighter than their
    /// parent's, show that none of their lights reaches `p`), in proportion to their power:
    /// whatever is picked there contributes nothing, but the probabilities of all lights still
    /// sum to 1 at every point. Both [`LightTree::pick`] and [`LightTree::pmf`] go through here,
    /// so the probability of a pick and that reported for the same light are the same floats.
    #[inline(always)]
    fn first_child_probability(&self, at: usize, p: Vec3, n: Vec3) -> f32 {
        let pair = &self.pairs[self.nodes[at].pair as usize];
        let i = pair.importance(p, n);
        let sum = i.x + i.y;
        if sum > 0.0 {
            i.x / sum
        } else {
            pair.phi.x / (pair.phi.x + pair.phi.y)
        }
    }

    /// Picks a light for the shading point `p` with normal `n` (zero if none) with the uniform
    /// number `u`: its index, its probability, and `u` remapped to a fresh uniform number in
    /// [0, 1) (pbrt-v4's `SampleDiscrete` applied at each level). `None` when the tree is
    /// empty.
    pub fn pick(&self, p: Vec3, n: Vec3, mut u: f32) -> Option<(usize, f32, f32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut at = 0;
        let mut pmf = 1.0f32;
        loop {
            let node = &self.nodes[at];
            if node.leaf {
                return Some((node.index as usize, pmf, u));
            }
            let p0 = self.first_child_probability(at, p, n);
            if u < p0 {
                u = (u / p0).min(ONE_MINUS_EPSILON);
                pmf *= p0;
                at += 1;
            } else {
                let p1 = 1.0 - p0;
                u = ((u - p0) / p1).min(ONE_MINUS_EPSILON);
                pmf *= p1;
                at = node.index as usize;
            }
        }
    }

    /// Probability that [`LightTree::pick`] returns light `i` at `p`, `n`.
    pub fn pmf(&self, p: Vec3, n: Vec3, i: usize) -> f32 {
        let Some(Slot::Trail(mut trail)) = self.slots.get(i).copied() else {
            return 0.0;
        };
        let mut at = 0;
        let mut pmf = 1.0f32;
        while !self.nodes[at].leaf {
            let p0 = self.first_child_probability(at, p, n);
            if trail & 1 == 0 {
                pmf *= p0;
                at += 1;
            } else {
                pmf *= 1.0 - p0;
                at = self.nodes[at].index as usize;
            }
            trail >>= 1;
        }
        debug_assert_eq!(self.nodes[at].index as usize, i);
        pmf
    }
}

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// The box of the lights' centroids.
fn centroid_box(items: &[(u32, LightBounds)]) -> (Vec3, Vec3) {
    items.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), (_, b)| (lo.min(b.centroid()), hi.max(b.centroid())),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::chi2;
    use crate::light::tests::triangle_light as triangle;
    use crate::light_sampler::{LightSampler, LightSamplerKind};
    use crate::math::Vec2;
    use crate::sampler::Pcg32;

    fn unit(rng: &mut Pcg32) -> Vec3 {
        let z = 1.0 - 2.0 * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * rng.next_f32();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    fn in_box(rng: &mut Pcg32, half: f32) -> Vec3 {
        Vec3::new(
            (2.0 * rng.next_f32() - 1.0) * half,
            (2.0 * rng.next_f32() - 1.0) * half,
            (2.0 * rng.next_f32() - 1.0) * half,
        )
    }

    /// 60 triangles (a quarter two-sided) of random size, orientation and emission in a box of
    /// side 10, four point lights, four spots, three spheres and a directional light.
    fn lights() -> Vec<Light> {
        let mut rng = Pcg32::new(5, 1);
        let mut lights = Vec::new();
        for k in 0..60 {
            let c = in_box(&mut rng, 5.0);
            let s = 0.1 + 0.9 * rng.next_f32();
            let v = [
                c + unit(&mut rng) * s,
                c + unit(&mut rng) * s,
                c + unit(&mut rng) * s,
            ];
            let e = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
            lights.push(triangle(v, e, k % 4 == 0));
        }
        for _ in 0..4 {
            lights.push(Light::Point {
                position: in_box(&mut rng, 5.0),
                intensity: Vec3::splat(rng.next_f32()),
            });
        }
        for _ in 0..4 {
            lights.push(Light::Spot {
                position: in_box(&mut rng, 5.0),
                axis: unit(&mut rng),
                intensity: Vec3::splat(2.0 * rng.next_f32()),
                cos_inner: 0.9,
                cos_outer: 0.7,
            });
        }
        for _ in 0..3 {
            lights.push(Light::Sphere {
                instance: 0,
                center: in_box(&mut rng, 5.0),
                radius: 0.2 + 0.3 * rng.next_f32(),
                emission: Vec3::splat(rng.next_f32()),
            });
        }
        lights.push(Light::Directional {
            to_light: unit(&mut rng),
            irradiance: Vec3::splat(0.5),
            scene_radius: 8.0,
        });
        lights
    }

    /// Shading points and normals: on surfaces, inside the cloud of lights and far from it, and
    /// one not on a surface (normal 0).
    fn points() -> Vec<(&'static str, Vec3, Vec3)> {
        vec![
            ("centre", Vec3::ZERO, Vec3::Y),
            (
                "corner",
                Vec3::new(4.5, -4.5, 4.0),
                Vec3::new(-1.0, 1.0, 0.0).normalize(),
            ),
            (
                "far above",
                Vec3::new(1.0, 30.0, -2.0),
                Vec3::new(0.2, -1.0, 0.1).normalize(),
            ),
            (
                "side, grazing",
                Vec3::new(-6.0, 0.5, 0.0),
                Vec3::new(0.05, 1.0, 0.0).normalize(),
            ),
            ("in a medium", Vec3::new(2.0, 1.0, -3.0), Vec3::ZERO),
        ]
    }

    /// The frequency of each light and of the remapped number (in eight bins) matches
    /// pmf(p, n, i) × uniform, every pick reports exactly the pmf that `pmf` gives, and the
    /// same picks reject the power sampler's probabilities (the test can tell them apart).
    #[test]
    fn picks_follow_the_pmf() {
        const N: usize = 400_000;
        const UB: usize = 8;
        let lights = lights();
        let sampler = LightSampler::new(&lights, LightSamplerKind::Tree);
        assert!(sampler.is_tree());
        let power = crate::light_sampler::PowerSampler::new(&lights);
        let mut ps = Vec::new();
        for (name, p, n) in points() {
            let mut rng = Pcg32::new(9, 2);
            let mut observed = vec![0.0f64; lights.len() * UB];
            for _ in 0..N {
                let u = rng.next_f32();
                let Some((i, pmf, ur)) = sampler.pick(p, n, u) else {
                    continue;
                };
                assert_eq!(pmf, sampler.pmf(p, n, i), "{name}: light {i}");
                assert!((0.0..1.0).contains(&ur), "{name}: remapped {ur}");
                observed[i * UB + ((ur * UB as f32) as usize).min(UB - 1)] += 1.0;
            }
            let expected: Vec<f64> = (0..lights.len() * UB)
                .map(|k| f64::from(sampler.pmf(p, n, k / UB)) * N as f64 / UB as f64)
                .collect();
            ps.push((
                name.to_string(),
                chi2::p_value_of_counts(name, &observed, &expected),
            ));
            let by_power: Vec<f64> = (0..lights.len() * UB)
                .map(|k| f64::from(power.pmf(k / UB)) * N as f64 / UB as f64)
                .collect();
            let mut observed_any = observed.clone();
            // Lights the tree rules out would make the comparison panic (samples where the
            // power pdf is zero cannot occur the other way round): compare on the power's bins.
            for (o, e) in observed_any.iter_mut().zip(&by_power) {
                if *e == 0.0 {
                    *o = 0.0;
                }
            }
            let p_power = chi2::p_value_of_counts(name, &observed_any, &by_power);
            assert!(p_power < 1e-6, "{name}: power pmf not rejected ({p_power})");
        }
        chi2::assert_all_pass(&ps);
    }

    /// The two-lane evaluation of a node's children gives the importances of the scalar one.
    #[test]
    fn child_pairs_match_scalar_importance() {
        let lights = lights();
        let bounds: Vec<Cluster> = lights
            .iter()
            .filter_map(LightBounds::of)
            .map(|b| Cluster::of(&b))
            .collect();
        let mut rng = Pcg32::new(1, 9);
        for k in 0..20_000 {
            let (a, b) = (
                &bounds[k % bounds.len()],
                &bounds[(k * 7 + 3) % bounds.len()],
            );
            let pair = ChildPair::of(a, b);
            // Points near the lights too, where the bounding spheres hold them.
            let p = if k % 3 == 0 {
                a.center + unit(&mut rng) * a.radius * 2.0 * rng.next_f32()
            } else {
                in_box(&mut rng, 8.0)
            };
            let n = if k % 4 == 0 {
                Vec3::ZERO
            } else {
                unit(&mut rng)
            };
            let i = pair.importance(p, n);
            for (got, c) in [(i.x, a), (i.y, b)] {
                let want = c.importance(p, n);
                assert!(
                    (got - want).abs() <= 1e-4 * want.max(1e-6) && (got == 0.0) == (want == 0.0),
                    "{p:?} {n:?}: {got} vs {want}"
                );
            }
        }
    }

    /// Over random shading points the probabilities of all lights sum to 1.
    #[test]
    fn pmf_sums_to_one() {
        let lights = lights();
        let sampler = LightSampler::new(&lights, LightSamplerKind::Tree);
        let mut rng = Pcg32::new(3, 4);
        for k in 0..2000 {
            let p = in_box(&mut rng, 8.0);
            let n = if k % 5 == 0 {
                Vec3::ZERO
            } else {
                unit(&mut rng)
            };
            let sum: f64 = (0..lights.len())
                .map(|i| f64::from(sampler.pmf(p, n, i)))
                .sum();
            assert!((sum - 1.0).abs() < 1e-4, "{p:?}, {n:?}: {sum}");
        }
    }

    /// A light gets probability 0 only where it cannot contribute: behind a one-sided
    /// triangle, outside a spot's cone. Wherever sampling the light yields a point that emits
    /// towards p (and not exactly in p's tangent plane) its pmf is positive; and the tree
    /// does rule lights out (a fifth of the pairs here), so the check is not vacuous.
    #[test]
    fn pmf_is_zero_only_where_a_light_cannot_contribute() {
        let lights = lights();
        let sampler = LightSampler::new(&lights, LightSamplerKind::Tree);
        let mut rng = Pcg32::new(8, 8);
        let (mut pairs, mut zero) = (0usize, 0usize);
        for _ in 0..300 {
            let p = in_box(&mut rng, 7.0);
            let n = unit(&mut rng);
            for (i, light) in lights.iter().enumerate() {
                let pmf = sampler.pmf(p, n, i);
                pairs += 1;
                let contributes = (0..64).any(|k| {
                    let u = Vec2::new((k as f32 + 0.5) / 64.0, rng.next_f32());
                    light.sample(p, u).is_some_and(|s| {
                        let emits = match light {
                            Light::Triangle {
                                n: nl, two_sided, ..
                            } => *two_sided || nl.dot(-s.wi) > 0.0,
                            _ => true,
                        };
                        emits && s.wi.dot(n) != 0.0 && s.li.is_finite()
                    })
                });
                if contributes {
                    assert!(pmf > 0.0, "light {i} at {p:?}: pmf 0 but it contributes");
                }
                if pmf == 0.0 {
                    zero += 1;
                }
            }
        }
        assert!(zero * 5 > pairs / 2, "{zero} of {pairs} pairs ruled out");
        // Behind a lone one-sided triangle (beside a point light) it is never picked.
        let tri = triangle([Vec3::ZERO, Vec3::X, Vec3::Y], Vec3::ONE, false);
        let two = vec![
            tri,
            Light::Point {
                position: Vec3::new(3.0, 0.0, 0.0),
                intensity: Vec3::ONE,
            },
        ];
        let s = LightSampler::new(&two, LightSamplerKind::Tree);
        for (p, n) in [
            (Vec3::new(0.2, 0.2, -1.0), Vec3::Z),
            (Vec3::new(0.5, 0.5, -2.0), Vec3::ZERO),
        ] {
            assert_eq!(s.pmf(p, n, 0), 0.0);
            assert_eq!(s.pmf(p, n, 1), 1.0);
            assert!((0..100).all(|k| s.pick(p, n, k as f32 / 100.0).unwrap().0 == 1));
        }
        assert!(s.pmf(Vec3::new(0.2, 0.2, 1.0), Vec3::Z, 0) > 0.5);
    }
}
