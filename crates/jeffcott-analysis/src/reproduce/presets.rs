//! The three resolutions of the figure set ([`QUICK`], [`FULL`], [`SMOKE`]) and the article's
//! speeds, enlargements and throw.

/// Resolutions of one mode of the figure set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preset {
    /// `quick`, `full` or `smoke`.
    pub name: &'static str,
    /// Speeds of the bifurcation diagram over 130..141 rad/s.
    pub speeds: usize,
    /// Transient at the first speed of a sweep.
    pub sweep_first: u32,
    /// Transient at every later speed of a sweep.
    pub sweep_transient: u32,
    /// Brute-force start states per speed.
    pub ics: u32,
    /// Brute-force transient.
    pub brute_transient: u32,
    /// Recorded periods of the diagram.
    pub periods: u32,
    /// Neighbour seeds at most per speed.
    pub max_seeds: usize,
    /// Speeds of each enlargement.
    pub zoom_speeds: usize,
    /// Cells per side of the basin at 133 rad/s.
    pub basin_n: usize,
    /// Transient of the basin's lanes.
    pub basin_transient: u32,
    /// Recorded periods of the basin's lanes.
    pub basin_periods: u32,
    /// Transient of the sections at 135 and 140 rad/s.
    pub section_transient: u32,
    /// Poincare points of those sections.
    pub section_points: u32,
    /// Start states of the survey per article speed.
    pub survey_ics: u32,
    /// Transient of the survey.
    pub survey_transient: u32,
    /// Recorded periods of the survey.
    pub survey_periods: u32,
    /// Transient of the full spectra.
    pub spectrum_transient: u32,
    /// Least accumulation time of the spectra [s].
    pub spectrum_min_time: f64,
    /// Largest accumulation time of the spectra [s].
    pub spectrum_max_time: f64,
    /// Speeds of the design chart.
    pub map_nx: usize,
    /// Unbalances of the design chart.
    pub map_ny: usize,
    /// Start states per cell of the design chart.
    pub map_ics: u32,
    /// Transient of the maps.
    pub map_transient: u32,
    /// Recorded periods of the maps.
    pub map_periods: u32,
    /// Speeds of the continuation.
    pub cont_values: usize,
    /// Fresh start states per speed of the continuation.
    pub cont_ics: u32,
    /// Transient of the continuation.
    pub cont_transient: u32,
    /// Recorded periods of the continuation.
    pub cont_periods: u32,
    /// Speeds of the rub map.
    pub rub_nx: usize,
    /// Friction coefficients of the rub map.
    pub rub_ny: usize,
    /// Speeds of the cascade.
    pub cascade_speeds: usize,
    /// Re-integration samples of the uncertainty exponent.
    pub uncertainty_samples: usize,
    /// Points of the period-1 orbit branch over 130..141 rad/s, at most.
    pub orbit_points: usize,
    /// Boundary refinement levels of the basin.
    pub basin_refine: u32,
}

/// Reduced resolution, sized to finish within two minutes on a 2-core CPU of any
/// x86-64 family (the default).
pub const QUICK: Preset = Preset {
    name: "quick",
    speeds: 200,
    sweep_first: 1000,
    sweep_transient: 150,
    ics: 4,
    brute_transient: 300,
    periods: 48,
    max_seeds: 6,
    zoom_speeds: 100,
    basin_n: 56,
    basin_transient: 250,
    basin_periods: 32,
    section_transient: 500,
    section_points: 1500,
    survey_ics: 24,
    survey_transient: 400,
    survey_periods: 64,
    spectrum_transient: 1000,
    spectrum_min_time: 20.0,
    spectrum_max_time: 100.0,
    map_nx: 36,
    map_ny: 14,
    map_ics: 1,
    map_transient: 300,
    map_periods: 32,
    cont_values: 25,
    cont_ics: 16,
    cont_transient: 400,
    cont_periods: 48,
    rub_nx: 49,
    rub_ny: 7,
    cascade_speeds: 101,
    uncertainty_samples: 60,
    basin_refine: 1,
    orbit_points: 240,
};

