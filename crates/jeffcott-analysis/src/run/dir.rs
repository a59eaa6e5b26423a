//! An output directory owned by one run: locked, checked for writability before any
//! computing, marked `running` then `complete` in `run.json`, holding the committed
//! units under `units/`.
//!
//! Rules (runs that survive an interruption, docs/runs.md):
//! - `run.json` is written first, with `state: "running"`, the command and the full
//!   specification; it is rewritten last with `state: "complete"`. A directory whose
//!   `run.json` says `running` is an unfinished run, whatever else it holds.
//! - The same command and specification into the same directory resumes: committed units
//!   are kept, the rest computed, and the final files are bit-identical to an
//!   uninterrupted run (every unit is deterministic, and the assembly reads the units in
//!   order).
//! - A different specification (or files of a run this version cannot read) is refused
//!   unless `overwrite`, which first removes that run's files.
//! - An exclusive lock on `.jeffcott.lock` keeps a second run out while one is writing;
//!   the operating system drops it when the process dies, SIGKILL included. The run
//!   checks before every commit and before it marks itself complete that the file at
//!   that path is still the one it locked (and that `run.json` is still its own): a lock
//!   file deleted mid-run would let a second run in, so the first stops instead of
//!   mixing its files with the second's ([`RunDirError::LockLost`]).

use super::unit::{Unit, run_fingerprint};
use crate::output;
use jeffcott_core::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Name of the run's metadata file.
pub const RUN_JSON: &str = "run.json";
/// Folder of the committed units.
pub const UNITS: &str = "units";
const LOCK: &str = ".jeffcott.lock";

/// What was found in the directory when the run opened it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Found {
    /// Nothing of a run: a fresh start.
    Fresh,
    /// An unfinished run of the same specification: resumed.
    Unfinished,
    /// A complete run of the same specification: its files are assembled again from
    /// its units (identical bits).
    Complete,
    /// Another run, removed because `overwrite` was given.
    Overwritten,
}

/// What `run.json` says of a run from the start: what it computes and how it was asked
/// for.
#[derive(Clone, Debug)]
pub struct RunHeader {
    /// The subcommand.
    pub command: String,
    /// Its specification, the run's identity: the same command and specification
    /// resume, another one is refused.
    pub spec: serde_json::Value,
    /// The shard this run computes, if any.
    pub shard: Option<super::Shard>,
    /// The command line.
    pub argv: Vec<String>,
    /// What the command's writer needs besides the study's result (its file options;
    /// `Null` for none): recorded, not part of the identity, so that `jeffcott merge`
    /// writes the files the shards' command would have.
    pub write: serde_json::Value,
    /// Specification keys the command's options spell otherwise (`basin-stability`
    /// records `--sample` as a continuation's `ics`): a refusal names the option.
    pub names: &'static [(&'static str, &'static str)],
}

impl RunHeader {
    /// The header of `command` with specification `spec`, unsharded, no command line
    /// and no writer options.
    pub fn new(command: &str, spec: &impl serde::Serialize) -> Result<RunHeader> {
        Ok(RunHeader {
            command: command.to_string(),
            spec: serde_json::to_value(spec)
                .map_err(|e| Error::invalid("run specification", command, e.to_string()))?,
            shard: None,
            argv: Vec::new(),
            write: serde_json::Value::Null,
            names: &[],
        })
    }
}

