//! The scene graph: everything the renderer needs, resolved and in world space. Built from a
//! validated scene description and its assets by [`build()`]; the renderer never sees the file formats.

pub mod build;

use crate::camera::Camera;
use crate::environment::Environment;
use crate::geometry::mesh::SurfaceLanes;
use crate::geometry::{Accel, Geometry, LaneSurfaces, RawHit, SegmentLanes, SurfaceHit};
use crate::lanes::Mask;
use crate::light::Light;
use crate::light_sampler::LightSampler;
use crate::material::Material;
use crate::math::{Ray, Rgb, Vec3};
use crate::texture::Texture;

pub use build::{build, BuildError};

/// The light-transport algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntegratorKind {
    /// Path tracing with next-event estimation and MIS.
    Path,
    /// Fast preview.
    Raycast,
}

/// Render settings.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum path depth (Mitsuba's counting: 1 = emitters seen directly).
    pub max_depth: u32,
    /// Seed.
    pub seed: u64,
    /// Algorithm.
    pub integrator: IntegratorKind,
    /// Sample sequence.
    pub sampler: crate::sampler::SamplerKind,
    /// Optional wall-clock budget in seconds.
    pub time_budget_s: Option<f32>,
}

/// A renderable scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// What rays that leave the scene see (`None`: black).
    pub environment: Option<std::sync::Arc<Environment>>,
    /// Index of the environment in `lights`, when it is sampled as a light.
    pub environment_light: Option<usize>,
    /// Geometry and its acceleration structure.
    pub geometry: Geometry,
    /// Materials, indexed by instances.
    pub materials: Vec<Material>,
    /// Textures, indexed by materials.
    pub textures: Vec<Texture>,
    /// Lights for next-event estimation (punctual lights and emissive shapes).
    pub lights: Vec<Light>,
    /// Light selection for next-event estimation (by power, or by a light tree).
    pub light_sampler: LightSampler,
    /// Settings.
    pub settings: Settings,
    /// Whether any material is transparent (alpha mask or blend): only then do rays look past
    /// the surfaces they meet.
    pub has_alpha: bool,
}

