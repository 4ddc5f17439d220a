//! glTF → lumo scene.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::str::FromStr;

use gltf::camera::Projection;
use gltf::khr_lights_punctual::Kind;
use gltf::mesh::Mode;
use gltf::Semantic;
use lumo_schema::{
    AlphaMode, Background, Camera, ColorSpace, DirectionalLight, GltfMeshRef, Image, Lathe, Light,
    Material, Mesh, MeshSource, Object, Plane, PointLight, Scene, Sphere, SpotLight, Texture,
    Transform, Triangle, Wrap, FORMAT_VERSION,
};
use serde::de::DeserializeOwned;

use super::document::{decode_data_uri, Loaded};
use super::document::{HANDLED_EXTENSIONS, INSTANCING};
use super::error::GltfError;
use super::extras::{
    CameraExtras, LightExtras, MaterialExtras, NodeExtras, SceneExtras, TextureExtras, EXTRAS_KEY,
};
use super::math::{self, Mat4};
use super::mesh::{read_primitive, MeshData};
use super::nodes::{camera_node_matrix, camera_values, light_node_matrix};
use super::pbr::{self, LightValues, Pbr, TexInfo};
use lumo_schema::geometry::paths::portable;

/// Which glTF camera to look through.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CameraChoice {
    /// The camera (or camera node) with this name.
    Name(String),
    /// Index into the file's `cameras` array.
    Index(u32),
}

impl FromStr for CameraChoice {
    type Err = std::convert::Infallible;
    /// A number is an index, anything else a name (as `--camera NAME|INDEX` takes it).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.parse::<u32>() {
            Ok(i) => CameraChoice::Index(i),
            Err(_) => CameraChoice::Name(s.to_string()),
        })
    }
}

/// Options of [`import`].
#[derive(Debug, Clone, Default)]
pub struct ImportOptions {
    /// The camera to use; default: the first camera node of the scene, or, when the file has
    /// none, a camera framing the scene's bounding box.
    pub camera: Option<CameraChoice>,
    /// The folder the scene JSON will live in: file paths in the scene (the glTF file itself,
    /// textures, meshes) are written relative to it. Default: the glTF file's folder.
    pub scene_dir: Option<PathBuf>,
}

/// The start of the warning given when a file without punctual lights gets lumo's default
/// environment (a caller that replaces the environment, like `lumo render --env`, drops it).
pub const DEFAULT_ENVIRONMENT_WARNING: &str =
    "no punctual lights: lit by a uniform white environment";

/// The result of [`import`].
#[derive(Debug, Clone)]
pub struct Imported {
    /// The scene, referencing the glTF file's meshes and images by index.
    pub scene: Scene,
    /// Things that were not imported or approximated, for the user.
    pub warnings: Vec<String>,
}

/// Imports a .gltf or .glb file as a lumo scene. See `docs/gltf.md` for the mapping.
pub fn import(path: &Path, options: &ImportOptions) -> Result<Imported, GltfError> {
    let loaded = Loaded::open(path)?;
    import_loaded(&loaded, options)
}

/// Imports an already loaded document (used by [`import`] and the fuzz target).
pub fn import_loaded(loaded: &Loaded, options: &ImportOptions) -> Result<Imported, GltfError> {
    import_keeping(loaded, options, None)
}

/// The triangle primitives an import read (to check them), by (mesh, primitive) index.
pub(super) type ReadPrimitives = std::sync::Mutex<HashMap<(usize, usize), MeshData>>;

/// [`import_loaded`], keeping in `keep` the primitives it reads to check them, for a caller
/// that reads them next (so they are not read twice).
pub(super) fn import_keeping(
    loaded: &Loaded,
    options: &ImportOptions,
    keep: Option<&ReadPrimitives>,
) -> Result<Imported, GltfError> {
    // The gltf crate parses some extensions lumo does not render (it would accept a file that
    // requires them); a required extension must be one the importer maps.
    for (index, ext) in loaded.doc.extensions_required().enumerate() {
        if !HANDLED_EXTENSIONS.contains(&ext) {
            return Err(GltfError::UnsupportedExtension {
                file: loaded.file.clone(),
                index,
                extension: ext.to_string(),
            });
        }
    }
    let scene_dir = options
        .scene_dir
        .clone()
        .unwrap_or_else(|| loaded.dir().to_path_buf());
    let scene_dir = if scene_dir.as_os_str().is_empty() {
        PathBuf::from(".")
    } else {
        scene_dir
    };
    let imp = Importer {
        l: loaded,
        file_ref: portable(&loaded.file, &scene_dir),
        scene_dir,
        warnings: Vec::new(),
        ignored: BTreeSet::new(),
        textures: BTreeMap::new(),
        tex_names: HashMap::new(),
        materials: BTreeMap::new(),
        mat_names: HashMap::new(),
        objects: Vec::new(),
        lights: Vec::new(),
        cameras: Vec::new(),
        bounds: None,
    };
    imp.run(options, keep)
}

struct Importer<'a> {
    l: &'a Loaded,
    scene_dir: PathBuf,
    /// The glTF file relative to the scene folder.
    file_ref: String,
    warnings: Vec<String>,
    ignored: BTreeSet<String>,
    textures: BTreeMap<String, Texture>,
    tex_names: HashMap<(usize, bool), String>,
    materials: BTreeMap<String, Material>,
    mat_names: HashMap<Option<usize>, String>,
    objects: Vec<Object>,
    lights: Vec<Light>,
    /// (camera index, node index, world matrix).
    cameras: Vec<(usize, usize, [[f32; 4]; 4])>,
    bounds: Option<([f64; 3], [f64; 3])>,
}

