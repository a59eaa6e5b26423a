//! `jeffcott cascade`: full-spectrum cascades of a quasistatic run-up and run-down,
//! resumable (docs/rub.md).

use super::files::Documented;
use super::rundir::{self, RunArgs};
use super::{ModelArgs, StepperArgs};
use clap::Args;
use jeffcott_analysis::cascade::{CascadeResult, CascadeSpec, Sweep, cascade_with};
use jeffcott_analysis::output;
use jeffcott_analysis::record::Span;
use jeffcott_analysis::rub::natural_frequencies;
use jeffcott_core::error::{Error, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `jeffcott cascade`.
#[derive(Args, Debug)]
pub struct CascadeArgs {
    /// Rotor speeds a:b:n [rad/s] (n >= 2), swept quasistatically.
    #[arg(long, value_name = "a:b:n", allow_hyphen_values = true)]
    pub omega: String,
    /// Forcing periods at the first speed of each sweep, from the static equilibrium.
    #[arg(long, default_value_t = 1000, value_name = "Q")]
    pub transient_first: u32,
    /// Forcing periods at each later speed before the spectrum is taken.
    #[arg(long, default_value_t = 100, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods of each spectrum (a multiple of 6 puts 1/2X, 1/3X and 2/3X on bins).
    #[arg(long, default_value_t = 24, value_name = "S")]
    pub periods: u32,
    /// Orders kept and drawn, -max..=max.
    #[arg(long, default_value_t = 4.0, value_name = "ORDER")]
    pub max_order: f64,
    /// Run-up, run-down or both.
    #[arg(long, value_enum, default_value_t = super::continuation::DirectionArg::Both)]
    pub direction: super::continuation::DirectionArg,
    #[command(flatten)]
    pub model: ModelArgs,
    #[command(flatten)]
    pub stepper: StepperArgs,
    /// Output directory (created if missing). An unfinished run of the same command there
    /// is resumed.
    #[arg(long, value_name = "DIR", default_value = "jeffcott-out/cascade")]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: RunArgs,
    /// Also write cascade_up.csv / cascade_down.csv (speed, order, Hz, amplitudes).
    #[arg(long)]
    pub csv: bool,
    /// Skip the pictures.
    #[arg(long)]
    pub no_plot: bool,
    /// Print nothing but errors (no progress bar).
    #[arg(long)]
    pub quiet: bool,
}

/// Final files (run.json aside).
pub const OUTPUTS: &[&str] = &[
    "omega.npy",
    "orders.npy",
    "cascade.npy",
    "cascade_stator.npy",
    "regime.npy",
    "cascade.json",
    "cascade_up.png",
    "cascade_down.png",
    "cascade_up.csv",
    "cascade_down.csv",
];

impl CascadeArgs {
    /// The cascade these arguments describe, validated.
    pub fn spec(&self) -> Result<CascadeSpec> {
        use super::continuation::DirectionArg;
        let r = jeffcott_core::ensemble::RangeSpec::parse("omega", &self.omega)?;
        if r.n > 100_000 {
            return Err(Error::invalid(
                "omega",
                &self.omega,
                "at most 100000 speeds",
            ));
        }
        let spec = CascadeSpec {
            params: self.model.params()?,
            omegas: r.values(),
            transient_first: self.transient_first,
            transient: self.transient,
            periods: self.periods,
            max_order: self.max_order,
            stepper: self.stepper.config(),
            up: self.direction != DirectionArg::Down,
            down: self.direction != DirectionArg::Up,
        };
        spec.validate()?;
        Ok(spec)
    }
}

/// Runs `jeffcott cascade`.
pub fn run_cascade(a: &CascadeArgs) -> Result<()> {
    let spec = a.spec()?;
    let rd = rundir::open(&a.out, "cascade", &spec.record(), OUTPUTS, a.run, a.quiet)?;
    let n = spec.omegas.len() as u64 * (spec.up as u64 + spec.down as u64);
    let bar = crate::progress::Bar::new("cascade", n, 1, a.quiet);
    let t = std::time::Instant::now();
    let cb = rundir::bar_callback(&bar);
    let res = cascade_with(&spec, rundir::store(&rd).as_ref(), &rundir::cancel(), &cb);
    bar.finish();
    let res = res?;
    write_cascade(&a.out, &spec, &res, !a.no_plot, a.csv)?;
    let secs = t.elapsed().as_secs_f64();
    rd.finish(
        &rundir::WallTime { wall_time_s: secs },
        &rundir::written(&rd, OUTPUTS),
    )?;
    if !a.quiet {
        println!(
            "Cascade over {} speeds ({}..{} rad/s){}: {}; {secs:.1} s. Files in {}.",
            spec.omegas.len(),
            spec.omegas[0],
            spec.omegas[spec.omegas.len() - 1],
            match (spec.up, spec.down) {
                (true, true) => ", run-up and run-down",
                (true, false) => ", run-up",
                _ => ", run-down",
            },
            regime_summary(&spec, &res),
            a.out.display()
        );
    }
    Ok(())
}

/// A sweep's rows in ascending speed order.
fn ascending(s: &Sweep, values: &[f64], per: usize) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..s.omegas.len()).collect();
    idx.sort_by(|&a, &b| s.omegas[a].total_cmp(&s.omegas[b]));
    idx.iter()
        .flat_map(|&i| values[i * per..(i + 1) * per].iter().copied())
        .collect()
}

