//! Measures of a labelled basin grid: the numbers researchers quantify basins with.
//!
//! Input: labels row-major `[ny, nx]` (row `iy`, column `ix`, cell `iy * nx + ix`),
//! attractor ids `>= 0` and `-1` for diverged cells, as [`super::basin`] writes them.
//! Every measure here treats `-1` as a class of its own: a cell that diverges next to a
//! cell that settles is on a boundary, and a box holding both has entropy. The Wada test
//! is the exception: by default the diverged cells are not a basin there (they are
//! "not this basin" for every attractor), unless [`WadaOptions::diverged_is_basin`].
//!
//! - [`basin_fractions`]: f_k = n_k / N, the binomial standard error a random sample of
//!   N start states would have, and the bound a grid actually has (boundary cells / N).
//! - [`basin_entropy`]: S_b and S_bb of Daza, Wagemakers, Georgeot, Guery-Odelin and
//!   Sanjuan, Sci. Rep. 6, 31416 (2016), with their sufficient test for a fractal
//!   boundary, S_bb > ln 2.
//! - [`uncertainty_exponent`]: the uncertain fraction f(eps) ~ eps^alpha of Grebogi,
//!   McDonald, Ott and Yorke, Phys. Lett. A 99, 415 (1983), and McDonald et al., Physica
//!   D 17, 125 (1985), on the grid; the boundary dimension is D = 2 - alpha.
//! - [`boundary_box_dimension`]: the box-counting dimension of the boundary itself, a
//!   cross-check of D.
//! - [`wada_merge_test`]: the merging method of Daza, Wagemakers and Sanjuan, Sci. Rep.
//!   8, 9954 (2018).
//! - [`classify_boundary`] / [`classify_measures`]: smooth or fractal, with the evidence.
//!
//! Every pass is O(N) in the number of cells: neighbourhood questions are answered by
//! one exact Chebyshev distance transform (two raster passes) instead of scanning
//! eps x eps windows, so the 1..n/20 box sizes of the uncertainty exponent cost one
//! transform in all. docs/basin-measures.md has the definitions and the defaults.

use jeffcott_core::error::{Error, Result};
use serde::Serialize;

/// Default box side (cells) of the basin entropy: 5 x 5 boxes are small enough to
/// follow a boundary's fine structure and hold 25 cells, enough for a plug-in entropy
/// whose bias is (m - 1) / 50 for m equally likely labels (Miller-Madow).
pub const DEFAULT_ENTROPY_BOX: usize = 5;

/// The largest box size of the scaling fits is min(nx, ny) / this: boxes much bigger
/// than 1/20 of the grid see the grid's edges and the basins' large-scale shape rather
/// than the boundary's self-similarity.
pub const SCALE_DIVISOR: usize = 20;

/// The fewest box sizes a log-log fit is made from.
pub const MIN_FIT_POINTS: usize = 3;

/// How far below 1 alpha must lie, at least, before [`classify_measures`] calls it a
/// fractal boundary, whatever its standard error. The fit's standard error comes from
/// the scatter of correlated points (every f(eps) counts the same boundary) and says
/// nothing of the grid's systematic error: a rasterised straight line gives alpha within
/// ~0.01 of 1 with a standard error of 1e-3 or less, and a 2-sigma test alone would call
/// it fractal.
pub const ALPHA_RESOLUTION: f64 = 0.05;

/// Half-width of the band around alpha = 1 that counts as a smooth boundary.
pub const SMOOTH_ALPHA_BAND: f64 = 0.1;

/// A validated label grid, with every label mapped to a dense class index.
#[derive(Clone, Debug)]
pub struct LabelGrid {
    nx: usize,
    ny: usize,
    /// The distinct labels, ascending (`-1` first when present).
    labels: Vec<i32>,
    /// Per cell, the index of its label in `labels`.
    class: Vec<u32>,
}

