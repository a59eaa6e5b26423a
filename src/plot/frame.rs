//! The frame every figure shares: the white canvas written as PNG, a chart's builder
//! settings, its axes, the zero line and the legend keys. Each figure keeps only what
//! differs; the helpers make the same plotters calls in the same order as before, so
//! the pixels do not change.

use super::{plot_err, register_font, render_png};
use jeffcott_core::error::Result;
use plotters::chart::SeriesAnno;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::ops::Range;
use std::path::Path;

/// A drawing area of an in-memory figure.
pub(crate) type Area<'b> = DrawingArea<BitMapBackend<'b>, Shift>;

/// The result of drawing; [`figure`] turns a failure into a [`super::PlotError`].
pub(crate) type Drawn<T = ()> = std::result::Result<T, Box<dyn std::error::Error>>;

/// A chart on an in-memory figure over `X` and `Y` coordinates.
pub(crate) type Chart<'a, 'b, X, Y> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<X, Y>>;

/// A chart over plain f64 axes.
pub(crate) type Linear<'a, 'b> = Chart<'a, 'b, RangedCoordf64, RangedCoordf64>;

/// Draws a `size` figure with `draw` on a white canvas and writes it to `path` as PNG.
pub(crate) fn figure(
    path: &Path,
    size: (u32, u32),
    draw: impl for<'b> FnOnce(&Area<'b>) -> Drawn,
) -> Result<()> {
    register_font();
    // Every failure while drawing becomes one PlotError naming the file.
    let err = plot_err(path);
    render_png(path, size, |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        draw(&root).map_err(|e| err(e.to_string()))?;
        root.present().map_err(|e| err(e.to_string()))
    })
}

/// Builds a chart on `area` over `x` and `y`, `areas` = (margin, x-label, y-label) px.
pub(crate) fn chart<'a, 'b, X: AsRangedCoord, Y: AsRangedCoord>(
    area: &'a Area<'b>,
    caption: Option<(&str, u32)>,
    areas: (u32, u32, u32),
    x: X,
    y: Y,
) -> Drawn<Chart<'a, 'b, X::CoordDescType, Y::CoordDescType>> {
    let mut builder = ChartBuilder::on(area);
    // A caption (text, font size) is optional: panels under a figure title go without.
    if let Some((text, size)) = caption {
        builder.caption(text, ("sans-serif", size));
    }
    Ok(builder
        .margin(areas.0)
        .x_label_area_size(areas.1)
        .y_label_area_size(areas.2)
        .build_cartesian_2d(x, y)?)
}

/// Formats a tick value into its label.
pub(crate) type Ticks<'m> = &'m dyn Fn(&f64) -> String;

/// Tick labels for an axis from `lo` to `hi`: enough digits to tell apart ticks a tenth
/// of the span apart, in scientific notation where the values are below 1e-3 or from 1e5
/// up (a map over unbalances of 1e-5 m read 0.0000 on every tick with four decimals).
pub(crate) fn axis_ticks(lo: f64, hi: f64) -> impl Fn(&f64) -> String {
    let step = ((hi - lo).abs() / 10.0).max(f64::MIN_POSITIVE);
    let mag = lo.abs().max(hi.abs());
    let sci = mag > 0.0 && !(1e-3..1e5).contains(&mag);
    let digits = if sci {
        // Mantissa decimals: the largest value over the step, in digits, less one.
        ((mag / step).log10().ceil() - 1.0).clamp(0.0, 6.0) as usize
    } else {
        (-step.log10()).ceil().clamp(0.0, 8.0) as usize
    };
    move |v: &f64| {
        if sci {
            format!("{v:.digits$e}")
        } else {
            format!("{v:.digits$}")
        }
    }
}

/// How a chart's axes are drawn: descriptions, font sizes, tick labels and grid lines.
pub(crate) struct Mesh<'m> {
    x_desc: &'m str,
    y_desc: &'m str,
    fonts: (u32, u32),
    ticks: Option<(Ticks<'m>, Ticks<'m>)>,
    light_lines: bool,
    grid: bool,
}

