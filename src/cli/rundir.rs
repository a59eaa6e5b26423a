//! The command line's side of the run engine ([`jeffcott_analysis::run`]): opening `--out` for a
//! run (resume or refuse, `--overwrite`), a progress bar fed by the engine's callback,
//! and the SIGINT/SIGTERM handler that stops cleanly and prints the command that resumes.

use clap::Args;
use jeffcott_analysis::run::{Found, RunDir, RunHeader, Shard, ShardStore, UnitStore};
use jeffcott_core::error::Result;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// Options every resumable command takes: may it replace another run, and may it talk.
#[derive(Args, Debug, Clone, Copy, Default)]
pub struct RunArgs {
    /// Replace the run in --out if it has another specification (its files are removed
    /// first). Without it such a directory is refused. The same command into the same
    /// --out always resumes: committed work units are kept, and the files are identical
    /// to those of an uninterrupted run.
    #[arg(long)]
    pub overwrite: bool,
    /// Print nothing but errors (no progress bar).
    #[arg(long)]
    pub quiet: bool,
}

/// Options of the study commands, whose runs can be spread over many machines: where the
/// run goes, may it replace another, may it talk, which shard it computes.
#[derive(Args, Debug, Clone, Default)]
pub struct StudyRunArgs {
    /// Output directory (created if missing) [default: jeffcott-out/ and the
    /// command's name]. An unfinished run of the same command there is resumed.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub run: RunArgs,
    /// Compute one shard of the run: `i/n` (shard i of n, 0 <= i < n; the units whose
    /// index is i modulo n) or `slurm` (i and n from the Slurm job array's
    /// SLURM_ARRAY_TASK_ID, _MIN and _COUNT). Each shard writes its own --out (its units
    /// and run.json, no final files); `jeffcott merge` turns the shard directories into
    /// the files of the unsharded run, identical to the bit. A shard resumes like any run.
    /// (`bifurcation` shards its first brute-force pass only: the merge runs the sweeps
    /// and the seeded second pass, which need the whole first pass.)
    #[arg(long, value_name = "i/n|slurm", allow_hyphen_values = true)]
    pub shard: Option<String>,
}

impl StudyRunArgs {
    /// The execution these options ask for of `command` (its --out by default
    /// `jeffcott-out/<command>`; `--shard` parsed: the environment read for `slurm`).
    pub fn execution(
        &self,
        command: &str,
        backend: jeffcott_core::ensemble::Backend,
    ) -> Result<Execution> {
        Ok(Execution {
            out: (self.out.clone()).unwrap_or_else(|| Path::new("jeffcott-out").join(command)),
            run: self.run,
            shard: self.shard.as_deref().map(Shard::parse).transpose()?,
            backend,
        })
    }
}

/// Runs `work` under a progress bar for `stage` (unless `quiet`) and the command's
/// cancel flag.
pub fn progress<T>(
    stage: jeffcott_analysis::run::Stage<'_>,
    quiet: bool,
    work: impl FnOnce(jeffcott_analysis::run::lanes::Control) -> Result<T>,
) -> Result<T> {
    let bar = crate::progress::Bar::new(stage.label, stage.total, stage.per_lane, quiet);
    let cancel = cancel();
    let cb = bar_callback(&bar);
    let r = work(jeffcott_analysis::run::lanes::Control {
        progress: &cb,
        cancel: &cancel,
    });
    bar.finish();
    r
}

/// The host a command's study runs under ([`jeffcott_analysis::run::Host`]): its run
/// directory's store ([`store`]), a progress bar per stage unless `quiet`, the
/// command's cancel flag.
pub struct CommandHost<'a> {
    store: Box<dyn UnitStore + 'a>,
    quiet: bool,
}

impl<'a> CommandHost<'a> {
    /// The host of a command writing to `run_dir`.
    pub fn new(run_dir: &'a RunDir, quiet: bool) -> Self {
        CommandHost {
            store: store(run_dir),
            quiet,
        }
    }
}

impl jeffcott_analysis::run::Host for CommandHost<'_> {
    fn store(&self) -> &dyn UnitStore {
        &*self.store
    }
    fn progress<T>(
        &self,
        stage: jeffcott_analysis::run::Stage<'_>,
        work: impl FnOnce(jeffcott_analysis::run::lanes::Control) -> Result<T>,
    ) -> Result<T> {
        progress(stage, self.quiet, work)
    }
}

