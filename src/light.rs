//! Light sources: what each kind emits and how a point on it is sampled
//! ([`crate::light_sampler`] chooses among them).

use std::f32::consts::PI;

use crate::lanes::{F32s, Mask, V3s};
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
        /// Bounding sphere (centroid, squared distance of the farthest corner from it), for
        /// the quick bound on the solid angle the triangle subtends.
        sphere: (Vec3, f32),
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
    /// The light of the emissive triangle `prim` of instance `instance`, world-space corners
    /// `v` (front face counter-clockwise) with texture coordinates `uv`.
    pub fn triangle(
        instance: u32,
        prim: u32,
        v: [Vec3; 3],
        uv: [Vec2; 3],
        emission: Rgb,
        two_sided: bool,
    ) -> Light {
        let c = (v[1] - v[0]).cross(v[2] - v[0]);
        let centroid = (v[0] + v[1] + v[2]) / 3.0;
        let r2 = v
            .iter()
            .map(|c| (*c - centroid).length_squared())
            .fold(0.0f32, f32::max);
        Light::Triangle {
            instance,
            prim,
            v,
            uv,
            n: c.normalize(),
            area: 0.5 * c.length(),
            emission,
            two_sided,
            sphere: (centroid, r2),
        }
    }

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
                sphere,
                ..
            } => {
                if unlit_side(n.dot(p - v[0]), plane_scale(p, v[0]), two_sided) {
                    return None; // behind a one-sided emitter, or in the emitter's plane
                }
                if let Some(st) = SphericalTriangle::seen_from(p, v, (n, area), sphere) {
                    return st
                        .sample(p, v, n, u)
                        .map(|(wi, q, d, (b1, b2))| LightSample {
                            wi,
                            distance: d,
                            point: q,
                            normal: n,
                            uv: uv[0] * (1.0 - b1 - b2) + uv[1] * b1 + uv[2] * b2,
                            li: Vec3::ZERO,
                            pdf: 1.0 / st.solid_angle,
                            delta: false,
                        });
                }
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
            Light::Environment { ref env, .. } => env.sample(u).map(|s| environment_sample(s, p)),
        }
    }

    /// [`Light::sample`] for next-event estimation combined with BSDF sampling by MIS: the
    /// same, but an environment samples its compensated distribution
    /// ([`Environment::sample_mis`](crate::environment::Environment::sample_mis)), which leaves
    /// the directions no brighter than its mean to BSDF sampling. Its pdf is then
    /// `Environment::pdf_mis`, which the MIS weights of BSDF samples must use too.
    pub fn sample_mis(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match *self {
            Light::Environment { ref env, .. } => {
                env.sample_mis(u).map(|s| environment_sample(s, p))
            }
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Directional { .. }
            | Light::Triangle { .. }
            | Light::Sphere { .. } => self.sample(p, u),
        }
    }

    /// Solid-angle pdf of [`Light::sample`] producing the point `q` with normal `n` seen from `p`.
    pub fn pdf(&self, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        match *self {
            Light::Triangle {
                area,
                v,
                n: normal,
                sphere,
                ..
            } => {
                if let Some(st) = SphericalTriangle::seen_from(p, v, (normal, area), sphere) {
                    return 1.0 / st.solid_angle;
                }
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
            // Punctual lights cannot be hit; the environment's pdf is its own
            // (`Environment::pdf_mis`, looked up by the scene for escaped rays).
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Directional { .. }
            | Light::Environment { .. } => 0.0,
        }
    }

    /// The instance whose surface emits this light (its material gives the radiance of every
    /// point sampled on it); `None` for lights without a surface, whose samples carry their
    /// radiance themselves.
    pub fn surface_instance(&self) -> Option<u32> {
        match *self {
            Light::Triangle { instance, .. } | Light::Sphere { instance, .. } => Some(instance),
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Directional { .. }
            | Light::Environment { .. } => None,
        }
    }

    /// Points whose convex hull holds every point the light's samples can lie at, or `None`
    /// for a light at infinity.
    pub fn hull(&self) -> Option<Vec<Vec3>> {
        match *self {
            Light::Point { position, .. } | Light::Spot { position, .. } => Some(vec![position]),
            Light::Triangle { v, .. } => Some(v.to_vec()),
            Light::Sphere { center, radius, .. } => Some(
                (0..8)
                    .map(|k| {
                        let corner = Vec3::new(
                            if k & 1 == 0 { -radius } else { radius },
                            if k & 2 == 0 { -radius } else { radius },
                            if k & 4 == 0 { -radius } else { radius },
                        );
                        center + corner
                    })
                    .collect(),
            ),
            Light::Directional { .. } | Light::Environment { .. } => None,
        }
    }

    /// Whether the light's samples lie infinitely far away (their shadow rays run to ∞ along
    /// the sampled direction instead of to a point).
    pub fn at_infinity(&self) -> bool {
        match *self {
            Light::Directional { .. } | Light::Environment { .. } => true,
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Triangle { .. }
            | Light::Sphere { .. } => false,
        }
    }
}

/// Points this close to an emitting triangle's plane, relative to the largest coordinate of
/// the point and the triangle's first corner ([`plane_scale`]), count as lying in it: 32 units
/// in the last place of that coordinate, beyond the rounding of a hit point on the plane.
const EDGE_ON: f32 = 1.0 / (1u32 << 18) as f32;

