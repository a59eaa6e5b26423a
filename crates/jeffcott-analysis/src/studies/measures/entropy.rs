//! Basin entropy S_b and boundary basin entropy S_bb of a label grid (Daza et al. 2016),
//! with their ln 2 test for a fractal boundary.

use super::LabelGrid;
use jeffcott_core::error::{Error, Result};
use serde::Serialize;

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
/// [`DEFAULT_ENTROPY_BOX`](super::DEFAULT_ENTROPY_BOX)).
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
