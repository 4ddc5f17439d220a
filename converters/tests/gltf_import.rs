//! Importing the shared glTF sample models.

mod common;

use std::path::Path;

use lumo_converters::gltf::{import, load_image, load_mesh_primitive, CameraChoice, ImportOptions};
use lumo_schema::{validate, Light, MeshSource, Object, TransformOp};

fn sample(shared: &Path, rel: &str) -> std::path::PathBuf {
    shared.join("gltf").join(rel)
}

#[test]
fn every_sample_imports_validates_and_its_meshes_and_images_load() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let files = common::sample_files(&shared);
    assert!(files.len() >= 20, "found only {} sample files", files.len());
    for f in &files {
        let imp =
            import(f, &ImportOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let dir = f.parent().unwrap();
        let diags = validate(&imp.scene, Some(dir));
        assert!(
            diags.is_empty(),
            "{}: imported scene does not validate: {diags:?}",
            f.display()
        );
        assert!(!imp.scene.objects.is_empty(), "{}: no objects", f.display());
        for o in &imp.scene.objects {
            let Object::Mesh(m) = o else {
                panic!("{}: unexpected {}", f.display(), o.kind())
            };
            let MeshSource::Gltf(g) = &m.source else {
                panic!("not referenced")
            };
            let d = load_mesh_primitive(&dir.join(&g.file), g.mesh, g.primitive).unwrap();
            assert!(!d.indices.is_empty());
            assert!(d.positions.iter().flatten().all(|x| x.is_finite()));
            assert_eq!(
                m.smooth,
                d.normals.is_some(),
                "smooth follows the presence of NORMAL"
            );
            if let Some(n) = &d.normals {
                assert_eq!(n.len(), d.positions.len());
                assert!(n
                    .iter()
                    .all(
                        |v| ((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() - 1.0).abs() < 1e-5
                    ));
            }
        }
        for t in imp.scene.textures.values() {
            let (bytes, _) = match t.gltf_image {
                Some(i) => load_image(&dir.join(&t.file), i).unwrap(),
                None => (std::fs::read(dir.join(&t.file)).unwrap(), None),
            };
            assert!(
                bytes.starts_with(b"\x89PNG") || bytes.starts_with(&[0xFF, 0xD8]),
                "{}: texture {} not an image",
                f.display(),
                t.file
            );
        }
    }
}

#[test]
fn box_matrix_hierarchy_is_composed() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    for rel in [
        "Box/glTF/Box.gltf",
        "Box/glTF-Binary/Box.glb",
        "Box/glTF-Embedded/Box.gltf",
    ] {
        let imp = import(&sample(&shared, rel), &ImportOptions::default()).unwrap();
        let Object::Mesh(m) = &imp.scene.objects[0] else {
            panic!()
        };
        // Root: −90° about x (z-up to y-up); child: identity. So the world matrix maps
        // y → −z and z → y.
        let [TransformOp::Matrix(w)] = m.transform.as_slice() else {
            panic!("{:?}", m.transform)
        };
        assert_eq!(w[0], [1.0, 0.0, 0.0, 0.0]);
        assert!(
            (w[1][2] - 1.0).abs() < 1e-6 && (w[2][1] + 1.0).abs() < 1e-6,
            "{w:?}"
        );
        assert!(m.smooth);
        let mat = &imp.scene.materials[&m.material];
        assert!((mat.base_color[0] - 0.8).abs() < 1e-6 && mat.base_color[1] == 0.0);
        // No glTF camera: a framing camera looks at the box.
        let c = imp.scene.camera;
        assert!(c.position[2] > c.look_at[2]);
    }
}

