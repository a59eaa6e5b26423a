//! The keyword arguments of the package's functions read from Python objects. Each
//! argument is read by the function of this module named after its keyword
//! (`#[pyo3(from_py_with = kw::transient)] transient: u32`), so a value of the wrong
//! kind raises a TypeError, and a whole number out of range or an array of the wrong
//! shape a ValueError, whose message names the keyword and says what it accepts:
//! "invalid value for `transient`: -1 (expected a whole number in 0..=4294967295)". On
//! every Python version: PyO3 itself names the argument only in a note (Python >= 3.11)
//! and lets an OverflowError (-1 for a count) pass bare.
//!
//! What the values mean (ranges, names, choices) is checked afterwards by the library,
//! whose errors name the same keyword.

use jeffcott_core::integrate::lane::StepperConfig;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::{PyOverflowError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyMapping, PyString, PyTuple};
use serde::Deserialize;
use std::collections::HashMap;

/// Why a value was refused, with what about it was wrong (may be empty).
pub enum Bad {
    /// The wrong kind of object: a TypeError.
    Type(String),
    /// The right kind, out of range or of the wrong shape: a ValueError.
    Value(String),
    /// Python failed while looking (an exception passed on as it is).
    Py(PyErr),
}

impl From<PyErr> for Bad {
    fn from(e: PyErr) -> Bad {
        Bad::Py(e)
    }
}

/// A value read from a keyword argument.
pub trait FromArg<'py>: Sized {
    /// Whether None is accepted (`Option<T>`).
    const NONE_OK: bool = false;
    /// What the type accepts, in words ("a whole number in 0..=4294967295").
    fn what() -> String;
    /// Reads `o`.
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad>;
}

/// Reads keyword `name` from `o`; `accepts` replaces the type's own words where the
/// keyword says more ("'lane' or 'article'").
pub fn read<'py, T: FromArg<'py>>(
    name: &str,
    accepts: Option<&str>,
    o: &Bound<'py, PyAny>,
) -> PyResult<T> {
    let (value_error, detail) = match T::read(o) {
        Ok(v) => return Ok(v),
        Err(Bad::Py(e)) => return Err(e),
        Err(Bad::Type(d)) => (false, d),
        Err(Bad::Value(d)) => (true, d),
    };
    let what = match accepts {
        Some(a) if T::NONE_OK => format!("{a}, or None"),
        Some(a) => a.to_string(),
        None => T::what(),
    };
    let detail = if detail.is_empty() {
        String::new()
    } else {
        format!("; {detail}")
    };
    let msg = format!(
        "invalid value for `{name}`: {} (expected {what}{detail})",
        shown(o)
    );
    Err(if value_error {
        PyValueError::new_err(msg)
    } else {
        PyTypeError::new_err(msg)
    })
}

/// A value as an error message shows it: its repr, shortened; an array by its shape and
/// dtype, a long container by its length (their reprs can be huge).
pub fn shown(o: &Bound<'_, PyAny>) -> String {
    if let (Ok(shape), Ok(dtype)) = (o.getattr("shape"), o.getattr("dtype")) {
        return format!("an array of shape {shape} and dtype {dtype}");
    }
    if !o.is_instance_of::<PyString>()
        && let Ok(n) = o.len()
        && n > 16
    {
        let kind = o
            .get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_else(|_| "container".into());
        return format!("a {kind} of {n} items");
    }
    let r = o
        .repr()
        .map(|r| r.to_string())
        .unwrap_or_else(|_| "<unprintable>".into());
    if r.chars().count() > 80 {
        r.chars().take(77).collect::<String>() + "..."
    } else {
        r
    }
}

/// A whole number in `0..=max`: a Python int or anything with `__index__` (numpy
/// integers), not a bool and not a float (as Python's `range` reads its arguments).
fn whole(o: &Bound<'_, PyAny>, max: u64) -> Result<u64, Bad> {
    if o.is_instance_of::<PyBool>() {
        return Err(Bad::Type(String::new()));
    }
    match o.extract::<u64>() {
        Ok(v) if v <= max => Ok(v),
        Ok(_) => Err(Bad::Value(String::new())),
        Err(e) if e.is_instance_of::<PyOverflowError>(o.py()) => Err(Bad::Value(String::new())),
        Err(_) => Err(Bad::Type(String::new())),
    }
}

