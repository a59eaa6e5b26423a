//! Pictures of Lyapunov spectra: the running estimates against time
//! (`convergence.png`) and the spectrum against the rotor speed (`lyapunov.png`).

use super::{padded_range, plot_err, register_font};
use jeffcott_core::error::Result;
use jeffcott_core::model::STATE_DIM;
use plotters::prelude::*;
use std::path::Path;

/// One colour per exponent: the attractor palette, so every picture shares one set.
fn colour(i: usize) -> RGBColor {
    super::PALETTE[i % super::PALETTE.len()]
}

/// The running estimate of each exponent against the accumulation time, with a zero
/// line. `history` holds (t [s], exponents [1/s]).
pub fn convergence(path: &Path, title: &str, history: &[(f64, [f64; STATE_DIM])]) -> Result<()> {
    register_font();
    let err = plot_err(path);
    crate::plot::render_png(path, (1200, 800), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let xr = padded_range(history.iter().map(|h| h.0).chain([0.0]));
        // Skip the first tenth for the vertical range: the earliest estimates swing widely.
        let skip = history.len() / 10;
        let yr = padded_range(
            history[skip..]
                .iter()
                .flat_map(|h| h.1.iter().copied())
                .chain([0.0]),
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(xr.clone(), yr.clone())
            .map_err(|e| err(e.to_string()))?;
        // Clamped into the frame (plotters does not clip lines).
        let clamp = |v: f64| v.clamp(yr.start, yr.end);
        chart
            .configure_mesh()
            .x_desc("accumulation time [s]")
            .y_desc("running estimate [1/s]")
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        chart
            .draw_series(LineSeries::new(
                [(xr.start, 0.0), (xr.end, 0.0)],
                BLACK.stroke_width(1),
            ))
            .map_err(|e| err(e.to_string()))?;
        for i in 0..STATE_DIM {
            let c = colour(i);
            chart
                .draw_series(LineSeries::new(
                    history.iter().map(|h| (h.0, clamp(h.1[i]))),
                    c.stroke_width(2),
                ))
                .map_err(|e| err(e.to_string()))?
                .label(format!("lambda_{}", i + 1))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c));
        }
        super::legend(&mut chart, SeriesLabelPosition::MiddleRight, 14).map_err(&err)?;
        root.present().map_err(|e| err(e.to_string()))
    })
}

/// The eight exponents against the rotor speed W, with the zero line marked.
pub fn spectrum_vs_omega(
    path: &Path,
    title: &str,
    omegas: &[f64],
    exponents: &[[f64; STATE_DIM]],
) -> Result<()> {
    register_font();
    let err = plot_err(path);
    crate::plot::render_png(path, (1200, 800), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let xr = padded_range(omegas.iter().copied());
        let yr = padded_range(exponents.iter().flatten().copied().chain([0.0]));
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(xr.clone(), yr)
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("W [rad/s]")
            .y_desc("Lyapunov exponent [1/s]")
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        chart
            .draw_series(LineSeries::new(
                [(xr.start, 0.0), (xr.end, 0.0)],
                BLACK.stroke_width(2),
            ))
            .map_err(|e| err(e.to_string()))?
            .label("zero")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
        for i in 0..STATE_DIM {
            let c = colour(i);
            let pts: Vec<(f64, f64)> = omegas
                .iter()
                .zip(exponents)
                .filter(|(_, e)| e[i].is_finite())
                .map(|(&w, e)| (w, e[i]))
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), c.mix(0.6).stroke_width(1)))
                .map_err(|e| err(e.to_string()))?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                .map_err(|e| err(e.to_string()))?
                .label(format!("lambda_{}", i + 1))
                .legend(move |(x, y)| Circle::new((x + 9, y), 4, c.filled()));
        }
        super::legend(&mut chart, SeriesLabelPosition::MiddleRight, 14).map_err(&err)?;
        root.present().map_err(|e| err(e.to_string()))
    })
}
