//! lumo scene → glTF (.gltf + .bin, or .glb).

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write as _;
use std::path::{Path, PathBuf};

use lumo_schema::{AlphaMode, GltfMeshRef, MeshSource, Object, Scene, Texture, Wrap};
use serde_json::{json, Value};

use super::document::{mime_of_bytes, percent_encode, read_file};
use super::error::GltfError;
use super::extras::{
    CameraExtras, LightExtras, LumoExtras, MaterialExtras, NodeExtras, PlaneShape, SceneExtras,
    SphereShape, Tessellation, TextureExtras,
};
use super::math::{self, Mat4};
use super::mesh::{load_image, load_mesh_primitive, MeshData};
use super::nodes::{camera_node_trs, camera_values, light_node_trs};
use super::pbr::{light_values, pbr_of_material, Pbr, TexInfo, EXPORTED_THICKNESS};
use super::tessellate;
use lumo_schema::geometry::glam::DVec3;
use lumo_schema::geometry::normals;
use lumo_schema::geometry::paths::relative;

/// Exports a scene as glTF 2.0: `.glb` (one binary file) or `.gltf` (JSON plus a `.bin` file
/// with the same stem beside it), chosen by `out`'s extension. `scene_dir` is the folder the
/// scene's relative paths resolve against. Returns warnings (e.g. textures in formats glTF
/// cannot hold). Files are written atomically (temporary file, then rename).
pub fn export(scene: &Scene, scene_dir: &Path, out: &Path) -> Result<Vec<String>, GltfError> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let glb = match ext.as_deref() {
        Some("glb") => true,
        Some("gltf") => false,
        _ => {
            return Err(GltfError::Export {
                file: out.to_path_buf(),
                element: "output".into(),
                message: "the output must end in .gltf or .glb".into(),
            })
        }
    };
    let out_dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut b = Builder {
        scene_dir: scene_dir.to_path_buf(),
        out_dir,
        ..Builder::default()
    };
    b.build(scene)?;
    let bin_name = format!(
        "{}.bin",
        out.file_stem().and_then(|s| s.to_str()).unwrap_or("scene")
    );
    let root = b.root(scene, if glb { None } else { Some(&bin_name) });
    let mut text = serde_json::to_string(&root).map_err(|e| GltfError::Export {
        file: out.to_path_buf(),
        element: "JSON".into(),
        message: e.to_string(),
    })?;
    if glb {
        while !text.len().is_multiple_of(4) {
            text.push(' ');
        }
        let mut bin = std::mem::take(&mut b.bin);
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + text.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
        let mut data = Vec::with_capacity(total);
        data.extend_from_slice(b"glTF");
        data.extend_from_slice(&2u32.to_le_bytes());
        data.extend_from_slice(&(total as u32).to_le_bytes());
        data.extend_from_slice(&(text.len() as u32).to_le_bytes());
        data.extend_from_slice(b"JSON");
        data.extend_from_slice(text.as_bytes());
        if !bin.is_empty() {
            data.extend_from_slice(&(bin.len() as u32).to_le_bytes());
            data.extend_from_slice(b"BIN\0");
            data.extend_from_slice(&bin);
        }
        write_atomic(out, &data)?;
    } else {
        if !b.bin.is_empty() {
            write_atomic(&b.out_dir.join(&bin_name), &b.bin)?;
        }
        write_atomic(out, text.as_bytes())?;
    }
    Ok(b.warnings)
}

/// Writes via a temporary file in the same folder and a rename, so readers never see a
/// half-written file.
fn write_atomic(path: &Path, data: &[u8]) -> Result<(), GltfError> {
    let io = |source| GltfError::Io {
        file: path.to_path_buf(),
        action: "cannot write",
        source,
    };
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        path.file_name().and_then(|n| n.to_str()).unwrap_or("out"),
        std::process::id()
    ));
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(data).and_then(|_| f.sync_all()).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

