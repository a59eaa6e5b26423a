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

/// Model parameters from Table 1 with `pairs` applied ([`apply_pairs`]), validated:
/// errors name the key and its allowed range.
pub fn params_with(pairs: &[(String, f64)]) -> Result<Params> {
    let mut p = Params::default();
    apply_pairs(&mut p, pairs)?;
    p.validate()?;
    Ok(p)
}

/// Keys that describe a machine as an engineer measures it, each in place of one model
/// parameter: (key, the parameter it sets). A directional key (`k_rx`, `c_sy`, ...)
/// sets its direction's parameter (docs/model.md 7). Their units and formulas are in
/// docs/parameters.md and in `set_machine_key` below.
pub const MACHINE_KEYS: [(&str, &str); 13] = [
    ("k_r", "omega_r"),
    ("k_rx", "omega_rx"),
    ("k_ry", "omega_ry"),
    ("c_r", "xi_r"),
    ("c_rx", "xi_rx"),
    ("c_ry", "xi_ry"),
    ("k_s", "omega_s"),
    ("k_sx", "omega_sx"),
    ("k_sy", "omega_sy"),
    ("c_s", "xi_s"),
    ("c_sx", "xi_sx"),
    ("c_sy", "xi_sy"),
    ("unbalance", "e"),
];

/// Applies `pairs` to `p`: the model's parameters (as in a parameter file) first, in
/// order, then the [`MACHINE_KEYS`], converted with the masses and frequencies as they
/// then stand, so that a list's order does not matter. A machine key given together
/// with the parameter it sets is refused, naming both. Values are checked by
/// [`Params::validate`] afterwards, machine keys here (their own ranges).
pub fn apply_pairs(p: &mut Params, pairs: &[(String, f64)]) -> Result<()> {
    let is_machine = |name: &str| MACHINE_KEYS.iter().any(|k| k.0 == name);
    for (name, value) in pairs.iter().filter(|(n, _)| !is_machine(n)) {
        // `set` refuses only an unknown name; the refusal lists the machine keys too.
        p.set(name, *value).map_err(|_| {
            let machine: Vec<&str> = MACHINE_KEYS.iter().map(|k| k.0).collect();
            Error::invalid(
                name,
                value,
                format!(
                    "unknown parameter; valid names: {}, or a machine's {}",
                    Params::names_list(),
                    machine.join(", ")
                ),
            )
        })?;
    }
    // In MACHINE_KEYS' order: a stiffness before the damping that converts with it.
    let given = |name: &str| pairs.iter().any(|(n, _)| n == name);
    for (key, model) in MACHINE_KEYS {
        let Some((_, value)) = pairs.iter().rev().find(|(n, _)| n == key) else {
            continue;
        };
        if given(model) {
            return Err(Error::invalid(
                key,
                value,
                format!("sets `{model}`, which is given too: give one of `{key}` and `{model}`"),
            ));
        }
        set_machine_key(p, key, *value, &given)?;
    }
    Ok(())
}

