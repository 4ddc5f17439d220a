//! Helpers shared by the BSDF tests: test directions, sample triples and a deterministic
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

/// ∫ f(ωi) dωi over the upper hemisphere by the midpoint rule on an n × n grid in (cos θ, φ),
/// whose cells have equal solid angle 2π / n².
pub fn hemisphere_integral(n: usize, mut f: impl FnMut(Vec3) -> f64) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..n {
        let z = (i as f32 + 0.5) / n as f32;
        let r = (1.0 - z * z).sqrt();
        for j in 0..n {
            let phi = std::f32::consts::TAU * (j as f32 + 0.5) / n as f32;
            sum += f(Vec3::new(r * phi.cos(), r * phi.sin(), z));
        }
    }
    sum * std::f64::consts::TAU / (n * n) as f64
}
