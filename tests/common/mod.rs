//! Helpers shared by the integration tests (one copy each; a test file declares
//! `mod common;` and imports what it uses): run the binary, require success, read its
//! JSON and NPY files (and check an NPY file against the format spec), the GPU-required
//! rule of CI (an f64 device or a skip, a failure under `JEFFCOTT_REQUIRE_GPU=1`) and the
//! shared GPU runner ([`gpu`]), a deterministic hash for test inputs.
#![allow(dead_code)] // each test file uses a different subset

pub mod gpu;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the jeffcott binary with `args` (`&str`s or `String`s).
pub fn jeffcott<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_jeffcott"))
        .args(args)
        .output()
        .expect("run jeffcott")
}

/// The files of a `map` run but its figures (the command's own list, so a new file is
/// compared too).
pub fn map_files() -> Vec<&'static str> {
    jeffcott::cli::map::OUTPUTS
        .iter()
        .copied()
        .filter(|f| !f.ends_with(".png"))
        .collect()
}

/// A command line's arguments, split at white space (for lines whose arguments hold none),
/// `''` standing for an empty argument.
pub fn words(line: &str) -> Vec<&str> {
    line.split_whitespace()
        .map(|w| if w == "''" { "" } else { w })
        .collect()
}

/// Runs the jeffcott binary with the words of `line` and `--out out`.
pub fn jeffcott_out(line: &str, out: impl AsRef<Path>) -> Output {
    let out = out.as_ref().to_str().expect("UTF-8 path");
    jeffcott(&[words(line), vec!["--out", out]].concat())
}

/// The entry of the JSON array `list` (of attractors) whose "class" is `class`.
pub fn of_class<'a>(list: &'a serde_json::Value, class: &str) -> Option<&'a serde_json::Value> {
    list.as_array()
        .expect("an array")
        .iter()
        .find(|a| a["class"] == class)
}

/// A fresh temporary directory and the path `name` in it, not yet made (the directory
/// goes when the first is dropped).
pub fn temp_out(name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("temporary directory");
    let out = dir.path().join(name);
    (dir, out)
}

/// A fresh temporary directory and the paths `names` in it, not yet made.
pub fn temp_outs<const N: usize>(names: [&str; N]) -> (tempfile::TempDir, [PathBuf; N]) {
    let dir = tempfile::tempdir().expect("temporary directory");
    let outs = names.map(|n| dir.path().join(n));
    (dir, outs)
}

/// Runs the words of `line` with `--out` a fresh temporary path `name` ([`temp_out`]):
/// the directory (it lasts while held), the path and the run's output.
pub fn jeffcott_temp(name: &str, line: &str) -> (tempfile::TempDir, PathBuf, Output) {
    let (dir, out) = temp_out(name);
    let o = jeffcott_out(line, &out);
    (dir, out, o)
}

/// [`jeffcott_temp`] for a run that must succeed: the directory (it lasts while held)
/// and the output path.
pub fn jeffcott_ok(name: &str, line: &str) -> (tempfile::TempDir, PathBuf) {
    let (dir, out, o) = jeffcott_temp(name, line);
    ok(&o);
    (dir, out)
}

/// Asserts that a run of `input` was refused: exit code 2, every one of `needles` in its
/// stderr.
pub fn assert_refused_naming(o: &Output, input: impl std::fmt::Debug, needles: &[&str]) {
    assert_eq!(o.status.code(), Some(2), "{input:?}");
    let e = String::from_utf8_lossy(&o.stderr);
    for n in needles {
        assert!(e.contains(n), "{input:?}: `{n}` not in {e}");
    }
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

/// f64 lane settings on the CPU for `params`, with the default stepper and tolerances.
pub fn cpu_f64_lane(
    params: jeffcott_core::model::Params,
    lyapunov: bool,
) -> jeffcott_analysis::settings::LaneSettings {
    jeffcott_analysis::settings::LaneSettings {
        params,
        stepper: Default::default(),
        precision: jeffcott_core::ensemble::Precision::F64,
        backend: jeffcott_core::ensemble::Backend::Cpu,
        catalogue: Default::default(),
        lyapunov,
    }
}

/// Asserts that the analytic Jacobian at `x` (W = 133, phase 0.01) matches central
/// differences of the right-hand side entry by entry within 1e-6 max(|J|, 1) + `abs_tol`;
/// returns it. Steps of 1e-9 m and 1e-6 m/s stay on one side of a contact.
pub fn assert_jacobian_matches_central_differences(
    p: &jeffcott_core::model::Params,
    x: &jeffcott_core::model::State,
    abs_tol: f64,
) -> [[f64; jeffcott_core::model::STATE_DIM]; jeffcott_core::model::STATE_DIM] {
    use jeffcott_core::model::{STATE_DIM, jacobian, rhs};
    let jac = jacobian(p, x);
    for j in 0..STATE_DIM {
        let h = if j % 2 == 0 { 1e-9 } else { 1e-6 };
        let (mut xp, mut xm) = (*x, *x);
        xp[j] += h;
        xm[j] -= h;
        let (fp, fm) = (rhs(p, 133.0, 0.01, &xp), rhs(p, 133.0, 0.01, &xm));
        for i in 0..STATE_DIM {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            let tol = 1e-6 * jac[i][j].abs().max(1.0) + abs_tol;
            assert!(
                (fd - jac[i][j]).abs() <= tol,
                "J[{i}][{j}] = {} vs FD {fd} (mu {})",
                jac[i][j],
                p.mu
            );
        }
    }
    jac
}

/// A small deterministic hash of (`i`, `salt`) in [-1, 1).
pub fn unit(i: usize, salt: u64) -> f64 {
    let mut z = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ salt;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The indices of the positions in a state: x_r, y_r, x_s, y_s.
pub const POSITIONS: [usize; 4] = [
    jeffcott_core::model::X_R,
    jeffcott_core::model::Y_R,
    jeffcott_core::model::X_S,
    jeffcott_core::model::Y_S,
];

/// The largest absolute difference of `a` and `b` over the indices `idx`.
pub fn max_abs_diff(a: &[f64], b: &[f64], idx: &[usize]) -> f64 {
    idx.iter().map(|&i| (a[i] - b[i]).abs()).fold(0.0, f64::max)
}

/// Asserts fourth-order convergence of `errs`, the errors at `ns` steps per period: the
/// least-squares order of log error against log N at least 3.8, and every ratio of
/// successive errors (each N doubled) above 2^3.5.
pub fn assert_fourth_order(ns: &[u32], errs: &[f64]) {
    let k = ns.len() as f64;
    let lx: Vec<f64> = ns.iter().map(|&n| f64::from(n).ln()).collect();
    let ly: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
    let (mx, my) = (lx.iter().sum::<f64>() / k, ly.iter().sum::<f64>() / k);
    let slope = lx
        .iter()
        .zip(&ly)
        .map(|(x, y)| (x - mx) * (y - my))
        .sum::<f64>()
        / lx.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
    eprintln!("errors {errs:?} at N = {ns:?}: fitted order {:.3}", -slope);
    assert!(-slope >= 3.8, "fitted order {} from {errs:?}", -slope);
    for w in errs.windows(2) {
        assert!((w[0] / w[1]).log2() > 3.5, "ratio below 2^3.5 in {errs:?}");
    }
}
