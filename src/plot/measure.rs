//! Measure and uncertainty plots: stacked basin fractions, the uncertain fraction
//! f(eps) on log-log axes, and work-precision diagrams.

use super::frame::{Area, Chart, Drawn, Mesh, chart, dot_key, extent, figure, line_key};
use super::{PALETTE, legend};
use jeffcott_core::error::Result;
use plotters::prelude::*;
use std::path::Path;

/// One panel of [`stacked_fractions`]: a title and, per band, its legend text, colour and
/// value at each x (bands stacked bottom-up in the order given).
pub struct StackedPanel {
    /// Panel caption.
    pub title: String,
    /// (legend, colour, values at each x).
    pub bands: Vec<(String, RGBColor, Vec<f64>)>,
}

/// Stacked-area chart of fractions (0..1) against `x`, one panel per entry, stacked
/// vertically: which attractor's basin dominates where.
pub fn stacked_fractions(
    path: &Path,
    title: &str,
    x_label: &str,
    x: &[f64],
    panels: &[StackedPanel],
) -> Result<()> {
    let h = 140 + 430 * panels.len().max(1) as u32;
    let (x0, x1) = (x[0], x[x.len() - 1].max(x[0] + 1e-12));
    figure(path, (1300, h), |root| {
        let root = root.titled(title, ("sans-serif", 24))?;
        let areas = root.split_evenly((panels.len().max(1), 1));
        for (area, panel) in areas.iter().zip(panels) {
            let caption = Some((panel.title.as_str(), 19));
            let mut chart = chart(area, caption, (12, 46, 70), x0..x1, 0.0..1.0)?;
            Mesh::new(x_label, "basin fraction").draw(&mut chart)?;
            let mut lower = vec![0.0; x.len()];
            for (name, colour, values) in &panel.bands {
                let upper: Vec<f64> = lower.iter().zip(values).map(|(l, v)| l + v).collect();
                let outline: Vec<(f64, f64)> = x
                    .iter()
                    .zip(&upper)
                    .map(|(&a, &b)| (a, b))
                    .chain(x.iter().zip(&lower).rev().map(|(&a, &b)| (a, b)))
                    .collect();
                let c = *colour;
                chart
                    .draw_series(std::iter::once(Polygon::new(outline, c.mix(0.85).filled())))?
                    .label(name.as_str())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 6), (x + 16, y + 6)], c.filled())
                    });
                lower = upper;
            }
            legend(&mut chart, SeriesLabelPosition::UpperRight, 14)?;
        }
        Ok(())
    })
}

/// A captioned chart on log-log axes over `x` and `y`, axes labelled `desc` (x, y) and
/// ticks in 1e-n notation: the frame of the uncertainty and work-precision plots.
fn log_log_chart<'a, 'b>(
    root: &'a Area<'b>,
    title: &str,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    desc: (&str, &str),
) -> Drawn<Chart<'a, 'b, LogCoord<f64>, LogCoord<f64>>> {
    let mut chart = chart(
        root,
        Some((title, 20)),
        (14, 50, 80),
        x.log_scale(),
        y.log_scale(),
    )?;
    Mesh::new(desc.0, desc.1)
        .ticks(&|v| format!("{v:.0e}"), &|v| format!("{v:.0e}"))
        .draw(&mut chart)?;
    Ok(chart)
}

/// The x and y extents of the points with both coordinates positive (those a log-log
/// chart can show), each starting from its `start` range.
fn positive_extents<'a>(
    points: impl Iterator<Item = &'a (f64, f64)>,
    x_start: (f64, f64),
    y_start: (f64, f64),
) -> ((f64, f64), (f64, f64)) {
    let pts: Vec<(f64, f64)> = points.copied().filter(|p| p.0 > 0.0 && p.1 > 0.0).collect();
    (
        extent(pts.iter().map(|p| p.0), x_start),
        extent(pts.iter().map(|p| p.1), y_start),
    )
}

