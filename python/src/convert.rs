//! Python values to library inputs and library outputs to Python values: parameter and
//! start-state dictionaries, axes, lane tables, JSON values as plain dictionaries, and
//! flat vectors as numpy arrays of the command line's `.npy` shapes.

use crate::run::to_py_err;
use jeffcott_analysis::basin::Axis;
use jeffcott_analysis::map::MapAxis;
use jeffcott_core::Error;
use jeffcott_core::ensemble::LaneSpec;
use jeffcott_core::ensemble::table::{LaneTable, TableDefaults, lanes_from_table};
use jeffcott_core::model::{Params, State};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use std::collections::HashMap;

/// Dictionary items in name order (so errors and results do not depend on hashing).
pub fn sorted_pairs(d: HashMap<String, f64>) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = d.into_iter().collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

/// Table 1 with the overrides of `params` (TOML keys), validated.
pub fn model_params(params: Option<HashMap<String, f64>>) -> PyResult<Params> {
    jeffcott_core::inputs::params_with(&sorted_pairs(params.unwrap_or_default())).map_err(to_py_err)
}

/// The model of `params` ([`model_params`]) and its static equilibrium with the
/// coordinates of `init` set: a single trajectory's start.
pub fn model_and_start(
    params: Option<HashMap<String, f64>>,
    init: Option<HashMap<String, f64>>,
) -> PyResult<(Params, State)> {
    let p = model_params(params)?;
    let mut x0 = p.static_equilibrium();
    jeffcott_core::inputs::set_coords("init", &mut x0, &sorted_pairs(init.unwrap_or_default()))
        .map_err(to_py_err)?;
    Ok((p, x0))
}

/// An axis from `(name, lo, hi, n)` or `"name:lo:hi:n"`.
pub fn axis(field: &str, v: &Bound<'_, PyAny>) -> PyResult<Axis> {
    if let Ok(text) = v.extract::<String>() {
        return crate::parse_axis(field, &text);
    }
    let (name, lo, hi, n): (String, f64, f64, usize) = v.extract().map_err(|_| {
        pyo3::exceptions::PyValueError::new_err(format!(
            "invalid value for `{field}`: {} (expected (name, lo, hi, n) or \"name:lo:hi:n\", e.g. (\"x_r\", -0.006, 0.006, 80))",
            crate::args::shown(v)
        ))
    })?;
    let coord = jeffcott_core::inputs::coord(field, &name).map_err(to_py_err)?;
    let a = Axis { coord, lo, hi, n };
    a.validate(field).map_err(to_py_err)?;
    Ok(a)
}

/// A map or continuation axis from `(name, lo, hi, n)` or `"name:lo:hi:n"` (omega, a
/// model parameter or a start coordinate), geometric with `log`.
pub fn map_axis(field: &str, v: &Bound<'_, PyAny>, log: bool) -> PyResult<MapAxis> {
    let text = match v.extract::<String>() {
        Ok(t) => t,
        Err(_) => {
            let (name, lo, hi, n): (String, f64, f64, usize) = v.extract().map_err(|_| {
                pyo3::exceptions::PyValueError::new_err(format!(
                    "invalid value for `{field}`: {} (expected (name, lo, hi, n) or \"name:lo:hi:n\", e.g. (\"omega\", 120, 150, 60))",
                    crate::args::shown(v)
                ))
            })?;
            // `{:e}` is the shortest text that parses back to the same f64.
            format!("{name}:{lo:e}:{hi:e}:{n}")
        }
    };
    MapAxis::parse(field, &text, log).map_err(to_py_err)
}

