//! `jeffcott reproduce`: regenerates the article's figure set (Figs. 3-12) plus the
//! down-sweep and brute-force diagrams it does not have, and writes `REPORT.md` with
//! every figure, what this tool found there, the equivalent command and its time.

mod article;
mod beyond;
mod report;

use crate::cli::choice::{choice, name_of};
use article::{
    BasinFigures, basin_section, bifurcation_figures, enlargement, portrait, section_figures,
};
use beyond::{cascade_section, continuation_section, design_chart, rub_map, spectrum_section};
use clap::Args;
use jeffcott_analysis::backend::default_precision;
use jeffcott_analysis::reproduce::{
    FULL, Host, QUICK, ReproduceSpec, SMOKE, STEPS, Section, reproduce,
};
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::StepperConfig;
use report::Report;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `jeffcott reproduce`.
#[derive(Args, Debug)]
pub struct ReproduceArgs {
    /// Reduced resolution, about two minutes on a 2-core CPU (the default).
    #[arg(long, conflicts_with = "full")]
    pub quick: bool,
    /// Publication resolution (2000 speeds, a 1000 x 1000 basin): meant for a GPU.
    #[arg(long)]
    pub full: bool,
    /// A tiny resolution that only checks the pipeline (for tests).
    #[arg(long, hide = true, conflicts_with_all = ["quick", "full"])]
    pub smoke: bool,
    /// Backend of the ensembles (brute force, basins, surveys).
    #[arg(long, value_parser = choice::<Backend>(), default_value = name_of(Backend::Auto))]
    pub backend: Backend,
    /// Lane precision [default: f64 on the CPU, f32 on a GPU].
    #[arg(long, value_parser = choice::<Precision>())]
    pub precision: Option<Precision>,
    /// Output directory (created if missing). An unfinished reproduce of the same mode
    /// there is resumed (its finished studies are not computed again).
    #[arg(long, value_name = "DIR", default_value = "jeffcott-out/reproduce")]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: super::rundir::RunArgs,
}

/// Runs `jeffcott reproduce`: the sections below in order, each adding its figures to
/// the report, then REPORT.md with the summary table at the top.
pub fn run_reproduce(a: &ReproduceArgs) -> Result<()> {
    let preset = if a.full {
        FULL
    } else if a.smoke {
        SMOKE
    } else {
        QUICK
    };
    let precision = a.precision.unwrap_or_else(|| default_precision(a.backend));
    let spec = ReproduceSpec::new(preset, a.backend, precision);
    let dir = a.out.as_path();
    // One run directory for the whole figure set; each study keeps its units under its
    // own prefix, so an interrupted reproduce resumes where it stopped.
    let run_dir = super::rundir::open(
        dir,
        "reproduce",
        &RunSpec {
            mode: preset.name,
            precision,
            stepper: StepperConfig::DEFAULT,
        },
        &["REPORT.md"],
        a.run,
        super::rundir::Work::Units,
    )?;
    let mut c = Ctx {
        args: a,
        spec: &spec,
        dir,
        run_dir: &run_dir,
        mode: format!("--{}", preset.name),
        backend: format!("{:?}", a.backend).to_lowercase(),
        rep: Report {
            text: String::new(),
            started: Instant::now(),
        },
    };
    let result = reproduce(&spec, &mut c)?;
    let Ctx {
        ref mode,
        ref backend,
        ref rep,
        ..
    } = c;

    // REPORT.md.
    say(a, &format!("[{STEPS}/{STEPS}] REPORT.md"));
    // The whole run's time, every session of a resumed figure set included.
    rep.write(dir, &spec, &result, mode, backend, run_dir.wall_time_s())?;
    run_dir.finish(
        &super::rundir::WallTime {
            wall_time_s: rep.started.elapsed().as_secs_f64(),
        },
        &super::rundir::files_under(dir)?,
    )?;
    if !a.run.quiet {
        println!(
            "reproduce {mode}: figures and REPORT.md in {} ({:.1} s in all)",
            dir.display(),
            run_dir.wall_time_s()
        );
    }
    Ok(())
}

