//! `reproduce` as a study: the article's figure set (Figs. 3-12 of "Nonlinear Dynamics
//! and Chaos of a Nonsmooth Rotor-Stator System", MODEL.md 6) and the studies beyond it,
//! at one of three resolutions.
//!
//! This module holds what the figure set computes and what it finds, typed:
//! - the presets ([`QUICK`], [`FULL`], [`SMOKE`]) and the article's speeds;
//! - [`ReproduceSpec`]: the specification of every study of the set (bifurcation with
//!   both sweeps and brute force, the enlargements, the survey and spectra at the
//!   article's speeds, the basin at 133 rad/s, the sections, the design chart, the
//!   continuation, the rub map, the cascade, the backward throws);
//! - [`Survey`], computed here: the seeded start states at the article's speeds (one
//!   ensemble, split per speed into catalogues) and the full Lyapunov spectra;
//! - the findings REPORT.md quotes, each a struct computed from a study's result:
//!   [`SweepCounts`], [`Lambda1Row`], [`BruteCounts`], [`MapFindings`],
//!   [`RampFindings`], [`RegimeCells`], [`ThrowOutcome`], the sum rule
//!   ([`sum_rule`]) and the summary table's rows ([`SummaryRow`]).
//!
//! The command line runs the studies (each with its progress bar, its units under its own
//! prefix of one run directory, and its own output writer into a sub-folder), draws the
//! figures and words REPORT.md from these values.

use crate::basin::study::{BasinOutcome, BasinStudy};
use crate::basin::{Axis, BasinSpec};
use crate::bifurcation::{BifurcationResult, BifurcationSpec, Sweep, SweepPoint, start_states};
use crate::cascade::{CascadeResult, CascadeSpec};
use crate::catalogue::{Catalogue, CatalogueConfig, catalogue_result};
use crate::classify::Class;
use crate::continuation::{ContinuationResult, ContinuationSpec, Direction, Ramp};
use crate::map::{MapAxis, MapResult, MapSpec, MapVar, code};
use crate::rub::RubRegime;
use crate::run::Prefixed;
use crate::simulate::{
    Integrator, RubOutputs, SimulateResult, SimulateSpec, rub_outputs, simulate,
};
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{Backend, EnsembleResult, EnsembleSpec, LaneSpec, Precision};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::Status;
use jeffcott_core::lyapunov::{Spectrum, SpectrumConfig, spectrum};
use jeffcott_core::model::{Params, VX_R, VY_R, X_R};

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
    /// Boundary refinement levels of the basin.
    pub basin_refine: u32,
}

/// Reduced resolution that finishes in under 10 minutes on a 2-core CPU (the default).
pub const QUICK: Preset = Preset {
    name: "quick",
    speeds: 400,
    sweep_first: 1000,
    sweep_transient: 150,
    ics: 4,
    brute_transient: 400,
    periods: 48,
    max_seeds: 6,
    zoom_speeds: 200,
    basin_n: 80,
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
    map_nx: 56,
    map_ny: 20,
    map_ics: 1,
    map_transient: 300,
    map_periods: 32,
    cont_values: 45,
    cont_ics: 16,
    cont_transient: 400,
    cont_periods: 48,
    rub_nx: 49,
    rub_ny: 7,
    cascade_speeds: 101,
    uncertainty_samples: 100,
    basin_refine: 1,
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
};

/// The article's speeds and what it reports there (MODEL.md 6).
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

/// What a figure set computes: its resolutions, the model (Table 1), and how its lanes
/// run; every study's specification follows from these.
#[derive(Clone, Debug)]
pub struct ReproduceSpec {
    /// The resolutions.
    pub preset: Preset,
    /// Model parameters.
    pub params: Params,
    /// Lane precision of the ensembles.
    pub precision: Precision,
    /// Backend of the ensembles.
    pub backend: Backend,
    /// Catalogue settings (tolerances follow the precision).
    pub catalogue: CatalogueConfig,
}

impl ReproduceSpec {
    /// The figure set at `preset` with Table 1's parameters.
    pub fn new(preset: Preset, backend: Backend, precision: Precision) -> Self {
        ReproduceSpec {
            preset,
            params: Params::default(),
            precision,
            backend,
            catalogue: CatalogueConfig::for_precision(precision),
        }
    }

    /// Figs. 3-4, the down sweep and the brute force: one study over [130, 141].
    pub fn bifurcation(&self) -> Result<BifurcationSpec> {
        let p = &self.preset;
        Ok(BifurcationSpec {
            params: self.params.clone(),
            omegas: jeffcott_core::ensemble::parse_range(
                "omega",
                &format!("130:141:{}", p.speeds),
            )?,
            sweep: Some(Sweep::Both),
            transient_first: p.sweep_first,
            transient: p.sweep_transient,
            ics: p.ics,
            brute_transient: p.brute_transient,
            recorded: p.periods,
            seed: 1,
            stepper: Default::default(),
            precision: self.precision,
            backend: self.backend,
            catalogue: self.catalogue,
            max_seeds: p.max_seeds,
            lyapunov: true,
        })
    }

    /// Enlargement `k` of Fig. 3 over [`ZOOMS`]`[k]`: an up sweep alone.
    pub fn zoom(&self, k: usize) -> Result<BifurcationSpec> {
        let (lo, hi) = ZOOMS[k];
        Ok(BifurcationSpec {
            omegas: jeffcott_core::ensemble::parse_range(
                "omega",
                &format!("{lo}:{hi}:{}", self.preset.zoom_speeds),
            )?,
            sweep: Some(Sweep::Up),
            ics: 0,
            ..self.bifurcation()?
        })
    }

    /// The survey: the same seeded start states at each article speed, in one ensemble
    /// (speed-major, [`Preset::survey_ics`] lanes per speed).
    pub fn survey(&self) -> EnsembleSpec {
        let p = &self.preset;
        let starts = start_states(&self.params, p.survey_ics, 135.0, 7);
        let lanes = ARTICLE_SPEEDS
            .iter()
            .flat_map(|&(omega, _)| {
                starts.iter().map(move |&x0| LaneSpec {
                    omega,
                    x0,
                    param_set: 0,
                })
            })
            .collect();
        EnsembleSpec {
            param_sets: vec![self.params.clone()],
            lanes,
            transient: p.survey_transient,
            recorded: p.survey_periods,
            stepper: Default::default(),
            precision: self.precision,
        }
    }

    /// The full spectra's settings.
    pub fn spectrum_config(&self) -> SpectrumConfig {
        SpectrumConfig {
            transient: self.preset.spectrum_transient,
            min_time: self.preset.spectrum_min_time,
            max_time: self.preset.spectrum_max_time,
            ..SpectrumConfig::default()
        }
    }

