//! What REPORT.md quotes, each computed from a study's result: sweep counts, lambda_1
//! rows, brute-force counts, the design chart's, the continuation's and the rub map's
//! findings, the backward throws, the summary table's rows.

use super::*;

/// What a quasistatic sweep found: speeds per kind of response.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SweepCounts {
    /// Speeds of the sweep.
    pub speeds: usize,
    /// Period-1 (of those not diverged).
    pub period1: usize,
    /// Periodic with period > 1.
    pub higher_period: usize,
    /// No period up to the classifier's n_max.
    pub aperiodic: usize,
    /// Of all speeds, quasiperiodic by lambda_1.
    pub quasiperiodic: usize,
    /// Of all speeds, chaotic by lambda_1.
    pub chaotic: usize,
    /// Diverged.
    pub diverged: usize,
}

impl SweepCounts {
    /// The counts of sweep `sw`.
    pub fn of(sw: &[SweepPoint]) -> Self {
        let count = |f: &dyn Fn(Option<usize>) -> bool| {
            sw.iter()
                .filter(|q| !q.status.is_frozen() && f(q.class.class.period()))
                .count()
        };
        let class = |c: Class| sw.iter().filter(|q| q.class.class == c).count();
        SweepCounts {
            speeds: sw.len(),
            period1: count(&|n| n == Some(1)),
            higher_period: count(&|n| n.is_some_and(|n| n > 1)),
            aperiodic: count(&|n| n.is_none()),
            quasiperiodic: class(Class::Quasiperiodic),
            chaotic: class(Class::Chaotic),
            diverged: sw.iter().filter(|q| q.status.is_frozen()).count(),
        }
    }
}

/// What the lambda_1 panel under a sweep shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Lambda1Row {
    /// The threshold of "positive" [1/s].
    pub tol: f64,
    /// Speeds with a finite lambda_1.
    pub finite: usize,
    /// Of them, above `tol`.
    pub positive: usize,
    /// The largest [1/s].
    pub largest: f64,
    /// (lambda_1, speed) of the sweep point nearest each speed asked for.
    pub at: Vec<Option<(f64, f64)>>,
}

impl Lambda1Row {
    /// The row of sweep `sw`, with the points nearest `speeds`.
    pub fn of(sw: &[SweepPoint], tol: f64, speeds: &[f64]) -> Self {
        let f: Vec<f64> = sw
            .iter()
            .map(|q| q.lambda1)
            .filter(|l| l.is_finite())
            .collect();
        Lambda1Row {
            tol,
            finite: f.len(),
            positive: f.iter().filter(|&&l| l > tol).count(),
            largest: f.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            at: speeds
                .iter()
                .map(|&w| {
                    sw.iter()
                        .min_by(|a, b| (a.omega - w).abs().total_cmp(&(b.omega - w).abs()))
                        .map(|q| (q.lambda1, q.omega))
                })
                .collect(),
        }
    }
}

/// The first speed of an up sweep where it leaves the period-1 branch it reached.
pub fn leaves_period1(up: &[SweepPoint]) -> Option<f64> {
    up.iter()
        .skip_while(|q| q.class.class.period() != Some(1))
        .find(|q| q.class.class.period() != Some(1))
        .map(|q| q.omega)
}

/// Speeds where the up and down sweeps differ in class (without the lambda_1
/// refinement): the hysteresis the down-sweep figure shows.
pub fn up_down_differ(res: &BifurcationResult) -> Vec<f64> {
    res.up
        .iter()
        .zip(&res.down)
        .filter(|(u, d)| u.class.class.unrefined() != d.class.class.unrefined())
        .map(|(u, _)| u.omega)
        .collect()
}

/// The periods an up sweep met, ascending, each once.
pub fn periods_seen(up: &[SweepPoint]) -> Vec<usize> {
    let mut periods: Vec<usize> = up.iter().filter_map(|q| q.class.class.period()).collect();
    periods.sort();
    periods.dedup();
    periods
}

/// What the brute force found: coexisting attractors per speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BruteCounts {
    /// Speeds brute-forced.
    pub speeds: usize,
    /// Of them, with more than one attractor.
    pub multistable: usize,
    /// The most attractors at one speed.
    pub most: usize,
    /// The (last) speed with that many [rad/s].
    pub most_at: f64,
}

