//! The attractor catalogue of an ensemble at one rotor speed W (MODEL.md 5): every lane
//! is classified from its Poincare points ([`classify`]) and given the id of the
//! attractor it settled on; lanes on the same orbit get the same id even when their
//! Poincare sequences are shifted in phase.
//!
//! Identity, in the metric of [`classify`] (positions in metres, velocities divided by W):
//! - period-n: two cycles are the same when they have the same n and some cyclic shift
//!   of one matches the other point by point within
//!   `max(match_rel * size, match_abs)` (size = the larger of the two cycles' diameters).
//!   The shift is found from the first point, so a comparison costs O(n). Cycles are
//!   stored in a canonical rotation (starting at the point of smallest x_r), so the
//!   representative points do not depend on which lane was seen first.
//! - aperiodic (quasiperiodic, chaotic): a lane's cloud lies on an attractor when their
//!   diameters agree within a factor 2 and at least 60 % of the lane's points are within
//!   `cloud_rel` times the diameter of the attractor's reference cloud (the points of
//!   the lanes that joined it, up to 512). Coexisting aperiodic attractors that overlap
//!   that closely are not told apart.
//! - diverged (flagged) lanes get label -1 and no catalogue entry.
//!
//! Lyapunov hook: when a largest exponent lambda1 [1/s] is known per lane, aperiodic
//! lanes split into quasiperiodic (|lambda1| < `lambda_tol`) and chaotic
//! (lambda1 > `lambda_tol`). Identity stays with the clouds: lanes of the aperiodic
//! family on one cloud are one attractor whatever their own short-time lambda1, and the
//! attractor's class follows the mean lambda1 of its lanes.

use crate::classify::{Class, Classification, ClassifyConfig, classify, distance};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{STATE_DIM, State, X_R};
use rayon::prelude::*;
use serde::Serialize;

/// Tolerances of the catalogue; `Default` gives sound values for Table 1 runs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct CatalogueConfig {
    /// Period detection (n_max, repeat tolerances).
    pub classify: ClassifyConfig,
    /// Cycle match tolerance relative to the cycle's diameter.
    pub match_rel: f64,
    /// Cycle match tolerance floor [m] (period-1 cycles have zero diameter).
    pub match_abs: f64,
    /// Aperiodic clouds match when most points lie within this fraction of the diameter
    /// of the attractor's reference cloud.
    pub cloud_rel: f64,
    /// |lambda1| below this [1/s] is quasiperiodic, above it (positive) chaotic.
    pub lambda_tol: f64,
}

impl CatalogueConfig {
    /// The defaults for f64 lanes, in one place (see [`CatalogueConfig::for_precision`]
    /// for f32 lanes).
    pub const DEFAULT: CatalogueConfig = CatalogueConfig {
        classify: ClassifyConfig::DEFAULT,
        match_rel: 1e-2,
        match_abs: 1e-6,
        cloud_rel: 0.1,
        lambda_tol: 0.2,
    };
}

impl Default for CatalogueConfig {
    fn default() -> Self {
        CatalogueConfig::DEFAULT
    }
}

impl CatalogueConfig {
    /// The defaults for lanes integrated in `precision`: f32 lanes get the 10x floors of
    /// [`ClassifyConfig::for_precision`] (their rounding noise never dies out).
    pub fn for_precision(precision: jeffcott_core::ensemble::Precision) -> Self {
        let d = CatalogueConfig::default();
        match precision {
            jeffcott_core::ensemble::Precision::F64 => d,
            jeffcott_core::ensemble::Precision::F32 => CatalogueConfig {
                classify: ClassifyConfig::for_precision(precision),
                match_abs: 10.0 * d.match_abs,
                ..d
            },
        }
    }

    /// The repeat and cycle-match tolerances and lambda_tol multiplied by `factor`
    /// (n_max and cloud_rel unchanged); used to show that labels do not hinge on them.
    pub fn scaled(&self, factor: f64) -> Self {
        CatalogueConfig {
            classify: ClassifyConfig {
                n_max: self.classify.n_max,
                rel_tol: self.classify.rel_tol * factor,
                abs_tol: self.classify.abs_tol * factor,
            },
            match_rel: self.match_rel * factor,
            match_abs: self.match_abs * factor,
            cloud_rel: self.cloud_rel,
            lambda_tol: self.lambda_tol * factor,
        }
    }

