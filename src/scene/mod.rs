//! The scene graph: everything the renderer needs, resolved and in world space. Built from a
//! validated scene description and its assets by [`build()`]; the renderer never sees the file formats.

pub mod build;

use crate::camera::Camera;
use crate::geometry::{Accel, Geometry, SurfaceHit};
use crate::light::{Light, LightSampler};
use crate::material::Material;
use crate::math::{Ray, Rgb};
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
    /// Radiance of rays that leave the scene.
    pub background: Rgb,
    /// Geometry and its acceleration structure.
    pub geometry: Geometry,
    /// Materials, indexed by instances.
    pub materials: Vec<Material>,
    /// Textures, indexed by materials.
    pub textures: Vec<Texture>,
    /// Lights for next-event estimation (punctual lights and emissive shapes).
    pub lights: Vec<Light>,
    /// Light selection by power.
    pub light_sampler: LightSampler,
    /// Settings.
    pub settings: Settings,
}

impl Scene {
    /// Closest hit along a ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        self.geometry.intersect(ray, t_min, t_max)
    }

    /// Whether anything blocks the ray within (t_min, t_max).
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.geometry.occluded(ray, t_min, t_max)
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
        let instance = match light {
            Light::Triangle { instance, .. } | Light::Sphere { instance, .. } => *instance,
            Light::Point { .. } | Light::Directional { .. } | Light::Spot { .. } => return None,
        };
        let material = self.geometry.instances.get(instance as usize)?.material;
        self.materials.get(material as usize)
    }
}
