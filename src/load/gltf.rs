//! glTF files opened for the loader: mesh primitives and images referenced by index from a
//! scene are read through `lumo_converters::gltf`, each file parsed once.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use lumo_converters::gltf::GltfFile;

use crate::assets::{Assets, MeshData};

/// The glTF files opened so far, by path.
#[derive(Default)]
pub(super) struct GltfCache {
    files: HashMap<PathBuf, Arc<GltfFile>>,
}

impl GltfCache {
    /// Opens `file` (once), noting it and its buffer files among the files `assets` read.
    pub(super) fn open(
        &mut self,
        file: &Path,
        assets: &mut Assets,
    ) -> Result<Arc<GltfFile>, String> {
        if let Some(f) = self.files.get(&key(file)) {
            return Ok(f.clone());
        }
        let f = Arc::new(GltfFile::open(file).map_err(|e| e.to_string())?);
        self.insert(f.clone(), assets);
        Ok(f)
    }

    /// Adds a file opened elsewhere, noting it and its buffer files among the files `assets`
    /// read.
    pub(super) fn insert(&mut self, file: Arc<GltfFile>, assets: &mut Assets) {
        let paths = file.files();
        if let Some(path) = paths.first() {
            self.files.insert(key(path), file.clone());
        }
        for path in paths {
            assets.note_file(path);
        }
    }
}

/// The cache key of a path: the same file however the scene spells it (`a/../b.glb`,
/// relative or absolute), else the path as given.
fn key(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// One primitive of one mesh as the renderer's mesh arrays.
pub(super) fn mesh_data(file: &GltfFile, mesh: u32, primitive: u32) -> Result<MeshData, String> {
    let d = file
        .mesh_primitive(mesh, primitive)
        .map_err(|e| e.to_string())?;
    Ok(MeshData {
        positions: shared(d.positions),
        triangles: Arc::new(d.indices),
        normals: d.normals.map(shared),
        // Already in lumo's bottom-left convention.
        uvs: d.uvs.map(shared),
        uvs1: d.texcoords_1.map(shared),
        tangents: d.tangents.map(shared),
        colors: d.colors.map(shared),
    })
}

/// The array as glam values, shared. Arrays of the same layout (`[f32; 3]` → `Vec3`,
/// `[f32; 2]` → `Vec2`) are converted in place, without a copy.
fn shared<T, U: From<T>>(v: Vec<T>) -> Arc<Vec<U>> {
    Arc::new(v.into_iter().map(U::from).collect())
}
