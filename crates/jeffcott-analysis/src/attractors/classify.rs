//! Attractor classification from stroboscopic Poincare points (docs/model.md 5).
//!
//! Points are compared in a metric with one unit, metres: positions as they are and
//! velocities divided by W (a velocity v on an orbit of radius A at frequency W has
//! v/W ~ A). A sequence is period-n when every point agrees with the point n periods
//! later within `tol = max(rel_tol * size, abs_tol)`, with `size` the diameter of the
//! Poincare set in that metric, for the smallest such n <= n_max that the record can
//! show at least twice.

use jeffcott_core::model::{STATE_DIM, State};
use serde::{Deserialize, Serialize};

/// Tolerances of the classifier.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClassifyConfig {
    /// Largest period looked for.
    pub n_max: usize,
    /// Repeat tolerance relative to the Poincare set's diameter.
    pub rel_tol: f64,
    /// Repeat tolerance floor [m] (period-1 sets have zero diameter).
    pub abs_tol: f64,
}

impl ClassifyConfig {
    /// The defaults for f64 lanes, in one place (the command line's and the Python
    /// package's defaults are these fields).
    pub const DEFAULT: ClassifyConfig = ClassifyConfig {
        n_max: 32,
        rel_tol: 1e-3,
        abs_tol: 1e-7,
    };
}

impl Default for ClassifyConfig {
    fn default() -> Self {
        ClassifyConfig::DEFAULT
    }
}

impl ClassifyConfig {
    /// Checks the tolerances; errors name the option (`n-max`, `rel-tol`, `abs-tol`)
    /// and the allowed range. Every front end validates here, not on its own.
    pub fn validate(&self) -> jeffcott_core::Result<()> {
        use jeffcott_core::Error;
        if !(1..=4096).contains(&self.n_max) {
            return Err(Error::invalid("n-max", self.n_max, "must be in 1..=4096"));
        }
        jeffcott_core::inputs::check_positive("rel-tol", self.rel_tol, "")?;
        jeffcott_core::inputs::check_positive("abs-tol", self.abs_tol, "m")
    }

    /// The defaults for lanes integrated in `precision`. In f32 the state carries a
    /// rounding noise that a stable cycle damps but never removes: measured on
    /// period-1 lanes at W = 131.5-132.0 (tests/gpu.rs), points scatter by 3-7e-8 m,
    /// and by more close to a period-doubling, where the cycle's multiplier nears -1
    /// and damps the noise slowly. The f64 floor (1e-7 m) would then split a period-1
    /// cycle into a spurious period-2, so f32 lanes get a 10x floor, 1e-6 m: still far
    /// below the smallest attractor features of interest (the period-2 cycle at
    /// W = 132.2 spans ~1e-4 m).
    pub fn for_precision(precision: jeffcott_core::ensemble::Precision) -> Self {
        match precision {
            jeffcott_core::ensemble::Precision::F64 => ClassifyConfig::default(),
            jeffcott_core::ensemble::Precision::F32 => ClassifyConfig {
                abs_tol: 1e-6,
                ..ClassifyConfig::default()
            },
        }
    }
}

/// The class of a trajectory's long-time behaviour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Class {
    /// Poincare points repeat after `n` periods.
    Periodic(usize),
    /// No period up to n_max, and no Lyapunov exponent to say more (or one that is
    /// clearly negative: a period beyond n_max or a slow transient).
    Aperiodic,
    /// Aperiodic with a largest Lyapunov exponent ~ 0 (|lambda1| < tolerance).
    Quasiperiodic,
    /// Aperiodic with a positive largest Lyapunov exponent (lambda1 > tolerance).
    Chaotic,
    /// The lane was frozen (diverged or non-finite).
    Diverged,
    /// Fewer than [`MIN_POINTS`] Poincare points: too few to say anything (even
    /// period-1 needs one repeat).
    Unclassified,
}

/// Fewest Poincare points the classifier needs: period-1 is one point that repeats.
pub const MIN_POINTS: usize = 2;

impl Class {
    /// The label used in files: `period-N`, `aperiodic`, `quasiperiodic`, `chaotic`,
    /// `diverged`, `unclassified`.
    pub fn label(&self) -> String {
        match self {
            Class::Periodic(n) => format!("period-{n}"),
            Class::Aperiodic => "aperiodic".into(),
            Class::Quasiperiodic => "quasiperiodic".into(),
            Class::Chaotic => "chaotic".into(),
            Class::Diverged => "diverged".into(),
            Class::Unclassified => "unclassified".into(),
        }
    }

    /// The class without its lambda_1 refinement (quasiperiodic and chaotic are
    /// aperiodic): what the Poincare points alone say. Comparisons between runs use it,
    /// since a lambda_1 over a few dozen periods scatters across the thresholds.
    pub fn unrefined(&self) -> Class {
        match self {
            Class::Quasiperiodic | Class::Chaotic => Class::Aperiodic,
            c => *c,
        }
    }

