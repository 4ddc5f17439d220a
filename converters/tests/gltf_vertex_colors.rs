//! Vertex colours (`COLOR_0`) and the second texture-coordinate set (`TEXCOORD_1`) of a glTF
//! primitive (issue 12): decoded values are compared with values read here from the raw accessor
//! bytes by plain byte arithmetic, and broken accessors give located errors.

mod common;

use std::path::{Path, PathBuf};

use lumo_converters::gltf::load_mesh_primitive;
use serde_json::{json, Value};

/// A GLB's JSON and binary chunk.
fn glb_chunks(file: &Path) -> (Value, Vec<u8>) {
    let b = std::fs::read(file).unwrap();
    let u32_at = |o: usize| u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]) as usize;
    assert_eq!(&b[..4], b"glTF");
    let json_len = u32_at(12);
    let json: Value = serde_json::from_slice(&b[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at);
    (json, b[bin_at + 8..bin_at + 8 + bin_len].to_vec())
}

/// The f32 components of accessor `acc` (no sparse, FLOAT) read straight from the bytes.
fn raw_f32s(json: &Value, bin: &[u8], acc: usize, k: usize) -> Vec<Vec<f32>> {
    let a = &json["accessors"][acc];
    assert_eq!(a["componentType"], 5126);
    assert!(a.get("sparse").is_none());
    let v = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let base = v["byteOffset"].as_u64().unwrap_or(0) + a["byteOffset"].as_u64().unwrap_or(0);
    let stride = v["byteStride"].as_u64().unwrap_or(4 * k as u64);
    (0..a["count"].as_u64().unwrap())
        .map(|i| {
            (0..k)
                .map(|c| {
                    let o = (base + i * stride) as usize + 4 * c;
                    f32::from_le_bytes([bin[o], bin[o + 1], bin[o + 2], bin[o + 3]])
                })
                .collect()
        })
        .collect()
}

fn color_accessor(json: &Value, mesh: usize, prim: usize) -> usize {
    json["meshes"][mesh]["primitives"][prim]["attributes"]["COLOR_0"]
        .as_u64()
        .unwrap() as usize
}

#[test]
fn float_vec4_colors_match_the_raw_bytes() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let file = shared.join("gltf/VertexColorTest/glTF-Binary/VertexColorTest.glb");
    let (json, bin) = glb_chunks(&file);
    let raw = raw_f32s(&json, &bin, color_accessor(&json, 1, 0), 4);
    let d = load_mesh_primitive(&file, 1, 0).unwrap();
    let colors = d.colors.expect("mesh 1 has COLOR_0");
    assert_eq!(colors.len(), d.positions.len());
    assert_eq!(colors.len(), raw.len());
    for (c, r) in colors.iter().zip(&raw) {
        assert_eq!(c.as_slice(), r.as_slice());
    }
    // Not a constant: the sample has several colours.
    assert!(colors.iter().any(|c| *c != colors[0]));
    // The first mesh (textured, no COLOR_0) has none, and no sample primitive has TEXCOORD_1.
    let plain = load_mesh_primitive(&file, 0, 0).unwrap();
    assert_eq!(plain.colors, None);
    assert_eq!(plain.texcoords_1, None);
    assert!(plain.uvs.is_some());
}

#[test]
fn float_vec3_colors_get_alpha_one() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    // Interleaved (byteStride 12) VEC3 colours at an accessor byteOffset.
    let file = shared.join("gltf/BoxVertexColors/glTF-Binary/BoxVertexColors.glb");
    let (json, bin) = glb_chunks(&file);
    let raw = raw_f32s(&json, &bin, color_accessor(&json, 0, 0), 3);
    let d = load_mesh_primitive(&file, 0, 0).unwrap();
    let colors = d.colors.expect("BoxVertexColors has COLOR_0");
    assert_eq!(colors.len(), raw.len());
    for (c, r) in colors.iter().zip(&raw) {
        assert_eq!(c, &[r[0], r[1], r[2], 1.0]);
    }
    assert!(colors.iter().any(|c| *c != colors[0]));
}

#[test]
fn primitives_without_colors_get_none() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    for (rel, mesh) in [
        ("Box/glTF-Binary/Box.glb", 0),
        ("TextureCoordinateTest/glTF/TextureCoordinateTest.gltf", 3),
        ("TextureCoordinateTest/glTF/TextureCoordinateTest.gltf", 0),
    ] {
        let d = load_mesh_primitive(&shared.join("gltf").join(rel), mesh, 0).unwrap();
        assert_eq!(d.colors, None, "{rel}");
        assert_eq!(d.texcoords_1, None, "{rel}");
    }
}

