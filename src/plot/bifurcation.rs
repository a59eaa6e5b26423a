//! Bifurcation diagrams: Poincare points against the rotor speed W, one panel per
//! coordinate, with an optional lambda_1 panel underneath.

use super::frame::{Area, Drawn, Mesh, Ticks, chart, dot_key, figure, line_key, zero_line};
use super::{coord_axis, legend, padded_range};
use jeffcott_core::error::Result;
use jeffcott_core::model::State;
use plotters::prelude::*;
use std::path::Path;

/// A set of dots of one colour in a bifurcation diagram: (W, state) pairs.
#[derive(Clone, Debug)]
pub struct DotSeries {
    /// Legend text.
    pub label: String,
    /// Colour.
    pub color: RGBColor,
    /// Dot radius in pixels (0: single pixels).
    pub radius: u32,
    /// (W [rad/s], Poincare point) pairs.
    pub points: Vec<(f64, State)>,
}

/// lambda_1 against W for the panel under a bifurcation diagram: one series of
/// (W [rad/s], lambda_1 [1/s]) values.
#[derive(Clone, Debug)]
pub struct Lambda1Series {
    /// Legend text.
    pub label: String,
    /// Colour.
    pub color: RGBColor,
    /// Dot radius in pixels (0: single pixels, no line).
    pub radius: u32,
    /// Join consecutive values by a line (a sweep), or dots only (brute force).
    pub line: bool,
    /// (W, lambda_1) pairs; non-finite values are skipped.
    pub points: Vec<(f64, f64)>,
}

/// Margin and label areas of every panel: the W axes line up across panels.
const PANEL: (u32, u32, u32) = (14, 50, 90);

/// The axes of a panel against W, `y_desc` with ticks by `y_ticks`.
fn w_mesh<'m>(y_desc: &'m str, y_ticks: Ticks<'m>) -> Mesh<'m> {
    // No light grid lines: they would hide single-pixel dots.
    Mesh::new("W [rad/s]", y_desc)
        .fonts(16, 19)
        .no_light_lines()
        .ticks(&|v| format!("{v:.2}"), y_ticks)
}

/// Draws a bifurcation diagram: one panel per coordinate in `coords`, W on the x axis,
/// the series drawn in order (later ones on top); with `lambda1` series, a panel under
/// them with the largest Lyapunov exponent against the same W axis and the zero line.
pub fn bifurcation_diagram(
    path: &Path,
    title: &str,
    coords: &[usize],
    w_range: (f64, f64),
    series: &[DotSeries],
    lambda1: &[Lambda1Series],
) -> Result<()> {
    let l1 = lambda1
        .iter()
        .any(|s| s.points.iter().any(|p| p.1.is_finite()));
    let l1_h = if l1 { 380 } else { 0 };
    let h = 120 + 620 * coords.len().max(1) as u32 + l1_h;
    figure(path, (1800, h), |root| {
        let root = root.titled(title, ("sans-serif", 26))?;
        let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 - l1_h);
        let pad = 0.005 * (w_range.1 - w_range.0).max(1e-9);
        if l1 {
            lambda1_panel(&bottom, w_range, pad, lambda1)?;
        }
        for (area, &ci) in top
            .split_evenly((coords.len().max(1), 1))
            .iter()
            .zip(coords)
        {
            let (s, label) = coord_axis(ci);
            let yr = padded_range(
                series
                    .iter()
                    .flat_map(|se| se.points.iter().map(move |p| p.1[ci] * s)),
            );
            let x = (w_range.0 - pad)..(w_range.1 + pad);
            let mut chart = chart(area, None, PANEL, x, yr)?;
            w_mesh(&label, &|v| format!("{v:.4}")).draw(&mut chart)?;
            for se in series.iter().filter(|se| !se.points.is_empty()) {
                let c = se.color;
                let r = se.radius;
                let anno = if r == 0 {
                    chart.draw_series(
                        se.points
                            .iter()
                            .filter(|p| p.1[ci].is_finite())
                            .map(|p| Pixel::new((p.0, p.1[ci] * s), c)),
                    )
                } else {
                    chart.draw_series(
                        se.points
                            .iter()
                            .filter(|p| p.1[ci].is_finite())
                            .map(|p| Circle::new((p.0, p.1[ci] * s), r, c.filled())),
                    )
                }?;
                anno.label(se.label.as_str()).legend(dot_key(c, 4));
            }
            legend(&mut chart, SeriesLabelPosition::UpperLeft, 16)?;
        }
        Ok(())
    })
}

/// The lambda_1 panel of [`bifurcation_diagram`].
fn lambda1_panel(
    area: &Area<'_>,
    w_range: (f64, f64),
    pad: f64,
    series: &[Lambda1Series],
) -> Drawn {
    let yr = padded_range(
        series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1))
            .chain([0.0]),
    );
    let x = (w_range.0 - pad)..(w_range.1 + pad);
    let mut chart = chart(area, None, PANEL, x.clone(), yr)?;
    w_mesh("lambda_1 [1/s]", &|v| format!("{v:.1}")).draw(&mut chart)?;
    zero_line(&mut chart, &x, 1)?
        .label("lambda_1 = 0")
        .legend(line_key(BLACK));
    for s in series {
        let c = s.color;
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.1.is_finite())
            .collect();
        if pts.is_empty() {
            continue;
        }
        if s.line {
            // Break the line at gaps (frozen lanes) so it does not bridge them.
            let mut run: Vec<(f64, f64)> = Vec::new();
            for p in &s.points {
                if p.1.is_finite() {
                    run.push(*p);
                } else if !run.is_empty() {
                    chart.draw_series(LineSeries::new(
                        std::mem::take(&mut run),
                        c.mix(0.7).stroke_width(1),
                    ))?;
                }
            }
            if !run.is_empty() {
                chart.draw_series(LineSeries::new(run, c.mix(0.7).stroke_width(1)))?;
            }
        }
        let anno = if s.radius == 0 {
            chart.draw_series(pts.iter().map(|&p| Pixel::new(p, c)))
        } else {
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, s.radius, c.filled())))
        }?;
        anno.label(s.label.as_str()).legend(dot_key(c, 4));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft, 16)?;
    Ok(())
}
