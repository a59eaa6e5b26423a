//! The hostile user's probe, kept: a table of bad inputs for every subcommand (negative,
//! fractional and absurd counts, empty and malformed lists, reversed and degenerate
//! ranges, unknown names, contradictory options, unwritable places). What it proves:
//! each is refused with exit code 2 and one line on stderr that names the option, before
//! any output directory is made, never with a panic; and every subcommand has rows in
//! the table, so the next command added is probed too.

mod common;
use clap::CommandFactory;
use common::{jeffcott, words};

/// (command line (`common::words`: `''` is an empty argument), texts the one-line
/// error must contain).
type Case = (&'static str, &'static [&'static str]);

const CASES: &[Case] = &[
    // Cases found by the hostile user's second probe: a bad bound blamed on itself, an
    // override of the varied parameter refused, huge values short, dashed names.
    (
        "basin --omega 133 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4 --divergence-bound 0",
        &["`divergence-bound`", "> 0"],
    ),
    (
        "ensemble --omega 133 --divergence-bound -1",
        &["`divergence-bound`"],
    ),
    (
        "lyapunov --omega 133 --divergence-bound 0",
        &["`divergence-bound`"],
    ),
    (
        "continuation --vary mu:0:0.1:3 --omega 133 --param mu=0.05",
        &["`param`", "varies mu"],
    ),
    (
        "map --x mu:0:0.1:3 --y omega:132:133:2 --param mu=0.05",
        &["`param`", "varies mu"],
    ),
    (
        "simulate --omega 133 --init x_r=1e300",
        &["`init x_r`", "1e300"],
    ),
    (
        "simulate --omega 133 --timeseries-periods 1000000000",
        &["`timeseries-periods`"],
    ),
    (
        "simulate --omega 133 --config /dev/zero",
        &["/dev/zero", "larger than"],
    ),
    (
        "basin --omega 133 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4 --shard -1/3",
        &["`shard`"],
    ),
    ("bench --out .", &["`out`", "is a directory"]),
    // simulate
    ("simulate --omega 133 --periods -1", &["`periods`", ">= 0"]),
    (
        "simulate --omega 133 --transient 1.5",
        &["`transient`", "whole number"],
    ),
    ("simulate --omega 133 --param ''", &["`param`", "empty"]),
    (
        "simulate --omega 133 --param mu",
        &["`param`", "NAME=VALUE"],
    ),
    ("simulate --omega 133 --param spin=1", &["spin"]),
    ("simulate --omega 133 --init ''", &["`init`", "empty"]),
    ("simulate --omega -133", &["omega"]),
    ("simulate --omega nan", &["omega"]),
    ("simulate", &["--omega"]),
    (
        "simulate --omega 133 --no-such-option",
        &["--no-such-option"],
    ),
    (
        "simulate --omega 133 --spectrum-periods 0",
        &["`spectrum-periods`"],
    ),
    (
        "simulate --omega 133 --spectrum-periods 10000 --steps-per-period 1000000",
        &["`spectrum-periods`", "memory"],
    ),
    (
        "simulate --omega 133 --steps-per-period 4",
        &["`steps-per-period`", "8..="],
    ),
    // ensemble
    ("ensemble --omega 130:141:0", &["`omega`", ">= 1"]),
    ("ensemble --omega 130:130:4", &["`omega`", "a != b"]),
    (
        "ensemble --omega 130:141:1000000000000",
        &["`omega`", "memory"],
    ),
    ("ensemble --omega 130:141:8 --periods 0", &["`periods`"]),
    (
        "ensemble --omega 130:141:8 --param ''",
        &["`param`", "empty"],
    ),
    ("ensemble --omega 130:141:8 --backend tpu", &["tpu"]),
    // bifurcation
    (
        "bifurcation --omega 130:141:8 --coord x_r,x_r",
        &["`coord`", "twice"],
    ),
    (
        "bifurcation --omega 130:141:8 --coord spin",
        &["`coord`", "unknown"],
    ),
    ("bifurcation --omega 130:130:8", &["`omega`", "a != b"]),
    (
        "bifurcation --omega 130:141:8 --periods -3",
        &["`periods`", ">= 0"],
    ),
    (
        "bifurcation --omega 130:141:8 --param ''",
        &["`param`", "empty"],
    ),
    // basin
    (
        "basin --omega 133 --x x_r:-0.006:0.006:1 --y vx_r:-1:1:4",
        &["`x`", "n = 1"],
    ),
    (
        "basin --omega 133 --x x_r:0.006:-0.006:4 --y vx_r:-1:1:4",
        &["`x`", "lo < hi"],
    ),
    (
        "basin --omega 133 --x x_r:-0.006:0.006:4 --y x_r:-0.006:0.006:4",
        &["`y`", "different"],
    ),
    (
        "basin --omega 133 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4 --uncertainty-samples 1000000000000",
        &["`uncertainty-samples`", "0..=1000000"],
    ),
    (
        "basin --omega 133 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4 --param ''",
        &["`param`", "empty"],
    ),
    // map
    (
        "map --omega 133 --x omega:120:150:4 --y e:0.0002:0.002:4",
        &["`omega`", "leave --omega out"],
    ),
    (
        "map --x mu:0:0.3:4 --y e:0.0002:0.002:4",
        &["`omega`", "--omega"],
    ),
    ("map --x mu:0:0.3:4 --y mu:0:0.3:4 --omega 133", &["`y`"]),
    (
        "map --x omega:120:150:4 --y e:0.0002:0.002:4 --param ''",
        &["`param`", "empty"],
    ),
    // continuation
    (
        "continuation --vary omega:130:130:1",
        &["`vary`", "at least 2"],
    ),
    (
        "continuation --vary omega:130:131:3 --param mu:0:0.3:4",
        &["`param`", "--vary"],
    ),
    (
        "continuation --vary omega:130:131:3 --param ''",
        &["`param`", "empty"],
    ),
    ("continuation --vary omega:130:131:3 --ics 0", &["`ics`"]),
    (
        "continuation --vary omega:130:131:3 --omega 133",
        &["`omega`", "leave omega out"],
    ),
    // cascade
    ("cascade --omega 130:130:4", &["`omega`", "a != b"]),
    ("cascade --omega 141:130:4", &["`omega`", "upward"]),
    ("cascade --omega 130:141:4 --periods 0", &["`periods`"]),
    (
        "cascade --omega 130:141:4 --param ''",
        &["`param`", "empty"],
    ),
    // basin-stability
    (
        "basin-stability --omega 133 --box x_r:-0.006:0.006 --sample 10001",
        &["`sample`", "2..=10000"],
    ),
    (
        "basin-stability --omega 133 --box x_r:-0.006:0.006 --sample 1",
        &["`sample`", "2..=10000"],
    ),
    (
        "basin-stability --omega -133 --box x_r:-0.006:0.006",
        &["`omega`"],
    ),
    (
        "basin-stability --omega 141:130:4 --box x_r:-0.006:0.006",
        &["`omega`", "lo < hi"],
    ),
    (
        "basin-stability --omega 133 --box spin:0:1",
        &["`box`", "unknown"],
    ),
    (
        "basin-stability --omega 133 --box x_r:-0.006:0.006 --param ''",
        &["`param`", "empty"],
    ),
    // reproduce
    ("reproduce --backend tpu", &["tpu"]),
    ("reproduce --no-such-option", &["--no-such-option"]),
    // info
    ("info --no-such-option", &["--no-such-option"]),
    // bench
    ("bench --lanes 0", &["`lanes`"]),
    ("bench --out /", &["/"]),
    // lyapunov
    ("lyapunov --omega 130:130:4", &["`omega`", "a != b"]),
    ("lyapunov --omega 133 --time -1", &["`time`"]),
    ("lyapunov --omega 133 --param ''", &["`param`", "empty"]),
    // orbits
    ("orbits --vary x_r:0:1", &["`vary`", "start coordinate"]),
    ("orbits --vary omega:131", &["`vary`", "NAME:lo:hi"]),
    ("orbits --vary omega:132.4:131.7", &["`vary`", "lo < hi"]),
    ("orbits --vary omega:nan:132", &["`vary`", "finite"]),
    ("orbits --vary e:0.0008:0.0012", &["`omega`"]),
    ("orbits --vary omega:131.7:132.4 --omega 130", &["`omega`"]),
    (
        "orbits --vary omega:131.7:132.4 --period 0",
        &["`period`", "1..=64"],
    ),
    ("orbits --vary omega:131.7:132.4 --ds 0", &["`ds`"]),
    (
        "orbits --vary omega:131.7:132.4 --max-points 1",
        &["`max-points`"],
    ),
    ("orbits --vary omega:131.7:132.4 --settle -1", &["`settle`"]),
    ("orbits --vary omega:131.7:132.4 --coord spin", &["spin"]),
    ("orbits --vary omega:131.7:132.4 --backend tpu", &["tpu"]),
    (
        "orbits --vary omega:131.7:132.4 --from /no/such/result",
        &["`from`", "jeffcott basin"],
    ),
    (
        "orbits --vary omega:131.7:132.4 --from /no/such/result --settle 5",
        &["--from", "--settle"],
    ),
    (
        "orbits --vary omega:131.7:132.4 --over /no/such/bifurcation",
        &["`over`"],
    ),
    ("orbits", &["`vary`", "missing", "NAME:lo:hi"]),
    // The explorer refuses a bad model or stepper before it listens.
    ("explore --no-browser --param delta=-1", &["delta", "> 0"]),
    ("explore --no-browser --contact-substeps 3", &["contact"]),
    ("explore --no-browser --port 70000", &["`port`", "70000"]),
    ("explore --no-browser --host localhost-ish", &["`host`"]),
    // A model parameter's range is checked at both ends, as continuation and map do.
    (
        "orbits --vary k_c:-1:1e8 --omega 132",
        &["`vary`", "k_c = -1", "> 0"],
    ),
    (
        "orbits --vary e:-0.001:0.001 --omega 132",
        &["`vary`", "e = -0.001"],
    ),
    (
        "orbits --vary e_max:-1:1 --omega 132",
        &["`vary`", "e_max = -1"],
    ),
    ("orbits --vary m_r:0:50 --omega 132", &["`vary`", "m_r = 0"]),
    (
        "orbits --vary xi_r:-0.5:0.5 --omega 132",
        &["`vary`", "xi_r = -0.5"],
    ),
    // The continued parameter overridden as well.
    (
        "orbits --vary mu:0:0.1 --omega 132 --param mu=0.05",
        &["`param`", "varies mu"],
    ),
    (
        "orbits --vary omega:131.7:132.4 --param mu:0:0.1",
        &["`param`", "NAME=VALUE", "--vary"],
    ),
    (
        "orbits --vary omega:131.7:132.4 --ds-max inf",
        &["`ds-max`"],
    ),
    (
        "orbits --vary omega:131.7:132.4 --ds -1e-5",
        &["`ds`", "> 0"],
    ),
    (
        "orbits --vary omega:131.7:132.4 --init x_r=1e300",
        &["`init x_r`", "1e300", "divergence-bound"],
    ),
    (
        "orbits --vary spin:1:2 --omega 132",
        &["`vary`", "unknown", "omega, omega_r"],
    ),
    // merge
    ("merge --out m", &["SHARD_DIR"]),
    ("merge /no/such/shard --out m", &["/no/such/shard"]),
    // help
    ("help no-such-command", &["no-such-command"]),
];

#[test]
fn every_bad_input_of_the_table_is_refused_in_one_line_naming_the_option() {
    let tmp = tempfile::tempdir().unwrap();
    for (i, (line, needles)) in CASES.iter().enumerate() {
        let out = tmp.path().join(format!("out{i}"));
        let args = words(line);
        let mut a: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        let takes_out = !matches!(args[0], "info" | "bench" | "merge" | "help");
        if takes_out && !a.iter().any(|s| s == "--no-such-option") {
            a.extend(["--out".into(), out.to_str().unwrap().into()]);
        }
        let o = jeffcott(&a);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.starts_with("error: "), "{args:?}: {e}");
        assert_eq!(
            e.trim_end().lines().count(),
            1,
            "{args:?}: not one line: {e}"
        );
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        for n in *needles {
            assert!(e.contains(n), "{args:?}: `{n}` not in {e}");
        }
        assert!(!out.exists(), "{args:?}: made its output directory");
    }
}

#[test]
fn every_subcommand_has_rows_in_the_bad_input_table() {
    let cmd = jeffcott::cli::Cli::command();
    let names: Vec<String> = cmd
        .get_subcommands()
        .map(|c| c.get_name().to_string())
        .chain(["help".to_string()])
        .collect();
    for n in &names {
        assert!(
            CASES.iter().any(|(line, _)| words(line)[0] == n),
            "subcommand `{n}` has no bad inputs in the table"
        );
    }
    // And no row names a subcommand that does not exist.
    for (line, _) in CASES {
        let a = words(line);
        assert!(
            names.iter().any(|n| n == a[0]),
            "unknown subcommand {}",
            a[0]
        );
    }
}