macro_rules! whole_numbers {
    ($($t:ty),*) => {$(
        impl<'py> FromArg<'py> for $t {
            fn what() -> String {
                format!("a whole number in 0..={}", <$t>::MAX)
            }
            fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
                Ok(whole(o, <$t>::MAX as u64)? as $t)
            }
        }
    )*};
}
whole_numbers!(u32, u64, usize);

impl<'py> FromArg<'py> for f64 {
    fn what() -> String {
        "a number".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        if o.is_instance_of::<PyBool>() {
            return Err(Bad::Type(String::new()));
        }
        o.extract::<f64>().map_err(|e| {
            if e.is_instance_of::<PyOverflowError>(o.py()) {
                Bad::Value("too large for a float".into())
            } else {
                Bad::Type(String::new())
            }
        })
    }
}

impl<'py> FromArg<'py> for bool {
    fn what() -> String {
        "True or False".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        o.extract::<bool>().map_err(|_| Bad::Type(String::new()))
    }
}

impl<'py> FromArg<'py> for String {
    fn what() -> String {
        "a string".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        match o.cast::<PyString>() {
            Ok(s) => Ok(s.to_cow()?.into_owned()),
            Err(_) => Err(Bad::Type(String::new())),
        }
    }
}

/// A path: a string or any `os.PathLike` (a `pathlib.Path`), read through `os.fspath`;
/// a bytes path is refused (jeffcott names files in text).
impl<'py> FromArg<'py> for std::path::PathBuf {
    fn what() -> String {
        "a path (a str or an os.PathLike such as pathlib.Path)".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        let fspath = o.py().import("os")?.getattr("fspath")?;
        let p = fspath.call1((o,)).map_err(|_| Bad::Type(String::new()))?;
        match p.cast::<PyString>() {
            Ok(s) => Ok(std::path::PathBuf::from(s.to_cow()?.into_owned())),
            Err(_) => Err(Bad::Type(String::new())),
        }
    }
}

/// Names mapped to numbers (`params`, `init`, `fix`): a dict or any mapping.
impl<'py> FromArg<'py> for HashMap<String, f64> {
    fn what() -> String {
        "a dict of names to numbers".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        let m = o
            .cast::<PyMapping>()
            .map_err(|_| Bad::Type(String::new()))?;
        let mut out = HashMap::new();
        for item in m.items()?.iter() {
            let (k, v) = item
                .cast_into::<PyTuple>()
                .map_err(PyErr::from)?
                .extract::<(Bound<'py, PyAny>, Bound<'py, PyAny>)>()?;
            let key = String::read(&k)
                .map_err(|_| Bad::Type(format!("the key {} is not a string", shown(&k))))?;
            let value = f64::read(&v).map_err(|bad| {
                let d = format!("{} maps to {}, not a number", shown(&k), shown(&v));
                match bad {
                    Bad::Value(_) => Bad::Value(d),
                    _ => Bad::Type(d),
                }
            })?;
            out.insert(key, value);
        }
        Ok(out)
    }
}

/// A list (any sequence but a string) of strings (`columns`).
impl<'py> FromArg<'py> for Vec<String> {
    fn what() -> String {
        "a list of strings".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        if o.is_instance_of::<PyString>() {
            return Err(Bad::Type("a single string, not a list".into()));
        }
        let items = o.try_iter().map_err(|_| Bad::Type(String::new()))?;
        let mut out = Vec::new();
        for item in items {
            let item = item?;
            out.push(
                String::read(&item)
                    .map_err(|_| Bad::Type(format!("{} is not a string", shown(&item))))?,
            );
        }
        Ok(out)
    }
}

impl<'py, T: FromArg<'py>> FromArg<'py> for Option<T> {
    const NONE_OK: bool = true;
    fn what() -> String {
        format!("{}, or None", T::what())
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        if o.is_none() {
            Ok(None)
        } else {
            T::read(o).map(Some)
        }
    }
}

