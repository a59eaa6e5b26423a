//! Basins and their measures: `basin`, `basin_stability` and `basin_metrics`.

use crate::args::{self, Callback, Labels, kw};
use crate::convert::{self, array1, array2, json_to_py};
use crate::lane_settings;
use crate::run;
use jeffcott_analysis::basin::BasinSpec;
use jeffcott_analysis::basin::study::BasinStudy;
use jeffcott_analysis::defaults;
use jeffcott_analysis::record::StudySpec;
use jeffcott_analysis::run::MemoryHost;
use jeffcott_core::ensemble::Precision;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;

/// The `run` dictionary of `basin`: backend, device, precision, wall time and the
/// specification `run.json` records.
#[derive(serde::Serialize)]
struct BasinRun<'a> {
    backend: Option<&'static str>,
    device: Option<&'a str>,
    precision: Precision,
    wall_time_s: f64,
    spec: jeffcott_analysis::basin::BasinSpec,
}

/// A basin of attraction over two start coordinates at one speed: the command line's
/// `basin`.
///
/// Returns `labels` (int32 `[ny, nx]`, attractor ids, -1
/// diverged, -2 an attractor a refinement found that the coarse grid did not), `x`,
/// `y` (the axis values), `attractors` (the list of `attractors.json`, each with its
/// rub figures under `rub`), `diverged`, `metrics` (`basin_metrics.json`'s keys:
/// fractions, entropies, uncertainty exponent, box-counting dimension, Wada test; with
/// `uncertainty_samples > 0` the re-integration estimate), with `refine > 0` `refined`
/// (uint8 `[ny, nx]`, 1 where the label was integrated), with `lyapunov=True`
/// `lambda1` `[ny, nx]`, and `run` (backend, wall time).
///
/// Parameters:
/// - `omega`: the rotor speed W [rad/s].
/// - `x`, `y`: the horizontal and vertical axes, each a start coordinate with its
///   range and count, `(name, lo, hi, n)` tuples or `"name:lo:hi:n"` strings (n values
///   from lo to hi inclusive [m or m/s]), e.g. `("x_r", -0.006, 0.006, 80)`.
/// - `fix`: other start coordinates, `{name: value}` (default: the static
///   equilibrium).
#[doc = param_doc!(params)]
/// - `transient`: forcing periods integrated and discarded.
/// - `periods`: forcing periods recorded per cell (at least 2 n to see period n).
#[doc = param_doc!(backend, precision)]
/// - `lyapunov`: also compute every cell's largest Lyapunov exponent lambda_1 (one
///   tangent vector per lane): `lambda1`, lambda_1 per attractor, and aperiodic
///   attractors split into quasiperiodic and chaotic (not with `refine`).
/// - `refine`: levels of boundary refinement (0: none), each a 2 x 2 subdivision
///   around every cell with a differently labelled neighbour, interiors filled from
///   their parent; the labels and measures are then on the finest grid, of
///   (n - 1) 2^levels + 1 points per axis.
/// - `uncertainty_samples`: draws of the uncertainty exponent by re-integration (each
///   draw integrated as it is and displaced along both axes); 0 skips it.
/// - `entropy_box`: the side of the basin entropy's boxes in cells; None: 5, or the
///   grid's shorter side if smaller.
#[doc = param_doc!(progress)]
#[doc = param_doc!(stepper)]
#[pyfunction]
#[pyo3(signature = (
    omega, x, y, *, fix=None, params=None,
    transient=defaults::basin::TRANSIENT, periods=defaults::basin::PERIODS,
    backend="auto", precision=None, lyapunov=false,
    refine=0, uncertainty_samples=defaults::basin::UNCERTAINTY_SAMPLES, entropy_box=None,
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn basin<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = kw::omega)] omega: f64,
    x: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
    #[pyo3(from_py_with = kw::fix)] fix: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::transient)] transient: u32,
    #[pyo3(from_py_with = kw::periods)] periods: u32,
    #[pyo3(from_py_with = kw::backend)] backend: &str,
    #[pyo3(from_py_with = kw::precision)] precision: Option<&str>,
    #[pyo3(from_py_with = kw::lyapunov)] lyapunov: bool,
    #[pyo3(from_py_with = kw::refine)] refine: u32,
    #[pyo3(from_py_with = kw::uncertainty_samples)] uncertainty_samples: usize,
    #[pyo3(from_py_with = kw::entropy_box)] entropy_box: Option<usize>,
    #[pyo3(from_py_with = kw::progress)] progress: Option<Callback<'py>>,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let lane = lane_settings("basin", params, backend, precision, lyapunov, stepper)?;
    let x = convert::axis("x", &x)?;
    let y = convert::axis("y", &y)?;
    let base = jeffcott_analysis::basin::base_state(
        &lane.params,
        &x,
        &y,
        &convert::sorted_pairs(fix.unwrap_or_default()),
        lane.stepper.divergence_bound,
    )
    .map_err(run::to_py_err)?;
    let spec = BasinSpec {
        lane,
        omega,
        x,
        y,
        base,
        transient,
        periods,
        lanes_per_unit: None,
    };
    let study = BasinStudy {
        refine,
        uncertainty_samples,
        entropy_box,
        ..BasinStudy::new(spec)
    };
    study.validate().map_err(run::to_py_err)?;
    let o = run::detached(py, progress.as_ref().map(|c| &c.0), |ctl| {
        let lane = &study.basin.lane;
        let engine = jeffcott_analysis::backend::Engine::new(lane.backend, lane.precision)?;
        jeffcott_analysis::basin::study::run(&study, &engine, &MemoryHost::new(ctl))
    })?;
    let (spec, res) = (&o.spec, &o.result);
    let (nx, ny) = (spec.x.n, spec.y.n);
    let d = PyDict::new(py);
    d.set_item("labels", array2(py, res.labels.clone(), nx)?)?;
    d.set_item(
        "x",
        array1(py, (0..nx).map(|i| spec.x.value(i)).collect::<Vec<_>>()),
    )?;
    d.set_item(
        "y",
        array1(py, (0..ny).map(|i| spec.y.value(i)).collect::<Vec<_>>()),
    )?;
    // As attractors.json lists them: each with its rub figures.
    d.set_item("attractors", json_to_py(py, &o.attractors())?)?;
    d.set_item("diverged", res.catalogue.diverged)?;
    d.set_item("metrics", json_to_py(py, &o.metrics_record())?)?;
    if let Some(f) = &o.refined {
        d.set_item("refined", array2(py, f.computed.clone(), nx)?)?;
    }
    if let Some(l) = &res.lambda1 {
        d.set_item("lambda1", array2(py, l.clone(), nx)?)?;
    }
    // The specification asked for (the coarse grid), as run.json records it.
    let run = BasinRun {
        backend: res.info.as_ref().map(|i| i.backend),
        device: res.info.as_ref().map(|i| i.device.as_str()),
        precision: spec.lane.precision,
        wall_time_s: res.seconds,
        spec: o.coarse.resolved(),
    };
    d.set_item("run", json_to_py(py, &run)?)?;
    Ok(d)
}

