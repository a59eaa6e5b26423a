//! The model's parameters (docs/model.md 4 and 7, docs/parameters.md): the article's
//! Table 1 as `Default`, the machine variants beside it (supports stiffer in one
//! direction than the other, a stator set off the bearing axis), their names, units,
//! ranges and the rest state they give.

use crate::error::{Error, Result};
use crate::model::{STATE_DIM, State, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S};
use serde::{Deserialize, Serialize};

/// Model parameters. `Default` is the article's Table 1 (after Demailly), docs/model.md 4.
///
/// The rotor speed `W` is not a parameter here: it is the control parameter of every
/// study and is passed alongside.
///
/// The isotropic frequencies and damping ratios (`omega_r`, `xi_r`, `omega_s`, `xi_s`)
/// mean both directions; a directional one (`omega_rx`, ..., `xi_sy`) given replaces
/// its direction's (docs/model.md 7). Unset directional fields and a zero offset are
/// left out of files, so the article's model reads and writes as it always did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Rotor natural frequency w_r = sqrt(k_r/m_r) [rad/s].
    pub omega_r: f64,
    /// Stator natural frequency w_s = sqrt(k_s/m_s) [rad/s].
    pub omega_s: f64,
    /// Rotor damping ratio xi_r = c_r / (2 sqrt(k_r m_r)) [-].
    pub xi_r: f64,
    /// Stator damping ratio xi_s [-].
    pub xi_s: f64,
    /// Radial rotor-stator gap [m].
    pub delta: f64,
    /// Coulomb friction coefficient at the contact [-].
    pub mu: f64,
    /// Rotor mass [kg].
    pub m_r: f64,
    /// Stator mass [kg].
    pub m_s: f64,
    /// Mass eccentricity of the rotor [m].
    pub e: f64,
    /// Contact (penalty) stiffness [N/m].
    pub k_c: f64,
    /// Contact damping [N s/m]: a normal dashpot acting only in contact (g > 0), not in
    /// the article (default 0). The normal force on the rotor becomes the Kelvin-Voigt
    /// law k_c g + c_c dg/dt, pointing from the stator to the rotor centre; friction
    /// stays mu k_c g. Plain Kelvin-Voigt, not clamped: near the exit of a contact the
    /// dashpot can outweigh the spring and the normal force turn adhesive (pull), and the
    /// force jumps at g = 0 by c_c dg/dt, so the vector field is discontinuous there
    /// (see `lyapunov` for the saltation matrix this needs). Per unit mass, as the
    /// rest of the model: c_c / m_r on the rotor, c_c / m_s on the stator.
    pub c_c: f64,
    /// Local error bound of the article's variable-step scheme (docs/numerics.md, the article's scheme) [m].
    pub e_max: f64,
    /// Gravitational acceleration, acting in -y on both bodies [m/s^2].
    pub a_g: f64,
    /// Phase of the unbalance at t = 0 [rad].
    pub phi0: f64,
    /// Rotor natural frequency in x [rad/s]; `None`: `omega_r`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub omega_rx: Option<f64>,
    /// Rotor natural frequency in y [rad/s]; `None`: `omega_r`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub omega_ry: Option<f64>,
    /// Rotor damping ratio in x [-]; `None`: `xi_r`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub xi_rx: Option<f64>,
    /// Rotor damping ratio in y [-]; `None`: `xi_r`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub xi_ry: Option<f64>,
    /// Stator natural frequency in x [rad/s]; `None`: `omega_s`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub omega_sx: Option<f64>,
    /// Stator natural frequency in y [rad/s]; `None`: `omega_s`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub omega_sy: Option<f64>,
    /// Stator damping ratio in x [-]; `None`: `xi_s`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub xi_sx: Option<f64>,
    /// Stator damping ratio in y [-]; `None`: `xi_s`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub xi_sy: Option<f64>,
    /// x of the stator suspension's rest centre relative to the bearing axis [m]
    /// (misalignment, a seal set off-centre); the gap is measured from the stator's
    /// centre wherever the stator is.
    #[serde(skip_serializing_if = "is_zero")]
    pub o_x: f64,
    /// y of the stator suspension's rest centre [m] (before gravity's sag).
    #[serde(skip_serializing_if = "is_zero")]
    pub o_y: f64,
    /// Exponent n of the contact law k_c g^n [-]: 1 the linear penalty spring, 3/2
    /// Hertz's point contact (Johnson 1985), 1 to 3 in steps of 1/2 (products and one
    /// square root, bit for bit the same on every GPU). `k_c` is then in N/m^n.
    #[serde(skip_serializing_if = "is_one")]
    pub n_c: f64,
    /// Hunt-Crossley contact damping alpha [s/m]: the normal force becomes
    /// k_c g^n (1 + 3/2 alpha dg/dt), zero at the moment of touching, with a coefficient
    /// of restitution e = 1 - alpha v_in for low impact speeds v_in (Hunt and Crossley
    /// 1975). 0: none. Friction stays mu k_c g^n.
    #[serde(skip_serializing_if = "is_zero")]
    pub alpha_c: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn is_one(v: &f64) -> bool {
    *v == 1.0
}

