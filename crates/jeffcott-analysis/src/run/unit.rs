//! A committed work unit on disk: a small self-checking container of named arrays and
//! JSON metadata. One file per unit, written atomically ([`crate::output`]), read back
//! on resume and at assembly.
//!
//! Layout: the magic `JCUNIT01`, the header length (u32 LE), the header (JSON: unit key,
//! the fingerprint of the run it belongs to, array names, types and lengths, metadata), the arrays (little-endian, in header
//! order), then an FNV-1a 64 checksum (u64 LE) of everything before it. A file that
//! fails the magic, the lengths or the checksum is not a unit: the run engine removes it
//! and computes the unit again.

use jeffcott_core::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

const MAGIC: &[u8; 8] = b"JCUNIT01";

/// One array of a unit.
#[derive(Clone, Debug, PartialEq)]
pub enum Array {
    /// f64 values.
    F64(Vec<f64>),
    /// i32 values.
    I32(Vec<i32>),
    /// u32 values.
    U32(Vec<u32>),
}

impl Array {
    fn dtype(&self) -> &'static str {
        match self {
            Array::F64(_) => "f64",
            Array::I32(_) => "i32",
            Array::U32(_) => "u32",
        }
    }

    fn len(&self) -> usize {
        match self {
            Array::F64(v) => v.len(),
            Array::I32(v) => v.len(),
            Array::U32(v) => v.len(),
        }
    }

    fn bytes(&self, out: &mut Vec<u8>) {
        match self {
            Array::F64(v) => v.iter().for_each(|x| out.extend(x.to_le_bytes())),
            Array::I32(v) => v.iter().for_each(|x| out.extend(x.to_le_bytes())),
            Array::U32(v) => v.iter().for_each(|x| out.extend(x.to_le_bytes())),
        }
    }
}

#[derive(Serialize, Deserialize)]
struct ArrayHeader {
    name: String,
    dtype: String,
    len: usize,
}

#[derive(Serialize, Deserialize)]
struct Header {
    key: String,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    run: String,
    arrays: Vec<ArrayHeader>,
    meta: serde_json::Value,
}

/// A unit's results: named arrays plus metadata (whatever the study needs to assemble
/// its files without recomputing the unit).
#[derive(Clone, Debug, PartialEq)]
pub struct Unit {
    /// The unit's key within its run (`"0000042"`, `"up-0003"`...).
    pub key: String,
    /// The fingerprint of the run that committed it ([`run_fingerprint`] of its command
    /// and specification; empty until committed): a unit copied into another run's
    /// directory is told from that run's own and never assembled there.
    pub run: String,
    /// Named arrays, in the order written.
    pub arrays: Vec<(String, Array)>,
    /// Metadata (JSON; f64 values round-trip exactly).
    pub meta: serde_json::Value,
}

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

fn corrupt(path: &Path, why: &str) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, why.to_string()),
    }
}

impl Unit {
    /// An empty unit with this key.
    pub fn new(key: impl Into<String>) -> Unit {
        Unit {
            key: key.into(),
            run: String::new(),
            arrays: Vec::new(),
            meta: serde_json::Value::Null,
        }
    }

    /// Adds an array (builder style).
    pub fn with(mut self, name: &str, a: Array) -> Unit {
        self.arrays.push((name.to_string(), a));
        self
    }

    /// Sets the metadata to a typed record (builder style). The studies' records (no
    /// maps with non-string keys) always serialize; one that did not would be stored as
    /// null and read back by [`Unit::meta_as`] as a corrupt unit, never silently.
    pub fn with_meta<T: Serialize + ?Sized>(mut self, meta: &T) -> Unit {
        self.meta = serde_json::to_value(meta).unwrap_or(serde_json::Value::Null);
        self
    }

    /// The metadata as the typed record `T`; metadata of another shape is a corrupt
    /// unit (an I/O error naming the unit).
    pub fn meta_as<T: serde::de::DeserializeOwned>(&self) -> Result<T> {
        serde_json::from_value(self.meta.clone()).map_err(|e| Error::Io {
            path: format!("unit {}", self.key).into(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("metadata: {e}")),
        })
    }

    fn get(&self, name: &str) -> Option<&Array> {
        self.arrays.iter().find(|(n, _)| n == name).map(|(_, a)| a)
    }

    /// The f64 array `name`; a missing or mistyped array is a corrupt unit.
    pub fn f64s(&self, name: &str) -> Result<&[f64]> {
        match self.get(name) {
            Some(Array::F64(v)) => Ok(v),
            _ => Err(self.missing(name)),
        }
    }

    /// The i32 array `name`.
    pub fn i32s(&self, name: &str) -> Result<&[i32]> {
        match self.get(name) {
            Some(Array::I32(v)) => Ok(v),
            _ => Err(self.missing(name)),
        }
    }

    /// The u32 array `name`.
    pub fn u32s(&self, name: &str) -> Result<&[u32]> {
        match self.get(name) {
            Some(Array::U32(v)) => Ok(v),
            _ => Err(self.missing(name)),
        }
    }

    /// Whether an array `name` is present.
    pub fn has(&self, name: &str) -> bool {
        self.get(name).is_some()
    }

