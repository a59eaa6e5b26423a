//! Runs spread over machines: `--shard i/n` computes every n-th work unit into a shard
//! directory, and `jeffcott merge` turns the shard directories, in any order, into the
//! files of the unsharded run, identical to the bit. Attractors found in several shards
//! get one id.

use jeffcott_analysis::catalogue::{CatalogueBuilder, CatalogueConfig, PartAttractor};
use jeffcott_analysis::classify::Class;
use jeffcott_core::model::{STATE_DIM, State};
use std::path::{Path, PathBuf};

mod common;
use common::{jeffcott, map_files, ok, words};

fn with(list: &[&str], extra: &[&str]) -> Vec<String> {
    list.iter().chain(extra).map(|s| s.to_string()).collect()
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

const BASIN: &str = "basin --omega 133 --x x_r:-0.006:0.006:24 --y vx_r:-1:1:20 --transient 60 \
                     --periods 16 --quiet";

fn same_files(a: &Path, b: &Path, files: &[&str]) {
    for f in files {
        let (x, y) = (std::fs::read(a.join(f)), std::fs::read(b.join(f)));
        assert!(x.is_ok(), "{f} missing in {}", a.display());
        assert!(
            x.unwrap() == y.unwrap(),
            "{f} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// The arguments of `jeffcott merge --out OUT DIRS...`, with `first` before `--out`.
fn merge_args<D: AsRef<Path>>(first: &[&str], out: &Path, dirs: &[D]) -> Vec<String> {
    let mut a = with(&["merge"], first);
    a.extend(["--out".into(), p(out).into()]);
    a.extend(dirs.iter().map(|d| p(d.as_ref()).to_string()));
    a
}

/// Runs `cmd` whole and, for each n of `ns` (the k-th merged in shuffled order
/// `first_seed + k`), as n shards merged, demanding `files` identical to the whole run's;
/// returns the last merged directory.
fn sharded_equals_whole(
    root: &Path,
    cmd: &str,
    ns: &[usize],
    first_seed: usize,
    files: &[&str],
) -> PathBuf {
    let cmd = words(cmd);
    let reference = root.join("reference");
    ok(&jeffcott(&with(&cmd, &["--out", p(&reference)])));
    let mut merged = PathBuf::new();
    for (k, &n) in ns.iter().enumerate() {
        merged = sharded(root, &cmd, n, first_seed + k);
        same_files(&reference, &merged, files);
    }
    merged
}

/// Runs `cmd` as n shards, merges them in a shuffled order, and returns the merged dir.
fn sharded(root: &Path, cmd: &[&str], n: usize, order_seed: usize) -> PathBuf {
    let mut dirs: Vec<PathBuf> = (0..n)
        .map(|i| {
            let d = root.join(format!("n{n}-shard{i}"));
            let shard = format!("{i}/{n}");
            ok(&jeffcott(&with(cmd, &["--shard", &shard, "--out", p(&d)])));
            let j: serde_json::Value =
                serde_json::from_slice(&std::fs::read(d.join("run.json")).unwrap()).unwrap();
            assert_eq!(j["state"], "complete");
            assert!(
                !d.join("labels.npy").exists(),
                "a shard writes no final file"
            );
            d
        })
        .collect();
    dirs.rotate_left(order_seed % n);
    dirs.reverse();
    let out = root.join(format!("n{n}-merged"));
    ok(&jeffcott(&merge_args(&["--quiet"], &out, &dirs)));
    out
}

const BASIN_FILES: &[&str] = &[
    "labels.npy",
    "x.npy",
    "y.npy",
    "attractors.json",
    "basin.png",
    "attractors.png",
];

#[test]
fn a_basin_sharded_in_1_2_3_and_7_and_merged_in_any_order_equals_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    let cpu = format!("{BASIN} --backend cpu");
    sharded_equals_whole(dir.path(), &cpu, &[1, 2, 3, 7], 1, BASIN_FILES);
}

#[test]
fn a_basin_sharded_on_the_gpu_in_f64_merges_to_the_cpu_run() {
    if !common::gpu_f64_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    ok(&jeffcott(&with(
        &words(BASIN),
        &["--backend", "cpu", "--out", p(&reference)],
    )));
    let gpu = with(&words(BASIN), &words("--backend gpu --precision f64"));
    let gpu: Vec<&str> = gpu.iter().map(|s| s.as_str()).collect();
    let merged = sharded(dir.path(), &gpu, 2, 0);
    same_files(&reference, &merged, &["labels.npy", "attractors.json"]);
}

#[test]
fn an_ensemble_sharded_and_merged_equals_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    sharded_equals_whole(
        dir.path(),
        "ensemble --omega 130:141:90 --transient 40 --periods 8 --lyapunov --backend cpu --quiet",
        &[3],
        1,
        &["poincare.npy", "status.npy", "lanes.npy", "lambda1.npy"],
    );
}

#[test]
fn a_lyapunov_range_sharded_in_2_and_5_and_merged_equals_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    sharded_equals_whole(
        dir.path(),
        "lyapunov --omega 131:135:24 --time 8 --min-time 4 --transient 200 --quiet",
        &[2, 5],
        3,
        &[
            "lyapunov.npy",
            "lyapunov_errors.npy",
            "lyapunov.json",
            "lyapunov.png",
        ],
    );
    // One speed is one piece of work: its shards would each compute it whole.
    let one = dir.path().join("one");
    let o = jeffcott(&with(
        &words("lyapunov --omega 133 --time 2 --shard 0/2 --quiet"),
        &["--out", p(&one)],
    ));
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("`shard`") && e.contains("range of speeds"),
        "{e}"
    );
    assert!(!one.exists(), "a refused shard made its directory");
}

