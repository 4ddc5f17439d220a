//! Reading what a scene references (OBJ and glTF meshes, texture images) into plain arrays,
//! so that building the scene graph does no I/O.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use lumo_schema as schema;
use lumo_schema::Validated;

use lumo_converters::gltf::GltfFile;

use super::gltf::GltfCache;
use crate::assets::{Assets, MeshKey, TextureImage};
use crate::math::{unorm8_table, Vec3};
use crate::texture::Texels;

/// A file the scene references could not be read or decoded.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}: {message} (referenced at {json_path})", file.display())]
pub struct AssetError {
    /// The file.
    pub file: PathBuf,
    /// JSON path of the reference in the scene.
    pub json_path: String,
    /// What went wrong.
    pub message: String,
}

impl Assets {
    /// Reads every texture and mesh file `scene` references; relative paths resolve against
    /// `base_dir`. The first file that fails is the error.
    pub fn read(scene: &Validated<schema::Scene>, base_dir: &Path) -> Result<Assets, AssetError> {
        Self::read_with(scene, base_dir, None)
    }

    /// [`Assets::read`], starting from a glTF file that is already open (the input itself, when
    /// the scene was imported from glTF): its meshes and images are read from it without
    /// opening it again.
    pub(super) fn read_with(
        scene: &Validated<schema::Scene>,
        base_dir: &Path,
        opened: Option<Arc<GltfFile>>,
    ) -> Result<Assets, AssetError> {
        let mut assets = Assets::default();
        assets.read_missing(scene, base_dir, opened)?;
        Ok(assets)
    }

    /// Reads what `scene` references and is not in memory yet (a scene derived from the one
    /// these assets were read for shares every mesh and image the two have in common).
    pub(super) fn read_missing(
        &mut self,
        scene: &Validated<schema::Scene>,
        base_dir: &Path,
        opened: Option<Arc<GltfFile>>,
    ) -> Result<(), AssetError> {
        let assets = self;
        let mut gltf = GltfCache::default();
        if let Some(file) = opened {
            gltf.insert(file, assets);
        }
        for (name, t) in &scene.textures {
            let key = (t.file.clone(), t.gltf_image);
            if assets.has_image(&key) {
                continue;
            }
            let path = base_dir.join(&t.file);
            let fail = |message: String| AssetError {
                file: path.clone(),
                json_path: format!("textures.{name}"),
                message,
            };
            let bytes = match t.gltf_image {
                Some(i) => {
                    let file = gltf.open(&path, assets).map_err(fail)?;
                    let bytes = file.image(i).map_err(|e| fail(e.to_string()))?.0;
                    if let Some(image_file) = file.image_file(i) {
                        assets.note_file(image_file);
                    }
                    bytes
                }
                None => {
                    let bytes = std::fs::read(&path)
                        .map_err(|e| fail(format!("cannot read texture: {e}")))?;
                    assets.note_file(path.clone());
                    bytes
                }
            };
            let image = decode_image(&bytes).map_err(fail)?;
            assets.insert_image(key, Arc::new(image));
        }
        assets.read_environment(&scene.background, base_dir)?;
        for (i, obj) in scene.objects.iter().enumerate() {
            let schema::Object::Mesh(m) = obj else {
                continue;
            };
            let Some(key) = MeshKey::of(&m.source) else {
                continue;
            };
            if assets.has_mesh(&key) {
                continue;
            }
            let json_path = format!("objects[{i}].{}", obj.kind());
            let data = match &m.source {
                schema::MeshSource::Obj(file) => {
                    let path = base_dir.join(file);
                    let data = super::obj::load_obj(&path).map_err(|message| AssetError {
                        file: path.clone(),
                        json_path: format!("{json_path}.source.obj"),
                        message,
                    })?;
                    assets.note_file(path);
                    data
                }
                schema::MeshSource::Gltf(g) => {
                    let path = base_dir.join(&g.file);
                    let fail = |message: String| AssetError {
                        file: path.clone(),
                        json_path: format!("{json_path}.source.gltf"),
                        message,
                    };
                    let file = gltf.open(&path, assets).map_err(fail)?;
                    super::gltf::mesh_data(&file, g.mesh, g.primitive).map_err(fail)?
                }
                schema::MeshSource::Inline(_) => continue,
            };
            assets.insert_mesh(key, Arc::new(data));
        }
        Ok(())
    }

    /// Reads the environment image `background` names, unless it is already in memory.
    pub(crate) fn read_environment(
        &mut self,
        background: &schema::Background,
        base_dir: &Path,
    ) -> Result<(), AssetError> {
        let Some(file) = &background.image else {
            return Ok(());
        };
        let key = (file.clone(), None);
        if self.has_image(&key) {
            return Ok(());
        }
        let path = base_dir.join(file);
        let fail = |message: String| AssetError {
            file: path.clone(),
            json_path: "background.image".into(),
            message,
        };
        let bytes = std::fs::read(&path)
            .map_err(|e| fail(format!("cannot read environment image: {e}")))?;
        self.note_file(path.clone());
        let image = decode_image(&bytes).map_err(fail)?;
        self.insert_image(key, Arc::new(image));
        Ok(())
    }
}

/// Decodes an encoded image (PNG, JPEG, BMP, HDR, EXR) into RGB texels.
fn decode_image(bytes: &[u8]) -> Result<TextureImage, String> {
    let img = image::load_from_memory(bytes).map_err(|e| format!("cannot decode image: {e}"))?;
    let is_float = matches!(
        img,
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)
    );
    let (width, height) = (img.width(), img.height());
    let texels = if img.color().bytes_per_pixel() == img.color().channel_count() {
        // 8 bits per channel (grey images are replicated to RGB, as to floats).
        let rgba = img.into_rgba8();
        let has_alpha = rgba.pixels().any(|p| p[3] != u8::MAX);
        let rgba: Arc<[[u8; 4]]> = rgba.pixels().map(|p| p.0).collect();
        Texels::Rgba8 {
            rgba,
            has_alpha,
            decode: unorm8_table(),
        }
    } else {
        let alpha = if img.color().has_alpha() {
            let rgba = img.to_rgba32f();
            let a: Vec<f32> = rgba.pixels().map(|p| p[3]).collect();
            a.iter().any(|&x| x != 1.0).then_some(a)
        } else {
            None
        };
        let rgb = img.to_rgb32f();
        Texels::Float {
            rgb: rgb.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect(),
            alpha,
        }
    };
    Ok(TextureImage {
        width,
        height,
        texels,
        is_float,
    })
}
