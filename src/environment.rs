//! The environment: the radiance arriving from infinitely far away in every direction, either a
//! constant colour or an equirectangular (latitude-longitude) HDR image, times a strength. It is
//! a light: next-event estimation samples it in proportion to its radiance (images) or
//! uniformly (constant), and paths that escape the scene see it, the two combined by multiple
//! importance sampling.
//!
//! **Orientation** (the same as Blender's Environment Texture with its default mapping, in
//! lumo's y-up coordinates): a direction d = (x, y, z) maps to
//!
//! ```text
//! u = 0.5 + atan2(z, x) / 2π,    v = 0.5 + asin(y) / π     (v counted from the bottom row)
//! ```
//!
//! so the image's centre column faces +x, u = 0.25 faces −z, u = 0.75 faces +z and the top row
//! is straight up. A rotation by φ about +y (counter-clockwise seen from above) turns the image
//! with the scene: the direction is rotated by −φ before the lookup.
//!
//! **Importance sampling** (pbrt-v4 §12.5.2, Cycles' background light): a piecewise-constant 2D
//! distribution over the texels, each weighted by its luminance times sin θ (θ the polar angle
//! from +y, the area of the texel's patch of sphere), sampled by inverting the marginal CDF of
//! the rows and then the conditional CDF of the chosen row, continuously within the texel so that
//! stratified 2D points stay stratified. The solid-angle pdf of a direction is
//! p(u, v) / (2π² sin θ).

use std::f32::consts::PI;

use crate::lanes::math;
use crate::math::{luminance, Rgb, Vec2, Vec3};
use crate::sampling::Distribution2D;
use crate::texture::{Texels, Texture};

/// Where the environment's radiance comes from.
#[derive(Debug, Clone)]
pub enum Radiance {
    /// The same in every direction.
    Constant(Rgb),
    /// An equirectangular image (linear RGB, row 0 at the top) and its sampling distribution.
    Image {
        /// The texels (wrap: repeat in u, clamp in v).
        texture: Texture,
        /// Luminance × sin θ per texel, rows top first as the texture.
        distribution: Distribution2D,
        /// The distribution next-event estimation draws from when BSDF sampling also covers
        /// every direction (MIS): (luminance − its mean over the sphere)⁺ × sin θ, so that
        /// light samples go to the texels brighter than average and the rest is left to BSDF
        /// sampling (MIS compensation: Karlík, Šik, Vévoda, Skřivan and Křivánek 2019;
        /// pbrt-v4's `allowIncompletePDF`). Its pdf is zero where a direction is no brighter
        /// than the mean, so it must never be used without MIS.
        mis: Box<Distribution2D>,
    },
}

/// The environment light.
#[derive(Debug, Clone)]
pub struct Environment {
    /// The radiance before `strength`.
    pub radiance: Radiance,
    /// Multiplies the radiance.
    pub strength: f32,
    /// sin and cos of the rotation about +y (counter-clockwise seen from above), which every
    /// lookup and every sampled direction needs.
    rotation: (f32, f32),
    /// Whether camera rays see it.
    pub visible: bool,
}

/// A direction sampled towards the environment.
#[derive(Debug, Clone, Copy)]
pub struct EnvironmentSample {
    /// Unit direction (world space).
    pub wi: Vec3,
    /// Radiance arriving from it.
    pub le: Rgb,
    /// Solid-angle pdf.
    pub pdf: f32,
}

impl Environment {
    /// A constant environment.
    pub fn constant(color: Rgb, strength: f32, visible: bool) -> Environment {
        Environment {
            radiance: Radiance::Constant(color),
            strength,
            rotation: (0.0, 1.0),
            visible,
        }
    }