impl LabelGrid {
    /// Checks `labels` (length `nx * ny`, every label `>= -1`) and indexes its classes.
    pub fn new(labels: &[i32], nx: usize, ny: usize) -> Result<LabelGrid> {
        if nx == 0 || ny == 0 {
            return Err(Error::invalid(
                "grid",
                format!("{nx} x {ny}"),
                "the grid needs at least one cell per axis",
            ));
        }
        if nx.checked_mul(ny) != Some(labels.len()) {
            return Err(Error::invalid(
                "labels",
                format!("{} labels", labels.len()),
                format!("a {nx} x {ny} grid needs nx * ny labels"),
            ));
        }
        if let Some(&bad) = labels.iter().find(|&&l| l < -1) {
            return Err(Error::invalid(
                "labels",
                bad,
                "attractor ids are >= 0 and -1 marks diverged cells",
            ));
        }
        let max = labels.iter().copied().max().unwrap_or(-1);
        // Attractor ids are small in practice: a lookup table indexed by label + 1 is
        // then one pass. Huge ids fall back to a sorted list and binary search.
        let span = max as usize + 2;
        let (distinct, class) = if span <= labels.len().max(1 << 16) * 2 {
            let mut seen = vec![false; span];
            for &l in labels {
                seen[(l + 1) as usize] = true;
            }
            let mut index = vec![u32::MAX; span];
            let mut distinct = Vec::new();
            for (slot, &present) in seen.iter().enumerate() {
                if present {
                    index[slot] = distinct.len() as u32;
                    distinct.push(slot as i32 - 1);
                }
            }
            let class = labels.iter().map(|&l| index[(l + 1) as usize]).collect();
            (distinct, class)
        } else {
            let mut distinct = labels.to_vec();
            distinct.sort_unstable();
            distinct.dedup();
            let class = labels
                .iter()
                .map(|l| distinct.binary_search(l).unwrap_or(0) as u32)
                .collect();
            (distinct, class)
        };
        Ok(LabelGrid {
            nx,
            ny,
            labels: distinct,
            class,
        })
    }

    /// Cells per row.
    pub fn nx(&self) -> usize {
        self.nx
    }

    /// Rows.
    pub fn ny(&self) -> usize {
        self.ny
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.class.len()
    }

    /// The distinct labels on the grid, ascending (`-1` first when present).
    pub fn labels(&self) -> &[i32] {
        &self.labels
    }

    /// The distinct classes of the 8 neighbours of cell (`ix`, `iy`) that differ from
    /// its own (clipped at the grid's edges), written into `out`; returns how many.
    /// "Neighbour" is the Moore neighbourhood, Chebyshev distance 1, the same metric
    /// as every neighbourhood in this module.
    fn foreign_neighbours(&self, ix: usize, iy: usize, out: &mut [u32; 8]) -> usize {
        let own = self.class[iy * self.nx + ix];
        let mut n = 0;
        let (x0, x1) = (ix.saturating_sub(1), (ix + 1).min(self.nx - 1));
        let (y0, y1) = (iy.saturating_sub(1), (iy + 1).min(self.ny - 1));
        for y in y0..=y1 {
            let row = &self.class[y * self.nx..(y + 1) * self.nx];
            for &c in &row[x0..=x1] {
                if c != own && !out[..n].contains(&c) {
                    out[n] = c;
                    n += 1;
                }
            }
        }
        n
    }

    /// Calls `f(cell, own_class, foreign_classes)` for every cell with at least one
    /// neighbour of another class. Such a cell lies on the boundary of its own basin
    /// and on the boundary of each foreign class.
    fn for_each_boundary_cell(&self, mut f: impl FnMut(usize, u32, &[u32])) {
        let mut buf = [0u32; 8];
        for iy in 0..self.ny {
            for ix in 0..self.nx {
                let n = self.foreign_neighbours(ix, iy, &mut buf);
                if n > 0 {
                    let cell = iy * self.nx + ix;
                    f(cell, self.class[cell], &buf[..n]);
                }
            }
        }
    }

    /// `true` for the cells with a neighbour of another class (the boundary cells).
    fn boundary_mask(&self) -> Vec<bool> {
        let mut mask = vec![false; self.cells()];
        self.for_each_boundary_cell(|cell, _, _| mask[cell] = true);
        mask
    }

    /// The largest box size of the scaling fits, min(nx, ny) / [`SCALE_DIVISOR`].
    fn max_scale(&self) -> usize {
        self.nx.min(self.ny) / SCALE_DIVISOR
    }
}

/// Chebyshev (chessboard) distance, in cells, from every cell to the nearest cell of
/// `set`; `u32::MAX` everywhere when `set` is empty. The two-pass 3x3 chamfer with unit
/// weights is exact for this metric (Rosenfeld and Pfaltz, J. ACM 13, 471 (1966)): a
/// shortest chessboard path is a chain of 8-neighbour steps, which the forward pass
/// propagates from above and the left and the backward pass from below and the right;
/// the path between two cells of a rectangle stays in it, so clipping changes nothing.
fn chebyshev_distance(nx: usize, ny: usize, set: &[bool]) -> Vec<u32> {
    let mut d: Vec<u32> = set.iter().map(|&s| if s { 0 } else { u32::MAX }).collect();
    let step = |v: u32| v.saturating_add(1);
    for iy in 0..ny {
        for ix in 0..nx {
            let i = iy * nx + ix;
            let mut m = d[i];
            if m == 0 {
                continue;
            }
            if ix > 0 {
                m = m.min(step(d[i - 1]));
            }
            if iy > 0 {
                let up = i - nx;
                m = m.min(step(d[up]));
                if ix > 0 {
                    m = m.min(step(d[up - 1]));
                }
                if ix + 1 < nx {
                    m = m.min(step(d[up + 1]));
                }
            }
            d[i] = m;
        }
    }
    for iy in (0..ny).rev() {
        for ix in (0..nx).rev() {
            let i = iy * nx + ix;
            let mut m = d[i];
            if m == 0 {
                continue;
            }
            if ix + 1 < nx {
                m = m.min(step(d[i + 1]));
            }
            if iy + 1 < ny {
                let down = i + nx;
                m = m.min(step(d[down]));
                if ix > 0 {
                    m = m.min(step(d[down - 1]));
                }
                if ix + 1 < nx {
                    m = m.min(step(d[down + 1]));
                }
            }
            d[i] = m;
        }
    }
    d
}

