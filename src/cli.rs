//! Command-line interface: argument parsing, file writing, human summaries. Nothing
//! numerical lives here (docs/architecture.md).

use crate::plot;
use clap::{Args, Parser, Subcommand};
use files::Documented;
use jeffcott_analysis::classify::ClassifyConfig;
use jeffcott_analysis::defaults;
use jeffcott_analysis::ensemble::{EnsembleStudy, LanesRecord, Totals};
use jeffcott_analysis::output;
use jeffcott_analysis::record::Span;
use jeffcott_analysis::simulate::{
    Integrator, SimulateOutcome, SimulateSpec, SimulateStudy, run_study,
};
use jeffcott_core::ensemble::Precision;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::article::{ArticleConfig, ErrorNorm};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, State};
use std::path::{Path, PathBuf};

mod basin;
mod bench;
mod bifurcation;
mod cascade;
mod continuation;
mod exit;
pub mod files;
mod info;
pub mod map;
mod merge;
pub mod orbits;
mod reproduce;
pub mod rubout;
pub mod rundir;
mod stability;
pub mod study;
mod usage;
pub use basin::{BasinArgs, run_basin};
pub use bench::{BenchArgs, run_bench};
pub use bifurcation::{BifurcationArgs, CatalogueArgs, SweepArg, run_bifurcation};
pub use cascade::{CascadeArgs, run_cascade};
pub use continuation::{ContinuationArgs, run_continuation};
pub use exit::{EXIT_CODES, exit_code};
pub use info::{InfoArgs, run_info};
pub use map::{MapArgs, run_map};
pub use merge::{MergeArgs, run_merge};
pub use usage::one_line_usage_error;
pub mod lyapunov;
pub use reproduce::{ReproduceArgs, run_reproduce};
pub use stability::{StabilityArgs, run_stability};

/// Nonlinear dynamics of a rubbing Jeffcott rotor hitting a flexibly suspended stator.
///
/// Implements the model of "Nonlinear Dynamics and Chaos of a Nonsmooth Rotor-Stator
/// System" (Mathematical Problems in Engineering, 2017) with its dimensional errors
/// corrected. All quantities are SI: metres, seconds, radians, kilograms.
#[derive(Parser, Debug)]
#[command(
    name = "jeffcott",
    version = jeffcott_analysis::LONG_VERSION,
    about,
    long_about,
    after_long_help = EXIT_CODES
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Integrate one trajectory at one rotor speed, write its Poincare points, time
    /// series, phase portraits and a classification (period-N, aperiodic, diverged).
    #[command(allow_negative_numbers = true)]
    Simulate(SimulateArgs),
    /// Run many independent lanes (one per rotor speed) on the CPU or a GPU and write
    /// their Poincare points, statuses and lane table.
    #[command(allow_negative_numbers = true)]
    Ensemble(EnsembleArgs),
    /// Bifurcation diagram over W: quasistatic sweeps up and down (hysteresis) and a
    /// brute-force ensemble of start states per W (coexisting attractors). The sweeps run
    /// on the CPU; --backend and --precision are the brute force's.
    #[command(allow_negative_numbers = true)]
    Bifurcation(BifurcationArgs),
    /// Basin of attraction at one W over two start coordinates: labels.npy (attractor id
    /// per cell), attractors.json, basin.png. Runs in work units committed to --out as
    /// they finish (resumable), so memory stays bounded (about 16 MB + 10 MB for
    /// 2000 x 2000 cells).
    #[command(allow_negative_numbers = true)]
    Basin(BasinArgs),
    /// Two-parameter map (design chart) over any two of omega, the model parameters and
    /// the start coordinates: per cell the response from the static equilibrium (period,
    /// lambda_1, contact fraction, peak contact force) and the coexisting attractors
    /// from K start states. Resumable and shardable like basin.
    #[command(allow_negative_numbers = true)]
    Map(MapArgs),
    /// Follow the attractors over omega or a model parameter, run-up and run-down
    /// (Attractors.jl's seeded find-and-match): basin fractions with errors, where
    /// attractors are born and die, and tipping probabilities between consecutive values.
    #[command(allow_negative_numbers = true)]
    Continuation(ContinuationArgs),
    /// Full-spectrum cascade of a quasistatic run-up and run-down: the rotor's and
    /// stator's full spectra (forward and backward whirl) against speed, with the 1X line
    /// and the natural frequencies, and the rub regime at each speed.
    #[command(allow_negative_numbers = true)]
    Cascade(CascadeArgs),
    /// Basin stability (Menck et al. 2013): fractions of start states drawn uniformly in a
    /// box of any start coordinates that end on each attractor, with 95 % intervals; over a
    /// speed range, stacked against W.
    #[command(name = "basin-stability", allow_negative_numbers = true)]
    BasinStability(StabilityArgs),
    /// Regenerate the article's figures (Figs. 3-12, plus down-sweep and brute-force
    /// diagrams) and a REPORT.md; --quick (default) takes about two minutes on 2 CPU cores.
    Reproduce(ReproduceArgs),
    /// List GPU adapters, their backends, f64 support and limits, and the CPU threads.
    Info(InfoArgs),
    /// Measure lane-steps and forcing periods per second of each backend and precision
    /// at W = 133 (a contact-heavy regime) and print them as a table (docs/performance.md).
    Bench(BenchArgs),
    /// Compute the Lyapunov spectrum (8 exponents, saltation at contact switches) at one
    /// speed or over a range of speeds.
    #[command(allow_negative_numbers = true)]
    Lyapunov(lyapunov::LyapunovArgs),
    /// Merge the shard directories of a run computed with --shard i/n (e.g. a Slurm job
    /// array) into the files of the unsharded run, identical to the bit.
    Merge(MergeArgs),
    /// Continue a branch of period-n orbits over W or a model parameter (Newton
    /// shooting, pseudo-arclength) with Floquet multipliers and located fold, period
    /// doubling, Neimark-Sacker and grazing bifurcations.
    #[command(allow_negative_numbers = true)]
    Orbits(orbits::OrbitsArgs),
}