    /// Checks the tolerances; errors name the option and its allowed range.
    pub fn validate(&self) -> Result<()> {
        self.classify.validate()?;
        for (name, v) in [
            ("match-rel", self.match_rel),
            ("match-abs", self.match_abs),
            ("cloud-rel", self.cloud_rel),
            ("lambda-tol", self.lambda_tol),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(name, v, "must be finite and > 0"));
            }
        }
        Ok(())
    }
}

/// One attractor of the catalogue.
#[derive(Clone, Debug, Serialize)]
pub struct Attractor {
    /// Id, 0-based in order of discovery (labels refer to it).
    pub id: u32,
    /// Class label (`period-N`, `aperiodic`, `quasiperiodic`, `chaotic`).
    pub class: String,
    /// The period for periodic attractors.
    pub period: Option<usize>,
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// Lanes that settled on it.
    pub lanes: u64,
    /// Fraction of all lanes of the catalogue (diverged ones included) that settled on it.
    pub basin_fraction: f64,
    /// Diameter of its Poincare set in the classification metric [m].
    pub size_m: f64,
    /// Representative Poincare points (states at t = kT, state order): the cycle in
    /// canonical rotation, or for aperiodic attractors the reference cloud (the points of
    /// the lanes that joined it, up to 512).
    pub points: Vec<State>,
    /// Index of the first lane (in the order added) that settled on it: a start state
    /// that reaches it.
    pub first_lane: u64,
    /// Mean largest Lyapunov exponent of its lanes [1/s], when lambda1 was computed
    /// (`None` otherwise).
    pub lambda1: Option<f64>,
    /// Smallest and largest lambda1 among its lanes [1/s].
    pub lambda1_range: Option<(f64, f64)>,
    #[serde(skip)]
    kind: Class,
    #[serde(skip)]
    l1_sum: f64,
    #[serde(skip)]
    l1_n: u64,
}

impl Attractor {
    /// Adds one lane's lambda1 to the mean and range (NaN: not computed, ignored).
    fn add_lambda1(&mut self, l: f64) {
        if l.is_finite() {
            self.merge_lambda1(l, 1, Some((l, l)));
        }
    }

    /// Adds `n` lanes' lambda1 (sum and range) to the mean and range.
    fn merge_lambda1(&mut self, sum: f64, n: u64, range: Option<(f64, f64)>) {
        if n == 0 {
            return;
        }
        self.l1_sum += sum;
        self.l1_n += n;
        self.lambda1 = Some(self.l1_sum / self.l1_n as f64);
        if let Some((lo, hi)) = range {
            self.lambda1_range = Some(match self.lambda1_range {
                Some((a, b)) => (a.min(lo), b.max(hi)),
                None => (lo, hi),
            });
        }
    }

    /// The class as an enum.
    pub fn kind(&self) -> Class {
        self.kind
    }

    /// "period-2 (#1)"-style name for legends.
    pub fn name(&self) -> String {
        format!("#{} {}", self.id, self.class)
    }
}

/// A lane after classification, before it is matched to the catalogue.
#[derive(Clone, Debug)]
pub struct LaneClass {
    /// The class.
    pub class: Class,
    /// Diameter of the Poincare set [m] (NaN when diverged).
    pub size: f64,
    /// The points that represent the lane: the last cycle for periodic lanes (canonical
    /// rotation), all points otherwise.
    pub points: Vec<State>,
    /// The lane's largest Lyapunov exponent [1/s] (NaN when not computed).
    pub lambda1: f64,
}

/// How a lane of an early-exit run ended ([`CatalogueBuilder::rebuilt_in_lane_order`]).
#[derive(Clone, Debug)]
pub enum LaneEnd {
    /// It ran whole and was classified from its record.
    Whole(LaneClass),
    /// It was recognised on this attractor of the rounds' catalogue.
    Recognised(u32),
}

