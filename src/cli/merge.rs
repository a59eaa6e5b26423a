//! `jeffcott merge`: shard directories of one run (`--shard i/n` on n machines, e.g. a
//! Slurm job array) into the files of the unsharded run.
//!
//! Checks that every shard carries the same command and specification and that the
//! shards are 0..n, each once; copies (hard-links where it can) every shard's units into
//! `--out`; then runs the shards' own command into `--out`, where every unit of the
//! stages the shards computed must be present (a missing one is an error, never computed
//! here), so the files come from the one assembly code path an unsharded run takes
//! ([`super::study::execute`], fed the specification and writer options the shards
//! recorded in run.json; an ensemble's lanes are in its units), reading the units in
//! unit order: the result is identical to the unsharded run's for
//! any n and any order of the shard directories. A bifurcation's quasistatic sweeps and
//! its seeded second brute-force pass need the whole first pass: the merge computes them.

use super::rundir::{self, RunArgs};
use super::study::execute_recorded;
use crate::cli::choice::{choice, name_of};
use clap::Args;
use jeffcott_analysis::run::dir::{RUN_JSON, UNITS};
use jeffcott_core::ensemble::Backend;
use jeffcott_core::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Arguments of `jeffcott merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The shard directories (any order).
    #[arg(value_name = "SHARD_DIR", required = true)]
    pub shards: Vec<PathBuf>,
    /// Output directory of the merged run (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: RunArgs,
    /// Backend of what the merge computes itself (a bifurcation's sweeps, a basin's
    /// traces and rub figures): auto (a hardware GPU if present, else the CPU), cpu, or
    /// gpu. Results are the same on either: the backends agree to the bit.
    #[arg(long, value_parser = choice::<Backend>(), default_value = name_of(Backend::Auto))]
    pub backend: Backend,
}

/// What a shard directory's run.json says.
struct ShardRun {
    dir: PathBuf,
    command: String,
    spec: serde_json::Value,
    version: String,
    write: serde_json::Value,
    index: usize,
    count: usize,
    units: Vec<String>,
    stages: Vec<String>,
}

fn read_shard(dir: &Path) -> Result<ShardRun> {
    let path = dir.join(RUN_JSON);
    let bad = |why: &str| Error::invalid("SHARD_DIR", dir.display(), why.to_string());
    let bytes = std::fs::read(&path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => bad("has no run.json: not a shard directory"),
        _ => Error::Io {
            path: path.clone(),
            source,
        },
    })?;
    let j: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|_| bad("its run.json is not readable JSON"))?;
    if j["state"] != "complete" {
        return Err(bad(
            "is an unfinished shard (run.json state is not complete): run its command again to finish it",
        ));
    }
    let shard = &j["shard"];
    let (Some(index), Some(count)) = (shard["index"].as_u64(), shard["count"].as_u64()) else {
        return Err(bad("is not a shard directory (run.json has no shard)"));
    };
    // A key the merge compares must be there: a shard without one would otherwise be
    // compared as empty, and the good shards blamed for differing from it.
    for key in ["command", "spec", "jeffcott_version"] {
        if j.get(key).is_none_or(|v| v.is_null()) {
            return Err(bad(&format!("its run.json lacks `{key}`")));
        }
    }
    let strings = |v: &serde_json::Value| -> Vec<String> {
        v.as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|s| s.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default()
    };
    Ok(ShardRun {
        dir: dir.to_path_buf(),
        command: j["command"].as_str().unwrap_or_default().to_string(),
        spec: j["spec"].clone(),
        version: j["jeffcott_version"]
            .as_str()
            .unwrap_or_default()
            .to_string(),
        write: j["write"].clone(),
        index: index as usize,
        count: count as usize,
        units: strings(&j["shard_units"]),
        stages: strings(&j["shard_stages"]),
    })
}

/// The unit index of a unit key (`stage-NNNNNNN`).
fn unit_index(key: &str) -> Option<usize> {
    key.rsplit_once('-').and_then(|(_, n)| n.parse().ok())
}

/// Places a unit file into the merged run: a hard link where the file system allows,
/// else a copy through a temporary.
fn place(from: &Path, to: &Path) -> Result<()> {
    if to.exists() {
        return Ok(());
    }
    if std::fs::hard_link(from, to).is_ok() {
        return Ok(());
    }
    let bytes = std::fs::read(from).map_err(|source| Error::Io {
        path: from.to_path_buf(),
        source,
    })?;
    jeffcott_analysis::output::write_atomically(to, |w| std::io::Write::write_all(w, &bytes))
}

/// `p` with every symbolic link and `..` resolved, also where its last components do not
/// exist yet (those are appended to the resolved part that does).
fn resolved(p: &Path) -> PathBuf {
    let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let mut tail = Vec::new();
    let mut head = abs.as_path();
    loop {
        if let Ok(c) = head.canonicalize() {
            return tail.iter().rev().fold(c, |acc, part| acc.join(part));
        }
        match (head.parent(), head.file_name()) {
            (Some(parent), Some(name)) => {
                tail.push(name.to_owned());
                head = parent;
            }
            _ => return abs,
        }
    }
}

/// Refuses an `--out` that is one of the shard directories, holds one or lies inside
/// one: `--overwrite` would remove a shard's units before they are read, and a merge
/// inside a shard would mix its files with the shard's.
fn check_out_apart(out: &Path, shards: &[PathBuf]) -> Result<()> {
    let o = resolved(out);
    for s in shards {
        let d = resolved(s);
        let how = if o == d {
            "is"
        } else if d.starts_with(&o) {
            "contains"
        } else if o.starts_with(&d) {
            "lies inside"
        } else {
            continue;
        };
        return Err(Error::invalid(
            "--out",
            out.display(),
            format!(
                "{how} the shard directory {}: the merged run needs a directory of its own, apart from every shard",
                s.display()
            ),
        ));
    }
    Ok(())
}

/// Checks that the shards are one run's, computed by one version, each of 0..n once;
/// returns n.
fn check_shards(shards: &[ShardRun], quiet: bool) -> Result<usize> {
    // Every refusal names the shard directory at fault.
    let refuse = |s: &ShardRun, why: String| Err(Error::invalid("SHARD_DIR", s.dir.display(), why));
    let first = &shards[0];
    for s in &shards[1..] {
        if s.version != first.version {
            return refuse(
                s,
                format!(
                    "was computed by jeffcott {} and {} by jeffcott {}: the shards of one run come from one version; rerun them with one build",
                    s.version,
                    first.dir.display(),
                    first.version
                ),
            );
        }
    }
    if first.version != env!("CARGO_PKG_VERSION") && !quiet {
        eprintln!(
            "note: the shards were computed by jeffcott {}; this is jeffcott {}, which assembles them",
            first.version,
            env!("CARGO_PKG_VERSION")
        );
    }
    for s in &shards[1..] {
        if s.command != first.command || s.spec != first.spec || s.count != first.count {
            return refuse(
                s,
                format!(
                    "is a shard of another run than {} (command, specification or shard count differ)",
                    first.dir.display()
                ),
            );
        }
    }
    let n = first.count;
    let mut by_index: Vec<Option<&ShardRun>> = vec![None; n];
    for s in shards {
        if let Some(other) = by_index[s.index] {
            return refuse(
                s,
                format!(
                    "duplicates shard {}/{n}, already given as {}",
                    s.index,
                    other.dir.display()
                ),
            );
        }
        by_index[s.index] = Some(s);
    }
    let missing: Vec<String> = (0..n)
        .filter(|&i| by_index[i].is_none())
        .map(|i| i.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(Error::invalid(
            "SHARD_DIR",
            format!("{} of {n} shards given", n - missing.len()),
            format!(
                "shard(s) {} missing (with Slurm: sbatch --array={} the array script again)",
                missing.join(", "),
                missing.join(",")
            ),
        ));
    }
    Ok(n)
}

/// Reads back every unit each shard lists, before anything is written to `--out`: a
/// unit of another shard, a missing, corrupt or swapped file, or a unit another run
/// committed (its fingerprint is not the run's) is named, with its shard.
fn check_units(shards: &[ShardRun], n: usize, out: &Path) -> Result<()> {
    let ours = jeffcott_analysis::run::run_fingerprint(&shards[0].command, &shards[0].spec);
    for s in shards {
        for key in &s.units {
            match unit_index(key) {
                Some(u) if u % n == s.index => {}
                _ => {
                    return Err(Error::invalid(
                        "SHARD_DIR",
                        s.dir.display(),
                        format!("holds unit {key}, which is not shard {}/{n}'s", s.index),
                    ));
                }
            }
            let f = s.dir.join(UNITS).join(format!("{key}.unit"));
            if !f.exists() {
                return Err(Error::invalid(
                    "SHARD_DIR",
                    s.dir.display(),
                    format!("lacks unit file {} that its run.json lists", f.display()),
                ));
            }
            // Each unit is read back whole before anything is written to --out: a
            // corrupt, truncated or swapped file is named here, with its shard.
            let recompute = "run that shard's command again (it recomputes the unit)";
            let (what, remedy) = match jeffcott_analysis::run::Unit::read(&f) {
                Ok(u) if u.key != *key => (
                    format!("is corrupt (it holds unit {} instead)", u.key),
                    recompute,
                ),
                Ok(u) if u.run != ours => (
                    jeffcott_analysis::run::dir::foreign_reason(&u.run, &ours),
                    "move it out of that shard's units/ and run the shard's command again (it computes the unit)",
                ),
                Ok(_) => continue,
                Err(Error::Io { source, .. }) => (format!("is corrupt ({source})"), recompute),
                Err(e) => (format!("is corrupt ({e})"), recompute),
            };
            return Err(Error::invalid(
                "SHARD_DIR",
                s.dir.display(),
                format!(
                    "unit file {} of shard {}/{n} {what}; {remedy}, then merge again; nothing was written to {}",
                    f.display(),
                    s.index,
                    out.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Runs `jeffcott merge`.
pub fn run_merge(a: &MergeArgs) -> Result<()> {
    let t = std::time::Instant::now();
    check_out_apart(&a.out, &a.shards)?;
    let shards: Vec<ShardRun> = a
        .shards
        .iter()
        .map(|d| read_shard(d))
        .collect::<Result<_>>()?;
    let n = check_shards(&shards, a.run.quiet)?;
    check_units(&shards, n, &a.out)?;
    let first = &shards[0];
    let outputs: &[&str] = match first.command.as_str() {
        "basin" => super::basin::OUTPUTS,
        "ensemble" => super::ensemble::ENSEMBLE_OUTPUTS,
        "bifurcation" => super::bifurcation::OUTPUTS,
        "map" => super::map::OUTPUTS,
        "continuation" => super::continuation::OUTPUTS,
        "basin-stability" => super::stability::OUTPUTS,
        "lyapunov" => super::lyapunov::OUTPUTS,
        c => {
            return Err(Error::invalid(
                "SHARD_DIR",
                first.dir.display(),
                format!("holds a `{c}` run, which cannot be sharded"),
            ));
        }
    };
    let mut stages: Vec<String> = shards.iter().flat_map(|s| s.stages.clone()).collect();
    stages.sort();
    stages.dedup();
    {
        let mut run_dir = rundir::open(
            &a.out,
            &first.command,
            &first.spec,
            outputs,
            a.run,
            rundir::Work::Units,
        )?;
        run_dir.begin_merge(stages)?;
        for s in &shards {
            for key in &s.units {
                place(
                    &s.dir.join(UNITS).join(format!("{key}.unit")),
                    &run_dir.path().join(UNITS).join(format!("{key}.unit")),
                )?;
            }
        }
        jeffcott_analysis::output::sync_dir(&run_dir.path().join(UNITS));
    } // the lock is released here; the assembly takes it again
    let exec = rundir::Execution {
        out: a.out.clone(),
        run: a.run,
        shard: None,
        backend: a.backend,
    };
    let (spec, write, dir) = (&first.spec, &first.write, first.dir.as_path());
    let r = match first.command.as_str() {
        "basin" => execute_recorded::<super::basin::Basin>(spec, write, dir, &exec),
        "map" => execute_recorded::<super::map::Map>(spec, write, dir, &exec),
        "continuation" => {
            execute_recorded::<super::continuation::Continuation>(spec, write, dir, &exec)
        }
        "basin-stability" => {
            execute_recorded::<super::stability::Stability>(spec, write, dir, &exec)
        }
        "bifurcation" => {
            execute_recorded::<super::bifurcation::Bifurcation>(spec, write, dir, &exec)
        }
        "lyapunov" => execute_recorded::<super::lyapunov::Lyapunov>(spec, write, dir, &exec),
        // The ensemble, the one other command the check above lets through.
        _ => execute_recorded::<super::Ensemble>(spec, write, dir, &exec),
    };
    if r.is_err() {
        eprintln!(
            "note: {} is left as an unfinished merge (its run.json says running); the same merge command resumes it once the cause below is mended",
            a.out.display()
        );
    }
    r?;
    if !a.run.quiet {
        println!(
            "merged {n} shards of a `{}` run into {} in {:.2} s",
            first.command,
            a.out.display(),
            t.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
