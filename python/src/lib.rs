//! The `jeffcott` Python package (PyO3 + numpy): the library's studies as functions that
//! return numpy arrays and plain dictionaries with the keys of the command line's JSON
//! files. Nothing numerical lives here: every function builds a library specification
//! (the defaults are the library's, `jeffcott_analysis::defaults` and the `DEFAULT`
//! constants of the configuration types), validates it in the library, and runs it with
//! the GIL released (`run::detached`), so a notebook stays responsive, an optional
//! Python callable sees the progress and Ctrl-C stops the run cleanly. Every argument is
//! read by its keyword's reader (`args::kw`, errors naming the keyword and what it
//! accepts), and every request the command line refuses for its size is refused here by
//! the same library check before anything is allocated.

mod args;
mod convert;
mod run;

use args::{Callback, Labels, Table, kw};
use convert::{array1, array2, array3, json_to_py, lane_specs, model_params, start_state};
use jeffcott_analysis::basin::study::BasinStudy;
use jeffcott_analysis::basin::{Axis, BasinSpec};
use jeffcott_analysis::bifurcation::{BifurcationSpec, Sweep};
use jeffcott_analysis::catalogue::CatalogueConfig;
use jeffcott_analysis::classify::ClassifyConfig;
use jeffcott_analysis::defaults;
use jeffcott_analysis::run::MemoryHost;
use jeffcott_analysis::simulate::{Integrator, SimulateSpec};
use jeffcott_core::Error;
use jeffcott_core::ensemble::{Backend, EnsembleSpec, Precision, RangeSpec};
use jeffcott_core::integrate::article::ArticleConfig;
use jeffcott_core::lyapunov::SpectrumConfig;
use jeffcott_core::model::STATE_DIM;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;

/// The backend and precision as the command line resolves them: `precision=None` is
/// f64 on the CPU and f32 on a GPU.
fn backend_precision(backend: &str, precision: Option<&str>) -> PyResult<(Backend, Precision)> {
    let b = Backend::parse("backend", backend).map_err(run::to_py_err)?;
    let p = match precision {
        Some(p) => Precision::parse("precision", p).map_err(run::to_py_err)?,
        None => jeffcott_analysis::backend::default_precision(b),
    };
    Ok((b, p))
}

/// Speeds from a number, a sequence of numbers or the command line's `"a:b:n"`; a range
/// or a sequence is first put to `check` (its text and count: the study's memory check,
/// the command line's), so a huge one is refused before its values (or its lanes) are
/// allocated.
fn speeds(
    field: &str,
    omega: &Bound<'_, PyAny>,
    check: impl Fn(&str, u64) -> jeffcott_core::Result<()>,
) -> PyResult<Vec<f64>> {
    if let Ok(text) = omega.extract::<String>() {
        let r = RangeSpec::parse(field, &text).map_err(run::to_py_err)?;
        check(&text, r.n).map_err(run::to_py_err)?;
        return Ok(r.values());
    }
    if let Ok(w) = omega.extract::<f64>() {
        return Ok(vec![w]);
    }
    let wrong = || {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "invalid value for `{field}`: {} (expected a number, a sequence of numbers or \"a:b:n\")",
            args::shown(omega)
        ))
    };
    let n = omega.len().map_err(|_| wrong())?;
    check(&format!("a sequence of {n} speeds"), n as u64).map_err(run::to_py_err)?;
    omega.extract::<Vec<f64>>().map_err(|_| wrong())
}

