//! Rub figures of a trajectory on its attractor: how much and how hard the rotor touches
//! the stator, from a dense time series on the lane stepper's grid (docs/model.md 2: contact
//! is g = |d| - delta > 0, the normal force k_c g + c_c dg/dt).
//!
//! The figures are sampled on the integrator's grid (N points per forcing period): a
//! contact shorter than one grid step can be missed by the fraction and the impact count,
//! and the peak force is the largest sampled one, a lower bound of the true peak within
//! one step. At the default N = 500 a grid step is 1/500 of a revolution.

use crate::spectrum::{Whirl, full_spectrum, orbit, whirl};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, State, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S};
use serde::{Deserialize, Serialize};

/// The rub regime of a stretch of trajectory (rules in [`regime`], docs/rub.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RubRegime {
    /// The rotor never touches the stator.
    #[default]
    NoContact,
    /// Intermittent impacts, or contact over part of the stator only.
    PartialRub,
    /// Permanent contact all around the stator with forward whirl.
    FullAnnularRub,
    /// Sustained contact with dominant backward whirl (towards dry whip).
    BackwardWhirl,
    /// The trajectory left the divergence bound.
    Diverged,
}

impl RubRegime {
    /// The label used in files.
    pub fn label(self) -> &'static str {
        match self {
            RubRegime::NoContact => "no_contact",
            RubRegime::PartialRub => "partial_rub",
            RubRegime::FullAnnularRub => "full_annular_rub",
            RubRegime::BackwardWhirl => "backward_whirl",
            RubRegime::Diverged => "diverged",
        }
    }

    /// A small integer code for arrays: 0 no_contact, 1 partial_rub, 2 full_annular_rub,
    /// 3 backward_whirl, -1 diverged.
    pub fn code(self) -> i32 {
        match self {
            RubRegime::NoContact => 0,
            RubRegime::PartialRub => 1,
            RubRegime::FullAnnularRub => 2,
            RubRegime::BackwardWhirl => 3,
            RubRegime::Diverged => -1,
        }
    }

    /// Every regime, in the order of their codes (diverged last).
    pub const ALL: [RubRegime; 5] = [
        RubRegime::NoContact,
        RubRegime::PartialRub,
        RubRegime::FullAnnularRub,
        RubRegime::BackwardWhirl,
        RubRegime::Diverged,
    ];

    /// The regime of a [`RubRegime::code`].
    pub fn from_code(code: i32) -> Option<RubRegime> {
        Self::ALL.into_iter().find(|r| r.code() == code)
    }
}

/// Contact at this share of grid points or more is permanent contact.
pub const PERMANENT_CONTACT: f64 = 0.99;

/// Contact at this share of grid points or more is sustained contact (backward whirl).
pub const SUSTAINED_CONTACT: f64 = 0.5;

/// Contact arc [deg] from which contact covers the whole stator.
pub const FULL_ARC_DEG: f64 = 355.0;

/// The regime rule: no contact -> `no_contact`; sustained contact (>= 50 % of grid
/// points) with dominant backward whirl -> `backward_whirl`; permanent contact (>= 99 %)
/// over an arc of >= 355 deg with forward whirl -> `full_annular_rub`; any other contact
/// -> `partial_rub`. (`diverged` is decided by the caller.) Backward whirl asks for
/// sustained rather than permanent contact: in this model permanent-contact backward
/// whirl (dry whip) is a self-excited instability without an amplitude limit (a linear
/// penalty contact), which diverges; the bounded backward whirl it has keeps the rotor
/// in contact about half the time (docs/rub.md).
pub fn regime(f: &RubFigures) -> RubRegime {
    if f.contact_fraction == 0.0 {
        RubRegime::NoContact
    } else if f.contact_fraction >= SUSTAINED_CONTACT && f.whirl == Whirl::Backward {
        RubRegime::BackwardWhirl
    } else if f.contact_fraction >= PERMANENT_CONTACT
        && f.contact_arc_deg >= FULL_ARC_DEG
        && f.whirl == Whirl::Forward
    {
        RubRegime::FullAnnularRub
    } else {
        RubRegime::PartialRub
    }
}

