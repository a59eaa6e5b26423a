//! Branches of periodic orbits over W or a model parameter, continued by
//! pseudo-arclength through folds, with their bifurcations located.
//!
//! A branch point is (x, p): x a fixed point of P^n at parameter value p
//! (`jeffcott_core::orbit`). From a converged point the tangent t of the solution curve
//! spans the null space of [M - I | dF/dp] (dF/dp by a central difference of P^n); the
//! next point is predicted at arclength ds along t and corrected by Newton on the
//! bordered system [P^n(x; p) - x ; t . (u - u_prev) - ds] (Keller's pseudo-arclength,
//! Seydel, "Practical Bifurcation and Stability Analysis", 2010, ch. 4), so the branch
//! turns at folds instead of stopping. Arclength is measured in scaled coordinates:
//! positions in metres, velocities divided by W, the parameter times 1 mm per its
//! range, so a step weighs a change of the orbit and of the parameter alike.
//!
//! Test functions between consecutive points ([`Crossing`]): a fold where the tangent's
//! parameter component changes sign; a period doubling where det(M + I) does (a real
//! multiplier through -1); a Neimark-Sacker bifurcation where the number of complex
//! multipliers outside the unit circle changes; a grazing where the orbit's smallest
//! clearance changes sign (a contact begins or ends). Each is located by bisection of
//! the arclength from the point before it, to 1e-8 in the parameter.

use crate::map::MapVar;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{Params, STATE_DIM, State};
use jeffcott_core::orbit::{
    Complex, Flow, FlowAsk, Flows, ShootConfig, Start, Want, advance, metric, multipliers,
    shoot_many, shoot_one,
};
use nalgebra::{SMatrix, SVector};
use serde::Serialize;

/// What a branch continues.
#[derive(Clone, Debug)]
pub struct BranchSpec {
    /// Model parameters (the continued one is overwritten at each point).
    pub params: Params,
    /// Rotor speed W [rad/s] when the continued parameter is not W.
    pub omega: f64,
    /// The continued parameter: W or a model parameter.
    pub var: MapVar,
    /// Its range: the branch stops when it leaves [lo, hi].
    pub lo: f64,
    /// See `lo`.
    pub hi: f64,
    /// The first point's parameter value.
    pub start_value: f64,
    /// A guess of the first orbit's state at t = 0.
    pub start: State,
    /// Period of the orbits in forcing periods.
    pub period: u32,
    /// +1: the parameter first increases; -1: decreases.
    pub direction: f64,
    /// Points at most.
    pub max_points: usize,
    /// First and largest arclength step (scaled coordinates, metres).
    pub ds: f64,
    /// See `ds`.
    pub ds_max: f64,
    /// Shooting settings (stepper, tolerance, iterations).
    pub shoot: ShootConfig,
}

/// One point of a branch.
#[derive(Clone, Debug, Serialize)]
pub struct BranchPoint {
    /// The parameter's value.
    pub value: f64,
    /// The orbit's state at t = 0.
    pub x: State,
    /// Floquet multipliers, by decreasing modulus, as [re, im].
    pub multipliers: Vec<[f64; 2]>,
    /// All multipliers inside the unit circle.
    pub stable: bool,
    /// The smallest rotor-stator clearance over the orbit [m] (negative: in contact).
    pub min_clearance: f64,
    /// The tangent's parameter component (scaled): its sign is the direction of travel.
    #[serde(skip)]
    tangent: [f64; STATE_DIM + 1],
    #[serde(skip)]
    mu: Vec<Complex<f64>>,
}

/// A bifurcation type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Crossing {
    /// A multiplier through +1: the branch turns back.
    Fold,
    /// A multiplier through -1: a period-2n branch is born.
    PeriodDoubling,
    /// A complex pair through the unit circle: a torus (quasiperiodic response) is born.
    NeimarkSacker,
    /// The orbit's smallest clearance through 0: a contact begins or ends.
    Grazing,
}

impl Crossing {
    /// The name in words ("period doubling").
    pub fn label(self) -> &'static str {
        match self {
            Crossing::Fold => "fold",
            Crossing::PeriodDoubling => "period doubling",
            Crossing::NeimarkSacker => "Neimark-Sacker",
            Crossing::Grazing => "grazing",
        }
    }
}