/// One trajectory at speed `omega` [rad/s]: the command line's `simulate`.
///
/// Returns the dictionary of `summary.json` (class, period, status, classification,
/// contact, rub figures, start and final state, settings, parameters) with the arrays
/// `poincare` `[periods, 8]`, `timeseries` `[M, 9]` (t, then the state), and, unless the
/// run diverged, `full_spectrum` `[bins, 4]` and `contact_history` `[M, 5]` (the files
/// `full_spectrum.npy` and `contact.npy`) of the stretch of
/// `spectrum_periods` periods continued from the final state.
#[pyfunction]
#[pyo3(signature = (
    omega, *, params=None, init=None,
    transient=defaults::simulate::TRANSIENT, periods=defaults::simulate::PERIODS,
    timeseries_periods=None, integrator="lane",
    spectrum_periods=defaults::simulate::SPECTRUM_PERIODS,
    n_max=ClassifyConfig::DEFAULT.n_max, rel_tol=ClassifyConfig::DEFAULT.rel_tol,
    abs_tol=ClassifyConfig::DEFAULT.abs_tol,
    article_steps=ArticleConfig::DEFAULT.steps_per_period,
    article_alpha=ArticleConfig::DEFAULT.alpha,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
fn simulate<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = kw::omega)] omega: f64,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::init)] init: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::transient)] transient: u32,
    #[pyo3(from_py_with = kw::periods)] periods: u32,
    #[pyo3(from_py_with = kw::timeseries_periods)] timeseries_periods: Option<u32>,
    #[pyo3(from_py_with = kw::integrator)] integrator: &str,
    #[pyo3(from_py_with = kw::spectrum_periods)] spectrum_periods: u32,
    #[pyo3(from_py_with = kw::n_max)] n_max: usize,
    #[pyo3(from_py_with = kw::rel_tol)] rel_tol: f64,
    #[pyo3(from_py_with = kw::abs_tol)] abs_tol: f64,
    #[pyo3(from_py_with = kw::article_steps)] article_steps: u32,
    #[pyo3(from_py_with = kw::article_alpha)] article_alpha: f64,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("simulate", stepper)?;
    let params = model_params(params)?;
    let x0 = start_state(&params, init)?;
    let integrator = match integrator {
        "lane" => Integrator::Lane,
        "article" => Integrator::Article,
        other => {
            return Err(run::to_py_err(Error::invalid(
                "integrator",
                other,
                "must be lane or article",
            )));
        }
    };
    let spec = SimulateSpec {
        params,
        omega,
        x0,
        transient,
        periods,
        timeseries_periods: timeseries_periods
            .unwrap_or(periods.min(defaults::simulate::TIMESERIES_PERIODS)),
        integrator,
        stepper,
        article: ArticleConfig {
            steps_per_period: article_steps,
            alpha: article_alpha,
            ..ArticleConfig::DEFAULT
        },
        classify: ClassifyConfig {
            n_max,
            rel_tol,
            abs_tol,
        },
    };
    spec.validate().map_err(run::to_py_err)?;
    spec.check_size().map_err(run::to_py_err)?;
    spec.check_spectrum_periods(spectrum_periods)
        .map_err(run::to_py_err)?;
    let (res, rub) = run::detached(py, None, |ctl| {
        let res = jeffcott_analysis::simulate::simulate_with(&spec, ctl.cancel)?;
        let rub = if res.status.is_frozen() {
            None
        } else {
            jeffcott_analysis::simulate::rub_outputs(
                &spec.params,
                spec.omega,
                &res.final_state,
                spectrum_periods,
                &spec.stepper,
            )?
        };
        Ok((res, rub))
    })?;
    let summary = jeffcott_analysis::simulate::summary(&spec, &res, rub.as_ref());
    let d = json_to_py(py, &summary)?.cast_into::<PyDict>()?;
    d.set_item(
        "poincare",
        array2(
            py,
            jeffcott_analysis::simulate::poincare_rows(&spec, &res),
            STATE_DIM,
        )?,
    )?;
    d.set_item(
        "timeseries",
        array2(
            py,
            res.timeseries.iter().flatten().copied().collect(),
            STATE_DIM + 1,
        )?,
    )?;
    if let Some(o) = &rub {
        d.set_item(
            "full_spectrum",
            array2(py, o.spectrum_table().into_iter().flatten().collect(), 4)?,
        )?;
        // `contact.npy`; the key `contact` is summary.json's contact counters.
        d.set_item(
            "contact_history",
            array2(py, o.contact.iter().flatten().copied().collect(), 5)?,
        )?;
    }
    Ok(d)
}