/// A callable (`progress`), checked when the function is called, not when the run
/// first reports.
pub struct Callback<'py>(pub Bound<'py, PyAny>);

impl<'py> FromArg<'py> for Callback<'py> {
    fn what() -> String {
        "a callable f(done, total)".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        if o.is_callable() {
            Ok(Callback(o.clone()))
        } else {
            Err(Bad::Type(String::new()))
        }
    }
}

/// `o` as a non-empty 2-D numpy array whose dtype is of one of the numpy `kinds` ("iuf"),
/// and a function converting it to a C-ordered array of a given dtype: any array-like of
/// such numbers, in any memory order and byte order, is read as numpy reads it.
fn array2<'py>(o: &Bound<'py, PyAny>, kinds: &str) -> Result<Bound<'py, PyAny>, Bad> {
    let py = o.py();
    let np = py.import("numpy")?;
    let a = np
        .call_method1("asarray", (o,))
        .map_err(|e| Bad::Type(e.value(py).to_string()))?;
    let dt = a.getattr("dtype")?;
    let kind: String = dt.getattr("kind")?.extract()?;
    if !kinds.contains(kind.as_str()) {
        return Err(Bad::Type(format!("its dtype is {dt}")));
    }
    let ndim: usize = a.getattr("ndim")?.extract()?;
    if ndim != 2 {
        return Err(Bad::Value(format!("it is {ndim}-D")));
    }
    let size: usize = a.getattr("size")?.extract()?;
    if size == 0 {
        return Err(Bad::Value("it has no elements".into()));
    }
    Ok(a)
}

/// `a` (a numpy array) as a C-ordered array of `dtype`, read as a 2-D array of `T`.
fn converted<'py, T: numpy::Element>(
    a: &Bound<'py, PyAny>,
    dtype: &str,
) -> Result<PyReadonlyArray2<'py, T>, Bad> {
    let np = a.py().import("numpy")?;
    let c = np.call_method1("ascontiguousarray", (a, dtype))?;
    Ok(c.extract()?)
}

/// A lane table (`lanes`): a 2-D array of numbers, any numeric dtype, read as float64.
pub struct Table<'py>(pub PyReadonlyArray2<'py, f64>);

impl<'py> FromArg<'py> for Table<'py> {
    fn what() -> String {
        "a 2-D array of numbers [lanes, columns]".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        Ok(Table(converted(&array2(o, "iuf")?, "float64")?))
    }
}

/// A basin's labels (`labels`): a 2-D array of integer attractor ids, any integer dtype,
/// read as int32.
pub struct Labels<'py>(pub PyReadonlyArray2<'py, i32>);

impl<'py> FromArg<'py> for Labels<'py> {
    fn what() -> String {
        "a non-empty 2-D array of integer attractor ids [ny, nx]".into()
    }
    fn read(o: &Bound<'py, PyAny>) -> Result<Self, Bad> {
        let a = array2(o, "iu")?;
        // Every integer dtype's range fits in f64's exactly enough to compare.
        let lo: f64 = a.call_method0("min")?.extract()?;
        let hi: f64 = a.call_method0("max")?.extract()?;
        if lo < i32::MIN as f64 || hi > i32::MAX as f64 {
            return Err(Bad::Value(format!(
                "ids from {lo} to {hi} do not fit in int32"
            )));
        }
        Ok(Labels(converted(&a, "int32")?))
    }
}

/// The reader of each keyword: `kw::NAME` reads keyword `NAME` (or the name in
/// parentheses), with the words after `=` for what it accepts where the type's own
/// words say too little.
macro_rules! keywords {
    ($($f:ident $(($name:literal))? $(= $accepts:literal)?),* $(,)?) => {$(
        #[doc = concat!("Reads the keyword `", keywords!(@name $f $($name)?), "`.")]
        pub fn $f<'py, T: FromArg<'py>>(o: &Bound<'py, PyAny>) -> PyResult<T> {
            read(keywords!(@name $f $($name)?), keywords!(@accepts $($accepts)?), o)
        }
    )*};
    (@name $f:ident $name:literal) => { $name };
    (@name $f:ident) => { stringify!($f) };
    (@accepts $a:literal) => { Some($a) };
    (@accepts) => { None };
}

