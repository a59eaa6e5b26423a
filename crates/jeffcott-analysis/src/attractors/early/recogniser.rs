//! The rule ([`Recogniser`]): a lane's Poincare points compared, period by period, with
//! the attractors early exit knows ([`Known`]), and [`ByGroup`], which recognises each
//! lane on the catalogue of its group.

use crate::classify::distance;
use jeffcott_core::ensemble::early::{Recognise, Track};
use jeffcott_core::model::{STATE_DIM, State};

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

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(v: f64) -> State {
        [v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
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
    fn aperiodic_and_unclassified_entries_are_never_recognised() {
        let r = Recogniser::new(100.0, 1, vec![Known::Never]);
        let mut t = Track::default();
        for v in [0.0, 0.5, 1.0] {
            assert_eq!(r.observe(0, &mut t, &pt(v)), None);
        }
    }
}
