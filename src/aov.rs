//! Render passes (AOVs, "arbitrary output variables"): what a pixel's samples saw besides their
//! radiance: the albedo and shading normal a denoiser is guided by, the depth, position and
//! texture coordinates of the camera ray's hit, the ids of the object and material there, and
//! the beauty's standard error.
//!
//! # Definitions
//!
//! They follow what denoisers expect (Open Image Denoise's documentation):
//!
//! - **albedo** (`albedo.R/G/B`) and **normal** (`normal.X/Y/Z`) are taken at the path's first
//!   *non-delta* vertex: mirrors and smooth glass are followed, their throughput (Fresnel
//!   weight, tint, absorption) multiplying the albedo, so a mirror's albedo shows what it
//!   reflects. The albedo is one sample of the BSDF's directional albedo ∫ f |cos θ| dω (the
//!   weight of the BSDF sample the path scatters with, so it costs nothing and leaves the
//!   beauty unchanged): exact for Lambertian surfaces (the base colour times texture and vertex
//!   colour), unbiased and averaged over the pixel's samples otherwise. The normal is the
//!   world-space shading normal (normal maps applied) on the surface's front side. An unlit
//!   surface's albedo is its colour clamped to [0, 1]; a path that leaves the scene before a
//!   non-delta vertex records the environment's radiance clamped to [0, 1] (times the
//!   throughput) as albedo and a zero normal. A path cut by `max_depth` before a non-delta
//!   vertex records zero.
//! - **depth** (`depth.Z`): the distance from the camera ray's origin to its first hit, along
//!   the ray (not the z of camera space), in scene units; **position** (`position.X/Y/Z`) and
//!   **uv** (`uv.U/V`) are that hit's world-space point and first texture coordinates. Pixels
//!   whose rays miss the scene hold 0 in all three (averaged with the samples that hit, at
//!   silhouettes).
//! - **object_id** and **material_id** (`object_id.I`, `material_id.I`, unsigned 32-bit): the
//!   index + 1 of the object in the scene's `objects` list and of its material among the
//!   scene's `materials` sorted by name (the order of the table, which is keyed by name) hit by the pixel's *lowest-numbered* sample (sample 0 of
//!   a whole render), never an average; 0 where that sample's camera ray missed.
//! - **std_error** (`std_error.R/G/B`): the standard error of each pixel's beauty mean, from the
//!   film's sums of squares.
//!
//! # Exact sums
//!
//! Each sample's pass values go into the same film as its radiance, as fixed-point integers
//! (see [`crate::render::Film`]), so a render split by sample ranges or windows, checkpointed
//! and resumed, or merged in any order has the same pass bits as one uninterrupted render. Ids
//! keep the lowest sample index seen, which is also independent of the order of merging.

use std::fmt;
use std::str::FromStr;

use crate::geometry::SurfaceHit;
use crate::math::{Ray, Vec2, Vec3};

/// One render pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Aov {
    /// Albedo at the first non-delta vertex.
    Albedo,
    /// Shading normal at the first non-delta vertex.
    Normal,
    /// Distance along the camera ray to its hit.
    Depth,
    /// World-space position of the camera ray's hit.
    Position,
    /// Texture coordinates of the camera ray's hit.
    Uv,
    /// Index + 1 of the object the pixel's first sample hit.
    ObjectId,
    /// Index + 1 of the material the pixel's first sample hit.
    MaterialId,
    /// Standard error of the beauty.
    StdError,
}

impl Aov {
    /// Every pass, in the order they are stored and written.
    pub const ALL: [Aov; 8] = [
        Aov::Albedo,
        Aov::Normal,
        Aov::Depth,
        Aov::Position,
        Aov::Uv,
        Aov::ObjectId,
        Aov::MaterialId,
        Aov::StdError,
    ];

    /// Its name on the command line and the prefix of its EXR channels.
    pub fn name(self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::Position => "position",
            Aov::Uv => "uv",
            Aov::ObjectId => "object_id",
            Aov::MaterialId => "material_id",
            Aov::StdError => "std_error",
        }
    }

    /// The suffixes of its EXR channels (`albedo.R`, …).
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Aov::Albedo | Aov::StdError => &["R", "G", "B"],
            Aov::Normal | Aov::Position => &["X", "Y", "Z"],
            Aov::Depth => &["Z"],
            Aov::Uv => &["U", "V"],
            Aov::ObjectId | Aov::MaterialId => &["I"],
        }
    }

    /// Whether its values are summed per sample in the film (the ids and the standard error
    /// are not: ids are kept from one sample, the error comes from the beauty's sums).
    fn summed(self) -> bool {
        !matches!(self, Aov::ObjectId | Aov::MaterialId | Aov::StdError)
    }

    fn bit(self) -> u16 {
        1 << (self as u16)
    }
}