/// A located bifurcation.
#[derive(Clone, Debug, Serialize)]
pub struct Bifurcation {
    /// Its type.
    #[serde(rename = "type")]
    pub kind: Crossing,
    /// The parameter's value.
    pub value: f64,
    /// The orbit's state there.
    pub x: State,
    /// The multipliers there, as [re, im].
    pub multipliers: Vec<[f64; 2]>,
    /// The smallest clearance there [m].
    pub min_clearance: f64,
    /// Index of the branch point before it.
    pub after_point: usize,
}

/// A continued branch.
#[derive(Clone, Debug, Serialize)]
pub struct Branch {
    /// Period in forcing periods, as asked for (the shooting problem's).
    pub period: u32,
    /// The smallest number of forcing periods after which the branch's first orbit
    /// closes: a divisor of `period`, smaller when a period-1 orbit was shot as period 2
    /// (its multipliers are then those of `period` forcing periods).
    pub minimal_period: u32,
    /// Its points in the order continued.
    pub points: Vec<BranchPoint>,
    /// Its bifurcations in the order met.
    pub bifurcations: Vec<Bifurcation>,
    /// Why it ended.
    pub stop: String,
}

impl Branch {
    /// The parameter's values at its first and last points (NaN when it has none).
    pub fn span(&self) -> (f64, f64) {
        (
            self.points.first().map_or(f64::NAN, |p| p.value),
            self.points.last().map_or(f64::NAN, |p| p.value),
        )
    }

    /// Its bifurcations in words, in the order met and joined by commas: "period
    /// doubling at {at}{value}", the value to `decimals` places; `none` when it has none.
    pub fn found(&self, at: &str, decimals: usize, none: &str) -> String {
        if self.bifurcations.is_empty() {
            return none.to_string();
        }
        let words: Vec<String> = self
            .bifurcations
            .iter()
            .map(|x| format!("{} at {at}{:.*}", x.kind.label(), decimals, x.value))
            .collect();
        words.join(", ")
    }
}

/// Scale of the parameter in the arclength: 1 mm per the range.
fn theta(spec: &BranchSpec) -> f64 {
    1e-3 / (spec.hi - spec.lo).abs().max(f64::MIN_POSITIVE)
}

impl BranchSpec {
    /// Parameters and speed at parameter value `v`.
    fn at(&self, v: f64) -> (Params, f64) {
        let mut p = self.params.clone();
        let mut w = self.omega;
        match self.var {
            MapVar::Omega => w = v,
            MapVar::Param(k) => p.set(k, v).expect("MapVar::Param holds a known key"),
            MapVar::Coord(_) => unreachable!("validated: a branch continues W or a parameter"),
        }
        (p, w)
    }

    /// The n Poincare points of the period-n orbit through `x` at value `v`: x, P(x),
    /// ..., P^(n-1)(x) (fewer if the lane leaves the divergence bound).
    pub fn cycle(&self, v: f64, x: &State, n: u32) -> Vec<State> {
        let (p, w) = self.at(v);
        let mut out = vec![*x];
        for _ in 1..n {
            match advance(&p, w, out.last().expect("a point"), 1, &self.shoot.stepper) {
                Some(next) => out.push(next),
                None => break,
            }
        }
        out
    }

    /// The smallest d dividing the period after which the orbit through `x` at value
    /// `v` closes: |P^d(x) - x| within a thousand times the shooting tolerance (in the
    /// metric of the shooting), so the points of a genuine period-n orbit, which lie
    /// apart by far more, are never taken for one.
    pub fn minimal_period(&self, v: f64, x: &State) -> u32 {
        let n = self.period;
        let (_, w) = self.at(v);
        let points = self.cycle(v, x, n);
        (1..n)
            .filter(|d| n.is_multiple_of(*d))
            .find(|&d| {
                points.get(d as usize).is_some_and(|y| {
                    let diff: State = std::array::from_fn(|i| y[i] - x[i]);
                    jeffcott_core::orbit::metric(&diff, w) <= 1e3 * self.shoot.tol
                })
            })
            .unwrap_or(n)
    }