/// Runs a parsed command.
pub fn dispatch(command: &Command) -> Result<()> {
    match command {
        Command::Simulate(a) => run_simulate(a),
        Command::Ensemble(a) => run_ensemble(a),
        Command::Bifurcation(a) => run_bifurcation(a),
        Command::Basin(a) => run_basin(a),
        Command::Map(a) => run_map(a),
        Command::Continuation(a) => run_continuation(a),
        Command::Cascade(a) => run_cascade(a),
        Command::BasinStability(a) => run_stability(a),
        Command::Reproduce(a) => run_reproduce(a),
        Command::Info(a) => run_info(a),
        Command::Bench(a) => run_bench(a),
        Command::Lyapunov(a) => lyapunov::run_lyapunov(a),
        Command::Merge(a) => run_merge(a),
        Command::Orbits(a) => orbits::run_orbits(a),
    }
}

/// Arguments of `jeffcott ensemble`.
#[derive(Args, Debug)]
pub struct EnsembleArgs {
    /// Rotor speeds: `a:b:n` is n speeds from a to b inclusive, evenly spaced, or one
    /// number [rad/s]. With --lanes: the speed of lanes whose table has no omega column.
    #[arg(
        long,
        value_name = "a:b:n",
        allow_hyphen_values = true,
        required_unless_present = "lanes"
    )]
    pub omega: Option<String>,
    /// Lanes from a table, one row each: a CSV file with a header, or a 2-D f64 .npy with
    /// --columns (a lanes.npy of an earlier run needs none; a params.npy beside it gives
    /// its param_set column's parameter sets). Columns: omega, any parameter key
    /// (omega_r, omega_s, xi_r, xi_s, delta, mu, m_r, m_s, e, k_c, c_c, e_max, a_g, phi0),
    /// start coordinates (x_r, vx_r, ... or x_r0, ...), param_set. Absent columns take
    /// --omega, --config/--param and the static equilibrium with --init.
    #[arg(long, value_name = "FILE")]
    pub lanes: Option<PathBuf>,
    /// Column names of an .npy lane table, e.g. `--columns omega,mu,k_c`.
    #[arg(
        long,
        value_name = "NAME,...",
        value_delimiter = ',',
        requires = "lanes"
    )]
    pub columns: Option<Vec<String>>,
    /// Override coordinates of every lane's start state (default: static equilibrium),
    /// e.g. `--init x_r=0.005,vx_r=-0.5`.
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub init: Vec<String>,
    /// Forcing periods integrated and discarded.
    #[arg(long, default_value_t = defaults::ensemble::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded per lane.
    #[arg(long, default_value_t = defaults::ensemble::PERIODS, value_name = "P")]
    pub periods: u32,
    #[command(flatten)]
    pub lane: LaneArgs,
    #[command(flatten)]
    pub exec: rundir::StudyRunArgs,
    /// Also compute each lane's largest Lyapunov exponent lambda_1 [1/s] from a tangent
    /// vector renormalised every period (written to `lambda1.npy`).
    #[arg(long)]
    pub lyapunov: bool,
}

