//! The `jeffcott` command line: good runs write every promised file; bad input gives a
//! clear error naming the field and range, exit code 2, no panic, and no summary.json
//! (the file that marks a complete result).

use std::path::Path;

mod common;
use common::{jeffcott, jeffcott_out, jeffcott_temp, npy_header, ok, temp_out, words};

/// The shape of an f64 NPY file that follows the format spec (`common::npy_header`).
fn npy_shape(path: &Path) -> Vec<usize> {
    let (descr, dims) = npy_header(path);
    assert_eq!(descr, "<f8", "{}", path.display());
    dims
}

#[test]
fn simulate_writes_poincare_timeseries_summary_and_plot() {
    let (_dir, out, o) = jeffcott_temp(
        "run",
        "simulate --omega 132.2 --transient 600 --periods 16 --init vx_r=0.01",
    );
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("period-2"), "{stdout}");
    assert_eq!(npy_shape(&out.join("poincare.npy")), vec![16, 8]);
    assert_eq!(npy_shape(&out.join("timeseries.npy")), vec![8 * 500 + 1, 9]);
    let png = std::fs::read(out.join("phase.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["omega"], 132.2);
    assert_eq!(s["class"], "period-2");
    assert_eq!(s["period"], 2);
    assert_eq!(s["periods"], 16);
    assert_eq!(s["transient"], 600);
    assert_eq!(s["steps_per_period"], 500);
    assert_eq!(s["params"]["k_c"], 1e8);
    assert_eq!(s["initial_state"]["vx_r"], 0.01);
    assert!(s["contact"]["counters"]["switches"].as_u64().unwrap() > 0);
    // The wall time is run.json's only, so a re-run's summary.json is byte-identical.
    assert!(s.get("wall_time_s").is_none());
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
    assert!(r["wall_time_s"].as_f64().unwrap() > 0.0);
}

fn assert_rejected(args: &[&str], needles: &[&str]) {
    let (_dir, out) = temp_out("run");
    let mut all: Vec<&str> = args.to_vec();
    all.extend([
        "--out",
        out.to_str().unwrap(),
        "--transient",
        "2",
        "--periods",
        "2",
    ]);
    let o = jeffcott(&all);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "args {args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for n in needles {
        assert!(
            stderr.contains(n),
            "args {args:?}: expected {n:?} in {stderr}"
        );
    }
    assert!(
        !out.join("summary.json").exists(),
        "no result may be presented"
    );
}

#[test]
fn bad_parameters_and_input_are_rejected_with_the_field_and_range() {
    let cases: &[(&str, &[&str])] = &[
        ("simulate --omega 133 --param k_c=-1", &["k_c", "-1", "> 0"]),
        ("simulate --omega 133 --param xi_r=-0.1", &["xi_r", ">= 0"]),
        ("simulate --omega 133 --param m_s=0", &["m_s", "> 0"]),
        (
            "simulate --omega 133 --param delta=inf",
            &["delta", "finite"],
        ),
        ("simulate --omega 133 --param mu=nan", &["mu", "finite"]),
        (
            "simulate --omega 133 --param stiffness=3",
            &["stiffness", "valid names", "k_c"],
        ),
        ("simulate --omega 133 --param k_c", &["param", "NAME=VALUE"]),
        ("simulate --omega -5", &["omega", "> 0"]),
        ("simulate --omega nan", &["omega"]),
        ("simulate --omega abc", &["omega"]),
        ("simulate --omega 133 --init z_r=1", &["z_r", "x_r, vx_r"]),
        (
            "simulate --omega 133 --init x_r=fast",
            &["x_r", "not a number"],
        ),
        (
            "simulate --omega 133 --steps-per-period 3",
            &["steps-per-period", "8..="],
        ),
        (
            "simulate --omega 133 --config /nonexistent/p.toml",
            &["/nonexistent/p.toml"],
        ),
        ("simulate", &["--omega"]),
    ];
    for &(line, needles) in cases {
        assert_rejected(&words(line), needles);
    }
}

