//! Helpers shared by the BSDF tests: test directions, sample triples and the deterministic
//! hemisphere quadrature (no sampling routine involved, so it can check the samplers).

use crate::math::{Vec2, Vec3};
use crate::sampler::Pcg32;

/// Direction at polar angle `theta_deg` from +z and azimuth `phi` (radians); beyond 90° it is
/// below the surface.
pub fn dir(theta_deg: f32, phi: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
}

/// A direction with θ uniform in [0°, 180°) and φ uniform in [0, 2π): both sides of the
/// surface, grazing angles well represented.
pub fn random_dir(rng: &mut Pcg32) -> Vec3 {
    dir(
        rng.next_f32() * 180.0,
        rng.next_f32() * std::f32::consts::TAU,
    )
}

/// One lobe-choice number and one 2D sample.
pub fn u3(rng: &mut Pcg32) -> (f32, Vec2) {
    (rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()))
}

pub(crate) use super::hemisphere_integral;
