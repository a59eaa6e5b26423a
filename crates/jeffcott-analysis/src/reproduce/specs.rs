//! [`ReproduceSpec`]: the specification of every study of the figure set, from its preset,
//! model and backend.

use super::*;
use crate::settings::LaneSettings;

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

    /// The lanes of every study: Table 1's model, the default stepper, the set's
    /// precision, backend and tolerances; lambda_1 with `lyapunov`.
    pub fn lane(&self, lyapunov: bool) -> LaneSettings {
        LaneSettings {
            params: self.params.clone(),
            stepper: Default::default(),
            precision: self.precision,
            backend: self.backend,
            catalogue: self.catalogue,
            lyapunov,
        }
    }

    /// Figs. 3-4, the down sweep and the brute force: one study over [130, 141].
    pub fn bifurcation(&self) -> Result<BifurcationSpec> {
        let p = &self.preset;
        Ok(BifurcationSpec {
            lane: self.lane(true),
            omegas: jeffcott_core::ensemble::parse_range(
                "omega",
                &format!("130:141:{}", p.speeds),
            )?,
            sweep: Some(Sweep::Both),
            transient_first: p.sweep_first,
            transient: p.sweep_transient,
            ics: p.ics,
            brute_transient: p.brute_transient,
            periods: p.periods,
            seed: 1,
            max_seeds: p.max_seeds,
        })
    }

    /// The periodic orbits over the bifurcation diagram's range: the period-1 branch from
    /// the attractor at 130 rad/s (settled from the static equilibrium), continued up to
    /// 141 rad/s through its folds, with the period-2 branch of every period doubling.
    pub fn orbits(&self) -> crate::orbits::OrbitsStudy {
        use crate::defaults::orbits as d;
        let branch = crate::orbits::BranchSpec {
            params: self.params.clone(),
            omega: f64::NAN,
            var: MapVar::Omega,
            lo: 130.0,
            hi: 141.0,
            start_value: 130.0,
            start: self.params.static_equilibrium(),
            period: 1,
            direction: 1.0,
            max_points: self.preset.orbit_points,
            ds: d::DS,
            ds_max: d::DS_MAX,
            shoot: jeffcott_core::orbit::ShootConfig::default(),
        };
        crate::orbits::OrbitsStudy {
            branch,
            settle: d::SETTLE,
            follow_doublings: true,
            starts: Vec::new(),
        }
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
            lane: self.lane(false),
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
            periods: p.basin_periods,
            lanes_per_unit: None,
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
            lane: self.lane(lyapunov),
            omega: None,
            x,
            y,
            ics,
            seed: 1,
            transient: self.preset.map_transient,
            periods: self.preset.map_periods,
            cells_per_unit: None,
        }
    }

    /// The continuation over 130..141 rad/s, run-up and run-down.
    pub fn continuation(&self) -> ContinuationSpec {
        let p = &self.preset;
        ContinuationSpec {
            lane: self.lane(true),
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
            periods: p.cont_periods,
            directions: vec![Direction::Up, Direction::Down],
            match_threshold: f64::INFINITY,
            values_per_unit: None,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::StudySpec;
    use serde::{Serialize, de::DeserializeOwned};

    /// `spec` written as `run.json` records it and read back.
    fn round_trip<T: Serialize + DeserializeOwned>(spec: &T) -> T {
        let json = serde_json::to_string(spec).unwrap();
        serde_json::from_str(&json).unwrap_or_else(|e| panic!("{e}: {json}"))
    }

    /// The recorded spec reads back equal to itself (the backend, not recorded, is
    /// `auto` on both sides).
    fn reads_back<T: StudySpec + PartialEq + std::fmt::Debug>(spec: &T) {
        let recorded = spec.resolved();
        assert_eq!(round_trip(&recorded), recorded);
    }

    #[test]
    fn every_study_spec_reads_back_from_its_record_unchanged() {
        for preset in [SMOKE, QUICK, FULL] {
            // The backend is not recorded: a spec read back runs on `auto`.
            let r = ReproduceSpec::new(preset, Backend::Auto, Precision::F64);
            // The study records its grid and stages; the entropy box and the traces,
            // computed from the units on every run, are not part of it.
            let basin = r.basin_study().resolved();
            assert_eq!(round_trip(&basin).basin, basin.basin);
            assert_eq!(basin.basin.lanes_per_unit, Some(basin.basin.unit_lanes()));
            reads_back(&basin.basin);
            reads_back(&r.design_map());
            reads_back(&r.rub_map());
            reads_back(&r.continuation());
            reads_back(&r.bifurcation().unwrap());
            reads_back(&r.cascade().unwrap());
        }
    }

    #[test]
    fn speeds_are_recorded_as_a_span_only_when_a_range_gives_them_bit_for_bit() {
        let mut k = ReproduceSpec::new(SMOKE, Backend::Auto, Precision::F64)
            .cascade()
            .unwrap();
        let v = serde_json::to_value(&k).unwrap();
        assert_eq!(v["omega"]["count"], serde_json::json!(k.omegas.len()));
        // One speed nudged by an ulp: no longer a range, so recorded value by value.
        k.omegas[1] = f64::from_bits(k.omegas[1].to_bits() + 1);
        let v = serde_json::to_value(&k).unwrap();
        assert!(v["omega"].is_array(), "{}", v["omega"]);
        assert_eq!(round_trip(&k), k);
    }

    #[test]
    fn an_infinite_match_threshold_is_recorded_as_inf_and_reads_back() {
        let c = ReproduceSpec::new(SMOKE, Backend::Auto, Precision::F64).continuation();
        assert!(c.match_threshold.is_infinite());
        let v = serde_json::to_value(&c).unwrap();
        assert_eq!(v["match_threshold"], serde_json::json!("inf"));
        assert_eq!(round_trip(&c).match_threshold, f64::INFINITY);
    }
}
