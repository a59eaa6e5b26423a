//! Studies over parameters: the two-parameter `map` and `continuation`.

use crate::args::kw;
use crate::convert::{self, array1, array2, json_to_py};
use crate::run;
use jeffcott_analysis::defaults;
use jeffcott_core::Error;
use pyo3::prelude::*;
use pyo3::types::PyDict;

lane_study! {
    /// A two-parameter map (design chart): the command line's `map`.
    ///
    /// Returns `period`, `class`, `attractors`, `regime` (int32 `[ny, nx]`), `lambda1`,
    /// `contact`, `peak_force` (f64 `[ny, nx]`), `x`, `y` (the axis values) and `summary`,
    /// the dictionary of `map.json` (every cell's attractors under `cell_attractors`).
    ///
    /// Parameters:
    /// - `x`, `y`: the horizontal and vertical axes, `(name, lo, hi, n)` tuples or
    ///   `"name:lo:hi:n"` strings (n values from lo to hi inclusive) over `omega`, any
    ///   model parameter or start coordinate, e.g. `"omega:130:141:200"`.
    /// - `omega`: the rotor speed W of every cell when neither axis is omega [rad/s].
    /// - `ics`: start states per cell: the static equilibrium of the cell's parameters
    ///   and `ics` - 1 seeded ones (the same draws in every cell); 1 is the classical
    ///   diagram from the static equilibrium.
    /// - `seed`: the seed of the start states.
    /// - `transient`: forcing periods integrated and discarded.
    /// - `periods`: forcing periods recorded per lane (at least 2 n to see period n).
    /// - `log_x`, `log_y`: space the x or y values geometrically (lo > 0).
    signature = (
        x, y, *, omega=None, ics=defaults::map::ICS, seed=defaults::map::SEED,
        transient=defaults::map::TRANSIENT, periods=defaults::map::PERIODS,
        log_x=false, log_y=false,
    );
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
    )
    with (lane: lane, progress: progress, overridden: overridden)
    {
        use jeffcott_analysis::map::MapSpec;
        let x = convert::map_axis("x", &x, log_x)?;
        let y = convert::map_axis("y", &y, log_y)?;
        for (axis, a) in [("x", &x), ("y", &y)] {
            (a.var).check_not_overridden(axis, "params", &overridden).map_err(run::to_py_err)?;
        }
        jeffcott_analysis::map::check_size(&x, &y, ics).map_err(run::to_py_err)?;
        let spec = MapSpec {
            lane,
            omega,
            x,
            y,
            ics,
            seed,
            transient,
            periods,
            cells_per_unit: None,
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
}

lane_study! {
    /// Attractors followed over a parameter, run-up and run-down: the command line's
    /// `continuation` (Attractors.jl's seeded find-and-match).
    ///
    /// Returns `values` `[n]` and per ramp (`up`, `down`) `fractions_<dir>`
    /// `[n, ids + 1]` (last column diverged), `fraction_errors_<dir>` and `tipping_<dir>`
    /// `[n - 1, ids + 1, ids + 1]`, and `summary`, the dictionary of `continuation.json`.
    ///
    /// Parameters:
    /// - `param`: the continued parameter, `(name, lo, hi, n)` or `"name:lo:hi:n"` over
    ///   `omega` or a model parameter (n >= 2 values from lo to hi inclusive).
    /// - `omega`: the rotor speed W when the parameter is not omega [rad/s].
    /// - `ics`: fresh start states per value (the static equilibrium plus seeded draws,
    ///   the same at every value): they give the basin fractions and tipping
    ///   probabilities.
    /// - `start_box`: draw the fresh start states uniformly in a box of start coordinates
    ///   instead, e.g. `"x_r:-0.006:0.006,vx_r:-1:1"` (the command line's `--box`): the
    ///   fractions are then the basin stability of that box.
    /// - `seed`: the seed of the start states.
    /// - `direction`: `"up"` (run-up), `"down"` (run-down) or `"both"`.
    /// - `match_threshold`: the largest Poincare-set distance at which attractors of
    ///   consecutive values are one attractor [m; velocities count divided by W]; None:
    ///   no limit, always the nearest.
    /// - `transient`: forcing periods integrated and discarded per lane.
    /// - `periods`: forcing periods recorded per lane.
    signature = (
        param, *, omega=None, ics=defaults::continuation::ICS, start_box=None,
        seed=defaults::continuation::SEED, direction="both", match_threshold=None,
        transient=defaults::continuation::TRANSIENT, periods=defaults::continuation::PERIODS,
    );
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
    )
    with (lane: lane, progress: progress, overridden: overridden)
    {
        use jeffcott_analysis::continuation::ContinuationSpec;
        let directions =
            jeffcott_analysis::continuation::directions(direction).map_err(run::to_py_err)?;
        let param = convert::map_axis("param", &param, false)?;
        (param.var).check_not_overridden("param", "params", &overridden).map_err(run::to_py_err)?;
        if param.n < 2 {
            return Err(run::to_py_err(Error::invalid(
                "param",
                param.n,
                "a continuation needs at least 2 values",
            )));
        }
        let spec = ContinuationSpec {
            lane,
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
            periods,
            directions,
            match_threshold: match_threshold.unwrap_or(f64::INFINITY),
            values_per_unit: None,
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
}
