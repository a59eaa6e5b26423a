//! Pictures a rotordynamics engineer reads: the full spectrum with its 1X, 2X, 1/2X and
//! 1/3X marks (`full_spectrum.png`), the orbit relative to the stator with the clearance
//! circle and the contact load histories (`contact.png`), and the full-spectrum cascade
//! against speed (`cascade.png`).

use super::{padded_range, plot_err, register_font};
use jeffcott_analysis::spectrum::FullSpectrum;
use jeffcott_core::error::Result;
use plotters::prelude::*;
use std::path::Path;

/// Orders marked on spectra: the classic rub signatures.
const MARKS: [(f64, &str); 8] = [
    (1.0, "1X"),
    (2.0, "2X"),
    (3.0, "3X"),
    (0.5, "1/2X"),
    (1.0 / 3.0, "1/3X"),
    (2.0 / 3.0, "2/3X"),
    (-1.0, "-1X"),
    (-0.5, "-1/2X"),
];

/// Full spectra of the rotor and the stator (amplitude [mm] against order, forward
/// right of 0, backward left), within +-`max_order`.
pub fn full_spectrum(
    path: &Path,
    title: &str,
    rotor: &FullSpectrum,
    stator: &FullSpectrum,
    max_order: f64,
) -> Result<()> {
    register_font();
    let err = plot_err(path);
    crate::plot::render_png(path, (1300, 1000), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 24))
            .map_err(|e| err(e.to_string()))?;
        let areas = root.split_evenly((2, 1));
        for (area, (name, s)) in areas.iter().zip([("rotor", rotor), ("stator", stator)]) {
            let pts: Vec<(f64, f64)> = s
                .order
                .iter()
                .zip(&s.amplitude)
                .filter(|(o, _)| o.abs() <= max_order)
                .map(|(&o, &a)| (o, a * 1e3))
                .collect();
            let top = pts.iter().map(|p| p.1).fold(1e-9, f64::max) * 1.15;
            let mut chart = ChartBuilder::on(area)
                .caption(
                    format!("{name}: full spectrum of x + i y (forward > 0, backward < 0)"),
                    ("sans-serif", 19),
                )
                .margin(12)
                .x_label_area_size(46)
                .y_label_area_size(80)
                .build_cartesian_2d(-max_order..max_order, 0.0..top)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_desc("frequency / W (order)")
                .y_desc("amplitude [mm]")
                .label_style(("sans-serif", 15))
                .axis_desc_style(("sans-serif", 17))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            for (o, label) in MARKS {
                if o.abs() <= max_order {
                    chart
                        .draw_series(std::iter::once(PathElement::new(
                            vec![(o, 0.0), (o, top)],
                            RGBColor(170, 170, 170).stroke_width(1),
                        )))
                        .map_err(|e| err(e.to_string()))?;
                    chart
                        .draw_series(std::iter::once(Text::new(
                            label,
                            (o, top * 0.97),
                            ("sans-serif", 14).into_font().color(&RGBColor(90, 90, 90)),
                        )))
                        .map_err(|e| err(e.to_string()))?;
                }
            }
            chart
                .draw_series(
                    pts.iter().map(|&(o, a)| {
                        PathElement::new(vec![(o, 0.0), (o, a)], BLUE.stroke_width(2))
                    }),
                )
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))
    })
}