/// An output directory held by this run (see the module docs).
#[derive(Debug)]
pub struct RunDir {
    dir: PathBuf,
    command: String,
    spec: serde_json::Value,
    /// [`run_fingerprint`] of the command and specification, stamped on every unit this
    /// run commits and checked on every unit it reads.
    fingerprint: String,
    shard: Option<super::Shard>,
    argv: Vec<String>,
    write: serde_json::Value,
    found: Found,
    /// While `jeffcott merge` assembles shards: the stages whose units came from them
    /// (every unit must be there; none is computed here). Kept in run.json, so an
    /// interrupted merge resumes as one.
    merge_stages: Option<Vec<String>>,
    /// The stages the run's study asked about, in first-asked order (a shard lists
    /// them in run.json for the merge).
    stages: std::sync::Mutex<Vec<String>>,
    /// When this session opened the directory, and the wall time of the sessions
    /// before it (run.json's `wall_time_s`, kept up to date at every commit), so the
    /// wall time recorded at the end is the whole run's, however often it was resumed.
    opened: std::time::Instant,
    earlier_s: f64,
    _lock: std::fs::File,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// A differing key as the command's options spell it: its first component renamed by
/// `names`, where listed.
fn spelled(key: &str, names: &[(&str, &str)]) -> String {
    let (head, rest) = key
        .split_once('.')
        .map_or((key, None), |(h, r)| (h, Some(r)));
    match names.iter().find(|(k, _)| *k == head) {
        Some((_, name)) => rest.map_or(name.to_string(), |r| format!("{name}.{r}")),
        None => key.to_string(),
    }
}

/// The top-level keys in which two specifications differ (for the refusal message).
fn differing_keys(a: &serde_json::Value, b: &serde_json::Value) -> Vec<String> {
    match (a.as_object(), b.as_object()) {
        (Some(_), Some(_)) => {
            let mut keys = Vec::new();
            differing_paths(a, b, "", &mut keys);
            keys.sort();
            keys.dedup();
            keys
        }
        _ => vec!["(whole specification)".into()],
    }
}

/// The dotted paths (`lane.stepper.early_exit_after`) at which two JSON objects
/// differ, down to the innermost object holding a difference, so that a refusal names
/// the setting, not only the group it is in.
fn differing_paths(a: &serde_json::Value, b: &serde_json::Value, at: &str, out: &mut Vec<String>) {
    let (Some(ao), Some(bo)) = (a.as_object(), b.as_object()) else {
        out.push(at.to_string());
        return;
    };
    for k in ao.keys().chain(bo.keys()) {
        let (x, y) = (ao.get(k), bo.get(k));
        if x == y {
            continue;
        }
        let path = if at.is_empty() {
            k.clone()
        } else {
            format!("{at}.{k}")
        };
        match (x, y) {
            (Some(x), Some(y)) if x.is_object() && y.is_object() => {
                differing_paths(x, y, &path, out)
            }
            _ => out.push(path),
        }
    }
}

/// A relative path inside the directory (plain components, no `.`/`..`, not absolute):
/// what a run may remove.
fn plain_name(name: &str) -> bool {
    !name.is_empty()
        && !name.contains('\\')
        && name
            .split('/')
            .all(|c| !c.is_empty() && c != "." && c != "..")
}

/// What occupies a directory whose `run.json` (`o`) is not of this run (`command` with
/// `spec`), in words for the refusal; `names` spells the specification's keys.
fn other_run(
    o: &serde_json::Value,
    command: &str,
    spec: &serde_json::Value,
    names: &[(&str, &str)],
) -> String {
    match (o.get("command").and_then(|c| c.as_str()), o.get("spec")) {
        (Some(c), Some(s)) if c == command && s == spec => format!(
            "another shard of this `{c}` run ({})",
            o.get("shard").map_or("unsharded".into(), |s| s.to_string())
        ),
        (Some(c), Some(s)) if c == command => format!(
            "another `{c}` run (its specification differs in: {})",
            differing_keys(s, spec)
                .iter()
                .map(|k| spelled(k, names))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        (Some(c), Some(_)) => format!("a `{c}` run"),
        _ => "files of an earlier run this version cannot resume".into(),
    }
}

impl RunDir {
    /// Opens `dir` for the run `header` describes, whose final files are named
    /// `outputs`. Creates the
    /// directory, takes its lock, checks that files can
    /// be written there, compares with what the directory holds (module docs), removes
    /// temporaries a killed run left, and writes `run.json` with `state: "running"`.
    pub fn open(
        dir: &Path,
        header: RunHeader,
        outputs: &[&str],
        overwrite: bool,
    ) -> Result<RunDir> {
        let RunHeader {
            command,
            spec,
            shard,
            argv,
            write,
            names,
        } = header;
        let command = command.as_str();
        let lock = Self::lock_and_clean(dir)?;
        let old = Self::read_run_json(dir)?;
        let units_exist = dir.join(UNITS).exists();
        let outputs_exist: Vec<&str> = outputs
            .iter()
            .copied()
            .filter(|f| dir.join(f).exists())
            .collect();
        let found = match &old {
            Some(o)
                if o.get("command").and_then(|c| c.as_str()) == Some(command)
                    && o.get("spec") == Some(&spec)
                    && o.get("shard").cloned().unwrap_or(serde_json::Value::Null)
                        == serde_json::to_value(shard).unwrap_or_default() =>
            {
                match o.get("state").and_then(|s| s.as_str()) {
                    Some("complete") => Found::Complete,
                    _ => Found::Unfinished,
                }
            }
            None if !units_exist && outputs_exist.is_empty() => Found::Fresh,
            _ if overwrite => {
                Self::remove_run(dir, old.as_ref(), outputs)?;
                Found::Overwritten
            }
            Some(o) => {
                return Err(Error::layer(RunDirError::Occupied {
                    path: dir.to_path_buf(),
                    reason: other_run(o, command, &spec, names),
                }));
            }
            None => {
                return Err(Error::layer(RunDirError::Occupied {
                    path: dir.to_path_buf(),
                    reason: format!(
                        "files of another run ({}) without a run.json",
                        if outputs_exist.is_empty() {
                            UNITS.to_string()
                        } else {
                            outputs_exist.join(", ")
                        }
                    ),
                }));
            }
        };
        // A merge in progress (or done) in this directory stays one.
        let merge_stages = match (&old, found) {
            (Some(o), Found::Unfinished | Found::Complete) => o
                .get("merge_stages")
                .and_then(|v| serde_json::from_value(v.clone()).ok()),
            _ => None,
        };
        let earlier_s = match (&old, found) {
            (Some(o), Found::Unfinished | Found::Complete) => o
                .get("wall_time_s")
                .and_then(|v| v.as_f64())
                .filter(|s| s.is_finite() && *s >= 0.0)
                .unwrap_or(0.0),
            _ => 0.0,
        };
        let run_dir = RunDir {
            dir: dir.to_path_buf(),
            command: command.to_string(),
            fingerprint: run_fingerprint(command, &spec),
            spec,
            shard,
            argv,
            write,
            found,
            merge_stages,
            stages: Default::default(),
            opened: std::time::Instant::now(),
            earlier_s,
            _lock: lock,
        };
        run_dir.write_running()?;
        std::fs::create_dir_all(dir.join(UNITS)).map_err(io(&dir.join(UNITS)))?;
        Ok(run_dir)
    }

    /// Creates `dir`, takes its lock (held by the returned file), checks that files can
    /// be written there and removes the temporaries a killed run left.
    fn lock_and_clean(dir: &Path) -> Result<std::fs::File> {
        output::ensure_dir(dir)?;
        let lock_path = dir.join(LOCK);
        let lock = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .map_err(io(&lock_path))?;
        match lock.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                return Err(Error::layer(RunDirError::Busy {
                    path: dir.to_path_buf(),
                }));
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(io(&lock_path)(e)),
        }
        // Writability before any computing: a probe file through the same atomic path
        // every output takes.
        let probe = dir.join(".write-probe");
        output::write_atomically(&probe, |_| Ok(()))?;
        std::fs::remove_file(&probe).map_err(io(&probe))?;
        output::remove_temporaries(dir)?;
        output::remove_temporaries(&dir.join(UNITS))?;
        Ok(lock)
    }

    /// The directory's `run.json`, if it has one (`Null` where it is not JSON).
    fn read_run_json(dir: &Path) -> Result<Option<serde_json::Value>> {
        let run_json = dir.join(RUN_JSON);
        match std::fs::read(&run_json) {
            Ok(bytes) => Ok(Some(
                serde_json::from_slice(&bytes).unwrap_or(serde_json::Value::Null),
            )),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(io(&run_json)(e)),
        }
    }

    /// Removes the files of the run recorded in `old` (its `outputs`, and the `files` of
    /// run.json written by earlier versions), the files named `outputs`, `units/` and
    /// `run.json`. Nothing else in the directory is touched.
    fn remove_run(dir: &Path, old: Option<&serde_json::Value>, outputs: &[&str]) -> Result<()> {
        let mut names: Vec<String> = outputs.iter().map(|s| s.to_string()).collect();
        if let Some(o) = old {
            if let Some(list) = o.get("outputs").and_then(|v| v.as_array()) {
                names.extend(list.iter().filter_map(|v| v.as_str().map(String::from)));
            }
            if let Some(map) = o.get("files").and_then(|v| v.as_object()) {
                names.extend(map.keys().cloned());
            }
        }
        for name in names.iter().filter(|n| plain_name(n)) {
            let p = dir.join(name);
            match std::fs::remove_file(&p) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(io(&p)(e)),
            }
        }
        let units = dir.join(UNITS);
        if units.exists() {
            std::fs::remove_dir_all(&units).map_err(io(&units))?;
        }
        let run_json = dir.join(RUN_JSON);
        if run_json.exists() {
            std::fs::remove_file(&run_json).map_err(io(&run_json))?;
        }
        Ok(())
    }

