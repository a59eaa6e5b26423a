//! Input handling shared by every front end (the command line, the Python package):
//! `NAME=VALUE` lists, named start coordinates, parameter overrides and the check that a
//! start state lies within the divergence bound. Errors name the option and the allowed
//! range.

use crate::error::{Error, Result};
use crate::model::{COORD_NAMES, Params, STATE_DIM, State, X_R, X_S, Y_R, Y_S, coord_index};

/// Parses `a=1,b=2e-3` into pairs; `option` names the CLI option in errors.
/// An empty list (`--param ''`) is refused: it sets nothing, which is never what was meant.
pub fn parse_assignments(option: &str, text: &str) -> Result<Vec<(String, f64)>> {
    let mut out = Vec::new();
    if text.trim().is_empty() {
        return Err(Error::invalid(
            option,
            format!("{text:?}"),
            "empty; expected NAME=VALUE,... (leave the option out to set nothing)",
        ));
    }
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((name, value)) = item.split_once('=') else {
            let hint = if item.contains(':') {
                " (a range NAME:lo:hi:n is `--vary` of `continuation` and `--x`/`--y` of `map`)"
            } else {
                ""
            };
            return Err(Error::invalid(
                option,
                item,
                format!("expected NAME=VALUE{hint}"),
            ));
        };
        let name = name.trim();
        let value: f64 = value.trim().parse().map_err(|_| {
            Error::invalid(&format!("{option} {name}"), value.trim(), "not a number")
        })?;
        out.push((name.to_string(), value));
    }
    Ok(out)
}

/// Parses every `NAME=VALUE,...` list of a repeatable option (`--param`, `--init`,
/// `--fix`) into pairs in order, refusing a name given twice, in one list or across
/// repeated flags: which of the two values was meant cannot be guessed.
pub fn parse_assignment_lists(option: &str, lists: &[String]) -> Result<Vec<(String, f64)>> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for list in lists {
        for (name, value) in parse_assignments(option, list)? {
            if let Some((_, first)) = out.iter().find(|(n, _)| *n == name) {
                return Err(Error::invalid(
                    &format!("{option} {name}"),
                    format!("{name}={first} and {name}={value}"),
                    format!("`{name}` is given twice; give each name once"),
                ));
            }
            out.push((name, value));
        }
    }
    Ok(out)
}

/// Sets named coordinates of a start state (`x_r`, `vx_r`, ... in
/// [`COORD_NAMES`]); `option` names the option or argument in errors (`init`, `fix`).
/// Unknown names and non-finite values are refused.
pub fn set_coords(option: &str, x0: &mut State, pairs: &[(String, f64)]) -> Result<()> {
    for (name, value) in pairs {
        let i = coord(option, name)?;
        if !value.is_finite() {
            return Err(Error::invalid(
                &format!("{option} {name}"),
                value,
                "must be finite",
            ));
        }
        x0[i] = *value;
    }
    Ok(())
}

/// The index of start coordinate `name` (`x_r`, `vx_r`, ... in [`COORD_NAMES`]); an
/// unknown name is an error naming `option` and the valid names.
pub fn coord(option: &str, name: &str) -> Result<usize> {
    coord_index(name).ok_or_else(|| {
        Error::invalid(
            option,
            name,
            format!(
                "unknown coordinate; valid names: {}",
                COORD_NAMES.join(", ")
            ),
        )
    })
}

/// Model parameters from Table 1 with `pairs` (TOML keys) applied, validated: errors
/// name the key and its allowed range.
pub fn params_with(pairs: &[(String, f64)]) -> Result<Params> {
    let mut p = Params::default();
    for (name, value) in pairs {
        p.set(name, *value)?;
    }
    p.validate()?;
    Ok(p)
}

/// Refuses a value of option `option` that is not finite and > 0; `unit` (e.g. "m",
/// "1/s", or "" for a ratio) follows the bound in the message.
pub fn check_positive(option: &str, value: f64, unit: &str) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        let unit = if unit.is_empty() {
            String::new()
        } else {
            format!(" {unit}")
        };
        Err(Error::invalid(
            option,
            value,
            format!("must be finite and > 0{unit}"),
        ))
    }
}

/// Refuses a start state with a position coordinate beyond the divergence bound: the
/// lane stepper declares a lane diverged when |x_r|, |y_r|, |x_s| or |y_s| exceeds it,
/// so such a start would only report "diverged" without integrating anything.
/// `option` is the option that set the state (`init`, `fix`).
pub fn check_start_within_bound(option: &str, x0: &[f64; STATE_DIM], bound: f64) -> Result<()> {
    for i in [X_R, Y_R, X_S, Y_S] {
        check_coord_within_bound(option, i, x0[i], bound)?;
    }
    Ok(())
}

/// [`check_start_within_bound`] for one coordinate value (velocities always pass).
pub fn check_coord_within_bound(option: &str, coord: usize, value: f64, bound: f64) -> Result<()> {
    // The bound is checked first, so a bad bound is blamed on itself, not on the state.
    check_positive("divergence-bound", bound, "m")?;
    let position = [X_R, Y_R, X_S, Y_S].contains(&coord);
    // NaN passes here: non-finite values have their own checks and messages.
    if position && value.abs() > bound {
        return Err(Error::invalid(
            &format!("{option} {}", COORD_NAMES[coord]),
            value,
            format!(
                "start position beyond --divergence-bound {bound} m; must be in -{bound}..={bound} m \
                 (or raise --divergence-bound)"
            ),
        ));
    }
    Ok(())
}
