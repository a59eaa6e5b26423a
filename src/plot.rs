//! Pictures (plotters, bitmap backend, the bundled DejaVu Sans font so no system font
//! library is needed).

use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{STATE_DIM, State, VX_R, VX_S, X_R, X_S, Y_R, Y_S};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

pub mod lyapunov;
pub mod rub;

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is compiled in; failure would be a build defect caught by the tests.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Draws a chart's series legend in the house style (white box, black border).
pub(crate) fn legend<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
    font: u32,
) -> std::result::Result<(), String>
where
    DB: DrawingBackend + 'a,
    CT: plotters::coord::CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", font))
        .draw()
        .map_err(|e| e.to_string())
}

/// Draws a `size` picture in memory with `draw` and writes it as PNG through a
/// temporary renamed into place ([`jeffcott_analysis::output::write_png`]), so a picture under its
/// final name is always whole and an I/O error names the file.
pub(crate) fn render_png(
    path: &Path,
    size: (u32, u32),
    draw: impl for<'b> FnOnce(DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>) -> Result<()>,
) -> Result<()> {
    let mut buf = vec![0u8; size.0 as usize * size.1 as usize * 3];
    draw(BitMapBackend::with_buffer(&mut buf, size).into_drawing_area())?;
    jeffcott_analysis::output::write_png(path, size, &buf)
}

fn plot_err(path: &Path) -> impl Fn(String) -> Error + '_ {
    move |message| Error::Plot {
        path: path.to_path_buf(),
        message,
    }
}

/// Range of values padded by 5 % (and widened if degenerate).
fn padded_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return -1.0..1.0;
    }
    let span = (hi - lo).max(1e-12 * lo.abs().max(hi.abs())).max(1e-15);
    (lo - 0.05 * span)..(hi + 0.05 * span)
}

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

/// Draws the phase portraits of `simulate`: rotor and stator (x, vx) and (x, y), the
/// trajectory as a line and the Poincare points as red dots.
pub fn phase_portraits(
    path: &Path,
    title: &str,
    timeseries: &[[f64; STATE_DIM + 1]],
    poincare: &[State],
) -> Result<()> {
    register_font();
    let err = plot_err(path);
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
    crate::plot::render_png(path, (1400, 1150), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 26))
            .map_err(|e| err(e.to_string()))?;
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
            let mut chart = ChartBuilder::on(area)
                .caption(pn.title, ("sans-serif", 20))
                .margin(12)
                .x_label_area_size(48)
                .y_label_area_size(80)
                .build_cartesian_2d(xr, yr)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_desc(pn.x_label)
                .y_desc(pn.y_label)
                .label_style(("sans-serif", 15))
                .axis_desc_style(("sans-serif", 17))
                .x_label_formatter(&|v| format!("{v:.3}"))
                .y_label_formatter(&|v| format!("{v:.3}"))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            chart
                .draw_series(LineSeries::new(line, BLUE.mix(0.55).stroke_width(1)))
                .map_err(|e| err(e.to_string()))?
                .label("trajectory")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLUE));
            chart
                .draw_series(dots.iter().map(|&p| Circle::new(p, 4, RED.filled())))
                .map_err(|e| err(e.to_string()))?
                .label("Poincare points (t = kT)")
                .legend(|(x, y)| Circle::new((x + 9, y), 4, RED.filled()));
            legend(&mut chart, SeriesLabelPosition::MiddleRight, 14).map_err(&err)?;
        }
        root.present().map_err(|e| err(e.to_string()))
    })
}

/// A palette of distinguishable colours for attractor ids (cycled beyond its length).
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(127, 127, 127),
];

/// The colour of attractor `id` (black for -1, diverged).
pub fn attractor_color(id: i32) -> RGBColor {
    if id < 0 {
        BLACK
    } else {
        PALETTE[id as usize % PALETTE.len()]
    }
}

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

