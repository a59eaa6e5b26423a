//! The kernel's anatomy: parts of the lane kernel timed alone on a GPU (`jeffcott bench
//! --anatomy`, the GPU campaign).
//!
//! The H100 and H200 ran the lane kernel at about 3.4e8 f64 lane-steps/s where a
//! hand-written CUDA RK4 of the same model ran 2.1e10 (docs/gpu.md), and the kernel's
//! free-flight twin (no contact at all) is only 20 % faster, so most of the time is spent
//! outside contact handling. Where exactly can only be measured on the hardware, and a
//! GPU is lent seldom: these entry points answer it in one call. Each runs one part of
//! the kernel in a tight loop, `N` macro steps per forcing period, over the same lanes,
//! buffers and host protocol as the kernel (`advance_lanes`): time slices, chunks, the
//! loop budget, the Poincare point recorded at each period's end. Compared with the
//! kernel's own rate on the same lanes they say what its control structure costs
//! (one loop of sub-steps with the macro step's state kept between them, the committed
//! lane, the switch search's phases), what arrays cost against the same arithmetic on
//! vectors, and what the certainty test, the switch search and contact cost.
//!
//! The parts (anatomy.wgsl; the functions called are the kernel's own):
//! - [`Part::Kernel`]: the whole kernel (`advance_lanes`) run the same way, so that the
//!   parts and the kernel are timed alike (dispatches only, `AnatomyTimes`);
//! - [`Part::Rk4`]: `rk4_substep` in free flight, one per macro step (ds = 1);
//! - [`Part::Rk4Scalar`]: the same arithmetic with the state in two `vec4`s instead of
//!   an array (`rk4_pair`), the same bits;
//! - [`Part::Certain`]: [`Part::Rk4`] plus `free_flight_certain` on every step (what
//!   the kernel does in free flight);
//! - [`Part::Search`]: [`Part::Rk4`] plus the whole switch search (`find_switch`) on
//!   every step, its result counted but not acted on;
//! - [`Part::Contact`]: every macro step held in contact, its R sub-steps
//!   (`trial_extent`), the contact force at every stage.
//!
//! None of them is the model's dynamics (the rotor passes through the stator, or is held
//! to it): they are timing instruments, never used by a study. Each has a CPU reference
//! ([`cpu_period`]) that `tests/gpu.rs` checks bit for bit on the test adapter, so a
//! part cannot silently compute less than it claims.

use crate::shader::{self, Variant};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::{
    Lane, LaneConsts, MAX_CONTACT_SUBSTEPS, advance_period, find_switch, free_flight_certain,
    rk4_substep, trial_extent,
};
use jeffcott_core::real::Real;

/// The anatomy's entry points, appended to the kernel (see the module docs).
pub const WGSL: &str = include_str!("anatomy.wgsl");

/// A part of the lane kernel timed alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The whole kernel, `advance_lanes`: the model.
    Kernel,
    /// `rk4_substep` in free flight, one per macro step.
    Rk4,
    /// The same with the state in two `vec4`s instead of an array.
    Rk4Scalar,
    /// `rk4_substep` and `free_flight_certain`.
    Certain,
    /// `rk4_substep` and `find_switch`.
    Search,
    /// Every macro step in contact, R sub-steps.
    Contact,
}

impl Part {
    /// Every part, in the order the bench reports them.
    pub const ALL: [Part; 6] = [
        Part::Kernel,
        Part::Rk4,
        Part::Rk4Scalar,
        Part::Certain,
        Part::Search,
        Part::Contact,
    ];

