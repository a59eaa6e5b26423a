//! Limits on what one run may ask for: forcing periods per lane, and the memory a run
//! needs against the memory the machine has. Every command checks its inputs against
//! these *before* allocating anything, so an absurd request (a trillion speeds, a basin
//! of 1e10 cells) ends in an error naming the option and what fits, not in an
//! allocation abort or a machine driven into swap.

use crate::error::{Error, Result};

/// Largest number of forcing periods for any one count (`--transient`, `--periods`,
/// `--transient-first`, `--brute-transient`, `--tangent-transient`, ...). 1e8 periods
/// are about 2.4 days of CPU for one lane at W = 132 (~87 us per period, README), far
/// beyond any transient of this model (its slowest decay, xi_r w_r = 2.8 1/s, forgets
/// a start state within a few hundred periods); it keeps transient + recorded inside a
/// `u32` and the lane-period counters exact.
pub const MAX_PERIODS: u32 = 100_000_000;

/// Checks one count of forcing periods: `min..=MAX_PERIODS`. `option` is the name the
/// user typed (`"transient"`, `"periods"`...).
pub fn check_periods(option: &str, value: u32, min: u32) -> Result<()> {
    if (min..=MAX_PERIODS).contains(&value) {
        Ok(())
    } else {
        Err(Error::invalid(
            option,
            value,
            format!("must be in {min}..={MAX_PERIODS} forcing periods"),
        ))
    }
}

/// Memory assumed available where `/proc/meminfo` cannot be read (not Linux, or a
/// sandbox): generous, so that only requests no ordinary machine could hold are
/// refused there.
pub const FALLBACK_AVAILABLE_BYTES: u64 = 64 << 30;

/// Bytes of memory available to a new run, and where the figure comes from:
/// `MemAvailable` of `/proc/meminfo` where readable, else [`FALLBACK_AVAILABLE_BYTES`].
pub fn available_memory() -> (u64, &'static str) {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| mem_available_kib(&t))
        .map(|kib| (kib.saturating_mul(1024), "MemAvailable in /proc/meminfo"))
        .unwrap_or((
            FALLBACK_AVAILABLE_BYTES,
            "fixed cap; /proc/meminfo not readable",
        ))
}

/// The `MemAvailable:` line of a `/proc/meminfo` text [KiB].
fn mem_available_kib(meminfo: &str) -> Option<u64> {
    meminfo
        .lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|v| v.parse().ok())
}

/// `bytes` in GB (1e9 bytes), for messages.
pub fn gb(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / 1e9)
}

/// Refuses a run whose estimated memory `estimate` [bytes] exceeds what is available.
/// The error names `option` (the input that sets the size) with `value`, says what the
/// run needs (`what`: "1000 lanes x 64 recorded periods"), what is available, and
/// `hint` (what to ask for instead).
pub fn check_memory(
    option: &str,
    value: impl ToString,
    estimate: u64,
    what: &str,
    hint: &str,
) -> Result<()> {
    check_memory_against(option, value, estimate, what, hint, available_memory())
}

/// [`check_memory`] against a given budget (bytes, source).
pub fn check_memory_against(
    option: &str,
    value: impl ToString,
    estimate: u64,
    what: &str,
    hint: &str,
    available: (u64, &str),
) -> Result<()> {
    if estimate <= available.0 {
        return Ok(());
    }
    Err(Error::invalid(
        option,
        value,
        format!(
            "the run would need about {} of memory ({what}), more than the {} available ({}); {hint}",
            gb(estimate),
            gb(available.0),
            available.1
        ),
    ))
}

/// `a * b * ...` in u64, saturating (an estimate that overflows is refused anyway).
pub fn product(factors: &[u64]) -> u64 {
    factors.iter().fold(1u64, |acc, &f| acc.saturating_mul(f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_is_read_from_meminfo_text() {
        let t = "MemTotal:       32791872 kB\nMemFree:  1 kB\nMemAvailable:   24338116 kB\n";
        assert_eq!(mem_available_kib(t), Some(24338116));
        assert_eq!(mem_available_kib("MemTotal: 5 kB\n"), None);
    }

    #[test]
    fn a_run_larger_than_the_budget_is_refused_with_estimate_and_budget() {
        let e = check_memory_against("omega", "x", 5_000_000_000, "w", "h", (1_000_000_000, "s"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("5.0 GB") && e.contains("1.0 GB available"),
            "{e}"
        );
        assert!(check_memory_against("omega", "x", 10, "w", "h", (10, "s")).is_ok());
    }

    #[test]
    fn period_counts_beyond_the_shared_cap_are_refused() {
        assert!(check_periods("transient", MAX_PERIODS, 0).is_ok());
        assert!(check_periods("transient", 0, 0).is_ok());
        assert!(check_periods("periods", 0, 1).is_err());
        let e = check_periods("transient", u32::MAX, 0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("transient") && e.contains("0..=100000000"),
            "{e}"
        );
    }

    #[test]
    fn products_saturate_instead_of_wrapping() {
        assert_eq!(product(&[u64::MAX, 2]), u64::MAX);
        assert_eq!(product(&[3, 4]), 12);
    }
}
