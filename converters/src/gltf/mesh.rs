//! Reading one mesh primitive's triangles for the renderer.

use std::path::Path;

use gltf::mesh::Mode;
use gltf::Semantic;

use super::document::Loaded;
use super::error::GltfError;
use super::pbr::TexInfo;
use super::tangents;

/// The triangles of one glTF mesh primitive, in the primitive's own (object) space.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Vertex normals (unit length) when the primitive has a NORMAL attribute. When absent,
    /// glTF asks for flat shading: the importer sets the object's `smooth` to false.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Texture coordinates `TEXCOORD_0` in lumo's convention: (0, 0) is the bottom-left of the
    /// image, so v = 1 − v_glTF (a texture use picks set 0 or 1 by its `tex_coord`).
    pub uvs: Option<Vec<[f32; 2]>>,
    /// The second texture-coordinate set, `TEXCOORD_1`, whatever set [`MeshData::uvs`] holds,
    /// in the same convention (v = 1 − v_glTF), for textures whose `texCoord` (or
    /// `KHR_texture_transform`'s `texCoord` override) is 1. Checked as glTF 2.0 (§3.7.2.1)
    /// allows: VEC2 of FLOAT, or of normalized UNSIGNED_BYTE (c / 255) or UNSIGNED_SHORT
    /// (c / 65535); one per vertex. `None` when the primitive has no `TEXCOORD_1`.
    pub texcoords_1: Option<Vec<[f32; 2]>>,
    /// Per-vertex colours `[r, g, b, a]` from `COLOR_0`, linear, each in [0, 1]: glTF
    /// materials multiply their base colour (and alpha) by them. VEC3 (alpha 1) or VEC4, of
    /// FLOAT or of normalized UNSIGNED_BYTE (c / 255) or UNSIGNED_SHORT (c / 65535), as glTF
    /// 2.0 (§3.7.2.1) allows. FLOAT components outside [0, 1] are clamped, as glTF viewers
    /// and Blender's importer do (the Khronos glTF-Validator flags them, `ACCESSOR_NON_CLAMPED`,
    /// but refusing a whole model for a colour of 1.0000001 would help nobody); components
    /// that are not finite are an error. `None` when the primitive has no `COLOR_0`.
    pub colors: Option<Vec<[f32; 4]>>,
    /// Per-vertex tangents `[x, y, z, w]` for normal mapping: xyz unit length, w = ±1 the
    /// bitangent's handedness, B = cross(N, T.xyz) · w, in glTF's sense (B points up the
    /// normal texture). The file's TANGENT attribute when the primitive has one (checked:
    /// VEC4, finite, unit xyz, w = ±1); else, when its material has a `normalTexture` and the
    /// primitive has normals and that texture's TEXCOORD set, MikkTSpace tangents computed as
    /// glTF asks (see [`GltfFile::computed_tangents`]); else `None` (always `None` without
    /// normals, as glTF then ignores tangents).
    pub tangents: Option<Vec<[f32; 4]>>,
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
    /// Primitives [`GltfFile::import`] read to check them, until
    /// [`GltfFile::mesh_primitive`] takes them.
    read: super::import::ReadPrimitives,
}

impl GltfFile {
    /// Reads, parses and validates a .gltf or .glb file and loads its buffers.
    pub fn open(file: &Path) -> Result<GltfFile, GltfError> {
        Ok(GltfFile {
            loaded: Loaded::open(file)?,
            read: Default::default(),
        })
    }

    /// Imports this already opened file as a lumo scene (see [`super::import()`]), so a loader
    /// that also reads its meshes and images parses the file once. The primitives the import
    /// reads (every triangle primitive, to report a broken buffer at once) are kept for
    /// [`GltfFile::mesh_primitive`], so a loader does not read them twice.
    pub fn import(&self, options: &super::ImportOptions) -> Result<super::Imported, GltfError> {
        super::import::import_keeping(&self.loaded, options, Some(&self.read))
    }

    /// See [`load_mesh_primitive`]. A primitive kept by [`GltfFile::import`] is handed over
    /// (the first call takes it; later calls read it again).
    pub fn mesh_primitive(&self, mesh: u32, primitive: u32) -> Result<MeshData, GltfError> {
        let key = (mesh as usize, primitive as usize);
        if let Some(d) = self.read.lock().ok().and_then(|mut r| r.remove(&key)) {
            return Ok(d);
        }
        read_primitive(&self.loaded, mesh as usize, primitive as usize)
    }

