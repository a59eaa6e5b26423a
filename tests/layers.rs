//! The workspace's layers hold: the numerical core depends on no command line, terminal,
//! picture or GPU crate; the GPU and analysis layers on no command line, terminal or
//! picture crate (`cargo tree`, normal dependencies, default features, as a user of
//! the library crate gets them).

use std::process::Command;

/// The crates `package` pulls in (normal dependencies, default features).
fn dependencies(package: &str) -> Vec<String> {
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "-p",
            package,
            "-e",
            "normal",
            "--prefix",
            "none",
            "--format",
            "{p}",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree -p {package}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect()
}

fn assert_none_of(package: &str, forbidden: &[&str]) {
    let deps = dependencies(package);
    assert!(deps.iter().any(|d| d == package), "{package}: {deps:?}");
    for f in forbidden {
        assert!(
            !deps.iter().any(|d| d == f),
            "{package} depends on {f}: the layer would carry it"
        );
    }
}

#[test]
fn jeffcott_core_depends_on_no_clap_indicatif_plotters_or_wgpu() {
    assert_none_of("jeffcott-core", &["clap", "indicatif", "plotters", "wgpu"]);
}

#[test]
fn the_gpu_and_analysis_layers_depend_on_no_clap_indicatif_or_plotters() {
    for p in ["jeffcott-gpu", "jeffcott-analysis"] {
        assert_none_of(p, &["clap", "indicatif", "plotters"]);
    }
    // And the binding crate sees only the library layers.
    assert_none_of("jeffcott-py", &["clap", "indicatif", "plotters"]);
}
