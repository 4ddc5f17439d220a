//! Small exact-enough math for the converter: the legacy transform composition rule (on
//! [`lumo_schema::geometry::transform`]'s f64 matrices), the point-light reference distance, and inverting f32 maps exactly so that
//! export followed by import reproduces every number bit for bit.

use lumo_schema::geometry::bounds::{object_bounds, points_bounds, Aabb};
use lumo_schema::geometry::glam::{DMat4, DVec3};
use lumo_schema::geometry::transform::{ops_matrix, rotation_axis_angle};
use lumo_schema::{Mesh, MeshSource, Object, Scene};

use std::path::Path;

use super::ast::Op;

/// A 4×4 matrix acting on column vectors: p' = M · (x, y, z, 1).
pub type M4 = DMat4;

/// Right-handed rotation by `deg` degrees about `axis`.
fn rotation(axis: [f64; 3], deg: f64) -> M4 {
    rotation_axis_angle(DVec3::from(axis), deg.to_radians())
}

fn v64(v: [f32; 3]) -> [f64; 3] {
    [v[0] as f64, v[1] as f64, v[2] as f64]
}

/// The matrix a legacy `Matrix4f` lists: its 16 numbers run down the columns (row index varies
/// fastest), so entry i is `m[i % 4][i / 4]`.
pub fn matrix4f(values: &[f32; 16]) -> M4 {
    DMat4::from_cols_array(&values.map(f64::from))
}

/// The matrix of one legacy step (Matrix4f as stored).
pub fn legacy_op_matrix(op: &Op) -> M4 {
    match *op {
        Op::Scale(s) => DMat4::from_scale(DVec3::from(v64(s))),
        Op::UniformScale(s) => DMat4::from_scale(DVec3::splat(s as f64)),
        Op::Translate(t) => DMat4::from_translation(DVec3::from(v64(t))),
        Op::XRotate(d) => rotation([1.0, 0.0, 0.0], d as f64),
        Op::YRotate(d) => rotation([0.0, 1.0, 0.0], d as f64),
        Op::ZRotate(d) => rotation([0.0, 0.0, 1.0], d as f64),
        Op::Rotate(a, d) => rotation(v64(a), d as f64),
        Op::Matrix4f(ref m) => matrix4f(m),
    }
}

/// The object-to-world matrix of one `Transform` block, by the framework's rule: start from the
/// identity and, for each step in file order, right-multiply (M = M · Op), except `Matrix4f`,
/// which left-multiplies (M = Mat · M).
pub fn legacy_block_matrix(ops: &[Op]) -> M4 {
    ops.iter().fold(DMat4::IDENTITY, |m, op| match op {
        Op::Matrix4f(_) => legacy_op_matrix(op) * m,
        _ => m * legacy_op_matrix(op),
    })
}

/// The world-space point a legacy point light's brightness is matched at: the centre of the
/// box of the scene's bounded objects, by their true bounds
/// ([`lumo_schema::geometry::bounds::object_bounds`]: a lathe by its curve, not its control
/// points, so an exact lathe and its tessellation give the same point), or `None` when there
/// are none. Meshes in OBJ files are read (relative to `base_dir`, the folder the scene's paths
/// resolve against) and count by their placed vertices; one that cannot be read, and glTF
/// meshes, count by their placed origin. Import and export pass the same folder, so they agree.
pub fn scene_reference_point(scene: &Scene, base_dir: &Path) -> Option<[f64; 3]> {
    let mut all: Option<Aabb> = None;
    for obj in &scene.objects {
        let b = match obj {
            Object::Mesh(Mesh {
                source: MeshSource::Obj(file),
                transform,
                ..
            }) => match crate::obj::load(&base_dir.join(file)) {
                Ok(mesh) => points_bounds(
                    mesh.positions.iter().map(|p| DVec3::from(p.map(f64::from))),
                    &ops_matrix(transform),
                ),
                Err(_) => points_bounds([DVec3::ZERO], &ops_matrix(transform)),
            },
            Object::Mesh(Mesh {
                source: MeshSource::Gltf(_),
                transform,
                ..
            }) => points_bounds([DVec3::ZERO], &ops_matrix(transform)),
            _ => object_bounds(obj),
        };
        if let Some(b) = b {
            all = Some(all.map_or(b, |a| a.union(&b)));
        }
    }
    all.map(|b| b.center().to_array())
}

