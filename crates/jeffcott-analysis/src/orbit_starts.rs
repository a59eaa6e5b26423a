//! Starts for periodic-orbit branches from an earlier result's periodic attractors
//! (`jeffcott orbits --from DIR`, issue 26): a point of each attractor is a state at a
//! whole number of forcing periods (t = kT, where the Poincare section lies), so Newton
//! shooting of P^n from it starts on the orbit up to the attractor's transient.
//!
//! Read from a `jeffcott basin` directory (`attractors.json`: every periodic attractor
//! with its period and Poincare points) or a `jeffcott bifurcation` directory (its
//! brute force at the speed nearest a given one: `summary.json` names each attractor's
//! period, `bifurcation_rows.npy` the lane rows that found it, `bifurcation.npy` their
//! Poincare points).

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
    /// Period in forcing periods.
    pub period: u32,
    /// A Poincare point of the attractor (a state at t = kT).
    pub x: State,
    /// Its name in the result, e.g. `attractor 2 at W = 133`.
    pub label: String,
}

/// The periodic attractors of a result and the model they were computed with.
#[derive(Clone, Debug)]
pub struct Attractors {
    /// The result's model parameters.
    pub params: Params,
    /// Its periodic attractors (none: the result has none).
    pub starts: Vec<AttractorStart>,
}

/// Reads the periodic attractors of the result in `dir` (field `from` in errors): a
/// basin's, or a bifurcation diagram's brute force at the speed nearest `near` [rad/s].
pub fn read(dir: &Path, near: f64) -> Result<Attractors> {
    let bad = |why: String| Error::invalid("from", dir.display(), why);
    if dir.join("attractors.json").is_file() {
        from_basin(dir)
    } else if dir.join("summary.json").is_file() && dir.join("bifurcation_rows.npy").is_file() {
        from_bifurcation(dir, near)
    } else {
        Err(bad(
            "not a `jeffcott basin` output (attractors.json) or a `jeffcott bifurcation` \
             output (summary.json, bifurcation_rows.npy)"
                .into(),
        ))
    }
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
        starts.push(AttractorStart {
            omega: w,
            period: n,
            x,
            label: format!("attractor {id} at W = {w}"),
        });
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
    let at = per_omega
        .iter()
        .filter(|o| o["omega"].as_f64().is_some())
        .min_by(|a, b| {
            let d = |o: &Value| (o["omega"].as_f64().unwrap_or(f64::NAN) - near).abs();
            d(a).total_cmp(&d(b))
        })
        .ok_or_else(|| bad("summary.json lists no speed"))?;
    let w = at["omega"].as_f64().expect("filtered");
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
            starts.push(AttractorStart {
                omega: w,
                period: n,
                x,
                label: format!("brute-force attractor {id} at W = {w}"),
            });
        }
    }
    Ok(Attractors { params, starts })
}