    /// Checks the inputs; errors name the field and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.validate_as("param")
    }

    /// [`Self::validate`], the continued parameter's range named `field` (the front
    /// end's name for it: the CLI's `vary`, Python's `param`).
    pub fn validate_as(&self, field: &str) -> Result<()> {
        if matches!(self.var, MapVar::Coord(_)) {
            return Err(Error::invalid(
                field,
                self.var.name(),
                "continue W (omega) or a model parameter, not a start coordinate",
            ));
        }
        if !(self.lo.is_finite() && self.hi.is_finite() && self.lo < self.hi) {
            return Err(Error::invalid(
                field,
                format!("{}..{}", self.lo, self.hi),
                "need finite lo < hi",
            ));
        }
        // Both ends of the range are a model: every value between them is one too (each
        // parameter's allowed set is an interval), so the branch never leaves the model.
        for v in [self.lo, self.hi] {
            let (p, w) = self.at(v);
            let w_ok = match self.var {
                MapVar::Omega => jeffcott_core::model::validate_omega(w),
                _ => Ok(()), // the speed, checked by the request
            };
            w_ok.and_then(|_| p.validate()).map_err(|e| {
                Error::invalid(
                    field,
                    format!("{} = {v}", self.var.name()),
                    format!("an end of the range is invalid: {e}"),
                )
            })?;
        }
        if !(self.lo..=self.hi).contains(&self.start_value) {
            return Err(Error::invalid(
                "start-value",
                self.start_value,
                format!("must lie in the range {}..{}", self.lo, self.hi),
            ));
        }
        jeffcott_core::inputs::check_positive("ds", self.ds, "")?;
        if !(self.ds_max >= self.ds && self.ds_max.is_finite()) {
            return Err(Error::invalid(
                "ds-max",
                self.ds_max,
                format!("must be finite and >= ds ({})", self.ds),
            ));
        }
        jeffcott_core::orbit::check_period(self.period)?;
        if !(2..=MAX_POINTS).contains(&self.max_points) {
            return Err(Error::invalid(
                "max-points",
                self.max_points,
                format!("must be in 2..={MAX_POINTS}"),
            ));
        }
        self.params.validate()?;
        self.shoot.stepper.validate()
    }

    /// Scales a state and value into arclength coordinates.
    fn scaled(&self, x: &State, v: f64) -> [f64; STATE_DIM + 1] {
        let w = self.at(v).1;
        let mut z = [0.0; STATE_DIM + 1];
        for i in 0..STATE_DIM {
            z[i] = if i % 2 == 1 { x[i] / w } else { x[i] };
        }
        z[STATE_DIM] = v * theta(self);
        z
    }

    /// The ask for `periods` periods from `x` at value `v`.
    fn ask(&self, x: &State, v: f64, periods: u32, want: Want) -> FlowAsk {
        let (params, omega) = self.at(v);
        FlowAsk {
            params,
            omega,
            x0: *x,
            periods,
            want,
        }
    }

    /// A shot of a period-`period` orbit from `x` at value `v`.
    pub(crate) fn start_at(&self, x: &State, v: f64, period: u32) -> Start {
        let (params, omega) = self.at(v);
        Start {
            params,
            omega,
            x0: *x,
            period,
        }
    }

    /// The linearisation at (x, v) in one call of `engine`: the flow of n periods with
    /// its monodromy matrix, and dF/dp by a central difference of P^n (`None` when a
    /// lane leaves the divergence bound).
    fn linearise(
        &self,
        engine: &dyn Flows,
        x: &State,
        v: f64,
    ) -> Result<Option<(Flow, SVector<f64, STATE_DIM>)>> {
        let e = 1e-7 * v.abs().max(1.0);
        let asks = [
            self.ask(x, v, self.period, Want::Monodromy),
            self.ask(x, v + e, self.period, Want::End),
            self.ask(x, v - e, self.period, Want::End),
        ];
        let [f, a, b]: [Flow; 3] = engine
            .flows(&asks, &self.shoot.stepper)?
            .try_into()
            .expect("three asks, three flows");
        if !(f.finite && a.finite && b.finite) {
            return Ok(None);
        }
        let fp = SVector::from_fn(|i, _| (a.end[i] - b.end[i]) / (2.0 * e));
        Ok(Some((f, fp)))
    }
}

