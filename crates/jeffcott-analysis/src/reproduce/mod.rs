//! `reproduce` as a study: the article's figure set (Figs. 3-12 of "Nonlinear Dynamics
//! and Chaos of a Nonsmooth Rotor-Stator System", docs/model.md 6) and the studies beyond it,
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
//!   ([`sum_rule`]) and the summary table's rows ([`SummaryRow`]);
//! - the spectra set beside the QR spectra: the article's own ([`ARTICLE_SPECTRA`], in
//!   bits/s: [`ArticleComparison`]) and the Floquet spectra of the periodic responses
//!   ([`Floquet`]).
//!
//! One file each: `presets.rs`, `specs.rs`, `survey.rs`, `findings.rs`, `spectra.rs`,
//! and `run.rs` (the set as one study: [`Host`], [`Section`], [`reproduce`]).
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
use crate::simulate::{
    Integrator, RubOutputs, SimulateResult, SimulateSpec, rub_outputs, simulate,
};
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{Backend, EnsembleResult, EnsembleSpec, LaneSpec, Precision};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::Status;
use jeffcott_core::lyapunov::{Spectrum, SpectrumConfig, spectrum};
use jeffcott_core::model::{Params, VX_R, VY_R, X_R};

mod findings;
mod presets;
mod run;
mod specs;
mod spectra;
mod survey;

pub use findings::*;
pub use presets::*;
pub use run::*;
pub use specs::*;
pub use spectra::*;
pub use survey::*;

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
            stage: crate::run::Stage<'_>,
            work: impl FnOnce(Control) -> Result<T>,
        ) -> Result<T> {
            let done = std::sync::atomic::AtomicU64::new(0);
            let report = |d: u64, _| {
                done.fetch_max(d, std::sync::atomic::Ordering::Relaxed);
            };
            let r = work(Control::progress(&report));
            self.committed_by.lock().unwrap().push((
                stage.label.to_string(),
                done.into_inner(),
                stage.total,
            ));
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
                Section::Orbits { branches, .. } => {
                    assert!(!branches.is_empty() && branches[0].period == 1);
                    format!("orbits {}", branches[0].points.len())
                }
                Section::Zoom { k, res, .. } => format!("zoom {k} {:?}", periods_seen(&res.up)),
                Section::Portrait { figure, at } => format!("fig{figure} {:?}", at.class),
                Section::Basin { outcome, class, .. } => {
                    let (coarse, spec, res) = (&outcome.coarse, &outcome.spec, &outcome.result);
                    let refined = &outcome.refined;
                    // One refinement level: (n - 1) 2 + 1 points per side.
                    assert_eq!(spec.x.n, (coarse.x.n - 1) * 2 + 1);
                    assert_eq!(res.labels.len(), spec.x.n * spec.y.n);
                    assert!(refined.is_some());
                    format!("basin {:?} {class:?}", res.labels)
                }
                Section::PoincareSection { at, .. } => {
                    format!("section {} {:?}", at.omega, at.class)
                }
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
                "orbits",
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
        // The Floquet spectra: a row per periodic response, every other speed passed over.
        let periodic = first
            .static_class
            .iter()
            .filter(|(_, c)| c.period().is_some())
            .count();
        assert_eq!(first.floquet.rows.len(), periodic);
        assert_eq!(
            first.floquet.rows.len() + first.floquet.skipped.len(),
            ARTICLE_SPEEDS.len()
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
        let exponents = |r: &ReproduceResult| -> Vec<_> {
            r.floquet.rows.iter().map(FloquetRow::exponents).collect()
        };
        assert_eq!(exponents(&again), exponents(&first));
    }
}
