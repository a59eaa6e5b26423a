//! Runs that survive (the run engine, `jeffcott_analysis::run`): a run killed at any point and
//! resumed by the same command ends with files bit-identical to an uninterrupted run;
//! an output directory never holds a half-written file under a final name, nor files of
//! two runs; a different specification is refused unless `--overwrite`.
//!
//! The harness runs the real binary, kills it with SIGKILL once a given number of work
//! units are committed (it polls `units/`), and runs the same command again.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{jeffcott, ok, temp_out, words};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_jeffcott"))
}

/// Starts the binary with `a`, its stdout discarded and its stderr as `stderr` says.
fn spawn(a: &[String], stderr: Stdio) -> std::process::Child {
    bin()
        .args(a)
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .unwrap()
}

fn args(list: &[&str], out: &Path) -> Vec<String> {
    let mut v: Vec<String> = list.iter().map(|s| s.to_string()).collect();
    v.push("--out".into());
    v.push(out.to_str().unwrap().into());
    v
}

/// Runs `list` into `out`, demanding a refusal (exit code 2, bad input) whose stderr
/// contains every one of `needles`.
fn assert_refused(list: &[&str], out: &Path, needles: &[&str]) {
    assert_refused_with(2, list, out, needles);
}

/// [`assert_refused`] with exit code `code`.
fn assert_refused_with(code: i32, list: &[&str], out: &Path, needles: &[&str]) {
    let o = jeffcott(&args(list, out));
    assert_eq!(o.status.code(), Some(code));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(needles.iter().all(|n| err.contains(n)), "{err}");
}

fn units(dir: &Path) -> usize {
    std::fs::read_dir(dir.join("units"))
        .map(|d| {
            d.flatten()
                .filter(|e| e.file_name().to_string_lossy().ends_with(".unit"))
                .count()
        })
        .unwrap_or(0)
}

/// Starts the command, waits until at least `k` units are committed, kills it with
/// SIGKILL. Returns the units committed when it died, or None when the run finished
/// first: it exited before the poll saw `k` units (a fast machine), or the poll saw them
/// late (a loaded machine) and the kill landed after the run had written its files and
/// marked itself complete, interrupting nothing.
fn kill_after_units(a: &[String], out: &Path, k: usize) -> Option<usize> {
    let mut child = spawn(a, Stdio::null());
    let t = Instant::now();
    loop {
        if let Some(_status) = child.try_wait().unwrap() {
            return None;
        }
        if units(out) >= k {
            child.kill().unwrap();
            child.wait().unwrap();
            if state(out) == "complete" {
                return None;
            }
            return Some(units(out));
        }
        assert!(
            t.elapsed() < Duration::from_secs(300),
            "run did not progress"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Modification times of the committed units. A temporary (`.NAME.unit.PID-N.tmp`) that
/// a SIGKILL left mid-write is not a committed unit: resuming removes it
/// (`no_temporaries` checks that), so it is not compared.
fn unit_times(dir: &Path) -> std::collections::HashMap<String, std::time::SystemTime> {
    std::fs::read_dir(dir.join("units"))
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".unit"))
        .map(|e| {
            (
                e.file_name().to_string_lossy().to_string(),
                e.metadata().unwrap().modified().unwrap(),
            )
        })
        .collect()
}

/// Every final file of a finished run (run.json, the lock and units/ aside), relative.
fn final_files(dir: &Path) -> Vec<PathBuf> {
    fn walk(root: &Path, sub: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(root.join(sub)).unwrap().flatten() {
            let rel = sub.join(e.file_name());
            let name = e.file_name().to_string_lossy().to_string();
            if name == "run.json" || name == "units" || name == ".jeffcott.lock" {
                continue;
            }
            if e.path().is_dir() {
                walk(root, &rel, out);
            } else {
                out.push(rel);
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, Path::new(""), &mut v);
    v.sort();
    v
}

fn assert_same_files(reference: &Path, resumed: &Path) {
    assert_same_files_but(reference, resumed, &[]);
}

/// As [`assert_same_files`], with `skip` (files that carry wall times) only required to
/// exist in both.
fn assert_same_files_but(reference: &Path, resumed: &Path, skip: &[&str]) {
    let a = final_files(reference);
    assert_eq!(a, final_files(resumed), "the same files");
    assert!(!a.is_empty());
    for f in a.iter().filter(|f| !skip.iter().any(|s| f.ends_with(s))) {
        assert!(
            std::fs::read(reference.join(f)).unwrap() == std::fs::read(resumed.join(f)).unwrap(),
            "{} differs from the uninterrupted run's",
            f.display()
        );
    }
}

fn state(dir: &Path) -> String {
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("run.json")).unwrap()).unwrap();
    j["state"].as_str().unwrap().to_string()
}

/// No temporary anywhere under `dir`.
fn no_temporaries(dir: &Path) {
    fn walk(d: &Path) {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            assert!(
                !name.ends_with(".tmp"),
                "temporary left: {}",
                e.path().display()
            );
            if e.path().is_dir() {
                walk(&e.path());
            }
        }
    }
    walk(dir);
}

