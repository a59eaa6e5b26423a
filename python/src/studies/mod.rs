//! The package's functions, one file per family of studies. Each builds the study's
//! specification from its keywords ([`crate::args`]), runs it with the GIL released
//! ([`crate::run`]) and returns the command line's files as numpy arrays and
//! dictionaries ([`crate::convert`]).

/// Declares a lane study's package function (`bifurcation`, `map`, `continuation`,
/// `basin_stability`): those whose keywords end alike, `params=None, backend="auto",
/// precision=None, lyapunov=True, progress=None, **stepper`, read alike into the lane
/// settings. Written once here, the shared tail cannot drift between the functions (a
/// default, a reader or the order of the keywords, which the type stub mirrors).
///
/// The invocation gives the function's docstring, ending in its `Parameters:` list of
/// its own parameters (the macro adds the tail's items), its own signature up to that
/// tail (ending in a comma), its own arguments, the names under which the body sees the
/// lane settings ([`crate::lane_settings`], read first: an unknown stepper keyword is
/// named before anything else) and the `progress` callback, and the body; the function
/// returns the result dictionary.
macro_rules! lane_study {
    (
        $(#[$($attr:tt)*])*
        signature = ($($sig:tt)*);
        fn $name:ident<$py:lifetime>($($arg:tt)*)
        with (lane: $lane:ident, progress: $progress:ident $(, overridden: $over:ident)?)
        { $($body:tt)* }
    ) => {
        $(#[$($attr)*])*
        #[doc = param_doc!(params)]
        #[doc = param_doc!(backend)]
        #[doc = param_doc!(precision)]
        /// - `lyapunov`: compute every lane's largest Lyapunov exponent lambda_1 (one
        ///   tangent vector per lane); without it aperiodic attractors are not told
        ///   apart as quasiperiodic or chaotic.
        #[doc = param_doc!(progress)]
        #[doc = param_doc!(stepper)]
        #[pyo3::pyfunction]
        #[pyo3(signature = (
            $($sig)*
            params=None, backend="auto", precision=None, lyapunov=true,
            progress=None,
            **stepper,
        ))]
        #[allow(clippy::too_many_arguments)]
        pub(crate) fn $name<$py>(
            $($arg)*
            #[pyo3(from_py_with = crate::args::kw::params)] params: Option<
                std::collections::HashMap<String, f64>,
            >,
            #[pyo3(from_py_with = crate::args::kw::backend)] backend: &str,
            #[pyo3(from_py_with = crate::args::kw::precision)] precision: Option<&str>,
            #[pyo3(from_py_with = crate::args::kw::lyapunov)] lyapunov: bool,
            #[pyo3(from_py_with = crate::args::kw::progress)] $progress: Option<
                crate::args::Callback<$py>,
            >,
            stepper: Option<&pyo3::Bound<$py, pyo3::types::PyDict>>,
        ) -> pyo3::PyResult<pyo3::Bound<$py, pyo3::types::PyDict>> {
            // The names `params` sets, where the study refuses an override of what it
            // varies.
            $(let $over: Vec<String> =
                params.as_ref().map(|p| p.keys().cloned().collect()).unwrap_or_default();)?
            let $lane = crate::lane_settings(
                stringify!($name),
                params,
                backend,
                precision,
                lyapunov,
                stepper,
            )?;
            $($body)*
        }
    };
}

pub mod basins;
pub mod lanes;
pub mod maps;
pub mod orbits;
pub mod trajectory;