/// The largest coordinate, in magnitude, of the shading point `p` and the triangle's corner
/// `v0`: the scale of the rounding of p's distance to the triangle's plane.
#[inline]
fn plane_scale(p: Vec3, v0: Vec3) -> f32 {
    use crate::lanes::max;
    let largest = |v: Vec3| max(max(v.x.abs(), v.y.abs()), v.z.abs());
    max(largest(p), largest(v0))
}

/// Whether a point at signed distance `h` from an emitting triangle's plane (positive on its
/// front) receives nothing from it: behind a one-sided emitter, or in the plane (within
/// [`EDGE_ON`] of `scale`), where the emitter is seen edge-on. A point on the emitter itself
/// (a light whose surface also reflects) is in the plane: its light samples lie beside it,
/// along directions the rounding of its position sets, and would add their radiance
/// divided by a distance² and cosines of rounding errors, a firefly where the exact answer is
/// nothing.
#[inline]
fn unlit_side(h: f32, scale: f32, two_sided: bool) -> bool {
    h.abs() <= scale * EDGE_ON || (!two_sided && h <= 0.0)
}

/// Triangles that subtend at least this solid angle (sr) from the shading point are sampled
/// uniformly in solid angle; smaller ones uniformly by area. Near a light, area sampling's
/// density in solid angle varies across the light with distance² / cos, which solid-angle sampling
/// removes; far away the two agree and area sampling is cheaper. Measured (docs/performance.md):
/// at 0.02 sr the Cornell box loses 11 % MSE at equal time (−1.8 % RMSE per sample for +15 %
/// time); at 0.2 sr it is unchanged while a large light 0.2 above a floor gains 23 % MSE at equal
/// time.
pub const SPHERICAL_SAMPLING_MIN_SOLID_ANGLE: f32 = 0.2;

/// [`SphericalTriangle::seen_from`]'s bound for points near the triangle's plane rejects below
/// this, under [`SPHERICAL_SAMPLING_MIN_SOLID_ANGLE`] by a margin far beyond rounding.
const SPHERICAL_SAMPLING_PLANE_BOUND: f32 = 0.19;

/// The light kernel ([`TriangleLanes::sample`]) decides by area where a triangle's solid angle
/// computed in f32 is below [`SPHERICAL_SAMPLING_MIN_SOLID_ANGLE`] − 10⁻³ sr: then the f64
/// one of [`SphericalTriangle::seen_from`] is below the threshold too. Near 0.2 sr the
/// formula's f32 error is a few 10⁻⁷ (unit vectors within a few ulp, no cancellation in a
/// denominator near 4): the margin is thousands of times that (tested against `seen_from` near
/// the threshold). The kernel compares N < D·tan(Ω/2) for Ω = 2 atan2(N, D), so the threshold
/// is kept as tan((0.2 − 10⁻³) / 2) (a test checks it against the two constants).
const TAN_HALF_F32_THRESHOLD: f32 = 0.099_829_66;

/// The margin below the threshold that [`TAN_HALF_F32_THRESHOLD`] keeps, in steradians.
#[cfg(test)]
const F32_MARGIN: f32 = 1e-3;

/// A bounding sphere seen with sin² α below this subtends 2π sin²α / (1 + cos α) < 0.192 sr,
/// under [`SPHERICAL_SAMPLING_MIN_SOLID_ANGLE`] with a margin far beyond rounding (tested).
const SPHERICAL_SAMPLING_FAR_SIN2: f32 = 0.06;

/// Whether a bounding sphere of squared radius `r2` at squared distance `d2` is seen so small
/// (sin² α < [`SPHERICAL_SAMPLING_FAR_SIN2`]: a bound under 0.192 sr, whatever the rounding) that
/// [`sphere_solid_angle`]'s bound rejects it too; decided without a division or square root.
#[inline]
fn far_beyond_sphere(d2: f32, r2: f32) -> bool {
    r2 < SPHERICAL_SAMPLING_FAR_SIN2 * d2
}

/// The solid angle 2π(1 − cos α) of a sphere seen with sin² α = `sin2`, written
/// 2π sin² α / (1 + cos α) to stay accurate when small: a bound on that of anything inside it.
#[inline]
fn sphere_solid_angle(sin2: f32) -> f32 {
    2.0 * PI * sin2 / (1.0 + (1.0 - sin2).sqrt())
}

/// Whether the bound for points near a triangle's plane (corner `v0`, unit normal `n`, area
/// `area`; bounding sphere of squared radius `r2` at squared distance `d2`) is under
/// [`SPHERICAL_SAMPLING_PLANE_BOUND`]. Near the plane (a ceiling seen beside its lamp) the
/// sphere's bound is loose; there Ω = ∫ h / |q − p|³ dA ≤ A·h / (d − r)³, with h the distance to
/// the plane and d − r at most the distance to any point q of the triangle.
#[inline]
fn near_plane_bound_rejects(p: Vec3, (v0, n, area): (Vec3, Vec3, f32), d2: f32, r2: f32) -> bool {
    let gap = d2.sqrt() - r2.sqrt();
    let h = n.dot(p - v0).abs();
    gap > 0.0 && area * h < SPHERICAL_SAMPLING_PLANE_BOUND * (gap * gap * gap)
}

/// The solid angle of the spherical triangle of unit vectors `a`, `b`, `c` (Van Oosterom and
/// Strackee 1983).
#[inline]
fn solid_angle_of(a: glam::DVec3, b: glam::DVec3, c: glam::DVec3) -> f64 {
    2.0 * crate::lanes::math::atan2_f64(
        a.dot(b.cross(c)).abs(),
        1.0 + a.dot(b) + b.dot(c) + c.dot(a),
    )
}

