//! Pictures of Lyapunov spectra: the running estimates against time
//! (`convergence.png`) and the spectrum against the rotor speed (`lyapunov.png`).

use super::frame::{Mesh, chart, dot_key, figure, line_key, zero_line};
use super::{legend, padded_range};
use jeffcott_core::error::Result;
use jeffcott_core::model::STATE_DIM;
use plotters::prelude::*;
use std::path::Path;

/// One colour per exponent: the attractor palette, so every picture shares one set.
fn colour(i: usize) -> RGBColor {
    super::PALETTE[i % super::PALETTE.len()]
}

/// Margin and label areas of both pictures: room for the exponents' tick labels.
const AREAS: (u32, u32, u32) = (16, 50, 80);

/// The running estimate of each exponent against the accumulation time, with a zero
/// line. `history` holds (t [s], exponents [1/s]).
pub fn convergence(path: &Path, title: &str, history: &[(f64, [f64; STATE_DIM])]) -> Result<()> {
    figure(path, (1200, 800), |root| {
        let xr = padded_range(history.iter().map(|h| h.0).chain([0.0]));
        // Skip the first tenth for the vertical range: the earliest estimates swing widely.
        let skip = history.len() / 10;
        let yr = padded_range(
            history[skip..]
                .iter()
                .flat_map(|h| h.1.iter().copied())
                .chain([0.0]),
        );
        let mut chart = chart(root, Some((title, 24)), AREAS, xr.clone(), yr.clone())?;
        // Clamped into the frame (plotters does not clip lines).
        let clamp = |v: f64| v.clamp(yr.start, yr.end);
        Mesh::new("accumulation time [s]", "running estimate [1/s]").draw(&mut chart)?;
        zero_line(&mut chart, &xr, 1)?;
        for i in 0..STATE_DIM {
            let c = colour(i);
            chart
                .draw_series(LineSeries::new(
                    history.iter().map(|h| (h.0, clamp(h.1[i]))),
                    c.stroke_width(2),
                ))?
                .label(format!("lambda_{}", i + 1))
                .legend(line_key(c));
        }
        legend(&mut chart, SeriesLabelPosition::MiddleRight, 14)?;
        Ok(())
    })
}

/// The eight exponents against the rotor speed W, with the zero line marked.
pub fn spectrum_vs_omega(
    path: &Path,
    title: &str,
    omegas: &[f64],
    exponents: &[[f64; STATE_DIM]],
) -> Result<()> {
    figure(path, (1200, 800), |root| {
        let xr = padded_range(omegas.iter().copied());
        let yr = padded_range(exponents.iter().flatten().copied().chain([0.0]));
        let mut chart = chart(root, Some((title, 24)), AREAS, xr.clone(), yr)?;
        Mesh::new("W [rad/s]", "Lyapunov exponent [1/s]").draw(&mut chart)?;
        zero_line(&mut chart, &xr, 2)?
            .label("zero")
            .legend(line_key(BLACK));
        for i in 0..STATE_DIM {
            let c = colour(i);
            let pts: Vec<(f64, f64)> = omegas
                .iter()
                .zip(exponents)
                .filter(|(_, e)| e[i].is_finite())
                .map(|(&w, e)| (w, e[i]))
                .collect();
            chart.draw_series(LineSeries::new(pts.clone(), c.mix(0.6).stroke_width(1)))?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))?
                .label(format!("lambda_{}", i + 1))
                .legend(dot_key(c, 4));
        }
        legend(&mut chart, SeriesLabelPosition::MiddleRight, 14)?;
        Ok(())
    })
}