/// [`BASIN`] on the CPU over a 6 x 5 grid (15 units): quick shards for refusals.
fn small_basin() -> Vec<String> {
    with(&words(BASIN), &["--backend", "cpu"])
        .into_iter()
        .map(|a| match a.as_str() {
            "x_r:-0.006:0.006:24" => "x_r:-0.006:0.006:6".into(),
            "vx_r:-1:1:20" => "vx_r:-1:1:5".into(),
            _ => a,
        })
        .collect()
}

#[test]
fn merge_refuses_a_missing_a_duplicated_and_a_foreign_shard() {
    let dir = tempfile::tempdir().unwrap();
    let small = small_basin();
    let small: Vec<&str> = small.iter().map(|s| s.as_str()).collect();
    let s = |i: usize, cmd: &[&str], tag: &str| {
        let d = dir.path().join(format!("{tag}{i}"));
        ok(&jeffcott(&with(
            cmd,
            &["--shard", &format!("{i}/3"), "--out", p(&d)],
        )));
        d
    };
    let (s0, s1, s2) = (s(0, &small, "a"), s(1, &small, "a"), s(2, &small, "a"));
    let mut other = small.clone();
    other[2] = "134";
    let foreign = s(2, &other, "b");
    let merge = |dirs: &[&PathBuf]| {
        let out = dir.path().join("m");
        let o = jeffcott(&merge_args(&[], &out, dirs));
        assert_eq!(o.status.code(), Some(2));
        assert!(!out.join("labels.npy").exists());
        String::from_utf8_lossy(&o.stderr).to_string()
    };
    let e = merge(&[&s0, &s2]);
    assert!(e.contains("shard(s) 1 missing"), "{e}");
    let e = merge(&[&s0, &s1, &s2, &s1]);
    assert!(e.contains("duplicates shard 1/3"), "{e}");
    let e = merge(&[&s0, &s1, &foreign]);
    assert!(e.contains("another run"), "{e}");
    // A shard directory whose run is unfinished is refused too.
    let j = s1.join("run.json");
    let text = std::fs::read_to_string(&j)
        .unwrap()
        .replace("\"complete\"", "\"running\"");
    std::fs::write(&j, text).unwrap();
    let e = merge(&[&s0, &s1, &s2]);
    assert!(e.contains("unfinished shard"), "{e}");
}