// ---------------------------------------------------------------------------------------
// 1. Basin fractions
// ---------------------------------------------------------------------------------------

/// The share of the grid one label holds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BasinFraction {
    /// The attractor id (`-1`: diverged).
    pub label: i32,
    /// Cells with this label.
    pub cells: usize,
    /// f = cells / N.
    pub fraction: f64,
    /// sqrt(f (1 - f) / N): the standard error of f *if the N cells were independent
    /// random start states*. A grid is not a random sample; see `grid_error_bound`.
    pub sampling_std_error: f64,
    /// Cells on this basin's boundary, both sides: cells of this label with a
    /// neighbour of another label, and cells of another label with a neighbour of
    /// this one.
    pub boundary_cells: usize,
    /// boundary_cells / N: a bound on |f - (true area fraction)| for the grid as it
    /// is, when the boundary is resolved (no structure finer than a cell).
    pub grid_error_bound: f64,
}

/// Basin fractions of a grid.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BasinFractions {
    /// N, the number of cells.
    pub cells: usize,
    /// One entry per label, ascending (`-1` first when present).
    pub basins: Vec<BasinFraction>,
    /// Cells with a neighbour of another label (any basins).
    pub boundary_cells: usize,
    /// boundary_cells / N.
    pub boundary_fraction: f64,
}

/// Basin fractions f_k = n_k / N with two error estimates.
///
/// `sampling_std_error` is the binomial sqrt(f (1 - f) / N), right for N start states
/// drawn at random, which is how basin stability is usually estimated (Menck, Heitzig,
/// Marwan and Kurths, Nat. Phys. 9, 89 (2013)). Grid cells are not independent: a
/// smooth basin's grid estimate is wrong only in the cells its boundary cuts, each by
/// at most one cell's area. Those are the cells with a neighbour across the boundary,
/// so |f_grid - f_true| <= `grid_error_bound` = (boundary cells) / N. On an n x n grid
/// with a smooth boundary that is ~ c / n, the same order as the binomial error, but a
/// hard bound, not a standard deviation; the actual error is usually far smaller, as
/// the cut cells' errors have both signs and cancel along the boundary. For a fractal
/// boundary the bound holds only down to the structure the grid resolves.
pub fn basin_fractions(grid: &LabelGrid) -> BasinFractions {
    let k = grid.labels.len();
    let mut counts = vec![0usize; k];
    for &c in &grid.class {
        counts[c as usize] += 1;
    }
    let mut boundary = vec![0usize; k];
    let mut boundary_cells = 0usize;
    grid.for_each_boundary_cell(|_, own, foreign| {
        boundary_cells += 1;
        boundary[own as usize] += 1;
        for &c in foreign {
            boundary[c as usize] += 1;
        }
    });
    let n = grid.cells() as f64;
    let basins = (0..k)
        .map(|i| {
            let f = counts[i] as f64 / n;
            BasinFraction {
                label: grid.labels[i],
                cells: counts[i],
                fraction: f,
                sampling_std_error: (f * (1.0 - f) / n).sqrt(),
                boundary_cells: boundary[i],
                grid_error_bound: boundary[i] as f64 / n,
            }
        })
        .collect();
    BasinFractions {
        cells: grid.cells(),
        basins,
        boundary_cells,
        boundary_fraction: boundary_cells as f64 / n,
    }
}

// ---------------------------------------------------------------------------------------
// 2. Basin entropy
// ---------------------------------------------------------------------------------------

/// Basin entropy S_b and boundary basin entropy S_bb (Daza et al., Sci. Rep. 6, 31416
/// (2016)), in nats.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BasinEntropy {
    /// Box side in cells.
    pub eps: usize,
    /// Boxes per row (a right-edge strip narrower than a box is dropped).
    pub boxes_x: usize,
    /// Boxes per column (a bottom strip narrower than a box is dropped).
    pub boxes_y: usize,
    /// N, the number of boxes.
    pub boxes: usize,
    /// Cells dropped at the right and bottom edges (they fill no whole box).
    pub dropped_cells: usize,
    /// N_b, boxes holding more than one label.
    pub boundary_boxes: usize,
    /// Classes on the grid (the diverged `-1` counts as one); ln of it bounds S_b.
    pub classes: usize,
    /// S_b = (1/N) sum_i S_i, S_i = -sum_j p_ij ln p_ij.
    pub s_b: f64,
    /// S_bb = (1/N_b) sum_i S_i; `None` when no box holds two labels.
    pub s_bb: Option<f64>,
    /// S_bb > ln 2, the paper's sufficient condition for a fractal boundary.
    pub fractal_by_sbb: bool,
}