    fn write_state(
        &self,
        state: &str,
        result: &serde_json::Map<String, serde_json::Value>,
        outputs: &[String],
    ) -> Result<()> {
        let run = RunJson {
            state,
            command: &self.command,
            spec: &self.spec,
            shard: self.shard,
            argv: &self.argv,
            write: &self.write,
            merge_stages: self.merge_stages.as_deref(),
            units_dir: UNITS,
            outputs,
            jeffcott_version: env!("CARGO_PKG_VERSION"),
            jeffcott_commit: crate::COMMIT,
            result,
        };
        output::write_json(&self.dir.join(RUN_JSON), &run)
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The shard this run computes, if any.
    pub fn shard(&self) -> Option<super::Shard> {
        self.shard
    }

    /// Makes this run the merge of shards that computed `stages`: recorded in run.json
    /// (state `running`), so the run that assembles the files, and any resumption of
    /// it, requires every unit of those stages and computes none.
    pub fn begin_merge(&mut self, stages: Vec<String>) -> Result<()> {
        self.merge_stages = Some(stages);
        self.write_running()
    }

    /// The run's wall time so far [s]: this session's and every earlier one's.
    pub fn wall_time_s(&self) -> f64 {
        self.earlier_s + self.opened.elapsed().as_secs_f64()
    }

    /// run.json with `state: "running"` and the wall time so far.
    fn write_running(&self) -> Result<()> {
        let mut time = serde_json::Map::new();
        time.insert("wall_time_s".into(), self.wall_time_s().into());
        self.write_state("running", &time, &[])
    }

    /// The stages whose units came from shards, while this directory is a merge.
    pub fn merge_stages(&self) -> Option<&[String]> {
        self.merge_stages.as_deref()
    }

    /// The stages the run's study asked about so far, in first-asked order.
    pub fn stages_asked(&self) -> Vec<String> {
        self.stages.lock().map(|s| s.clone()).unwrap_or_default()
    }

    /// Keys of the unit files committed in the directory, sorted.
    pub fn unit_keys(&self) -> Result<Vec<String>> {
        let units = self.dir.join(UNITS);
        let mut keys: Vec<String> = std::fs::read_dir(&units)
            .map_err(io(&units))?
            .flatten()
            .filter_map(|e| {
                e.file_name()
                    .to_str()
                    .and_then(|n| n.strip_suffix(".unit"))
                    .map(String::from)
            })
            .collect();
        keys.sort();
        Ok(keys)
    }

    /// What the directory held when the run opened it.
    pub fn found(&self) -> Found {
        self.found
    }

    fn unit_path(&self, stage: &str, index: usize) -> PathBuf {
        self.dir
            .join(UNITS)
            .join(format!("{stage}-{index:07}.unit"))
    }

    /// Indices of the units of `stage` committed so far and still readable. A unit file
    /// that does not read back (torn by a crash of the machine, altered) is removed, so
    /// its unit is computed again. A unit file of another run (copied in by hand, left by
    /// another specification) is an error naming it ([`RunDirError::ForeignUnit`]): it
    /// is neither assembled nor deleted.
    pub fn committed(&self, stage: &str, count: usize) -> Result<Vec<bool>> {
        if let Ok(mut s) = self.stages.lock()
            && !s.iter().any(|x| x == stage)
        {
            s.push(stage.to_string());
        }
        let mut done = vec![false; count];
        for (i, d) in done.iter_mut().enumerate() {
            let p = self.unit_path(stage, i);
            if !p.exists() {
                continue;
            }
            match Unit::read(&p) {
                Ok(u) if u.key == unit_key(stage, i) => {
                    self.check_owner(&p, &u)?;
                    *d = true
                }
                _ => std::fs::remove_file(&p).map_err(io(&p))?,
            }
        }
        Ok(done)
    }

    /// Whether unit `index` of `stage` is committed (the file exists; see [`committed`]
    /// for the check of its contents).
    ///
    /// [`committed`]: RunDir::committed
    pub fn has(&self, stage: &str, index: usize) -> bool {
        self.unit_path(stage, index).exists()
    }

    /// Commits a unit: written atomically under its final name, with the key of its
    /// stage and index whatever key the study gave it (the key is what [`committed`]
    /// checks on resume; a unit committed under another key would be thrown away there
    /// and computed again, as cascade's and continuation's ramp units once were). The
    /// lock is checked first: a run whose lock was taken from it writes nothing more.
    ///
    /// [`committed`]: RunDir::committed
    pub fn commit(&self, stage: &str, index: usize, unit: &Unit) -> Result<()> {
        self.check_lock()?;
        let key = unit_key(stage, index);
        let path = self.unit_path(stage, index);
        if unit.key == key && unit.run == self.fingerprint {
            unit.write(&path)?;
        } else {
            let mut u = unit.clone();
            u.key = key;
            u.run = self.fingerprint.clone();
            u.write(&path)?;
        }
        // The wall time so far goes with every unit, so a run killed now and resumed
        // later still records its whole time.
        self.write_running()
    }

    /// Reads a committed unit (its key and its run checked).
    pub fn load(&self, stage: &str, index: usize) -> Result<Unit> {
        let path = self.unit_path(stage, index);
        let u = Unit::read(&path)?;
        if u.key != unit_key(stage, index) {
            return Err(Error::Io {
                path,
                source: std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    "unit file holds another unit",
                ),
            });
        }
        self.check_owner(&path, &u)?;
        Ok(u)
    }