/// Kills the command after 1, a few and most units, resumes each time, and compares
/// with an uninterrupted run.
fn killed_and_resumed_equals_uninterrupted(cmd: &str, kill_at: &[usize]) {
    killed_and_resumed_equals_uninterrupted_but(cmd, kill_at, &[]);
}

fn killed_and_resumed_equals_uninterrupted_but(cmd: &str, kill_at: &[usize], skip: &[&str]) {
    let cmd = &words(cmd);
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    ok(&jeffcott(&args(cmd, &reference)));
    assert_eq!(state(&reference), "complete");
    let out = dir.path().join("resumed");
    let a = args(cmd, &out);
    let mut killed = 0;
    for &k in kill_at {
        if let Some(n) = kill_after_units(&a, &out, k) {
            killed += 1;
            assert_eq!(
                state(&out),
                "running",
                "killed after {n} units: still marked running"
            );
        }
    }
    assert!(killed > 0, "the run was never interrupted");
    let before = unit_times(&out);
    assert!(!before.is_empty());
    ok(&jeffcott(&a));
    let after = unit_times(&out);
    for (name, t) in &before {
        assert_eq!(
            after.get(name),
            Some(t),
            "committed unit {name} was computed again"
        );
    }
    assert_eq!(state(&out), "complete");
    assert_same_files_but(&reference, &out, skip);
    no_temporaries(&out);
}

const BASIN: &str = "basin --omega 133 --x x_r:-0.006:0.006:24 --y vx_r:-1:1:20 --transient 60 \
                     --periods 16 --backend cpu --quiet";

/// [`BASIN`] at W = 134: another specification for the same directory.
fn basin_at_134() -> Vec<&'static str> {
    let mut b = words(BASIN);
    b[2] = "134";
    b
}

#[test]
fn basin_killed_with_sigkill_and_resumed_has_the_files_of_an_uninterrupted_run() {
    killed_and_resumed_equals_uninterrupted(BASIN, &[1, 5, 14]);
}

#[test]
fn a_refined_and_reintegrated_basin_with_early_exit_killed_and_resumed_equals_an_uninterrupted_run()
{
    // Long enough for lanes to retire early at every stage (grid, refinement, draws).
    killed_and_resumed_equals_uninterrupted(
        "basin --omega 133 --x x_r:-0.006:0.006:16 --y vx_r:-1:1:16 --transient 250 \
         --periods 16 --steps-per-period 200 --refine 1 --uncertainty-samples 12 \
         --backend cpu --quiet",
        &[5, 25, 45],
    );
}

#[test]
fn bifurcation_sweeps_and_brute_force_killed_and_resumed_equal_an_uninterrupted_run() {
    killed_and_resumed_equals_uninterrupted(
        "bifurcation --omega 131:134:24 --ics 2 --transient 40 --transient-first 100 \
         --brute-transient 60 --periods 16 --portraits 133 --backend cpu --quiet",
        // Sweep units (up and down), then the two brute-force passes.
        &[2, 25, 45],
    );
}

#[test]
fn a_brute_force_with_early_exit_killed_and_resumed_equals_an_uninterrupted_run() {
    // Without lambda_1 and with a transient long enough for lanes to record early.
    killed_and_resumed_equals_uninterrupted(
        "bifurcation --omega 131:134.5:24 --ics 4 --no-sweep --brute-transient 300 \
         --periods 24 --max-seeds 4 --steps-per-period 200 --no-lyapunov --backend cpu \
         --quiet",
        &[3, 15, 30],
    );
}

