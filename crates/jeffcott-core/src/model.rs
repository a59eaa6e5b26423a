//! The rotor-stator model of docs/model.md sections 1-3: parameters, state layout, the
//! corrected equations of motion, the contact force, the analytic Jacobian and the
//! energy. Pure functions; the `f64` entry points here are the reference that the
//! integrators and the GPU kernel are tested against.
//!
//! `penetration`, `contact_force_per_kc`, `contact_partials` and `rhs_frozen` are
//! mirrored, in that order, by `model.wgsl` beside this file (a part of the lane kernel):
//! keep in sync with it.

use crate::error::{Error, Result};
use crate::real::{Arith, Real};
use serde::{Deserialize, Serialize};

/// The WGSL mirror of the lane functions of this module (`model.wgsl`, beside this
/// file), a part of the lane kernel (`integrate::lane::WGSL_FILES`).
pub const WGSL: &str = include_str!("model.wgsl");

/// Number of state components.
pub const STATE_DIM: usize = 8;
/// A state vector in the order of docs/model.md 1: `[x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s]`.
pub type State = [f64; STATE_DIM];

/// Index of `x_r` in the state.
pub const X_R: usize = 0;
/// Index of `vx_r`.
pub const VX_R: usize = 1;
/// Index of `y_r`.
pub const Y_R: usize = 2;
/// Index of `vy_r`.
pub const VY_R: usize = 3;
/// Index of `x_s`.
pub const X_S: usize = 4;
/// Index of `vx_s`.
pub const VX_S: usize = 5;
/// Index of `y_s`.
pub const Y_S: usize = 6;
/// Index of `vy_s`.
pub const VY_S: usize = 7;

/// Names of the state components, in state order (used by the CLI and in files).
pub const COORD_NAMES: [&str; STATE_DIM] =
    ["x_r", "vx_r", "y_r", "vy_r", "x_s", "vx_s", "y_s", "vy_s"];

/// Units of the state components, in state order.
pub const COORD_UNITS: [&str; STATE_DIM] = ["m", "m/s", "m", "m/s", "m", "m/s", "m", "m/s"];

/// Index of a state component by name (`"vx_s"` -> 5).
pub fn coord_index(name: &str) -> Option<usize> {
    COORD_NAMES.iter().position(|n| *n == name)
}

/// Model parameters. `Default` is the article's Table 1 (after Demailly), docs/model.md 4.
///
/// The rotor speed `W` is not a parameter here: it is the control parameter of every
/// study and is passed alongside.
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
        _ => ("?", "-", "unknown parameter"),
    }
}

/// Allowed range of a field, for validation and error messages.
#[derive(Clone, Copy)]
enum Range {
    Positive,
    NonNegative,
    Finite,
}

impl Range {
    /// The rule as an error message and the parameter table say it.
    fn allowed(self) -> &'static str {
        match self {
            Range::Positive => "must be finite and > 0",
            Range::NonNegative => "must be finite and >= 0",
            Range::Finite => "must be finite",
        }
    }
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
    /// Table 1's value.
    pub default: f64,
    /// The allowed range, as [`Params::validate`]'s errors say it.
    pub allowed: &'static str,
    /// What it is, in a few words.
    pub meaning: &'static str,
}

impl Params {
    /// Names of all fields, in declaration order (the TOML keys and `--param` names).
    pub const FIELDS: [&'static str; 14] = [
        "omega_r", "omega_s", "xi_r", "xi_s", "delta", "mu", "m_r", "m_s", "e", "k_c", "c_c",
        "e_max", "a_g", "phi0",
    ];

    fn field_mut(&mut self, name: &str) -> Option<(&mut f64, Range)> {
        use Range::*;
        Some(match name {
            "omega_r" => (&mut self.omega_r, Positive),
            "omega_s" => (&mut self.omega_s, Positive),
            "xi_r" => (&mut self.xi_r, NonNegative),
            "xi_s" => (&mut self.xi_s, NonNegative),
            "delta" => (&mut self.delta, Positive),
            "mu" => (&mut self.mu, NonNegative),
            "m_r" => (&mut self.m_r, Positive),
            "m_s" => (&mut self.m_s, Positive),
            "e" => (&mut self.e, NonNegative),
            "k_c" => (&mut self.k_c, Positive),
            "c_c" => (&mut self.c_c, NonNegative),
            "e_max" => (&mut self.e_max, Positive),
            "a_g" => (&mut self.a_g, Finite),
            "phi0" => (&mut self.phi0, Finite),
            _ => return None,
        })
    }