/// A triangle seen from a point as a spherical triangle (unit vectors to its corners), for
/// uniform solid-angle sampling (Arvo 1995, "Stratified sampling of spherical triangles", in the
/// form of pbrt-v4 §6.5.4). Computed in f64: the formulas subtract nearly equal angles.
struct SphericalTriangle {
    a: glam::DVec3,
    b: glam::DVec3,
    c: glam::DVec3,
    /// Interior angle at `a`.
    alpha: f64,
    /// Solid angle (= spherical excess α + β + γ − π).
    solid_angle: f32,
}

impl SphericalTriangle {
    /// The triangle `v` seen from `p`, when it subtends at least
    /// [`SPHERICAL_SAMPLING_MIN_SOLID_ANGLE`] and is not degenerate; `None` means area sampling.
    /// Both [`Light::sample`] and [`Light::pdf`] decide with this, so they always agree.
    fn seen_from(
        p: Vec3,
        v: [Vec3; 3],
        (n, area): (Vec3, f32),
        sphere: (Vec3, f32),
    ) -> Option<SphericalTriangle> {
        // Most shading points see most lights small: bound the solid angle first by that of the
        // triangle's bounding sphere (centroid, farthest corner), 2π(1 − cos α) with
        // sin α = r / d, written r²/d² / (1 + cos α) to stay accurate when small.
        let (centroid, r2) = sphere;
        let d2 = (p - centroid).length_squared();
        if far_beyond_sphere(d2, r2) {
            return None;
        }
        if d2 > r2 {
            if sphere_solid_angle(r2 / d2) < SPHERICAL_SAMPLING_MIN_SOLID_ANGLE {
                return None;
            }
            if near_plane_bound_rejects(p, (v[0], n, area), d2, r2) {
                return None;
            }
        }
        let p = p.as_dvec3();
        let a = (v[0].as_dvec3() - p).normalize_or_zero();
        let b = (v[1].as_dvec3() - p).normalize_or_zero();
        let c = (v[2].as_dvec3() - p).normalize_or_zero();
        // A cheap test first.
        let omega = solid_angle_of(a, b, c);
        // (A NaN solid angle fails this too.)
        if omega.is_nan() || omega < f64::from(SPHERICAL_SAMPLING_MIN_SOLID_ANGLE) {
            return None;
        }
        let (nab, nbc, nca) = (a.cross(b), b.cross(c), c.cross(a));
        if nab.length_squared() == 0.0 || nbc.length_squared() == 0.0 || nca.length_squared() == 0.0
        {
            return None;
        }
        let (nab, nbc, nca) = (nab.normalize(), nbc.normalize(), nca.normalize());
        let angle = |x: glam::DVec3, y: glam::DVec3| {
            crate::lanes::math::acos_f64(x.dot(y).clamp(-1.0, 1.0))
        };
        let alpha = angle(nab, -nca);
        let beta = angle(nbc, -nab);
        let gamma = angle(nca, -nbc);
        let area = alpha + beta + gamma - std::f64::consts::PI;
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        Some(SphericalTriangle {
            a,
            b,
            c,
            alpha,
            solid_angle: area as f32,
        })
    }

    /// A direction uniform over the spherical triangle, the point where it meets the plane of
    /// the triangle `v` (normal `n`), its distance from `p`, and the point's barycentrics
    /// (b1, b2) for texture coordinates; `None` when rounding puts the direction off the plane.
    #[allow(clippy::type_complexity)]
    fn sample(
        &self,
        p: Vec3,
        v: [Vec3; 3],
        n: Vec3,
        u: Vec2,
    ) -> Option<(Vec3, Vec3, f32, (f32, f32))> {
        use std::f64::consts::PI;
        let (a, b, c) = (self.a, self.b, self.c);
        let (u0, u1) = (f64::from(u.x), f64::from(u.y));
        // Choose the sub-triangle area A' = u0·A, i.e. the angle α + β' + γ' = A' + π …
        let ap_pi = PI + u0 * f64::from(self.solid_angle);
        let (sin_alpha, cos_alpha) = crate::lanes::math::sin_cos_f64(self.alpha);
        let (sin_app, cos_app) = crate::lanes::math::sin_cos_f64(ap_pi);
        let sin_phi = sin_app * cos_alpha - cos_app * sin_alpha;
        let cos_phi = cos_app * cos_alpha + sin_app * sin_alpha;
        let k1 = cos_phi + cos_alpha;
        let k2 = sin_phi - sin_alpha * a.dot(b);
        // … whose third corner c' on the arc from a to c has cos of its distance to a:
        let cos_bp = ((k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha)
            / ((k2 * sin_phi + k1 * cos_phi) * sin_alpha))
            .clamp(-1.0, 1.0);
        let sin_bp = (1.0 - cos_bp * cos_bp).max(0.0).sqrt();
        let cp = cos_bp * a + sin_bp * (c - c.dot(a) * a).normalize_or_zero();
        // Then a point on the arc from b to c', uniform in the sub-triangle's area.
        let cos_theta = 1.0 - u1 * (1.0 - cp.dot(b));
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let w = (cos_theta * b + sin_theta * (cp - cp.dot(b) * b).normalize_or_zero()).normalize();
        if !w.is_finite() {
            return None;
        }
        let wi = w.as_vec3();
        let denom = n.dot(wi);
        let t = n.dot(v[0] - p) / denom;
        if !(t > 0.0 && t.is_finite()) {
            return None;
        }
        let q = p + wi * t;
        // Barycentrics of q (for the emission texture), clamped into the triangle.
        let (e1, e2, eq) = (v[1] - v[0], v[2] - v[0], q - v[0]);
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (dq1, dq2) = (eq.dot(e1), eq.dot(e2));
        let det = d11 * d22 - d12 * d12;
        let (b1, b2) = if det > 0.0 {
            (
                ((d22 * dq1 - d12 * dq2) / det).clamp(0.0, 1.0),
                ((d11 * dq2 - d12 * dq1) / det).clamp(0.0, 1.0),
            )
        } else {
            (0.0, 0.0)
        };
        Some((wi, q, t, (b1, b2)))
    }
}