    /// The name `--anatomy` takes.
    pub fn name(self) -> &'static str {
        match self {
            Part::Kernel => "kernel",
            Part::Rk4 => "rk4",
            Part::Rk4Scalar => "rk4-scalar",
            Part::Certain => "certain",
            Part::Search => "search",
            Part::Contact => "contact",
        }
    }

    /// The entry point in anatomy.wgsl.
    pub fn entry(self) -> &'static str {
        match self {
            Part::Kernel => shader::ENTRY_POINT,
            Part::Rk4 => "anatomy_rk4",
            Part::Rk4Scalar => "anatomy_rk4_scalar",
            Part::Certain => "anatomy_certain",
            Part::Search => "anatomy_search",
            Part::Contact => "anatomy_contact",
        }
    }

    /// Parses a comma-separated list of part names ("all" for every part); the error
    /// names `field` and the names allowed.
    pub fn parse_list(field: &str, text: &str) -> Result<Vec<Part>> {
        let mut out: Vec<Part> = Vec::new();
        for name in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let named: Vec<Part> = if name == "all" {
                Part::ALL.to_vec()
            } else {
                Part::ALL.into_iter().filter(|p| p.name() == name).collect()
            };
            if named.is_empty() {
                return Err(Error::invalid(
                    field,
                    name,
                    format!(
                        "must be a comma-separated list of {} or all",
                        Part::ALL.map(Part::name).join(", ")
                    ),
                ));
            }
            // Each part once, in the order first named.
            for p in named {
                if !out.contains(&p) {
                    out.push(p);
                }
            }
        }
        Ok(out)
    }
}

/// The kernel source with the anatomy's entry points, for precision `R` and variant
/// `v` (the plain kernel's; the parts take nothing from its other switches).
pub fn source<R: Real>(v: Variant) -> String {
    format!(
        "{}\nconst MAX_CONTACT_SUBSTEPS: u32 = {MAX_CONTACT_SUBSTEPS}u;\n{WGSL}",
        shader::source::<R>(v)
    )
}

/// One forcing period of `part` on the CPU from `lane` (macro steps k = 0 .. N - 1),
/// the reference the GPU's entry point must equal bit for bit: for [`Part::Kernel`] the
/// lane stepper's `advance_period`; for the others the state, and the counters they keep (`macro_steps`; with [`Part::Certain`] the steps not certified in
/// `contact_steps`; with [`Part::Search`] the steps with a switch in `switches` and the
/// largest sampled g in `max_penetration`; with [`Part::Contact`] the sub-steps beyond
/// one in `extra_substeps`).
pub fn cpu_period<R: Real>(part: Part, lc: &LaneConsts<R>, lane: &mut Lane<R>) {
    if part == Part::Kernel {
        advance_period(lc, lane);
        return;
    }
    let (zero, one) = (R::lit(0.0), R::lit(1.0));
    let c = &mut lane.counters;
    let mut x = lane.x;
    for k in 0..lc.n {
        match part {
            Part::Rk4 | Part::Rk4Scalar => x = rk4_substep(lc, &x, k, zero, one, false),
            Part::Kernel => unreachable!("the kernel's period is advance_period, above"),
            Part::Certain => {
                let x1 = rk4_substep(lc, &x, k, zero, one, false);
                c.contact_steps += !free_flight_certain(lc, &x, &x1, one * lc.h) as u64;
                x = x1;
            }
            Part::Search => {
                let x1 = rk4_substep(lc, &x, k, zero, one, false);
                let sw = find_switch(lc, &x, &x1, one * lc.h, false);
                // The kernel's max_penetration starts from -REAL_MAX where the CPU's
                // counter starts from 0; both keep the larger, as `rmax` does.
                let g = sw.max_g.to_f64();
                if g > c.max_penetration {
                    c.max_penetration = g;
                }
                c.switches += (sw.theta <= one) as u64;
                x = x1;
            }
            Part::Contact => {
                let mut s = zero;
                let mut substeps = 0u64;
                for _ in 0..MAX_CONTACT_SUBSTEPS {
                    if s >= one {
                        break;
                    }
                    let (ds, end) = trial_extent(lc, s, true);
                    x = rk4_substep(lc, &x, k, s, ds, true);
                    s = end;
                    substeps += 1;
                }
                c.extra_substeps += substeps - 1;
            }
        }
        c.macro_steps += 1;
    }
    lane.x = x;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_lists_name_each_part_once_in_the_order_first_named() {
        assert_eq!(
            Part::parse_list("anatomy", "search, all,rk4").unwrap(),
            [
                Part::Search,
                Part::Kernel,
                Part::Rk4,
                Part::Rk4Scalar,
                Part::Certain,
                Part::Contact
            ]
        );
        assert_eq!(Part::parse_list("anatomy", "").unwrap(), []);
        let e = Part::parse_list("anatomy", "rk4,warp")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("anatomy") && e.contains("warp") && e.contains("rk4-scalar"),
            "{e}"
        );
    }
}