impl<'m> Mesh<'m> {
    /// Axes described `x_desc` and `y_desc` in the house fonts (labels 15, descriptions 17).
    pub(crate) fn new(x_desc: &'m str, y_desc: &'m str) -> Self {
        Mesh {
            x_desc,
            y_desc,
            fonts: (15, 17),
            ticks: None,
            light_lines: true,
            grid: true,
        }
    }

    /// Other font sizes for the tick labels and the axis descriptions.
    pub(crate) fn fonts(mut self, labels: u32, descs: u32) -> Self {
        self.fonts = (labels, descs);
        self
    }

    /// Tick labels formatted by `x` and `y` instead of plotters' default.
    pub(crate) fn ticks(mut self, x: Ticks<'m>, y: Ticks<'m>) -> Self {
        self.ticks = Some((x, y));
        self
    }

    /// Without the light grid lines (drawn white), so dense dots stay readable.
    pub(crate) fn no_light_lines(mut self) -> Self {
        self.light_lines = false;
        self
    }

    /// Without any grid lines (a map covers the whole plotting area).
    pub(crate) fn no_grid(mut self) -> Self {
        self.grid = false;
        self
    }

    /// Draws these axes on `chart`.
    pub(crate) fn draw<X, Y>(&self, chart: &mut Chart<'_, '_, X, Y>) -> Drawn
    where
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let mut mesh = chart.configure_mesh();
        if !self.grid {
            mesh.disable_mesh();
        }
        if !self.light_lines {
            mesh.light_line_style(WHITE);
        }
        mesh.x_desc(self.x_desc)
            .y_desc(self.y_desc)
            .label_style(("sans-serif", self.fonts.0))
            .axis_desc_style(("sans-serif", self.fonts.1));
        if let Some((x, y)) = self.ticks {
            mesh.x_label_formatter(x).y_label_formatter(y);
        }
        Ok(mesh.draw()?)
    }
}

/// Draws the black line y = 0 across `x`, where an exponent changes sign; label it after.
pub(crate) fn zero_line<'c, 'a, 'b>(
    chart: &'c mut Linear<'a, 'b>,
    x: &Range<f64>,
    width: u32,
) -> Drawn<&'c mut SeriesAnno<'a, BitMapBackend<'b>>> {
    Ok(chart.draw_series(LineSeries::new(
        [(x.start, 0.0), (x.end, 0.0)],
        BLACK.stroke_width(width),
    ))?)
}

/// A legend key for a line series: a short line in `c`.
pub(crate) fn line_key(c: RGBColor) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c)
}

/// A legend key for a dot series: a filled dot of radius `r` in `c`.
pub(crate) fn dot_key(c: RGBColor, r: u32) -> impl Fn((i32, i32)) -> Circle<(i32, i32), u32> {
    move |(x, y)| Circle::new((x + 9, y), r, c.filled())
}

/// The smallest and the largest of `start`'s two values and `values`: a plot's extent
/// that always includes `start` (its minimum candidate and its maximum candidate).
pub(crate) fn extent(values: impl IntoIterator<Item = f64>, start: (f64, f64)) -> (f64, f64) {
    values
        .into_iter()
        .fold(start, |(lo, hi), v| (lo.min(v), hi.max(v)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_ticks_tell_neighbouring_ticks_apart_at_any_scale() {
        let e = axis_ticks(2e-5, 1.2e-4);
        assert_eq!(
            [e(&2e-5), e(&4e-5), e(&1.2e-4)],
            ["2.0e-5", "4.0e-5", "1.2e-4"]
        );
        let w = axis_ticks(100.0, 200.0);
        assert_eq!([w(&100.0), w(&120.0)], ["100", "120"]);
        let mu = axis_ticks(0.0, 0.3);
        assert_eq!([mu(&0.0), mu(&0.05)], ["0.00", "0.05"]);
        let w = axis_ticks(131.7, 132.4);
        assert_eq!([w(&131.7), w(&131.75)], ["131.70", "131.75"]);
    }
}
