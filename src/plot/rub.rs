//! Pictures a rotordynamics engineer reads: the full spectrum with its 1X, 2X, 1/2X and
//! 1/3X marks (`full_spectrum.png`), the orbit relative to the stator with the clearance
//! circle and the contact load histories (`contact.png`), and the full-spectrum cascade
//! against speed (`cascade.png`).

use super::frame::{Mesh, chart, dot_key, figure, line_key};
use super::{legend, padded_range};
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
    figure(path, (1300, 1000), |root| {
        let root = root.titled(title, ("sans-serif", 24))?;
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
            let caption = format!("{name}: full spectrum of x + i y (forward > 0, backward < 0)");
            let mut chart = chart(
                area,
                Some((&caption, 19)),
                (12, 46, 80),
                -max_order..max_order,
                0.0..top,
            )?;
            Mesh::new("frequency / W (order)", "amplitude [mm]").draw(&mut chart)?;
            for (o, label) in MARKS {
                if o.abs() <= max_order {
                    chart.draw_series(std::iter::once(PathElement::new(
                        vec![(o, 0.0), (o, top)],
                        RGBColor(170, 170, 170).stroke_width(1),
                    )))?;
                    chart.draw_series(std::iter::once(Text::new(
                        label,
                        (o, top * 0.97),
                        ("sans-serif", 14).into_font().color(&RGBColor(90, 90, 90)),
                    )))?;
                }
            }
            chart
                .draw_series(pts.iter().map(|&(o, a)| {
                    PathElement::new(vec![(o, 0.0), (o, a)], BLUE.stroke_width(2))
                }))?;
        }
        Ok(())
    })
}

/// The rotor orbit relative to the stator with the clearance circle (contact points
/// red), and the normal contact force and penetration against time. `rows` are
/// (t [s], dx [m], dy [m], g [m], F_n [N]).
pub fn contact(path: &Path, title: &str, rows: &[[f64; 5]], delta: f64) -> Result<()> {
    figure(path, (1500, 800), |root| {
        let root = root.titled(title, ("sans-serif", 24))?;
        let (left, right) = root.split_horizontally(760);
        let reach = rows
            .iter()
            .map(|r| r[1].abs().max(r[2].abs()))
            .fold(delta, f64::max)
            * 1.1e3;
        let mut orbit = chart(
            &left,
            Some(("rotor centre relative to the stator, clearance circle", 18)),
            (12, 46, 70),
            -reach..reach,
            -reach..reach,
        )?;
        Mesh::new("x_r - x_s [mm]", "y_r - y_s [mm]").draw(&mut orbit)?;
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
            )))?
            .label("clearance")
            .legend(line_key(BLACK));
        orbit
            .draw_series(LineSeries::new(
                rows.iter().map(|r| (r[1] * 1e3, r[2] * 1e3)),
                BLUE.mix(0.6).stroke_width(1),
            ))?
            .label("orbit")
            .legend(line_key(BLUE));
        orbit
            .draw_series(
                rows.iter()
                    .filter(|r| r[3] > 0.0)
                    .map(|r| Circle::new((r[1] * 1e3, r[2] * 1e3), 2, RED.filled())),
            )?
            .label("in contact")
            .legend(dot_key(RED, 3));
        legend(&mut orbit, SeriesLabelPosition::UpperRight, 14)?;
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
            let mut chart = chart(area, None, (12, 40, 80), 0.0..(t1 - t0).max(1e-12), yr)?;
            Mesh::new("t - t0 [s]", name)
                .fonts(14, 16)
                .draw(&mut chart)?;
            chart.draw_series(LineSeries::new(
                rows.iter().map(|r| (r[0] - t0, r[col].max(0.0) * scale)),
                RED.stroke_width(1),
            ))?;
        }
        Ok(())
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
    figure(path, (1400, 1000), |root| {
        let mut chart = chart(root, Some((title, 22)), (14, 50, 80), w0..w1, -fmax..fmax)?;
        Mesh::new(
            "rotor speed W [rad/s]",
            "frequency [Hz] (forward > 0, backward < 0)",
        )
        .draw(&mut chart)?;
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
        chart.draw_series(cells)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(w0, w0 / tau), (w1, w1 / tau)],
                BLUE.stroke_width(2),
            )))?
            .label("1X")
            .legend(line_key(BLUE));
        for (k, (name, f)) in naturals.iter().enumerate() {
            let c = super::PALETTE[(k + 2) % super::PALETTE.len()];
            for sign in [1.0, -1.0] {
                if f.abs() <= fmax {
                    let s = chart.draw_series(std::iter::once(PathElement::new(
                        vec![(w0, sign * f), (w1, sign * f)],
                        c.stroke_width(1),
                    )))?;
                    if sign > 0.0 {
                        s.label(name.as_str()).legend(line_key(c));
                    }
                }
            }
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft, 14)?;
        Ok(())
    })
}
