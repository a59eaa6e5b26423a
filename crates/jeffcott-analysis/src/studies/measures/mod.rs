//! Measures of a labelled basin grid: the numbers researchers quantify basins with.
//!
//! Input: labels row-major `[ny, nx]` (row `iy`, column `ix`, cell `iy * nx + ix`),
//! attractor ids `>= 0` and `-1` for diverged cells, as [`crate::basin`] writes them.
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

mod boundary;
mod entropy;
mod fractions;
mod scaling;
mod wada;

pub use boundary::{BoundaryClassification, BoundaryKind, classify_boundary, classify_measures};
pub use entropy::{BasinEntropy, basin_entropy};
pub use fractions::{BasinFraction, BasinFractions, basin_fractions};
pub use scaling::{
    BoxCountingDimension, LogLogFit, ScalePoint, UncertaintyExponent, boundary_box_dimension,
    log_log_line, uncertainty_exponent,
};
pub use wada::{MergedBoundary, WadaOptions, WadaPair, WadaTest, wada_merge_test};

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
    // Each pass takes, cell by cell in its order, the least of the cell's own distance
    // and one step from each of its neighbours the pass has already visited.
    let pass = |d: &mut [u32],
                cells: &mut dyn Iterator<Item = (usize, usize)>,
                visited: [(isize, isize); 4]| {
        for (ix, iy) in cells {
            let i = iy * nx + ix;
            if d[i] == 0 {
                continue;
            }
            let mut m = d[i];
            for (dx, dy) in visited {
                let (jx, jy) = (ix.checked_add_signed(dx), iy.checked_add_signed(dy));
                if let (Some(jx), Some(jy)) = (jx, jy)
                    && jx < nx
                    && jy < ny
                {
                    m = m.min(d[jy * nx + jx].saturating_add(1));
                }
            }
            d[i] = m;
        }
    };
    // Forward: rows top to bottom, each left to right (the left and the row above).
    let mut forward = (0..ny).flat_map(|iy| (0..nx).map(move |ix| (ix, iy)));
    pass(&mut d, &mut forward, [(-1, 0), (-1, -1), (0, -1), (1, -1)]);
    // Backward: rows bottom to top, each right to left (the right and the row below).
    let mut backward = (0..ny)
        .rev()
        .flat_map(|iy| (0..nx).rev().map(move |ix| (ix, iy)));
    pass(&mut d, &mut backward, [(1, 0), (-1, 1), (0, 1), (1, 1)]);
    d
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
            parts.push(b.kind.words().into());
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