#[test]
fn periods_zero_and_bad_config_keys_are_rejected() {
    let (dir, _, o) = jeffcott_temp("run", "simulate --omega 133 --periods 0");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("periods"));
    let cfg = dir.path().join("p.toml");
    std::fs::write(&cfg, "k_c = 2e8\nstiffnes = 1\n").unwrap();
    let with_config = |needles: &[&str]| {
        let args = [
            "simulate",
            "--omega",
            "133",
            "--config",
            cfg.to_str().unwrap(),
        ];
        assert_rejected(&args, needles)
    };
    with_config(&["stiffnes", "p.toml"]);
    std::fs::write(&cfg, "k_c = -2e8\n").unwrap();
    with_config(&["k_c", "> 0"]);
}

#[test]
fn config_file_and_param_overrides_reach_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("p.toml");
    std::fs::write(&cfg, "delta = 1.0\nmu = 0.2\n").unwrap();
    let out = dir.path().join("run");
    let o = jeffcott(&[
        "simulate",
        "--omega",
        "133",
        "--config",
        cfg.to_str().unwrap(),
        "--param",
        "mu=0.1",
        "--transient",
        "300",
        "--periods",
        "4",
        "--no-plot",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    ok(&o);
    assert!(o.stdout.is_empty(), "--quiet prints nothing");
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["params"]["delta"], 1.0);
    assert_eq!(s["params"]["mu"], 0.1);
    // A 1 m gap never rubs: the free response is period-1.
    assert_eq!(s["class"], "period-1");
    assert_eq!(s["contact"]["counters"]["switches"], 0);
    assert!(!out.join("phase.png").exists());
}

#[test]
fn a_config_file_of_a_machine_as_measured_reaches_the_model_as_its_frequencies() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("machine.toml");
    // Integers are numbers too; the keys in any order.
    let machine = "c_r = 170\nk_r = 600000\nm_r = 30\nunbalance = 0.024\n";
    std::fs::write(&cfg, machine).unwrap();
    let out = dir.path().join("run");
    let cfg_s = cfg.to_str().unwrap();
    let args = ["simulate", "--omega", "133", "--config", cfg_s];
    let mut all = args.to_vec();
    let out_s = out.to_str().unwrap();
    all.extend(["--periods", "2", "--no-plot", "--quiet", "--out", out_s]);
    ok(&jeffcott(&all));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let wr = (600000.0f64 / 30.0).sqrt();
    assert_eq!(s["params"]["omega_r"], wr);
    assert_eq!(s["params"]["xi_r"], 170.0 / (2.0 * 30.0 * wr));
    assert_eq!(s["params"]["e"], 0.024 / 30.0);
    std::fs::write(&cfg, "k_r = \"stiff\"\n").unwrap();
    assert_rejected(&args, &["k_r", "machine.toml", "number"]);
    std::fs::write(&cfg, "k_r = 6e5\nomega_r = 141\n").unwrap();
    assert_rejected(&args, &["k_r", "omega_r", "give one of"]);
}

#[test]
fn ensemble_writes_poincare_status_lanes_and_run_json() {
    let (_dir, out, o) = jeffcott_temp(
        "ens",
        "ensemble --omega 131.7:132.2:3 --transient 400 --periods 8 --backend cpu",
    );
    ok(&o);
    assert_eq!(npy_shape(&out.join("poincare.npy")), vec![3, 8, 8]);
    assert_eq!(npy_shape(&out.join("lanes.npy")), vec![3, 10]);
    let status = std::fs::read(out.join("status.npy")).unwrap();
    assert!(String::from_utf8_lossy(&status[..128]).contains("'descr': '<u4'"));
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(r["backend"], "cpu");
    assert_eq!(r["precision"], "f64");
    assert_eq!(r["lanes"], 3);
    assert_eq!(r["status_counts"]["ok"], 3);
    assert!(r["lane_steps_per_s"].as_f64().unwrap() > 0.0);
    assert!(!out.join("lambda1.npy").exists(), "lambda1 only on request");
}

