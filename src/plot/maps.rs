//! Maps over a grid of start states or parameters: basins of attraction, category
//! maps with a legend, and lambda_1 maps with a diverging colour bar.

use super::attractor_color;
use super::frame::{Area, Drawn, Mesh, axis_ticks, chart, extent, figure};
use jeffcott_core::error::Result;
use plotters::prelude::*;
use std::path::Path;

/// Draws a basin of attraction: `labels` is [ny, nx] (row 0 at the grid's lowest y),
/// each cell coloured by its attractor id (black: diverged); `legend` names the ids.
pub fn basin_map(
    path: &Path,
    title: &str,
    labels: &[i32],
    grid: &MapGrid,
    legend: &[(i32, String)],
) -> Result<()> {
    category_map(path, title, labels, grid, legend, &attractor_color)
}

/// Draws a map of categories: `labels` is [ny, nx] (row 0 at the grid's lowest y), each
/// cell in `colour(label)`; `legend` names the labels shown in the side panel.
pub fn category_map(
    path: &Path,
    title: &str,
    labels: &[i32],
    grid: &MapGrid,
    legend: &[(i32, String)],
    colour: &dyn Fn(i32) -> RGBColor,
) -> Result<()> {
    grid_map(path, title, grid, &|i| colour(labels[i]), &|side| {
        for (k, (id, name)) in legend.iter().enumerate() {
            let y = 80 + 36 * k as i32;
            side.draw(&Rectangle::new(
                [(10, y), (34, y + 24)],
                colour(*id).filled(),
            ))?;
            side.draw(&Text::new(
                name.clone(),
                (42, y + 3),
                ("sans-serif", 17).into_font(),
            ))?;
        }
        Ok(())
    })
}

/// A map's grid: [nx, ny] cells (row 0 at y = y_range.0), the plotted ranges of the two
/// axes and their labels.
pub struct MapGrid {
    /// Cells along x and along y.
    pub cells: (usize, usize),
    /// Plotted range of x.
    pub x_range: (f64, f64),
    /// Plotted range of y.
    pub y_range: (f64, f64),
    /// Axis labels (x, y).
    pub axes: (String, String),
}

/// The side panel of a grid map (legend or colour bar), drawn by the caller.
type SidePanel<'a> = dyn Fn(&Area<'_>) -> Drawn + 'a;

/// Draws a grid map: each cell (index iy * nx + ix) in `colour(index)`, scaled to the
/// plotting area pixel by pixel, axes labelled, and a side panel to the right.
fn grid_map(
    path: &Path,
    title: &str,
    grid: &MapGrid,
    colour: &dyn Fn(usize) -> RGBColor,
    side: &SidePanel,
) -> Result<()> {
    let (nx, ny) = grid.cells;
    let (x_range, y_range) = (grid.x_range, grid.y_range);
    figure(path, (1300, 1100), |root| {
        let root = root.titled(title, ("sans-serif", 24))?;
        let (plot_area, side_area) = root.split_horizontally(1000);
        let mut chart = chart(
            &plot_area,
            None,
            (14, 50, 90),
            x_range.0..x_range.1,
            y_range.0..y_range.1,
        )?;
        let x_ticks = axis_ticks(x_range.0, x_range.1);
        let y_ticks = axis_ticks(y_range.0, y_range.1);
        Mesh::new(&grid.axes.0, &grid.axes.1)
            .no_grid()
            .fonts(16, 19)
            .ticks(&x_ticks, &y_ticks)
            .draw(&mut chart)?;
        let (pw, ph) = chart.plotting_area().dim_in_pixel();
        let mut buf = vec![0u8; (pw * ph * 3) as usize];
        for py in 0..ph as usize {
            // Pixel row 0 is the top, i.e. the largest y.
            let iy = ((ph as usize - 1 - py) * ny / ph as usize).min(ny - 1);
            for px in 0..pw as usize {
                let ix = (px * nx / pw as usize).min(nx - 1);
                let c = colour(iy * nx + ix);
                let o = (py * pw as usize + px) * 3;
                buf[o..o + 3].copy_from_slice(&[c.0, c.1, c.2]);
            }
        }
        let img = BitMapElement::with_owned_buffer((x_range.0, y_range.1), (pw, ph), buf)
            .ok_or("bitmap buffer size")?;
        chart.draw_series(std::iter::once(img))?;
        side(&side_area)?;
        Ok(())
    })
}

/// Colour of lambda_1 `v` on a diverging scale: blue for negative (full at `lo`), white at
/// 0, red for positive (full at `hi`); black for NaN (diverged lanes).
pub fn lambda1_color(v: f64, lo: f64, hi: f64) -> RGBColor {
    if !v.is_finite() {
        return BLACK;
    }
    let mix = |a: (f64, f64, f64), t: f64| {
        let t = t.clamp(0.0, 1.0);
        let c = |x: f64| (255.0 + (x - 255.0) * t).round() as u8;
        RGBColor(c(a.0), c(a.1), c(a.2))
    };
    if v < 0.0 {
        mix((33.0, 102.0, 172.0), if lo < 0.0 { v / lo } else { 1.0 })
    } else {
        mix((178.0, 24.0, 43.0), if hi > 0.0 { v / hi } else { 0.0 })
    }
}

/// Draws a map of the largest Lyapunov exponent per start state: `values` is [ny, nx]
/// (row 0 at the grid's lowest y) in 1/s, on the diverging scale of [`lambda1_color`] with a
/// colour bar; NaN cells (diverged) black.
pub fn lambda1_map(path: &Path, title: &str, values: &[f64], grid: &MapGrid) -> Result<()> {
    let (lo, hi) = extent(values.iter().copied().filter(|v| v.is_finite()), (0.0, 0.0));
    grid_map(
        path,
        title,
        grid,
        &|i| lambda1_color(values[i], lo, hi),
        &|bar_area| {
            // Colour bar: hi at the top, lo at the bottom.
            let (top, bot) = (80i32, 880i32);
            for y in top..bot {
                let v = hi + (lo - hi) * (y - top) as f64 / (bot - top) as f64;
                bar_area.draw(&Rectangle::new(
                    [(20, y), (60, y + 1)],
                    lambda1_color(v, lo, hi).filled(),
                ))?;
            }
            bar_area.draw(&Rectangle::new([(20, top), (60, bot)], BLACK))?;
            let zero_y = if hi > lo {
                top + ((hi / (hi - lo)) * (bot - top) as f64).round() as i32
            } else {
                top
            };
            for (y, text) in [
                (top, format!("{hi:.2}")),
                (zero_y, "0".to_string()),
                (bot, format!("{lo:.2}")),
            ] {
                bar_area.draw(&Text::new(
                    text,
                    (68, y - 8),
                    ("sans-serif", 17).into_font(),
                ))?;
            }
            bar_area.draw(&Text::new(
                "lambda_1 [1/s]",
                (10, top - 40),
                ("sans-serif", 18).into_font(),
            ))?;
            bar_area.draw(&Text::new(
                "black: diverged",
                (10, bot + 30),
                ("sans-serif", 16).into_font(),
            ))?;
            Ok(())
        },
    )
}