impl Default for Params {
    fn default() -> Self {
        Params {
            omega_r: 140.0,
            omega_s: 540.0,
            xi_r: 0.02,
            xi_s: 0.05,
            delta: 0.006,
            mu: 0.0,
            m_r: 50.0,
            m_s: 50.0,
            e: 0.001,
            k_c: 1e8,
            c_c: 0.0,
            e_max: 1e-9,
            a_g: 9.81,
            phi0: 0.0,
            omega_rx: None,
            omega_ry: None,
            xi_rx: None,
            xi_ry: None,
            omega_sx: None,
            omega_sy: None,
            xi_sx: None,
            xi_sy: None,
            o_x: 0.0,
            o_y: 0.0,
            n_c: 1.0,
            alpha_c: 0.0,
        }
    }
}

/// Symbol, unit and meaning of a parameter by name.
fn describe(name: &str) -> (&'static str, &'static str, &'static str) {
    match name {
        "omega_r" => ("w_r", "rad/s", "rotor natural frequency sqrt(k_r / m_r)"),
        "omega_s" => ("w_s", "rad/s", "stator natural frequency sqrt(k_s / m_s)"),
        "xi_r" => ("xi_r", "-", "rotor damping ratio"),
        "xi_s" => ("xi_s", "-", "stator damping ratio"),
        "delta" => ("delta", "m", "radial rotor-stator gap"),
        "mu" => ("mu", "-", "Coulomb friction coefficient at the contact"),
        "m_r" => ("m_r", "kg", "rotor mass"),
        "m_s" => ("m_s", "kg", "stator mass"),
        "e" => ("e", "m", "mass eccentricity of the rotor"),
        "k_c" => ("k_c", "N/m", "contact (penalty) stiffness"),
        "c_c" => ("c_c", "N s/m", "contact damping, in contact only"),
        "e_max" => (
            "E_max",
            "m",
            "error bound of the article's variable-step scheme",
        ),
        "a_g" => ("a_g", "m/s^2", "gravity, in -y on both bodies"),
        "phi0" => ("phi0", "rad", "phase of the unbalance at t = 0"),
        "omega_rx" => (
            "w_rx",
            "rad/s",
            "rotor natural frequency in x (omega_r when unset)",
        ),
        "omega_ry" => (
            "w_ry",
            "rad/s",
            "rotor natural frequency in y (omega_r when unset)",
        ),
        "xi_rx" => ("xi_rx", "-", "rotor damping ratio in x (xi_r when unset)"),
        "xi_ry" => ("xi_ry", "-", "rotor damping ratio in y (xi_r when unset)"),
        "omega_sx" => (
            "w_sx",
            "rad/s",
            "stator natural frequency in x (omega_s when unset)",
        ),
        "omega_sy" => (
            "w_sy",
            "rad/s",
            "stator natural frequency in y (omega_s when unset)",
        ),
        "xi_sx" => ("xi_sx", "-", "stator damping ratio in x (xi_s when unset)"),
        "xi_sy" => ("xi_sy", "-", "stator damping ratio in y (xi_s when unset)"),
        "o_x" => (
            "o_x",
            "m",
            "x of the stator's rest centre off the bearing axis",
        ),
        "o_y" => (
            "o_y",
            "m",
            "y of the stator's rest centre off the bearing axis",
        ),
        "n_c" => (
            "n",
            "-",
            "exponent of the contact law k_c g^n (1 linear, 1.5 Hertz)",
        ),
        "alpha_c" => (
            "alpha",
            "s/m",
            "Hunt-Crossley contact damping, in contact only",
        ),
        _ => ("?", "-", "unknown parameter"),
    }
}