/// Sets the model parameter of machine key `key` from its value (stiffnesses first, so
/// that a damping converts with the frequency its stiffness gives). An isotropic damping
/// (`c_r`, `c_s`) of supports whose stiffness differs by direction is the same dashpot
/// in both directions: each direction's ratio converts with its own frequency, except
/// where that direction's damping is given itself (`given`).
fn set_machine_key(p: &mut Params, key: &str, v: f64, given: &dyn Fn(&str) -> bool) -> Result<()> {
    check_positive("m_r", p.m_r, "kg")?;
    check_positive("m_s", p.m_s, "kg")?;
    if key.starts_with('k') {
        check_positive(key, v, "N/m")?;
    } else if !(v.is_finite() && v >= 0.0) {
        return Err(Error::invalid(key, v, "must be finite and >= 0"));
    }
    let (mr, ms) = (p.m_r, p.m_s);
    let ((wrx, wry), (wsx, wsy)) = (p.omega_r_xy(), p.omega_s_xy());
    let ratio = |m: f64, w: f64| v / (2.0 * m * w);
    // An isotropic damping's ratio in the directions whose stiffness differs.
    let both = |p: &mut Params, body: char, m: f64, (wx, wy): (f64, f64)| {
        for (dir, w) in [('x', wx), ('y', wy)] {
            let name = format!("xi_{body}{dir}");
            let iso = if body == 'r' { p.omega_r } else { p.omega_s };
            if w != iso && !given(&name) && !given(&format!("c_{body}{dir}")) {
                p.set(&name, ratio(m, w))
                    .expect("a directional damping ratio");
            }
        }
    };
    match key {
        "k_r" => p.omega_r = (v / mr).sqrt(),
        "k_rx" => p.omega_rx = Some((v / mr).sqrt()),
        "k_ry" => p.omega_ry = Some((v / mr).sqrt()),
        "k_s" => p.omega_s = (v / ms).sqrt(),
        "k_sx" => p.omega_sx = Some((v / ms).sqrt()),
        "k_sy" => p.omega_sy = Some((v / ms).sqrt()),
        "c_r" => {
            p.xi_r = ratio(mr, p.omega_r);
            both(p, 'r', mr, (wrx, wry));
        }
        "c_rx" => p.xi_rx = Some(ratio(mr, wrx)),
        "c_ry" => p.xi_ry = Some(ratio(mr, wry)),
        "c_s" => {
            p.xi_s = ratio(ms, p.omega_s);
            both(p, 's', ms, (wsx, wsy));
        }
        "c_sx" => p.xi_sx = Some(ratio(ms, wsx)),
        "c_sy" => p.xi_sy = Some(ratio(ms, wsy)),
        "unbalance" => p.e = v / mr,
        _ => unreachable!("MACHINE_KEYS lists these"),
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    fn pairs(list: &[(&str, f64)]) -> Vec<(String, f64)> {
        list.iter().map(|(k, v)| (k.to_string(), *v)).collect()
    }

    #[test]
    fn a_machine_given_by_stiffness_damping_and_unbalance_is_the_model_of_the_formulas() {
        let machine = [
            ("c_r", 170.0),
            ("k_r", 6.0e5),
            ("m_r", 30.0),
            ("unbalance", 0.024),
            ("c_s", 2200.0),
            ("k_s", 1.2e7),
            ("m_s", 40.0),
        ];
        let p = params_with(&pairs(&machine)).unwrap();
        let (wr, ws) = ((6.0e5f64 / 30.0).sqrt(), (1.2e7f64 / 40.0).sqrt());
        assert_eq!(p.omega_r, wr);
        assert_eq!(p.omega_s, ws);
        // The damping ratio c / (2 sqrt(k m)) of the guide, to rounding.
        assert!((p.xi_r - 170.0 / (2.0 * (6.0e5f64 * 30.0).sqrt())).abs() < 1e-15);
        assert!((p.xi_s - 2200.0 / (2.0 * (1.2e7f64 * 40.0).sqrt())).abs() < 1e-15);
        assert_eq!(p.e, 0.024 / 30.0);
        assert!((p.k_r() - 6.0e5).abs() < 1e-9 * 6.0e5 && (p.k_s() - 1.2e7).abs() < 1e-9 * 1.2e7);
        // The order of a list does not matter: masses and stiffnesses come first.
        let mut reversed = machine;
        reversed.reverse();
        assert_eq!(params_with(&pairs(&reversed)).unwrap(), p);
    }

    #[test]
    fn directional_machine_keys_set_each_direction_and_an_isotropic_dashpot_converts_per_direction()
    {
        let p = params_with(&pairs(&[
            ("m_r", 20.0),
            ("k_rx", 8.0e5),
            ("k_ry", 1.8e6),
            ("c_r", 400.0),
            ("k_s", 5.0e6),
            ("k_sy", 2.0e7),
            ("c_sx", 900.0),
        ]))
        .unwrap();
        let ((wrx, wry), (wsx, wsy)) = (p.omega_r_xy(), p.omega_s_xy());
        assert_eq!(
            (wrx, wry),
            ((8.0e5f64 / 20.0).sqrt(), (1.8e6f64 / 20.0).sqrt())
        );
        assert_eq!(
            (wsx, wsy),
            ((5.0e6f64 / 50.0).sqrt(), (2.0e7f64 / 50.0).sqrt())
        );
        // One dashpot c_r = 400 N s/m: the ratio c / (2 m w) of each direction.
        let (xrx, xry) = p.xi_r_xy();
        assert!((xrx - 400.0 / (2.0 * 20.0 * wrx)).abs() < 1e-15);
        assert!((xry - 400.0 / (2.0 * 20.0 * wry)).abs() < 1e-15);
        // c_sx converts with the stator's x frequency; y keeps Table 1's ratio.
        let (xsx, xsy) = p.xi_s_xy();
        assert!((xsx - 900.0 / (2.0 * 50.0 * wsx)).abs() < 1e-15);
        assert_eq!(xsy, Params::default().xi_s);
    }

    #[test]
    fn a_machine_key_beside_the_parameter_it_sets_is_refused_naming_both() {
        for (key, model) in MACHINE_KEYS {
            let e = params_with(&pairs(&[(key, 1.0), (model, 1.0)])).unwrap_err();
            let text = e.to_string();
            assert!(text.contains(key) && text.contains(model), "{text}");
        }
    }

    #[test]
    fn machine_keys_out_of_range_are_refused_naming_the_key() {
        for (key, bad) in [
            ("k_r", 0.0),
            ("k_s", -1.0),
            ("k_ry", f64::INFINITY),
            ("c_sx", -2.0),
            ("c_r", -1.0),
            ("unbalance", f64::NAN),
        ] {
            let text = params_with(&pairs(&[(key, bad)])).unwrap_err().to_string();
            assert!(text.contains(key), "{text}");
        }
        let text = params_with(&pairs(&[("stiffness", 1.0)]))
            .unwrap_err()
            .to_string();
        assert!(
            text.contains("valid names") && text.contains("k_r"),
            "{text}"
        );
    }
}
