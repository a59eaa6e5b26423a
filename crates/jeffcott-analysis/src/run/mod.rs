//! The run engine under every study: a study is a deterministic list of work units
//! (chunks of lanes; for a quasistatic sweep, groups of its steps), each computed and
//! then committed to the output directory as it finishes ([`RunDir`]); the study's files
//! are assembled from the committed units, in unit order, once all exist. So:
//!
//! - an interrupted run loses at most the units in flight, and the same command resumes
//!   it; the final files are bit-identical to an uninterrupted run's;
//! - analysis code never knows whether a unit was computed by this process or an earlier
//!   one, on the CPU or a GPU;
//! - nothing half-written ever sits under a final name ([`crate::output`]), and
//!   `run.json` says `running` until the last final file is in place.
//!
//! Units are sized by [`unit_lanes`]: at most ~5 % of the run and at most ~25 s of CPU
//! work each. A GPU runs several units per dispatch batch ([`lanes`]), sized from the
//! measured speed, so unit size never costs GPU throughput.

pub mod dir;
pub mod host;
pub mod lanes;
pub mod unit;

pub use dir::{Found, RunDir, RunHeader};
pub use host::{Host, MemoryHost, PrefixedHost, Stage};
pub use unit::{Array, Unit, run_fingerprint};

use jeffcott_core::error::{Error, Result};
use std::collections::HashMap;
use std::sync::Mutex;

/// Where committed units live: an output directory ([`RunDir`]) or memory
/// ([`MemoryStore`], for library calls that want results, not files). Studies see only
/// this trait.
pub trait UnitStore: Sync {
    /// Which of the `count` units of `stage` are committed (and read back whole).
    fn committed(&self, stage: &str, count: usize) -> Result<Vec<bool>>;
    /// Commits unit `index` of `stage`.
    fn commit(&self, stage: &str, index: usize, unit: &Unit) -> Result<()>;
    /// Reads committed unit `index` of `stage`.
    fn load(&self, stage: &str, index: usize) -> Result<Unit>;
}

impl UnitStore for RunDir {
    fn committed(&self, stage: &str, count: usize) -> Result<Vec<bool>> {
        RunDir::committed(self, stage, count)
    }
    fn commit(&self, stage: &str, index: usize, unit: &Unit) -> Result<()> {
        RunDir::commit(self, stage, index, unit)
    }
    fn load(&self, stage: &str, index: usize) -> Result<Unit> {
        RunDir::load(self, stage, index)
    }
}

/// A store seen through a stage prefix: the studies of a composite run (`reproduce`)
/// keep their units apart in one directory (`units/<prefix>.<stage>-NNNNNNN.unit`).
pub struct Prefixed<'a> {
    /// The store underneath.
    pub inner: &'a dyn UnitStore,
    /// Prepended to every stage name.
    pub prefix: &'a str,
}

impl Prefixed<'_> {
    fn stage(&self, stage: &str) -> String {
        format!("{}.{stage}", self.prefix)
    }
}

impl UnitStore for Prefixed<'_> {
    fn committed(&self, stage: &str, count: usize) -> Result<Vec<bool>> {
        self.inner.committed(&self.stage(stage), count)
    }
    fn commit(&self, stage: &str, index: usize, unit: &Unit) -> Result<()> {
        let mut u = unit.clone();
        u.key = dir::unit_key(&self.stage(stage), index);
        self.inner.commit(&self.stage(stage), index, &u)
    }
    fn load(&self, stage: &str, index: usize) -> Result<Unit> {
        let mut u = self.inner.load(&self.stage(stage), index)?;
        u.key = dir::unit_key(stage, index);
        Ok(u)
    }
}

/// One shard of a run spread over many machines: shard `index` of `count` computes the
/// units whose index is congruent to `index` modulo `count` (interleaved, so shards take
/// about equal time even where the cost varies across a grid).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Shard {
    /// 0-based shard index.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

/// Shards at most (far more than a cluster array needs; keeps unit lists small).
pub const MAX_SHARDS: usize = 100_000;

impl Shard {
    /// Parses `i/n` (0 <= i < n) or `slurm`: i and n from a Slurm job array's
    /// `SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN` and `SLURM_ARRAY_TASK_COUNT`.
    pub fn parse(text: &str) -> Result<Shard> {
        Self::parse_with(text, &|k| std::env::var(k).ok())
    }

