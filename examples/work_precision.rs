//! The work-precision diagram (`bash benches/baseline/run.sh`): the
//! lane stepper against the strongest simple peer (`benches/peer/rk4_numba.py`: numba
//! RK4, steps whose stages disagree on the contact state redone as 8 sub-steps, prange),
//! the C loop (`benches/baseline/rk4_switch.c`: steps whose contact state changes redone
//! as 8 sub-steps, OpenMP) and the event-free loop, on the standard job (1024 lanes at W = 133, x_r0 evenly over
//! [-4, 4] mm, 200 periods from t = 0). Error: per lane, the largest position error of
//! the final state against the lane stepper at N = 8000 (two references, N = 4000 and
//! 8000, say how converged that is). Writes docs/work-precision.png and .csv and prints
//! the table and the speed ratios at equal worst-lane and 99th-percentile accuracy.
//!
//! Each program's own timing of its work is used (numba's compilation and the process
//! start are not part of it).
//!
//! Usage: work_precision PATH_TO_rk4_switch [LANES] [PERIODS] [PYTHON_WITH_NUMBA]

use jeffcott_analysis::backend::run;
use jeffcott_analysis::bench::{quantile, sorted_position_errors};
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision};
use jeffcott_core::integrate::lane::{DEFAULT_CONTACT_SUBSTEPS, StepperConfig};
use jeffcott_core::model::{Params, STATE_DIM, State};
use std::process::Command;
use std::time::Instant;

/// The standard job's lanes, integrated by the lane stepper at N steps per period with
/// contact refinement R (and the exact free-flight step where `exact`); also the mean
/// RK4 sub-steps per lane-period.
fn lane_stepper(
    lanes: usize,
    periods: u32,
    n: u32,
    r: u32,
    exact: bool,
) -> anyhow::Result<(Vec<State>, f64, f64)> {
    let p = Params::default();
    let eq = p.static_equilibrium();
    let spec = EnsembleSpec {
        param_sets: vec![p],
        lanes: (0..lanes)
            .map(|i| {
                let mut x0 = eq;
                x0[0] = -0.004 + 0.008 * i as f64 / (lanes.max(2) - 1) as f64;
                LaneSpec {
                    omega: 133.0,
                    x0,
                    param_set: 0,
                }
            })
            .collect(),
        transient: periods - 1,
        recorded: 1,
        stepper: StepperConfig {
            steps_per_period: n,
            contact_substeps: r,
            exact_free_flight: exact,
            ..Default::default()
        },
        precision: Precision::F64,
    };
    let t = Instant::now();
    let (res, _) = run(&spec, Backend::Cpu, false, Control::none())?;
    let wall = t.elapsed().as_secs_f64();
    let substeps: u64 = res
        .counters
        .iter()
        .map(|c| c.macro_steps + c.extra_substeps)
        .sum();
    let per_lane_period = substeps as f64 / (lanes as f64 * periods as f64);
    Ok((res.final_state, wall, per_lane_period))
}

/// Runs a hand-written loop, `program` (its command words: the C binary, or a Python
/// interpreter and the numba script), in `mode` (`plain` or `substep`) at N = `n`: the
/// final states it wrote and the wall time it printed (`wall=SECONDS`).
fn baseline(
    program: &[&str],
    mode: &str,
    n: u32,
    lanes: usize,
    periods: u32,
) -> anyhow::Result<(Vec<State>, f64)> {
    let out = std::env::temp_dir().join(format!("rk4_baseline_{}.bin", std::process::id()));
    let exe = program.join(" ");
    let o = Command::new(program[0])
        .args(&program[1..])
        .args([
            mode,
            &n.to_string(),
            &periods.to_string(),
            &lanes.to_string(),
        ])
        .arg(&out)
        .output()?;
    anyhow::ensure!(o.status.success(), "{exe} failed: {o:?}");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let wall: f64 = stdout
        .split_whitespace()
        .find_map(|w| w.strip_prefix("wall="))
        .ok_or_else(|| anyhow::anyhow!("{exe} printed no wall=: {stdout}"))?
        .parse()?;
    let bytes = std::fs::read(&out)?;
    std::fs::remove_file(&out).ok();
    let states: Vec<State> = bytes
        .chunks_exact(8 * STATE_DIM)
        .map(|c| {
            std::array::from_fn(|d| f64::from_le_bytes(c[8 * d..8 * d + 8].try_into().unwrap()))
        })
        .collect();
    anyhow::ensure!(states.len() == lanes, "{exe} wrote {} lanes", states.len());
    Ok((states, wall))
}

