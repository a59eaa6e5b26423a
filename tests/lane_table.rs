//! `jeffcott ensemble --lanes FILE`: ensembles from a lane table. What they prove: the
//! lanes.npy (+ params.npy) of a run is a valid input and reproduces the run; a CSV row
//! with its own parameters is the same lane as a plain run with those parameters; bad
//! tables are refused naming row and column.

mod common;
use common::*;
use std::process::Output;

use npyz::WriterBuilder;
use std::path::Path;

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

const SHORT: &[&str] = &[
    "--transient",
    "30",
    "--periods",
    "8",
    "--backend",
    "cpu",
    "--quiet",
];

fn ensemble(out: &Path, extra: &[&str]) -> Output {
    let mut a = vec!["ensemble", "--out", p(out)];
    a.extend_from_slice(SHORT);
    a.extend_from_slice(extra);
    jeffcott(&a)
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn the_lanes_npy_of_a_run_fed_back_reproduces_its_files() {
    let (_tmp, [a, b]) = temp_outs(["a", "b"]);
    ok(&ensemble(
        &a,
        &words("--omega 131:135:7 --init x_r=0.004,vy_r=0.2"),
    ));
    ok(&ensemble(&b, &["--lanes", p(&a.join("lanes.npy"))]));
    for f in ["poincare.npy", "status.npy", "lanes.npy", "params.npy"] {
        assert_eq!(read(&a.join(f)), read(&b.join(f)), "{f}");
    }
}

#[test]
fn a_csv_row_with_its_own_parameters_is_the_lane_of_a_plain_run_with_them() {
    let tmp = tempfile::tempdir().unwrap();
    let csv = tmp.path().join("mc.csv");
    std::fs::write(
        &csv,
        "# Monte Carlo over friction and contact stiffness\n\
         omega, mu, k_c, x_r\n\
         133, 0.0, 1e8, 0.004\n\
         133, 0.2, 1e8, 0.004\n\
         134, 0.1, 5e7, -0.002\n\
         133, 0.2, 1e8, 0.004\n",
    )
    .unwrap();
    let t = tmp.path().join("table");
    ok(&ensemble(&t, &["--lanes", p(&csv)]));
    // Rows 2 and 4 share a parameter set: three distinct sets.
    let params = read(&t.join("params.npy"));
    let f = npyz::NpyFile::new(&params[..]).unwrap();
    assert_eq!(f.shape(), &[3, 14]);
    // Row 2 is the lane of a plain run at W = 133 with mu = 0.2 from x_r = 4 mm.
    let plain = tmp.path().join("plain");
    ok(&ensemble(
        &plain,
        &words("--omega 133 --param mu=0.2 --init x_r=0.004"),
    ));
    let rows = |dir: &Path| -> Vec<f64> {
        let b = read(&dir.join("poincare.npy"));
        npyz::NpyFile::new(&b[..]).unwrap().into_vec().unwrap()
    };
    let (table, single) = (rows(&t), rows(&plain));
    let per = 8 * 8;
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&table[per..2 * per]), bits(&single));
    assert_eq!(bits(&table[3 * per..4 * per]), bits(&single));
    assert_ne!(bits(&table[..per]), bits(&single), "mu = 0 must differ");
    // The run's lanes.npy (param_set column) with its params.npy is itself a table.
    let again = tmp.path().join("again");
    ok(&ensemble(&again, &["--lanes", p(&t.join("lanes.npy"))]));
    assert_eq!(
        read(&t.join("poincare.npy")),
        read(&again.join("poincare.npy"))
    );
    assert_eq!(read(&t.join("params.npy")), read(&again.join("params.npy")));
}