    /// Whether `u`, read from `path`, was committed by a run of this command and
    /// specification.
    fn check_owner(&self, path: &Path, u: &Unit) -> Result<()> {
        if u.run == self.fingerprint {
            return Ok(());
        }
        Err(Error::layer(RunDirError::ForeignUnit {
            path: path.to_path_buf(),
            reason: foreign_reason(&u.run, &self.fingerprint),
        }))
    }

    /// Checks that the lock file is still the one this run locked: a lock file removed
    /// mid-run (by hand, by a cleaning script) lets a second run take a lock of its own
    /// and write into the directory, so a run that finds its lock gone or replaced stops
    /// writing ([`RunDirError::LockLost`]). Called before every commit and before the run is
    /// marked complete.
    pub fn check_lock(&self) -> Result<()> {
        let path = self.dir.join(LOCK);
        let lost = || {
            Error::layer(RunDirError::LockLost {
                path: self.dir.clone(),
            })
        };
        let on_disk = std::fs::metadata(&path).map_err(|_| lost())?;
        let held = self._lock.metadata().map_err(io(&path))?;
        if same_file(&on_disk, &held) {
            Ok(())
        } else {
            Err(lost())
        }
    }

    /// Marks the run complete: `run.json` with `state: "complete"`, the run's result
    /// record `result` (a struct or map; its keys stay at the top level, and may not be
    /// the run's own keys, [`RUN_KEYS`]) and the list of final files. Call after every
    /// final file is written.
    pub fn finish<T: serde::Serialize>(&self, result: &T, outputs: &[String]) -> Result<()> {
        let bad = |what: String| Error::invalid("run result", self.command.as_str(), what);
        let map = match serde_json::to_value(result).map_err(|e| bad(e.to_string()))? {
            serde_json::Value::Object(m) => m,
            v => return Err(bad(format!("{v} is not an object"))),
        };
        // The command measured this session; the run's wall time is every session's.
        let mut map = map;
        if let Some(w) = map.get("wall_time_s").and_then(|v| v.as_f64()) {
            map.insert("wall_time_s".into(), (self.earlier_s + w).into());
        }
        if let Some(k) = RUN_KEYS.iter().find(|k| map.contains_key(**k)) {
            return Err(bad(format!(
                "the result may not set run.json's own key `{k}`"
            )));
        }
        self.check_lock()?;
        // run.json must still describe this run: another one writing here would have
        // rewritten it with its own command and specification.
        let run_json = self.dir.join(RUN_JSON);
        let now: Option<serde_json::Value> = std::fs::read(&run_json)
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok());
        let ours = now.as_ref().is_some_and(|o| {
            o.get("command").and_then(|c| c.as_str()) == Some(self.command.as_str())
                && o.get("spec") == Some(&self.spec)
                && o.get("shard").cloned().unwrap_or(serde_json::Value::Null)
                    == serde_json::to_value(self.shard).unwrap_or_default()
        });
        if !ours {
            return Err(Error::layer(RunDirError::LockLost {
                path: self.dir.clone(),
            }));
        }
        self.write_state("complete", &map, outputs)
    }
}

