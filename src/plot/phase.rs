//! Phase portraits and state-space traces: one run's portraits with its Poincare
//! points, coexisting attractors on common axes, and Poincare sections.

use super::frame::{Mesh, axis_ticks, chart, dot_key, figure, line_key};
use super::{coord_axis, legend, padded_range};
use jeffcott_core::error::Result;
use jeffcott_core::model::{STATE_DIM, State, VX_R, VX_S, X_R, X_S, Y_R, Y_S};
use plotters::prelude::*;
use std::ops::Range;
use std::path::Path;

/// One panel: which state components go on the axes, their scale and labels.
struct Panel {
    title: &'static str,
    x: usize,
    y: usize,
    x_scale: f64,
    y_scale: f64,
    x_label: &'static str,
    y_label: &'static str,
}

/// Margin and label areas of a portrait panel (the four panels share one layout).
const PORTRAIT: (u32, u32, u32) = (12, 48, 80);

/// Tick labels for a panel's ranges, at their scale (a stator that barely moves gets
/// digits enough to tell its ticks apart).
fn ticks_for(xr: &Range<f64>, yr: &Range<f64>) -> [impl Fn(&f64) -> String + use<>; 2] {
    [axis_ticks(xr.start, xr.end), axis_ticks(yr.start, yr.end)]
}

/// Draws the phase portraits of `simulate`: rotor and stator (x, vx) and (x, y), the
/// trajectory as a line and the Poincare points as red dots.
pub fn phase_portraits(
    path: &Path,
    title: &str,
    timeseries: &[[f64; STATE_DIM + 1]],
    poincare: &[State],
) -> Result<()> {
    let panels = [
        Panel {
            title: "rotor phase portrait",
            x: X_R,
            y: VX_R,
            x_scale: 1e3,
            y_scale: 1.0,
            x_label: "x_r [mm]",
            y_label: "vx_r [m/s]",
        },
        Panel {
            title: "rotor orbit",
            x: X_R,
            y: Y_R,
            x_scale: 1e3,
            y_scale: 1e3,
            x_label: "x_r [mm]",
            y_label: "y_r [mm]",
        },
        Panel {
            title: "stator phase portrait",
            x: X_S,
            y: VX_S,
            x_scale: 1e3,
            y_scale: 1.0,
            x_label: "x_s [mm]",
            y_label: "vx_s [m/s]",
        },
        Panel {
            title: "stator orbit",
            x: X_S,
            y: Y_S,
            x_scale: 1e3,
            y_scale: 1e3,
            x_label: "x_s [mm]",
            y_label: "y_s [mm]",
        },
    ];
    figure(path, (1400, 1150), |root| {
        let root = root.titled(title, ("sans-serif", 26))?;
        for (area, pn) in root.split_evenly((2, 2)).iter().zip(panels.iter()) {
            // Row layout: timeseries rows are (t, state...), so component i is column i + 1.
            let line: Vec<(f64, f64)> = timeseries
                .iter()
                .map(|r| (r[pn.x + 1] * pn.x_scale, r[pn.y + 1] * pn.y_scale))
                .collect();
            let dots: Vec<(f64, f64)> = poincare
                .iter()
                .map(|p| (p[pn.x] * pn.x_scale, p[pn.y] * pn.y_scale))
                .collect();
            let xr = padded_range(line.iter().chain(dots.iter()).map(|p| p.0));
            let yr = padded_range(line.iter().chain(dots.iter()).map(|p| p.1));
            let [tx, ty] = ticks_for(&xr, &yr);
            let mut chart = chart(area, Some((pn.title, 20)), PORTRAIT, xr, yr)?;
            Mesh::new(pn.x_label, pn.y_label)
                .ticks(&tx, &ty)
                .draw(&mut chart)?;
            chart
                .draw_series(LineSeries::new(line, BLUE.mix(0.55).stroke_width(1)))?
                .label("trajectory")
                .legend(line_key(BLUE));
            chart
                .draw_series(dots.iter().map(|&p| Circle::new(p, 4, RED.filled())))?
                .label("Poincare points (t = kT)")
                .legend(dot_key(RED, 4));
            legend(&mut chart, SeriesLabelPosition::MiddleRight, 14)?;
        }
        Ok(())
    })
}

/// One attractor in a comparison figure: its name, a time series over a few periods
/// (rows t, state) and its Poincare points.
#[derive(Clone, Debug)]
pub struct AttractorTrace {
    /// Legend text.
    pub name: String,
    /// Colour.
    pub color: RGBColor,
    /// Rows (t, state) on the integrator grid.
    pub timeseries: Vec<[f64; STATE_DIM + 1]>,
    /// Poincare points.
    pub poincare: Vec<State>,
}