/// Many independent lanes: the command line's `ensemble`.
///
/// `omega` is a speed, a sequence of speeds or `"a:b:n"`; or give `lanes`, a 2-D array
/// with one lane per row and `columns` naming its columns (omega, parameter keys, start
/// coordinates, param_set), as `--lanes` with `--columns`. Returns `poincare`
/// `[lanes, periods, 8]` (NaN from the period a lane froze in), `status` (uint32: 0 ok,
/// 1 refinement_cap, 2 diverged, 3 non_finite), `lanes` `[lanes, 10]`, `params`
/// `[sets, 14]`, with `lyapunov=True` `lambda1` `[lanes]`, and `run`, the dictionary of
/// `run.json` (backend, device, precision, counters, status counts, speed).
#[pyfunction]
#[pyo3(signature = (
    omega=None, *, lanes=None, columns=None, params=None, init=None,
    transient=defaults::ensemble::TRANSIENT, periods=defaults::ensemble::PERIODS,
    backend="auto", precision=None, lyapunov=false,
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
fn ensemble<'py>(
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
    let record = jeffcott_analysis::ensemble::run_record(&spec, &totals, &codes, &info);
    let d = PyDict::new(py);
    d.set_item("poincare", array3(py, res.poincare, n, periods as usize)?)?;
    d.set_item("status", array1(py, codes))?;
    d.set_item(
        "lanes",
        array2(
            py,
            jeffcott_analysis::ensemble::lanes_table(&spec),
            2 + STATE_DIM,
        )?,
    )?;
    d.set_item(
        "params",
        array2(
            py,
            jeffcott_core::ensemble::table::params_table(&spec.param_sets),
            jeffcott_core::model::Params::FIELDS.len(),
        )?,
    )?;
    if let Some(l) = res.lambda1 {
        d.set_item("lambda1", array1(py, l))?;
    }
    d.set_item("run", json_to_py(py, &record)?)?;
    Ok(d)
}

/// The `run` dictionary of `basin`: backend, device, precision, wall time and the
/// specification `run.json` records.
#[derive(serde::Serialize)]
struct BasinRun<'a> {
    backend: Option<&'static str>,
    device: Option<&'a str>,
    precision: Precision,
    wall_time_s: f64,
    spec: jeffcott_analysis::basin::SpecRecord<'a>,
}

/// A basin of attraction over two start coordinates at one speed: the command line's
/// `basin`.
///
/// `x` and `y` are `(name, lo, hi, n)` tuples or `"name:lo:hi:n"` strings (e.g.
/// `("x_r", -0.006, 0.006, 80)`); `fix` sets other start coordinates (default: the
/// static equilibrium). Returns `labels` (int32 `[ny, nx]`, attractor ids, -1
/// diverged), `x`, `y` (the axis values), `attractors` (the list of `attractors.json`),
/// `diverged`, with `lyapunov=True` `lambda1` `[ny, nx]`, and `run` (backend, wall time).
#[pyfunction]
#[pyo3(signature = (
    omega, x, y, *, fix=None, params=None,
    transient=defaults::basin::TRANSIENT, periods=defaults::basin::PERIODS,
    backend="auto", precision=None, lyapunov=false,
    refine=0, uncertainty_samples=0, entropy_box=None,
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
fn basin<'py>(
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
    let stepper = args::stepper("basin", stepper)?;
    let (backend, precision) = backend_precision(backend, precision)?;
    let params = model_params(params)?;
    let x = convert::axis("x", &x)?;
    let y = convert::axis("y", &y)?;
    let base = jeffcott_analysis::basin::base_state(
        &params,
        &x,
        &y,
        &convert::sorted_pairs(fix.unwrap_or_default()),
        stepper.divergence_bound,
    )
    .map_err(run::to_py_err)?;
    let spec = BasinSpec {
        params,
        omega,
        x,
        y,
        base,
        transient,
        recorded: periods,
        stepper,
        precision,
        backend,
        catalogue: CatalogueConfig::for_precision(precision),
        chunk: None,
        lyapunov,
    };
    let study = BasinStudy {
        refine,
        uncertainty_samples,
        entropy_box,
        ..BasinStudy::new(spec)
    };
    study.validate().map_err(run::to_py_err)?;
    let o = run::detached(py, progress.as_ref().map(|c| &c.0), |ctl| {
        let engine = jeffcott_analysis::backend::Engine::new(backend, precision)?;
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
        precision: spec.precision,
        wall_time_s: res.seconds,
        spec: o.coarse.record(),
    };
    d.set_item("run", json_to_py(py, &run)?)?;
    Ok(d)
}

