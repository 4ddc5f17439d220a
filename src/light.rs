//! Light sources and light selection proportional to power.

use std::f32::consts::PI;

use crate::math::{luminance, Rgb, Vec2, Vec3};

/// A light that next-event estimation can sample.
#[derive(Debug, Clone)]
pub enum Light {
    /// Isotropic point light with radiant intensity `intensity` (W/sr).
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity.
        intensity: Rgb,
    },
    /// Spot light: point light limited to a cone with smoothstep falloff between the angles.
    Spot {
        /// Position.
        position: Vec3,
        /// Unit axis (direction of emission).
        axis: Vec3,
        /// Intensity on the axis.
        intensity: Rgb,
        /// cos of the inner half-angle.
        cos_inner: f32,
        /// cos of the outer half-angle.
        cos_outer: f32,
    },
    /// Light arriving from one direction with irradiance `irradiance` (W/m²).
    Directional {
        /// Unit direction towards the light (opposite to the travel direction).
        to_light: Vec3,
        /// Irradiance on a surface facing the light.
        irradiance: Rgb,
        /// Radius of the scene's bounding sphere (for the power estimate).
        scene_radius: f32,
    },
    /// One emissive triangle (world space).
    Triangle {
        /// Instance the triangle belongs to.
        instance: u32,
        /// Triangle index within the instance's mesh.
        prim: u32,
        /// Corners.
        v: [Vec3; 3],
        /// Texture coordinates of the corners.
        uv: [Vec2; 3],
        /// Unit geometric normal (front side).
        n: Vec3,
        /// Area.
        area: f32,
        /// Emission factor (for the power estimate).
        emission: Rgb,
        /// Emits from both faces.
        two_sided: bool,
    },
    /// The environment, infinitely far away in every direction.
    Environment {
        /// The environment (shared with the scene, which looks it up for escaped rays).
        env: std::sync::Arc<crate::environment::Environment>,
        /// Radius of the scene's bounding sphere (for the power estimate).
        scene_radius: f32,
    },
    /// An emissive sphere (world space; only under similarity transforms).
    Sphere {
        /// Instance.
        instance: u32,
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Emission factor (for the power estimate).
        emission: Rgb,
    },
}

/// A point sampled on a light, seen from a shading point.
#[derive(Debug, Clone, Copy)]
pub struct LightSample {
    /// Unit direction from the shading point to the light.
    pub wi: Vec3,
    /// Distance to the light point (∞ for directional lights).
    pub distance: f32,
    /// The sampled point on the light (for the shadow ray).
    pub point: Vec3,
    /// Normal at the light point (zero for punctual lights).
    pub normal: Vec3,
    /// Texture coordinates at the light point (area lights).
    pub uv: Vec2,
    /// Incident radiance for area lights (filled by the caller from the material) or the
    /// delta light's contribution (intensity / d² or irradiance) for punctual lights.
    pub li: Rgb,
    /// Solid-angle pdf (area lights), or 1 for delta lights.
    pub pdf: f32,
    /// Whether the light is a delta light (cannot be hit by rays).
    pub delta: bool,
}

impl Light {
    /// Emitted power estimate (W, luminance) used to choose lights.
    pub fn power(&self) -> f32 {
        match self {
            Light::Point { intensity, .. } => 4.0 * PI * luminance(*intensity),
            Light::Spot {
                intensity,
                cos_inner,
                cos_outer,
                ..
            } => 2.0 * PI * (1.0 - 0.5 * (cos_inner + cos_outer)) * luminance(*intensity),
            Light::Directional {
                irradiance,
                scene_radius,
                ..
            } => PI * scene_radius * scene_radius * luminance(*irradiance),
            Light::Triangle {
                area,
                emission,
                two_sided,
                ..
            } => PI * area * luminance(*emission) * if *two_sided { 2.0 } else { 1.0 },
            Light::Sphere {
                radius, emission, ..
            } => PI * 4.0 * PI * radius * radius * luminance(*emission),
            Light::Environment { env, scene_radius } => env.power(*scene_radius),
        }
    }