/// Publication resolution (2000 speeds, a 1000 x 1000 basin): meant for a GPU.
pub const FULL: Preset = Preset {
    name: "full",
    speeds: 2000,
    sweep_first: 2000,
    sweep_transient: 300,
    ics: 16,
    brute_transient: 500,
    periods: 64,
    max_seeds: 8,
    zoom_speeds: 1000,
    basin_n: 1000,
    basin_transient: 500,
    basin_periods: 64,
    section_transient: 1000,
    section_points: 20000,
    survey_ics: 256,
    survey_transient: 1000,
    survey_periods: 128,
    spectrum_transient: 2000,
    spectrum_min_time: 100.0,
    spectrum_max_time: 1000.0,
    map_nx: 400,
    map_ny: 200,
    map_ics: 4,
    map_transient: 500,
    map_periods: 64,
    cont_values: 221,
    cont_ics: 64,
    cont_transient: 500,
    cont_periods: 64,
    rub_nx: 241,
    rub_ny: 31,
    cascade_speeds: 1001,
    uncertainty_samples: 4000,
    basin_refine: 2,
    orbit_points: 1500,
};

/// A tiny resolution that only checks the pipeline (for tests).
pub const SMOKE: Preset = Preset {
    name: "smoke",
    speeds: 6,
    sweep_first: 100,
    sweep_transient: 20,
    ics: 2,
    brute_transient: 30,
    periods: 8,
    max_seeds: 2,
    zoom_speeds: 4,
    basin_n: 3,
    basin_transient: 30,
    basin_periods: 8,
    section_transient: 30,
    section_points: 40,
    survey_ics: 2,
    survey_transient: 30,
    survey_periods: 8,
    spectrum_transient: 30,
    spectrum_min_time: 0.5,
    spectrum_max_time: 1.0,
    map_nx: 3,
    map_ny: 2,
    map_ics: 1,
    map_transient: 30,
    map_periods: 8,
    cont_values: 3,
    cont_ics: 2,
    cont_transient: 30,
    cont_periods: 8,
    rub_nx: 3,
    rub_ny: 2,
    cascade_speeds: 3,
    uncertainty_samples: 2,
    basin_refine: 1,
    orbit_points: 12,
};

/// The article's speeds and what it reports there (docs/model.md 6).
pub const ARTICLE_SPEEDS: [(f64, &str); 5] = [
    (131.7, "period-1 (Fig. 5)"),
    (132.2, "period-2 (Fig. 6)"),
    (133.0, "coexisting attractors (Figs. 7-8)"),
    (135.0, "aperiodic (Figs. 9-10)"),
    (140.0, "aperiodic (Figs. 11-12)"),
];

/// Windows enlarged from Fig. 3 (where the diagram is most complex).
pub const ZOOMS: [(f64, f64); 2] = [(132.6, 133.8), (138.4, 141.0)];

/// The rotor start of the backward throws: displaced to x_r = 6.5 mm and thrown with
/// vy_r = -1 m/s against the rotation (docs/rub.md).
pub const THROW: (f64, f64) = (0.0065, -1.0);

/// A Lyapunov spectrum as the source article prints it: eight exponents in bits/s (base-2
/// rates; 1 bit/s = ln 2 1/s) by decreasing value, and the sum it prints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArticleSpectrum {
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// The eight exponents [bits/s], as printed.
    pub bits: [f64; 8],
    /// Their sum as printed [bits/s].
    pub sum_bits: f64,
}

/// The article's own Lyapunov spectra, at 135 rad/s (with Figs. 9-10) and 140 rad/s
/// (with Figs. 11-12), in bits/s as it prints them. Its sums, -171.4 and -171.7 bits/s,
/// are -118.8 and -119.0 1/s: the trace rule's -119.2 1/s (docs/model.md 6) to 0.4 %, which
/// says the unit is bits/s (in 1/s they would break the rule by a factor 1.44). REPORT.md
/// sets them beside jeffcott's spectra at the same speeds.
pub const ARTICLE_SPECTRA: [ArticleSpectrum; 2] = [
    ArticleSpectrum {
        omega: 135.0,
        bits: [0.0, -2.8, -6.7, -9.7, -25.8, -35.4, -36.9, -54.1],
        sum_bits: -171.4,
    },
    ArticleSpectrum {
        omega: 140.0,
        bits: [11.4, -3.4, -9.5, -18.2, -25.6, -30.9, -38.5, -57.0],
        sum_bits: -171.7,
    },
];
