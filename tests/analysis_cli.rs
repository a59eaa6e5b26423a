//! `jeffcott bifurcation` and `jeffcott basin` from the command line: every promised
//! file, `.npy` files that follow the NPY format spec, clear errors for bad input.

mod common;
use common::{jeffcott, jeffcott_temp, json, npy_header, ok, temp_out, words};

#[test]
fn bifurcation_writes_arrays_summary_and_diagram() {
    let (_dir, out, o) = jeffcott_temp(
        "bif",
        "bifurcation --omega 132.1:132.3:3 --coord vx_s,vx_r --ics 2 --transient 60 \
         --transient-first 300 --brute-transient 150 --periods 8 --backend cpu --portraits 132.2",
    );
    ok(&o);
    assert_eq!(npy_header(&out.join("omega.npy")), ("<f8".into(), vec![3]));
    let png = std::fs::read(out.join("attractors_132.2000.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let (_, rows) = npy_header(&out.join("bifurcation_rows.npy"));
    assert_eq!(rows[1], 4);
    assert!(rows[0] >= 3 * 2 + 3 * 2, "{rows:?}");
    assert_eq!(
        npy_header(&out.join("bifurcation.npy")).1,
        vec![rows[0], 8, 8]
    );
    // lambda_1 per row, on by default: f64 [rows], aligned with bifurcation_rows.npy.
    assert_eq!(
        npy_header(&out.join("bifurcation_lambda1.npy")),
        ("<f8".into(), vec![rows[0]])
    );
    let png = std::fs::read(out.join("bifurcation.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let s = json(&out.join("summary.json"));
    assert_eq!(s["lyapunov"], true);
    let per = s["per_omega"].as_array().unwrap();
    assert_eq!(per.len(), 3);
    for w in per {
        assert!(w["up"]["class"].is_string() && w["down"]["class"].is_string());
        assert!(w["up"]["lambda1"].is_f64() && w["down"]["lambda1"].is_f64());
        assert!(
            !w["brute_force"]["attractors"]
                .as_array()
                .unwrap()
                .is_empty()
        );
    }
}

#[test]
fn basin_writes_int32_labels_catalogue_and_pictures() {
    let (_dir, out, o) = jeffcott_temp(
        "basin",
        "basin --omega 132.2 --x x_r:-0.004:0.004:4 --y vx_r:-0.5:0.5:3 --fix y_r=-0.0005 \
         --lyapunov --transient 150 --periods 8 --backend cpu",
    );
    ok(&o);
    let a = json(&out.join("attractors.json"));
    assert!(
        a["attractors"]
            .as_array()
            .unwrap()
            .iter()
            .all(|x| x["lambda1"].is_f64())
    );
    assert_eq!(
        npy_header(&out.join("labels.npy")),
        ("<i4".into(), vec![3, 4])
    );
    assert_eq!(npy_header(&out.join("x.npy")).1, vec![4]);
    assert_eq!(
        npy_header(&out.join("lambda1.npy")),
        ("<f8".into(), vec![3, 4])
    );
    for f in ["basin.png", "basin_lambda1.png", "attractors.png"] {
        let png = std::fs::read(out.join(f)).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{f}");
    }
    let a = json(&out.join("attractors.json"));
    assert_eq!(a["fixed"]["y_r"], -0.0005);
    let total: f64 = a["attractors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x["basin_fraction"].as_f64().unwrap())
        .sum::<f64>()
        + a["diverged_fraction"].as_f64().unwrap();
    assert!((total - 1.0).abs() < 1e-12, "fractions sum to 1: {total}");
}

#[test]
fn bad_analysis_input_names_the_field_and_the_allowed_range() {
    let (_dir, out) = temp_out("x");
    let o = out.to_str().unwrap();
    let cases = [
        (
            "basin --omega 133 --x q_r:0:1:4 --y vx_r:0:1:4",
            "unknown coordinate",
        ),
        ("basin --omega 133 --x x_r:1:0:4 --y vx_r:0:1:4", "lo < hi"),
        (
            "basin --omega 133 --x x_r:0:1:4 --y x_r:0:1:4",
            "different coordinates",
        ),
        (
            "basin --omega 133 --x x_r:0:1:4 --y vx_r:0:1:4 --fix x_r=0",
            "is an axis",
        ),
        ("bifurcation --omega 133:130:4", "speeds must increase"),
        (
            "bifurcation --omega 130:133:4 --coord vz",
            "unknown coordinate",
        ),
    ];
    for (line, msg) in cases {
        let args = [words(line), vec!["--out", o]].concat();
        let r = jeffcott(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(msg), "{args:?}: {err}");
    }
    assert!(!out.exists() || !out.join("summary.json").exists());
}

#[test]
fn reproduce_writes_every_figure_and_a_report_that_shows_them() {
    let (_dir, out, o) = jeffcott_temp("rep", "reproduce --smoke --backend cpu --quiet");
    ok(&o);
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    for fig in [
        "fig03_bifurcation_vx_s.png",
        "fig04_bifurcation_vx_r.png",
        "fig05_phase_131.7.png",
        "fig06_phase_132.2.png",
        "fig07_basin_133.png",
        "fig09_phase_135.png",
        "fig10_section_135.png",
        "fig11_section_stator_140.png",
        "fig12_section_rotor_140.png",
        "fig_down_sweep.png",
        "fig_brute_force.png",
    ] {
        let png = std::fs::read(out.join(fig)).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{fig}");
        assert!(
            report.contains(&format!("]({fig})")),
            "REPORT.md shows {fig}"
        );
    }
    assert!(report.contains("| 131.7 |") && report.contains("Command: `jeffcott"));
    // The full spectra at the article's speeds: a row per speed with eight exponents.
    assert!(report.contains("## Lyapunov spectra at the article's speeds"));
    for w in ["131.7", "132.2", "133", "135", "140"] {
        let row = report
            .lines()
            .filter(|l| l.starts_with(&format!("| {w} |")))
            .find(|l| l.matches("+-").count() == 8)
            .unwrap_or_else(|| panic!("a spectrum row at {w}"));
        assert!(row.contains(" %)"), "{row}");
    }
    // The article's spectra beside jeffcott's: as printed (bits/s), in 1/s, and
    // jeffcott's in bits/s with its eight errors, each with its sum.
    assert!(report.contains("## The article's Lyapunov spectra beside jeffcott's"));
    assert!(report.contains("1 bit/s = ln 2 1/s = 0.693 1/s"));
    for (w, printed, per_s) in [
        ("135", "| 0.0 | -2.8 | -6.7 |", "-118.81 | +0.33 % |"),
        ("140", "| 11.4 | -3.4 | -9.5 |", "-119.01 | +0.16 % |"),
    ] {
        let row = |label: &str| {
            let head = format!("| {w} | {label} |");
            report
                .lines()
                .find(|l| l.starts_with(&head))
                .unwrap_or_else(|| panic!("a row {head}"))
                .to_string()
        };
        assert!(row("article, as printed [bits/s]").contains(printed));
        assert!(row("article x ln 2 [1/s]").contains(per_s));
        let jeffcott = row("jeffcott / ln 2 [bits/s]");
        assert_eq!(jeffcott.matches("+-").count(), 8, "{jeffcott}");
        assert!(jeffcott.contains("| -171.97 |"), "{jeffcott}");
    }
    // The Floquet spectra: the period-1 response at 131.7 rad/s has its orbit shot, its
    // eight exponents summing to the trace rule, beside the QR exponents.
    assert!(report.contains("## Floquet spectra of the periodic responses"));
    let floquet = report
        .lines()
        .find(|l| l.starts_with("| 131.7 | period 1, "))
        .expect("a Floquet row at 131.7");
    assert!(floquet.contains("| Floquet [1/s] |"), "{floquet}");
    assert!(floquet.ends_with("| -119.20 |"), "{floquet}");
    for label in ["QR [1/s]", "Floquet - QR [1/s]", "(Floquet - QR) / error"] {
        assert!(
            report.contains(&format!("| 131.7 | | {label} |")),
            "a row {label} at 131.7"
        );
    }
}

#[test]
fn bifurcation_no_lyapunov_writes_no_lambda1_array() {
    let (_dir, out, o) = jeffcott_temp(
        "bif",
        "bifurcation --omega 131.6:131.8:2 --ics 0 --sweep up --transient 20 --transient-first 50 \
         --periods 4 --no-lyapunov --no-plot --quiet",
    );
    ok(&o);
    assert!(!out.join("bifurcation_lambda1.npy").exists());
    let s = json(&out.join("summary.json"));
    assert_eq!(s["lyapunov"], false);
    assert!(s["per_omega"][0]["up"]["lambda1"].is_null());
}
