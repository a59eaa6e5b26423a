//! Lanes that record from where they are recognised ([`record_lanes`]), and the brute
//! force's and map's records by group ([`records_by_group`]), in lane order as a plain
//! run gives them.

use super::{ByGroup, EarlySaved, Recogniser};
use crate::backend::Engine;
use crate::catalogue::{CatalogueBuilder, CatalogueConfig, classify_lane};
use crate::classify::Class;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::early::{EarlyExit, EarlyResult, Recognise, Then};
use jeffcott_core::ensemble::{EnsembleResult, EnsembleSpec, RunInfo};
use jeffcott_core::error::Result;

/// Runs `ens` with early exit, each lane recognised by `rec` during its transient and
/// then recording its own `recorded` periods from there ([`Then::Record`]), with its
/// lambda_1 over that record when `lambda1`: for studies that classify or draw every
/// lane's record (the brute force). What early exit saved comes with the result, and
/// each lane's recognition.
pub fn record_lanes(
    ens: &EnsembleSpec,
    rec: &dyn Recognise,
    lambda1: bool,
    engine: &Engine,
    ctl: Control,
) -> Result<(EarlyResult, EarlySaved, RunInfo)> {
    let early = EarlyExit {
        recognise: rec,
        after: ens.stepper.early_exit_after,
        then: Then::Record,
    };
    let (r, info) = engine.run_early(ens, &early, lambda1, ctl)?;
    let full = ens.transient + ens.recorded;
    let saved = EarlySaved {
        // Lanes recognised before the transient's end (one recognised at its last
        // period has the plain run's record and saved nothing).
        retired: r
            .retired
            .iter()
            .filter(|r| r.is_some_and(|r| r.periods < full))
            .count() as u64,
        ..EarlySaved::of(&r.retired, full)
    };
    Ok((r, saved, info))
}

/// How [`records_by_group`] recognises its lanes.
pub enum GroupRecognition {
    /// Each group's first lane runs whole and catalogues the group for its other lanes
    /// (nothing is known of a group before).
    FirstLane,
    /// Each group's lanes are recognised from the start by its recogniser (one per
    /// group: an earlier pass's catalogues).
    Known(Vec<Recogniser>),
}

/// Runs `ens`'s lanes with early exit in record mode ([`record_lanes`]): lane i belongs
/// to group `group[i]` (a brute force's speed, a map's cell; groups consecutive), whose
/// speed is `omegas[group]`, recognised as `how` says. The records come back in lane
/// order, as a plain run gives them (points, final states, statuses, counters,
/// lambda_1), with what early exit saved (the first lanes count as run whole) and the
/// last round's run information (`None` when no lane was left for it).
#[allow(clippy::too_many_arguments)]
pub fn records_by_group(
    ens: &EnsembleSpec,
    group: &[usize],
    omegas: &[f64],
    how: GroupRecognition,
    cfg: CatalogueConfig,
    lambda1: bool,
    engine: &Engine,
    ctl: Control,
) -> Result<(EnsembleResult, EarlySaved, Option<RunInfo>)> {
    let n = ens.lanes.len();
    let full = (ens.transient + ens.recorded) as u64;
    if n == 0 {
        // Groups without lanes (a brute force's speeds without seeds): nothing to run.
        let empty = EnsembleResult::with_capacity(0, ens.recorded, lambda1);
        return Ok((empty, EarlySaved::default(), None));
    }
    let sub = |pick: &[usize]| sub_ensemble(ens, pick);
    let (known, first, mut saved) = match how {
        GroupRecognition::Known(rec) => (rec, None, EarlySaved::default()),
        GroupRecognition::FirstLane => {
            let (rec, firsts, r1, saved) =
                first_lanes_whole(ens, group, omegas, cfg, lambda1, engine, ctl)?;
            (rec, Some((firsts, r1)), saved)
        }
    };
    let base = saved.periods_full;
    let rest: Vec<usize> = match &first {
        Some((firsts, _)) => (0..n)
            .filter(|i| firsts.binary_search(i).is_err())
            .collect(),
        None => (0..n).collect(),
    };
    let rest_group: Vec<usize> = rest.iter().map(|&i| group[i]).collect();
    let report = |d: u64, _: u64| (ctl.progress)(base + d, n as u64 * full);
    // No lane may be left (one lane per group, or no lanes).
    let (r2, info) = if rest.is_empty() {
        (
            EarlyResult {
                result: EnsembleResult::with_capacity(0, ens.recorded, lambda1),
                retired: Vec::new(),
            },
            None,
        )
    } else {
        let (r, s, i) = record_lanes(
            &sub(&rest),
            &ByGroup {
                recognisers: &known,
                group: &rest_group,
                watched: None,
            },
            lambda1,
            engine,
            Control {
                progress: &report,
                cancel: ctl.cancel,
            },
        )?;
        saved.add(&s);
        (r, Some(i))
    };
    let redo = records_to_redo(&r2, &rest_group, omegas, &known, &cfg, full);
    let whole = if redo.is_empty() {
        EnsembleResult::with_capacity(0, ens.recorded, lambda1)
    } else {
        let lanes: Vec<usize> = redo.iter().map(|&k| rest[k]).collect();
        let quiet = |_: u64, _: u64| {};
        let w = engine
            .run(
                &sub(&lanes),
                lambda1,
                Control {
                    progress: &quiet,
                    cancel: ctl.cancel,
                },
            )?
            .0;
        saved.retired -= redo.len() as u64;
        saved.periods_run += redo.len() as u64 * full;
        w
    };
    // The records back in lane order.
    let mut from: Vec<(usize, &EnsembleResult, usize)> = rest
        .iter()
        .enumerate()
        .map(|(k, &i)| (i, &r2.result, k))
        .collect();
    for (j, &k) in redo.iter().enumerate() {
        from[k] = (rest[k], &whole, j);
    }
    if let Some((firsts, r1)) = &first {
        from.extend(firsts.iter().enumerate().map(|(k, &i)| (i, r1, k)));
    }
    from.sort_unstable_by_key(|f| f.0);
    Ok((in_lane_order(from, n, ens.recorded, lambda1), saved, info))
}

