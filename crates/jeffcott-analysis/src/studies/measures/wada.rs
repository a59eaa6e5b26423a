//! The Wada merge test of Daza, Wagemakers and Sanjuan (2018): do the boundaries of
//! every basin against the rest merged coincide?

use super::{LabelGrid, chebyshev_distance};
use jeffcott_core::error::{Error, Result};
use serde::Serialize;

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
    let members = boundary_members(grid, &tested);
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
    let r_max = options.r_max;
    let far = far_counts(grid, &members, k, r_max);
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

/// Every boundary cell's memberships among the `tested` classes, as (cell, position in
/// `tested`) pairs: a cell is on the merged boundary of its own basin and of each
/// foreign neighbour's basin.
fn boundary_members(grid: &LabelGrid, tested: &[u32]) -> Vec<(u32, u32)> {
    // slot[class] = position of the class among the tested basins.
    let mut slot = vec![usize::MAX; grid.labels.len()];
    for (s, &c) in tested.iter().enumerate() {
        slot[c as usize] = s;
    }
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
    members
}

/// `far[j][i][r - 1]`: the cells of boundary i (of `k`, from `members`) farther than r
/// from boundary j, for r = 1..=`r_max`.
fn far_counts(
    grid: &LabelGrid,
    members: &[(u32, u32)],
    k: usize,
    r_max: usize,
) -> Vec<Vec<Vec<usize>>> {
    let mut far = vec![vec![vec![0usize; r_max]; k]; k];
    let mut mask = vec![false; grid.cells()];
    for (j, far_j) in far.iter_mut().enumerate() {
        mask.fill(false);
        for &(cell, s) in members {
            if s as usize == j {
                mask[cell as usize] = true;
            }
        }
        let dist = chebyshev_distance(grid.nx, grid.ny, &mask);
        for &(cell, s) in members {
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
    far
}