/// Value of component `i` in plot units (positions in mm, velocities in m/s) and the
/// axis label with its unit.
pub fn coord_axis(i: usize) -> (f64, String) {
    let name = jeffcott_core::model::COORD_NAMES[i];
    if i.is_multiple_of(2) {
        (1e3, format!("{name} [mm]"))
    } else {
        (1.0, format!("{name} [m/s]"))
    }
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
    register_font();
    let err = plot_err(path);
    let l1 = lambda1
        .iter()
        .any(|s| s.points.iter().any(|p| p.1.is_finite()));
    let l1_h = if l1 { 380 } else { 0 };
    let h = 120 + 620 * coords.len().max(1) as u32 + l1_h;
    crate::plot::render_png(path, (1800, h), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 26))
            .map_err(|e| err(e.to_string()))?;
        let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 - l1_h);
        let pad = 0.005 * (w_range.1 - w_range.0).max(1e-9);
        if l1 {
            lambda1_panel(&bottom, w_range, pad, lambda1).map_err(|e| err(e.to_string()))?;
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
            let mut chart = ChartBuilder::on(area)
                .margin(14)
                .x_label_area_size(50)
                .y_label_area_size(90)
                .build_cartesian_2d((w_range.0 - pad)..(w_range.1 + pad), yr)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .light_line_style(WHITE)
                .x_desc("W [rad/s]")
                .y_desc(label.as_str())
                .label_style(("sans-serif", 16))
                .axis_desc_style(("sans-serif", 19))
                .x_label_formatter(&|v| format!("{v:.2}"))
                .y_label_formatter(&|v| format!("{v:.4}"))
                .draw()
                .map_err(|e| err(e.to_string()))?;
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
                }
                .map_err(|e| err(e.to_string()))?;
                anno.label(se.label.as_str())
                    .legend(move |(x, y)| Circle::new((x + 9, y), 4, c.filled()));
            }
            legend(&mut chart, SeriesLabelPosition::UpperLeft, 16).map_err(&err)?;
        }
        root.present().map_err(|e| err(e.to_string()))
    })
}

/// The lambda_1 panel of [`bifurcation_diagram`].
fn lambda1_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    w_range: (f64, f64),
    pad: f64,
    series: &[Lambda1Series],
) -> std::result::Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    let yr = padded_range(
        series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1))
            .chain([0.0]),
    );
    let x = (w_range.0 - pad)..(w_range.1 + pad);
    let mut chart = ChartBuilder::on(area)
        .margin(14)
        .x_label_area_size(50)
        .y_label_area_size(90)
        .build_cartesian_2d(x.clone(), yr)
        .map_err(e)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc("W [rad/s]")
        .y_desc("lambda_1 [1/s]")
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 19))
        .x_label_formatter(&|v| format!("{v:.2}"))
        .y_label_formatter(&|v| format!("{v:.1}"))
        .draw()
        .map_err(e)?;
    chart
        .draw_series(LineSeries::new(
            [(x.start, 0.0), (x.end, 0.0)],
            BLACK.stroke_width(1),
        ))
        .map_err(e)?
        .label("lambda_1 = 0")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
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
                    chart
                        .draw_series(LineSeries::new(
                            std::mem::take(&mut run),
                            c.mix(0.7).stroke_width(1),
                        ))
                        .map_err(e)?;
                }
            }
            if !run.is_empty() {
                chart
                    .draw_series(LineSeries::new(run, c.mix(0.7).stroke_width(1)))
                    .map_err(e)?;
            }
        }
        let anno = if s.radius == 0 {
            chart.draw_series(pts.iter().map(|&p| Pixel::new(p, c)))
        } else {
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, s.radius, c.filled())))
        }
        .map_err(e)?;
        anno.label(s.label.as_str())
            .legend(move |(x, y)| Circle::new((x + 9, y), 4, c.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft, 16)?;
    Ok(())
}

/// Draws a basin of attraction: `labels` is [ny, nx] (row 0 at y = y_range.0), each cell
/// coloured by its attractor id (black: diverged); `legend` names the ids.
#[allow(clippy::too_many_arguments)]
pub fn basin_map(
    path: &Path,
    title: &str,
    labels: &[i32],
    cells: (usize, usize),
    x_range: (f64, f64),
    y_range: (f64, f64),
    axes: (&str, &str),
    legend: &[(i32, String)],
) -> Result<()> {
    category_map(
        path,
        title,
        labels,
        cells,
        (x_range, y_range),
        axes,
        legend,
        &attractor_color,
    )
}