/// Parses `extras.lumo` of an element into `T`; `Err` carries a warning.
fn lumo_extras<T: DeserializeOwned>(
    extras: &gltf::json::Extras,
    element: &str,
) -> Result<Option<T>, String> {
    let Some(raw) = extras else { return Ok(None) };
    let value: serde_json::Value =
        serde_json::from_str(raw.get()).map_err(|e| format!("{element}.extras: {e}"))?;
    match value.get(EXTRAS_KEY) {
        None => Ok(None),
        Some(v) => serde_json::from_value(v.clone())
            .map(Some)
            .map_err(|e| format!("{element}.extras.{EXTRAS_KEY} ignored: {e}")),
    }
}

fn unique(name: &str, taken: &dyn Fn(&str) -> bool) -> String {
    if !taken(name) {
        return name.to_string();
    }
    (2..)
        .map(|k| format!("{name}_{k}"))
        .find(|n| !taken(n))
        .unwrap_or_default()
}

impl Importer<'_> {
    fn file(&self) -> &Path {
        &self.l.file
    }

    fn extras<T: DeserializeOwned>(
        &mut self,
        extras: &gltf::json::Extras,
        element: &str,
    ) -> Option<T> {
        match lumo_extras(extras, element) {
            Ok(v) => v,
            Err(w) => {
                self.warnings.push(w);
                None
            }
        }
    }

    fn run(
        mut self,
        options: &ImportOptions,
        keep: Option<&ReadPrimitives>,
    ) -> Result<Imported, GltfError> {
        let doc = &self.l.doc;
        if doc.animations().len() > 0 {
            self.ignored
                .insert(format!("animations ({})", doc.animations().len()));
        }
        if doc.skins().len() > 0 {
            self.ignored
                .insert(format!("skins ({})", doc.skins().len()));
        }
        for ext in doc.extensions_used() {
            if !HANDLED_EXTENSIONS.contains(&ext) {
                self.ignored.insert(format!("extension {ext}"));
            }
        }
        let n_scenes = doc.scenes().len();
        let scene = doc.default_scene().or_else(|| doc.scenes().next());
        let roots: Vec<gltf::Node> = match &scene {
            Some(s) => s.nodes().collect(),
            None => {
                let mut child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        child[c.index()] = true;
                    }
                }
                doc.nodes().filter(|n| !child[n.index()]).collect()
            }
        };
        if n_scenes > 1 {
            let k = scene.as_ref().map(|s| s.index()).unwrap_or(0);
            self.warnings.push(format!(
                "the file has {n_scenes} scenes; imported scenes[{k}] (the default)"
            ));
        }
        let scene_extras: SceneExtras = match &scene {
            Some(s) => self
                .extras(s.extras(), &format!("scenes[{}]", s.index()))
                .unwrap_or_default(),
            None => SceneExtras::default(),
        };

        // Depth-first traversal, in the order of the scene's node list, children in order.
        let mut stack: Vec<(gltf::Node, Mat4, usize)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, math::IDENTITY, 0))
            .collect();
        let limit = doc.nodes().len();
        while let Some((node, parent, depth)) = stack.pop() {
            if depth > limit {
                return Err(GltfError::invalid(
                    self.file(),
                    format!("nodes[{}].children", node.index()),
                    "the node hierarchy has a cycle",
                ));
            }
            let world = math::mul(&parent, &self.local_matrix(&node)?);
            self.node(&node, &world)?;
            let children: Vec<gltf::Node> = node.children().collect();
            for c in children.into_iter().rev() {
                stack.push((c, world, depth + 1));
            }
        }

        // Read every triangle primitive now, as the renderer will, so a broken buffer is
        // reported by the import rather than at render time.
        for m in doc.meshes() {
            for p in m.primitives() {
                if p.mode() == Mode::Triangles && p.get(&Semantic::Positions).is_some() {
                    let data = read_primitive(self.l, m.index(), p.index())?;
                    if let Some(keep) = keep {
                        if let Ok(mut kept) = keep.lock() {
                            kept.insert((m.index(), p.index()), data);
                        }
                    }
                }
            }
        }
        let (camera, image) = self.camera(options, &scene_extras)?;
        if !self.ignored.is_empty() {
            let list: Vec<String> = self.ignored.iter().cloned().collect();
            self.warnings
                .push(format!("not imported: {}", list.join(", ")));
        }
        // glTF viewers always light a model with an environment (emissive surfaces add to
        // it), so a file without punctual lights gets a uniform white environment of radiance
        // 1 (unless lumo's own extras give one): a white Lambertian surface facing it reads 1.
        let background = match scene_extras.background {
            // An image in lumo's extras is relative to the glTF file; the scene's paths are
            // relative to the scene folder.
            Some(b) => lumo_schema::Background {
                image: b
                    .image
                    .as_ref()
                    .map(|f| portable(&self.l.dir().join(f), &self.scene_dir)),
                ..b
            },
            None if self.lights.is_empty() => {
                self.warnings.push(format!(
                    "{DEFAULT_ENVIRONMENT_WARNING} (radiance 1; replace it with --env FILE.exr)"
                ));
                Background {
                    color: [1.0; 3],
                    ..Background::default()
                }
            }
            None => Background::default(),
        };
        let scene = Scene {
            // The scene file's own, carried through an export (`lumo convert` writes
            // `lumo_schema::SCENE_SCHEMA` into every JSON scene it writes).
            schema: scene_extras.schema.clone(),
            format_version: FORMAT_VERSION,
            image,
            render: scene_extras.render.unwrap_or_default(),
            camera,
            background,
            textures: self.textures,
            materials: self.materials,
            objects: self.objects,
            lights: self.lights,
        };
        Ok(Imported {
            scene,
            warnings: self.warnings,
        })
    }

    fn local_matrix(&self, node: &gltf::Node) -> Result<Mat4, GltfError> {
        let el = format!("nodes[{}]", node.index());
        match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                let flat: [f32; 16] = std::array::from_fn(|k| matrix[k / 4][k % 4]);
                if let Some(k) = flat.iter().position(|x| !x.is_finite()) {
                    return Err(GltfError::invalid(
                        self.file(),
                        format!("{el}.matrix[{k}]"),
                        format!("is {}: the matrix must be finite", flat[k]),
                    ));
                }
                Ok(math::from_f32(&math::from_column_major(&flat)))
            }
            gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                for (key, v) in [
                    ("translation", &translation[..]),
                    ("rotation", &rotation[..]),
                    ("scale", &scale[..]),
                ] {
                    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                        return Err(GltfError::invalid(
                            self.file(),
                            format!("{el}.{key}[{k}]"),
                            format!("is {}: must be finite", v[k]),
                        ));
                    }
                }
                Ok(math::trs(translation, rotation, scale))
            }
        }
    }

    fn node(&mut self, node: &gltf::Node, world: &Mat4) -> Result<(), GltfError> {
        let el = format!("nodes[{}]", node.index());
        let wf = math::to_f32(world);
        if wf.iter().flatten().any(|x| !x.is_finite()) {
            return Err(GltfError::invalid(
                self.file(),
                el,
                "the composed world transform overflows (NaN or infinity)",
            ));
        }
        if let Some(c) = node.camera() {
            self.cameras.push((c.index(), node.index(), wf));
        }
        if let Some(light) = node.light() {
            self.light(&light, world, &wf);
        }
        let Some(mesh) = node.mesh() else {
            return Ok(());
        };
        if node.skin().is_some() || node.weights().is_some() || mesh.weights().is_some() {
            self.ignored.insert("skinning and morph weights".into());
        }
        let Some(instances) = self.instances(node, &el)? else {
            return self.mesh_objects(node, &mesh, world, &wf, &el, None);
        };
        for (i, local) in instances.iter().enumerate() {
            let instance_world = math::mul(world, local);
            let iwf = math::to_f32(&instance_world);
            if iwf.iter().flatten().any(|x| !x.is_finite()) {
                return Err(GltfError::invalid(
                    self.file(),
                    format!("{el}.extensions.{INSTANCING}"),
                    format!("instance {i}'s world transform overflows (NaN or infinity)"),
                ));
            }
            self.mesh_objects(node, &mesh, &instance_world, &iwf, &el, Some(i))?;
        }
        Ok(())
    }

    /// The transforms, relative to the node, of the instances `EXT_mesh_gpu_instancing` gives
    /// a node's mesh (translation · rotation · scale per instance, each attribute defaulting to
    /// the identity's); `None` without the extension.
    fn instances(&self, node: &gltf::Node, el: &str) -> Result<Option<Vec<Mat4>>, GltfError> {
        let Some(ext) = node.extension_value(INSTANCING) else {
            return Ok(None);
        };
        let el = format!("{el}.extensions.{INSTANCING}.attributes");
        let Some(attributes) = ext.get("attributes").and_then(serde_json::Value::as_object) else {
            return Err(GltfError::invalid(
                self.file(),
                el,
                "must be an object mapping TRANSLATION, ROTATION or SCALE to accessor indices",
            ));
        };
        let mut columns: [Option<Vec<f64>>; 3] = [None, None, None];
        let mut count = None;
        for (k, (key, width)) in [("TRANSLATION", 3), ("ROTATION", 4), ("SCALE", 3)]
            .into_iter()
            .enumerate()
        {
            let Some(index) = attributes.get(key) else {
                continue;
            };
            let ael = format!("{el}.{key}");
            let acc = index
                .as_u64()
                .and_then(|i| self.l.doc.accessors().nth(usize::try_from(i).ok()?));
            let Some(acc) = acc else {
                return Err(GltfError::invalid(
                    self.file(),
                    ael,
                    format!(
                        "is {index}, which is not an index into the file's {} accessors",
                        self.l.doc.accessors().len()
                    ),
                ));
            };
            let values = self.l.read_accessor(&acc, &ael)?;
            if values.len() != acc.count() * width {
                return Err(GltfError::invalid(
                    self.file(),
                    format!("{ael} (accessors[{}])", acc.index()),
                    format!("must be a VEC{width} accessor"),
                ));
            }
            if let Some(j) = values.iter().position(|x| !x.is_finite()) {
                return Err(GltfError::invalid(
                    self.file(),
                    format!("{ael} (accessors[{}])", acc.index()),
                    format!("instance {}: the value is not finite", j / width),
                ));
            }
            match count {
                Some(n) if n != acc.count() => {
                    return Err(GltfError::invalid(
                        self.file(),
                        format!("{ael} (accessors[{}])", acc.index()),
                        format!(
                            "has {} instances where the other attributes have {n}; all must have the same count",
                            acc.count()
                        ),
                    ));
                }
                _ => count = Some(acc.count()),
            }
            columns[k] = Some(values);
        }
        let [translation, rotation, scale] = &columns;
        let n = count.unwrap_or(0);
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let t = translation
                .as_ref()
                .map_or([0.0; 3], |v| std::array::from_fn(|c| v[3 * i + c] as f32));
            let mut q = rotation.as_ref().map_or([0.0, 0.0, 0.0, 1.0], |v| {
                std::array::from_fn(|c| v[4 * i + c])
            });
            // Normalized integer quaternions are unit only to within their quantisation.
            let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm == 0.0 {
                return Err(GltfError::invalid(
                    self.file(),
                    format!("{el}.ROTATION"),
                    format!(
                        "instance {i}: the quaternion is zero; rotations must be unit quaternions"
                    ),
                ));
            }
            q = q.map(|x| x / norm);
            let s = scale
                .as_ref()
                .map_or([1.0; 3], |v| std::array::from_fn(|c| v[3 * i + c] as f32));
            out.push(math::trs(t, q.map(|x| x as f32), s));
        }
        Ok(Some(out))
    }

    /// The objects of a node's mesh with the given world transform: one per triangle
    /// primitive, or the node's exact shape from lumo's extras. `instance` numbers an
    /// `EXT_mesh_gpu_instancing` instance (named `NAME@i`; lumo's own node extras apply to
    /// a node without instances alone).
    fn mesh_objects(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: &Mat4,
        wf: &[[f32; 4]; 4],
        el: &str,
        instance: Option<usize>,
    ) -> Result<(), GltfError> {
        let singular = math::det3(&math::from_f32(wf)) == 0.0;
        if singular {
            self.warnings.push(format!(
                "{el}: skipped: its world transform is singular (scaled to zero)"
            ));
            return Ok(());
        }
        let ex: NodeExtras = match instance {
            None => self.extras(node.extras(), el).unwrap_or_default(),
            Some(_) => NodeExtras::default(),
        };
        let world_ops = math::ops_of_world(wf);
        let transform: Transform = match ex.transform.clone() {
            Some(ops) if !ex.baked && math::to_f32(&math::ops_matrix(&ops)) == *wf => ops,
            Some(ops) if ex.baked && math::from_f32(wf) == math::IDENTITY => ops,
            Some(mut ops) if ex.baked => {
                ops.extend(world_ops);
                ops
            }
            _ => world_ops,
        };
        let base_name = node.name().or(mesh.name()).map(|n| match instance {
            Some(i) => format!("{n}@{i}"),
            None => n.to_string(),
        });
        let prims: Vec<gltf::Primitive> = mesh.primitives().collect();
        let tri_count = prims.iter().filter(|p| p.mode() == Mode::Triangles).count();
        for p in &prims {
            self.extend_bounds(p, world);
        }
        let shape = self.shape_object(&ex, el, base_name.clone(), &transform, prims.first());
        if let Some(obj) = shape {
            self.objects.push(obj);
            return Ok(());
        }
        for (j, p) in prims.iter().enumerate() {
            let pel = format!("meshes[{}].primitives[{j}]", mesh.index());
            if p.mode() != Mode::Triangles {
                self.warnings.push(format!(
                    "{pel}: mode {:?} skipped (only TRIANGLES are rendered)",
                    p.mode()
                ));
                continue;
            }
            if p.get(&Semantic::Positions).is_none() {
                self.warnings
                    .push(format!("{pel}: skipped: no POSITION attribute"));
                continue;
            }
            if p.morph_targets().len() > 0 {
                self.ignored.insert("morph targets".into());
            }
            let material = self.material(p.material())?;
            let name = match (&base_name, tri_count) {
                (Some(n), 1) => Some(n.clone()),
                (Some(n), _) => Some(format!("{n}#{j}")),
                (None, _) => None,
            };
            let own = MeshSource::Gltf(GltfMeshRef {
                file: self.file_ref.clone(),
                mesh: mesh.index() as u32,
                primitive: j as u32,
            });
            let source = match (&ex.source, prims.len()) {
                (Some(src), 1) => self.extras_source(src, el).unwrap_or(own),
                _ => own,
            };
            let smooth = p.get(&Semantic::Normals).is_some();
            self.objects.push(Object::Mesh(Mesh {
                name,
                material,
                transform: transform.clone(),
                source,
                smooth,
            }));
        }
        Ok(())
    }

    /// The exact object of a node's `extras.lumo` shape, if any.
    fn shape_object(
        &mut self,
        ex: &NodeExtras,
        el: &str,
        name: Option<String>,
        transform: &Transform,
        prim: Option<&gltf::Primitive>,
    ) -> Option<Object> {
        let count = [
            ex.sphere.is_some(),
            ex.plane.is_some(),
            ex.lathe.is_some(),
            ex.triangle.is_some(),
        ]
        .iter()
        .filter(|x| **x)
        .count();
        if count == 0 {
            return None;
        }
        if count > 1 {
            self.warnings.push(format!(
                "{el}.extras.{EXTRAS_KEY}: more than one shape given; using the node's mesh"
            ));
            return None;
        }
        let material = self.material(prim?.material()).ok()?;
        let transform = transform.clone();
        Some(if let Some(s) = &ex.sphere {
            Object::Sphere(Sphere {
                name,
                material,
                transform,
                center: s.center,
                radius: s.radius,
            })
        } else if let Some(p) = &ex.plane {
            Object::Plane(Plane {
                name,
                material,
                transform,
                normal: p.normal,
                offset: p.offset,
            })
        } else if let Some(profile) = &ex.lathe {
            Object::Lathe(Lathe {
                name,
                material,
                transform,
                profile: profile.clone(),
            })
        } else {
            let vertices = ex.triangle?;
            Object::Triangle(Triangle {
                name,
                material,
                transform,
                vertices,
            })
        })
    }

    /// A mesh source from node extras, re-based from the glTF folder to the scene folder, when
    /// its file still exists.
    fn extras_source(&mut self, src: &MeshSource, el: &str) -> Option<MeshSource> {
        let rebase = |this: &mut Self, file: &str| -> Option<String> {
            let full = this.l.dir().join(file);
            if full.is_file() {
                Some(portable(&full, &this.scene_dir))
            } else {
                this.warnings.push(format!(
                    "{el}: the original mesh file `{file}` is gone; using the glTF file's copy"
                ));
                None
            }
        };
        match src {
            MeshSource::Obj(f) => rebase(self, f).map(MeshSource::Obj),
            MeshSource::Gltf(g) => rebase(self, &g.file)
                .map(|file| MeshSource::Gltf(GltfMeshRef { file, ..g.clone() })),
            MeshSource::Inline(m) => Some(MeshSource::Inline(m.clone())),
        }
    }

    fn extend_bounds(&mut self, p: &gltf::Primitive, world: &Mat4) {
        let Some(acc) = p.get(&Semantic::Positions) else {
            return;
        };
        let get = |v: Option<serde_json::Value>| -> Option<[f64; 3]> {
            let a = v?;
            let a = a.as_array()?;
            Some([
                a.first()?.as_f64()?,
                a.get(1)?.as_f64()?,
                a.get(2)?.as_f64()?,
            ])
        };
        let (Some(lo), Some(hi)) = (get(acc.min()), get(acc.max())) else {
            return;
        };
        for k in 0..8 {
            let c = [
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ];
            let w = math::point(world, c);
            if w.iter().any(|x| !x.is_finite()) {
                continue;
            }
            let b = self.bounds.get_or_insert((w, w));
            for (i, &x) in w.iter().enumerate() {
                b.0[i] = b.0[i].min(x);
                b.1[i] = b.1[i].max(x);
            }
        }
    }

    /// The lumo material name for a glTF material (`None`: glTF's default material).
    fn material(&mut self, m: gltf::Material) -> Result<String, GltfError> {
        let key = m.index();
        if let Some(n) = self.mat_names.get(&key) {
            return Ok(n.clone());
        }
        let el = match key {
            Some(i) => format!("materials[{i}]"),
            None => "default material".to_string(),
        };
        let base = m.name().map(str::to_string).unwrap_or_else(|| match key {
            Some(i) => format!("material{i}"),
            None => "default".into(),
        });
        let name = unique(&base, &|n| self.materials.contains_key(n));
        let pbr = self.read_pbr(&m, &el);
        let ex: Option<MaterialExtras> = self.extras(m.extras(), &el);
        let doc = &self.l.doc;
        let index_of = |tex: &str| {
            doc.textures()
                .find(|t| t.name() == Some(tex))
                .map(|t| t.index())
        };
        let material = match ex {
            Some(ex)
                if pbr::pbr_of_material(&ex.material, &index_of) == pbr
                    && self.textures_of_extras_ok(&ex.material, &index_of)? =>
            {
                ex.material
            }
            _ => {
                let normal = pbr.normal_texture.as_ref().map(|(t, _)| t.clone());
                let coat_normal = pbr
                    .clearcoat_normal_texture
                    .as_ref()
                    .map(|(t, _)| t.clone());
                let names: Vec<(usize, bool, String)> = {
                    let uses = [
                        (&pbr.base_color_texture, true),
                        (&pbr.emissive_texture, true),
                        (&pbr.specular_color_texture, true),
                        (&pbr.metallic_roughness_texture, false),
                        (&pbr.specular_texture, false),
                        (&pbr.transmission_texture, false),
                        (&normal, false),
                        (&pbr.clearcoat_texture, false),
                        (&pbr.clearcoat_roughness_texture, false),
                        (&coat_normal, false),
                        (&pbr.sheen_color_texture, true),
                        (&pbr.sheen_roughness_texture, false),
                    ]
                    .into_iter()
                    .filter_map(|(t, srgb)| t.as_ref().map(|t| (t.index, srgb)));
                    let mut out = Vec::new();
                    for (i, srgb) in uses {
                        let n = self.texture(i, srgb)?;
                        out.push((i, srgb, n));
                    }
                    out
                };
                pbr::material_from_pbr(&pbr, &mut |t: &TexInfo, srgb| {
                    names
                        .iter()
                        .find(|(i, s, _)| *i == t.index && *s == srgb)
                        .map(|x| x.2.clone())
                })
            }
        };
        self.mat_names.insert(key, name.clone());
        self.materials.insert(name.clone(), material);
        Ok(name)
    }

    /// Imports the textures an exact (extras) material names, by name; false when one is
    /// missing so the glTF values are used instead.
    fn textures_of_extras_ok(
        &mut self,
        m: &Material,
        index_of: &dyn Fn(&str) -> Option<usize>,
    ) -> Result<bool, GltfError> {
        for (key, r) in m.texture_refs() {
            let Some(r) = r else { continue };
            let srgb = matches!(
                key,
                "base_color_texture"
                    | "emission_texture"
                    | "specular_color_texture"
                    | "sheen_color_texture"
            );
            let Some(i) = index_of(&r.texture) else {
                return Ok(false);
            };
            let name = self.texture(i, srgb)?;
            if name != r.texture {
                return Ok(false);
            }
        }
        Ok(true)
    }

    fn read_pbr(&mut self, m: &gltf::Material, el: &str) -> Pbr {
        let info = |i: Option<gltf::texture::Info>| i.as_ref().map(TexInfo::of_info);
        let p = m.pbr_metallic_roughness();
        // KHR_materials_clearcoat and KHR_materials_sheen, which the gltf crate does not parse.
        let coat = m.extension_value("KHR_materials_clearcoat");
        let sheen = m.extension_value("KHR_materials_sheen");
        let number = |ext: Option<&serde_json::Value>, key: &str, default: f32| {
            ext.and_then(|e| e.get(key))
                .and_then(serde_json::Value::as_f64)
                .map_or(default, |x| x as f32)
        };
        let raw_info = |ext: Option<&serde_json::Value>, key: &str| {
            ext.and_then(|e| e.get(key)).and_then(TexInfo::from_json)
        };
        let specular = m.specular();
        let transmission = m.transmission();
        if m.occlusion_texture().is_some() {
            self.ignored.insert("occlusion textures".into());
        }
        let pbr = Pbr {
            base_color: p.base_color_factor(),
            base_color_texture: info(p.base_color_texture()),
            alpha_mode: match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask,
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            alpha_cutoff: m.alpha_cutoff().unwrap_or(0.5),
            normal_texture: m
                .normal_texture()
                .map(|n| (TexInfo::of_normal(&n), n.scale())),
            metallic: p.metallic_factor(),
            roughness: p.roughness_factor(),
            metallic_roughness_texture: info(p.metallic_roughness_texture()),
            emissive: m.emissive_factor(),
            emissive_texture: info(m.emissive_texture()),
            emissive_strength: m.emissive_strength().unwrap_or(1.0),
            ior: m.ior().unwrap_or(1.5),
            specular: specular.as_ref().map_or(1.0, |s| s.specular_factor()),
            specular_texture: info(specular.as_ref().and_then(|s| s.specular_texture())),
            specular_color: specular
                .as_ref()
                .map_or([1.0; 3], |s| s.specular_color_factor()),
            specular_color_texture: info(
                specular.as_ref().and_then(|s| s.specular_color_texture()),
            ),
            transmission: transmission
                .as_ref()
                .map_or(0.0, |t| t.transmission_factor()),
            transmission_texture: info(
                transmission.as_ref().and_then(|t| t.transmission_texture()),
            ),
            volume: m
                .volume()
                .filter(|v| v.thickness_factor() > 0.0 || v.thickness_texture().is_some())
                .map(|v| {
                    let d = v.attenuation_distance();
                    (v.attenuation_color(), d.is_finite().then_some(d))
                }),
            clearcoat: number(coat, "clearcoatFactor", 0.0),
            clearcoat_texture: raw_info(coat, "clearcoatTexture"),
            clearcoat_roughness: number(coat, "clearcoatRoughnessFactor", 0.0),
            clearcoat_roughness_texture: raw_info(coat, "clearcoatRoughnessTexture"),
            clearcoat_normal_texture: raw_info(coat, "clearcoatNormalTexture").map(|t| {
                let scale = coat
                    .and_then(|c| c.get("clearcoatNormalTexture"))
                    .and_then(|n| n.get("scale"))
                    .and_then(serde_json::Value::as_f64)
                    .unwrap_or(1.0) as f32;
                (t, scale)
            }),
            sheen_color: sheen
                .and_then(|s| s.get("sheenColorFactor"))
                .and_then(|c| serde_json::from_value::<[f32; 3]>(c.clone()).ok())
                .unwrap_or([0.0; 3]),
            sheen_color_texture: raw_info(sheen, "sheenColorTexture"),
            sheen_roughness: number(sheen, "sheenRoughnessFactor", 0.0),
            sheen_roughness_texture: raw_info(sheen, "sheenRoughnessTexture"),
            unlit: m.unlit(),
            double_sided: m.double_sided(),
        };
        for t in [
            &pbr.base_color_texture,
            &pbr.metallic_roughness_texture,
            &pbr.emissive_texture,
            &pbr.specular_texture,
            &pbr.specular_color_texture,
            &pbr.transmission_texture,
            &pbr.normal_texture.as_ref().map(|(t, _)| t.clone()),
            &pbr.clearcoat_texture,
            &pbr.clearcoat_roughness_texture,
            &pbr.clearcoat_normal_texture
                .as_ref()
                .map(|(t, _)| t.clone()),
            &pbr.sheen_color_texture,
            &pbr.sheen_roughness_texture,
        ]
        .into_iter()
        .flatten()
        {
            if t.tex_coord > 1 {
                self.ignored.insert(format!(
                    "TEXCOORD_{} on some textures ({el}; lumo reads sets 0 and 1, set 0 used)",
                    t.tex_coord
                ));
            }
        }
        pbr
    }

    /// The lumo texture name for glTF texture `i` used as colour (sRGB) or data (linear).
    fn texture(&mut self, i: usize, srgb: bool) -> Result<String, GltfError> {
        if let Some(n) = self.tex_names.get(&(i, srgb)) {
            return Ok(n.clone());
        }
        let doc = &self.l.doc;
        let Some(t) = doc.textures().nth(i) else {
            return Err(GltfError::invalid(
                self.file(),
                format!("textures[{i}]"),
                "does not exist",
            ));
        };
        let el = format!("textures[{i}]");
        let ex: Option<TextureExtras> = self.extras(t.extras(), &el);
        let img = t.source();
        let base = t
            .name()
            .or(img.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("texture{i}"));
        let color_space = if srgb {
            ColorSpace::Srgb
        } else {
            ColorSpace::Linear
        };
        let wrap = |m| match m {
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
            gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
        };
        let (wrap_s, wrap_t) = (wrap(t.sampler().wrap_s()), wrap(t.sampler().wrap_t()));
        let exact = ex.and_then(|ex| {
            let full = self.l.dir().join(&ex.texture.file);
            full.is_file().then(|| Texture {
                file: portable(&full, &self.scene_dir),
                ..ex.texture
            })
        });
        let tex = match exact {
            Some(t) => t,
            None => {
                let iel = format!("images[{}]", img.index());
                let file = match img.source() {
                    gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => {
                        let full = self.l.resolve_uri(uri);
                        if !full.is_file() {
                            return Err(GltfError::invalid(
                                self.file(),
                                format!("{iel}.uri"),
                                format!("texture image `{uri}` not found (looked for {}); copy it next to the glTF file", full.display()),
                            ));
                        }
                        Some(portable(&full, &self.scene_dir))
                    }
                    gltf::image::Source::Uri { uri, .. } => {
                        if let Some(r) = decode_data_uri(self.file(), &iel, uri) {
                            r?;
                        }
                        None
                    }
                    gltf::image::Source::View { view, .. } => {
                        self.l.view_bytes(&view, &iel)?;
                        None
                    }
                };
                match file {
                    Some(file) => Texture {
                        file,
                        gltf_image: None,
                        color_space,
                        wrap_s,
                        wrap_t,
                    },
                    None => Texture {
                        file: self.file_ref.clone(),
                        gltf_image: Some(img.index() as u32),
                        color_space,
                        wrap_s,
                        wrap_t,
                    },
                }
            }
        };
        // One lumo texture per (image, colour space): the same image used as colour and as
        // data needs two decodings.
        let existing = self
            .textures
            .iter()
            .find(|(_, v)| **v == tex)
            .map(|(k, _)| k.clone());
        let name = match existing {
            Some(n) => n,
            None => {
                let base = if self.textures.contains_key(&base) && !srgb {
                    format!("{base}_linear")
                } else {
                    base
                };
                let name = unique(&base, &|n| self.textures.contains_key(n));
                self.textures.insert(name.clone(), tex);
                name
            }
        };
        self.tex_names.insert((i, srgb), name.clone());
        Ok(name)
    }

    fn light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        world: &Mat4,
        wf: &[[f32; 4]; 4],
    ) {
        let el = format!("KHR_lights_punctual.lights[{}]", light.index());
        let values = LightValues {
            kind: match light.kind() {
                Kind::Point => "point",
                Kind::Directional => "directional",
                Kind::Spot { .. } => "spot",
            },
            color: light.color(),
            intensity: light.intensity(),
            cone: match light.kind() {
                Kind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => Some((inner_cone_angle, outer_cone_angle)),
                _ => None,
            },
        };
        if light.range().is_some() {
            self.ignored
                .insert("light range (lumo lights fall off with the squared distance)".into());
        }
        let ex: Option<LightExtras> = self.extras(light.extras(), &el);
        if let Some(ex) = ex {
            if pbr::light_values(&ex.light) == values && light_node_matrix(&ex.light) == *wf {
                self.lights.push(ex.light);
                return;
            }
        }
        let pos = math::point(world, [0.0; 3]).map(|x| x as f32);
        let dir = math::normalize(math::vector(world, [0.0, 0.0, -1.0]))
            .unwrap_or([0.0, 0.0, -1.0])
            .map(|x| x as f32);
        let rgb = pbr::radiometric(&values);
        self.lights.push(match values.cone {
            None if values.kind == "point" => Light::Point(PointLight {
                position: pos,
                intensity: rgb,
            }),
            None => Light::Directional(DirectionalLight {
                direction: dir,
                irradiance: rgb,
            }),
            Some((inner, outer)) => {
                let outer_deg = (f64::from(outer).to_degrees() as f32).clamp(1e-3, 90.0);
                let inner_deg = (f64::from(inner).to_degrees() as f32).clamp(0.0, outer_deg);
                Light::Spot(SpotLight {
                    position: pos,
                    direction: dir,
                    intensity: rgb,
                    inner_angle_deg: inner_deg,
                    outer_angle_deg: outer_deg,
                })
            }
        });
    }

    fn camera(
        &mut self,
        options: &ImportOptions,
        sx: &SceneExtras,
    ) -> Result<(Camera, Image), GltfError> {
        let doc = &self.l.doc;
        let chosen = match &options.camera {
            Some(CameraChoice::Index(k)) => {
                let k = *k as usize;
                if k >= doc.cameras().len() {
                    return Err(GltfError::NotFound {
                        file: self.file().to_path_buf(),
                        element: format!("cameras[{k}]"),
                        message: format!(
                            "the file has {} cameras (indices start at 0)",
                            doc.cameras().len()
                        ),
                    });
                }
                match self.cameras.iter().find(|c| c.0 == k) {
                    Some(c) => Some(*c),
                    None => {
                        return Err(GltfError::NotFound {
                            file: self.file().to_path_buf(),
                            element: format!("cameras[{k}]"),
                            message: "no node of the imported scene uses this camera".into(),
                        })
                    }
                }
            }
            Some(CameraChoice::Name(name)) => {
                let found = self.cameras.iter().find(|(c, n, _)| {
                    doc.cameras().nth(*c).and_then(|c| c.name()) == Some(name.as_str())
                        || doc.nodes().nth(*n).and_then(|n| n.name()) == Some(name.as_str())
                });
                match found {
                    Some(c) => Some(*c),
                    None => {
                        let names: Vec<String> = self
                            .cameras
                            .iter()
                            .map(|(c, n, _)| {
                                doc.cameras()
                                    .nth(*c)
                                    .and_then(|c| c.name())
                                    .or(doc.nodes().nth(*n).and_then(|n| n.name()))
                                    .unwrap_or("(unnamed)")
                                    .to_string()
                            })
                            .collect();
                        return Err(GltfError::NotFound {
                            file: self.file().to_path_buf(),
                            element: format!("camera `{name}`"),
                            message: format!("no camera or camera node has that name; the scene's cameras are: {}", if names.is_empty() { "none".into() } else { names.join(", ") }),
                        });
                    }
                }
            }
            None => {
                let first = self
                    .cameras
                    .iter()
                    .find(|(c, _, _)| is_perspective(doc, *c) == Some(true));
                if self
                    .cameras
                    .iter()
                    .any(|(c, _, _)| is_perspective(doc, *c) == Some(false))
                {
                    self.ignored.insert("orthographic cameras".into());
                }
                first.copied()
            }
        };
        let Some((ci, _ni, wf)) = chosen else {
            return Ok((self.frame(), sx.image.unwrap_or_default()));
        };
        let Some(cam) = doc.cameras().nth(ci) else {
            return Err(GltfError::invalid(
                self.file(),
                format!("cameras[{ci}]"),
                "does not exist",
            ));
        };
        let Projection::Perspective(p) = cam.projection() else {
            return Err(GltfError::NotFound {
                file: self.file().to_path_buf(),
                element: format!("cameras[{ci}]"),
                message: "is orthographic; lumo has perspective cameras only — choose another with --camera".into(),
            });
        };
        let image = sx.image.unwrap_or_else(|| match p.aspect_ratio() {
            Some(a) if a.is_finite() && a > 0.0 => {
                let w = (512.0 * f64::from(a)).round().clamp(1.0, 16384.0) as u32;
                Image {
                    width: w,
                    height: 512,
                }
            }
            _ => Image::default(),
        });
        let ex: Option<CameraExtras> = self.extras(cam.extras(), &format!("cameras[{ci}]"));
        if let Some(ex) = ex {
            let (yfov, aspect) = camera_values(&ex.camera, &image);
            if yfov == p.yfov()
                && Some(aspect) == p.aspect_ratio()
                && camera_node_matrix(&ex.camera) == wf
            {
                return Ok((ex.camera, image));
            }
        }
        let w = math::from_f32(&wf);
        let pos = math::point(&w, [0.0; 3]);
        let fwd = math::normalize(math::vector(&w, [0.0, 0.0, -1.0])).unwrap_or([0.0, 0.0, -1.0]);
        let up = math::normalize(math::vector(&w, [0.0, 1.0, 0.0])).unwrap_or([0.0, 1.0, 0.0]);
        let fov = (f64::from(p.yfov()).to_degrees() as f32).clamp(1e-3, 179.0);
        let camera = Camera {
            position: pos.map(|x| x as f32),
            look_at: [0, 1, 2].map(|k| (pos[k] + fwd[k]) as f32),
            up: up.map(|x| x as f32),
            fov_y_deg: fov,
            aperture_radius: 0.0,
            focus_distance: None,
        };
        Ok((camera, image))
    }

    /// A camera on the +z side of the scene's bounding box looking at its centre, with a 45°
    /// vertical field of view and the bounding sphere just inside the view. A model that is
    /// flat in y or x (a ground plane, a wall) would be seen edge-on from +z, so the camera
    /// then moves up (or right) by atan(1/2) ≈ 26.6° to see its face.
    fn frame(&self) -> Camera {
        let (lo, hi) = self.bounds.unwrap_or(([-1.0; 3], [1.0; 3]));
        let c = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        let r = (0.5 * math::len(math::sub(hi, lo))).max(1e-3);
        let flat = |k: usize| hi[k] - lo[k] <= 1e-3 * r;
        let tilt = |k: usize| if flat(k) && !flat(2) { 0.5 } else { 0.0 };
        let dir = math::normalize([tilt(0), tilt(1), 1.0]).unwrap_or([0.0, 0.0, 1.0]);
        let fov: f64 = 45.0;
        let d = 1.1 * r / (fov.to_radians() / 2.0).sin();
        Camera {
            position: [0, 1, 2].map(|k| (c[k] + d * dir[k]) as f32),
            look_at: c.map(|x| x as f32),
            up: [0.0, 1.0, 0.0],
            fov_y_deg: fov as f32,
            aperture_radius: 0.0,
            focus_distance: None,
        }
    }
}

fn is_perspective(doc: &gltf::Document, camera: usize) -> Option<bool> {
    let c = doc.cameras().nth(camera)?;
    let p = matches!(c.projection(), Projection::Perspective(_));
    Some(p)
}