    /// Figs. 7-8: the basin at 133 rad/s over the rotor's x_r and vx_r.
    pub fn basin(&self) -> BasinSpec {
        let p = &self.preset;
        BasinSpec {
            params: self.params.clone(),
            omega: 133.0,
            x: Axis {
                coord: X_R,
                lo: -0.006,
                hi: 0.006,
                n: p.basin_n,
            },
            y: Axis {
                coord: VX_R,
                lo: -1.0,
                hi: 1.0,
                n: p.basin_n,
            },
            base: self.params.static_equilibrium(),
            transient: p.basin_transient,
            recorded: p.basin_periods,
            stepper: Default::default(),
            precision: self.precision,
            backend: self.backend,
            catalogue: self.catalogue,
            chunk: None,
            lyapunov: false,
        }
    }

    /// Fig. 7's study: [`ReproduceSpec::basin`] refined and re-integrated as the preset
    /// asks, with the traces of Fig. 8.
    pub fn basin_study(&self) -> BasinStudy {
        BasinStudy {
            refine: self.preset.basin_refine,
            uncertainty_samples: self.preset.uncertainty_samples,
            traces: crate::defaults::basin::TRACES,
            ..BasinStudy::new(self.basin())
        }
    }

    /// A trajectory from the static equilibrium at `omega`, the last `ts` periods kept
    /// as a time series.
    pub fn from_static(&self, omega: f64, transient: u32, periods: u32, ts: u32) -> SimulateSpec {
        SimulateSpec {
            params: self.params.clone(),
            omega,
            x0: self.params.static_equilibrium(),
            transient,
            periods,
            timeseries_periods: ts.min(periods),
            integrator: Integrator::Lane,
            stepper: Default::default(),
            article: Default::default(),
            classify: Default::default(),
        }
    }

    /// Figs. 5-6 (and the class at 133 and the rub figures at 132.2): 1000 transient
    /// periods, 64 recorded, the last 4 as a time series.
    pub fn portrait(&self, omega: f64) -> SimulateSpec {
        self.from_static(omega, 1000, 64, 4)
    }

    /// Figs. 9-12: the sections at 135 and 140 rad/s, the last 8 periods as a time series.
    pub fn section(&self, omega: f64) -> SimulateSpec {
        let p = &self.preset;
        self.from_static(omega, p.section_transient, p.section_points, 8)
    }

    /// The design chart over rotor speed and unbalance (W 128..142 rad/s, e 0.2..2 mm).
    pub fn design_map(&self) -> MapSpec {
        let p = &self.preset;
        self.map(
            MapAxis {
                var: MapVar::Omega,
                lo: 128.0,
                hi: 142.0,
                n: p.map_nx,
                log: false,
            },
            MapAxis {
                var: MapVar::Param("e"),
                lo: 0.0002,
                hi: 0.002,
                n: p.map_ny,
                log: false,
            },
            p.map_ics,
            true,
        )
    }

    /// The rub map over rotor speed and friction (W 60..300 rad/s, mu 0..0.3), from the
    /// static equilibrium alone, without lambda_1.
    pub fn rub_map(&self) -> MapSpec {
        let p = &self.preset;
        self.map(
            MapAxis {
                var: MapVar::Omega,
                lo: 60.0,
                hi: 300.0,
                n: p.rub_nx,
                log: false,
            },
            MapAxis {
                var: MapVar::Param("mu"),
                lo: 0.0,
                hi: 0.3,
                n: p.rub_ny,
                log: false,
            },
            1,
            false,
        )
    }

    fn map(&self, x: MapAxis, y: MapAxis, ics: u32, lyapunov: bool) -> MapSpec {
        MapSpec {
            params: self.params.clone(),
            omega: None,
            x,
            y,
            ics,
            seed: 1,
            transient: self.preset.map_transient,
            recorded: self.preset.map_periods,
            stepper: Default::default(),
            precision: self.precision,
            backend: self.backend,
            catalogue: self.catalogue,
            lyapunov,
            chunk: None,
        }
    }

    /// The continuation over 130..141 rad/s, run-up and run-down.
    pub fn continuation(&self) -> ContinuationSpec {
        let p = &self.preset;
        ContinuationSpec {
            params: self.params.clone(),
            omega: None,
            param: MapAxis {
                var: MapVar::Omega,
                lo: 130.0,
                hi: 141.0,
                n: p.cont_values,
                log: false,
            },
            ics: p.cont_ics,
            start_box: None,
            seed: 1,
            transient: p.cont_transient,
            recorded: p.cont_periods,
            stepper: Default::default(),
            precision: self.precision,
            backend: self.backend,
            catalogue: self.catalogue,
            lyapunov: true,
            directions: vec![Direction::Up, Direction::Down],
            match_threshold: f64::INFINITY,
        }
    }

    /// The full-spectrum cascade over 100..200 rad/s, run-up and run-down.
    pub fn cascade(&self) -> Result<CascadeSpec> {
        Ok(CascadeSpec {
            params: self.params.clone(),
            omegas: jeffcott_core::ensemble::parse_range(
                "omega",
                &format!("100:200:{}", self.preset.cascade_speeds),
            )?,
            transient_first: 1000,
            transient: 100,
            periods: 24,
            max_order: 4.0,
            stepper: Default::default(),
            up: true,
            down: true,
        })
    }

    /// The rotor thrown backward into the stator ([`THROW`]) at 140 rad/s with friction
    /// `mu` and contact stiffness `k_c`: 1000 transient periods, 8 recorded.
    pub fn throw(&self, mu: f64, k_c: f64) -> SimulateSpec {
        let params = Params {
            mu,
            k_c,
            ..self.params.clone()
        };
        let mut x0 = params.static_equilibrium();
        x0[X_R] = THROW.0;
        x0[VY_R] = THROW.1;
        SimulateSpec {
            x0,
            timeseries_periods: 1,
            ..SimulateSpec {
                params,
                ..self.from_static(140.0, 1000, 8, 1)
            }
        }
    }
}

/// The survey at the article's speeds and their full spectra, which the sections and
/// the summary table quote.
#[derive(Clone, Debug)]
pub struct Survey {
    /// Per article speed, the catalogue of the seeded start states (lambda_1 per lane).
    pub catalogues: Vec<Catalogue>,
    /// Wall time of the survey [s].
    pub seconds: f64,
    /// Per article speed, the full spectrum from the static equilibrium.
    pub spectra: Vec<Spectrum>,
    /// Wall time of the spectra [s].
    pub spectra_seconds: f64,
}

