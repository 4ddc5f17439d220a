//! Reading one mesh primitive's triangles for the renderer.

use std::path::Path;

use gltf::mesh::Mode;
use gltf::Semantic;

use super::document::Loaded;
use super::error::GltfError;

/// The triangles of one glTF mesh primitive, in the primitive's own (object) space.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Vertex normals (unit length) when the primitive has a NORMAL attribute. When absent,
    /// glTF asks for flat shading: the importer sets the object's `smooth` to false.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Texture coordinates in lumo's convention: (0, 0) is the bottom-left of the image, so
    /// v = 1 − v_glTF. From the set `TEXCOORD_n` that the material's base-colour texture names
    /// (else its emissive, else its metallic-roughness texture; else set 0).
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Triangles as vertex indices, counter-clockwise front faces.
    pub indices: Vec<[u32; 3]>,
}

/// Loads one primitive of one mesh of a .gltf/.glb file. Only TRIANGLES primitives can be
/// loaded; every index and offset is checked.
pub fn load_mesh_primitive(file: &Path, mesh: u32, primitive: u32) -> Result<MeshData, GltfError> {
    GltfFile::open(file)?.mesh_primitive(mesh, primitive)
}

/// Loads image `image` of a .gltf/.glb file: its encoded bytes (PNG, JPEG...) and MIME type when
/// the file states it or the URI's extension tells.
pub fn load_image(file: &Path, image: u32) -> Result<(Vec<u8>, Option<String>), GltfError> {
    GltfFile::open(file)?.image(image)
}

/// A glTF file opened once (parsed, buffers loaded) for reading many primitives and images, as
/// a renderer's loader does; [`load_mesh_primitive`] and [`load_image`] open the file per call.
pub struct GltfFile {
    loaded: Loaded,
}

impl GltfFile {
    /// Reads, parses and validates a .gltf or .glb file and loads its buffers.
    pub fn open(file: &Path) -> Result<GltfFile, GltfError> {
        Ok(GltfFile {
            loaded: Loaded::open(file)?,
        })
    }

    /// See [`load_mesh_primitive`].
    pub fn mesh_primitive(&self, mesh: u32, primitive: u32) -> Result<MeshData, GltfError> {
        read_primitive(&self.loaded, mesh as usize, primitive as usize)
    }

    /// Every file read to open this one: the glTF file, then its external buffer files.
    pub fn files(&self) -> Vec<std::path::PathBuf> {
        let mut files = vec![self.loaded.file.clone()];
        files.extend(self.loaded.buffer_files.iter().cloned());
        files
    }

    /// The external file image `image` is read from, if it is one (not a data URI or a
    /// buffer view).
    pub fn image_file(&self, image: u32) -> Option<std::path::PathBuf> {
        let img = self.loaded.doc.images().nth(image as usize)?;
        self.loaded.image_file(&img)
    }

    /// See [`load_image`].
    pub fn image(&self, image: u32) -> Result<(Vec<u8>, Option<String>), GltfError> {
        let Some(img) = self.loaded.doc.images().nth(image as usize) else {
            return Err(GltfError::NotFound {
                file: self.loaded.file.clone(),
                element: format!("images[{image}]"),
                message: format!("the file has {} images", self.loaded.doc.images().len()),
            });
        };
        self.loaded.image_bytes(&img)
    }
}

/// The TEXCOORD set a primitive's material samples (see [`MeshData::uvs`]).
pub fn texcoord_set(material: &gltf::Material) -> u32 {
    let pbr = material.pbr_metallic_roughness();
    let set = |info: Option<gltf::texture::Info>| {
        info.map(|i| {
            i.texture_transform()
                .and_then(|t| t.tex_coord())
                .unwrap_or(i.tex_coord())
        })
    };
    set(pbr.base_color_texture())
        .or_else(|| set(material.emissive_texture()))
        .or_else(|| set(pbr.metallic_roughness_texture()))
        .unwrap_or(0)
}

