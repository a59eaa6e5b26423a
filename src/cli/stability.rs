//! `jeffcott basin-stability`: basin stability (Menck, Heitzig, Marwan and Kurths, Nature
//! Physics 9, 89 (2013)): the fraction of start states drawn uniformly in a box of any
//! number of start coordinates that end on each attractor, with 95 % Wilson intervals; over
//! a speed range, the fractions against W as a stacked-area plot, attractors followed from
//! speed to speed (the continuation's find-and-match, `analysis::continuation`).
//! Resumable and shardable (its sampling pass runs in units).

use super::study::{self};
use crate::plot::{PALETTE, StackedPanel, stacked_fractions};
use clap::Args;
use jeffcott_analysis::continuation::{ContinuationResult, ContinuationSpec, Ramp};
use jeffcott_analysis::defaults;
use jeffcott_analysis::output;
use jeffcott_core::error::Result;
use plotters::style::RGBColor;
use std::path::Path;

/// Arguments of `jeffcott basin-stability`.
#[derive(Args, Debug)]
pub struct StabilityArgs {
    /// Rotor speed W, or a range a:b:n for the fractions against W [rad/s].
    #[arg(long, value_name = "W|a:b:n", allow_hyphen_values = true)]
    pub omega: String,
    /// Start states drawn per speed.
    #[arg(long, default_value_t = defaults::stability::SAMPLE, value_name = "N")]
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
    #[arg(long, default_value_t = defaults::stability::SEED)]
    pub seed: u64,
    /// Forcing periods integrated and discarded per lane.
    #[arg(long, default_value_t = defaults::stability::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded per lane.
    #[arg(long, default_value_t = defaults::stability::PERIODS, value_name = "P")]
    pub periods: u32,
    /// Skip lambda_1 (aperiodic attractors are then not told apart as quasiperiodic or
    /// chaotic).
    #[arg(long)]
    pub no_lyapunov: bool,
    #[command(flatten)]
    pub study: super::StudyArgs,
    /// Skip basin_stability.png.
    #[arg(long)]
    pub no_plot: bool,
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

impl StabilityArgs {
    /// The study as a continuation over W of uniform draws in the box.
    pub fn spec(&self) -> Result<ContinuationSpec> {
        jeffcott_analysis::stability::spec(&jeffcott_analysis::stability::StabilityRequest {
            lane: self.study.settings(!self.no_lyapunov)?,
            omega: &self.omega,
            sample: self.sample,
            start_box: &self.start_box,
            seed: self.seed,
            transient: self.transient,
            periods: self.periods,
        })
    }
}

study::plot_study! {
    Stability, "basin-stability", StabilityArgs => run_stability,
    jeffcott_analysis::continuation::run, ContinuationSpec, ContinuationResult,
    names: &[("ics", "sample"), ("start_box", "box"), ("param", "omega")]
}

/// Writes a basin-stability study's files; returns its summary line.
fn write_study(out: &Path, spec: &Spec, res: &Outcome, plot: bool) -> Result<String> {
    let text = write_stability(out, spec, res, plot)?;
    Ok(format!(
        "{text} {:.1} s. Files in {}.",
        res.seconds,
        out.display()
    ))
}

/// The bands of the stacked plot: each attractor id's fraction per speed (`f`, of
/// shape [n, ids + 1]) named by its most frequent class, then the diverged lanes',
/// bands that are never positive left out.
fn stability_bands(ramp: &Ramp, f: &[f64], n: usize) -> Vec<(String, RGBColor, Vec<f64>)> {
    let g = ramp.ids + 1;
    (0..ramp.ids)
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
        .collect()
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
    let (f, lo, hi) = jeffcott_analysis::stability::fractions_with_intervals(spec, ramp);
    output::write_npy(&dir.join("omega.npy"), &[n], &res.values)?;
    output::write_npy(&dir.join("fractions.npy"), &[n, g], &f)?;
    output::write_npy(&dir.join("ci_low.npy"), &[n, g], &lo)?;
    output::write_npy(&dir.join("ci_high.npy"), &[n, g], &hi)?;
    let json = super::files::Documented::new(
        jeffcott_analysis::stability::summary(spec, res),
        &[
            ("omega.npy", "f64 [n]: the speeds"),
            (
                "fractions.npy",
                "f64 [n, ids + 1]: basin stability of each attractor id per speed (last column: diverged)",
            ),
            (
                "ci_low.npy",
                "f64 [n, ids + 1]: lower end of the 95 % Wilson interval",
            ),
            ("ci_high.npy", "f64 [n, ids + 1]: upper end"),
            (
                "basin_stability.png",
                "the fractions stacked against W (a range of speeds only)",
            ),
        ],
    );
    output::write_json(&dir.join("basin_stability.json"), &json)?;
    if plot_it && n >= 2 {
        let bands = stability_bands(ramp, &f, n);
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