/// A figure set's specification as `run.json` records it: the preset, the lanes'
/// precision and the stepper's defaults (so that a figure set begun by a version with
/// other defaults, such as early exit's first period, is not resumed with units of
/// both: the run directory names the field that differs).
#[derive(serde::Serialize)]
struct RunSpec {
    mode: &'static str,
    precision: Precision,
    stepper: StepperConfig,
}

/// The command line as the figure set's host: the arguments, the set's specification,
/// the output directory and its run (every study's units under its own prefix), and the
/// report being written. Each section draws its figures, writes its studies' files into
/// a sub-folder as the study's own command would, and adds its text.
struct Ctx<'a> {
    args: &'a ReproduceArgs,
    spec: &'a ReproduceSpec,
    dir: &'a Path,
    run_dir: &'a jeffcott_analysis::run::RunDir,
    mode: String,
    backend: String,
    rep: Report,
}

impl jeffcott_analysis::run::Host for Ctx<'_> {
    fn store(&self) -> &dyn jeffcott_analysis::run::UnitStore {
        self.run_dir
    }

    fn progress<T>(
        &self,
        stage: jeffcott_analysis::run::Stage<'_>,
        work: impl FnOnce(jeffcott_core::control::Control) -> Result<T>,
    ) -> Result<T> {
        super::rundir::progress(stage, self.args.run.quiet, work)
    }
}

impl Host for Ctx<'_> {
    fn begin(&mut self, step: usize, what: &str) {
        say(self.args, &format!("[{step}/{STEPS}] {what}"));
    }

    fn section(&mut self, section: Section<'_>) -> Result<()> {
        match section {
            Section::Bifurcation { spec, res } => bifurcation_figures(self, spec, res),
            Section::Orbits {
                study,
                branches,
                background,
                seconds,
            } => beyond::orbits_section(self, study, branches, background, seconds),
            Section::Zoom {
                k,
                spec,
                res,
                seconds,
            } => enlargement(self, k, spec, res, seconds),
            Section::Portrait { figure, at } => portrait(self, figure, at),
            Section::Basin {
                outcome,
                class,
                survey,
                seconds,
            } => basin_section(
                self,
                &BasinFigures {
                    outcome,
                    class,
                    survey,
                    seconds,
                },
            ),
            Section::PoincareSection { index, at } => section_figures(self, index, at),
            Section::DesignChart {
                spec,
                res,
                findings,
                seconds,
            } => design_chart(self, spec, res, findings, seconds),
            Section::Continuation {
                spec,
                res,
                ramps,
                seconds,
            } => continuation_section(self, spec, res, ramps, seconds),
            Section::RubMap {
                spec,
                res,
                regimes,
                throws,
                soft_modes,
                seconds,
            } => rub_map(self, spec, res, regimes, throws, soft_modes, seconds),
            Section::Cascade { spec, res, seconds } => cascade_section(self, spec, res, seconds),
            Section::Spectrum {
                omega,
                res,
                rub,
                seconds,
            } => spectrum_section(self, omega, res, rub, seconds),
        }
    }
}

/// Copies a study's picture `from` to `to` in the report's folder `dir` (atomically).
fn copy(dir: &Path, from: &Path, to: &str) -> Result<()> {
    let bytes = std::fs::read(from).map_err(|source| Error::Io {
        path: from.to_path_buf(),
        source,
    })?;
    jeffcott_analysis::output::write_atomically(&dir.join(to), |w| {
        std::io::Write::write_all(w, &bytes)
    })
}

/// A progress line on stderr (not with --quiet).
fn say(a: &ReproduceArgs, s: &str) {
    if !a.run.quiet {
        eprintln!("{s}");
    }
}