/// Allowed range of a field, for validation and error messages.
#[derive(Clone, Copy)]
enum Range {
    Positive,
    NonNegative,
    Finite,
    /// 1, 1.5, 2, 2.5 or 3 (a contact law's exponent).
    HalfSteps1To3,
}

impl Range {
    /// The rule as an error message and the parameter table say it.
    fn allowed(self) -> &'static str {
        match self {
            Range::Positive => "must be finite and > 0",
            Range::NonNegative => "must be finite and >= 0",
            Range::Finite => "must be finite",
            Range::HalfSteps1To3 => "must be 1, 1.5, 2, 2.5 or 3",
        }
    }

    fn admits(self, v: f64) -> bool {
        v.is_finite()
            && match self {
                Range::Positive => v > 0.0,
                Range::NonNegative => v >= 0.0,
                Range::Finite => true,
                Range::HalfSteps1To3 => (1.0..=3.0).contains(&v) && (2.0 * v).fract() == 0.0,
            }
    }
}

/// A parameter's storage: a value, or a directional override that falls back on its
/// isotropic parameter.
enum Slot<'a> {
    Value(&'a mut f64),
    Directional(&'a mut Option<f64>, f64),
}

/// What a user needs to know of one model parameter: its name (the TOML key and the
/// `--param` name), its symbol, its SI unit, its default and its allowed range
/// (docs/parameters.md holds the same table).
#[derive(Clone, Debug, Serialize)]
pub struct ParamInfo {
    /// The TOML key and `--param` name.
    pub name: &'static str,
    /// The symbol in the equations (docs/model.md).
    pub symbol: &'static str,
    /// SI unit ("-" for a ratio).
    pub unit: &'static str,
    /// Table 1's value (a directional parameter's: its isotropic one's).
    pub default: f64,
    /// The allowed range, as [`Params::validate`]'s errors say it.
    pub allowed: &'static str,
    /// What it is, in a few words.
    pub meaning: &'static str,
}

impl Params {
    /// Names of the article's parameters, in declaration order (the TOML keys and
    /// `--param` names; the columns of `params.npy`).
    pub const FIELDS: [&'static str; 14] = [
        "omega_r", "omega_s", "xi_r", "xi_s", "delta", "mu", "m_r", "m_s", "e", "k_c", "c_c",
        "e_max", "a_g", "phi0",
    ];

    /// Names of the machine variants' parameters (docs/model.md 7): directional
    /// frequencies and damping ratios, the stator's offset, then the contact law.
    pub const VARIANT_FIELDS: [&'static str; 12] = [
        "omega_rx", "omega_ry", "xi_rx", "xi_ry", "omega_sx", "omega_sy", "xi_sx", "xi_sy", "o_x",
        "o_y", "n_c", "alpha_c",
    ];

    /// Every parameter name: [`Params::FIELDS`], then [`Params::VARIANT_FIELDS`].
    pub fn names() -> impl Iterator<Item = &'static str> {
        Params::FIELDS.into_iter().chain(Params::VARIANT_FIELDS)
    }

    /// Whether `name` is a parameter name.
    pub fn is_name(name: &str) -> bool {
        Params::names().any(|n| n == name)
    }

    /// The names as one comma-separated list, for messages.
    pub fn names_list() -> String {
        Params::names().collect::<Vec<_>>().join(", ")
    }

    fn slot(&mut self, name: &str) -> Option<(Slot<'_>, Range)> {
        use Range::*;
        use Slot::{Directional as D, Value as V};
        let (wr, xr, ws, xs) = (self.omega_r, self.xi_r, self.omega_s, self.xi_s);
        Some(match name {
            "omega_r" => (V(&mut self.omega_r), Positive),
            "omega_s" => (V(&mut self.omega_s), Positive),
            "xi_r" => (V(&mut self.xi_r), NonNegative),
            "xi_s" => (V(&mut self.xi_s), NonNegative),
            "delta" => (V(&mut self.delta), Positive),
            "mu" => (V(&mut self.mu), NonNegative),
            "m_r" => (V(&mut self.m_r), Positive),
            "m_s" => (V(&mut self.m_s), Positive),
            "e" => (V(&mut self.e), NonNegative),
            "k_c" => (V(&mut self.k_c), Positive),
            "c_c" => (V(&mut self.c_c), NonNegative),
            "e_max" => (V(&mut self.e_max), Positive),
            "a_g" => (V(&mut self.a_g), Finite),
            "phi0" => (V(&mut self.phi0), Finite),
            "omega_rx" => (D(&mut self.omega_rx, wr), Positive),
            "omega_ry" => (D(&mut self.omega_ry, wr), Positive),
            "xi_rx" => (D(&mut self.xi_rx, xr), NonNegative),
            "xi_ry" => (D(&mut self.xi_ry, xr), NonNegative),
            "omega_sx" => (D(&mut self.omega_sx, ws), Positive),
            "omega_sy" => (D(&mut self.omega_sy, ws), Positive),
            "xi_sx" => (D(&mut self.xi_sx, xs), NonNegative),
            "xi_sy" => (D(&mut self.xi_sy, xs), NonNegative),
            "o_x" => (V(&mut self.o_x), Finite),
            "o_y" => (V(&mut self.o_y), Finite),
            "n_c" => (V(&mut self.n_c), HalfSteps1To3),
            "alpha_c" => (V(&mut self.alpha_c), NonNegative),
            _ => return None,
        })
    }

    /// Every parameter's name, symbol, unit, default and allowed range, in
    /// [`Params::names`] order.
    pub fn info() -> Vec<ParamInfo> {
        let d = Params::default();
        Params::names()
            .map(|name| {
                let (symbol, unit, meaning) = describe(name);
                let range = d.clone().slot(name).expect("names() are known").1;
                ParamInfo {
                    name,
                    symbol,
                    unit,
                    default: d.get(name).expect("names() are known"),
                    allowed: range.allowed(),
                    meaning,
                }
            })
            .collect()
    }

    /// The SI unit of a parameter ("-" for a ratio or an unknown name).
    pub fn unit(name: &str) -> &'static str {
        describe(name).1
    }

    /// One parameter by name (as in the TOML file), `None` for an unknown name. A
    /// directional parameter that is not set reads as its isotropic one.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.clone().slot(name).map(|(s, _)| match s {
            Slot::Value(v) => *v,
            Slot::Directional(v, iso) => v.unwrap_or(iso),
        })
    }

    /// Sets one parameter by name (as in the TOML file), e.g. `set("k_c", 2e8)`.
    /// Unknown names are an error listing the valid ones. The value is checked by
    /// [`Params::validate`], not here.
    pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
        match self.slot(name) {
            Some((Slot::Value(v), _)) => *v = value,
            Some((Slot::Directional(v, _), _)) => *v = Some(value),
            None => {
                return Err(Error::invalid(
                    name,
                    value,
                    format!("unknown parameter; valid names: {}", Params::names_list()),
                ));
            }
        }
        Ok(())
    }

    /// Whether this is the article's model: every variant parameter
    /// ([`Params::VARIANT_FIELDS`]) at its default, an unset directional one included
    /// (the model of docs/model.md 2 as printed there).
    pub fn is_article_model(&self) -> bool {
        let article = Params::default();
        Params::VARIANT_FIELDS.iter().all(|&name| {
            let mut mine = self.clone();
            let mut theirs = article.clone();
            match (mine.slot(name), theirs.slot(name)) {
                (Some((Slot::Value(a), _)), Some((Slot::Value(b), _))) => *a == *b,
                (Some((Slot::Directional(a, _), _)), Some(_)) => a.is_none(),
                _ => unreachable!("VARIANT_FIELDS are known names"),
            }
        })
    }

    /// Checks every parameter against its allowed range (the error names the field, its
    /// value and the range), then that the rest state exists ([`Params::rest_state`]).
    pub fn validate(&self) -> Result<()> {
        self.validate_fields()?;
        self.rest_state().map(|_| ())
    }

    fn validate_fields(&self) -> Result<()> {
        for name in Params::names() {
            let (_, range) = self.clone().slot(name).expect("names() are known");
            let v = self.get(name).expect("names() are known");
            if !range.admits(v) {
                return Err(Error::invalid(name, v, range.allowed()));
            }
        }
        Ok(())
    }

    /// Loads parameters from a TOML file; absent keys keep the Table 1 defaults,
    /// unknown keys are an error. The result is validated.
    pub fn from_toml_file(path: &std::path::Path) -> Result<Params> {
        let p = Params::read_toml_file(path)?;
        p.validate()?;
        Ok(p)
    }

    /// [`Params::from_toml_file`] without [`Params::validate`]: for callers that apply
    /// overrides (`--param`) first and validate the final set, so a config value that
    /// an override replaces is never judged. Read and parse errors are still errors.
    pub fn read_toml_file(path: &std::path::Path) -> Result<Params> {
        use std::io::Read;
        let bad = |message: String| Error::Config {
            path: path.to_path_buf(),
            message,
        };
        // A parameter file is a few hundred bytes; reading stops past the limit, so a
        // device such as /dev/zero or a huge file is refused, not read into memory.
        let mut text = String::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(MAX_CONFIG_BYTES + 1).read_to_string(&mut text))
            .map_err(|e| bad(e.to_string()))?;
        if text.len() as u64 > MAX_CONFIG_BYTES {
            return Err(bad(format!(
                "larger than {} KiB; a parameter file holds at most the {} parameter keys",
                MAX_CONFIG_BYTES / 1024,
                Params::names().count()
            )));
        }
        let table: toml::Table = toml::from_str(&text).map_err(|e| bad(e.to_string()))?;
        let mut pairs = Vec::with_capacity(table.len());
        for (key, value) in table {
            let v = match value {
                toml::Value::Float(v) => v,
                toml::Value::Integer(v) => v as f64,
                other => {
                    return Err(bad(format!(
                        "`{key}` = {other}: every value is a number (SI units)"
                    )));
                }
            };
            pairs.push((key, v));
        }
        let mut p = Params::default();
        crate::inputs::apply_pairs(&mut p, &pairs).map_err(|e| bad(e.to_string()))?;
        Ok(p)
    }

    /// The rotor's natural frequencies in x and y [rad/s].
    pub fn omega_r_xy(&self) -> (f64, f64) {
        (
            self.omega_rx.unwrap_or(self.omega_r),
            self.omega_ry.unwrap_or(self.omega_r),
        )
    }

    /// The rotor's damping ratios in x and y.
    pub fn xi_r_xy(&self) -> (f64, f64) {
        (
            self.xi_rx.unwrap_or(self.xi_r),
            self.xi_ry.unwrap_or(self.xi_r),
        )
    }

    /// The stator's natural frequencies in x and y [rad/s].
    pub fn omega_s_xy(&self) -> (f64, f64) {
        (
            self.omega_sx.unwrap_or(self.omega_s),
            self.omega_sy.unwrap_or(self.omega_s),
        )
    }

    /// The stator's damping ratios in x and y.
    pub fn xi_s_xy(&self) -> (f64, f64) {
        (
            self.xi_sx.unwrap_or(self.xi_s),
            self.xi_sy.unwrap_or(self.xi_s),
        )
    }

    /// Rotor shaft stiffness k_r = m_r w_r^2 [N/m] (the isotropic one).
    pub fn k_r(&self) -> f64 {
        self.m_r * self.omega_r * self.omega_r
    }

    /// Stator suspension stiffness k_s = m_s w_s^2 [N/m] (the isotropic one).
    pub fn k_s(&self) -> f64 {
        self.m_s * self.omega_s * self.omega_s
    }

    /// The rest state without contact: each oscillator at its spring's rest under
    /// gravity, the stator about its offset centre (docs/model.md 4 and 7).
    pub fn free_rest_state(&self) -> State {
        let ((_, wry), (_, wsy)) = (self.omega_r_xy(), self.omega_s_xy());
        let mut x = [0.0; STATE_DIM];
        x[Y_R] = -self.a_g / (wry * wry);
        // `o + 0.0`: a centred stator's rest is +0 and -a_g / w^2 exactly, as ever.
        x[X_S] = self.o_x + 0.0;
        x[Y_S] = self.o_y + -self.a_g / (wsy * wsy);
        x
    }

    /// The static equilibrium, the default initial state: [`Params::free_rest_state`]
    /// where the bodies do not touch there, else the equilibrium in contact that an
    /// offset stator presses the rotor into ([`Params::rest_state`]); the free rest
    /// state where that does not exist (a set [`Params::validate`] refuses).
    pub fn static_equilibrium(&self) -> State {
        self.rest_state().unwrap_or_else(|_| self.free_rest_state())
    }

    /// The static equilibrium (see [`Params::static_equilibrium`]): in contact, Newton's
    /// method on the four positions from the free rest state, with the analytic
    /// stiffness of the contact. Refused, naming the offset, when the rotor would rest
    /// pressed into the stator by more than a tenth of the gap: the penalty contact
    /// models a slight elastic overlap, not a stator set through the shaft.
    pub fn rest_state(&self) -> Result<State> {
        let free = self.free_rest_state();
        if crate::model::penetration(self.delta, &free) <= 0.0 {
            return Ok(free);
        }
        let refuse = |why: String| {
            Error::invalid(
                "o_x, o_y",
                format!("{}, {}", self.o_x, self.o_y),
                format!(
                    "{why}; the stator's offset must leave the rotor at rest within the gap \
                     delta = {} m, or pressed into it by at most delta / 10",
                    self.delta
                ),
            )
        };
        let x = newton_rest(self).ok_or_else(|| refuse("no static equilibrium found".into()))?;
        let g = crate::model::penetration(self.delta, &x);
        if g > self.delta / 10.0 {
            return Err(refuse(format!(
                "the rotor rests pressed {g:.3e} m into the stator"
            )));
        }
        Ok(x)
    }
}