#[test]
fn merge_names_a_corrupt_truncated_or_swapped_unit_with_its_shard_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let small = small_basin();
    let small: Vec<&str> = small.iter().map(|s| s.as_str()).collect();
    let shards: Vec<PathBuf> = (0..2)
        .map(|i| {
            let d = dir.path().join(format!("s{i}"));
            ok(&jeffcott(&with(
                &small,
                &["--shard", &format!("{i}/2"), "--out", p(&d)],
            )));
            d
        })
        .collect();
    let unit_files = |d: &Path| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(d.join("units"))
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|e| e == "unit"))
            .collect();
        v.sort();
        v
    };
    let (u0, u1) = (unit_files(&shards[0]), unit_files(&shards[1]));
    let victim = u1[0].clone();
    let good = std::fs::read(&victim).unwrap();
    let damage: [(&str, Vec<u8>); 3] = [
        ("corrupt", {
            let mut b = good.clone();
            let mid = b.len() / 2;
            b[mid] ^= 0x40;
            b
        }),
        ("truncated", good[..good.len() - 9].to_vec()),
        // Another unit's file under this unit's name.
        ("swapped", std::fs::read(&u1[1]).unwrap()),
    ];
    for (what, bytes) in damage {
        std::fs::write(&victim, &bytes).unwrap();
        let out = dir.path().join("m");
        let o = jeffcott(&merge_args(&[], &out, &shards));
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{what}: {e}");
        assert!(e.contains("is corrupt"), "{what}: {e}");
        assert!(e.contains(p(&shards[1])), "{what}: names the shard: {e}");
        assert!(e.contains(p(&victim)), "{what}: names the file: {e}");
        assert!(e.contains("nothing was written"), "{what}: {e}");
        assert!(!out.exists(), "{what}: --out was made");
    }
    // Mended, the shards merge.
    std::fs::write(&victim, &good).unwrap();
    assert!(!u0.is_empty());
    let out = dir.path().join("m");
    ok(&jeffcott(&merge_args(&[], &out, &shards)));
}

/// The small basin as shards `0..n` of `n` into `root/{tag}{i}`, with `extra` arguments.
fn shards_of(root: &Path, tag: &str, n: usize, extra: &[&str]) -> Vec<PathBuf> {
    let small = small_basin();
    let small: Vec<&str> = small.iter().map(|s| s.as_str()).collect();
    (0..n)
        .map(|i| {
            let d = root.join(format!("{tag}{i}"));
            let shard = format!("{i}/{n}");
            let args = with(&small, extra);
            let args: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
            ok(&jeffcott(&with(
                &args,
                &["--shard", &shard, "--out", p(&d)],
            )));
            d
        })
        .collect()
}

fn unit_count(d: &Path) -> usize {
    std::fs::read_dir(d.join("units")).map_or(0, |r| r.count())
}

#[test]
fn merge_refuses_an_out_that_is_holds_or_lies_inside_a_shard_and_leaves_the_shards_whole() {
    let dir = tempfile::tempdir().unwrap();
    let shards = shards_of(dir.path(), "s", 3, &[]);
    let before: Vec<usize> = shards.iter().map(|d| unit_count(d)).collect();
    let inside = shards[1].join("merged");
    // Through a symbolic link too: the link resolves to shard 0.
    let link = dir.path().join("link");
    std::os::unix::fs::symlink(&shards[0], &link).unwrap();
    for (out, how) in [
        (shards[0].clone(), "is the shard directory"),
        (dir.path().to_path_buf(), "contains the shard directory"),
        (inside.clone(), "lies inside the shard directory"),
        (link, "is the shard directory"),
    ] {
        let o = jeffcott(&merge_args(&["--overwrite"], &out, &shards));
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{}: {e}", out.display());
        assert!(
            e.contains("`--out`") && e.contains(how),
            "{}: {e}",
            out.display()
        );
    }
    assert!(!inside.exists());
    for (d, n) in shards.iter().zip(before) {
        assert_eq!(unit_count(d), n, "{} lost units", d.display());
        assert!(d.join("run.json").exists());
    }
    ok(&jeffcott(&merge_args(&[], &dir.path().join("m"), &shards)));
}

