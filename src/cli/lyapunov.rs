//! `jeffcott lyapunov`: the full Lyapunov spectrum at one speed (`spectrum.json`,
//! `convergence.png`) or over a range of speeds (`lyapunov.npy`, `lyapunov.json`,
//! `lyapunov.png`): the study is [`jeffcott_analysis::lyapunov`], the numerics
//! [`jeffcott_core::lyapunov`]; a range shards and merges like the other studies.

use super::rundir::{CommandHost, Execution, WallTime};
use super::study::StudyCommand;
use super::{ModelArgs, StepperArgs, apply_init, check_start_within_bound};
use crate::cli::choice::{choice, name_of};
use crate::plot;
use clap::Args;
use jeffcott_analysis::lyapunov::{
    self, LyapunovOutcome, LyapunovStudy, SpectrumOptions, SpeedSpectrum,
};
use jeffcott_analysis::output;
use jeffcott_analysis::run::RunDir;
use jeffcott_core::ensemble::Backend;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::lyapunov::{Spectrum, SpectrumConfig, SpectrumRecord, StopReason, SweepStart};
use jeffcott_core::model::{Params, STATE_DIM, State};
use serde::Serialize;

/// The settings both files record under `run`.
#[derive(Serialize)]
struct Settings<'a> {
    config: &'a SpectrumConfig,
    start: SweepStart,
    initial_state: State,
    params: &'a Params,
    /// How the error of each exponent is estimated.
    error_estimate: &'static str,
    jeffcott_version: &'static str,
}

/// `spectrum.json`: the spectrum, the settings and the units.
#[derive(Serialize)]
struct SpectrumFile<'a> {
    #[serde(flatten)]
    spectrum: SpectrumRecord<'a>,
    run: &'a Settings<'a>,
    units: Units,
}

/// The units of the exponents.
#[derive(Serialize)]
struct Units {
    exponents: &'static str,
    exponents_bits: &'static str,
}

/// `lyapunov.json`: per speed the sum rule's terms, the accumulation time, why each
/// stopped and the lane status, with the settings and the list of files.
#[derive(Serialize)]
struct RangeFile<'a> {
    omega: &'a [f64],
    sum: Vec<f64>,
    trace_average: Vec<f64>,
    saltation_log_det_rate: Vec<f64>,
    integration_time: Vec<f64>,
    stop: Vec<StopReason>,
    status: Vec<jeffcott_core::integrate::lane::Status>,
    run: &'a Settings<'a>,
    files: super::files::Files,
}

/// Arguments of `jeffcott lyapunov`.
#[derive(Args, Debug)]
pub struct LyapunovArgs {
    /// Rotor speed W [rad/s], or `a:b:n` for n speeds from a to b inclusive.
    #[arg(long, value_name = "W|a:b:n", allow_hyphen_values = true)]
    pub omega: String,
    /// Override coordinates of the start state (default: static equilibrium), e.g.
    /// `--init x_r=0.005,vx_r=-0.5`.
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub init: Vec<String>,
    /// Forcing periods of the state alone before the tangent vectors start.
    #[arg(long, default_value_t = SpectrumConfig::DEFAULT.transient, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods in which the tangent vectors align, not accumulated.
    #[arg(long, default_value_t = SpectrumConfig::DEFAULT.tangent_transient, value_name = "P")]
    pub tangent_transient: u32,
    /// Largest accumulation time [s] (the stopping rule's maximum).
    #[arg(long, default_value_t = SpectrumConfig::DEFAULT.max_time, value_name = "T")]
    pub time: f64,
    /// Accumulation time before the stopping rule may stop [s]; at most --time
    /// [default: 20, or --time if that is shorter].
    #[arg(long, value_name = "T")]
    pub min_time: Option<f64>,
    /// Stop when no exponent changed by more than this over the last window [1/s].
    #[arg(long, default_value_t = SpectrumConfig::DEFAULT.tol)]
    pub tol: f64,
    /// Window of the stopping rule [forcing periods].
    #[arg(long, default_value_t = SpectrumConfig::DEFAULT.window)]
    pub window: u32,
    /// For a range of speeds: quasistatic (each speed's transient starts where the
    /// previous one ended, speeds in the order given) or given (every speed from the
    /// start state).
    #[arg(long, value_parser = choice::<SweepStart>(), default_value = name_of(SweepStart::Quasistatic))]
    pub start: SweepStart,
    /// Leave the saltation matrices out at contact switches (to see what they change;
    /// they matter only with contact damping c_c > 0).
    #[arg(long)]
    pub no_saltation: bool,
    #[command(flatten)]
    pub model: ModelArgs,
    #[command(flatten)]
    pub stepper: StepperArgs,
    #[command(flatten)]
    pub exec: super::rundir::StudyRunArgs,
}