/// The keys of `run.json` the run itself writes (a result's `jeffcott_version`, where it
/// has one, is its own).
pub const RUN_KEYS: [&str; 10] = [
    "state",
    "command",
    "spec",
    "shard",
    "argv",
    "write",
    "merge_stages",
    "units_dir",
    "outputs",
    "jeffcott_commit",
];

/// `run.json`: how far the run got, what it computes (command, specification, shard,
/// command line), where its units are, and once complete its final files and the
/// command's result record.
#[derive(serde::Serialize)]
struct RunJson<'a> {
    /// `running` or `complete`.
    state: &'a str,
    /// The subcommand.
    command: &'a str,
    /// Its specification (the resume identity).
    spec: &'a serde_json::Value,
    /// The shard this directory computes, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    shard: Option<super::Shard>,
    /// The command line.
    argv: &'a [String],
    /// The writer's options (not part of the identity).
    #[serde(skip_serializing_if = "serde_json::Value::is_null")]
    write: &'a serde_json::Value,
    /// While a merge: the stages whose units came from the shards.
    #[serde(skip_serializing_if = "Option::is_none")]
    merge_stages: Option<&'a [String]>,
    /// Folder of the committed units.
    units_dir: &'static str,
    /// The final files, once complete.
    #[serde(skip_serializing_if = "<[String]>::is_empty")]
    outputs: &'a [String],
    /// The version that wrote the file.
    jeffcott_version: &'static str,
    /// The git commit of the build that wrote it (the version alone cannot tell two
    /// builds apart).
    jeffcott_commit: &'static str,
    /// The command's result record, at the top level (its own `jeffcott_version` wins).
    #[serde(flatten)]
    result: &'a serde_json::Map<String, serde_json::Value>,
}