#[test]
fn units_of_another_run_are_named_and_never_assembled_by_a_merge_or_a_rerun() {
    let dir = tempfile::tempdir().unwrap();
    let ours = shards_of(dir.path(), "a", 2, &[]);
    let theirs = shards_of(dir.path(), "b", 2, &["--param", "mu=0.11"]);
    let key = "basin-0000001.unit";
    let (good, foreign) = (
        ours[1].join("units").join(key),
        theirs[1].join("units").join(key),
    );
    let kept = std::fs::read(&good).unwrap();
    std::fs::copy(&foreign, &good).unwrap();
    let out = dir.path().join("m");
    let o = jeffcott(&merge_args(&[], &out, &ours));
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains(p(&good)) && e.contains("another run"), "{e}");
    assert!(!out.exists(), "--out was made");
    // Rerunning the shard whose units/ holds the foreign unit refuses it and keeps it.
    let small = small_basin();
    let small: Vec<&str> = small.iter().map(|s| s.as_str()).collect();
    let o = jeffcott(&with(&small, &["--shard", "1/2", "--out", p(&ours[1])]));
    let e = String::from_utf8_lossy(&o.stderr);
    assert_ne!(o.status.code(), Some(0), "{e}");
    assert!(e.contains(p(&good)) && e.contains("another run"), "{e}");
    assert_eq!(
        std::fs::read(&good).unwrap(),
        std::fs::read(&foreign).unwrap()
    );
    // A complete unsharded run whose units/ gets another run's unit: no reassembly.
    let whole = dir.path().join("whole");
    ok(&jeffcott(&with(&small, &["--out", p(&whole)])));
    std::fs::copy(&foreign, whole.join("units").join(key)).unwrap();
    let o = jeffcott(&with(&small, &["--out", p(&whole)]));
    let e = String::from_utf8_lossy(&o.stderr);
    assert_ne!(o.status.code(), Some(0), "{e}");
    assert!(e.contains("another run"), "{e}");
    // Mended, the shard's command finishes it (its units kept) and the shards merge.
    std::fs::write(&good, kept).unwrap();
    ok(&jeffcott(&with(
        &small,
        &["--shard", "1/2", "--out", p(&ours[1])],
    )));
    ok(&jeffcott(&merge_args(&[], &out, &ours)));
}

#[test]
fn merge_blames_the_shard_whose_run_json_lacks_a_key_and_a_fresh_merge_says_no_resume() {
    let dir = tempfile::tempdir().unwrap();
    let shards = shards_of(dir.path(), "s", 2, &[]);
    let j = shards[1].join("run.json");
    let text = std::fs::read_to_string(&j).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v.as_object_mut().unwrap().remove("spec");
    std::fs::write(&j, v.to_string()).unwrap();
    let out = dir.path().join("m");
    let o = jeffcott(&merge_args(&[], &out, &shards));
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains(p(&shards[1])) && e.contains("lacks `spec`"),
        "{e}"
    );
    assert!(!e.contains(p(&shards[0])), "the good shard is blamed: {e}");
    std::fs::write(&j, text).unwrap();
    let o = jeffcott(&merge_args(&[], &out, &shards));
    ok(&o);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!e.contains("resuming"), "{e}");
}

fn cycle(n: usize, scale: f64) -> Vec<State> {
    (0..n)
        .map(|k| {
            let mut s = [0.0; STATE_DIM];
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            s[0] = scale * a.cos();
            s[2] = scale * a.sin();
            s
        })
        .collect()
}

fn part(class: Class, points: Vec<State>, lanes: u64) -> PartAttractor {
    let size = 2.0 * points.iter().map(|p| p[0].hypot(p[2])).fold(0.0, f64::max);
    PartAttractor {
        class,
        size_m: size,
        points,
        lanes,
        first_lane: 0,
        l1_sum: 0.0,
        l1_n: 0,
        l1_range: None,
    }
}

