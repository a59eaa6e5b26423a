//! The seeded pass of one ramp direction: one unit per value in ramp order, the previous
//! value's attractors seeded, catalogued with the fresh lanes and matched; and the
//! units a step is stored in.

use super::{ContinuationSpec, Direction, Ramp, Step, Tracked, fresh_value, match_attractors};
use crate::catalogue::{CatalogueBuilder, PartAttractor, classify_lane, fill_points};
use crate::run::lanes::Control;
use crate::run::{Array, Unit, UnitStore};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::State;
use serde::{Deserialize, Serialize};

/// Unit of step `s` of a ramp: the step and the next free id.
fn step_unit(step: &Step, next_id: u32) -> Unit {
    let counts: Vec<usize> = step.attractors.iter().map(|a| a.points.len()).collect();
    Unit::new("")
        .with("labels", Array::I32(step.labels.clone()))
        .with(
            "points",
            Array::F64(
                step.attractors
                    .iter()
                    .flat_map(|a| a.points.iter().flatten().copied())
                    .collect(),
            ),
        )
        .with_meta(&StepMeta {
            step,
            point_counts: counts,
            next_id,
        })
}

/// The metadata of a ramp step's unit: the step (its attractors' points in the unit's
/// `points` array, its labels in `labels`), how many points each attractor has, and the
/// next free continuation id.
#[derive(Serialize, Deserialize)]
struct StepMeta<S> {
    step: S,
    point_counts: Vec<usize>,
    next_id: u32,
}

fn unit_step(unit: &Unit) -> Result<(Step, u32)> {
    let bad = |what: String| Error::Io {
        path: format!("unit {}", unit.key).into(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, what),
    };
    let StepMeta {
        mut step,
        point_counts: counts,
        next_id: next,
    } = unit.meta_as::<StepMeta<Step>>()?;
    step.labels = unit.i32s("labels")?.to_vec();
    let flat = unit.f64s("points")?;
    let targets = step.attractors.iter_mut().map(|a| &mut a.points);
    if !fill_points(flat, &counts, targets) {
        return Err(bad("points do not match".into()));
    }
    Ok((step, next))
}

/// The seeded pass in one direction: one unit per value, in ramp order, each needing the
/// previous one.
pub(super) fn ramp(
    spec: &ContinuationSpec,
    engine: &crate::backend::Engine,
    store: &dyn UnitStore,
    dir: Direction,
    ctl: Control,
) -> Result<Ramp> {
    let n = spec.param.n;
    let order: Vec<usize> = match dir {
        Direction::Up => (0..n).collect(),
        Direction::Down => (0..n).rev().collect(),
    };
    let stage = dir.name();
    let done = store.committed(stage, n)?;
    let mut steps: Vec<Step> = Vec::with_capacity(n);
    let mut next_id = 0u32;
    for (s, &i) in order.iter().enumerate() {
        if done[s] {
            let (step, next) = unit_step(&store.load(stage, s)?)?;
            steps.push(step);
            next_id = next;
            continue;
        }
        if ctl.cancel.is_set() {
            return Err(Error::Interrupted {
                committed: s,
                total: n,
            });
        }
        let fresh = fresh_value(spec, store, i)?;
        let (parts, diverged) = crate::catalogue::unit_parts(&fresh)?;
        let prev: &[Tracked] = steps.last().map(|p| p.attractors.as_slice()).unwrap_or(&[]);
        let step = seeded_step(
            spec,
            engine,
            i,
            &parts,
            diverged,
            fresh.i32s("labels")?,
            prev,
            &mut next_id,
        )?;
        store.commit(stage, s, &step_unit(&step, next_id))?;
        steps.push(step);
    }
    Ok(Ramp {
        direction: dir,
        steps,
        ids: next_id as usize,
    })
}

/// One value of the seeded pass: the fresh partial catalogue absorbed, the previous
/// value's attractors seeded, everything catalogued and matched to the previous value.
#[allow(clippy::too_many_arguments)]
fn seeded_step(
    spec: &ContinuationSpec,
    engine: &crate::backend::Engine,
    i: usize,
    parts: &[PartAttractor],
    diverged: u64,
    fresh_labels: &[i32],
    prev: &[Tracked],
    next_id: &mut u32,
) -> Result<Step> {
    let (_, w) = spec.value_params(i);
    let k = fresh_labels.len();
    let mut b = CatalogueBuilder::new(w, spec.lane.catalogue);
    let ids: Vec<i32> = parts.iter().map(|p| b.absorb(p, 0)).collect();
    b.add_lanes(k as u64, diverged);
    let mut labels: Vec<i32> = fresh_labels
        .iter()
        .map(|&l| if l >= 0 { ids[l as usize] } else { -1 })
        .collect();
    // One seed lane per previous attractor, from one of its Poincare points (a state at
    // t = kT, where every lane starts its forcing phase).
    let seeds: Vec<State> = prev
        .iter()
        .filter_map(|a| a.points.first().copied())
        .collect();
    if !seeds.is_empty() {
        let e = spec.ensemble(i, seeds);
        let (res, _) = engine.run(&e, spec.lane.lyapunov, Control::none())?;
        for lane in 0..e.lanes.len() {
            let states = res.lane_states(lane);
            let lc = classify_lane(
                &states,
                w,
                res.status[lane].is_frozen(),
                res.lambda1.as_ref().map(|l| l[lane]),
                &spec.lane.catalogue,
            );
            labels.push(b.add(lc));
        }
    }
    let cat = b.finish(labels);
    let fresh = &cat.labels[..k];
    let now: Vec<Vec<State>> = cat.attractors.iter().map(|a| a.points.clone()).collect();
    let before: Vec<Vec<State>> = prev.iter().map(|a| a.points.clone()).collect();
    let matched = match_attractors(&before, &now, w, spec.match_threshold);
    let gid: Vec<u32> = matched
        .iter()
        .map(|m| match m {
            Some(p) => prev[*p].id,
            None => {
                *next_id += 1;
                *next_id - 1
            }
        })
        .collect();
    let kf = k.max(1) as f64;
    let attractors = cat
        .attractors
        .iter()
        .zip(&gid)
        .map(|(a, &id)| {
            let hits = fresh.iter().filter(|&&l| l == a.id as i32).count();
            let f = hits as f64 / kf;
            Tracked {
                id,
                class: a.class.clone(),
                period: a.period,
                fraction: f,
                error: (f * (1.0 - f) / kf).sqrt(),
                lambda1: a.lambda1,
                size_m: a.size_m,
                seeded_only: hits == 0,
                state: a.points.first().copied(),
                points: a.points.iter().take(64).copied().collect(),
            }
        })
        .collect();
    let diverged = fresh.iter().filter(|&&l| l < 0).count();
    Ok(Step {
        value: spec.param.value(i),
        attractors,
        diverged_fraction: diverged as f64 / kf,
        labels: fresh
            .iter()
            .map(|&l| if l >= 0 { gid[l as usize] as i32 } else { -1 })
            .collect(),
    })
}