/// Classifies one lane's Poincare sequence (`frozen`: flagged diverged / non-finite),
/// refining aperiodic with `lambda1` when given.
pub fn classify_lane(
    points: &[State],
    omega: f64,
    frozen: bool,
    lambda1: Option<f64>,
    cfg: &CatalogueConfig,
) -> LaneClass {
    let c = classify(points, omega, frozen, &cfg.classify);
    // A lane whose whole record lies within the catalogue's identity floor `match_abs`
    // is at a fixed point at the catalogue's resolution, whatever finer structure the
    // classifier's tighter repeat tolerance sees: a lane still spiralling into a period-1
    // response repeats after n periods (the spiral's rotation) or not at all. At 137.25
    // rad/s such lanes made "period-4", "period-5" and "aperiodic" entries 0.2-0.9 um
    // across beside the period-1 attractor they converge to (docs/early-exit.md).
    let c = match c.class {
        Class::Periodic(n) if n > 1 && c.size <= cfg.match_abs => Classification {
            class: Class::Periodic(1),
            ..c
        },
        Class::Aperiodic if c.size <= cfg.match_abs => Classification {
            class: Class::Periodic(1),
            ..c
        },
        _ => c,
    };
    let class = match (c.class, lambda1) {
        (Class::Aperiodic, Some(l)) if l.is_finite() && l.abs() < cfg.lambda_tol => {
            Class::Quasiperiodic
        }
        (Class::Aperiodic, Some(l)) if l.is_finite() && l > cfg.lambda_tol => Class::Chaotic,
        (k, _) => k,
    };
    let points = match class {
        Class::Diverged | Class::Unclassified => Vec::new(),
        Class::Periodic(n) => {
            let cycle = &points[points.len() - n..];
            // Canonical rotation: start at the smallest x_r (ties broken by order, which
            // only matters for points that agree within roundoff anyway).
            let start = (0..n)
                .min_by(|&a, &b| cycle[a][X_R].total_cmp(&cycle[b][X_R]))
                .unwrap_or(0);
            (0..n).map(|k| cycle[(start + k) % n]).collect()
        }
        _ => points.to_vec(),
    };
    LaneClass {
        class,
        size: c.size,
        points,
        lambda1: lambda1.unwrap_or(f64::NAN),
    }
}

/// True for the classes without a period (aperiodic and its lambda_1 refinements).
fn aperiodic_family(c: Class) -> bool {
    matches!(c, Class::Aperiodic | Class::Quasiperiodic | Class::Chaotic)
}

/// True when lane `l` lies on attractor `a` (the rules of the module docs). Aperiodic,
/// quasiperiodic and chaotic lanes may share an attractor: their clouds decide, since a
/// lane's lambda_1 over a few dozen periods scatters around the attractor's.
fn same(cfg: &CatalogueConfig, w: f64, l: &LaneClass, a: &Attractor) -> bool {
    if l.class != a.kind && !(aperiodic_family(l.class) && aperiodic_family(a.kind)) {
        return false;
    }
    match l.class {
        Class::Periodic(n) => {
            let tol = (cfg.match_rel * l.size.max(a.size_m)).max(cfg.match_abs);
            (0..n).any(|j| {
                distance(&l.points[0], &a.points[j], w) <= tol
                    && (0..n).all(|i| distance(&l.points[i], &a.points[(i + j) % n], w) <= tol)
            })
        }
        Class::Diverged | Class::Unclassified => false,
        _ => {
            // Same attractor: similar diameters, and most of the lane's points lie within
            // cloud_rel * size of the attractor's reference cloud (which grows as lanes
            // join it, so its coverage improves).
            let size = l.size.max(a.size_m);
            if !(l.size <= 2.0 * a.size_m && a.size_m <= 2.0 * l.size) {
                return false;
            }
            let tol = cfg.cloud_rel * size;
            let need = (l.points.len() as f64 * CLOUD_COVERAGE).ceil() as usize;
            let mut near = 0usize;
            for (k, p) in l.points.iter().enumerate() {
                if a.points.iter().any(|q| distance(p, q, w) <= tol) {
                    near += 1;
                    if near >= need {
                        return true;
                    }
                }
                if near + (l.points.len() - k - 1) < need {
                    return false;
                }
            }
            near >= need
        }
    }
}

/// Fraction of an aperiodic lane's points that must lie near an attractor's cloud.
const CLOUD_COVERAGE: f64 = 0.6;

/// Early exit's cycle tolerance relative to the cycle's diameter: 10 times the identity
/// tolerance's (a lane that close to a stable cycle for the streak's periods, in its
/// order, is on its way there; at W = 133 the 100 x 100 basin's labels were identical
/// with 10 times and 3 % off with 30 times, docs/early-exit.md).
pub const RECOGNISE_REL: f64 = 0.1;

