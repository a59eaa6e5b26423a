//! Catalogues built with early exit, in rounds ([`rounds`]): each round's lanes
//! recognised on the catalogue of the rounds before it, the clouds its watched lanes
//! confirm recognised in the next.

use super::{ByGroup, EarlySaved, Recogniser, UNSEEN};
use crate::backend::Engine;
use crate::catalogue::{CatalogueBuilder, CatalogueConfig, LaneEnd};
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::early::{EarlyExit, EarlyResult, Then};
use jeffcott_core::ensemble::{EnsembleSpec, RunInfo};
use jeffcott_core::error::Result;

/// The lanes (indices into `0..n`) of each round, in order: every 64th lane, then every
/// 8th of the others, then the rest. Every lane is in exactly one round.
pub fn rounds(n: usize) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    for (k, &stride) in ROUND_STRIDES.iter().enumerate() {
        let earlier = &ROUND_STRIDES[..k];
        out.push(
            (0..n)
                .step_by(stride)
                .filter(|i| earlier.iter().all(|s| i % s != 0))
                .collect(),
        );
    }
    out.retain(|r| !r.is_empty());
    out
}

/// Lanes a group (a continuation's value) needs for its lanes to exit early: the first
/// round's stride, so that round has a lane per 64 and the later rounds fill batches.
/// Measured: a continuation over 45 speeds with 16 lanes each (`reproduce --quick`'s)
/// took 21.9 s with early exit against 20.9 s without (its rounds of 2-3 lanes per unit
/// ran mostly empty batches full length); basin stability at 1000 lanes per speed took
/// 50.8 s against 68.2 s (docs/early-exit.md).
pub const MIN_GROUP: usize = ROUND_STRIDES[0];

/// Strides of the rounds: 1/64 of a unit's lanes make its first catalogue (they run full
/// length), 1/8 see that catalogue and add to it, the rest see both. Few rounds keep the
/// rounds large: a round waits for its slowest lane, and the batches of a small round
/// run mostly empty.
pub(super) const ROUND_STRIDES: [usize; 3] = [64, 8, 1];

/// Lanes catalogued with early exit ([`catalogue_lanes`]).
pub struct EarlyLanes {
    /// The catalogue with every lane added.
    pub builder: CatalogueBuilder,
    /// Each lane's label as the builder gave it.
    pub labels: Vec<i32>,
    /// What early exit saved.
    pub saved: EarlySaved,
    /// How the last round ran.
    pub info: Option<RunInfo>,
}

/// Catalogues the lanes of `ens` at speed `omega` with early exit, in [`rounds`].
/// `ctl.progress` counts a lane as its full periods when it ends.
pub fn catalogue_lanes(
    ens: &EnsembleSpec,
    omega: f64,
    cfg: CatalogueConfig,
    engine: &Engine,
    ctl: Control,
) -> Result<EarlyLanes> {
    let n = ens.lanes.len();
    let whole = std::iter::once(0..n).collect::<Vec<_>>();
    let mut all = catalogue_groups(ens, &whole, &[omega], cfg, false, engine, ctl)?;
    Ok(all.pop().expect("one group"))
}

/// How the lanes that stayed in a watched cloud for the streak ended ([`Known::Cloud`]):
/// on it, or elsewhere (another attractor, diverged, recognised on a cycle).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct CloudVotes {
    stayed: u32,
    left: u32,
}

impl CloudVotes {
    fn note(&mut self, stayed: bool) {
        if stayed {
            self.stayed += 1;
        } else {
            self.left += 1;
        }
    }

    /// A cloud is recognised once [`CLOUD_CONFIRMATIONS`] lanes that stayed in it for
    /// the streak ended on it and none ended elsewhere.
    pub(super) fn confirmed(&self) -> bool {
        self.left == 0 && self.stayed >= CLOUD_CONFIRMATIONS
    }
}

/// Counts, for each lane noted in a watched cloud `seen` that ended on entry `on` (-1
/// diverged, -2 on none), whether it ended on that cloud: on one of its entries as
/// `cloud_of` groups them (`catalogue::cloud_groups`: a lane compared against a still
/// sparse cloud may open a second entry of the same attractor).
pub(super) fn tally(
    votes: &mut Vec<CloudVotes>,
    cloud_of: &[u32],
    ends: impl Iterator<Item = (u32, i32)>,
) {
    for (seen, on) in ends {
        let k = seen as usize;
        if votes.len() <= k {
            votes.resize(k + 1, CloudVotes::default());
        }
        votes[k].note(on >= 0 && cloud_of.get(on as usize) == cloud_of.get(k));
    }
}

/// A log of `n` lanes' first watched cloud, none noted yet ([`ByGroup::watched`]).
pub(super) fn watch_log(n: usize) -> Vec<std::sync::atomic::AtomicU32> {
    (0..n)
        .map(|_| std::sync::atomic::AtomicU32::new(UNSEEN))
        .collect()
}