/// Where each regime was found, per sweep: "run-up: partial_rub at 131.0..140.2 rad/s".
/// `cascade.json`: the speeds, the sweeps, the settings, the natural frequencies drawn
/// on the pictures and the regimes met (the command line adds the files and version).
#[derive(Serialize)]
struct CascadeFile<'a> {
    omega: Span,
    sweeps: Vec<&'static str>,
    transient_first: u32,
    transient: u32,
    periods: u32,
    max_order: f64,
    natural_frequencies_rad_s: Vec<NaturalFrequency>,
    regimes: String,
    params: &'a jeffcott_core::model::Params,
}

/// A natural frequency of the linearised system.
#[derive(Serialize)]
struct NaturalFrequency {
    name: String,
    rad_s: f64,
    hz: f64,
}

/// Where each rub regime lies along the sweeps, as cascade.json's `regimes` says it.
pub fn regime_summary(spec: &CascadeSpec, res: &CascadeResult) -> String {
    let mut parts = Vec::new();
    for (name, s) in [("run-up", &res.up), ("run-down", &res.down)] {
        let Some(s) = s else { continue };
        let mut by: std::collections::BTreeMap<i32, Vec<f64>> = Default::default();
        for (w, r) in s.omegas.iter().zip(&s.regime) {
            by.entry(*r).or_default().push(*w);
        }
        let text: Vec<String> = by
            .iter()
            .map(|(r, ws)| {
                let lo = ws.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = ws.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                format!(
                    "{} at {} speed(s) in {lo:.2}..{hi:.2} rad/s",
                    regime_label(*r),
                    ws.len()
                )
            })
            .collect();
        parts.push(format!("{name}: {}", text.join(", ")));
    }
    let _ = spec;
    parts.join("; ")
}

fn regime_label(code: i32) -> &'static str {
    use jeffcott_analysis::rub::RubRegime::*;
    [
        NoContact,
        PartialRub,
        FullAnnularRub,
        BackwardWhirl,
        Diverged,
    ]
    .into_iter()
    .find(|r| r.code() == code)
    .map(|r| r.label())
    .unwrap_or("unknown")
}

