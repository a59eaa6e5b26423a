//! What the explorer's views compute, each from one request's query: a slice of columns
//! of a brute-force bifurcation diagram, a basin at one resolution, one lane's
//! trajectory with its attractor. Every input is checked here with the command line's
//! messages (the field, its value, the allowed range) before any work; the numbers
//! come from the same library calls the commands make.

use super::query::Query;
use jeffcott_analysis::backend::Engine;
use jeffcott_analysis::basin::{Axis, BasinSpec, base_state};
use jeffcott_analysis::bifurcation::start_states;
use jeffcott_analysis::catalogue::CatalogueConfig;
use jeffcott_analysis::classify::ClassifyConfig;
use jeffcott_analysis::map::MapVar;
use jeffcott_analysis::run::{MemoryStore, UnitStudy, Units};
use jeffcott_analysis::settings::LaneSettings;
use jeffcott_analysis::simulate::{Integrator, SimulateSpec, SimulateStudy, run_study};
use jeffcott_core::control::{Cancel, Control, no_progress};
use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision, range_value};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::article::ArticleConfig;
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{COORD_NAMES, Params, STATE_DIM, State};
use jeffcott_core::orbit::{ShootConfig, shoot};
use serde_json::{Value, json};

/// Columns of a bifurcation view at most (a screen's width, twice).
pub const MAX_COLUMNS: u32 = 8192;
/// Start states per column at most.
pub const MAX_STARTS: u32 = 256;
/// Lanes of one bifurcation request at most.
pub const MAX_LANES: u64 = 1 << 18;
/// Values one bifurcation request returns at most (64 MiB of f32).
pub const MAX_VALUES: u64 = 1 << 24;
/// Cells per axis of a basin view at most.
pub const MAX_BASIN_CELLS: u32 = 512;
/// Forcing periods a view integrates per lane at most (transient and record together).
pub const MAX_PERIODS: u32 = 20_000;
/// Forcing periods a view records per lane at most.
pub const MAX_RECORDED: u32 = 1024;
/// Seed of the start states of a bifurcation column (as `jeffcott bifurcation --seed`).
pub const SEED: u64 = 1;
/// Rows of a trajectory's time series sent to the page at most.
const MAX_ROWS: usize = 2400;

/// What every view shares: the model parameters, stepper and precision the explorer was
/// started with (`--config`, `--param`, the stepper options), which a request's `p.NAME`
/// fields override.
#[derive(Clone, Debug)]
pub struct Base {
    /// The parameters before a request's overrides.
    pub params: Params,
    /// The lane stepper.
    pub stepper: StepperConfig,
    /// The lanes' precision.
    pub precision: Precision,
    /// The backend asked for (the engine resolved it once).
    pub backend: Backend,
}

impl Base {
    /// The parameters of a request: the base ones with its `p.NAME` overrides, validated.
    pub fn params(&self, q: &Query) -> Result<Params> {
        let mut p = self.params.clone();
        for (key, value) in q.prefixed("p.") {
            let v = super::query::number(&format!("p.{key}"), value)?;
            p.set(key, v)?;
        }
        p.validate()?;
        Ok(p)
    }
}

/// The variable along a bifurcation view's horizontal axis: W or a model parameter.
fn column_var(q: &Query) -> Result<MapVar> {
    let name = q.text("param", "omega")?;
    match MapVar::parse("param", name)? {
        MapVar::Coord(_) => Err(Error::invalid(
            "param",
            name,
            "a bifurcation view varies omega or a model parameter, not a start coordinate",
        )),
        v => Ok(v),
    }
}

/// The lanes of bifurcation columns `from, from + step, ...` (`count` of them) of a view
/// of `n` columns over [lo, hi], and what they record.
struct Columns {
    var: MapVar,
    lo: f64,
    hi: f64,
    n: u32,
    from: u32,
    step: u32,
    count: u32,
    starts: u32,
    omega: f64,
    coord: usize,
    transient: u32,
    periods: u32,
}

impl Columns {
    fn parse(q: &Query) -> Result<Columns> {
        let var = column_var(q)?;
        let (lo, hi) = (q.number("lo", Some(125.0))?, q.number("hi", Some(145.0))?);
        if lo >= hi {
            return Err(Error::invalid("hi", hi, format!("must be > lo ({lo})")));
        }
        let n = q.count("n", 400, 1, MAX_COLUMNS)?;
        let from = q.count("from", 0, 0, n - 1)?;
        let step = q.count("step", 1, 1, n)?;
        let count = q.count("count", n, 1, n)?;
        let last = from as u64 + step as u64 * (count as u64 - 1);
        if last >= n as u64 {
            return Err(Error::invalid(
                "count",
                count,
                format!("column {last} is past the view's {n} columns"),
            ));
        }
        let starts = q.count("k", 4, 1, MAX_STARTS)?;
        let transient = q.count("transient", 200, 0, MAX_PERIODS)?;
        let periods = q.count("periods", 32, 1, MAX_RECORDED)?;
        check_periods(transient, periods)?;
        let lanes = count as u64 * starts as u64;
        if lanes > MAX_LANES {
            return Err(Error::invalid(
                "count",
                count,
                format!("{lanes} lanes (count x k) is more than one request takes ({MAX_LANES})"),
            ));
        }
        if lanes * periods as u64 > MAX_VALUES {
            return Err(Error::invalid(
                "periods",
                periods,
                format!("count x k x periods is more than one request returns ({MAX_VALUES})"),
            ));
        }
        Ok(Columns {
            var,
            lo,
            hi,
            n,
            from,
            step,
            count,
            starts,
            omega: q.number("omega", Some(133.0))?,
            coord: q.coord("coord", "vx_s")?,
            transient,
            periods,
        })
    }

