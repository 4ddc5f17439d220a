//! Generated scenes survive serialise → parse unchanged, including every optional field.

use std::collections::BTreeMap;

use lumo_schema::*;
use proptest::prelude::*;

fn num() -> impl Strategy<Value = f32> {
    prop_oneof![-1e4f32..1e4, Just(0.0f32), Just(1.0f32), 1e-6f32..1e-3]
}
fn vec3() -> impl Strategy<Value = Vec3> {
    [num(), num(), num()]
}
fn vec2() -> impl Strategy<Value = Vec2> {
    [num(), num()]
}
fn unit() -> impl Strategy<Value = f32> {
    0.0f32..=1.0
}

fn transform() -> impl Strategy<Value = Transform> {
    prop::collection::vec(
        prop_oneof![
            vec3().prop_map(TransformOp::Translate),
            (vec3(), num())
                .prop_map(|(axis, degrees)| TransformOp::Rotate(Rotation { axis, degrees })),
            num().prop_map(|s| TransformOp::Scale(Scale::Uniform(s))),
            vec3().prop_map(|s| TransformOp::Scale(Scale::PerAxis(s))),
            prop::array::uniform4(prop::array::uniform4(num())).prop_map(TransformOp::Matrix),
        ],
        0..4,
    )
}

fn texture_ref() -> impl Strategy<Value = Option<TextureRef>> {
    prop::option::of(("[a-z]{1,6}", vec2(), num(), vec2(), 0u32..2).prop_map(
        |(texture, offset, rotation_deg, scale, tex_coord)| TextureRef {
            texture,
            offset,
            rotation_deg,
            scale,
            tex_coord,
        },
    ))
}

fn material() -> impl Strategy<Value = Material> {
    let volume = prop::option::of(([unit(), unit(), unit()], prop::option::of(0.01f32..100.0)));
    (
        (
            [unit(), unit(), unit()],
            texture_ref(),
            (unit(), unit()),
            texture_ref(),
            0.5f32..3.0,
        ),
        (unit(), texture_ref(), [num(), num(), num()], texture_ref()),
        (unit(), texture_ref(), volume),
        ([num(), num(), num()], texture_ref(), any::<bool>()),
        (unit(), 0u32..3, unit(), texture_ref(), num()),
        (
            unit(),
            texture_ref(),
            unit(),
            texture_ref(),
            texture_ref(),
            num(),
        ),
        (
            [unit(), unit(), unit()],
            texture_ref(),
            unit(),
            texture_ref(),
            any::<bool>(),
        ),
    )
        .prop_map(
            |(
                (base_color, base_color_texture, (metallic, roughness), mr_texture, ior),
                (specular, specular_texture, specular_color, specular_color_texture),
                (transmission, transmission_texture, volume),
                (emission, emission_texture, two_sided_emission),
                (alpha, alpha_mode, alpha_cutoff, normal_texture, normal_scale),
                (
                    clearcoat,
                    clearcoat_texture,
                    clearcoat_roughness,
                    cc_rough_tex,
                    cc_normal,
                    cc_scale,
                ),
                (sheen_color, sheen_color_texture, sheen_roughness, sheen_roughness_texture, unlit),
            )| Material {
                base_color,
                base_color_texture,
                alpha,
                alpha_mode: [AlphaMode::Opaque, AlphaMode::Mask, AlphaMode::Blend]
                    [alpha_mode as usize],
                alpha_cutoff,
                normal_texture,
                normal_scale,
                metallic,
                roughness,
                metallic_roughness_texture: mr_texture,
                ior,
                specular,
                specular_texture,
                specular_color: specular_color.map(f32::abs),
                specular_color_texture,
                transmission,
                transmission_texture,
                volume: volume.map(|(c, d): ([f32; 3], Option<f32>)| Volume {
                    attenuation_color: c.map(|x| x.max(0.01)),
                    attenuation_distance: d,
                }),
                clearcoat,
                clearcoat_texture,
                clearcoat_roughness,
                clearcoat_roughness_texture: cc_rough_tex,
                clearcoat_normal_texture: cc_normal,
                clearcoat_normal_scale: cc_scale,
                sheen_color,
                sheen_color_texture,
                sheen_roughness,
                sheen_roughness_texture,
                unlit,
                emission,
                emission_texture,
                two_sided_emission,
            },
        )
}

