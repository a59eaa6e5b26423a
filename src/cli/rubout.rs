//! What `simulate` adds for rotordynamics engineers: the rub figures and regime, the full
//! spectra of rotor and stator, the contact load histories and the orbit relative to the
//! stator, from a stretch of whole forcing periods continued from the run's final state
//! (on the attractor) with the lane stepper (docs/rub.md); optionally as CSV.

use jeffcott_analysis::output;
use jeffcott_analysis::rub::{RubFigures, normal_force, rub_figures};
use jeffcott_analysis::spectrum::{FullSpectrum, full_spectrum, orbit};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, State, X_R, X_S, Y_R, Y_S, penetration};
use std::path::Path;

/// The rub outputs of a trajectory.
pub struct RubOutputs {
    /// Forcing periods of the stretch.
    pub periods: u32,
    /// Rub figures and regime.
    pub figures: RubFigures,
    /// Full spectrum of the rotor's x + i y.
    pub rotor: FullSpectrum,
    /// Full spectrum of the stator's x + i y.
    pub stator: FullSpectrum,
    /// (t [s], dx [m], dy [m], g [m], F_n [N]) at each grid point of the stretch.
    pub contact: Vec<[f64; 5]>,
}

/// Integrates `periods` forcing periods from `x0` (a state at t = kT) and derives the
/// rub outputs; `None` when the stretch froze (diverged or non-finite).
pub fn rub_outputs(
    p: &Params,
    omega: f64,
    x0: &State,
    periods: u32,
    stepper: &StepperConfig,
) -> Result<Option<RubOutputs>> {
    let spec = jeffcott_analysis::simulate::SimulateSpec {
        params: p.clone(),
        omega,
        x0: *x0,
        transient: 0,
        periods,
        timeseries_periods: periods,
        integrator: jeffcott_analysis::simulate::Integrator::Lane,
        stepper: *stepper,
        article: Default::default(),
        classify: Default::default(),
    };
    let r = jeffcott_analysis::simulate::simulate(&spec)?;
    if r.status.is_frozen() || x0.iter().any(|v| !v.is_finite()) {
        return Ok(None);
    }
    let rows = &r.timeseries;
    let contact = rows
        .iter()
        .map(|row| {
            let mut x = [0.0; STATE_DIM];
            x.copy_from_slice(&row[1..]);
            [
                row[0],
                x[X_R] - x[X_S],
                x[Y_R] - x[Y_S],
                penetration(p.delta, &x),
                normal_force(p, &x),
            ]
        })
        .collect();
    Ok(Some(RubOutputs {
        periods,
        figures: rub_figures(p, omega, rows, periods),
        rotor: full_spectrum(&orbit(rows, false), periods, omega),
        stator: full_spectrum(&orbit(rows, true), periods, omega),
        contact,
    }))
}

/// The strongest lines of a spectrum: (order, amplitude [m]) of the `n` largest local
/// maxima above 0.1 % of the largest, strongest first.
pub fn strongest_lines(s: &FullSpectrum, n: usize) -> Vec<(f64, f64)> {
    let a = &s.amplitude;
    let top = a.iter().copied().fold(0.0, f64::max);
    let mut peaks: Vec<(f64, f64)> = (1..a.len().saturating_sub(1))
        .filter(|&k| a[k] >= a[k - 1] && a[k] > a[k + 1] && a[k] > 1e-3 * top)
        .map(|k| (s.order[k], a[k]))
        .collect();
    peaks.sort_by(|x, y| y.1.total_cmp(&x.1));
    peaks.truncate(n);
    peaks
}

/// Files `rub_outputs` writes.
pub const FILES: &[&str] = &[
    "full_spectrum.npy",
    "full_spectrum.png",
    "contact.npy",
    "contact.png",
    "timeseries.csv",
    "full_spectrum.csv",
    "contact.csv",
];

