//! Early exit for the attractor-labelling studies (issue 24): lanes that are recognised
//! on an attractor already catalogued retire, the rest run their whole transient and
//! record and are classified as without it (`jeffcott_core::ensemble::early`).
//!
//! **The rule** ([`Recogniser`]): from period `early_exit_after` on, a lane's Poincare
//! point at the end of every period is compared with the catalogue. A periodic attractor
//! is recognised when `early_exit_streak` points in a row, and at least two whole cycles,
//! each lie within the recognition tolerance
//! ([`CatalogueBuilder::recogniser`]: a tenth of the cycle's diameter, at most 0.45
//! of its distance to any other attractor, at least the identity tolerance below that
//! cap; a cycle within four identity tolerances of another attractor, the floor at most
//! 1 um in f32 too, or a period-2n cycle that close to itself shifted by n points, is not
//! recognised) of the cycle
//! point expected next, in its cyclic order (the analogue of the
//! recurrence cells of Datseris and Wagemakers, Chaos 32, 023104 (2022)). An aperiodic
//! attractor (a cloud) is recognised when `early_exit_streak` points in a row lie within
//! a tenth of its diameter of its reference cloud (at most 0.45 of its distance to any
//! other attractor), but only in studies that catalogue in rounds ([`catalogue_groups`])
//! and only once it is confirmed: lanes still in a long transient form clouds that look
//! like attractors (docs/early-exit.md), so a cloud ([`Known::Cloud`]) is first watched,
//! and recognised after [`CLOUD_CONFIRMATIONS`] lanes that stayed in
//! it for the streak ended on it and none ended elsewhere. A miss starts the count
//! again. Only attractors are catalogued, never saddles, so a lane that lingers near an
//! unstable orbit is not matched by it; a lane that passes close to an attractor and
//! leaves it again breaks its streak.
//!
//! **Rounds** ([`catalogue_lanes`]): a unit's lanes run in rounds spread over the unit:
//! every 64th lane first (no catalogue yet: these run full length and make the first
//! catalogue), then every 8th of the others, then the rest, each round seeing the
//! attractors of the rounds before it (an attractor with a small basin missed by the
//! first rounds costs its lanes their early exit, never their label). Each round's
//! recogniser is fixed while it runs, so the labels depend on the unit's lanes alone, not
//! on threads, backends or other units: resumable and shardable as before. The labels
//! and entries then come from the catalogue rebuilt in lane order
//! (`CatalogueBuilder::rebuilt_in_lane_order`), as a pass without rounds builds it.

use crate::backend::Engine;
use crate::catalogue::{CatalogueBuilder, CatalogueConfig, LaneEnd, classify_lane};
use crate::classify::Class;
use crate::classify::distance;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::early::{EarlyExit, EarlyResult, Recognise, Retired, Then, Track};
use jeffcott_core::ensemble::{EnsembleSpec, RunInfo};
use jeffcott_core::error::Result;
use jeffcott_core::model::{STATE_DIM, State};
use serde::{Deserialize, Serialize};

/// An attractor as early exit sees it.
#[derive(Clone, Debug)]
pub enum Known {
    /// A cycle (canonical rotation) and the distance within which a point matches.
    Cycle {
        /// The cycle's points in order.
        points: Vec<State>,
        /// Match tolerance (the metric of [`distance`]).
        tol: f64,
    },
    /// An aperiodic attractor: a point matches within `tol` of any point of its
    /// reference cloud. Lanes still in a long transient form clouds that look like
    /// attractors (docs/early-exit.md), and only the lanes that go on to the end tell
    /// the two apart: so a cloud is recognised only once `confirmed` (every lane that
    /// stayed in it ended on it: [`catalogue_groups`]); until then it is watched, a
    /// lane that stays in it for the streak noted ([`Seen::Watched`]), never retired.
    Cloud {
        /// The reference cloud.
        points: Vec<State>,
        /// Match tolerance.
        tol: f64,
        /// The cloud's bounding box, lowest and highest coordinates ([`Known::cloud`]).
        bounds: [State; 2],
        /// Recognised (else watched).
        confirmed: bool,
    },
    /// Never recognised (aperiodic entries where no evidence is gathered, unclassified
    /// entries, cycles too close to another attractor).
    Never,
}

