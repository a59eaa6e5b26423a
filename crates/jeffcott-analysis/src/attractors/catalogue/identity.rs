//! Which attractor a lane lies on: a lane classified and reduced to its representative
//! points ([`classify_lane`]), and the identity rules of the catalogue's module docs
//! that match it to a catalogued attractor.

use super::{Attractor, CatalogueConfig, LaneClass};
use crate::classify::{Class, Classification, classify, distance};
use jeffcott_core::model::{State, X_R};

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
pub(super) fn aperiodic_family(c: Class) -> bool {
    matches!(c, Class::Aperiodic | Class::Quasiperiodic | Class::Chaotic)
}

/// True when lane `l` lies on attractor `a` (the rules of the module docs). Aperiodic,
/// quasiperiodic and chaotic lanes may share an attractor: their clouds decide, since a
/// lane's lambda_1 over a few dozen periods scatters around the attractor's.
pub(super) fn same(cfg: &CatalogueConfig, w: f64, l: &LaneClass, a: &Attractor) -> bool {
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

/// Points kept in an aperiodic attractor's reference cloud, at most.
pub(super) const CLOUD_POINTS: usize = 512;

/// The index of the attractor lane `l` lies on, if any.
pub(super) fn find(
    cfg: &CatalogueConfig,
    w: f64,
    attractors: &[Attractor],
    l: &LaneClass,
) -> Option<usize> {
    attractors.iter().position(|a| same(cfg, w, l, a))
}
