//! What an orbits run writes: `branches.json`'s records and the `.npy` arrays.

use super::{Branch, BranchPoint, Crossing};
use jeffcott_core::model::State;
use serde::Serialize;

/// A bifurcation as `branches.json` lists it: its type, the parameter's value under the
/// parameter's name (e.g. `"omega": 132.07`), the multipliers and the orbit there.
#[derive(Serialize)]
pub struct BifurcationRecord<'a> {
    #[serde(rename = "type")]
    kind: Crossing,
    #[serde(flatten)]
    value: std::collections::BTreeMap<&'static str, f64>,
    multipliers: &'a [[f64; 2]],
    min_clearance_m: f64,
    state: State,
    after_point: usize,
}

/// A branch as `branches.json` lists it.
#[derive(Serialize)]
pub struct BranchRecord<'a> {
    period: u32,
    minimal_period: u32,
    points: &'a [BranchPoint],
    bifurcations: Vec<BifurcationRecord<'a>>,
    stop: &'a str,
}

/// `branches.json` (and the Python function's dictionary): the parameter's name and the
/// branches.
#[derive(Serialize)]
pub struct BranchesRecord<'a> {
    param: &'static str,
    branches: Vec<BranchRecord<'a>>,
}

/// The record of `branches`, over the parameter `name`.
pub fn record<'a>(name: &'static str, branches: &'a [Branch]) -> BranchesRecord<'a> {
    let one = |branch: &'a Branch| {
        let bifurcations = branch
            .bifurcations
            .iter()
            .map(|x| BifurcationRecord {
                kind: x.kind,
                value: [(name, x.value)].into_iter().collect(),
                multipliers: &x.multipliers,
                min_clearance_m: x.min_clearance,
                state: x.x,
                after_point: x.after_point,
            })
            .collect();
        BranchRecord {
            period: branch.period,
            minimal_period: branch.minimal_period,
            points: &branch.points,
            bifurcations,
            stop: &branch.stop,
        }
    };
    BranchesRecord {
        param: name,
        branches: branches.iter().map(one).collect(),
    }
}

/// Columns of a branch point's row in [`arrays`].
pub const ROW: usize = 13;

/// The branches as flat arrays: `[points, 13]` rows (branch index, parameter value, the
/// orbit's state at t = 0, largest multiplier modulus, smallest clearance [m], stable
/// 1/0) and the multipliers `[points, 8, 2]` (re, im), the branches' points in order.
pub fn arrays(branches: &[Branch]) -> (Vec<f64>, Vec<f64>) {
    let n: usize = branches.iter().map(|b| b.points.len()).sum();
    let mut rows = Vec::with_capacity(n * ROW);
    let mut mu = Vec::with_capacity(n * 16);
    for (k, p) in branches
        .iter()
        .enumerate()
        .flat_map(|(k, b)| b.points.iter().map(move |p| (k, p)))
    {
        rows.push(k as f64);
        rows.push(p.value);
        rows.extend_from_slice(&p.x);
        rows.push(p.multipliers.first().map_or(f64::NAN, |m| m[0].hypot(m[1])));
        rows.push(p.min_clearance);
        rows.push(if p.stable { 1.0 } else { 0.0 });
        for m in &p.multipliers {
            mu.extend_from_slice(m);
        }
    }
    (rows, mu)
}
