//! Basin fractions f_k = n_k / N of a label grid, with the binomial sampling error and
//! the bound the grid itself puts on them (its boundary cells / N).

use super::LabelGrid;
use serde::Serialize;

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
