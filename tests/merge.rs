//! `jeffcott merge` assembles a study from what its shards recorded (the specification
//! and the writer's options in run.json), not from their command line.

mod common;

use common::{jeffcott, ok};
use std::path::{Path, PathBuf};

const MAP: &[&str] = &[
    "map",
    "--x",
    "omega:131:137:4",
    "--y",
    "e:2e-5:6e-5:3",
    "--ics",
    "2",
    "--transient",
    "60",
    "--periods",
    "12",
    "--no-plot",
    "--backend",
    "cpu",
    "--quiet",
];

fn run(args: &[&str], out: &Path) {
    let mut a: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    a.extend(["--out".into(), out.display().to_string()]);
    ok(&jeffcott(&a));
}

/// The map computed as two shards into `root`; returns their directories.
fn shards(root: &Path) -> Vec<PathBuf> {
    (0..2)
        .map(|i| {
            let d = root.join(format!("shard{i}"));
            let shard = format!("{i}/2");
            let mut a = MAP.to_vec();
            a.extend(["--shard", &shard]);
            run(&a, &d);
            d
        })
        .collect()
}

/// Rewrites key `key` of `dir`'s run.json.
fn set_run_json(dir: &Path, key: &str, value: serde_json::Value) {
    let path = dir.join("run.json");
    let mut j = common::json(&path);
    j[key] = value;
    std::fs::write(&path, serde_json::to_vec_pretty(&j).unwrap()).unwrap();
}

fn merge(out: &Path, shards: &[PathBuf]) -> std::process::Output {
    let mut a = vec![
        "merge".to_string(),
        "--quiet".into(),
        "--out".into(),
        out.display().to_string(),
    ];
    a.extend(shards.iter().map(|d| d.display().to_string()));
    jeffcott(&a)
}

/// Asserts every final file of `reference` (run.json, which records each run's own
/// command, aside) is in `merged` with the same bytes; returns how many were compared.
fn same_final_files(reference: &Path, merged: &Path) -> usize {
    let mut compared = 0;
    for e in std::fs::read_dir(reference).unwrap().flatten() {
        let f = e.file_name();
        if e.path().is_dir() || f == "run.json" || f.to_string_lossy().starts_with('.') {
            continue;
        }
        assert!(
            std::fs::read(e.path()).unwrap() == std::fs::read(merged.join(&f)).unwrap(),
            "{f:?} differs from the unsharded run's"
        );
        compared += 1;
    }
    compared
}

#[test]
fn a_merge_reads_the_study_from_the_shards_spec_and_not_their_command_line() {
    let tmp = tempfile::tempdir().unwrap();
    let reference = tmp.path().join("reference");
    run(MAP, &reference);
    let shards = shards(tmp.path());
    // A command line that no longer parses: the merge must not need it.
    for d in &shards {
        set_run_json(
            d,
            "argv",
            serde_json::json!(["jeffcott", "no-such-command"]),
        );
    }
    let merged = tmp.path().join("merged");
    ok(&merge(&merged, &shards));
    let compared = same_final_files(&reference, &merged);
    assert!(compared >= 8, "only {compared} files compared");
    // --no-plot was recorded as the writer's option and honoured.
    assert!(!merged.join("map_period.png").exists());
    assert_eq!(
        common::json(&merged.join("run.json"))["write"]["plot"],
        false
    );
}

#[test]
fn a_shard_whose_recorded_spec_does_not_read_is_refused_and_named() {
    let tmp = tempfile::tempdir().unwrap();
    let shards = shards(tmp.path());
    for d in &shards {
        set_run_json(d, "write", serde_json::json!({"plot": "sometimes"}));
    }
    let merged = tmp.path().join("merged");
    let o = merge(&merged, &shards);
    assert_eq!(o.status.code(), Some(2), "{o:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("SHARD_DIR") && err.contains("write"), "{err}");
    assert!(err.contains("shard"), "{err}");
    assert!(!merged.join("period.npy").exists());
}

#[test]
fn an_ensemble_from_a_table_merges_from_its_units_without_the_table() {
    // An ensemble's lanes are in its table, which run.json names but does not hold: the
    // shards' units keep their lanes, so the merge needs neither the shards' command
    // line nor the table (here removed before the merge).
    let tmp = tempfile::tempdir().unwrap();
    let table = tmp.path().join("lanes.csv");
    let mut csv = String::from("omega,x_r,vy_r\n");
    for i in 0..30 {
        let f = i as f64 / 29.0;
        csv += &format!("{},{},{}\n", 130.0 + 11.0 * f, -0.004 + 0.008 * f, 0.3 * f);
    }
    std::fs::write(&table, csv).unwrap();
    let t = table.display().to_string();
    let cmd = [
        "ensemble",
        "--lanes",
        &t,
        "--transient",
        "30",
        "--periods",
        "6",
        "--lyapunov",
        "--backend",
        "cpu",
        "--quiet",
    ];
    let reference = tmp.path().join("reference");
    run(&cmd, &reference);
    let shards: Vec<PathBuf> = (0..3)
        .map(|i| {
            let d = tmp.path().join(format!("shard{i}"));
            let shard = format!("{i}/3");
            let mut a = cmd.to_vec();
            a.extend(["--shard", &shard]);
            run(&a, &d);
            d
        })
        .collect();
    std::fs::remove_file(&table).unwrap();
    let merged = tmp.path().join("merged");
    ok(&merge(&merged, &shards));
    // poincare, status, lanes, params, lambda1.
    assert_eq!(same_final_files(&reference, &merged), 5);
    let j = common::json(&merged.join("run.json"));
    assert_eq!(j["state"], "complete");
    assert_eq!(j["spec"]["lanes"]["count"], 30);
}