    /// The MikkTSpace tangents of a primitive computed from its positions, normals and the
    /// TEXCOORD set of its material's normal texture (set 0 without one), whether or not the
    /// file carries TANGENT: the tangents [`MeshData::tangents`] holds for a file without them.
    /// `None` when the primitive has no normals or no such set. For checking a file's
    /// tangents against the computed ones.
    pub fn computed_tangents(
        &self,
        mesh: u32,
        primitive: u32,
    ) -> Result<Option<Vec<[f32; 4]>>, GltfError> {
        let d = self.mesh_primitive(mesh, primitive)?;
        let Some(normals) = &d.normals else {
            return Ok(None);
        };
        let (m, p) = (mesh as usize, primitive as usize);
        // mesh_primitive succeeded, so the primitive exists.
        let Some(prim) = self
            .loaded
            .doc
            .meshes()
            .nth(m)
            .and_then(|x| x.primitives().nth(p))
        else {
            return Ok(None);
        };
        let set = tangent_set(&prim.material()).unwrap_or(0);
        computed_tangents(
            &self.loaded,
            &prim,
            &format!("meshes[{m}].primitives[{p}]"),
            set,
            &d.positions,
            normals,
            &d.indices,
        )
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

/// The TEXCOORD set a material's tangent space follows: the set its normal texture samples
/// (with KHR_texture_transform's override, as the importer reads it), else its clear-coat
/// normal texture's (`KHR_materials_clearcoat`); `None` when it has neither, so needs no
/// tangents.
pub fn tangent_set(material: &gltf::Material) -> Option<u32> {
    if let Some(n) = material.normal_texture() {
        return Some(TexInfo::of_normal(&n).tex_coord);
    }
    let coat = material
        .extension_value("KHR_materials_clearcoat")?
        .get("clearcoatNormalTexture")?;
    TexInfo::from_json(coat).map(|t| t.tex_coord)
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
    // glTF's (0, 0) is the image's top-left corner, lumo's the bottom-left: v' = 1 − v.
    let uvs = texcoords(loaded, &p, &el, 0, n)?
        .map(|t| t.into_iter().map(|[u, v]| [u, 1.0 - v]).collect());
    let texcoords_1 = match p.get(&Semantic::TexCoords(1)) {
        Some(acc) => {
            check_normalized_type(
                loaded,
                &acc,
                &format!("{el}.attributes.TEXCOORD_1"),
                "texture coordinates",
            )?;
            texcoords(loaded, &p, &el, 1, n)?
                .map(|t| t.into_iter().map(|[u, v]| [u, 1.0 - v]).collect())
        }
        None => None,
    };
    let colors = match p.get(&Semantic::Colors(0)) {
        Some(acc) => Some(vertex_colors(loaded, &acc, &el, n)?),
        None => None,
    };
    let not_triangles = |count: usize| {
        GltfError::invalid(
            file,
            el.clone(),
            format!("{count} indices is not a multiple of 3 (TRIANGLES)"),
        )
    };
    let indices: Vec<[u32; 3]> = match p.indices() {
        Some(acc) => {
            let ie = format!("{el}.indices");
            if acc.dimensions() != gltf::accessor::Dimensions::Scalar {
                return Err(GltfError::invalid(file, ie, "indices must be SCALAR"));
            }
            let out_of_range = |flat: &[u32]| {
                let k = flat.iter().position(|&i| i as usize >= n)?;
                Some(GltfError::invalid(
                    file,
                    format!("{ie} (accessors[{}])", acc.index()),
                    format!("index {k} is {}, out of range for {n} vertices", flat[k]),
                ))
            };
            // Most index accessors are read straight into triangles; any other is read flat
            // and checked in the same order (range first, then count).
            match loaded.read_u32s::<3>(&acc, &ie)? {
                Some(indices) => match out_of_range(indices.as_flattened()) {
                    Some(e) => return Err(e),
                    None => indices,
                },
                None => {
                    let flat: Vec<u32> = loaded
                        .read_accessor(&acc, &ie)?
                        .iter()
                        .map(|&x| (x as u64).min(u64::from(u32::MAX)) as u32)
                        .collect();
                    if let Some(e) = out_of_range(&flat) {
                        return Err(e);
                    }
                    if !flat.len().is_multiple_of(3) {
                        return Err(not_triangles(flat.len()));
                    }
                    flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
                }
            }
        }
        None if n.is_multiple_of(3) => (0..n as u32 / 3)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect(),
        None => return Err(not_triangles(n)),
    };
    let tangents = match (&normals, p.get(&Semantic::Tangents)) {
        // glTF §3.7.2.1: without normals, given tangents are ignored (shading is flat).
        (None, _) => None,
        (Some(_), Some(acc)) => Some(file_tangents(loaded, &acc, &el, n)?),
        (Some(normals), None) => match tangent_set(&p.material()) {
            Some(set) => computed_tangents(loaded, &p, &el, set, &positions, normals, &indices)?,
            None => None,
        },
    };
    Ok(MeshData {
        positions,
        normals,
        uvs,
        texcoords_1,
        colors,
        tangents,
        indices,
    })
}

/// MikkTSpace tangents from the primitive's normals and TEXCOORD set `set`; `None` when the
/// primitive has no such set.
fn computed_tangents(
    loaded: &Loaded,
    p: &gltf::Primitive,
    el: &str,
    set: u32,
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    indices: &[[u32; 3]],
) -> Result<Option<Vec<[f32; 4]>>, GltfError> {
    let Some(uvs) = texcoords(loaded, p, el, set, positions.len())? else {
        return Ok(None);
    };
    // MikkTSpace wants v up the image (see `tangents::mikktspace`): (u, −v) is an exact flip of
    // glTF's v, so equal coordinates stay equal for its vertex welding.
    let up: Vec<[f32; 2]> = uvs.into_iter().map(|[u, v]| [u, -v]).collect();
    Ok(Some(tangents::mikktspace(positions, normals, &up, indices)))
}

/// Largest accepted |‖xyz‖ − 1| of a TANGENT: normalised byte tangents are off by up to about
/// 1.4 %; anything further is not a unit vector written with rounding but a broken one.
const TANGENT_LENGTH_TOLERANCE: f32 = 0.02;

/// The TANGENT attribute: VEC4, one per vertex, finite, xyz unit length (within
/// [`TANGENT_LENGTH_TOLERANCE`], then normalised), w = ±1.
fn file_tangents(
    loaded: &Loaded,
    acc: &gltf::Accessor,
    el: &str,
    n: usize,
) -> Result<Vec<[f32; 4]>, GltfError> {
    let te = format!("{el}.attributes.TANGENT");
    let file = &loaded.file;
    let located = |msg: String| {
        GltfError::invalid(
            file,
            format!("{te} (accessors[{}])", acc.index()),
            format!("{msg}; re-export the model with valid tangents, or without TANGENT so lumo computes them"),
        )
    };
    if acc.dimensions() != gltf::accessor::Dimensions::Vec4 {
        return Err(located(format!(
            "has type {:?}, tangents must be VEC4",
            acc.dimensions()
        )));
    }
    let raw = loaded.read_accessor(acc, &te)?;
    if raw.len() / 4 != n {
        return Err(located(format!(
            "{} tangents for {n} positions",
            raw.len() / 4
        )));
    }
    let mut out = Vec::with_capacity(n);
    for (i, c) in raw.chunks_exact(4).enumerate() {
        let t = [c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32];
        if t.iter().any(|x| !x.is_finite()) {
            return Err(located(format!(
                "vertex {i} is {t:?}: tangents must be finite"
            )));
        }
        let l = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
        if (l - 1.0).abs() > TANGENT_LENGTH_TOLERANCE {
            return Err(located(format!(
                "vertex {i} is {t:?}: its xyz has length {l}, tangents must be unit length"
            )));
        }
        if (t[3].abs() - 1.0).abs() > 1e-3 {
            return Err(located(format!(
                "vertex {i} is {t:?}: w must be 1 or −1 (the bitangent's handedness)"
            )));
        }
        out.push([t[0] / l, t[1] / l, t[2] / l, t[3].signum()]);
    }
    Ok(out)
}

/// Checks that an accessor holds FLOAT, normalized UNSIGNED_BYTE or normalized UNSIGNED_SHORT
/// components: the types glTF 2.0 (§3.7.2.1) allows for TEXCOORD_n and COLOR_n.
fn check_normalized_type(
    loaded: &Loaded,
    acc: &gltf::Accessor,
    element: &str,
    what: &str,
) -> Result<(), GltfError> {
    use gltf::accessor::DataType;
    let ok = match acc.data_type() {
        DataType::F32 => true,
        DataType::U8 | DataType::U16 => acc.normalized(),
        _ => false,
    };
    if ok {
        return Ok(());
    }
    let norm = if acc.normalized() { "normalized " } else { "" };
    Err(GltfError::invalid(
        &loaded.file,
        format!("{element} (accessors[{}])", acc.index()),
        format!(
            "has {norm}component type {:?}; {what} must be FLOAT, or UNSIGNED_BYTE or UNSIGNED_SHORT with `normalized: true`",
            acc.data_type()
        ),
    ))
}

/// The COLOR_0 attribute as linear RGBA (see [`MeshData::colors`]): VEC3 or VEC4, an allowed
/// component type, one per vertex, every component finite (clamped to [0, 1]).
fn vertex_colors(
    loaded: &Loaded,
    acc: &gltf::Accessor,
    el: &str,
    n: usize,
) -> Result<Vec<[f32; 4]>, GltfError> {
    let ce = format!("{el}.attributes.COLOR_0");
    let located = |msg: String| {
        GltfError::invalid(
            &loaded.file,
            format!("{ce} (accessors[{}])", acc.index()),
            msg,
        )
    };
    let k = match acc.dimensions() {
        gltf::accessor::Dimensions::Vec3 => 3,
        gltf::accessor::Dimensions::Vec4 => 4,
        other => {
            return Err(located(format!(
                "has type {other:?}, vertex colours must be VEC3 or VEC4"
            )))
        }
    };
    check_normalized_type(loaded, acc, &ce, "vertex colours")?;
    let raw = loaded.read_accessor(acc, &ce)?;
    if raw.len() / k != n {
        return Err(located(format!(
            "{} colours for {n} positions",
            raw.len() / k
        )));
    }
    let mut out = Vec::with_capacity(n);
    for (i, c) in raw.chunks_exact(k).enumerate() {
        // Normalized integers are in [0, 1] by construction; only FLOAT can fail here.
        if let Some(x) = c.iter().find(|x| !x.is_finite()) {
            return Err(located(format!(
                "vertex {i} is {c:?}: component {x} is not a finite number; re-export the model"
            )));
        }
        let unit = |x: f64| x.clamp(0.0, 1.0) as f32;
        let a = if k == 4 { unit(c[3]) } else { 1.0 };
        out.push([unit(c[0]), unit(c[1]), unit(c[2]), a]);
    }
    Ok(out)
}

/// TEXCOORD set `set` in glTF's convention ((0, 0) top-left), checked; `None` when the
/// primitive has no such set.
fn texcoords(
    loaded: &Loaded,
    p: &gltf::Primitive,
    el: &str,
    set: u32,
    n: usize,
) -> Result<Option<Vec<[f32; 2]>>, GltfError> {
    let file = &loaded.file;
    let Some(acc) = p.get(&Semantic::TexCoords(set)) else {
        return Ok(None);
    };
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
    Ok(Some(
        raw.chunks_exact(2)
            .map(|c| [c[0] as f32, c[1] as f32])
            .collect(),
    ))
}

fn vec3s(loaded: &Loaded, acc: &gltf::Accessor, element: &str) -> Result<Vec<[f32; 3]>, GltfError> {
    if acc.dimensions() != gltf::accessor::Dimensions::Vec3 {
        return Err(GltfError::invalid(
            &loaded.file,
            element,
            format!("has type {:?}, expected VEC3", acc.dimensions()),
        ));
    }
    if let Some(v) = loaded.read_f32x3(acc, element)? {
        return Ok(v);
    }
    let raw = loaded.read_accessor(acc, element)?;
    Ok(raw
        .chunks_exact(3)
        .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use base64::Engine as _;

    /// A one-primitive glTF: three vertices and an index accessor of `component_type` (5121
    /// bytes, 5123 shorts, 5125 ints) holding `indices`, in a data-URI buffer.
    fn triangles(component_type: u32, indices: &[u32]) -> Result<MeshData, GltfError> {
        let mut bin = Vec::new();
        for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
            p.iter()
                .for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
        }
        let at = bin.len();
        for &i in indices {
            match component_type {
                5121 => bin.push(i as u8),
                5123 => bin.extend_from_slice(&(i as u16).to_le_bytes()),
                _ => bin.extend_from_slice(&i.to_le_bytes()),
            }
        }
        let uri = base64::engine::general_purpose::STANDARD.encode(&bin);
        let json = serde_json::json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{uri}")}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": at},
                {"buffer": 0, "byteOffset": at, "byteLength": bin.len() - at}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": component_type, "count": indices.len(), "type": "SCALAR"}
            ],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}]
        });
        let text = serde_json::to_vec(&json).unwrap();
        let loaded = Loaded::from_bytes(Path::new("t.gltf"), &text, false)?;
        read_primitive(&loaded, 0, 0)
    }

    /// Indices of every integer type become the same triangles; a count that is not a multiple
    /// of three and an index past the last vertex are refused with the index named, the range
    /// checked first.
    #[test]
    fn index_accessors_become_triangles_or_located_errors() {
        for ty in [5121, 5123, 5125] {
            let mesh = triangles(ty, &[0, 1, 2, 2, 1, 0]).unwrap();
            assert_eq!(
                mesh.indices,
                vec![[0, 1, 2], [2, 1, 0]],
                "componentType {ty}"
            );
            let err = triangles(ty, &[0, 1, 2, 1]).unwrap_err().to_string();
            assert!(err.contains("4 indices is not a multiple of 3"), "{err}");
            let err = triangles(ty, &[0, 1, 2, 2, 3, 0]).unwrap_err().to_string();
            assert!(
                err.contains("index 4 is 3, out of range for 3 vertices"),
                "{err}"
            );
            let err = triangles(ty, &[0, 1, 2, 7]).unwrap_err().to_string();
            assert!(err.contains("index 3 is 7, out of range"), "{err}");
        }
    }
}