/// Writes full_spectrum.npy/.png, contact.npy/.png and with `csv` their CSV twins and
/// the time series as CSV.
pub fn write_rub_outputs(
    dir: &Path,
    title: &str,
    p: &Params,
    o: &RubOutputs,
    timeseries: &[[f64; STATE_DIM + 1]],
    plot_it: bool,
    csv: bool,
) -> Result<()> {
    let m = o.rotor.order.len();
    let spectrum_rows = (0..m).map(|k| {
        vec![
            o.rotor.order[k],
            o.rotor.hz[k],
            o.rotor.amplitude[k],
            o.stator.amplitude[k],
        ]
    });
    let flat: Vec<f64> = spectrum_rows.clone().flatten().collect();
    output::write_npy(&dir.join("full_spectrum.npy"), &[m, 4], &flat)?;
    let flat: Vec<f64> = o.contact.iter().flatten().copied().collect();
    output::write_npy(&dir.join("contact.npy"), &[o.contact.len(), 5], &flat)?;
    if plot_it {
        crate::plot::rub::full_spectrum(
            &dir.join("full_spectrum.png"),
            &format!(
                "{title}: full spectra over {} periods (Hann window)",
                o.periods
            ),
            &o.rotor,
            &o.stator,
            4.0,
        )?;
        crate::plot::rub::contact(
            &dir.join("contact.png"),
            &format!(
                "{title}: {} , contact {:.1} % of the time, peak normal force {:.0} N",
                o.figures.regime.label(),
                100.0 * o.figures.contact_fraction,
                o.figures.peak_force_n
            ),
            &o.contact,
            p.delta,
        )?;
    }
    if csv {
        output::write_csv(
            &dir.join("full_spectrum.csv"),
            &["order", "hz", "rotor_amplitude_m", "stator_amplitude_m"],
            spectrum_rows,
        )?;
        output::write_csv(
            &dir.join("contact.csv"),
            &["t_s", "dx_m", "dy_m", "penetration_m", "normal_force_n"],
            o.contact.iter().map(|r| r.to_vec()),
        )?;
        let mut header = vec!["t_s"];
        header.extend(jeffcott_core::model::COORD_NAMES);
        output::write_csv(
            &dir.join("timeseries.csv"),
            &header,
            timeseries.iter().map(|r| r.to_vec()),
        )?;
    }
    Ok(())
}

/// One sentence on the rub for the stdout summary.
pub fn rub_sentence(o: &RubOutputs) -> String {
    let f = &o.figures;
    let lines: Vec<String> = strongest_lines(&o.rotor, 6)
        .iter()
        .map(|(ord, a)| format!("{} {:.3} mm", order_name(*ord), a * 1e3))
        .collect();
    format!(
        "Rub regime: {} (contact {:.1} % of the time, {:.2} impacts per revolution, peak normal force {:.0} N, mean {:.0} N in contact, peak penetration {:.2} um, contact arc {:.0} deg); whirl {:?} ({:.0} % of the rotor's non-static spectral power forward); rotor full spectrum: {}.",
        f.regime.label(),
        100.0 * f.contact_fraction,
        f.impacts_per_rev,
        f.peak_force_n,
        f.mean_force_n,
        f.peak_penetration_m * 1e6,
        f.contact_arc_deg,
        f.whirl,
        100.0 * f.forward_share,
        lines.join(", ")
    )
}

/// "+1X", "-1/2X", "+2/3X", "+0.37X" for an order.
pub fn order_name(o: f64) -> String {
    let sign = if o < 0.0 { "-" } else { "+" };
    let a = o.abs();
    if a < 1e-9 {
        return "0X (static)".into();
    }
    for d in 1..=6u32 {
        let n = (a * d as f64).round();
        if (a * d as f64 - n).abs() < 1e-9 && n > 0.0 {
            return if d == 1 {
                format!("{sign}{n}X")
            } else {
                format!("{sign}{n}/{d}X")
            };
        }
    }
    format!("{sign}{a:.3}X")
}
