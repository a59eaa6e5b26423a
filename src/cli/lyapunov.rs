//! `jeffcott lyapunov`: the full Lyapunov spectrum at one speed (`spectrum.json`,
//! `convergence.png`) or over a range of speeds (`lyapunov.npy`, `lyapunov.json`,
//! `lyapunov.png`). The numerics are in [`jeffcott_core::lyapunov`].

use super::{ModelArgs, StepperArgs, apply_init, check_start_within_bound};
use crate::plot;
use clap::Args;
use jeffcott_analysis::output;
use jeffcott_analysis::record::Span;
use jeffcott_analysis::run::{Array, Unit};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::lyapunov::{
    Spectrum, SpectrumConfig, SpectrumRecord, StopReason, SweepStart, spectrum, sweep_starts,
};
use jeffcott_core::model::{Params, STATE_DIM, State};
use rayon::prelude::*;
use serde::Serialize;
use std::path::PathBuf;

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

/// The specification `run.json` records.
#[derive(Serialize)]
struct RunSpec<'a> {
    omegas: Span,
    config: &'a SpectrumConfig,
    start: SweepStart,
    initial_state: State,
    params: &'a Params,
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
    #[arg(long, value_enum, default_value_t = SweepStart::Quasistatic)]
    pub start: SweepStart,
    /// Leave the saltation matrices out at contact switches (to see what they change;
    /// they matter only with contact damping c_c > 0).
    #[arg(long)]
    pub no_saltation: bool,
    #[command(flatten)]
    pub model: ModelArgs,
    #[command(flatten)]
    pub stepper: StepperArgs,
    /// Output directory (created if missing). An unfinished range of the same command
    /// there is resumed (speeds already computed are kept).
    #[arg(long, value_name = "DIR", default_value = "jeffcott-out/lyapunov")]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: super::rundir::RunArgs,
}

