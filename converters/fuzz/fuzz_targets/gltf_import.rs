//! Fuzzes the glTF importer with arbitrary bytes as a .glb (or .gltf JSON) file: it must return
//! an error or a scene, never panic. Seed corpus: the .glb files of ../shared/gltf.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use lumo_converters::gltf::{import_bytes, ImportOptions};

fuzz_target!(|data: &[u8]| {
    let _ = import_bytes(Path::new("fuzz.glb"), data, &ImportOptions::default());
});
