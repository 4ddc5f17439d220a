//! Spheres in object space.

use crate::lanes::math;
use crate::math::{Aabb, Vec2, Vec3};
use std::f32::consts::PI;

/// A sphere.
#[derive(Debug, Clone, Copy)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
}

impl Sphere {
    /// Bounds.
    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: self.center - Vec3::splat(self.radius),
            max: self.center + Vec3::splat(self.radius),
        }
    }

    /// Closest hit parameter within (t_min, t_max). Uses the discriminant form of Hearn and
    /// Baker as recommended in Ray Tracing Gems ch. 7 (Haines et al., "Precision Improvements
    /// for Ray/Sphere Intersection"): r² − |f − (f·d̂)d̂|² loses no precision for distant spheres,
    /// and the nearer root comes from the stable quadratic formula.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let len = d.length();
        let dn = d / len;
        let f = o - self.center;
        let b = -f.dot(dn);
        let perp = f + dn * b;
        let disc = self.radius * self.radius - perp.length_squared();
        if disc < 0.0 {
            return None;
        }
        let c = f.length_squared() - self.radius * self.radius;
        let q = b + disc.sqrt().copysign(b);
        let (mut t0, mut t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q) };
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        [t0 / len, t1 / len]
            .into_iter()
            .find(|&t| t > t_min && t < t_max)
    }

    /// The point on the sphere nearest to `p` (re-projection removes the error of o + t d),
    /// its outward normal and texture coordinates (u = φ/2π from +x towards −z about +y,
    /// v = 1 at +y).
    pub fn surface(&self, p: Vec3) -> (Vec3, Vec3, Vec2) {
        let n = (p - self.center).normalize();
        let p = self.center + n * self.radius;
        let mut phi = math::atan2(-n.z, n.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let v = 1.0 - math::acos(n.y.clamp(-1.0, 1.0)) / PI;
        (p, n, Vec2::new(phi / (2.0 * PI), v))
    }
}

/// An infinite plane n·p = offset (n unit length).
#[derive(Debug, Clone, Copy)]
pub struct Plane {
    /// Unit normal.
    pub normal: Vec3,
    /// Offset along the normal.
    pub offset: f32,
}

impl Plane {
    /// Hit parameter within (t_min, t_max).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let denom = self.normal.dot(d);
        if denom == 0.0 {
            return None;
        }
        let t = (self.offset - self.normal.dot(o)) / denom;
        (t > t_min && t < t_max).then_some(t)
    }

    /// Texture coordinates: the point's coordinates along the plane's two tangent axes.
    pub fn uv(&self, p: Vec3) -> Vec2 {
        let f = crate::math::Frame::from_normal(self.normal);
        Vec2::new(p.dot(f.s), p.dot(f.t))
    }

    /// The point of the plane nearest to `p`.
    pub fn project(&self, p: Vec3) -> Vec3 {
        p - self.normal * (self.normal.dot(p) - self.offset)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_hits_from_outside_inside_and_far_away() {
        let s = Sphere {
            center: Vec3::new(0.0, 0.0, -5.0),
            radius: 1.0,
        };
        let t = s
            .intersect(Vec3::ZERO, Vec3::new(0.0, 0.0, -2.0), 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        let t = s
            .intersect(Vec3::new(0.0, 0.0, -5.0), Vec3::X, 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        let far = Sphere {
            center: Vec3::new(0.0, 0.0, -1e6),
            radius: 1.0,
        };
        let t = far
            .intersect(Vec3::ZERO, -Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - (1e6 - 1.0)).abs() / 1e6 < 1e-6);
        assert!(s
            .intersect(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY)
            .is_none());
    }

    #[test]
    fn sphere_uv_convention() {
        let s = Sphere {
            center: Vec3::ZERO,
            radius: 2.0,
        };
        let (_, n, uv) = s.surface(Vec3::new(0.0, 5.0, 0.0));
        assert!((n - Vec3::Y).length() < 1e-6 && (uv.y - 1.0).abs() < 1e-6);
        let (_, _, uv) = s.surface(Vec3::new(0.0, 0.0, -2.0));
        assert!((uv.x - 0.25).abs() < 1e-6 && (uv.y - 0.5).abs() < 1e-6);
    }
}