impl Survey {
    /// The catalogues of a survey ensemble ([`ReproduceSpec::survey`]) run with
    /// lambda_1: its lanes split per speed, each speed's lanes catalogued.
    pub fn catalogues(spec: &ReproduceSpec, res: &EnsembleResult) -> Vec<Catalogue> {
        let k = spec.preset.survey_ics as usize;
        let per_lane = res.recorded * jeffcott_core::model::STATE_DIM;
        ARTICLE_SPEEDS
            .iter()
            .enumerate()
            .map(|(i, &(omega, _))| {
                let lanes = i * k..(i + 1) * k;
                let sub = EnsembleResult {
                    poincare: res.poincare[lanes.start * per_lane..lanes.end * per_lane].to_vec(),
                    recorded: res.recorded,
                    final_state: res.final_state[lanes.clone()].to_vec(),
                    status: res.status[lanes.clone()].to_vec(),
                    counters: res.counters[lanes.clone()].to_vec(),
                    lambda1: res.lambda1.as_ref().map(|l| l[lanes.clone()].to_vec()),
                };
                catalogue_result(omega, &sub, sub.lambda1.as_deref(), &spec.catalogue)
            })
            .collect()
    }

    /// Runs the survey ensemble on `engine` (with lambda_1 per lane, so aperiodic
    /// attractors are told apart as quasiperiodic or chaotic) and catalogues it;
    /// `ctl.progress` counts lane-periods. Returns the catalogues and the wall time.
    pub fn run_survey(
        spec: &ReproduceSpec,
        engine: &crate::backend::Engine,
        ctl: Control,
    ) -> Result<(Vec<Catalogue>, f64)> {
        let t = std::time::Instant::now();
        let (res, _) = engine.run(&spec.survey(), true, ctl)?;
        Ok((Self::catalogues(spec, &res), t.elapsed().as_secs_f64()))
    }

    /// The full spectrum at each article speed from the static equilibrium (independent,
    /// in parallel). Returns the spectra and the wall time.
    pub fn run_spectra(spec: &ReproduceSpec) -> Result<(Vec<Spectrum>, f64)> {
        use rayon::prelude::*;
        let t = std::time::Instant::now();
        let cfg = spec.spectrum_config();
        let eq = spec.params.static_equilibrium();
        let spectra = ARTICLE_SPEEDS
            .par_iter()
            .map(|&(omega, _)| spectrum(&spec.params, omega, &eq, &cfg))
            .collect::<Result<Vec<_>>>()?;
        Ok((spectra, t.elapsed().as_secs_f64()))
    }

    /// The spectrum at `omega`, if it is an article speed.
    pub fn spectrum(&self, omega: f64) -> Option<&Spectrum> {
        self.spectra.iter().find(|s| s.omega == omega)
    }

    /// The class from the static equilibrium at `omega`, an aperiodic one refined by the
    /// full spectrum's lambda_1: quasiperiodic when |lambda_1| < `lambda_tol`, chaotic
    /// above.
    pub fn refine(&self, class: Class, omega: f64, lambda_tol: f64) -> Class {
        match (class, self.spectrum(omega).map(|s| s.exponents[0])) {
            (Class::Aperiodic, Some(l)) if l.abs() < lambda_tol => Class::Quasiperiodic,
            (Class::Aperiodic, Some(l)) if l > lambda_tol => Class::Chaotic,
            (c, _) => c,
        }
    }
}

/// The sum of the Lyapunov exponents for viscous damping with no saltation (S = I),
/// MODEL.md 6: -2 (2 xi_r w_r + 2 xi_s w_s) [1/s].
pub fn sum_rule(p: &Params) -> f64 {
    -2.0 * (2.0 * p.xi_r * p.omega_r + 2.0 * p.xi_s * p.omega_s)
}

/// What a quasistatic sweep found: speeds per kind of response.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SweepCounts {
    /// Speeds of the sweep.
    pub speeds: usize,
    /// Period-1 (of those not diverged).
    pub period1: usize,
    /// Periodic with period > 1.
    pub higher_period: usize,
    /// No period up to the classifier's n_max.
    pub aperiodic: usize,
    /// Of all speeds, quasiperiodic by lambda_1.
    pub quasiperiodic: usize,
    /// Of all speeds, chaotic by lambda_1.
    pub chaotic: usize,
    /// Diverged.
    pub diverged: usize,
}

impl SweepCounts {
    /// The counts of sweep `sw`.
    pub fn of(sw: &[SweepPoint]) -> Self {
        let count = |f: &dyn Fn(Option<usize>) -> bool| {
            sw.iter()
                .filter(|q| !q.status.is_frozen() && f(q.class.class.period()))
                .count()
        };
        let class = |c: Class| sw.iter().filter(|q| q.class.class == c).count();
        SweepCounts {
            speeds: sw.len(),
            period1: count(&|n| n == Some(1)),
            higher_period: count(&|n| n.is_some_and(|n| n > 1)),
            aperiodic: count(&|n| n.is_none()),
            quasiperiodic: class(Class::Quasiperiodic),
            chaotic: class(Class::Chaotic),
            diverged: sw.iter().filter(|q| q.status.is_frozen()).count(),
        }
    }
}

/// What the lambda_1 panel under a sweep shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Lambda1Row {
    /// The threshold of "positive" [1/s].
    pub tol: f64,
    /// Speeds with a finite lambda_1.
    pub finite: usize,
    /// Of them, above `tol`.
    pub positive: usize,
    /// The largest [1/s].
    pub largest: f64,
    /// (lambda_1, speed) of the sweep point nearest each speed asked for.
    pub at: Vec<Option<(f64, f64)>>,
}

impl Lambda1Row {
    /// The row of sweep `sw`, with the points nearest `speeds`.
    pub fn of(sw: &[SweepPoint], tol: f64, speeds: &[f64]) -> Self {
        let f: Vec<f64> = sw
            .iter()
            .map(|q| q.lambda1)
            .filter(|l| l.is_finite())
            .collect();
        Lambda1Row {
            tol,
            finite: f.len(),
            positive: f.iter().filter(|&&l| l > tol).count(),
            largest: f.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            at: speeds
                .iter()
                .map(|&w| {
                    sw.iter()
                        .min_by(|a, b| (a.omega - w).abs().total_cmp(&(b.omega - w).abs()))
                        .map(|q| (q.lambda1, q.omega))
                })
                .collect(),
        }
    }
}