    /// [`Shard::parse`] with the environment given (for tests).
    pub fn parse_with(text: &str, env: &dyn Fn(&str) -> Option<String>) -> Result<Shard> {
        let (i, n) = if text.trim() == "slurm" {
            let get = |k: &str| -> Result<usize> {
                let v = env(k).ok_or_else(|| {
                    Error::invalid(
                        "shard",
                        "slurm",
                        format!("{k} is not set: --shard slurm works inside a Slurm job array (sbatch --array=0-N), give --shard i/n elsewhere"),
                    )
                })?;
                v.trim()
                    .parse()
                    .map_err(|_| Error::invalid("shard", format!("{k}={v}"), "not a whole number"))
            };
            let (id, min, count) = (
                get("SLURM_ARRAY_TASK_ID")?,
                get("SLURM_ARRAY_TASK_MIN")?,
                get("SLURM_ARRAY_TASK_COUNT")?,
            );
            (
                id.checked_sub(min).ok_or_else(|| {
                    Error::invalid(
                        "shard",
                        id,
                        "SLURM_ARRAY_TASK_ID below SLURM_ARRAY_TASK_MIN",
                    )
                })?,
                count,
            )
        } else {
            let (i, n) = text.split_once('/').ok_or_else(|| {
                Error::invalid(
                    "shard",
                    text,
                    "expected i/n (shard i of n, 0 <= i < n) or slurm",
                )
            })?;
            let num = |s: &str| -> Result<usize> {
                s.trim().parse().map_err(|_| {
                    Error::invalid("shard", text, format!("`{s}` is not a whole number"))
                })
            };
            (num(i)?, num(n)?)
        };
        if n == 0 || n > MAX_SHARDS || i >= n {
            return Err(Error::invalid(
                "shard",
                format!("{i}/{n}"),
                format!("need 0 <= i < n and 1 <= n <= {MAX_SHARDS}"),
            ));
        }
        Ok(Shard { index: i, count: n })
    }

    /// Whether unit `u` belongs to this shard.
    pub fn owns(&self, u: usize) -> bool {
        u % self.count == self.index
    }
}

/// A shard reached the assembly: its own share is done (the command line turns this
/// into a finished shard directory, not an error).
#[derive(Debug, thiserror::Error)]
#[error("a shard computes units only; `jeffcott merge` assembles them")]
pub struct ShardDone;

/// A store seen by one shard: the units of other shards count as committed (so the
/// engine skips them), and reading any unit is [`ShardDone`]: a shard's work
/// ends where the assembly would begin (the merge assembles).
pub struct ShardStore<'a> {
    /// The shard's own store (its directory).
    pub inner: &'a dyn UnitStore,
    /// Which shard.
    pub shard: Shard,
}

impl UnitStore for ShardStore<'_> {
    fn committed(&self, stage: &str, count: usize) -> Result<Vec<bool>> {
        let mut c = self.inner.committed(stage, count)?;
        for (u, d) in c.iter_mut().enumerate() {
            *d |= !self.shard.owns(u);
        }
        Ok(c)
    }
    fn commit(&self, stage: &str, index: usize, unit: &Unit) -> Result<()> {
        self.inner.commit(stage, index, unit)
    }
    fn load(&self, _stage: &str, _index: usize) -> Result<Unit> {
        Err(Error::layer(ShardDone))
    }
}

/// Units kept in memory for the length of one call.
#[derive(Debug, Default)]
pub struct MemoryStore(Mutex<HashMap<String, Unit>>);

impl MemoryStore {
    /// An empty store.
    pub fn new() -> MemoryStore {
        MemoryStore::default()
    }

    fn map(&self) -> std::sync::MutexGuard<'_, HashMap<String, Unit>> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

impl UnitStore for MemoryStore {
    fn committed(&self, stage: &str, count: usize) -> Result<Vec<bool>> {
        let m = self.map();
        Ok((0..count)
            .map(|i| m.contains_key(&dir::unit_key(stage, i)))
            .collect())
    }
    fn commit(&self, stage: &str, index: usize, unit: &Unit) -> Result<()> {
        self.map().insert(dir::unit_key(stage, index), unit.clone());
        Ok(())
    }
    fn load(&self, stage: &str, index: usize) -> Result<Unit> {
        let key = dir::unit_key(stage, index);
        self.map().get(&key).cloned().ok_or_else(|| Error::Io {
            path: key.into(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "unit not committed"),
        })
    }
}

pub use jeffcott_core::control::{Cancel, ProgressFn, no_progress};

/// Where a study computed unit by unit runs: the engine its lanes go to, the store its
/// units are committed to (and resumed from), and the progress and cancel control.
#[derive(Clone, Copy)]
pub struct Units<'a> {
    /// The engine the lanes run on.
    pub engine: &'a crate::backend::Engine,
    /// Where the units are committed and found again on resume.
    pub store: &'a dyn UnitStore,
    /// Progress (lane-periods) and cancel.
    pub ctl: lanes::Control<'a>,
}

