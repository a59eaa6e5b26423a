//! `jeffcott simulate`: one trajectory at one rotor speed, with its Poincare points,
//! time series, phase portraits, rub figures and a classification (summary.json).

use super::files::Documented;
use super::{ModelArgs, StepperArgs, apply_init, rubout, rundir};
use crate::cli::choice::{choice, name_of};
use crate::plot;
use clap::Args;
use jeffcott_analysis::classify::ClassifyConfig;
use jeffcott_analysis::defaults;
use jeffcott_analysis::output;
use jeffcott_analysis::simulate::{
    Integrator, SimulateOutcome, SimulateSpec, SimulateStudy, run_study,
};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::article::{ArticleConfig, ErrorNorm};
use jeffcott_core::model::STATE_DIM;
use std::path::{Path, PathBuf};

/// Arguments of `jeffcott simulate`.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// Rotor speed W [rad/s]; the article's interesting range is 130..141.
    #[arg(long, value_name = "W")]
    pub omega: f64,
    /// Forcing periods T = 2 pi / W integrated and discarded before recording.
    #[arg(long, default_value_t = defaults::simulate::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded (one Poincare point each); at least 2 n for period n to
    /// be detectable.
    #[arg(long, default_value_t = defaults::simulate::PERIODS, value_name = "P")]
    pub periods: u32,
    /// Override coordinates of the start state (default: static equilibrium without
    /// contact), e.g. `--init x_r=0.005,vx_r=-0.5`. Names: x_r, vx_r, y_r, vy_r, x_s,
    /// vx_s, y_s, vy_s [m, m/s].
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub init: Vec<String>,
    #[command(flatten)]
    pub model: ModelArgs,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR", default_value = "jeffcott-out/simulate")]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: rundir::RunArgs,
    /// Integrator: the ensemble lane stepper (crossing-located RK4, the default) or the
    /// article's variable-step RK4 (a cross-check; slower).
    #[arg(long, value_parser = choice::<Integrator>(), default_value = name_of(Integrator::Lane))]
    pub integrator: Integrator,
    #[command(flatten)]
    pub stepper: StepperArgs,
    /// Standard steps per period of the article's scheme.
    #[arg(long, default_value_t = ArticleConfig::DEFAULT.steps_per_period, value_name = "N")]
    pub article_steps: u32,
    /// Components of the article scheme's step-doubling error (E_max is in metres).
    #[arg(long, value_parser = choice::<ErrorNorm>(), default_value = name_of(ErrorNorm::Positions))]
    pub article_norm: ErrorNorm,
    /// Exponent of the article scheme's step reduction dt (E_max/E)^alpha.
    #[arg(long, default_value_t = ArticleConfig::DEFAULT.alpha)]
    pub article_alpha: f64,
    /// Periods at the end written to timeseries.npy and drawn [default: min(8, P)].
    #[arg(long, value_name = "M")]
    pub timeseries_periods: Option<u32>,
    /// Largest period the classifier looks for.
    #[arg(long, default_value_t = ClassifyConfig::DEFAULT.n_max)]
    pub n_max: usize,
    /// Classifier repeat tolerance relative to the Poincare set's size.
    #[arg(long, default_value_t = ClassifyConfig::DEFAULT.rel_tol)]
    pub rel_tol: f64,
    /// Classifier repeat tolerance floor [m].
    #[arg(long, default_value_t = ClassifyConfig::DEFAULT.abs_tol)]
    pub abs_tol: f64,
    /// Forcing periods of the stretch, continued from the final state, that the rub
    /// figures, full spectra and contact histories are taken over (a multiple of 6 shows
    /// the 1/2X, 1/3X and 2/3X lines on bins).
    #[arg(long, default_value_t = defaults::simulate::SPECTRUM_PERIODS, value_name = "S")]
    pub spectrum_periods: u32,
    /// Also write timeseries.csv, full_spectrum.csv and contact.csv.
    #[arg(long)]
    pub csv: bool,
    /// Skip phase.png, full_spectrum.png and contact.png.
    #[arg(long)]
    pub no_plot: bool,
}

