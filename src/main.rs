//! The `lumo` command.

use clap::Parser;

fn main() {
    let cli = lumo::cli::Cli::parse();
    if let Err(e) = lumo::cli::run(cli) {
        eprintln!("error: {}", e.message);
        std::process::exit(e.code);
    }
}
