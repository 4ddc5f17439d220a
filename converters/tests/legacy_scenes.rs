//! Every real legacy scene converts, validates (lumo's checks and the JSON Schema), and survives
//! legacy → JSON → legacy → JSON unchanged.

mod common;

use std::path::Path;

use lumo_converters::legacy::{self, ImportOptions, LightsPolicy};
use lumo_schema::{Integrator, Light, Object, Profile};

fn schema_validator() -> jsonschema::Validator {
    let text = std::fs::read_to_string(
        common::workspace_root()
            .join("schema")
            .join("scene.schema.json"),
    )
    .expect("schema file");
    let schema: serde_json::Value = serde_json::from_str(&text).expect("schema is JSON");
    jsonschema::validator_for(&schema).expect("schema compiles")
}

fn import_into(path: &Path, out: &Path) -> legacy::Imported {
    let opts = ImportOptions {
        output_dir: Some(out.to_path_buf()),
        ..ImportOptions::default()
    };
    legacy::import(path, &opts).unwrap_or_else(|e| panic!("{}", e))
}

fn check_scene(path: &Path, validator: &jsonschema::Validator) {
    let out = tempfile::tempdir().expect("temp dir");
    let imported = import_into(path, out.path());
    let diags = lumo_schema::validate(&imported.scene, Some(out.path()));
    assert!(diags.is_empty(), "{}: {diags:?}", path.display());
    let json: serde_json::Value =
        serde_json::from_str(&lumo_schema::to_json(&imported.scene)).expect("json");
    let errors: Vec<String> = validator
        .iter_errors(&json)
        .map(|e| format!("{} at {}", e, e.instance_path()))
        .collect();
    assert!(
        errors.is_empty(),
        "{}: schema errors {errors:?}",
        path.display()
    );
    for w in &imported.warnings {
        assert!(w.contains(": warning: "), "{w}");
    }
}

#[test]
fn every_shared_legacy_scene_converts_and_validates() {
    let Some(files) = common::shared_legacy_scenes() else {
        return;
    };
    let validator = schema_validator();
    for f in &files {
        check_scene(f, &validator);
    }
}

#[test]
fn own_example_scenes_convert_and_validate() {
    let files = common::own_legacy_scenes();
    assert!(
        files.len() >= 4,
        "scenes/legacy/ should hold the example scenes"
    );
    let validator = schema_validator();
    for f in &files {
        check_scene(f, &validator);
    }
}

/// legacy → JSON₁ → legacy → JSON₂ must give JSON₂ == JSON₁, byte for byte.
fn fixpoint(path: &Path) {
    let out = tempfile::tempdir().expect("temp dir");
    let first = import_into(path, out.path());
    let json1 = lumo_schema::to_json(&first.scene);
    let text = legacy::export(&first.scene, out.path())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let written = out.path().join("exported.txt");
    std::fs::write(&written, &text).expect("write");
    let second = legacy::import(
        &written,
        &ImportOptions {
            output_dir: Some(out.path().to_path_buf()),
            ..ImportOptions::default()
        },
    )
    .unwrap_or_else(|e| {
        panic!(
            "re-importing the export of {} failed:\n{e}\n--- exported text ---\n{text}",
            path.display()
        )
    });
    let json2 = lumo_schema::to_json(&second.scene);
    assert!(
        json1 == json2,
        "{}: round trip is not a fixpoint\n--- first ---\n{json1}\n--- second ---\n{json2}",
        path.display()
    );
}

#[test]
fn shared_scenes_round_trip_to_a_fixpoint() {
    let Some(files) = common::shared_legacy_scenes() else {
        return;
    };
    for f in &files {
        fixpoint(f);
    }
}

#[test]
fn own_scenes_round_trip_to_a_fixpoint() {
    for f in &common::own_legacy_scenes() {
        fixpoint(f);
    }
}

