//! The `lumo` command.

use clap::Parser;

mod cli;

#[global_allocator]
static ALLOCATOR: lumo::alloc::HugePageAlloc = lumo::alloc::HugePageAlloc;

fn main() {
    lumo::alloc::return_big_frees_to_os();
    let cli = cli::Cli::parse();
    if let Err(e) = cli::run(cli) {
        if e.code == cli::split::EXIT_SIGINT || e.code == cli::split::EXIT_SIGTERM {
            eprintln!("{}", e.message);
        } else {
            eprintln!("error: {}", e.message);
        }
        std::process::exit(e.code);
    }
}