impl Known {
    /// A cloud of `points` matching within `tol`: recognised where `confirmed`, else
    /// watched.
    pub fn cloud(points: Vec<State>, tol: f64, confirmed: bool) -> Known {
        let mut bounds = [[f64::INFINITY; STATE_DIM], [f64::NEG_INFINITY; STATE_DIM]];
        for p in &points {
            for i in 0..STATE_DIM {
                bounds[0][i] = bounds[0][i].min(p[i]);
                bounds[1][i] = bounds[1][i].max(p[i]);
            }
        }
        Known::Cloud {
            points,
            tol,
            bounds,
            confirmed,
        }
    }

    /// Whether `x` matches point `j` of a cycle, or any point of a cloud.
    fn matches(&self, x: &State, j: usize, w: f64) -> bool {
        match self {
            Known::Cycle { points, tol } => distance(x, &points[j], w) <= *tol,
            Known::Cloud {
                points,
                tol,
                bounds,
                ..
            } => {
                // Outside the box grown by the tolerance no point can match: in the
                // coordinate where x lies beyond the box, every point's difference is
                // at least the box's (rounded subtraction and division are monotone),
                // so this skips exactly the scans that would find nothing.
                for i in 0..STATE_DIM {
                    let scale = crate::classify::metric_scale(i, w);
                    if (bounds[0][i] - x[i]) / scale > *tol || (x[i] - bounds[1][i]) / scale > *tol
                    {
                        return false;
                    }
                }
                points.iter().any(|p| distance(x, p, w) <= *tol)
            }
            Known::Never => false,
        }
    }

    /// Points in a row that recognise a lane: `streak`, and two whole cycles at least.
    fn needs(&self, streak: u32) -> u32 {
        match self {
            Known::Cycle { points, .. } => streak.max(2 * points.len() as u32),
            _ => streak,
        }
    }
}

/// What one Poincare point did to a lane's track ([`Recogniser::step`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seen {
    /// Not recognised.
    Nothing,
    /// Recognised on this attractor: the lane retires (or records).
    Retire(u32),
    /// In this watched cloud for the whole streak: noted, the lane goes on.
    Watched(u32),
}

/// Recognises lanes on a catalogue's attractors (module docs); built by
/// [`CatalogueBuilder::recogniser`].
#[derive(Clone, Debug)]
pub struct Recogniser {
    omega: f64,
    streak: u32,
    known: Vec<Known>,
}

impl Recogniser {
    /// Recognises on `known` (ids are their indices) at speed `omega` after `streak`
    /// points in a row.
    pub fn new(omega: f64, streak: u32, known: Vec<Known>) -> Self {
        Recogniser {
            omega,
            streak: streak.max(1),
            known,
        }
    }

    /// The period of attractor `id` when it is a cycle this recogniser recognises.
    pub fn cycle_period(&self, id: u32) -> Option<usize> {
        match self.known.get(id as usize) {
            Some(Known::Cycle { points, .. }) => Some(points.len()),
            _ => None,
        }
    }

    /// Starts a streak at `x`: the first cycle (and cycle point) it matches, else the
    /// first cloud. No point matches two attractors (the tolerances are capped under
    /// half their separation), so the order only saves work: a cycle's few points are
    /// tried before a cloud's hundreds.
    fn start(&self, x: &State) -> Track {
        for (id, k) in self.known.iter().enumerate() {
            let Known::Cycle { points, .. } = k else {
                continue;
            };
            if let Some(j) = (0..points.len()).find(|&j| k.matches(x, j, self.omega)) {
                return Track {
                    attractor: id as u32,
                    next: ((j + 1) % points.len()) as u32,
                    streak: 1,
                };
            }
        }
        for (id, k) in self.known.iter().enumerate() {
            if matches!(k, Known::Cloud { .. }) && k.matches(x, 0, self.omega) {
                return Track {
                    attractor: id as u32,
                    next: 0,
                    streak: 1,
                };
            }
        }
        Track::default()
    }