#[test]
fn bad_tables_are_refused_naming_row_and_column() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let mut body = String::from("omega,m_r,mu\n");
    for r in 1..=20 {
        let m = if r == 17 { "-50" } else { "50" };
        body += &format!("133,{m},0.1\n");
    }
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "unknown.csv",
            "omega,spin\n133,1\n".into(),
            vec!["spin", "unknown column", "mu"],
        ),
        (
            "nan.csv",
            "omega\n133\n134\nNaN\n".into(),
            vec!["row 3, column omega", "NaN"],
        ),
        ("mass.csv", body, vec!["row 17, column m_r", "-50"]),
        (
            "text.csv",
            "omega,mu\n133,0.1\n133,lots\n".into(),
            vec!["row 2, column mu", "not a number"],
        ),
        (
            "ragged.csv",
            "omega,mu\n133\n".into(),
            vec!["row 1", "header has 2"],
        ),
        (
            "twice.csv",
            "x_r,x_r0\n0.001,0.002\n".into(),
            vec!["x_r0", "same thing as column x_r"],
        ),
        ("noomega.csv", "mu\n0.1\n".into(), vec!["omega", "--omega"]),
        (
            "far.csv",
            "omega,x_r\n133,2.0\n".into(),
            vec!["row 1, column x_r", "divergence-bound"],
        ),
    ];
    for (name, text, needles) in cases {
        let path = tmp.path().join(name);
        std::fs::write(&path, text).unwrap();
        let o = ensemble(&out, &["--lanes", p(&path)]);
        assert_eq!(o.status.code(), Some(2), "{name}");
        let e = String::from_utf8_lossy(&o.stderr);
        for n in needles {
            assert!(e.contains(n), "{name}: `{n}` not in {e}");
        }
        assert!(!out.join("poincare.npy").exists(), "{name}");
    }
    // An .npy of other than 10 columns needs --columns; a wrong count is named.
    let npy = tmp.path().join("three.npy");
    {
        let mut w = npyz::WriteOptions::new()
            .default_dtype()
            .shape(&[2, 3])
            .writer(std::fs::File::create(&npy).unwrap())
            .begin_nd()
            .unwrap();
        w.extend([133.0, 0.1, 0.0, 134.0, 0.2, 0.0]).unwrap();
        w.finish().unwrap();
    }
    let o = ensemble(&out, &["--lanes", p(&npy)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--columns"));
    let o = ensemble(&out, &["--lanes", p(&npy), "--columns", "omega,mu"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("names 2 columns"));
    ok(&ensemble(
        &out,
        &["--lanes", p(&npy), "--columns", "omega,mu,x_r"],
    ));
}

/// Writes a [rows, cols] f64 table given row by row, in C or Fortran (column-major) order,
/// as `np.save` writes a C array or a transposed one.
fn write_table(path: &Path, rows: &[&[f64]], fortran: bool) {
    let (nr, nc) = (rows.len(), rows[0].len());
    let order = if fortran {
        npyz::Order::Fortran
    } else {
        npyz::Order::C
    };
    let mut w = npyz::WriteOptions::new()
        .default_dtype()
        .shape(&[nr as u64, nc as u64])
        .order(order)
        .writer(std::fs::File::create(path).unwrap())
        .begin_nd()
        .unwrap();
    if fortran {
        w.extend((0..nc).flat_map(|c| rows.iter().map(move |r| r[c])))
            .unwrap();
    } else {
        w.extend(rows.iter().flat_map(|r| r.iter().copied()))
            .unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn a_fortran_ordered_npy_table_is_read_by_rows_as_numpy_means_it() {
    // np.save(f, np.asfortranarray([[131., 0.1], [132., 0.2]])) once ran lanes with
    // omega = [131, 0.1] and mu = [132, 0.2].
    let tmp = tempfile::tempdir().unwrap();
    let rows: &[&[f64]] = &[&[131.0, 0.1], &[132.0, 0.2], &[133.0, 0.15]];
    let (c, f) = (tmp.path().join("c.npy"), tmp.path().join("f.npy"));
    write_table(&c, rows, false);
    write_table(&f, rows, true);
    assert!(String::from_utf8_lossy(&read(&f)).contains("'fortran_order': True"));
    let (oc, of) = (tmp.path().join("oc"), tmp.path().join("of"));
    ok(&ensemble(&oc, &["--lanes", p(&c), "--columns", "omega,mu"]));
    ok(&ensemble(&of, &["--lanes", p(&f), "--columns", "omega,mu"]));
    for name in ["lanes.npy", "params.npy", "poincare.npy"] {
        assert_eq!(read(&oc.join(name)), read(&of.join(name)), "{name}");
    }
    let (shape, lanes) = npy::<f64>(&of.join("lanes.npy"));
    assert_eq!(shape[0], 3);
    let w: Vec<f64> = lanes.chunks(shape[1] as usize).map(|r| r[0]).collect();
    assert_eq!(w, [131.0, 132.0, 133.0]);
    let (pshape, params) = npy::<f64>(&of.join("params.npy"));
    let mu_col = 5; // Params::FIELDS: omega_r, omega_s, xi_r, xi_s, delta, mu, ...
    let mus: Vec<f64> = params
        .chunks(pshape[1] as usize)
        .map(|r| r[mu_col])
        .collect();
    assert_eq!(mus, [0.1, 0.2, 0.15]);
}
