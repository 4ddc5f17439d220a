//! The glTF importer wired into the renderer's loader: mesh primitives and images referenced
//! by index from a scene are read through `lumo_converters::gltf`, each file parsed once.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use lumo_converters::gltf::GltfFile;

use crate::math::{Vec2, Vec3};
use crate::scene::build::ExternalData;
use crate::scene::MeshData;

/// [`ExternalData`] backed by the glTF importer, with a cache of opened files.
#[derive(Default)]
pub struct GltfData {
    files: Mutex<HashMap<PathBuf, Arc<GltfFile>>>,
}

impl GltfData {
    fn open(&self, file: &Path) -> Result<Arc<GltfFile>, String> {
        let mut files = self
            .files
            .lock()
            .map_err(|_| "glTF cache poisoned by an earlier failure".to_string())?;
        if let Some(f) = files.get(file) {
            return Ok(f.clone());
        }
        let f = Arc::new(GltfFile::open(file).map_err(|e| e.to_string())?);
        files.insert(file.to_path_buf(), f.clone());
        Ok(f)
    }
}

impl ExternalData for GltfData {
    fn gltf_mesh(&self, file: &Path, mesh: u32, primitive: u32) -> Result<MeshData, String> {
        let d = self
            .open(file)?
            .mesh_primitive(mesh, primitive)
            .map_err(|e| e.to_string())?;
        Ok(MeshData {
            positions: d.positions.into_iter().map(Vec3::from).collect(),
            triangles: d.indices,
            normals: d.normals.map(|n| n.into_iter().map(Vec3::from).collect()),
            // Already in lumo's bottom-left convention.
            uvs: d.uvs.map(|t| t.into_iter().map(Vec2::from).collect()),
        })
    }

    fn gltf_image(&self, file: &Path, image: u32) -> Result<Vec<u8>, String> {
        Ok(self.open(file)?.image(image).map_err(|e| e.to_string())?.0)
    }
}
