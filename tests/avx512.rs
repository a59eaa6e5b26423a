//! The AVX-512 build of the SIMD batch code (opt-in, `JEFFCOTT_AVX512=1`) gives the same
//! bits as the default AVX2 build: the same operations in the same order, no FMA.

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

#[test]
fn avx512_batch_code_gives_the_bits_of_the_avx2_build() {
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
    ensemble(&a, false);
    ensemble(&b, true);
    for f in ["poincare.npy", "lambda1.npy", "status.npy"] {
        let (x, y) = (std::fs::read(a.join(f)), std::fs::read(b.join(f)));
        let (x, y) = (x.expect(f), y.expect(f));
        assert!(x == y, "{f} differs between the AVX2 and AVX-512 builds");
    }
}