/// Draws a map of categories: `labels` is [ny, nx] (row 0 at y = ranges.1 .0), each cell
/// in `colour(label)`; `legend` names the labels shown in the side panel.
#[allow(clippy::too_many_arguments)]
pub fn category_map(
    path: &Path,
    title: &str,
    labels: &[i32],
    cells: (usize, usize),
    ranges: ((f64, f64), (f64, f64)),
    axes: (&str, &str),
    legend: &[(i32, String)],
    colour: &dyn Fn(i32) -> RGBColor,
) -> Result<()> {
    let grid = Grid {
        cells,
        x_range: ranges.0,
        y_range: ranges.1,
        axes,
    };
    grid_map(path, title, &grid, &|i| colour(labels[i]), &|side| {
        for (k, (id, name)) in legend.iter().enumerate() {
            let y = 80 + 36 * k as i32;
            side.draw(&Rectangle::new(
                [(10, y), (34, y + 24)],
                colour(*id).filled(),
            ))
            .map_err(|e| e.to_string())?;
            side.draw(&Text::new(
                name.clone(),
                (42, y + 3),
                ("sans-serif", 17).into_font(),
            ))
            .map_err(|e| e.to_string())?;
        }
        Ok(())
    })
}

/// A map over a grid of start states: [ny, nx] cells (row 0 at y = y_range.0), the
/// ranges of the two start coordinates and their axis labels.
struct Grid<'a> {
    cells: (usize, usize),
    x_range: (f64, f64),
    y_range: (f64, f64),
    axes: (&'a str, &'a str),
}

/// The side panel of a grid map (legend or colour bar), drawn by the caller.
type SidePanel<'a> = dyn Fn(&DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> std::result::Result<(), String>
    + 'a;

