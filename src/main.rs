//! The `jeffcott` binary: parses arguments and reports errors; the work is in the library.

use clap::Parser;
use jeffcott::cli::{
    Cli, Command, run_basin, run_bench, run_bifurcation, run_ensemble, run_info, run_reproduce,
    run_simulate,
};

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Simulate(a) => run_simulate(a),
        Command::Ensemble(a) => run_ensemble(a),
        Command::Bifurcation(a) => run_bifurcation(a),
        Command::Basin(a) => run_basin(a),
        Command::Reproduce(a) => run_reproduce(a),
        Command::Info => run_info(),
        Command::Bench(a) => run_bench(a),
        Command::Lyapunov(a) => jeffcott::cli::lyapunov::run_lyapunov(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {:#}", anyhow::Error::from(e));
            std::process::ExitCode::from(2)
        }
    }
}
