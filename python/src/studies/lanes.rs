//! Lanes over speeds: `ensemble`, `bifurcation` (sweeps and brute force) and `cascade`.

use crate::args::{self, Callback, Table, kw};
use crate::convert::{self, array1, array2, array3, json_to_py, lane_specs, model_params};
use crate::run;
use crate::{backend_precision, speeds};
use jeffcott_analysis::bifurcation::{BifurcationSpec, Sweep};
use jeffcott_analysis::defaults;
use jeffcott_core::Error;
use jeffcott_core::ensemble::EnsembleSpec;
use jeffcott_core::model::STATE_DIM;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;

/// Many independent lanes: the command line's `ensemble`.
///
/// The lanes are speeds (`omega`) from one start state, or the rows of a table
/// (`lanes`). Returns `poincare` `[lanes, periods, 8]` (NaN from the period a lane froze
/// in), `status` (uint32: 0 ok, 1 refinement_cap, 2 diverged, 3 non_finite), `lanes`
/// `[lanes, 10]`, `params` `[sets, 14]` (`[sets, 24]`, the columns of `PARAM_KEYS`,
/// when a set uses a machine variant), with `lyapunov=True` `lambda1` `[lanes]`, and
/// `run`, the dictionary of `run.json` (backend, device, precision, counters, status
/// counts, speed).
///
/// Parameters:
/// - `omega`: a speed [rad/s], a sequence of speeds or `"a:b:n"` (n speeds from a to b
///   inclusive), one lane each; with `lanes`, the one speed of lanes whose table has no
///   omega column.
/// - `lanes`: a 2-D array-like of numbers (read as float64), one lane per row, as the
///   command line's `--lanes`: its columns may be omega, parameter keys, start
///   coordinates and param_set; absent ones take `omega`, `params` and the static
///   equilibrium with `init`.
/// - `columns`: the names of the columns of `lanes` (needed with it).
#[doc = param_doc!(params, init)]
/// - `transient`: forcing periods integrated and discarded.
/// - `periods`: forcing periods recorded per lane.
#[doc = param_doc!(backend, precision)]
/// - `lyapunov`: also compute each lane's largest Lyapunov exponent lambda_1 [1/s]
///   (`lambda1`) from a tangent vector renormalised every period.
#[doc = param_doc!(progress)]
#[doc = param_doc!(stepper)]
#[pyfunction]
#[pyo3(signature = (
    omega=None, *, lanes=None, columns=None, params=None, init=None,
    transient=defaults::ensemble::TRANSIENT, periods=defaults::ensemble::PERIODS,
    backend="auto", precision=None, lyapunov=false,
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn ensemble<'py>(
    py: Python<'py>,
    omega: Option<Bound<'py, PyAny>>,
    #[pyo3(from_py_with = kw::lanes)] lanes: Option<Table<'py>>,
    #[pyo3(from_py_with = kw::columns)] columns: Option<Vec<String>>,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::init)] init: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::transient)] transient: u32,
    #[pyo3(from_py_with = kw::periods)] periods: u32,
    #[pyo3(from_py_with = kw::backend)] backend: &str,
    #[pyo3(from_py_with = kw::precision)] precision: Option<&str>,
    #[pyo3(from_py_with = kw::lyapunov)] lyapunov: bool,
    #[pyo3(from_py_with = kw::progress)] progress: Option<Callback<'py>>,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("ensemble", stepper)?;
    jeffcott_core::limits::check_periods("transient", transient, 0).map_err(run::to_py_err)?;
    jeffcott_core::limits::check_periods("periods", periods, 1).map_err(run::to_py_err)?;
    let (backend, precision) = backend_precision(backend, precision)?;
    let overridden: Vec<String> = params.iter().flat_map(|p| p.keys().cloned()).collect();
    let model = model_params(params)?;
    let omegas = match &omega {
        Some(w) => Some(speeds("omega", w, |text, n| {
            EnsembleSpec::check_size("omega", text, n, periods)
        })?),
        None => None,
    };
    if let Some(t) = &lanes {
        let rows = t.0.as_array().nrows();
        EnsembleSpec::check_size(
            "lanes",
            &format!("an array of {rows} rows"),
            rows as u64,
            periods,
        )
        .map_err(run::to_py_err)?;
    }
    let (param_sets, lane_list) = lane_specs(
        &model,
        omegas,
        lanes.map(|t| t.0),
        columns,
        init,
        &overridden,
        stepper.divergence_bound,
    )?;
    let spec = EnsembleSpec {
        lanes: lane_list,
        param_sets,
        transient,
        recorded: periods,
        stepper,
        precision,
    };
    spec.validate().map_err(run::to_py_err)?;
    let (res, info) = run::detached(py, progress.as_ref().map(|c| &c.0), |ctl| {
        jeffcott_analysis::backend::run(&spec, backend, lyapunov, ctl)
    })?;
    let n = spec.lanes.len();
    let codes: Vec<u32> = res.status.iter().map(|s| s.code()).collect();
    let totals = jeffcott_analysis::ensemble::Totals::of(&res.counters);
    let record = jeffcott_analysis::ensemble::run_record(
        jeffcott_analysis::ensemble::Sizes::of(&spec),
        &totals,
        &codes,
        &info,
    );
    let d = PyDict::new(py);
    d.set_item("poincare", array3(py, res.poincare, n, periods as usize)?)?;
    d.set_item("status", array1(py, codes))?;
    d.set_item(
        "lanes",
        array2(
            py,
            jeffcott_analysis::ensemble::lanes_table(&spec.lanes),
            2 + STATE_DIM,
        )?,
    )?;
    d.set_item(
        "params",
        array2(
            py,
            jeffcott_core::ensemble::table::params_table(&spec.param_sets),
            jeffcott_core::ensemble::table::params_columns(&spec.param_sets).len(),
        )?,
    )?;
    if let Some(l) = res.lambda1 {
        d.set_item("lambda1", array1(py, l))?;
    }
    d.set_item("run", json_to_py(py, &record)?)?;
    Ok(d)
}