/// Draws a grid map: each cell (index iy * nx + ix) in `colour(index)`, scaled to the
/// plotting area pixel by pixel, axes labelled, and a side panel to the right.
fn grid_map(
    path: &Path,
    title: &str,
    grid: &Grid,
    colour: &dyn Fn(usize) -> RGBColor,
    side: &SidePanel,
) -> Result<()> {
    register_font();
    let err = plot_err(path);
    let (nx, ny) = grid.cells;
    let (x_range, y_range) = (grid.x_range, grid.y_range);
    crate::plot::render_png(path, (1300, 1100), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 24))
            .map_err(|e| err(e.to_string()))?;
        let (plot_area, side_area) = root.split_horizontally(1000);
        let mut chart = ChartBuilder::on(&plot_area)
            .margin(14)
            .x_label_area_size(50)
            .y_label_area_size(90)
            .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(grid.axes.0)
            .y_desc(grid.axes.1)
            .label_style(("sans-serif", 16))
            .axis_desc_style(("sans-serif", 19))
            .x_label_formatter(&|v| format!("{v:.4}"))
            .y_label_formatter(&|v| format!("{v:.4}"))
            .draw()
            .map_err(|e| err(e.to_string()))?;
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
            .ok_or_else(|| err("bitmap buffer size".into()))?;
        chart
            .draw_series(std::iter::once(img))
            .map_err(|e| err(e.to_string()))?;
        side(&side_area).map_err(&err)?;
        root.present().map_err(|e| err(e.to_string()))
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
/// (row 0 at y = y_range.0) in 1/s, on the diverging scale of [`lambda1_color`] with a
/// colour bar; NaN cells (diverged) black.
#[allow(clippy::too_many_arguments)]
pub fn lambda1_map(
    path: &Path,
    title: &str,
    values: &[f64],
    cells: (usize, usize),
    x_range: (f64, f64),
    y_range: (f64, f64),
    axes: (&str, &str),
) -> Result<()> {
    let (lo, hi) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0f64, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
    let grid = Grid {
        cells,
        x_range,
        y_range,
        axes,
    };
    grid_map(
        path,
        title,
        &grid,
        &|i| lambda1_color(values[i], lo, hi),
        &|bar_area| {
            let e = |e: DrawingAreaErrorKind<_>| e.to_string();
            // Colour bar: hi at the top, lo at the bottom.
            let (top, bot) = (80i32, 880i32);
            for y in top..bot {
                let v = hi + (lo - hi) * (y - top) as f64 / (bot - top) as f64;
                bar_area
                    .draw(&Rectangle::new(
                        [(20, y), (60, y + 1)],
                        lambda1_color(v, lo, hi).filled(),
                    ))
                    .map_err(e)?;
            }
            bar_area
                .draw(&Rectangle::new([(20, top), (60, bot)], BLACK))
                .map_err(e)?;
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
                bar_area
                    .draw(&Text::new(
                        text,
                        (68, y - 8),
                        ("sans-serif", 17).into_font(),
                    ))
                    .map_err(e)?;
            }
            bar_area
                .draw(&Text::new(
                    "lambda_1 [1/s]",
                    (10, top - 40),
                    ("sans-serif", 18).into_font(),
                ))
                .map_err(e)?;
            bar_area
                .draw(&Text::new(
                    "black: diverged",
                    (10, bot + 30),
                    ("sans-serif", 16).into_font(),
                ))
                .map_err(e)?;
            Ok(())
        },
    )
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
    register_font();
    let err = plot_err(path);
    let panels = [
        (X_R, VX_R, "rotor phase portrait"),
        (X_R, Y_R, "rotor orbit"),
        (X_S, VX_S, "stator phase portrait"),
        (X_S, Y_S, "stator orbit"),
    ];
    crate::plot::render_png(path, (1400, 1150), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 26))
            .map_err(|e| err(e.to_string()))?;
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
            let mut chart = ChartBuilder::on(area)
                .caption(name, ("sans-serif", 20))
                .margin(12)
                .x_label_area_size(48)
                .y_label_area_size(80)
                .build_cartesian_2d(
                    padded_range(all().map(|p| p.0)),
                    padded_range(all().map(|p| p.1)),
                )
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_desc(xl.as_str())
                .y_desc(yl.as_str())
                .label_style(("sans-serif", 15))
                .axis_desc_style(("sans-serif", 17))
                .x_label_formatter(&|v| format!("{v:.3}"))
                .y_label_formatter(&|v| format!("{v:.3}"))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            for t in traces {
                let c = t.color;
                chart
                    .draw_series(LineSeries::new(
                        t.timeseries
                            .iter()
                            .map(|r| (r[xi + 1] * xs, r[yi + 1] * ys)),
                        c.mix(0.6).stroke_width(1),
                    ))
                    .map_err(|e| err(e.to_string()))?
                    .label(t.name.as_str())
                    .legend(move |(x, y)| Circle::new((x + 9, y), 5, c.filled()));
                chart
                    .draw_series(
                        t.poincare
                            .iter()
                            .map(|p| Circle::new((p[xi] * xs, p[yi] * ys), 5, c.filled())),
                    )
                    .map_err(|e| err(e.to_string()))?;
            }
            legend(&mut chart, SeriesLabelPosition::MiddleRight, 14).map_err(&err)?;
        }
        root.present().map_err(|e| err(e.to_string()))
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
    register_font();
    let err = plot_err(path);
    let cols = panels.len().clamp(1, 2);
    let rows = panels.len().div_ceil(2).max(1);
    crate::plot::render_png(path, (700 * cols as u32, 80 + 620 * rows as u32), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 24))
            .map_err(|e| err(e.to_string()))?;
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
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(48)
                .y_label_area_size(85)
                .build_cartesian_2d(xr, yr)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_desc(xl.as_str())
                .y_desc(yl.as_str())
                .label_style(("sans-serif", 15))
                .axis_desc_style(("sans-serif", 17))
                .light_line_style(WHITE)
                .x_label_formatter(&|v| format!("{v:.4}"))
                .y_label_formatter(&|v| format!("{v:.4}"))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            let r = if inside.len() > 5000 { 1 } else { 2 };
            chart
                .draw_series(
                    inside
                        .iter()
                        .map(|&p| Circle::new(p, r, RGBColor(20, 60, 160).filled())),
                )
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))
    })
}

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
    register_font();
    let err = plot_err(path);
    let h = 140 + 430 * panels.len().max(1) as u32;
    let (x0, x1) = (x[0], x[x.len() - 1].max(x[0] + 1e-12));
    crate::plot::render_png(path, (1300, h), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 24))
            .map_err(|e| err(e.to_string()))?;
        let areas = root.split_evenly((panels.len().max(1), 1));
        for (area, panel) in areas.iter().zip(panels) {
            let mut chart = ChartBuilder::on(area)
                .caption(panel.title.as_str(), ("sans-serif", 19))
                .margin(12)
                .x_label_area_size(46)
                .y_label_area_size(70)
                .build_cartesian_2d(x0..x1, 0.0..1.0)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc("basin fraction")
                .label_style(("sans-serif", 15))
                .axis_desc_style(("sans-serif", 17))
                .draw()
                .map_err(|e| err(e.to_string()))?;
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
                    .draw_series(std::iter::once(Polygon::new(outline, c.mix(0.85).filled())))
                    .map_err(|e| err(e.to_string()))?
                    .label(name.as_str())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 6), (x + 16, y + 6)], c.filled())
                    });
                lower = upper;
            }
            legend(&mut chart, SeriesLabelPosition::UpperRight, 14).map_err(&err)?;
        }
        root.present().map_err(|e| err(e.to_string()))
    })
}