    /// Takes lane's next Poincare point `x` into its track `t`: what [`Recognise::observe`]
    /// decides, and where the lane has stayed in a watched cloud for the streak, that.
    pub fn step(&self, t: &mut Track, x: &State) -> Seen {
        if t.streak > 0 {
            let k = &self.known[t.attractor as usize];
            if k.matches(x, t.next as usize, self.omega) {
                t.streak += 1;
                if let Known::Cycle { points, .. } = k {
                    t.next = (t.next + 1) % points.len() as u32;
                }
            } else {
                t.streak = 0;
            }
        }
        if t.streak == 0 {
            *t = self.start(x);
        }
        let Some(k) = self.known.get(t.attractor as usize) else {
            return Seen::Nothing;
        };
        if t.streak == 0 || t.streak < k.needs(self.streak) {
            return Seen::Nothing;
        }
        match k {
            Known::Cloud {
                confirmed: false, ..
            } => Seen::Watched(t.attractor),
            _ => Seen::Retire(t.attractor),
        }
    }
}

impl Recognise for Recogniser {
    fn observe(&self, _lane: usize, t: &mut Track, x: &State) -> Option<u32> {
        match self.step(t, x) {
            Seen::Retire(id) => Some(id),
            Seen::Nothing | Seen::Watched(_) => None,
        }
    }
}

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
const ROUND_STRIDES: [usize; 3] = [64, 8, 1];

/// What early exit saved, per unit or summed over a study (run.json's `early_exit`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EarlySaved {
    /// Lanes run.
    pub lanes: u64,
    /// Lanes that retired early.
    pub retired: u64,
    /// Periods integrated by all lanes.
    pub periods_run: u64,
    /// Periods the same lanes integrate without early exit.
    pub periods_full: u64,
}

impl EarlySaved {
    /// The count of lanes that ran `full` periods each unless `retired` says otherwise.
    pub fn of(retired: &[Option<Retired>], full: u32) -> EarlySaved {
        EarlySaved {
            lanes: retired.len() as u64,
            retired: retired.iter().filter(|r| r.is_some()).count() as u64,
            periods_run: jeffcott_core::ensemble::early::periods_run(retired, full),
            periods_full: retired.len() as u64 * full as u64,
        }
    }

    /// Adds `more` to `total` (`None`: nothing ran with early exit yet).
    pub fn accumulate(total: &mut Option<EarlySaved>, more: Option<EarlySaved>) {
        if let Some(m) = more {
            total.get_or_insert_with(EarlySaved::default).add(&m);
        }
    }

    /// Adds another count.
    pub fn add(&mut self, o: &EarlySaved) {
        self.lanes += o.lanes;
        self.retired += o.retired;
        self.periods_run += o.periods_run;
        self.periods_full += o.periods_full;
    }

    /// As four numbers (a unit's `early` array).
    pub fn to_array(self) -> Vec<f64> {
        [
            self.lanes,
            self.retired,
            self.periods_run,
            self.periods_full,
        ]
        .map(|v| v as f64)
        .to_vec()
    }

    /// From a unit's `early` array.
    pub fn from_array(a: &[f64]) -> EarlySaved {
        let v = |i: usize| a.get(i).copied().unwrap_or(0.0) as u64;
        EarlySaved {
            lanes: v(0),
            retired: v(1),
            periods_run: v(2),
            periods_full: v(3),
        }
    }
}

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
struct CloudVotes {
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
    fn confirmed(&self) -> bool {
        self.left == 0 && self.stayed >= CLOUD_CONFIRMATIONS
    }
}