/// The distance at which a legacy point light (no falloff) and lumo's inverse-square light give
/// the same irradiance: from the light to [`scene_reference_point`], else to the camera; 1 when
/// both coincide with the light.
/// `base_dir` is where the scene's relative paths resolve (see [`scene_reference_point`]).
pub fn point_light_reference_distance(scene: &Scene, light: [f32; 3], base_dir: &Path) -> f64 {
    let l = v64(light);
    let dist = |p: [f64; 3]| {
        ((p[0] - l[0]).powi(2) + (p[1] - l[1]).powi(2) + (p[2] - l[2]).powi(2)).sqrt()
    };
    let mut d = scene_reference_point(scene, base_dir)
        .map(dist)
        .unwrap_or(0.0);
    if !(d > 1e-6 && d.is_finite()) {
        d = dist(v64(scene.camera.position));
    }
    if !(d > 1e-6 && d.is_finite()) {
        d = 1.0;
    }
    d
}

/// The intensity (W/sr) the importer gives a legacy point light of colour channel `color` at
/// `position`: π · colour · d² with d from [`point_light_reference_distance`].
pub fn point_light_intensity(
    scene: &Scene,
    position: [f32; 3],
    color: f32,
    base_dir: &Path,
) -> f32 {
    let d = point_light_reference_distance(scene, position, base_dir);
    legacy_to_radiometric(color, d * d)
}

/// Legacy colour → lumo radiometric quantity. The legacy shading is `kd · colour · cos θ` with
/// no 1/π, while a lumo Lambertian surface reflects `albedo/π · E · cos θ`; so a directional
/// light's irradiance is E = π · colour, and a point light's intensity is I = π · colour · d²
/// with d from [`point_light_reference_distance`].
pub fn legacy_to_radiometric(color: f32, scale: f64) -> f32 {
    (std::f64::consts::PI * color as f64 * scale) as f32
}

/// The next representable f32 above/below (like `f32::next_up`, which needs Rust 1.86).
fn step(x: f32, up: bool) -> f32 {
    if x.is_nan() || x.is_infinite() {
        return x;
    }
    if x == 0.0 {
        let tiny = f32::from_bits(1);
        return if up { tiny } else { -tiny };
    }
    let bits = x.to_bits();
    let towards_larger_magnitude = up == (x > 0.0);
    f32::from_bits(if towards_larger_magnitude {
        bits + 1
    } else {
        bits - 1
    })
}

/// Finds x near `guess` with `forward(x) == target` exactly (searching up to 256 representable
/// neighbours each way), so that a value written by the exporter reads back as the same f32.
/// Falls back to `guess` when no exact preimage exists.
pub fn invert_exact(target: f32, guess: f32, forward: impl Fn(f32) -> f32) -> f32 {
    if !guess.is_finite() {
        return guess;
    }
    if forward(guess) == target {
        return guess;
    }
    let (mut up, mut down) = (guess, guess);
    for _ in 0..256 {
        up = step(up, true);
        if forward(up) == target {
            return up;
        }
        down = step(down, false);
        if forward(down) == target {
            return down;
        }
    }
    guess
}

/// Shininess → roughness. A Phong exponent s corresponds to a Beckmann width
/// α = √(2 / (s + 2)) (Walter, Marschner, Li, Torrance 2007, "Microfacet models for refraction
/// through rough surfaces", §5.2), used as GGX's α; lumo's α = roughness², so
/// roughness = (2 / (s + 2))^¼. s = 0 gives roughness 1, s → ∞ a mirror.
pub fn shininess_to_roughness(s: f32) -> f32 {
    (2.0 / (s as f64 + 2.0)).powf(0.25) as f32
}