impl fmt::Display for Aov {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A set of render passes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct AovSet(u16);

impl AovSet {
    /// No passes.
    pub const NONE: AovSet = AovSet(0);

    /// Whether no pass is asked for.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Whether `aov` is in the set.
    pub fn contains(self, aov: Aov) -> bool {
        self.0 & aov.bit() != 0
    }

    /// The set with `aov` added.
    pub fn with(self, aov: Aov) -> AovSet {
        AovSet(self.0 | aov.bit())
    }

    /// The union of two sets.
    pub fn union(self, other: AovSet) -> AovSet {
        AovSet(self.0 | other.0)
    }

    /// The passes, in [`Aov::ALL`]'s order.
    pub fn iter(self) -> impl Iterator<Item = Aov> {
        Aov::ALL.into_iter().filter(move |a| self.contains(*a))
    }

    /// The passes' names, as `lumo render --aov` takes them.
    pub fn names(self) -> Vec<&'static str> {
        self.iter().map(Aov::name).collect()
    }

    /// Whether any pass needs per-sample records of the paths (all but `std_error`).
    pub fn needs_samples(self) -> bool {
        self.iter().any(|a| a != Aov::StdError)
    }

    /// The passes a film records per sample: all but `std_error`, which comes from the
    /// beauty's sums.
    pub fn recorded(self) -> AovSet {
        AovSet(self.0 & !Aov::StdError.bit())
    }

    /// Whether ids are recorded.
    pub fn has_ids(self) -> bool {
        self.contains(Aov::ObjectId) || self.contains(Aov::MaterialId)
    }

    /// Fixed-point channels summed per pixel: the channels of the summed passes.
    pub fn summed_channels(self) -> usize {
        self.iter()
            .filter(|a| a.summed())
            .map(|a| a.channels().len())
            .sum()
    }

    /// Offset of a summed pass's first channel among [`summed_channels`](Self::summed_channels).
    pub fn offset(self, aov: Aov) -> Option<usize> {
        if !self.contains(aov) || !aov.summed() {
            return None;
        }
        Some(
            self.iter()
                .take_while(|a| *a != aov)
                .filter(|a| a.summed())
                .map(|a| a.channels().len())
                .sum(),
        )
    }
}

impl fmt::Display for AovSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return f.write_str("none");
        }
        f.write_str(&self.names().join(","))
    }
}

impl FromStr for AovSet {
    type Err = String;

    /// A comma-separated list of pass names (`albedo,normal,depth`); `none` or an empty string
    /// is the empty set.
    fn from_str(s: &str) -> Result<AovSet, String> {
        let mut set = AovSet::NONE;
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            if name == "none" {
                continue;
            }
            let aov = Aov::ALL
                .into_iter()
                .find(|a| a.name() == name)
                .ok_or_else(|| {
                    format!(
                        "unknown render pass `{name}` (choose from {})",
                        Aov::ALL.map(Aov::name).join(", ")
                    )
                })?;
            set = set.with(aov);
        }
        Ok(set)
    }
}

/// What one sample's path saw, filled in as it is traced ([`crate::integrator::path::Path`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct AovSample {
    /// Albedo at the first non-delta vertex (see the module doc).
    pub albedo: Vec3,
    /// Shading normal there.
    pub normal: Vec3,
    /// Distance along the camera ray to its hit.
    pub depth: f32,
    /// The camera ray's hit point.
    pub position: Vec3,
    /// Its texture coordinates.
    pub uv: Vec2,
    /// Index + 1 of the object hit by the camera ray, 0 for none.
    pub object: u32,
    /// Index + 1 of its material, 0 for none.
    pub material: u32,
    /// Whether albedo and normal are final (a non-delta vertex, an unlit surface or the
    /// environment was reached).
    pub found: bool,
    /// Whether the normal is that of a non-delta vertex whose albedo comes with its BSDF sample.
    pending: bool,
}

