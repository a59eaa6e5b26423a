//! The attractor catalogue of an ensemble at one rotor speed W (docs/model.md 5): every lane
//! is classified from its Poincare points ([`classify`](crate::classify::classify)) and given the id of the
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
//!
//! The rules live in [`identity`] (which attractor a lane lies on), [`recognise`] (what
//! early exit may retire a lane on), `builder` (the catalogue grown lane by lane) and
//! `parts` (the partial catalogues of work units and how they are absorbed).

mod builder;
mod identity;
mod parts;
mod recognise;

pub use builder::CatalogueBuilder;
pub use identity::classify_lane;
pub(crate) use parts::fill_points;
pub use parts::{PartAttractor, part_unit, unit_parts};
pub use recognise::{
    Closeness, RECOGNISE_REL, RECOGNISE_SEPARATION, SEPARATION_ABS, recogniser_of,
};

use crate::classify::{Class, ClassifyConfig};
use identity::{aperiodic_family, find};
use jeffcott_core::error::Result;
use jeffcott_core::model::State;
use recognise::{apart, cloud_groups, separation_identity, too_close_to_recognise};
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
            jeffcott_core::inputs::check_positive(name, v, "")?;
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
