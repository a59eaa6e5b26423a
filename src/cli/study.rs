//! The shardable study commands (`ensemble`, `basin`, `map`, `continuation`,
//! `basin-stability`, `bifurcation`) run one way, [`execute`]: from their arguments, or by `jeffcott merge`
//! from the specification and writer options their shards recorded in run.json
//! ([`execute_recorded`]), never by parsing a command line again.

use super::rundir::{CommandHost, Execution, StudyRunArgs, finish_shard};
use jeffcott_analysis::record::StudySpec;
use jeffcott_analysis::run::{RunDir, RunHeader, ShardDone};
use jeffcott_core::ensemble::Backend;
use jeffcott_core::error::{Error, Result};
use serde::{Serialize, de::DeserializeOwned};

/// A study command: its specification, the writer's options, and how the study is run
/// and its files written.
pub trait StudyCommand {
    /// The subcommand (run.json's `command`).
    const COMMAND: &'static str;
    /// Its final files (run.json aside).
    const OUTPUTS: &'static [&'static str];
    /// Specification keys its options spell otherwise (key, option), for refusals.
    const SPEC_NAMES: &'static [(&'static str, &'static str)] = &[];
    /// The study's specification: run.json's `spec` ([`StudySpec::resolved`]), the
    /// run's identity.
    type Spec: StudySpec;
    /// What the writer needs besides the study's result (file options): run.json's
    /// `write`, not part of the identity.
    type Write: Serialize + DeserializeOwned;
    /// What the study computes.
    type Outcome;
    /// Runs every stage of the study on `host` (a shard's end is
    /// [`ShardDone`]).
    fn run(spec: &Self::Spec, write: &Self::Write, host: &CommandHost) -> Result<Self::Outcome>;
    /// Writes the files, marks the run complete and says what it found.
    fn finish(
        spec: &Self::Spec,
        write: &Self::Write,
        outcome: Self::Outcome,
        run_dir: &RunDir,
        exec: &Execution,
    ) -> Result<()>;
}

/// Runs study `C` as its command line asks: `spec`, the writer options `write`, the
/// run options (`--out`, by default `jeffcott-out/<command>`; `--overwrite`, `--quiet`,
/// `--shard`) and `--backend`.
pub fn execute_args<C: StudyCommand>(
    spec: &C::Spec,
    write: &C::Write,
    args: &StudyRunArgs,
    backend: Backend,
) -> Result<()> {
    execute::<C>(spec, write, &args.execution(C::COMMAND, backend)?)
}

/// Runs study `C` with `spec` and writer options `write` as `exec` says: opens `--out`
/// (resume, refuse or replace), runs the study under the command's host, and either ends
/// a shard or writes the files.
pub fn execute<C: StudyCommand>(spec: &C::Spec, write: &C::Write, exec: &Execution) -> Result<()> {
    let header = RunHeader {
        write: serde_json::to_value(write)
            .map_err(|e| Error::invalid("run specification", C::COMMAND, e.to_string()))?,
        names: C::SPEC_NAMES,
        ..RunHeader::new(C::COMMAND, &spec.resolved())?
    };
    let run_dir = exec.open(header, C::OUTPUTS)?;
    match C::run(spec, write, &CommandHost::new(&run_dir, exec.run.quiet)) {
        Err(e) if e.layer_error::<ShardDone>().is_some() => finish_shard(&run_dir, exec.run.quiet),
        r => C::finish(spec, write, r?, &run_dir, exec),
    }
}

/// [`execute`] for the specification and writer options a shard recorded (`spec` and
/// `write` of its run.json); `shard_dir` names the shard in errors.
pub fn execute_recorded<C: StudyCommand>(
    spec: &serde_json::Value,
    write: &serde_json::Value,
    shard_dir: &std::path::Path,
    exec: &Execution,
) -> Result<()> {
    let unreadable = |what: &str, e: serde_json::Error| {
        Error::invalid(
            "SHARD_DIR",
            shard_dir.display(),
            format!(
                "its run.json's {what} does not read as a `{}` run's ({e}); run the shard's command again with this version (it keeps the committed units) and merge again",
                C::COMMAND
            ),
        )
    };
    let mut spec: C::Spec =
        serde_json::from_value(spec.clone()).map_err(|e| unreadable("spec", e))?;
    spec.set_backend(exec.backend);
    let write: C::Write =
        serde_json::from_value(write.clone()).map_err(|e| unreadable("write", e))?;
    execute::<C>(&spec, &write, exec)
}