impl AovSample {
    /// Records the camera ray's hit: depth, position, uv and ids.
    pub fn camera_hit(&mut self, scene: &crate::scene::Scene, hit: &SurfaceHit, ray: &Ray) {
        self.depth = hit.t * ray.d.length();
        self.position = hit.p;
        self.uv = hit.uv;
        self.object = hit.instance + 1;
        self.material = scene
            .geometry
            .instances
            .get(hit.instance as usize)
            .map_or(0, |i| i.material + 1);
    }

    /// The path left the scene, finding `radiance` there, with throughput `beta`.
    pub fn escaped(&mut self, beta: Vec3, radiance: Vec3) {
        if !self.found {
            self.albedo = beta * radiance.clamp(Vec3::ZERO, Vec3::ONE);
            self.normal = Vec3::ZERO;
            self.found = true;
        }
    }

    /// The path met an unlit surface of this colour and normal.
    pub fn unlit(&mut self, beta: Vec3, colour: Vec3, normal: Vec3) {
        if !self.found {
            self.albedo = beta * colour.clamp(Vec3::ZERO, Vec3::ONE);
            self.normal = normal;
            self.found = true;
        }
    }

    /// The path reached a vertex with a non-delta lobe, of this shading normal: its albedo
    /// comes with the BSDF sample ([`scattered`](Self::scattered)).
    pub fn smooth_vertex(&mut self, normal: Vec3) {
        if !self.found {
            self.normal = normal;
            self.pending = true;
            self.found = true;
        }
    }

    /// The BSDF sample of the vertex after [`smooth_vertex`](Self::smooth_vertex): its weight
    /// f |cos θ| / pdf (`None` when sampling failed), with throughput `beta` before it.
    pub fn scattered(&mut self, beta: Vec3, weight: Option<Vec3>) {
        if self.pending {
            self.albedo = beta * weight.unwrap_or(Vec3::ZERO);
            self.pending = false;
        }
    }
    /// The summed channels' values, in the order of `set`'s [`AovSet::offset`]s.
    fn values(&self, set: AovSet, out: &mut [f32]) {
        let mut k = 0;
        let mut put = |vs: &[f32]| {
            out[k..k + vs.len()].copy_from_slice(vs);
            k += vs.len();
        };
        for aov in set.iter() {
            match aov {
                Aov::Albedo => put(&self.albedo.to_array()),
                Aov::Normal => put(&self.normal.to_array()),
                Aov::Depth => put(&[self.depth]),
                Aov::Position => put(&self.position.to_array()),
                Aov::Uv => put(&self.uv.to_array()),
                Aov::ObjectId | Aov::MaterialId | Aov::StdError => {}
            }
        }
    }
}

/// The id record of a pixel: the ids of its lowest-numbered sample so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdRecord {
    /// That sample's index ([`IdRecord::NONE`]'s `u32::MAX` when there is none).
    pub sample: u32,
    /// Object index + 1 (0: the ray missed).
    pub object: u32,
    /// Material index + 1 (0: the ray missed).
    pub material: u32,
}

impl IdRecord {
    /// No sample yet.
    pub const NONE: IdRecord = IdRecord {
        sample: u32::MAX,
        object: 0,
        material: 0,
    };

    /// Keeps whichever of the two records comes from the lower sample index.
    pub fn merge(&mut self, other: &IdRecord) {
        if other.sample < self.sample {
            *self = *other;
        }
    }
}

impl Default for IdRecord {
    fn default() -> Self {
        IdRecord::NONE
    }
}

/// Largest magnitude a pass value is stored with: values are clamped to ±this (and a NaN is
/// stored as 0), so that a pass sample is never dropped and every pixel's pass sums hold the
/// same samples as its beauty (2³¹ scene units, far beyond any scene).
pub const MAX_AOV_VALUE: f32 = 2_147_483_648.0;

/// 2⁶⁴: the fixed-point scale of pass sums, that of the film's sums of radiance.
const FIXED_POINT_SCALE: f64 = 18_446_744_073_709_551_616.0;

/// A pass value (|v| ≤ [`MAX_AOV_VALUE`]) as a fixed-point term: v · 2⁶⁴ rounded half away from
/// zero, exact in f64 (a power-of-two scaling), the same integer the film adds for radiance.
#[inline]
fn fixed_point(v: f32) -> i128 {
    (f64::from(v) * FIXED_POINT_SCALE).round() as i128
}

