//! A few shared glTF sample models render like reference images rendered once at high sample
//! counts and checked in (`tests/reference/gltf/`), within Monte Carlo noise measured at test time.
//! Regenerate the references with `LUMO_BLESS=1 cargo test --test gltf_reference`.

mod common;

use lumo::render::Image;
use lumo::LoadOptions;

const SIZE: u32 = 64;
const SPP: u32 = 64;
const REFERENCE_SPP: u32 = 2048;
/// CC0 (MetalRoughSpheresNoTextures, TextureCoordinateTest) and CC-BY-4.0 (EmissiveStrengthTest,
/// © 2022 AGI, Ed Mackey) models from the Khronos glTF Sample Assets.
const MODELS: [&str; 3] = [
    "MetalRoughSpheresNoTextures/glTF/MetalRoughSpheresNoTextures.gltf",
    "TextureCoordinateTest/glTF/TextureCoordinateTest.gltf",
    "EmissiveStrengthTest/glTF/EmissiveStrengthTest.gltf",
];

fn render(path: &std::path::Path, spp: u32, seed: u64) -> Image {
    let mut inp = lumo::load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    inp.edit(|s| {
        s.image.width = SIZE;
        s.image.height = SIZE;
        s.render.spp = spp;
        s.render.seed = seed;
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let (scene, _) = inp.build().unwrap_or_else(|e| panic!("{e}"));
    common::render(&scene)
}

#[test]
fn sample_models_match_their_reference_images() {
    let Some(shared) = common::shared() else {
        return;
    };
    let bless = std::env::var_os("LUMO_BLESS").is_some();
    for model in MODELS {
        let path = shared.join("gltf").join(model);
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let reference_path = common::root().join(format!("tests/reference/gltf/{name}.exr"));
        if bless {
            std::fs::create_dir_all(reference_path.parent().unwrap()).unwrap();
            lumo::output::write_image(
                &render(&path, REFERENCE_SPP, 1000),
                &reference_path,
                lumo::output::ToneMap::Clamp,
            )
            .unwrap();
        }
        let reference = lumo::output::read_image(&reference_path)
            .unwrap_or_else(|e| panic!("{e} (run with LUMO_BLESS=1 to create it)"));
        let (a, b) = (render(&path, SPP, 1), render(&path, SPP, 2));
        let noise = a.rmse(&b) / 2f64.sqrt();
        // The reference's own noise is that of SPP samples scaled by √(SPP / REFERENCE_SPP).
        let expected = noise * (1.0 + f64::from(SPP) / f64::from(REFERENCE_SPP)).sqrt();
        let error = a.rmse(&reference);
        eprintln!("{name}: RMSE vs reference {error:.5}, expected from noise {expected:.5}");
        assert!(
            error <= 1.2 * expected + 1e-6,
            "{name}: RMSE {error} vs reference, noise explains {expected}"
        );
    }
}