/// Basin entropy of `grid` in boxes of `eps` x `eps` cells (default
/// [`DEFAULT_ENTROPY_BOX`]).
///
/// The boxes tile the grid from cell (0, 0); a strip narrower than `eps` at the right
/// or bottom edge is dropped (reported in `dropped_cells`). In box i, p_ij is the share
/// of its cells with label j (the diverged `-1` is a label like any other) and
/// S_i = -sum_j p_ij ln p_ij. S_b is the mean over all N boxes, S_bb the sum over boxes
/// divided by the N_b boxes with more than one label. S_bb > ln 2 is sufficient for a
/// fractal boundary (Daza et al. 2016, the "ln 2 criterion"): a smooth boundary cuts most
/// of its boxes into two unequal parts, whose entropy is below ln 2.
///
/// The plug-in S_i of a box with n = eps^2 cells is biased low by about
/// (m - 1) / (2 n) for m equally likely labels (Miller-Madow): 0.02 per extra label at
/// eps = 5.
pub fn basin_entropy(grid: &LabelGrid, eps: usize) -> Result<BasinEntropy> {
    if eps == 0 || eps > grid.nx.min(grid.ny) {
        return Err(Error::invalid(
            "eps",
            eps,
            format!(
                "the box side must be 1..={} cells (the grid is {} x {})",
                grid.nx.min(grid.ny),
                grid.nx,
                grid.ny
            ),
        ));
    }
    let k = grid.labels.len();
    let (bx, by) = (grid.nx / eps, grid.ny / eps);
    let mut counts = vec![0u32; bx * k];
    let mut total = 0.0;
    let mut boundary_boxes = 0usize;
    let per_box = (eps * eps) as f64;
    for jy in 0..by {
        counts.fill(0);
        for iy in jy * eps..(jy + 1) * eps {
            let row = &grid.class[iy * grid.nx..iy * grid.nx + bx * eps];
            for (ix, &c) in row.iter().enumerate() {
                counts[(ix / eps) * k + c as usize] += 1;
            }
        }
        for b in 0..bx {
            let box_counts = &counts[b * k..(b + 1) * k];
            let mut s = 0.0;
            let mut present = 0;
            for &n in box_counts {
                if n > 0 {
                    present += 1;
                    let p = n as f64 / per_box;
                    s -= p * p.ln();
                }
            }
            if present > 1 {
                boundary_boxes += 1;
                total += s;
            }
        }
    }
    let boxes = bx * by;
    let s_bb = (boundary_boxes > 0).then(|| total / boundary_boxes as f64);
    Ok(BasinEntropy {
        eps,
        boxes_x: bx,
        boxes_y: by,
        boxes,
        dropped_cells: grid.cells() - boxes * eps * eps,
        boundary_boxes,
        classes: k,
        s_b: total / boxes as f64,
        s_bb,
        fractal_by_sbb: s_bb.is_some_and(|s| s > std::f64::consts::LN_2),
    })
}

// ---------------------------------------------------------------------------------------
// 3. Uncertainty exponent and box-counting dimension
// ---------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------
// 4. Wada merge test
// ---------------------------------------------------------------------------------------

/// Settings of [`wada_merge_test`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct WadaOptions {
    /// Largest fattening radius r tried (cells).
    pub r_max: usize,
    /// Largest mismatch fraction still counted as agreement: a few boundary cells off
    /// are numerical noise (unresolved filaments, non-converged cells).
    pub tolerance: f64,
    /// Treat the diverged cells (`-1`) as a basin of their own (the basin of infinity);
    /// otherwise they belong to "the rest" of every merged system and are not tested.
    pub diverged_is_basin: bool,
}

impl Default for WadaOptions {
    fn default() -> Self {
        WadaOptions {
            r_max: 5,
            tolerance: 0.05,
            diverged_is_basin: false,
        }
    }
}

/// Agreement of the boundaries of two merged systems.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct WadaPair {
    /// The first basin's label.
    pub a: i32,
    /// The second basin's label.
    pub b: i32,
    /// Share of the cells of boundary(a vs rest) farther than r from boundary(b vs rest).
    pub a_not_near_b: f64,
    /// Share of the cells of boundary(b vs rest) farther than r from boundary(a vs rest).
    pub b_not_near_a: f64,
    /// The larger of the two.
    pub mismatch: f64,
}

/// The boundary of one basin against all the others merged.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MergedBoundary {
    /// The basin's label.
    pub label: i32,
    /// Cells of its boundary (both sides).
    pub cells: usize,
}

