//! `jeffcott basin-stability`: basin stability (Menck, Heitzig, Marwan and Kurths, Nature
//! Physics 9, 89 (2013)): the fraction of start states drawn uniformly in a box of any
//! number of start coordinates that end on each attractor, with 95 % Wilson intervals; over
//! a speed range, the fractions against W as a stacked-area plot, attractors followed from
//! speed to speed (the continuation's find-and-match, `analysis::continuation`).
//! Resumable and shardable (its sampling pass runs in units).

use super::continuation::run_continuation_study;
use super::rundir::{self, RunArgs};
use super::{CatalogueArgs, ModelArgs, StepperArgs};
use crate::plot::{PALETTE, StackedPanel, stacked_fractions};
use clap::Args;
use jeffcott_analysis::continuation::{ContinuationResult, ContinuationSpec, Direction, parse_box};
use jeffcott_analysis::map::{MapAxis, MapVar};
use jeffcott_analysis::output;
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Arguments of `jeffcott basin-stability`.
#[derive(Args, Debug)]
pub struct StabilityArgs {
    /// Rotor speed W, or a range a:b:n for the fractions against W [rad/s].
    #[arg(long, value_name = "W|a:b:n", allow_hyphen_values = true)]
    pub omega: String,
    /// Start states drawn per speed.
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub sample: u32,
    /// The box of start coordinates drawn from, uniformly: NAME:lo:hi,... over any of
    /// x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s (the others at the static equilibrium),
    /// e.g. x_r:-0.006:0.006,vx_r:-1:1,y_r:-0.006:0.006,vy_r:-1:1.
    #[arg(
        long = "box",
        value_name = "NAME:lo:hi,...",
        allow_hyphen_values = true
    )]
    pub start_box: String,
    /// Seed of the draws (the same draws at every speed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Forcing periods integrated and discarded per lane.
    #[arg(long, default_value_t = 500, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded per lane.
    #[arg(long, default_value_t = 64, value_name = "P")]
    pub periods: u32,
    /// Skip lambda_1 (aperiodic attractors are then not told apart as quasiperiodic or
    /// chaotic).
    #[arg(long)]
    pub no_lyapunov: bool,
    /// Backend: auto (a hardware GPU if present, else the CPU), cpu, or gpu.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Lane precision [default: f64 on the CPU, f32 on a GPU].
    #[arg(long, value_enum)]
    pub precision: Option<Precision>,
    #[command(flatten)]
    pub model: ModelArgs,
    #[command(flatten)]
    pub stepper: StepperArgs,
    #[command(flatten)]
    pub catalogue: CatalogueArgs,
    /// Output directory (created if missing). An unfinished run of the same command there
    /// is resumed.
    #[arg(
        long,
        value_name = "DIR",
        default_value = "jeffcott-out/basin-stability"
    )]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub shard: rundir::ShardArgs,
    /// Skip basin_stability.png.
    #[arg(long)]
    pub no_plot: bool,
    /// Print nothing but errors (no progress bar).
    #[arg(long)]
    pub quiet: bool,
}

/// Final files (run.json aside).
pub const OUTPUTS: &[&str] = &[
    "omega.npy",
    "fractions.npy",
    "ci_low.npy",
    "ci_high.npy",
    "basin_stability.json",
    "basin_stability.png",
];

/// The 95 % Wilson score interval of a binomial fraction k/n (Wilson 1927), which keeps
/// its coverage near 0 and 1 where the normal interval does not.
pub fn wilson95(k: u64, n: u64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let z = 1.959_963_984_540_054;
    let (n, p) = (n as f64, k as f64 / n as f64);
    let d = 1.0 + z * z / n;
    let c = (p + z * z / (2.0 * n)) / d;
    let h = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / d;
    ((c - h).max(0.0), (c + h).min(1.0))
}