/// Writes the arrays, cascade.json and the pictures.
pub fn write_cascade(
    dir: &Path,
    spec: &CascadeSpec,
    res: &CascadeResult,
    plot_it: bool,
    csv: bool,
) -> Result<()> {
    output::ensure_dir(dir)?;
    let n = spec.omegas.len();
    let nb = res.orders.len();
    let sweeps: Vec<(&str, &Sweep)> = [("up", &res.up), ("down", &res.down)]
        .into_iter()
        .filter_map(|(d, s)| s.as_ref().map(|s| (d, s)))
        .collect();
    output::write_npy(&dir.join("omega.npy"), &[n], &spec.omegas)?;
    output::write_npy(&dir.join("orders.npy"), &[nb], &res.orders)?;
    let rotor: Vec<f64> = sweeps
        .iter()
        .flat_map(|(_, s)| ascending(s, &s.rotor, nb))
        .collect();
    let stator: Vec<f64> = sweeps
        .iter()
        .flat_map(|(_, s)| ascending(s, &s.stator, nb))
        .collect();
    let regime: Vec<i32> = sweeps
        .iter()
        .flat_map(|(_, s)| {
            let mut idx: Vec<usize> = (0..n).collect();
            idx.sort_by(|&a, &b| s.omegas[a].total_cmp(&s.omegas[b]));
            idx.into_iter().map(|i| s.regime[i]).collect::<Vec<_>>()
        })
        .collect();
    output::write_npy(&dir.join("cascade.npy"), &[sweeps.len(), n, nb], &rotor)?;
    output::write_npy(
        &dir.join("cascade_stator.npy"),
        &[sweeps.len(), n, nb],
        &stator,
    )?;
    output::write_npy(&dir.join("regime.npy"), &[sweeps.len(), n], &regime)?;
    let tau = std::f64::consts::TAU;
    let naturals: Vec<(String, f64)> = natural_frequencies(&spec.params)
        .into_iter()
        .map(|(name, w)| (format!("{name} {:.0} rad/s", w), w / tau))
        .collect();
    for (k, (d, _)) in sweeps.iter().enumerate() {
        let block = &rotor[k * n * nb..(k + 1) * n * nb];
        if plot_it {
            crate::plot::rub::cascade(
                &dir.join(format!("cascade_{d}.png")),
                &format!(
                    "Full-spectrum cascade of the rotor, quasistatic run-{d} ({} periods per spectrum)",
                    spec.periods
                ),
                &spec.omegas,
                &res.orders,
                block,
                &naturals,
            )?;
        }
        if csv {
            let st = &stator[k * n * nb..(k + 1) * n * nb];
            output::write_csv(
                &dir.join(format!("cascade_{d}.csv")),
                &[
                    "omega_rad_s",
                    "order",
                    "hz",
                    "rotor_amplitude_m",
                    "stator_amplitude_m",
                ],
                (0..n).flat_map(|i| {
                    (0..nb).map(move |b| {
                        let w = spec.omegas[i];
                        vec![
                            w,
                            res.orders[b],
                            res.orders[b] * w / tau,
                            block[i * nb + b],
                            st[i * nb + b],
                        ]
                    })
                }),
            )?;
        }
    }
    let json = Documented::new(
        CascadeFile {
            omega: Span::of(&spec.omegas),
            sweeps: sweeps.iter().map(|(d, _)| *d).collect(),
            transient_first: spec.transient_first,
            transient: spec.transient,
            periods: spec.periods,
            max_order: spec.max_order,
            natural_frequencies_rad_s: natural_frequencies(&spec.params)
                .into_iter()
                .map(|(name, w)| NaturalFrequency {
                    name,
                    rad_s: w,
                    hz: w / tau,
                })
                .collect(),
            regimes: regime_summary(spec, res),
            params: &spec.params,
        },
        &[
            ("omega.npy", "f64 [n]: the speeds, ascending [rad/s]"),
            (
                "orders.npy",
                "f64 [bins]: frequency / W of each bin (< 0 backward whirl)",
            ),
            (
                "cascade.npy",
                "f64 [sweeps, n, bins]: rotor full-spectrum amplitude [m] per sweep (in the order of `sweeps`), speed (ascending) and order; NaN after a divergence",
            ),
            (
                "cascade_stator.npy",
                "f64 [sweeps, n, bins]: the same for the stator",
            ),
            (
                "regime.npy",
                "int32 [sweeps, n]: rub regime per speed: 0 no_contact, 1 partial_rub, 2 full_annular_rub, 3 backward_whirl, -1 diverged",
            ),
            (
                "cascade_<sweep>.png",
                "frequency [Hz] against speed, colour = log amplitude, 1X line and natural frequencies",
            ),
            (
                "cascade_<sweep>.csv",
                "with --csv: one row per speed and bin",
            ),
        ],
    );
    output::write_json(&dir.join("cascade.json"), &json)
}