/// Whether two metadata describe the same file (device and inode on Unix).
#[cfg(unix)]
fn same_file(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

/// Elsewhere a replaced lock file cannot be told from the held one; its presence is
/// what is checked.
#[cfg(not(unix))]
fn same_file(_: &std::fs::Metadata, _: &std::fs::Metadata) -> bool {
    true
}

/// Why a unit stamped `found` is not a unit of the run `ours`.
pub fn foreign_reason(found: &str, ours: &str) -> String {
    if found.is_empty() {
        "carries no run fingerprint (written by a jeffcott older than fingerprinted units)"
            .to_string()
    } else {
        format!("was committed by another run (fingerprint {found}; this run's is {ours})")
    }
}

/// The key of unit `index` of `stage`.
pub fn unit_key(stage: &str, index: usize) -> String {
    format!("{stage}-{index:07}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open(dir: &Path) -> RunDir {
        let header = RunHeader::new("basin", &serde_json::json!({"n": 3})).unwrap();
        RunDir::open(dir, header, &[], false).unwrap()
    }

    #[test]
    fn a_refusal_names_the_innermost_settings_that_differ() {
        let old = serde_json::json!({"n": 3, "lane": {"stepper": {"after": 100, "streak": 16},
            "precision": "f64"}, "gone": 1});
        let new = serde_json::json!({"n": 3, "lane": {"stepper": {"after": 30, "streak": 16},
            "precision": "f32"}, "stepper": {"after": 30}});
        assert_eq!(
            differing_keys(&old, &new),
            ["gone", "lane.precision", "lane.stepper.after", "stepper"]
        );
        assert_eq!(
            differing_keys(&old, &serde_json::json!(3)),
            ["(whole specification)"]
        );
    }

    #[test]
    fn a_merge_stays_a_merge_when_it_is_interrupted_and_resumed() {
        let tmp = tempfile::tempdir().unwrap();
        {
            let mut d = open(tmp.path());
            assert_eq!(d.merge_stages(), None);
            d.begin_merge(vec!["basin".into()]).unwrap();
        } // killed here: the lock is released, run.json says running
        let resumed = open(tmp.path());
        assert_eq!(resumed.found(), Found::Unfinished);
        assert_eq!(resumed.merge_stages(), Some(&["basin".to_string()][..]));
        let j: serde_json::Value =
            serde_json::from_slice(&std::fs::read(tmp.path().join(RUN_JSON)).unwrap()).unwrap();
        assert_eq!(j["merge_stages"], serde_json::json!(["basin"]));
    }

    #[test]
    fn another_specification_in_the_directory_does_not_inherit_a_merge() {
        let tmp = tempfile::tempdir().unwrap();
        open(tmp.path()).begin_merge(vec!["basin".into()]).unwrap();
        let header = RunHeader::new("basin", &serde_json::json!({"n": 4})).unwrap();
        let other = RunDir::open(tmp.path(), header, &[], true).unwrap();
        assert_eq!(other.found(), Found::Overwritten);
        assert_eq!(other.merge_stages(), None);
    }

    #[test]
    fn the_stages_a_study_asks_about_are_listed_once_in_first_asked_order() {
        let tmp = tempfile::tempdir().unwrap();
        let d = open(tmp.path());
        for stage in ["basin", "refine", "basin"] {
            d.committed(stage, 2).unwrap();
        }
        assert_eq!(d.stages_asked(), ["basin", "refine"]);
    }

    #[test]
    fn the_wall_time_recorded_is_the_whole_runs_over_a_kill_and_a_resume() {
        let tmp = tempfile::tempdir().unwrap();
        let first = {
            let d = open(tmp.path());
            std::thread::sleep(std::time::Duration::from_millis(30));
            d.commit("basin", 0, &Unit::new("x")).unwrap();
            let j: serde_json::Value =
                serde_json::from_slice(&std::fs::read(tmp.path().join(RUN_JSON)).unwrap()).unwrap();
            j["wall_time_s"].as_f64().unwrap()
        }; // killed here
        assert!(first >= 0.03, "{first}");
        let d = open(tmp.path());
        assert!(d.wall_time_s() >= first);
        d.finish(&serde_json::json!({"wall_time_s": 0.5}), &[])
            .unwrap();
        let j: serde_json::Value =
            serde_json::from_slice(&std::fs::read(tmp.path().join(RUN_JSON)).unwrap()).unwrap();
        assert_eq!(j["wall_time_s"].as_f64().unwrap(), first + 0.5);
    }

    #[test]
    fn a_unit_of_another_run_copied_into_the_directory_is_refused_and_kept() {
        let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let unit = Unit::new("x").with("l", super::super::Array::I32(vec![1, 2]));
        open(a.path()).commit("basin", 0, &unit).unwrap();
        let header = RunHeader::new("basin", &serde_json::json!({"n": 4})).unwrap();
        let other = RunDir::open(b.path(), header, &[], false).unwrap();
        let from = a.path().join(UNITS).join("basin-0000000.unit");
        let to = b.path().join(UNITS).join("basin-0000000.unit");
        std::fs::copy(&from, &to).unwrap();
        for e in [
            other.committed("basin", 1).unwrap_err(),
            other.load("basin", 0).unwrap_err(),
        ] {
            let e = e
                .layer_error::<RunDirError>()
                .expect("a run directory error");
            assert!(matches!(e, RunDirError::ForeignUnit { .. }), "{e}");
            assert!(e.to_string().contains("basin-0000000.unit"), "{e}");
        }
        assert!(to.exists(), "the foreign unit was removed");
        // The run's own unit reads back.
        let own = open(a.path());
        assert_eq!(own.committed("basin", 1).unwrap(), [true]);
        assert_eq!(own.load("basin", 0).unwrap().i32s("l").unwrap(), [1, 2]);
    }
}

/// What keeps a run from its output directory, or stops it there.
#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    /// Another run holds the output directory's lock.
    #[error(
        "another jeffcott run is writing into {path}; wait for it to end or choose another --out"
    )]
    Busy {
        /// The output directory.
        path: PathBuf,
    },
    /// The output directory's lock file was removed or replaced while this run held it:
    /// another run may have taken the directory, so this one writes nothing more and is
    /// not marked complete.
    #[error(
        "the lock file {path}/.jeffcott.lock was removed or replaced while this run was writing; another run may have written into {path}, so this run stopped and is not marked complete (its committed units are kept): rerun the same command when no other run writes there, or choose another --out"
    )]
    LockLost {
        /// The output directory.
        path: PathBuf,
    },
    /// The output directory holds another run.
    #[error(
        "{path} holds {reason}; choose another --out, or give --overwrite to remove that run's files first"
    )]
    Occupied {
        /// The output directory.
        path: PathBuf,
        /// What it holds.
        reason: String,
    },
    /// A unit file in the directory belongs to another run (another command or
    /// specification): it is never assembled into this run's files, nor removed.
    #[error(
        "unit file {path} {reason}; it is not this run's and was neither used nor removed: move it out of the directory and run the command again (its unit is then computed), or give --overwrite to start this run afresh"
    )]
    ForeignUnit {
        /// The unit file.
        path: PathBuf,
        /// Whose it is.
        reason: String,
    },
}