lane_study! {
    /// Basin stability (Menck et al. 2013): the command line's `basin-stability`.
    ///
    /// Returns `omega` `[n]`, `fractions` `[n, ids + 1]` (last column diverged), `ci_low`
    /// and `ci_high` (95 % Wilson intervals) and `summary`, the dictionary of
    /// `basin_stability.json`.
    ///
    /// Parameters:
    /// - `omega`: the rotor speed W [rad/s], or `"a:b:n"` for the fractions against W.
    /// - `start_box`: the box of start coordinates drawn from uniformly,
    ///   `"NAME:lo:hi,..."` over any start coordinates (the others at the static
    ///   equilibrium), e.g. `"x_r:-0.006:0.006,vx_r:-1:1"` (the command line's `--box`).
    /// - `sample`: start states drawn per speed.
    /// - `seed`: the seed of the draws (the same draws at every speed).
    /// - `transient`: forcing periods integrated and discarded per lane.
    /// - `periods`: forcing periods recorded per lane.
    signature = (
        omega, start_box, *, sample=defaults::stability::SAMPLE, seed=defaults::stability::SEED,
        transient=defaults::stability::TRANSIENT, periods=defaults::stability::PERIODS,
    );
    fn basin_stability<'py>(
        py: Python<'py>,
        omega: Bound<'py, PyAny>,
        #[pyo3(from_py_with = kw::start_box)] start_box: String,
        #[pyo3(from_py_with = kw::sample)] sample: u32,
        #[pyo3(from_py_with = kw::seed)] seed: u64,
        #[pyo3(from_py_with = kw::transient)] transient: u32,
        #[pyo3(from_py_with = kw::periods)] periods: u32,
    )
    with (lane: lane, progress: progress)
    {
        use jeffcott_analysis::stability::{StabilityRequest, fractions_with_intervals};
        let omega = match omega.extract::<f64>() {
            Ok(w) => format!("{w:e}"),
            Err(_) => omega.extract::<String>().map_err(|_| {
                pyo3::exceptions::PyTypeError::new_err(format!(
                    "invalid value for `omega`: {} (expected a speed in rad/s or a range \"a:b:n\")",
                    args::shown(&omega)
                ))
            })?,
        };
        let spec = jeffcott_analysis::stability::spec(&StabilityRequest {
            lane,
            omega: &omega,
            sample,
            start_box: &start_box,
            seed,
            transient,
            periods,
        })
        .map_err(run::to_py_err)?;
        let res = run::detached(py, progress.as_ref().map(|c| &c.0), |ctl| {
            jeffcott_analysis::continuation::continuation(&spec, ctl)
        })?;
        let ramp = &res.ramps[0];
        let g = ramp.ids + 1;
        let (f, lo, hi) = fractions_with_intervals(&spec, ramp);
        let d = PyDict::new(py);
        d.set_item("omega", array1(py, res.values.clone()))?;
        d.set_item("fractions", array2(py, f, g)?)?;
        d.set_item("ci_low", array2(py, lo, g)?)?;
        d.set_item("ci_high", array2(py, hi, g)?)?;
        let summary = jeffcott_analysis::stability::summary(&spec, &res);
        d.set_item("summary", json_to_py(py, &summary)?)?;
        Ok(d)
    }
}

