//! The scaling laws of a boundary: the uncertainty exponent alpha by the uncertain
//! fraction on the grid, the box-counting dimension, and the log-log fits they share.

use super::{LabelGrid, MIN_FIT_POINTS, SCALE_DIVISOR, chebyshev_distance};
use serde::Serialize;

/// One point of a scaling law: a box size and the measured quantity there.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ScalePoint {
    /// Box size (cells).
    pub eps: usize,
    /// The uncertain fraction f(eps), or the number of boundary boxes N(eps).
    pub value: f64,
}

/// A least-squares line log(value) = slope * log(eps) + intercept, and the dimension
/// it gives.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LogLogFit {
    /// Smallest box size fitted.
    pub eps_min: usize,
    /// Largest box size fitted.
    pub eps_max: usize,
    /// Points fitted.
    pub points: usize,
    /// The slope (alpha for the uncertain fraction, -D for box counting).
    pub slope: f64,
    /// The slope's standard error from the residuals, sqrt(SSR / (m - 2) / Sxx). It
    /// measures how straight the log-log points lie, not the grid's systematic error.
    pub slope_std_error: f64,
    /// The intercept.
    pub intercept: f64,
    /// The dimension of the boundary the slope gives.
    pub dimension: f64,
    /// Its standard error (= the slope's).
    pub dimension_std_error: f64,
}

/// The uncertainty exponent of a grid.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UncertaintyExponent {
    /// Cells with a neighbour of another label (f(1) = boundary_cells / N).
    pub boundary_cells: usize,
    /// (eps, f(eps)) for eps = 1..=min(nx, ny)/20 (empty when that is 0).
    pub points: Vec<ScalePoint>,
    /// The fit of log f against log eps over all the points: slope = alpha,
    /// dimension = 2 - alpha. `None` with `not_fitted` saying why.
    pub fit: Option<LogLogFit>,
    /// Why there is no fit (too few box sizes, no boundary).
    pub not_fitted: Option<String>,
}

impl UncertaintyExponent {
    /// alpha, when fitted.
    pub fn alpha(&self) -> Option<f64> {
        self.fit.map(|f| f.slope)
    }
}

/// The box-counting dimension of the boundary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoxCountingDimension {
    /// (eps, N(eps)): boxes of side eps (closed, (eps + 1)^2 cells, see
    /// [`boundary_box_dimension`]) holding two or more labels, scaled by (grid area) /
    /// (area the whole boxes cover) so the dropped edge strips do not bend the line.
    pub points: Vec<ScalePoint>,
    /// The fit of log N against log eps: slope = -D.
    pub fit: Option<LogLogFit>,
    /// Why there is no fit.
    pub not_fitted: Option<String>,
}

/// Least squares through (ln x, ln y): (slope, intercept, slope standard error
/// sqrt(SSR / (m - 2) / Sxx)); `None` for fewer than 3 points or a degenerate abscissa.
pub fn log_log_line(x: &[f64], y: &[f64]) -> Option<(f64, f64, f64)> {
    let m = x.len().min(y.len());
    if m < MIN_FIT_POINTS {
        return None;
    }
    let xs: Vec<f64> = x[..m].iter().map(|v| v.ln()).collect();
    let ys: Vec<f64> = y[..m].iter().map(|v| v.ln()).collect();
    let mx = xs.iter().sum::<f64>() / m as f64;
    let my = ys.iter().sum::<f64>() / m as f64;
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let ssr: f64 = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| (y - intercept - slope * x).powi(2))
        .sum();
    Some((slope, intercept, (ssr / (m - 2) as f64 / sxx).sqrt()))
}

/// Least squares through (ln eps, ln value); `None` when fewer than 3 points or a
/// degenerate abscissa.
fn fit_log_log(points: &[ScalePoint], dimension: impl Fn(f64) -> f64) -> Option<LogLogFit> {
    let m = points.len();
    let x: Vec<f64> = points.iter().map(|p| p.eps as f64).collect();
    let y: Vec<f64> = points.iter().map(|p| p.value).collect();
    let (slope, intercept, se) = log_log_line(&x, &y)?;
    Some(LogLogFit {
        eps_min: points[0].eps,
        eps_max: points[m - 1].eps,
        points: m,
        slope,
        slope_std_error: se,
        intercept,
        dimension: dimension(slope),
        dimension_std_error: se,
    })
}