/// Final files of an ensemble (run.json aside).
pub(crate) const ENSEMBLE_OUTPUTS: &[&str] = &[
    "poincare.npy",
    "status.npy",
    "lanes.npy",
    "params.npy",
    "lambda1.npy",
];

/// The lanes of `jeffcott ensemble`: a speed range from one start state, or a table.
/// Returns the parameter sets, the lanes and what run.json records of them.
fn ensemble_lanes(
    a: &EnsembleArgs,
) -> Result<(
    Vec<Params>,
    Vec<jeffcott_core::ensemble::LaneSpec>,
    LanesRecord,
)> {
    use jeffcott_core::ensemble::LaneSpec;
    use jeffcott_core::ensemble::table::{
        LaneTable, TableDefaults, lanes_checksum, lanes_from_table, read_params_table,
    };
    let params = a.lane.model.params()?;
    let bound = a.lane.stepper.divergence_bound;
    if let Some(path) = &a.lanes {
        let table = LaneTable::read(path, a.columns.as_deref())?;
        jeffcott_core::limits::check_memory(
            "lanes",
            path.display(),
            jeffcott_core::ensemble::EnsembleSpec::memory_estimate_for(
                table.rows.len() as u64,
                a.periods as u64,
            ),
            &format!(
                "{} lanes x {} recorded periods",
                table.rows.len(),
                a.periods
            ),
            "use a shorter table or fewer --periods",
        )?;
        // A params.npy beside the table holds the sets its param_set column indexes.
        let beside = path.with_file_name("params.npy");
        let sets = if table.columns.iter().any(|c| c == "param_set") && beside.exists() {
            read_params_table(&beside)?
        } else {
            Vec::new()
        };
        table.refuse_set_by(
            "init",
            parse_assignment_lists("init", &a.init)?
                .iter()
                .map(|(n, _)| n.as_str()),
        )?;
        let overridden = a.lane.model.overridden()?;
        table.refuse_set_by("param", overridden.iter().map(String::as_str))?;
        let init = |x: &mut State| apply_init(x, &a.init);
        // --omega with a table: one speed for lanes without an omega column.
        let omega = match &a.omega {
            Some(text) => {
                let r = jeffcott_core::ensemble::RangeSpec::parse("omega", text)?;
                if r.n != 1 {
                    return Err(Error::invalid(
                        "omega",
                        text,
                        "with --lanes give one speed (for lanes without an omega column), not a range",
                    ));
                }
                Some(r.a)
            }
            None => None,
        };
        let (sets, lanes) = lanes_from_table(
            &table,
            &TableDefaults {
                params: &params,
                param_sets: &sets,
                omega,
                init: &init,
                divergence_bound: bound,
            },
        )?;
        let j = LanesRecord::Table {
            lanes: jeffcott_analysis::ensemble::TableRecord {
                table: path.display().to_string(),
                columns: table.columns,
                count: lanes.len(),
                checksum: lanes_checksum(&sets, &lanes),
            },
        };
        return Ok((sets, lanes, j));
    }
    let omega = a.omega.as_deref().unwrap_or_default();
    let mut x0 = params.static_equilibrium();
    apply_init(&mut x0, &a.init)?;
    check_start_within_bound("init", &x0, bound)?;
    let range = jeffcott_core::ensemble::RangeSpec::parse("omega", omega)?;
    jeffcott_core::ensemble::EnsembleSpec::check_size("omega", omega, range.len(), a.periods)?;
    let omegas = range.values();
    let j = LanesRecord::Range {
        omega: Span::of(&omegas),
        x0,
    };
    Ok((vec![params], LaneSpec::at_speeds(&omegas, x0), j))
}

/// Runs `jeffcott ensemble`: lanes in work units committed to --out, then the files
/// assembled from the units (poincare.npy streamed, one unit in memory at a time).
pub fn run_ensemble(a: &EnsembleArgs) -> Result<()> {
    jeffcott_core::limits::check_periods("transient", a.transient, 0)?;
    jeffcott_core::limits::check_periods("periods", a.periods, 1)?;
    let (param_sets, lanes, record) = ensemble_lanes(a)?;
    let spec = jeffcott_core::ensemble::EnsembleSpec {
        lanes,
        param_sets,
        transient: a.transient,
        recorded: a.periods,
        stepper: a.lane.stepper.config(),
        precision: a.lane.precision(),
    };
    spec.validate()?;
    let study = EnsembleStudy::of(spec, record, a.lyapunov, a.lane.backend);
    study::execute_args::<Ensemble>(&study, &NoOptions {}, &a.exec, a.lane.backend)
}