lane_study! {
    /// Quasistatic sweeps up and down in W and a brute-force ensemble per W: the command
    /// line's `bifurcation`.
    ///
    /// Returns `omega` `[W]`, `rows` `[rows, 4]` (W, sweep 0 up / 1 down / 2 brute force,
    /// lane, attractor id), `points` `[rows, periods, 8]` (each row's Poincare points),
    /// `lambda1` `[rows]` and `summary`, the dictionary of `summary.json`.
    ///
    /// Parameters:
    /// - `omega`: the rotor speeds [rad/s]: `"a:b:n"` (n speeds from a to b inclusive),
    ///   a sequence of speeds or one speed.
    /// - `sweep`: the quasistatic sweeps, `"up"`, `"down"` or `"both"` (run
    ///   concurrently), or `"none"` (brute force only; needs `ics` >= 1).
    /// - `ics`: brute-force start states per W (the static equilibrium and a seeded
    ///   random set); 0 disables the brute force.
    /// - `seed`: the seed of the random start states.
    /// - `transient`: forcing periods of transient per W of the quasistatic sweeps.
    /// - `transient_first`: forcing periods of transient at the first W of each sweep,
    ///   from the static equilibrium.
    /// - `brute_transient`: forcing periods of transient of the brute-force lanes.
    /// - `periods`: recorded periods (Poincare points) per lane.
    /// - `max_seeds`: neighbour seeds per W in the brute force's second pass, at most.
    signature = (
        omega, *, sweep="both", ics=defaults::bifurcation::ICS, seed=defaults::bifurcation::SEED,
        transient=defaults::bifurcation::TRANSIENT,
        transient_first=defaults::bifurcation::TRANSIENT_FIRST,
        brute_transient=defaults::bifurcation::BRUTE_TRANSIENT,
        periods=defaults::bifurcation::PERIODS, max_seeds=defaults::bifurcation::MAX_SEEDS,
    );
    fn bifurcation<'py>(
        py: Python<'py>,
        omega: Bound<'py, PyAny>,
        #[pyo3(from_py_with = kw::sweep)] sweep: &str,
        #[pyo3(from_py_with = kw::ics)] ics: u32,
        #[pyo3(from_py_with = kw::seed)] seed: u64,
        #[pyo3(from_py_with = kw::transient)] transient: u32,
        #[pyo3(from_py_with = kw::transient_first)] transient_first: u32,
        #[pyo3(from_py_with = kw::brute_transient)] brute_transient: u32,
        #[pyo3(from_py_with = kw::periods)] periods: u32,
        #[pyo3(from_py_with = kw::max_seeds)] max_seeds: usize,
    )
    with (lane: lane, progress: progress)
    {
        let sweep = match sweep {
            "up" => Some(Sweep::Up),
            "down" => Some(Sweep::Down),
            "both" => Some(Sweep::Both),
            "none" => None,
            other => {
                return Err(run::to_py_err(Error::invalid(
                    "sweep",
                    other,
                    "must be up, down, both or none",
                )));
            }
        };
        for (name, v, min) in [
            ("transient_first", transient_first, 0),
            ("transient", transient, 0),
            ("brute_transient", brute_transient, 0),
            ("periods", periods, 2),
        ] {
            jeffcott_core::limits::check_periods(name, v, min).map_err(run::to_py_err)?;
        }
        let sweeps = match sweep {
            None => 0,
            Some(Sweep::Both) => 2,
            Some(_) => 1,
        };
        let omegas = speeds("omega", &omega, |text, n| {
            BifurcationSpec::check_size(text, n, sweeps, ics, max_seeds, periods)
        })?;
        let spec = BifurcationSpec {
            lane,
            omegas,
            sweep,
            transient_first,
            transient,
            ics,
            brute_transient,
            periods,
            seed,
            max_seeds,
        };
        spec.validate().map_err(run::to_py_err)?;
        let (res, summary) = run::detached(py, progress.as_ref().map(|c| &c.0), |ctl| {
            let res = jeffcott_analysis::bifurcation::bifurcation(&spec, ctl)?;
            // The summary borrows the result: held as the file's JSON value.
            let summary = jeffcott_analysis::bifurcation::summary(&spec, &res)?;
            let summary = serde_json::to_value(summary)
                .map_err(|e| jeffcott_core::Error::invalid("summary", "", e.to_string()))?;
            Ok((res, summary))
        })?;
        let a = jeffcott_analysis::bifurcation::arrays(&res);
        let rows = a.rows.len() / 4;
        let d = PyDict::new(py);
        d.set_item("omega", array1(py, spec.omegas.clone()))?;
        d.set_item("rows", array2(py, a.rows, 4)?)?;
        d.set_item("points", array3(py, a.points, rows, periods as usize)?)?;
        d.set_item("lambda1", array1(py, a.lambda1))?;
        d.set_item("summary", json_to_py(py, &summary)?)?;
        Ok(d)
    }
}