    /// Every parameter's name, symbol, unit, default and allowed range, in
    /// [`Params::FIELDS`] order.
    pub fn info() -> Vec<ParamInfo> {
        let d = Params::default();
        Params::FIELDS
            .iter()
            .map(|&name| {
                let (symbol, unit, meaning) = describe(name);
                let (default, range) = d
                    .clone()
                    .field_mut(name)
                    .map(|(v, r)| (*v, r))
                    .expect("FIELDS lists only known names");
                ParamInfo {
                    name,
                    symbol,
                    unit,
                    default,
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

    /// One field by name (as in the TOML file), `None` for an unknown name.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.clone().field_mut(name).map(|(v, _)| *v)
    }

    /// Sets one field by name (as in the TOML file), e.g. `set("k_c", 2e8)`.
    /// Unknown names are an error listing the valid ones. The value is checked by
    /// [`Params::validate`], not here.
    pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
        match self.field_mut(name) {
            Some((f, _)) => {
                *f = value;
                Ok(())
            }
            None => Err(Error::invalid(
                name,
                value,
                format!(
                    "unknown parameter; valid names: {}",
                    Params::FIELDS.join(", ")
                ),
            )),
        }
    }

    /// Checks every field against its allowed range; the error names the field, its
    /// value and the range.
    pub fn validate(&self) -> Result<()> {
        let mut p = self.clone();
        for name in Params::FIELDS {
            let (v, range) = p.field_mut(name).expect("FIELDS lists only known names");
            let v = *v;
            let ok = v.is_finite()
                && match range {
                    Range::Positive => v > 0.0,
                    Range::NonNegative => v >= 0.0,
                    Range::Finite => true,
                };
            if !ok {
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
                "larger than {} KiB; a parameter file holds at most the {} keys of Table 1",
                MAX_CONFIG_BYTES / 1024,
                Params::FIELDS.len()
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

    /// Rotor shaft stiffness k_r = m_r w_r^2 [N/m].
    pub fn k_r(&self) -> f64 {
        self.m_r * self.omega_r * self.omega_r
    }

    /// Stator suspension stiffness k_s = m_s w_s^2 [N/m].
    pub fn k_s(&self) -> f64 {
        self.m_s * self.omega_s * self.omega_s
    }

    /// The default initial state: static equilibrium without contact (docs/model.md 4).
    pub fn static_equilibrium(&self) -> State {
        let mut x = [0.0; STATE_DIM];
        x[Y_R] = -self.a_g / (self.omega_r * self.omega_r);
        x[Y_S] = -self.a_g / (self.omega_s * self.omega_s);
        x
    }
}

/// Largest `--config` file read [bytes].
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;

/// Largest rotor speed accepted [rad/s] (about 955,000 rpm): two orders of magnitude
/// above the article's range (130..141 rad/s) and the rotor's natural frequency
/// (140 rad/s), and far beyond any real rotor; above it T = 2 pi / W and the unbalance
/// e W^2 leave every regime the model describes, and speeds such as 1e300 rad/s only
/// produce overflowing forces.
pub const MAX_OMEGA: f64 = 1e5;

/// The allowed range of a rotor speed, for messages.
pub const OMEGA_RANGE: &str = "rotor speed must be finite, > 0 and <= 1e5 rad/s";

/// Checks a rotor speed W [rad/s]: finite, > 0, <= [`MAX_OMEGA`].
pub fn validate_omega(omega: f64) -> Result<()> {
    if omega.is_finite() && omega > 0.0 && omega <= MAX_OMEGA {
        Ok(())
    } else {
        Err(Error::invalid("omega", short_number(omega), OMEGA_RANGE))
    }
}

/// A number for messages: as typed for ordinary magnitudes, in exponent form for huge
/// or tiny ones (`1e300`, not its 301 digits).
pub fn short_number(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// The coefficients of the equations of motion per unit mass (docs/model.md 2) for one rotor
/// speed, in the lane's precision. Computed once in `f64` on the host and rounded, so
/// the CPU and GPU lanes see identical constants.
///
/// `#[repr(C)]` with every field of one type, so the struct has no padding and is the
/// GPU's `Coeffs` as it stands (`integrate/lane_buffers.wgsl`; jeffcott-gpu's layout
/// test checks every offset against naga's): the lane constants are uploaded without a
/// second struct of the same fields.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Coeffs<R> {
    /// w_r^2 [1/s^2].
    pub wr2: R,
    /// 2 xi_r w_r [1/s].
    pub dr: R,
    /// w_s^2 [1/s^2].
    pub ws2: R,
    /// 2 xi_s w_s [1/s].
    pub ds: R,
    /// Unbalance acceleration amplitude e W^2 [m/s^2].
    pub unbalance: R,
    /// Gravity a_g [m/s^2].
    pub a_g: R,
    /// k_c / m_r [1/s^2].
    pub kc_mr: R,
    /// k_c / m_s [1/s^2].
    pub kc_ms: R,
    /// Friction coefficient mu.
    pub mu: R,
    /// Gap delta [m].
    pub delta: R,
    /// Contact damping over contact stiffness c_c / k_c [s] (0 without damping).
    pub tau_c: R,
}

// SAFETY: `Coeffs<R>` is `#[repr(C)]` and all its fields are `R`, so it has the size of
// `[R; 11]`, no padding, and every bit pattern of it is valid when every bit pattern of
// `R` is (`R: Pod`); zeroed it is all-zero `R`s (`R: Zeroable`).
unsafe impl<R: bytemuck::Zeroable> bytemuck::Zeroable for Coeffs<R> {}
// SAFETY: as above; `R: Pod` also gives `Copy + 'static`.
unsafe impl<R: bytemuck::Pod> bytemuck::Pod for Coeffs<R> {}

impl<R: Real> Coeffs<R> {
    /// Derives the coefficients from the parameters and the rotor speed.
    pub fn new(p: &Params, omega: f64) -> Self {
        Coeffs {
            wr2: R::lit(p.omega_r * p.omega_r),
            dr: R::lit(2.0 * p.xi_r * p.omega_r),
            ws2: R::lit(p.omega_s * p.omega_s),
            ds: R::lit(2.0 * p.xi_s * p.omega_s),
            unbalance: R::lit(p.e * omega * omega),
            a_g: R::lit(p.a_g),
            kc_mr: R::lit(p.k_c / p.m_r),
            kc_ms: R::lit(p.k_c / p.m_s),
            mu: R::lit(p.mu),
            delta: R::lit(p.delta),
            tau_c: R::lit(p.c_c / p.k_c),
        }
    }
}

impl<R: Copy, const B: usize> Coeffs<[R; B]> {
    /// The coefficients of `B` lanes, structure-of-arrays (each field one value per
    /// lane), so a loop over the lanes vectorises (`integrate::batch`).
    #[inline(always)]
    pub fn transpose(lanes: &[Coeffs<R>; B]) -> Self {
        // A plain loop, not `std::array::from_fn` with a getter per field: out of line
        // (the batch stepper's pack loop, perf) those were compiled without the batch
        // code's instruction set.
        const { assert!(B > 0, "a batch holds at least one lane") };
        let c0 = &lanes[0];
        let mut t = Coeffs {
            wr2: [c0.wr2; B],
            dr: [c0.dr; B],
            ws2: [c0.ws2; B],
            ds: [c0.ds; B],
            unbalance: [c0.unbalance; B],
            a_g: [c0.a_g; B],
            kc_mr: [c0.kc_mr; B],
            kc_ms: [c0.kc_ms; B],
            mu: [c0.mu; B],
            delta: [c0.delta; B],
            tau_c: [c0.tau_c; B],
        };
        #[allow(clippy::needless_range_loop)]
        for l in 1..B {
            let c = &lanes[l];
            t.wr2[l] = c.wr2;
            t.dr[l] = c.dr;
            t.ws2[l] = c.ws2;
            t.ds[l] = c.ds;
            t.unbalance[l] = c.unbalance;
            t.a_g[l] = c.a_g;
            t.kc_mr[l] = c.kc_mr;
            t.kc_ms[l] = c.kc_ms;
            t.mu[l] = c.mu;
            t.delta[l] = c.delta;
            t.tau_c[l] = c.tau_c;
        }
        t
    }

    /// Lane `l`'s coefficients.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Coeffs<R> {
        Coeffs {
            wr2: self.wr2[l],
            dr: self.dr[l],
            ws2: self.ws2[l],
            ds: self.ds[l],
            unbalance: self.unbalance[l],
            a_g: self.a_g[l],
            kc_mr: self.kc_mr[l],
            kc_ms: self.kc_ms[l],
            mu: self.mu[l],
            delta: self.delta[l],
            tau_c: self.tau_c[l],
        }
    }
}

/// The rotor's displacement and velocity relative to the stator, [dx, dy, dvx, dvy]
/// (docs/model.md 2).
#[inline(always)]
pub fn relative_motion<T: Arith>(x: &[T; STATE_DIM]) -> [T; 4] {
    [
        x[X_R] - x[X_S],
        x[Y_R] - x[Y_S],
        x[VX_R] - x[VX_S],
        x[VY_R] - x[VY_S],
    ]
}

/// Penetration g = |d| - delta with d the rotor centre relative to the stator centre
/// (docs/model.md 2). Contact is `g > 0`.
#[inline(always)]
pub fn penetration<R: Real>(delta: R, x: &[R; STATE_DIM]) -> R {
    let [dx, dy, _, _] = relative_motion(x);
    (dx * dx + dy * dy).sqrt() - delta
}

/// Contact force on the rotor divided by k_c, as a function of the relative position
/// d = (dx, dy) and relative velocity (dvx, dvy), evaluated with the contact formula
/// whatever the sign of g (the caller decides whether contact is on; docs/numerics.md holds
/// the contact state fixed over a step, which needs this analytic continuation).
/// Returns (fx, fy) in metres.
///
/// F/k_c = -(g/r + tau_c (d . v)/r^2) d + mu (g/r) (d_y, -d_x), with tau_c = c_c/k_c:
/// the normal part (k_c g + c_c dg/dt, dg/dt = (d . v)/r) points from the stator to the
/// rotor centre and the friction part follows the article's convention (its eq. 5 and
/// Figure 2, corrected so friction is mu times the spring's normal force). With
/// tau_c = 0 this is bit for bit the undamped law (the added term is an exact zero).
#[inline(always)]
pub fn contact_force_per_kc<R: Real>(
    delta: R,
    mu: R,
    tau_c: R,
    dx: R,
    dy: R,
    dvx: R,
    dvy: R,
) -> (R, R) {
    // The guard written out rather than `concentric` before a shared branch-free body
    // (as `contact_partials` has it): with that form the batch stepper's per-lane force
    // was compiled into a copy through memory and ran 25 % slower (docs/performance.md,
    // "Whole-batch tangent steps").
    let r2 = dx * dx + dy * dy;
    let r = r2.sqrt();
    if r <= R::lit(0.0) {
        // Concentric bodies: the normal direction is undefined and the gap is -delta,
        // far outside contact; no continuation is meaningful.
        return (R::lit(0.0), R::lit(0.0));
    }
    let s = (r - delta) / r;
    let nrm = s + tau_c * ((dx * dvx + dy * dvy) / r2);
    (-nrm * dx + mu * s * dy, -nrm * dy - mu * s * dx)
}

/// Whether the bodies are concentric (|d| = sqrt(dx^2 + dy^2) <= 0), where the contact
/// partials are zero ([`contact_partials`]' guard, [`contact_force_per_kc`]'s too).
#[inline(always)]
pub fn concentric<R: Real>(dx: R, dy: R) -> bool {
    (dx * dx + dy * dy).sqrt() <= R::lit(0.0)
}

/// Partial derivatives of [`contact_force_per_kc`] (fx, fy) with respect to
/// (dx, dy, dvx, dvy), in the order
/// `[fx_dx, fx_dy, fx_dvx, fx_dvy, fy_dx, fy_dy, fy_dvx, fy_dvy]`: the contact block of
/// the Jacobian, shared by [`jacobian`] and the lanes' variational equations.
///
/// Keep in sync with `contact_partials` in `model.wgsl`.
#[inline(always)]
pub fn contact_partials<R: Real>(c: &Coeffs<R>, x: &[R; STATE_DIM]) -> [R; 8] {
    let [dx, dy, _, _] = relative_motion(x);
    if concentric(dx, dy) {
        return [R::lit(0.0); 8];
    }
    contact_partials_off_centre(c, x)
}

/// [`contact_partials`] off the concentric position, branch-free, so a batch of lanes
/// (`integrate::wide::Wide`) computes it at once and keeps it where a lane is in contact
/// and not [`concentric`] (`integrate::batch`, the tangent step).
#[inline(always)]
pub fn contact_partials_off_centre<T: Arith>(c: &Coeffs<T>, x: &[T; STATE_DIM]) -> [T; 8] {
    let [dx, dy, dvx, dvy] = relative_motion(x);
    let r2 = dx * dx + dy * dy;
    let r = r2.root();
    let s = (r - c.delta) / r;
    let q = (dx * dvx + dy * dvy) / r2;
    let nrm = s + c.tau_c * q;
    // s = 1 - delta/r: ds/d(dx) = delta dx / r^3; q = (d . v)/r^2.
    let r3 = r2 * r;
    let (sx, sy) = (c.delta * dx / r3, c.delta * dy / r3);
    let two = T::splat(2.0);
    let nx = sx + c.tau_c * (dvx - two * q * dx) / r2;
    let ny = sy + c.tau_c * (dvy - two * q * dy) / r2;
    let nvx = c.tau_c * dx / r2;
    let nvy = c.tau_c * dy / r2;
    let mu = c.mu;
    [
        -nx * dx - nrm + mu * sx * dy,
        -ny * dx + mu * sy * dy + mu * s,
        -nvx * dx,
        -nvy * dx,
        -nx * dy - mu * sx * dx - mu * s,
        -ny * dy - nrm - mu * sy * dx,
        -nvx * dy,
        -nvy * dy,
    ]
}

/// Right-hand side of the corrected equations of motion (docs/model.md 2) with the contact
/// state given (`contact`) and the unbalance phasor (cos(Wt - phi0), sin(Wt - phi0))
/// given, so the caller chooses how the forcing is evaluated.
///
/// Keep in sync with `rhs_frozen` in `model.wgsl`.
#[inline(always)]
pub fn rhs_frozen<R: Real>(
    c: &Coeffs<R>,
    x: &[R; STATE_DIM],
    cos_phase: R,
    sin_phase: R,
    contact: bool,
) -> [R; STATE_DIM] {
    let (mut fx, mut fy) = (R::lit(0.0), R::lit(0.0));
    if contact {
        let [dx, dy, dvx, dvy] = relative_motion(x);
        (fx, fy) = contact_force_per_kc(c.delta, c.mu, c.tau_c, dx, dy, dvx, dvy);
    }
    rhs_with_force(c, x, cos_phase, sin_phase, fx, fy)
}

/// The right-hand side given the contact force per unit contact stiffness on the rotor
/// (`fx`, `fy`; zero out of contact): the one definition of the equations of motion on
/// the CPU, used by [`rhs_frozen`] and, lane by lane, by the batched stepper (which
/// computes the force branch-free and selects it per lane).
#[inline(always)]
pub fn rhs_with_force<R: Real>(
    c: &Coeffs<R>,
    x: &[R; STATE_DIM],
    cos_phase: R,
    sin_phase: R,
    fx: R,
    fy: R,
) -> [R; STATE_DIM] {
    [
        x[VX_R],
        -c.wr2 * x[X_R] - c.dr * x[VX_R] + c.unbalance * cos_phase + c.kc_mr * fx,
        x[VY_R],
        -c.wr2 * x[Y_R] - c.dr * x[VY_R] + c.unbalance * sin_phase - c.a_g + c.kc_mr * fy,
        x[VX_S],
        -c.ws2 * x[X_S] - c.ds * x[VX_S] - c.kc_ms * fx,
        x[VY_S],
        -c.ws2 * x[Y_S] - c.ds * x[VY_S] - c.a_g - c.kc_ms * fy,
    ]
}

/// The reference right-hand side dX/dt at time t (docs/model.md 2), `f64`, forcing from
/// `std` trigonometry, contact on exactly when g > 0.
pub fn rhs(p: &Params, omega: f64, t: f64, x: &State) -> State {
    let c = Coeffs::<f64>::new(p, omega);
    let phase = omega * t - p.phi0;
    let contact = penetration(p.delta, x) > 0.0;
    rhs_frozen(&c, x, phase.cos(), phase.sin(), contact)
}

/// The contact force on the rotor [N] (the stator receives the opposite force).
/// Zero when g <= 0.
pub fn contact_force(p: &Params, x: &State) -> (f64, f64) {
    if penetration(p.delta, x) > 0.0 {
        let c = Coeffs::<f64>::new(p, 0.0);
        let [dx, dy, dvx, dvy] = relative_motion(x);
        let (fx, fy) = contact_force_per_kc(c.delta, c.mu, c.tau_c, dx, dy, dvx, dvy);
        (p.k_c * fx, p.k_c * fy)
    } else {
        (0.0, 0.0)
    }
}

/// The analytic Jacobian d(rhs)/dX, 8x8, row-major (`jac[i][j]` = d f_i / d X_j), with the
/// contact state taken from g > 0 (on the switching surface g = 0 the one-sided
/// Jacobians differ; this returns the no-contact one there).
pub fn jacobian(p: &Params, x: &State) -> [[f64; STATE_DIM]; STATE_DIM] {
    let c = Coeffs::<f64>::new(p, 0.0);
    let mut j = [[0.0; STATE_DIM]; STATE_DIM];
    for (pos, vel) in [(X_R, VX_R), (Y_R, VY_R), (X_S, VX_S), (Y_S, VY_S)] {
        j[pos][vel] = 1.0;
    }
    j[VX_R][X_R] = -c.wr2;
    j[VX_R][VX_R] = -c.dr;
    j[VY_R][Y_R] = -c.wr2;
    j[VY_R][VY_R] = -c.dr;
    j[VX_S][X_S] = -c.ws2;
    j[VX_S][VX_S] = -c.ds;
    j[VY_S][Y_S] = -c.ws2;
    j[VY_S][VY_S] = -c.ds;
    if penetration(p.delta, x) > 0.0 {
        let pc = contact_partials(&c, x);
        // Rows of the accelerations: rotor +k_c/m_r f, stator -k_c/m_s f; columns through
        // d = rotor - stator (positions and velocities).
        for (row, scale, o) in [
            (VX_R, c.kc_mr, 0),
            (VX_S, -c.kc_ms, 0),
            (VY_R, c.kc_mr, 4),
            (VY_S, -c.kc_ms, 4),
        ] {
            for (k, (col_r, col_s)) in [(X_R, X_S), (Y_R, Y_S), (VX_R, VX_S), (VY_R, VY_S)]
                .into_iter()
                .enumerate()
            {
                let a = pc[o + k] * scale;
                j[row][col_r] += a;
                j[row][col_s] -= a;
            }
        }
    }
    j
}

/// Total mechanical energy [J]: kinetic, shaft and suspension springs, gravity (zero at
/// y = 0) and the contact potential k_c g^2 / 2 for g > 0. Conserved when xi_r = xi_s =
/// e = mu = c_c = 0 (docs/model.md 6).
pub fn energy(p: &Params, x: &State) -> f64 {
    let kinetic = 0.5 * p.m_r * (x[VX_R] * x[VX_R] + x[VY_R] * x[VY_R])
        + 0.5 * p.m_s * (x[VX_S] * x[VX_S] + x[VY_S] * x[VY_S]);
    let springs = 0.5 * p.k_r() * (x[X_R] * x[X_R] + x[Y_R] * x[Y_R])
        + 0.5 * p.k_s() * (x[X_S] * x[X_S] + x[Y_S] * x[Y_S]);
    let gravity = p.a_g * (p.m_r * x[Y_R] + p.m_s * x[Y_S]);
    let g = penetration(p.delta, x);
    let contact = if g > 0.0 { 0.5 * p.k_c * g * g } else { 0.0 };
    kinetic + springs + gravity + contact
}

/// Steady-state amplitude [m] and phase lag [rad] of the rotor's linear unbalance
/// response without contact (docs/model.md 6): x_r = A cos(W t - phi0 - lag) about the static
/// deflection, y_r likewise with sin.
pub fn linear_unbalance_response(p: &Params, omega: f64) -> (f64, f64) {
    let r = omega / p.omega_r;
    let amp = p.e * r * r / ((1.0 - r * r).powi(2) + (2.0 * p.xi_r * r).powi(2)).sqrt();
    let lag = (2.0 * p.xi_r * r).atan2(1.0 - r * r);
    (amp, lag)
}