#[test]
fn basin_stability_with_early_exit_killed_and_resumed_equals_an_uninterrupted_run() {
    killed_and_resumed_equals_uninterrupted(
        "basin-stability --omega 133:137.25:4 --sample 64 --box x_r:-0.006:0.006,vx_r:-1:1 \
         --transient 250 --periods 16 --backend cpu --quiet",
        // Fresh units (lanes retire at 133 and 137.25), then the seeded ramp's.
        &[1, 3, 6],
    );
}

#[test]
fn ensemble_killed_and_resumed_equals_an_uninterrupted_run() {
    killed_and_resumed_equals_uninterrupted(
        "ensemble --omega 130:141:200 --transient 60 --periods 8 --lyapunov --backend cpu --quiet",
        &[2, 11],
    );
}

#[test]
fn lyapunov_range_killed_and_resumed_equals_an_uninterrupted_run() {
    killed_and_resumed_equals_uninterrupted(
        "lyapunov --omega 131:135:24 --time 8 --min-time 4 --transient 200 --quiet",
        &[3, 12],
    );
}

#[test]
fn cascade_killed_and_resumed_keeps_its_committed_units_and_equals_an_uninterrupted_run() {
    // Its units were once committed under an empty key and thrown away on resume, so a
    // resumed cascade computed everything again: the harness fails
    // when a unit committed before the kill is computed again.
    killed_and_resumed_equals_uninterrupted(
        "cascade --omega 120:150:100 --transient 200 --transient-first 200 --periods 48 \
         --no-plot --quiet",
        &[2, 5],
    );
}

#[test]
fn continuation_killed_and_resumed_keeps_its_ramp_units_and_equals_an_uninterrupted_run() {
    // Its ramp steps were committed under an empty key like cascade's.
    killed_and_resumed_equals_uninterrupted(
        "continuation --vary omega:131:134:16 --ics 6 --transient 150 --periods 16 \
         --backend cpu --no-plot --quiet",
        &[3, 22],
    );
}

#[test]
fn reproduce_killed_and_resumed_redraws_the_same_figures() {
    // REPORT.md states the wall times of this session's studies; everything else
    // (every figure, every array and JSON file of the studies) is bit-identical.
    killed_and_resumed_equals_uninterrupted_but(
        "reproduce --smoke --backend cpu --quiet",
        &[4, 30],
        &["REPORT.md"],
    );
}

#[test]
fn a_figure_set_begun_with_other_stepper_defaults_is_refused_naming_the_field_and_kept() {
    // reproduce's studies take the stepper's defaults, so its run.json records them: a
    // figure set begun by a version whose early exit started at period 100 must not be
    // finished with units computed from period 30 (docs/early-exit.md).
    let (_dir, out) = temp_out("set");
    let cmd = words("reproduce --smoke --backend cpu --quiet");
    let a = args(&cmd, &out);
    kill_after_units(&a, &out, 4);
    let path = out.join("run.json");
    let mut run = common::json(&path);
    assert_eq!(
        run["spec"]["stepper"]["early_exit_after"],
        jeffcott_core::integrate::lane::StepperConfig::DEFAULT.early_exit_after
    );
    run["spec"]["stepper"]["early_exit_after"] = 100.into();
    std::fs::write(&path, serde_json::to_vec_pretty(&run).unwrap()).unwrap();
    let before = units(&out);
    assert!(before > 0);
    assert_refused(&cmd, &out, &["early_exit_after"]);
    assert_eq!(units(&out), before, "a refused resume removed units");
}