fn object() -> impl Strategy<Value = Object> {
    fn common() -> impl Strategy<Value = (Option<String>, String, Transform)> {
        (prop::option::of("[a-z ]{0,8}"), "[a-z]{1,6}", transform())
    }
    prop_oneof![
        (common(), vec3(), 0.001f32..100.0).prop_map(
            |((name, material, transform), center, radius)| Object::Sphere(Sphere {
                name,
                material,
                transform,
                center,
                radius
            })
        ),
        (common(), vec3(), num()).prop_map(|((name, material, transform), normal, offset)| {
            Object::Plane(Plane {
                name,
                material,
                transform,
                normal,
                offset,
            })
        }),
        (common(), [vec3(), vec3(), vec3()]).prop_map(|((name, material, transform), vertices)| {
            Object::Triangle(Triangle {
                name,
                material,
                transform,
                vertices,
            })
        }),
        (
            common(),
            prop::collection::vec(vec3(), 1..5),
            prop::collection::vec([0u32..5, 0u32..5, 0u32..5], 1..4),
            any::<bool>(),
            any::<bool>()
        )
            .prop_map(
                |((name, material, transform), positions, indices, with_normals, smooth)| {
                    let normals = with_normals.then(|| positions.clone());
                    Object::Mesh(Mesh {
                        name,
                        material,
                        transform,
                        source: MeshSource::Inline(InlineMesh {
                            positions,
                            indices,
                            normals,
                            uvs: None,
                        }),
                        smooth,
                    })
                }
            ),
        (common(), "[a-z]{1,8}\\.obj").prop_map(
            |((name, material, transform), file)| Object::Mesh(Mesh {
                name,
                material,
                transform,
                source: MeshSource::Obj(file),
                smooth: false
            })
        ),
        (common(), "[a-z]{1,8}\\.glb", 0u32..9, 0u32..3).prop_map(
            |((name, material, transform), file, mesh, primitive)| Object::Mesh(Mesh {
                name,
                material,
                transform,
                source: MeshSource::Gltf(GltfMeshRef {
                    file,
                    mesh,
                    primitive
                }),
                smooth: true
            })
        ),
        (common(), prop::collection::vec(vec2(), 2..6)).prop_map(
            |((name, material, transform), points)| Object::Lathe(Lathe {
                name,
                material,
                transform,
                profile: Profile::Bezier(BezierProfile { points })
            })
        ),
        (
            common(),
            1u32..4,
            prop::collection::vec(vec2(), 4..8),
            any::<bool>()
        )
            .prop_map(|((name, material, transform), degree, points, explicit)| {
                let mut b = BsplineProfile {
                    degree,
                    points,
                    knots: None,
                };
                if explicit {
                    b.knots = Some(b.knots_or_default());
                }
                Object::Lathe(Lathe {
                    name,
                    material,
                    transform,
                    profile: Profile::Bspline(b),
                })
            }),
    ]
}

fn light() -> impl Strategy<Value = Light> {
    prop_oneof![
        (vec3(), vec3()).prop_map(|(position, intensity)| Light::Point(PointLight {
            position,
            intensity
        })),
        (vec3(), vec3()).prop_map(
            |(direction, irradiance)| Light::Directional(DirectionalLight {
                direction,
                irradiance
            })
        ),
        (vec3(), vec3(), vec3(), 0.0f32..45.0, 45.0f32..90.0).prop_map(
            |(position, direction, intensity, inner_angle_deg, outer_angle_deg)| Light::Spot(
                SpotLight {
                    position,
                    direction,
                    intensity,
                    inner_angle_deg,
                    outer_angle_deg
                }
            )
        ),
    ]
}

fn scene() -> impl Strategy<Value = Scene> {
    (
        (
            1u32..4096,
            1u32..4096,
            prop_oneof![Just(Integrator::Path), Just(Integrator::Raycast)],
            1u32..10_000,
            1u32..64,
            any::<u64>(),
            prop::option::of(0.1f32..1000.0),
        ),
        (
            vec3(),
            vec3(),
            vec3(),
            1.0f32..179.0,
            prop_oneof![Just(0.0f32), 0.001f32..1.0],
            prop::option::of(0.1f32..100.0),
        ),
        [unit(), unit(), unit()],
        prop::collection::btree_map(
            "[a-z]{1,6}",
            (
                "[a-z]{1,8}\\.png",
                prop::option::of(0u32..4),
                any::<bool>(),
                0u8..3,
            ),
            0..3,
        ),
        prop::collection::btree_map("[a-z]{1,6}", material(), 0..4),
        prop::collection::vec(object(), 0..6),
        prop::collection::vec(light(), 0..3),
    )
        .prop_map(
            |(
                (width, height, integrator, spp, max_depth, seed, time_budget_s),
                (position, look_at, up, fov_y_deg, aperture_radius, focus_distance),
                bg,
                textures,
                materials,
                objects,
                lights,
            )| {
                let textures: BTreeMap<String, Texture> = textures
                    .into_iter()
                    .map(|(k, (file, gltf_image, linear, wrap))| {
                        let modes = [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp];
                        // Both axes from one number: s = wrap % 3, t = wrap / 3.
                        let (wrap_s, wrap_t) =
                            (modes[wrap as usize % 3], modes[wrap as usize / 3 % 3]);
                        (
                            k,
                            Texture {
                                file,
                                gltf_image,
                                color_space: if linear {
                                    ColorSpace::Linear
                                } else {
                                    ColorSpace::Srgb
                                },
                                wrap_s,
                                wrap_t,
                            },
                        )
                    })
                    .collect();
                Scene {
                    schema: Some("../schema/scene.schema.json".into()),
                    format_version: FORMAT_VERSION,
                    image: Image { width, height },
                    render: RenderSettings {
                        integrator,
                        sampler: if seed % 2 == 0 {
                            SamplerKind::Sobol
                        } else {
                            SamplerKind::Independent
                        },
                        spp,
                        max_depth,
                        seed,
                        time_budget_s,
                        aov: Vec::new(),
                    },
                    camera: Camera {
                        position,
                        look_at,
                        up,
                        fov_y_deg,
                        aperture_radius,
                        focus_distance,
                    },
                    background: Background {
                        color: bg,
                        ..Background::default()
                    },
                    textures,
                    materials,
                    objects,
                    lights,
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn serialise_then_parse_is_identity(scene in scene()) {
        let text = to_json(&scene);
        let back = parse_scene(&text).map_err(|d| TestCaseError::fail(format!("{d}\n{text}")))?;
        prop_assert_eq!(back, scene);
    }
}