/// Keyword `name`: one of the strings `choices`, as the static string of the list, or
/// with `none_ok` None (a ValueError for another string, a TypeError for what is not a
/// string).
fn choice(
    name: &str,
    choices: &[&'static str],
    none_ok: bool,
    o: &Bound<'_, PyAny>,
) -> PyResult<Option<&'static str>> {
    if none_ok && o.is_none() {
        return Ok(None);
    }
    if let Ok(t) = String::read(o)
        && let Some(c) = choices.iter().find(|c| **c == t)
    {
        return Ok(Some(c));
    }
    let mut words: Vec<String> = choices.iter().map(|c| format!("'{c}'")).collect();
    if none_ok {
        words.push("None".into());
    }
    let what = match words.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => words.join(""),
    };
    let msg = format!("invalid value for `{name}`: {} (expected {what})", shown(o));
    Err(if o.is_instance_of::<PyString>() {
        PyValueError::new_err(msg)
    } else {
        PyTypeError::new_err(msg)
    })
}

/// The keyword readers (see [`keywords!`]).
pub mod kw {
    use super::{FromArg, choice, read};
    use pyo3::prelude::*;

    // The choices the library parses (`Backend::parse`, `Precision::parse`,
    // `continuation::directions`, the bifurcation's and simulate's own), read as static
    // strings so that the defaults stay string literals in the signatures.