    /// The value of column `c`.
    fn value(&self, c: u32) -> f64 {
        range_value(self.lo, self.hi, self.n as u64, c as u64)
    }

    /// The reference speed of the start states' velocity spread.
    fn w_ref(&self) -> f64 {
        match self.var {
            MapVar::Omega => 0.5 * (self.lo + self.hi),
            _ => self.omega,
        }
    }

    /// The ensemble of these columns: `starts` lanes per column, column-major.
    fn ensemble(&self, base: &Base, params: &Params) -> Result<EnsembleSpec> {
        let mut param_sets = Vec::new();
        let mut lanes = Vec::new();
        for i in 0..self.count {
            let v = self.value(self.from + i * self.step);
            let (p, omega) = column(&self.var, params, v, self.omega)?;
            let set = param_sets.len() as u32;
            for x0 in start_states(&p, self.starts, self.w_ref(), SEED) {
                lanes.push(LaneSpec {
                    omega,
                    x0,
                    param_set: set,
                });
            }
            param_sets.push(p);
        }
        let spec = EnsembleSpec {
            param_sets,
            lanes,
            transient: self.transient,
            recorded: self.periods,
            stepper: base.stepper,
            precision: base.precision,
        };
        spec.validate()?;
        Ok(spec)
    }
}

/// The parameters and speed of a column at value `v` of `var`.
fn column(var: &MapVar, params: &Params, v: f64, omega: f64) -> Result<(Params, f64)> {
    let mut p = params.clone();
    let omega = match var {
        MapVar::Omega => v,
        // The parameters are validated with the ensemble (EnsembleSpec::validate).
        MapVar::Param(name) => {
            p.set(name, v)?;
            omega
        }
        MapVar::Coord(_) => unreachable!("column_var refuses coordinates"),
    };
    jeffcott_core::model::validate_omega(omega)?;
    Ok((p, omega))
}

fn check_periods(transient: u32, periods: u32) -> Result<()> {
    if transient + periods > MAX_PERIODS {
        return Err(Error::invalid(
            "transient",
            transient,
            format!("transient + periods must be <= {MAX_PERIODS} in a view"),
        ));
    }
    Ok(())
}

/// A slice of a bifurcation view: per lane (columns in the order asked, `k` lanes per
/// column), its `periods` recorded values of the chosen coordinate; NaN for a lane that
/// diverged or went non-finite.
pub fn bifurcation(engine: &Engine, base: &Base, q: &Query, cancel: &Cancel) -> Result<Vec<f32>> {
    let cols = Columns::parse(q)?;
    let params = base.params(q)?;
    let spec = cols.ensemble(base, &params)?;
    let ctl = Control {
        progress: &no_progress,
        cancel,
    };
    let (res, _) = engine.run(&spec, false, ctl)?;
    let per = res.recorded;
    let mut out = Vec::with_capacity(res.status.len() * per);
    for (l, status) in res.status.iter().enumerate() {
        for r in 0..per {
            let v = res.poincare[(l * per + r) * STATE_DIM + cols.coord];
            out.push(if status.is_frozen() {
                f32::NAN
            } else {
                v as f32
            });
        }
    }
    Ok(out)
}

/// The basin of a view: labels per cell of an n x n grid at W over two start
/// coordinates (early exit as `jeffcott basin`), the axes' values, the base state and
/// the attractors with their fractions.
pub fn basin(engine: &Engine, base: &Base, q: &Query, cancel: &Cancel) -> Result<Value> {
    let params = base.params(q)?;
    let n = q.count("n", 64, 2, MAX_BASIN_CELLS)? as usize;
    let axis = |name: &str, coord: &str, lo: f64, hi: f64| -> Result<Axis> {
        let a = Axis {
            coord: q.coord(name, coord)?,
            lo: q.number(&format!("{name}lo"), Some(lo))?,
            hi: q.number(&format!("{name}hi"), Some(hi))?,
            n,
        };
        a.validate(name)?;
        Ok(a)
    };
    let x = axis("x", "x_r", -params.delta, params.delta)?;
    let y = axis("y", "vx_r", -1.0, 1.0)?;
    let transient = q.count("transient", 250, 0, MAX_PERIODS)?;
    let periods = q.count("periods", 32, 2, MAX_RECORDED)?;
    check_periods(transient, periods)?;
    let spec = BasinSpec {
        base: base_state(&params, &x, &y, &[], base.stepper.divergence_bound)?,
        lane: LaneSettings {
            params,
            stepper: base.stepper,
            precision: base.precision,
            backend: base.backend,
            catalogue: CatalogueConfig::for_precision(base.precision),
            lyapunov: false,
        },
        omega: q.number("omega", Some(133.0))?,
        x,
        y,
        transient,
        periods,
        lanes_per_unit: None,
    };
    spec.validate()?;
    let ctl = Control {
        progress: &no_progress,
        cancel,
    };
    let store = MemoryStore::new();
    let r = spec.compute(Units {
        engine,
        store: &store,
        ctl,
    })?;
    let attractors: Vec<Value> = r
        .catalogue
        .attractors
        .iter()
        .map(|a| {
            json!({"id": a.id, "class": a.class, "period": a.period,
                   "fraction": a.basin_fraction, "size_m": a.size_m})
        })
        .collect();
    Ok(json!({
        "nx": n, "ny": n,
        "xs": (0..n).map(|i| spec.x.value(i)).collect::<Vec<_>>(),
        "ys": (0..n).map(|i| spec.y.value(i)).collect::<Vec<_>>(),
        "x": COORD_NAMES[spec.x.coord], "y": COORD_NAMES[spec.y.coord],
        "base": spec.base,
        "labels": r.labels,
        "attractors": attractors,
        "diverged_fraction": r.catalogue.diverged_fraction,
        "seconds": r.seconds,
    }))
}