/// The triangle lights that a wave's lanes sample, one per lane (structure of arrays), for
/// [`TriangleLanes::sample`].
#[repr(C, align(64))]
pub(crate) struct TriangleLanes<const W: usize> {
    v: [V3s<W>; 3],
    n: V3s<W>,
    area: F32s<W>,
    two_sided: Mask<W>,
    centroid: V3s<W>,
    r2: F32s<W>,
}

/// What [`TriangleLanes::sample`] found in each lane.
#[repr(C, align(64))]
pub(crate) struct TriangleSamples<const W: usize> {
    /// The lanes it decided: those behind a one-sided emitter and those that sample the
    /// triangle by area ([`Light::sample`]'s choice, by its bounds or by the solid angle in
    /// f32 well below the threshold); in the others the triangle may subtend
    /// [`SPHERICAL_SAMPLING_MIN_SOLID_ANGLE`], and [`Light::sample`] decides.
    pub decided: Mask<W>,
    /// The decided lanes with a sample ([`Light::sample`] gives `Some`).
    pub valid: Mask<W>,
    /// Unit direction to the sampled point.
    pub wi: V3s<W>,
    /// The sampled point.
    pub point: V3s<W>,
    /// Its solid-angle pdf.
    pub pdf: F32s<W>,
}

impl<const W: usize> TriangleLanes<W> {
    /// No lights: every lane's data zero (its results mean nothing until [`set`](Self::set)).
    pub fn new() -> Self {
        TriangleLanes {
            v: [V3s::default(); 3],
            n: V3s::default(),
            area: F32s::default(),
            two_sided: Mask::splat(false),
            centroid: V3s::default(),
            r2: F32s::default(),
        }
    }

    /// Lane `i` samples `light`, when it is a triangle (other kinds leave the lane as it was).
    #[inline(always)]
    pub fn set(&mut self, i: usize, light: &Light) {
        if let Light::Triangle {
            v,
            n,
            area,
            two_sided,
            sphere: (centroid, r2),
            ..
        } = light
        {
            for (lanes, corner) in self.v.iter_mut().zip(v) {
                lanes.set(i, *corner);
            }
            self.n.set(i, *n);
            self.area[i] = *area;
            self.two_sided.set(i, *two_sided);
            self.centroid.set(i, *centroid);
            self.r2[i] = *r2;
        }
    }

    /// Sets the lanes of `lanes` to the triangle light `light` (as [`set`](Self::set) sets
    /// one lane); other lights leave them as they are.
    #[inline(always)]
    pub fn set_where(&mut self, lanes: Mask<W>, light: &Light) {
        if let Light::Triangle {
            v,
            n,
            area,
            two_sided,
            sphere: (centroid, r2),
            ..
        } = light
        {
            for (vs, corner) in self.v.iter_mut().zip(v) {
                *vs = V3s::select(lanes, V3s::splat(*corner), *vs);
            }
            self.n = V3s::select(lanes, V3s::splat(*n), self.n);
            self.area = F32s::select(lanes, F32s::splat(*area), self.area);
            self.two_sided = if *two_sided {
                self.two_sided | lanes
            } else {
                self.two_sided.and_not(lanes)
            };
            self.centroid = V3s::select(lanes, V3s::splat(*centroid), self.centroid);
            self.r2 = F32s::select(lanes, F32s::splat(*r2), self.r2);
        }
    }

    /// Each lane's unit normal (front side).
    #[inline(always)]
    pub fn normal(&self) -> V3s<W> {
        self.n
    }