/// Quasistatic sweeps up and down in W and a brute-force ensemble per W: the command
/// line's `bifurcation`.
///
/// Returns `omega` `[W]`, `rows` `[rows, 4]` (W, sweep 0 up / 1 down / 2 brute force,
/// lane, attractor id), `points` `[rows, periods, 8]` (each row's Poincare points),
/// `lambda1` `[rows]` and `summary`, the dictionary of `summary.json`.
#[pyfunction]
#[pyo3(signature = (
    omega, *, sweep="both", ics=defaults::bifurcation::ICS, seed=defaults::bifurcation::SEED,
    transient=defaults::bifurcation::TRANSIENT,
    transient_first=defaults::bifurcation::TRANSIENT_FIRST,
    brute_transient=defaults::bifurcation::BRUTE_TRANSIENT,
    periods=defaults::bifurcation::PERIODS, max_seeds=defaults::bifurcation::MAX_SEEDS,
    params=None, backend="auto", precision=None, lyapunov=true,
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
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
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::backend)] backend: &str,
    #[pyo3(from_py_with = kw::precision)] precision: Option<&str>,
    #[pyo3(from_py_with = kw::lyapunov)] lyapunov: bool,
    #[pyo3(from_py_with = kw::progress)] progress: Option<Callback<'py>>,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("bifurcation", stepper)?;
    let (backend, precision) = backend_precision(backend, precision)?;
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
        params: model_params(params)?,
        omegas,
        sweep,
        transient_first,
        transient,
        ics,
        brute_transient,
        recorded: periods,
        seed,
        stepper,
        precision,
        backend,
        catalogue: CatalogueConfig::for_precision(precision),
        max_seeds,
        lyapunov,
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

/// The full Lyapunov spectrum (all 8 exponents, saltation matrices at the contact
/// switches) at one speed: the command line's `lyapunov --omega W`.
///
/// Returns the dictionary of `spectrum.json` (`exponents` [1/s], `errors`, `sum`,
/// `trace_average`, `stop`, ...) and `history` `[periods, 9]` (accumulation time, then
/// the eight running estimates).
#[pyfunction]
#[pyo3(signature = (
    omega, *, params=None, init=None,
    time=SpectrumConfig::DEFAULT.max_time, min_time=None,
    transient=SpectrumConfig::DEFAULT.transient,
    tangent_transient=SpectrumConfig::DEFAULT.tangent_transient,
    tol=SpectrumConfig::DEFAULT.tol, window=SpectrumConfig::DEFAULT.window,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