/// Early exit's cycle tolerance at most this fraction of the cycle's distance to the
/// nearest point of another catalogued attractor, so no point can match two of them.
/// 0.45 since 2026-11-28 (0.25 before): replaying the rule on the full-length records of
/// the 100 x 100 basin at 133 rad/s, whose period-5 and period-4 cycles pass within
/// 28 um of each other, no lane was misrecognised below a cap of 1.0 (7 of 10000 at 1.0,
/// lanes lingering 7-30 um from the period-4 cycle near a saddle before leaving for the
/// period-5), and 0.45 ran 29.7 % of the periods against 32.4 % (docs/early-exit.md,
/// "Replaying the rule").
pub const RECOGNISE_SEPARATION: f64 = 0.45;
// At half the separation or more a point could be within the tolerance of two cycles;
// and a cycle the never-recognise rule lets through has its identity tolerance under the
// cap (`recogniser_of` relies on both).
const _: () = assert!(RECOGNISE_SEPARATION < 0.5 && NEVER_SEPARATION <= RECOGNISE_SEPARATION);

/// A cycle whose identity tolerance exceeds this fraction of its distance to another
/// catalogued attractor (the two lie within four identity tolerances) is not recognised
/// at all ([`too_close_to_recognise`]): such entries are usually one attractor whose
/// lanes still converge.
const NEVER_SEPARATION: f64 = 0.25;

/// Points kept in an aperiodic attractor's reference cloud, at most.
const CLOUD_POINTS: usize = 512;

/// The index of the attractor lane `l` lies on, if any.
fn find(cfg: &CatalogueConfig, w: f64, attractors: &[Attractor], l: &LaneClass) -> Option<usize> {
    attractors.iter().position(|a| same(cfg, w, l, a))
}

/// How close to a catalogued cycle a recognised lane must be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Closeness {
    /// Close enough to take its label (a lane that retires): within [`RECOGNISE_REL`] of
    /// the cycle's diameter, never more than [`RECOGNISE_SEPARATION`] of its distance to
    /// the nearest point of another attractor, and not less than the identity tolerance
    /// `max(match_rel * size, match_abs)` unless that cap is; a cycle within four
    /// of its separation tolerances of another attractor is not recognised
    /// ([`SEPARATION_ABS`]).
    Label,
    /// Close enough that a record taken from there classifies as the cycle (a lane that
    /// records early): within half the classifier's repeat tolerance
    /// `max(rel_tol * size, abs_tol)`, so points a period apart already repeat within it
    /// while the lane, contracting onto the attractor, stays so. Where it does not (a
    /// deviation that turns with a complex pair of multipliers near -1 grows again in
    /// the metric), the lane's record does not repeat like the cycle and
    /// `early::records_by_group` runs it again whole.
    Record,
}

/// Whether a cycle (tolerance `identity` of [`separation_identity`]) lies too close to an
/// attractor at distance `separation` (nearest points) for early exit to recognise it:
/// within four of its identity tolerances ([`NEVER_SEPARATION`]), so the two are likely
/// one attractor whose lanes still converge.
fn too_close_to_recognise(identity: f64, separation: f64) -> bool {
    identity > NEVER_SEPARATION * separation
}

/// A catalogued cycle's identity tolerance `max(match_rel * size, match_abs)`.
fn cycle_identity(cfg: &CatalogueConfig, a: &Attractor) -> f64 {
    (cfg.match_rel * a.size_m).max(cfg.match_abs)
}

/// The floor [m] of the separation rule ([`too_close_to_recognise`]): `match_abs`, but
/// never above the f64 catalogue's 1 um. Two entries within four of
/// `max(match_rel * size, floor)` are taken for one attractor whose lanes are still
/// converging, a statement about the dynamics at the resolution of f64 lanes. f32 lanes
/// raise their identity floor ten-fold for their rounding noise
/// ([`CatalogueConfig::for_precision`]), which says nothing about how far apart distinct
/// attractors lie: at 133 rad/s the period-5 and period-4 cycles are 28 um apart, under
/// four f32 floors (40 um), and an f32 basin there retired 62 of 3600 lanes against
/// f64's 3483 (docs/early-exit.md).
pub const SEPARATION_ABS: f64 = CatalogueConfig::DEFAULT.match_abs;

/// A catalogued cycle's tolerance in the separation rule: its identity tolerance with
/// the floor [`SEPARATION_ABS`] at most.
fn separation_identity(cfg: &CatalogueConfig, a: &Attractor) -> f64 {
    (cfg.match_rel * a.size_m).max(cfg.match_abs.min(SEPARATION_ABS))
}