/// The point's tangent: the null vector of [M - I | F_p] (scaled), oriented along
/// `prev` (a scaled tangent), unit length.
fn tangent(
    spec: &BranchSpec,
    f: &Flow,
    fp: &SVector<f64, STATE_DIM>,
    v: f64,
    prev: &[f64; STATE_DIM + 1],
) -> Option<[f64; STATE_DIM + 1]> {
    let m = f.jacobian()?;
    let w = spec.at(v).1;
    let th = theta(spec);
    // Unknowns in scaled coordinates: x_i = z_i * s_i, p = z_p / theta.
    let s = |i: usize| if i % 2 == 1 { w } else { 1.0 };
    let a = SMatrix::<f64, 9, 9>::from_fn(|r, c| {
        if r < STATE_DIM {
            if c < STATE_DIM {
                (m[r][c] - if r == c { 1.0 } else { 0.0 }) * s(c)
            } else {
                fp[r] / th
            }
        } else {
            prev[c]
        }
    });
    let mut rhs = SVector::<f64, 9>::zeros();
    rhs[STATE_DIM] = 1.0;
    let t = a.lu().solve(&rhs)?;
    let n = t.norm();
    let mut out = [0.0; STATE_DIM + 1];
    for (o, v) in out.iter_mut().zip(t.iter()) {
        *o = v / n;
    }
    Some(out)
}

/// A converged point: its flow, F_p and tangent, and the corrector's iterations.
struct Solved {
    x: State,
    v: f64,
    flow: Flow,
    tangent: [f64; STATE_DIM + 1],
    iterations: u32,
}

/// Steps are accepted when the tangent turns by less than this (cosine: 10 degrees), so a
/// step cannot jump to another branch near a fold or a grazing.
const MIN_TANGENT_COS: f64 = 0.985;

/// Newton on the bordered system from the prediction at arclength `ds` along `t` from
/// `(x0, v0)`. `None` when it does not converge in 10 iterations; an error when the
/// engine fails.
fn correct(
    spec: &BranchSpec,
    engine: &dyn Flows,
    x0: &State,
    v0: f64,
    t: &[f64; STATE_DIM + 1],
    ds: f64,
) -> Result<Option<Solved>> {
    let z0 = spec.scaled(x0, v0);
    let th = theta(spec);
    // Prediction in scaled coordinates, back to (x, v).
    let w0 = spec.at(v0).1;
    let mut v = v0 + ds * t[STATE_DIM] / th;
    let mut x: State = std::array::from_fn(|i| {
        let s = if i % 2 == 1 { w0 } else { 1.0 };
        x0[i] + ds * t[i] * s
    });
    for iterations in 0..10 {
        let Some((f, fp)) = spec.linearise(engine, &x, v)? else {
            return Ok(None);
        };
        let m = *f.jacobian().expect("a finite flow has its monodromy");
        let z = spec.scaled(&x, v);
        let g_arc: f64 = (0..=STATE_DIM).map(|i| t[i] * (z[i] - z0[i])).sum::<f64>() - ds;
        let g: State = std::array::from_fn(|i| f.end[i] - x[i]);
        let w = spec.at(v).1;
        if metric(&g, w) <= spec.shoot.tol && g_arc.abs() <= spec.shoot.tol {
            let Some(tangent) = tangent(spec, &f, &fp, v, t) else {
                return Ok(None);
            };
            return Ok(Some(Solved {
                x,
                v,
                flow: f,
                tangent,
                iterations,
            }));
        }
        let s = |i: usize| if i % 2 == 1 { 1.0 / w } else { 1.0 };
        let j = SMatrix::<f64, 9, 9>::from_fn(|r, c| {
            if r < STATE_DIM {
                if c < STATE_DIM {
                    m[r][c] - if r == c { 1.0 } else { 0.0 }
                } else {
                    fp[r]
                }
            } else if c < STATE_DIM {
                t[c] * s(c)
            } else {
                t[STATE_DIM] * th
            }
        });
        let mut rhs = SVector::<f64, 9>::zeros();
        for i in 0..STATE_DIM {
            rhs[i] = -g[i];
        }
        rhs[STATE_DIM] = -g_arc;
        let Some(d) = j.lu().solve(&rhs) else {
            return Ok(None);
        };
        for i in 0..STATE_DIM {
            x[i] += d[i];
        }
        v += d[STATE_DIM];
    }
    Ok(None)
}

