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

#[macro_use]
mod docs;
mod args;
mod convert;
mod run;
mod studies;

use args::kw;
use convert::{json_to_py, model_params};
use jeffcott_analysis::basin::Axis;
use jeffcott_analysis::classify::ClassifyConfig;
use jeffcott_analysis::defaults;
use jeffcott_core::ensemble::{Backend, Precision, RangeSpec};
use jeffcott_core::integrate::article::ArticleConfig;
use jeffcott_core::lyapunov::SpectrumConfig;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;

/// The backend and precision as the command line resolves them: `precision=None` is
/// f64 on the CPU and f32 on a GPU.
pub(crate) fn backend_precision(
    backend: &str,
    precision: Option<&str>,
) -> PyResult<(Backend, Precision)> {
    let b = Backend::parse("backend", backend).map_err(run::to_py_err)?;
    let p = match precision {
        Some(p) => Precision::parse("precision", p).map_err(run::to_py_err)?,
        None => jeffcott_analysis::backend::default_precision(b),
    };
    Ok((b, p))
}

/// A study's lane settings from its keywords: `params`, `backend`, `precision`,
/// `lyapunov` and the stepper keywords of `function` (read first, so an unknown keyword
/// is named before anything else); the tolerances follow the precision.
pub(crate) fn lane_settings(
    function: &str,
    params: Option<HashMap<String, f64>>,
    backend: &str,
    precision: Option<&str>,
    lyapunov: bool,
    stepper: Option<&Bound<'_, PyDict>>,
) -> PyResult<jeffcott_analysis::settings::LaneSettings> {
    let stepper = args::stepper(function, stepper)?;
    let (backend, precision) = backend_precision(backend, precision)?;
    Ok(jeffcott_analysis::settings::LaneSettings {
        params: convert::model_params(params)?,
        stepper,
        precision,
        backend,
        catalogue: jeffcott_analysis::catalogue::CatalogueConfig::for_precision(precision),
        lyapunov,
    })
}

/// Speeds from a number, a sequence of numbers or the command line's `"a:b:n"`; a range
/// or a sequence is first put to `check` (its text and count: the study's memory check,
/// the command line's), so a huge one is refused before its values (or its lanes) are
/// allocated.
pub(crate) fn speeds(
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

/// The model's parameters (Table 1 of the article, SI units) with `params` applied, as
/// a dictionary keyed like the TOML file; raises ValueError naming a bad key or value.
///
/// Parameters:
#[doc = param_doc!(params)]
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
    m.add(
        "PARAM_KEYS",
        jeffcott_core::model::Params::names().collect::<Vec<_>>(),
    )?;
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
    m.add_function(wrap_pyfunction!(studies::trajectory::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(studies::lanes::ensemble, m)?)?;
    m.add_function(wrap_pyfunction!(studies::basins::basin, m)?)?;
    m.add_function(wrap_pyfunction!(studies::lanes::bifurcation, m)?)?;
    m.add_function(wrap_pyfunction!(studies::trajectory::lyapunov, m)?)?;
    m.add_function(wrap_pyfunction!(studies::orbits::orbits, m)?)?;
    m.add_function(wrap_pyfunction!(studies::maps::map, m)?)?;
    m.add_function(wrap_pyfunction!(studies::maps::continuation, m)?)?;
    m.add_function(wrap_pyfunction!(studies::basins::basin_stability, m)?)?;
    m.add_function(wrap_pyfunction!(studies::lanes::cascade, m)?)?;
    m.add_function(wrap_pyfunction!(studies::basins::basin_metrics, m)?)?;
    m.add_function(wrap_pyfunction!(parameters, m)?)?;
    m.add_function(wrap_pyfunction!(adapters, m)?)?;
    Ok(())
}

/// Parses an axis given as `"name:lo:hi:n"` (the command line's syntax).
pub(crate) fn parse_axis(field: &str, text: &str) -> PyResult<Axis> {
    Axis::parse(field, text).map_err(run::to_py_err)
}