/// The identity rules across shards' partial catalogues: a cycle seen in some units
/// only and one seen in all get one id each; an aperiodic cloud whose points are split
/// between units (each unit saw half of the circle) is one attractor.
#[test]
fn attractors_found_in_some_or_all_shards_and_a_split_cloud_get_one_id_each() {
    let mut b = CatalogueBuilder::new(133.0, CatalogueConfig::default());
    let p5 = cycle(5, 1e-3);
    let mut p5_shifted = p5.clone();
    p5_shifted.rotate_left(2); // the same cycle seen from another phase
    let p4 = cycle(4, 2e-3);
    let cloud: Vec<State> = cycle(400, 3e-3);
    let half_a: Vec<State> = cloud.iter().step_by(2).copied().collect();
    let half_b: Vec<State> = cloud.iter().skip(1).step_by(2).copied().collect();
    let units = [
        vec![
            part(Class::Periodic(4), p4.clone(), 3),
            part(Class::Aperiodic, half_a, 2),
        ],
        vec![
            part(Class::Periodic(5), p5.clone(), 1),
            part(Class::Periodic(4), p4.clone(), 1),
        ],
        vec![
            part(Class::Aperiodic, half_b, 4),
            part(Class::Periodic(4), p4, 2),
        ],
        vec![part(Class::Periodic(5), p5_shifted, 2)],
    ];
    let mut ids = Vec::new();
    for (u, parts) in units.iter().enumerate() {
        ids.push(
            parts
                .iter()
                .map(|p| b.absorb(p, 10 * u as u64))
                .collect::<Vec<_>>(),
        );
        b.add_lanes(parts.iter().map(|p| p.lanes).sum(), 0);
    }
    let c = b.finish(Vec::new());
    assert_eq!(
        c.attractors.len(),
        3,
        "{:?}",
        c.attractors.iter().map(|a| a.name()).collect::<Vec<_>>()
    );
    let p4_id = ids[0][0];
    assert!(
        ids[1][1] == p4_id && ids[2][1] == p4_id,
        "the cycle in every unit: one id"
    );
    assert_eq!(
        ids[1][0], ids[3][0],
        "the cycle in two units, phase-shifted: one id"
    );
    assert_eq!(ids[0][1], ids[2][0], "the split cloud: one attractor");
    let lanes: Vec<u64> = c.attractors.iter().map(|a| a.lanes).collect();
    assert_eq!(lanes.iter().sum::<u64>(), 15);
    assert_eq!(c.attractors[p4_id as usize].lanes, 6);
    assert_eq!(
        c.attractors[ids[1][0] as usize].first_lane, 10,
        "first lane from its unit"
    );
}

#[test]
fn a_brute_force_bifurcation_sharded_over_speeds_and_merged_equals_the_unsharded_one() {
    let dir = tempfile::tempdir().unwrap();
    let merged = sharded_equals_whole(
        dir.path(),
        "bifurcation --omega 131:134:24 --ics 3 --transient 40 --transient-first 100 \
         --brute-transient 60 --periods 16 --portraits 133 --backend cpu --quiet",
        &[3],
        2,
        &[
            "omega.npy",
            "bifurcation.npy",
            "bifurcation_rows.npy",
            "bifurcation_lambda1.npy",
            "summary.json",
            "bifurcation.png",
            "attractors_132.9565.png",
        ],
    );
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(merged.join("run.json")).unwrap()).unwrap();
    assert_eq!(j["state"], "complete");
}

#[test]
fn a_map_sharded_in_2_and_5_and_merged_in_any_order_equals_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    sharded_equals_whole(
        dir.path(),
        "map --x omega:131:135:5 --y e:0.0008:0.0012:3 --ics 2 --transient 60 --periods 16 \
         --chunk 1 --backend cpu --quiet",
        &[2, 5],
        2,
        &[&map_files()[..], &["map_period.png"]].concat(),
    );
}

#[test]
fn a_continuation_sharded_in_3_and_merged_equals_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    sharded_equals_whole(
        dir.path(),
        "continuation --vary omega:132.6:133.4:9 --ics 8 --transient 60 --periods 16 \
         --backend cpu --quiet",
        &[3],
        1,
        &[
            "values.npy",
            "fractions_up.npy",
            "tipping_up.npy",
            "fractions_down.npy",
            "tipping_down.npy",
            "continuation.json",
            "continuation.png",
        ],
    );
}