    /// An image environment; negative texels (compression noise in HDR files) count as 0.
    pub fn image(mut texture: Texture, strength: f32, rotation: f32, visible: bool) -> Environment {
        // Float texels (taken, not copied): the loop below clamps them, and lookups of a sun
        // need no decoding.
        let mut rgb = match &mut texture.texels {
            Texels::Float { rgb, .. } => std::mem::take(rgb),
            Texels::Rgba8 { .. } => texture.decoded(),
        };
        for t in rgb.iter_mut() {
            *t = t.max(Vec3::ZERO);
            if !t.is_finite() {
                *t = Vec3::ZERO;
            }
        }
        let (w, h) = (texture.width as usize, texture.height as usize);
        // Each cell's weight is the mean over the cell of the bilinearly interpolated
        // luminance that `le` returns (as pbrt-v4's sampling distribution): in each axis 1/8 of
        // each neighbour and 3/4 of the texel itself. With the texel's own value alone, the
        // half-texel rim that a bright sun bleeds into its neighbours would be sampled at their
        // low density: fireflies.
        let lum: Vec<f32> = rgb.iter().map(|t| luminance(*t)).collect();
        texture.texels = Texels::Float { rgb, alpha: None };
        let at = |x: isize, y: isize| {
            let x = x.rem_euclid(w as isize) as usize;
            let y = y.clamp(0, h as isize - 1) as usize;
            lum[y * w + x]
        };
        const TAP: [f32; 3] = [0.125, 0.75, 0.125];
        // Row `row` (top first) spans polar angles [row, row + 1] · π / h; its cells' solid
        // angles are proportional to sin θ at its middle.
        let sin_theta: Vec<f32> = (0..h)
            .map(|row| math::sin(PI * (row as f32 + 0.5) / h as f32))
            .collect();
        let weights: Vec<f32> = (0..h)
            .flat_map(|row| {
                let sin_theta = sin_theta[row];
                (0..w).map(move |col| {
                    let mut sum = 0.0;
                    for (dy, ty) in TAP.iter().enumerate() {
                        for (dx, tx) in TAP.iter().enumerate() {
                            sum += ty
                                * tx
                                * at(
                                    col as isize + dx as isize - 1,
                                    row as isize + dy as isize - 1,
                                );
                        }
                    }
                    sum * sin_theta
                })
            })
            .collect();
        let distribution = Distribution2D::new(&weights, w, h);
        // The mean luminance over the sphere: Σ weight / Σ sin θ.
        let solid_angle: f64 = sin_theta.iter().map(|&s| f64::from(s) * w as f64).sum();
        let mean = (weights.iter().map(|&x| f64::from(x)).sum::<f64>() / solid_angle) as f32;
        let compensated: Vec<f32> = weights
            .iter()
            .enumerate()
            .map(|(i, &x)| (x - mean * sin_theta[i / w]).max(0.0))
            .collect();
        // A constant image has nothing above its mean: then the complete distribution.
        let mis = Box::new(if compensated.iter().any(|&x| x > 0.0) {
            Distribution2D::new(&compensated, w, h)
        } else {
            distribution.clone()
        });
        Environment {
            radiance: Radiance::Image {
                texture,
                distribution,
                mis,
            },
            strength,
            rotation: math::sin_cos(rotation),
            visible,
        }
    }

    /// Whether it sends no light at all.
    pub fn is_black(&self) -> bool {
        self.strength <= 0.0
            || match &self.radiance {
                Radiance::Constant(c) => c.max_element() <= 0.0,
                Radiance::Image { distribution, .. } => distribution.integral() <= 0.0,
            }
    }

    /// Image coordinates (u, v from the bottom) of a world direction.
    fn uv(&self, d: Vec3) -> Vec2 {
        // Rotating the image by φ about +y = looking it up in the direction rotated by −φ.
        // The rotation by −φ: sin(−φ) = −sin φ.
        let (s, c) = (-self.rotation.0, self.rotation.1);
        let (x, z) = (c * d.x + s * d.z, -s * d.x + c * d.z);
        let u = 0.5 + math::atan2(z, x) / (2.0 * PI);
        let v = 0.5 + math::asin(d.y.clamp(-1.0, 1.0)) / PI;
        // u ∈ [0, 1] (atan2 ∈ [−π, π]; NaN stays NaN): `rem_euclid(1.0)` without its library
        // call, exact (u − 1 is exact for u ∈ [1, 2)).
        Vec2::new(if u >= 1.0 { u - 1.0 } else { u }, v)
    }