/// The lanes of an ensemble: one per speed from the start state, or one per row of a
/// lane table (the command line's `--lanes` rules: every value checked, errors name the
/// row and the column).
pub fn lane_specs(
    params: &Params,
    omegas: Option<Vec<f64>>,
    lanes: Option<PyReadonlyArray2<'_, f64>>,
    columns: Option<Vec<String>>,
    init: Option<HashMap<String, f64>>,
    overridden: &[String],
    divergence_bound: f64,
) -> PyResult<(Vec<Params>, Vec<LaneSpec>)> {
    let init = sorted_pairs(init.unwrap_or_default());
    if let Some(table) = lanes {
        let columns = columns.ok_or_else(|| {
            to_py_err(Error::invalid(
                "columns",
                "None",
                "a lanes array needs columns naming its columns, e.g. [\"omega\", \"x_r\"]",
            ))
        })?;
        let a = table.as_array();
        if a.ncols() != columns.len() {
            return Err(to_py_err(Error::invalid(
                "columns",
                columns.join(","),
                format!("the lanes array has {} columns", a.ncols()),
            )));
        }
        let t = LaneTable {
            columns,
            rows: a.rows().into_iter().map(|r| r.to_vec()).collect(),
        };
        t.refuse_set_by("init", init.iter().map(|(n, _)| n.as_str()))
            .and_then(|_| t.refuse_set_by("params", overridden.iter().map(String::as_str)))
            .map_err(to_py_err)?;
        let omega = match omegas.as_deref() {
            None => None,
            Some([w]) => Some(*w),
            Some(_) => {
                return Err(to_py_err(Error::invalid(
                    "omega",
                    "a range",
                    "with lanes give one speed (for lanes without an omega column), not a range",
                )));
            }
        };
        let set_init = |x: &mut State| jeffcott_core::inputs::set_coords("init", x, &init);
        return lanes_from_table(
            &t,
            &TableDefaults {
                params,
                param_sets: &[],
                omega,
                init: &set_init,
                divergence_bound,
            },
        )
        .map_err(to_py_err);
    }
    let omegas = omegas.ok_or_else(|| {
        to_py_err(Error::invalid(
            "omega",
            "None",
            "give the speeds (a number, a sequence or \"a:b:n\") or a lanes table",
        ))
    })?;
    let mut x0 = params.static_equilibrium();
    jeffcott_core::inputs::set_coords("init", &mut x0, &init).map_err(to_py_err)?;
    jeffcott_core::inputs::check_start_within_bound("init", &x0, divergence_bound)
        .map_err(to_py_err)?;
    Ok((vec![params.clone()], LaneSpec::at_speeds(&omegas, x0)))
}

/// A record (any `Serialize` value: the library's typed records, parameters) as Python
/// objects (dict, list, float, int, str, bool, None), through [`serde_json::Value`] (keys
/// sorted, as the files write them) and Python's own `json` module, so numbers and key
/// order are exactly the file's.
pub fn json_to_py<'py, T: serde::Serialize>(py: Python<'py>, v: &T) -> PyResult<Bound<'py, PyAny>> {
    let err = |e: serde_json::Error| pyo3::exceptions::PyRuntimeError::new_err(e.to_string());
    let text = serde_json::to_string(&serde_json::to_value(v).map_err(err)?).map_err(err)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A 1-D array.
pub fn array1<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, v)
}

/// A 2-D array of `cols` columns from row-major data.
pub fn array2<'py, T: numpy::Element>(
    py: Python<'py>,
    v: Vec<T>,
    cols: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let rows = v.len().checked_div(cols).unwrap_or(0);
    Ok(PyArray1::from_vec(py, v).reshape([rows, cols])?.into_any())
}

/// A `[a, b, 8]` array from row-major data.
pub fn array3<'py>(
    py: Python<'py>,
    v: Vec<f64>,
    a: usize,
    b: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let c = jeffcott_core::model::STATE_DIM;
    Ok(PyArray1::from_vec(py, v).reshape([a, b, c])?.into_any())
}

/// An array of any `shape` from row-major data.
pub fn array_nd<'py>(py: Python<'py>, v: Vec<f64>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, v)
        .reshape(shape.to_vec())?
        .into_any())
}