/// What a stretch of trajectory did at the contact.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RubFigures {
    /// The rub regime ([`regime`]).
    pub regime: RubRegime,
    /// Fraction of grid points in contact (g > 0) [-].
    pub contact_fraction: f64,
    /// Contact entries (a grid point in contact after one without) per forcing period.
    pub impacts_per_rev: f64,
    /// Largest normal contact force at the grid points [N] (0 without contact).
    pub peak_force_n: f64,
    /// Mean normal contact force over the grid points in contact [N] (0 without contact).
    pub mean_force_n: f64,
    /// Largest penetration g at the grid points [m] (0 without contact).
    pub peak_penetration_m: f64,
    /// Range of contact angles on the stator [deg]: 360 minus the largest gap between the
    /// directions (rotor centre seen from the stator centre) of the contact points.
    pub contact_arc_deg: f64,
    /// Whirl of the rotor's orbit from its full spectrum.
    pub whirl: Whirl,
    /// Share of the rotor's non-static spectral power at forward frequencies.
    pub forward_share: f64,
}

/// Normal contact force on the rotor [N] at state `x` (positive pushes the rotor back
/// towards the centre, docs/model.md 2 with the optional dashpot, and 7's contact laws:
/// k_c g^n (1 + 3/2 alpha dg/dt) + c_c dg/dt), 0 out of contact.
pub fn normal_force(p: &Params, x: &State) -> f64 {
    let (dx, dy) = (x[X_R] - x[X_S], x[Y_R] - x[Y_S]);
    let r = (dx * dx + dy * dy).sqrt();
    let g = r - p.delta;
    if g <= 0.0 {
        return 0.0;
    }
    let dg = (dx * (x[VX_R] - x[VX_S]) + dy * (x[VY_R] - x[VY_S])) / r;
    // The linear law's k_c g to the bit: g^0 is 1 and 1 + 0 dg is 1, exactly.
    let spring = p.k_c * g * jeffcott_core::model::pow_half(g, p.n_c - 1.0);
    spring * (1.0 + 1.5 * p.alpha_c * dg) + p.c_c * dg
}

/// Rub figures of a time series (rows `(t, state)` on a uniform grid covering `periods`
/// forcing periods of speed `omega`, the first row at the start of the first).
pub fn rub_figures(
    p: &Params,
    omega: f64,
    rows: &[[f64; STATE_DIM + 1]],
    periods: u32,
) -> RubFigures {
    // The first row is the start of the stretch, the others its grid points: count each
    // grid point of the stretch once (the start belongs to the period before).
    let mut f = RubFigures::default();
    let (mut n, mut in_contact, mut entries, mut sum) = (0u64, 0u64, 0u64, 0.0);
    let mut angles: Vec<f64> = Vec::new();
    let mut prev = rows
        .first()
        .map(|r| jeffcott_core::model::penetration(p.delta, &state(r)) > 0.0)
        .unwrap_or(false);
    for r in rows.iter().skip(1) {
        let x = state(r);
        let g = jeffcott_core::model::penetration(p.delta, &x);
        n += 1;
        let now = g > 0.0;
        if now {
            in_contact += 1;
            let fnorm = normal_force(p, &x);
            sum += fnorm;
            f.peak_force_n = f.peak_force_n.max(fnorm);
            f.peak_penetration_m = f.peak_penetration_m.max(g);
            entries += (!prev) as u64;
            angles.push((x[Y_R] - x[Y_S]).atan2(x[X_R] - x[X_S]).to_degrees());
        }
        prev = now;
    }
    if n > 0 {
        f.contact_fraction = in_contact as f64 / n as f64;
    }
    if in_contact > 0 {
        f.mean_force_n = sum / in_contact as f64;
    }
    f.impacts_per_rev = entries as f64 / periods.max(1) as f64;
    f.contact_arc_deg = arc(&mut angles);
    let (w, share) = orbit_whirl(rows, periods, omega);
    f.whirl = w;
    f.forward_share = share;
    f.regime = regime(&f);
    f
}

/// Whirl of the rotor's orbit in time-series rows (as [`rub_figures`] takes them): the
/// [`whirl`] of the full spectrum of its motion about its mean position. The mean (the
/// static sag under gravity, a rub's offset) is taken out first: through the Hann window
/// a 0X line leaks into the bins at orders +-1/P of a P-period record, and on a short
/// record (an attractor's rub stretch is 8 periods) a sag larger than the orbit would
/// otherwise decide the direction and the forward share.
pub fn orbit_whirl(rows: &[[f64; STATE_DIM + 1]], periods: u32, omega: f64) -> (Whirl, f64) {
    let z = orbit(rows, false);
    let mean = z.iter().sum::<rustfft::num_complex::Complex64>() / z.len().max(1) as f64;
    let about_mean: Vec<_> = z.iter().map(|v| v - mean).collect();
    whirl(&full_spectrum(&about_mean, periods, omega))
}

