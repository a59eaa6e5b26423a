//! What `simulate` adds for rotordynamics engineers: the rub figures and regime, the full
//! spectra of rotor and stator, the contact load histories and the orbit relative to the
//! stator, from a stretch of whole forcing periods continued from the run's final state
//! (on the attractor) with the lane stepper (docs/rub.md); optionally as CSV.

use jeffcott_analysis::output;
use jeffcott_core::error::Result;
use jeffcott_core::model::{Params, STATE_DIM};
use std::path::Path;

pub use jeffcott_analysis::simulate::{RubOutputs, order_name, rub_outputs, strongest_lines};

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
    let spectrum_rows = o.spectrum_table();
    let flat: Vec<f64> = spectrum_rows.iter().flatten().copied().collect();
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
                "{title}: {}, contact {:.1} % of the time, peak normal force {:.0} N",
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
            spectrum_rows.iter().map(|r| r.to_vec()),
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