/// The writer options of a command that has none (run.json's `write` is `{}`).
#[derive(serde::Serialize, serde::Deserialize)]
pub struct NoOptions {}

/// `jeffcott ensemble` as a study command.
pub struct Ensemble;

impl study::StudyCommand for Ensemble {
    const COMMAND: &'static str = "ensemble";
    const OUTPUTS: &'static [&'static str] = ENSEMBLE_OUTPUTS;
    type Spec = EnsembleStudy;
    type Write = NoOptions;
    /// How the run went, its wall time and the device set-up's part of it [s].
    type Outcome = (jeffcott_core::ensemble::RunInfo, f64, f64);
    fn run(
        study: &EnsembleStudy,
        _: &NoOptions,
        host: &rundir::CommandHost,
    ) -> Result<Self::Outcome> {
        let start = std::time::Instant::now();
        let engine = jeffcott_analysis::backend::Engine::new(study.backend, study.precision)?;
        let setup = start.elapsed().as_secs_f64();
        let info = jeffcott_analysis::ensemble::run(study, &engine, host)?;
        Ok((info, start.elapsed().as_secs_f64(), setup))
    }
    fn finish(
        study: &EnsembleStudy,
        _: &NoOptions,
        (info, elapsed, setup): Self::Outcome,
        run_dir: &jeffcott_analysis::run::RunDir,
        exec: &rundir::Execution,
    ) -> Result<()> {
        if !exec.run.quiet {
            println!(
                "backend: {} ({}; {}), precision {:?}",
                info.backend, info.device, info.reason, info.precision
            );
        }
        let info = jeffcott_core::ensemble::RunInfo {
            elapsed_s: elapsed,
            setup_s: setup,
            ..info
        };
        write_ensemble(study, &info, run_dir, exec.run.quiet)
    }
}

/// Writes an ensemble's files from its units (poincare.npy streamed, one unit in memory
/// at a time) and its record, marks the run complete and, unless `quiet`, says what ran.
fn write_ensemble(
    study: &EnsembleStudy,
    info: &jeffcott_core::ensemble::RunInfo,
    run_dir: &jeffcott_analysis::run::RunDir,
    quiet: bool,
) -> Result<()> {
    use jeffcott_analysis::ensemble::STAGE;
    let n = study.lane_count();
    let units = study.split().count();
    let dir = run_dir.path();
    output::write_npy_parts(
        &dir.join("poincare.npy"),
        &[n, study.periods as usize, STATE_DIM],
        (0..units).map(|u| Ok(run_dir.load(STAGE, u)?.f64s("poincare")?.to_vec())),
    )?;
    let mut codes: Vec<u32> = Vec::with_capacity(n);
    let mut lambda1: Vec<f64> = Vec::new();
    let mut lanes: Vec<f64> = Vec::with_capacity(n * (2 + STATE_DIM));
    let mut totals = Totals::default();
    for u in 0..units {
        let unit = run_dir.load(STAGE, u)?;
        codes.extend_from_slice(unit.u32s("status")?);
        match unit.f64s("lanes") {
            Ok(l) => lanes.extend_from_slice(l),
            // A unit of an earlier version, without its lanes: this run has them.
            Err(_) if study.given.len() == n => {
                let given = &study.given[study.split().range(u)];
                lanes.extend(jeffcott_analysis::ensemble::lanes_table(given));
            }
            Err(e) => return Err(e),
        }
        if study.lyapunov {
            lambda1.extend_from_slice(unit.f64s("lambda1")?);
        }
        totals.add(&unit.meta_as::<Totals>()?);
    }
    output::write_npy(&dir.join("status.npy"), &[n], &codes)?;
    output::write_npy(&dir.join("lanes.npy"), &[n, 2 + STATE_DIM], &lanes)?;
    output::write_npy(
        &dir.join("params.npy"),
        &[study.params.len(), Params::FIELDS.len()],
        &jeffcott_core::ensemble::table::params_table(&study.params),
    )?;
    if study.lyapunov {
        output::write_npy(&dir.join("lambda1.npy"), &[n], &lambda1)?;
    }
    let record = jeffcott_analysis::ensemble::run_record(study.sizes(), &totals, &codes, info);
    let run_json = Documented::new(
        &record,
        &[
            (
                "poincare.npy",
                "f64 [lanes, periods, 8], state order x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s",
            ),
            ("status.npy", "u32 [lanes], codes in status_codes"),
            ("lanes.npy", "f64 [lanes, 10], columns in lanes_columns"),
            (
                "lambda1.npy",
                "f64 [lanes], largest Lyapunov exponent [1/s] over the recorded periods (NaN for frozen lanes; only with --lyapunov)",
            ),
        ],
    );
    run_dir.finish(&run_json, &rundir::written(run_dir, ENSEMBLE_OUTPUTS))?;
    if !quiet {
        let s = record.status_counts;
        println!(
            "{n} lanes x {} periods in {:.2} s ({:.3e} lane-steps/s); status ok {}, refinement_cap {}, diverged {}, non_finite {}; files in {}",
            study.transient + study.periods,
            info.elapsed_s,
            totals.macro_steps as f64 / info.elapsed_s,
            s.ok,
            s.refinement_cap,
            s.diverged,
            s.non_finite,
            dir.display()
        );
    }
    Ok(())
}