#[test]
fn gpu_basin_killed_and_resumed_equals_an_uninterrupted_cpu_run_bit_for_bit() {
    if !common::gpu_f64_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cpu: Vec<&str> = words(BASIN);
    let mut gpu: Vec<&str> = words(BASIN);
    let b = gpu.iter().position(|a| *a == "cpu").unwrap();
    gpu[b] = "gpu";
    gpu.extend(["--precision", "f64"]);
    let reference = dir.path().join("cpu");
    ok(&jeffcott(&args(&cpu, &reference)));
    // Part on the GPU, killed, then finished on the GPU: the units are backend-free,
    // and f64 lanes on lavapipe are bit-identical to the CPU's.
    let out = dir.path().join("gpu");
    let a = args(&gpu, &out);
    kill_after_units(&a, &out, 3);
    ok(&jeffcott(&a));
    for f in ["labels.npy", "attractors.json", "x.npy", "y.npy"] {
        assert!(
            std::fs::read(reference.join(f)).unwrap() == std::fs::read(out.join(f)).unwrap(),
            "{f}: GPU resumed run differs from the CPU run"
        );
    }
}

#[test]
fn sigint_and_sigterm_stop_cleanly_and_print_the_command_that_resumes() {
    for sig in ["INT", "TERM"] {
        let (_dir, out) = temp_out("b");
        let a = args(&words(BASIN), &out);
        let child = spawn(&a, Stdio::piped());
        let t = Instant::now();
        while units(&out) < 2 {
            assert!(t.elapsed() < Duration::from_secs(300));
            std::thread::sleep(Duration::from_millis(20));
        }
        let status = Command::new("kill")
            .args([&format!("-{sig}"), &child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(130), "SIG{sig}: {err}");
        assert!(err.contains("resume with"), "{err}");
        assert!(err.contains("basin --omega 133"), "{err}");
        assert_eq!(state(&out), "running");
        no_temporaries(&out);
        let kept = units(&out);
        assert!(kept >= 2, "committed units kept");
        ok(&jeffcott(&a));
        assert_eq!(state(&out), "complete");
    }
}

#[test]
fn a_different_specification_is_refused_and_overwrite_leaves_no_file_of_the_old_run() {
    let (_dir, out) = temp_out("b");
    let small: Vec<&str> = words(BASIN)
        .into_iter()
        .map(|a| match a {
            "x_r:-0.006:0.006:24" => "x_r:-0.006:0.006:6",
            "vx_r:-1:1:20" => "vx_r:-1:1:5",
            a => a,
        })
        .collect();
    let mut first = small.clone();
    first.push("--lyapunov");
    ok(&jeffcott(&args(&first, &out)));
    assert!(out.join("lambda1.npy").exists() && out.join("basin_lambda1.png").exists());
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let mut other = small.clone();
    other[2] = "134";
    assert_refused(&other, &out, &["--overwrite", "omega"]);
    assert!(
        out.join("lambda1.npy").exists(),
        "the refused run touched nothing"
    );
    let mut a = args(&other, &out);
    a.push("--overwrite".into());
    ok(&jeffcott(&a));
    assert!(!out.join("lambda1.npy").exists(), "old lambda1.npy removed");
    assert!(
        !out.join("basin_lambda1.png").exists(),
        "old picture removed"
    );
    assert!(
        out.join("notes.txt").exists(),
        "files of no run are left alone"
    );
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("attractors.json")).unwrap()).unwrap();
    assert_eq!(j["omega"], 134.0);
    // A different command into the directory is refused too.
    let ensemble = words("ensemble --omega 133 --transient 1 --periods 2 --quiet");
    assert_refused(&ensemble, &out, &["`basin` run"]);
}

#[test]
fn two_concurrent_runs_into_one_directory_never_mix_their_files() {
    let (_dir, out) = temp_out("b");
    let a = args(&words(BASIN), &out);
    let other = basin_at_134();
    let b = args(&other, &out);
    let (ca, cb) = (spawn(&a, Stdio::piped()), spawn(&b, Stdio::piped()));
    let (oa, ob) = (
        ca.wait_with_output().unwrap(),
        cb.wait_with_output().unwrap(),
    );
    let succeeded = [&oa, &ob].iter().filter(|o| o.status.success()).count();
    assert_eq!(succeeded, 1, "exactly one run owns the directory");
    for o in [&oa, &ob] {
        if !o.status.success() {
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(
                err.contains("another jeffcott run is writing") || err.contains("holds"),
                "{err}"
            );
        }
    }
    assert_eq!(state(&out), "complete");
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("attractors.json")).unwrap()).unwrap();
    let run: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(j["omega"], run["spec"]["omega"], "files of one run only");
    no_temporaries(&out);
}