/// The lanes `pick` of `ens`, as an ensemble of their own.
fn sub_ensemble(ens: &EnsembleSpec, pick: &[usize]) -> EnsembleSpec {
    EnsembleSpec {
        lanes: pick.iter().map(|&i| ens.lanes[i]).collect(),
        ..ens.clone()
    }
}

/// The first round of [`GroupRecognition::FirstLane`]: each group's first lane run
/// whole, its catalogue the recogniser of the group's other lanes. Returns the
/// recognisers, the first lanes, their result and their count as run whole.
#[allow(clippy::too_many_arguments)]
fn first_lanes_whole(
    ens: &EnsembleSpec,
    group: &[usize],
    omegas: &[f64],
    cfg: CatalogueConfig,
    lambda1: bool,
    engine: &Engine,
    ctl: Control,
) -> Result<(Vec<Recogniser>, Vec<usize>, EnsembleResult, EarlySaved)> {
    let n = ens.lanes.len();
    let full = (ens.transient + ens.recorded) as u64;
    let firsts: Vec<usize> = (0..n)
        .filter(|&i| i == 0 || group[i] != group[i - 1])
        .collect();
    let r1 = engine.run(&sub_ensemble(ens, &firsts), lambda1, ctl)?.0;
    let mut builders: Vec<CatalogueBuilder> = omegas
        .iter()
        .map(|&w| CatalogueBuilder::new(w, cfg))
        .collect();
    for (k, &i) in firsts.iter().enumerate() {
        builders[group[i]].add_result_lanes(&r1, k..k + 1);
    }
    let rec = builders
        .iter()
        .map(|b| b.recogniser_to_record(ens.stepper.early_exit_streak))
        .collect();
    let saved = EarlySaved {
        lanes: firsts.len() as u64,
        retired: 0,
        periods_run: firsts.len() as u64 * full,
        periods_full: firsts.len() as u64 * full,
    };
    Ok((rec, firsts, r1, saved))
}

/// The lanes of `r2` (indices into it; lane k of group `rest_group[k]`) recorded early
/// whose record does not classify as the cycle they were recognised on.
///
/// A lane recorded early is recognised close to a cycle, but its record may still
/// not repeat within the classifier's tolerance: where the cycle's slowest
/// multipliers are a complex pair near -1 (the period-9 cycle at 133.19 rad/s,
/// -0.81 +- 0.31i), a deviation that was within the recognition tolerance at the
/// points the streak saw grows again as it turns, and 12 of 29 such lanes
/// classified as period-18 (docs/early-exit.md). Such a lane runs again whole, as
/// without early exit, so its record and class are the plain run's.
fn records_to_redo(
    r2: &EarlyResult,
    rest_group: &[usize],
    omegas: &[f64],
    known: &[Recogniser],
    cfg: &CatalogueConfig,
    full: u64,
) -> Vec<usize> {
    (0..rest_group.len())
        .filter(|&k| match r2.retired[k] {
            Some(ret) if ret.periods < full as u32 => {
                let g = rest_group[k];
                let lane = classify_lane(
                    &r2.result.lane_states(k),
                    omegas[g],
                    r2.result.status[k].is_frozen(),
                    None,
                    cfg,
                );
                known[g].cycle_period(ret.attractor).map(Class::Periodic) != Some(lane.class)
            }
            _ => false,
        })
        .collect()
}

/// One result of `n` lanes from `from`, sorted by lane: lane i is lane k of result r
/// for each (i, r, k).
fn in_lane_order(
    from: Vec<(usize, &EnsembleResult, usize)>,
    n: usize,
    recorded: u32,
    lambda1: bool,
) -> EnsembleResult {
    let mut out = EnsembleResult::with_capacity(n, recorded, lambda1);
    for (_, r, k) in from {
        out.poincare.extend_from_slice(r.lane_points(k));
        out.final_state.push(r.final_state[k]);
        out.status.push(r.status[k]);
        out.counters.push(r.counters[k]);
        if let (Some(l), Some(rl)) = (out.lambda1.as_mut(), r.lambda1.as_ref()) {
            l.push(rl[k]);
        }
    }
    out
}