/// Newton's method for the rest state with contact on: the accelerations as functions
/// of the four positions (velocities zero, no unbalance) and their Jacobian.
fn newton_rest(p: &Params) -> Option<State> {
    use nalgebra::{Matrix4, Vector4};
    const POS: [usize; 4] = [X_R, Y_R, X_S, Y_S];
    const ACC: [usize; 4] = [VX_R, VY_R, VX_S, VY_S];
    let c = crate::model::Coeffs::<f64>::new(p, 0.0);
    let mut x = p.free_rest_state();
    for _ in 0..100 {
        let f = crate::model::rhs_frozen(&c, &x, 0.0, 0.0, true);
        let j = crate::model::jacobian_frozen(&c, &x, true);
        let r = Vector4::from_fn(|i, _| f[ACC[i]]);
        let a = Matrix4::from_fn(|i, k| j[ACC[i]][POS[k]]);
        let dx = a.lu().solve(&(-r))?;
        for (k, &i) in POS.iter().enumerate() {
            x[i] += dx[k];
        }
        if dx.amax() <= 1e-14 * p.delta {
            let g = crate::model::penetration(p.delta, &x);
            return (g > 0.0 && x.iter().all(|v| v.is_finite())).then_some(x);
        }
    }
    None
}

/// Largest `--config` file read [bytes].
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;
