//! The catalogue grown lane by lane ([`CatalogueBuilder`]): lanes added one at a time
//! or in classified blocks, early exit's recognised lanes counted on their attractors,
//! aperiodic entries that are one attractor merged when it is finished.

use super::identity::{CLOUD_POINTS, aperiodic_family, find, same};
use super::recognise::{Closeness, cloud_groups, recogniser_of};
use super::{Attractor, Catalogue, CatalogueConfig, LaneClass, LaneEnd, classify_lane};
use crate::classify::Class;
use crate::early::Recogniser;
use jeffcott_core::model::{STATE_DIM, State};
use rayon::prelude::*;

/// Builds a catalogue lane by lane (so basins can stream chunks with bounded memory).
#[derive(Clone, Debug)]
pub struct CatalogueBuilder {
    pub(super) cfg: CatalogueConfig,
    pub(super) omega: f64,
    pub(super) attractors: Vec<Attractor>,
    pub(super) total: u64,
    pub(super) diverged: u64,
}

impl CatalogueBuilder {
    /// An empty catalogue at speed `omega`.
    pub fn new(omega: f64, cfg: CatalogueConfig) -> Self {
        CatalogueBuilder {
            cfg,
            omega,
            attractors: Vec::new(),
            total: 0,
            diverged: 0,
        }
    }

    /// Adds a classified lane; returns its attractor id, or -1 for a diverged lane.
    pub fn add(&mut self, l: LaneClass) -> i32 {
        self.add_at(l, self.total)
    }

    /// [`CatalogueBuilder::add`] for a lane whose index (the attractor's `first_lane`
    /// if it is new) is `lane`: lanes added out of order, as early exit's rounds do.
    pub fn add_at(&mut self, l: LaneClass, lane: u64) -> i32 {
        self.total += 1;
        if l.class == Class::Diverged {
            self.diverged += 1;
            return -1;
        }
        if let Some(k) = find(&self.cfg, self.omega, &self.attractors, &l) {
            let a = &mut self.attractors[k];
            a.lanes += 1;
            a.add_lambda1(l.lambda1);
            if a.period.is_none() && a.points.len() < CLOUD_POINTS {
                let room = CLOUD_POINTS - a.points.len();
                a.points.extend(l.points.iter().take(room));
            }
            return k as i32;
        }
        let id = self.attractors.len() as u32;
        self.attractors.push(Attractor {
            id,
            class: l.class.label(),
            period: l.class.period(),
            omega: self.omega,
            lanes: 1,
            basin_fraction: 0.0,
            size_m: l.size,
            points: l.points,
            first_lane: lane,
            lambda1: None,
            lambda1_range: None,
            kind: l.class,
            l1_sum: 0.0,
            l1_n: 0,
        });
        self.attractors[id as usize].add_lambda1(l.lambda1);
        id as i32
    }

    /// Early exit's catalogue rebuilt as one pass over the lanes in index order builds
    /// it: `lanes[i]` is how lane i ended, its class where it ran whole, else the id
    /// (in this catalogue, the rounds') of the attractor it was recognised on. A lane that ran
    /// whole is added as a pass adds it; a recognised lane joins the entry of its
    /// attractor's cycle, or starts it with this catalogue's cycle (and no lambda_1:
    /// the lanes that ran whole bring theirs). Returns the new catalogue and the
    /// labels. Why: an aperiodic lane joins the first entry whose cloud covers it and
    /// grows that cloud, so the entries aperiodic lanes form depend on the order they
    /// are added in; in the rounds' order (every 64th lane first) 230 of 3600 cells at
    /// 136.038 rad/s, all run whole, joined other entries than in the full-length run
    /// (docs/early-exit.md). Ids come out in the order of each attractor's first lane,
    /// with that lane as its `first_lane`, whatever the units or rounds.
    pub fn rebuilt_in_lane_order(&self, lanes: Vec<LaneEnd>) -> (Self, Vec<i32>) {
        let mut out = CatalogueBuilder::new(self.omega, self.cfg);
        let labels = lanes
            .into_iter()
            .enumerate()
            .map(|(i, lane)| match lane {
                LaneEnd::Whole(class) => out.add_at(class, i as u64),
                LaneEnd::Recognised(id) => {
                    let a = &self.attractors[id as usize];
                    let cycle = LaneClass {
                        class: a.kind,
                        size: a.size_m,
                        points: a.points.clone(),
                        lambda1: f64::NAN,
                    };
                    match find(&out.cfg, out.omega, &out.attractors, &cycle) {
                        Some(k) => out.add_recognised(k as u32),
                        // The cycle as this lane's (no lambda_1: NaN is not counted).
                        None => out.add_at(cycle, i as u64),
                    }
                }
            })
            .collect();
        (out, labels)
    }

