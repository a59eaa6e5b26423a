//! The defaults of every study, in one place: the command line's option defaults
//! (`default_value_t = defaults::...`) and the Python package's keyword defaults are
//! these constants. Defaults of the stepper, the classifier, the catalogue, the
//! article's scheme and the Lyapunov spectrum are the `DEFAULT` constants of their
//! configuration types (`StepperConfig::DEFAULT`, `ClassifyConfig::DEFAULT`,
//! `CatalogueConfig::DEFAULT`, `ArticleConfig::DEFAULT`, `SpectrumConfig::DEFAULT`).
//!
//! [`table`] lists them all by study and keyword, so a front end can show them and a
//! test can check a front end's declared defaults against them (Python's `DEFAULTS`
//! and its type stub).

/// Declares each study's defaults as a module of constants and [`table`] listing them.
macro_rules! studies {
    ($($(#[$sm:meta])* $study:ident { $($(#[$m:meta])* $name:ident: $t:ty = $v:expr,)* })*) => {
        $($(#[$sm])* pub mod $study { $($(#[$m])* pub const $name: $t = $v;)* })*

        /// Every default above: (study, keyword, value), the keyword being the
        /// constant's name in lower case (`basin::TRANSIENT` is basin's `transient`).
        pub fn table() -> Vec<(&'static str, String, serde_json::Value)> {
            vec![$($((
                stringify!($study),
                stringify!($name).to_lowercase(),
                serde_json::json!($study::$name),
            ),)*)*]
        }
    };
}

studies! {
    /// `simulate`: one trajectory.
    simulate {
        /// Forcing periods integrated and discarded.
        TRANSIENT: u32 = 1000,
        /// Forcing periods recorded (one Poincare point each).
        PERIODS: u32 = 64,
        /// Periods at the end kept as the time series, at most (fewer when fewer are
        /// recorded).
        TIMESERIES_PERIODS: u32 = 8,
        /// Forcing periods of the stretch the rub figures and full spectra are taken over.
        SPECTRUM_PERIODS: u32 = 24,
    }

    /// `ensemble`: many independent lanes.
    ensemble {
        /// Forcing periods integrated and discarded.
        TRANSIENT: u32 = 500,
        /// Forcing periods recorded per lane.
        PERIODS: u32 = 64,
    }

    /// `basin`: a basin of attraction over two start coordinates.
    basin {
        /// Forcing periods integrated and discarded.
        TRANSIENT: u32 = 500,
        /// Forcing periods recorded per cell.
        PERIODS: u32 = 64,
        /// Draws of the uncertainty exponent by re-integration.
        UNCERTAINTY_SAMPLES: usize = 100,
        /// Attractors drawn in the phase portraits of `attractors.png`, the largest basins
        /// first.
        TRACES: usize = 8,
    }

    /// `cascade`: full spectra along quasistatic sweeps.
    cascade {
        /// Forcing periods at the first speed before its spectrum.
        TRANSIENT_FIRST: u32 = 1000,
        /// Forcing periods at every later speed before its spectrum.
        TRANSIENT: u32 = 100,
        /// Forcing periods per spectrum (the bins are 1 / periods of W apart).
        PERIODS: u32 = 24,
        /// Largest order |frequency / W| kept.
        MAX_ORDER: f64 = 4.0,
    }

    /// `map`: two-parameter maps.
    map {
        /// Start states per cell.
        ICS: u32 = 1,
        /// Seed of the start states.
        SEED: u64 = 1,
        /// Forcing periods integrated and discarded.
        TRANSIENT: u32 = 500,
        /// Forcing periods recorded per lane.
        PERIODS: u32 = 64,
    }

    /// `continuation`: attractors followed over a parameter.
    continuation {
        /// Fresh start states per value.
        ICS: u32 = 32,
        /// Seed of the start states.
        SEED: u64 = 1,
        /// Forcing periods integrated and discarded per lane.
        TRANSIENT: u32 = 500,
        /// Forcing periods recorded per lane.
        PERIODS: u32 = 64,
    }

    /// `basin-stability`: uniform draws in a box of start states.
    stability {
        /// Start states drawn per speed.
        SAMPLE: u32 = 1000,
        /// Seed of the draws.
        SEED: u64 = 1,
        /// Forcing periods integrated and discarded per lane.
        TRANSIENT: u32 = 500,
        /// Forcing periods recorded per lane.
        PERIODS: u32 = 64,
    }

    /// `bifurcation`: quasistatic sweeps and brute force over W.
    bifurcation {
        /// Brute-force start states per W.
        ICS: u32 = 8,
        /// Seed of the random start states.
        SEED: u64 = 1,
        /// Transient per W of the quasistatic sweeps.
        TRANSIENT: u32 = 200,
        /// Transient at the first W of each sweep.
        TRANSIENT_FIRST: u32 = 1000,
        /// Transient of the brute-force lanes.
        BRUTE_TRANSIENT: u32 = 500,
        /// Recorded periods per lane.
        PERIODS: u32 = 64,
        /// Neighbour seeds per W in the brute force's second pass, at most.
        MAX_SEEDS: usize = 8,
    }

    /// `orbits`: a branch of periodic orbits continued over W or a parameter.
    orbits {
        /// Period of the orbits in forcing periods.
        PERIOD: u32 = 1,
        /// Forcing periods integrated from the start state before shooting.
        SETTLE: u32 = 300,
        /// Branch points at most: the period-1 branch over 125..141 rad/s takes 2680 (10 s).
        MAX_POINTS: usize = 5000,
        /// First arclength step (positions in metres, velocities over W, the parameter
        /// at 1 mm per its range).
        DS: f64 = 2e-5,
        /// Largest arclength step.
        DS_MAX: f64 = 2e-4,
    }
}