fn lyapunov<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = kw::omega)] omega: f64,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::init)] init: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::time)] time: f64,
    #[pyo3(from_py_with = kw::min_time)] min_time: Option<f64>,
    #[pyo3(from_py_with = kw::transient)] transient: u32,
    #[pyo3(from_py_with = kw::tangent_transient)] tangent_transient: u32,
    #[pyo3(from_py_with = kw::tol)] tol: f64,
    #[pyo3(from_py_with = kw::window)] window: u32,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("lyapunov", stepper)?;
    let params = model_params(params)?;
    let x0 = start_state(&params, init)?;
    jeffcott_core::inputs::check_start_within_bound("init", &x0, stepper.divergence_bound)
        .map_err(run::to_py_err)?;
    jeffcott_core::model::validate_omega(omega).map_err(run::to_py_err)?;
    let min_time = min_time.unwrap_or(SpectrumConfig::DEFAULT.min_time.min(time));
    if min_time.is_finite() && time.is_finite() && min_time > time {
        return Err(run::to_py_err(Error::invalid(
            "min_time",
            min_time,
            format!("must be at most time ({time} s)"),
        )));
    }
    let cfg = SpectrumConfig {
        transient,
        tangent_transient,
        min_time,
        max_time: time,
        window,
        tol,
        stepper,
        ..SpectrumConfig::DEFAULT
    };
    cfg.validate().map_err(run::to_py_err)?;
    cfg.check_size("time", &time.to_string(), 1, omega)
        .map_err(run::to_py_err)?;
    let s = run::detached(py, None, |ctl| {
        jeffcott_core::lyapunov::spectrum_with(&params, omega, &x0, &cfg, ctl.cancel)
    })?;
    let d = json_to_py(py, &s.record())?.cast_into::<PyDict>()?;
    let history: Vec<f64> = s
        .history
        .iter()
        .flat_map(|(t, e)| std::iter::once(*t).chain(e.iter().copied()))
        .collect();
    d.set_item("history", array2(py, history, STATE_DIM + 1)?)?;
    Ok(d)
}

/// A two-parameter map (design chart): the command line's `map`.
///
/// `x` and `y` are `(name, lo, hi, n)` tuples or `"name:lo:hi:n"` strings over `omega`,
/// any model parameter or start coordinate (geometric spacing with `log_x`/`log_y`);
/// `omega` is the speed of every cell unless an axis is `omega`. Returns `period`,
/// `class`, `attractors`, `regime` (int32 `[ny, nx]`), `lambda1`, `contact`,
/// `peak_force` (f64 `[ny, nx]`), `x`, `y` (the axis values) and `summary`, the
/// dictionary of `map.json` (every cell's attractors under `cell_attractors`).
#[pyfunction]
#[pyo3(signature = (
    x, y, *, omega=None, ics=defaults::map::ICS, seed=defaults::map::SEED,
    transient=defaults::map::TRANSIENT, periods=defaults::map::PERIODS,
    log_x=false, log_y=false, params=None, backend="auto", precision=None, lyapunov=true,
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
fn map<'py>(
    py: Python<'py>,
    x: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
    #[pyo3(from_py_with = kw::omega)] omega: Option<f64>,
    #[pyo3(from_py_with = kw::ics)] ics: u32,
    #[pyo3(from_py_with = kw::seed)] seed: u64,
    #[pyo3(from_py_with = kw::transient)] transient: u32,
    #[pyo3(from_py_with = kw::periods)] periods: u32,
    #[pyo3(from_py_with = kw::log_x)] log_x: bool,
    #[pyo3(from_py_with = kw::log_y)] log_y: bool,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::backend)] backend: &str,
    #[pyo3(from_py_with = kw::precision)] precision: Option<&str>,
    #[pyo3(from_py_with = kw::lyapunov)] lyapunov: bool,
    #[pyo3(from_py_with = kw::progress)] progress: Option<Callback<'py>>,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("map", stepper)?;
    use jeffcott_analysis::map::MapSpec;
    let (backend, precision) = backend_precision(backend, precision)?;
    let x = convert::map_axis("x", &x, log_x)?;
    let y = convert::map_axis("y", &y, log_y)?;
    jeffcott_analysis::map::check_size(&x, &y, ics).map_err(run::to_py_err)?;
    let spec = MapSpec {
        params: model_params(params)?,
        omega,
        x,
        y,
        ics,
        seed,
        transient,
        recorded: periods,
        stepper,
        precision,
        backend,
        catalogue: CatalogueConfig::for_precision(precision),
        lyapunov,
        chunk: None,
    };
    spec.validate().map_err(run::to_py_err)?;
    let res = run::detached(py, progress.as_ref().map(|c| &c.0), |ctl| {
        jeffcott_analysis::map::map(&spec, ctl)
    })?;
    let summary = json_to_py(py, &jeffcott_analysis::map::summary(&spec, &res))?;
    let nx = spec.x.n;
    let d = PyDict::new(py);
    d.set_item("period", array2(py, res.period, nx)?)?;
    d.set_item("class", array2(py, res.class, nx)?)?;
    d.set_item("lambda1", array2(py, res.lambda1, nx)?)?;
    d.set_item("attractors", array2(py, res.attractors, nx)?)?;
    d.set_item("contact", array2(py, res.contact, nx)?)?;
    d.set_item("peak_force", array2(py, res.peak_force, nx)?)?;
    d.set_item("regime", array2(py, res.regime, nx)?)?;
    d.set_item("x", array1(py, spec.x.values()))?;
    d.set_item("y", array1(py, spec.y.values()))?;
    d.set_item("summary", summary)?;
    Ok(d)
}