/// The uncertain fraction f(eps) against eps (a fraction of the box side), log-log: the
/// grid estimate and the re-integration estimate as points, each with its fitted slope
/// drawn through the mean of its fitted points (where a least-squares line passes).
pub fn uncertainty(
    path: &Path,
    title: &str,
    grid: &[(f64, f64)],
    grid_alpha: Option<f64>,
    reint: &[(f64, f64)],
    reint_alpha: Option<f64>,
) -> Result<()> {
    let ((x0, x1), (y0, y1)) = positive_extents(grid.iter().chain(reint), (1e-7, 1.0), (1e-4, 1.0));
    figure(path, (1100, 800), |root| {
        let mut chart = log_log_chart(
            root,
            title,
            x0 * 0.5..x1 * 2.0,
            y0 * 0.5..y1 * 2.0,
            (
                "eps (fraction of the box side)",
                "uncertain fraction f(eps)",
            ),
        )?;
        for (k, (pts, alpha, name)) in [
            (grid, grid_alpha, "labelled grid"),
            (reint, reint_alpha, "re-integration (Grebogi et al. 1983)"),
        ]
        .into_iter()
        .enumerate()
        {
            let c = PALETTE[k];
            let used: Vec<(f64, f64)> = pts.iter().copied().filter(|p| p.1 > 0.0).collect();
            if used.is_empty() {
                continue;
            }
            let label = match alpha {
                Some(a) => format!("{name}: alpha = {a:.3}"),
                None => format!("{name}: not fitted"),
            };
            chart
                .draw_series(used.iter().map(|&p| Circle::new(p, 5, c.filled())))?
                .label(label)
                .legend(dot_key(c, 5));
            if let Some(a) = alpha {
                let n = used.len() as f64;
                let mx = used.iter().map(|p| p.0.ln()).sum::<f64>() / n;
                let my = used.iter().map(|p| p.1.ln()).sum::<f64>() / n;
                let (lo, hi) = extent(used.iter().map(|p| p.0), (f64::INFINITY, 0.0));
                let line = [lo, hi].map(|x| (x, (my + a * (x.ln() - mx)).exp()));
                chart.draw_series(std::iter::once(PathElement::new(
                    line.to_vec(),
                    c.stroke_width(2),
                )))?;
            }
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight, 15)?;
        Ok(())
    })
}

/// One series of a work-precision diagram: legend, colour, dashed, and its points of
/// (lane-periods per second, error [m]).
pub type WorkPrecisionSeries = (String, RGBColor, bool, Vec<(f64, f64)>);

/// A work-precision diagram (SciML style): a line through each series' points, log-log,
/// with a horizontal line at `target` [m].
pub fn work_precision(
    path: &Path,
    title: &str,
    series: &[WorkPrecisionSeries],
    target: f64,
) -> Result<()> {
    let ((x0, x1), (y0, y1)) = positive_extents(
        series.iter().flat_map(|s| s.3.iter()),
        (f64::INFINITY, 0.0),
        (target, target),
    );
    // The axes' ranges, padded; the target line spans the x range.
    let (xs, ys) = (x0 * 0.7..x1 * 1.4, y0 * 0.3..y1 * 3.0);
    let target_line = vec![(xs.start, target), (xs.end, target)];
    figure(path, (1200, 850), |root| {
        let mut chart = log_log_chart(
            root,
            title,
            xs.clone(),
            ys.clone(),
            (
                "throughput [lane-periods per second] (higher is better)",
                "position error after 200 periods [m] (lower is better)",
            ),
        )?;
        chart.draw_series(std::iter::once(PathElement::new(
            target_line.clone(),
            RGBColor(150, 150, 150).stroke_width(1),
        )))?;
        for (name, c, dashed, p) in series {
            let c = *c;
            let style = if *dashed {
                c.mix(0.6).stroke_width(2)
            } else {
                c.stroke_width(3)
            };
            chart
                .draw_series(LineSeries::new(p.iter().copied(), style))?
                .label(name.as_str())
                .legend(line_key(c));
            chart.draw_series(p.iter().map(|&q| Circle::new(q, 4, c.filled())))?;
        }
        legend(&mut chart, SeriesLabelPosition::LowerLeft, 15)?;
        Ok(())
    })
}
