//! The AVX-512 build of the SIMD batch code (the default on AMD CPUs for the grouped
//! and the refilled batches; `JEFFCOTT_AVX512=1` or `0` decides)
//! gives the same bits as the AVX2 build: the same operations in the same order, no FMA.

mod common;

use std::process::Command;

fn ensemble(out: &std::path::Path, avx512: bool) {
    let o = Command::new(env!("CARGO_BIN_EXE_jeffcott"))
        .args([
            "ensemble",
            "--omega",
            "130:141:64",
            "--transient",
            "10",
            "--periods",
            "5",
            "--backend",
            "cpu",
            "--lyapunov",
            "--quiet",
            "--out",
        ])
        .arg(out)
        .env("JEFFCOTT_AVX512", if avx512 { "1" } else { "0" })
        .output()
        .expect("binary runs");
    common::ok(&o);
}

/// Whether this CPU runs the AVX-512 batch code (the features `use_avx512` in
/// `jeffcott-core`'s CPU backend asks for).
fn cpu_has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512dq")
            && std::is_x86_feature_detected!("avx512vl")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Runs `run` with the AVX2 and the AVX-512 build into two directories and compares
/// `files` between them byte for byte.
fn same_bits_both_builds(run: fn(&std::path::Path, bool), files: &[&str]) {
    // Without AVX-512 both runs would take the AVX2 code and compare it with itself: a
    // test that cannot fail. It says so instead of passing.
    if !cpu_has_avx512() {
        eprintln!(
            "skipped: this CPU has no AVX-512 (f, dq, vl), so there is no AVX-512 build to compare"
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("avx2"), dir.path().join("avx512"));
    run(&a, false);
    run(&b, true);
    for f in files {
        let (x, y) = (std::fs::read(a.join(f)), std::fs::read(b.join(f)));
        let (x, y) = (x.expect(f), y.expect(f));
        assert!(x == y, "{f} differs between the AVX2 and AVX-512 builds");
    }
}

#[test]
fn avx512_batch_code_gives_the_bits_of_the_avx2_build() {
    same_bits_both_builds(ensemble, &["poincare.npy", "lambda1.npy", "status.npy"]);
}

/// A brute force (refilled batches with early exit, lambda_1 on) and a basin (refilled
/// batches without lambda_1) with each build.
fn refilled(out: &std::path::Path, avx512: bool) {
    for (study, args) in [
        (
            "bifurcation",
            &[
                "--omega",
                "130:141:6",
                "--no-sweep",
                "--ics",
                "3",
                "--brute-transient",
                "120",
                "--periods",
                "8",
                "--max-seeds",
                "2",
                "--early-exit-after",
                "20",
            ][..],
        ),
        (
            "basin",
            &[
                "--omega",
                "133",
                "--x",
                "x_r:-0.006:0.006:6",
                "--y",
                "vx_r:-1:1:6",
                "--transient",
                "150",
                "--periods",
                "16",
                "--uncertainty-samples",
                "0",
                "--early-exit-after",
                "20",
            ][..],
        ),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_jeffcott"))
            .arg(study)
            .args(args)
            .args(["--backend", "cpu", "--no-plot", "--quiet", "--out"])
            .arg(out.join(study))
            .env("JEFFCOTT_AVX512", if avx512 { "1" } else { "0" })
            .output()
            .expect("binary runs");
        common::ok(&o);
    }
}

#[test]
fn avx512_refilled_batches_give_the_bits_of_the_avx2_build_with_and_without_lambda1() {
    same_bits_both_builds(
        refilled,
        &[
            "bifurcation/bifurcation.npy",
            "bifurcation/bifurcation_lambda1.npy",
            "bifurcation/bifurcation_rows.npy",
            "basin/labels.npy",
            "basin/attractors.json",
        ],
    );
}
