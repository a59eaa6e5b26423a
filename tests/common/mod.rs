//! Helpers shared by the integration tests (one copy each; a test file declares
//! `mod common;` and imports what it uses): run the binary, require success, read its
//! JSON and NPY files (and check an NPY file against the format spec), the GPU-required
//! rule of CI (an f64 device or a skip, a failure under `JEFFCOTT_REQUIRE_GPU=1`) and the
//! shared GPU runner ([`gpu`]), a deterministic hash for test inputs.
#![allow(dead_code)] // each test file uses a different subset

pub mod gpu;

use std::path::Path;
use std::process::{Command, Output};

/// Runs the jeffcott binary with `args` (`&str`s or `String`s).
pub fn jeffcott<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
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

/// Checks a file against the NPY v1/v2 format spec (magic, version, little-endian header
/// length, a Python dict literal with descr / fortran_order / shape, the data start
/// aligned to 64 bytes, data length = product of the shape x item size) and returns its
/// descr and shape.
pub fn npy_header(path: &Path) -> (String, Vec<usize>) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY", "{}: magic", path.display());
    let (major, minor) = (bytes[6], bytes[7]);
    assert!(
        matches!((major, minor), (1, 0) | (2, 0) | (3, 0)),
        "version"
    );
    let (hlen, start) = if major == 1 {
        (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10)
    } else {
        (
            u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
            12,
        )
    };
    assert_eq!((start + hlen) % 64, 0, "data aligned to 64 bytes");
    let header = std::str::from_utf8(&bytes[start..start + hlen]).unwrap();
    assert!(header.ends_with('\n'), "header ends with a newline");
    let h = header.trim_end();
    assert!(h.starts_with('{') && h.ends_with('}'), "{header}");
    assert!(h.contains("'fortran_order': False"), "{header}");
    let descr = &h[h.find("'descr': '").unwrap() + 10..];
    let descr = descr[..descr.find('\'').unwrap()].to_string();
    let shape = &h[h.find("'shape': (").unwrap() + 10..];
    let shape = &shape[..shape.find(')').unwrap()];
    let dims: Vec<usize> = shape
        .split(',')
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let item: usize = descr[2..].parse().unwrap();
    assert_eq!(
        bytes.len() - start - hlen,
        dims.iter().product::<usize>() * item,
        "data length"
    );
    (descr, dims)
}

/// An NPY file's shape and data.
pub fn npy<T: npyz::Deserialize>(path: &Path) -> (Vec<u64>, Vec<T>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let f = npyz::NpyFile::new(&bytes[..]).expect("npy header");
    // npyz reads either byte order into T; the project writes little-endian only.
    let descr = f.dtype().descr();
    assert!(
        descr.starts_with("'<") || descr.starts_with("'|"),
        "{}: descr {descr} is not little-endian",
        path.display()
    );
    let shape = f.shape().to_vec();
    (shape, f.into_vec().expect("npy data"))
}

/// True when CI asked for GPU tests to fail rather than skip without an adapter.
pub fn require_gpu() -> bool {
    std::env::var("JEFFCOTT_REQUIRE_GPU").as_deref() == Ok("1")
}

/// A device on an adapter with SHADER_F64 (software adapters such as lavapipe allowed, as
/// the CLI's `--backend gpu` allows them), or `None` after saying so; panics without one
/// when `JEFFCOTT_REQUIRE_GPU=1`.
pub fn gpu_f64_device() -> Option<jeffcott_gpu::GpuDevice> {
    let req = jeffcott_gpu::DeviceRequest {
        need_f64: true,
        allow_software: true,
    };
    match jeffcott_gpu::GpuDevice::new(&req) {
        Ok(gpu) => Some(gpu),
        Err(e) => {
            assert!(
                !require_gpu(),
                "JEFFCOTT_REQUIRE_GPU=1 but no GPU adapter with f64 could be opened: {e}"
            );
            eprintln!("skipped: no Vulkan adapter with f64 ({e})");
            None
        }
    }
}

/// True when an f64-capable device opens ([`gpu_f64_device`]); panics without one when
/// required.
pub fn gpu_f64_present() -> bool {
    gpu_f64_device().is_some()
}

/// A small deterministic hash of (`i`, `salt`) in [-1, 1).
pub fn unit(i: usize, salt: u64) -> f64 {
    let mut z = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ salt;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}