    /// The world direction of image coordinates (inverse of [`Environment::uv`]).
    fn direction(&self, uv: Vec2) -> Vec3 {
        let phi = (uv.x - 0.5) * 2.0 * PI;
        let elevation = (uv.y - 0.5) * PI;
        let (sin_elevation, cos_elevation) = math::sin_cos(elevation);
        let (sin_phi, cos_phi) = math::sin_cos(phi);
        let (x, z) = (cos_elevation * cos_phi, cos_elevation * sin_phi);
        // The rotation by φ about +y (x → −z for φ = 90°): the inverse of `uv`'s.
        let (s, c) = self.rotation;
        Vec3::new(c * x + s * z, sin_elevation, -s * x + c * z)
    }

    /// Radiance arriving from direction `d` (unit, pointing away from the scene).
    pub fn le(&self, d: Vec3) -> Rgb {
        match &self.radiance {
            Radiance::Constant(c) => *c * self.strength,
            Radiance::Image { texture, .. } => texture.lookup(self.uv(d)) * self.strength,
        }
    }

    /// Samples a direction towards the environment from the 2D point `u`.
    pub fn sample(&self, u: Vec2) -> Option<EnvironmentSample> {
        self.sample_from(u, false)
    }

    /// Samples a direction for next-event estimation combined with BSDF sampling by MIS: from
    /// the compensated distribution (see [`Radiance::Image`]), with [`Environment::pdf_mis`].
    pub fn sample_mis(&self, u: Vec2) -> Option<EnvironmentSample> {
        self.sample_from(u, true)
    }

    fn sample_from(&self, u: Vec2, for_mis: bool) -> Option<EnvironmentSample> {
        match &self.radiance {
            Radiance::Constant(c) => {
                let z = 1.0 - 2.0 * u.x;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (sin_phi, cos_phi) = math::sin_cos(2.0 * PI * u.y);
                Some(EnvironmentSample {
                    wi: Vec3::new(r * cos_phi, z, r * sin_phi),
                    le: *c * self.strength,
                    pdf: 1.0 / (4.0 * PI),
                })
            }
            Radiance::Image {
                texture,
                distribution,
                mis,
            } => {
                let distribution = if for_mis { mis } else { distribution };
                // The distribution's rows are top first; image v counts from the bottom.
                let (xy, pdf_xy) = distribution.sample(u)?;
                let uv = Vec2::new(xy.x, 1.0 - xy.y);
                let sin_theta = math::sin(PI * xy.y);
                if sin_theta <= 0.0 {
                    return None;
                }
                let pdf = pdf_xy / (2.0 * PI * PI * sin_theta);
                Some(EnvironmentSample {
                    wi: self.direction(uv),
                    le: texture.lookup(uv) * self.strength,
                    pdf,
                })
            }
        }
    }

