//! Watertight ray–triangle intersection: Woop, Benthin and Wald, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1), 2013. The ray is sheared so it runs along +z; edge functions are
//! then evaluated in 2D, with a fallback to f64 when one is exactly zero, so rays never slip
//! through the shared edge of two triangles.

use crate::math::Vec3;

/// Per-ray constants of the shear transform.
#[derive(Debug, Clone, Copy)]
pub struct RayShear {
    o: Vec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl RayShear {
    /// Precomputes the shear for a ray with origin `o` and direction `d`.
    pub fn new(o: Vec3, d: Vec3) -> RayShear {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z { 0 } else if a.y >= a.z { 1 } else { 2 };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayShear { o, kx, ky, kz, sx: d[kx] / d[kz], sy: d[ky] / d[kz], sz: 1.0 / d[kz] }
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
pub fn intersect(r: &RayShear, v0: Vec3, v1: Vec3, v2: Vec3, t_min: f32, t_max: f32) -> Option<TriHit> {
    let a = v0 - r.o;
    let b = v1 - r.o;
    let c = v2 - r.o;
    let ax = a[r.kx] - r.sx * a[r.kz];
    let ay = a[r.ky] - r.sy * a[r.kz];
    let bx = b[r.kx] - r.sx * b[r.kz];
    let by = b[r.ky] - r.sy * b[r.kz];
    let cx = c[r.kx] - r.sx * c[r.kz];
    let cy = c[r.ky] - r.sy * c[r.kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        // Exactly on an edge in f32: decide in double precision so neighbours agree.
        u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
        v = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
        w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let az = r.sz * a[r.kz];
    let bz = r.sz * b[r.kz];
    let cz = r.sz * c[r.kz];
    let t_scaled = u * az + v * bz + w * cz;
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t > t_min && t < t_max) {
        return None;
    }
    Some(TriHit { t, b1: v * inv, b2: w * inv })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_through_a_shared_edge_hit_exactly_one_side_or_both_never_neither() {
        // Two triangles sharing the diagonal of the unit square; rays aimed exactly at the
        // diagonal from many directions must never pass between them.
        let (p0, p1, p2, p3) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let mut misses = 0;
        // Interior points of the shared edge (its ends are on the square's outer boundary,
        // where a miss is legitimate).
        for i in 1..1000 {
            let s = i as f32 / 1000.0;
            let target = Vec3::new(s, s, 0.0);
            for o in [Vec3::new(0.3, 0.7, 1.0), Vec3::new(-2.0, 5.0, 3.0), Vec3::new(0.5, 0.5, -2.0), Vec3::new(7.1, -3.3, 0.9)] {
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
        assert!((h.t - 2.0).abs() < 1e-6 && (h.b1 - 0.25).abs() < 1e-6 && (h.b2 - 0.5).abs() < 1e-6);
        assert!(intersect(&r, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0, 1.5).is_none());
    }
}