/// Model parameters: Table 1 of the article unless a config file or `--param` says
/// otherwise.
#[derive(Args, Debug)]
pub struct ModelArgs {
    /// TOML file of model parameters (keys: omega_r, omega_s, xi_r, xi_s, delta, mu, m_r,
    /// m_s, e, k_c, c_c, e_max, a_g, phi0; SI units; absent keys keep Table 1 values).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Override model parameters, e.g. `--param mu=0.1,k_c=2e8` (applied after --config;
    /// repeatable).
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub param: Vec<String>,
}

impl ModelArgs {
    /// The parameters these arguments describe, validated. Only the final set is
    /// validated: a value in the config file that a `--param` override replaces is
    /// never judged (read and parse errors of the file still are errors).
    pub fn params(&self) -> Result<Params> {
        let mut p = match &self.config {
            Some(path) => Params::read_toml_file(path)?,
            None => Params::default(),
        };
        for (name, value) in parse_assignment_lists("param", &self.param)? {
            p.set(&name, value)?;
        }
        p.validate()?;
        Ok(p)
    }

    /// The names `--param` sets (an axis over one of them refuses it).
    pub fn overridden(&self) -> Result<Vec<String>> {
        Ok(parse_assignment_lists("param", &self.param)?
            .into_iter()
            .map(|(name, _)| name)
            .collect())
    }
}

/// Lane stepper settings shared by every command that integrates lanes.
#[derive(Args, Debug)]
pub struct StepperArgs {
    /// Macro steps per forcing period of the lane stepper (docs/convergence.md).
    #[arg(long, default_value_t = StepperConfig::DEFAULT.steps_per_period, value_name = "N")]
    pub steps_per_period: u32,
    /// Cap on contact switches per macro step; steps that need more are flagged.
    #[arg(long, default_value_t = StepperConfig::DEFAULT.max_segments)]
    pub max_segments: u32,
    /// A lane whose |position| exceeds this [m] is declared diverged.
    #[arg(long, default_value_t = StepperConfig::DEFAULT.divergence_bound, value_name = "METRES")]
    pub divergence_bound: f64,
    /// Contact refinement: a sub-step in contact covers at most 1/R of a macro step
    /// (1, 2, 4, 8 or 16; 1 turns it off; docs/performance.md).
    #[arg(long, default_value_t = StepperConfig::DEFAULT.contact_substeps, value_name = "R")]
    pub contact_substeps: u32,
    /// Early exit: periods a lane integrates before it may retire on a known attractor
    /// (attractor-labelling studies; docs/early-exit.md).
    #[arg(long, default_value_t = StepperConfig::DEFAULT.early_exit_after, value_name = "PERIODS")]
    pub early_exit_after: u32,
    /// Early exit: Poincare points in a row on a known attractor that retire a lane
    /// (basin; docs/early-exit.md); 0 turns early exit off (every lane runs its whole
    /// transient and record).
    #[arg(long, default_value_t = StepperConfig::DEFAULT.early_exit_streak, value_name = "M")]
    pub early_exit_streak: u32,
    /// Macro steps begun in free flight take the exact flow map of the free motion
    /// instead of RK4 (contact stays RK4); halve --steps-per-period and double
    /// --contact-substeps for the same accuracy at less cost (docs/performance.md). Lanes
    /// whose free motion is not underdamped take RK4.
    #[arg(long)]
    pub exact_free_flight: bool,
    /// lambda_1: periods the tangent vector aligns before each lane's record (it starts
    /// afresh then; 0: over the whole transient; docs/performance.md).
    #[arg(long, default_value_t = StepperConfig::DEFAULT.lyapunov_align, value_name = "PERIODS")]
    pub lyapunov_align: u32,
}

