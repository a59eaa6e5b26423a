//! Starts for periodic-orbit branches from an earlier result's periodic attractors
//! (`jeffcott orbits --from DIR`): a point of each attractor is a state at a
//! whole number of forcing periods (t = kT, where the Poincare section lies), so Newton
//! shooting of P^n from it starts on the orbit up to the attractor's transient.
//!
//! Read from a `jeffcott basin` directory (`attractors.json`: every periodic attractor
//! with its period and Poincare points), a `jeffcott bifurcation` directory (its
//! brute force at the speed nearest a given one: `summary.json` names each attractor's
//! period, `bifurcation_rows.npy` the lane rows that found it, `bifurcation.npy` their
//! Poincare points) or a `jeffcott continuation` directory (`continuation.json`: the
//! attractors of the step nearest a given value, each with a Poincare point).

use crate::map::MapVar;
use crate::output::read_npy_f64;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{Params, STATE_DIM, State};
use serde_json::Value;
use std::path::Path;

/// A periodic attractor of an earlier result.
#[derive(Clone, Debug, PartialEq)]
pub struct AttractorStart {
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// The continued parameter's value there (W itself when it is W).
    pub value: f64,
    /// Period in forcing periods.
    pub period: u32,
    /// A Poincare point of the attractor (a state at t = kT).
    pub x: State,
    /// Its name in the result, e.g. `attractor 2 at W = 133`.
    pub label: String,
}

impl AttractorStart {
    /// An attractor at speed `w` (the value W until [`read`] sets the branch's own).
    fn at_speed(w: f64, period: u32, x: State, label: String) -> Self {
        AttractorStart {
            omega: w,
            value: w,
            period,
            x,
            label,
        }
    }
}

/// The periodic attractors of a result and the model they were computed with.
#[derive(Clone, Debug)]
pub struct Attractors {
    /// The result's model parameters.
    pub params: Params,
    /// Its periodic attractors (none: the result has none).
    pub starts: Vec<AttractorStart>,
}

/// Reads the periodic attractors of the result in `dir` (field `from` in errors) for a
/// branch continuing `var` from `near`: a basin's, a bifurcation diagram's brute force
/// at the speed nearest `near`, or a continuation's (over `var` itself) at the step
/// nearest `near`.
pub fn read(dir: &Path, var: MapVar, near: f64) -> Result<Attractors> {
    let bad = |why: String| Error::invalid("from", dir.display(), why);
    check_complete("from", dir)?;
    let mut found = if dir.join("attractors.json").is_file() {
        from_basin(dir)?
    } else if dir.join("summary.json").is_file() && dir.join("bifurcation_rows.npy").is_file() {
        from_bifurcation(dir, near)?
    } else if dir.join("continuation.json").is_file() {
        return from_continuation(dir, var, near);
    } else {
        return Err(bad(
            "not a `jeffcott basin` output (attractors.json), a `jeffcott bifurcation` \
             output (summary.json, bifurcation_rows.npy) or a `jeffcott continuation` \
             output (continuation.json)"
                .into(),
        ));
    };
    // A basin or a brute force lies at one speed, in the result's model.
    for s in &mut found.starts {
        s.value = match var {
            MapVar::Omega => s.omega,
            _ => found.params.get(var.name()).unwrap_or(f64::NAN),
        };
    }
    Ok(found)
}

/// `continuation.json`: the periodic attractors of the step nearest `near` (either
/// ramp; the up ramp where both hold the value), at that value of the continuation's
/// parameter, which must be the branch's.
fn from_continuation(dir: &Path, var: MapVar, near: f64) -> Result<Attractors> {
    let c = json(dir, "continuation.json")?;
    let params = params(dir, &c)?;
    let bad = |why: String| Error::invalid("from", dir.display(), why);
    let theirs = c["param"]["var"].as_str().unwrap_or("?");
    if theirs != var.name() {
        return Err(bad(format!(
            "a continuation over {theirs}; continue the same parameter ({theirs}:lo:hi)"
        )));
    }
    let steps = ["up", "down"]
        .iter()
        .filter_map(|d| c["ramps"][d]["steps"].as_array())
        .flatten();
    let step = nearest(steps, "value", near)
        .ok_or_else(|| bad("continuation.json lists no step".into()))?;
    let value = step["value"].as_f64().expect("nearest has one");
    let omega = match var {
        MapVar::Omega => value,
        _ => c["omega"].as_f64().unwrap_or(f64::NAN),
    };
    let mut starts = Vec::new();
    for a in step["attractors"].as_array().into_iter().flatten() {
        let (Some(n), Some(x)) = (
            period(&a["period"]),
            a["state"]
                .as_array()
                .and_then(|p| state(p.iter().map(Value::as_f64))),
        ) else {
            continue;
        };
        let id = a["id"].as_u64().unwrap_or(0);
        starts.push(AttractorStart {
            omega,
            value,
            period: n,
            x,
            label: format!("attractor #{id} at {} = {value}", var.name()),
        });
    }
    Ok(Attractors { params, starts })
}