impl BruteCounts {
    /// The counts of a study's brute force.
    pub fn of(res: &BifurcationResult) -> Self {
        let (most, most_at) = res
            .brute
            .iter()
            .map(|b| (b.catalogue.attractors.len(), b.omega))
            .max_by_key(|x| x.0)
            .unwrap_or((0, 0.0));
        BruteCounts {
            speeds: res.brute.len(),
            multistable: res
                .brute
                .iter()
                .filter(|b| b.catalogue.attractors.len() > 1)
                .count(),
            most,
            most_at,
        }
    }
}

/// What the design chart shows: cells per response from the static equilibrium, where
/// the rotor rubs, and along the row of unbalance nearest a given one.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFindings {
    /// Period-1 cells.
    pub period1: usize,
    /// Chaotic cells.
    pub chaotic: usize,
    /// Quasiperiodic cells.
    pub quasiperiodic: usize,
    /// Cells whose response touches the stator.
    pub rubbing: usize,
    /// Cells holding coexisting attractors.
    pub multistable: usize,
    /// The largest peak normal contact force [N].
    pub peak_force: f64,
    /// The row nearest the unbalance asked for: its value [m].
    pub row_value: f64,
    /// The speeds of that row where the rotor rubs [rad/s].
    pub rub_speeds: Vec<f64>,
}

impl MapFindings {
    /// The findings of a map whose y axis is the unbalance e, with the row nearest `e`.
    pub fn of(spec: &MapSpec, res: &MapResult, e: f64) -> Self {
        let cells = res.class.len();
        let count = |f: &dyn Fn(usize) -> bool| (0..cells).filter(|&i| f(i)).count();
        let nx = spec.x.n;
        let row = (0..spec.y.n)
            .min_by(|&a, &b| {
                (spec.y.value(a) - e)
                    .abs()
                    .total_cmp(&(spec.y.value(b) - e).abs())
            })
            .unwrap_or(0);
        MapFindings {
            period1: count(&|i| res.period[i] == 1),
            chaotic: count(&|i| res.class[i] == code::CHAOTIC),
            quasiperiodic: count(&|i| res.class[i] == code::QUASIPERIODIC),
            rubbing: count(&|i| res.contact[i] > 0.0),
            multistable: count(&|i| res.attractors[i] > 1),
            peak_force: res
                .peak_force
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max),
            row_value: spec.y.value(row),
            rub_speeds: (0..nx)
                .filter(|&ix| res.contact[row * nx + ix] > 0.0)
                .map(|ix| spec.x.value(ix))
                .collect(),
        }
    }
}

/// The largest one-step tipping probability of a ramp away from an attractor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tipping {
    /// The probability.
    pub probability: f64,
    /// The value at the step it leaves from.
    pub value: f64,
    /// The attractor it leaves.
    pub from: usize,
    /// Where it goes: an attractor, or `ids` for divergence.
    pub to: usize,
}

/// What a continuation ramp found.
#[derive(Clone, Debug, PartialEq)]
pub struct RampFindings {
    /// The ramp's direction.
    pub direction: Direction,
    /// Attractors followed.
    pub ids: usize,
    /// The most at one value.
    pub most: usize,
    /// Steps of the ramp.
    pub steps: usize,
    /// The values where two or more attractors have a basin.
    pub coexist: Vec<f64>,
    /// The largest one-step tipping probability (zero when nothing tips).
    pub worst: Tipping,
}

impl RampFindings {
    /// The findings of ramp `r`.
    pub fn of(r: &Ramp) -> Self {
        let g = r.ids + 1;
        let tip = r.tipping();
        let mut worst = Tipping {
            probability: 0.0,
            value: 0.0,
            from: 0,
            to: 0,
        };
        for k in 0..r.steps.len().saturating_sub(1) {
            for i in 0..r.ids {
                for j in 0..g {
                    let v = tip[(k * g + i) * g + j];
                    if j != i && v.is_finite() && v > worst.probability {
                        worst = Tipping {
                            probability: v,
                            value: r.steps[k].value,
                            from: i,
                            to: j,
                        };
                    }
                }
            }
        }
        RampFindings {
            direction: r.direction,
            ids: r.ids,
            most: r
                .steps
                .iter()
                .map(|s| s.attractors.len())
                .max()
                .unwrap_or(0),
            steps: r.steps.len(),
            coexist: r
                .steps
                .iter()
                .filter(|s| s.attractors.iter().filter(|a| a.fraction > 0.0).count() > 1)
                .map(|s| s.value)
                .collect(),
            worst,
        }
    }
}