/// Runs `jeffcott lyapunov`.
pub fn run_lyapunov(a: &LyapunovArgs) -> Result<()> {
    let params = a.model.params()?;
    let mut x0 = params.static_equilibrium();
    apply_init(&mut x0, &a.init)?;
    check_start_within_bound("init", &x0, a.stepper.divergence_bound)?;
    let range = jeffcott_core::ensemble::RangeSpec::parse("omega", &a.omega)?;
    let min_time = match a.min_time {
        Some(m) => m,
        None => SpectrumConfig::default().min_time.min(a.time),
    };
    if min_time.is_finite() && a.time.is_finite() && min_time > a.time {
        return Err(Error::invalid(
            "min-time",
            min_time,
            format!(
                "must be in 0..=--time ({} s): the stopping rule may act only within the maximum time",
                a.time
            ),
        ));
    }
    let cfg = SpectrumConfig {
        transient: a.transient,
        tangent_transient: a.tangent_transient,
        min_time,
        max_time: a.time,
        window: a.window,
        tol: a.tol,
        saltation: !a.no_saltation,
        stepper: a.stepper.config(),
        ..SpectrumConfig::default()
    };
    cfg.validate()?;
    // The accumulation is counted in forcing periods like every transient: the same cap.
    cfg.check_size("omega", &a.omega, range.len(), range.a.max(range.b))?;
    let omegas = range.values();
    let dir = &a.out;
    let settings = Settings {
        config: &cfg,
        start: a.start,
        initial_state: x0,
        params: &params,
        error_estimate: "per exponent, max of the batch-means standard error (10 blocks) \
                         and the change of the running estimate over the last window",
        jeffcott_version: env!("CARGO_PKG_VERSION"),
    };
    let run_spec = RunSpec {
        omegas: Span::of(&omegas),
        config: &cfg,
        start: a.start,
        initial_state: x0,
        params: &params,
    };
    if let [omega] = omegas[..] {
        let run_dir = super::rundir::open(
            dir,
            "lyapunov",
            &run_spec,
            &["spectrum.json", "convergence.png"],
            a.run,
        )?;
        let s = spectrum(&params, omega, &x0, &cfg)?;
        plot::lyapunov::convergence(
            &dir.join("convergence.png"),
            &format!("Lyapunov spectrum at W = {omega} rad/s: running estimates"),
            &s.history,
        )?;
        let j = SpectrumFile {
            spectrum: s.record(),
            run: &settings,
            units: Units {
                exponents: "1/s",
                exponents_bits: "bits/s",
            },
        };
        output::write_json(&dir.join("spectrum.json"), &j)?;
        run_dir.finish(
            &super::rundir::WallTime {
                wall_time_s: s.wall_time_s,
            },
            &["spectrum.json".into(), "convergence.png".into()],
        )?;
        if !a.run.quiet {
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
        return Ok(());
    }
    if omegas.is_empty() {
        return Err(Error::invalid("omega", &a.omega, "no speeds"));
    }
    let outputs = [
        "lyapunov.npy",
        "lyapunov_errors.npy",
        "lyapunov.json",
        "lyapunov.png",
    ];
    let run_dir = super::rundir::open(dir, "lyapunov", &run_spec, &outputs, a.run)?;
    let start = std::time::Instant::now();
    let all = range_units(&run_dir, &params, &omegas, &x0, a.start, &cfg)?;
    let wall = start.elapsed().as_secs_f64();
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
            a.start
        ),
        &omegas,
        &exps,
    )?;
    let of = |f: fn(&Row) -> f64| all.iter().map(f).collect::<Vec<_>>();
    let j = RangeFile {
        omega: &omegas,
        sum: of(|s| s.sum),
        trace_average: of(|s| s.trace_average),
        saltation_log_det_rate: of(|s| s.saltation_log_det_rate),
        integration_time: of(|s| s.integration_time),
        stop: all.iter().map(|s| s.stop).collect(),
        status: all.iter().map(|s| s.status).collect(),
        run: &settings,
        files: [
            ("lyapunov.npy", "f64 [n_omega, 8], exponents [1/s] in QR order (descending), rows in the order of omega"),
            ("lyapunov_errors.npy", "f64 [n_omega, 8], error estimates [1/s]"),
            ("lyapunov.png", "the 8 exponents against W, zero line marked"),
        ]
        .into_iter()
        .collect(),
    };
    output::write_json(&dir.join("lyapunov.json"), &j)?;
    run_dir.finish(
        &super::rundir::WallTime { wall_time_s: wall },
        &outputs.map(String::from),
    )?;
    if !a.run.quiet {
        for s in &all {
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

/// What a range keeps of each speed's spectrum.
struct Row {
    omega: f64,
    exponents: [f64; STATE_DIM],
    errors: [f64; STATE_DIM],
    sum: f64,
    trace_average: f64,
    saltation_log_det_rate: f64,
    integration_time: f64,
    stop: StopReason,
    status: jeffcott_core::integrate::lane::Status,
}

const STOPS: [StopReason; 3] = [
    StopReason::Converged,
    StopReason::MaxTime,
    StopReason::LaneFrozen,
];

/// The spectra of a range, unit by unit into the run directory (a unit: consecutive
/// speeds, at most 1/20 of them, computed in parallel). The quasistatic transients that
/// give every speed its start state run first, in sequence, and are cheap beside the
/// spectra; they are recomputed on resume (deterministic).
fn range_units(
    run_dir: &jeffcott_analysis::run::RunDir,
    params: &jeffcott_core::model::Params,
    omegas: &[f64],
    x0: &jeffcott_core::model::State,
    start: SweepStart,
    cfg: &SpectrumConfig,
) -> Result<Vec<Row>> {
    let (starts, per_cfg) = sweep_starts(params, omegas, x0, start, cfg)?;
    let n = omegas.len();
    let per = jeffcott_analysis::run::unit_lanes(n, 1).min(rayon::current_num_threads().max(1) * 4);
    let count = jeffcott_analysis::run::unit_count(n, per);
    let done = run_dir.committed("lyapunov", count)?;
    for (u, _) in done.iter().enumerate().filter(|(_, d)| !**d) {
        let range = u * per..((u + 1) * per).min(n);
        let spectra: Vec<Spectrum> = range
            .clone()
            .into_par_iter()
            .map(|i| spectrum(params, omegas[i], &starts[i], &per_cfg))
            .collect::<Result<_>>()?;
        let f = |g: &dyn Fn(&Spectrum) -> f64| Array::F64(spectra.iter().map(g).collect());
        let unit = Unit::new(jeffcott_analysis::run::dir::unit_key("lyapunov", u))
            .with(
                "exponents",
                Array::F64(spectra.iter().flat_map(|s| s.exponents).collect()),
            )
            .with(
                "errors",
                Array::F64(spectra.iter().flat_map(|s| s.errors).collect()),
            )
            .with("sum", f(&|s| s.sum))
            .with("trace_average", f(&|s| s.trace_average))
            .with("saltation_log_det_rate", f(&|s| s.saltation_log_det_rate))
            .with("integration_time", f(&|s| s.integration_time))
            .with(
                "stop",
                Array::U32(
                    spectra
                        .iter()
                        .map(|s| STOPS.iter().position(|x| *x == s.stop).unwrap_or(0) as u32)
                        .collect(),
                ),
            )
            .with(
                "status",
                Array::U32(spectra.iter().map(|s| s.status.code()).collect()),
            );
        run_dir.commit("lyapunov", u, &unit)?;
    }
    let mut rows = Vec::with_capacity(n);
    for u in 0..count {
        let unit = run_dir.load("lyapunov", u)?;
        let (e, r) = (unit.f64s("exponents")?, unit.f64s("errors")?);
        for (j, i) in (u * per..((u + 1) * per).min(n)).enumerate() {
            let eight = |v: &[f64]| -> [f64; STATE_DIM] {
                v[j * STATE_DIM..(j + 1) * STATE_DIM]
                    .try_into()
                    .unwrap_or([f64::NAN; STATE_DIM])
            };
            rows.push(Row {
                omega: omegas[i],
                exponents: eight(e),
                errors: eight(r),
                sum: unit.f64s("sum")?[j],
                trace_average: unit.f64s("trace_average")?[j],
                saltation_log_det_rate: unit.f64s("saltation_log_det_rate")?[j],
                integration_time: unit.f64s("integration_time")?[j],
                stop: STOPS[(unit.u32s("stop")?[j] as usize).min(2)],
                status: jeffcott_core::integrate::lane::Status::from_code(unit.u32s("status")?[j])
                    .unwrap_or(jeffcott_core::integrate::lane::Status::NonFinite),
            });
        }
    }
    Ok(rows)
}