/// Starts `a`, waits for `k` committed units, deletes the lock file under it.
fn delete_lock_after_units(a: &[String], out: &Path, k: usize) -> std::process::Child {
    let mut child = spawn(a, Stdio::piped());
    let t = Instant::now();
    while units(out) < k {
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before {k} units"
        );
        assert!(t.elapsed() < Duration::from_secs(120));
        std::thread::sleep(Duration::from_millis(10));
    }
    std::fs::remove_file(out.join(".jeffcott.lock")).unwrap();
    child
}

#[test]
fn a_run_whose_lock_file_is_deleted_stops_and_is_never_marked_complete() {
    let (dir, out) = temp_out("b");
    let a = args(&words(BASIN), &out);
    let o = delete_lock_after_units(&a, &out, 2)
        .wait_with_output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(".jeffcott.lock") && err.contains("not marked complete"),
        "{err}"
    );
    assert_eq!(state(&out), "running");
    // The same command then resumes under a new lock and ends as an uninterrupted run.
    let reference = dir.path().join("reference");
    ok(&jeffcott(&args(&words(BASIN), &reference)));
    ok(&jeffcott(&a));
    assert_same_files(&reference, &out);
}

#[test]
fn a_second_run_let_in_by_a_deleted_lock_file_never_mixes_its_files_with_the_first() {
    // Run A loses its lock file mid-run; run B (another specification, --overwrite)
    // takes the directory. A stops at its next commit; B's files are B's alone.
    let (dir, out) = temp_out("b");
    let a = args(&words(BASIN), &out);
    let other = basin_at_134();
    let mut b = args(&other, &out);
    b.push("--overwrite".into());
    let ca = delete_lock_after_units(&a, &out, 2);
    let ob = jeffcott(&b);
    let oa = ca.wait_with_output().unwrap();
    ok(&ob);
    let err = String::from_utf8_lossy(&oa.stderr);
    assert_eq!(oa.status.code(), Some(2), "the first run stopped: {err}");
    assert!(err.contains(".jeffcott.lock"), "{err}");
    assert_eq!(state(&out), "complete");
    let reference = dir.path().join("reference");
    ok(&jeffcott(&args(&other, &reference)));
    assert_same_files(&reference, &out);
    no_temporaries(&out);
}

#[test]
fn an_unwritable_out_is_refused_before_any_computing() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plain-file");
    std::fs::write(&file, "x").unwrap();
    let t = Instant::now();
    let mut big: Vec<&str> = words(BASIN);
    big[4] = "x_r:-0.006:0.006:2000";
    // A place that cannot be written is an I/O failure: exit code 3.
    assert_refused_with(3, &big, &file, &["plain-file", "not a directory"]);
    assert!(
        t.elapsed() < Duration::from_secs(20),
        "refused before computing"
    );
    let unwritable = "/proc/jeffcott-cannot-write-here";
    assert_refused_with(3, &big, Path::new(unwritable), &[unwritable]);
}