impl StepperArgs {
    /// The stepper configuration (validated where it is used).
    pub fn config(&self) -> StepperConfig {
        StepperConfig {
            steps_per_period: self.steps_per_period,
            max_segments: self.max_segments,
            divergence_bound: self.divergence_bound,
            contact_substeps: self.contact_substeps,
            early_exit_after: self.early_exit_after,
            early_exit_streak: self.early_exit_streak,
            exact_free_flight: self.exact_free_flight,
            lyapunov_align: self.lyapunov_align,
        }
    }
}

/// How a command's lanes run: the backend and precision, the model and the stepper.
/// Every command that integrates ensembles flattens it, so each of these options is
/// declared once.
#[derive(Args, Debug)]
pub struct LaneArgs {
    /// Backend: auto (a hardware GPU if present, else the CPU), cpu, or gpu (any adapter,
    /// software included; an error if none).
    #[arg(long, value_enum, default_value_t = jeffcott_core::ensemble::Backend::Auto)]
    pub backend: jeffcott_core::ensemble::Backend,
    /// Lane precision [default: f64 on the CPU, f32 on a GPU]. f64 on a GPU needs an
    /// adapter with SHADER_F64.
    #[arg(long, value_enum)]
    pub precision: Option<jeffcott_core::ensemble::Precision>,
    #[command(flatten)]
    pub model: ModelArgs,
    #[command(flatten)]
    pub stepper: StepperArgs,
}

impl LaneArgs {
    /// The precision asked for, or the backend's default.
    pub fn precision(&self) -> Precision {
        self.precision
            .unwrap_or_else(|| jeffcott_analysis::backend::default_precision(self.backend))
    }
}

/// The options every attractor-labelling study takes (basin, map, continuation,
/// basin-stability, bifurcation): how its lanes run, how their attractors are told
/// apart, and where and how the run goes.
#[derive(Args, Debug)]
pub struct StudyArgs {
    #[command(flatten)]
    pub run: LaneArgs,
    #[command(flatten)]
    pub catalogue: CatalogueArgs,
    #[command(flatten)]
    pub exec: rundir::StudyRunArgs,
}

impl StudyArgs {
    /// The study's lane settings (with lambda_1 where `lyapunov`), validated.
    pub fn settings(&self, lyapunov: bool) -> Result<jeffcott_analysis::settings::LaneSettings> {
        let precision = self.run.precision();
        Ok(jeffcott_analysis::settings::LaneSettings {
            params: self.run.model.params()?,
            stepper: self.run.stepper.config(),
            precision,
            backend: self.run.backend,
            catalogue: self.catalogue.config(precision)?,
            lyapunov,
        })
    }
}

/// Arguments of `jeffcott simulate`.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// Rotor speed W [rad/s]; the article's interesting range is 130..141.
    #[arg(long, value_name = "W")]
    pub omega: f64,
    /// Forcing periods T = 2 pi / W integrated and discarded before recording.
    #[arg(long, default_value_t = defaults::simulate::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded (one Poincare point each); at least 2 n for period n to
    /// be detectable.
    #[arg(long, default_value_t = defaults::simulate::PERIODS, value_name = "P")]
    pub periods: u32,
    /// Override coordinates of the start state (default: static equilibrium without
    /// contact), e.g. `--init x_r=0.005,vx_r=-0.5`. Names: x_r, vx_r, y_r, vy_r, x_s,
    /// vx_s, y_s, vy_s [m, m/s].
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub init: Vec<String>,
    #[command(flatten)]
    pub model: ModelArgs,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR", default_value = "jeffcott-out/simulate")]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: rundir::RunArgs,
    /// Integrator: the ensemble lane stepper (crossing-located RK4, the default) or the
    /// article's variable-step RK4 (a cross-check; slower).
    #[arg(long, value_enum, default_value_t = Integrator::Lane)]
    pub integrator: Integrator,
    #[command(flatten)]
    pub stepper: StepperArgs,
    /// Standard steps per period of the article's scheme.
    #[arg(long, default_value_t = ArticleConfig::DEFAULT.steps_per_period, value_name = "N")]
    pub article_steps: u32,
    /// Components of the article scheme's step-doubling error (E_max is in metres).
    #[arg(long, value_enum, default_value_t = ErrorNorm::Positions)]
    pub article_norm: ErrorNorm,
    /// Exponent of the article scheme's step reduction dt (E_max/E)^alpha.
    #[arg(long, default_value_t = ArticleConfig::DEFAULT.alpha)]
    pub article_alpha: f64,
    /// Periods at the end written to timeseries.npy and drawn [default: min(8, P)].
    #[arg(long, value_name = "M")]
    pub timeseries_periods: Option<u32>,
    /// Largest period the classifier looks for.
    #[arg(long, default_value_t = ClassifyConfig::DEFAULT.n_max)]
    pub n_max: usize,
    /// Classifier repeat tolerance relative to the Poincare set's size.
    #[arg(long, default_value_t = ClassifyConfig::DEFAULT.rel_tol)]
    pub rel_tol: f64,
    /// Classifier repeat tolerance floor [m].
    #[arg(long, default_value_t = ClassifyConfig::DEFAULT.abs_tol)]
    pub abs_tol: f64,
    /// Forcing periods of the stretch, continued from the final state, that the rub
    /// figures, full spectra and contact histories are taken over (a multiple of 6 shows
    /// the 1/2X, 1/3X and 2/3X lines on bins).
    #[arg(long, default_value_t = defaults::simulate::SPECTRUM_PERIODS, value_name = "S")]
    pub spectrum_periods: u32,
    /// Also write timeseries.csv, full_spectrum.csv and contact.csv.
    #[arg(long)]
    pub csv: bool,
    /// Skip phase.png, full_spectrum.png and contact.png.
    #[arg(long)]
    pub no_plot: bool,
}