/// The uncertain fraction f(eps) against eps (a fraction of the box side), log-log: the
/// grid estimate and the re-integration estimate as points, each with its fitted slope
/// Log-log axes over f64.
type LogLog = Cartesian2d<LogCoord<f64>, LogCoord<f64>>;

/// A white canvas with a captioned chart on log-log axes over `x` and `y`, axes labelled
/// `desc` (x, y) and ticks in 1e-n notation: the frame of the uncertainty and
/// work-precision plots. `err` names the file in errors (`plot_err`).
fn log_log_chart<'a, DB: DrawingBackend + 'a>(
    err: &impl Fn(String) -> Error,
    root: &'a DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    desc: (&str, &str),
) -> Result<ChartContext<'a, DB, LogLog>> {
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 20))
        .margin(14)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(x.log_scale(), y.log_scale())
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .x_desc(desc.0)
        .y_desc(desc.1)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| err(e.to_string()))?;
    Ok(chart)
}

/// drawn through the mean of its fitted points (where a least-squares line passes).
pub fn uncertainty(
    path: &Path,
    title: &str,
    grid: &[(f64, f64)],
    grid_alpha: Option<f64>,
    reint: &[(f64, f64)],
    reint_alpha: Option<f64>,
) -> Result<()> {
    register_font();
    let err = plot_err(path);
    let all: Vec<(f64, f64)> = grid
        .iter()
        .chain(reint)
        .copied()
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .collect();
    let (x0, x1) = all
        .iter()
        .fold((1e-7f64, 1.0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (y0, y1) = all
        .iter()
        .fold((1e-4f64, 1.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    crate::plot::render_png(path, (1100, 800), |root| {
        let mut chart = log_log_chart(
            &err,
            &root,
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
                .draw_series(used.iter().map(|&p| Circle::new(p, 5, c.filled())))
                .map_err(|e| err(e.to_string()))?
                .label(label)
                .legend(move |(x, y)| Circle::new((x + 9, y), 5, c.filled()));
            if let Some(a) = alpha {
                let n = used.len() as f64;
                let mx = used.iter().map(|p| p.0.ln()).sum::<f64>() / n;
                let my = used.iter().map(|p| p.1.ln()).sum::<f64>() / n;
                let (lo, hi) = used.iter().fold((f64::INFINITY, 0.0f64), |(l, h), p| {
                    (l.min(p.0), h.max(p.0))
                });
                let line = [lo, hi].map(|x| (x, (my + a * (x.ln() - mx)).exp()));
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        line.to_vec(),
                        c.stroke_width(2),
                    )))
                    .map_err(|e| err(e.to_string()))?;
            }
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight, 15).map_err(&err)?;
        root.present().map_err(|e| err(e.to_string()))
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
    register_font();
    let err = plot_err(path);
    let pts: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.3.iter().copied())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .collect();
    let (x0, x1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (y0, y1) = pts
        .iter()
        .fold((target, target), |(a, b), p| (a.min(p.1), b.max(p.1)));
    crate::plot::render_png(path, (1200, 850), |root| {
        let mut chart = log_log_chart(
            &err,
            &root,
            title,
            x0 * 0.7..x1 * 1.4,
            y0 * 0.3..y1 * 3.0,
            (
                "throughput [lane-periods per second] (higher is better)",
                "position error after 200 periods [m] (lower is better)",
            ),
        )?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x0 * 0.7, target), (x1 * 1.4, target)],
                RGBColor(150, 150, 150).stroke_width(1),
            )))
            .map_err(|e| err(e.to_string()))?;
        for (name, c, dashed, p) in series {
            let c = *c;
            let style = if *dashed {
                c.mix(0.6).stroke_width(2)
            } else {
                c.stroke_width(3)
            };
            chart
                .draw_series(LineSeries::new(p.iter().copied(), style))
                .map_err(|e| err(e.to_string()))?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c));
            chart
                .draw_series(p.iter().map(|&q| Circle::new(q, 4, c.filled())))
                .map_err(|e| err(e.to_string()))?;
        }
        legend(&mut chart, SeriesLabelPosition::LowerLeft, 15).map_err(&err)?;
        root.present().map_err(|e| err(e.to_string()))
    })
}