    /// The solid-angle pdf with which [`Environment::sample`] returns direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        match &self.radiance {
            Radiance::Constant(_) => 1.0 / (4.0 * PI),
            Radiance::Image { distribution, .. } => Self::image_pdf(distribution, self.uv(d)),
        }
    }

    /// The solid-angle pdf with which [`Environment::sample_mis`] returns direction `d` (zero
    /// where the radiance is no brighter than the mean).
    pub fn pdf_mis(&self, d: Vec3) -> f32 {
        match &self.radiance {
            Radiance::Constant(_) => 1.0 / (4.0 * PI),
            Radiance::Image { mis, .. } => Self::image_pdf(mis, self.uv(d)),
        }
    }

    /// [`le`](Self::le) and [`pdf_mis`](Self::pdf_mis) of one direction, finding its image
    /// coordinates once (MIS of an escaped ray needs both).
    pub fn le_and_pdf_mis(&self, d: Vec3) -> (Rgb, f32) {
        match &self.radiance {
            Radiance::Constant(c) => (*c * self.strength, 1.0 / (4.0 * PI)),
            Radiance::Image { texture, mis, .. } => {
                let uv = self.uv(d);
                (texture.lookup(uv) * self.strength, Self::image_pdf(mis, uv))
            }
        }
    }

    /// The solid-angle density of image coordinates `uv` under `distribution`.
    fn image_pdf(distribution: &Distribution2D, uv: Vec2) -> f32 {
        let xy = Vec2::new(uv.x, 1.0 - uv.y);
        let sin_theta = math::sin(PI * xy.y);
        if sin_theta <= 0.0 {
            return 0.0;
        }
        distribution.pdf(xy) / (2.0 * PI * PI * sin_theta)
    }

    /// The power estimate for choosing among lights: the flux through a disc of the scene's
    /// radius r, π r² × ∫ L dω (luminance), as pbrt-v4's `ImageInfiniteLight::Phi`.
    pub fn power(&self, scene_radius: f32) -> f32 {
        let integral = match &self.radiance {
            Radiance::Constant(c) => 4.0 * PI * luminance(*c),
            // ∫ L dω = Σ L · ΔΩ with ΔΩ = (2π/w)(π/h) sin θ: the distribution's integral
            // (the mean of luminance × sin θ over the texels) × 2π².
            Radiance::Image { distribution, .. } => 2.0 * PI * PI * distribution.integral(),
        };
        PI * scene_radius * scene_radius * integral * self.strength
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::chi2;
    use crate::texture::Wrap;

    /// A 16 × 8 image with a bright "sun" texel and a gradient elsewhere.
    fn image_env(rotation: f32) -> Environment {
        let (w, h) = (16u32, 8u32);
        let texels = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (x, y) == (11, 2) {
                    Vec3::new(400.0, 300.0, 200.0)
                } else {
                    Vec3::new(0.2 + x as f32 * 0.05, 0.3, 0.1 + y as f32 * 0.1)
                }
            })
            .collect();
        let texture = Texture::from_rgb(w, h, texels, Wrap::Repeat, Wrap::Clamp);
        Environment::image(texture, 1.5, rotation, true)
    }

    #[test]
    fn orientation_is_blenders() {
        let env = image_env(0.0);
        let close = |a: Vec2, b: Vec2| (a - b).length() < 1e-5;
        assert!(
            close(env.uv(Vec3::X), Vec2::new(0.5, 0.5)),
            "centre column faces +x"
        );
        assert!(
            close(env.uv(-Vec3::Z), Vec2::new(0.25, 0.5)),
            "u = 0.25 faces −z"
        );
        assert!(
            close(env.uv(Vec3::Z), Vec2::new(0.75, 0.5)),
            "u = 0.75 faces +z"
        );
        assert!(
            (env.uv(Vec3::Y).y - 1.0).abs() < 1e-6,
            "the top row is straight up"
        );
        // Rotating by 90° counter-clockwise seen from above (+x towards −z) carries the centre
        // column from +x to −z.
        let turned = image_env(std::f32::consts::FRAC_PI_2);
        assert!(close(turned.uv(-Vec3::Z), Vec2::new(0.5, 0.5)));
        // direction() inverts uv().
        for d in [Vec3::new(0.3, 0.5, -0.8), Vec3::new(-0.9, -0.2, 0.1)] {
            let d = d.normalize();
            assert!((turned.direction(turned.uv(d)) - d).length() < 1e-5);
        }
    }

    /// `le_and_pdf_mis` is `le` and `pdf_mis` of the same direction, bit for bit.
    #[test]
    fn le_and_pdf_mis_are_le_and_pdf_mis() {
        let mut rng = crate::sampler::Pcg32::new(5, 1);
        for env in [image_env(0.7), Environment::constant(Vec3::ONE, 2.0, true)] {
            for _ in 0..10_000 {
                let z = 1.0 - 2.0 * rng.next_f32();
                let phi = std::f32::consts::TAU * rng.next_f32();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let d = Vec3::new(r * phi.cos(), z, r * phi.sin());
                let (le, pdf) = env.le_and_pdf_mis(d);
                assert_eq!(
                    le.to_array().map(f32::to_bits),
                    env.le(d).to_array().map(f32::to_bits)
                );
                assert_eq!(pdf.to_bits(), env.pdf_mis(d).to_bits());
            }
        }
    }

    #[test]
    fn pdf_integrates_to_one_over_the_sphere() {
        type Pdf = fn(&Environment, Vec3) -> f32;
        let pdfs: [(&str, Pdf); 2] = [("pdf", Environment::pdf), ("pdf_mis", Environment::pdf_mis)];
        for (env, (name, pdf)) in [image_env(0.7), Environment::constant(Vec3::ONE, 1.0, true)]
            .into_iter()
            .flat_map(|e| pdfs.map(|p| (e.clone(), p)))
        {
            // Midpoint rule over the image's (u, v), 8 × 8 points per texel (so the sun texel
            // is resolved), with dω = 2π du · π dv · sin θ; the directions come from
            // `direction`, so this also checks it against `pdf`'s `uv`.
            let (n_u, n_v) = (16 * 8, 8 * 8);
            let mut sum = 0.0f64;
            for j in 0..n_v {
                let v = (j as f32 + 0.5) / n_v as f32;
                let sin_theta = (PI * v).sin();
                for i in 0..n_u {
                    let u = (i as f32 + 0.5) / n_u as f32;
                    let d = env.direction(Vec2::new(u, v));
                    sum += f64::from(pdf(&env, d) * 2.0 * PI * PI * sin_theta);
                }
            }
            let integral = sum / (n_u * n_v) as f64;
            assert!((integral - 1.0).abs() < 1e-3, "∫ {name} = {integral}");
        }
    }

    /// The compensated distribution leaves the texels no brighter than the mean to BSDF
    /// sampling (density 0) and gives the brighter ones more density than the complete one.
    #[test]
    fn compensated_pdf_is_zero_below_the_mean() {
        let env = image_env(0.0);
        let sun = env.direction(Vec2::new(11.5 / 16.0, 1.0 - 2.5 / 8.0));
        let dim = env.direction(Vec2::new(0.5 / 16.0, 0.5));
        assert!(
            env.pdf_mis(sun) > env.pdf(sun),
            "{} {}",
            env.pdf_mis(sun),
            env.pdf(sun)
        );
        assert_eq!(env.pdf_mis(dim), 0.0);
        assert!(env.pdf(dim) > 0.0);
    }

    #[test]
    fn samples_follow_the_pdf() {
        let env = image_env(0.3);
        let p = chi2::p_value(
            "environment",
            200_000,
            7,
            |rng| {
                env.sample(Vec2::new(rng.next_f32(), rng.next_f32()))
                    .map(|s| s.wi)
            },
            |wi| env.pdf(wi),
        );
        let p_mis = chi2::p_value(
            "environment, compensated",
            200_000,
            7,
            |rng| {
                env.sample_mis(Vec2::new(rng.next_f32(), rng.next_f32()))
                    .map(|s| s.wi)
            },
            |wi| env.pdf_mis(wi),
        );
        chi2::assert_all_pass(&[
            ("environment".to_string(), p),
            ("environment, compensated".to_string(), p_mis),
        ]);
        // The radiance a sample carries is the lookup in its direction.
        let s = env.sample(Vec2::new(0.3, 0.6)).unwrap();
        assert!((s.le - env.le(s.wi)).abs().max_element() < 1e-3 * s.le.max_element());
    }
}