/// The files of one speed and of a range (a run writes the one set or the other).
pub const OUTPUTS: &[&str] = &[
    "spectrum.json",
    "convergence.png",
    "lyapunov.npy",
    "lyapunov_errors.npy",
    "lyapunov.json",
    "lyapunov.png",
];

/// Runs `jeffcott lyapunov`.
pub fn run_lyapunov(a: &LyapunovArgs) -> Result<()> {
    let params = a.model.params()?;
    let mut x0 = params.static_equilibrium();
    apply_init(&mut x0, &a.init)?;
    check_start_within_bound("init", &x0, a.stepper.divergence_bound)?;
    let range = jeffcott_core::ensemble::RangeSpec::parse("omega", &a.omega)?;
    let config = SpectrumOptions {
        transient: a.transient,
        tangent_transient: a.tangent_transient,
        max_time: a.time,
        min_time: a.min_time,
        tol: a.tol,
        window: a.window,
        saltation: !a.no_saltation,
        stepper: a.stepper.config(),
    }
    .config()?;
    let study = LyapunovStudy::new(("omega", &a.omega), range, x0, a.start, params, config)?;
    if range.n == 1 && a.exec.shard.is_some() {
        return Err(Error::invalid(
            "shard",
            a.exec.shard.as_deref().unwrap_or_default(),
            "one speed's spectrum is one piece of work: shard a range of speeds (--omega a:b:n)",
        ));
    }
    super::study::execute_args::<Lyapunov>(&study, &super::NoOptions {}, &a.exec, Backend::Cpu)
}

/// `jeffcott lyapunov` as a study command.
pub struct Lyapunov;

impl StudyCommand for Lyapunov {
    const COMMAND: &'static str = "lyapunov";
    const OUTPUTS: &'static [&'static str] = OUTPUTS;
    type Spec = LyapunovStudy;
    type Write = super::NoOptions;
    type Outcome = LyapunovOutcome;
    fn run(
        study: &LyapunovStudy,
        _: &super::NoOptions,
        host: &CommandHost,
    ) -> Result<LyapunovOutcome> {
        lyapunov::run(study, host)
    }
    fn finish(
        study: &LyapunovStudy,
        _: &super::NoOptions,
        outcome: LyapunovOutcome,
        run_dir: &RunDir,
        exec: &Execution,
    ) -> Result<()> {
        match outcome {
            LyapunovOutcome::One(s) => write_spectrum(study, &s, run_dir, exec),
            LyapunovOutcome::Range(rows, wall) => write_range(study, &rows, wall, run_dir, exec),
        }
    }
}

/// The settings both kinds of files record under `run`.
fn settings(study: &LyapunovStudy) -> Settings<'_> {
    Settings {
        config: &study.config,
        start: study.start,
        initial_state: study.initial_state,
        params: &study.params,
        error_estimate: "per exponent, max of the batch-means standard error (10 blocks) \
                         and the change of the running estimate over the last window",
        jeffcott_version: env!("CARGO_PKG_VERSION"),
    }
}