/// Outcome of the Wada merge test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WadaTest {
    /// The settings used.
    pub options: WadaOptions,
    /// The basins tested (labels).
    pub basins: Vec<i32>,
    /// Whether the test applies (3 or more basins).
    pub applicable: bool,
    /// Why it does not apply.
    pub not_applicable: Option<String>,
    /// Per basin, its merged system's boundary.
    pub boundaries: Vec<MergedBoundary>,
    /// The radius the pairs below are given at: the smallest r in 1..=r_max at which
    /// every pair agrees, or r_max when none does.
    pub r: usize,
    /// Per pair of basins, the mismatch at `r`.
    pub pairs: Vec<WadaPair>,
    /// The largest mismatch over the pairs at `r`.
    pub max_mismatch: f64,
    /// Every pair agrees within `tolerance` at `r`.
    pub wada: bool,
}

/// The merging method of Daza, Wagemakers and Sanjuan, "Ascertaining when a basin is
/// Wada: the merging method", Sci. Rep. 8, 9954 (2018).
///
/// For each basin A, merge all the others into one: the boundary of A against the rest
/// is the set of cells of A with a neighbour not in A and cells not in A with a
/// neighbour in A. A Wada boundary is the one boundary that merging leaves unchanged:
/// all these boundaries coincide. On a grid they coincide up to the resolution, so each
/// is fattened by r cells (Chebyshev) and, for every pair (A, B), the test counts the
/// share of boundary(A) cells farther than r from boundary(B) and vice versa (divided by
/// the boundary's own size, so the result does not depend on the grid's area; the
/// Attractors.jl implementation divides by the grid's cells). The basins are Wada when
/// every share is at most `tolerance` for some r <= `r_max`. Three sectors meeting at
/// one point are not Wada: half of each boundary faces the third basin only, and the
/// shares stay near 1/2 until r grows to the size of the grid.
///
/// Needs 3 or more basins; the diverged cells are one of them only with
/// `diverged_is_basin`.
pub fn wada_merge_test(grid: &LabelGrid, options: &WadaOptions) -> Result<WadaTest> {
    if options.r_max == 0 {
        return Err(Error::invalid(
            "r_max",
            0,
            "the fattening radius must be >= 1",
        ));
    }
    if !(0.0..1.0).contains(&options.tolerance) {
        return Err(Error::invalid(
            "tolerance",
            options.tolerance,
            "a mismatch fraction in [0, 1)",
        ));
    }
    let tested: Vec<u32> = (0..grid.labels.len() as u32)
        .filter(|&c| options.diverged_is_basin || grid.labels[c as usize] >= 0)
        .collect();
    let basins: Vec<i32> = tested.iter().map(|&c| grid.labels[c as usize]).collect();
    let mut result = WadaTest {
        options: *options,
        basins: basins.clone(),
        applicable: false,
        not_applicable: None,
        boundaries: Vec::new(),
        r: options.r_max,
        pairs: Vec::new(),
        max_mismatch: 0.0,
        wada: false,
    };
    if tested.len() < 3 {
        result.not_applicable = Some(format!(
            "the Wada property needs 3 or more basins; the grid has {}{}",
            tested.len(),
            if !options.diverged_is_basin && grid.labels.first() == Some(&-1) {
                " (the diverged cells are not counted as a basin)"
            } else {
                ""
            }
        ));
        return Ok(result);
    }
    result.applicable = true;
    let k = tested.len();
    // slot[class] = position of the class among the tested basins.
    let mut slot = vec![usize::MAX; grid.labels.len()];
    for (s, &c) in tested.iter().enumerate() {
        slot[c as usize] = s;
    }
    // Every boundary cell's memberships, as (cell, slot) pairs: a cell is on the merged
    // boundary of its own basin and of each foreign neighbour's basin.
    let mut members: Vec<(u32, u32)> = Vec::new();
    grid.for_each_boundary_cell(|cell, own, foreign| {
        if slot[own as usize] != usize::MAX {
            members.push((cell as u32, slot[own as usize] as u32));
        }
        for &c in foreign {
            if slot[c as usize] != usize::MAX {
                members.push((cell as u32, slot[c as usize] as u32));
            }
        }
    });
    let mut sizes = vec![0usize; k];
    for &(_, s) in &members {
        sizes[s as usize] += 1;
    }
    result.boundaries = (0..k)
        .map(|s| MergedBoundary {
            label: basins[s],
            cells: sizes[s],
        })
        .collect();
    // far[j][i][r - 1] = cells of boundary i farther than r from boundary j.
    let r_max = options.r_max;
    let mut far = vec![vec![vec![0usize; r_max]; k]; k];
    let mut mask = vec![false; grid.cells()];
    for (j, far_j) in far.iter_mut().enumerate() {
        mask.fill(false);
        for &(cell, s) in &members {
            if s as usize == j {
                mask[cell as usize] = true;
            }
        }
        let dist = chebyshev_distance(grid.nx, grid.ny, &mask);
        for &(cell, s) in &members {
            let i = s as usize;
            if i == j {
                continue;
            }
            let d = dist[cell as usize] as usize;
            // Farther than r for r = 1..min(d - 1, r_max).
            for slot in far_j[i].iter_mut().take(d.saturating_sub(1).min(r_max)) {
                *slot += 1;
            }
        }
    }
    let share = |i: usize, j: usize, r: usize| -> f64 {
        if sizes[i] == 0 {
            0.0
        } else {
            far[j][i][r - 1] as f64 / sizes[i] as f64
        }
    };
    let worst = |r: usize| -> f64 {
        let mut w: f64 = 0.0;
        for i in 0..k {
            for j in 0..k {
                if i != j {
                    w = w.max(share(i, j, r));
                }
            }
        }
        w
    };
    let r = (1..=r_max)
        .find(|&r| worst(r) <= options.tolerance)
        .unwrap_or(r_max);
    result.r = r;
    for i in 0..k {
        for j in i + 1..k {
            let (ab, ba) = (share(i, j, r), share(j, i, r));
            result.pairs.push(WadaPair {
                a: basins[i],
                b: basins[j],
                a_not_near_b: ab,
                b_not_near_a: ba,
                mismatch: ab.max(ba),
            });
        }
    }
    result.max_mismatch = worst(r);
    result.wada = result.max_mismatch <= options.tolerance;
    Ok(result)
}