/// Full-spectrum cascade of a quasistatic run-up and run-down: the command line's
/// `cascade` (docs/rub.md).
///
/// Returns `omega` `[n]` (ascending), `orders` `[bins]` (frequency / W, < 0 backward
/// whirl), `cascade` and `cascade_stator` (f64 `[sweeps, n, bins]`, full-spectrum
/// amplitudes [m], NaN after a divergence), `regime` (int32 `[sweeps, n]`: 0 no_contact,
/// 1 partial_rub, 2 full_annular_rub, 3 backward_whirl, -1 diverged) and `summary`, the
/// dictionary of `cascade.json` (its `sweeps` name the blocks).
///
/// Parameters:
/// - `omega`: the rotor speeds, `"a:b:n"` (n >= 2 speeds from a to b inclusive)
///   [rad/s], swept quasistatically.
#[doc = param_doc!(params)]
/// - `transient_first`: forcing periods at the first speed of each sweep, from the
///   static equilibrium.
/// - `transient`: forcing periods at each later speed before its spectrum is taken.
/// - `periods`: forcing periods of each spectrum (a multiple of 6 puts 1/2X, 1/3X and
///   2/3X on bins).
/// - `max_order`: the orders kept, -max..=max (frequency / W).
/// - `direction`: `"up"` (run-up), `"down"` (run-down) or `"both"`.
/// - `progress`: a callable `f(done, total)` called as the run advances (in speeds),
///   or None.
#[doc = param_doc!(stepper)]
#[pyfunction]
#[pyo3(signature = (
    omega, *, params=None,
    transient_first=defaults::cascade::TRANSIENT_FIRST,
    transient=defaults::cascade::TRANSIENT,
    periods=defaults::cascade::PERIODS,
    max_order=defaults::cascade::MAX_ORDER,
    direction="both",
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn cascade<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = kw::omega_range)] omega: String,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::transient_first)] transient_first: u32,
    #[pyo3(from_py_with = kw::transient)] transient: u32,
    #[pyo3(from_py_with = kw::periods)] periods: u32,
    #[pyo3(from_py_with = kw::max_order)] max_order: f64,
    #[pyo3(from_py_with = kw::direction)] direction: &str,
    #[pyo3(from_py_with = kw::progress)] progress: Option<Callback<'py>>,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("cascade", stepper)?;
    use jeffcott_analysis::cascade::CascadeSpec;
    use jeffcott_analysis::continuation::Direction;
    let ramps = jeffcott_analysis::continuation::directions(direction).map_err(run::to_py_err)?;
    let spec = CascadeSpec {
        params: model_params(params)?,
        omegas: CascadeSpec::speeds(&omega).map_err(run::to_py_err)?,
        transient_first,
        transient,
        periods,
        max_order,
        stepper,
        up: ramps.contains(&Direction::Up),
        down: ramps.contains(&Direction::Down),
    };
    spec.validate().map_err(run::to_py_err)?;
    spec.check_size(&omega).map_err(run::to_py_err)?;
    let res = run::detached(py, progress.as_ref().map(|c| &c.0), |ctl| {
        jeffcott_analysis::cascade::cascade(&spec, ctl)
    })?;
    let a = jeffcott_analysis::cascade::arrays(&res);
    let (ns, n, nb) = (a.sweeps.len(), spec.omegas.len(), res.orders.len());
    let d = PyDict::new(py);
    d.set_item("omega", array1(py, spec.omegas.clone()))?;
    d.set_item("orders", array1(py, res.orders.clone()))?;
    d.set_item("cascade", convert::array_nd(py, a.rotor, &[ns, n, nb])?)?;
    d.set_item(
        "cascade_stator",
        convert::array_nd(py, a.stator, &[ns, n, nb])?,
    )?;
    d.set_item("regime", array2(py, a.regime, n)?)?;
    d.set_item(
        "summary",
        json_to_py(py, &jeffcott_analysis::cascade::summary(&spec, &res))?,
    )?;
    Ok(d)
}
