//! The hand-written baseline comparison: accuracy and speed of a
//! straightforward per-trajectory RK4 loop in C (`benches/handwritten/rk4_loop.c`,
//! contact switched per stage, no crossing location) against the lane stepper on the
//! same lanes (`jeffcott_analysis::bench`, W = 133).
//!
//! Both are measured against a reference: the lane stepper at N = 8000 steps per period
//! (its error there is ~1e-12 m, docs/convergence.md). The C loop needs far more steps
//! for the same accuracy because each unlocated contact switch inside a step costs it
//! its fourth order.
//!
//! Run: `bash benches/handwritten/run.sh` (builds the C program and calls this with its
//! path), or `cargo run --release --example handwritten -- ./rk4_loop LANES PERIODS N...`.

use jeffcott_analysis::bench::{quantile, reference_final_states, sorted_position_errors};
use jeffcott_core::model::{STATE_DIM, State};
use std::process::Command;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        args.len() >= 4,
        "usage: handwritten PATH_TO_rk4_loop LANES PERIODS N [N...]"
    );
    let exe = &args[0];
    let lanes: usize = args[1].parse()?;
    let periods: u32 = args[2].parse()?;
    let ns: Vec<u32> = args[3..]
        .iter()
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let reference = reference_final_states(lanes, periods, 8000)?;
    println!(
        "{lanes} lanes x {periods} periods at W = 133; per-lane position error vs the lane stepper at N = 8000"
    );
    println!("| method | N | median error [m] | 90% [m] | max [m] | wall [s] | lane-steps/s |");
    println!("|---|---|---|---|---|---|---|");
    let errors = |s: &[State]| {
        let e = sorted_position_errors(s, &reference);
        format!(
            "{:.2e} | {:.2e} | {:.2e}",
            quantile(&e, 0.5),
            quantile(&e, 0.9),
            quantile(&e, 1.0)
        )
    };
    for &n in &[250u32, 500, 1000] {
        let t = Instant::now();
        let ours = reference_final_states(lanes, periods, n)?;
        let wall = t.elapsed().as_secs_f64();
        println!(
            "| lane stepper (rayon, all cores) | {n} | {} | {wall:.2} | {:.3e} |",
            errors(&ours),
            lanes as f64 * periods as f64 * n as f64 / wall
        );
    }
    let out = std::env::temp_dir().join(format!("rk4_loop_{}.bin", std::process::id()));
    for &n in &ns {
        let t = Instant::now();
        let status = Command::new(exe)
            .args([n.to_string(), periods.to_string(), lanes.to_string()])
            .arg(&out)
            .output()?;
        let wall = t.elapsed().as_secs_f64();
        anyhow::ensure!(status.status.success(), "{exe} failed: {status:?}");
        let bytes = std::fs::read(&out)?;
        let states: Vec<State> = bytes
            .chunks_exact(8 * STATE_DIM)
            .map(|c| {
                let mut s = [0.0; STATE_DIM];
                for (d, v) in s.iter_mut().enumerate() {
                    *v = f64::from_le_bytes(c[8 * d..8 * d + 8].try_into().unwrap());
                }
                s
            })
            .collect();
        anyhow::ensure!(states.len() == lanes, "{exe} wrote {} lanes", states.len());
        println!(
            "| hand-written C RK4 ({}) | {n} | {} | {wall:.2} | {:.3e} |",
            exe.rsplit('/').next().unwrap_or(exe),
            errors(&states),
            lanes as f64 * periods as f64 * n as f64 / wall
        );
    }
    std::fs::remove_file(&out).ok();
    Ok(())
}