/// Attractors followed over a parameter, run-up and run-down: the command line's
/// `continuation` (Attractors.jl's seeded find-and-match).
///
/// `param` is `(name, lo, hi, n)` or `"name:lo:hi:n"` over `omega` or a model parameter;
/// `start_box` (the CLI's `--box`), e.g. `"x_r:-0.006:0.006,vx_r:-1:1"`, draws the fresh
/// start states uniformly in a box. Returns `values` `[n]` and per ramp (`up`, `down`)
/// `fractions_<dir>` `[n, ids + 1]` (last column diverged), `fraction_errors_<dir>` and
/// `tipping_<dir>` `[n - 1, ids + 1, ids + 1]`, and `summary`, the dictionary of
/// `continuation.json`.
#[pyfunction]
#[pyo3(signature = (
    param, *, omega=None, ics=defaults::continuation::ICS, start_box=None,
    seed=defaults::continuation::SEED, direction="both", match_threshold=None,
    transient=defaults::continuation::TRANSIENT, periods=defaults::continuation::PERIODS,
    params=None, backend="auto", precision=None, lyapunov=true,
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
fn continuation<'py>(
    py: Python<'py>,
    param: Bound<'py, PyAny>,
    #[pyo3(from_py_with = kw::omega)] omega: Option<f64>,
    #[pyo3(from_py_with = kw::ics)] ics: u32,
    #[pyo3(from_py_with = kw::start_box)] start_box: Option<String>,
    #[pyo3(from_py_with = kw::seed)] seed: u64,
    #[pyo3(from_py_with = kw::direction)] direction: &str,
    #[pyo3(from_py_with = kw::match_threshold)] match_threshold: Option<f64>,
    #[pyo3(from_py_with = kw::transient)] transient: u32,
    #[pyo3(from_py_with = kw::periods)] periods: u32,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::backend)] backend: &str,
    #[pyo3(from_py_with = kw::precision)] precision: Option<&str>,
    #[pyo3(from_py_with = kw::lyapunov)] lyapunov: bool,
    #[pyo3(from_py_with = kw::progress)] progress: Option<Callback<'py>>,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("continuation", stepper)?;
    use jeffcott_analysis::continuation::ContinuationSpec;
    let (backend, precision) = backend_precision(backend, precision)?;
    let directions =
        jeffcott_analysis::continuation::directions(direction).map_err(run::to_py_err)?;
    let param = convert::map_axis("param", &param, false)?;
    if param.n < 2 {
        return Err(run::to_py_err(Error::invalid(
            "param",
            param.n,
            "a continuation needs at least 2 values",
        )));
    }
    let spec = ContinuationSpec {
        params: model_params(params)?,
        omega,
        param,
        ics,
        start_box: start_box
            .as_deref()
            .map(|b| jeffcott_analysis::continuation::parse_box("start_box", b))
            .transpose()
            .map_err(run::to_py_err)?,
        seed,
        transient,
        recorded: periods,
        stepper,
        precision,
        backend,
        catalogue: CatalogueConfig::for_precision(precision),
        lyapunov,
        directions,
        match_threshold: match_threshold.unwrap_or(f64::INFINITY),
    };
    spec.validate().map_err(run::to_py_err)?;
    let res = run::detached(py, progress.as_ref().map(|c| &c.0), |ctl| {
        jeffcott_analysis::continuation::continuation(&spec, ctl)
    })?;
    let summary = jeffcott_analysis::continuation::summary(&spec, &res);
    let n = res.values.len();
    let d = PyDict::new(py);
    d.set_item("values", array1(py, res.values.clone()))?;
    for r in &res.ramps {
        let name = r.direction.name();
        let g = r.ids + 1;
        let (f, e) = r.fractions();
        d.set_item(format!("fractions_{name}"), array2(py, f, g)?)?;
        d.set_item(format!("fraction_errors_{name}"), array2(py, e, g)?)?;
        let t = convert::array_nd(py, r.tipping(), &[n - 1, g, g])?;
        d.set_item(format!("tipping_{name}"), t)?;
    }
    d.set_item("summary", json_to_py(py, &summary)?)?;
    Ok(d)
}

