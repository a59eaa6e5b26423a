//! What a study needs from the program that runs it: where its units are committed and
//! how each of its stages reports progress and is stopped. A study's `run` takes the
//! engine (how lanes are integrated) and a host (where they go and who watches); it
//! never knows whether it runs under the command line (a run directory and a progress
//! bar), Python (memory and a callback) or `reproduce` (one directory, a prefix per
//! study).

use super::{Prefixed, UnitStore};
use jeffcott_core::control::Control;
use jeffcott_core::error::Result;

/// A stage of a study as its host shows it.
#[derive(Clone, Copy, Debug)]
pub struct Stage<'a> {
    /// Its name (the progress bar's label).
    pub label: &'a str,
    /// Its work [lane-periods].
    pub total: u64,
    /// The lane-periods of one lane (the bar counts lanes with them).
    pub per_lane: u64,
}

impl<'a> Stage<'a> {
    /// Stage `label` of `total` lane-periods, `per_lane` of them per lane.
    pub fn new(label: &'a str, total: u64, per_lane: u64) -> Self {
        Stage {
            label,
            total,
            per_lane,
        }
    }
}

/// The frame a study's stages run in.
pub trait Host {
    /// The store the study commits its units to.
    fn store(&self) -> &dyn UnitStore;
    /// Runs `stage` under the host's progress display and cancel flag.
    fn progress<T>(&self, stage: Stage<'_>, work: impl FnOnce(Control) -> Result<T>) -> Result<T>;
    /// This host with its store seen under `prefix` ([`PrefixedHost`]).
    fn prefixed<'a>(&'a self, prefix: &'a str) -> PrefixedHost<'a, Self>
    where
        Self: Sized,
    {
        PrefixedHost::new(self, prefix)
    }
}

/// A host for library calls: units in memory, every stage reported through one
/// [`Control`] (its totals are each stage's own).
pub struct MemoryHost<'a> {
    store: super::MemoryStore,
    ctl: Control<'a>,
}

impl<'a> MemoryHost<'a> {
    /// An empty store, reporting and stopped through `ctl`.
    pub fn new(ctl: Control<'a>) -> Self {
        MemoryHost {
            store: super::MemoryStore::new(),
            ctl,
        }
    }
}

impl Host for MemoryHost<'_> {
    fn store(&self) -> &dyn UnitStore {
        &self.store
    }
    fn progress<T>(&self, _: Stage<'_>, work: impl FnOnce(Control) -> Result<T>) -> Result<T> {
        work(self.ctl)
    }
}

/// Another host seen with its store under a stage prefix ([`Prefixed`]): the studies
/// of a composite run keep their units apart in one directory.
pub struct PrefixedHost<'a, H: Host> {
    host: &'a H,
    store: Prefixed<'a>,
}

impl<'a, H: Host> PrefixedHost<'a, H> {
    /// `host` with its store seen under `prefix`.
    pub fn new(host: &'a H, prefix: &'a str) -> Self {
        PrefixedHost {
            host,
            store: Prefixed {
                inner: host.store(),
                prefix,
            },
        }
    }
}

impl<H: Host> Host for PrefixedHost<'_, H> {
    fn store(&self) -> &dyn UnitStore {
        &self.store
    }
    fn progress<T>(&self, stage: Stage<'_>, work: impl FnOnce(Control) -> Result<T>) -> Result<T> {
        self.host.progress(stage, work)
    }
}
