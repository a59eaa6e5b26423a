//! One trajectory and its Lyapunov spectrum: `simulate` and `lyapunov`.

use crate::args::{self, kw};
use crate::convert::{array2, json_to_py, model_and_start};
use crate::run;
use jeffcott_analysis::classify::ClassifyConfig;
use jeffcott_analysis::defaults;
use jeffcott_analysis::lyapunov::{LyapunovOutcome, LyapunovStudy, SpectrumOptions};
use jeffcott_analysis::run::MemoryHost;
use jeffcott_analysis::simulate::{Integrator, SimulateOutcome, SimulateSpec, SimulateStudy};
use jeffcott_core::Error;
use jeffcott_core::ensemble::RangeSpec;
use jeffcott_core::integrate::article::ArticleConfig;
use jeffcott_core::lyapunov::{SpectrumConfig, SweepStart};
use jeffcott_core::model::STATE_DIM;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;

/// One trajectory at speed `omega` [rad/s]: the command line's `simulate`.
///
/// Returns the dictionary of `summary.json` (class, period, status, classification,
/// contact, rub figures, start and final state, settings, parameters) with the arrays
/// `poincare` `[periods, 8]`, `timeseries` `[M, 9]` (t, then the state), and, unless the
/// run diverged, `full_spectrum` `[bins, 4]` and `contact_history` `[M, 5]` (the files
/// `full_spectrum.npy` and `contact.npy`) of the stretch of
/// `spectrum_periods` periods continued from the final state.
///
/// Parameters:
/// - `omega`: the rotor speed W [rad/s]; the article's interesting range is 130..141.
#[doc = param_doc!(params, init)]
/// - `transient`: forcing periods T = 2 pi / W integrated and discarded before the
///   record.
/// - `periods`: forcing periods recorded, one Poincare point each (at least 2 n for
///   period n to be detectable).
/// - `timeseries_periods`: the last recorded periods returned in `timeseries`; None:
///   min(8, `periods`).
/// - `integrator`: `"lane"` (the ensemble lane stepper, crossing-located RK4) or
///   `"article"` (the article's variable-step RK4, a cross-check; slower).
/// - `spectrum_periods`: forcing periods of the stretch, continued from the final
///   state, that the rub figures, full spectrum and contact history are taken over (a
///   multiple of 6 puts the 1/2X, 1/3X and 2/3X lines on bins).
/// - `n_max`: the largest period the classifier looks for.
/// - `rel_tol`: the classifier's repeat tolerance relative to the Poincare set's size.
/// - `abs_tol`: the classifier's repeat tolerance floor [m].
/// - `article_steps`: standard steps per period of the article's scheme (with
///   `integrator="article"`).
/// - `article_alpha`: exponent alpha of the article scheme's step reduction
///   dt (E_max/E)^alpha.
#[doc = param_doc!(stepper)]
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
pub(crate) fn simulate<'py>(
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
    let (params, x0) = model_and_start(params, init)?;
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
    let study = SimulateStudy {
        spec,
        spectrum_periods,
    };
    study.validate().map_err(run::to_py_err)?;
    let SimulateOutcome { result: res, rub } = run::detached(py, None, |ctl| {
        jeffcott_analysis::simulate::run_study(&study, ctl.cancel)
    })?;
    let spec = study.spec;
    let summary = jeffcott_analysis::simulate::summary(&spec, &res, rub.as_ref());
    let d = json_to_py(py, &summary)?.cast_into::<PyDict>()?;
    d.set_item("wall_time_s", res.elapsed.as_secs_f64())?;
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

/// The full Lyapunov spectrum (all 8 exponents, saltation matrices at the contact
/// switches) at one speed: the command line's `lyapunov --omega W`.
///
/// Returns the dictionary of `spectrum.json` (`exponents` [1/s], `errors`, `sum`,
/// `trace_average`, `stop`, ...) and `history` `[periods, 9]` (accumulation time, then
/// the eight running estimates).
///
/// Parameters:
/// - `omega`: the rotor speed W [rad/s].
#[doc = param_doc!(params, init)]
/// - `time`: the largest accumulation time [s] (the stopping rule's maximum).
/// - `min_time`: accumulation time before the stopping rule may stop [s], at most
///   `time`; None: 20 s, or `time` if that is shorter.
/// - `transient`: forcing periods of the state alone before the tangent vectors start.
/// - `tangent_transient`: forcing periods in which the tangent vectors align, not
///   accumulated.
/// - `tol`: stop when no exponent changed by more than this over the last `window`
///   [1/s].
/// - `window`: the stopping rule's window [forcing periods].
#[doc = param_doc!(stepper)]
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
pub(crate) fn lyapunov<'py>(
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
    let (params, x0) = model_and_start(params, init)?;
    let config = SpectrumOptions {
        transient,
        tangent_transient,
        max_time: time,
        min_time,
        tol,
        window,
        saltation: true,
        stepper,
    }
    .config()
    .map_err(run::to_py_err)?;
    // One speed; its accumulation is capped like `time`'s.
    let speed = RangeSpec {
        a: omega,
        b: omega,
        n: 1,
    };
    let time_text = time.to_string();
    let study = LyapunovStudy::new(
        ("time", &time_text),
        speed,
        x0,
        SweepStart::Given,
        params,
        config,
    )
    .map_err(run::to_py_err)?;
    let s = match run::detached(py, None, |ctl| {
        jeffcott_analysis::lyapunov::run(&study, &MemoryHost::new(ctl))
    })? {
        LyapunovOutcome::One(s) => s,
        LyapunovOutcome::Range(..) => unreachable!("one speed gives one spectrum"),
    };
    let d = json_to_py(py, &s.record())?.cast_into::<PyDict>()?;
    d.set_item("wall_time_s", s.wall_time_s)?;
    let history: Vec<f64> = s
        .history
        .iter()
        .flat_map(|(t, e)| std::iter::once(*t).chain(e.iter().copied()))
        .collect();
    d.set_item("history", array2(py, history, STATE_DIM + 1)?)?;
    Ok(d)
}
