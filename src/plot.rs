//! Pictures (plotters, bitmap backend, the bundled DejaVu Sans font so no system font
//! library is needed).

use jeffcott_core::error::{Error, Result};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

mod bifurcation;
mod frame;
pub mod lyapunov;
mod maps;
mod measure;
pub mod orbits;
mod phase;
pub mod rub;

pub use bifurcation::{DotSeries, Lambda1Series, bifurcation_diagram};
pub use maps::{MapGrid, basin_map, category_map, lambda1_color, lambda1_map};
pub use measure::{
    StackedPanel, WorkPrecisionSeries, stacked_fractions, uncertainty, work_precision,
};
pub use phase::{AttractorTrace, coexisting_attractors, phase_portraits, poincare_sections};

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

/// Drawing a picture failed.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw {path}: {message}")]
pub struct PlotError {
    /// The picture being drawn.
    pub path: std::path::PathBuf,
    /// What went wrong.
    pub message: String,
}

fn plot_err(path: &Path) -> impl Fn(String) -> Error + '_ {
    move |message| {
        Error::layer(PlotError {
            path: path.to_path_buf(),
            message,
        })
    }
}

/// Range of values padded by 5 % (and widened if degenerate).
fn padded_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = frame::extent(
        values.filter(|v| v.is_finite()),
        (f64::INFINITY, f64::NEG_INFINITY),
    );
    if !lo.is_finite() {
        return -1.0..1.0;
    }
    let span = (hi - lo).max(1e-12 * lo.abs().max(hi.abs())).max(1e-15);
    (lo - 0.05 * span)..(hi + 0.05 * span)
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