/// The point record of a solved point.
fn point(s: &Solved) -> BranchPoint {
    let mu = multipliers(s.flow.jacobian().expect("a solved point's flow is finite"));
    BranchPoint {
        value: s.v,
        x: s.x,
        multipliers: mu.iter().map(|m| [m.re, m.im]).collect(),
        stable: mu.iter().all(|m| m.norm() < 1.0),
        min_clearance: s.flow.min_clearance,
        tangent: s.tangent,
        mu,
    }
}

/// The test function of `kind` at a point: a sign change (or, for Neimark-Sacker, a
/// change of the count) between two points brackets the bifurcation.
fn test_value(kind: Crossing, p: &BranchPoint) -> f64 {
    match kind {
        Crossing::Fold => p.tangent[STATE_DIM],
        Crossing::PeriodDoubling => {
            // det(M + I): complex pairs contribute |mu + 1|^2 > 0.
            p.mu.iter()
                .map(|m| m + Complex::new(1.0, 0.0))
                .fold(Complex::new(1.0, 0.0), |a, b| a * b)
                .re
        }
        Crossing::NeimarkSacker => {
            p.mu.iter()
                .filter(|m| m.im.abs() > 1e-9 * m.norm() && m.norm() > 1.0)
                .count() as f64
        }
        Crossing::Grazing => p.min_clearance,
    }
}

/// Whether the test function of `kind` changes between `a` and `b`.
fn crosses(kind: Crossing, a: &BranchPoint, b: &BranchPoint) -> bool {
    let (ta, tb) = (test_value(kind, a), test_value(kind, b));
    match kind {
        Crossing::NeimarkSacker => ta != tb,
        _ => (ta > 0.0) != (tb > 0.0),
    }
}

/// Locates a crossing of `kind` between point `a` (solved) and the point at arclength
/// `ds` from it, by bisection of the arclength until the parameter is known to 1e-8.
fn locate(
    spec: &BranchSpec,
    engine: &dyn Flows,
    a: &BranchPoint,
    ds: f64,
    kind: Crossing,
) -> Result<Option<BranchPoint>> {
    let (mut lo, mut hi) = (0.0, ds);
    let mut best: Option<BranchPoint> = None;
    let mut v_lo = a.value;
    // Until the parameter is known to 1e-8 and, at a fold (where the parameter is flat
    // along the branch, so 1e-8 in it is ~1e-4 in arclength), the arclength too.
    let known = |best: &Option<BranchPoint>, v_lo: f64, lo: f64, hi: f64| {
        best.as_ref()
            .is_some_and(|b| (b.value - v_lo).abs() < 1e-8 && (hi - lo) < 1e-9 * ds)
    };
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        let Some(s) = correct(spec, engine, &a.x, a.value, &a.tangent, mid)? else {
            return Ok(None);
        };
        let p = point(&s);
        if crosses(kind, a, &p) {
            hi = mid;
            best = Some(p);
        } else {
            lo = mid;
            v_lo = p.value;
        }
        if known(&best, v_lo, lo, hi) {
            break;
        }
    }
    Ok(best)
}

/// Whether the step from `a` to `b` passes the first orbit of the branch: its first
/// point `first` going the way the branch left it, or (n > 1) another of that orbit's
/// Poincare points `shifted` (P^k of the first state, k = 1..n-1: a fixed point of P^n
/// describing the same orbit). Either way a closed branch has come round (an isola, or
/// a period-2n branch joining two doublings of its period-n branch), and from there on
/// it would list the same orbits again. In scaled coordinates the point lies within 5 %
/// of the step's length of the chord from a to b (the arc bows out by ~ds^2 times the
/// curvature).
fn passes_start(
    spec: &BranchSpec,
    first: &BranchPoint,
    shifted: &[State],
    a: &BranchPoint,
    b: &BranchPoint,
) -> bool {
    let same_way: f64 = (0..=STATE_DIM)
        .map(|i| first.tangent[i] * b.tangent[i])
        .sum();
    (same_way > 0.0 && near_chord(spec, &first.x, first.value, a, b))
        || shifted
            .iter()
            .any(|x| near_chord(spec, x, first.value, a, b))
}

