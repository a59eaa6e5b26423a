//! The quasistatic sweeps: one lane stepped through the speeds in order on the CPU lane
//! stepper, each speed starting from the last one's final state, unit by unit.

use super::{BifurcationSpec, SweepPoint};
use crate::catalogue::classify_lane;
use crate::run::lanes::Control;
use crate::run::{Array, Unit, UnitStore};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::{
    LAMBDA1_START, Lane, LaneConsts, Status, Tangent, advance_period, advance_period_tangent,
    renormalise,
};
use jeffcott_core::model::{STATE_DIM, State};

/// W steps per unit of a quasistatic sweep: at most 1/20 of the sweep and about 25 s
/// of one core (a sweep is one lane, stepped at about a quarter of the batched
/// ensemble rate that [`crate::run::MAX_UNIT_LANE_STEPS`] assumes).
pub fn sweep_unit(spec: &BifurcationSpec) -> usize {
    let per_w = (spec.transient.max(spec.transient_first) + spec.periods) as u64
        * spec.lane.stepper.steps_per_period as u64
        * if spec.lane.lyapunov { 2 } else { 1 };
    crate::run::unit_lanes(spec.omegas.len(), 4 * per_w)
}

/// One W of a sweep, from start state `x`: the point and the state the next W starts
/// from (the static equilibrium again after a diverged lane).
fn sweep_step(spec: &BifurcationSpec, omega: f64, first: bool, x: &State) -> (SweepPoint, State) {
    let lc = LaneConsts::<f64>::new(&spec.lane.params, omega, &spec.lane.stepper);
    let mut lane = Lane::<f64>::new(x, spec.lane.params.delta);
    let transient = if first {
        spec.transient_first
    } else {
        spec.transient
    };
    // The tangent vector (with `lyapunov`) starts afresh at each W and aligns over the
    // last `lyapunov_align` periods of the transient, as the ensembles' lambda_1 does;
    // before, the lane steps without it (the same state arithmetic).
    let from = spec.lane.stepper.tangent_from(transient);
    let mut period = 0u32;
    let mut tan = Tangent::<f64, 1>::new([[LAMBDA1_START; STATE_DIM]]);
    let mut step = |lane: &mut Lane<f64>| -> f64 {
        period += 1;
        if spec.lane.lyapunov && period > from {
            advance_period_tangent(&lc, lane, &mut tan);
            if lane.status.is_frozen() {
                1.0
            } else {
                renormalise(&mut tan.v[0])
            }
        } else {
            advance_period(&lc, lane);
            1.0
        }
    };
    for _ in 0..transient {
        if lane.status.is_frozen() {
            break;
        }
        step(&mut lane);
    }
    let mut points = Vec::with_capacity(spec.periods as usize);
    let mut norms = Vec::with_capacity(spec.periods as usize);
    for _ in 0..spec.periods {
        norms.push(step(&mut lane));
        // As in the ensembles (`ensemble::mask_frozen_records`): from the period in which
        // the lane froze on, its records are NaN, not its last finite state.
        points.push(if lane.status.is_frozen() {
            [f64::NAN; STATE_DIM]
        } else {
            lane.x
        });
    }
    let lambda1 = if spec.lane.lyapunov && !lane.status.is_frozen() {
        jeffcott_core::lyapunov::lambda1_from_norms(&norms, omega)
    } else {
        f64::NAN
    };
    let next = if lane.status.is_frozen() {
        spec.lane.params.static_equilibrium()
    } else {
        lane.x
    };
    (sweep_point(spec, omega, points, lane.status, lambda1), next)
}

fn sweep_point(
    spec: &BifurcationSpec,
    omega: f64,
    points: Vec<State>,
    status: Status,
    lambda1: f64,
) -> SweepPoint {
    let class = classify_lane(
        &points,
        omega,
        status.is_frozen(),
        spec.lane.lyapunov.then_some(lambda1),
        &spec.lane.catalogue,
    );
    SweepPoint {
        omega,
        points,
        status,
        class,
        lambda1,
    }
}

/// One quasistatic sweep over `omegas` in the given order, unit by unit into `store`
/// under `stage` (a unit: [`sweep_unit`] consecutive speeds, with the state the next
/// unit starts from); committed units are read back, not recomputed.
pub(super) fn sweep(
    spec: &BifurcationSpec,
    omegas: &[f64],
    stage: &str,
    store: &dyn UnitStore,
    done_work: &std::sync::atomic::AtomicU64,
    ctl: Control,
    total: u64,
) -> Result<Vec<SweepPoint>> {
    let per = sweep_unit(spec);
    let count = crate::run::unit_count(omegas.len(), per);
    let done = store.committed(stage, count)?;
    let rec = spec.periods as usize;
    let mut x = spec.lane.params.static_equilibrium();
    let mut out = Vec::with_capacity(omegas.len());
    let add = |periods: u64| {
        let d = done_work.fetch_add(periods, std::sync::atomic::Ordering::Relaxed) + periods;
        (ctl.progress)(d, total);
    };
    for (u, &is_done) in done.iter().enumerate() {
        let range = u * per..((u + 1) * per).min(omegas.len());
        let periods: u64 = range
            .clone()
            .map(|k| {
                (if k == 0 {
                    spec.transient_first
                } else {
                    spec.transient
                } + spec.periods) as u64
            })
            .sum();
        if is_done {
            let unit = store.load(stage, u)?;
            let pts = unit.f64s("points")?;
            let codes = unit.u32s("status")?;
            let l1 = unit.f64s("lambda1")?;
            for (j, k) in range.clone().enumerate() {
                let points: Vec<State> = pts[j * rec * STATE_DIM..(j + 1) * rec * STATE_DIM]
                    .chunks_exact(STATE_DIM)
                    .map(|c| c.try_into().unwrap_or([f64::NAN; STATE_DIM]))
                    .collect();
                let status = Status::from_code(codes[j]).unwrap_or(Status::NonFinite);
                out.push(sweep_point(spec, omegas[k], points, status, l1[j]));
            }
            x = unit
                .f64s("carry")?
                .try_into()
                .unwrap_or([f64::NAN; STATE_DIM]);
            add(periods);
            continue;
        }
        if ctl.cancel.is_set() {
            return Err(Error::Interrupted {
                committed: u,
                total: count,
            });
        }
        let mut pts = Vec::with_capacity(range.len() * rec * STATE_DIM);
        let mut codes = Vec::with_capacity(range.len());
        let mut l1 = Vec::with_capacity(range.len());
        for k in range.clone() {
            let (p, next) = sweep_step(spec, omegas[k], k == 0, &x);
            pts.extend(p.points.iter().flatten());
            codes.push(p.status.code());
            l1.push(p.lambda1);
            x = next;
            out.push(p);
        }
        let unit = Unit::new(crate::run::dir::unit_key(stage, u))
            .with("points", Array::F64(pts))
            .with("status", Array::U32(codes))
            .with("lambda1", Array::F64(l1))
            .with("carry", Array::F64(x.to_vec()));
        store.commit(stage, u, &unit)?;
        add(periods);
    }
    Ok(out)
}
