//! Warping functions: uniform numbers in [0, 1)² mapped to points and directions with known
//! densities, and the weights that combine two sampling strategies (pbrt-v4 ch. A.5, 2.4).

use crate::math::{Vec2, Vec3};

/// Shirley–Chiu concentric map of the unit square to the unit disk (area-preserving).
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    Vec2::new(r * theta.cos(), r * theta.sin())
}

/// Cosine-weighted hemisphere direction (Malley's method); pdf = cos θ / π.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    Vec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt())
}

/// Power heuristic with β = 2 (Veach 1997).
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a == 0.0 {
        0.0
    } else if a.is_infinite() {
        1.0
    } else {
        a / (a + b)
    }
}