/// Whether (x, v) lies within 5 % of the step's length of the chord from a to b, in
/// scaled coordinates.
fn near_chord(spec: &BranchSpec, x: &State, v: f64, a: &BranchPoint, b: &BranchPoint) -> bool {
    let (z0, za, zb) = (
        spec.scaled(x, v),
        spec.scaled(&a.x, a.value),
        spec.scaled(&b.x, b.value),
    );
    let seg: [f64; STATE_DIM + 1] = std::array::from_fn(|i| zb[i] - za[i]);
    let len2: f64 = seg.iter().map(|v| v * v).sum();
    if len2 == 0.0 || !len2.is_finite() {
        return false;
    }
    let t = ((0..=STATE_DIM)
        .map(|i| (z0[i] - za[i]) * seg[i])
        .sum::<f64>()
        / len2)
        .clamp(0.0, 1.0);
    let dist2: f64 = (0..=STATE_DIM)
        .map(|i| (za[i] + t * seg[i] - z0[i]).powi(2))
        .sum();
    dist2 <= 0.05 * 0.05 * len2
}

/// Past a corner of the branch, where the pseudo-arclength corrector fails at every
/// step: a contact episode begins or ends somewhere in the period (the grazing of a
/// further contact, which the smallest clearance, already negative, does not show), and
/// the stiff penalty contact turns the branch within nanometres of arclength (docs/model.md:
/// k_c = 1e8 N/m). The parameter itself is stepped instead (a natural-parameter step:
/// the orbit shot at the new value from the last one), by 1e-6, 1e-5, then 1e-4 of the
/// range along the branch's direction; the first that converges to a nearby orbit (moved
/// less than 100 x the step x max(range, 1) mm per unit of the parameter, in the
/// classification metric) is the next point, its tangent oriented along the last one.
/// `None` when none does.
fn corner_step(
    spec: &BranchSpec,
    engine: &dyn Flows,
    last: &BranchPoint,
) -> Result<Option<Solved>> {
    let along = if last.tangent[STATE_DIM] != 0.0 {
        last.tangent[STATE_DIM].signum()
    } else {
        spec.direction.signum()
    };
    let range = spec.hi - spec.lo;
    for frac in [1e-6, 1e-5, 1e-4] {
        let v = last.value + along * frac * range;
        let start = spec.start_at(&last.x, v, spec.period);
        let Ok(o) = shoot_one(engine, start, &spec.shoot)? else {
            continue;
        };
        let moved = metric(&std::array::from_fn(|i| o.x[i] - last.x[i]), o.omega);
        if moved > 100.0 * frac * range.abs().max(1.0) * 1e-3 {
            continue;
        }
        let Some((f, fp)) = spec.linearise(engine, &o.x, v)? else {
            continue;
        };
        let Some(tangent) = tangent(spec, &f, &fp, v, &last.tangent) else {
            continue;
        };
        return Ok(Some(Solved {
            x: o.x,
            v,
            flow: f,
            tangent,
            iterations: o.iterations,
        }));
    }
    Ok(None)
}