    /// Adds a lane recognised on attractor `id` of this catalogue (early exit: it has no
    /// record of its own, so the attractor's points and lambda_1 stay as they are).
    pub fn add_recognised(&mut self, id: u32) -> i32 {
        self.total += 1;
        self.attractors[id as usize].lanes += 1;
        id as i32
    }

    /// What early exit recognises lanes on: the cycles so far ([`recogniser_of`]).
    pub fn recogniser(&self, streak: u32) -> Recogniser {
        self.recogniser_with_clouds(streak, None)
    }

    /// [`CatalogueBuilder::recogniser`], with `clouds` the aperiodic attractors too:
    /// entry `i` a recognised cloud where `clouds[i]`, else watched (`early::Known`).
    pub fn recogniser_with_clouds(&self, streak: u32, clouds: Option<&[bool]>) -> Recogniser {
        recogniser_of(
            &self.attractors,
            &self.cfg,
            self.omega,
            streak,
            Closeness::Label,
            clouds,
        )
    }

    /// For each attractor so far (by id), the first entry of its cloud
    /// (`cloud_groups`: aperiodic entries that are one attractor).
    pub fn cloud_groups(&self) -> Vec<u32> {
        cloud_groups(&self.attractors, &self.cfg, self.omega)
    }

    /// Attractors catalogued so far.
    pub fn len(&self) -> usize {
        self.attractors.len()
    }

    /// Whether nothing is catalogued yet.
    pub fn is_empty(&self) -> bool {
        self.attractors.is_empty()
    }

    /// What early exit recognises lanes on before they record ([`Closeness::Record`]).
    pub fn recogniser_to_record(&self, streak: u32) -> Recogniser {
        recogniser_of(
            &self.attractors,
            &self.cfg,
            self.omega,
            streak,
            Closeness::Record,
            None,
        )
    }

    /// Classifies (in parallel) and adds a block of lanes: `points` is
    /// [lanes, recorded, 8] flat, `frozen[i]` says lane i was flagged. Returns the labels.
    pub fn add_block(
        &mut self,
        points: &[f64],
        recorded: usize,
        frozen: &[bool],
        lambda1: Option<&[f64]>,
    ) -> Vec<i32> {
        self.classify_block(points, recorded, frozen, lambda1)
            .into_iter()
            .map(|c| self.add(c))
            .collect()
    }

    /// [`CatalogueBuilder::add_block`] for lanes `lanes` of an ensemble result: their
    /// points, their diverged flags and their lambda_1 where it has them.
    pub fn add_result_lanes(
        &mut self,
        res: &jeffcott_core::ensemble::EnsembleResult,
        lanes: std::ops::Range<usize>,
    ) -> Vec<i32> {
        let rec = res.recorded * STATE_DIM;
        let frozen: Vec<bool> = res.status[lanes.clone()]
            .iter()
            .map(|s| s.is_frozen())
            .collect();
        self.add_block(
            &res.poincare[lanes.start * rec..lanes.end * rec],
            res.recorded,
            &frozen,
            res.lambda1.as_ref().map(|l| &l[lanes]),
        )
    }

    /// Classifies a block of lanes (in parallel) as [`CatalogueBuilder::add_block`]
    /// does, without adding them.
    pub fn classify_block(
        &self,
        points: &[f64],
        recorded: usize,
        frozen: &[bool],
        lambda1: Option<&[f64]>,
    ) -> Vec<LaneClass> {
        let (omega, cfg) = (self.omega, self.cfg);
        frozen
            .par_iter()
            .enumerate()
            .map(|(i, &f)| {
                let flat = &points[i * recorded * STATE_DIM..(i + 1) * recorded * STATE_DIM];
                let states: Vec<State> = flat
                    .chunks_exact(STATE_DIM)
                    .map(|c| c.try_into().unwrap_or([f64::NAN; STATE_DIM]))
                    .collect();
                classify_lane(&states, omega, f, lambda1.map(|l| l[i]), &cfg)
            })
            .collect()
    }