/// Basin stability (Menck et al. 2013): the command line's `basin-stability`.
///
/// `omega` is a speed or `"a:b:n"`; `start_box` the box of start coordinates drawn
/// from uniformly, e.g. `"x_r:-0.006:0.006,vx_r:-1:1"`. Returns `omega` `[n]`,
/// `fractions` `[n, ids + 1]` (last column diverged), `ci_low` and `ci_high` (95 %
/// Wilson intervals) and `summary`, the dictionary of `basin_stability.json`.
#[pyfunction]
#[pyo3(signature = (
    omega, start_box, *, sample=defaults::stability::SAMPLE, seed=defaults::stability::SEED,
    transient=defaults::stability::TRANSIENT, periods=defaults::stability::PERIODS,
    params=None, backend="auto", precision=None, lyapunov=true,
    progress=None,
    **stepper,
))]
#[allow(clippy::too_many_arguments)]
fn basin_stability<'py>(
    py: Python<'py>,
    omega: Bound<'py, PyAny>,
    #[pyo3(from_py_with = kw::start_box)] start_box: String,
    #[pyo3(from_py_with = kw::sample)] sample: u32,
    #[pyo3(from_py_with = kw::seed)] seed: u64,
    #[pyo3(from_py_with = kw::transient)] transient: u32,
    #[pyo3(from_py_with = kw::periods)] periods: u32,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
    #[pyo3(from_py_with = kw::backend)] backend: &str,
    #[pyo3(from_py_with = kw::precision)] precision: Option<&str>,
    #[pyo3(from_py_with = kw::lyapunov)] lyapunov: bool,
    #[pyo3(from_py_with = kw::progress)] progress: Option<Callback<'py>>,
    stepper: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let stepper = args::stepper("basin_stability", stepper)?;
    use jeffcott_analysis::stability::{StabilityRequest, fractions_with_intervals};
    let (backend, precision) = backend_precision(backend, precision)?;
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
        params: model_params(params)?,
        omega: &omega,
        sample,
        start_box: &start_box,
        seed,
        transient,
        recorded: periods,
        stepper,
        precision,
        backend,
        catalogue: CatalogueConfig::for_precision(precision),
        lyapunov,
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

/// Full-spectrum cascade of a quasistatic run-up and run-down: the command line's
/// `cascade` (docs/rub.md).
///
/// `omega` is `"a:b:n"` (n >= 2 speeds); `direction` is `"up"`, `"down"` or `"both"`.
/// Returns `omega` `[n]` (ascending), `orders` `[bins]` (frequency / W, < 0 backward
/// whirl), `cascade` and `cascade_stator` (f64 `[sweeps, n, bins]`, full-spectrum
/// amplitudes [m], NaN after a divergence), `regime` (int32 `[sweeps, n]`: 0 no_contact,
/// 1 partial_rub, 2 full_annular_rub, 3 backward_whirl, -1 diverged) and `summary`, the
/// dictionary of `cascade.json` (its `sweeps` name the blocks). Progress counts speeds.
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
fn cascade<'py>(
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

