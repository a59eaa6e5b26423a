//! `jeffcott cascade`: full-spectrum cascades of a quasistatic run-up and run-down,
//! resumable (docs/rub.md).

use super::files::Documented;
use super::rundir::{self, RunArgs};
use super::{ModelArgs, StepperArgs};
use clap::Args;
use jeffcott_analysis::cascade::{CascadeResult, CascadeSpec, arrays, regime_summary, summary};
use jeffcott_analysis::defaults;
use jeffcott_analysis::output;
use jeffcott_analysis::rub::natural_frequencies;
use jeffcott_core::error::Result;
use std::path::{Path, PathBuf};

/// Arguments of `jeffcott cascade`.
#[derive(Args, Debug)]
pub struct CascadeArgs {
    /// Rotor speeds a:b:n [rad/s] (n >= 2), swept quasistatically.
    #[arg(long, value_name = "a:b:n", allow_hyphen_values = true)]
    pub omega: String,
    /// Forcing periods at the first speed of each sweep, from the static equilibrium.
    #[arg(long, default_value_t = defaults::cascade::TRANSIENT_FIRST, value_name = "Q")]
    pub transient_first: u32,
    /// Forcing periods at each later speed before the spectrum is taken.
    #[arg(long, default_value_t = defaults::cascade::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods of each spectrum (a multiple of 6 puts 1/2X, 1/3X and 2/3X on bins).
    #[arg(long, default_value_t = defaults::cascade::PERIODS, value_name = "S")]
    pub periods: u32,
    /// Orders kept and drawn, -max..=max.
    #[arg(long, default_value_t = defaults::cascade::MAX_ORDER, value_name = "ORDER")]
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
        let spec = CascadeSpec {
            params: self.model.params()?,
            omegas: CascadeSpec::speeds(&self.omega)?,
            transient_first: self.transient_first,
            transient: self.transient,
            periods: self.periods,
            max_order: self.max_order,
            stepper: self.stepper.config(),
            up: self.direction != DirectionArg::Down,
            down: self.direction != DirectionArg::Up,
        };
        spec.validate()?;
        spec.check_size(&self.omega)?;
        Ok(spec)
    }
}

/// Runs `jeffcott cascade`.
pub fn run_cascade(a: &CascadeArgs) -> Result<()> {
    let spec = a.spec()?;
    let run_dir = rundir::open(
        &a.out,
        "cascade",
        &spec,
        OUTPUTS,
        a.run,
        rundir::Work::Units,
    )?;
    let t = std::time::Instant::now();
    let res =
        jeffcott_analysis::cascade::run(&spec, &rundir::CommandHost::new(&run_dir, a.run.quiet))?;
    write_cascade(&a.out, &spec, &res, !a.no_plot, a.csv)?;
    let secs = t.elapsed().as_secs_f64();
    run_dir.finish(
        &rundir::WallTime { wall_time_s: secs },
        &rundir::written(&run_dir, OUTPUTS),
    )?;
    if !a.run.quiet {
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
            regime_summary(&res),
            a.out.display()
        );
    }
    Ok(())
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
    let arr = arrays(res);
    let ns = arr.sweeps.len();
    output::write_npy(&dir.join("omega.npy"), &[n], &spec.omegas)?;
    output::write_npy(&dir.join("orders.npy"), &[nb], &res.orders)?;
    output::write_npy(&dir.join("cascade.npy"), &[ns, n, nb], &arr.rotor)?;
    output::write_npy(&dir.join("cascade_stator.npy"), &[ns, n, nb], &arr.stator)?;
    output::write_npy(&dir.join("regime.npy"), &[ns, n], &arr.regime)?;
    let tau = std::f64::consts::TAU;
    let naturals: Vec<(String, f64)> = natural_frequencies(&spec.params)
        .into_iter()
        .map(|(name, w)| (format!("{name} {:.0} rad/s", w), w / tau))
        .collect();
    for (k, d) in arr.sweeps.iter().enumerate() {
        let block = &arr.rotor[k * n * nb..(k + 1) * n * nb];
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
            let st = &arr.stator[k * n * nb..(k + 1) * n * nb];
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
        summary(spec, res),
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