/// The start state of a trajectory: `x0` (eight numbers), or start `start` of the `k`
/// start states of a bifurcation column (`wref`: their velocity spread's speed).
fn trajectory_start(q: &Query, params: &Params) -> Result<State> {
    if let Some(text) = q.get("x0") {
        let v: Vec<f64> = text
            .split(',')
            .map(|s| super::query::number("x0", s))
            .collect::<Result<_>>()?;
        let x: State = v.try_into().map_err(|v: Vec<f64>| {
            Error::invalid(
                "x0",
                v.len(),
                "needs 8 numbers: x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s",
            )
        })?;
        return Ok(x);
    }
    let k = q.count("k", 1, 1, MAX_STARTS)?;
    let j = q.count("start", 0, 0, k - 1)?;
    let w_ref = q.number("wref", Some(133.0))?;
    Ok(start_states(params, k, w_ref, SEED)[j as usize])
}

/// One lane's trajectory: its class and period, Poincare points, the last periods'
/// time series, the rub stretch's contact force and full spectrum, and for a periodic
/// response its Floquet multipliers (shooting from the final state).
pub fn trajectory(base: &Base, q: &Query, cancel: &Cancel) -> Result<Value> {
    let params = base.params(q)?;
    let omega = q.number("omega", Some(133.0))?;
    let x0 = trajectory_start(q, &params)?;
    let transient = q.count("transient", 200, 0, MAX_PERIODS)?;
    let periods = q.count("periods", 64, 2, MAX_RECORDED)?;
    check_periods(transient, periods)?;
    let study = SimulateStudy {
        spec: SimulateSpec {
            params: params.clone(),
            omega,
            x0,
            transient,
            periods,
            timeseries_periods: periods.min(8),
            integrator: Integrator::Lane,
            stepper: base.stepper,
            article: ArticleConfig::DEFAULT,
            classify: ClassifyConfig::DEFAULT,
        },
        spectrum_periods: 48,
    };
    let out = run_study(&study, cancel)?;
    let res = &out.result;
    let period = res.classification.class.period();
    let floquet = match period {
        Some(n) if !res.status.is_frozen() => {
            let cfg = ShootConfig {
                stepper: base.stepper,
                ..ShootConfig::default()
            };
            match shoot(&params, omega, &res.final_state, n as u32, &cfg) {
                Ok(o) => json!({"multipliers": o.multipliers.iter()
                    .map(|m| [m.re, m.im]).collect::<Vec<_>>(),
                    "stable": o.stable(), "residual": o.residual}),
                Err(e) => json!({"error": e.to_string()}),
            }
        }
        _ => Value::Null,
    };
    let rows = &res.timeseries;
    let stride = rows.len().div_ceil(MAX_ROWS).max(1);
    let series: Vec<&[f64; STATE_DIM + 1]> = rows.iter().step_by(stride).collect();
    let (contact, spectrum) = match &out.rub {
        Some(r) => {
            let stride = r.contact.len().div_ceil(MAX_ROWS).max(1);
            let c: Vec<[f64; 2]> = r
                .contact
                .iter()
                .step_by(stride)
                .map(|c| [c[0], c[4]])
                .collect();
            let s: Vec<[f64; 3]> = r
                .spectrum_table()
                .into_iter()
                .filter(|row| row[0].abs() <= 4.0)
                .map(|row| [row[0], row[2], row[3]])
                .collect();
            (json!(c), json!(s))
        }
        None => (Value::Null, Value::Null),
    };
    Ok(json!({
        "omega": omega,
        "x0": x0,
        "class": res.classification.class.label(),
        "period": period,
        "status": res.status,
        "contact_fraction": res.contact_fraction,
        "delta": params.delta,
        "poincare": res.poincare,
        "timeseries": series,
        "contact": contact,
        "spectrum": spectrum,
        "floquet": floquet,
    }))
}
