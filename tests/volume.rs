//! `KHR_materials_volume`: light crossing a transmissive solid keeps attenuation_color^(d / D)
//! of its radiance after a path of length d inside (Beer–Lambert), so solids of different
//! thickness render as an absorption ramp, not one flat colour.

mod common;

/// Two clear spheres (ior 1: no bending, no Fresnel reflection) of radii 0.25 and 0.5 in front of
/// a white background, seen from far away through a narrow field of view, so each pixel's ray
/// crosses its sphere along a chord of known length.
#[test]
fn absorption_follows_beer_lambert_along_the_chord() {
    let dir = tempfile::tempdir().unwrap();
    let color = [0.5f32, 0.25, 0.8];
    let distance = 0.5f32;
    let text = format!(
        r#"{{"format_version": 2,
        "image": {{"width": 64, "height": 64}},
        "render": {{"spp": 16, "max_depth": 8, "seed": 1}},
        "camera": {{"position": [0, 0, 20], "look_at": [0, 0, 0], "fov_y_deg": 6}},
        "background": {{"color": [1, 1, 1]}},
        "materials": {{
            "tinted": {{"base_color": [1, 1, 1], "roughness": 0, "ior": 1.0, "transmission": 1,
                        "volume": {{"attenuation_color": {color:?}, "attenuation_distance": {distance}}}}}
        }},
        "objects": [
            {{"sphere": {{"material": "tinted", "center": [-0.55, 0, 0], "radius": 0.25}}}},
            {{"sphere": {{"material": "tinted", "center": [0.45, 0, 0], "radius": 0.5}}}}
        ]}}"#
    );
    let path = dir.path().join("volume.json");
    std::fs::write(&path, text).unwrap();
    let scene = common::build(&common::load_scene(&path), dir.path());
    let image = common::render(&scene);
    // Half-width of the view at the spheres' distance (20): 20 · tan 3°.
    let half = 20.0 * 3f32.to_radians().tan();
    let pixel = 2.0 * half / 64.0;
    let mut checked = 0;
    for (cx, radius) in [(-0.55f32, 0.25f32), (0.45, 0.5)] {
        let col = ((cx + half) / pixel) as u32;
        for row in 30..34u32 {
            let (x, y) = (
                -half + (col as f32 + 0.5) * pixel - cx,
                half - (row as f32 + 0.5) * pixel,
            );
            let chord = 2.0 * (radius * radius - x * x - y * y).sqrt();
            let p = image.pixels[(row * 64 + col) as usize];
            for k in 0..3 {
                let expected = color[k].powf(chord / distance);
                assert!(
                    (p[k] - expected).abs() <= 0.01 * expected + 1e-4,
                    "radius {radius}, pixel ({col}, {row}), channel {k}: {} vs {expected}",
                    p[k]
                );
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 8);
    // The thicker sphere is darker: a ramp, not one flat grey.
    let centre = |cx: f32| image.pixels[(32 * 64 + ((cx + half) / pixel) as u32) as usize];
    assert!(centre(0.45).x < 0.6 * centre(-0.55).x);
}