/// Reads a primitive of a loaded document.
pub fn read_primitive(
    loaded: &Loaded,
    mesh: usize,
    primitive: usize,
) -> Result<MeshData, GltfError> {
    let file = &loaded.file;
    let Some(m) = loaded.doc.meshes().nth(mesh) else {
        return Err(GltfError::NotFound {
            file: file.clone(),
            element: format!("meshes[{mesh}]"),
            message: format!("the file has {} meshes", loaded.doc.meshes().len()),
        });
    };
    let Some(p) = m.primitives().nth(primitive) else {
        return Err(GltfError::NotFound {
            file: file.clone(),
            element: format!("meshes[{mesh}].primitives[{primitive}]"),
            message: format!("the mesh has {} primitives", m.primitives().len()),
        });
    };
    let el = format!("meshes[{mesh}].primitives[{primitive}]");
    if p.mode() != Mode::Triangles {
        return Err(GltfError::invalid(
            file,
            format!("{el}.mode"),
            format!(
                "mode {:?} is not supported; lumo renders TRIANGLES only",
                p.mode()
            ),
        ));
    }
    let Some(pos_acc) = p.get(&Semantic::Positions) else {
        return Err(GltfError::invalid(
            file,
            format!("{el}.attributes"),
            "has no POSITION attribute",
        ));
    };
    let pe = format!("{el}.attributes.POSITION");
    let positions = vec3s(loaded, &pos_acc, &pe)?;
    if let Some(i) = positions
        .iter()
        .position(|v| v.iter().any(|x| !x.is_finite()))
    {
        return Err(GltfError::invalid(
            file,
            pe,
            format!("vertex {i} is {:?}: positions must be finite", positions[i]),
        ));
    }
    let n = positions.len();
    let normals = match p.get(&Semantic::Normals) {
        Some(acc) => {
            let ne = format!("{el}.attributes.NORMAL");
            let mut v = vec3s(loaded, &acc, &ne)?;
            if v.len() != n {
                return Err(GltfError::invalid(
                    file,
                    ne,
                    format!("{} normals for {n} positions", v.len()),
                ));
            }
            for x in v.iter_mut() {
                let l = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
                if l.is_finite() && l > 0.0 {
                    *x = [x[0] / l, x[1] / l, x[2] / l];
                } else {
                    // A zero or broken normal: fall back to "up"; flat shading would be
                    // better, but one bad normal must not reject the whole model.
                    *x = [0.0, 0.0, 1.0];
                }
            }
            Some(v)
        }
        None => None,
    };
    let set = texcoord_set(&p.material());
    let uvs = match p.get(&Semantic::TexCoords(set)) {
        Some(acc) => {
            let te = format!("{el}.attributes.TEXCOORD_{set}");
            if acc.dimensions() != gltf::accessor::Dimensions::Vec2 {
                return Err(GltfError::invalid(
                    file,
                    te,
                    format!(
                        "has type {:?}, texture coordinates must be VEC2",
                        acc.dimensions()
                    ),
                ));
            }
            let raw = loaded.read_accessor(&acc, &te)?;
            if raw.len() / 2 != n {
                return Err(GltfError::invalid(
                    file,
                    te,
                    format!("{} texture coordinates for {n} positions", raw.len() / 2),
                ));
            }
            // glTF's (0, 0) is the image's top-left corner, lumo's the bottom-left: v' = 1 − v.
            Some(
                raw.chunks_exact(2)
                    .map(|c| [c[0] as f32, 1.0 - c[1] as f32])
                    .collect(),
            )
        }
        None => None,
    };
    let flat: Vec<u32> = match p.indices() {
        Some(acc) => {
            let ie = format!("{el}.indices");
            if acc.dimensions() != gltf::accessor::Dimensions::Scalar {
                return Err(GltfError::invalid(file, ie, "indices must be SCALAR"));
            }
            let raw = loaded.read_accessor(&acc, &ie)?;
            let mut out = Vec::with_capacity(raw.len());
            for (k, x) in raw.iter().enumerate() {
                let i = *x as u64;
                if i >= n as u64 {
                    return Err(GltfError::invalid(
                        file,
                        format!("{ie} (accessors[{}])", acc.index()),
                        format!("index {k} is {i}, out of range for {n} vertices"),
                    ));
                }
                out.push(i as u32);
            }
            out
        }
        None => (0..n as u32).collect(),
    };
    if flat.len() % 3 != 0 {
        return Err(GltfError::invalid(
            file,
            el,
            format!("{} indices is not a multiple of 3 (TRIANGLES)", flat.len()),
        ));
    }
    let indices = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Ok(MeshData {
        positions,
        normals,
        uvs,
        indices,
    })
}

fn vec3s(loaded: &Loaded, acc: &gltf::Accessor, element: &str) -> Result<Vec<[f32; 3]>, GltfError> {
    if acc.dimensions() != gltf::accessor::Dimensions::Vec3 {
        return Err(GltfError::invalid(
            &loaded.file,
            element,
            format!("has type {:?}, expected VEC3", acc.dimensions()),
        ));
    }
    let raw = loaded.read_accessor(acc, element)?;
    Ok(raw
        .chunks_exact(3)
        .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
        .collect())
}
