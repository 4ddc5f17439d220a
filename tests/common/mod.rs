//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The workspace root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The shared test data folder (`../shared` beside the checkout, or `$LUMO_SHARED`). When it is
/// missing, returns `None` after a loud message, or panics under `LUMO_REQUIRE_SHARED=1` (CI).
pub fn shared() -> Option<PathBuf> {
    let dir = std::env::var_os("LUMO_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("../shared"));
    if dir.join("README.md").is_file() {
        return Some(dir);
    }
    if std::env::var_os("LUMO_REQUIRE_SHARED").is_some_and(|v| v == "1") {
        panic!(
            "shared test data not found at {} and LUMO_REQUIRE_SHARED=1",
            dir.display()
        );
    }
    eprintln!("\n=== SKIPPED: shared test data not found at {} (set LUMO_SHARED or place ../shared beside the checkout) ===\n", dir.display());
    None
}

/// `file` loaded, made small (24 × 18 pixels, 4 spp), edited by `edit` and built, panicking
/// with the file's name on any error.
pub fn small_scene(file: &Path, edit: impl Fn(&mut lumo_schema::Scene)) -> lumo::scene::Scene {
    let mut input = lumo::load(file, &lumo::LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    input
        .edit(|s| {
            s.image.width = 24;
            s.image.height = 18;
            s.render.spp = 4;
            edit(s);
        })
        .unwrap();
    input
        .build()
        .unwrap_or_else(|e| panic!("{}: {e}", file.display()))
        .0
}

/// The files under `dir` (recursively) with one of `extensions`, sorted.
pub fn files_in(dir: &Path, extensions: &[&str]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap().flatten() {
            let p = entry.path();
            if p.is_dir() {
                stack.push(p);
            } else if p
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| extensions.contains(&e))
            {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// Loads and builds a scene file from the workspace, with settings overridden for a small test.
pub fn load_scene(path: &Path) -> lumo_schema::Scene {
    lumo_schema::load_scene_file(path)
        .unwrap_or_else(|e| panic!("{e}"))
        .into_inner()
}

/// Validates a scene description, reads its assets (relative to `base`) and builds it into a
/// renderable scene.
pub fn build(desc: &lumo_schema::Scene, base: &Path) -> lumo::scene::Scene {
    let valid = lumo_schema::Validated::new(desc.clone(), Some(base))
        .unwrap_or_else(|d| panic!("invalid scene: {}", d[0]));
    let assets = lumo::load::Assets::read(&valid, base).unwrap_or_else(|e| panic!("{e}"));
    lumo::scene::build(&valid, &assets)
        .unwrap_or_else(|e| panic!("{e}"))
        .0
}

/// Renders with the scene's own settings on the current rayon pool.
pub fn render(scene: &lumo::scene::Scene) -> lumo::render::Image {
    lumo::render::render(scene, &Default::default()).0
}

/// The reference Cornell box (`scenes/cornell.json`) at `size`² pixels with the given samples,
/// seed and sample sequence, ready to render.
pub fn cornell(
    size: u32,
    spp: u32,
    seed: u64,
    sampler: lumo_schema::SamplerKind,
) -> lumo::scene::Scene {
    let mut desc = load_scene(&root().join("scenes/cornell.json"));
    desc.image.width = size;
    desc.image.height = size;
    desc.render.spp = spp;
    desc.render.seed = seed;
    desc.render.sampler = sampler;
    build(&desc, &root().join("scenes"))
}

/// The pyoidn package folder of the test environment `tests/oidn/.venv` (it bundles Open Image
/// Denoise), if that environment exists.
pub fn test_venv_pyoidn() -> Option<PathBuf> {
    let lib = root().join("tests/oidn/.venv/lib");
    std::fs::read_dir(lib).ok().and_then(|entries| {
        entries
            .flatten()
            .map(|e| e.path().join("site-packages/pyoidn"))
            .find(|p| p.is_dir())
    })
}

/// Where the tests find Open Image Denoise: `LUMO_OIDN`, else [`test_venv_pyoidn`]. `None`
/// after a loud message when it is missing; under `LUMO_REQUIRE_OIDN=1` (CI) a missing library
/// fails the test instead.
pub fn oidn_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("LUMO_OIDN").filter(|v| !v.is_empty()) {
        return Some(PathBuf::from(dir));
    }
    let found = test_venv_pyoidn();
    if found.is_none() {
        if std::env::var_os("LUMO_REQUIRE_OIDN").is_some_and(|v| v == "1") {
            panic!(
                "Open Image Denoise not found (LUMO_OIDN unset, no pyoidn in {}) and \
                 LUMO_REQUIRE_OIDN=1",
                root().join("tests/oidn/.venv/lib").display()
            );
        }
        eprintln!(
            "\n=== SKIPPED: Open Image Denoise not found (python3 -m venv tests/oidn/.venv && \
             tests/oidn/.venv/bin/pip install -r tests/oidn/requirements.txt) ===\n"
        );
    }
    found
}
