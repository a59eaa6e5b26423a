//! What the hostile user's probes found beyond single bad inputs (those are the table of
//! tests/bad_inputs.rs), kept as tests: re-runs that must be byte-identical, options a
//! run never reads that must not make it another run, refusals that must name the
//! option the user typed, paths that lead nowhere, and lane tables whose columns an
//! option would silently lose to.

mod common;
use common::{jeffcott, jeffcott_out, json, ok, words};
use std::path::Path;

/// Runs `line` into `out` twice and returns the bytes of `file` after each run.
fn twice(line: &str, out: &Path, file: &str) -> (Vec<u8>, Vec<u8>) {
    ok(&jeffcott_out(line, out));
    let first = std::fs::read(out.join(file)).unwrap();
    ok(&jeffcott_out(line, out));
    (first, std::fs::read(out.join(file)).unwrap())
}

#[test]
fn a_rerun_of_simulate_or_a_one_speed_lyapunov_writes_its_files_byte_identical() {
    let tmp = tempfile::tempdir().unwrap();
    for (line, file) in [
        (
            "simulate --omega 132.2 --transient 100 --periods 8 --no-plot --quiet",
            "summary.json",
        ),
        (
            "lyapunov --omega 133 --time 2 --min-time 2 --quiet",
            "spectrum.json",
        ),
    ] {
        let out = tmp.path().join(words(line)[0]);
        let (a, b) = twice(line, &out, file);
        assert!(a == b, "{line}: {file} differs between two runs");
        let run = json(&out.join("run.json"));
        assert!(run["wall_time_s"].as_f64().unwrap() > 0.0, "{run}");
    }
}

#[test]
fn options_a_run_never_reads_do_not_make_it_another_run() {
    let tmp = tempfile::tempdir().unwrap();
    let sim = tmp.path().join("sim");
    let line = "simulate --omega 132.2 --transient 20 --periods 4 --no-plot --quiet";
    ok(&jeffcott_out(line, &sim));
    ok(&jeffcott_out(
        &format!("{line} --early-exit-streak 4 --lyapunov-align 7"),
        &sim,
    ));
    let orbits = tmp.path().join("orbits");
    let line = "orbits --vary omega:131.0:131.2 --max-points 3 --no-plot --quiet";
    ok(&jeffcott_out(&format!("{line} --backend cpu"), &orbits));
    ok(&jeffcott_out(
        &format!("{line} --backend auto --early-exit-after 50"),
        &orbits,
    ));
    let spec = &json(&orbits.join("run.json"))["spec"];
    assert!(spec.get("backend").is_none(), "{spec}");
    assert!(spec["stepper"].get("early_exit_after").is_none(), "{spec}");
}

#[test]
fn a_basin_stability_rerun_with_another_sample_is_refused_naming_sample() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("bs");
    let line = "basin-stability --omega 133:133.2:2 --box x_r:-0.004:0.004,vx_r:-0.5:0.5 \
                --transient 40 --periods 16 --no-plot --backend cpu --quiet";
    ok(&jeffcott_out(&format!("{line} --sample 8"), &out));
    let o = jeffcott_out(&format!("{line} --sample 9"), &out);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("differs in: sample"), "{e}");
    assert!(!e.contains("ics"), "{e}");
}

#[test]
fn an_out_that_is_a_dangling_or_looping_symbolic_link_is_explained() {
    let tmp = tempfile::tempdir().unwrap();
    let dangling = tmp.path().join("dangling");
    std::os::unix::fs::symlink(tmp.path().join("nowhere"), &dangling).unwrap();
    let looping = tmp.path().join("loop");
    std::os::unix::fs::symlink(&looping, &looping).unwrap();
    for (out, needle) in [(&dangling, "which does not exist"), (&looping, "loops")] {
        let o = jeffcott_out("simulate --omega 133 --periods 2 --quiet", out);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "{e}");
        assert!(e.contains("symbolic link") && e.contains(needle), "{e}");
        assert!(!e.contains("File exists"), "{e}");
    }
}

#[test]
fn an_init_or_param_that_a_lane_tables_column_sets_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let table = tmp.path().join("t.csv");
    std::fs::write(&table, "omega,x_r,mu\n133,0.001,0.1\n133.5,0.002,0.1\n").unwrap();
    for (extra, needle) in [
        ("--init x_r=0.003", "`init`"),
        ("--param mu=0.2", "`param`"),
    ] {
        let o = jeffcott(&words(&format!(
            "ensemble --lanes {} {extra} --transient 1 --periods 1 --quiet --out {}",
            table.display(),
            tmp.path().join("e").display()
        )));
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(e.contains(needle) && e.contains("column"), "{e}");
    }
    // Options the table does not set still apply.
    ok(&jeffcott(&words(&format!(
        "ensemble --lanes {} --init y_r=0.0001 --param k_c=2e8 --transient 1 --periods 1 \
         --quiet --out {}",
        table.display(),
        tmp.path().join("f").display()
    ))));
}

#[test]
fn merge_refuses_shards_of_two_versions_naming_them() {
    let tmp = tempfile::tempdir().unwrap();
    let line = "basin --omega 133 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:3 --transient 20 \
                --periods 16 --backend cpu --quiet";
    let shards: Vec<_> = (0..2)
        .map(|i| {
            let d = tmp.path().join(format!("s{i}"));
            ok(&jeffcott_out(&format!("{line} --shard {i}/2"), &d));
            d
        })
        .collect();
    let j = shards[1].join("run.json");
    let mut v = json(&j);
    v["jeffcott_version"] = "0.0.1".into();
    std::fs::write(&j, v.to_string()).unwrap();
    let mut a = vec!["merge".to_string(), "--out".into()];
    a.push(tmp.path().join("m").display().to_string());
    a.extend(shards.iter().map(|d| d.display().to_string()));
    let o = jeffcott(&a);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("jeffcott 0.0.1") && e.contains("one version"),
        "{e}"
    );
}