pub use jeffcott_core::inputs::{
    check_coord_within_bound, check_start_within_bound, parse_assignment_lists, parse_assignments,
};

/// Applies `--init` overrides to a start state.
pub fn apply_init(x0: &mut [f64; STATE_DIM], lists: &[String]) -> Result<()> {
    jeffcott_core::inputs::set_coords("init", x0, &parse_assignment_lists("init", lists)?)
}

/// Runs `jeffcott simulate`.
pub fn run_simulate(a: &SimulateArgs) -> Result<()> {
    let params = a.model.params()?;
    let mut x0 = params.static_equilibrium();
    apply_init(&mut x0, &a.init)?;
    let spec = SimulateSpec {
        params,
        omega: a.omega,
        x0,
        transient: a.transient,
        periods: a.periods,
        timeseries_periods: a
            .timeseries_periods
            .unwrap_or(a.periods.min(defaults::simulate::TIMESERIES_PERIODS)),
        integrator: a.integrator,
        stepper: a.stepper.config(),
        article: ArticleConfig {
            steps_per_period: a.article_steps,
            alpha: a.article_alpha,
            norm: a.article_norm,
            ..ArticleConfig::default()
        },
        classify: ClassifyConfig {
            n_max: a.n_max,
            rel_tol: a.rel_tol,
            abs_tol: a.abs_tol,
        },
    };
    let study = SimulateStudy {
        spec,
        spectrum_periods: a.spectrum_periods,
    };
    study.validate()?;
    let mut outputs = vec![
        "poincare.npy",
        "timeseries.npy",
        "phase.png",
        "summary.json",
    ];
    outputs.extend_from_slice(rubout::FILES);
    let run_dir = rundir::open_whole(
        &a.out,
        "simulate",
        &SimulateRecord {
            spec: &study.spec,
            spectrum_periods: a.spectrum_periods,
        },
        &outputs,
        a.run,
    )?;
    let SimulateOutcome { result: res, rub } = run_study(&study, &rundir::cancel())?;
    let spec = study.spec;
    if let Some(o) = &rub {
        rubout::write_rub_outputs(
            &a.out,
            &format!("W = {} rad/s", spec.omega),
            &spec.params,
            o,
            &res.timeseries,
            !a.no_plot,
            a.csv,
        )?;
    }
    write_simulation(&a.out, &spec, &res, rub.as_ref(), !a.no_plot)?;
    run_dir.finish(
        &rundir::WallTime {
            wall_time_s: res.elapsed.as_secs_f64(),
        },
        &rundir::written(&run_dir, &outputs),
    )?;
    if !a.run.quiet {
        println!("{}", human_summary(&spec, &res, &a.out));
        match &rub {
            Some(o) => println!("{}", rubout::rub_sentence(o)),
            None => println!("Rub regime: diverged."),
        }
    }
    Ok(())
}

/// A simulation's specification as `run.json` records it.
#[derive(serde::Serialize)]
struct SimulateRecord<'a> {
    #[serde(flatten)]
    spec: &'a SimulateSpec,
    spectrum_periods: u32,
}