// ---------------------------------------------------------------------------------------
// 5. Classification
// ---------------------------------------------------------------------------------------

/// What a boundary is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundaryKind {
    /// One label: nothing to classify.
    NoBoundary,
    /// alpha within [`SMOOTH_ALPHA_BAND`] of 1 and S_bb <= ln 2.
    Smooth,
    /// S_bb > ln 2, or alpha clearly below 1.
    Fractal,
    /// Neither test is conclusive (e.g. alpha unavailable or between the bands).
    Undetermined,
}

/// A boundary's class with the evidence.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoundaryClassification {
    /// The verdict.
    pub kind: BoundaryKind,
    /// Which criteria fired, in words.
    pub criteria: Vec<String>,
    /// S_bb > ln 2 fired.
    pub sbb_above_ln2: bool,
    /// alpha < 1 - max(2 se, [`ALPHA_RESOLUTION`]) fired (D clearly above 1).
    pub alpha_below_one: bool,
    /// |alpha - 1| <= [`SMOOTH_ALPHA_BAND`].
    pub alpha_near_one: bool,
    /// The basin entropy used.
    pub entropy: BasinEntropy,
    /// The uncertainty exponent used.
    pub uncertainty: UncertaintyExponent,
    /// The box-counting dimension (reported, not used in the verdict).
    pub box_counting: Option<BoxCountingDimension>,
}

/// Smooth or fractal from measures already computed.
///
/// Fractal when S_bb > ln 2 (sufficient, Daza et al. 2016) or when D = 2 - alpha exceeds
/// 1 by more than two standard errors *and* by more than [`ALPHA_RESOLUTION`] (the
/// grid's own systematic error on alpha; the fit's standard error alone is too small to
/// trust). Smooth when alpha is within [`SMOOTH_ALPHA_BAND`] of 1 and S_bb <= ln 2.
/// Fractal evidence wins when both fire (possible for alpha in [0.90, 0.95)).
pub fn classify_measures(
    entropy: &BasinEntropy,
    uncertainty: &UncertaintyExponent,
    box_counting: Option<&BoxCountingDimension>,
) -> BoundaryClassification {
    let ln2 = std::f64::consts::LN_2;
    let mut criteria = Vec::new();
    let sbb_above_ln2 = entropy.fractal_by_sbb;
    let (mut alpha_below_one, mut alpha_near_one) = (false, false);
    if let Some(s) = entropy.s_bb {
        criteria.push(if sbb_above_ln2 {
            format!(
                "S_bb = {s:.4} > ln 2 = {ln2:.4} (eps = {}): fractal",
                entropy.eps
            )
        } else {
            format!(
                "S_bb = {s:.4} <= ln 2 (eps = {}): not conclusive alone",
                entropy.eps
            )
        });
    }
    match uncertainty.fit {
        Some(fit) => {
            let (alpha, se) = (fit.slope, fit.slope_std_error);
            alpha_below_one = alpha < 1.0 - (2.0 * se).max(ALPHA_RESOLUTION);
            alpha_near_one = (alpha - 1.0).abs() <= SMOOTH_ALPHA_BAND;
            criteria.push(format!(
                "alpha = {alpha:.4} +- {se:.4} (D = {:.4}, eps {}..{}){}",
                fit.dimension,
                fit.eps_min,
                fit.eps_max,
                if alpha_below_one {
                    ": D > 1 beyond 2 standard errors and the grid's resolution, fractal"
                } else if alpha_near_one {
                    ": within 0.1 of 1, smooth-like"
                } else {
                    ": neither clearly below 1 nor within 0.1 of it"
                }
            ));
        }
        None => criteria.push(format!(
            "alpha: not fitted ({})",
            uncertainty.not_fitted.as_deref().unwrap_or("unknown")
        )),
    }
    let kind = if uncertainty.boundary_cells == 0 {
        criteria.push("no cell has a neighbour of another label".into());
        BoundaryKind::NoBoundary
    } else if sbb_above_ln2 || alpha_below_one {
        BoundaryKind::Fractal
    } else if alpha_near_one {
        BoundaryKind::Smooth
    } else {
        BoundaryKind::Undetermined
    };
    BoundaryClassification {
        kind,
        criteria,
        sbb_above_ln2,
        alpha_below_one,
        alpha_near_one,
        entropy: entropy.clone(),
        uncertainty: uncertainty.clone(),
        box_counting: box_counting.cloned(),
    }
}