/// Refuses a result whose run.json says it is not complete (an unfinished or
/// interrupted run: its files are an earlier run's or partial). A directory without
/// run.json (files made elsewhere) is taken as it is.
pub fn check_complete(field: &str, dir: &Path) -> Result<()> {
    let Ok(text) = std::fs::read_to_string(dir.join("run.json")) else {
        return Ok(());
    };
    let state = serde_json::from_str::<Value>(&text)
        .ok()
        .and_then(|j| j["state"].as_str().map(String::from));
    match state.as_deref() {
        Some("complete") => Ok(()),
        other => Err(Error::invalid(
            field,
            dir.display(),
            format!(
                "its run.json says the run is {} (not complete): finish it first (run its command again)",
                other.unwrap_or("unreadable")
            ),
        )),
    }
}

/// Refuses a result in `dir` (field `field`) whose model parameters `theirs` are not
/// `ours`, naming each one that differs.
pub fn check_same_model(field: &str, dir: &Path, ours: &Params, theirs: &Params) -> Result<()> {
    let (a, b) = (
        serde_json::to_value(ours).expect("params serialise"),
        serde_json::to_value(theirs).expect("params serialise"),
    );
    let (Some(a), Some(b)) = (a.as_object(), b.as_object()) else {
        return Ok(());
    };
    let differ: Vec<String> = a
        .iter()
        .filter(|(k, v)| b.get(*k) != Some(*v))
        .map(|(k, v)| format!("{k} = {} there, {v} here", b.get(k).unwrap_or(&Value::Null)))
        .collect();
    if differ.is_empty() {
        return Ok(());
    }
    Err(Error::invalid(
        field,
        dir.display(),
        format!(
            "it belongs to another model ({}); give the same model options",
            differ.join(", ")
        ),
    ))
}

/// Checks that the `jeffcott bifurcation` result in `dir` (field `field`) can be drawn
/// under a branch over W from `lo` to `hi` in the model `ours`: the same model, and at
/// least one of its speeds inside the range.
pub fn check_diagram(field: &str, dir: &Path, ours: &Params, (lo, hi): (f64, f64)) -> Result<()> {
    check_complete(field, dir)?;
    let path = dir.join("summary.json");
    let bad = |why: String| Error::invalid(field, dir.display(), why);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        bad(format!(
            "not a `jeffcott bifurcation` output: summary.json: {e}"
        ))
    })?;
    let s: Value = serde_json::from_str(&text).map_err(|e| bad(format!("summary.json: {e}")))?;
    let theirs: Params = serde_json::from_value(s["params"].clone())
        .map_err(|e| bad(format!("its model parameters cannot be read: {e}")))?;
    check_same_model(field, dir, ours, &theirs)?;
    let speeds: Vec<f64> = s["per_omega"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|v| v["omega"].as_f64())
        .collect();
    if !speeds.iter().any(|w| (lo..=hi).contains(w)) {
        let (a, b) = speeds
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &w| {
                (a.min(w), b.max(w))
            });
        return Err(bad(format!(
            "its speeds ({a}..{b} rad/s) lie outside the branch's range {lo}..{hi}"
        )));
    }
    Ok(())
}

/// The JSON file `name` of `dir`.
fn json(dir: &Path, name: &str) -> Result<Value> {
    let path = dir.join(name);
    let bad = |why: String| Error::invalid("from", path.display(), why);
    let text = std::fs::read_to_string(&path).map_err(|e| bad(format!("cannot read it: {e}")))?;
    serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))
}

/// The model parameters a result file records under `params`.
fn params(dir: &Path, v: &Value) -> Result<Params> {
    serde_json::from_value(v["params"].clone()).map_err(|e| {
        Error::invalid(
            "from",
            dir.display(),
            format!("its model parameters cannot be read: {e}"),
        )
    })
}

