//! What the command line adds to the library's records in the JSON files it writes
//! (`summary.json`, `map.json`, an ensemble's `run.json`, ...): what each file beside it
//! holds, and the version that wrote it. The records are the library's typed structs;
//! [`jeffcott_analysis::output::write_json`] sorts the keys.

use serde::Serialize;
use std::collections::BTreeMap;

/// File name (or pattern) -> what it holds.
pub type Files = BTreeMap<&'static str, &'static str>;

/// A library record with the list of files and the version at its top level.
#[derive(Clone, Debug, Serialize)]
pub struct Documented<T: Serialize> {
    /// The record, its fields at the top level.
    #[serde(flatten)]
    pub record: T,
    /// What each output file holds.
    pub files: Files,
    /// The version that wrote the file.
    pub jeffcott_version: &'static str,
}

impl<T: Serialize> Documented<T> {
    /// `record` with `files` and this build's version.
    pub fn new(record: T, files: &[(&'static str, &'static str)]) -> Self {
        Documented {
            record,
            files: files.iter().copied().collect(),
            jeffcott_version: env!("CARGO_PKG_VERSION"),
        }
    }
}