/// Continues the branch of `spec` (see the module docs), every flow on `engine`.
pub fn continue_branch(spec: &BranchSpec, engine: &dyn Flows) -> Result<Branch> {
    spec.validate()?;
    let (first, shifted) = first_point(spec, engine)?;
    let mut points = vec![first];
    let mut bifurcations = Vec::new();
    let mut ds = spec.ds;
    let stop;
    loop {
        let last = points.last().expect("a point");
        if points.len() >= spec.max_points {
            stop = format!("{} points", spec.max_points);
            break;
        }
        let turn = |s: &Solved| {
            (0..=STATE_DIM)
                .map(|i| s.tangent[i] * last.tangent[i])
                .sum::<f64>()
        };
        // At a grazing the branch has a corner (the orbit's Jacobian jumps as a contact
        // begins): a sharp turn is accepted there once the step is small.
        let corner = |s: &Solved| {
            (s.flow.min_clearance > 0.0) != (last.min_clearance > 0.0) && ds <= 1e-2 * spec.ds
        };
        let solved = correct(spec, engine, &last.x, last.value, &last.tangent, ds)?
            .filter(|s| turn(s) >= MIN_TANGENT_COS || corner(s));
        let solved = match solved {
            Some(s) => Some(s),
            // A corner the arclength cannot turn: step the parameter itself.
            None if ds * 0.5 < spec.ds * 1e-4 => corner_step(spec, engine, last)?,
            None => None,
        };
        let Some(s) = solved else {
            ds *= 0.5;
            if ds < spec.ds * 1e-4 {
                stop = format!(
                    "the corrector failed at {} = {} with steps down to {ds:.1e}",
                    spec.var.name(),
                    last.value
                );
                break;
            }
            continue;
        };
        let next = point(&s);
        let step = (last, &next, ds, points.len() - 1);
        add_crossings(spec, engine, step, &mut bifurcations)?;
        let outside = !(spec.lo..=spec.hi).contains(&next.value);
        let closed = points.len() >= 3 && passes_start(spec, &points[0], &shifted, last, &next);
        points.push(next);
        if closed {
            stop = format!(
                "closed: the branch came back to its first orbit after {} points",
                points.len() - 1
            );
            break;
        }
        if outside {
            stop = format!("left the range {}..{}", spec.lo, spec.hi);
            break;
        }
        if s.iterations <= 3 {
            ds = (ds * 1.5).min(spec.ds_max);
        }
    }
    let minimal_period = points
        .first()
        .map_or(spec.period, |p| spec.minimal_period(p.value, &p.x));
    Ok(Branch {
        period: spec.period,
        minimal_period,
        points,
        bifurcations,
        stop,
    })
}

/// The first point of the branch of `spec` (its start shot onto the orbit, with the
/// branch's tangent along `spec.direction`) and the orbit's other Poincare points, for
/// the closed-branch test.
fn first_point(spec: &BranchSpec, engine: &dyn Flows) -> Result<(BranchPoint, Vec<State>)> {
    let start = spec.start_at(&spec.start, spec.start_value, spec.period);
    let orbit = shoot_one(engine, start, &spec.shoot)??;
    let (f0, fp0) = spec
        .linearise(engine, &orbit.x, spec.start_value)?
        .ok_or_else(|| {
            Error::invalid(
                "start",
                spec.start_value,
                "the orbit leaves the divergence bound",
            )
        })?;
    let mut along = [0.0; STATE_DIM + 1];
    along[STATE_DIM] = spec.direction.signum();
    let t0 = tangent(spec, &f0, &fp0, spec.start_value, &along).ok_or_else(|| {
        Error::invalid(
            "start-value",
            spec.start_value,
            "the start lies on a singular point of the branch (a fold or branch point)",
        )
    })?;
    let first = point(&Solved {
        x: orbit.x,
        v: spec.start_value,
        flow: f0,
        tangent: t0,
        iterations: 0,
    });
    // The first orbit's other Poincare points, for the closed-branch test.
    let images: Vec<FlowAsk> = (1..spec.period)
        .map(|k| spec.ask(&orbit.x, spec.start_value, k, Want::End))
        .collect();
    let shifted: Vec<State> = engine
        .flows(&images, &spec.shoot.stepper)?
        .into_iter()
        .map(|f| f.end)
        .collect();
    Ok((first, shifted))
}

/// Adds to `bifurcations` those the step from `last` to `next` (arclength `ds`, after
/// point `after_point`) crosses, each located by bisection. A closed period-2n loop
/// meets each orbit at its n Poincare points, so it crosses a bifurcation once per
/// point: listed once (two orbits bifurcating alike at one parameter value, to 1e-7,
/// are not generic).
fn add_crossings(
    spec: &BranchSpec,
    engine: &dyn Flows,
    (last, next, ds, after_point): (&BranchPoint, &BranchPoint, f64, usize),
    bifurcations: &mut Vec<Bifurcation>,
) -> Result<()> {
    for kind in [
        Crossing::Fold,
        Crossing::PeriodDoubling,
        Crossing::NeimarkSacker,
        Crossing::Grazing,
    ] {
        if crosses(kind, last, next)
            && let Some(b) = locate(spec, engine, last, ds, kind)?
        {
            let seen = bifurcations
                .iter()
                .any(|x: &Bifurcation| x.kind == kind && (x.value - b.value).abs() < 1e-7);
            if seen {
                continue;
            }
            bifurcations.push(Bifurcation {
                kind,
                value: b.value,
                x: b.x,
                multipliers: b.multipliers.clone(),
                min_clearance: b.min_clearance,
                after_point,
            });
        }
    }
    Ok(())
}