impl Scene {
    /// Closest hit along a ray, looking past the cut-away parts of alpha-masked surfaces and,
    /// with probability 1 − alpha, past alpha-blended ones (stochastic transparency). The
    /// transparent hits are skipped within the traversal that finds them (as Embree's filter
    /// functions do), however many there are, instead of a new ray being traced past each.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        if !self.has_alpha {
            return self.geometry.intersect(ray, t_min, t_max);
        }
        let (k, raw) = self
            .geometry
            .intersect_accepted(ray, t_min, t_max, &mut |k, raw| self.stops(ray, k, raw))?;
        Some(self.geometry.instances[k as usize].surface(ray, &raw, k))
    }

    /// Whether anything blocks the ray within (t_min, t_max); transparent parts let it through
    /// as they do for [`Scene::intersect`].
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        if !self.has_alpha {
            return self.geometry.occluded(ray, t_min, t_max);
        }
        self.geometry
            .occluded_accepted(ray, t_min, t_max, &mut |k, raw| self.stops(ray, k, raw))
    }

    /// The closest hits of a wave's rays into `hits` (`None` lanes are idle), each as
    /// [`intersect`](Scene::intersect) over (0, ∞) finds it (`surfaces`: working memory for
    /// [`Geometry::intersect_lanes`], which scenes without alpha-tested surfaces use).
    #[inline]
    pub fn intersect_lanes<const W: usize>(
        &self,
        rays: &[Option<Ray>; W],
        hits: &mut [Option<SurfaceHit>; W],
        surfaces: &mut SurfaceLanes<W>,
    ) {
        if !self.has_alpha {
            self.geometry.intersect_lanes(rays, hits, surfaces);
            return;
        }
        for (ray, hit) in rays.iter().zip(hits) {
            *hit = ray
                .as_ref()
                .and_then(|ray| self.intersect(ray, 0.0, f32::INFINITY));
        }
    }

    /// [`intersect_lanes`](Scene::intersect_lanes) of the rays of `rays`' live lanes (over
    /// (0, ∞)), keeping the hits whose surfaces are computed in SIMD lanes as lanes in `found` ([`Geometry::intersect_wave`](crate::geometry::Geometry::intersect_wave)):
    /// those are returned, the others go into `hits`.
    #[inline(always)]
    pub fn intersect_wave<const W: usize>(
        &self,
        rays: &SegmentLanes<W>,
        hits: &mut [Option<SurfaceHit>; W],
        surfaces: &mut SurfaceLanes<W>,
        found: &mut LaneSurfaces<W>,
    ) {
        if !self.has_alpha {
            return self.geometry.intersect_wave(rays, hits, surfaces, found);
        }
        found.in_lanes = Mask::splat(false);
        let rays = std::array::from_fn(|i| rays.get(i).map(|(ray, _)| ray));
        self.intersect_lanes(&rays, hits, surfaces);
    }

    /// Whether something blocks the shadow ray `ray`, a segment from a point of the scene
    /// towards a light sample (over (0, `t_max`)), as [`occluded`](Scene::occluded) finds it:
    /// only the triangles that can block such a segment are tested
    /// ([`Geometry::limit_shadow_casters`](crate::geometry::Geometry::limit_shadow_casters)).
    #[inline]
    pub fn shadowed(&self, ray: &Ray, t_max: f32) -> bool {
        if !self.has_alpha {
            return self.geometry.shadowed(ray, t_max);
        }
        self.occluded(ray, 0.0, t_max)
    }

    /// [`shadowed`](Scene::shadowed) for each of a wave's shadow rays (idle lanes report
    /// `false`).
    #[inline(always)]
    pub fn shadowed_lanes<const W: usize>(&self, segments: &SegmentLanes<W>) -> [bool; W] {
        if !self.has_alpha {
            return self.geometry.shadowed_lanes(segments);
        }
        std::array::from_fn(|i| {
            segments
                .get(i)
                .is_some_and(|(ray, t_max)| self.shadowed(&ray, t_max))
        })
    }

    /// Whether hit `raw` on instance `k` stops the ray: always on opaque materials; on
    /// transparent ones where the opacity is 1, or, for a blended surface, when a hash of the
    /// ray and the hit (as pbrt-v4 does: it consumes no sampler dimension, a shadow ray decides
    /// like the camera ray along the same line, and distinct layers get independent numbers)
    /// falls below the opacity.
    fn stops(&self, ray: &Ray, k: u32, raw: &RawHit) -> bool {
        let instance = &self.geometry.instances[k as usize];
        let material = &self.materials[instance.material as usize];
        if !material.has_alpha() {
            return true;
        }
        let opacity = material.opacity(&self.textures, &instance.opacity_inputs(ray, raw, k));
        opacity >= 1.0 || (opacity > 0.0 && alpha_hash(ray, raw, k) < opacity)
    }

    /// Radiance arriving along a ray that left the scene in direction `d` (unit), the MIS
    /// weight against light sampling applied: `bsdf_pdf` is the pdf with which the previous
    /// vertex sampled `d` (`None` for camera rays and delta lobes, which light sampling cannot
    /// produce), and `from` that vertex's position and normal, from which light sampling would
    /// have chosen the environment.
    #[inline]
    pub fn escaped(
        &self,
        d: Vec3,
        bsdf_pdf: Option<f32>,
        from: (Vec3, Vec3),
        camera_ray: bool,
    ) -> Rgb {
        let Some(env) = &self.environment else {
            return Vec3::ZERO;
        };
        if camera_ray && !env.visible {
            return Vec3::ZERO;
        }
        match (bsdf_pdf, self.environment_light) {
            (Some(pdf), Some(i)) => {
                let (le, pdf_env) = env.le_and_pdf_mis(d);
                let pdf_light = self.light_sampler.pmf(from.0, from.1, i) * pdf_env;
                le * crate::sampling::power_heuristic(pdf, pdf_light)
            }
            _ => env.le(d),
        }
    }

    /// Whether a ray leaving the scene finds no light whatever its direction: no environment,
    /// so [`escaped`](Self::escaped) gives zero.
    #[inline]
    pub fn escapes_dark(&self) -> bool {
        self.environment.is_none()
    }

    /// The material of a hit.
    #[inline]
    pub fn material(&self, hit: &SurfaceHit) -> &Material {
        &self.materials[self.geometry.instances[hit.instance as usize].material as usize]
    }

    /// Index of the area light a hit lies on, if its surface can be sampled by NEE.
    #[inline]
    pub fn light_of(&self, hit: &SurfaceHit) -> Option<usize> {
        let inst = &self.geometry.instances[hit.instance as usize];
        inst.light_base.map(|b| {
            b as usize
                + if matches!(inst.shape, crate::geometry::Shape::Mesh(_)) {
                    hit.prim as usize
                } else {
                    0
                }
        })
    }

    /// The material of an area light's surface; `None` for punctual lights, which have no
    /// surface.
    #[inline]
    pub fn material_of_light(&self, light: &Light) -> Option<&Material> {
        let instance = light.surface_instance()?;
        let material = self.geometry.instances.get(instance as usize)?.material;
        self.materials.get(material as usize)
    }
}

/// A uniform number in [0, 1) from a ray and a hit on it.
fn alpha_hash(ray: &Ray, hit: &RawHit, instance: u32) -> f32 {
    let bits = |v: Vec3| {
        (u64::from(v.x.to_bits()) << 32 | u64::from(v.y.to_bits()))
            ^ u64::from(v.z.to_bits()).rotate_left(17)
    };
    let mut h = crate::sampler::mix64(bits(ray.o) ^ 0x9e37_79b9_7f4a_7c15);
    h = crate::sampler::mix64(h ^ bits(ray.d));
    h = crate::sampler::mix64(
        h ^ (u64::from(hit.t.to_bits()) << 32 | u64::from(hit.prim))
            ^ u64::from(instance).rotate_left(40),
    );
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}