/// Declares `jeffcott $name`, a study whose one writer option is `--no-plot` ([`Plot`])
/// and whose run.json adds its backend and wall time (its outcome has `info` and
/// `seconds`): the command `$cmd` ([`StudyCommand`]) and `$run_cmd(&$args)`, which runs it
/// as the command line asks. The study is computed by `$study(spec, engine, host)` (an
/// analysis crate's `run`) and written by the invoking module's
/// `write_study(out, spec, outcome, plot)` (returns the line printed unless `--quiet`),
/// or, with `write: w, summary: s`, by `w(out, spec, outcome, plot)` and the line
/// `s(spec, outcome, out)`; with its `OUTPUTS`; the module gets the aliases `Spec` and
/// `Outcome`.
macro_rules! plot_study {
    // A writer `$write(out, spec, outcome, plot)` and a summary line
    // `$summary(spec, outcome, out)` printed after it.
    ($cmd:ident, $name:literal, $args:ty => $run_cmd:ident, $study:path, $spec:ty, $outcome:ty,
     write: $write:path, summary: $summary:path) => {
        /// Writes the study's files; returns its summary line.
        fn write_study(
            out: &std::path::Path,
            spec: &Spec,
            res: &Outcome,
            plot: bool,
        ) -> jeffcott_core::error::Result<String> {
            $write(out, spec, res, plot)?;
            Ok($summary(spec, res, out))
        }
        $crate::cli::study::plot_study!($cmd, $name, $args => $run_cmd, $study, $spec, $outcome);
    };
    // The module's own `write_study(out, spec, outcome, plot)`, which returns the line.
    ($cmd:ident, $name:literal, $args:ty => $run_cmd:ident, $study:path, $spec:ty, $outcome:ty
     $(, names: $names:expr)?) => {
        #[doc = concat!("The spec of `jeffcott ", $name, "`.")]
        type Spec = $spec;
        #[doc = concat!("The computed study of `jeffcott ", $name, "`.")]
        type Outcome = $outcome;

        #[doc = concat!("Runs `jeffcott ", $name, "`.")]
        pub fn $run_cmd(a: &$args) -> jeffcott_core::error::Result<()> {
            let plot = $crate::cli::study::Plot { plot: !a.no_plot };
            $crate::cli::study::execute_args::<$cmd>(
                &a.spec()?,
                &plot,
                &a.study.exec,
                a.study.run.backend,
            )
        }

        #[doc = concat!("`jeffcott ", $name, "` as a study command.")]
        pub struct $cmd;

        impl $crate::cli::study::StudyCommand for $cmd {
            const COMMAND: &'static str = $name;
            const OUTPUTS: &'static [&'static str] = OUTPUTS;
            $(const SPEC_NAMES: &'static [(&'static str, &'static str)] = $names;)?
            type Spec = $spec;
            type Write = $crate::cli::study::Plot;
            type Outcome = $outcome;
            fn run(
                spec: &$spec,
                _: &Self::Write,
                host: &$crate::cli::rundir::CommandHost,
            ) -> jeffcott_core::error::Result<$outcome> {
                let engine = jeffcott_analysis::backend::Engine::new(
                    spec.lane.backend,
                    spec.lane.precision,
                )?;
                $study(spec, &engine, host)
            }
            fn finish(
                spec: &$spec,
                w: &Self::Write,
                res: $outcome,
                run_dir: &jeffcott_analysis::run::RunDir,
                exec: &$crate::cli::rundir::Execution,
            ) -> jeffcott_core::error::Result<()> {
                let line = write_study(&exec.out, spec, &res, w.plot)?;
                $crate::cli::rundir::finish_study(
                    run_dir,
                    OUTPUTS,
                    res.info.as_ref(),
                    res.seconds,
                    $crate::cli::study::EarlyExitRecord::early_exit(&res),
                )?;
                if !exec.run.quiet {
                    println!("{line}");
                }
                Ok(())
            }
        }
    };
}
pub(crate) use plot_study;

/// What early exit saved in a study's outcome, for its run.json (none by default).
pub trait EarlyExitRecord {
    /// Lanes retired early and periods integrated, when the lanes exited early.
    fn early_exit(&self) -> Option<jeffcott_analysis::early::EarlySaved> {
        None
    }
}

impl EarlyExitRecord for jeffcott_analysis::continuation::ContinuationResult {
    fn early_exit(&self) -> Option<jeffcott_analysis::early::EarlySaved> {
        self.early_exit
    }
}

impl EarlyExitRecord for jeffcott_analysis::map::MapResult {
    fn early_exit(&self) -> Option<jeffcott_analysis::early::EarlySaved> {
        self.early_exit
    }
}

/// The writer options of the commands whose only file option is `--no-plot`.
#[derive(Clone, Copy, Debug, Serialize, serde::Deserialize)]
pub struct Plot {
    /// Draw the pictures.
    pub plot: bool,
}