    /// Merges aperiodic entries that are one attractor; returns old id -> new id.
    pub(super) fn merge_clouds(&mut self) -> Vec<i32> {
        let n = self.attractors.len();
        let mut target: Vec<usize> = (0..n).collect();
        for b in 1..n {
            if self.attractors[b].period.is_some() {
                continue;
            }
            let lb = LaneClass {
                class: self.attractors[b].kind,
                size: self.attractors[b].size_m,
                points: self.attractors[b].points.clone(),
                lambda1: f64::NAN,
            };
            if let Some(a) = (0..b).find(|&a| {
                target[a] == a && {
                    let la = LaneClass {
                        class: self.attractors[a].kind,
                        size: self.attractors[a].size_m,
                        points: self.attractors[a].points.clone(),
                        lambda1: f64::NAN,
                    };
                    same(&self.cfg, self.omega, &lb, &self.attractors[a])
                        || same(&self.cfg, self.omega, &la, &self.attractors[b])
                }
            }) {
                target[b] = a;
            }
        }
        let mut map = vec![-1i32; n];
        let mut kept: Vec<Attractor> = Vec::new();
        for k in 0..n {
            if target[k] == k {
                map[k] = kept.len() as i32;
                let mut a = self.attractors[k].clone();
                a.id = kept.len() as u32;
                kept.push(a);
            }
        }
        for k in 0..n {
            if target[k] != k {
                let t = map[target[k]] as usize;
                map[k] = t as i32;
                let extra = self.attractors[k].lanes;
                let room = CLOUD_POINTS.saturating_sub(kept[t].points.len());
                let pts: Vec<State> = self.attractors[k]
                    .points
                    .iter()
                    .take(room)
                    .copied()
                    .collect();
                kept[t].lanes += extra;
                kept[t].points.extend(pts);
                let (sum, n, range) = (
                    self.attractors[k].l1_sum,
                    self.attractors[k].l1_n,
                    self.attractors[k].lambda1_range,
                );
                kept[t].merge_lambda1(sum, n, range);
            }
        }
        self.attractors = kept;
        map
    }

    /// The attractors so far with their basin fractions; an aperiodic attractor's class
    /// comes from the mean lambda_1 of its lanes when known (quasiperiodic if
    /// |mean| < `lambda_tol`, chaotic above, aperiodic otherwise).
    pub fn attractors(&self) -> Vec<Attractor> {
        let mut v = self.attractors.clone();
        for a in &mut v {
            a.basin_fraction = a.lanes as f64 / self.total.max(1) as f64;
            if let (true, Some(l)) = (aperiodic_family(a.kind), a.lambda1) {
                a.kind = if l.abs() < self.cfg.lambda_tol {
                    Class::Quasiperiodic
                } else if l > self.cfg.lambda_tol {
                    Class::Chaotic
                } else {
                    Class::Aperiodic
                };
                a.class = a.kind.label();
            }
        }
        v
    }

    /// Lanes added so far, and how many of them diverged.
    pub fn counts(&self) -> (u64, u64) {
        (self.total, self.diverged)
    }
}

impl CatalogueBuilder {
    /// The finished catalogue with the given labels (all lanes' ids, in order).
    ///
    /// Aperiodic attractors whose reference clouds cover each other are merged first
    /// (a lane compared early against a still sparse cloud may have opened a second
    /// entry for the same attractor); ids are renumbered in order and `labels` remapped.
    pub fn finish(mut self, mut labels: Vec<i32>) -> Catalogue {
        let map = self.merge_clouds();
        for l in labels.iter_mut() {
            if *l >= 0 {
                *l = map[*l as usize];
            }
        }
        let attractors = self.attractors();
        let (lanes, diverged) = self.counts();
        Catalogue {
            omega: self.omega,
            attractors,
            labels,
            lanes,
            diverged,
            diverged_fraction: diverged as f64 / lanes.max(1) as f64,
            config: self.cfg,
        }
    }
}