#[derive(Default)]
struct Builder {
    scene_dir: PathBuf,
    out_dir: PathBuf,
    warnings: Vec<String>,
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
    materials: Vec<Value>,
    material_index: BTreeMap<String, usize>,
    textures: Vec<Value>,
    texture_index: BTreeMap<String, usize>,
    images: Vec<Value>,
    samplers: Vec<Value>,
    sampler_index: BTreeMap<(u32, u32), usize>,
    cameras: Vec<Value>,
    lights: Vec<Value>,
    used: BTreeSet<&'static str>,
}

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

fn extras<T: serde::Serialize>(t: T) -> Value {
    serde_json::to_value(LumoExtras { lumo: t }).unwrap_or(Value::Null)
}

impl Builder {
    fn err(&self, element: impl Into<String>, message: impl Into<String>) -> GltfError {
        GltfError::Export {
            file: self.scene_dir.clone(),
            element: element.into(),
            message: message.into(),
        }
    }

    /// A path relative to the scene folder, re-based onto the output folder.
    fn rebase(&self, file: &str) -> String {
        relative(&self.scene_dir.join(file), &self.out_dir)
    }

    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor_f32(&mut self, data: &[f32], n: usize, kind: &str, min_max: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        let mut a = json!({"bufferView": view, "componentType": 5126, "count": data.len() / n, "type": kind});
        if min_max {
            let mut lo = vec![f32::INFINITY; n];
            let mut hi = vec![f32::NEG_INFINITY; n];
            for c in data.chunks_exact(n) {
                for k in 0..n {
                    lo[k] = lo[k].min(c[k]);
                    hi[k] = hi[k].max(c[k]);
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn accessor_indices(&mut self, idx: &[[u32; 3]]) -> usize {
        let bytes: Vec<u8> = idx.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({"bufferView": view, "componentType": 5125, "count": idx.len() * 3, "type": "SCALAR"}));
        self.accessors.len() - 1
    }

    fn build(&mut self, scene: &Scene) -> Result<(), GltfError> {
        for (name, tex) in &scene.textures {
            self.texture(name, tex)?;
        }
        let tex_index = self.texture_index.clone();
        let index_of = |n: &str| tex_index.get(n).copied();
        for (name, m) in &scene.materials {
            let pbr = pbr_of_material(m, &index_of);
            let mut v = material_json(&pbr, &mut self.used);
            v["name"] = json!(name);
            v["extras"] = extras(MaterialExtras {
                material: m.clone(),
            });
            self.material_index
                .insert(name.clone(), self.materials.len());
            self.materials.push(v);
        }
        // Tessellate everything but planes first: planes are squares sized from the rest.
        let mut bounds = Bounds::default();
        bounds.add(math::f64x3(scene.camera.position));
        let mut geoms: Vec<Option<(MeshData, NodeExtras, Mat4)>> = Vec::new();
        for (i, obj) in scene.objects.iter().enumerate() {
            let w = math::ops_matrix(obj.transform());
            if matches!(obj, Object::Plane(_)) {
                geoms.push(None);
                continue;
            }
            let (data, ex) = self.geometry(i, obj, 0.0)?;
            for p in &data.positions {
                bounds.add(math::point(&w, math::f64x3(*p)));
            }
            geoms.push(Some((data, ex, w)));
        }
        let half = (20.0 * bounds.radius()).max(100.0) as f32;
        for (i, obj) in scene.objects.iter().enumerate() {
            let (data, ex, w) = match geoms[i].take() {
                Some(g) => g,
                None => {
                    let (d, e) = self.geometry(i, obj, half)?;
                    (d, e, math::ops_matrix(obj.transform()))
                }
            };
            self.object(i, obj, data, ex, &w)?;
        }
        // The camera.
        let (yfov, aspect) = camera_values(&scene.camera, &scene.image);
        let znear = (1e-3 * bounds.radius()).max(1e-4) as f32;
        self.cameras.push(json!({
            "type": "perspective",
            "perspective": {"yfov": yfov, "aspectRatio": aspect, "znear": znear},
            "extras": extras(CameraExtras { camera: scene.camera }),
        }));
        let (t, r) = camera_node_trs(&scene.camera);
        self.nodes
            .push(json!({"name": "camera", "camera": 0, "translation": t, "rotation": r}));
        // Lights.
        for (i, l) in scene.lights.iter().enumerate() {
            let v = light_values(l);
            let mut j = json!({"type": v.kind, "color": v.color, "intensity": v.intensity, "extras": extras(LightExtras { light: l.clone() })});
            if let Some((inner, outer)) = v.cone {
                j["spot"] = json!({"innerConeAngle": inner, "outerConeAngle": outer});
            }
            self.lights.push(j);
            let (t, r) = light_node_trs(l);
            let mut node = json!({"name": format!("light{i}"), "extensions": {"KHR_lights_punctual": {"light": i}}});
            if let Some(t) = t {
                node["translation"] = json!(t);
            }
            if let Some(r) = r {
                node["rotation"] = json!(r);
            }
            self.nodes.push(node);
            self.used.insert("KHR_lights_punctual");
        }
        Ok(())
    }

    fn texture(&mut self, name: &str, tex: &Texture) -> Result<(), GltfError> {
        let el = format!("textures.{name}");
        let path = self.scene_dir.join(&tex.file);
        let bytes = match tex.gltf_image {
            Some(i) => {
                load_image(&path, i)
                    .map_err(|e| self.err(&el, e.to_string()))?
                    .0
            }
            None => read_file(&path).map_err(|e| {
                self.err(
                    format!("{el}.file"),
                    format!("{e}; fix the path (relative to the scene file)"),
                )
            })?,
        };
        let Some(mime) = mime_of_bytes(&bytes) else {
            self.warnings.push(format!("{el}: `{}` is not PNG or JPEG, which glTF requires; the texture is left out of the glTF materials (lumo's extras keep it)", tex.file));
            return Ok(());
        };
        let view = self.view(&bytes, None);
        self.images
            .push(json!({"bufferView": view, "mimeType": mime, "name": name}));
        let mode = |w: Wrap| match w {
            Wrap::Repeat => 10497,
            Wrap::Mirror => 33648,
            Wrap::Clamp => 33071,
        };
        let key = (mode(tex.wrap_s), mode(tex.wrap_t));
        let sampler = match self.sampler_index.get(&key) {
            Some(s) => *s,
            None => {
                self.samplers.push(json!({"wrapS": key.0, "wrapT": key.1}));
                self.sampler_index.insert(key, self.samplers.len() - 1);
                self.samplers.len() - 1
            }
        };
        let exact = Texture {
            file: self.rebase(&tex.file),
            ..tex.clone()
        };
        self.texture_index
            .insert(name.to_string(), self.textures.len());
        self.textures.push(json!({"name": name, "source": self.images.len() - 1, "sampler": sampler, "extras": extras(TextureExtras { texture: exact })}));
        Ok(())
    }

    /// The object's triangles in object space and the exact description for its node.
    fn geometry(
        &mut self,
        i: usize,
        obj: &Object,
        half: f32,
    ) -> Result<(MeshData, NodeExtras), GltfError> {
        let el = format!("objects[{i}]");
        let mut ex = NodeExtras::default();
        let data = match obj {
            Object::Sphere(s) => {
                ex.sphere = Some(SphereShape {
                    center: s.center,
                    radius: s.radius,
                });
                ex.tessellation = Some(Tessellation {
                    segments: tessellate::SPHERE_SEGMENTS,
                    rings: tessellate::SPHERE_RINGS,
                    half_size: None,
                });
                tessellate::sphere(
                    s.center,
                    s.radius,
                    tessellate::SPHERE_SEGMENTS,
                    tessellate::SPHERE_RINGS,
                )
            }
            Object::Plane(p) => {
                ex.plane = Some(PlaneShape {
                    normal: p.normal,
                    offset: p.offset,
                });
                ex.tessellation = Some(Tessellation {
                    segments: 1,
                    rings: 1,
                    half_size: Some(half),
                });
                tessellate::plane(p.normal, p.offset, half)
            }
            Object::Lathe(l) => {
                ex.lathe = Some(l.profile.clone());
                ex.tessellation = Some(Tessellation {
                    segments: tessellate::LATHE_SEGMENTS,
                    rings: tessellate::LATHE_RINGS,
                    half_size: None,
                });
                tessellate::lathe(
                    &l.profile,
                    tessellate::LATHE_SEGMENTS,
                    tessellate::LATHE_RINGS,
                )
            }
            Object::Triangle(t) => {
                ex.triangle = Some(t.vertices);
                MeshData {
                    positions: t.vertices.to_vec(),
                    normals: None,
                    uvs: None,
                    tangents: None,
                    texcoords_1: None,
                    colors: None,
                    indices: vec![[0, 1, 2]],
                }
            }
            Object::Mesh(m) => {
                let mut data = match &m.source {
                    MeshSource::Obj(f) => {
                        ex.source = Some(MeshSource::Obj(self.rebase(f)));
                        load_obj(&self.scene_dir.join(f))
                            .map_err(|e| self.err(format!("{el}.mesh.source.obj"), e))?
                    }
                    MeshSource::Gltf(g) => {
                        ex.source = Some(MeshSource::Gltf(GltfMeshRef {
                            file: self.rebase(&g.file),
                            ..g.clone()
                        }));
                        load_mesh_primitive(&self.scene_dir.join(&g.file), g.mesh, g.primitive)
                            .map_err(|e| {
                                self.err(format!("{el}.mesh.source.gltf"), e.to_string())
                            })?
                    }
                    MeshSource::Inline(inl) => {
                        ex.source = Some(MeshSource::Inline(inl.clone()));
                        MeshData {
                            positions: inl.positions.clone(),
                            normals: inl.normals.clone(),
                            uvs: inl.uvs.clone(),
                            tangents: None,
                            texcoords_1: None,
                            colors: None,
                            indices: inl.indices.clone(),
                        }
                    }
                };
                let n = data.positions.len();
                if data.indices.is_empty()
                    || data.indices.iter().flatten().any(|k| *k as usize >= n)
                {
                    return Err(self.err(
                        format!("{el}.mesh"),
                        "the mesh has no triangles or an index out of range",
                    ));
                }
                if data.positions.iter().flatten().any(|x| !x.is_finite()) {
                    return Err(self.err(
                        format!("{el}.mesh"),
                        "the mesh has a NaN or infinite position",
                    ));
                }
                if data.normals.as_ref().is_some_and(|v| v.len() != n) {
                    data.normals = None;
                }
                if data.uvs.as_ref().is_some_and(|v| v.len() != n) {
                    data.uvs = None;
                }
                data.normals = if m.smooth {
                    Some(data.normals.take().unwrap_or_else(|| vertex_normals(&data)))
                } else {
                    None
                };
                data
            }
        };
        Ok((data, ex))
    }

    fn object(
        &mut self,
        i: usize,
        obj: &Object,
        mut data: MeshData,
        mut ex: NodeExtras,
        w: &Mat4,
    ) -> Result<(), GltfError> {
        let ops = obj.transform().clone();
        let wf = math::to_f32(w);
        let mut node = json!({});
        if let Some(n) = obj.name() {
            node["name"] = json!(n);
        }
        if math::decompose_trs(&math::from_f32(&wf)).is_some() {
            if math::from_f32(&wf) != math::IDENTITY {
                node["matrix"] = json!(math::to_column_major(&wf));
            }
            if math::ops_of_world(&wf) != ops {
                ex.transform = Some(ops);
            }
        } else {
            // A shearing transform: glTF nodes cannot hold it, so the vertices go to world space.
            for p in data.positions.iter_mut() {
                *p = math::point(w, math::f64x3(*p)).map(|x| x as f32);
            }
            if let Some(ns) = &mut data.normals {
                for nn in ns.iter_mut() {
                    *nn = math::normalize(math::normal(w, math::f64x3(*nn)))
                        .unwrap_or([0.0, 0.0, 1.0])
                        .map(|x| x as f32);
                }
            }
            // Tangents are directions on the surface; a mirroring transform flips handedness.
            let flip = math::determinant3(w) < 0.0;
            if let Some(ts) = &mut data.tangents {
                for t in ts.iter_mut() {
                    let v = math::normalize(math::vector(w, [t[0], t[1], t[2]].map(f64::from)))
                        .unwrap_or([1.0, 0.0, 0.0]);
                    *t = [
                        v[0] as f32,
                        v[1] as f32,
                        v[2] as f32,
                        if flip { -t[3] } else { t[3] },
                    ];
                }
            }
            ex.baked = true;
            ex.transform = Some(ops);
        }
        let Some(&material) = self.material_index.get(obj.material()) else {
            return Err(self.err(
                format!("objects[{i}].{}.material", obj.kind()),
                format!("unknown material `{}`", obj.material()),
            ));
        };
        let flat: Vec<f32> = data.positions.iter().flatten().copied().collect();
        let pos = self.accessor_f32(&flat, 3, "VEC3", true);
        let mut attributes = json!({"POSITION": pos});
        if let Some(ns) = &data.normals {
            // glTF requires unit normals.
            let flat: Vec<f32> = ns
                .iter()
                .flat_map(|n| {
                    math::normalize(math::f64x3(*n))
                        .unwrap_or([0.0, 0.0, 1.0])
                        .map(|x| x as f32)
                })
                .collect();
            attributes["NORMAL"] = json!(self.accessor_f32(&flat, 3, "VEC3", false));
        }
        if let Some(uvs) = &data.uvs {
            // lumo's (0, 0) is the image's bottom-left, glTF's the top-left: v_glTF = 1 − v.
            let flat: Vec<f32> = uvs.iter().flat_map(|t| [t[0], 1.0 - t[1]]).collect();
            attributes["TEXCOORD_0"] = json!(self.accessor_f32(&flat, 2, "VEC2", false));
        }
        if let (Some(ts), Some(_)) = (&data.tangents, &data.normals) {
            let flat: Vec<f32> = ts.iter().flatten().copied().collect();
            attributes["TANGENT"] = json!(self.accessor_f32(&flat, 4, "VEC4", false));
        }
        if let Some(uvs) = &data.texcoords_1 {
            let flat: Vec<f32> = uvs.iter().flat_map(|t| [t[0], 1.0 - t[1]]).collect();
            attributes["TEXCOORD_1"] = json!(self.accessor_f32(&flat, 2, "VEC2", false));
        }
        if let Some(cs) = &data.colors {
            let flat: Vec<f32> = cs.iter().flatten().copied().collect();
            attributes["COLOR_0"] = json!(self.accessor_f32(&flat, 4, "VEC4", false));
        }
        let indices = self.accessor_indices(&data.indices);
        let mut mesh = json!({"primitives": [{"attributes": attributes, "indices": indices, "material": material, "mode": 4}]});
        if let Some(n) = obj.name() {
            mesh["name"] = json!(n);
        }
        self.meshes.push(mesh);
        node["mesh"] = json!(self.meshes.len() - 1);
        if ex != NodeExtras::default() {
            node["extras"] = extras(ex);
        }
        self.nodes.push(node);
        Ok(())
    }

    fn root(&self, scene: &Scene, bin_uri: Option<&str>) -> Value {
        let sx = SceneExtras {
            schema: scene.schema.clone(),
            image: Some(scene.image),
            render: Some(scene.render.clone()),
            background: Some(lumo_schema::Background {
                image: scene.background.image.as_ref().map(|f| self.rebase(f)),
                ..scene.background.clone()
            }),
        };
        let mut root = json!({
            "asset": {"version": "2.0", "generator": concat!("lumo ", env!("CARGO_PKG_VERSION"))},
            "scene": 0,
            "scenes": [{"nodes": (0..self.nodes.len()).collect::<Vec<_>>(), "extras": extras(sx)}],
            "nodes": self.nodes,
        });
        for (key, arr) in [
            ("meshes", &self.meshes),
            ("materials", &self.materials),
            ("textures", &self.textures),
            ("images", &self.images),
            ("samplers", &self.samplers),
            ("cameras", &self.cameras),
            ("accessors", &self.accessors),
            ("bufferViews", &self.views),
        ] {
            if !arr.is_empty() {
                root[key] = json!(arr);
            }
        }
        if !self.bin.is_empty() {
            let mut buffer = json!({"byteLength": self.bin.len()});
            if let Some(uri) = bin_uri {
                buffer["uri"] = json!(percent_encode(uri));
            }
            root["buffers"] = json!([buffer]);
        }
        if !self.lights.is_empty() {
            root["extensions"] = json!({"KHR_lights_punctual": {"lights": self.lights}});
        }
        if !self.used.is_empty() {
            root["extensionsUsed"] = json!(self.used.iter().collect::<Vec<_>>());
        }
        root
    }
}

/// The JSON of a material's glTF values (extensions only where they differ from the default).
fn material_json(p: &Pbr, used: &mut BTreeSet<&'static str>) -> Value {
    // Collected separately so `tex` does not hold `used` while the extensions are written.
    let mut transformed = false;
    let mut tex = |t: &TexInfo| {
        let mut v = json!({"index": t.index});
        if t.tex_coord != 0 {
            v["texCoord"] = json!(t.tex_coord);
        }
        if let Some((o, r, s)) = t.transform {
            v["extensions"] =
                json!({"KHR_texture_transform": {"offset": o, "rotation": r, "scale": s}});
            transformed = true;
        }
        v
    };
    let mut pbr = json!({"baseColorFactor": p.base_color, "metallicFactor": p.metallic, "roughnessFactor": p.roughness});
    if let Some(t) = &p.base_color_texture {
        pbr["baseColorTexture"] = tex(t);
    }
    if let Some(t) = &p.metallic_roughness_texture {
        pbr["metallicRoughnessTexture"] = tex(t);
    }
    let mut m = json!({"pbrMetallicRoughness": pbr, "doubleSided": p.double_sided});
    match p.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask => {
            m["alphaMode"] = json!("MASK");
            m["alphaCutoff"] = json!(p.alpha_cutoff);
        }
        AlphaMode::Blend => m["alphaMode"] = json!("BLEND"),
    }
    if let Some((t, scale)) = &p.normal_texture {
        m["normalTexture"] = tex(t);
        if *scale != 1.0 {
            m["normalTexture"]["scale"] = json!(scale);
        }
    }
    if p.emissive != [0.0; 3] {
        m["emissiveFactor"] = json!(p.emissive);
    }
    if let Some(t) = &p.emissive_texture {
        m["emissiveTexture"] = tex(t);
    }
    let mut exts = serde_json::Map::new();
    if p.emissive_strength != 1.0 {
        exts.insert(
            "KHR_materials_emissive_strength".into(),
            json!({"emissiveStrength": p.emissive_strength}),
        );
        used.insert("KHR_materials_emissive_strength");
    }
    if p.transmission != 0.0 || p.transmission_texture.is_some() {
        let mut t = json!({"transmissionFactor": p.transmission});
        if let Some(x) = &p.transmission_texture {
            t["transmissionTexture"] = tex(x);
        }
        exts.insert("KHR_materials_transmission".into(), t);
        used.insert("KHR_materials_transmission");
    }
    if p.ior != 1.5 {
        exts.insert("KHR_materials_ior".into(), json!({"ior": p.ior}));
        used.insert("KHR_materials_ior");
    }
    if p.specular != 1.0
        || p.specular_color != [1.0; 3]
        || p.specular_texture.is_some()
        || p.specular_color_texture.is_some()
    {
        let mut sp = json!({"specularFactor": p.specular, "specularColorFactor": p.specular_color});
        if let Some(x) = &p.specular_texture {
            sp["specularTexture"] = tex(x);
        }
        if let Some(x) = &p.specular_color_texture {
            sp["specularColorTexture"] = tex(x);
        }
        exts.insert("KHR_materials_specular".into(), sp);
        used.insert("KHR_materials_specular");
    }
    if p.clearcoat != 0.0 || p.clearcoat_texture.is_some() || p.clearcoat_normal_texture.is_some() {
        let mut c = json!({"clearcoatFactor": p.clearcoat, "clearcoatRoughnessFactor": p.clearcoat_roughness});
        if let Some(x) = &p.clearcoat_texture {
            c["clearcoatTexture"] = tex(x);
        }
        if let Some(x) = &p.clearcoat_roughness_texture {
            c["clearcoatRoughnessTexture"] = tex(x);
        }
        if let Some((x, scale)) = &p.clearcoat_normal_texture {
            c["clearcoatNormalTexture"] = tex(x);
            if *scale != 1.0 {
                c["clearcoatNormalTexture"]["scale"] = json!(scale);
            }
        }
        exts.insert("KHR_materials_clearcoat".into(), c);
        used.insert("KHR_materials_clearcoat");
    }
    if p.sheen_color != [0.0; 3] || p.sheen_color_texture.is_some() {
        let mut sh =
            json!({"sheenColorFactor": p.sheen_color, "sheenRoughnessFactor": p.sheen_roughness});
        if let Some(x) = &p.sheen_color_texture {
            sh["sheenColorTexture"] = tex(x);
        }
        if let Some(x) = &p.sheen_roughness_texture {
            sh["sheenRoughnessTexture"] = tex(x);
        }
        exts.insert("KHR_materials_sheen".into(), sh);
        used.insert("KHR_materials_sheen");
    }
    if p.unlit {
        exts.insert("KHR_materials_unlit".into(), json!({}));
        used.insert("KHR_materials_unlit");
    }
    if let Some((color, distance)) = p.volume {
        let mut v = json!({"thicknessFactor": EXPORTED_THICKNESS, "attenuationColor": color});
        if let Some(d) = distance {
            v["attenuationDistance"] = json!(d);
        }
        exts.insert("KHR_materials_volume".into(), v);
        used.insert("KHR_materials_volume");
    }
    if transformed {
        used.insert("KHR_texture_transform");
    }
    if !exts.is_empty() {
        m["extensions"] = Value::Object(exts);
    }
    m
}

/// Loads an OBJ file's triangles through the one reader ([`crate::obj::load`]).
fn load_obj(path: &Path) -> Result<MeshData, String> {
    let m =
        crate::obj::load(path).map_err(|e| format!("cannot load OBJ `{}`: {e}", path.display()))?;
    Ok(MeshData {
        positions: m.positions,
        normals: m.normals,
        uvs: m.uvs,
        tangents: None,
        texcoords_1: None,
        colors: None,
        indices: m.triangles,
    })
}

/// Angle-weighted vertex normals ([`lumo_schema::geometry::normals`]), +z where a vertex has
/// no non-degenerate face.
pub fn vertex_normals(d: &MeshData) -> Vec<[f32; 3]> {
    let p: Vec<DVec3> = d
        .positions
        .iter()
        .map(|v| DVec3::from(math::f64x3(*v)))
        .collect();
    normals::angle_weighted_normals(&p, &d.indices)
        .into_iter()
        .map(|n| if n == DVec3::ZERO { DVec3::Z } else { n })
        .map(|n| n.to_array().map(|x| x as f32))
        .collect()
}

#[derive(Default)]
struct Bounds {
    lo: Option<[f64; 3]>,
    hi: [f64; 3],
}

impl Bounds {
    fn add(&mut self, p: [f64; 3]) {
        if p.iter().any(|x| !x.is_finite()) {
            return;
        }
        match &mut self.lo {
            None => {
                self.lo = Some(p);
                self.hi = p;
            }
            Some(lo) => {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    self.hi[k] = self.hi[k].max(p[k]);
                }
            }
        }
    }

    /// Distance from the origin to the farthest corner.
    fn radius(&self) -> f64 {
        let Some(lo) = self.lo else { return 1.0 };
        let m = [0, 1, 2].map(|k| lo[k].abs().max(self.hi[k].abs()));
        math::len(m)
    }
}