/// The distance between the nearest points of attractors `a` and `b` at speed `w`
/// (infinite when either has no points).
fn apart(a: &Attractor, b: &Attractor, w: f64) -> f64 {
    a.points
        .iter()
        .flat_map(|p| b.points.iter().map(move |q| distance(p, q, w)))
        .fold(f64::INFINITY, f64::min)
}

/// The largest distance at speed `w` between the points of cycle `a` half its period
/// apart (infinite for an odd period): how far a period-2n entry lies from being a
/// period-n one.
fn half_shift(a: &Attractor, w: f64) -> f64 {
    let p = a.points.len();
    if p < 2 || p % 2 == 1 {
        return f64::INFINITY;
    }
    (0..p)
        .map(|j| distance(&a.points[j], &a.points[(j + p / 2) % p], w))
        .fold(0.0, f64::max)
}

/// What early exit recognises lanes on at speed `omega`: the periodic attractors of
/// `attractors`, a cycle point matching as `closeness` says (module docs), and with
/// `clouds` (entry i confirmed or not, [`Closeness::Label`] only) the aperiodic ones,
/// recognised where confirmed and watched where not (`early::Known`).
pub fn recogniser_of(
    attractors: &[Attractor],
    cfg: &CatalogueConfig,
    omega: f64,
    streak: u32,
    closeness: Closeness,
    clouds: Option<&[bool]>,
) -> crate::early::Recogniser {
    let separation = |a: &Attractor| {
        attractors
            .iter()
            .filter(|b| b.id != a.id)
            .map(|b| apart(a, b, omega))
            .fold(f64::INFINITY, f64::min)
    };
    let cloud_of = cloud_groups(attractors, cfg, omega);
    let known = attractors
        .iter()
        .map(|a| match a.kind {
            Class::Periodic(_)
                if too_close_to_recognise(separation_identity(cfg, a), half_shift(a, omega)) =>
            {
                // A period-2n entry within four identity tolerances of itself shifted
                // by n points: a period-n cycle whose lanes still converge near a
                // period doubling (a multiplier near -1 makes their alternation decay
                // slowly). At 133.08 rad/s the brute force's "period-18" entry is the
                // period-9 cycle seen at T = 1000 (`jeffcott orbits`: the period-9
                // cycle is stable there); lanes recorded early on it kept their
                // alternation where the full-length run's had decayed to period-9
                // (docs/early-exit.md). Its lanes run whole, as without early exit.
                crate::early::Known::Never
            }
            Class::Periodic(_) => {
                let tol = match closeness {
                    Closeness::Label => {
                        let sep = separation(a);
                        if too_close_to_recognise(separation_identity(cfg, a), sep) {
                            // Another catalogued attractor lies within four identity
                            // tolerances: a point near this cycle could be near that
                            // one too. Such neighbours are lanes still converging near
                            // a bifurcation (at 132.07 rad/s a period-1 point and two
                            // period-2 cycles within 2 um, at 136.04 a period-4 and a
                            // "period-8" on the same points; docs/early-exit.md), so
                            // the lanes run their whole record and are classified from
                            // it.
                            return crate::early::Known::Never;
                        }
                        // Never more than RECOGNISE_SEPARATION (under half) of the
                        // separation, so that no point matches two attractors, also where
                        // the identity floor (f32's) exceeds it. For f64 lanes with the
                        // default floor the cap never binds on the floor (the rule above
                        // leaves identity <= sep / 4).
                        let cap = RECOGNISE_SEPARATION * sep;
                        cycle_identity(cfg, a)
                            .max((RECOGNISE_REL * a.size_m).min(cap))
                            .min(cap)
                    }
                    Closeness::Record => {
                        0.5 * (cfg.classify.rel_tol * a.size_m).max(cfg.classify.abs_tol)
                    }
                };
                crate::early::Known::Cycle {
                    points: a.points.clone(),
                    tol,
                }
            }
            // Aperiodic entries: at 137.25 rad/s lanes still in a long transient form
            // clouds of their own, and lanes crossing them were retired on them
            // although they settle on a cycle later (docs/early-exit.md). So a cloud is
            // recognised only where `clouds` says the lanes that stayed in it ended on
            // it (`early::catalogue_groups` counts them), and watched until then;
            // without `clouds` (records, finished catalogues) never.
            // Entries of one cloud (`cloud_of`) are recognised as its first entry, on
            // all their points, at most 0.45 of their distance to any other attractor.
            k if aperiodic_family(k) && closeness == Closeness::Label => {
                let Some(confirmed) = clouds else {
                    return crate::early::Known::Never;
                };
                let rep = cloud_of[a.id as usize];
                if rep != a.id {
                    return crate::early::Known::Never;
                }
                let members: Vec<&Attractor> = attractors
                    .iter()
                    .filter(|b| cloud_of[b.id as usize] == rep)
                    .collect();
                let sep = attractors
                    .iter()
                    .filter(|b| cloud_of[b.id as usize] != rep)
                    .flat_map(|b| members.iter().map(move |m| apart(m, b, omega)))
                    .fold(f64::INFINITY, f64::min);
                let size = members.iter().map(|m| m.size_m).fold(0.0, f64::max);
                let identity = separation_identity(cfg, a);
                let tol = (cfg.cloud_rel * size).min(RECOGNISE_SEPARATION * sep);
                if too_close_to_recognise(identity, sep)
                    || tol.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
                {
                    return crate::early::Known::Never;
                }
                let points = members
                    .iter()
                    .flat_map(|m| m.points.iter().copied())
                    .collect();
                let confirmed = confirmed.get(a.id as usize).copied().unwrap_or(false);
                crate::early::Known::cloud(points, tol, confirmed)
            }
            _ => crate::early::Known::Never,
        })
        .collect();
    crate::early::Recogniser::new(omega, streak, known)
}

