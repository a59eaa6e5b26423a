//! The work-precision diagram of issue 12 (`bash benches/baseline/run.sh`): the lane
//! stepper against the strong hand-written baseline (`benches/baseline/rk4_switch.c`:
//! fixed-step RK4, steps whose contact state changes redone as 8 sub-steps, OpenMP) and
//! the event-free loop, on the standard job (1024 lanes at W = 133, x_r0 evenly over
//! [-4, 4] mm, 200 periods from t = 0). Error: per lane, the largest position error of
//! the final state against the lane stepper at N = 8000 (two references, N = 4000 and
//! 8000, say how converged that is). Writes docs/work-precision.png and .csv and prints
//! the table and the speed ratios at equal worst-lane and 99th-percentile accuracy.
//!
//! Usage: work_precision PATH_TO_rk4_switch [LANES] [PERIODS]

use jeffcott::bench::{quantile, sorted_position_errors};
use jeffcott::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision, run};
use jeffcott::integrate::lane::StepperConfig;
use jeffcott::model::{Params, STATE_DIM, State};
use std::process::Command;
use std::time::Instant;

/// The standard job's lanes, integrated by the lane stepper at N steps per period.
fn lane_stepper(lanes: usize, periods: u32, n: u32) -> anyhow::Result<(Vec<State>, f64)> {
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
            ..Default::default()
        },
        precision: Precision::F64,
    };
    let t = Instant::now();
    let (res, _) = run(&spec, Backend::Cpu, &|_, _| {})?;
    Ok((res.final_state, t.elapsed().as_secs_f64()))
}

fn baseline(
    exe: &str,
    mode: &str,
    n: u32,
    lanes: usize,
    periods: u32,
) -> anyhow::Result<(Vec<State>, f64)> {
    let out = std::env::temp_dir().join(format!("rk4_switch_{}.bin", std::process::id()));
    let t = Instant::now();
    let o = Command::new(exe)
        .args([
            mode,
            &n.to_string(),
            &periods.to_string(),
            &lanes.to_string(),
        ])
        .arg(&out)
        .output()?;
    let wall = t.elapsed().as_secs_f64();
    anyhow::ensure!(o.status.success(), "{exe} failed: {o:?}");
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

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        !args.is_empty(),
        "usage: work_precision PATH_TO_rk4_switch [LANES] [PERIODS]"
    );
    let exe = &args[0];
    let lanes: usize = args.get(1).map_or(Ok(1024), |s| s.parse())?;
    let periods: u32 = args.get(2).map_or(Ok(200), |s| s.parse())?;
    let lp = lanes as f64 * periods as f64;
    let (reference, _) = lane_stepper(lanes, periods, 8000)?;
    let (check, _) = lane_stepper(lanes, periods, 4000)?;
    let agree = sorted_position_errors(&check, &reference);
    println!(
        "{lanes} lanes x {periods} periods at W = 133 (x_r0 over [-4, 4] mm); references N = 4000 and 8000 agree to {:.1e} m (median), {:.1e} (99 %), {:.1e} (worst)",
        quantile(&agree, 0.5),
        quantile(&agree, 0.99),
        quantile(&agree, 1.0)
    );
    println!(
        "| integrator | N | lane-periods/s | median err [m] | 99th pct | worst lane | lanes < 1e-7 m |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mut rows: Vec<(String, u32, f64, Vec<f64>)> = Vec::new();
    let mut record = |name: &str, n: u32, states: &[State], wall: f64| {
        let e = sorted_position_errors(states, &reference);
        let ok = e.iter().filter(|&&v| v < 1e-7).count() as f64 / e.len() as f64;
        println!(
            "| {name} | {n} | {:.3e} | {:.1e} | {:.1e} | {:.1e} | {:.1} % |",
            lp / wall,
            quantile(&e, 0.5),
            quantile(&e, 0.99),
            quantile(&e, 1.0),
            100.0 * ok
        );
        rows.push((name.to_string(), n, lp / wall, e));
    };
    for n in [250u32, 500, 1000, 2000] {
        let (s, w) = lane_stepper(lanes, periods, n)?;
        record("jeffcott CPU f64 (2 threads)", n, &s, w);
    }
    for n in [1536u32, 3072, 6144] {
        let (s, w) = baseline(exe, "substep", n, lanes, periods)?;
        record("RK4 + switch sub-steps (C, OpenMP)", n, &s, w);
    }
    for n in [2000u32, 8000] {
        let (s, w) = baseline(exe, "plain", n, lanes, periods)?;
        record("RK4 event-free (C, OpenMP)", n, &s, w);
    }
    let curve = |name: &str, q: f64| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.0 == name)
            .map(|r| (r.2, quantile(&r.3, q).max(1e-16)))
            .collect()
    };
    let ours = "jeffcott CPU f64 (2 threads)";
    let strong = "RK4 + switch sub-steps (C, OpenMP)";
    let plain = "RK4 event-free (C, OpenMP)";
    for (what, q) in [("worst lane", 1.0), ("99th percentile", 0.99)] {
        match (
            at_error(&curve(ours, q), 1e-7),
            at_error(&curve(strong, q), 1e-7),
        ) {
            (Some(a), Some(b)) => println!(
                "at equal {what} error 1e-7 m: jeffcott {a:.3e} lane-periods/s, strong baseline {b:.3e}: ratio {:.2}",
                a / b
            ),
            (a, b) => println!(
                "at equal {what} error 1e-7 m: jeffcott {a:?}, strong baseline {b:?} (a curve does not cross 1e-7 m)"
            ),
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
    jeffcott::plot::work_precision(
        std::path::Path::new("docs/work-precision.png"),
        &format!("Work-precision at W = 133: {lanes} lanes x {periods} periods, 2-core CPU"),
        &[
            (format!("{ours}, worst lane"), p[0], false, curve(ours, 1.0)),
            (format!("{ours}, 99th pct"), p[0], true, curve(ours, 0.99)),
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
        ],
        1e-7,
    )?;
    println!("wrote docs/work-precision.png and docs/work-precision.csv");
    Ok(())
}
