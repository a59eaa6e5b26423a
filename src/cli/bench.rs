//! `jeffcott bench`: lane-steps and forcing periods per second of each backend and
//! precision on the W = 133 workload of [`jeffcott_analysis::bench`], as a Markdown table (the
//! README's) and a JSON file.

use crate::cli::choice::{choice, name_of};
use clap::Args;
use jeffcott_analysis::backend::Engine;
use jeffcott_analysis::bench::{BenchRow, measure, measure_anatomy, periods_for};
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::error::{Error, Result};
use std::path::PathBuf;

/// Arguments of `jeffcott bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Ensemble sizes (lanes), comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [1024usize, 16384, 131072])]
    pub lanes: Vec<usize>,
    /// Work per configuration in lane-periods (periods per lane = this / lanes, at
    /// least 4), so every size does about the same work.
    #[arg(long, default_value_t = 65536)]
    pub lane_periods: u64,
    /// Backends to measure (default: the CPU, and a GPU when an adapter exists).
    #[arg(long, value_delimiter = ',', value_parser = choice::<Backend>())]
    pub backend: Vec<Backend>,
    /// Precisions to measure.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = choice::<Precision>(),
        default_values = [name_of(Precision::F64), name_of(Precision::F32)]
    )]
    pub precision: Vec<Precision>,
    /// Also time a free-flight twin (gap 1 m) at this size to measure the share of time
    /// due to contact; 0 to skip.
    #[arg(long, default_value_t = 16384)]
    pub twin_at: usize,
    /// Also time parts of the GPU kernel alone on the same lanes, after each GPU row
    /// (comma-separated: rk4, rk4-scalar, certain, search, contact, or all): where a
    /// GPU's time per lane-step goes (jeffcott_gpu::anatomy, docs/gpu.md). The parts do
    /// not integrate the model; they are timing instruments.
    #[arg(long, value_name = "PARTS")]
    pub anatomy: Option<String>,
    /// Write the rows as JSON here.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// The machine of the workload (Table 1 unless given: the published figures are
    /// Table 1's); the start states and the speed stay the workload's.
    #[command(flatten)]
    pub model: crate::cli::ModelArgs,
}