/// Computes the basin entropy (boxes of `eps` cells), the uncertainty exponent and the
/// box-counting dimension, and classifies the boundary by [`classify_measures`].
pub fn classify_boundary(grid: &LabelGrid, eps: usize) -> Result<BoundaryClassification> {
    let entropy = basin_entropy(grid, eps)?;
    let uncertainty = uncertainty_exponent(grid);
    let boxes = boundary_box_dimension(grid);
    Ok(classify_measures(&entropy, &uncertainty, Some(&boxes)))
}

/// Every measure of one basin, as `basin_metrics.json` holds them: the fractions, the
/// basin entropies at box `eps`, the uncertainty exponent, the boundary's box-counting
/// dimension, the Wada merge test (with 3 or more basins) and the smooth/fractal verdict.
/// A measure the grid is too small for is `None` with the reason in `notes`.
#[derive(Clone, Debug, Serialize)]
pub struct BasinMetrics {
    /// Fractions and their errors.
    pub fractions: BasinFractions,
    /// S_b and S_bb, when the grid holds at least one box of `eps` cells.
    pub entropy: Option<BasinEntropy>,
    /// alpha (and D = 2 - alpha) by the uncertain fraction on the grid.
    pub uncertainty: UncertaintyExponent,
    /// Box-counting dimension of the boundary.
    pub box_counting: BoxCountingDimension,
    /// The Wada merge test.
    pub wada: Option<WadaTest>,
    /// Smooth or fractal, with the criteria that fired.
    pub boundary: Option<BoundaryClassification>,
    /// Why a measure is missing.
    pub notes: Vec<String>,
}

/// The side of the entropy boxes (field `entropy-box`): `given`, or
/// [`DEFAULT_ENTROPY_BOX`] capped by the grid's shorter side; it must fit the grid.
pub fn entropy_box(given: Option<usize>, nx: usize, ny: usize) -> Result<usize> {
    let short = nx.min(ny);
    let eps = given.unwrap_or(DEFAULT_ENTROPY_BOX.min(short));
    if eps == 0 || eps > short {
        return Err(Error::invalid(
            "entropy-box",
            eps,
            format!("must be in 1..={short} (the shorter side of the grid)"),
        ));
    }
    Ok(eps)
}

/// [`basin_metrics`] of a computed basin's labels: a refinement's -2 (an attractor the
/// coarse catalogue lacks, [`crate::refine`]) counts as one more basin, the next free id.
pub fn basin_labels_metrics(
    labels: &[i32],
    nx: usize,
    ny: usize,
    eps: usize,
) -> Result<BasinMetrics> {
    let other = labels.iter().copied().max().unwrap_or(0).max(-1) + 1;
    if labels.contains(&-2) {
        let relabelled: Vec<i32> = labels
            .iter()
            .map(|&l| if l == -2 { other } else { l })
            .collect();
        basin_metrics(&relabelled, nx, ny, eps)
    } else {
        basin_metrics(labels, nx, ny, eps)
    }
}

/// Where `basin_metrics.json` says its measures are defined.
pub const DEFINITIONS: &str = "docs/basin-measures.md: fractions with the binomial (random sampling) error and the grid's boundary-cell bound; S_b, S_bb in nats, boxes of entropy.eps cells (Daza et al. 2016), S_bb > ln 2 sufficient for a fractal boundary; alpha from the uncertain fraction f(eps) ~ eps^alpha on the grid, D = 2 - alpha; box-counting dimension of the boundary; Wada merge test (Daza et al. 2018) with 3 or more basins";

