//! Periodic orbits: `orbits`.

use crate::args::{self, kw};
use crate::convert::{array_nd, array2, json_to_py, model_and_start};
use crate::run;
use jeffcott_analysis::defaults;
use jeffcott_analysis::orbits::OrbitsRequest;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;

/// A branch of period-`period` orbits continued over `param` by Newton shooting and
/// pseudo-arclength: the command line's `orbits`.
///
/// Returns the dictionary of `branches.json` (`param`; `branches`, each with its
/// `points` (value, orbit state `x`, `multipliers` [re, im], `stable`,
/// `min_clearance`), its `bifurcations` (`type`: fold, period_doubling, neimark_sacker
/// or grazing, and the parameter's value under its name) and why it `stop`ped; with
/// `follow_doublings` also the period-2n branch of each period doubling) with the arrays
/// `branch` `[points, 13]` (branch index, value, state, largest |mu|, smallest
/// clearance, stable) and `multipliers` `[points, 8, 2]`.
///
/// Parameters:
/// - `param`: the continued parameter and its range, `"NAME:lo:hi"` (NAME `omega` or a
///   model parameter), e.g. `"omega:131.7:132.4"`.
/// - `omega`: the rotor speed W [rad/s] when the continued parameter is not omega.
/// - `period`: the period of the orbits in forcing periods.
/// - `direction`: which way the parameter first moves, `"up"` (the branch starts at
///   lo) or `"down"` (at hi).
/// - `settle`: forcing periods integrated from the start state before shooting, so
///   Newton starts near the attractor there (0: shoot from the start state itself).
#[doc = param_doc!(init)]
/// - `max_points`: branch points at most.
/// - `ds`: the first arclength step (positions in metres, velocities over W, the
///   parameter at 1 mm per its range).
/// - `ds_max`: the largest arclength step.
/// - `follow_doublings`: also continue the period-2n branch born at each period
///   doubling.
/// - `start_from`: a basin, bifurcation or continuation output directory whose
///   periodic attractors start the branches (the command line's `--from`).
/// - `backend`: where the flows run, always in f64 (`"cpu"`, `"gpu"`, `"auto"`; the
///   same bits on each).
#[doc = param_doc!(params)]
#[doc = param_doc!(stepper)]
#[pyfunction]
#[pyo3(signature = (
    param, *, omega=None, period=defaults::orbits::PERIOD, direction="up",
    settle=defaults::orbits::SETTLE, init=None, max_points=defaults::orbits::MAX_POINTS,
    ds=defaults::orbits::DS, ds_max=defaults::orbits::DS_MAX, follow_doublings=false,
    start_from=None, backend="cpu", params=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn orbits<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = kw::param)] param: String,
    #[pyo3(from_py_with = kw::omega)] omega: Option<f64>,
    #[pyo3(from_py_with = kw::period)] period: u32,
    #[pyo3(from_py_with = kw::branch_direction)] direction: &str,
    #[pyo3(from_py_with = kw::settle)] settle: u32,
    #[pyo3(from_py_with = kw::init)] init: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::max_points)] max_points: usize,
    #[pyo3(from_py_with = kw::ds)] ds: f64,
    #[pyo3(from_py_with = kw::ds_max)] ds_max: f64,
    #[pyo3(from_py_with = kw::follow_doublings)] follow_doublings: bool,
    #[pyo3(from_py_with = kw::start_from)] start_from: Option<std::path::PathBuf>,
    #[pyo3(from_py_with = kw::backend)] backend: &str,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("orbits", stepper)?;
    let overridden: Vec<String> = params.iter().flat_map(|p| p.keys().cloned()).collect();
    let (params, start) = model_and_start(params, init)?;
    let study = OrbitsRequest {
        params,
        param: &param,
        param_field: "param",
        omega,
        period,
        up: direction == "up",
        settle,
        start,
        max_points,
        ds,
        ds_max,
        stepper,
        follow_doublings,
        from: start_from.as_deref(),
    }
    .study()
    .map_err(run::to_py_err)?;
    (study.branch.var)
        .check_not_overridden("param", "params", &overridden)
        .map_err(run::to_py_err)?;
    let backend =
        jeffcott_core::ensemble::Backend::parse("backend", backend).map_err(run::to_py_err)?;
    let branches = run::detached(py, None, |ctl| {
        let engine = jeffcott_analysis::backend::Engine::new(
            backend,
            jeffcott_core::ensemble::Precision::F64,
        )?;
        jeffcott_analysis::orbits::run(&study, &engine, ctl.cancel)
    })?;
    let name = study.branch.var.name();
    let d = json_to_py(py, &jeffcott_analysis::orbits::record(name, &branches))?
        .cast_into::<PyDict>()?;
    let (rows, mu) = jeffcott_analysis::orbits::arrays(&branches);
    let n = rows.len() / jeffcott_analysis::orbits::ROW;
    d.set_item("branch", array2(py, rows, jeffcott_analysis::orbits::ROW)?)?;
    d.set_item("multipliers", array_nd(py, mu, &[n, 8, 2])?)?;
    Ok(d)
}