/// Counts, for each lane noted in a watched cloud `seen` that ended on entry `on` (-1
/// diverged, -2 on none), whether it ended on that cloud: on one of its entries as
/// `cloud_of` groups them (`catalogue::cloud_groups`: a lane compared against a still
/// sparse cloud may open a second entry of the same attractor).
fn tally(votes: &mut Vec<CloudVotes>, cloud_of: &[u32], ends: impl Iterator<Item = (u32, i32)>) {
    for (seen, on) in ends {
        let k = seen as usize;
        if votes.len() <= k {
            votes.resize(k + 1, CloudVotes::default());
        }
        votes[k].note(on >= 0 && cloud_of.get(on as usize) == cloud_of.get(k));
    }
}

/// A log of `n` lanes' first watched cloud, none noted yet ([`ByGroup::watched`]).
fn watch_log(n: usize) -> Vec<std::sync::atomic::AtomicU32> {
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
    let mut out: Vec<EarlyLanes> = groups
        .iter()
        .zip(omegas)
        .map(|(g, &w)| EarlyLanes {
            builder: CatalogueBuilder::new(w, cfg),
            labels: vec![-1i32; g.len()],
            saved: EarlySaved::default(),
            info: None,
        })
        .collect();
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
        let rec: Vec<Recogniser> = out
            .iter()
            .zip(&votes)
            .map(|(e, v)| {
                let confirmed: Vec<bool> = (0..e.builder.len())
                    .map(|i| v.get(i).is_some_and(CloudVotes::confirmed))
                    .collect();
                e.builder
                    .recogniser_with_clouds(ens.stepper.early_exit_streak, Some(&confirmed))
            })
            .collect();
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
        let frozen: Vec<bool> = res.result.status.iter().map(|s| s.is_frozen()).collect();
        let len = res.result.recorded * jeffcott_core::model::STATE_DIM;
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
            let classes = e.builder.classify_block(
                &res.result.poincare[lanes.start * len..lanes.end * len],
                res.result.recorded,
                &frozen[lanes.clone()],
                res.result.lambda1.as_ref().map(|l| &l[lanes.clone()]),
            );
            let mut crossed: Vec<(u32, i32)> = Vec::new();
            for (((&(_, i), class), retired), seen) in picks[lanes.clone()]
                .iter()
                .zip(classes)
                .zip(&res.retired[lanes.clone()])
                .zip(&watched[lanes.clone()])
            {
                // The rounds' catalogue only recognises: it needs the attractors of the
                // lanes that ran whole, not the recognised lanes' counts or labels
                // (those come from the rebuild below).
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
            e.saved.add(&EarlySaved::of(&res.retired[lanes], full));
        }
        base += picks.len() as u64 * per_lane;
    }
    // The catalogue as a pass without rounds builds it, lanes in index order
    // (`CatalogueBuilder::rebuilt_in_lane_order`): entries, ids and first lanes then do
    // not depend on the rounds' order, nor on how the grid is cut into units.
    for (e, ends) in out.iter_mut().zip(ends) {
        let lanes = ends
            .into_iter()
            .map(|l| l.expect("every lane ends in one round"))
            .collect();
        (e.builder, e.labels) = e.builder.rebuilt_in_lane_order(lanes);
    }
    Ok(out)
}

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

/// What early exit saved in a committed unit (nothing when it ran without: no `early`).
pub fn unit_saved(unit: &crate::run::Unit) -> Result<Option<EarlySaved>> {
    if !unit.has("early") {
        return Ok(None);
    }
    Ok(Some(EarlySaved::from_array(unit.f64s("early")?)))
}

/// Recognises each lane on the catalogue of its group (in a brute force, its speed):
/// lane i on `recognisers[group[i]]`.
pub struct ByGroup<'a> {
    /// One recogniser per group.
    pub recognisers: &'a [Recogniser],
    /// Each lane's group.
    pub group: &'a [usize],
    /// Where given, each lane's first watched cloud ([`Seen::Watched`]; [`UNSEEN`]
    /// where none), noted as the runner's threads observe it.
    pub watched: Option<&'a [std::sync::atomic::AtomicU32]>,
}