/// A small tmpfs (mounted here; the test runs as root in CI) fills during the run: the
/// run fails naming the file, leaves no temporary and no truncated final file, and once
/// space is freed the same command resumes to the uninterrupted run's files.
#[test]
fn a_full_disk_leaves_no_partial_file_and_the_run_resumes_after_space_is_freed() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    ok(&jeffcott(&args(&words(BASIN), &reference)));
    let units_bytes: u64 = std::fs::read_dir(reference.join("units"))
        .unwrap()
        .flatten()
        .map(|e| e.metadata().unwrap().len())
        .sum();
    let mnt = dir.path().join("mnt");
    std::fs::create_dir(&mnt).unwrap();
    // Room for about half of the units, none of the pictures.
    let size = (units_bytes / 2).max(64 * 1024);
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
        .arg(&mnt)
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !mounted {
        let root = Command::new("id")
            .arg("-u")
            .output()
            .map(|o| o.stdout == b"0\n");
        assert!(
            std::env::var("CI").is_err() && root.as_ref().map(|r| !r).unwrap_or(true),
            "cannot mount a tmpfs (CI runs as root and must run this test)"
        );
        eprintln!("skipped: not root, cannot mount a tmpfs");
        return;
    }
    struct Unmount(PathBuf);
    impl Drop for Unmount {
        fn drop(&mut self) {
            let _ = Command::new("umount").arg(&self.0).status();
        }
    }
    let _guard = Unmount(mnt.clone());
    let out = mnt.join("b");
    let a = args(&words(BASIN), &out);
    let o = jeffcott(&a);
    assert_eq!(
        o.status.code(),
        Some(3),
        "the run must fail on a full disk (I/O)"
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("No space left on device"), "{err}");
    assert!(
        err.contains(out.to_str().unwrap()),
        "the error names the file: {err}"
    );
    no_temporaries(&out);
    for f in final_files(&out) {
        let p = out.join(&f);
        let bytes = std::fs::read(&p).unwrap();
        if f.extension().is_some_and(|e| e == "png") {
            assert!(
                bytes.ends_with(&[0xAE, 0x42, 0x60, 0x82]),
                "{} truncated",
                f.display()
            );
        }
    }
    assert_eq!(state(&out), "running");
    let committed = units(&out);
    assert!(committed > 0);
    let status = Command::new("mount")
        .args(["-o", "remount,size=64m"])
        .arg(&mnt)
        .status()
        .unwrap();
    assert!(status.success());
    ok(&jeffcott(&a));
    assert_same_files(&reference, &out);
}

/// A basin's labels and catalogue do not depend on how its grid is cut into units when
/// its attractors are periodic: partial catalogues absorbed in unit order give the ids,
/// fractions and representative cycles of one unit holding every lane (every lane run
/// whole); with early exit the same labels, ids, fractions and first lanes, and
/// representative cycles within the catalogue's cycle tolerance (each is the cycle of
/// the lane that found it, and which lane that is depends on the unit's rounds).
#[test]
fn basin_labels_do_not_depend_on_the_unit_size() {
    for early in [false, true] {
        basin_labels_do_not_depend_on_the_unit_size_with(early);
    }
}

fn basin_labels_do_not_depend_on_the_unit_size_with(early: bool) {
    use jeffcott_analysis::basin::{Axis, BasinSpec, basin};
    use jeffcott_core::model::{Params, VX_R, X_R};
    let p = Params::default();
    let mut spec = BasinSpec {
        base: p.static_equilibrium(),
        lane: {
            let mut l = common::cpu_f64_lane(p, false);
            if !early {
                l.stepper.early_exit_streak = 0;
            }
            l
        },
        omega: 133.0,
        x: Axis {
            coord: X_R,
            lo: -0.006,
            hi: 0.006,
            n: 10,
        },
        y: Axis {
            coord: VX_R,
            lo: -1.0,
            hi: 1.0,
            n: 8,
        },
        transient: 250,
        periods: 32,
        lanes_per_unit: Some(80),
    };
    let one = basin(&spec, jeffcott_core::control::Control::none()).unwrap();
    let periods: Vec<Option<usize>> = one.catalogue.attractors.iter().map(|a| a.period).collect();
    assert!(
        periods.len() >= 2 && periods.iter().all(|p| p.is_some()),
        "two or more periodic attractors at W = 133: {periods:?}"
    );
    for unit in [1, 7, 13] {
        spec.lanes_per_unit = Some(unit);
        let cut = basin(&spec, jeffcott_core::control::Control::none()).unwrap();
        assert_eq!(
            cut.labels, one.labels,
            "units of {unit} lanes, early exit {early}"
        );
        for (a, b) in cut
            .catalogue
            .attractors
            .iter()
            .zip(&one.catalogue.attractors)
        {
            assert_eq!(
                (a.id, a.period, a.lanes, a.first_lane),
                (b.id, b.period, b.lanes, b.first_lane)
            );
            if early {
                let tol = 1e-2 * a.size_m.max(b.size_m) + 1e-6;
                for (p, q) in a.points.iter().zip(&b.points) {
                    let d = jeffcott_analysis::classify::distance(p, q, 133.0);
                    assert!(d <= tol, "cycle points {d} apart (tolerance {tol})");
                }
            } else {
                assert_eq!(a.points, b.points);
            }
        }
    }
}
