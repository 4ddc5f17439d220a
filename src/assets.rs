//! What a scene references, in memory: meshes and decoded images, keyed by how the scene names
//! them, and the list of files they were read from. Plain data: [`crate::load`] reads it, the
//! scene build ([`crate::scene::build()`]) takes meshes and images from it without touching a
//! file.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use lumo_schema as schema;

pub use crate::geometry::mesh::MeshData;
use crate::texture::Texels;

/// A decoded texture image: texels as stored in the file (not yet linearised).
#[derive(Debug, Clone)]
pub struct TextureImage {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texels, row-major, top row first, as the file stores them: 8-bit images keep their bytes
    /// (decoded as k/255), others are floats (16-bit values as k/65535).
    pub texels: Texels,
    /// Whether the file holds linear floating-point values (EXR, HDR), which are never
    /// sRGB-decoded.
    pub is_float: bool,
}

/// Where a mesh comes from, as the scene writes it (inline meshes are not assets).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(crate) enum MeshKey {
    Obj(String),
    Gltf(String, u32, u32),
}

impl MeshKey {
    /// The key of a mesh source, `None` for inline meshes.
    pub(crate) fn of(source: &schema::MeshSource) -> Option<MeshKey> {
        match source {
            schema::MeshSource::Obj(f) => Some(MeshKey::Obj(f.clone())),
            schema::MeshSource::Gltf(g) => Some(MeshKey::Gltf(g.file.clone(), g.mesh, g.primitive)),
            schema::MeshSource::Inline(_) => None,
        }
    }
}

/// The key of an image: the file as the scene names it and, for images inside a glTF file, the
/// image's index.
pub(crate) type ImageKey = (String, Option<u32>);

/// Every mesh and image a scene references, each once, keyed by how the scene refers to them.
#[derive(Debug, Clone, Default)]
pub struct Assets {
    meshes: HashMap<MeshKey, Arc<MeshData>>,
    images: HashMap<ImageKey, Arc<TextureImage>>,
    files: Vec<PathBuf>,
}

impl Assets {
    /// The mesh read for `source`, or `None` for inline meshes and sources that were not
    /// read (the scene was changed after its assets were read).
    pub fn mesh(&self, source: &schema::MeshSource) -> Option<&Arc<MeshData>> {
        self.meshes.get(&MeshKey::of(source)?)
    }

    /// The image read for `texture`.
    pub fn texture(&self, texture: &schema::Texture) -> Option<&Arc<TextureImage>> {
        self.images.get(&(texture.file.clone(), texture.gltf_image))
    }

    /// The decoded environment image of the scene's `background.image`, if it has one.
    pub fn environment(&self, background: &schema::Background) -> Option<&Arc<TextureImage>> {
        let file = background.image.as_ref()?;
        self.images.get(&(file.clone(), None))
    }

    /// Every file read, each once, in the order first read.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    pub(crate) fn has_mesh(&self, key: &MeshKey) -> bool {
        self.meshes.contains_key(key)
    }

    pub(crate) fn insert_mesh(&mut self, key: MeshKey, mesh: Arc<MeshData>) {
        self.meshes.insert(key, mesh);
    }

    pub(crate) fn has_image(&self, key: &ImageKey) -> bool {
        self.images.contains_key(key)
    }

    pub(crate) fn insert_image(&mut self, key: ImageKey, image: Arc<TextureImage>) {
        self.images.insert(key, image);
    }

    /// Records a file as read (once, in the order first read).
    pub(crate) fn note_file(&mut self, file: PathBuf) {
        if !self.files.contains(&file) {
            self.files.push(file);
        }
    }
}