/// The entry of `list` whose number under `key` lies nearest `near` (the first of
/// equals; entries without one are passed over).
fn nearest<'a>(list: impl Iterator<Item = &'a Value>, key: &str, near: f64) -> Option<&'a Value> {
    list.filter_map(|v| Some((v, (v[key].as_f64()? - near).abs())))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(v, _)| v)
}

/// A period as a result records it (null: not periodic).
fn period(v: &Value) -> Option<u32> {
    v.as_u64()
        .and_then(|n| u32::try_from(n).ok())
        .filter(|&n| n >= 1)
}

/// A finite state from up to 8 JSON numbers or f64s.
fn state(values: impl IntoIterator<Item = Option<f64>>) -> Option<State> {
    let v: Vec<f64> = values.into_iter().collect::<Option<_>>()?;
    let x: State = v.try_into().ok()?;
    x.iter().all(|c| c.is_finite()).then_some(x)
}

/// `attractors.json` of a basin.
fn from_basin(dir: &Path) -> Result<Attractors> {
    let a = json(dir, "attractors.json")?;
    let params = params(dir, &a)?;
    let omega = a["omega"].as_f64();
    let list = a["attractors"].as_array().ok_or_else(|| {
        Error::invalid(
            "from",
            dir.display(),
            "attractors.json has no attractor list",
        )
    })?;
    let mut starts = Vec::new();
    for (k, at) in list.iter().enumerate() {
        let (Some(n), Some(w)) = (period(&at["period"]), at["omega"].as_f64().or(omega)) else {
            continue;
        };
        let first = at["points"].get(0).and_then(Value::as_array);
        let Some(x) = first.and_then(|p| state(p.iter().map(Value::as_f64))) else {
            continue;
        };
        let id = at["id"].as_u64().unwrap_or(k as u64);
        starts.push(AttractorStart::at_speed(
            w,
            n,
            x,
            format!("attractor {id} at W = {w}"),
        ));
    }
    Ok(Attractors { params, starts })
}

/// The brute force of a bifurcation diagram at the speed nearest `near`.
fn from_bifurcation(dir: &Path, near: f64) -> Result<Attractors> {
    let s = json(dir, "summary.json")?;
    let params = params(dir, &s)?;
    let bad = |why: &str| Error::invalid("from", dir.display(), why.to_string());
    let per_omega = s["per_omega"]
        .as_array()
        .ok_or_else(|| bad("summary.json has no per_omega list"))?;
    let at = nearest(per_omega.iter(), "omega", near)
        .ok_or_else(|| bad("summary.json lists no speed"))?;
    let w = at["omega"].as_f64().expect("nearest has one");
    let catalogue = at["brute_force"]["attractors"]
        .as_array()
        .ok_or_else(|| bad("no brute force in this diagram (it was run without one)"))?;
    let (shape, rows) = read_npy_f64("from", &dir.join("bifurcation_rows.npy"))?;
    let (pshape, points) = read_npy_f64("from", &dir.join("bifurcation.npy"))?;
    if shape.len() != 2 || shape[1] != 4 || pshape.len() != 3 || pshape[2] != STATE_DIM as u64 {
        return Err(bad(
            "bifurcation_rows.npy is not [rows, 4] or bifurcation.npy not [rows, periods, 8]",
        ));
    }
    let row_len = (pshape[1] as usize) * STATE_DIM;
    let mut starts = Vec::new();
    for (k, entry) in catalogue.iter().enumerate() {
        let Some(n) = period(&entry["period"]) else {
            continue;
        };
        let id = entry["id"].as_u64().unwrap_or(k as u64) as f64;
        // The first brute-force row (sweep 2) of this speed that found the attractor.
        let row = rows
            .chunks_exact(4)
            .position(|r| r[0] == w && r[1] == 2.0 && r[3] == id);
        let x = row.and_then(|r| {
            let p = points.get(r * row_len..r * row_len + STATE_DIM)?;
            state(p.iter().map(|&c| Some(c)))
        });
        if let Some(x) = x {
            let label = format!("brute-force attractor {id} at W = {w}");
            starts.push(AttractorStart::at_speed(w, n, x, label));
        }
    }
    Ok(Attractors { params, starts })
}
