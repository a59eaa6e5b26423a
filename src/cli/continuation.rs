//! `jeffcott continuation`: attractors followed over omega or a model parameter, run-up
//! and run-down, with basin fractions, births and deaths, and tipping probabilities;
//! resumable, its fresh pass shardable.

use super::study::{self};
use crate::plot::{PALETTE, StackedPanel, stacked_fractions};
use clap::{Args, ValueEnum};
use jeffcott_analysis::continuation::{
    ContinuationResult, ContinuationSpec, Direction, Fields, id_name,
};
use jeffcott_analysis::defaults;
use jeffcott_analysis::map::MapAxis;
use jeffcott_analysis::output;
use jeffcott_core::error::{Error, Result};
use std::path::Path;

/// Which ramps to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DirectionArg {
    /// First value to last.
    Up,
    /// Last value to first.
    Down,
    /// Both.
    Both,
}

/// Arguments of `jeffcott continuation`.
#[derive(Args, Debug)]
pub struct ContinuationArgs {
    /// The continued parameter, NAME:lo:hi:n: omega or a model parameter (omega_r, ...,
    /// phi0, omega_rx, ..., alpha_c: docs/parameters.md), n >= 2
    /// values from lo to hi inclusive, e.g. omega:130:141:111. (`--param NAME=VALUE`
    /// sets the other model parameters, as in every command.)
    #[arg(long, value_name = "NAME:lo:hi:n", allow_hyphen_values = true)]
    pub vary: String,
    /// Rotor speed when the parameter is not omega [rad/s].
    #[arg(long, value_name = "W")]
    pub omega: Option<f64>,
    /// Fresh start states per value (the static equilibrium plus seeded draws, the same at
    /// every value): they give the basin fractions and tipping probabilities.
    #[arg(long, default_value_t = defaults::continuation::ICS, value_name = "K")]
    pub ics: u32,
    /// Draw the fresh start states uniformly in a box of start coordinates instead,
    /// e.g. `--box x_r:-0.006:0.006,vx_r:-1:1` (the others at the static equilibrium):
    /// the fractions are then the basin stability of that box (Menck et al. 2013).
    #[arg(
        long = "box",
        value_name = "NAME:lo:hi,...",
        allow_hyphen_values = true
    )]
    pub start_box: Option<String>,
    /// Seed of the start states.
    #[arg(long, default_value_t = defaults::continuation::SEED)]
    pub seed: u64,
    /// Ramp direction: up (run-up), down (run-down) or both.
    #[arg(long, value_enum, default_value_t = DirectionArg::Both)]
    pub direction: DirectionArg,
    /// Largest Poincare-set distance at which attractors of consecutive values are one
    /// attractor [m; velocities count divided by W] [default: inf, always the nearest].
    #[arg(long, value_name = "M")]
    pub match_threshold: Option<f64>,
    /// Forcing periods integrated and discarded per lane.
    #[arg(long, default_value_t = defaults::continuation::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded per lane.
    #[arg(long, default_value_t = defaults::continuation::PERIODS, value_name = "P")]
    pub periods: u32,
    /// Skip lambda_1 (aperiodic attractors are then not told apart as quasiperiodic or
    /// chaotic).
    #[arg(long)]
    pub no_lyapunov: bool,
    #[command(flatten)]
    pub study: super::StudyArgs,
    /// Skip continuation.png.
    #[arg(long)]
    pub no_plot: bool,
}

impl ContinuationArgs {
    /// The continuation these arguments describe, validated.
    pub fn spec(&self) -> Result<ContinuationSpec> {
        let spec = ContinuationSpec {
            lane: self.study.settings(!self.no_lyapunov)?,
            omega: self.omega,
            param: MapAxis::parse("vary", &self.vary, false)?,
            ics: self.ics,
            start_box: self
                .start_box
                .as_deref()
                .map(|b| jeffcott_analysis::continuation::parse_box("box", b))
                .transpose()?,
            seed: self.seed,
            transient: self.transient,
            periods: self.periods,
            directions: match self.direction {
                DirectionArg::Up => vec![Direction::Up],
                DirectionArg::Down => vec![Direction::Down],
                DirectionArg::Both => vec![Direction::Up, Direction::Down],
            },
            match_threshold: self.match_threshold.unwrap_or(f64::INFINITY),
            values_per_unit: None,
        };
        (spec.param.var).check_not_overridden(
            "vary",
            "param",
            &self.study.run.model.overridden()?,
        )?;
        if spec.param.n < 2 {
            return Err(Error::invalid(
                "vary",
                spec.param.n,
                "a continuation needs at least 2 values",
            ));
        }
        spec.validate_as(&FIELDS)?;
        Ok(spec)
    }
}

/// The continuation's fields as this command spells them: the continued parameter is
/// `--vary` (`--param NAME=VALUE` is the model-parameter override of every command).
const FIELDS: Fields = Fields {
    param: "vary",
    ..Fields::CONTINUATION
};