/// Where one rub regime lies on the rub map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegimeCells {
    /// The regime.
    pub regime: RubRegime,
    /// Its cells.
    pub cells: usize,
    /// The speeds it spans [rad/s] (lo, hi); `None` where it is nowhere.
    pub x: Option<(f64, f64)>,
    /// The y values (friction) it spans.
    pub y: Option<(f64, f64)>,
}

/// Every regime's cells on map `res`, in the order no contact, partial rub, full annular
/// rub, backward whirl, diverged.
pub fn regime_cells(spec: &MapSpec, res: &MapResult) -> Vec<RegimeCells> {
    let nx = spec.x.n;
    let span = |v: Vec<f64>| {
        (!v.is_empty()).then(|| {
            (
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        })
    };
    RubRegime::ALL
        .into_iter()
        .map(|regime| {
            let cells: Vec<usize> = (0..res.regime.len())
                .filter(|&i| res.regime[i] == regime.code())
                .collect();
            RegimeCells {
                regime,
                cells: cells.len(),
                x: span(cells.iter().map(|&i| spec.x.value(i % nx)).collect()),
                y: span(cells.iter().map(|&i| spec.y.value(i / nx)).collect()),
            }
        })
        .collect()
}

/// Where a backward throw ends.
#[derive(Clone, Debug)]
pub enum ThrowOutcome {
    /// The lane left the divergence bound (or became non-finite) within the periods
    /// integrated.
    Diverged {
        /// The lane's status.
        status: Status,
        /// Forcing periods integrated.
        periods: u32,
    },
    /// It settled; the rub figures and spectra over 24 periods from its final state.
    Settled(Box<RubOutputs>),
    /// It settled, but the stretch of the rub figures diverged.
    StretchDiverged,
}

/// Integrates a backward throw ([`ReproduceSpec::throw`]) and takes its rub figures.
pub fn throw(spec: &ReproduceSpec, mu: f64, k_c: f64) -> Result<ThrowOutcome> {
    let s = spec.throw(mu, k_c);
    let r = simulate(&s)?;
    if r.status.is_frozen() {
        return Ok(ThrowOutcome::Diverged {
            status: r.status,
            periods: s.transient + s.periods,
        });
    }
    Ok(
        match rub_outputs(&s.params, s.omega, &r.final_state, 24, &Default::default())? {
            Some(o) => ThrowOutcome::Settled(Box::new(o)),
            None => ThrowOutcome::StretchDiverged,
        },
    )
}

/// A row of the summary table at the top of REPORT.md.
#[derive(Clone, Debug)]
pub struct SummaryRow<'a> {
    /// The article speed [rad/s].
    pub omega: f64,
    /// What the article reports there.
    pub article: &'static str,
    /// The class from the static equilibrium (refined by lambda_1), if simulated.
    pub static_class: Option<Class>,
    /// The full spectrum there.
    pub spectrum: Option<&'a Spectrum>,
    /// The survey's catalogue there.
    pub survey: &'a Catalogue,
}

/// The summary table: per article speed, the class from the static equilibrium found
/// by the sections (`static_class`: speed, class), the spectrum and the survey.
pub fn summary_rows<'a>(survey: &'a Survey, static_class: &[(f64, Class)]) -> Vec<SummaryRow<'a>> {
    ARTICLE_SPEEDS
        .iter()
        .enumerate()
        .map(|(i, &(omega, article))| SummaryRow {
            omega,
            article,
            static_class: static_class
                .iter()
                .find(|(w, _)| *w == omega)
                .map(|&(_, c)| c),
            spectrum: survey.spectrum(omega),
            survey: &survey.catalogues[i],
        })
        .collect()
}