/// Lanes that must have stayed in a watched cloud for the streak and ended on it, with
/// none ending elsewhere, before the cloud is recognised (docs/early-exit.md, "Chaotic
/// attractors"). A cloud of lanes still in a long transient leaks: at 137.25 rad/s with
/// T = 250, replayed on full-length records without the separation cap, the largest
/// "aperiodic" entry would have retired 1253 of 1600 lanes that the full-length run
/// puts elsewhere, most of them on the period-1 cycle, and every 8th lane, watched,
/// marks it leaky (with the cap, the separation rule keeps it out already).
const CLOUD_CONFIRMATIONS: u32 = 3;

/// Catalogues each group of lanes of `ens` on its own with early exit, in [`rounds`]:
/// group g is the lanes `groups[g]` (consecutive), at speed `omegas[g]` (the groups of a
/// continuation's unit are its parameter values, each with its own catalogue). A round
/// runs the same round of every group as one ensemble, each lane recognised on its
/// group's catalogue ([`ByGroup`]), so a group's labels are those it gets run alone.
/// With `lambda1` the lanes that run whole also give their lambda_1, so an attractor's
/// is the mean over those lanes (retired ones have none) and aperiodic lanes are told
/// apart as quasiperiodic or chaotic as without early exit.
/// `ctl.progress` counts a lane as its full periods when it ends. The last round's run
/// information is in every group's `info`.
pub fn catalogue_groups(
    ens: &EnsembleSpec,
    groups: &[std::ops::Range<usize>],
    omegas: &[f64],
    cfg: CatalogueConfig,
    lambda1: bool,
    engine: &Engine,
    ctl: Control,
) -> Result<Vec<EarlyLanes>> {
    let n = ens.lanes.len();
    let full = ens.transient + ens.recorded;
    let per_lane = full as u64;
    let mut out = empty_catalogues(groups, omegas, cfg);
    // How each lane ended: its class where it ran whole, else the rounds' attractor id
    // it was recognised on (the catalogue is rebuilt from these in lane order at the end).
    let mut ends: Vec<Vec<Option<LaneEnd>>> = groups.iter().map(|g| vec![None; g.len()]).collect();
    let group_rounds: Vec<Vec<Vec<usize>>> = groups.iter().map(|g| rounds(g.len())).collect();
    let count = group_rounds.iter().map(Vec::len).max().unwrap_or(0);
    // Per group and catalogue entry, the lanes that stayed in it for a streak while it
    // was watched, and how they ended: on it, or elsewhere (`CloudVotes`).
    let mut votes: Vec<Vec<CloudVotes>> = vec![Vec::new(); groups.len()];
    let mut base = 0u64;
    for r in 0..count {
        // The round's lanes, group by group: (group, index in the group).
        let picks: Vec<(usize, usize)> = group_rounds
            .iter()
            .enumerate()
            .flat_map(|(g, rs)| rs.get(r).into_iter().flatten().map(move |&i| (g, i)))
            .collect();
        if picks.is_empty() {
            continue;
        }
        let sub = EnsembleSpec {
            lanes: picks
                .iter()
                .map(|&(g, i)| ens.lanes[groups[g].start + i])
                .collect(),
            ..ens.clone()
        };
        let rec = round_recognisers(&out, &votes, ens.stepper.early_exit_streak);
        let group: Vec<usize> = picks.iter().map(|p| p.0).collect();
        let watched = watch_log(picks.len());
        let by_group = ByGroup {
            recognisers: &rec,
            group: &group,
            watched: Some(&watched),
        };
        let early = EarlyExit {
            recognise: &by_group,
            after: ens.stepper.early_exit_after,
            then: Then::Retire,
        };
        let b0 = base;
        let report = |d: u64, _: u64| (ctl.progress)(b0 + d, n as u64 * per_lane);
        let (res, info) = engine.run_early(
            &sub,
            &early,
            lambda1,
            Control {
                progress: &report,
                cancel: ctl.cancel,
            },
        )?;
        let round = Round {
            res: &res,
            picks: &picks,
            watched: &watched,
            frozen: res.result.status.iter().map(|s| s.is_frozen()).collect(),
            full,
        };
        // Each group's lanes of the round are consecutive in `picks`.
        let mut at = 0;
        for (g, ((e, ends), votes)) in out.iter_mut().zip(&mut ends).zip(&mut votes).enumerate() {
            let m = picks[at..].iter().take_while(|p| p.0 == g).count();
            let lanes = at..at + m;
            at += m;
            e.info = Some(info.clone());
            if m == 0 {
                continue;
            }
            round.add_group(e, ends, votes, lanes);
        }
        base += picks.len() as u64 * per_lane;
    }
    rebuild_in_lane_order(&mut out, ends);
    Ok(out)
}

/// One empty catalogue per group (`groups[g]` its lanes, at speed `omegas[g]`).
fn empty_catalogues(
    groups: &[std::ops::Range<usize>],
    omegas: &[f64],
    cfg: CatalogueConfig,
) -> Vec<EarlyLanes> {
    groups
        .iter()
        .zip(omegas)
        .map(|(g, &w)| EarlyLanes {
            builder: CatalogueBuilder::new(w, cfg),
            labels: vec![-1i32; g.len()],
            saved: EarlySaved::default(),
            info: None,
        })
        .collect()
}