#[test]
fn triangle_without_normals_is_flat_and_without_indices_loads() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let imp = import(
        &sample(
            &shared,
            "TriangleWithoutIndices/glTF/TriangleWithoutIndices.gltf",
        ),
        &ImportOptions::default(),
    )
    .unwrap();
    let Object::Mesh(m) = &imp.scene.objects[0] else {
        panic!()
    };
    assert!(!m.smooth);
    let MeshSource::Gltf(g) = &m.source else {
        panic!()
    };
    let d = load_mesh_primitive(
        &shared
            .join("gltf/TriangleWithoutIndices/glTF")
            .join(&g.file),
        0,
        0,
    )
    .unwrap();
    assert_eq!(d.indices, vec![[0, 1, 2]]);
    // The default material of glTF: white, fully metallic, fully rough.
    let mat = &imp.scene.materials[&m.material];
    assert_eq!(
        (mat.base_color, mat.metallic, mat.roughness, mat.specular),
        ([1.0; 3], 1.0, 1.0, 1.0)
    );
}

#[test]
fn sparse_accessor_substitutes_values() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let d = load_mesh_primitive(
        &sample(
            &shared,
            "SimpleSparseAccessor/glTF/SimpleSparseAccessor.gltf",
        ),
        0,
        0,
    )
    .unwrap();
    // The base positions lie in z = 0 on a 0..6 × 0..4 grid; the sparse entries lift 8..10
    // and 12..13 to y = 1..2 (values from the file's sparse buffer view).
    assert_eq!(d.positions.len(), 14);
    let lifted = d
        .positions
        .iter()
        .filter(|p| p[1] > 0.5 && p[1] < 4.0 && p[0] > 0.5)
        .count();
    assert!(lifted >= 4, "{:?}", d.positions);
    let raw = std::fs::read(sample(
        &shared,
        "SimpleSparseAccessor/glTF/SimpleSparseAccessor.bin",
    ))
    .unwrap();
    // Vertex 8 of the base view (offset 0 of bufferView 1 at byte 72 + 8·12) differs from the
    // loaded value: the sparse substitution happened.
    let base_at = |i: usize| -> [f32; 3] {
        let o = 72 + i * 12;
        [0, 1, 2].map(|k| f32::from_le_bytes(raw[o + 4 * k..o + 4 * k + 4].try_into().unwrap()))
    };
    assert_ne!(d.positions[8], base_at(8));
    assert_eq!(d.positions[0], base_at(0));
}

#[test]
fn texture_coordinates_are_flipped_to_bottom_left() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let f = sample(
        &shared,
        "TextureCoordinateTest/glTF/TextureCoordinateTest.gltf",
    );
    let d = load_mesh_primitive(&f, 0, 0).unwrap();
    let uvs = d.uvs.unwrap();
    // In glTF the top of the image is v = 0, so the top vertex of the quad has the smallest v
    // there and the largest v in lumo.
    let top = (0..d.positions.len())
        .max_by(|a, b| d.positions[*a][1].total_cmp(&d.positions[*b][1]))
        .unwrap();
    let bottom = (0..d.positions.len())
        .min_by(|a, b| d.positions[*a][1].total_cmp(&d.positions[*b][1]))
        .unwrap();
    assert!(
        uvs[top][1] > uvs[bottom][1],
        "top {:?} bottom {:?}",
        uvs[top],
        uvs[bottom]
    );
}