/// For each of `attractors` (by id), the first entry of its cloud: aperiodic entries
/// whose reference clouds come within `cloud_rel` of the larger diameter of each other,
/// directly or through others, are one cloud (a lane compared early against a still
/// sparse cloud opens a second entry of the same attractor, which `merge_clouds`
/// merges at the end); every other entry is its own.
fn cloud_groups(attractors: &[Attractor], cfg: &CatalogueConfig, omega: f64) -> Vec<u32> {
    let mut rep: Vec<u32> = (0..attractors.len() as u32).collect();
    fn root(rep: &mut [u32], mut i: u32) -> u32 {
        while rep[i as usize] != i {
            i = rep[i as usize];
        }
        i
    }
    for (i, a) in attractors.iter().enumerate() {
        for b in &attractors[..i] {
            if !(aperiodic_family(a.kind) && aperiodic_family(b.kind)) {
                continue;
            }
            if apart(a, b, omega) <= cfg.cloud_rel * a.size_m.max(b.size_m) {
                let (ra, rb) = (root(&mut rep, a.id), root(&mut rep, b.id));
                rep[ra.max(rb) as usize] = ra.min(rb);
            }
        }
    }
    (0..attractors.len() as u32)
        .map(|i| root(&mut rep, i))
        .collect()
}

/// Builds a catalogue lane by lane (so basins can stream chunks with bounded memory).
#[derive(Clone, Debug)]
pub struct CatalogueBuilder {
    cfg: CatalogueConfig,
    omega: f64,
    attractors: Vec<Attractor>,
    total: u64,
    diverged: u64,
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
    pub fn recogniser(&self, streak: u32) -> crate::early::Recogniser {
        self.recogniser_with_clouds(streak, None)
    }