/// Each group's catalogue as a pass without rounds builds it, from how its lanes ended
/// (`ends`), in index order (`CatalogueBuilder::rebuilt_in_lane_order`): entries, ids
/// and first lanes then do not depend on the rounds' order, nor on how the grid is cut
/// into units.
fn rebuild_in_lane_order(out: &mut [EarlyLanes], ends: Vec<Vec<Option<LaneEnd>>>) {
    for (e, ends) in out.iter_mut().zip(ends) {
        let lanes = ends
            .into_iter()
            .map(|l| l.expect("every lane ends in one round"))
            .collect();
        (e.builder, e.labels) = e.builder.rebuilt_in_lane_order(lanes);
    }
}

/// Each group's recogniser for the next round: its catalogue so far, with the clouds
/// its watched lanes have confirmed (`votes`) recognised and the others watched.
fn round_recognisers(
    out: &[EarlyLanes],
    votes: &[Vec<CloudVotes>],
    streak: u32,
) -> Vec<Recogniser> {
    out.iter()
        .zip(votes)
        .map(|(e, v)| {
            let confirmed: Vec<bool> = (0..e.builder.len())
                .map(|i| v.get(i).is_some_and(CloudVotes::confirmed))
                .collect();
            e.builder.recogniser_with_clouds(streak, Some(&confirmed))
        })
        .collect()
}

/// One round of [`catalogue_groups`] as it came back from the engine.
struct Round<'a> {
    /// The round's result, its lanes in the order of `picks`.
    res: &'a EarlyResult,
    /// Each lane's (group, index in the group).
    picks: &'a [(usize, usize)],
    /// Each lane's first watched cloud ([`UNSEEN`] where none).
    watched: &'a [std::sync::atomic::AtomicU32],
    /// Each lane's diverged flag.
    frozen: Vec<bool>,
    /// Periods of a lane that runs whole.
    full: u32,
}

impl Round<'_> {
    /// Takes the round's lanes `lanes` of one group into its catalogue `e`: a lane that
    /// ran whole is classified and added, a retired one noted as recognised (`ends`),
    /// and the lanes noted in a watched cloud vote on it (`votes`).
    fn add_group(
        &self,
        e: &mut EarlyLanes,
        ends: &mut [Option<LaneEnd>],
        votes: &mut Vec<CloudVotes>,
        lanes: std::ops::Range<usize>,
    ) {
        let res = self.res;
        let len = res.result.recorded * jeffcott_core::model::STATE_DIM;
        let classes = e.builder.classify_block(
            &res.result.poincare[lanes.start * len..lanes.end * len],
            res.result.recorded,
            &self.frozen[lanes.clone()],
            res.result.lambda1.as_ref().map(|l| &l[lanes.clone()]),
        );
        let mut crossed: Vec<(u32, i32)> = Vec::new();
        for (((&(_, i), class), retired), seen) in self.picks[lanes.clone()]
            .iter()
            .zip(classes)
            .zip(&res.retired[lanes.clone()])
            .zip(&self.watched[lanes.clone()])
        {
            // The rounds' catalogue only recognises: it needs the attractors of the
            // lanes that ran whole, not the recognised lanes' counts or labels
            // (those come from the rebuild at the end).
            let (end, on) = match retired {
                Some(ret) => (LaneEnd::Recognised(ret.attractor), ret.attractor as i32),
                None => {
                    let id = e.builder.add_at(class.clone(), i as u64);
                    (LaneEnd::Whole(class), id)
                }
            };
            ends[i] = Some(end);
            let seen = seen.load(std::sync::atomic::Ordering::Relaxed);
            if seen != UNSEEN {
                crossed.push((seen, on));
            }
        }
        // Grouped as the catalogue now holds them, with the round's new entries.
        if !crossed.is_empty() {
            tally(votes, &e.builder.cloud_groups(), crossed.into_iter());
        }
        e.saved.add(&EarlySaved::of(&res.retired[lanes], self.full));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rounds_cover_every_lane_once_and_start_with_every_64th() {
        for n in [1, 7, 64, 65, 500, 1773] {
            let r = rounds(n);
            let mut all: Vec<usize> = r.concat();
            all.sort_unstable();
            assert_eq!(all, (0..n).collect::<Vec<_>>(), "n = {n}");
            assert_eq!(r[0], (0..n).step_by(64).collect::<Vec<_>>());
        }
    }

    #[test]
    fn a_cloud_is_confirmed_by_three_lanes_that_stayed_and_none_that_left() {
        let mut v = CloudVotes::default();
        v.note(true);
        v.note(true);
        assert!(!v.confirmed());
        v.note(true);
        assert!(v.confirmed());
        v.note(false);
        assert!(!v.confirmed(), "one lane that left keeps it watched");
    }
}