/// The rotor orbit relative to the stator with the clearance circle (contact points
/// red), and the normal contact force and penetration against time. `rows` are
/// (t [s], dx [m], dy [m], g [m], F_n [N]).
pub fn contact(path: &Path, title: &str, rows: &[[f64; 5]], delta: f64) -> Result<()> {
    register_font();
    let err = plot_err(path);
    crate::plot::render_png(path, (1500, 800), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 24))
            .map_err(|e| err(e.to_string()))?;
        let (left, right) = root.split_horizontally(760);
        let reach = rows
            .iter()
            .map(|r| r[1].abs().max(r[2].abs()))
            .fold(delta, f64::max)
            * 1.1e3;
        let mut orbit = ChartBuilder::on(&left)
            .caption(
                "rotor centre relative to the stator, clearance circle",
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(46)
            .y_label_area_size(70)
            .build_cartesian_2d(-reach..reach, -reach..reach)
            .map_err(|e| err(e.to_string()))?;
        orbit
            .configure_mesh()
            .x_desc("x_r - x_s [mm]")
            .y_desc("y_r - y_s [mm]")
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        let circle: Vec<(f64, f64)> = (0..=360)
            .map(|k| {
                let a = (k as f64).to_radians();
                (delta * 1e3 * a.cos(), delta * 1e3 * a.sin())
            })
            .collect();
        orbit
            .draw_series(std::iter::once(PathElement::new(
                circle,
                BLACK.stroke_width(2),
            )))
            .map_err(|e| err(e.to_string()))?
            .label("clearance")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
        orbit
            .draw_series(LineSeries::new(
                rows.iter().map(|r| (r[1] * 1e3, r[2] * 1e3)),
                BLUE.mix(0.6).stroke_width(1),
            ))
            .map_err(|e| err(e.to_string()))?
            .label("orbit")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLUE));
        orbit
            .draw_series(
                rows.iter()
                    .filter(|r| r[3] > 0.0)
                    .map(|r| Circle::new((r[1] * 1e3, r[2] * 1e3), 2, RED.filled())),
            )
            .map_err(|e| err(e.to_string()))?
            .label("in contact")
            .legend(|(x, y)| Circle::new((x + 9, y), 3, RED.filled()));
        super::legend(&mut orbit, SeriesLabelPosition::UpperRight, 14).map_err(&err)?;
        let (t0, t1) = (
            rows.first().map(|r| r[0]).unwrap_or(0.0),
            rows.last().map(|r| r[0]).unwrap_or(1.0),
        );
        let panels = right.split_evenly((2, 1));
        for (area, (col, name, scale)) in panels.iter().zip([
            (4, "normal contact force [N]", 1.0),
            (3, "penetration g [um]", 1e6),
        ]) {
            let yr = padded_range(rows.iter().map(|r| r[col].max(0.0) * scale).chain([0.0]));
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(80)
                .build_cartesian_2d(0.0..(t1 - t0).max(1e-12), yr)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_desc("t - t0 [s]")
                .y_desc(name)
                .label_style(("sans-serif", 14))
                .axis_desc_style(("sans-serif", 16))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            chart
                .draw_series(LineSeries::new(
                    rows.iter().map(|r| (r[0] - t0, r[col].max(0.0) * scale)),
                    RED.stroke_width(1),
                ))
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))
    })
}

/// A cascade: per speed (x, rad/s) the full spectrum amplitude (colour, log scale) at
/// each frequency (y, Hz; forward above 0, backward below), with the 1X line and
/// horizontal lines at the natural frequencies (name, Hz) overlaid.
pub fn cascade(
    path: &Path,
    title: &str,
    speeds: &[f64],
    orders: &[f64],
    amplitude: &[f64],
    naturals: &[(String, f64)],
) -> Result<()> {
    register_font();
    let err = plot_err(path);
    let n = orders.len();
    let tau = std::f64::consts::TAU;
    let (w0, w1) = (speeds[0], speeds[speeds.len() - 1].max(speeds[0] + 1e-9));
    let fmax = orders.iter().fold(0.0f64, |m, o| m.max(o.abs())) * w1 / tau;
    let top = amplitude
        .iter()
        .copied()
        .filter(|a| a.is_finite())
        .fold(1e-12, f64::max);
    let floor = top * 1e-4;
    crate::plot::render_png(path, (1400, 1000), |root| {
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(14)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(w0..w1, -fmax..fmax)
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("rotor speed W [rad/s]")
            .y_desc("frequency [Hz] (forward > 0, backward < 0)")
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        let dw = if speeds.len() > 1 {
            (w1 - w0) / (speeds.len() - 1) as f64
        } else {
            1.0
        };
        let dor = if n > 1 {
            (orders[1] - orders[0]).abs()
        } else {
            1.0
        };
        let mut cells = Vec::new();
        for (i, &w) in speeds.iter().enumerate() {
            for (k, &o) in orders.iter().enumerate() {
                let a = amplitude[i * n + k];
                if a.is_nan() || a <= floor {
                    continue;
                }
                // Log scale over 4 decades: pale for small lines, dark red for the largest.
                let s = ((a / top).log10() / 4.0 + 1.0).clamp(0.0, 1.0);
                let c = RGBColor(255, (235.0 * (1.0 - s)) as u8, (200.0 * (1.0 - s)) as u8);
                let f = o * w / tau;
                let half = 0.5 * dor * w / tau;
                cells.push(Rectangle::new(
                    [(w - 0.5 * dw, f - half), (w + 0.5 * dw, f + half)],
                    c.filled(),
                ));
            }
        }
        chart.draw_series(cells).map_err(|e| err(e.to_string()))?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(w0, w0 / tau), (w1, w1 / tau)],
                BLUE.stroke_width(2),
            )))
            .map_err(|e| err(e.to_string()))?
            .label("1X")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLUE));
        for (k, (name, f)) in naturals.iter().enumerate() {
            let c = super::PALETTE[(k + 2) % super::PALETTE.len()];
            for sign in [1.0, -1.0] {
                if f.abs() <= fmax {
                    let s = chart
                        .draw_series(std::iter::once(PathElement::new(
                            vec![(w0, sign * f), (w1, sign * f)],
                            c.stroke_width(1),
                        )))
                        .map_err(|e| err(e.to_string()))?;
                    if sign > 0.0 {
                        s.label(name.as_str())
                            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c));
                    }
                }
            }
        }
        super::legend(&mut chart, SeriesLabelPosition::UpperLeft, 14).map_err(&err)?;
        root.present().map_err(|e| err(e.to_string()))
    })
}