/// The branch of period-2n orbits born at the period doubling `b` of a period-n branch
/// of `spec`, continued away from it over the same range. The critical eigenvector v
/// (the null vector of M + I, by SVD) gives the start: the doubled orbit exists on one
/// side of the bifurcation with an amplitude growing like the square root of the
/// distance, so shots of period 2n from x + eps v at a small distance on either side
/// are tried until one converges onto an orbit that is not the period-n one (which is a
/// fixed point of P^2n too). Errors name `period` when none does.
pub fn doubled_branch(spec: &BranchSpec, b: &Bifurcation, engine: &dyn Flows) -> Result<Branch> {
    let (_, w) = spec.at(b.value);
    let no_orbit = |why: &str| {
        Error::invalid(
            "period",
            spec.period * 2,
            format!(
                "no period-{} orbit was found next to the period doubling at {} = {}{why}",
                spec.period * 2,
                spec.var.name(),
                b.value
            ),
        )
    };
    let ask = spec.ask(&b.x, b.value, spec.period, Want::Monodromy);
    let f = engine.flows(&[ask], &spec.shoot.stepper)?.remove(0);
    let m = f
        .jacobian()
        .ok_or_else(|| no_orbit(" (the orbit there leaves the bound)"))?;
    let a = SMatrix::<f64, STATE_DIM, STATE_DIM>::from_fn(|r, c| {
        m[r][c] + if r == c { 1.0 } else { 0.0 }
    });
    let svd = a.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| no_orbit(" (no singular vectors there)"))?;
    let k = svd.singular_values.imin();
    let v: State = std::array::from_fn(|i| v_t[(k, i)]);
    let v_size = metric(&v, w).max(f64::MIN_POSITIVE);
    let doubled = spec.period * 2;
    let step = 1e-3 * (spec.hi - spec.lo);
    let collapsed = 1e3 * spec.shoot.tol;
    // Every trial start at once (one engine call per Newton iteration for all of them);
    // the first, in this order, that converges onto a true period-2n orbit is taken.
    let (mut sides, mut starts) = (Vec::new(), Vec::new());
    for side in [1.0, -1.0] {
        let value = b.value + side * step;
        if !(spec.lo..=spec.hi).contains(&value) {
            continue;
        }
        for eps in [1e-7, 1e-6, 1e-5, 1e-4] {
            let x0: State = std::array::from_fn(|i| b.x[i] + eps / v_size * v[i]);
            sides.push((side, value));
            starts.push(spec.start_at(&x0, value, doubled));
        }
    }
    let shots = shoot_many(engine, &starts, &spec.shoot)?;
    // Not the period-n orbit: P^n(x) is another point.
    let halves: Vec<FlowAsk> = sides
        .iter()
        .zip(&shots)
        .filter_map(|(&(_, value), o)| {
            let o = o.as_ref().ok()?;
            Some(spec.ask(&o.x, value, spec.period, Want::End))
        })
        .collect();
    let mut halves = engine.flows(&halves, &spec.shoot.stepper)?.into_iter();
    for ((side, value), o) in sides.iter().zip(&shots) {
        let Ok(o) = o else { continue };
        let half = halves.next().expect("one half per orbit");
        let d: State = std::array::from_fn(|i| half.end[i] - o.x[i]);
        if half.finite && metric(&d, o.omega) > collapsed {
            return continue_branch(
                &BranchSpec {
                    start: o.x,
                    start_value: *value,
                    period: doubled,
                    direction: *side,
                    ..spec.clone()
                },
                engine,
            );
        }
    }
    Err(no_orbit(""))
}

mod record;
mod study;
pub use record::{BifurcationRecord, BranchRecord, BranchesRecord, ROW, arrays, record};
pub use study::{MAX_POINTS, OrbitsRequest, OrbitsStudy, parse_param, run};