/// A triangle file with integer colours and two UV sets, written by hand: the JSON and its
/// buffer `two.bin`. Primitive 0: COLOR_0 normalized u8 VEC4, TEXCOORD_0 FLOAT, TEXCOORD_1
/// normalized u16 (stride 4). Primitive 1: COLOR_0 normalized u16 VEC3 (stride 8), TEXCOORD_1
/// normalized u8 (stride 4). Primitive 2: COLOR_0 FLOAT VEC4 with one sparse entry.
fn synthetic() -> (Value, Vec<u8>) {
    let mut b: Vec<u8> = Vec::new();
    // 0: positions, 36 bytes. Vertex 1's x = 2 lets a test point COLOR_0 at an out-of-range
    // FLOAT accessor.
    for p in [[0.0f32, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        p.iter().for_each(|x| b.extend(x.to_le_bytes()));
    }
    // 36: COLOR_0 u8 VEC4.
    b.extend([255u8, 0, 128, 255, 0, 255, 64, 17, 1, 2, 3, 0]);
    // 48: TEXCOORD_0 f32.
    for t in [[0.0f32, 0.0], [1.0, 0.0], [0.0, 1.0]] {
        t.iter().for_each(|x| b.extend(x.to_le_bytes()));
    }
    // 72: TEXCOORD_1 u16 VEC2.
    for x in [0u16, 65535, 32768, 1, 65535, 0] {
        b.extend(x.to_le_bytes());
    }
    // 84: COLOR_0 u16 VEC3, stride 8 (2 bytes of padding per element).
    for c in [[65535u16, 0, 1], [300, 40000, 65534], [7, 7, 7]] {
        c.iter().for_each(|x| b.extend(x.to_le_bytes()));
        b.extend([0xAB, 0xCD]);
    }
    // 108: TEXCOORD_1 u8 VEC2, stride 4.
    b.extend([
        0u8, 255, 0xEE, 0xEE, 51, 204, 0xEE, 0xEE, 255, 1, 0xEE, 0xEE,
    ]);
    // 120: COLOR_0 f32 VEC4, then its sparse index (u16 2, padded) and value.
    for c in [
        [0.25f32, 0.5, 0.75, 1.0],
        [1.0, 0.0, 0.0, 0.5],
        [0.0, 0.0, 0.0, 0.0],
    ] {
        c.iter().for_each(|x| b.extend(x.to_le_bytes()));
    }
    b.extend([2u8, 0, 0, 0]);
    for x in [0.1f32, 0.2, 0.3, 0.4] {
        b.extend(x.to_le_bytes());
    }
    assert_eq!(b.len(), 188);
    let view = |o: usize, l: usize, stride: Option<usize>| match stride {
        Some(s) => json!({"buffer": 0, "byteOffset": o, "byteLength": l, "byteStride": s}),
        None => json!({"buffer": 0, "byteOffset": o, "byteLength": l}),
    };
    let acc = |v: usize, ct: u32, ty: &str, norm: bool| json!({"bufferView": v, "componentType": ct, "count": 3, "type": ty, "normalized": norm});
    let mut sparse = acc(6, 5126, "VEC4", false);
    sparse["sparse"] = json!({
        "count": 1,
        "indices": {"bufferView": 7, "componentType": 5123},
        "values": {"bufferView": 8}
    });
    let mut pos = acc(0, 5126, "VEC3", false);
    pos["min"] = json!([0.0, 0.0, 0.0]);
    pos["max"] = json!([2.0, 1.0, 0.0]);
    let json = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "two.bin", "byteLength": b.len()}],
        "bufferViews": [
            view(0, 36, Some(12)),
            view(36, 12, Some(4)),
            view(48, 24, Some(8)),
            view(72, 12, Some(4)),
            view(84, 24, Some(8)),
            view(108, 12, Some(4)),
            view(120, 48, Some(16)),
            view(168, 2, None),
            view(172, 16, None),
        ],
        "accessors": [
            pos,
            acc(1, 5121, "VEC4", true),
            acc(2, 5126, "VEC2", false),
            acc(3, 5123, "VEC2", true),
            acc(4, 5123, "VEC3", true),
            acc(5, 5121, "VEC2", true),
            sparse,
        ],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0, "COLOR_0": 1, "TEXCOORD_0": 2, "TEXCOORD_1": 3}},
            {"attributes": {"POSITION": 0, "COLOR_0": 4, "TEXCOORD_1": 5}},
            {"attributes": {"POSITION": 0, "COLOR_0": 6}},
        ]}],
    });
    (json, b)
}