/// `--lyapunov` adds lambda_1 per lane: negative on the article's period-1 and period-2
/// responses (131.7, 132.2), and a positive one on the chaotic response at 140.
#[test]
fn ensemble_lyapunov_writes_lambda1_negative_when_periodic_positive_when_chaotic() {
    let (dir, out, o) = jeffcott_temp(
        "ens",
        "ensemble --omega 131.7 --transient 300 --periods 200 --backend cpu --lyapunov --quiet",
    );
    ok(&o);
    let read = |out: &Path| -> Vec<f64> {
        assert_eq!(npy_shape(&out.join("lambda1.npy")), vec![1]);
        let b = std::fs::read(out.join("lambda1.npy")).unwrap();
        b[b.len() - 8..]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    };
    let periodic = read(&out)[0];
    assert!(periodic < -0.5, "lambda_1 at 131.7 = {periodic}");
    let out2 = dir.path().join("ens2");
    ok(&jeffcott_out(
        "ensemble --omega 140 --transient 300 --periods 300 --backend cpu --lyapunov --quiet",
        &out2,
    ));
    let chaotic = read(&out2)[0];
    assert!(chaotic > 1.0, "lambda_1 at 140 = {chaotic}");
}

#[test]
fn ensemble_rejects_bad_ranges_with_the_syntax() {
    for (range, needle) in [
        ("130:141", "a:b:n"),
        ("130:141:0", ">= 1"),
        ("130:x:4", "not a number"),
        ("-1:2:3", "omega (lane 0)"),
    ] {
        let (_dir, out) = temp_out("ens");
        let o = jeffcott(&[
            "ensemble",
            "--omega",
            range,
            "--backend",
            "cpu",
            "--out",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{range}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{range}: expected {needle:?} in {stderr}"
        );
        assert!(!out.join("run.json").exists());
    }
}

#[test]
fn the_cli_reference_in_docs_is_the_one_the_binary_generates() {
    // docs/cli.md is `jeffcott info --cli-reference`: a flag added, renamed or described
    // anew without regenerating it fails here.
    let o = jeffcott(&["info", "--cli-reference"]);
    ok(&o);
    let generated = String::from_utf8(o.stdout).unwrap();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/cli.md");
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        generated.contains("## `jeffcott orbits`") && generated.contains("--vary"),
        "{generated}"
    );
    assert!(
        committed == generated,
        "docs/cli.md is not current: regenerate it with `cargo run --release -- info --cli-reference > docs/cli.md`"
    );
}

#[test]
fn run_json_records_the_version_and_commit_that_jeffcott_version_reports() {
    let v = jeffcott(&["--version"]);
    ok(&v);
    let said = String::from_utf8(v.stdout).unwrap();
    // "jeffcott 0.2.0 (commit 0123456789ab)"
    let commit = said
        .split("(commit ")
        .nth(1)
        .and_then(|r| r.split(')').next())
        .unwrap_or_else(|| panic!("no commit in --version: {said}"))
        .to_string();
    assert!(said.starts_with(&format!("jeffcott {} ", env!("CARGO_PKG_VERSION"))));
    assert!(!commit.is_empty(), "{said}");
    let (_dir, out, o) = jeffcott_temp(
        "ver",
        "simulate --omega 131.7 --transient 10 --periods 4 --no-plot --quiet",
    );
    ok(&o);
    let run = common::json(&out.join("run.json"));
    assert_eq!(run["jeffcott_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(run["jeffcott_commit"], commit.as_str());
    // Built from a git checkout (as the test suite is), the commit is its HEAD's.
    let head = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output();
    match head {
        Ok(h) if h.status.success() => {
            assert_eq!(String::from_utf8_lossy(&h.stdout).trim(), commit)
        }
        _ => eprintln!("skipped: the commit against git (no git here)"),
    }
}
