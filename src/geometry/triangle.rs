//! Watertight ray–triangle intersection: Woop, Benthin and Wald, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1), 2013. The ray is sheared so it runs along +z; edge functions are
//! then evaluated in 2D, with a fallback to f64 when one is exactly zero, so rays never slip
//! through the shared edge of two triangles.

use glam::{Mat3A, Vec3A};

use crate::math::Vec3;

/// Per-ray constants of the shear transform.
///
/// With `kz` the dominant axis of the direction and (kx, ky) the other two (swapped when
/// d\[kz\] < 0 to keep the winding), a vertex a relative to the origin maps to
/// (a\[kx\] − sx·a\[kz\], a\[ky\] − sy·a\[kz\], sz·a\[kz\]). That map is stored as a matrix whose columns
/// are the images of the unit axes: (1, 0, 0) for kx, (0, 1, 0) for ky and (−sx, −sy, sz) for
/// kz. Multiplying by it adds the same products as the scalar formula plus exact zeros, so the
/// result is bit-identical to the paper's, without per-ray branching on axis indices.
#[derive(Debug, Clone, Copy)]
pub struct RayShear {
    o: Vec3A,
    m: Mat3A,
}

/// The shear's axis permutation [kx, ky, kz] for direction `d`: kz is the dominant axis, and kx,
/// ky follow it cyclically, swapped when d\[kz\] < 0 so the triangles' winding is kept.
#[inline]
pub fn shear_axes(d: Vec3) -> [usize; 3] {
    let a = d.abs();
    let kz = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if d[kz] < 0.0 {
        [ky, kx, kz]
    } else {
        [kx, ky, kz]
    }
}

impl RayShear {
    /// Precomputes the shear for a ray with origin `o` and direction `d`.
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> RayShear {
        let [kx, ky, kz] = shear_axes(d);
        let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        let mut cols = [Vec3A::ZERO; 3];
        cols[kx] = Vec3A::X;
        cols[ky] = Vec3A::Y;
        cols[kz] = Vec3A::new(-sx, -sy, sz);
        RayShear {
            o: o.into(),
            m: Mat3A::from_cols(cols[0], cols[1], cols[2]),
        }
    }

    /// The vertex in the sheared frame: (x, y) relative to the ray, z scaled along it.
    #[inline(always)]
    fn map(&self, v: Vec3A) -> Vec3A {
        self.m * (v - self.o)
    }
}

/// A hit on a triangle: distance and barycentric coordinates of v1 and v2 (b0 = 1 − b1 − b2).
#[derive(Debug, Clone, Copy)]
pub struct TriHit {
    /// Ray parameter.
    pub t: f32,
    /// Weight of vertex 1.
    pub b1: f32,
    /// Weight of vertex 2.
    pub b2: f32,
}

/// Intersects the sheared ray with triangle (v0, v1, v2) within (t_min, t_max). Both faces hit.
#[inline]
pub fn intersect(
    r: &RayShear,
    v0: Vec3,
    v1: Vec3,
    v2: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<TriHit> {
    intersect_a(r, &[v0.into(), v1.into(), v2.into()], t_min, t_max)
}

/// The edge functions (u, v, w) of the sheared corners a, b, c (x and y) in f64, rounded to
/// f32: the watertight test's decision for a ray exactly on an edge in f32, so neighbouring
/// triangles agree. Every form of the test (scalar, the BVH's packets, the small set's lanes)
/// takes it from here.
#[inline(always)]
pub(crate) fn edge_functions_f64(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> [f32; 3] {
    let ([ax, ay], [bx, by], [cx, cy]) = (a.map(f64::from), b.map(f64::from), c.map(f64::from));
    [
        (cx * by - cy * bx) as f32,
        (ax * cy - ay * cx) as f32,
        (bx * ay - by * ax) as f32,
    ]
}

/// [`intersect`] on corners stored in SIMD layout (as the triangle sets keep them).
#[inline(always)]
pub fn intersect_a(r: &RayShear, v: &[Vec3A; 3], t_min: f32, t_max: f32) -> Option<TriHit> {
    let a = r.map(v[0]);
    let b = r.map(v[1]);
    let c = r.map(v[2]);
    let mut u = c.x * b.y - c.y * b.x;
    let mut v = a.x * c.y - a.y * c.x;
    let mut w = b.x * a.y - b.y * a.x;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        // Exactly on an edge in f32: decide in double precision so neighbours agree.
        [u, v, w] = edge_functions_f64([a.x, a.y], [b.x, b.y], [c.x, c.y]);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t_scaled = u * a.z + v * b.z + w * c.z;
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t > t_min && t < t_max) {
        return None;
    }
    Some(TriHit {
        t,
        b1: v * inv,
        b2: w * inv,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_through_a_shared_edge_hit_exactly_one_side_or_both_never_neither() {
        // Two triangles sharing the diagonal of the unit square; rays aimed exactly at the
        // diagonal from many directions must never pass between them.
        let (p0, p1, p2, p3) = (
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        let mut misses = 0;
        // Interior points of the shared edge (its ends are on the square's outer boundary,
        // where a miss is legitimate).
        for i in 1..1000 {
            let s = i as f32 / 1000.0;
            let target = Vec3::new(s, s, 0.0);
            for o in [
                Vec3::new(0.3, 0.7, 1.0),
                Vec3::new(-2.0, 5.0, 3.0),
                Vec3::new(0.5, 0.5, -2.0),
                Vec3::new(7.1, -3.3, 0.9),
            ] {
                let d = target - o;
                let r = RayShear::new(o, d);
                let h1 = intersect(&r, p0, p1, p2, 0.0, f32::INFINITY);
                let h2 = intersect(&r, p0, p2, p3, 0.0, f32::INFINITY);
                if h1.is_none() && h2.is_none() {
                    misses += 1;
                }
            }
        }
        assert_eq!(misses, 0);
    }

    #[test]
    fn barycentrics_and_distance_are_right() {
        let r = RayShear::new(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let h = intersect(&r, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0, 10.0).unwrap();
        assert!(
            (h.t - 2.0).abs() < 1e-6 && (h.b1 - 0.25).abs() < 1e-6 && (h.b2 - 0.5).abs() < 1e-6
        );
        assert!(intersect(&r, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0, 1.5).is_none());
    }
}
