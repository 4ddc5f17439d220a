//! Tangents for normal maps (glTF 2.0 §3.7.2.1): the file's TANGENT when present, else
//! MikkTSpace tangents computed from the normals and the normal texture's texture coordinates.

mod common;

use std::path::{Path, PathBuf};

use lumo_converters::gltf::{load_mesh_primitive, GltfFile};

/// Largest angle (degrees) between a computed tangent and the file's for the vertex to agree.
/// Exporters write f32 tangents from the same reference algorithm; what differs is rounding
/// (the file's normals and uvs are themselves rounded copies of the tool's) and, at seams, which
/// of a welded vertex's tangents a tool kept.
const AGREE_DEGREES: f64 = 0.01;

/// Fraction of vertices that must agree (angle and w) per sample.
const AGREE_FRACTION: f64 = 0.99;

fn sample(shared: &Path, rel: &str) -> PathBuf {
    shared.join("gltf").join(rel)
}

fn norm3(t: &[f32]) -> f64 {
    t[..3]
        .iter()
        .map(|x| f64::from(*x).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn angle_degrees(a: &[f32; 4], b: &[f32; 4]) -> f64 {
    let dot: f64 = (0..3).map(|k| f64::from(a[k]) * f64::from(b[k])).sum();
    (dot / (norm3(a) * norm3(b)))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// Agreement of one primitive's computed tangents with the file's.
#[derive(Default, Debug)]
struct Agreement {
    vertices: usize,
    agreeing: usize,
    max_degrees: f64,
    sum_degrees: f64,
    w_mismatches: usize,
    /// Vertices by the file's w: (+1, −1), and how many of those agree.
    positive: (usize, usize),
    negative: (usize, usize),
}

fn compare(file: &Path, mesh: u32, primitive: u32, a: &mut Agreement) {
    let f = GltfFile::open(file).unwrap_or_else(|e| panic!("{e}"));
    let d = f.mesh_primitive(mesh, primitive).unwrap();
    let given = d.tangents.unwrap_or_else(|| {
        panic!(
            "{}: meshes[{mesh}].primitives[{primitive}] has TANGENT",
            file.display()
        )
    });
    let computed = f
        .computed_tangents(mesh, primitive)
        .unwrap()
        .expect("normals and TEXCOORD_0");
    assert_eq!(given.len(), computed.len());
    // Only vertices that triangles use: an exporter's leftovers carry whatever it wrote.
    let mut used = vec![false; given.len()];
    for k in d.indices.iter().flatten() {
        used[*k as usize] = true;
    }
    for ((g, c), _) in given.iter().zip(&computed).zip(&used).filter(|(_, u)| **u) {
        let deg = angle_degrees(g, c);
        let ok = deg <= AGREE_DEGREES && g[3] == c[3];
        a.vertices += 1;
        a.agreeing += usize::from(ok);
        a.max_degrees = a.max_degrees.max(deg);
        a.sum_degrees += deg;
        a.w_mismatches += usize::from(g[3] != c[3]);
        let side = if g[3] > 0.0 {
            &mut a.positive
        } else {
            &mut a.negative
        };
        side.0 += 1;
        side.1 += usize::from(ok);
    }
}

fn report(name: &str, a: &Agreement) {
    eprintln!(
        "{name}: {} vertices, {} agree within {AGREE_DEGREES}° and w ({:.3} %), angle max {:.4}° mean {:.5}°, w mismatches {}, w=+1: {}/{} agree, w=−1: {}/{} agree",
        a.vertices,
        a.agreeing,
        100.0 * a.agreeing as f64 / a.vertices.max(1) as f64,
        a.max_degrees,
        a.sum_degrees / a.vertices.max(1) as f64,
        a.w_mismatches,
        a.positive.1,
        a.positive.0,
        a.negative.1,
        a.negative.0,
    );
    assert!(a.vertices > 0, "{name}: nothing compared");
    assert!(
        a.agreeing as f64 >= AGREE_FRACTION * a.vertices as f64,
        "{name}: only {}/{} vertices agree: {a:?}",
        a.agreeing,
        a.vertices
    );
}

/// NormalTangentMirrorTest (Blender's exporter, MikkTSpace) mirrors its uvs: half the model has
/// w = −1. Computing its tangents must give the file's, both signs included: this pins the uv
/// convention (v up) and the handedness.
#[test]
fn computed_tangents_match_the_mirror_tests_both_handednesses() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let f = sample(
        &shared,
        "NormalTangentMirrorTest/glTF-Binary/NormalTangentMirrorTest.glb",
    );
    let mut a = Agreement::default();
    compare(&f, 0, 0, &mut a);
    report("NormalTangentMirrorTest", &a);
    for (sign, (n, ok)) in [("+1", a.positive), ("−1", a.negative)] {
        // The file has 80 vertices with w = −1 (the mirrored half's seam) out of 2770.
        assert!(n >= 50, "only {n} vertices with w = {sign}");
        assert!(
            ok as f64 >= AGREE_FRACTION * n as f64,
            "w = {sign}: only {ok}/{n} agree"
        );
    }
}

/// The other sample whose TANGENT Blender's exporter (MikkTSpace) wrote. Not VertexColorTest:
/// it has no normal texture and its TANGENT is a placeholder (1, 0, 0, 1) on every vertex,
/// parallel to the normal on two of its cube's faces. Cube and TwoSidedPlane (VKTS exporter)
/// use the other convention, checked as such: see `vkts_exports_have_the_flipped_handedness`.
#[test]
fn computed_tangents_match_other_exported_ones() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    for (rel, prims) in [(
        "AlphaBlendModeTest/glTF-Binary/AlphaBlendModeTest.glb",
        (0..9).map(|m| (m, 0)).collect::<Vec<_>>(),
    )] {
        let f = sample(&shared, rel);
        let mut a = Agreement::default();
        for (m, p) in prims {
            compare(&f, m, p, &mut a);
        }
        report(rel, &a);
    }
}

/// Cube's and TwoSidedPlane's exporter (VKTS) ran MikkTSpace on glTF's v, which points down
/// the image: their tangents' xyz are ours, but every w is negated, so B = cross(N, T) · w
/// points down the normal texture, against glTF's +Y up. (TwoSidedPlane by hand: T = dP/du =
/// −z, up the image is dP/d(−v) = +x, cross(N = +y, T) = −x, so glTF's w is −1; the file has
/// +1.) That is the mistake the v-up convention of `mikktspace_tangents` avoids, and the
/// comparison catches it: had we fed glTF's v, the Blender-made samples above would fail.
#[test]
fn vkts_exports_have_the_flipped_handedness() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    for (rel, count) in [
        ("Cube/glTF/Cube.gltf", 36),
        ("TwoSidedPlane/glTF/TwoSidedPlane.gltf", 6),
    ] {
        let f = GltfFile::open(&sample(&shared, rel)).unwrap();
        let given = f.mesh_primitive(0, 0).unwrap().tangents.unwrap();
        let computed = f.computed_tangents(0, 0).unwrap().unwrap();
        assert_eq!(given.len(), count, "{rel}");
        let mut max_degrees: f64 = 0.0;
        for (g, c) in given.iter().zip(&computed) {
            max_degrees = max_degrees.max(angle_degrees(g, c));
            assert_eq!(g[3], -c[3], "{rel}: {g:?} vs {c:?}");
        }
        eprintln!("{rel}: {count} vertices, xyz angle max {max_degrees:.5}°, every w negated");
        assert!(max_degrees <= AGREE_DEGREES, "{rel}");
    }
    // Cube has both signs: not one global flip of a single-signed mesh.
    let cube = load_mesh_primitive(&sample(&shared, "Cube/glTF/Cube.gltf"), 0, 0)
        .unwrap()
        .tangents
        .unwrap();
    assert!(cube.iter().any(|t| t[3] > 0.0) && cube.iter().any(|t| t[3] < 0.0));
}

