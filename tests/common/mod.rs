//! Helpers shared by the integration tests: run the binary, require success, read its
//! JSON and NPY files, the GPU-required rule of CI and the shared GPU runner
//! ([`gpu`]), a deterministic hash for test inputs.
#![allow(dead_code)] // each test file uses a different subset

pub mod gpu;

use std::path::Path;
use std::process::{Command, Output};

/// Runs the jeffcott binary with `args`.
pub fn jeffcott(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_jeffcott"))
        .args(args)
        .output()
        .expect("run jeffcott")
}

/// Asserts a run succeeded, showing its exit code, stdout and stderr otherwise.
pub fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A JSON file, parsed.
pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).expect("read json")).expect("parse json")
}

/// An NPY file's shape and data.
pub fn npy<T: npyz::Deserialize>(path: &Path) -> (Vec<u64>, Vec<T>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let f = npyz::NpyFile::new(&bytes[..]).expect("npy header");
    let shape = f.shape().to_vec();
    (shape, f.into_vec().expect("npy data"))
}

/// True when CI asked for GPU tests to fail rather than skip without an adapter.
pub fn require_gpu() -> bool {
    std::env::var("JEFFCOTT_REQUIRE_GPU").as_deref() == Ok("1")
}

/// True when an f64-capable adapter exists; panics without one when required.
pub fn gpu_f64_present() -> bool {
    let present = jeffcott_gpu::list_adapters()
        .iter()
        .any(|a| a.compute && a.f64);
    assert!(
        present || !require_gpu(),
        "JEFFCOTT_REQUIRE_GPU=1 but no adapter with SHADER_F64 was found"
    );
    if !present {
        eprintln!("skipped: no GPU adapter with f64");
    }
    present
}

/// A small deterministic hash of (`i`, `salt`) in [-1, 1).
pub fn unit(i: usize, salt: u64) -> f64 {
    let mut z = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ salt;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}