    /// [`CatalogueBuilder::recogniser`], with `clouds` the aperiodic attractors too:
    /// entry `i` a recognised cloud where `clouds[i]`, else watched (`early::Known`).
    pub fn recogniser_with_clouds(
        &self,
        streak: u32,
        clouds: Option<&[bool]>,
    ) -> crate::early::Recogniser {
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
    pub fn recogniser_to_record(&self, streak: u32) -> crate::early::Recogniser {
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
    fn merge_clouds(&mut self) -> Vec<i32> {
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

/// The catalogue of a set of lanes at one W.
#[derive(Clone, Debug, Serialize)]
pub struct Catalogue {
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// The attractors, by id.
    pub attractors: Vec<Attractor>,
    /// Per lane: the attractor id, -1 for diverged lanes.
    #[serde(skip)]
    pub labels: Vec<i32>,
    /// Lanes in all.
    pub lanes: u64,
    /// Lanes flagged diverged or non-finite.
    pub diverged: u64,
    /// Fraction of lanes that diverged.
    pub diverged_fraction: f64,
    /// The tolerances used.
    pub config: CatalogueConfig,
}

impl Catalogue {
    /// The id of the catalogued attractor that the classified lane `l` lies on, if any.
    pub fn identify(&self, l: &LaneClass) -> Option<u32> {
        find(&self.config, self.omega, &self.attractors, l).map(|k| k as u32)
    }

    /// The label of every lane of `r` (integrated at this catalogue's W) against this
    /// catalogue: the attractor id, -1 for a frozen (diverged) lane, -2 for a lane on no
    /// catalogued attractor. The labelling of the basin's re-integrated points
    /// (refinement, uncertainty exponent).
    pub fn label_lanes(&self, r: &jeffcott_core::ensemble::EnsembleResult) -> Vec<i32> {
        (0..r.status.len()).map(|i| self.label_lane(r, i)).collect()
    }

    /// Lane `i` of `r` labelled as [`Catalogue::label_lanes`] does.
    pub fn label_lane(&self, r: &jeffcott_core::ensemble::EnsembleResult, i: usize) -> i32 {
        if r.status[i].is_frozen() {
            return -1;
        }
        let lc = classify_lane(
            &r.lane_states(i),
            self.omega,
            false,
            r.lambda1.as_ref().map(|l| l[i]),
            &self.config,
        );
        self.identify(&lc).map(|id| id as i32).unwrap_or(-2)
    }

    /// Pairs of entries (ids, distance of their nearest points [metric of `distance`])
    /// of which at least one is a cycle lying within four of its separation tolerances
    /// (identity tolerances with the floor [`SEPARATION_ABS`] at most) of the other: the
    /// pairs early exit does not recognise ([`recogniser_of`]). Near a bifurcation such
    /// entries are usually one attractor whose lanes are still converging (at
    /// 132.068 rad/s a period-1 point and two period-2 "cycles" within 2 um at 1000
    /// transient periods, one period-1 point at 4000; docs/early-exit.md), so the basin
    /// study names them for the user to check with a longer transient.
    pub fn close_pairs(&self) -> Vec<(u32, u32, f64)> {
        let unrecognised = |a: &Attractor, d: f64| {
            matches!(a.kind, Class::Periodic(_))
                && too_close_to_recognise(separation_identity(&self.config, a), d)
        };
        let mut out = Vec::new();
        for (i, a) in self.attractors.iter().enumerate() {
            for b in &self.attractors[i + 1..] {
                let d = apart(a, b, self.omega);
                if unrecognised(a, d) || unrecognised(b, d) {
                    out.push((a.id, b.id, d));
                }
            }
        }
        out
    }

    /// What early exit recognises lanes on against this catalogue ([`recogniser_of`]):
    /// its cycles, and with `clouds` its aperiodic attractors, entry i recognised where
    /// `clouds[i]` and watched where not.
    pub fn recogniser(&self, streak: u32, clouds: Option<&[bool]>) -> crate::early::Recogniser {
        recogniser_of(
            &self.attractors,
            &self.config,
            self.omega,
            streak,
            Closeness::Label,
            clouds,
        )
    }

    /// For each attractor (by id), the first entry of its cloud ([`cloud_groups`]).
    pub fn cloud_groups(&self) -> Vec<u32> {
        cloud_groups(&self.attractors, &self.config, self.omega)
    }

    /// Whether any attractor is aperiodic (a cloud early exit may recognise).
    pub fn has_clouds(&self) -> bool {
        self.attractors.iter().any(|a| aperiodic_family(a.kind))
    }
}

/// Catalogues lanes at one W: `points` is [lanes, recorded, 8] flat (as in
/// `EnsembleResult::poincare`), `frozen` flags diverged lanes, `lambda1` is the largest
/// Lyapunov exponent per lane [1/s] when known.
pub fn catalogue(
    omega: f64,
    points: &[f64],
    recorded: usize,
    frozen: &[bool],
    lambda1: Option<&[f64]>,
    cfg: &CatalogueConfig,
) -> Catalogue {
    let mut b = CatalogueBuilder::new(omega, *cfg);
    let labels = b.add_block(points, recorded, frozen, lambda1);
    b.finish(labels)
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

/// Catalogues lanes of an ensemble result that all run at speed `omega`.
pub fn catalogue_result(
    omega: f64,
    res: &jeffcott_core::ensemble::EnsembleResult,
    lambda1: Option<&[f64]>,
    cfg: &CatalogueConfig,
) -> Catalogue {
    let frozen: Vec<bool> = res.status.iter().map(|s| s.is_frozen()).collect();
    catalogue(omega, &res.poincare, res.recorded, &frozen, lambda1, cfg)
}
