//! Perspective cameras: a pinhole, or a thin lens with depth of field.

use crate::lanes::{F32s, V3s};
use crate::math::{Ray, Vec2, Vec3};
use crate::sampling::concentric_disk;

/// A perspective camera.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    /// Lens centre.
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit right vector of the image plane.
    pub right: Vec3,
    /// Unit up vector of the image plane.
    pub up: Vec3,
    /// tan(fov_y / 2).
    pub tan_half_fov_y: f32,
    /// Width / height of the image.
    pub aspect: f32,
    /// Radius of the lens (0 = pinhole).
    pub lens_radius: f32,
    /// Distance along `forward` to the plane in focus.
    pub focus_distance: f32,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, with vertical field of view `fov_y_deg`.
    pub fn look_at(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        aspect: f32,
        lens_radius: f32,
        focus_distance: Option<f32>,
    ) -> Camera {
        let forward = (look_at - position).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        Camera {
            position,
            forward,
            right,
            up,
            tan_half_fov_y: crate::lanes::math::tan(fov_y_deg.to_radians() * 0.5),
            aspect,
            lens_radius,
            focus_distance: focus_distance.unwrap_or((look_at - position).length()),
        }
    }

    /// The ray through film position `film` ∈ [0, 1]² ((0, 0) = top-left of the image), using
    /// `u_lens` to pick a point on the lens (sampled uniformly over the disk by the concentric
    /// map). Direction is unit length.
    pub fn ray(&self, film: Vec2, u_lens: Vec2) -> Ray {
        let sx = (2.0 * film.x - 1.0) * self.tan_half_fov_y * self.aspect;
        let sy = (1.0 - 2.0 * film.y) * self.tan_half_fov_y;
        let dir = self.forward + self.right * sx + self.up * sy;
        if self.lens_radius <= 0.0 {
            return Ray::new(self.position, dir.normalize());
        }
        // Every ray through the lens meets the pinhole ray on the plane of focus.
        let focus = self.position + dir * self.focus_distance;
        let lens = concentric_disk(u_lens) * self.lens_radius;
        let origin = self.position + self.right * lens.x + self.up * lens.y;
        Ray::new(origin, (focus - origin).normalize())
    }

    /// The directions of [`ray`](Self::ray) through the film positions `(x, y)` of W lanes, for
    /// a pinhole camera (their origin is `position`), with the same operations in every lane.
    #[inline(always)]
    pub fn pinhole_directions<const W: usize>(&self, (x, y): (F32s<W>, F32s<W>)) -> V3s<W> {
        let one = F32s::splat(1.0);
        let two = F32s::splat(2.0);
        let tan = F32s::splat(self.tan_half_fov_y);
        let sx = (two * x - one) * tan * F32s::splat(self.aspect);
        let sy = (one - two * y) * tan;
        let dir = V3s::splat(self.forward) + V3s::splat(self.right) * sx + V3s::splat(self.up) * sy;
        dir.normalize()
    }

    /// Film position in [0, 1]² of a world point in front of the camera (pinhole projection).
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let v = p - self.position;
        let z = v.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = v.dot(self.right) / z / (self.tan_half_fov_y * self.aspect);
        let sy = v.dot(self.up) / z / self.tan_half_fov_y;
        Some(Vec2::new((sx + 1.0) * 0.5, (1.0 - sy) * 0.5))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_corners_span_the_fov() {
        let c = Camera::look_at(
            Vec3::new(0.0, 0.0, 3.9),
            Vec3::ZERO,
            Vec3::Y,
            39.3077,
            1.0,
            0.0,
            None,
        );
        let r = c.ray(Vec2::splat(0.5), Vec2::ZERO);
        assert!((r.d - -Vec3::Z).length() < 1e-6);
        let top = c.ray(Vec2::new(0.5, 0.0), Vec2::ZERO);
        let angle = top.d.dot(-Vec3::Z).acos().to_degrees();
        assert!((angle - 39.3077 / 2.0).abs() < 1e-3);
        assert!(top.d.y > 0.0, "film y = 0 is the top of the image");
        let left = c.ray(Vec2::new(0.0, 0.5), Vec2::ZERO);
        assert!(left.d.x < 0.0, "film x = 0 is the left of the image");
    }

    #[test]
    fn thin_lens_rays_converge_on_the_focus_plane() {
        let c = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 40.0, 1.5, 0.2, Some(5.0));
        let film = Vec2::new(0.3, 0.7);
        let pin = Camera {
            lens_radius: 0.0,
            ..c
        }
        .ray(film, Vec2::ZERO);
        let target = pin.at(5.0 / pin.d.dot(c.forward));
        for u in [
            Vec2::new(0.1, 0.9),
            Vec2::new(0.8, 0.2),
            Vec2::new(0.5, 0.5),
        ] {
            let r = c.ray(film, u);
            let t = (target - r.o).dot(r.d);
            assert!((r.at(t) - target).length() < 1e-4);
            assert!((r.o - c.position).length() <= 0.2 + 1e-6);
        }
    }
}