/// No watched cloud noted for a lane ([`ByGroup::watched`]).
pub const UNSEEN: u32 = u32::MAX;

impl Recognise for ByGroup<'_> {
    fn observe(&self, lane: usize, t: &mut Track, x: &State) -> Option<u32> {
        match self.recognisers[self.group[lane]].step(t, x) {
            Seen::Retire(id) => Some(id),
            Seen::Watched(id) => {
                if let Some(w) = self.watched {
                    // The first cloud the lane stayed in; each lane is observed by one
                    // thread at a time, so this is the same on any number of threads.
                    let _ = w[lane].compare_exchange(
                        UNSEEN,
                        id,
                        std::sync::atomic::Ordering::Relaxed,
                        std::sync::atomic::Ordering::Relaxed,
                    );
                }
                None
            }
            Seen::Nothing => None,
        }
    }
}

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
) -> Result<(
    jeffcott_core::ensemble::EnsembleResult,
    EarlySaved,
    Option<RunInfo>,
)> {
    use jeffcott_core::ensemble::EnsembleResult;
    let streak = ens.stepper.early_exit_streak;
    let n = ens.lanes.len();
    let full = (ens.transient + ens.recorded) as u64;
    if n == 0 {
        // Groups without lanes (a brute force's speeds without seeds): nothing to run.
        let empty = EnsembleResult::with_capacity(0, ens.recorded, lambda1);
        return Ok((empty, EarlySaved::default(), None));
    }
    let sub = |pick: &[usize]| EnsembleSpec {
        lanes: pick.iter().map(|&i| ens.lanes[i]).collect(),
        ..ens.clone()
    };
    let (known, first, mut saved) = match how {
        GroupRecognition::Known(rec) => (rec, None, EarlySaved::default()),
        GroupRecognition::FirstLane => {
            // Round 1: each group's first lane, whole; its catalogue recognises the rest.
            let firsts: Vec<usize> = (0..n)
                .filter(|&i| i == 0 || group[i] != group[i - 1])
                .collect();
            let r1 = engine.run(&sub(&firsts), lambda1, ctl)?.0;
            let mut builders: Vec<CatalogueBuilder> = omegas
                .iter()
                .map(|&w| CatalogueBuilder::new(w, cfg))
                .collect();
            for (k, &i) in firsts.iter().enumerate() {
                builders[group[i]].add_result_lanes(&r1, k..k + 1);
            }
            let rec = builders
                .iter()
                .map(|b| b.recogniser_to_record(streak))
                .collect();
            let saved = EarlySaved {
                lanes: firsts.len() as u64,
                retired: 0,
                periods_run: firsts.len() as u64 * full,
                periods_full: firsts.len() as u64 * full,
            };
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
    // A lane recorded early is recognised close to a cycle, but its record may still
    // not repeat within the classifier's tolerance: where the cycle's slowest
    // multipliers are a complex pair near -1 (the period-9 cycle at 133.19 rad/s,
    // -0.81 +- 0.31i), a deviation that was within the recognition tolerance at the
    // points the streak saw grows again as it turns, and 12 of 29 such lanes
    // classified as period-18 (docs/early-exit.md). Such a lane runs again whole, as
    // without early exit, so its record and class are the plain run's.
    let redo: Vec<usize> = (0..rest.len())
        .filter(|&k| match r2.retired[k] {
            Some(ret) if ret.periods < full as u32 => {
                let g = rest_group[k];
                let lane = classify_lane(
                    &r2.result.lane_states(k),
                    omegas[g],
                    r2.result.status[k].is_frozen(),
                    None,
                    &cfg,
                );
                known[g].cycle_period(ret.attractor).map(Class::Periodic) != Some(lane.class)
            }
            _ => false,
        })
        .collect();
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
    let mut out = EnsembleResult::with_capacity(n, ens.recorded, lambda1);
    for (_, r, k) in from {
        out.poincare.extend_from_slice(r.lane_points(k));
        out.final_state.push(r.final_state[k]);
        out.status.push(r.status[k]);
        out.counters.push(r.counters[k]);
        if let (Some(l), Some(rl)) = (out.lambda1.as_mut(), r.lambda1.as_ref()) {
            l.push(rl[k]);
        }
    }
    Ok((out, saved, info))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(v: f64) -> State {
        [v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    }

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
    fn a_cycle_is_recognised_only_in_its_order_after_two_cycles_and_the_streak() {
        let cycle = Known::Cycle {
            points: vec![pt(0.0), pt(1.0), pt(2.0)],
            tol: 0.1,
        };
        let r = Recogniser::new(100.0, 4, vec![cycle]);
        // In order: recognised at the 6th point (two cycles of 3 > streak 4).
        let mut t = Track::default();
        let seq = [0.0, 1.0, 2.0, 0.0, 1.0, 2.0];
        let got: Vec<Option<u32>> = seq.iter().map(|&v| r.observe(0, &mut t, &pt(v))).collect();
        assert_eq!(got[..5], [None; 5]);
        assert_eq!(got[5], Some(0));
        // Near the cycle's points but out of order: never.
        let mut t = Track::default();
        for v in [0.0, 2.0, 1.0, 0.0, 2.0, 1.0, 0.0, 2.0, 1.0] {
            assert_eq!(r.observe(0, &mut t, &pt(v)), None);
        }
    }

    #[test]
    fn a_lane_that_passes_close_to_an_attractor_and_leaves_is_not_retired() {
        // A synthetic transient: five points on a period-1 attractor (fewer than the
        // streak of 8), then away, then back on it for good.
        let r = Recogniser::new(
            100.0,
            8,
            vec![Known::Cycle {
                points: vec![pt(0.0)],
                tol: 1e-3,
            }],
        );
        let mut t = Track::default();
        let mut first = None;
        let seq: Vec<f64> = [vec![0.0; 5], vec![0.5; 3], vec![0.0; 20]].concat();
        for (k, &v) in seq.iter().enumerate() {
            if r.observe(0, &mut t, &pt(v)).is_some() && first.is_none() {
                first = Some(k);
            }
        }
        // The visit of 5 points did not retire it; 8 in a row after its return did.
        assert_eq!(first, Some(8 + 7));
    }

    #[test]
    fn a_watched_cloud_notes_a_lane_that_stays_for_the_streak_and_never_retires_it() {
        let cloud = vec![pt(0.0), pt(1.0), pt(2.0)];
        let watch = Known::cloud(cloud.clone(), 0.3, false);
        let r = Recogniser::new(100.0, 4, vec![watch]);
        let mut t = Track::default();
        let seen: Vec<Seen> = [0.1, 1.2, 5.0, 2.1, 0.0, 1.1, 1.9]
            .iter()
            .map(|&v| r.step(&mut t, &pt(v)))
            .collect();
        // 5.0 lies outside the cloud: the count starts again at 2.1, and the fourth
        // point in a row (1.9) is noted, not retired.
        assert_eq!(seen[..6], [Seen::Nothing; 6]);
        assert_eq!(seen[6], Seen::Watched(0));
        assert_eq!(r.observe(0, &mut t, &pt(0.2)), None);
        // Confirmed, the same cloud retires the lane after the same streak.
        let r = Recogniser::new(100.0, 4, vec![Known::cloud(cloud, 0.3, true)]);
        let mut t = Track::default();
        let got: Vec<Option<u32>> = [0.1, 1.2, 2.1, 0.0]
            .iter()
            .map(|&v| r.observe(0, &mut t, &pt(v)))
            .collect();
        assert_eq!(got, [None, None, None, Some(0)]);
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

    #[test]
    fn aperiodic_and_unclassified_entries_are_never_recognised() {
        let r = Recogniser::new(100.0, 1, vec![Known::Never]);
        let mut t = Track::default();
        for v in [0.0, 0.5, 1.0] {
            assert_eq!(r.observe(0, &mut t, &pt(v)), None);
        }
    }
}
