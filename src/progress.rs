//! Progress bars for long runs (indicatif): lane-periods done, lanes per second and ETA,
//! on stderr. Hidden with `--quiet` and when stderr is not a terminal.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use std::fmt::Write;
use std::time::Duration;

/// A terminal progress bar counting lane-periods of a run whose lanes each integrate
/// `periods_per_lane` forcing periods.
#[derive(Clone, Debug)]
pub struct Bar {
    bar: ProgressBar,
}

impl Bar {
    /// A bar labelled `what` over `total` lane-periods; `quiet` hides it.
    pub fn new(what: &str, total: u64, periods_per_lane: u64, quiet: bool) -> Self {
        let bar = if quiet {
            ProgressBar::hidden()
        } else {
            ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr())
        };
        let per_lane = periods_per_lane.max(1) as f64;
        let style = ProgressStyle::with_template(
            "{prefix:>12} [{bar:30}] {percent:>3}% {lanes} lanes, {lanes_per_sec} lanes/s, ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
        .with_key(
            "lanes",
            move |s: &ProgressState, w: &mut dyn Write| {
                let _ = write!(
                    w,
                    "{:.0}/{:.0}",
                    s.pos() as f64 / per_lane,
                    s.len().unwrap_or(0) as f64 / per_lane
                );
            },
        )
        .with_key(
            "lanes_per_sec",
            move |s: &ProgressState, w: &mut dyn Write| {
                let _ = write!(w, "{:.0}", s.per_sec() / per_lane);
            },
        );
        bar.set_style(style);
        bar.set_prefix(what.to_string());
        bar.enable_steady_tick(Duration::from_millis(250));
        Bar { bar }
    }

    /// Sets the lane-periods done so far (monotone; callable from any thread).
    pub fn set(&self, done: u64) {
        if done > self.bar.position() {
            self.bar.set_position(done);
        }
    }

    /// Lane-periods done so far.
    pub fn position(&self) -> u64 {
        self.bar.position()
    }

    /// Adds to the lane-periods done.
    pub fn inc(&self, delta: u64) {
        self.bar.inc(delta);
    }

    /// A callback for `ensemble::run` that reports its (done, total) counts offset by
    /// `offset` lane-periods already done in this bar (for runs made of several ensembles).
    pub fn callback(&self, offset: u64) -> impl Fn(u64, u64) + Sync + '_ {
        move |done, _total| self.set(offset + done)
    }

    /// Clears the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