/// Draws coexisting attractors at one W on common axes: rotor and stator (x, vx) and
/// (x, y), each attractor in its colour with its Poincare points as large dots.
pub fn coexisting_attractors(path: &Path, title: &str, traces: &[AttractorTrace]) -> Result<()> {
    let panels = [
        (X_R, VX_R, "rotor phase portrait"),
        (X_R, Y_R, "rotor orbit"),
        (X_S, VX_S, "stator phase portrait"),
        (X_S, Y_S, "stator orbit"),
    ];
    figure(path, (1400, 1150), |root| {
        let root = root.titled(title, ("sans-serif", 26))?;
        for (area, &(xi, yi, name)) in root.split_evenly((2, 2)).iter().zip(panels.iter()) {
            let (xs, xl) = coord_axis(xi);
            let (ys, yl) = coord_axis(yi);
            let all = || {
                traces.iter().flat_map(|t| {
                    t.timeseries
                        .iter()
                        .map(|r| (r[xi + 1] * xs, r[yi + 1] * ys))
                        .chain(t.poincare.iter().map(|p| (p[xi] * xs, p[yi] * ys)))
                })
            };
            let xr = padded_range(all().map(|p| p.0));
            let yr = padded_range(all().map(|p| p.1));
            let [tx, ty] = ticks_for(&xr, &yr);
            let mut chart = chart(area, Some((name, 20)), PORTRAIT, xr, yr)?;
            Mesh::new(&xl, &yl).ticks(&tx, &ty).draw(&mut chart)?;
            for t in traces {
                let c = t.color;
                chart
                    .draw_series(LineSeries::new(
                        t.timeseries
                            .iter()
                            .map(|r| (r[xi + 1] * xs, r[yi + 1] * ys)),
                        c.mix(0.6).stroke_width(1),
                    ))?
                    .label(t.name.as_str())
                    .legend(dot_key(c, 5));
                chart.draw_series(
                    t.poincare
                        .iter()
                        .map(|p| Circle::new((p[xi] * xs, p[yi] * ys), 5, c.filled())),
                )?;
            }
            legend(&mut chart, SeriesLabelPosition::MiddleRight, 14)?;
        }
        Ok(())
    })
}

/// Draws Poincare sections: one panel per (x, y) component pair, every point a small dot.
/// `zoom` (a fraction in (0, 1]) shows, instead of the whole set, a window of that
/// fraction of each axis' span centred on the median point: an enlargement.
pub fn poincare_sections(
    path: &Path,
    title: &str,
    points: &[State],
    panels: &[(usize, usize)],
    zoom: Option<f64>,
) -> Result<()> {
    let cols = panels.len().clamp(1, 2);
    let rows = panels.len().div_ceil(2).max(1);
    figure(path, (700 * cols as u32, 80 + 620 * rows as u32), |root| {
        let root = root.titled(title, ("sans-serif", 24))?;
        for (area, &(xi, yi)) in root.split_evenly((rows, cols)).iter().zip(panels) {
            let (xs, xl) = coord_axis(xi);
            let (ys, yl) = coord_axis(yi);
            let pts: Vec<(f64, f64)> = points
                .iter()
                .map(|p| (p[xi] * xs, p[yi] * ys))
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect();
            let mut xr = padded_range(pts.iter().map(|p| p.0));
            let mut yr = padded_range(pts.iter().map(|p| p.1));
            if let Some(f) = zoom {
                let median = |mut v: Vec<f64>| {
                    v.sort_by(f64::total_cmp);
                    v.get(v.len() / 2).copied().unwrap_or(0.0)
                };
                let (mx, my) = (
                    median(pts.iter().map(|p| p.0).collect()),
                    median(pts.iter().map(|p| p.1).collect()),
                );
                let (hx, hy) = (0.5 * f * (xr.end - xr.start), 0.5 * f * (yr.end - yr.start));
                xr = (mx - hx)..(mx + hx);
                yr = (my - hy)..(my + hy);
            }
            let inside: Vec<(f64, f64)> = pts
                .into_iter()
                .filter(|p| xr.contains(&p.0) && yr.contains(&p.1))
                .collect();
            let [tx, ty] = ticks_for(&xr, &yr);
            let mut chart = chart(area, None, (12, 48, 85), xr, yr)?;
            Mesh::new(&xl, &yl)
                .no_light_lines()
                .ticks(&tx, &ty)
                .draw(&mut chart)?;
            let r = if inside.len() > 5000 { 1 } else { 2 };
            chart.draw_series(
                inside
                    .iter()
                    .map(|&p| Circle::new(p, r, RGBColor(20, 60, 160).filled())),
            )?;
        }
        Ok(())
    })
}
