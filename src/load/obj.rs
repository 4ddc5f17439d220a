//! Wavefront OBJ meshes as the renderer's arrays: all objects and groups, polygons
//! fan-triangulated, normals and texture coordinates from the file.

use std::path::Path;
use std::sync::Arc;

use crate::math::{Vec2, Vec3};

use crate::geometry::mesh::MeshData;

/// Reads an OBJ file through the one OBJ reader ([`lumo_converters::obj::load`]) into the
/// renderer's arrays (normals normalised). Errors name the problem; the caller names the file.
pub fn load_obj(path: &Path) -> Result<MeshData, String> {
    use lumo_converters::obj::{load, ObjLoadError};
    let mesh = load(path).map_err(|e| match e {
        ObjLoadError::Read(message) => format!("cannot read OBJ: {message}"),
        other => other.to_string(),
    })?;
    Ok(MeshData {
        positions: Arc::new(mesh.positions.into_iter().map(Vec3::from).collect()),
        triangles: Arc::new(mesh.triangles),
        normals: mesh.normals.map(|n| {
            Arc::new(
                n.into_iter()
                    .map(|v| Vec3::from(v).normalize_or_zero())
                    .collect(),
            )
        }),
        uvs: mesh
            .uvs
            .map(|t| Arc::new(t.into_iter().map(Vec2::from).collect())),
        ..MeshData::default()
    })
}