/// A study computed unit by unit into a [`UnitStore`] (resumable and shardable): the
/// basin, the map and the continuation. It runs the same way in memory (the library
/// calls, [`in_memory`]) and under a front end's host ([`under_host`]).
pub trait UnitStudy {
    /// What the study computes.
    type Output;
    /// The progress label of its units.
    const STAGE: &'static str;
    /// Its lane settings (the backend and precision of the engine [`in_memory`] opens).
    fn lane_settings(&self) -> &crate::settings::LaneSettings;
    /// Its work [lane-periods] and the lane-periods of one lane.
    fn work(&self) -> (u64, u64);
    /// Computes it unit by unit into `at.store`, resuming from the units it holds.
    fn compute(&self, at: Units<'_>) -> Result<Self::Output>;
}

/// Runs a study in memory (a [`MemoryStore`], nothing written) on a freshly opened
/// engine, reporting and stopped through `ctl`: the library entry points of the studies
/// (`basin`, `map`, `continuation`).
pub fn in_memory<S: UnitStudy>(study: &S, ctl: lanes::Control) -> Result<S::Output> {
    let lane = study.lane_settings();
    let engine = crate::backend::Engine::new(lane.backend, lane.precision)?;
    study.compute(Units {
        engine: &engine,
        store: &MemoryStore::new(),
        ctl,
    })
}

/// Runs a study on `engine` under `host`: its units committed to the host's store, its
/// progress on the host's display as stage [`UnitStudy::STAGE`] (the front ends' entry).
pub fn under_host<S: UnitStudy>(
    study: &S,
    engine: &crate::backend::Engine,
    host: &impl Host,
) -> Result<S::Output> {
    let (total, per_lane) = study.work();
    host.progress(Stage::new(S::STAGE, total, per_lane), |ctl| {
        study.compute(Units {
            engine,
            store: host.store(),
            ctl,
        })
    })
}

/// Lane-steps per unit at most: about 25 s on the 2-core CPU the defaults were measured
/// on (2e7 lane-steps/s), far less on a GPU, which batches units.
pub const MAX_UNIT_LANE_STEPS: u64 = 500_000_000;

/// Units a run is cut into at least (each at most ~5 % of the work).
pub const MIN_UNITS: usize = 20;

/// Lanes per unit for a run of `lanes` lanes costing `steps_per_lane` lane-steps each
/// (a lambda_1 lane counts double): at most 1/[`MIN_UNITS`] of the lanes and at most
/// [`MAX_UNIT_LANE_STEPS`] lane-steps, at least one lane. Depends only on the
/// specification, never on the backend, so every backend and every resume cuts the
/// same units.
pub fn unit_lanes(lanes: usize, steps_per_lane: u64) -> usize {
    let by_share = lanes.div_ceil(MIN_UNITS);
    let by_time = (MAX_UNIT_LANE_STEPS / steps_per_lane.max(1)) as usize;
    by_share.min(by_time).max(1)
}

/// Number of units of `unit` lanes covering `lanes` lanes.
pub fn unit_count(lanes: usize, unit: usize) -> usize {
    lanes.div_ceil(unit.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_from_i_over_n_and_from_a_slurm_array() {
        let none = |_: &str| None;
        assert_eq!(
            Shard::parse_with("2/7", &none).unwrap(),
            Shard { index: 2, count: 7 }
        );
        for bad in ["7/7", "1/0", "a/3", "3", "-1/2"] {
            assert!(Shard::parse_with(bad, &none).is_err(), "{bad}");
        }
        let e = Shard::parse_with("slurm", &none).unwrap_err().to_string();
        assert!(
            e.contains("SLURM_ARRAY_TASK_ID") && e.contains("job array"),
            "{e}"
        );
        let env = |k: &str| {
            match k {
                "SLURM_ARRAY_TASK_ID" => Some("12"),
                "SLURM_ARRAY_TASK_MIN" => Some("10"),
                "SLURM_ARRAY_TASK_COUNT" => Some("4"),
                _ => None,
            }
            .map(String::from)
        };
        assert_eq!(
            Shard::parse_with("slurm", &env).unwrap(),
            Shard { index: 2, count: 4 }
        );
        let s = Shard { index: 1, count: 3 };
        assert_eq!(
            (0..7).filter(|&u| s.owns(u)).collect::<Vec<_>>(),
            vec![1, 4]
        );
    }

    #[test]
    fn units_are_at_most_a_twentieth_of_the_run_and_25_seconds_of_cpu_work() {
        // The 200 x 200 basin of the issue: 564 periods x 500 steps per lane.
        let u = unit_lanes(40_000, 564 * 500);
        assert!(
            u <= 2000 && u as u64 * 564 * 500 <= MAX_UNIT_LANE_STEPS,
            "{u}"
        );
        assert!(unit_count(40_000, u) >= MIN_UNITS);
        assert_eq!(unit_lanes(3, 1000), 1);
        assert_eq!(unit_lanes(1, u64::MAX), 1);
    }
}