/// Runs `jeffcott simulate`.
pub fn run_simulate(a: &SimulateArgs) -> Result<()> {
    let params = a.model.params()?;
    let mut x0 = params.static_equilibrium();
    apply_init(&mut x0, &a.init)?;
    let spec = SimulateSpec {
        params,
        omega: a.omega,
        x0,
        transient: a.transient,
        periods: a.periods,
        timeseries_periods: a
            .timeseries_periods
            .unwrap_or(a.periods.min(defaults::simulate::TIMESERIES_PERIODS)),
        integrator: a.integrator,
        stepper: a.stepper.config(),
        article: ArticleConfig {
            steps_per_period: a.article_steps,
            alpha: a.article_alpha,
            norm: a.article_norm,
            ..ArticleConfig::default()
        },
        classify: ClassifyConfig {
            n_max: a.n_max,
            rel_tol: a.rel_tol,
            abs_tol: a.abs_tol,
        },
    };
    let study = SimulateStudy {
        spec,
        spectrum_periods: a.spectrum_periods,
    };
    study.validate()?;
    let mut outputs = vec![
        "poincare.npy",
        "timeseries.npy",
        "phase.png",
        "summary.json",
    ];
    outputs.extend_from_slice(rubout::FILES);
    let run_dir = rundir::open(
        &a.out,
        "simulate",
        &SimulateRecord {
            spec: &study.spec,
            spectrum_periods: a.spectrum_periods,
        },
        &outputs,
        a.run,
        rundir::Work::Whole,
    )?;
    let SimulateOutcome { result: res, rub } = run_study(&study, &rundir::cancel())?;
    let spec = study.spec;
    if let Some(o) = &rub {
        rubout::write_rub_outputs(
            &a.out,
            &format!("W = {} rad/s", spec.omega),
            &spec.params,
            o,
            &res.timeseries,
            !a.no_plot,
            a.csv,
        )?;
    }
    write_simulation(&a.out, &spec, &res, rub.as_ref(), !a.no_plot)?;
    run_dir.finish(
        &rundir::WallTime {
            wall_time_s: res.elapsed.as_secs_f64(),
        },
        &rundir::written(&run_dir, &outputs),
    )?;
    if !a.run.quiet {
        println!("{}", human_summary(&spec, &res, &a.out));
        match &rub {
            Some(o) => println!("{}", rubout::rub_sentence(o)),
            None => println!(
                "Rub regime: diverged (no bounded stretch to take rub figures, spectra or their CSV files from)."
            ),
        }
    }
    Ok(())
}

/// A simulation's specification as `run.json` records it.
#[derive(serde::Serialize)]
struct SimulateRecord<'a> {
    #[serde(flatten)]
    spec: &'a SimulateSpec,
    spectrum_periods: u32,
}

fn write_simulation(
    dir: &Path,
    spec: &SimulateSpec,
    res: &jeffcott_analysis::simulate::SimulateResult,
    rub: Option<&rubout::RubOutputs>,
    plot_it: bool,
) -> Result<()> {
    output::ensure_dir(dir)?;
    let flat = jeffcott_analysis::simulate::poincare_rows(spec, res);
    output::write_npy(
        &dir.join("poincare.npy"),
        &[spec.periods as usize, STATE_DIM],
        &flat,
    )?;
    let flat: Vec<f64> = res.timeseries.iter().flatten().copied().collect();
    output::write_npy(
        &dir.join("timeseries.npy"),
        &[res.timeseries.len(), STATE_DIM + 1],
        &flat,
    )?;
    if plot_it {
        let title = format!(
            "W = {} rad/s: {} ({} periods after {} transient)",
            spec.omega,
            res.classification.class.label(),
            spec.periods,
            spec.transient
        );
        plot::phase_portraits(
            &dir.join("phase.png"),
            &title,
            &res.timeseries,
            &res.poincare,
        )?;
    }
    let summary = Documented::new(
        jeffcott_analysis::simulate::summary(spec, res, rub),
        &[
            (
                "poincare.npy",
                "f64 [K, 8], state order x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s (m, m/s)",
            ),
            (
                "timeseries.npy",
                "f64 [M, 9], t [s] then the state, on the integrator's grid",
            ),
            (
                "phase.png",
                if plot_it {
                    "rotor and stator phase portraits and orbits"
                } else {
                    "not drawn (--no-plot)"
                },
            ),
            (
                "full_spectrum.npy",
                "f64 [bins, 4]: order (frequency / W, < 0 backward whirl), frequency [Hz], rotor and stator amplitude [m] of the full spectrum of x + i y over rub.periods periods continued from the final state (Hann window, line-calibrated)",
            ),
            (
                "contact.npy",
                "f64 [M, 5]: t [s], x_r - x_s, y_r - y_s [m], penetration g [m] (> 0 in contact), normal contact force [N], at each grid point of that stretch",
            ),
            (
                "full_spectrum.png",
                "the full spectra with 1X, 2X, 3X, 1/2X, 1/3X, 2/3X marks",
            ),
            (
                "contact.png",
                "the rotor orbit relative to the stator with the clearance circle and contact points; normal force and penetration against time",
            ),
            (
                "*.csv",
                "with --csv: timeseries.csv, full_spectrum.csv, contact.csv (the same columns, headed)",
            ),
        ],
    );
    // Written last: its presence marks a complete run.
    output::write_json(&dir.join("summary.json"), &summary)
}

