//! The figure set as one study: the steps, what it needs from its host ([`Host`]), the
//! sections it hands over ([`Section`]) and [`reproduce`], which runs every study in order.

use super::*;

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
    /// The periodic orbits over the bifurcation diagram's range
    /// ([`ReproduceSpec::orbits`]), drawn over its brute force.
    Orbits {
        /// The study.
        study: &'a crate::orbits::OrbitsStudy,
        /// Its branches (the period-1 one first).
        branches: &'a [crate::orbits::Branch],
        /// The brute force of the bifurcation section (its Poincare points are drawn
        /// under the branches).
        background: &'a crate::bifurcation::BifurcationResult,
        /// Wall time [s].
        seconds: f64,
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
    /// Fig. 5 or 6: the response from the static equilibrium at `at.omega`
    /// ([`ReproduceSpec::portrait`]).
    Portrait {
        /// 5 or 6.
        figure: usize,
        /// The response.
        at: &'a AtSpeed<'a>,
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
    /// Figs. 9-12: the section from the static equilibrium at 135 or 140 rad/s
    /// ([`ReproduceSpec::section`]).
    PoincareSection {
        /// Index in [`ARTICLE_SPEEDS`].
        index: usize,
        /// The response.
        at: &'a AtSpeed<'a>,
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

/// The response from the static equilibrium at one of the article's speeds, as the
/// portraits and sections (Figs. 5, 6 and 9 to 12) and the basin's text quote it.
pub struct AtSpeed<'a> {
    /// Rotor speed [rad/s].
    pub omega: f64,
    /// The trajectory.
    pub res: SimulateResult,
    /// Its class, refined by the full spectrum's lambda_1.
    pub class: Class,
    /// The survey, for the text.
    pub survey: &'a Survey,
    /// Wall time [s].
    pub seconds: f64,
}

impl<'a> AtSpeed<'a> {
    /// Simulates `sim` (from the static equilibrium at `omega`), refines its class by
    /// the survey's lambda_1 (`lambda_tol`) and records that class in `static_class`,
    /// which the report's head quotes.
    fn run(
        sim: &SimulateSpec,
        omega: f64,
        survey: &'a Survey,
        lambda_tol: f64,
        static_class: &mut Vec<(f64, Class)>,
    ) -> Result<AtSpeed<'a>> {
        let (res, seconds) = timed(|| simulate(sim))?;
        let class = survey.refine(res.classification.class, omega, lambda_tol);
        static_class.push((omega, class));
        Ok(AtSpeed {
            omega,
            res,
            class,
            survey,
            seconds,
        })
    }
}

/// `work`'s value and its wall time [s].
fn timed<T>(work: impl FnOnce() -> Result<T>) -> Result<(T, f64)> {
    let t = std::time::Instant::now();
    let value = work()?;
    Ok((value, t.elapsed().as_secs_f64()))
}

/// What the report's head quotes once every section is done.
#[derive(Clone, Debug)]
pub struct ReproduceResult {
    /// The survey and the full spectra at the article's speeds.
    pub survey: Survey,
    /// The class from the static equilibrium at each article speed simulated.
    pub static_class: Vec<(f64, Class)>,
    /// The Floquet spectra of the periodic ones, beside their QR spectra.
    pub floquet: Floquet,
}

/// Computes the figure set, section by section, handing each section's results to
/// `host` as they come. Every lane study keeps its units in `host.store()` under its own
/// prefix, so a set interrupted and started again resumes where it stopped.
pub fn reproduce<H: Host + Sync>(spec: &ReproduceSpec, host: &mut H) -> Result<ReproduceResult> {
    let engine = crate::backend::Engine::new(spec.backend, spec.precision)?;
    diagram_orbits_and_zooms(spec, host)?;
    let survey = survey_and_spectra(spec, &engine, host)?;
    let mut static_class = Vec::new();
    portraits_and_basin(spec, &engine, host, &survey, &mut static_class)?;
    // Every article speed is classified by now: shoot the periodic ones' orbits, for
    // the report's Floquet spectra.
    let floquet = floquet(spec, &survey, &static_class);
    design_chart_and_continuation(spec, &engine, host)?;
    rub_regimes(spec, &engine, host)?;
    Ok(ReproduceResult {
        survey,
        static_class,
        floquet,
    })
}

/// Sections 1 and 2: the bifurcation diagram, then the periodic orbits behind it and
/// its enlargements.
fn diagram_orbits_and_zooms<H: Host + Sync>(spec: &ReproduceSpec, host: &mut H) -> Result<()> {
    host.begin(1, "bifurcation diagram over 130..141 rad/s");
    let b = spec.bifurcation()?;
    let res = crate::bifurcation::run(&b, &host.prefixed("bifurcation"))?;
    host.section(Section::Bifurcation {
        spec: &b,
        res: &res,
    })?;
    // The periodic orbits behind the diagram, stable and unstable, and the
    // enlargements: independent of each other (the orbits read the diagram only to be
    // drawn over it), each mostly on one core (a continuation is a chain of Newton
    // steps, an enlargement one quasistatic sweep), so they run side by side; their
    // sections follow in the set's order.
    host.begin(2, "periodic orbits and enlargements of Fig. 3");
    let o = spec.orbits();
    let zooms = (0..ZOOMS.len())
        .map(|k| spec.zoom(k))
        .collect::<Result<Vec<_>>>()?;
    let (orbits, enlarged) = {
        use rayon::prelude::*;
        let shared = &*host;
        rayon::join(
            || {
                timed(|| {
                    crate::orbits::run(&o, &jeffcott_core::orbit::CpuFlows, &Default::default())
                })
            },
            || {
                zooms
                    .par_iter()
                    .enumerate()
                    .map(|(k, z)| {
                        timed(|| {
                            crate::bifurcation::run(z, &shared.prefixed(["zoom0", "zoom1"][k]))
                        })
                    })
                    .collect::<Vec<_>>()
            },
        )
    };
    let (branches, seconds) = orbits?;
    host.section(Section::Orbits {
        study: &o,
        branches: &branches,
        background: &res,
        seconds,
    })?;
    drop(res);
    for (k, (z, zoomed)) in zooms.iter().zip(enlarged).enumerate() {
        let (res, seconds) = zoomed?;
        host.section(Section::Zoom {
            k,
            spec: z,
            res: &res,
            seconds,
        })?;
    }

    Ok(())
}

/// Sections 3 and 4: the attractor survey and the Lyapunov spectra at the article's
/// speeds.
fn survey_and_spectra<H: Host + Sync>(
    spec: &ReproduceSpec,
    engine: &crate::backend::Engine,
    host: &mut H,
) -> Result<Survey> {
    let p = spec.preset;
    host.begin(3, "attractor survey at the article's speeds");
    let per_lane = (p.survey_transient + p.survey_periods) as u64;
    let lanes = ARTICLE_SPEEDS.len() as u64 * p.survey_ics as u64;
    let (catalogues, seconds) = host.progress(
        crate::run::Stage::new("survey", lanes * per_lane, per_lane),
        |ctl| Survey::run_survey(spec, engine, ctl),
    )?;
    host.begin(4, "Lyapunov spectra at the article's speeds");
    let (spectra, spectra_seconds) = Survey::run_spectra(spec)?;
    Ok(Survey {
        catalogues,
        seconds,
        spectra,
        spectra_seconds,
    })
}

/// Sections 5 to 7: the phase portraits, the basin at 133 rad/s and the Poincare
/// sections, each speed's class from the static equilibrium added to `static_class`.
fn portraits_and_basin<H: Host + Sync>(
    spec: &ReproduceSpec,
    engine: &crate::backend::Engine,
    host: &mut H,
    survey: &Survey,
    static_class: &mut Vec<(f64, Class)>,
) -> Result<()> {
    let lambda_tol = spec.catalogue.lambda_tol;
    host.begin(5, "phase portraits at 131.7 and 132.2 rad/s");
    for (figure, omega) in [(5, 131.7), (6, 132.2)] {
        let sim = spec.portrait(omega);
        let at = AtSpeed::run(&sim, omega, survey, lambda_tol, static_class)?;
        host.section(Section::Portrait { figure, at: &at })?;
    }

    host.begin(6, "basin of attraction at 133 rad/s");
    let t = std::time::Instant::now();
    let outcome =
        crate::basin::study::run(&spec.basin_study(), engine, &host.prefixed("basin_133"))?;
    let sim = spec.portrait(133.0);
    let class = AtSpeed::run(&sim, 133.0, survey, lambda_tol, static_class)?.class;
    host.section(Section::Basin {
        outcome: &outcome,
        class,
        survey,
        seconds: t.elapsed().as_secs_f64(),
    })?;
    drop(outcome);

    host.begin(
        7,
        "phase portraits and Poincare sections at 135 and 140 rad/s",
    );
    for (index, omega) in [(3, 135.0), (4, 140.0)] {
        let sim = spec.section(omega);
        let at = AtSpeed::run(&sim, omega, survey, lambda_tol, static_class)?;
        host.section(Section::PoincareSection { index, at: &at })?;
    }
    Ok(())
}

/// Sections 8 and 9: the design chart (speed against unbalance) and the attractor
/// continuation.
fn design_chart_and_continuation<H: Host + Sync>(
    spec: &ReproduceSpec,
    engine: &crate::backend::Engine,
    host: &mut H,
) -> Result<()> {
    host.begin(8, "design chart: speed against unbalance");
    let m = spec.design_map();
    let (res, seconds) = timed(|| crate::map::run(&m, engine, &host.prefixed("map_w_e")))?;
    host.section(Section::DesignChart {
        spec: &m,
        res: &res,
        findings: &MapFindings::of(&m, &res, 0.001),
        seconds,
    })?;
    drop(res);

    host.begin(9, "attractor continuation over 130..141 rad/s");
    let c = spec.continuation();
    let (res, seconds) =
        timed(|| crate::continuation::run(&c, engine, &host.prefixed("continuation")))?;
    let ramps: Vec<RampFindings> = res.ramps.iter().map(RampFindings::of).collect();
    host.section(Section::Continuation {
        spec: &c,
        res: &res,
        ramps: &ramps,
        seconds,
    })?;
    drop(res);

    Ok(())
}

/// Section 10: the rub regimes, as a (W, mu) map with the backward-whirl throws, a
/// full-spectrum cascade and the full spectrum at 132.2 rad/s.
fn rub_regimes<H: Host + Sync>(
    spec: &ReproduceSpec,
    engine: &crate::backend::Engine,
    host: &mut H,
) -> Result<()> {
    host.begin(
        10,
        "rub regimes: (W, mu) map, full-spectrum cascade, full spectrum at 132.2",
    );
    let t = std::time::Instant::now();
    let r = spec.rub_map();
    let res = crate::map::run(&r, engine, &host.prefixed("map_w_mu"))?;
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
    let k = spec.cascade()?;
    let (res, seconds) = timed(|| crate::cascade::run(&k, &host.prefixed("cascade")))?;
    host.section(Section::Cascade {
        spec: &k,
        res: &res,
        seconds,
    })?;
    drop(res);
    let study = crate::simulate::SimulateStudy {
        spec: spec.portrait(132.2),
        spectrum_periods: crate::defaults::simulate::SPECTRUM_PERIODS,
    };
    let (s, seconds) =
        timed(|| crate::simulate::run_study(&study, &jeffcott_core::control::Cancel::new()))?;
    host.section(Section::Spectrum {
        omega: 132.2,
        res: &s.result,
        rub: s.rub.as_ref(),
        seconds,
    })?;
    Ok(())
}