/// Throughput at which a method's error curve crosses `target` (log-log interpolation
/// between its two points around it), if it does.
fn at_error(points: &[(f64, f64)], target: f64) -> Option<f64> {
    points.windows(2).find_map(|w| {
        let ((x0, e0), (x1, e1)) = (w[0], w[1]);
        let (lo, hi) = (e0.min(e1), e0.max(e1));
        (lo <= target && target <= hi && e0 != e1).then(|| {
            let f = (target.ln() - e0.ln()) / (e1.ln() - e0.ln());
            (x0.ln() + f * (x1.ln() - x0.ln())).exp()
        })
    })
}

/// Throughput of the fastest measured point whose error is at most `target`.
fn cheapest(points: &[(f64, f64)], target: f64) -> Option<f64> {
    points
        .iter()
        .filter(|p| p.1 <= target)
        .map(|p| p.0)
        .reduce(f64::max)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        !args.is_empty(),
        "usage: work_precision PATH_TO_rk4_switch [LANES] [PERIODS] [PYTHON_WITH_NUMBA]"
    );
    let exe = args[0].as_str();
    let python = args.get(3).map(String::as_str);
    let lanes: usize = args.get(1).map_or(Ok(1024), |s| s.parse())?;
    let periods: u32 = args.get(2).map_or(Ok(200), |s| s.parse())?;
    let lp = lanes as f64 * periods as f64;
    let (reference, _, _) = lane_stepper(lanes, periods, 8000, 1, false)?;
    let (check, _, _) = lane_stepper(lanes, periods, 4000, 1, false)?;
    let agree = sorted_position_errors(&check, &reference);
    println!(
        "{lanes} lanes x {periods} periods at W = 133 (x_r0 over [-4, 4] mm); references N = 4000 and 8000 agree to {:.1e} m (median), {:.1e} (99 %), {:.1e} (worst)",
        quantile(&agree, 0.5),
        quantile(&agree, 0.99),
        quantile(&agree, 1.0)
    );
    println!(
        "| integrator | N | RK4 steps per period | lane-periods/s | median err [m] | 99th pct | worst lane | lanes < 1e-7 m |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut rows: Vec<(String, u32, f64, Vec<f64>)> = Vec::new();
    let mut record = |name: &str, n: u32, steps: Option<f64>, states: &[State], wall: f64| {
        let e = sorted_position_errors(states, &reference);
        let ok = e.iter().filter(|&&v| v < 1e-7).count() as f64 / e.len() as f64;
        let steps = steps.map_or("".to_string(), |v| format!("{v:.0}"));
        println!(
            "| {name} | {n} | {steps} | {:.3e} | {:.1e} | {:.1e} | {:.1e} | {:.1} % |",
            lp / wall,
            quantile(&e, 0.5),
            quantile(&e, 0.99),
            quantile(&e, 1.0),
            100.0 * ok
        );
        rows.push((name.to_string(), n, lp / wall, e));
    };
    let name = |r: u32| format!("jeffcott CPU f64 (2 threads), R = {r}");
    let study: [(u32, &[u32]); 3] = [
        (1, &[250, 500, 1000, 2000]),
        // Around the accuracy where the worst lane stops flipping, finer: the worst
        // lane's error is bimodal (a lane on a chaotic transient lands elsewhere, ~1e-5 m,
        // or not, ~1e-9 m), so interpolating between coarse points says nothing.
        (2, &[250, 400, 500, 600, 700, 800, 1000, 2000]),
        (4, &[250, 500, 1000]),
    ];
    for (r, ns) in study {
        for &n in ns {
            let (s, w, steps) = lane_stepper(lanes, periods, n, r, false)?;
            record(&name(r), n, Some(steps), &s, w);
        }
    }
    // The exact free-flight step: its error is contact's alone, so
    // half the N at twice the R.
    let exact_name = |r: u32| format!("jeffcott CPU f64 (2 threads), exact free flight, R = {r}");
    let exact_study: [(u32, &[u32]); 2] = [(4, &[250, 350, 500]), (8, &[175, 250, 350])];
    for (r, ns) in exact_study {
        for &n in ns {
            let (s, w, steps) = lane_stepper(lanes, periods, n, r, true)?;
            record(&exact_name(r), n, Some(steps), &s, w);
        }
    }
    let peer = "RK4 + switch sub-steps (numba, prange)";
    if let Some(py) = python {
        for n in [1024u32, 1536, 2048, 3072, 4096, 5120, 5632, 6144, 8192] {
            let (s, w) = baseline(
                &[py, "benches/peer/rk4_numba.py"],
                "substep",
                n,
                lanes,
                periods,
            )?;
            record(peer, n, None, &s, w);
        }
    }
    for n in [1024u32, 1536, 3072, 5120, 5632, 6144] {
        let (s, w) = baseline(&[exe], "substep", n, lanes, periods)?;
        record("RK4 + switch sub-steps (C, OpenMP)", n, None, &s, w);
    }
    for n in [2000u32, 8000] {
        let (s, w) = baseline(&[exe], "plain", n, lanes, periods)?;
        record("RK4 event-free (C, OpenMP)", n, None, &s, w);
    }
    let curve = |name: &str, q: f64| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.0 == name)
            .map(|r| (r.2, quantile(&r.3, q).max(1e-16)))
            .collect()
    };
    let ours = &name(DEFAULT_CONTACT_SUBSTEPS);
    let strong = "RK4 + switch sub-steps (C, OpenMP)";
    let plain = "RK4 event-free (C, OpenMP)";
    let baselines: &[&str] = if python.is_some() {
        &[peer, strong]
    } else {
        &[strong]
    };
    let exact4 = &exact_name(4);
    for (what, q, target) in [
        ("worst lane", 1.0, 1e-7),
        ("99th percentile", 0.99, 1e-7),
        ("99th percentile", 0.99, 2e-9),
    ] {
        for (mine, &other) in baselines
            .iter()
            .map(|b| (ours, b))
            .chain(baselines.iter().map(|b| (exact4, b)))
        {
            println!("{mine}:");
            let (ours_c, other_c) = (curve(mine, q), curve(other, q));
            match (cheapest(&ours_c, target), cheapest(&other_c, target)) {
                (Some(a), Some(b)) => println!(
                    "{what} <= {target:e} m, fastest measured point: jeffcott {a:.3e} lane-periods/s, {other} {b:.3e}: ratio {:.2}",
                    a / b
                ),
                (a, b) => println!(
                    "{what} <= {target:e} m: jeffcott {a:?}, {other} {b:?} (no measured point reaches it)"
                ),
            }
            if let (Some(a), Some(b)) = (at_error(&ours_c, target), at_error(&other_c, target)) {
                println!(
                    "  interpolated (log-log) to equal {what} error {target:e} m: {a:.3e} vs {b:.3e}: ratio {:.2}",
                    a / b
                );
            }
        }
    }
    let mut csv = String::from("integrator,n,lane_periods_per_s,median_m,p99_m,worst_m\n");
    for r in &rows {
        csv += &format!(
            "{},{},{},{},{},{}\n",
            r.0,
            r.1,
            r.2,
            quantile(&r.3, 0.5),
            quantile(&r.3, 0.99),
            quantile(&r.3, 1.0)
        );
    }
    std::fs::write("docs/work-precision.csv", csv)?;
    let p = jeffcott::plot::PALETTE;
    let mut series = vec![
        (format!("{ours}, worst lane"), p[0], false, curve(ours, 1.0)),
        (format!("{ours}, 99th pct"), p[0], true, curve(ours, 0.99)),
        (
            format!("{}, worst lane", name(1)),
            p[2],
            false,
            curve(&name(1), 1.0),
        ),
        (
            format!("{}, 99th pct", name(1)),
            p[2],
            true,
            curve(&name(1), 0.99),
        ),
        (
            format!("{}, worst lane", name(4)),
            p[4],
            false,
            curve(&name(4), 1.0),
        ),
        (
            format!("{exact4}, worst lane"),
            p[3],
            false,
            curve(exact4, 1.0),
        ),
        (format!("{peer}, worst lane"), p[5], false, curve(peer, 1.0)),
        (
            format!("{strong}, worst lane"),
            p[1],
            false,
            curve(strong, 1.0),
        ),
        (
            format!("{strong}, 99th pct"),
            p[1],
            true,
            curve(strong, 0.99),
        ),
        (
            format!("{plain}, worst lane"),
            p[3],
            false,
            curve(plain, 1.0),
        ),
    ];
    // Without a Python with numba the peer has no points.
    series.retain(|s| !s.3.is_empty());
    jeffcott::plot::work_precision(
        std::path::Path::new("docs/work-precision.png"),
        &format!("Work-precision at W = 133: {lanes} lanes x {periods} periods, 2-core CPU"),
        &series,
        1e-7,
    )?;
    println!("wrote docs/work-precision.png and docs/work-precision.csv");
    Ok(())
}