fn write(dir: &Path, json: &Value, bin: &[u8]) -> PathBuf {
    std::fs::write(dir.join("two.bin"), bin).unwrap();
    let f = dir.join("two.gltf");
    std::fs::write(&f, serde_json::to_vec(json).unwrap()).unwrap();
    f
}

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}

fn f32_at(b: &[u8], o: usize) -> f32 {
    f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

fn assert_close<const N: usize>(got: &[[f32; N]], want: &[[f32; N]]) {
    assert_eq!(got.len(), want.len());
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        for c in 0..N {
            assert!(
                (g[c] - w[c]).abs() <= 1e-6,
                "vertex {i} component {c}: got {g:?}, want {w:?}"
            );
        }
    }
}

#[test]
fn normalized_integer_colors_and_texcoord_1_match_the_raw_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let (json, b) = synthetic();
    let f = write(dir.path(), &json, &b);

    let d = load_mesh_primitive(&f, 0, 0).unwrap();
    let want: Vec<[f32; 4]> = (0..3)
        .map(|i| std::array::from_fn(|c| f32::from(b[36 + 4 * i + c]) / 255.0))
        .collect();
    assert_close(&d.colors.unwrap(), &want);
    // TEXCOORD_1 in lumo's convention: v = 1 − v_glTF; `uvs` stays set 0.
    let want: Vec<[f32; 2]> = (0..3)
        .map(|i| {
            let u = f32::from(u16_at(&b, 72 + 4 * i)) / 65535.0;
            let v = f32::from(u16_at(&b, 74 + 4 * i)) / 65535.0;
            [u, 1.0 - v]
        })
        .collect();
    assert_close(&d.texcoords_1.unwrap(), &want);
    let uvs0: Vec<[f32; 2]> = (0..3)
        .map(|i| [f32_at(&b, 48 + 8 * i), 1.0 - f32_at(&b, 52 + 8 * i)])
        .collect();
    assert_eq!(d.uvs.unwrap(), uvs0);

    let d = load_mesh_primitive(&f, 0, 1).unwrap();
    let want: Vec<[f32; 4]> = (0..3)
        .map(|i| {
            let c = |k: usize| f32::from(u16_at(&b, 84 + 8 * i + 2 * k)) / 65535.0;
            [c(0), c(1), c(2), 1.0]
        })
        .collect();
    assert_close(&d.colors.unwrap(), &want);
    let want: Vec<[f32; 2]> = (0..3)
        .map(|i| {
            let t = |k: usize| f32::from(b[108 + 4 * i + k]) / 255.0;
            [t(0), 1.0 - t(1)]
        })
        .collect();
    assert_close(&d.texcoords_1.unwrap(), &want);
    assert_eq!(d.uvs, None);
}

#[test]
fn sparse_float_colors_substitute_their_entries() {
    let dir = tempfile::tempdir().unwrap();
    let (json, b) = synthetic();
    let f = write(dir.path(), &json, &b);
    let d = load_mesh_primitive(&f, 0, 2).unwrap();
    let row = |o: usize| std::array::from_fn(|c| f32_at(&b, o + 4 * c));
    // Vertex 2 is replaced by the sparse value (index 2 at byte 168, value at 172).
    assert_eq!(u16_at(&b, 168), 2);
    let want: Vec<[f32; 4]> = vec![row(120), row(136), row(172)];
    assert_eq!(d.colors.unwrap(), want);
    assert_eq!(d.texcoords_1, None);
}

/// Loads primitive `prim` of the synthetic file after `edit`, expecting an error naming the file
/// and every string of `names`.
fn expect_error(prim: u32, edit: impl FnOnce(&mut Value, &mut Vec<u8>), names: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let (mut json, mut b) = synthetic();
    edit(&mut json, &mut b);
    let f = write(dir.path(), &json, &b);
    let msg = match load_mesh_primitive(&f, 0, prim) {
        Ok(_) => panic!("loaded without error; wanted one naming {names:?}"),
        Err(e) => e.to_string(),
    };
    assert!(msg.contains(&f.display().to_string()), "no file: {msg}");
    for n in names {
        assert!(msg.contains(n), "message does not name `{n}`: {msg}");
    }
    msg
}