/// The inverse of [`shininess_to_roughness`], exact in f32 where possible.
pub fn roughness_to_shininess(r: f32) -> f32 {
    let guess = (2.0 / (r as f64).powi(4) - 2.0) as f32;
    invert_exact(r, guess.max(0.0), shininess_to_roughness)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumo_schema::TransformOp;

    #[test]
    fn rotation_is_right_handed() {
        let p = rotation([0.0, 0.0, 1.0], 90.0).transform_point3(DVec3::X);
        assert!((p[0]).abs() < 1e-12 && (p[1] - 1.0).abs() < 1e-12);
        let p = rotation([1.0, 0.0, 0.0], 90.0).transform_point3(DVec3::Y);
        assert!((p[2] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn matrix4f_is_column_by_column_and_left_multiplied() {
        // A translation by (1, 2, 3) written column by column: the last column comes last.
        let t = [
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 2.0, 3.0, 1.0,
        ];
        assert_eq!(
            matrix4f(&t).transform_point3(DVec3::ZERO).to_array(),
            [1.0, 2.0, 3.0]
        );
        // Scale 2 then Matrix4f: M = Mat · (I · S), so the object is scaled first, then moved.
        let m = legacy_block_matrix(&[Op::UniformScale(2.0), Op::Matrix4f(t)]);
        assert_eq!(m.transform_point3(DVec3::ONE).to_array(), [3.0, 4.0, 5.0]);
    }

    #[test]
    fn shininess_round_trips_exactly() {
        for s in [0.0f32, 1.0, 10.0, 20.0, 25.0, 100.0, 1000.0, 3.7] {
            let r = shininess_to_roughness(s);
            assert_eq!(
                shininess_to_roughness(roughness_to_shininess(r)),
                r,
                "s = {s}"
            );
        }
        assert_eq!(shininess_to_roughness(0.0), 1.0);
        for r in [0.1f32, 0.316_227_77, 0.5, 0.9, 1.0] {
            assert_eq!(
                shininess_to_roughness(roughness_to_shininess(r)),
                r,
                "r = {r}"
            );
        }
    }

    /// The intended change of issue 11: a lathe and its tessellation (as an inline mesh) put a
    /// legacy point light at the same reference point. Before, the lathe counted by its control
    /// polygon and a mesh by its origin (a B-spline student scene gave 70.8 vs 46.9). The
    /// tolerance, 1e-3 relative on the intensity d², covers the 64-ring tessellation's chord
    /// error on this profile (about 1e-4 of its size) doubled by the square.
    #[test]
    fn exact_and_tessellated_lathes_give_the_same_point_light() {
        use lumo_schema::geometry::tessellate;
        use lumo_schema::{BsplineProfile, InlineMesh, Lathe, Profile, Rotation};
        let profile = Profile::Bspline(BsplineProfile {
            degree: 3,
            points: vec![
                [0.0, -1.0],
                [1.6, -1.0],
                [0.2, 0.0],
                [0.9, 1.2],
                [0.4, 1.5],
                [0.0, 1.5],
            ],
            knots: None,
        });
        let transform = vec![
            TransformOp::Translate([1.7, 0.3, -2.0]),
            TransformOp::Rotate(Rotation {
                axis: [0.0, 0.0, 1.0],
                degrees: 15.0,
            }),
        ];
        let mut scene: Scene = lumo_schema::parse_scene(
            r#"{"format_version": 1, "camera": {"position": [0, 0, 8], "look_at": [0, 0, 0], "fov_y_deg": 40}, "materials": {}, "objects": []}"#,
        )
        .expect("a minimal scene");
        scene.objects = vec![Object::Lathe(Lathe {
            name: None,
            material: "m".into(),
            transform: transform.clone(),
            profile: profile.clone(),
        })];
        let light = [4.0, 5.0, 3.0];
        let exact = point_light_reference_distance(&scene, light, Path::new("."));
        let t = tessellate::lathe(&profile, 64, 64);
        let f32s = |v: DVec3| v.to_array().map(|x| x as f32);
        scene.objects = vec![Object::Mesh(Mesh {
            name: None,
            material: "m".into(),
            transform,
            source: MeshSource::Inline(InlineMesh {
                positions: t.positions.iter().map(|p| f32s(*p)).collect(),
                indices: t.indices.clone(),
                normals: None,
                uvs: None,
            }),
            smooth: false,
        })];
        let mesh = point_light_reference_distance(&scene, light, Path::new("."));
        let (i1, i2) = (
            legacy_to_radiometric(1.0, exact * exact),
            legacy_to_radiometric(1.0, mesh * mesh),
        );
        assert!(
            ((i1 - i2) / i1).abs() < 1e-3,
            "exact lathe {i1} vs tessellated {i2}"
        );
    }
}