/// Primitives whose material has a normal texture, by the file's JSON.
fn normal_mapped_primitives(file: &Path) -> Vec<(u32, u32)> {
    // Without validation: the gltf crate refuses required extensions it does not parse
    // (clearcoat), which lumo implements.
    let bytes = std::fs::read(file).unwrap();
    let g = gltf::Gltf::from_slice_without_validation(&bytes)
        .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let mut out = Vec::new();
    for m in g.meshes() {
        for p in m.primitives() {
            if p.material().normal_texture().is_some() {
                out.push((m.index() as u32, p.index() as u32));
            }
        }
    }
    out
}

/// Every shared sample with a normal texture gets tangents, given or computed: finite, unit
/// length, orthogonal to the normals, w = ±1.
#[test]
fn every_normal_mapped_sample_gets_unit_orthogonal_tangents() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let mut checked = Vec::new();
    for f in common::sample_files(&shared) {
        let prims = normal_mapped_primitives(&f);
        if prims.is_empty() {
            continue;
        }
        let file = GltfFile::open(&f).unwrap_or_else(|e| panic!("{e}"));
        for (m, p) in prims {
            let d = file.mesh_primitive(m, p).unwrap();
            let at = format!("{} meshes[{m}].primitives[{p}]", f.display());
            let (Some(t), Some(n)) = (&d.tangents, &d.normals) else {
                panic!("{at}: no tangents");
            };
            assert_eq!(t.len(), d.positions.len(), "{at}");
            let mut worst: (f64, f64) = (0.0, 0.0);
            for (t, n) in t.iter().zip(n) {
                assert!(t.iter().all(|x| x.is_finite()), "{at}: {t:?}");
                assert!(t[3] == 1.0 || t[3] == -1.0, "{at}: w of {t:?}");
                let len_err = (norm3(t) - 1.0).abs();
                let dot: f64 = (0..3).map(|k| f64::from(t[k]) * f64::from(n[k])).sum();
                worst = (worst.0.max(len_err), worst.1.max(dot.abs()));
            }
            assert!(worst.0 < 1e-5, "{at}: |‖T‖ − 1| up to {}", worst.0);
            // Computed tangents are orthogonal to lumo's (normalised) normals to rounding;
            // exporters' to their own unrounded normals, so a little more is allowed there.
            assert!(worst.1 < 2e-3, "{at}: |T·N| up to {}", worst.1);
            checked.push(format!(
                "{at}: max |‖T‖−1| {:.1e}, max |T·N| {:.1e}",
                worst.0, worst.1
            ));
        }
    }
    eprintln!("{}", checked.join("\n"));
    assert!(
        checked.len() >= 10,
        "only {} primitives checked",
        checked.len()
    );
}