/// The first speed of an up sweep where it leaves the period-1 branch it reached.
pub fn leaves_period1(up: &[SweepPoint]) -> Option<f64> {
    up.iter()
        .skip_while(|q| q.class.class.period() != Some(1))
        .find(|q| q.class.class.period() != Some(1))
        .map(|q| q.omega)
}

/// Speeds where the up and down sweeps differ in class (without the lambda_1
/// refinement): the hysteresis the down-sweep figure shows.
pub fn up_down_differ(res: &BifurcationResult) -> Vec<f64> {
    res.up
        .iter()
        .zip(&res.down)
        .filter(|(u, d)| u.class.class.unrefined() != d.class.class.unrefined())
        .map(|(u, _)| u.omega)
        .collect()
}

/// The periods an up sweep met, ascending, each once.
pub fn periods_seen(up: &[SweepPoint]) -> Vec<usize> {
    let mut periods: Vec<usize> = up.iter().filter_map(|q| q.class.class.period()).collect();
    periods.sort();
    periods.dedup();
    periods
}

/// What the brute force found: coexisting attractors per speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BruteCounts {
    /// Speeds brute-forced.
    pub speeds: usize,
    /// Of them, with more than one attractor.
    pub multistable: usize,
    /// The most attractors at one speed.
    pub most: usize,
    /// The (last) speed with that many [rad/s].
    pub most_at: f64,
}

impl BruteCounts {
    /// The counts of a study's brute force.
    pub fn of(res: &BifurcationResult) -> Self {
        let (most, most_at) = res
            .brute
            .iter()
            .map(|b| (b.catalogue.attractors.len(), b.omega))
            .max_by_key(|x| x.0)
            .unwrap_or((0, 0.0));
        BruteCounts {
            speeds: res.brute.len(),
            multistable: res
                .brute
                .iter()
                .filter(|b| b.catalogue.attractors.len() > 1)
                .count(),
            most,
            most_at,
        }
    }
}

/// What the design chart shows: cells per response from the static equilibrium, where
/// the rotor rubs, and along the row of unbalance nearest a given one.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFindings {
    /// Period-1 cells.
    pub period1: usize,
    /// Chaotic cells.
    pub chaotic: usize,
    /// Quasiperiodic cells.
    pub quasiperiodic: usize,
    /// Cells whose response touches the stator.
    pub rubbing: usize,
    /// Cells holding coexisting attractors.
    pub multistable: usize,
    /// The largest peak normal contact force [N].
    pub peak_force: f64,
    /// The row nearest the unbalance asked for: its value [m].
    pub row_value: f64,
    /// The speeds of that row where the rotor rubs [rad/s].
    pub rub_speeds: Vec<f64>,
}

impl MapFindings {
    /// The findings of a map whose y axis is the unbalance e, with the row nearest `e`.
    pub fn of(spec: &MapSpec, res: &MapResult, e: f64) -> Self {
        let cells = res.class.len();
        let count = |f: &dyn Fn(usize) -> bool| (0..cells).filter(|&i| f(i)).count();
        let nx = spec.x.n;
        let row = (0..spec.y.n)
            .min_by(|&a, &b| {
                (spec.y.value(a) - e)
                    .abs()
                    .total_cmp(&(spec.y.value(b) - e).abs())
            })
            .unwrap_or(0);
        MapFindings {
            period1: count(&|i| res.period[i] == 1),
            chaotic: count(&|i| res.class[i] == code::CHAOTIC),
            quasiperiodic: count(&|i| res.class[i] == code::QUASIPERIODIC),
            rubbing: count(&|i| res.contact[i] > 0.0),
            multistable: count(&|i| res.attractors[i] > 1),
            peak_force: res
                .peak_force
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max),
            row_value: spec.y.value(row),
            rub_speeds: (0..nx)
                .filter(|&ix| res.contact[row * nx + ix] > 0.0)
                .map(|ix| spec.x.value(ix))
                .collect(),
        }
    }
}

/// The largest one-step tipping probability of a ramp away from an attractor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tipping {
    /// The probability.
    pub probability: f64,
    /// The value at the step it leaves from.
    pub value: f64,
    /// The attractor it leaves.
    pub from: usize,
    /// Where it goes: an attractor, or `ids` for divergence.
    pub to: usize,
}

/// What a continuation ramp found.
#[derive(Clone, Debug, PartialEq)]
pub struct RampFindings {
    /// The ramp's direction.
    pub direction: Direction,
    /// Attractors followed.
    pub ids: usize,
    /// The most at one value.
    pub most: usize,
    /// Steps of the ramp.
    pub steps: usize,
    /// The values where two or more attractors have a basin.
    pub coexist: Vec<f64>,
    /// The largest one-step tipping probability (zero when nothing tips).
    pub worst: Tipping,
}

impl RampFindings {
    /// The findings of ramp `r`.
    pub fn of(r: &Ramp) -> Self {
        let g = r.ids + 1;
        let tip = r.tipping();
        let mut worst = Tipping {
            probability: 0.0,
            value: 0.0,
            from: 0,
            to: 0,
        };
        for k in 0..r.steps.len().saturating_sub(1) {
            for i in 0..r.ids {
                for j in 0..g {
                    let v = tip[(k * g + i) * g + j];
                    if j != i && v.is_finite() && v > worst.probability {
                        worst = Tipping {
                            probability: v,
                            value: r.steps[k].value,
                            from: i,
                            to: j,
                        };
                    }
                }
            }
        }
        RampFindings {
            direction: r.direction,
            ids: r.ids,
            most: r
                .steps
                .iter()
                .map(|s| s.attractors.len())
                .max()
                .unwrap_or(0),
            steps: r.steps.len(),
            coexist: r
                .steps
                .iter()
                .filter(|s| s.attractors.iter().filter(|a| a.fraction > 0.0).count() > 1)
                .map(|s| s.value)
                .collect(),
            worst,
        }
    }
}

/// Where one rub regime lies on the rub map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegimeCells {
    /// The regime.
    pub regime: RubRegime,
    /// Its cells.
    pub cells: usize,
    /// The speeds it spans [rad/s] (lo, hi); `None` where it is nowhere.
    pub x: Option<(f64, f64)>,
    /// The y values (friction) it spans.
    pub y: Option<(f64, f64)>,
}

