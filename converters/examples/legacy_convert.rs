//! Converts a legacy scene and prints the JSON (stdout) and warnings (stderr), or with
//! `--export` converts it and prints the legacy text written back from the JSON.
//!
//! `cargo run -p lumo-converters --example legacy_convert -- scene.txt [--export]`

use std::path::PathBuf;
use std::process::ExitCode;

use lumo_converters::legacy::{self, ImportOptions};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.iter().find(|a| !a.starts_with("--")) else {
        eprintln!("usage: legacy_convert SCENE.txt [--export]");
        return ExitCode::from(2);
    };
    match legacy::import(&PathBuf::from(path), &ImportOptions::default()) {
        Ok(imported) => {
            for w in &imported.warnings {
                eprintln!("{w}");
            }
            if args.iter().any(|a| a == "--export") {
                match legacy::export(
                    &imported.scene,
                    &lumo_schema::base_dir_of(&PathBuf::from(path)),
                ) {
                    Ok(text) => print!("{text}"),
                    Err(e) => {
                        eprintln!("{e}");
                        return ExitCode::FAILURE;
                    }
                }
            } else {
                print!("{}", lumo_schema::to_json(&imported.scene));
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