/// No normal texture and no TANGENT: no tangents (nothing computed). A normal texture without
/// TANGENT: computed ones.
#[test]
fn tangents_only_where_a_normal_texture_needs_them() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    for rel in [
        "Box/glTF/Box.gltf",
        "BoxTextured/glTF/BoxTextured.gltf",
        "Duck/glTF-Binary/Duck.glb",
    ] {
        let d = load_mesh_primitive(&sample(&shared, rel), 0, 0).unwrap();
        assert!(d.normals.is_some() && d.tangents.is_none(), "{rel}");
    }
    let d = load_mesh_primitive(
        &sample(&shared, "NormalTangentTest/glTF/NormalTangentTest.gltf"),
        0,
        0,
    )
    .unwrap();
    assert_eq!(d.tangents.map(|t| t.len()), Some(d.positions.len()));
}

/// A copy of TwoSidedPlane (one primitive, TANGENT is accessors[3] in bufferViews[3] at byte
/// 156 of its .bin) in a temporary folder.
fn two_sided_plane(shared: &Path, dir: &Path) -> PathBuf {
    let src = sample(shared, "TwoSidedPlane/glTF");
    for e in std::fs::read_dir(&src).unwrap().flatten() {
        std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
    }
    dir.join("TwoSidedPlane.gltf")
}

fn tangent_error(file: &Path) -> String {
    match load_mesh_primitive(file, 0, 0) {
        Ok(d) => panic!("loaded with tangents {:?}", d.tangents),
        Err(e) => e.to_string(),
    }
}

fn assert_located(msg: &str, file: &Path, what: &str) {
    for part in [
        file.display().to_string().as_str(),
        "meshes[0].primitives[0].attributes.TANGENT (accessors[3])",
        what,
    ] {
        assert!(msg.contains(part), "`{part}` missing from: {msg}");
    }
}

#[test]
fn malformed_tangents_give_located_errors() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let f = two_sided_plane(&shared, dir.path());
    let good = load_mesh_primitive(&f, 0, 0).unwrap();
    assert_eq!(good.tangents, Some(vec![[0.0, 0.0, -1.0, 1.0]; 6]));
    let bin = dir.path().join("TwoSidedPlane.bin");
    let original = std::fs::read(&bin).unwrap();
    // Vertex 1's x (byte 156 + 16) and w (156 + 28).
    for (offset, value, what) in [
        (
            172,
            f32::NAN,
            "vertex 1 is [NaN, 0.0, -1.0, 1.0]: tangents must be finite",
        ),
        (
            172,
            0.5,
            "vertex 1 is [0.5, 0.0, -1.0, 1.0]: its xyz has length 1.118",
        ),
        (
            184,
            0.5,
            "vertex 1 is [0.0, 0.0, -1.0, 0.5]: w must be 1 or −1",
        ),
        (184, 0.0, "w must be 1 or −1"),
    ] {
        let mut b = original.clone();
        b[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
        std::fs::write(&bin, &b).unwrap();
        assert_located(&tangent_error(&f), &f, what);
    }
    std::fs::write(&bin, &original).unwrap();
    // A VEC3 TANGENT accessor.
    let mut json: serde_json::Value = serde_json::from_slice(&std::fs::read(&f).unwrap()).unwrap();
    json["accessors"][3]["type"] = "VEC3".into();
    std::fs::write(&f, serde_json::to_vec(&json).unwrap()).unwrap();
    assert_located(
        &tangent_error(&f),
        &f,
        "has type Vec3, tangents must be VEC4",
    );
    // Fewer tangents than positions.
    json["accessors"][3]["type"] = "VEC4".into();
    json["accessors"][3]["count"] = 5.into();
    std::fs::write(&f, serde_json::to_vec(&json).unwrap()).unwrap();
    assert_located(&tangent_error(&f), &f, "5 tangents for 6 positions");
}