/// The cancel flag a command's engine runs with.
pub fn cancel() -> jeffcott_analysis::run::Cancel {
    jeffcott_analysis::run::Cancel::new()
}

/// The store a command's study commits to: the directory, seen through its shard, or
/// while it is a merge ([`RunDir::begin_merge`]), checked for the shards' stages.
pub fn store(run_dir: &RunDir) -> Box<dyn UnitStore + '_> {
    match (run_dir.shard(), run_dir.merge_stages()) {
        (Some(shard), _) => Box::new(ShardStore {
            inner: run_dir,
            shard,
        }),
        (None, Some(stages)) => Box::new(Merged { run_dir, stages }),
        (None, None) => Box::new(Plain(run_dir)),
    }
}

struct Plain<'a>(&'a RunDir);

impl UnitStore for Plain<'_> {
    fn committed(&self, stage: &str, count: usize) -> Result<Vec<bool>> {
        self.0.committed(stage, count)
    }
    fn commit(&self, stage: &str, index: usize, unit: &jeffcott_analysis::run::Unit) -> Result<()> {
        self.0.commit(stage, index, unit)
    }
    fn load(&self, stage: &str, index: usize) -> Result<jeffcott_analysis::run::Unit> {
        self.0.load(stage, index)
    }
}

/// The merged run's store: the shards' stages must be complete.
struct Merged<'a> {
    run_dir: &'a RunDir,
    stages: &'a [String],
}

impl UnitStore for Merged<'_> {
    fn committed(&self, stage: &str, count: usize) -> Result<Vec<bool>> {
        let c = self.run_dir.committed(stage, count)?;
        if self.stages.iter().any(|s| s == stage)
            && let Some(u) = c.iter().position(|d| !d)
        {
            return Err(jeffcott_core::Error::invalid(
                "SHARD_DIR",
                jeffcott_analysis::run::dir::unit_key(stage, u),
                format!(
                    "no shard holds this unit ({} of {count} units of stage {stage} present); finish or rerun the shard that owns it",
                    c.iter().filter(|d| **d).count()
                ),
            ));
        }
        Ok(c)
    }
    fn commit(&self, stage: &str, index: usize, unit: &jeffcott_analysis::run::Unit) -> Result<()> {
        self.run_dir.commit(stage, index, unit)
    }
    fn load(&self, stage: &str, index: usize) -> Result<jeffcott_analysis::run::Unit> {
        self.run_dir.load(stage, index)
    }
}

/// What most commands' `run.json` adds once complete: the wall time of the run.
#[derive(serde::Serialize)]
pub struct WallTime {
    /// Wall time [s].
    pub wall_time_s: f64,
}

/// What a study's `run.json` adds once complete: the backend that ran its lanes (null
/// when every unit was already committed) and the wall time.
#[derive(serde::Serialize)]
pub struct BackendTime<'a> {
    /// Backend, device and precision.
    pub backend: Option<&'a jeffcott_core::ensemble::RunInfo>,
    /// Wall time [s].
    pub wall_time_s: f64,
    /// Lanes retired early and periods integrated, where the study's lanes exit early.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub early_exit: Option<jeffcott_analysis::early::EarlySaved>,
}

/// What a shard's `run.json` adds once its units are committed: their keys, and the
/// stages the shard computed (so `jeffcott merge` knows what to expect).
#[derive(serde::Serialize)]
struct ShardResult<'a> {
    /// Keys of the committed units.
    shard_units: &'a [String],
    /// Stages the shard computed.
    shard_stages: &'a [String],
}

/// Ends a shard's run: its units are committed; `run.json` says complete and lists them.
pub fn finish_shard(run_dir: &RunDir, quiet: bool) -> Result<()> {
    let keys = run_dir.unit_keys()?;
    let shard = run_dir.shard().unwrap_or(Shard { index: 0, count: 1 });
    let stages = run_dir.stages_asked();
    run_dir.finish(
        &ShardResult {
            shard_units: &keys,
            shard_stages: &stages,
        },
        &[],
    )?;
    if !quiet {
        println!(
            "shard {}/{}: {} work units committed in {}; when every shard is done: jeffcott merge --out DIR SHARD_DIR...",
            shard.index,
            shard.count,
            keys.len(),
            run_dir.path().display()
        );
    }
    Ok(())
}