/// Runs `jeffcott bench`.
pub fn run_bench(a: &BenchArgs) -> Result<()> {
    check_sizes(a)?;
    let params = a.model.params()?;
    let anatomy = match &a.anatomy {
        Some(text) => jeffcott_gpu::anatomy::Part::parse_list("anatomy", text)?,
        None => Vec::new(),
    };
    let adapters = jeffcott_gpu::list_adapters();
    let gpu = adapters.iter().find(|s| s.compute);
    let backends = if a.backend.is_empty() {
        match gpu {
            Some(_) => vec![Backend::Cpu, Backend::Gpu],
            None => {
                println!("no GPU adapter found: measuring the CPU only");
                vec![Backend::Cpu]
            }
        }
    } else {
        a.backend.clone()
    };
    if !anatomy.is_empty() && !backends.contains(&Backend::Gpu) {
        return Err(Error::invalid(
            "anatomy",
            a.anatomy.as_deref().unwrap_or(""),
            "times parts of the GPU kernel: needs --backend gpu (or a GPU adapter)",
        ));
    }
    if let Some(path) = &a.out {
        if path.is_dir() {
            return Err(Error::invalid(
                "out",
                path.display(),
                "is a directory; bench writes its rows to a JSON file: give the file's path",
            ));
        }
        // Checked before any timing work: a --out that cannot be written (a directory,
        // a read-only place) is refused at once. It holds the rows measured so far.
        jeffcott_analysis::output::write_json(path, &Vec::<BenchRow>::new())?;
    }
    println!(
        "workload: W = {} rad/s, start states spread over x_r in [-4, 4] mm, vx_r in [-0.5, 0.5] m/s, {} steps/period, {} lane-periods per row; CPU: {} threads",
        jeffcott_analysis::bench::BENCH_OMEGA,
        jeffcott_core::integrate::lane::DEFAULT_STEPS_PER_PERIOD,
        a.lane_periods,
        rayon::current_num_threads()
    );
    println!(
        "| backend | device | kernel | precision | lanes | periods | wall s (set-up excluded) | lane-steps/s | periods/s | refinement sub-steps | contact steps | time due to contact |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows: Vec<BenchRow> = Vec::new();
    for &backend in &backends {
        // One engine per backend for all its rows. Opened for f32 so an adapter
        // without SHADER_F64 still measures f32; its f64 rows are skipped below.
        let engine = Engine::new(backend, Precision::F32)?;
        for &precision in &a.precision {
            let gpu_lacks_f64 = engine.runner().is_some_and(|r| !r.gpu().supports_f64());
            if precision == Precision::F64 && gpu_lacks_f64 {
                if a.backend.is_empty() {
                    println!("(GPU f64 skipped: the adapter has no SHADER_F64)");
                    continue;
                }
                return Err(Error::invalid(
                    "precision",
                    "f64",
                    "the GPU adapter has no SHADER_F64; measure f32 only",
                ));
            }
            for &lanes in &a.lanes {
                let periods = periods_for(lanes, a.lane_periods);
                let size = (lanes, periods, precision);
                let mut measured = vec![measure(&params, size, &engine, lanes == a.twin_at)?];
                if let Some(runner) = engine.runner() {
                    for &part in &anatomy {
                        measured.push(measure_anatomy(part, &params, size, runner)?);
                    }
                }
                for r in measured {
                    print_row(&r);
                    rows.push(r);
                    if let Some(path) = &a.out {
                        // Rewritten after every row, so an interrupted run keeps its rows.
                        jeffcott_analysis::output::write_json(path, &rows)?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// Checks the sizes asked for before anything runs: lanes and lane-periods in range,
/// the twin at one of the sizes, and every row within the period and memory limits.
fn check_sizes(a: &BenchArgs) -> Result<()> {
    if let Some(&bad) = a.lanes.iter().find(|&&n| n == 0 || n > 1 << 24) {
        return Err(Error::invalid(
            "lanes",
            bad,
            "each size must be in 1..=16777216",
        ));
    }
    if a.lane_periods == 0 {
        return Err(Error::invalid("lane_periods", 0, "must be >= 1"));
    }
    // The twin is timed at one of the sizes measured; any other value would silently
    // measure no twin at all.
    if a.twin_at != 0 && !a.lanes.contains(&a.twin_at) {
        return Err(Error::invalid(
            "twin-at",
            a.twin_at,
            format!(
                "must be 0 (no free-flight twin) or one of the --lanes sizes ({})",
                a.lanes
                    .iter()
                    .map(|n| n.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    for &lanes in &a.lanes {
        let periods = periods_for(lanes, a.lane_periods);
        jeffcott_core::limits::check_periods("lane-periods", periods, 1).map_err(|_| {
            Error::invalid(
                "lane-periods",
                a.lane_periods,
                format!(
                    "gives {periods} periods per lane at {lanes} lanes; at most {} periods per lane",
                    jeffcott_core::limits::MAX_PERIODS
                ),
            )
        })?;
        jeffcott_core::limits::check_memory(
            "lane-periods",
            a.lane_periods,
            jeffcott_core::ensemble::EnsembleSpec::memory_estimate_for(
                lanes as u64,
                periods as u64,
            ),
            &format!("{lanes} lanes x {periods} periods"),
            "ask for fewer --lane-periods or smaller --lanes",
        )?;
    }
    Ok(())
}

/// One row of the Markdown table.
fn print_row(r: &BenchRow) {
    println!(
        "| {} | {} | {} | {:?} | {} | {} | {:.2}{} | {:.3e} | {:.3e} | {:.1}% | {:.1}% | {} |",
        r.backend,
        r.device,
        r.kernel,
        r.precision,
        r.lanes,
        r.periods,
        r.wall_s,
        // Anatomy rows: their rates are per second of dispatches (BenchRow::dispatch_s).
        r.dispatch_s
            .map_or(String::new(), |s| format!(" (dispatches {s:.2})")),
        r.lane_steps_per_s,
        r.lane_periods_per_s,
        100.0 * r.refinement_substep_share,
        100.0 * r.contact_step_share,
        r.contact_time_share
            .map_or("-".into(), |s| format!("{:.0}%", 100.0 * s))
    );
}