impl StabilityArgs {
    /// The study as a continuation over W of uniform draws in the box.
    pub fn spec(&self) -> Result<ContinuationSpec> {
        let r = jeffcott_core::ensemble::RangeSpec::parse("omega", &self.omega)?;
        if r.n > 100_000 {
            return Err(Error::invalid(
                "omega",
                &self.omega,
                "at most 100000 speeds",
            ));
        }
        let precision = self
            .precision
            .unwrap_or_else(|| jeffcott_analysis::backend::default_precision(self.backend));
        if !(2..=100_000_000).contains(&self.sample) {
            return Err(Error::invalid(
                "sample",
                self.sample,
                "must be in 2..=100000000",
            ));
        }
        let spec = ContinuationSpec {
            params: self.model.params()?,
            omega: None,
            param: MapAxis {
                var: MapVar::Omega,
                lo: r.a,
                hi: r.b,
                n: r.n as usize,
                log: false,
            },
            ics: self.sample,
            start_box: Some(parse_box("box", &self.start_box)?),
            seed: self.seed,
            transient: self.transient,
            recorded: self.periods,
            stepper: self.stepper.config(),
            precision,
            backend: self.backend,
            catalogue: self.catalogue.config(precision)?,
            lyapunov: !self.no_lyapunov,
            directions: vec![Direction::Up],
            match_threshold: f64::INFINITY,
        };
        spec.validate()?;
        Ok(spec)
    }
}

/// Runs `jeffcott basin-stability`.
pub fn run_stability(a: &StabilityArgs) -> Result<()> {
    let spec = a.spec()?;
    let shard = a.shard.shard()?;
    let rd = rundir::open_shard(
        &a.out,
        "basin-stability",
        spec.to_json(),
        OUTPUTS,
        a.run,
        shard,
        a.quiet,
    )?;
    let res = match run_continuation_study(&spec, rundir::store(&rd).as_ref(), a.quiet) {
        Err(Error::NotInShard) => return rundir::finish_shard(&rd, a.quiet),
        r => r?,
    };
    let text = write_stability(&a.out, &spec, &res, !a.no_plot)?;
    rd.finish(
        serde_json::json!({"backend": res.info, "wall_time_s": res.seconds}),
        &rundir::written(&rd, OUTPUTS),
    )?;
    if !a.quiet {
        println!("{text} {:.1} s. Files in {}.", res.seconds, a.out.display());
    }
    Ok(())
}

