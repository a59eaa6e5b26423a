//! The rotor-stator model of docs/model.md sections 1-3: parameters, state layout, the
//! corrected equations of motion, the contact force, the analytic Jacobian and the
//! energy. Pure functions; the `f64` entry points here are the reference that the
//! integrators and the GPU kernel are tested against.
//!
//! `penetration`, `contact_force_per_kc`, `pow_half`, `contact_force_per_kc_law`,
//! `contact_force_lane`, `contact_partials`, `contact_block`,
//! `contact_partials_law_off_centre` and `rhs_frozen` are mirrored, in that order, by `model.wgsl` beside this file (a part of
//! the lane kernel): keep in sync with it.

use crate::error::{Error, Result};
use crate::real::{Arith, Real};

pub use crate::params::{MAX_CONFIG_BYTES, ParamInfo, Params};

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

/// Defines [`Coeffs`] from its field list, with the per-field helpers that must name
/// every field (so a field added is added to all of them).
macro_rules! define_coeffs {
    ($($(#[$doc:meta])* $f:ident),* $(,)?) => {
        /// The coefficients of the equations of motion per unit mass (docs/model.md 2 and
        /// 7) for one rotor speed, in the lane's precision. Computed once in `f64` on the
        /// host and rounded, so the CPU and GPU lanes see identical constants.
        ///
        /// `#[repr(C)]` with every field of one type, so the struct has no padding and is
        /// the GPU's `Coeffs` as it stands (`integrate/lane_buffers.wgsl`; jeffcott-gpu's
        /// layout test checks every offset against naga's): the lane constants are
        /// uploaded without a second struct of the same fields.
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        pub struct Coeffs<R> {
            $($(#[$doc])* pub $f: R,)*
        }

        impl<R> Coeffs<R> {
            /// The field names, in the struct's order.
            pub const NAMES: &'static [&'static str] = &[$(stringify!($f)),*];

            /// Every field through `f`.
            #[inline(always)]
            pub fn map<U>(self, mut f: impl FnMut(R) -> U) -> Coeffs<U> {
                Coeffs { $($f: f(self.$f)),* }
            }
        }

        impl<R: Copy, const B: usize> Coeffs<[R; B]> {
            /// The coefficients of `B` lanes, structure-of-arrays (each field one value
            /// per lane), so a loop over the lanes vectorises (`integrate::batch`).
            #[inline(always)]
            pub fn transpose(lanes: &[Coeffs<R>; B]) -> Self {
                // A plain loop, not `std::array::from_fn` with a getter per field: out of
                // line (the batch stepper's pack loop, perf) those were compiled without
                // the batch code's instruction set.
                const { assert!(B > 0, "a batch holds at least one lane") };
                let c0 = &lanes[0];
                let mut t = Coeffs { $($f: [c0.$f; B]),* };
                #[allow(clippy::needless_range_loop)]
                for l in 1..B {
                    let c = &lanes[l];
                    $(t.$f[l] = c.$f;)*
                }
                t
            }

            /// Lane `l`'s coefficients.
            #[inline(always)]
            pub fn lane(&self, l: usize) -> Coeffs<R> {
                Coeffs { $($f: self.$f[l]),* }
            }
        }
    };
}

define_coeffs! {
    /// w_rx^2 [1/s^2].
    wr2x,
    /// w_ry^2 [1/s^2].
    wr2y,
    /// 2 xi_rx w_rx [1/s].
    drx,
    /// 2 xi_ry w_ry [1/s].
    dry,
    /// w_sx^2 [1/s^2].
    ws2x,
    /// w_sy^2 [1/s^2].
    ws2y,
    /// 2 xi_sx w_sx [1/s].
    dsx,
    /// 2 xi_sy w_sy [1/s].
    dsy,
    /// The stator's rest centre o_x [m] (+0 when centred).
    ox,
    /// The stator's rest centre o_y [m] (+0 when centred).
    oy,
    /// Unbalance acceleration amplitude e W^2 [m/s^2].
    unbalance,
    /// Gravity a_g [m/s^2].
    a_g,
    /// k_c / m_r [1/s^2].
    kc_mr,
    /// k_c / m_s [1/s^2].
    kc_ms,
    /// Friction coefficient mu.
    mu,
    /// Gap delta [m].
    delta,
    /// Contact damping over contact stiffness c_c / k_c [s] (0 without damping).
    tau_c,
    /// The contact law's exponent n (1 for the linear spring).
    n_c,
    /// Hunt-Crossley damping 3/2 alpha [s/m] (0 without).
    hc,
}

// SAFETY: `Coeffs<R>` is `#[repr(C)]` and all its fields are `R`, so it has the size of
// `[R; 19]`, no padding, and every bit pattern of it is valid when every bit pattern of
// `R` is (`R: Pod`); zeroed it is all-zero `R`s (`R: Zeroable`).
unsafe impl<R: bytemuck::Zeroable> bytemuck::Zeroable for Coeffs<R> {}
// SAFETY: as above; `R: Pod` also gives `Copy + 'static`.
unsafe impl<R: bytemuck::Pod> bytemuck::Pod for Coeffs<R> {}

impl<R: Real> Coeffs<R> {
    /// Derives the coefficients from the parameters and the rotor speed.
    pub fn new(p: &Params, omega: f64) -> Self {
        let ((wrx, wry), (xrx, xry)) = (p.omega_r_xy(), p.xi_r_xy());
        let ((wsx, wsy), (xsx, xsy)) = (p.omega_s_xy(), p.xi_s_xy());
        Coeffs {
            wr2x: R::lit(wrx * wrx),
            wr2y: R::lit(wry * wry),
            drx: R::lit(2.0 * xrx * wrx),
            dry: R::lit(2.0 * xry * wry),
            ws2x: R::lit(wsx * wsx),
            ws2y: R::lit(wsy * wsy),
            dsx: R::lit(2.0 * xsx * wsx),
            dsy: R::lit(2.0 * xsy * wsy),
            // + 0.0 turns -0 into +0, so that x - ox is x itself for a centred stator.
            ox: R::lit(p.o_x + 0.0),
            oy: R::lit(p.o_y + 0.0),
            unbalance: R::lit(p.e * omega * omega),
            a_g: R::lit(p.a_g),
            kc_mr: R::lit(p.k_c / p.m_r),
            kc_ms: R::lit(p.k_c / p.m_s),
            mu: R::lit(p.mu),
            delta: R::lit(p.delta),
            tau_c: R::lit(p.c_c / p.k_c),
            n_c: R::lit(p.n_c),
            hc: R::lit(1.5 * p.alpha_c),
        }
    }

    /// Whether the stator's rest centre is off the bearing axis: the equations then
    /// subtract it from the stator's position ([`rhs_with_force`]'s `OFFSET`).
    #[inline(always)]
    pub fn offset(&self) -> bool {
        self.ox != R::lit(0.0) || self.oy != R::lit(0.0)
    }

    /// Whether the supports differ by direction, bit for bit: the y coefficients are
    /// then not the x ones ([`rhs_with_force`]'s `ANISOTROPIC`).
    #[inline(always)]
    pub fn anisotropic(&self) -> bool {
        let differ = |x: R, y: R| x.to_f64().to_bits() != y.to_f64().to_bits();
        differ(self.wr2x, self.wr2y)
            || differ(self.drx, self.dry)
            || differ(self.ws2x, self.ws2y)
            || differ(self.dsx, self.dsy)
    }

    /// Whether the contact is not the article's linear spring: a power law (n != 1) or
    /// Hunt-Crossley damping ([`contact_force_lane`]). Decided from the lane's own
    /// coefficients, in the kernel as here, so a lane takes the same law whatever the
    /// other lanes of its batch or dispatch take.
    #[inline(always)]
    pub fn contact_law(&self) -> bool {
        self.n_c != R::lit(1.0) || self.hc != R::lit(0.0)
    }

    /// The optional terms these coefficients use, decided once (a lane's constants
    /// carry them: `integrate::lane::LaneConsts::terms`).
    pub fn terms(&self) -> Terms {
        Terms {
            offset: self.offset(),
            anisotropic: self.anisotropic(),
            contact_law: self.contact_law(),
        }
    }
}

/// Which optional terms of the equations a lane's coefficients use (docs/model.md 7):
/// code for a term no lane of a batch or a GPU run uses is left out of it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Terms {
    /// The stator's rest centre is off the bearing axis ([`Coeffs::offset`]).
    pub offset: bool,
    /// The supports differ by direction ([`Coeffs::anisotropic`]).
    pub anisotropic: bool,
    /// The contact is a power law or has Hunt-Crossley damping ([`Coeffs::contact_law`]).
    pub contact_law: bool,
}

impl Terms {
    /// No optional term: the article's model.
    pub const NONE: Terms = Terms {
        offset: false,
        anisotropic: false,
        contact_law: false,
    };

    /// Every optional term.
    pub const ALL: Terms = Terms {
        offset: true,
        anisotropic: true,
        contact_law: true,
    };

    /// The terms of either.
    #[inline(always)]
    pub fn or(self, other: Terms) -> Terms {
        Terms {
            offset: self.offset || other.offset,
            anisotropic: self.anisotropic || other.anisotropic,
            contact_law: self.contact_law || other.contact_law,
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

/// a^m for the exponents of the contact laws, m = n - 1 in {0, 1/2, 1, 3/2, 2}, a >= 0:
/// products and at most one square root, each correctly rounded on the CPU and in the
/// kernel (a `pow` is neither, and WGSL has none for f64), so both give the same bits.
#[inline(always)]
pub fn pow_half<R: Real>(a: R, m: R) -> R {
    // The root computed and kept or not, picked by `Real::pick` (vector blends in a batch).
    let (whole, k) = whole_power(a, m);
    let root = whole * a.sqrt();
    R::pick(m != k, root, whole)
}

/// a^k and the whole part k of a contact law's exponent m (0, 1 or 2), from one pair of
/// comparisons, not `floor` (a libm call on the CPU's baseline x86-64, which keeps the
/// batch's lane loop from vectorising).
#[inline(always)]
fn whole_power<R: Real>(a: R, m: R) -> (R, R) {
    let (two, one) = (m >= R::lit(2.0), m >= R::lit(1.0));
    // Every candidate formed, then picked by its bits (`Real::pick`): written as `if`s,
    // even with the square formed before them, a batch's lanes took scalar branches.
    let k = R::pick(two, R::lit(2.0), R::pick(one, R::lit(1.0), R::lit(0.0)));
    let whole = R::pick(two, a * a, R::pick(one, a, R::lit(1.0)));
    (whole, k)
}

/// The whole part of a contact law's exponent m: m is whole where it equals it.
#[inline(always)]
pub fn whole_part<R: Real>(m: R) -> R {
    whole_power(R::lit(1.0), m).1
}

/// a^k for the whole part k of m ([`whole_part`]): [`pow_half`] without its root, the
/// same bits where m is whole. The batch stepper takes it for a batch whose exponents
/// are all whole (n = 1, 2 or 3), which then computes no root.
#[inline(always)]
pub fn pow_whole<R: Real>(a: R, m: R) -> R {
    whole_power(a, m).0
}

/// [`contact_force_per_kc`] for the general contact law of docs/model.md 7: the normal
/// force k_c P(g) (1 + hc dg/dt) + c_c dg/dt with P(g) = g |g|^(n-1) (Hertz's k_c g^n
/// in contact, continued oddly below g = 0 for the held contact mode) and hc = 3/2 alpha
/// (Hunt and Crossley 1975), friction mu k_c P(g). With n = 1 and hc = 0 it is the
/// linear law, though not its bits: a lane takes one or the other by
/// [`Coeffs::contact_law`] ([`contact_force_lane`]).
#[inline(always)]
pub fn contact_force_per_kc_law<R: Real>(c: &Coeffs<R>, dx: R, dy: R, dvx: R, dvy: R) -> (R, R) {
    if concentric(dx, dy) {
        return (R::lit(0.0), R::lit(0.0));
    }
    contact_force_law_off_centre(c, dx, dy, dvx, dvy)
}

/// [`contact_force_per_kc_law`] off the concentric position, branch-free, so a batch of
/// lanes (`integrate::wide::Wide`) computes it at once: the batch stepper's forces for
/// the lanes of a contact law (`integrate::batch`, through [`contact_force_law_powered`]),
/// which per lane inside its main loop kept that loop from vectorising.
#[inline(always)]
pub fn contact_force_law_off_centre<T: Arith>(
    c: &Coeffs<T>,
    dx: T,
    dy: T,
    dvx: T,
    dvy: T,
) -> (T, T) {
    contact_force_law_powered::<T, true>(c, dx, dy, dvx, dvy)
}

/// [`contact_force_law_off_centre`] with the law's power of the gap |g|^(n-1) by
/// [`Arith::pow_half`] (`ROOT`) or by [`Arith::pow_whole`], without a root, in a batch
/// whose exponents are all whole, where the two agree to the bit. (A const parameter,
/// not a function argument: the batch stepper's copy for each instruction set then
/// inlines it, where a passed function was called out of line, 5 % of a run.)
#[inline(always)]
pub fn contact_force_law_powered<T: Arith, const ROOT: bool>(
    c: &Coeffs<T>,
    dx: T,
    dy: T,
    dvx: T,
    dvy: T,
) -> (T, T) {
    let r = (dx * dx + dy * dy).root();
    // One division, 1/r, for the spring part, the gap's rate and the dashpot: a
    // division costs a batch several times a product.
    let inv_r = T::splat(1.0) / r;
    let g = r - c.delta;
    let m = c.n_c - T::splat(1.0);
    let s =
        g * if ROOT {
            g.abs().pow_half(m)
        } else {
            g.abs().pow_whole(m)
        } * inv_r;
    let rate = (dx * dvx + dy * dvy) * inv_r;
    let nrm = s + c.hc * s * rate + c.tau_c * (rate * inv_r);
    (-nrm * dx + c.mu * s * dy, -nrm * dy - c.mu * s * dx)
}

/// The contact force per k_c of a lane's own law: [`contact_force_per_kc_law`] where
/// [`Coeffs::contact_law`], else the article's [`contact_force_per_kc`].
#[inline(always)]
pub fn contact_force_lane<R: Real>(c: &Coeffs<R>, dx: R, dy: R, dvx: R, dvy: R) -> (R, R) {
    if c.contact_law() {
        contact_force_per_kc_law(c, dx, dy, dvx, dvy)
    } else {
        contact_force_per_kc(c.delta, c.mu, c.tau_c, dx, dy, dvx, dvy)
    }
}

/// Whether the bodies are concentric (|d| = sqrt(dx^2 + dy^2) <= 0), where the contact
/// partials are zero ([`contact_partials`]' guard, [`contact_force_per_kc`]'s too).
#[inline(always)]
pub fn concentric<R: Real>(dx: R, dy: R) -> bool {
    // sqrt(s) <= 0 exactly where s <= 0, for every s (NaN included): no root needed.
    dx * dx + dy * dy <= R::lit(0.0)
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
    if c.contact_law() {
        contact_partials_law_off_centre(c, x)
    } else {
        contact_partials_off_centre(c, x)
    }
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
    contact_block(
        dx,
        dy,
        c.mu,
        &NormalPartials(s, nrm, sx, sy, nx, ny, nvx, nvy),
    )
}

/// The normal force per k_c and r of a contact law, nrm, its spring part s (which
/// friction follows), and their partials, in this order: s, nrm, (sx, sy) =
/// ds/d(dx, dy), (nx, ny) = dnrm/d(dx, dy), (nvx, nvy) = dnrm/d(dvx, dvy).
pub struct NormalPartials<T>(pub T, pub T, pub T, pub T, pub T, pub T, pub T, pub T);

/// The contact block of [`contact_partials`] from the normal force's partials, for any
/// law: the force is (-nrm dx + mu s dy, -nrm dy - mu s dx).
#[inline(always)]
pub fn contact_block<T: Arith>(dx: T, dy: T, mu: T, n: &NormalPartials<T>) -> [T; 8] {
    let NormalPartials(s, nrm, sx, sy, nx, ny, nvx, nvy) = *n;
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

/// [`contact_partials_off_centre`] of the general law ([`contact_force_per_kc_law`]),
/// for a lane whose [`Coeffs::contact_law`] holds.
///
/// With A = |g|^(n-1), P = g A and P' = n A: d(P/r)/d(dx) = (P' r - P) dx / r^3, and
/// P' r - P = A ((n - 1) r + delta) (no cancellation near g = 0); dg/dt = (d . v)/r has
/// d(dg/dt)/d(dx) = (dvx - q dx)/r and d(dg/dt)/d(dvx) = dx / r.
#[inline(always)]
pub fn contact_partials_law_off_centre<T: Arith>(c: &Coeffs<T>, x: &[T; STATE_DIM]) -> [T; 8] {
    let [dx, dy, dvx, dvy] = relative_motion(x);
    let one = T::splat(1.0);
    let r2 = dx * dx + dy * dy;
    let r = r2.root();
    let g = r - c.delta;
    let a = g.abs().pow_half(c.n_c - one);
    let s = g * a / r;
    let dv = dx * dvx + dy * dvy;
    let (q, gd) = (dv / r2, dv / r);
    let nrm = s + c.hc * s * gd + c.tau_c * q;
    let r3 = r2 * r;
    let num = a * ((c.n_c - one) * r + c.delta);
    let (sx, sy) = (num * dx / r3, num * dy / r3);
    let (gx, gy) = ((dvx - q * dx) / r, (dvy - q * dy) / r);
    let two = T::splat(2.0);
    let nx = sx + c.hc * (sx * gd + s * gx) + c.tau_c * (dvx - two * q * dx) / r2;
    let ny = sy + c.hc * (sy * gd + s * gy) + c.tau_c * (dvy - two * q * dy) / r2;
    let nvx = c.hc * s * dx / r + c.tau_c * dx / r2;
    let nvy = c.hc * s * dy / r + c.tau_c * dy / r2;
    contact_block(
        dx,
        dy,
        c.mu,
        &NormalPartials(s, nrm, sx, sy, nx, ny, nvx, nvy),
    )
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
        (fx, fy) = contact_force_lane(c, dx, dy, dvx, dvy);
    }
    if c.offset() {
        rhs_with_force::<R, true, true>(c, x, cos_phase, sin_phase, fx, fy)
    } else {
        rhs_with_force::<R, false, true>(c, x, cos_phase, sin_phase, fx, fy)
    }
}

/// The right-hand side given the contact force per unit contact stiffness on the rotor
/// (`fx`, `fy`; zero out of contact): the one definition of the equations of motion on
/// the CPU, used by [`rhs_frozen`] and, lane by lane, by the batched stepper (which
/// computes the force branch-free and selects it per lane).
///
/// Each direction has its own stiffness and damping (docs/model.md 7; equal for the
/// article's isotropic machine). `OFFSET`: the stator's springs pull towards its rest
/// centre (ox, oy); without it they pull towards the bearing axis and the subtraction
/// of a zero centre is not done at all (x - (+0) is x, so both give the same bits for a
/// centred stator, and the article's model keeps its speed). `ANISOTROPIC`: the y
/// coefficients are read; without it the x ones serve both directions (the same bits
/// for an isotropic machine, whose y coefficients are its x ones, and four arrays fewer
/// for a batch to read).
#[inline(always)]
pub fn rhs_with_force<R: Real, const OFFSET: bool, const ANISOTROPIC: bool>(
    c: &Coeffs<R>,
    x: &[R; STATE_DIM],
    cos_phase: R,
    sin_phase: R,
    fx: R,
    fy: R,
) -> [R; STATE_DIM] {
    let (xs, ys) = if OFFSET {
        (x[X_S] - c.ox, x[Y_S] - c.oy)
    } else {
        (x[X_S], x[Y_S])
    };
    let (wr2y, dry, ws2y, dsy) = if ANISOTROPIC {
        (c.wr2y, c.dry, c.ws2y, c.dsy)
    } else {
        (c.wr2x, c.drx, c.ws2x, c.dsx)
    };
    [
        x[VX_R],
        -c.wr2x * x[X_R] - c.drx * x[VX_R] + c.unbalance * cos_phase + c.kc_mr * fx,
        x[VY_R],
        -wr2y * x[Y_R] - dry * x[VY_R] + c.unbalance * sin_phase - c.a_g + c.kc_mr * fy,
        x[VX_S],
        -c.ws2x * xs - c.dsx * x[VX_S] - c.kc_ms * fx,
        x[VY_S],
        -ws2y * ys - dsy * x[VY_S] - c.a_g - c.kc_ms * fy,
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
        let (fx, fy) = contact_force_lane(&c, dx, dy, dvx, dvy);
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
    jacobian_frozen(&c, x, penetration(p.delta, x) > 0.0)
}

/// [`jacobian`] with the contact state given (`contact`), from the coefficients.
pub fn jacobian_frozen(c: &Coeffs<f64>, x: &State, contact: bool) -> [[f64; STATE_DIM]; STATE_DIM] {
    let mut j = [[0.0; STATE_DIM]; STATE_DIM];
    for (pos, vel) in [(X_R, VX_R), (Y_R, VY_R), (X_S, VX_S), (Y_S, VY_S)] {
        j[pos][vel] = 1.0;
    }
    j[VX_R][X_R] = -c.wr2x;
    j[VX_R][VX_R] = -c.drx;
    j[VY_R][Y_R] = -c.wr2y;
    j[VY_R][VY_R] = -c.dry;
    j[VX_S][X_S] = -c.ws2x;
    j[VX_S][VX_S] = -c.dsx;
    j[VY_S][Y_S] = -c.ws2y;
    j[VY_S][VY_S] = -c.dsy;
    if contact {
        let pc = contact_partials(c, x);
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

/// Total mechanical energy [J]: kinetic, shaft and suspension springs (each direction
/// its own stiffness, the stator's stretched from its rest centre), gravity (zero at
/// y = 0) and the contact potential k_c g^(n+1) / (n+1) for g > 0 (k_c g^2 / 2 for the
/// linear spring). Conserved when every damping ratio, e, mu, c_c and alpha_c are zero
/// (docs/model.md 6).
pub fn energy(p: &Params, x: &State) -> f64 {
    let kinetic = 0.5 * p.m_r * (x[VX_R] * x[VX_R] + x[VY_R] * x[VY_R])
        + 0.5 * p.m_s * (x[VX_S] * x[VX_S] + x[VY_S] * x[VY_S]);
    // An isotropic spring as k (dx^2 + dy^2) / 2, the article model's bits.
    let spring = |m: f64, (wx, wy): (f64, f64), dx: f64, dy: f64| {
        if wx == wy {
            0.5 * (m * wx * wx) * (dx * dx + dy * dy)
        } else {
            0.5 * ((m * wx * wx) * dx * dx + (m * wy * wy) * dy * dy)
        }
    };
    let springs = spring(p.m_r, p.omega_r_xy(), x[X_R], x[Y_R])
        + spring(p.m_s, p.omega_s_xy(), x[X_S] - p.o_x, x[Y_S] - p.o_y);
    let gravity = p.a_g * (p.m_r * x[Y_R] + p.m_s * x[Y_S]);
    let g = penetration(p.delta, x);
    let contact = match g > 0.0 {
        false => 0.0,
        true if p.n_c == 1.0 => 0.5 * p.k_c * g * g,
        true => p.k_c * g * pow_half(g, p.n_c - 1.0) * g / (p.n_c + 1.0),
    };
    kinetic + springs + gravity + contact
}

/// Steady-state amplitude [m] and phase lag [rad] of the rotor's linear unbalance
/// response without contact (docs/model.md 6): x_r = A cos(W t - phi0 - lag) about the static
/// deflection, y_r likewise with sin.
pub fn linear_unbalance_response(p: &Params, omega: f64) -> (f64, f64) {
    unbalance_response(p.e, p.omega_r, p.xi_r, omega)
}

/// [`linear_unbalance_response`] of each direction of a rotor whose supports differ in
/// x and y (docs/model.md 7): ((amplitude, lag) in x, (amplitude, lag) in y). The
/// directions are uncoupled without contact, so the orbit is the ellipse
/// x_r = A_x cos(W t - phi0 - lag_x), y_r = A_y sin(W t - phi0 - lag_y) about the rest.
pub fn linear_unbalance_response_xy(p: &Params, omega: f64) -> ((f64, f64), (f64, f64)) {
    let ((wx, wy), (xx, xy)) = (p.omega_r_xy(), p.xi_r_xy());
    (
        unbalance_response(p.e, wx, xx, omega),
        unbalance_response(p.e, wy, xy, omega),
    )
}

/// Amplitude and lag of q'' + 2 xi w q' + w^2 q = e W^2 cos(W t).
fn unbalance_response(e: f64, w: f64, xi: f64, omega: f64) -> (f64, f64) {
    let r = omega / w;
    let amp = e * r * r / ((1.0 - r * r).powi(2) + (2.0 * xi * r).powi(2)).sqrt();
    let lag = (2.0 * xi * r).atan2(1.0 - r * r);
    (amp, lag)
}