/// Why a grid gives no scaling fit, if it gives none for lack of size.
fn too_small(grid: &LabelGrid, sizes: usize) -> Option<String> {
    (sizes < MIN_FIT_POINTS).then(|| {
        format!(
            "a {} x {} grid allows box sizes up to min(nx, ny)/{SCALE_DIVISOR} = {}, {} of them; a fit needs at least {MIN_FIT_POINTS}",
            grid.nx,
            grid.ny,
            grid.max_scale(),
            sizes
        )
    })
}

/// The uncertainty exponent alpha by the uncertain fraction on the grid (Grebogi,
/// McDonald, Ott and Yorke, Phys. Lett. A 99, 415 (1983); McDonald, Grebogi, Ott and
/// Yorke, Physica D 17, 125 (1985)).
///
/// f(eps) is the fraction of cells whose eps-neighbourhood (the cells within Chebyshev
/// distance eps, clipped at the grid's edges) holds another label: the start states
/// that an error of eps cells could send to another attractor. f ~ eps^alpha, and the
/// boundary's dimension is D = 2 - alpha (alpha = 1 for a smooth curve). Fitted over
/// eps = 1..=min(nx, ny)/20.
///
/// One distance transform answers every eps: a cell of label a is uncertain at eps
/// exactly when it lies within eps - 1 of a boundary cell (a cell with a neighbour of
/// another label). If the nearest foreign cell c' is at distance d, the cell one step
/// from c' towards c is at distance d - 1, is labelled a (everything closer than d is)
/// and neighbours c', so it is a boundary cell; conversely a boundary cell at distance
/// m has a foreign cell within m + 1. So f(eps) = #{D_B < eps} / N with D_B the
/// Chebyshev distance to the boundary cells.
pub fn uncertainty_exponent(grid: &LabelGrid) -> UncertaintyExponent {
    let eps_max = grid.max_scale();
    let n = grid.cells() as f64;
    let boundary = grid.boundary_mask();
    let boundary_cells = boundary.iter().filter(|&&b| b).count();
    let mut points = Vec::new();
    if eps_max > 0 {
        let dist = chebyshev_distance(grid.nx, grid.ny, &boundary);
        let mut hist = vec![0usize; eps_max];
        for &d in &dist {
            if (d as usize) < eps_max {
                hist[d as usize] += 1;
            }
        }
        let mut cumulative = 0;
        for (eps, h) in (1..=eps_max).zip(hist) {
            cumulative += h;
            points.push(ScalePoint {
                eps,
                value: cumulative as f64 / n,
            });
        }
    }
    if let Some(why) = too_small(grid, points.len()) {
        return UncertaintyExponent {
            boundary_cells,
            points,
            fit: None,
            not_fitted: Some(why),
        };
    }
    if boundary_cells == 0 {
        return UncertaintyExponent {
            boundary_cells,
            points,
            fit: None,
            not_fitted: Some("no boundary: the grid holds one label".into()),
        };
    }
    let fit = fit_log_log(&points, |alpha| 2.0 - alpha);
    UncertaintyExponent {
        boundary_cells,
        not_fitted: fit.is_none().then(|| "degenerate fit".into()),
        points,
        fit,
    }
}

/// Box sizes 1..=eps_max, close to geometric (ratio ~1.25) so that every scale weighs
/// about the same in the log-log fit, each size once.
fn geometric_sizes(eps_max: usize) -> Vec<usize> {
    let mut sizes: Vec<usize> = Vec::new();
    let mut e = 1.0f64;
    while e.round() as usize <= eps_max {
        let s = e.round() as usize;
        if sizes.last() != Some(&s) {
            sizes.push(s);
        }
        e *= 1.25;
    }
    sizes
}