#[test]
fn cameras_by_default_index_and_name() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let f = sample(&shared, "Cameras/glTF/Cameras.gltf");
    let imp = import(&f, &ImportOptions::default()).unwrap();
    assert!((imp.scene.camera.fov_y_deg - 0.7f32.to_degrees()).abs() < 1e-4);
    assert_eq!((imp.scene.image.width, imp.scene.image.height), (512, 512));
    assert!(
        imp.warnings.iter().any(|w| w.contains("orthographic")),
        "{:?}",
        imp.warnings
    );
    let by_index = import(
        &f,
        &ImportOptions {
            camera: Some(CameraChoice::Index(0)),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(by_index.scene.camera, imp.scene.camera);
    let ortho = import(
        &f,
        &ImportOptions {
            camera: Some(CameraChoice::Index(1)),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(
        ortho.to_string().contains("cameras[1]") && ortho.to_string().contains("orthographic"),
        "{ortho}"
    );
    let missing = import(
        &f,
        &ImportOptions {
            camera: Some("nope".parse().unwrap()),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(missing.to_string().contains("nope"), "{missing}");
    // Duck: a perspective camera node; its view direction points at the duck.
    let duck = import(
        &sample(&shared, "Duck/glTF/Duck.gltf"),
        &ImportOptions::default(),
    )
    .unwrap();
    let c = duck.scene.camera;
    let d = [0, 1, 2].map(|k| c.look_at[k] - c.position[k]);
    let to_origin = [0, 1, 2].map(|k| -c.position[k]);
    let cos = (d[0] * to_origin[0] + d[1] * to_origin[1] + d[2] * to_origin[2])
        / ((d.iter().map(|x| x * x).sum::<f32>()).sqrt()
            * (to_origin.iter().map(|x| x * x).sum::<f32>()).sqrt());
    assert!(cos > 0.8, "duck camera looks away: cos {cos}");
}

#[test]
fn materials_transmission_ior_and_emissive_strength() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let t = import(
        &sample(
            &shared,
            "TransmissionRoughnessTest/glTF/TransmissionRoughnessTest.gltf",
        ),
        &ImportOptions::default(),
    )
    .unwrap();
    let iors: std::collections::BTreeSet<u32> = t
        .scene
        .materials
        .values()
        .filter(|m| m.transmission > 0.0)
        .map(|m| (m.ior * 100.0).round() as u32)
        .collect();
    assert!(
        iors.contains(&133) && iors.contains(&242) && iors.contains(&150),
        "{iors:?}"
    );
    // KHR_materials_volume: the glass spheres are solids with their attenuation.
    let volumes: Vec<_> = t
        .scene
        .materials
        .values()
        .filter_map(|m| m.volume.as_ref())
        .collect();
    assert!(!volumes.is_empty(), "{:?}", t.scene.materials);
    assert!(
        !t.warnings
            .iter()
            .any(|w| w.contains("KHR_materials_volume")),
        "{:?}",
        t.warnings
    );
    let e = import(
        &sample(
            &shared,
            "EmissiveStrengthTest/glTF/EmissiveStrengthTest.gltf",
        ),
        &ImportOptions::default(),
    )
    .unwrap();
    let peak = e
        .scene
        .materials
        .values()
        .map(|m| m.emission.iter().copied().fold(0.0, f32::max))
        .fold(0.0, f32::max);
    assert!(peak > 1.5, "emissive strength not applied: {peak}");
}

#[test]
fn texture_transform_and_multiple_scenes() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let t = import(
        &sample(
            &shared,
            "TextureTransformTest/glTF/TextureTransformTest.gltf",
        ),
        &ImportOptions::default(),
    )
    .unwrap();
    let transformed = t
        .scene
        .materials
        .values()
        .filter_map(|m| m.base_color_texture.as_ref())
        .filter(|r| r.rotation_deg != 0.0 || r.scale != [1.0, 1.0])
        .count();
    assert!(transformed >= 3, "{:#?}", t.scene.materials);
    let m = import(
        &sample(&shared, "MultipleScenes/glTF/MultipleScenes.gltf"),
        &ImportOptions::default(),
    )
    .unwrap();
    assert!(
        m.warnings.iter().any(|w| w.contains("2 scenes")),
        "{:?}",
        m.warnings
    );
}

#[test]
fn punctual_lights_use_683_lumens_per_watt() {
    // A file with one spot light of 683 cd, colour (1, 0.5, 0): 1 W/sr red, 0.5 W/sr green.
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("light.gltf");
    std::fs::write(
        &f,
        r#"{"asset":{"version":"2.0"},"extensionsUsed":["KHR_lights_punctual"],
            "extensions":{"KHR_lights_punctual":{"lights":[
              {"type":"spot","color":[1,0.5,0],"intensity":683,"spot":{"innerConeAngle":0.2,"outerConeAngle":0.5}},
              {"type":"directional","intensity":6.83}]}},
            "scene":0,"scenes":[{"nodes":[0,1]}],
            "nodes":[{"translation":[1,2,3],"extensions":{"KHR_lights_punctual":{"light":0}}},
                     {"rotation":[-0.7071068,0,0,0.7071068],"extensions":{"KHR_lights_punctual":{"light":1}}}]}"#,
    )
    .unwrap();
    let imp = import(&f, &ImportOptions::default()).unwrap();
    let Light::Spot(s) = &imp.scene.lights[0] else {
        panic!()
    };
    assert_eq!(s.position, [1.0, 2.0, 3.0]);
    assert_eq!(s.intensity, [1.0, 0.5, 0.0]);
    assert!((s.direction[2] + 1.0).abs() < 1e-6);
    assert!((s.outer_angle_deg - 0.5f32.to_degrees()).abs() < 1e-4);
    let Light::Directional(d) = &imp.scene.lights[1] else {
        panic!()
    };
    assert!((d.irradiance[0] - 0.01).abs() < 1e-7);
    // −90° about x turns −z into −y: the sun shines straight down.
    assert!((d.direction[1] + 1.0).abs() < 1e-6, "{:?}", d.direction);
}

/// `EXT_mesh_gpu_instancing`: SimpleInstancing's one node draws its cube 125 times, each
/// instance at the translation, rotation and scale of its row in the extension's accessors
/// (read here straight from the GLB's binary chunk), relative to the node.
#[test]
fn gpu_instances_become_objects_with_their_own_transforms() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let f = sample(&shared, "SimpleInstancing/glTF-Binary/SimpleInstancing.glb");
    let imp = import(&f, &ImportOptions::default()).unwrap();
    assert!(
        !imp.warnings
            .iter()
            .any(|w| w.contains("EXT_mesh_gpu_instancing")),
        "{:?}",
        imp.warnings
    );
    let bytes = std::fs::read(&f).unwrap();
    let (json, rest) = common::split_glb(&bytes);
    let doc: serde_json::Value = serde_json::from_slice(json).unwrap();
    let bin = &rest[8..];
    let attributes = &doc["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"];
    let column = |key: &str, width: usize| -> Vec<Vec<f64>> {
        let index = attributes[key].as_u64().unwrap() as usize;
        let acc = &doc["accessors"][index];
        let start = common::accessor_start(&doc, index);
        (0..acc["count"].as_u64().unwrap() as usize)
            .map(|i| {
                (0..width)
                    .map(|c| {
                        let at = start + 4 * (width * i + c);
                        f64::from(f32::from_le_bytes(bin[at..at + 4].try_into().unwrap()))
                    })
                    .collect()
            })
            .collect()
    };
    let (t, r, s) = (
        column("TRANSLATION", 3),
        column("ROTATION", 4),
        column("SCALE", 3),
    );
    assert_eq!(imp.scene.objects.len(), 125);
    assert_eq!(t.len(), 125);
    for (i, o) in imp.scene.objects.iter().enumerate() {
        let Object::Mesh(m) = o else {
            panic!("object {i} is a {}", o.kind())
        };
        let matrix = lumo_schema::geometry::transform::ops_matrix(&m.transform);
        // The cube's corner (1, 1, 1): rotate (x, y, z, w) its scaled position, then translate.
        let p = lumo_schema::geometry::glam::DVec3::from_slice(&s[i]);
        let q = lumo_schema::geometry::glam::DQuat::from_xyzw(r[i][0], r[i][1], r[i][2], r[i][3])
            .normalize();
        let expected = q * p + lumo_schema::geometry::glam::DVec3::from_slice(&t[i]);
        let got = matrix.transform_point3(lumo_schema::geometry::glam::DVec3::ONE);
        assert!(
            (got - expected).length() < 1e-5,
            "instance {i}: {got} where the file says {expected}"
        );
    }
}