    /// Samples the light as seen from `p`.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match *self {
            Light::Point {
                position,
                intensity,
            } => {
                let v = position - p;
                let d2 = v.length_squared();
                let d = d2.sqrt();
                (d > 0.0).then(|| LightSample {
                    wi: v / d,
                    distance: d,
                    point: position,
                    normal: Vec3::ZERO,
                    uv: Vec2::ZERO,
                    li: intensity / d2,
                    pdf: 1.0,
                    delta: true,
                })
            }
            Light::Spot {
                position,
                axis,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                let v = position - p;
                let d2 = v.length_squared();
                let d = d2.sqrt();
                if d == 0.0 {
                    return None;
                }
                let wi = v / d;
                let cos = (-wi).dot(axis);
                let falloff = smoothstep(cos_outer, cos_inner, cos);
                (falloff > 0.0).then(|| LightSample {
                    wi,
                    distance: d,
                    point: position,
                    normal: Vec3::ZERO,
                    uv: Vec2::ZERO,
                    li: intensity * (falloff / d2),
                    pdf: 1.0,
                    delta: true,
                })
            }
            Light::Directional {
                to_light,
                irradiance,
                ..
            } => Some(LightSample {
                wi: to_light,
                distance: f32::INFINITY,
                point: p,
                normal: Vec3::ZERO,
                uv: Vec2::ZERO,
                li: irradiance,
                pdf: 1.0,
                delta: true,
            }),
            Light::Triangle {
                v,
                uv,
                n,
                area,
                two_sided,
                ..
            } => {
                // Uniform point on the triangle (pbrt-v4's square-root mapping).
                let su = u.x.sqrt();
                let (b0, b1) = (1.0 - su, u.y * su);
                let b2 = 1.0 - b0 - b1;
                let q = v[0] * b0 + v[1] * b1 + v[2] * b2;
                let w = q - p;
                let d2 = w.length_squared();
                let d = d2.sqrt();
                if d == 0.0 {
                    return None;
                }
                let wi = w / d;
                let cos_l = n.dot(-wi);
                if cos_l <= 0.0 && !two_sided {
                    return None;
                }
                let pdf = d2 / (cos_l.abs() * area);
                (pdf.is_finite()).then(|| LightSample {
                    wi,
                    distance: d,
                    point: q,
                    normal: n,
                    uv: uv[0] * b0 + uv[1] * b1 + uv[2] * b2,
                    li: Vec3::ZERO,
                    pdf,
                    delta: false,
                })
            }
            Light::Sphere { center, radius, .. } => sample_sphere(center, radius, p, u),
            Light::Environment { ref env, .. } => env.sample(u).map(|s| LightSample {
                wi: s.wi,
                distance: f32::INFINITY,
                point: p,
                normal: Vec3::ZERO,
                uv: Vec2::ZERO,
                li: s.le,
                pdf: s.pdf,
                delta: false,
            }),
        }
    }

    /// Solid-angle pdf of [`Light::sample`] producing the point `q` with normal `n` seen from `p`.
    pub fn pdf(&self, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        match *self {
            Light::Triangle { area, .. } => {
                let w = q - p;
                let d2 = w.length_squared();
                let cos = n.dot(w.normalize()).abs();
                if cos == 0.0 {
                    0.0
                } else {
                    d2 / (cos * area)
                }
            }
            Light::Sphere { center, radius, .. } => {
                let d2 = (center - p).length_squared();
                let r2 = radius * radius;
                if d2 <= r2 * 1.0001 {
                    let w = q - p;
                    let cos = n.dot(w.normalize()).abs();
                    return w.length_squared() / (cos * 4.0 * PI * r2).max(f32::MIN_POSITIVE);
                }
                1.0 / (2.0 * PI * one_minus_cos_max(d2, r2))
            }
            _ => 0.0,
        }
    }
}

fn smoothstep(lo: f32, hi: f32, x: f32) -> f32 {
    if lo >= hi {
        return if x >= hi { 1.0 } else { 0.0 };
    }
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// 1 − cos θmax of the cone a sphere of radius² `r2` subtends at squared distance `d2`,
/// computed as sin²/(1 + cos) to stay accurate for small, distant spheres.
fn one_minus_cos_max(d2: f32, r2: f32) -> f32 {
    let sin2 = (r2 / d2).min(1.0);
    let cos = (1.0 - sin2).max(0.0).sqrt();
    sin2 / (1.0 + cos)
}

/// Samples a sphere light: uniformly in the cone of directions it subtends when `p` is outside
/// (pbrt-v4 §6.2.4), uniformly by area when inside.
fn sample_sphere(center: Vec3, radius: f32, p: Vec3, u: Vec2) -> Option<LightSample> {
    let to_c = center - p;
    let d2 = to_c.length_squared();
    let r2 = radius * radius;
    if d2 <= r2 * 1.0001 {
        let z = 1.0 - 2.0 * u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        let q = center + n * radius;
        let w = q - p;
        let dist2 = w.length_squared();
        let dist = dist2.sqrt();
        if dist == 0.0 {
            return None;
        }
        let wi = w / dist;
        let cos = n.dot(-wi).abs();
        let pdf = dist2 / (cos * 4.0 * PI * r2);
        return pdf.is_finite().then_some(LightSample {
            wi,
            distance: dist,
            point: q,
            normal: n,
            uv: Vec2::ZERO,
            li: Vec3::ZERO,
            pdf,
            delta: false,
        });
    }
    let d = d2.sqrt();
    let axis = to_c / d;
    let omc_max = one_minus_cos_max(d2, r2);
    let omc = u.x * omc_max;
    let cos_t = 1.0 - omc;
    let sin2_t = omc * (2.0 - omc);
    let sin_t = sin2_t.max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let frame = crate::math::Frame::from_normal(axis);
    let wi = frame
        .to_world(Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t))
        .normalize();
    // Distance to the near intersection with the sphere along wi.
    let b = wi.dot(to_c);
    let perp2 = (to_c - wi * b).length_squared();
    let h = (r2 - perp2).max(0.0).sqrt();
    let dist = (b - h).max(0.0);
    let q = p + wi * dist;
    let n = (q - center).normalize();
    let pdf = 1.0 / (2.0 * PI * omc_max);
    Some(LightSample {
        wi,
        distance: dist,
        point: q,
        normal: n,
        uv: Vec2::ZERO,
        li: Vec3::ZERO,
        pdf,
        delta: false,
    })
}

