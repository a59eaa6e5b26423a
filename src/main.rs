//! The `jeffcott` binary: parses arguments and reports errors; the work is in the library.

use clap::Parser;
use jeffcott::cli::{Cli, dispatch};

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = dispatch(&cli.command);
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {:#}", anyhow::Error::from(e));
            std::process::ExitCode::from(2)
        }
    }
}
