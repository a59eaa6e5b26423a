//! What early exit may retire a lane on: the catalogued cycles (and confirmed clouds)
//! with their recognition tolerances, kept under half of each one's distance to every
//! other attractor so that no point matches two of them.

use super::identity::aperiodic_family;
use super::{Attractor, CatalogueConfig};
use crate::classify::{Class, distance};
use crate::early::{Known, Recogniser};

/// Early exit's cycle tolerance relative to the cycle's diameter: 10 times the identity
/// tolerance's (a lane that close to a stable cycle for the streak's periods, in its
/// order, is on its way there; at W = 133 the 100 x 100 basin's labels were identical
/// with 10 times and 3 % off with 30 times, docs/early-exit.md).
pub const RECOGNISE_REL: f64 = 0.1;

/// Early exit's cycle tolerance at most this fraction of the cycle's distance to the
/// nearest point of another catalogued attractor, so no point can match two of them.
/// 0.45: replaying the rule on the full-length records of
/// the 100 x 100 basin at 133 rad/s, whose period-5 and period-4 cycles pass within
/// 28 um of each other, no lane was misrecognised below a cap of 1.0 (7 of 10000 at 1.0,
/// lanes lingering 7-30 um from the period-4 cycle near a saddle before leaving for the
/// period-5), and 0.45 ran 29.7 % of the periods against 32.4 % at 0.25 (docs/early-exit.md,
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
pub(super) fn too_close_to_recognise(identity: f64, separation: f64) -> bool {
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
pub(super) fn separation_identity(cfg: &CatalogueConfig, a: &Attractor) -> f64 {
    (cfg.match_rel * a.size_m).max(cfg.match_abs.min(SEPARATION_ABS))
}

/// The distance between the nearest points of attractors `a` and `b` at speed `w`
/// (infinite when either has no points).
pub(super) fn apart(a: &Attractor, b: &Attractor, w: f64) -> f64 {
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
) -> Recogniser {
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
                Known::Never
            }
            Class::Periodic(_) => known_cycle(attractors, cfg, omega, a, closeness),
            // Aperiodic entries: at 137.25 rad/s lanes still in a long transient form
            // clouds of their own, and lanes crossing them were retired on them
            // although they settle on a cycle later (docs/early-exit.md). So a cloud is
            // recognised only where `clouds` says the lanes that stayed in it ended on
            // it (`early::catalogue_groups` counts them), and watched until then;
            // without `clouds` (records, finished catalogues) never.
            k if aperiodic_family(k) && closeness == Closeness::Label => match clouds {
                Some(confirmed) => known_cloud(attractors, cfg, omega, a, &cloud_of, confirmed),
                None => Known::Never,
            },
            _ => Known::Never,
        })
        .collect();
    Recogniser::new(omega, streak, known)
}

/// The distance from `a` to the nearest point of any other of `attractors` at `omega`.
fn separation(attractors: &[Attractor], a: &Attractor, omega: f64) -> f64 {
    attractors
        .iter()
        .filter(|b| b.id != a.id)
        .map(|b| apart(a, b, omega))
        .fold(f64::INFINITY, f64::min)
}

/// How early exit knows the periodic entry `a` of `attractors`: its cycle with the
/// tolerance `closeness` asks for, or never where another attractor lies too close.
fn known_cycle(
    attractors: &[Attractor],
    cfg: &CatalogueConfig,
    omega: f64,
    a: &Attractor,
    closeness: Closeness,
) -> Known {
    let tol = match closeness {
        Closeness::Label => {
            let sep = separation(attractors, a, omega);
            if too_close_to_recognise(separation_identity(cfg, a), sep) {
                // Another catalogued attractor lies within four identity
                // tolerances: a point near this cycle could be near that
                // one too. Such neighbours are lanes still converging near
                // a bifurcation (at 132.07 rad/s a period-1 point and two
                // period-2 cycles within 2 um, at 136.04 a period-4 and a
                // "period-8" on the same points; docs/early-exit.md), so
                // the lanes run their whole record and are classified from
                // it.
                return Known::Never;
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
        Closeness::Record => 0.5 * (cfg.classify.rel_tol * a.size_m).max(cfg.classify.abs_tol),
    };
    Known::Cycle {
        points: a.points.clone(),
        tol,
    }
}

/// How early exit knows the aperiodic entry `a` of `attractors` (`cloud_of`: the first
/// entry of each one's cloud; `confirmed`: which clouds the lanes that stayed in them
/// ended on). Entries of one cloud are recognised as its first entry, on all their
/// points, at most 0.45 of their distance to any other attractor; the other entries of
/// the cloud, and a cloud too close to another attractor, never.
fn known_cloud(
    attractors: &[Attractor],
    cfg: &CatalogueConfig,
    omega: f64,
    a: &Attractor,
    cloud_of: &[u32],
    confirmed: &[bool],
) -> Known {
    let rep = cloud_of[a.id as usize];
    if rep != a.id {
        return Known::Never;
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
        return Known::Never;
    }
    let points = members
        .iter()
        .flat_map(|m| m.points.iter().copied())
        .collect();
    let confirmed = confirmed.get(a.id as usize).copied().unwrap_or(false);
    Known::cloud(points, tol, confirmed)
}

/// For each of `attractors` (by id), the first entry of its cloud: aperiodic entries
/// whose reference clouds come within `cloud_rel` of the larger diameter of each other,
/// directly or through others, are one cloud (a lane compared early against a still
/// sparse cloud opens a second entry of the same attractor, which `merge_clouds`
/// merges at the end); every other entry is its own.
pub(super) fn cloud_groups(
    attractors: &[Attractor],
    cfg: &CatalogueConfig,
    omega: f64,
) -> Vec<u32> {
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