/// 360 deg minus the largest gap between sorted directions (0 for fewer than 2).
fn arc(angles: &mut [f64]) -> f64 {
    if angles.len() < 2 {
        return 0.0;
    }
    angles.sort_by(f64::total_cmp);
    let wrap = angles[0] + 360.0 - angles[angles.len() - 1];
    let gap = angles.windows(2).map(|w| w[1] - w[0]).fold(wrap, f64::max);
    360.0 - gap
}

fn state(r: &[f64; STATE_DIM + 1]) -> State {
    let mut x = [0.0; STATE_DIM];
    x.copy_from_slice(&r[1..]);
    x
}

/// Rub figures over `periods` forcing periods from a state `x0` on an attractor at
/// t = kT (a Poincare point or a lane's final state), integrated on the CPU with the
/// lane stepper: the stretch starts at t = 0, which has the forcing phase of any t = kT.
/// `None` when the trajectory froze (diverged or non-finite) within the stretch.
pub fn rub_on_attractor(
    p: &Params,
    omega: f64,
    x0: &State,
    periods: u32,
    stepper: &StepperConfig,
) -> Result<Option<RubFigures>> {
    let spec = crate::simulate::SimulateSpec::stretch(p, omega, x0, periods, stepper);
    let r = crate::simulate::simulate(&spec)?;
    if r.status.is_frozen() {
        return Ok(None);
    }
    Ok(Some(rub_figures(p, omega, &r.timeseries, periods)))
}

/// Rub figures of a catalogued attractor: over [`rub_periods`] from its first
/// representative Poincare point (`None` if that stretch diverged or it has no point).
pub fn attractor_rub(
    p: &Params,
    a: &crate::catalogue::Attractor,
    stepper: &StepperConfig,
) -> Result<Option<RubFigures>> {
    match a.points.first() {
        Some(x0) => rub_on_attractor(p, a.omega, x0, rub_periods(a.period), stepper),
        None => Ok(None),
    }
}

/// An attractor's rub figures as the JSON files hold them: the figures, or only the
/// regime `diverged` when the stretch on the attractor left the divergence bound.
#[derive(Clone, Copy, Debug, Serialize)]
#[serde(untagged)]
pub enum RubEntry {
    /// The figures, their regime among them.
    Figures(RubFigures),
    /// No figures.
    Diverged {
        /// Always `diverged`.
        regime: &'static str,
    },
}

impl From<Option<RubFigures>> for RubEntry {
    fn from(r: Option<RubFigures>) -> Self {
        match r {
            Some(f) => RubEntry::Figures(f),
            None => RubEntry::Diverged { regime: "diverged" },
        }
    }
}

/// A catalogued attractor with its rub figures, as `attractors.json` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct AttractorWithRub<'a> {
    /// The attractor, its fields at the top level.
    #[serde(flatten)]
    pub attractor: &'a crate::catalogue::Attractor,
    /// Its rub figures.
    pub rub: RubEntry,
}

/// The catalogue's attractors, each with its rub figures (computed in parallel).
pub fn attractors_with_rub<'a>(
    p: &Params,
    attractors: &'a [crate::catalogue::Attractor],
    stepper: &StepperConfig,
) -> Result<Vec<AttractorWithRub<'a>>> {
    use rayon::prelude::*;
    attractors
        .par_iter()
        .map(|a| {
            Ok(AttractorWithRub {
                attractor: a,
                rub: attractor_rub(p, a, stepper)?.into(),
            })
        })
        .collect()
}

/// Forcing periods over which an attractor's rub figures are taken: whole cycles of a
/// periodic attractor, at least [`MIN_RUB_PERIODS`] (so whirl is read off a spectrum of
/// several cycles), [`APERIODIC_RUB_PERIODS`] for aperiodic ones.
pub fn rub_periods(period: Option<usize>) -> u32 {
    match period {
        Some(n) => (n as u32) * MIN_RUB_PERIODS.div_ceil(n as u32).max(1),
        None => APERIODIC_RUB_PERIODS,
    }
}

/// Fewest periods of a rub stretch (a period-1 response is measured over 8 cycles).
pub const MIN_RUB_PERIODS: u32 = 8;

/// Periods of a rub stretch on an aperiodic attractor.
pub const APERIODIC_RUB_PERIODS: u32 = 24;

