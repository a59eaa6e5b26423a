//! Rub figures of a trajectory on its attractor: how much and how hard the rotor touches
//! the stator, from a dense time series on the lane stepper's grid (MODEL.md 2: contact
//! is g = |d| - delta > 0, the normal force k_c g + c_c dg/dt).
//!
//! The figures are sampled on the integrator's grid (N points per forcing period): a
//! contact shorter than one grid step can be missed by the fraction and the impact count,
//! and the peak force is the largest sampled one, a lower bound of the true peak within
//! one step. At the default N = 500 a grid step is 1/500 of a revolution.

use crate::error::Result;
use crate::integrate::lane::StepperConfig;
use crate::model::{Params, STATE_DIM, State, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S};
use serde::{Deserialize, Serialize};

/// What a stretch of trajectory did at the contact.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RubFigures {
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
}

/// Normal contact force on the rotor [N] at state `x` (positive pushes the rotor back
/// towards the centre, MODEL.md 2 with the optional dashpot), 0 out of contact.
pub fn normal_force(p: &Params, x: &State) -> f64 {
    let (dx, dy) = (x[X_R] - x[X_S], x[Y_R] - x[Y_S]);
    let r = (dx * dx + dy * dy).sqrt();
    let g = r - p.delta;
    if g <= 0.0 {
        return 0.0;
    }
    let dg = (dx * (x[VX_R] - x[VX_S]) + dy * (x[VY_R] - x[VY_S])) / r;
    p.k_c * g + p.c_c * dg
}

/// Rub figures of a time series (rows `(t, state)` on a uniform grid covering `periods`
/// forcing periods, the first row at the start of the first).
pub fn rub_figures(p: &Params, rows: &[[f64; STATE_DIM + 1]], periods: u32) -> RubFigures {
    // The first row is the start of the stretch, the others its grid points: count each
    // grid point of the stretch once (the start belongs to the period before).
    let mut f = RubFigures::default();
    let (mut n, mut in_contact, mut entries, mut sum) = (0u64, 0u64, 0u64, 0.0);
    let mut prev = rows
        .first()
        .map(|r| crate::model::penetration(p.delta, &state(r)) > 0.0)
        .unwrap_or(false);
    for r in rows.iter().skip(1) {
        let x = state(r);
        let g = crate::model::penetration(p.delta, &x);
        n += 1;
        let now = g > 0.0;
        if now {
            in_contact += 1;
            let fnorm = normal_force(p, &x);
            sum += fnorm;
            f.peak_force_n = f.peak_force_n.max(fnorm);
            f.peak_penetration_m = f.peak_penetration_m.max(g);
            entries += (!prev) as u64;
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
    f
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
    let spec = crate::simulate::SimulateSpec {
        params: p.clone(),
        omega,
        x0: *x0,
        transient: 0,
        periods,
        timeseries_periods: periods,
        integrator: crate::simulate::Integrator::Lane,
        stepper: *stepper,
        article: Default::default(),
        classify: Default::default(),
    };
    let r = crate::simulate::simulate(&spec)?;
    if r.status.is_frozen() {
        return Ok(None);
    }
    Ok(Some(rub_figures(p, &r.timeseries, periods)))
}

/// Forcing periods over which an attractor's rub figures are taken: whole cycles of a
/// periodic attractor (at least [`MIN_RUB_PERIODS`]), [`APERIODIC_RUB_PERIODS`] for
/// aperiodic ones.
pub fn rub_periods(period: Option<usize>) -> u32 {
    match period {
        Some(n) => (n as u32) * MIN_RUB_PERIODS.div_ceil(n as u32).max(1),
        None => APERIODIC_RUB_PERIODS,
    }
}

/// Fewest periods of a rub stretch (a period-1 response is measured over 4 cycles).
pub const MIN_RUB_PERIODS: u32 = 4;

/// Periods of a rub stretch on an aperiodic attractor.
pub const APERIODIC_RUB_PERIODS: u32 = 16;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rub_stretches_cover_whole_cycles() {
        assert_eq!(rub_periods(Some(1)), 4);
        assert_eq!(rub_periods(Some(3)), 6);
        assert_eq!(rub_periods(Some(5)), 5);
        assert_eq!(rub_periods(Some(32)), 32);
        assert_eq!(rub_periods(None), 16);
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
