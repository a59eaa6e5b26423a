//! The defaults of every study, in one place: the command line's option defaults
//! (`default_value_t = defaults::...`) and the Python package's keyword defaults are
//! these constants. Defaults of the stepper, the classifier, the catalogue, the
//! article's scheme and the Lyapunov spectrum are the `DEFAULT` constants of their
//! configuration types (`StepperConfig::DEFAULT`, `ClassifyConfig::DEFAULT`,
//! `CatalogueConfig::DEFAULT`, `ArticleConfig::DEFAULT`, `SpectrumConfig::DEFAULT`).

/// `simulate`: one trajectory.
pub mod simulate {
    /// Forcing periods integrated and discarded.
    pub const TRANSIENT: u32 = 1000;
    /// Forcing periods recorded (one Poincare point each).
    pub const PERIODS: u32 = 64;
    /// Periods at the end kept as the time series, at most (fewer when fewer are
    /// recorded).
    pub const TIMESERIES_PERIODS: u32 = 8;
    /// Forcing periods of the stretch the rub figures and full spectra are taken over.
    pub const SPECTRUM_PERIODS: u32 = 24;
}

/// `ensemble`: many independent lanes.
pub mod ensemble {
    /// Forcing periods integrated and discarded.
    pub const TRANSIENT: u32 = 500;
    /// Forcing periods recorded per lane.
    pub const PERIODS: u32 = 64;
}

/// `basin`: a basin of attraction over two start coordinates.
pub mod basin {
    /// Forcing periods integrated and discarded.
    pub const TRANSIENT: u32 = 500;
    /// Forcing periods recorded per cell.
    pub const PERIODS: u32 = 64;
    /// Draws of the uncertainty exponent by re-integration.
    pub const UNCERTAINTY_SAMPLES: usize = 100;
    /// Attractors drawn in the phase portraits of `attractors.png`, the largest basins
    /// first.
    pub const TRACES: usize = 8;
}

/// `cascade`: full spectra along quasistatic sweeps.
pub mod cascade {
    /// Forcing periods at the first speed before its spectrum.
    pub const TRANSIENT_FIRST: u32 = 1000;
    /// Forcing periods at every later speed before its spectrum.
    pub const TRANSIENT: u32 = 100;
    /// Forcing periods per spectrum (the bins are 1 / periods of W apart).
    pub const PERIODS: u32 = 24;
    /// Largest order |frequency / W| kept.
    pub const MAX_ORDER: f64 = 4.0;
}

/// `map`: two-parameter maps.
pub mod map {
    /// Start states per cell.
    pub const ICS: u32 = 1;
    /// Seed of the start states.
    pub const SEED: u64 = 1;
    /// Forcing periods integrated and discarded.
    pub const TRANSIENT: u32 = 500;
    /// Forcing periods recorded per lane.
    pub const PERIODS: u32 = 64;
}

/// `continuation`: attractors followed over a parameter.
pub mod continuation {
    /// Fresh start states per value.
    pub const ICS: u32 = 32;
    /// Seed of the start states.
    pub const SEED: u64 = 1;
    /// Forcing periods integrated and discarded per lane.
    pub const TRANSIENT: u32 = 500;
    /// Forcing periods recorded per lane.
    pub const PERIODS: u32 = 64;
}

/// `basin-stability`: uniform draws in a box of start states.
pub mod stability {
    /// Start states drawn per speed.
    pub const SAMPLE: u32 = 1000;
    /// Seed of the draws.
    pub const SEED: u64 = 1;
    /// Forcing periods integrated and discarded per lane.
    pub const TRANSIENT: u32 = 500;
    /// Forcing periods recorded per lane.
    pub const PERIODS: u32 = 64;
}

/// `bifurcation`: quasistatic sweeps and brute force over W.
pub mod bifurcation {
    /// Brute-force start states per W.
    pub const ICS: u32 = 8;
    /// Seed of the random start states.
    pub const SEED: u64 = 1;
    /// Transient per W of the quasistatic sweeps.
    pub const TRANSIENT: u32 = 200;
    /// Transient at the first W of each sweep.
    pub const TRANSIENT_FIRST: u32 = 1000;
    /// Transient of the brute-force lanes.
    pub const BRUTE_TRANSIENT: u32 = 500;
    /// Recorded periods per lane.
    pub const PERIODS: u32 = 64;
    /// Neighbour seeds per W in the brute force's second pass, at most.
    pub const MAX_SEEDS: usize = 8;
}