    /// The period, if periodic.
    pub fn period(&self) -> Option<usize> {
        match self {
            Class::Periodic(n) => Some(*n),
            _ => None,
        }
    }
}

/// Outcome of [`classify`].
#[derive(Clone, Copy, Debug)]
pub struct Classification {
    /// The class.
    pub class: Class,
    /// Diameter of the Poincare set in the metric above [m].
    pub size: f64,
    /// Largest repeat mismatch at the detected period [m] (NaN when not periodic).
    pub repeat_error: f64,
    /// The tolerance used [m].
    pub tol: f64,
}

/// Distance between two states in the metric of the module docs [m].
pub fn distance(a: &State, b: &State, omega: f64) -> f64 {
    let mut d: f64 = 0.0;
    for i in 0..STATE_DIM {
        d = d.max((a[i] - b[i]).abs() / metric_scale(i, omega));
    }
    d
}

/// What [`distance`] divides coordinate `i`'s difference by: W for the velocities (odd
/// indices), 1 for the positions.
pub fn metric_scale(i: usize, omega: f64) -> f64 {
    if i % 2 == 1 { omega } else { 1.0 }
}

/// Classifies a Poincare sequence taken after the transient. `frozen` lanes are
/// "diverged" whatever their points; fewer than [`MIN_POINTS`] points are
/// "unclassified".
pub fn classify(
    points: &[State],
    omega: f64,
    frozen: bool,
    cfg: &ClassifyConfig,
) -> Classification {
    if frozen || points.iter().any(|p| p.iter().any(|v| !v.is_finite())) {
        return Classification {
            class: Class::Diverged,
            size: f64::NAN,
            repeat_error: f64::NAN,
            tol: f64::NAN,
        };
    }
    if points.len() < MIN_POINTS {
        return Classification {
            class: Class::Unclassified,
            size: f64::NAN,
            repeat_error: f64::NAN,
            tol: f64::NAN,
        };
    }
    // Diameter via the bounding box (within a factor sqrt(8) of the true diameter in the
    // max metric, and cheap for long records).
    let mut size: f64 = 0.0;
    for i in 0..STATE_DIM {
        let scale = if i % 2 == 1 { omega } else { 1.0 };
        let (lo, hi) = points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[i]), hi.max(p[i]))
            });
        size = size.max((hi - lo) / scale);
    }
    let tol = (cfg.rel_tol * size).max(cfg.abs_tol);
    for n in 1..=cfg.n_max {
        if points.len() < 2 * n {
            break;
        }
        let mut worst: f64 = 0.0;
        for i in 0..points.len() - n {
            worst = worst.max(distance(&points[i], &points[i + n], omega));
            if worst > tol {
                break;
            }
        }
        if worst <= tol {
            return Classification {
                class: Class::Periodic(n),
                size,
                repeat_error: worst,
                tol,
            };
        }
    }
    Classification {
        class: Class::Aperiodic,
        size,
        repeat_error: f64::NAN,
        tol,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn orbit(n: usize, len: usize, noise: f64) -> Vec<State> {
        (0..len)
            .map(|i| {
                let ph = (i % n) as f64;
                let jitter = noise * ((i * 7919 % 13) as f64 / 13.0 - 0.5);
                let mut s = [0.0; STATE_DIM];
                s[0] = 1e-3 * ph.cos() + jitter;
                s[1] = 0.1 * ph.sin();
                s[4] = 1e-5 * ph;
                s
            })
            .collect()
    }

    #[test]
    fn period_n_sequences_are_recognised_with_noise_below_tolerance() {
        for n in [1, 2, 3, 5, 12] {
            let c = classify(
                &orbit(n, 80, 1e-9),
                133.0,
                false,
                &ClassifyConfig::default(),
            );
            assert_eq!(c.class, Class::Periodic(n), "n = {n}");
        }
    }

    #[test]
    fn fewer_than_two_points_are_unclassified_not_aperiodic() {
        let cfg = ClassifyConfig::default();
        for len in [0, 1] {
            let c = classify(&orbit(1, len, 0.0), 133.0, false, &cfg);
            assert_eq!(c.class, Class::Unclassified, "{len} points");
            assert_eq!(c.class.label(), "unclassified");
        }
        assert_eq!(
            classify(&orbit(1, 2, 0.0), 133.0, false, &cfg).class,
            Class::Periodic(1)
        );
        assert_eq!(
            classify(&orbit(1, 1, 0.0), 133.0, true, &cfg).class,
            Class::Diverged
        );
    }

    #[test]
    fn a_quasiperiodic_circle_is_aperiodic() {
        let rho = (5f64.sqrt() - 1.0) / 2.0;
        let pts: Vec<State> = (0..200)
            .map(|i| {
                let a = std::f64::consts::TAU * rho * i as f64;
                let mut s = [0.0; STATE_DIM];
                s[0] = 1e-3 * a.cos();
                s[2] = 1e-3 * a.sin();
                s
            })
            .collect();
        assert_eq!(
            classify(&pts, 133.0, false, &ClassifyConfig::default()).class,
            Class::Aperiodic
        );
    }
}