/// The pass sums of a run of pixels (a film's, or a tile's): per pixel,
/// [`AovSet::summed_channels`] fixed-point sums in the beauty's units (2⁻⁶⁴), and an
/// [`IdRecord`] when ids are asked for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AovSums {
    set: AovSet,
    stride: usize,
    sums: Vec<i128>,
    ids: Vec<IdRecord>,
}

impl AovSums {
    /// Empty sums of `set`'s passes for `pixels` pixels.
    pub fn new(set: AovSet, pixels: usize) -> AovSums {
        let stride = set.summed_channels();
        AovSums {
            set,
            stride,
            sums: vec![0; stride * pixels],
            ids: if set.has_ids() {
                vec![IdRecord::NONE; pixels]
            } else {
                Vec::new()
            },
        }
    }

    /// Sums read from a file: `sums` (`stride` per pixel) and `ids` (one per pixel, or empty
    /// without id passes); `None` when their lengths do not fit `pixels`.
    pub fn from_parts(
        set: AovSet,
        pixels: usize,
        sums: Vec<i128>,
        ids: Vec<IdRecord>,
    ) -> Option<AovSums> {
        let stride = set.summed_channels();
        let ids_len = if set.has_ids() { pixels } else { 0 };
        (sums.len() == stride * pixels && ids.len() == ids_len).then_some(AovSums {
            set,
            stride,
            sums,
            ids,
        })
    }

    /// The passes.
    pub fn set(&self) -> AovSet {
        self.set
    }

    /// Summed channels per pixel.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Every pixel's sums, `stride` per pixel.
    pub fn sums(&self) -> &[i128] {
        &self.sums
    }

    /// Every pixel's id record (empty without id passes).
    pub fn ids(&self) -> &[IdRecord] {
        &self.ids
    }

    /// Adds sample number `index` of pixel `pixel`.
    #[inline]
    pub fn add(&mut self, pixel: usize, index: u32, sample: &AovSample) {
        if self.stride > 0 {
            let mut values = [0f32; 12];
            sample.values(self.set, &mut values);
            let sums = &mut self.sums[pixel * self.stride..(pixel + 1) * self.stride];
            for (sum, v) in sums.iter_mut().zip(values) {
                let v = if v.is_nan() {
                    0.0
                } else {
                    v.clamp(-MAX_AOV_VALUE, MAX_AOV_VALUE)
                };
                *sum += fixed_point(v);
            }
        }
        if let Some(id) = self.ids.get_mut(pixel) {
            id.merge(&IdRecord {
                sample: index,
                object: sample.object,
                material: sample.material,
            });
        }
    }

    /// Adds pixel `from` of `other` (of the same passes) into pixel `to`.
    pub fn merge_pixel(&mut self, to: usize, other: &AovSums, from: usize) {
        debug_assert_eq!(self.set, other.set);
        let s = self.stride;
        for k in 0..s {
            self.sums[to * s + k] += other.sums[from * s + k];
        }
        if let (Some(a), Some(b)) = (self.ids.get_mut(to), other.ids.get(from)) {
            a.merge(b);
        }
    }

    /// The mean of summed channel `channel` of pixel `pixel` over `samples` samples.
    pub fn mean(&self, pixel: usize, channel: usize, samples: u32) -> f32 {
        if samples == 0 {
            return 0.0;
        }
        (self.sums[pixel * self.stride + channel] as f64 / FIXED_POINT_SCALE / f64::from(samples))
            as f32
    }
}

/// A pass as an image: `channels` floats per pixel, row-major, top row first (ids as exact
/// integers in u32).
#[derive(Debug, Clone, PartialEq)]
pub enum PassPixels {
    /// Averaged values.
    Float(Vec<f32>),
    /// Ids.
    Id(Vec<u32>),
}

/// One pass of a finished image.
#[derive(Debug, Clone, PartialEq)]
pub struct PassImage {
    /// Which pass.
    pub aov: Aov,
    /// Its values, `aov.channels().len()` per pixel.
    pub pixels: PassPixels,
}

impl PassImage {
    /// The `std_error` pass of an image of per-pixel standard errors.
    pub fn std_error(std_error: &crate::image::Image) -> PassImage {
        PassImage {
            aov: Aov::StdError,
            pixels: PassPixels::Float(std_error.pixels.iter().flat_map(|p| p.to_array()).collect()),
        }
    }
}