/// The shell command that resumes this run: the arguments as given, `--overwrite`
/// dropped (a resume must not remove what it resumes), each quoted where needed.
fn resume_command() -> String {
    std::env::args()
        .filter(|a| a != "--overwrite")
        .map(|a| {
            if !a.is_empty()
                && a.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c))
            {
                a
            } else {
                format!("'{}'", a.replace('\'', r"'\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The directories this process writes runs into, each with whether its run commits
/// work units (false: a run computed whole, which a re-run starts over).
static RUN_DIRS: Mutex<Vec<(String, bool)>> = Mutex::new(Vec::new());

/// Adds `dir`, whose run commits work units or not (`units`), to the directories the
/// signal handler names, once (a merge opens its --out twice: to place the units, then
/// to assemble them).
fn remember(dirs: &mut Vec<(String, bool)>, dir: &Path, units: bool) {
    let name = dir.display().to_string();
    if !dirs.iter().any(|e| e.0 == name) {
        dirs.push((name, units));
    }
}

/// What the signal handler says of the directories: where committed units are kept,
/// and which runs start over.
fn interrupted_message(dirs: &[(String, bool)], command: &str) -> String {
    let list = |units: bool| -> String {
        let v: Vec<&str> = dirs
            .iter()
            .filter(|d| d.1 == units)
            .map(|d| d.0.as_str())
            .collect();
        v.join(", ")
    };
    let (kept, whole) = (list(true), list(false));
    let mut text = String::from("\njeffcott: interrupted.");
    if !kept.is_empty() {
        text += &format!(" Committed work units are kept in {kept}");
    }
    if !whole.is_empty() {
        text += &format!(
            "{}The run in {whole} is computed whole and keeps nothing",
            if kept.is_empty() { " " } else { "; " }
        );
    }
    let verb = if kept.is_empty() {
        "run it again"
    } else {
        "resume"
    };
    text + &format!("; {verb} with:\n  {command}")
}

/// Installs (once) the handler of SIGINT and SIGTERM: it waits for a file being
/// committed to be in place ([`jeffcott_analysis::output::commit_lock`]), prints which directory
/// keeps the committed units and the command that resumes, and exits with status 130.
/// Nothing else needs undoing: every file is written under a temporary name and
/// renamed, and the run's lock goes with the process.
fn install_signal_handler() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        let _ = ctrlc::set_handler(|| {
            let _guard = jeffcott_analysis::output::commit_lock();
            let dirs = RUN_DIRS.lock().map(|d| d.clone()).unwrap_or_default();
            eprintln!("{}", interrupted_message(&dirs, &resume_command()));
            std::process::exit(130);
        });
    });
}

/// How a run commits its work: in units that an interrupted run keeps and resumes, or
/// whole (`simulate`, `orbits`), where an interruption keeps nothing and the signal
/// handler says so.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Work {
    /// Work units, committed as they finish.
    Units,
    /// The whole run at its end.
    Whole,
}

/// Opens `dir` for an unsharded run (see [`RunDir::open`]), says on stderr when it
/// resumes, and arms the signal handler.
pub fn open(
    dir: &Path,
    command: &str,
    spec: &impl serde::Serialize,
    outputs: &[&str],
    args: RunArgs,
    work: Work,
) -> Result<RunDir> {
    let header = RunHeader::new(command, spec)?;
    unsharded(dir, args).open_as(header, outputs, work == Work::Units)
}

/// The execution of an unsharded run into `dir`.
fn unsharded(dir: &Path, args: RunArgs) -> Execution {
    Execution {
        out: dir.to_path_buf(),
        run: args,
        shard: None,
        backend: jeffcott_core::ensemble::Backend::Auto,
    }
}

/// How a command's run goes, whether the command line asked for it or `jeffcott merge`
/// assembles it from shards: where it writes, whether it may replace another run, which
/// shard it computes, how much it prints, which backend runs its lanes.
#[derive(Clone, Debug)]
pub struct Execution {
    /// `--out`.
    pub out: std::path::PathBuf,
    /// `--overwrite`, `--quiet`.
    pub run: RunArgs,
    /// `--shard`, parsed.
    pub shard: Option<Shard>,
    /// `--backend`.
    pub backend: jeffcott_core::ensemble::Backend,
}

impl Execution {
    /// Opens `--out` for the run `header` describes (its shard and command line filled
    /// in here), says on stderr when it resumes, and arms the signal handler.
    pub fn open(&self, header: RunHeader, outputs: &[&str]) -> Result<RunDir> {
        self.open_as(header, outputs, true)
    }

