//! The whole importer (parse, map, validate, render the error report) on arbitrary text, and
//! the exporter on whatever imports: never panic; an exported scene must import again.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use lumo_converters::legacy::{self, ImportOptions};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match legacy::import_str(text, Path::new("fuzz/in.txt"), &ImportOptions::default()) {
        Ok(imported) => {
            if let Ok(out) = legacy::export(&imported.scene, Path::new("fuzz")) {
                if let Err(e) = legacy::import_str(&out, Path::new("fuzz/in.txt"), &ImportOptions::default()) {
                    panic!("exported text does not import again: {e}\n{out}");
                }
            }
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
});