/// The basin measures of any 2-D integer label array (`basin_metrics.json` of the
/// command line's `basin`, docs/basin-measures.md): fractions with their errors, basin
/// entropy S_b and boundary basin entropy S_bb (boxes of `entropy_box` cells, default
/// min(5, shorter side)), the uncertainty exponent and boundary dimension on the grid,
/// the box-counting dimension and the Wada test. Labels are ids >= 0, -1 for diverged
/// (a basin of its own), -2 for a refinement's attractor the coarse catalogue lacks.
#[pyfunction]
#[pyo3(signature = (labels, *, entropy_box=None))]
fn basin_metrics<'py>(
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

/// The model's parameters (Table 1 of the article, SI units) with `params` applied, as
/// a dictionary keyed like the TOML file; raises ValueError naming a bad key or value.
#[pyfunction]
#[pyo3(signature = (params=None))]
fn parameters<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = kw::params)] params: Option<HashMap<String, f64>>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = model_params(params)?;
    json_to_py(py, &p)
}

/// The GPU adapters wgpu finds (name, backend, device type, software, f64 support,
/// limits), as `jeffcott info` lists them.
#[pyfunction]
fn adapters<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
    let list = py.detach(jeffcott_gpu::list_adapters);
    json_to_py(py, &list)
}

#[pymodule]
fn _jeffcott(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("COORD_NAMES", jeffcott_core::model::COORD_NAMES.to_vec())?;
    m.add("PARAM_KEYS", jeffcott_core::model::Params::FIELDS.to_vec())?;
    // The `**stepper` keywords of the integrating functions and their defaults.
    let stepper = PyDict::new(m.py());
    for (name, default) in args::stepper_defaults() {
        stepper.set_item(name, default)?;
    }
    m.add("STEPPER_DEFAULTS", stepper)?;
    // Every default the keywords take, by study (`analysis::defaults`) and by
    // configuration (`stepper`, `classify`, `article`, `spectrum`): what the type stub
    // is checked against (tests/test_stub.py).
    let all = PyDict::new(m.py());
    for (study, name, value) in defaults::table() {
        let group = match all.get_item(study)? {
            Some(g) => g,
            None => {
                let g = PyDict::new(m.py()).into_any();
                all.set_item(study, &g)?;
                g
            }
        };
        group.set_item(name, json_to_py(m.py(), &value)?)?;
    }
    all.set_item("stepper", m.getattr("STEPPER_DEFAULTS")?)?;
    all.set_item("classify", json_to_py(m.py(), &ClassifyConfig::DEFAULT)?)?;
    all.set_item("article", json_to_py(m.py(), &ArticleConfig::DEFAULT)?)?;
    all.set_item("spectrum", json_to_py(m.py(), &SpectrumConfig::DEFAULT)?)?;
    m.add("DEFAULTS", all)?;
    m.add(
        "LANES_COLUMNS",
        jeffcott_core::ensemble::lane_table_columns(),
    )?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble, m)?)?;
    m.add_function(wrap_pyfunction!(basin, m)?)?;
    m.add_function(wrap_pyfunction!(bifurcation, m)?)?;
    m.add_function(wrap_pyfunction!(lyapunov, m)?)?;
    m.add_function(wrap_pyfunction!(map, m)?)?;
    m.add_function(wrap_pyfunction!(continuation, m)?)?;
    m.add_function(wrap_pyfunction!(basin_stability, m)?)?;
    m.add_function(wrap_pyfunction!(cascade, m)?)?;
    m.add_function(wrap_pyfunction!(basin_metrics, m)?)?;
    m.add_function(wrap_pyfunction!(parameters, m)?)?;
    m.add_function(wrap_pyfunction!(adapters, m)?)?;
    Ok(())
}

/// Parses an axis given as `"name:lo:hi:n"` (the command line's syntax).
fn parse_axis(field: &str, text: &str) -> PyResult<Axis> {
    Axis::parse(field, text).map_err(run::to_py_err)
}