    /// [`Execution::open`] for a run that commits work units or not (`units`: what the
    /// signal handler says of its directory).
    fn open_as(&self, header: RunHeader, outputs: &[&str], units: bool) -> Result<RunDir> {
        let dir = &self.out;
        let header = RunHeader {
            shard: self.shard,
            argv: std::env::args().collect(),
            ..header
        };
        let run_dir = RunDir::open(dir, header, outputs, self.run.overwrite)?;
        if let Ok(mut d) = RUN_DIRS.lock() {
            remember(&mut d, dir, units);
        }
        install_signal_handler();
        if !self.run.quiet {
            match run_dir.found() {
                // A merge's directory says running from the moment its units are placed;
                // assembling them is no resumption.
                Found::Unfinished if run_dir.merge_stages().is_some() => {}
                Found::Unfinished => eprintln!(
                    "resuming the unfinished run in {} (committed work units, if any, are kept)",
                    dir.display()
                ),
                Found::Complete => eprintln!(
                    "{} holds this run, complete; writing its files again from its units",
                    dir.display()
                ),
                Found::Overwritten => eprintln!(
                    "--overwrite: removed the other run's files from {}",
                    dir.display()
                ),
                Found::Fresh => {}
            }
        }
        Ok(run_dir)
    }
}

/// The names among `candidates` that exist in the run's directory (for `outputs` in
/// run.json).
pub fn written(run_dir: &RunDir, candidates: &[&str]) -> Vec<String> {
    candidates
        .iter()
        .filter(|f| run_dir.path().join(f).exists())
        .map(|f| f.to_string())
        .collect()
}

/// A progress bar as the engine's callback.
pub fn bar_callback(bar: &crate::progress::Bar) -> impl Fn(u64, u64) + Sync + '_ {
    move |done, _total| bar.set(done)
}

/// Every file under `dir` (relative paths), the run's own bookkeeping (run.json, the
/// lock, units/) aside: the outputs of a composite run such as `reproduce`.
pub fn files_under(dir: &Path) -> Result<Vec<String>> {
    fn walk(root: &Path, sub: &Path, out: &mut Vec<String>) -> Result<()> {
        let here = root.join(sub);
        let entries = std::fs::read_dir(&here).map_err(|source| jeffcott_core::Error::Io {
            path: here.clone(),
            source,
        })?;
        for e in entries.flatten() {
            let rel = sub.join(e.file_name());
            let name = rel.to_string_lossy().to_string();
            if name == jeffcott_analysis::run::dir::RUN_JSON
                || name == jeffcott_analysis::run::dir::UNITS
                || name.starts_with('.')
            {
                continue;
            }
            if e.path().is_dir() {
                walk(root, &rel, out)?;
            } else {
                out.push(name);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, Path::new(""), &mut out)?;
    out.sort();
    Ok(out)
}

/// Marks a study's run complete once its files are written: the backend that ran its
/// lanes, the wall time, the outputs present among `outputs`.
pub fn finish_study(
    run_dir: &RunDir,
    outputs: &[&str],
    backend: Option<&jeffcott_core::ensemble::RunInfo>,
    wall_time_s: f64,
    early_exit: Option<jeffcott_analysis::early::EarlySaved>,
) -> Result<()> {
    run_dir.finish(
        &BackendTime {
            backend,
            wall_time_s,
            early_exit,
        },
        &written(run_dir, outputs),
    )
}

#[cfg(test)]
mod tests {
    use super::{interrupted_message, remember};

    #[test]
    fn a_directory_opened_twice_is_named_once() {
        let mut dirs = Vec::new();
        remember(&mut dirs, std::path::Path::new("m"), true);
        remember(&mut dirs, std::path::Path::new("m"), true);
        remember(&mut dirs, std::path::Path::new("n"), true);
        assert_eq!(dirs, [("m".to_string(), true), ("n".to_string(), true)]);
    }

    #[test]
    fn an_interrupted_run_says_what_it_keeps_and_a_whole_run_that_it_keeps_nothing() {
        let units = interrupted_message(&[("b".into(), true)], "jeffcott basin");
        assert!(
            units.contains("kept in b; resume with:\n  jeffcott basin"),
            "{units}"
        );
        let whole = interrupted_message(&[("o".into(), false)], "jeffcott orbits");
        assert!(!whole.contains("kept in"), "{whole}");
        assert!(whole.contains("o is computed whole and keeps nothing; run it again with"));
    }
}