fn write_simulation(
    dir: &Path,
    spec: &SimulateSpec,
    res: &jeffcott_analysis::simulate::SimulateResult,
    rub: Option<&rubout::RubOutputs>,
    plot_it: bool,
) -> Result<()> {
    output::ensure_dir(dir)?;
    let flat = jeffcott_analysis::simulate::poincare_rows(spec, res);
    output::write_npy(
        &dir.join("poincare.npy"),
        &[spec.periods as usize, STATE_DIM],
        &flat,
    )?;
    let flat: Vec<f64> = res.timeseries.iter().flatten().copied().collect();
    output::write_npy(
        &dir.join("timeseries.npy"),
        &[res.timeseries.len(), STATE_DIM + 1],
        &flat,
    )?;
    if plot_it {
        let title = format!(
            "W = {} rad/s: {} ({} periods after {} transient)",
            spec.omega,
            res.classification.class.label(),
            spec.periods,
            spec.transient
        );
        plot::phase_portraits(
            &dir.join("phase.png"),
            &title,
            &res.timeseries,
            &res.poincare,
        )?;
    }
    let summary = Documented::new(
        jeffcott_analysis::simulate::summary(spec, res, rub),
        &[
            (
                "poincare.npy",
                "f64 [K, 8], state order x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s (m, m/s)",
            ),
            (
                "timeseries.npy",
                "f64 [M, 9], t [s] then the state, on the integrator's grid",
            ),
            (
                "phase.png",
                if plot_it {
                    "rotor and stator phase portraits and orbits"
                } else {
                    "not drawn (--no-plot)"
                },
            ),
            (
                "full_spectrum.npy",
                "f64 [bins, 4]: order (frequency / W, < 0 backward whirl), frequency [Hz], rotor and stator amplitude [m] of the full spectrum of x + i y over rub.periods periods continued from the final state (Hann window, line-calibrated)",
            ),
            (
                "contact.npy",
                "f64 [M, 5]: t [s], x_r - x_s, y_r - y_s [m], penetration g [m] (> 0 in contact), normal contact force [N], at each grid point of that stretch",
            ),
            (
                "full_spectrum.png",
                "the full spectra with 1X, 2X, 3X, 1/2X, 1/3X, 2/3X marks",
            ),
            (
                "contact.png",
                "the rotor orbit relative to the stator with the clearance circle and contact points; normal force and penetration against time",
            ),
            (
                "*.csv",
                "with --csv: timeseries.csv, full_spectrum.csv, contact.csv (the same columns, headed)",
            ),
        ],
    );
    // Written last: its presence marks a complete run.
    output::write_json(&dir.join("summary.json"), &summary)
}

fn human_summary(
    spec: &SimulateSpec,
    res: &jeffcott_analysis::simulate::SimulateResult,
    dir: &Path,
) -> String {
    use jeffcott_analysis::classify::{Class, MIN_POINTS};
    let c = &res.classification;
    let what = match c.class.period() {
        Some(1) => {
            "a period-1 response (one Poincare point, synchronous with the unbalance)".to_string()
        }
        Some(n) => format!(
            "a period-{n} response ({n} distinct Poincare points, repeating every {n} forcing periods)"
        ),
        None if c.class == Class::Diverged => format!(
            "no bounded response: the lane ended with status {:?}",
            res.status
        ),
        None if c.class == Class::Unclassified => format!(
            "an unclassified response: {} recorded Poincare point(s) are too few to classify \
             (at least {MIN_POINTS}, and 2 n to see period n; record more --periods)",
            res.poincare.len()
        ),
        None => format!(
            "an aperiodic response (no period up to {}; quasiperiodic or chaotic)",
            spec.classify.n_max
        ),
    };
    let (min, max) = res
        .poincare
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let r = ((p[0] - p[4]).powi(2) + (p[2] - p[6]).powi(2)).sqrt();
            (lo.min(r), hi.max(r))
        });
    // No recorded point (the lane froze in the transient): no distance to report, and
    // never the fold's start values (inf, -inf).
    let distance = if min.is_finite() && max.is_finite() {
        format!("{:.4} to {:.4} mm", min * 1e3, max * 1e3)
    } else {
        "no recorded points".to_string()
    };
    format!(
        "At W = {} rad/s, started from ({}), after {} transient periods the rotor settles on {}. \
         Rotor-stator distance at the Poincare points: {} (gap {} mm); the rotor is in \
         contact at {:.1}% of recorded grid points. Integrated {} periods with the {:?} integrator in \
         {:.2} s (status {:?}). Files in {}: poincare.npy, timeseries.npy, summary.json{}.",
        spec.omega,
        if spec.x0 == spec.params.static_equilibrium() {
            "static equilibrium".to_string()
        } else {
            "the given state".to_string()
        },
        spec.transient,
        what,
        distance,
        spec.params.delta * 1e3,
        100.0 * res.contact_fraction,
        spec.transient + spec.periods,
        spec.integrator,
        res.elapsed.as_secs_f64(),
        res.status,
        dir.display(),
        if dir.join("phase.png").exists() {
            ", phase.png"
        } else {
            ""
        },
    )
}