/// Chooses lights with probability proportional to their power.
#[derive(Debug, Clone, Default)]
pub struct LightSampler {
    cdf: Vec<f32>,
    total: f32,
}

impl LightSampler {
    /// Builds the distribution over `lights`.
    pub fn new(lights: &[Light]) -> LightSampler {
        let mut cdf = Vec::with_capacity(lights.len());
        let mut acc = 0.0f64;
        for l in lights {
            let p = l.power();
            acc += if p.is_finite() && p > 0.0 {
                f64::from(p)
            } else {
                0.0
            };
            cdf.push(acc as f32);
        }
        LightSampler {
            total: acc as f32,
            cdf,
        }
    }

    /// Picks a light; returns its index and selection probability.
    pub fn pick(&self, u: f32) -> Option<(usize, f32)> {
        if self.total <= 0.0 {
            return None;
        }
        let target = u * self.total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let p = self.pmf(i);
        (p > 0.0).then_some((i, p))
    }

    /// Picks a light with `u` and also returns `u` remapped to [0, 1) within the chosen light's
    /// share of the unit interval, a fresh uniform number for sampling that light (pbrt-v4's
    /// `SampleDiscrete`): one 2D sample point then covers the choice of light and a point on it,
    /// so stratification carries over to the union of all lights (the two triangles of a quad
    /// light are sampled like one rectangle).
    #[inline]
    pub fn pick_remapped(&self, u: f32) -> Option<(usize, f32, f32)> {
        let (i, p) = self.pick(u)?;
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let remapped =
            ((u * self.total - lo) / (self.cdf[i] - lo)).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        Some((i, p, remapped))
    }

    /// Probability of picking light `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        if self.total <= 0.0 {
            return 0.0;
        }
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        (self.cdf[i] - lo) / self.total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selection_follows_power() {
        let lights = vec![
            Light::Point {
                position: Vec3::ZERO,
                intensity: Vec3::ONE,
            },
            Light::Point {
                position: Vec3::ZERO,
                intensity: Vec3::ZERO,
            },
            Light::Point {
                position: Vec3::ZERO,
                intensity: Vec3::splat(3.0),
            },
        ];
        let s = LightSampler::new(&lights);
        assert!(
            (s.pmf(0) - 0.25).abs() < 1e-6 && s.pmf(1) == 0.0 && (s.pmf(2) - 0.75).abs() < 1e-6
        );
        assert_eq!(s.pick(0.1).unwrap().0, 0);
        assert_eq!(s.pick(0.3).unwrap().0, 2);
        // The remapped number is uniform within the chosen light's share: u = 0.25 + 0.75·v
        // picks light 2 with v back, for v across [0, 1).
        for k in 0..100 {
            let v = k as f32 / 100.0;
            let (i, p, r) = s.pick_remapped(0.25 + 0.75 * v).unwrap();
            assert_eq!((i, p), (2, 0.75));
            assert!((r - v).abs() < 1e-5 && (0.0..1.0).contains(&r), "{v} → {r}");
        }
        assert_eq!(s.pick_remapped(0.999_999_9).unwrap().0, 2);
        assert!(s.pick_remapped(0.999_999_9).unwrap().2 < 1.0);
    }

    #[test]
    fn sphere_cone_sampling_pdf_is_consistent() {
        // The sampled directions' pdf integrates to 1 over the cone: check the solid angle.
        let (c, r, p) = (Vec3::new(0.0, 0.0, -10.0), 2.0, Vec3::ZERO);
        let mut rng = crate::sampler::Pcg32::new(3, 3);
        for _ in 0..1000 {
            let s = sample_sphere(c, r, p, Vec2::new(rng.next_f32(), rng.next_f32())).unwrap();
            assert!(((s.point - c).length() - r).abs() < 1e-3, "point on sphere");
            let l = Light::Sphere {
                instance: 0,
                center: c,
                radius: r,
                emission: Vec3::ONE,
            };
            assert!((l.pdf(p, s.point, s.normal) - s.pdf).abs() < 1e-3 * s.pdf);
        }
        let solid_angle = 2.0 * PI * one_minus_cos_max(100.0, 4.0);
        let exact = 2.0 * PI * (1.0 - (1.0f32 - 4.0 / 100.0).sqrt());
        assert!((solid_angle - exact).abs() < 1e-5);
    }
}
