//! What a ramp found: the attractors tracked at each value ([`Tracked`], [`Step`]) and,
//! per [`Ramp`], the basin fractions, the tipping probabilities between consecutive
//! values and each attractor's lifetime.

use super::Direction;
use jeffcott_core::model::State;
use serde::{Deserialize, Serialize};

/// An attractor at one value of a continuation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tracked {
    /// Continuation id (kept while the attractor is matched from value to value).
    pub id: u32,
    /// Class at this value.
    pub class: String,
    /// Period at this value, when periodic.
    pub period: Option<usize>,
    /// Basin fraction among the K fresh start states.
    pub fraction: f64,
    /// Its binomial standard error sqrt(f (1 - f) / K).
    pub error: f64,
    /// Mean lambda_1 of its lanes [1/s].
    pub lambda1: Option<f64>,
    /// Diameter of its Poincare set [m].
    pub size_m: f64,
    /// Found only from a seed (no fresh start state reaches it).
    pub seeded_only: bool,
    /// One of its Poincare points, a state at t = kT (`jeffcott orbits --from` shoots
    /// periodic orbits from it).
    #[serde(default)]
    pub state: Option<State>,
    /// Representative Poincare points (seeds and matching), not in the JSON.
    #[serde(skip)]
    pub points: Vec<State>,
}

/// One value of one direction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Step {
    /// Parameter value.
    pub value: f64,
    /// Attractors present.
    pub attractors: Vec<Tracked>,
    /// Fraction of fresh start states that diverged.
    pub diverged_fraction: f64,
    /// Continuation id of each fresh start state's attractor (-1 diverged).
    #[serde(skip)]
    pub labels: Vec<i32>,
}

/// One direction's result.
#[derive(Clone, Debug)]
pub struct Ramp {
    /// Which way.
    pub direction: Direction,
    /// Steps in ramp order.
    pub steps: Vec<Step>,
    /// Number of continuation ids used.
    pub ids: usize,
}

impl Ramp {
    /// Basin fractions [steps, ids + 1] in ramp order (last column: diverged), with
    /// their standard errors.
    pub fn fractions(&self) -> (Vec<f64>, Vec<f64>) {
        let g = self.ids + 1;
        let mut f = vec![0.0; self.steps.len() * g];
        let mut e = vec![0.0; self.steps.len() * g];
        for (k, s) in self.steps.iter().enumerate() {
            for a in &s.attractors {
                f[k * g + a.id as usize] = a.fraction;
                e[k * g + a.id as usize] = a.error;
            }
            let n = s.labels.len().max(1) as f64;
            f[k * g + self.ids] = s.diverged_fraction;
            e[k * g + self.ids] = (s.diverged_fraction * (1.0 - s.diverged_fraction) / n).sqrt();
        }
        (f, e)
    }

    /// Tipping probabilities [steps - 1, ids + 1, ids + 1] between consecutive steps in
    /// ramp order (index `ids` is diverged); rows of attractors without a basin at the
    /// earlier step are NaN.
    pub fn tipping(&self) -> Vec<f64> {
        let g = self.ids + 1;
        let idx = |l: i32| if l < 0 { self.ids } else { l as usize };
        let mut t = vec![f64::NAN; self.steps.len().saturating_sub(1) * g * g];
        for k in 0..self.steps.len().saturating_sub(1) {
            let (a, b) = (&self.steps[k].labels, &self.steps[k + 1].labels);
            let mut counts = vec![0u64; g * g];
            for (&i, &j) in a.iter().zip(b) {
                counts[idx(i) * g + idx(j)] += 1;
            }
            for i in 0..g {
                let row: u64 = counts[i * g..(i + 1) * g].iter().sum();
                if row > 0 {
                    for j in 0..g {
                        t[(k * g + i) * g + j] = counts[i * g + j] as f64 / row as f64;
                    }
                }
            }
        }
        t
    }

    /// (id, value where first present, value where last present) in id order.
    pub fn lifetimes(&self) -> Vec<(u32, f64, f64)> {
        (0..self.ids as u32)
            .filter_map(|id| {
                let present: Vec<f64> = self
                    .steps
                    .iter()
                    .filter(|s| s.attractors.iter().any(|a| a.id == id))
                    .map(|s| s.value)
                    .collect();
                Some((id, *present.first()?, *present.last()?))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tipping_rows_sum_to_one_and_follow_the_start_states() {
        let step = |labels: Vec<i32>| Step {
            value: 0.0,
            attractors: Vec::new(),
            diverged_fraction: 0.0,
            labels,
        };
        let r = Ramp {
            direction: Direction::Up,
            steps: vec![step(vec![0, 0, 1, 1]), step(vec![0, 1, 1, -1])],
            ids: 2,
        };
        let t = r.tipping();
        let g = 3;
        assert_eq!(&t[0..g], &[0.5, 0.5, 0.0]);
        assert_eq!(&t[g..2 * g], &[0.0, 0.5, 0.5]);
        assert!(t[2 * g].is_nan(), "no basin of diverged at the first step");
    }
}