#[test]
fn malformed_color_accessors_give_located_errors() {
    let at = "meshes[0].primitives[0].attributes.COLOR_0 (accessors[1])";
    expect_error(
        0,
        |j, _| j["accessors"][1]["type"] = json!("VEC2"),
        &[at, "VEC3 or VEC4"],
    );
    expect_error(0, |j, _| j["accessors"][1]["type"] = json!("MAT4"), &[at]);
    // Count past the end of its buffer view.
    expect_error(
        0,
        |j, _| j["accessors"][1]["count"] = json!(1000),
        &[at, "bytes"],
    );
    // Fewer colours than positions.
    expect_error(
        0,
        |j, _| j["accessors"][1]["count"] = json!(2),
        &[at, "2 colours for 3"],
    );
    // Integers must be normalized; signed types are not allowed.
    expect_error(
        0,
        |j, _| j["accessors"][1]["normalized"] = json!(false),
        &[at, "normalized"],
    );
    expect_error(
        0,
        |j, _| j["accessors"][1]["componentType"] = json!(5120),
        &[at, "FLOAT"],
    );
    // A NaN in the sparse value.
    expect_error(
        2,
        |_, b| b[172..176].copy_from_slice(&f32::NAN.to_le_bytes()),
        &[
            "meshes[0].primitives[2].attributes.COLOR_0",
            "vertex 2",
            "NaN",
        ],
    );
    // A sparse index out of range.
    expect_error(
        2,
        |_, b| b[168] = 3,
        &["accessors[6].sparse.indices", "out of range"],
    );
}

#[test]
fn malformed_texcoord_1_accessors_give_located_errors() {
    let at = "meshes[0].primitives[0].attributes.TEXCOORD_1";
    expect_error(
        0,
        |j, _| j["accessors"][3]["type"] = json!("VEC3"),
        &[at, "VEC2"],
    );
    expect_error(
        0,
        |j, _| j["accessors"][3]["count"] = json!(1000),
        &[at, "bytes"],
    );
    expect_error(
        0,
        |j, _| j["accessors"][3]["count"] = json!(2),
        &[at, "2 texture coordinates for 3"],
    );
    expect_error(
        0,
        |j, _| j["accessors"][3]["normalized"] = json!(false),
        &[at, "normalized"],
    );
    expect_error(
        0,
        |j, _| j["accessors"][3]["componentType"] = json!(5122),
        &[at, "FLOAT"],
    );
}

#[test]
fn uvs_are_set_0_whatever_set_the_material_names() {
    let texture_infos = [
        json!({"index": 0, "texCoord": 1}),
        json!({"index": 0, "extensions": {"KHR_texture_transform": {"texCoord": 1}}}),
    ];
    for info in texture_infos {
        let dir = tempfile::tempdir().unwrap();
        let (mut json, b) = synthetic();
        json["extensionsUsed"] = json!(["KHR_texture_transform"]);
        json["images"] = json!([{"uri": "unread.png"}]);
        json["textures"] = json!([{"source": 0}]);
        json["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": info}}]);
        json["meshes"][0]["primitives"][0]["material"] = json!(0);
        let f = write(dir.path(), &json, &b);
        let d = load_mesh_primitive(&f, 0, 0).unwrap();
        // Each texture use picks its set (`tex_coord`); the mesh keeps both.
        let set1 = d.texcoords_1.expect("primitive 0 has TEXCOORD_1");
        let set0 = d.uvs.expect("primitive 0 has TEXCOORD_0");
        assert_ne!(set0, set1, "{info}");
        assert_eq!(set0[1], [1.0, 1.0], "TEXCOORD_0's vertex 1 is (1, 1)");
    }
}

/// FLOAT colours outside [0, 1] are clamped, as glTF viewers do: the positions accessor
/// (x = 2 at vertex 1) read as VEC3 colours.
#[test]
fn out_of_range_float_colors_are_clamped() {
    let dir = tempfile::tempdir().unwrap();
    let (mut json, b) = synthetic();
    json["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(0);
    let f = write(dir.path(), &json, &b);
    let d = load_mesh_primitive(&f, 0, 0).unwrap();
    let want: Vec<[f32; 4]> = (0..3)
        .map(|i| {
            let c = |k: usize| f32_at(&b, 12 * i + 4 * k).clamp(0.0, 1.0);
            [c(0), c(1), c(2), 1.0]
        })
        .collect();
    assert_eq!(d.colors.unwrap(), want);
    assert_eq!(want[1][0], 1.0, "x = 2 is clamped to 1");
}