fn human_summary(
    spec: &SimulateSpec,
    res: &jeffcott_analysis::simulate::SimulateResult,
    dir: &Path,
) -> String {
    use jeffcott_analysis::classify::{Class, MIN_POINTS};
    let c = &res.classification;
    let what = match c.class.period() {
        Some(1) => {
            "a period-1 response (one Poincare point, synchronous with the unbalance)".to_string()
        }
        Some(n) => format!(
            "a period-{n} response ({n} distinct Poincare points, repeating every {n} forcing periods)"
        ),
        None if c.class == Class::Diverged => format!(
            "no bounded response: the lane ended with status {:?}",
            res.status
        ),
        None if c.class == Class::Unclassified => format!(
            "an unclassified response: {} recorded Poincare point(s) are too few to classify \
             (at least {MIN_POINTS}, and 2 n to see period n; record more --periods)",
            res.poincare.len()
        ),
        None => format!(
            "an aperiodic response (no period up to {}; quasiperiodic or chaotic)",
            spec.classify.n_max
        ),
    };
    let (min, max) = res
        .poincare
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let r = ((p[0] - p[4]).powi(2) + (p[2] - p[6]).powi(2)).sqrt();
            (lo.min(r), hi.max(r))
        });
    // No recorded point (the lane froze in the transient): no distance to report, and
    // never the fold's start values (inf, -inf).
    let distance = if min.is_finite() && max.is_finite() {
        format!("{:.4} to {:.4} mm", min * 1e3, max * 1e3)
    } else {
        "no recorded points".to_string()
    };
    // A lane that froze stopped where it was: say where, not the periods asked for.
    let recorded = res.poincare.iter().filter(|p| p[0].is_finite()).count();
    let integrated = if !res.status.is_frozen() {
        format!("Integrated {} periods", spec.transient + spec.periods)
    } else if recorded == 0 {
        format!("Stopped within the {} transient periods", spec.transient)
    } else {
        format!(
            "Stopped after the {} transient and {recorded} of {} recorded periods",
            spec.transient, spec.periods
        )
    };
    let contact = if recorded == 0 && res.status.is_frozen() {
        "no recorded grid points to measure contact on".to_string()
    } else {
        format!(
            "the rotor is in contact at {:.1}% of recorded grid points",
            100.0 * res.contact_fraction
        )
    };
    let settles = if res.status.is_frozen() {
        format!("the rotor reaches {what}")
    } else {
        format!(
            "after {} transient periods the rotor settles on {what}",
            spec.transient
        )
    };
    format!(
        "At W = {} rad/s, started from ({}), {settles}. \
         Rotor-stator distance at the Poincare points: {} (gap {} mm); {contact}. \
         {integrated} with the {:?} integrator in {:.2} s (status {:?}). \
         Files in {}: poincare.npy, timeseries.npy, summary.json{}.",
        spec.omega,
        if spec.x0 == spec.params.static_equilibrium() {
            "static equilibrium".to_string()
        } else {
            "the given state".to_string()
        },
        distance,
        spec.params.delta * 1e3,
        spec.integrator,
        res.elapsed.as_secs_f64(),
        res.status,
        dir.display(),
        if dir.join("phase.png").exists() {
            ", phase.png"
        } else {
            ""
        },
    )
}
