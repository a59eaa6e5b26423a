//! Partial catalogues: one work unit's attractors, stored in the unit instead of its
//! lanes' Poincare records, and absorbed into the catalogue of the whole run.

use super::identity::{CLOUD_POINTS, aperiodic_family, same};
use super::{Attractor, CatalogueBuilder, LaneClass};
use crate::classify::Class;
use jeffcott_core::model::{STATE_DIM, State};
use serde::Serialize;

/// An attractor of a partial catalogue (one work unit's lanes), with what it takes to
/// absorb it into the catalogue of the whole run ([`CatalogueBuilder::absorb`]): units
/// store these instead of their lanes' Poincare records.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct PartAttractor {
    /// The class (before the lambda_1 mean refines an aperiodic one).
    pub class: Class,
    /// Diameter of its Poincare set [m].
    pub size_m: f64,
    /// Representative points (cycle in canonical rotation, or the reference cloud).
    #[serde(skip)]
    pub points: Vec<State>,
    /// Its lanes in the unit.
    pub lanes: u64,
    /// The unit-local index of its first lane.
    pub first_lane: u64,
    /// Sum, count and range of its lanes' finite lambda_1.
    pub l1_sum: f64,
    /// See `l1_sum`.
    pub l1_n: u64,
    /// See `l1_sum`.
    pub l1_range: Option<(f64, f64)>,
}

impl CatalogueBuilder {
    /// Finishes a partial catalogue (one unit's lanes, `labels` as `add` returned them):
    /// aperiodic entries merged as in [`CatalogueBuilder::finish`], the attractors in id
    /// order, the labels remapped, and the number of diverged lanes.
    pub fn finish_part(mut self, mut labels: Vec<i32>) -> (Vec<PartAttractor>, Vec<i32>, u64) {
        let map = self.merge_clouds();
        for l in labels.iter_mut() {
            if *l >= 0 {
                *l = map[*l as usize];
            }
        }
        let parts = self
            .attractors
            .into_iter()
            .map(|a| PartAttractor {
                class: a.kind,
                size_m: a.size_m,
                points: a.points,
                lanes: a.lanes,
                first_lane: a.first_lane,
                l1_sum: a.l1_sum,
                l1_n: a.l1_n,
                l1_range: a.lambda1_range,
            })
            .collect();
        (parts, labels, self.diverged)
    }

    /// Absorbs an attractor of a partial catalogue whose lanes start at lane
    /// `lane_offset` of this catalogue; returns its id here. It joins the attractor it
    /// is the same as by the rules of the module docs (for aperiodic clouds in either
    /// direction, as the end merge compares them), else it becomes a new one. Lane
    /// counts are not touched: see [`CatalogueBuilder::add_lanes`].
    pub fn absorb(&mut self, p: &PartAttractor, lane_offset: u64) -> i32 {
        let lc = LaneClass {
            class: p.class,
            size: p.size_m,
            points: p.points.clone(),
            lambda1: f64::NAN,
        };
        let (cfg, w) = (self.cfg, self.omega);
        let found = self.attractors.iter().position(|a| {
            same(&cfg, w, &lc, a)
                || (a.period.is_none()
                    && aperiodic_family(p.class)
                    && same(
                        &cfg,
                        w,
                        &LaneClass {
                            class: a.kind,
                            size: a.size_m,
                            points: a.points.clone(),
                            lambda1: f64::NAN,
                        },
                        &Attractor {
                            kind: p.class,
                            size_m: p.size_m,
                            points: p.points.clone(),
                            ..a.clone()
                        },
                    ))
        });
        if let Some(k) = found {
            let a = &mut self.attractors[k];
            a.lanes += p.lanes;
            a.merge_lambda1(p.l1_sum, p.l1_n, p.l1_range);
            if a.period.is_none() && a.points.len() < CLOUD_POINTS {
                let room = CLOUD_POINTS - a.points.len();
                a.points.extend(p.points.iter().take(room));
            }
            return k as i32;
        }
        let id = self.attractors.len() as u32;
        let mut a = Attractor {
            id,
            class: p.class.label(),
            period: p.class.period(),
            omega: self.omega,
            lanes: p.lanes,
            basin_fraction: 0.0,
            size_m: p.size_m,
            points: p.points.clone(),
            first_lane: lane_offset + p.first_lane,
            lambda1: None,
            lambda1_range: None,
            kind: p.class,
            l1_sum: 0.0,
            l1_n: 0,
        };
        a.merge_lambda1(p.l1_sum, p.l1_n, p.l1_range);
        self.attractors.push(a);
        id as i32
    }

    /// Counts `lanes` more lanes of which `diverged` diverged (the lanes of absorbed
    /// partial catalogues).
    pub fn add_lanes(&mut self, lanes: u64, diverged: u64) {
        self.total += lanes;
        self.diverged += diverged;
    }
}

/// A work unit holding a partial catalogue: the lanes' `labels` (unit-local attractor
/// ids, -1 diverged), the attractors ([`PartAttractor`], their points flattened into the
/// `points` array) and the diverged count; read back by [`unit_parts`].
pub fn part_unit(labels: Vec<i32>, parts: &[PartAttractor], diverged: u64) -> crate::run::Unit {
    use crate::run::{Array, Unit};
    let counts: Vec<usize> = parts.iter().map(|p| p.points.len()).collect();
    Unit::new("")
        .with("labels", Array::I32(labels))
        .with(
            "points",
            Array::F64(
                parts
                    .iter()
                    .flat_map(|p| p.points.iter().flatten().copied())
                    .collect(),
            ),
        )
        .with_meta(&PartsMeta {
            parts,
            part_points: counts,
            diverged,
        })
}

/// The metadata of a [`part_unit`]: the attractors (their points in the unit's `points`
/// array), how many points each has there, and the diverged count.
#[derive(Serialize, serde::Deserialize)]
struct PartsMeta<P> {
    parts: P,
    part_points: Vec<usize>,
    diverged: u64,
}

/// The partial catalogue a [`part_unit`] stores, with its points, and its diverged count.
pub fn unit_parts(
    unit: &crate::run::Unit,
) -> jeffcott_core::error::Result<(Vec<PartAttractor>, u64)> {
    let bad = |what: &str| jeffcott_core::error::Error::Io {
        path: format!("unit {}", unit.key).into(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, what.to_string()),
    };
    let PartsMeta {
        mut parts,
        part_points: counts,
        diverged,
    } = unit.meta_as::<PartsMeta<Vec<PartAttractor>>>()?;
    let flat = unit.f64s("points")?;
    if !fill_points(flat, &counts, parts.iter_mut().map(|p| &mut p.points)) {
        return Err(bad("partial catalogue points do not match"));
    }
    Ok((parts, diverged))
}

/// Fills each of `targets` with its share of `flat`, the states of several attractors
/// stored one after another (`counts[i]` states for the i-th), as a unit keeps them;
/// `false`, with nothing filled, when the counts match neither the targets nor the
/// states stored.
pub(crate) fn fill_points<'a>(
    flat: &[f64],
    counts: &[usize],
    targets: impl ExactSizeIterator<Item = &'a mut Vec<State>>,
) -> bool {
    if counts.len() != targets.len() || counts.iter().sum::<usize>() * STATE_DIM != flat.len() {
        return false;
    }
    let mut at = 0;
    for (points, &n) in targets.zip(counts) {
        *points = flat[at * STATE_DIM..(at + n) * STATE_DIM]
            .chunks_exact(STATE_DIM)
            .map(|c| c.try_into().unwrap_or([f64::NAN; STATE_DIM]))
            .collect();
        at += n;
    }
    true
}