/// `basin_metrics.json`: the measures, the re-integration estimate of the uncertainty
/// exponent (null without one), and where the definitions are. The Python package
/// returns the same dictionary.
#[derive(Clone, Debug, Serialize)]
pub struct MetricsRecord<'a> {
    /// The measures, at the top level.
    #[serde(flatten)]
    pub metrics: &'a BasinMetrics,
    /// The uncertainty exponent by re-integration.
    pub uncertainty_reintegration: Option<&'a crate::uncertainty::Reintegration>,
    /// [`DEFINITIONS`].
    pub definitions: &'static str,
}

impl<'a> MetricsRecord<'a> {
    /// The record of `metrics` and `reintegration`.
    pub fn new(
        metrics: &'a BasinMetrics,
        reintegration: Option<&'a crate::uncertainty::Reintegration>,
    ) -> Self {
        MetricsRecord {
            metrics,
            uncertainty_reintegration: reintegration,
            definitions: DEFINITIONS,
        }
    }
}

/// Computes [`BasinMetrics`] of an `[ny, nx]` label grid with entropy boxes of `eps`.
pub fn basin_metrics(labels: &[i32], nx: usize, ny: usize, eps: usize) -> Result<BasinMetrics> {
    let grid = LabelGrid::new(labels, nx, ny)?;
    let mut notes = Vec::new();
    let entropy = match basin_entropy(&grid, eps) {
        Ok(e) => Some(e),
        Err(e) => {
            notes.push(format!("basin entropy: {e}"));
            None
        }
    };
    let uncertainty = uncertainty_exponent(&grid);
    let box_counting = boundary_box_dimension(&grid);
    let wada = match wada_merge_test(&grid, &WadaOptions::default()) {
        Ok(w) => Some(w),
        Err(e) => {
            notes.push(format!("Wada test: {e}"));
            None
        }
    };
    let boundary = entropy
        .as_ref()
        .map(|e| classify_measures(e, &uncertainty, Some(&box_counting)));
    Ok(BasinMetrics {
        fractions: basin_fractions(&grid),
        entropy,
        uncertainty,
        box_counting,
        wada,
        boundary,
        notes,
    })
}

impl BasinMetrics {
    /// One line for a summary: S_b, S_bb, alpha, D, Wada, the verdict.
    pub fn summary(&self) -> String {
        let mut parts = Vec::new();
        if let Some(e) = &self.entropy {
            parts.push(format!("S_b = {:.4}", e.s_b));
            if let Some(sbb) = e.s_bb {
                parts.push(format!(
                    "S_bb = {sbb:.4}{} (box {} cells)",
                    if e.fractal_by_sbb { " > ln 2" } else { "" },
                    e.eps
                ));
            }
        }
        if let Some(fit) = &self.uncertainty.fit {
            parts.push(format!(
                "alpha = {:.3} +- {:.3}, D = {:.3}",
                fit.slope, fit.slope_std_error, fit.dimension
            ));
        }
        if let Some(w) = self.wada.as_ref().filter(|w| w.applicable) {
            parts.push(if w.wada {
                "Wada".into()
            } else {
                "not Wada".into()
            });
        }
        if let Some(b) = &self.boundary {
            parts.push(format!("boundary {:?}", b.kind).to_lowercase());
        }
        parts.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: the distance to the nearest set cell, by looking at all of them.
    fn brute_distance(nx: usize, ny: usize, set: &[bool]) -> Vec<u32> {
        let mut d = vec![u32::MAX; nx * ny];
        for (i, di) in d.iter_mut().enumerate() {
            let (x, y) = (i % nx, i / nx);
            for (j, &s) in set.iter().enumerate() {
                if s {
                    let (u, v) = (j % nx, j / nx);
                    *di = (*di).min(x.abs_diff(u).max(y.abs_diff(v)) as u32);
                }
            }
        }
        d
    }

    #[test]
    fn chamfer_transform_is_the_exact_chebyshev_distance() {
        let (nx, ny) = (37, 23);
        let mut state = 12345u64;
        let set: Vec<bool> = (0..nx * ny)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 33).is_multiple_of(97)
            })
            .collect();
        assert!(set.iter().any(|&s| s));
        assert_eq!(
            chebyshev_distance(nx, ny, &set),
            brute_distance(nx, ny, &set)
        );
        let empty = vec![false; nx * ny];
        assert!(
            chebyshev_distance(nx, ny, &empty)
                .iter()
                .all(|&d| d == u32::MAX)
        );
    }

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

    #[test]
    fn invalid_grids_are_refused() {
        assert!(LabelGrid::new(&[0, 1, 2], 2, 2).is_err());
        assert!(LabelGrid::new(&[0, -2, 1, 1], 2, 2).is_err());
        assert!(LabelGrid::new(&[], 0, 0).is_err());
        let g = LabelGrid::new(&[5, -1, 1_000_000_000, 5], 2, 2).unwrap();
        assert_eq!(g.labels(), &[-1, 5, 1_000_000_000]);
        assert!(basin_entropy(&g, 3).is_err());
        assert!(basin_entropy(&g, 0).is_err());
    }
}