    /// Reads the keyword `integrator`.
    pub fn integrator(o: &Bound<'_, PyAny>) -> PyResult<&'static str> {
        Ok(choice("integrator", &["lane", "article"], false, o)?.unwrap_or_default())
    }
    /// Reads the keyword `backend`.
    pub fn backend(o: &Bound<'_, PyAny>) -> PyResult<&'static str> {
        Ok(choice("backend", &["auto", "cpu", "gpu"], false, o)?.unwrap_or_default())
    }
    /// Reads the keyword `precision` (None: the backend's default).
    pub fn precision(o: &Bound<'_, PyAny>) -> PyResult<Option<&'static str>> {
        choice("precision", &["f32", "f64"], true, o)
    }
    /// Reads the keyword `sweep`.
    pub fn sweep(o: &Bound<'_, PyAny>) -> PyResult<&'static str> {
        Ok(choice("sweep", &["up", "down", "both", "none"], false, o)?.unwrap_or_default())
    }
    /// Reads the keyword `direction`.
    pub fn direction(o: &Bound<'_, PyAny>) -> PyResult<&'static str> {
        Ok(choice("direction", &["up", "down", "both"], false, o)?.unwrap_or_default())
    }
    /// Reads the keyword `direction` of a branch (`orbits`): one way.
    pub fn branch_direction(o: &Bound<'_, PyAny>) -> PyResult<&'static str> {
        Ok(choice("direction", &["up", "down"], false, o)?.unwrap_or_default())
    }

    keywords! {
        omega = "a speed in rad/s",
        omega_range("omega") = "a range \"a:b:n\" (n >= 2 speeds)",
        params = "a dict of model parameter names (jeffcott.PARAM_KEYS) to numbers",
        init = "a dict of start coordinate names (jeffcott.COORD_NAMES) to numbers",
        fix = "a dict of start coordinate names (jeffcott.COORD_NAMES) to numbers",
        lanes,
        columns = "a list of column names (jeffcott.LANES_COLUMNS, parameter keys, param_set)",
        labels,
        progress,
        transient,
        transient_first,
        brute_transient,
        tangent_transient,
        periods,
        timeseries_periods,
        spectrum_periods,
        n_max,
        rel_tol,
        abs_tol,
        article_steps,
        article_alpha,
        lyapunov,
        refine,
        uncertainty_samples,
        entropy_box,
        ics,
        seed,
        max_seeds,
        time,
        min_time,
        tol,
        window,
        log_x,
        log_y,
        start_box = "a box of start coordinates \"NAME:lo:hi,...\"",
        match_threshold,
        sample,
        max_order,
        param = "a parameter and its range \"NAME:lo:hi\" (NAME omega or a model parameter)",
        period,
        settle,
        max_points,
        ds,
        ds_max,
        follow_doublings,
        start_from = "a path (a str or an os.PathLike such as pathlib.Path) of a basin, bifurcation or continuation output directory",
    }
}

/// The lane stepper's settings from a function's `**stepper` keywords: every field of
/// [`StepperConfig`] is a keyword of its name, its default that of
/// [`StepperConfig::DEFAULT`] (the command line's defaults). The fields and their kinds
/// are read from the settings' serde form, so a new stepper setting reaches every
/// function without code here; each value is read as the default's kind (a whole
/// number in 0..=u32::MAX, a number or a bool) with the keyword named in errors, and a keyword that is
/// not a setting is the TypeError Python raises for an unexpected keyword.
pub fn stepper(function: &str, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<StepperConfig> {
    use serde::de::value::MapDeserializer;
    let defaults = stepper_defaults();
    let mut values: Vec<(String, Scalar)> = Vec::with_capacity(defaults.len());
    for (name, default) in &defaults {
        let given = match kwargs {
            Some(d) => d.get_item(name)?,
            None => None,
        };
        values.push((
            name.clone(),
            match (given, *default) {
                (None, d) => d,
                (Some(v), Scalar::Whole(_)) => Scalar::Whole(read::<u32>(name, None, &v)? as u64),
                (Some(v), Scalar::Real(_)) => Scalar::Real(read::<f64>(name, None, &v)?),
                (Some(v), Scalar::Flag(_)) => Scalar::Flag(read::<bool>(name, None, &v)?),
            },
        ));
    }
    if let Some(d) = kwargs {
        for k in d.keys() {
            let k: String = k.extract()?;
            if !defaults.iter().any(|(n, _)| *n == k) {
                return Err(PyTypeError::new_err(format!(
                    "{function}() got an unexpected keyword argument '{k}'"
                )));
            }
        }
    }
    let de = MapDeserializer::<_, serde::de::value::Error>::new(values.into_iter());
    StepperConfig::deserialize(de).map_err(|e| PyValueError::new_err(format!("stepper: {e}")))
}

/// The stepper settings' names and default values, in declaration order.
pub fn stepper_defaults() -> Vec<(String, Scalar)> {
    let serde_json::Value::Object(fields) =
        serde_json::to_value(StepperConfig::DEFAULT).unwrap_or_default()
    else {
        return Vec::new();
    };
    fields
        .into_iter()
        .filter_map(|(k, v)| {
            let s = match v {
                serde_json::Value::Bool(b) => Scalar::Flag(b),
                serde_json::Value::Number(n) => match n.as_u64() {
                    Some(u) => Scalar::Whole(u),
                    None => Scalar::Real(n.as_f64()?),
                },
                _ => return None,
            };
            Some((k, s))
        })
        .collect()
}

/// A stepper setting's value.
#[derive(Clone, Copy, Debug)]
pub enum Scalar {
    /// A whole number.
    Whole(u64),
    /// A number.
    Real(f64),
    /// A switch.
    Flag(bool),
}

impl<'de> serde::de::IntoDeserializer<'de> for Scalar {
    type Deserializer = Scalar;
    fn into_deserializer(self) -> Scalar {
        self
    }
}

impl<'de> serde::Deserializer<'de> for Scalar {
    type Error = serde::de::value::Error;
    fn deserialize_any<V: serde::de::Visitor<'de>>(self, v: V) -> Result<V::Value, Self::Error> {
        match self {
            Scalar::Whole(u) => v.visit_u64(u),
            Scalar::Real(x) => v.visit_f64(x),
            Scalar::Flag(b) => v.visit_bool(b),
        }
    }
    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map struct enum identifier ignored_any
    }
}

impl<'py> IntoPyObject<'py> for Scalar {
    type Target = PyAny;
    type Output = Bound<'py, PyAny>;
    type Error = PyErr;
    fn into_pyobject(self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(match self {
            Scalar::Whole(u) => u.into_pyobject(py)?.into_any(),
            Scalar::Real(x) => x.into_pyobject(py)?.into_any(),
            Scalar::Flag(b) => pyo3::types::PyBool::new(py, b).to_owned().into_any(),
        })
    }
}