/// Final files (run.json aside).
pub const OUTPUTS: &[&str] = &[
    "values.npy",
    "fractions_up.npy",
    "fraction_errors_up.npy",
    "tipping_up.npy",
    "fractions_down.npy",
    "fraction_errors_down.npy",
    "tipping_down.npy",
    "continuation.json",
    "continuation.png",
];

study::plot_study! {
    Continuation, "continuation", ContinuationArgs => run_continuation,
    jeffcott_analysis::continuation::run, ContinuationSpec, ContinuationResult,
    write: write_continuation, summary: human_summary
}

/// Writes the arrays, continuation.json and continuation.png.
pub fn write_continuation(
    dir: &Path,
    spec: &ContinuationSpec,
    res: &ContinuationResult,
    plot_it: bool,
) -> Result<()> {
    output::ensure_dir(dir)?;
    let n = res.values.len();
    output::write_npy(&dir.join("values.npy"), &[n], &res.values)?;
    for r in &res.ramps {
        let d = r.direction.name();
        let g = r.ids + 1;
        let (f, e) = r.fractions();
        output::write_npy(&dir.join(format!("fractions_{d}.npy")), &[n, g], &f)?;
        output::write_npy(&dir.join(format!("fraction_errors_{d}.npy")), &[n, g], &e)?;
        output::write_npy(
            &dir.join(format!("tipping_{d}.npy")),
            &[n - 1, g, g],
            &r.tipping(),
        )?;
    }
    if plot_it {
        let panels: Vec<StackedPanel> = res
            .ramps
            .iter()
            .map(|r| {
                // Bands in ascending parameter order whatever the ramp direction.
                let asc = |col: &dyn Fn(&jeffcott_analysis::continuation::Step) -> f64| {
                    let mut v: Vec<(f64, f64)> = r.steps.iter().map(|s| (s.value, col(s))).collect();
                    v.sort_by(|a, b| a.0.total_cmp(&b.0));
                    v.into_iter().map(|p| p.1).collect::<Vec<f64>>()
                };
                let mut bands: Vec<(String, plotters::style::RGBColor, Vec<f64>)> = (0..r.ids as u32)
                    .map(|id| {
                        let v = asc(&|s| {
                            s.attractors
                                .iter()
                                .find(|a| a.id == id)
                                .map(|a| a.fraction)
                                .unwrap_or(0.0)
                        });
                        (id_name(r, id), PALETTE[id as usize % PALETTE.len()], v)
                    })
                    .filter(|b| b.2.iter().any(|&f| f > 0.0))
                    .collect();
                let div = asc(&|s| s.diverged_fraction);
                if div.iter().any(|&f| f > 0.0) {
                    bands.push(("diverged".into(), plotters::style::RGBColor(0, 0, 0), div));
                }
                StackedPanel {
                    title: format!(
                        "run-{} ({} start states per value; attractors found only from seeds have no basin band)",
                        r.direction.name(),
                        spec.ics
                    ),
                    bands,
                }
            })
            .collect();
        stacked_fractions(
            &dir.join("continuation.png"),
            &format!(
                "Basin fractions of the continued attractors over {}",
                spec.param.var.name()
            ),
            &format!("{} [{}]", spec.param.var.name(), spec.param.var.unit()),
            &res.values,
            &panels,
        )?;
    }
    let json = super::files::Documented::new(
        jeffcott_analysis::continuation::summary(spec, res),
        &[
            ("values.npy", "f64 [n]: the parameter values, ascending"),
            (
                "fractions_<dir>.npy",
                "f64 [n, ids + 1]: basin fraction of each continued attractor among the fresh start states at each step in ramp order (up ascending, down descending); last column diverged",
            ),
            (
                "fraction_errors_<dir>.npy",
                "f64 [n, ids + 1]: binomial standard errors sqrt(f (1 - f) / K)",
            ),
            (
                "tipping_<dir>.npy",
                "f64 [n - 1, ids + 1, ids + 1]: P(i -> j) from step k to step k + 1: the fraction of attractor i's basin at step k lying in attractor j's basin at step k + 1 (index ids: diverged); NaN rows: i has no basin at step k",
            ),
            (
                "continuation.json",
                "this file: per ramp, every attractor's first and last value and every step's attractors (id, class, period, fraction, error, lambda_1, seeded_only, state: one Poincare point at t = kT)",
            ),
            (
                "continuation.png",
                "stacked basin fractions against the parameter, one panel per ramp",
            ),
        ],
    );
    output::write_json(&dir.join("continuation.json"), &json)
}

fn human_summary(spec: &ContinuationSpec, res: &ContinuationResult, dir: &Path) -> String {
    let ramps: Vec<String> = res
        .ramps
        .iter()
        .map(|r| {
            let most = r
                .steps
                .iter()
                .map(|s| s.attractors.len())
                .max()
                .unwrap_or(0);
            format!(
                "run-{}: {} attractor(s) followed, at most {} at once",
                r.direction.name(),
                r.ids,
                most
            )
        })
        .collect();
    format!(
        "Continuation over {} ({} values, {} start states each): {}; {:.1} s. Files in {}.",
        spec.param.var.name(),
        res.values.len(),
        spec.ics,
        ramps.join("; "),
        res.seconds,
        dir.display()
    )
}
