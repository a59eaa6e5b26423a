//! Branches of periodic orbits against the continued parameter: stable stretches solid,
//! unstable ones dashed, bifurcations marked, optionally over a brute-force diagram's
//! Poincare points.

use super::frame::{Mesh, chart, dot_key, figure, line_key};
use super::{PALETTE, coord_axis, legend, padded_range};
use jeffcott_core::error::Result;
use plotters::prelude::*;
use std::path::Path;

/// One branch as drawn: per point the parameter's value, the coordinate's values at
/// each of the orbit's n Poincare points, and whether it is stable.
#[derive(Clone, Debug)]
pub struct BranchLine {
    /// Legend text.
    pub label: String,
    /// (value, coordinate at each of the orbit's Poincare points, stable).
    pub points: Vec<(f64, Vec<f64>, bool)>,
}

/// A marked bifurcation: (value, coordinate, text of the legend entry of its kind).
#[derive(Clone, Debug)]
pub struct Mark {
    /// The parameter's value.
    pub value: f64,
    /// The coordinate there.
    pub y: f64,
    /// The kind (legend text).
    pub kind: String,
}

/// What a branch picture is drawn over: a bifurcation diagram's Poincare points
/// (parameter value, coordinate), the brute force's and each quasistatic sweep's.
#[derive(Clone, Debug, Default)]
pub struct Backdrop {
    /// The brute force's points (grey).
    pub brute: Vec<(f64, f64)>,
    /// The up sweep's (light blue).
    pub up: Vec<(f64, f64)>,
    /// The down sweep's (light red).
    pub down: Vec<(f64, f64)>,
}

/// Draws `branches` (coordinate `coord` against the parameter `x_desc`), their `marks`,
/// over `background` (dots: a brute force's and the sweeps' Poincare points).
pub fn branches(
    path: &Path,
    title: &str,
    x_desc: &str,
    coord: usize,
    branches: &[BranchLine],
    marks: &[Mark],
    background: &Backdrop,
) -> Result<()> {
    let all = || {
        background
            .brute
            .iter()
            .chain(&background.up)
            .chain(&background.down)
    };
    let (s, y_desc) = coord_axis(coord);
    let scaled = scaled_lines(branches, s);
    let branches = &scaled;
    figure(path, (1600, 900), |root| {
        let xr = padded_range(
            branches
                .iter()
                .flat_map(|b| b.points.iter().map(|p| p.0))
                .chain(all().map(|p| p.0)),
        );
        let yr = padded_range(
            branches
                .iter()
                .flat_map(|b| b.points.iter().flat_map(|p| p.1.iter().copied()))
                .chain(all().filter(|p| p.1.is_finite()).map(|p| p.1 * s)),
        );
        let mut chart = chart(root, Some((title, 24)), (14, 50, 100), xr, yr)?;
        Mesh::new(x_desc, &y_desc)
            .no_light_lines()
            .draw(&mut chart)?;
        let layers = [
            (
                &background.brute,
                RGBColor(170, 170, 170),
                "brute force (Poincare points)",
            ),
            (&background.up, RGBColor(120, 160, 230), "up sweep"),
            (&background.down, RGBColor(235, 140, 140), "down sweep"),
        ];
        for (points, colour, label) in layers {
            if points.is_empty() {
                continue;
            }
            chart
                .draw_series(
                    points
                        .iter()
                        .filter(|p| p.1.is_finite())
                        .map(|p| Circle::new((p.0, p.1 * s), 1, colour.filled())),
                )?
                .label(label)
                .legend(dot_key(colour, 3));
        }
        for (k, b) in branches.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            let style = c.stroke_width(3);
            let mut labelled = false;
            for (run, stable) in stretches(b) {
                let anno = if stable {
                    chart.draw_series(LineSeries::new(run, style))?
                } else {
                    chart.draw_series(DashedLineSeries::new(run, 10, 6, style))?
                };
                if !labelled {
                    anno.label(b.label.as_str()).legend(line_key(c));
                    labelled = true;
                }
            }
        }
        for (i, kind) in mark_kinds(marks).iter().enumerate() {
            let c = PALETTE[(i + 5) % PALETTE.len()];
            chart
                .draw_series(
                    marks
                        .iter()
                        .filter(|m| m.kind == *kind)
                        .map(|m| Circle::new((m.value, m.y * s), 7, c.filled())),
                )?
                .label(*kind)
                .legend(dot_key(c, 6));
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft, 16)?;
        Ok(())
    })
}

/// `branches` with every coordinate value multiplied by `s` (the axis' unit).
fn scaled_lines(branches: &[BranchLine], s: f64) -> Vec<BranchLine> {
    branches
        .iter()
        .map(|b| BranchLine {
            label: b.label.clone(),
            points: b
                .points
                .iter()
                .map(|p| (p.0, p.1.iter().map(|v| v * s).collect(), p.2))
                .collect(),
        })
        .collect()
}

/// The kinds of `marks`, each once, sorted (one legend entry and colour each).
fn mark_kinds(marks: &[Mark]) -> Vec<&str> {
    let mut k: Vec<&str> = marks.iter().map(|m| m.kind.as_str()).collect();
    k.sort_unstable();
    k.dedup();
    k
}

/// The curves of a branch: each of the orbit's Poincare points traces one, cut where
/// the stability changes (the stretches share the point where they meet); each with
/// whether it is stable.
fn stretches(b: &BranchLine) -> Vec<(Vec<(f64, f64)>, bool)> {
    let n = b.points.iter().map(|p| p.1.len()).max().unwrap_or(0);
    let mut out = Vec::new();
    for j in 0..n {
        let mut run: Vec<(f64, f64)> = Vec::new();
        let mut stable = None;
        for p in &b.points {
            let Some(&y) = p.1.get(j) else { continue };
            if let Some(st) = stable
                && st != p.2
            {
                let last = run.last().copied();
                out.push((std::mem::take(&mut run), st));
                run.extend(last);
            }
            stable = Some(p.2);
            run.push((p.0, y));
        }
        if let Some(st) = stable {
            out.push((run, st));
        }
    }
    out.retain(|(run, _)| run.len() >= 2);
    out
}
