//! Command-line interface: argument parsing, file writing, human summaries. Nothing
//! numerical lives here (docs/architecture.md). This file holds the command enum, its
//! dispatch and the argument groups commands share; each command is in `cli/<command>.rs`.

use choice::{choice, name_of};
use clap::{Args, Parser, Subcommand};
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM};
use std::path::PathBuf;

mod basin;
mod bench;
mod bifurcation;
mod cascade;
mod choice;
mod continuation;
mod ensemble;
mod exit;
mod explore;
pub mod files;
mod info;
pub mod map;
mod merge;
pub mod orbits;
mod reproduce;
pub mod rubout;
pub mod rundir;
mod simulate;
mod stability;
pub mod study;
mod usage;
pub use basin::{BasinArgs, run_basin};
pub use bench::{BenchArgs, run_bench};
pub use bifurcation::{BifurcationArgs, CatalogueArgs, SweepArg, run_bifurcation};
pub use cascade::{CascadeArgs, run_cascade};
pub use continuation::{ContinuationArgs, run_continuation};
pub use ensemble::{Ensemble, EnsembleArgs, run_ensemble};
pub use exit::{EXIT_CODES, exit_code};
pub use explore::{ExploreArgs, run_explore};
pub use info::{InfoArgs, run_info};
pub use map::{MapArgs, run_map};
pub use merge::{MergeArgs, run_merge};
pub use usage::one_line_usage_error;
pub mod lyapunov;
pub use reproduce::{ReproduceArgs, run_reproduce};
pub use simulate::{SimulateArgs, run_simulate};
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
    /// Explore in the browser: a local web server and its page, with a bifurcation
    /// diagram and a basin whose zoom recomputes the region, and a click that opens one
    /// lane's trajectory, attractor and Floquet multipliers (docs/explore.md).
    #[command(allow_negative_numbers = true)]
    Explore(ExploreArgs),
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
        Command::Explore(a) => run_explore(a),
    }
}
/// The writer options of a command that has none (run.json's `write` is `{}`).
#[derive(serde::Serialize, serde::Deserialize)]
pub struct NoOptions {}

/// Model parameters: Table 1 of the article unless a config file or `--param` says
/// otherwise.
#[derive(Args, Debug)]
pub struct ModelArgs {
    /// TOML file of model parameters (keys: omega_r, omega_s, xi_r, xi_s, delta, mu, m_r,
    /// m_s, e, k_c, c_c, e_max, a_g, phi0; per direction omega_rx, omega_ry, xi_rx, xi_ry,
    /// omega_sx, omega_sy, xi_sx, xi_sy and the stator's offset o_x, o_y; or a machine's
    /// k_r, c_r, k_s, c_s [N/m, N s/m], per direction k_rx, ..., c_sy, and unbalance
    /// [kg m] in place of the frequencies, damping ratios and e; SI units; absent keys
    /// keep Table 1 values; docs/parameters.md).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Override model parameters, e.g. `--param mu=0.1,k_c=2e8` (the config file's keys;
    /// applied after --config; repeatable).
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
        let pairs = parse_assignment_lists("param", &self.param)?;
        jeffcott_core::inputs::apply_pairs(&mut p, &pairs)?;
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
    #[arg(long, value_parser = choice::<Backend>(), default_value = name_of(Backend::Auto))]
    pub backend: Backend,
    /// Lane precision [default: f64 on the CPU, f32 on a GPU]. f64 on a GPU needs an
    /// adapter with SHADER_F64.
    #[arg(long, value_parser = choice::<Precision>())]
    pub precision: Option<Precision>,
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

pub use jeffcott_core::inputs::{
    check_coord_within_bound, check_start_within_bound, parse_assignment_lists, parse_assignments,
};

/// Applies `--init` overrides to a start state.
pub fn apply_init(x0: &mut [f64; STATE_DIM], lists: &[String]) -> Result<()> {
    jeffcott_core::inputs::set_coords("init", x0, &parse_assignment_lists("init", lists)?)
}