/// Natural frequencies [rad/s] the cascade marks: the rotor and stator alone
/// (sqrt(k/m)), and the two modes of rotor and stator coupled through the contact
/// stiffness k_c (permanent contact, per direction: M^-1 K with K = [[k_r + k_c, -k_c],
/// [-k_c, k_s + k_c]]), where dry whip is expected (Childs and Bhattacharya 2007).
/// Supports stiffer in one direction than the other split each into an x and a y
/// frequency, the rotor's two critical speeds (docs/model.md 7): both are marked. A
/// power-law contact (n != 1) has no one contact stiffness, so no coupled modes.
pub fn natural_frequencies(p: &Params) -> Vec<(String, f64)> {
    let ((wrx, wry), (wsx, wsy)) = (p.omega_r_xy(), p.omega_s_xy());
    let coupled = |wr: f64, ws: f64| {
        let (kr, ks) = (p.m_r * wr * wr, p.m_s * ws * ws);
        let (a, d) = ((kr + p.k_c) / p.m_r, (ks + p.k_c) / p.m_s);
        let (b, c) = (-p.k_c / p.m_r, -p.k_c / p.m_s);
        let (tr, det) = (a + d, a * d - b * c);
        let disc = (0.25 * tr * tr - det).max(0.0).sqrt();
        ((0.5 * tr - disc).sqrt(), (0.5 * tr + disc).sqrt())
    };
    let mut out = Vec::new();
    let mut mark = |name: &str, x: f64, y: f64| {
        if x == y {
            out.push((name.to_string(), x));
        } else {
            out.push((format!("{name} in x"), x));
            out.push((format!("{name} in y"), y));
        }
    };
    mark("rotor w_r", wrx, wry);
    mark("stator w_s", wsx, wsy);
    if p.n_c == 1.0 {
        let ((lo_x, hi_x), (lo_y, hi_y)) = (coupled(wrx, wsx), coupled(wry, wsy));
        mark("coupled in contact, mode 1", lo_x, lo_y);
        mark("coupled in contact, mode 2", hi_x, hi_y);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A circular orbit of radius r at 1X, forward or backward, about a centre sagged by
    /// 2.5 r, sampled 64 times per period over `periods` periods.
    fn sagged_circle(periods: u32, forward: bool) -> Vec<[f64; STATE_DIM + 1]> {
        let (omega, r, sag) = (190.0, 0.16e-3, 0.4e-3);
        let dt = std::f64::consts::TAU / omega / 64.0;
        let sign = if forward { 1.0 } else { -1.0 };
        (0..=64 * periods)
            .map(|i| {
                let t = i as f64 * dt;
                let mut row = [0.0; STATE_DIM + 1];
                row[0] = t;
                row[1] = r * (omega * t).cos();
                row[3] = -sag + sign * r * (omega * t).sin();
                row
            })
            .collect()
    }

    #[test]
    fn a_sag_larger_than_the_orbit_does_not_decide_its_whirl_on_a_short_record() {
        use crate::spectrum::Whirl;
        for periods in [8, 48] {
            let (w, share) = orbit_whirl(&sagged_circle(periods, true), periods, 190.0);
            assert_eq!(w, Whirl::Forward, "{periods} periods");
            assert!(share > 0.999, "{periods} periods: forward share {share}");
            let (w, share) = orbit_whirl(&sagged_circle(periods, false), periods, 190.0);
            assert_eq!(w, Whirl::Backward, "{periods} periods");
            assert!(share < 0.001, "{periods} periods: forward share {share}");
        }
    }

    #[test]
    fn the_contact_arc_is_360_minus_the_largest_gap() {
        assert_eq!(arc(&mut [10.0]), 0.0);
        assert_eq!(arc(&mut [-170.0, 170.0]), 20.0);
        assert_eq!(arc(&mut [0.0, 90.0, 180.0, -90.0]), 270.0);
    }

    #[test]
    fn rub_stretches_cover_whole_cycles() {
        assert_eq!(rub_periods(Some(1)), 8);
        assert_eq!(rub_periods(Some(3)), 9);
        assert_eq!(rub_periods(Some(5)), 10);
        assert_eq!(rub_periods(Some(32)), 32);
        assert_eq!(rub_periods(None), 24);
    }

    #[test]
    fn normal_force_is_the_spring_law_in_contact_and_zero_outside() {
        let p = Params::default();
        let mut x = [0.0; STATE_DIM];
        x[X_R] = p.delta + 1e-6;
        assert!((normal_force(&p, &x) - p.k_c * 1e-6).abs() < 1e-6 * p.k_c * 1e-6);
        x[X_R] = p.delta - 1e-6;
        assert_eq!(normal_force(&p, &x), 0.0);
    }
}