#[test]
fn mapping_rules_on_real_scenes() {
    let Some(dir) = common::shared_dir() else {
        return;
    };
    let out = tempfile::tempdir().unwrap();
    let get = |name: &str| import_into(&dir.join("legacy-scenes").join(name), out.path());

    // Original ray caster: Phong material, point light kept, raycast integrator.
    let s = get("scene01_basic.txt").scene;
    assert_eq!(s.render.integrator, Integrator::Raycast);
    assert_eq!(s.objects.len(), 6);
    assert_eq!(s.lights.len(), 1);
    let m0 = &s.materials["material0"];
    // (1, ks = 1) normalised: half metal, half Lambertian (no specular coat).
    assert_eq!((m0.metallic, m0.specular, m0.transmission), (0.5, 0.0, 0.0));
    let expect_r = (2.0f64 / 22.0).powf(0.25) as f32;
    assert_eq!(m0.roughness, expect_r);
    assert_eq!(s.camera.look_at, [0.0, 0.0, 9.0]);
    assert_eq!(s.camera.fov_y_deg, 30.0);
    assert_eq!((s.image.width, s.image.height), (200, 200));
    // Global MaterialIndex: spheres 2 and 3 share material1.
    assert_eq!(s.objects[1].material(), "material1");
    assert_eq!(s.objects[2].material(), "material1");

    // Directional light colour c → irradiance π c.
    let s = get("scene03_sphere.txt").scene;
    match &s.lights[0] {
        Light::Directional(d) => assert_eq!(d.irradiance, [std::f32::consts::PI; 3]),
        other => panic!("{other:?}"),
    }

    // Path-tracing dialect: emitters → Lights block dropped, path integrator, two-sided emission.
    let imp = get("zhanglbthu_cornell.txt");
    assert!(imp.scene.lights.is_empty());
    assert_eq!(imp.scene.render.integrator, Integrator::Path);
    assert!(
        imp.warnings
            .iter()
            .any(|w| w.contains("dropping the Lights block")),
        "{:?}",
        imp.warnings
    );
    assert!(
        imp.warnings.iter().any(|w| w.contains("not unit length")),
        "non-unit plane normals are ambiguous"
    );
    // Its black front wall stands between the camera and the room; the dialect's planes are
    // one-sided, so it is left out (exact: it absorbs like the black background).
    assert_eq!(imp.scene.objects.len(), 8);
    assert!(
        imp.warnings
            .iter()
            .any(|w| w.contains("camera is behind this black plane")),
        "{:?}",
        imp.warnings
    );
    let glass = &imp.scene.materials["material5"];
    assert_eq!(
        (
            glass.transmission,
            glass.ior,
            glass.metallic,
            glass.roughness
        ),
        (1.0, 1.5, 0.0, 0.0)
    );
    // Legacy glass refracts: a clear volume, not a thin wall.
    assert_eq!(glass.volume, Some(lumo_schema::Volume::default()));
    assert!(imp.scene.materials["material6"].two_sided_emission);

    // ... unless asked to keep them.
    let kept = legacy::import(
        &dir.join("legacy-scenes").join("zhanglbthu_cornell.txt"),
        &ImportOptions {
            lights: LightsPolicy::Keep,
            output_dir: Some(out.path().to_path_buf()),
        },
    )
    .unwrap();
    assert_eq!(kept.scene.lights.len(), 2);

    // The wine glass: B-spline with the legacy uniform unclamped knots, z-rotation after translation.
    let s = get("scene10_wineglass.txt").scene;
    assert_eq!(s.objects.len(), 2);
    assert!(
        s.objects.iter().all(|o| o.material() == "material0"),
        "global current material carries over"
    );
    let Object::Lathe(l) = &s.objects[0] else {
        panic!("{:?}", s.objects[0])
    };
    let Profile::Bspline(b) = &l.profile else {
        panic!()
    };
    let n = b.points.len();
    assert_eq!((b.degree, n), (3, 26));
    let k = b.knots.as_ref().unwrap();
    assert_eq!(k.len(), n + 4);
    assert_eq!((k[3], k[n]), (3.0 / 29.0, 26.0 / 29.0));
    assert_eq!(
        format!("{:?}", l.transform),
        "[Translate([1.7, 0.0, 0.0]), Rotate(Rotation { axis: [0.0, 0.0, 1.0], degrees: 15.0 })]"
    );

    // Textures resolve against the scene folder and are written relative to the output folder.
    let s = get("1unx1_ball_texture.txt").scene;
    assert_eq!(s.textures.len(), 2);
    for t in s.textures.values() {
        assert!(out.path().join(&t.file).is_file(), "{}", t.file);
    }
    assert_eq!(
        s.materials["material4"]
            .base_color_texture
            .as_ref()
            .unwrap()
            .texture,
        "texture0"
    );

    // Thin lens.
    let s = get("zhanglbthu_depth.txt").scene;
    assert_eq!(
        (s.camera.aperture_radius, s.camera.focus_distance),
        (10.0, Some(220.0))
    );

    // Bare curves are not surfaces: left out with a warning, and there is no material at all.
    let imp = get("scene08_core.txt");
    assert!(imp.scene.objects.is_empty());
    assert_eq!(
        imp.warnings
            .iter()
            .filter(|w| w.contains("bare curve"))
            .count(),
        4
    );

    // `reflective` (jefflyy) is a mirror weight.
    let s = get("scene11_diamond.txt").scene;
    let m = &s.materials["material1"];
    assert_eq!((m.metallic, m.specular, m.transmission), (0.7, 0.0, 0.0));
}

#[test]
fn testcases_folder_resolves_against_its_parent() {
    let root = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(root.path().join("testcases")).unwrap();
    std::fs::create_dir_all(root.path().join("mesh")).unwrap();
    std::fs::write(
        root.path().join("mesh").join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let scene =
        "PerspectiveCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 angle 40 width 8 height 8 }\n\
                 Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }\n\
                 Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file mesh/tri.obj } }\n";
    let path = root.path().join("testcases").join("s.txt");
    std::fs::write(&path, scene).unwrap();
    // Default output folder = the scene's folder: the path climbs out of testcases/.
    let imp = legacy::import(&path, &ImportOptions::default()).unwrap();
    let Object::Mesh(m) = &imp.scene.objects[0] else {
        panic!()
    };
    assert_eq!(
        m.source,
        lumo_schema::MeshSource::Obj("../mesh/tri.obj".into())
    );
    // An output folder that does not exist yet still gets correct relative paths.
    let out = root.path().join("out").join("deep");
    let imp = legacy::import(
        &path,
        &ImportOptions {
            output_dir: Some(out),
            ..ImportOptions::default()
        },
    )
    .unwrap();
    let Object::Mesh(m) = &imp.scene.objects[0] else {
        panic!()
    };
    assert_eq!(
        m.source,
        lumo_schema::MeshSource::Obj("../../mesh/tri.obj".into())
    );
}
