//! Matching the attractors of one value to those of the previous one by Poincare-set
//! distance (Attractors.jl's `MatchBySSSetDistance`).

use crate::classify::distance;
use jeffcott_core::model::State;

/// Poincare-set distance between two attractors at speed `w`: the larger of the two
/// mean nearest-point distances (a mean Hausdorff distance, robust to a cloud's spread).
pub fn set_distance(a: &[State], b: &[State], w: f64) -> f64 {
    let one_way = |x: &[State], y: &[State]| {
        x.iter()
            .map(|p| {
                y.iter()
                    .map(|q| distance(p, q, w))
                    .fold(f64::INFINITY, f64::min)
            })
            .sum::<f64>()
            / x.len().max(1) as f64
    };
    if a.is_empty() || b.is_empty() {
        return f64::INFINITY;
    }
    one_way(a, b).max(one_way(b, a))
}

/// Matches `now` to `prev` (greedy in increasing set distance, each at most once, within
/// `threshold`); returns for each of `now` the index into `prev` it continues.
pub fn match_attractors(
    prev: &[Vec<State>],
    now: &[Vec<State>],
    w: f64,
    threshold: f64,
) -> Vec<Option<usize>> {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, p) in prev.iter().enumerate() {
        for (j, q) in now.iter().enumerate() {
            let d = set_distance(p, q, w);
            if d <= threshold {
                pairs.push((d, i, j));
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut out = vec![None; now.len()];
    let mut used = vec![false; prev.len()];
    for (_, i, j) in pairs {
        if !used[i] && out[j].is_none() {
            used[i] = true;
            out[j] = Some(i);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use jeffcott_core::model::STATE_DIM;

    fn pt(x: f64) -> State {
        let mut s = [0.0; STATE_DIM];
        s[0] = x;
        s
    }

    #[test]
    fn matching_pairs_nearest_sets_first_and_each_once() {
        let prev = vec![vec![pt(0.0)], vec![pt(1.0)]];
        let now = vec![vec![pt(1.1)], vec![pt(0.05)], vec![pt(5.0)]];
        let m = match_attractors(&prev, &now, 100.0, f64::INFINITY);
        assert_eq!(m, vec![Some(1), Some(0), None]);
        let m = match_attractors(&prev, &now, 100.0, 0.08);
        assert_eq!(m, vec![None, Some(0), None]);
    }
}
