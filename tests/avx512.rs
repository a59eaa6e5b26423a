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

#[test]
fn avx512_batch_code_gives_the_bits_of_the_avx2_build() {
    #[cfg(target_arch = "x86_64")]
    if !std::is_x86_feature_detected!("avx512f") {
        eprintln!("this CPU has no AVX-512: both runs use the AVX2 code");
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