/// The basin measures of any 2-D integer label array (`basin_metrics.json` of the
/// command line's `basin`, docs/basin-measures.md): fractions with their errors, basin
/// entropy S_b and boundary basin entropy S_bb (boxes of `entropy_box` cells), the
/// uncertainty exponent and boundary dimension on the grid, the box-counting dimension
/// and the Wada test. Labels are ids >= 0, -1 for diverged (a basin of its own), -2 for
/// a refinement's attractor the coarse catalogue lacks.
///
/// Parameters:
/// - `labels`: a non-empty 2-D integer array-like `[ny, nx]` of any integer dtype.
/// - `entropy_box`: the side of the basin entropy's boxes in cells; None: min(5,
///   shorter side).
#[pyfunction]
#[pyo3(signature = (labels, *, entropy_box=None))]
pub(crate) fn basin_metrics<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = kw::labels)] labels: Labels<'py>,
    #[pyo3(from_py_with = kw::entropy_box)] entropy_box: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let grid = labels.0.as_array();
    let (ny, nx) = grid.dim();
    let flat: Vec<i32> = grid.iter().copied().collect();
    let eps =
        jeffcott_analysis::measures::entropy_box(entropy_box, nx, ny).map_err(run::to_py_err)?;
    let m = py
        .detach(|| jeffcott_analysis::measures::basin_labels_metrics(&flat, nx, ny, eps))
        .map_err(run::to_py_err)?;
    json_to_py(
        py,
        &jeffcott_analysis::measures::MetricsRecord::new(&m, None),
    )
}
