//! The brute force: the K seeded start states per speed as one ensemble, then a second
//! ensemble seeded from the attractors and sweep states at the neighbouring speeds,
//! each speed catalogued.

use super::{BifurcationSpec, BrutePoint, SweepPoint};
use crate::catalogue::CatalogueBuilder;
use crate::early::EarlySaved;
use crate::run::lanes::{Control, LaneUnits, Split};
use crate::run::{Array, Unit, UnitStore};
use jeffcott_core::ensemble::{EnsembleSpec, LaneSpec, RunInfo};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::Status;
use jeffcott_core::model::{Params, STATE_DIM, State, VX_R, VY_R, X_R, Y_R};

/// A deterministic hash in [-1, 1) (splitmix64).
pub(crate) fn unit(i: u64, salt: u64) -> f64 {
    let mut z = i
        .wrapping_add(salt.wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The K brute-force start states: the static equilibrium, then rotor states drawn
/// (seeded) with positions within the gap `delta` of the static deflection and
/// velocities within `w_ref * delta`; the stator starts at rest at its static deflection.
pub fn start_states(params: &Params, k: u32, w_ref: f64, seed: u64) -> Vec<State> {
    let eq = params.static_equilibrium();
    (0..k as u64)
        .map(|i| {
            let mut x = eq;
            if i > 0 {
                let d = params.delta;
                x[X_R] += d * unit(i, seed.wrapping_mul(4));
                x[Y_R] += d * unit(i, seed.wrapping_mul(4) + 1);
                x[VX_R] += w_ref * d * unit(i, seed.wrapping_mul(4) + 2);
                x[VY_R] += w_ref * d * unit(i, seed.wrapping_mul(4) + 3);
            }
            x
        })
        .collect()
}

/// Concatenated results of all units of a brute-force stage.
pub(super) struct StageResult {
    poincare: Vec<f64>,
    status: Vec<Status>,
    lambda1: Option<Vec<f64>>,
    /// What early exit saved (`None`: it ran without).
    pub(super) early: Option<EarlySaved>,
}

/// How a brute-force stage's lanes exit early (`crate::early`, [`Then::Record`]: a lane
/// recognised on an attractor of its speed during its transient records its periods
/// from there, and is classified from that record as any lane).
///
/// [`Then::Record`]: jeffcott_core::ensemble::early::Then::Record
pub(super) enum BruteEarly<'a> {
    /// Each speed's first lane runs whole and catalogues the speed for its other lanes
    /// (the first pass: nothing is known of a speed before it).
    FirstLane,
    /// Lanes are recognised by this recogniser of their speed (index) from the start
    /// (the second pass: the first pass's catalogues').
    Known(&'a (dyn Fn(usize) -> crate::early::Recogniser + Sync)),
}

/// Unit `lanes`' records as a brute-force unit holds them.
fn stage_unit(r: jeffcott_core::ensemble::EnsembleResult) -> Unit {
    let mut unit = Unit::new("").with("poincare", Array::F64(r.poincare)).with(
        "status",
        Array::U32(r.status.iter().map(|s| s.code()).collect()),
    );
    if let Some(l) = r.lambda1 {
        unit = unit.with("lambda1", Array::F64(l));
    }
    unit
}

/// Computes one brute-force unit with early exit: `e`'s lanes, lane i at the speed of
/// group `group[i]`, `ws[g]` the index of each group's speed
/// ([`crate::early::records_by_group`], the speeds as its groups).
fn early_unit(
    spec: &BifurcationSpec,
    how: &BruteEarly,
    e: &EnsembleSpec,
    ws: &[usize],
    group: &[usize],
    engine: &crate::backend::Engine,
    ctl: Control,
) -> Result<(Unit, Option<RunInfo>)> {
    use crate::early::GroupRecognition;
    let how = match how {
        BruteEarly::FirstLane => GroupRecognition::FirstLane,
        BruteEarly::Known(recogniser) => {
            GroupRecognition::Known(ws.iter().map(|&wi| recogniser(wi)).collect())
        }
    };
    let omegas: Vec<f64> = ws.iter().map(|&wi| spec.omegas[wi]).collect();
    let (out, saved, info) = crate::early::records_by_group(
        e,
        group,
        &omegas,
        how,
        spec.lane.catalogue,
        spec.lane.lyapunov,
        engine,
        ctl,
    )?;
    let unit = stage_unit(out).with("early", Array::F64(saved.to_array()));
    Ok((unit, info))
}

/// Runs (or resumes) one brute-force stage: `lanes_of(wi)` are the lanes at speed index
/// wi; a unit holds consecutive speeds (at most 1/20 of them and ~25 s of work). With
/// `early` (and the study's early exit on) lanes exit early as it says.
#[allow(clippy::too_many_arguments)]
pub(super) fn brute_stage(
    spec: &BifurcationSpec,
    engine: &crate::backend::Engine,
    stage: &str,
    lanes_of: &(dyn Fn(usize) -> Vec<State> + Sync),
    early: Option<BruteEarly>,
    store: &dyn UnitStore,
    ctl: Control,
    base: u64,
) -> Result<(StageResult, Option<RunInfo>)> {
    let n = spec.omegas.len();
    let per_w = spec.ics.max(1) as u64
        * (spec.brute_transient + spec.periods) as u64
        * spec.lane.stepper.steps_per_period as u64
        * if spec.lane.lyapunov { 2 } else { 1 };
    let per = crate::run::unit_lanes(n, per_w);
    let split = Split::new(n, per);
    let count = split.count();
    let ensemble = |u: usize| EnsembleSpec {
        param_sets: vec![spec.lane.params.clone()],
        lanes: split
            .range(u)
            .flat_map(|wi| {
                let omega = spec.omegas[wi];
                lanes_of(wi).into_iter().map(move |x0| LaneSpec {
                    omega,
                    x0,
                    param_set: 0,
                })
            })
            .collect(),
        transient: spec.brute_transient,
        recorded: spec.periods,
        stepper: spec.lane.stepper,
        precision: spec.lane.precision,
    };
    let reduce = |_u: usize, _e: &EnsembleSpec, r: jeffcott_core::ensemble::EnsembleResult| {
        Ok(stage_unit(r))
    };
    let early = early.filter(|_| spec.lane.early_exit());
    let compute = |u: usize, e: &EnsembleSpec, engine: &crate::backend::Engine, c: Control| {
        let ws: Vec<usize> = split.range(u).collect();
        let group: Vec<usize> = (0..ws.len())
            .flat_map(|g| std::iter::repeat_n(g, lanes_of(ws[g]).len()))
            .collect();
        let how = early.as_ref().expect("computed with early exit only");
        early_unit(spec, how, e, &ws, &group, engine, c)
    };
    let progress = |d: u64, _t: u64| (ctl.progress)(base + d, 0);
    let lanes = |u: usize| split.range(u).map(|wi| lanes_of(wi).len()).sum();
    let ctl = Control {
        progress: &progress,
        cancel: ctl.cancel,
    };
    let info = LaneUnits::new(stage, split, &ensemble, &reduce)
        .lanes_of(&lanes)
        .lambda1(spec.lane.lyapunov)
        .computed_by(
            early
                .is_some()
                .then_some(&compute as &crate::run::lanes::ComputeUnit),
        )
        .run(store, engine, ctl)?;
    let mut out = StageResult {
        poincare: Vec::new(),
        status: Vec::new(),
        lambda1: spec.lane.lyapunov.then(Vec::new),
        early: None,
    };
    for u in 0..count {
        let unit = store.load(stage, u)?;
        EarlySaved::accumulate(&mut out.early, crate::early::unit_saved(&unit)?);
        out.poincare.extend_from_slice(unit.f64s("poincare")?);
        out.status.extend(
            unit.u32s("status")?
                .iter()
                .map(|&c| Status::from_code(c).unwrap_or(Status::NonFinite)),
        );
        if let Some(l) = out.lambda1.as_mut() {
            l.extend_from_slice(unit.f64s("lambda1")?);
        }
    }
    Ok((out, info))
}

/// The first brute-force pass as [`brute_force`] continues it: the engine, the common
/// start states, the pass's lanes and how it ran.
pub(super) type FirstPass = (
    crate::backend::Engine,
    Vec<State>,
    StageResult,
    Option<RunInfo>,
);

/// The second pass's starts at each W: the sweeps' states at the neighbouring W first
/// (they are the branches a continuation follows), then one point (a state at t = kT)
/// of every attractor the first pass found there, `spec.max_seeds` at most.
fn second_pass_seeds(
    spec: &BifurcationSpec,
    up: &[SweepPoint],
    down: &[SweepPoint],
    builders: &[CatalogueBuilder],
) -> Vec<Vec<State>> {
    let n = spec.omegas.len();
    let mut seeds: Vec<Vec<State>> = vec![Vec::new(); n];
    for (wi, s) in seeds.iter_mut().enumerate() {
        let mut cand: Vec<State> = Vec::new();
        let neighbours = [wi.wrapping_sub(1), wi + 1];
        for &nj in &neighbours {
            for sw in [up, down] {
                if let Some(p) = sw.get(nj)
                    && !p.status.is_frozen()
                {
                    cand.push(p.points[p.points.len() - 1]);
                }
            }
        }
        for &nj in &neighbours {
            if nj < n {
                for a in builders[nj].attractors() {
                    cand.push(a.points[a.points.len() - 1]);
                }
            }
        }
        cand.truncate(spec.max_seeds);
        *s = cand;
    }
    seeds
}

pub(super) fn brute_force(
    spec: &BifurcationSpec,
    up: &[SweepPoint],
    down: &[SweepPoint],
    first: FirstPass,
    store: &dyn UnitStore,
    ctl: Control,
) -> Result<(Vec<BrutePoint>, Option<RunInfo>, Option<EarlySaved>)> {
    let (engine, common, res1, info1) = first;
    let n = spec.omegas.len();
    let k = spec.ics as usize;
    let rec = spec.periods as usize;
    let lane_len = rec * STATE_DIM;
    // First-pass catalogues, to know what to seed from.
    let mut builders: Vec<CatalogueBuilder> = Vec::with_capacity(n);
    let mut labels: Vec<Vec<i32>> = Vec::with_capacity(n);
    for (wi, &omega) in spec.omegas.iter().enumerate() {
        let mut b = CatalogueBuilder::new(omega, spec.lane.catalogue);
        let frozen: Vec<bool> = res1.status[wi * k..(wi + 1) * k]
            .iter()
            .map(|s| s.is_frozen())
            .collect();
        labels.push(b.add_block(
            &res1.poincare[wi * k * lane_len..(wi + 1) * k * lane_len],
            rec,
            &frozen,
            res1.lambda1.as_ref().map(|l| &l[wi * k..(wi + 1) * k]),
        ));
        builders.push(b);
    }
    let seeds = second_pass_seeds(spec, up, down, &builders);
    let (res2, info2) = if seeds.iter().all(|s| s.is_empty()) {
        (None, None)
    } else {
        let streak = spec.lane.stepper.early_exit_streak;
        let known = |wi: usize| builders[wi].recogniser_to_record(streak);
        let (r, i) = brute_stage(
            spec,
            &engine,
            "bf2",
            &|wi| seeds[wi].clone(),
            Some(BruteEarly::Known(&known)),
            store,
            ctl,
            0,
        )?;
        (Some(r), i)
    };
    let mut out = Vec::with_capacity(n);
    let mut off2 = 0usize;
    for (wi, (mut b, mut lab)) in builders.into_iter().zip(labels).enumerate() {
        let m = seeds[wi].len();
        let mut points = res1.poincare[wi * k * lane_len..(wi + 1) * k * lane_len].to_vec();
        let mut lambda1 = res1
            .lambda1
            .as_ref()
            .map(|l| l[wi * k..(wi + 1) * k].to_vec());
        if let Some(r2) = &res2 {
            let frozen: Vec<bool> = r2.status[off2..off2 + m]
                .iter()
                .map(|s| s.is_frozen())
                .collect();
            let p2 = &r2.poincare[off2 * lane_len..(off2 + m) * lane_len];
            let l2 = r2.lambda1.as_ref().map(|l| &l[off2..off2 + m]);
            lab.extend(b.add_block(p2, rec, &frozen, l2));
            points.extend_from_slice(p2);
            if let (Some(l), Some(l2)) = (lambda1.as_mut(), l2) {
                l.extend_from_slice(l2);
            }
        }
        off2 += m;
        let mut starts = common.clone();
        starts.extend_from_slice(&seeds[wi]);
        out.push(BrutePoint {
            omega: spec.omegas[wi],
            starts,
            points,
            catalogue: b.finish(lab),
            lambda1,
        });
    }
    let mut saved = res1.early;
    EarlySaved::accumulate(&mut saved, res2.as_ref().and_then(|r| r.early));
    Ok((out, info2.or(info1), saved))
}