/// One speed's files: `spectrum.json`, `convergence.png`.
fn write_spectrum(
    study: &LyapunovStudy,
    s: &Spectrum,
    run_dir: &RunDir,
    exec: &Execution,
) -> Result<()> {
    let dir = &exec.out;
    let omega = study.omegas.first;
    plot::lyapunov::convergence(
        &dir.join("convergence.png"),
        &format!("Lyapunov spectrum at W = {omega} rad/s: running estimates"),
        &s.history,
    )?;
    let j = SpectrumFile {
        spectrum: s.record(),
        run: &settings(study),
        units: Units {
            exponents: "1/s",
            exponents_bits: "bits/s",
        },
    };
    output::write_json(&dir.join("spectrum.json"), &j)?;
    run_dir.finish(
        &WallTime {
            wall_time_s: s.wall_time_s,
        },
        &["spectrum.json".into(), "convergence.png".into()],
    )?;
    if !exec.run.quiet {
        println!(
            "W = {omega} rad/s: exponents [1/s] {}; sum {:.4} (= <tr J> {:.4} + saltation {:.1e}); \
             {:.1} s accumulated ({:?}) in {:.2} s wall; files in {}",
            s.exponents
                .iter()
                .zip(&s.errors)
                .map(|(l, e)| format!("{l:.4} +- {e:.1e}"))
                .collect::<Vec<_>>()
                .join(", "),
            s.sum,
            s.trace_average,
            s.saltation_log_det_rate,
            s.integration_time,
            s.stop,
            s.wall_time_s,
            dir.display()
        );
    }
    Ok(())
}

/// A range's files: `lyapunov.npy`, `lyapunov_errors.npy`, `lyapunov.json`,
/// `lyapunov.png`.
fn write_range(
    study: &LyapunovStudy,
    all: &[SpeedSpectrum],
    wall: f64,
    run_dir: &RunDir,
    exec: &Execution,
) -> Result<()> {
    let dir = &exec.out;
    let omegas: Vec<f64> = all.iter().map(|s| s.omega).collect();
    let n = omegas.len();
    let flat: Vec<f64> = all.iter().flat_map(|s| s.exponents).collect();
    output::write_npy(&dir.join("lyapunov.npy"), &[n, STATE_DIM], &flat)?;
    let errs: Vec<f64> = all.iter().flat_map(|s| s.errors).collect();
    output::write_npy(&dir.join("lyapunov_errors.npy"), &[n, STATE_DIM], &errs)?;
    let exps: Vec<[f64; STATE_DIM]> = all.iter().map(|s| s.exponents).collect();
    plot::lyapunov::spectrum_vs_omega(
        &dir.join("lyapunov.png"),
        &format!(
            "Lyapunov spectrum, W = {} .. {} rad/s ({:?} start)",
            omegas[0],
            omegas[n - 1],
            study.start
        ),
        &omegas,
        &exps,
    )?;
    let of = |f: fn(&SpeedSpectrum) -> f64| all.iter().map(f).collect::<Vec<_>>();
    let j = RangeFile {
        omega: &omegas,
        sum: of(|s| s.sum),
        trace_average: of(|s| s.trace_average),
        saltation_log_det_rate: of(|s| s.saltation_log_det_rate),
        integration_time: of(|s| s.integration_time),
        stop: all.iter().map(|s| s.stop).collect(),
        status: all.iter().map(|s| s.status).collect(),
        run: &settings(study),
        files: [
            ("lyapunov.npy", "f64 [n_omega, 8], exponents [1/s] in QR order (descending), rows in the order of omega"),
            ("lyapunov_errors.npy", "f64 [n_omega, 8], error estimates [1/s]"),
            ("lyapunov.png", "the 8 exponents against W, zero line marked"),
        ]
        .into_iter()
        .collect(),
    };
    output::write_json(&dir.join("lyapunov.json"), &j)?;
    let outputs = [
        "lyapunov.npy",
        "lyapunov_errors.npy",
        "lyapunov.json",
        "lyapunov.png",
    ];
    run_dir.finish(&WallTime { wall_time_s: wall }, &outputs.map(String::from))?;
    if !exec.run.quiet {
        for s in all {
            println!(
                "W = {:.4}: lambda_1 = {:.4} +- {:.1e} 1/s, sum {:.3}",
                s.omega, s.exponents[0], s.errors[0], s.sum
            );
        }
        println!(
            "{n} speeds in {wall:.2} s; files in {}: lyapunov.npy, lyapunov_errors.npy, lyapunov.json, lyapunov.png",
            dir.display()
        );
    }
    Ok(())
}
