//! Lanes labelled against a finished catalogue with early exit ([`label_lanes`]): the
//! re-integrated points of a basin (its refinement and uncertainty draws).

use super::rounds::{CloudVotes, ROUND_STRIDES, tally, watch_log};
use super::{ByGroup, EarlySaved, Recogniser, UNSEEN};
use crate::backend::Engine;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::early::{EarlyExit, Then};
use jeffcott_core::ensemble::{EnsembleSpec, RunInfo};
use jeffcott_core::error::Result;

/// The lanes of `ens` labelled against a finished `catalogue` (at the lanes' speed)
/// with early exit: a lane recognised on one of its attractors takes that attractor's
/// id, every other lane runs whole and is labelled from its record as
/// [`crate::catalogue::Catalogue::label_lanes`] labels it (-1 diverged, -2 on no
/// catalogued attractor). The catalogue is complete before the lanes start (the
/// re-integrated points of a basin: its refinement and uncertainty draws), so its
/// cycles recognise from the first lane. Its clouds must be confirmed by these lanes
/// first (module docs): where it has any, every 8th lane runs first with the clouds
/// watched, and the rest with those its watched lanes confirmed; so the labels depend
/// on the unit's lanes alone, as in [`catalogue_groups`].
pub fn label_lanes(
    ens: &EnsembleSpec,
    catalogue: &crate::catalogue::Catalogue,
    engine: &Engine,
    ctl: Control,
) -> Result<(Vec<i32>, EarlySaved, RunInfo)> {
    let n = ens.lanes.len();
    let streak = ens.stepper.early_exit_streak;
    let full = ens.transient + ens.recorded;
    let lanes_run = |lanes: &[usize],
                     rec: &Recogniser,
                     watched: Option<&[std::sync::atomic::AtomicU32]>,
                     done: u64|
     -> Result<(Vec<i32>, EarlySaved, RunInfo)> {
        let sub = EnsembleSpec {
            lanes: lanes.iter().map(|&i| ens.lanes[i]).collect(),
            ..ens.clone()
        };
        let group = vec![0usize; lanes.len()];
        let by = ByGroup {
            recognisers: std::slice::from_ref(rec),
            group: &group,
            watched,
        };
        let early = EarlyExit {
            recognise: &by,
            after: ens.stepper.early_exit_after,
            then: Then::Retire,
        };
        let report = |d: u64, _: u64| (ctl.progress)(done + d, n as u64 * full as u64);
        let (r, info) = engine.run_early(
            &sub,
            &early,
            false,
            Control {
                progress: &report,
                cancel: ctl.cancel,
            },
        )?;
        let labels = r
            .retired
            .iter()
            .enumerate()
            .map(|(i, ret)| match ret {
                Some(ret) => ret.attractor as i32,
                None => catalogue.label_lane(&r.result, i),
            })
            .collect();
        Ok((labels, EarlySaved::of(&r.retired, full), info))
    };
    if !catalogue.has_clouds() {
        let all: Vec<usize> = (0..n).collect();
        return lanes_run(&all, &catalogue.recogniser(streak, None), None, 0);
    }
    // Every 8th lane with the clouds watched; a cloud is confirmed where the lanes that
    // stayed in it for the streak ended on it (on one of its entries) and none left.
    let (first, rest): (Vec<usize>, Vec<usize>) = (0..n).partition(|i| i % CLOUD_WATCH_STRIDE == 0);
    let k = catalogue.attractors.len();
    let watched = watch_log(first.len());
    let none = vec![false; k];
    let (l1, mut saved, info1) = lanes_run(
        &first,
        &catalogue.recogniser(streak, Some(&none)),
        Some(&watched),
        0,
    )?;
    let mut votes = vec![CloudVotes::default(); k];
    let ends = watched
        .iter()
        .zip(&l1)
        .map(|(seen, &label)| (seen.load(std::sync::atomic::Ordering::Relaxed), label))
        .filter(|&(seen, _)| seen != UNSEEN);
    tally(&mut votes, &catalogue.cloud_groups(), ends);
    if rest.is_empty() {
        return Ok((l1, saved, info1));
    }
    let confirmed: Vec<bool> = votes.iter().map(CloudVotes::confirmed).collect();
    let (l2, saved2, info) = lanes_run(
        &rest,
        &catalogue.recogniser(streak, Some(&confirmed)),
        None,
        first.len() as u64 * full as u64,
    )?;
    saved.add(&saved2);
    let mut labels = vec![0i32; n];
    for (i, l) in first.iter().zip(l1).chain(rest.iter().zip(l2)) {
        labels[*i] = l;
    }
    Ok((labels, saved, info))
}

/// The stride of the lanes that watch a finished catalogue's clouds before the rest
/// may retire on them ([`label_lanes`]), as the second of [`rounds`].
const CLOUD_WATCH_STRIDE: usize = ROUND_STRIDES[1];

/// A unit of lanes labelled against `catalogue` ([`label_lanes`]): its `labels` and
/// what early exit saved (`early`), as the re-integration stages commit them.
pub fn labelled_unit(
    ens: &EnsembleSpec,
    catalogue: &crate::catalogue::Catalogue,
    engine: &Engine,
    ctl: Control,
) -> Result<(crate::run::Unit, Option<RunInfo>)> {
    let (labels, saved, info) = label_lanes(ens, catalogue, engine, ctl)?;
    let unit = crate::run::Unit::new("")
        .with("labels", crate::run::Array::I32(labels))
        .with("early", crate::run::Array::F64(saved.to_array()));
    Ok((unit, Some(info)))
}