/// Writes the arrays, basin_stability.json and the plot; returns the summary line.
pub fn write_stability(
    dir: &Path,
    spec: &ContinuationSpec,
    res: &ContinuationResult,
    plot_it: bool,
) -> Result<String> {
    output::ensure_dir(dir)?;
    let ramp = &res.ramps[0];
    let n = res.values.len();
    let g = ramp.ids + 1;
    let k = spec.ics as u64;
    let (f, _) = ramp.fractions();
    let count = |x: f64| (x * k as f64).round() as u64;
    let (lo, hi): (Vec<f64>, Vec<f64>) = f.iter().map(|&x| wilson95(count(x), k)).unzip();
    output::write_npy(&dir.join("omega.npy"), &[n], &res.values)?;
    output::write_npy(&dir.join("fractions.npy"), &[n, g], &f)?;
    output::write_npy(&dir.join("ci_low.npy"), &[n, g], &lo)?;
    output::write_npy(&dir.join("ci_high.npy"), &[n, g], &hi)?;
    let steps: Vec<serde_json::Value> = ramp
        .steps
        .iter()
        .enumerate()
        .map(|(s, st)| {
            let list: Vec<serde_json::Value> = st
                .attractors
                .iter()
                .map(|a| {
                    let i = s * g + a.id as usize;
                    serde_json::json!({
                        "id": a.id, "class": a.class, "period": a.period, "lambda1": a.lambda1,
                        "fraction": a.fraction, "standard_error": a.error,
                        "ci95": [lo[i], hi[i]], "found_only_from_a_seed": a.seeded_only,
                    })
                })
                .collect();
            serde_json::json!({
                "omega": st.value, "attractors": list,
                "diverged_fraction": st.diverged_fraction,
                "diverged_ci95": [lo[s * g + ramp.ids], hi[s * g + ramp.ids]],
            })
        })
        .collect();
    let boxed: Vec<serde_json::Value> = spec
        .start_box
        .iter()
        .flatten()
        .map(|&(c, lo, hi)| serde_json::json!({"coord": jeffcott_core::model::COORD_NAMES[c], "lo": lo, "hi": hi}))
        .collect();
    let json = serde_json::json!({
        "box": boxed,
        "sample": spec.ics,
        "seed": spec.seed,
        "transient": spec.transient,
        "periods": spec.recorded,
        "lyapunov": spec.lyapunov,
        "per_omega": steps,
        "params": spec.params,
        "definition": "basin stability (Menck et al. 2013): the fraction of start states drawn uniformly in the box that end on each attractor; standard error sqrt(f (1 - f) / N), 95 % Wilson score interval; attractor ids follow attractors from speed to speed (docs/maps.md, continuation)",
        "files": {
            "omega.npy": "f64 [n]: the speeds",
            "fractions.npy": "f64 [n, ids + 1]: basin stability of each attractor id per speed (last column: diverged)",
            "ci_low.npy": "f64 [n, ids + 1]: lower end of the 95 % Wilson interval",
            "ci_high.npy": "f64 [n, ids + 1]: upper end",
            "basin_stability.png": "the fractions stacked against W (a range of speeds only)",
        },
        "jeffcott_version": env!("CARGO_PKG_VERSION"),
    });
    output::write_json(&dir.join("basin_stability.json"), &json)?;
    if plot_it && n >= 2 {
        let bands: Vec<(String, plotters::style::RGBColor, Vec<f64>)> = (0..ramp.ids)
            .map(|id| {
                let name = ramp
                    .steps
                    .iter()
                    .flat_map(|s| s.attractors.iter())
                    .filter(|a| a.id == id as u32)
                    .max_by(|a, b| a.fraction.total_cmp(&b.fraction))
                    .map(|a| format!("#{id} {}", a.class))
                    .unwrap_or_else(|| format!("#{id}"));
                (
                    name,
                    PALETTE[id % PALETTE.len()],
                    (0..n).map(|s| f[s * g + id]).collect::<Vec<f64>>(),
                )
            })
            .filter(|b| b.2.iter().any(|&v| v > 0.0))
            .chain((0..n).any(|s| f[s * g + ramp.ids] > 0.0).then(|| {
                (
                    "diverged".to_string(),
                    plotters::style::RGBColor(0, 0, 0),
                    (0..n).map(|s| f[s * g + ramp.ids]).collect(),
                )
            }))
            .collect();
        stacked_fractions(
            &dir.join("basin_stability.png"),
            &format!(
                "Basin stability against W ({} start states per speed, uniform in the box)",
                spec.ics
            ),
            "rotor speed W [rad/s]",
            &res.values,
            &[StackedPanel {
                title: "which attractor dominates where".into(),
                bands,
            }],
        )?;
    }
    let first = &ramp.steps[0];
    let list: Vec<String> = first
        .attractors
        .iter()
        .map(|a| {
            let i = a.id as usize;
            format!(
                "#{} {} {:.1} % (95 % CI {:.1}..{:.1} %)",
                a.id,
                a.class,
                100.0 * a.fraction,
                100.0 * lo[i],
                100.0 * hi[i]
            )
        })
        .collect();
    Ok(format!(
        "Basin stability of {} start states per speed at {} speed(s){}: at W = {} rad/s {}{}.",
        spec.ics,
        n,
        if n > 1 {
            format!(" ({}..{} rad/s)", res.values[0], res.values[n - 1])
        } else {
            String::new()
        },
        first.value,
        list.join(", "),
        if first.diverged_fraction > 0.0 {
            format!(", diverged {:.1} %", 100.0 * first.diverged_fraction)
        } else {
            String::new()
        }
    ))
}

#[cfg(test)]
mod tests {
    use super::wilson95;

    #[test]
    fn wilson_intervals_match_published_values() {
        // Newcombe (1998), Table I: 81/263 -> 0.2553..0.3662.
        let (lo, hi) = wilson95(81, 263);
        assert!(
            (lo - 0.2553).abs() < 5e-5 && (hi - 0.3662).abs() < 5e-5,
            "{lo} {hi}"
        );
        // 0/10 -> 0..0.2775 (Wilson), never below 0.
        let (lo, hi) = wilson95(0, 10);
        assert_eq!(lo, 0.0);
        assert!((hi - 0.2775).abs() < 5e-5, "{hi}");
    }
}
