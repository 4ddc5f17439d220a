//! DamagedHelmet under `studio.exr` against a lumo reference of it: the textured asset of the
//! denoising test (`tests/denoise.rs`) and benchmark (`benches/denoise.rs`), each of which uses
//! part of it.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use glam::DVec3;
use lumo::image::{Image, REL_EPSILON};
use lumo::job::{JobSettings, RenderJob};

/// The model, its world and a reference render with its standard error.
pub struct Helmet {
    model: PathBuf,
    sky: PathBuf,
    /// The reference's radiance (its size is the renders').
    pub reference: Image,
    /// The standard error of each reference pixel's mean.
    pub ref_error: Image,
}

impl Helmet {
    /// The shared model and map, and the reference at `reference` (an EXR with a `std_error`
    /// group, as `tests/reference/README.md` makes `damaged_helmet_studio_1024.exr`).
    pub fn new(shared: &Path, reference: &Path) -> Helmet {
        let file = lumo::multilayer::read_exr(reference)
            .unwrap_or_else(|e| panic!("{}: {e}", reference.display()));
        let ref_error = file
            .group("std_error")
            .and_then(|g| g.to_rgb(file.beauty.width, file.beauty.height))
            .expect("the reference's standard error");
        Helmet {
            model: shared.join("gltf/DamagedHelmet/glTF-Binary/DamagedHelmet.glb"),
            sky: shared.join("hdri/studio.exr"),
            reference: file.beauty,
            ref_error,
        }
    }

    /// A render job at the reference's size: `spp` samples or `time_s` seconds, the passes
    /// `aovs`, paths of at most `depth` bounces.
    pub fn job(
        &self,
        spp: Option<u32>,
        time_s: Option<f32>,
        seed: u64,
        aovs: &str,
        depth: u32,
    ) -> RenderJob {
        let mut loaded = lumo::load(&self.model, &lumo::LoadOptions::default()).expect("loads");
        loaded
            .edit(|s| {
                s.image.width = self.reference.width;
                s.image.height = self.reference.height;
                s.render.seed = seed;
                s.render.max_depth = depth;
                s.background = lumo_schema::Background {
                    image: Some(self.sky.to_string_lossy().into_owned()),
                    ..Default::default()
                };
            })
            .expect("edits");
        RenderJob::new(
            &loaded,
            JobSettings {
                spp,
                time_s,
                aovs: aovs.parse().expect("pass names"),
                ..Default::default()
            },
        )
        .expect("job")
    }

    /// Each kept pixel's relative squared error against the reference, less the reference's own
    /// share (its variance), averaged over the three channels.
    pub fn rel_errors(&self, x: &Image, keep: &[bool]) -> Vec<f64> {
        (0..x.pixels.len())
            .filter(|&i| keep[i])
            .map(|i| {
                let (p, r, s) = (
                    x.pixels[i].as_dvec3(),
                    self.reference.pixels[i].as_dvec3(),
                    self.ref_error.pixels[i].as_dvec3(),
                );
                let d = p - r;
                ((d * d - s * s) / (r * r + DVec3::splat(REL_EPSILON))).element_sum() / 3.0
            })
            .collect()
    }

    /// relMSE over `keep`, less the reference's variance: the mean of [`Helmet::rel_errors`].
    pub fn rel_mse(&self, x: &Image, keep: &[bool]) -> f64 {
        let e = self.rel_errors(x, keep);
        e.iter().sum::<f64>() / e.len() as f64
    }
}