/// The box-counting dimension of the boundary: N(eps) = number of boxes of side eps
/// holding two or more labels, fitted as N ~ eps^-D over eps = 1..=min(nx, ny)/20 at
/// roughly geometric spacing. A cross-check of the uncertainty exponent's D = 2 - alpha:
/// for self-similar boundaries both give the box dimension (McDonald et al. 1985).
///
/// The boundary runs between cell centres, so the boxes are closed squares of side eps
/// in centre coordinates: box (bx, by) holds the (eps + 1)^2 cells from (bx eps, by eps)
/// to ((bx + 1) eps, (by + 1) eps) inclusive, sharing its last row and column with the
/// next box. With disjoint boxes of eps^2 cells a boundary that runs along box edges
/// (a half-plane split at a multiple of eps) would be in no box at all. Boxes tile from
/// cell (0, 0); an edge strip narrower than a box is dropped and N is scaled by
/// (area of the grid) / (area the boxes cover), in centre coordinates.
pub fn boundary_box_dimension(grid: &LabelGrid) -> BoxCountingDimension {
    fn note(first: &mut u32, mixed: &mut bool, class: u32) {
        if *first == u32::MAX {
            *first = class;
        } else if *first != class {
            *mixed = true;
        }
    }
    let sizes = geometric_sizes(grid.max_scale());
    let mut points = Vec::with_capacity(sizes.len());
    for &eps in &sizes {
        let (bx, by) = ((grid.nx - 1) / eps, (grid.ny - 1) / eps);
        // Per box in the current row of boxes: the first class seen, and whether
        // another one turned up.
        let mut first = vec![u32::MAX; bx];
        let mut mixed = vec![false; bx];
        let mut count = 0usize;
        for jy in 0..by {
            first.fill(u32::MAX);
            mixed.fill(false);
            for iy in jy * eps..=(jy + 1) * eps {
                let row = &grid.class[iy * grid.nx..iy * grid.nx + bx * eps + 1];
                for (ix, &c) in row.iter().enumerate() {
                    // Cell ix belongs to box ix / eps and, on a shared column, to the
                    // box before it too.
                    let b = ix / eps;
                    if b < bx {
                        note(&mut first[b], &mut mixed[b], c);
                    }
                    if ix % eps == 0 && b > 0 {
                        note(&mut first[b - 1], &mut mixed[b - 1], c);
                    }
                }
            }
            count += mixed.iter().filter(|&&m| m).count();
        }
        let covered = (bx * by * eps * eps) as f64;
        let area = ((grid.nx - 1) * (grid.ny - 1)) as f64;
        points.push(ScalePoint {
            eps,
            value: count as f64 * area / covered,
        });
    }
    if let Some(why) = too_small(grid, points.len()) {
        return BoxCountingDimension {
            points,
            fit: None,
            not_fitted: Some(why),
        };
    }
    if points.iter().any(|p| p.value == 0.0) {
        return BoxCountingDimension {
            points,
            fit: None,
            not_fitted: Some("no boundary box at some box size".into()),
        };
    }
    let fit = fit_log_log(&points, |slope| -slope);
    BoxCountingDimension {
        not_fitted: fit.is_none().then(|| "degenerate fit".into()),
        points,
        fit,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uncertain_fraction_equals_the_brute_force_neighbourhood_scan() {
        let (nx, ny) = (80, 61);
        let labels: Vec<i32> = (0..nx * ny)
            .map(|i| {
                let (x, y) = ((i % nx) as f64, (i / nx) as f64);
                if (x - 30.0).hypot(y - 25.0) < 17.0 {
                    2
                } else if x + 0.37 * y > 60.0 {
                    -1
                } else {
                    0
                }
            })
            .collect();
        let grid = LabelGrid::new(&labels, nx, ny).unwrap();
        let u = uncertainty_exponent(&grid);
        assert_eq!(u.points.len(), 3);
        for p in &u.points {
            let e = p.eps;
            let mut uncertain = 0;
            for iy in 0..ny {
                for ix in 0..nx {
                    let own = labels[iy * nx + ix];
                    let hit = (iy.saturating_sub(e)..=(iy + e).min(ny - 1)).any(|y| {
                        (ix.saturating_sub(e)..=(ix + e).min(nx - 1))
                            .any(|x| labels[y * nx + x] != own)
                    });
                    uncertain += hit as usize;
                }
            }
            assert_eq!(p.value, uncertain as f64 / (nx * ny) as f64, "eps = {e}");
        }
    }
}