    fn missing(&self, name: &str) -> Error {
        Error::Io {
            path: format!("unit {}", self.key).into(),
            source: std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("array `{name}` missing or of another type"),
            ),
        }
    }

    /// The unit as bytes (the layout of the module docs).
    pub fn encode(&self) -> Vec<u8> {
        let header = Header {
            key: self.key.clone(),
            run: self.run.clone(),
            arrays: self
                .arrays
                .iter()
                .map(|(n, a)| ArrayHeader {
                    name: n.clone(),
                    dtype: a.dtype().into(),
                    len: a.len(),
                })
                .collect(),
            meta: self.meta.clone(),
        };
        let h = serde_json::to_vec(&header).unwrap_or_default();
        let mut out = Vec::with_capacity(16 + h.len());
        out.extend_from_slice(MAGIC);
        out.extend((h.len() as u32).to_le_bytes());
        out.extend_from_slice(&h);
        for (_, a) in &self.arrays {
            a.bytes(&mut out);
        }
        let sum = fnv1a(&out);
        out.extend(sum.to_le_bytes());
        out
    }

    /// Parses bytes written by [`Unit::encode`]; `path` names the file in errors.
    pub fn decode(path: &Path, bytes: &[u8]) -> Result<Unit> {
        if bytes.len() < 20 || &bytes[..8] != MAGIC {
            return Err(corrupt(path, "not a jeffcott unit file"));
        }
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        let sum = u64::from_le_bytes(tail.try_into().unwrap_or_default());
        if fnv1a(body) != sum {
            return Err(corrupt(path, "checksum mismatch"));
        }
        let hlen = u32::from_le_bytes(body[8..12].try_into().unwrap_or_default()) as usize;
        let header: Header = body
            .get(12..12 + hlen)
            .and_then(|h| serde_json::from_slice(h).ok())
            .ok_or_else(|| corrupt(path, "unreadable header"))?;
        let mut at = 12 + hlen;
        let mut arrays = Vec::with_capacity(header.arrays.len());
        for a in &header.arrays {
            let width = match a.dtype.as_str() {
                "f64" => 8,
                "i32" | "u32" => 4,
                _ => return Err(corrupt(path, "unknown array type")),
            };
            let raw = body
                .get(at..at + a.len * width)
                .ok_or_else(|| corrupt(path, "truncated array"))?;
            at += a.len * width;
            let arr = match a.dtype.as_str() {
                "f64" => Array::F64(
                    raw.chunks_exact(8)
                        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or_default()))
                        .collect(),
                ),
                "i32" => Array::I32(
                    raw.chunks_exact(4)
                        .map(|c| i32::from_le_bytes(c.try_into().unwrap_or_default()))
                        .collect(),
                ),
                _ => Array::U32(
                    raw.chunks_exact(4)
                        .map(|c| u32::from_le_bytes(c.try_into().unwrap_or_default()))
                        .collect(),
                ),
            };
            arrays.push((a.name.clone(), arr));
        }
        if at != body.len() {
            return Err(corrupt(path, "trailing bytes"));
        }
        Ok(Unit {
            key: header.key,
            run: header.run,
            arrays,
            meta: header.meta,
        })
    }

    /// Writes the unit atomically to `path`.
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.encode();
        crate::output::write_atomically(path, |w| w.write_all(&bytes))
    }

    /// Reads and checks a unit file.
    pub fn read(path: &Path) -> Result<Unit> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Unit::decode(path, &bytes)
    }
}

/// The fingerprint of a run: FNV-1a 64 of its command and its specification as
/// run.json records it (serde_json writes an object's keys sorted, so equal
/// specifications give equal bytes), as 16 hex digits. A shard's units carry the
/// fingerprint of the unsharded run, since a shard's specification is the whole run's.
pub fn run_fingerprint(command: &str, spec: &serde_json::Value) -> String {
    let mut bytes = command.as_bytes().to_vec();
    bytes.push(0);
    bytes.extend(serde_json::to_vec(spec).unwrap_or_default());
    format!("{:016x}", fnv1a(&bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_unit_round_trips_to_the_bit_and_a_flipped_byte_is_detected() {
        let u = Unit::new("up-0003")
            .with("p", Array::F64(vec![0.1, -0.0, f64::NAN, 1e-300]))
            .with("l", Array::I32(vec![-1, 0, 7]))
            .with("s", Array::U32(vec![3]))
            .with_meta(&serde_json::json!({"x": 0.1 + 0.2, "n": 3}));
        let u = Unit {
            run: run_fingerprint("basin", &serde_json::json!({"omega": 133.0})),
            ..u
        };
        let bytes = u.encode();
        let back = Unit::decode(Path::new("u"), &bytes).unwrap();
        assert_eq!(back.key, u.key);
        assert_eq!(back.meta, u.meta);
        assert_eq!(back.run, u.run);
        let bits =
            |u: &Unit| -> Vec<u64> { u.f64s("p").unwrap().iter().map(|v| v.to_bits()).collect() };
        assert_eq!(bits(&back), bits(&u));
        assert_eq!(back.i32s("l").unwrap(), &[-1, 0, 7]);
        for i in [0, 9, 20, bytes.len() - 1] {
            let mut bad = bytes.clone();
            bad[i] ^= 0x10;
            assert!(Unit::decode(Path::new("u"), &bad).is_err(), "flip at {i}");
        }
        assert!(Unit::decode(Path::new("u"), &bytes[..bytes.len() - 3]).is_err());
    }

    #[test]
    fn runs_that_differ_in_one_value_or_in_their_command_have_different_fingerprints() {
        let a = serde_json::json!({"omega": 133.0, "grid": {"n": 8}});
        let b = serde_json::json!({"omega": 133.1, "grid": {"n": 8}});
        let c = serde_json::json!({"grid": {"n": 8}, "omega": 133.0});
        assert_ne!(run_fingerprint("basin", &a), run_fingerprint("basin", &b));
        assert_ne!(run_fingerprint("basin", &a), run_fingerprint("map", &a));
        assert_eq!(run_fingerprint("basin", &a), run_fingerprint("basin", &c));
        assert_eq!(run_fingerprint("basin", &a).len(), 16);
    }
}
