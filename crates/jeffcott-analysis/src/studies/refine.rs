//! Boundary refinement of a basin: cells with a differently labelled neighbour are
//! subdivided 2 x 2 and integrated, level after level, so the boundary is resolved at
//! ((n - 1) 2^K + 1)^2 points while the interiors of smooth basins are not recomputed.
//!
//! The grid is a lattice of start states including both ends of each axis; one level
//! inserts the midpoints, so level k has (n - 1) 2^k + 1 points per axis and every point
//! of level k - 1 is a point of level k (index doubled). At level k the points computed
//! are the new ones (an odd index) within one fine step of a *boundary point* of level
//! k - 1 (a point with a 4-neighbour of another label); every other new point takes the
//! label of its parent (the level k - 1 point at half its index, rounded down). Each
//! level's lanes run on the run engine (stage `refine<k>`, resumable) and are labelled
//! with the coarse basin's catalogue (`-2`: an attractor the coarse grid did not find);
//! with early exit a lane recognised on one of its cycles retires with that label
//! ([`crate::early::label_lanes`]).

use crate::basin::BasinSpec;
use crate::catalogue::Catalogue;
use crate::run::lanes::{Control, LaneUnits, Split};
use crate::run::{Array, Unit, UnitStore};
use jeffcott_core::ensemble::{EnsembleResult, EnsembleSpec};
use jeffcott_core::error::{Error, Result};
use serde::Serialize;

/// Levels at most.
pub const MAX_LEVELS: u32 = 8;

/// A refined basin.
#[derive(Clone, Debug)]
pub struct Refined {
    /// Points per axis at the finest level.
    pub nx: usize,
    /// See `nx`.
    pub ny: usize,
    /// Labels [ny, nx] at the finest level (row-major, row iy at the iy-th y value).
    pub labels: Vec<i32>,
    /// 1 where the label was computed (at any level), 0 where it was filled from a parent.
    pub computed: Vec<u8>,
    /// What each level cost.
    pub levels: Vec<Level>,
}

impl Refined {
    /// Lanes integrated by all levels, besides the coarse grid.
    pub fn lanes(&self) -> usize {
        self.levels.iter().map(|l| l.lanes).sum()
    }

    /// Points of the finest grid.
    pub fn points(&self) -> usize {
        self.nx * self.ny
    }
}

/// One refinement level.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Level {
    /// Level (1 = the first refinement).
    pub level: u32,
    /// Points per axis.
    pub nx: usize,
    /// See `nx`.
    pub ny: usize,
    /// Lanes integrated at this level.
    pub lanes: usize,
    /// Boundary points of the previous level that were refined around.
    pub boundary_points: usize,
    /// What early exit saved at this level (`None`: it ran without, or nothing ran).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub early_exit: Option<crate::early::EarlySaved>,
}

/// Whether point (i, j) of a [ny, nx] label grid has a 4-neighbour of another label.
pub fn on_boundary(labels: &[i32], nx: usize, ny: usize, i: usize, j: usize) -> bool {
    let l = labels[j * nx + i];
    (i > 0 && labels[j * nx + i - 1] != l)
        || (i + 1 < nx && labels[j * nx + i + 1] != l)
        || (j > 0 && labels[(j - 1) * nx + i] != l)
        || (j + 1 < ny && labels[(j + 1) * nx + i] != l)
}

/// Checks a refinement of `levels` of a basin of `nx` x `ny` cells (field `refine`):
/// at most [`MAX_LEVELS`], labels only (no lambda_1), and a finest grid of at most
/// [`crate::basin::MAX_BASIN_CELLS`] points.
pub fn check_levels(levels: u32, lyapunov: bool, nx: usize, ny: usize) -> Result<()> {
    if levels > MAX_LEVELS {
        return Err(Error::invalid(
            "refine",
            levels,
            format!("must be in 0..={MAX_LEVELS}"),
        ));
    }
    if levels > 0 && lyapunov {
        return Err(Error::invalid(
            "refine",
            levels,
            "a refinement computes labels only; compute lambda_1 (--lyapunov) without it",
        ));
    }
    let side = |n: usize| ((n as u64).saturating_sub(1) << levels) + 1;
    let fine = side(nx).saturating_mul(side(ny));
    let max = crate::basin::MAX_BASIN_CELLS;
    if fine > max {
        return Err(Error::invalid(
            "refine",
            levels,
            format!("the finest grid would have {fine} points; at most {max}"),
        ));
    }
    Ok(())
}

/// The basin at the refined resolution: the grid of `f`, its labels, and the
/// catalogue's basin and diverged fractions recounted over it.
pub fn refined_basin(
    spec: &BasinSpec,
    mut res: crate::basin::BasinResult,
    f: &Refined,
) -> (BasinSpec, crate::basin::BasinResult) {
    let mut fine = spec.clone();
    fine.x.n = f.nx;
    fine.y.n = f.ny;
    let total = f.labels.len() as f64;
    let share = |l: i32| f.labels.iter().filter(|&&x| x == l).count() as f64 / total;
    for a in &mut res.catalogue.attractors {
        a.basin_fraction = share(a.id as i32);
    }
    res.catalogue.diverged_fraction = share(-1);
    res.labels = f.labels.clone();
    (fine, res)
}