/// Every regime's cells on map `res`, in the order no contact, partial rub, full annular
/// rub, backward whirl, diverged.
pub fn regime_cells(spec: &MapSpec, res: &MapResult) -> Vec<RegimeCells> {
    let nx = spec.x.n;
    let span = |v: Vec<f64>| {
        (!v.is_empty()).then(|| {
            (
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        })
    };
    RubRegime::ALL
        .into_iter()
        .map(|regime| {
            let cells: Vec<usize> = (0..res.regime.len())
                .filter(|&i| res.regime[i] == regime.code())
                .collect();
            RegimeCells {
                regime,
                cells: cells.len(),
                x: span(cells.iter().map(|&i| spec.x.value(i % nx)).collect()),
                y: span(cells.iter().map(|&i| spec.y.value(i / nx)).collect()),
            }
        })
        .collect()
}

/// Where a backward throw ends.
#[derive(Clone, Debug)]
pub enum ThrowOutcome {
    /// The lane left the divergence bound (or became non-finite) within the periods
    /// integrated.
    Diverged {
        /// The lane's status.
        status: Status,
        /// Forcing periods integrated.
        periods: u32,
    },
    /// It settled; the rub figures and spectra over 24 periods from its final state.
    Settled(Box<RubOutputs>),
    /// It settled, but the stretch of the rub figures diverged.
    StretchDiverged,
}

/// Integrates a backward throw ([`ReproduceSpec::throw`]) and takes its rub figures.
pub fn throw(spec: &ReproduceSpec, mu: f64, k_c: f64) -> Result<ThrowOutcome> {
    let s = spec.throw(mu, k_c);
    let r = simulate(&s)?;
    if r.status.is_frozen() {
        return Ok(ThrowOutcome::Diverged {
            status: r.status,
            periods: s.transient + s.periods,
        });
    }
    Ok(
        match rub_outputs(&s.params, s.omega, &r.final_state, 24, &Default::default())? {
            Some(o) => ThrowOutcome::Settled(Box::new(o)),
            None => ThrowOutcome::StretchDiverged,
        },
    )
}

/// A row of the summary table at the top of REPORT.md.
#[derive(Clone, Debug)]
pub struct SummaryRow<'a> {
    /// The article speed [rad/s].
    pub omega: f64,
    /// What the article reports there.
    pub article: &'static str,
    /// The class from the static equilibrium (refined by lambda_1), if simulated.
    pub static_class: Option<Class>,
    /// The full spectrum there.
    pub spectrum: Option<&'a Spectrum>,
    /// The survey's catalogue there.
    pub survey: &'a Catalogue,
}

