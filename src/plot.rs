//! Pictures (plotters, bitmap backend, the bundled DejaVu Sans font so no system font
//! library is needed).

use crate::error::{Error, Result};
use crate::model::{STATE_DIM, State, VX_R, VX_S, X_R, X_S, Y_R, Y_S};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

pub mod lyapunov;

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is compiled in; failure would be a build defect caught by the tests.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
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
    let root = BitMapBackend::new(path, (1400, 1150)).into_drawing_area();
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
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| err(e.to_string()))?;
    }
    root.present().map_err(|e| err(e.to_string()))
}