/// The next level's labels and computed flags (both [fy, fx], fx = 2 nx - 1) filled
/// from their parents at level `cur` ([ny, nx]): the even-even points are the previous
/// level's, and only they keep their computed flag.
fn from_parents(cur: &[i32], computed: &[u8], nx: usize, ny: usize) -> (Vec<i32>, Vec<u8>) {
    let (fx, fy) = ((nx - 1) * 2 + 1, (ny - 1) * 2 + 1);
    let mut next = vec![0i32; fx * fy];
    let mut comp = vec![0u8; fx * fy];
    for b in 0..fy {
        for a in 0..fx {
            next[b * fx + a] = cur[(b / 2) * nx + a / 2];
            if a % 2 == 0 && b % 2 == 0 {
                comp[b * fx + a] = computed[(b / 2) * nx + a / 2];
            }
        }
    }
    (next, comp)
}

/// The new points of the next level (indices into its [fy, fx] grid, row-major)
/// around the boundary points of level `cur` ([ny, nx]), and how many boundary points
/// that level has.
fn new_points_near_boundary(cur: &[i32], nx: usize, ny: usize) -> (Vec<usize>, usize) {
    let (fx, fy) = ((nx - 1) * 2 + 1, (ny - 1) * 2 + 1);
    let mut todo = vec![false; fx * fy];
    let mut boundary = 0;
    for j in 0..ny {
        for i in 0..nx {
            if !on_boundary(cur, nx, ny, i, j) {
                continue;
            }
            boundary += 1;
            for db in -1i64..=1 {
                for da in -1i64..=1 {
                    let (a, b) = (2 * i as i64 + da, 2 * j as i64 + db);
                    if a < 0 || b < 0 || a >= fx as i64 || b >= fy as i64 {
                        continue;
                    }
                    let (a, b) = (a as usize, b as usize);
                    if a % 2 == 1 || b % 2 == 1 {
                        todo[b * fx + a] = true;
                    }
                }
            }
        }
    }
    ((0..fx * fy).filter(|&p| todo[p]).collect(), boundary)
}

/// Refines `labels` ([ny, nx], the basin of `spec`) `levels` times.
#[allow(clippy::too_many_arguments)]
pub fn refine(
    spec: &BasinSpec,
    catalogue: &Catalogue,
    labels: &[i32],
    levels: u32,
    engine: &crate::backend::Engine,
    store: &dyn UnitStore,
    ctl: Control,
) -> Result<Refined> {
    if levels > MAX_LEVELS {
        return Err(Error::invalid(
            "refine",
            levels,
            format!("must be in 0..={MAX_LEVELS}"),
        ));
    }
    let (mut nx, mut ny) = (spec.x.n, spec.y.n);
    let mut cur = labels.to_vec();
    let mut computed = vec![1u8; nx * ny];
    let mut out_levels = Vec::new();
    for k in 1..=levels {
        let (fx, fy) = ((nx - 1) * 2 + 1, (ny - 1) * 2 + 1);
        let (mut next, mut comp) = from_parents(&cur, &computed, nx, ny);
        let (points, boundary) = new_points_near_boundary(&cur, nx, ny);
        // The level's axes: the same bounds, more points (the coarse points keep their
        // values bit for bit, range_value's index scaling by a power of 2).
        let (ax, ay) = (
            crate::basin::Axis { n: fx, ..spec.x },
            crate::basin::Axis { n: fy, ..spec.y },
        );
        let start = |p: usize| {
            let mut x = spec.base;
            x[spec.x.coord] = ax.value(p % fx);
            x[spec.y.coord] = ay.value(p / fx);
            x
        };
        let n = points.len();
        let per_lane =
            (spec.transient + spec.periods) as u64 * spec.lane.stepper.steps_per_period as u64;
        let unit = crate::run::unit_lanes(n, per_lane);
        let split = Split::new(n, unit);
        let count = split.count();
        let stage = format!("refine{k}");
        let ensemble = |u: usize| spec.ensemble(points[split.range(u)].iter().map(|&p| start(p)));
        let reduce = |_u: usize, _e: &EnsembleSpec, r: EnsembleResult| {
            let labels = catalogue.label_lanes(&r);
            Ok(Unit::new("").with("labels", Array::I32(labels)))
        };
        let early = |_u: usize, e: &EnsembleSpec, engine: &crate::backend::Engine, c: Control| {
            crate::early::labelled_unit(e, catalogue, engine, c)
        };
        let mut saved = None;
        if n > 0 {
            LaneUnits::new(&stage, split, &ensemble, &reduce)
                .lambda1(spec.lane.lyapunov)
                .computed_by(
                    spec.early_exit()
                        .then_some(&early as &crate::run::lanes::ComputeUnit),
                )
                .run(store, engine, ctl)?;
            let mut at = 0;
            for u in 0..count {
                let unit = store.load(&stage, u)?;
                let s = crate::early::unit_saved(&unit)?;
                crate::early::EarlySaved::accumulate(&mut saved, s);
                for &l in unit.i32s("labels")? {
                    next[points[at]] = l;
                    comp[points[at]] = 1;
                    at += 1;
                }
            }
        }
        out_levels.push(Level {
            level: k,
            nx: fx,
            ny: fy,
            lanes: n,
            boundary_points: boundary,
            early_exit: saved,
        });
        cur = next;
        computed = comp;
        nx = fx;
        ny = fy;
    }
    Ok(Refined {
        nx,
        ny,
        labels: cur,
        computed,
        levels: out_levels,
    })
}

#[cfg(test)]
mod tests {
    use super::on_boundary;

    #[test]
    fn boundary_points_have_a_four_neighbour_of_another_label() {
        // 3 x 3, a 1 in the corner: the corner and its two 4-neighbours are boundary.
        let l = [1, 0, 0, 0, 0, 0, 0, 0, 0];
        let b: Vec<bool> = (0..9)
            .map(|p| on_boundary(&l, 3, 3, p % 3, p / 3))
            .collect();
        assert_eq!(
            b,
            [true, true, false, true, false, false, false, false, false]
        );
    }
}