/// The summary table: per article speed, the class from the static equilibrium found
/// by the sections (`static_class`: speed, class), the spectrum and the survey.
pub fn summary_rows<'a>(survey: &'a Survey, static_class: &[(f64, Class)]) -> Vec<SummaryRow<'a>> {
    ARTICLE_SPEEDS
        .iter()
        .enumerate()
        .map(|(i, &(omega, article))| SummaryRow {
            omega,
            article,
            static_class: static_class
                .iter()
                .find(|(w, _)| *w == omega)
                .map(|&(_, c)| c),
            spectrum: survey.spectrum(omega),
            survey: &survey.catalogues[i],
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// The figure set as one study
// ---------------------------------------------------------------------------------------

/// Steps of the figure set; the last, the report, is the host's.
pub const STEPS: usize = 11;

/// What the figure set needs from the program that runs it. The command line shows a
/// progress bar per study, keeps every study's units in one run directory (so an
/// interrupted set resumes where it stopped), then draws each section's figures, writes
/// its studies' files and words REPORT.md.
pub trait Host: crate::run::Host {
    /// Step `step` of [`STEPS`] begins; `what` it computes.
    fn begin(&mut self, step: usize, what: &str);
    /// One section's results, in the order of the set, as soon as they are computed
    /// (they are dropped after).
    fn section(&mut self, section: Section<'_>) -> Result<()>;
}

/// A backward throw and where it ended.
#[derive(Clone, Debug)]
pub struct Throw {
    /// Friction coefficient.
    pub mu: f64,
    /// Contact stiffness [N/m].
    pub k_c: f64,
    /// Where it ended.
    pub outcome: ThrowOutcome,
}

/// The results of one section of the figure set.
pub enum Section<'a> {
    /// Figs. 3-4, the down sweep and the brute force: one study over 130..141 rad/s.
    Bifurcation {
        /// The study.
        spec: &'a BifurcationSpec,
        /// Its result.
        res: &'a BifurcationResult,
    },
    /// Enlargement `k` of Fig. 3, over [`ZOOMS`]`[k]`.
    Zoom {
        /// Which enlargement.
        k: usize,
        /// The study (an up sweep).
        spec: &'a BifurcationSpec,
        /// Its result.
        res: &'a BifurcationResult,
        /// Wall time [s].
        seconds: f64,
    },
    /// Fig. 5 or 6: the response from the static equilibrium at `omega`.
    Portrait {
        /// 5 or 6.
        figure: usize,
        /// Rotor speed [rad/s].
        omega: f64,
        /// The trajectory ([`ReproduceSpec::portrait`]).
        res: &'a SimulateResult,
        /// Its class, refined by the full spectrum's lambda_1.
        class: Class,
        /// The survey, for the text.
        survey: &'a Survey,
        /// Wall time [s].
        seconds: f64,
    },
    /// Figs. 7-8: the basin at 133 rad/s at its finest resolution, with the refinement
    /// and the re-integration, and the class from the static equilibrium there.
    Basin {
        /// The study's outcome: the coarse and finest grids, labels and catalogue,
        /// refinement, re-integration, rub figures, traces and measures.
        outcome: &'a BasinOutcome,
        /// The class from the static equilibrium, refined by lambda_1.
        class: Class,
        /// The survey, for the text.
        survey: &'a Survey,
        /// Wall time of the basin study, all its stages [s].
        seconds: f64,
    },
    /// Figs. 9-12: the section from the static equilibrium at 135 or 140 rad/s.
    Section {
        /// Index in [`ARTICLE_SPEEDS`].
        index: usize,
        /// Rotor speed [rad/s].
        omega: f64,
        /// The trajectory ([`ReproduceSpec::section`]).
        res: &'a SimulateResult,
        /// Its class, refined by lambda_1.
        class: Class,
        /// The survey, for the text.
        survey: &'a Survey,
        /// Wall time [s].
        seconds: f64,
    },
    /// The design chart over rotor speed and unbalance.
    DesignChart {
        /// The map.
        spec: &'a MapSpec,
        /// Its cells.
        res: &'a MapResult,
        /// What it shows.
        findings: &'a MapFindings,
        /// Wall time [s].
        seconds: f64,
    },
    /// The attractor continuation over rotor speed.
    Continuation {
        /// The continuation.
        spec: &'a ContinuationSpec,
        /// Its ramps.
        res: &'a ContinuationResult,
        /// What each ramp found.
        ramps: &'a [RampFindings],
        /// Wall time [s].
        seconds: f64,
    },
    /// The rub map over rotor speed and friction, and the backward throws.
    RubMap {
        /// The map.
        spec: &'a MapSpec,
        /// Its cells.
        res: &'a MapResult,
        /// Where each regime lies.
        regimes: &'a [RegimeCells],
        /// The throws with stiff and soft contact.
        throws: &'a [Throw],
        /// The natural frequencies with the soft contact [rad/s].
        soft_modes: &'a [(String, f64)],
        /// Wall time [s].
        seconds: f64,
    },
    /// The full-spectrum cascade.
    Cascade {
        /// The cascade.
        spec: &'a CascadeSpec,
        /// Its spectra.
        res: &'a CascadeResult,
        /// Wall time [s].
        seconds: f64,
    },
    /// The full spectrum and contact loads at `omega` (none when the stretch diverged).
    Spectrum {
        /// Rotor speed [rad/s].
        omega: f64,
        /// The trajectory ([`ReproduceSpec::portrait`]).
        res: &'a SimulateResult,
        /// Its rub figures, spectra and contact history.
        rub: Option<&'a RubOutputs>,
        /// Wall time [s].
        seconds: f64,
    },
}

/// What the report's head quotes once every section is done.
#[derive(Clone, Debug)]
pub struct ReproduceResult {
    /// The survey and the full spectra at the article's speeds.
    pub survey: Survey,
    /// The class from the static equilibrium at each article speed simulated.
    pub static_class: Vec<(f64, Class)>,
}

/// Computes the figure set, section by section, handing each section's results to
/// `host` as they come. Every lane study keeps its units in `host.store()` under its own
/// prefix, so a set interrupted and started again resumes where it stopped.
pub fn reproduce<H: Host>(spec: &ReproduceSpec, host: &mut H) -> Result<ReproduceResult> {
    use std::time::Instant;
    let engine = crate::backend::Engine::new(spec.backend, spec.precision)?;
    let p = spec.preset;
    let lambda_tol = spec.catalogue.lambda_tol;

    host.begin(1, "bifurcation diagram over 130..141 rad/s");
    let b = spec.bifurcation()?;
    let res = run_bifurcation(host, &b, "bifurcation")?;
    host.section(Section::Bifurcation {
        spec: &b,
        res: &res,
    })?;
    drop(res);

    host.begin(2, "enlargements of Fig. 3");
    for k in 0..ZOOMS.len() {
        let t = Instant::now();
        let z = spec.zoom(k)?;
        let res = run_bifurcation(host, &z, ["zoom0", "zoom1"][k])?;
        host.section(Section::Zoom {
            k,
            spec: &z,
            res: &res,
            seconds: t.elapsed().as_secs_f64(),
        })?;
    }

    host.begin(3, "attractor survey at the article's speeds");
    let per_lane = (p.survey_transient + p.survey_periods) as u64;
    let lanes = ARTICLE_SPEEDS.len() as u64 * p.survey_ics as u64;
    let (catalogues, seconds) = host.progress("survey", lanes * per_lane, per_lane, |ctl| {
        Survey::run_survey(spec, &engine, ctl)
    })?;
    host.begin(4, "Lyapunov spectra at the article's speeds");
    let (spectra, spectra_seconds) = Survey::run_spectra(spec)?;
    let survey = Survey {
        catalogues,
        seconds,
        spectra,
        spectra_seconds,
    };
    let mut static_class = Vec::new();

    host.begin(5, "phase portraits at 131.7 and 132.2 rad/s");
    for (figure, omega) in [(5, 131.7), (6, 132.2)] {
        let t = Instant::now();
        let res = simulate(&spec.portrait(omega))?;
        let class = survey.refine(res.classification.class, omega, lambda_tol);
        static_class.push((omega, class));
        host.section(Section::Portrait {
            figure,
            omega,
            res: &res,
            class,
            survey: &survey,
            seconds: t.elapsed().as_secs_f64(),
        })?;
    }

    host.begin(6, "basin of attraction at 133 rad/s");
    let t = Instant::now();
    let outcome = crate::basin::study::run(
        &spec.basin_study(),
        &engine,
        &crate::run::PrefixedHost::new(&*host, "basin_133"),
    )?;
    let r133 = simulate(&spec.portrait(133.0))?;
    let class = survey.refine(r133.classification.class, 133.0, lambda_tol);
    static_class.push((133.0, class));
    host.section(Section::Basin {
        outcome: &outcome,
        class,
        survey: &survey,
        seconds: t.elapsed().as_secs_f64(),
    })?;
    drop(outcome);

    host.begin(
        7,
        "phase portraits and Poincare sections at 135 and 140 rad/s",
    );
    for (index, omega) in [(3, 135.0), (4, 140.0)] {
        let t = Instant::now();
        let res = simulate(&spec.section(omega))?;
        let class = survey.refine(res.classification.class, omega, lambda_tol);
        static_class.push((omega, class));
        host.section(Section::Section {
            index,
            omega,
            res: &res,
            class,
            survey: &survey,
            seconds: t.elapsed().as_secs_f64(),
        })?;
    }

    host.begin(8, "design chart: speed against unbalance");
    let t = Instant::now();
    let m = spec.design_map();
    let res = run_map(host, &engine, &m, "map_w_e")?;
    host.section(Section::DesignChart {
        spec: &m,
        res: &res,
        findings: &MapFindings::of(&m, &res, 0.001),
        seconds: t.elapsed().as_secs_f64(),
    })?;
    drop(res);

    host.begin(9, "attractor continuation over 130..141 rad/s");
    let t = Instant::now();
    let c = spec.continuation();
    let per_lane = (c.transient + c.recorded) as u64;
    let store = Prefixed {
        inner: host.store(),
        prefix: "continuation",
    };
    let res = host.progress("continuation", c.lane_periods(), per_lane, |ctl| {
        crate::continuation::continuation_with(&c, &engine, &store, ctl)
    })?;
    let ramps: Vec<RampFindings> = res.ramps.iter().map(RampFindings::of).collect();
    host.section(Section::Continuation {
        spec: &c,
        res: &res,
        ramps: &ramps,
        seconds: t.elapsed().as_secs_f64(),
    })?;
    drop(res);

    host.begin(
        10,
        "rub regimes: (W, mu) map, full-spectrum cascade, full spectrum at 132.2",
    );
    let t = Instant::now();
    let r = spec.rub_map();
    let res = run_map(host, &engine, &r, "map_w_mu")?;
    // Backward whirl from a backward throw, stiff and soft contact (docs/rub.md).
    let throws = [(0.3, 1e8), (0.25, 1e6)]
        .into_iter()
        .map(|(mu, k_c)| {
            Ok(Throw {
                mu,
                k_c,
                outcome: throw(spec, mu, k_c)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let soft_modes = crate::rub::natural_frequencies(&Params {
        k_c: 1e6,
        ..spec.params.clone()
    });
    host.section(Section::RubMap {
        spec: &r,
        res: &res,
        regimes: &regime_cells(&r, &res),
        throws: &throws,
        soft_modes: &soft_modes,
        seconds: t.elapsed().as_secs_f64(),
    })?;
    drop(res);
    let t = Instant::now();
    let k = spec.cascade()?;
    let speeds = k.omegas.len() as u64 * 2;
    let store = Prefixed {
        inner: host.store(),
        prefix: "cascade",
    };
    let res = host.progress("cascade", speeds, 1, |ctl| {
        crate::cascade::cascade_with(&k, &store, ctl)
    })?;
    host.section(Section::Cascade {
        spec: &k,
        res: &res,
        seconds: t.elapsed().as_secs_f64(),
    })?;
    drop(res);
    let t = Instant::now();
    let s = spec.portrait(132.2);
    let res = simulate(&s)?;
    let rub = rub_outputs(
        &s.params,
        s.omega,
        &res.final_state,
        24,
        &Default::default(),
    )?;
    host.section(Section::Spectrum {
        omega: s.omega,
        res: &res,
        rub: rub.as_ref(),
        seconds: t.elapsed().as_secs_f64(),
    })?;
    Ok(ReproduceResult {
        survey,
        static_class,
    })
}

/// A bifurcation study of the set, its units under `prefix`.
fn run_bifurcation<H: Host>(
    host: &H,
    b: &BifurcationSpec,
    prefix: &'static str,
) -> Result<BifurcationResult> {
    let store = Prefixed {
        inner: host.store(),
        prefix,
    };
    let per_lane = (b.brute_transient + b.recorded) as u64;
    host.progress(
        "bifurcation",
        crate::bifurcation::work(b),
        per_lane,
        |ctl| crate::bifurcation::bifurcation_with(b, &store, ctl),
    )
}

/// A map of the set, its units under `prefix`.
fn run_map<H: Host>(
    host: &H,
    engine: &crate::backend::Engine,
    m: &MapSpec,
    prefix: &'static str,
) -> Result<MapResult> {
    let store = Prefixed {
        inner: host.store(),
        prefix,
    };
    let per_lane = (m.transient + m.recorded) as u64;
    host.progress("map", m.lane_periods(), per_lane, |ctl| {
        crate::map::map_with(m, engine, &store, ctl)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::UnitStore;

    #[test]
    fn the_sum_rule_is_the_trace_of_the_models_jacobian_out_of_contact() {
        // Liouville: out of contact the exponents sum to the (constant) trace of the
        // Jacobian; the model's own Jacobian at the static equilibrium is independent of
        // the closed form.
        let p = Params::default();
        let j = jeffcott_core::model::jacobian(&p, &p.static_equilibrium());
        let trace: f64 = (0..8).map(|i| j[i][i]).sum();
        let rule = sum_rule(&p);
        assert!(rule < 0.0);
        assert!(
            (rule - trace).abs() <= 1e-12 * trace.abs(),
            "{rule} vs {trace}"
        );
    }

    #[test]
    fn the_survey_holds_every_start_state_at_every_article_speed_speed_major() {
        let spec = ReproduceSpec::new(SMOKE, Backend::Cpu, Precision::F64);
        let e = spec.survey();
        let k = SMOKE.survey_ics as usize;
        assert_eq!(e.lanes.len(), ARTICLE_SPEEDS.len() * k);
        for (i, &(w, _)) in ARTICLE_SPEEDS.iter().enumerate() {
            assert!(e.lanes[i * k..(i + 1) * k].iter().all(|l| l.omega == w));
            assert_eq!(e.lanes[i * k].x0, e.lanes[0].x0);
        }
    }

    #[test]
    fn every_study_of_the_smoke_set_is_valid() {
        let spec = ReproduceSpec::new(SMOKE, Backend::Cpu, Precision::F64);
        spec.bifurcation().unwrap().validate().unwrap();
        spec.zoom(0).unwrap().validate().unwrap();
        spec.zoom(1).unwrap().validate().unwrap();
        spec.basin().validate().unwrap();
        spec.design_map().validate().unwrap();
        spec.rub_map().validate().unwrap();
        spec.continuation().validate().unwrap();
        spec.cascade().unwrap().validate().unwrap();
        spec.throw(0.3, 1e8).validate().unwrap();
        spec.section(135.0).validate().unwrap();
        spec.spectrum_config().validate().unwrap();
    }

    #[test]
    fn a_throw_starts_displaced_and_moving_against_the_rotation() {
        let spec = ReproduceSpec::new(QUICK, Backend::Cpu, Precision::F64);
        let s = spec.throw(0.25, 1e6);
        assert_eq!((s.params.mu, s.params.k_c), (0.25, 1e6));
        assert_eq!((s.x0[X_R], s.x0[VY_R]), THROW);
        assert_eq!((s.omega, s.transient, s.periods), (140.0, 1000, 8));
    }

    #[test]
    fn the_survey_split_per_speed_equals_each_speed_run_and_catalogued_alone() {
        // The survey runs every article speed in one ensemble; splitting it must give
        // the catalogue of each speed's lanes run as their own ensemble (lanes are
        // independent, so their bits do not depend on their neighbours).
        let spec = ReproduceSpec::new(SMOKE, Backend::Cpu, Precision::F64);
        let all = spec.survey();
        let (res, _) = crate::backend::run(&all, Backend::Cpu, true, Control::none()).unwrap();
        let split = Survey::catalogues(&spec, &res);
        let k = SMOKE.survey_ics as usize;
        for (i, cat) in split.iter().enumerate() {
            let alone = EnsembleSpec {
                lanes: all.lanes[i * k..(i + 1) * k].to_vec(),
                ..all.clone()
            };
            let (r, _) = crate::backend::run(&alone, Backend::Cpu, true, Control::none()).unwrap();
            let want = catalogue_result(
                ARTICLE_SPEEDS[i].0,
                &r,
                r.lambda1.as_deref(),
                &spec.catalogue,
            );
            assert_eq!(cat.omega, ARTICLE_SPEEDS[i].0);
            assert_eq!(cat.lanes, k as u64);
            assert_eq!(cat.labels, want.labels, "speed {i}");
            assert_eq!(cat.attractors.len(), want.attractors.len());
        }
    }

    #[test]
    fn sweep_counts_partition_the_speeds_and_lambda1_rows_count_only_finite_values() {
        let spec = ReproduceSpec::new(SMOKE, Backend::Cpu, Precision::F64);
        let res =
            crate::bifurcation::bifurcation(&spec.bifurcation().unwrap(), Control::none()).unwrap();
        for sw in [&res.up, &res.down] {
            let n = SweepCounts::of(sw);
            assert_eq!(n.speeds, SMOKE.speeds);
            assert_eq!(
                n.period1 + n.higher_period + n.aperiodic + n.diverged,
                n.speeds
            );
            assert!(n.quasiperiodic + n.chaotic <= n.aperiodic + n.diverged);
            let row = Lambda1Row::of(sw, spec.catalogue.lambda_tol, &[131.7, 140.0]);
            assert_eq!(
                row.finite,
                sw.iter().filter(|q| q.lambda1.is_finite()).count()
            );
            assert!(row.positive <= row.finite);
            // The nearest points to 131.7 and 140 are the sweep's ends' neighbours.
            let (_, w) = row.at[1].unwrap();
            assert_eq!(w, *spec.bifurcation().unwrap().omegas.last().unwrap());
        }
        let b = BruteCounts::of(&res);
        assert_eq!(b.speeds, SMOKE.speeds);
        assert!(b.multistable <= b.speeds && b.most >= 1);
    }

    /// A host that keeps the units in memory, counts the lane-periods its progress
    /// displays report, and records what each section received.
    struct Recorder {
        store: crate::run::MemoryStore,
        sections: Vec<String>,
        steps: Vec<usize>,
        committed_by: std::sync::Mutex<Vec<(String, u64, u64)>>,
    }

    impl Host for Recorder {
        fn begin(&mut self, step: usize, _: &str) {
            self.steps.push(step);
        }
        fn section(&mut self, s: Section<'_>) -> Result<()> {
            self.record(s)
        }
    }

    impl crate::run::Host for Recorder {
        fn store(&self) -> &dyn UnitStore {
            &self.store
        }
        fn progress<T>(
            &self,
            label: &str,
            total: u64,
            _per_lane: u64,
            work: impl FnOnce(Control) -> Result<T>,
        ) -> Result<T> {
            let done = std::sync::atomic::AtomicU64::new(0);
            let report = |d: u64, _| {
                done.fetch_max(d, std::sync::atomic::Ordering::Relaxed);
            };
            let r = work(Control::progress(&report));
            self.committed_by
                .lock()
                .unwrap()
                .push((label.to_string(), done.into_inner(), total));
            r
        }
    }

    impl Recorder {
        fn record(&mut self, s: Section<'_>) -> Result<()> {
            self.sections.push(match s {
                Section::Bifurcation { spec, res } => {
                    assert_eq!(res.up.len(), spec.omegas.len());
                    format!("bifurcation {:?}", SweepCounts::of(&res.up))
                }
                Section::Zoom { k, res, .. } => format!("zoom {k} {:?}", periods_seen(&res.up)),
                Section::Portrait { figure, class, .. } => format!("fig{figure} {class:?}"),
                Section::Basin { outcome, class, .. } => {
                    let (coarse, spec, res) = (&outcome.coarse, &outcome.spec, &outcome.result);
                    let refined = &outcome.refined;
                    // One refinement level: (n - 1) 2 + 1 points per side.
                    assert_eq!(spec.x.n, (coarse.x.n - 1) * 2 + 1);
                    assert_eq!(res.labels.len(), spec.x.n * spec.y.n);
                    assert!(refined.is_some());
                    format!("basin {:?} {class:?}", res.labels)
                }
                Section::Section { omega, class, .. } => format!("section {omega} {class:?}"),
                Section::DesignChart { res, findings, .. } => {
                    assert!(findings.rubbing <= res.class.len());
                    format!("design {:?}", res.class)
                }
                Section::Continuation { ramps, .. } => format!("continuation {}", ramps.len()),
                Section::RubMap {
                    regimes, throws, ..
                } => {
                    let cells: usize = regimes.iter().map(|r| r.cells).sum();
                    format!("rub {cells} cells, {} throws", throws.len())
                }
                Section::Cascade { res, .. } => format!("cascade {}", res.orders.len()),
                Section::Spectrum { rub, .. } => format!("spectrum {}", rub.is_some()),
            });
            Ok(())
        }
    }

    #[test]
    fn the_smoke_set_hands_every_section_in_order_and_a_second_run_on_its_units_repeats_it() {
        let spec = ReproduceSpec::new(SMOKE, Backend::Cpu, Precision::F64);
        let mut host = Recorder {
            store: crate::run::MemoryStore::new(),
            sections: Vec::new(),
            steps: Vec::new(),
            committed_by: Default::default(),
        };
        let first = reproduce(&spec, &mut host).unwrap();
        assert_eq!(host.steps, (1..STEPS).collect::<Vec<_>>());
        let kinds: Vec<&str> = host
            .sections
            .iter()
            .map(|s| s.split(' ').next().unwrap())
            .collect();
        assert_eq!(
            kinds,
            [
                "bifurcation",
                "zoom",
                "zoom",
                "fig5",
                "fig6",
                "basin",
                "section",
                "section",
                "design",
                "continuation",
                "rub",
                "cascade",
                "spectrum"
            ]
        );
        // The summary table: a class at every article speed, in the survey's order.
        let rows = summary_rows(&first.survey, &first.static_class);
        assert!(
            rows.iter()
                .all(|r| r.static_class.is_some() && r.spectrum.is_some())
        );
        // Every lane study's progress reached its total (the brute force's is an upper
        // bound: its neighbour seeds are known only as they come; the refinement's is a
        // scale, its boundary lanes unknown in advance).
        for (label, done, total) in host.committed_by.lock().unwrap().iter() {
            match label.as_str() {
                "refine" => {}
                "bifurcation" => assert!(done <= total, "{label}"),
                _ => assert_eq!(done, total, "{label}"),
            }
        }
        // Again on the same units: nothing is computed twice, every section is the same.
        let sections = std::mem::take(&mut host.sections);
        host.committed_by.lock().unwrap().clear();
        let again = reproduce(&spec, &mut host).unwrap();
        assert_eq!(host.sections, sections);
        assert_eq!(again.static_class, first.static_class);
    }
}