    /// [`Light::sample`] of each lane's triangle from `p` with the 2D point `u`, where the
    /// triangle is sampled by area: the same operations lane by lane, so the same bits.
    #[inline(always)]
    pub fn sample(&self, p: V3s<W>, u: (F32s<W>, F32s<W>)) -> TriangleSamples<W> {
        let zero = F32s::splat(0.0);
        let [v0, v1, v2] = self.v;
        // `unlit_side` in every lane.
        let h = self.n.dot(p - v0);
        let scale =
            p.x.abs()
                .max(p.y.abs())
                .max(p.z.abs())
                .max(v0.x.abs().max(v0.y.abs()).max(v0.z.abs()));
        let behind = h.abs().le(scale * F32s::splat(EDGE_ON)) | (!self.two_sided & h.le(zero));
        // `SphericalTriangle::seen_from`'s bounds, each lane's decision as there.
        let d2 = (p - self.centroid).length_squared();
        let far = self.r2.lt(F32s::splat(SPHERICAL_SAMPLING_FAR_SIN2) * d2);
        let sin2 = self.r2 / d2;
        let bound = F32s::splat(2.0 * PI) * sin2 / (1.0 + (1.0 - sin2).sqrt());
        let small = bound.lt(F32s::splat(SPHERICAL_SAMPLING_MIN_SOLID_ANGLE));
        let gap = d2.sqrt() - self.r2.sqrt();
        let h = self.n.dot(p - v0).abs();
        let near_plane = gap.gt(zero)
            & (self.area * h).lt(F32s::splat(SPHERICAL_SAMPLING_PLANE_BOUND) * (gap * gap * gap));
        let bounded_small = far | (d2.gt(self.r2) & (small | near_plane));
        // The bounds are loose for points a little farther than the bounding sphere's reach:
        // there `seen_from`'s exact solid angle (in f64) usually rejects the triangle after
        // all. Lanes the bounds leave open take the same formula in f32 here, and those well
        // below the threshold are decided too (see `TAN_HALF_F32_THRESHOLD`).
        let open = !behind & !bounded_small;
        let by_area = if open.any() {
            let corner = |v: V3s<W>| (v - p).normalize();
            let (a, b, c) = (corner(v0), corner(v1), corner(v2));
            // Ω = 2 atan2(N, D) (Van Oosterom and Strackee) with N ≥ 0 is below the threshold
            // minus the margin, Ω', exactly where D > 0 and N < D tan(Ω'/2): no arctangent.
            let numerator = a.dot(b.cross(c)).abs();
            let denominator = F32s::splat(1.0) + a.dot(b) + b.dot(c) + c.dot(a);
            // A NaN (a corner at p) fails both comparisons and leaves the lane open.
            let exact_small = denominator.gt(F32s::splat(0.0))
                & numerator.lt(denominator * F32s::splat(TAN_HALF_F32_THRESHOLD));
            bounded_small | (open & exact_small)
        } else {
            bounded_small
        };
        // A uniform point on the triangle (pbrt-v4's square-root mapping).
        let su = u.0.sqrt();
        let (b0, b1) = (1.0 - su, u.1 * su);
        let b2 = 1.0 - b0 - b1;
        let q = v0 * b0 + v1 * b1 + v2 * b2;
        let w = q - p;
        let dist2 = w.length_squared();
        let d = dist2.sqrt();
        let wi = w / d;
        let cos_l = self.n.dot(-wi);
        let facing = !(cos_l.le(zero) & !self.two_sided);
        let pdf = dist2 / (cos_l.abs() * self.area);
        TriangleSamples {
            decided: behind | by_area,
            valid: !behind & by_area & d.ne(zero) & facing & pdf.is_finite(),
            wi,
            point: q,
            pdf,
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
        let (sin_phi, cos_phi) = crate::lanes::math::sin_cos(2.0 * PI * u.y);
        let n = Vec3::new(r * cos_phi, r * sin_phi, z);
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
    let (sin_phi, cos_phi) = crate::lanes::math::sin_cos(2.0 * PI * u.y);
    let frame = crate::math::Frame::from_normal(axis);
    let wi = frame
        .to_world(Vec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t))
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

/// An environment's sample as seen from `p`.
fn environment_sample(s: crate::environment::EnvironmentSample, p: Vec3) -> LightSample {
    LightSample {
        wi: s.wi,
        distance: f32::INFINITY,
        point: p,
        normal: Vec3::ZERO,
        uv: Vec2::ZERO,
        li: s.le,
        pdf: s.pdf,
        delta: false,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The triangle light of corners `v`, front face counter-clockwise (for the tests here and
    /// the light tree's).
    pub(crate) fn triangle_light(v: [Vec3; 3], emission: Vec3, two_sided: bool) -> Light {
        Light::triangle(0, 0, v, [Vec2::ZERO, Vec2::X, Vec2::Y], emission, two_sided)
    }

    /// Three corners with coordinates drawn from `r`.
    fn random_corners(r: &mut impl FnMut() -> f32) -> [Vec3; 3] {
        [
            Vec3::new(r(), r(), r()),
            Vec3::new(r(), r(), r()),
            Vec3::new(r(), r(), r()),
        ]
    }

    /// The one-sided white triangle light of corners `v` (facing +z for counter-clockwise
    /// corners).
    fn triangle(v: [Vec3; 3]) -> Light {
        triangle_light(v, Vec3::ONE, false)
    }

    /// Where the ray from `p` along `w` meets the triangle (Möller–Trumbore), if it does.
    fn hit(p: Vec3, w: Vec3, v: [Vec3; 3]) -> Option<Vec3> {
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let h = w.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-12 {
            return None;
        }
        let s = p - v[0];
        let b1 = s.dot(h) / det;
        let q = s.cross(e1);
        let b2 = w.dot(q) / det;
        let t = e2.dot(q) / det;
        let eps = 1e-5;
        (b1 >= -eps && b2 >= -eps && b1 + b2 <= 1.0 + eps && t > 0.0).then(|| p + w * t)
    }

    /// χ² test of triangle-light sampling against its pdf, binned on the triangle itself: the
    /// unit square (s, t) maps onto it by b1 = s(1 − t), b2 = st (Jacobian 2·area·s), so bins
    /// never straddle its edges. A sampler of solid-angle density pdf_ω puts density
    /// pdf_ω·cos θ_l / d² per unit area there. Cases close to the light (sampled in solid
    /// angle) and farther or grazing (sampled by area); behind the one-sided light nothing is
    /// sampled.
    #[test]
    fn triangle_light_samples_follow_their_pdf() {
        use crate::bsdf::chi2;
        const BINS: usize = 24;
        const SUB: usize = 8;
        const N: usize = 200_000;
        let v = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.5, -0.8, 0.0),
            Vec3::new(-0.4, 1.2, 0.0),
        ];
        // (name, shading point, sampled in solid angle): the solid angles are 3.5, 0.46 and 0.27
        // sr for the first three, 0.048, 0.064 and less for the others.
        let cases = [
            ("close, overhead", Vec3::new(0.1, 0.0, 0.4), true),
            ("close, off to the side", Vec3::new(0.9, 0.5, 0.2), true),
            ("near a corner", Vec3::new(1.6, -1.2, 0.3), true),
            ("off to the side", Vec3::new(2.0, 1.5, 0.3), false),
            (
                "beside a corner, grazing",
                Vec3::new(1.6, -1.2, 0.05),
                false,
            ),
            ("oblique", Vec3::new(0.0, -3.0, 0.5), false),
            ("farther", Vec3::new(0.0, -9.0, 1.5), false),
        ];
        let light = triangle(v);
        let Light::Triangle {
            n, area, sphere, ..
        } = light
        else {
            unreachable!()
        };
        let point = |s: f64, t: f64| {
            let (b1, b2) = (s * (1.0 - t), s * t);
            v[0].as_dvec3() * (1.0 - b1 - b2) + v[1].as_dvec3() * b1 + v[2].as_dvec3() * b2
        };
        let mut ps = Vec::new();
        for (name, p, spherical) in cases {
            let omega =
                SphericalTriangle::seen_from(p, v, (n, area), sphere).map(|s| s.solid_angle);
            assert_eq!(omega.is_some(), spherical, "{name}: solid angle {omega:?}");
            let mut observed = vec![0.0f64; BINS * BINS];
            let mut rng = crate::sampler::Pcg32::new(7, 3);
            for _ in 0..N {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                let Some(ls) = light.sample(p, u) else {
                    continue;
                };
                assert!((ls.pdf - light.pdf(p, ls.point, n)).abs() <= 1e-3 * ls.pdf);
                // (s, t) of the sampled point.
                let (e1, e2, eq) = (v[1] - v[0], v[2] - v[0], ls.point - v[0]);
                let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
                let (dq1, dq2) = (eq.dot(e1), eq.dot(e2));
                let det = d11 * d22 - d12 * d12;
                let b1 = f64::from((d22 * dq1 - d12 * dq2) / det);
                let b2 = f64::from((d11 * dq2 - d12 * dq1) / det);
                let s = (b1 + b2).clamp(0.0, 1.0);
                let t = if s > 0.0 {
                    (b2 / s).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (i, j) = (
                    ((s * BINS as f64) as usize).min(BINS - 1),
                    ((t * BINS as f64) as usize).min(BINS - 1),
                );
                observed[i * BINS + j] += 1.0;
            }
            // Expected counts: N ∫ pdf_area over each bin (midpoint rule on a sub-grid).
            let pa = p.as_dvec3();
            let density = |q: glam::DVec3| {
                let w = q - pa;
                let d2 = w.length_squared();
                let cos = n.as_dvec3().dot(-w / d2.sqrt()).max(0.0);
                match omega {
                    Some(o) => cos / d2 / f64::from(o),
                    None => 1.0 / f64::from(area),
                }
            };
            let mut expected = vec![0.0f64; BINS * BINS];
            let h = 1.0 / (BINS * SUB) as f64;
            for i in 0..BINS {
                for j in 0..BINS {
                    let mut sum = 0.0;
                    for a in 0..SUB {
                        for b in 0..SUB {
                            let s = (i * SUB + a) as f64 * h + 0.5 * h;
                            let t = (j * SUB + b) as f64 * h + 0.5 * h;
                            sum += density(point(s, t)) * 2.0 * f64::from(area) * s;
                        }
                    }
                    expected[i * BINS + j] = sum * h * h * N as f64;
                }
            }
            let total: f64 = expected.iter().sum::<f64>() / N as f64;
            assert!(
                (total - 1.0).abs() < 2e-3,
                "{name}: pdf integrates to {total}"
            );
            ps.push((
                name.to_string(),
                chi2::p_value_of_counts(name, &observed, &expected),
            ));
            if name == "close, overhead" {
                // The test has power: the same samples against area sampling's density fail.
                let by_area: Vec<f64> = (0..BINS * BINS)
                    .map(|k| {
                        let s = ((k / BINS) as f64 + 0.5) / BINS as f64;
                        2.0 * s * N as f64 / (BINS * BINS) as f64
                    })
                    .collect();
                let p_area = chi2::p_value_of_counts(name, &observed, &by_area);
                assert!(
                    p_area < 1e-6,
                    "{name}: area density not rejected (p = {p_area})"
                );
            }
            // Behind the one-sided light nothing is sampled.
            let behind = Vec3::new(p.x, p.y, -p.z);
            assert!(light.sample(behind, Vec2::new(0.3, 0.6)).is_none());
        }
        chi2::assert_all_pass(&ps);
    }

    /// The quick rejection by [`SPHERICAL_SAMPLING_FAR_SIN2`] only takes points whose bounding-
    /// sphere bound is under the threshold: the bound at sin² α just above it, computed as
    /// `seen_from` computes it, stays below [`SPHERICAL_SAMPLING_MIN_SOLID_ANGLE`].
    #[test]
    fn far_rejection_agrees_with_the_bound() {
        let sin2 = SPHERICAL_SAMPLING_FAR_SIN2 * (1.0 + 4.0 * f32::EPSILON);
        let bound = sphere_solid_angle(sin2);
        assert!(
            bound < 0.97 * SPHERICAL_SAMPLING_MIN_SOLID_ANGLE,
            "bound {bound} at sin² {sin2}"
        );
        // And on real triangles: whatever `seen_from` rejects quickly, the bound rejects too.
        let mut rng = crate::sampler::Pcg32::new(11, 5);
        let mut quick = 0;
        for _ in 0..100_000 {
            let mut r = || rng.next_f32() * 4.0 - 2.0;
            let v = [
                Vec3::new(r(), r(), r()),
                Vec3::new(r(), r(), r()),
                Vec3::new(r(), r(), r()),
            ];
            let p = Vec3::new(r(), r(), r()) * 3.0;
            let Light::Triangle { sphere, .. } = triangle(v) else {
                unreachable!()
            };
            let (centroid, r2) = sphere;
            let d2 = (p - centroid).length_squared();
            if far_beyond_sphere(d2, r2) {
                quick += 1;
                assert!(
                    sphere_solid_angle(r2 / d2) < SPHERICAL_SAMPLING_MIN_SOLID_ANGLE,
                    "{v:?} from {p:?}"
                );
            }
        }
        assert!(
            quick > 10_000,
            "only {quick} quick rejections: the test tests little"
        );
    }

    #[test]
    fn the_tangent_of_the_f32_threshold_is_the_thresholds() {
        let half = f64::from(SPHERICAL_SAMPLING_MIN_SOLID_ANGLE - F32_MARGIN) / 2.0;
        assert!((f64::from(TAN_HALF_F32_THRESHOLD) - half.tan()).abs() < 1e-8);
    }

    /// The light kernel decides by area only where [`SphericalTriangle::seen_from`] samples by
    /// area: random two-sided triangles seen from points whose solid angle lies around
    /// [`SPHERICAL_SAMPLING_MIN_SOLID_ANGLE`] (where the bounds leave lanes open and the f32
    /// solid angle decides), at W = 16 and 4.
    #[test]
    fn lanes_decide_by_area_only_where_seen_from_does() {
        fn check<const W: usize>(seed: u64) -> (usize, usize) {
            let mut rng = crate::sampler::Pcg32::new(seed, 3);
            let (mut by_f32, mut near) = (0, 0);
            for _ in 0..20_000 / W {
                let mut r = || rng.next_f32() * 2.0 - 1.0;
                let v = random_corners(&mut r);
                let light = triangle_light(v, Vec3::ONE, true);
                let Light::Triangle {
                    n, area, sphere, ..
                } = light
                else {
                    unreachable!()
                };
                let centroid = sphere.0;
                let mut lanes = TriangleLanes::<W>::new();
                let mut points = [Vec3::ZERO; W];
                for (i, point) in points.iter_mut().enumerate() {
                    lanes.set(i, &light);
                    // Distances where a triangle of this area subtends about 0.2 sr.
                    let dir = Vec3::new(r(), r(), r()).normalize_or_zero();
                    let d = (area / 0.2).sqrt() * (0.6 + 0.8 * (r() * 0.5 + 0.5));
                    *point = centroid + dir * d;
                }
                let p = V3s::from_fn(|i| points[i]);
                let out = lanes.sample(p, (F32s::splat(0.5), F32s::splat(0.5)));
                for (i, &p) in points.iter().enumerate() {
                    let seen = SphericalTriangle::seen_from(p, v, (n, area), sphere);
                    let q = p.as_dvec3();
                    let [a, b, c] = v.map(|c| (c.as_dvec3() - q).normalize_or_zero());
                    let omega = solid_angle_of(a, b, c);
                    let bound = f64::from(SPHERICAL_SAMPLING_MIN_SOLID_ANGLE);
                    if (bound - 2e-3..bound).contains(&omega) {
                        near += 1;
                    }
                    if out.decided.lane(i) {
                        assert!(
                            seen.is_none(),
                            "{v:?} from {p:?}: Ω {omega}, decided by area"
                        );
                        let (d2, r2) = ((p - centroid).length_squared(), sphere.1);
                        let bounded = far_beyond_sphere(d2, r2)
                            || (d2 > r2
                                && (sphere_solid_angle(r2 / d2)
                                    < SPHERICAL_SAMPLING_MIN_SOLID_ANGLE
                                    || near_plane_bound_rejects(p, (v[0], n, area), d2, r2)));
                        by_f32 += usize::from(!bounded);
                    }
                }
            }
            (by_f32, near)
        }
        for (by_f32, near) in [check::<16>(21), check::<4>(22)] {
            assert!(
                by_f32 > 2_000,
                "only {by_f32} lanes decided by the f32 solid angle"
            );
            assert!(
                near > 50,
                "only {near} points within 0.002 sr under the threshold"
            );
        }
    }

    /// The bound for points near a triangle's plane, A·h / (d − r)³, is never below the solid
    /// angle where it rejects: random triangles seen from points close to their planes (the
    /// case it is for) and anywhere, the solid angle in f64 (Van Oosterom and Strackee) always
    /// under [`SPHERICAL_SAMPLING_MIN_SOLID_ANGLE`] when the bound rejects.
    #[test]
    fn plane_bound_rejects_only_small_solid_angles() {
        let mut rng = crate::sampler::Pcg32::new(12, 9);
        let mut rejected = 0;
        for k in 0..200_000 {
            let mut r = || rng.next_f32() * 2.0 - 1.0;
            let v = [
                Vec3::new(r(), r(), 0.0),
                Vec3::new(r(), r(), 0.0),
                Vec3::new(r(), r(), 0.0),
            ];
            // Heights from 10⁻⁴ to 1 above or below the plane, or a point anywhere.
            let p = if k % 4 == 3 {
                Vec3::new(r(), r(), r()) * 3.0
            } else {
                let h = 10f32.powf(-4.0 * (r() * 0.5 + 0.5)) * r().signum();
                Vec3::new(r() * 2.5, r() * 2.5, h)
            };
            let Light::Triangle {
                n, area, sphere, ..
            } = triangle_light(v, Vec3::ONE, true)
            else {
                unreachable!()
            };
            let (centroid, r2) = sphere;
            let d2 = (p - centroid).length_squared();
            if near_plane_bound_rejects(p, (v[0], n, area), d2, r2) {
                rejected += 1;
                let q = p.as_dvec3();
                let [a, b, c] = v.map(|c| (c.as_dvec3() - q).normalize());
                let omega = solid_angle_of(a, b, c);
                assert!(
                    omega < f64::from(SPHERICAL_SAMPLING_MIN_SOLID_ANGLE),
                    "{v:?} from {p:?}: Ω {omega}"
                );
            }
        }
        assert!(
            rejected > 20_000,
            "only {rejected} rejections: the test tests little"
        );
    }

    /// Solid-angle sampling lands on the triangle, and its solid angle is the integral of the
    /// area pdf's inverse (a closed form check: Ω = ∫ cos/d² dA).
    #[test]
    fn spherical_triangle_solid_angle_matches_the_area_integral() {
        let v = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.5, -0.8, 0.0),
            Vec3::new(-0.4, 1.2, 0.0),
        ];
        let p = Vec3::new(0.2, 0.1, 0.5);
        let Light::Triangle {
            n, area, sphere, ..
        } = triangle(v)
        else {
            unreachable!()
        };
        let st = SphericalTriangle::seen_from(p, v, (n, area), sphere).expect("large");
        // ∫ cos θ / d² dA by the midpoint rule on a fine barycentric grid.
        let k = 600;
        let (mut sum, area) = (
            0.0f64,
            0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length() as f64,
        );
        for i in 0..k {
            for j in 0..k - i {
                for (di, dj) in [(1.0 / 3.0, 1.0 / 3.0), (2.0 / 3.0, 2.0 / 3.0)] {
                    let (b1, b2) = ((i as f64 + di) / k as f64, (j as f64 + dj) / k as f64);
                    if b1 + b2 > 1.0 {
                        continue;
                    }
                    let q = v[0].as_dvec3() * (1.0 - b1 - b2)
                        + v[1].as_dvec3() * b1
                        + v[2].as_dvec3() * b2;
                    let w = q - p.as_dvec3();
                    sum += w.z.abs() / w.length().powi(3);
                }
            }
        }
        let omega = sum * area / (k * k) as f64;
        assert!(
            (f64::from(st.solid_angle) - omega).abs() < 2e-3 * omega,
            "{} vs {omega}",
            st.solid_angle
        );
        for k in 0..1000 {
            let u = Vec2::new(
                (k as f32 + 0.5) / 1000.0,
                ((k * 7919) % 1000) as f32 / 1000.0,
            );
            let (w, q, _, _) = st.sample(p, v, Vec3::Z, u).expect("a direction");
            let on = hit(p, w, v);
            assert!(
                on.is_some_and(|h| (h - q).length() < 1e-4),
                "{u:?}: {w:?} misses"
            );
        }
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

    /// Points on an emitting triangle (its own surface, as a light that also reflects is hit)
    /// see it edge-on and receive nothing: no sample, whichever side rounding puts them on,
    /// from the light alone and in lanes. Points a little off the plane do receive light.
    #[test]
    fn points_in_an_emitters_plane_get_no_sample() {
        let mut rng = crate::sampler::Pcg32::new(11, 5);
        let (mut on_plane, mut off_plane_lit) = (0, 0);
        for two_sided in [false, true] {
            for _ in 0..2_000 {
                let mut r = || rng.next_f32() * 2.0 - 1.0;
                let v = random_corners(&mut r);
                let light = triangle_light(v, Vec3::ONE, two_sided);
                let Light::Triangle { n, .. } = light else {
                    unreachable!()
                };
                // A point of the triangle (rounded in f32, so within rounding of its plane).
                let (b1, b2) = (r() * 0.25 + 0.25, r() * 0.25 + 0.25);
                let p = v[0] * (1.0 - b1 - b2) + v[1] * b1 + v[2] * b2;
                let u = Vec2::new(r() * 0.5 + 0.5, r() * 0.5 + 0.5);
                assert!(light.sample(p, u).is_none(), "{v:?} {p:?}");
                let mut lanes = TriangleLanes::<4>::new();
                for i in 0..4 {
                    lanes.set(i, &light);
                }
                let out = lanes.sample(V3s::splat(p), (F32s::splat(u.x), F32s::splat(u.y)));
                assert!(out.decided.all() && !out.valid.any());
                on_plane += 1;
                // Off the plane by a thousandth, in front: lit (unless the triangle is too
                // thin to meet from there).
                let lifted = p + n * 1e-3;
                off_plane_lit += usize::from(light.sample(lifted, u).is_some());
            }
        }
        assert!(
            off_plane_lit > on_plane * 9 / 10,
            "{off_plane_lit} of {on_plane}"
        );
    }
}
