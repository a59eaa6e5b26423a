//! `jeffcott reproduce`: regenerates the article's figure set (Figs. 3-12) plus the
//! down-sweep and brute-force diagrams it does not have, and writes `REPORT.md` with
//! every figure, what this tool found there, the equivalent command and its time.

use super::basin::{legend_name, write_basin_files};
use super::bifurcation::{diagram_series, lambda1_series, write_bifurcation};
use crate::plot;
use clap::Args;
use jeffcott_analysis::backend::default_precision;
use jeffcott_analysis::basin::study::BasinOutcome;
use jeffcott_analysis::bifurcation::{BifurcationResult, BifurcationSpec};
use jeffcott_analysis::cascade::{CascadeResult, CascadeSpec};
use jeffcott_analysis::catalogue::Catalogue;
use jeffcott_analysis::classify::Class;
use jeffcott_analysis::continuation::{ContinuationResult, ContinuationSpec};
use jeffcott_analysis::map::{MapResult, MapSpec};
use jeffcott_analysis::reproduce::{
    ARTICLE_SPEEDS, BruteCounts, FULL, Host, Lambda1Row, MapFindings, Preset, QUICK, RampFindings,
    RegimeCells, ReproduceResult, ReproduceSpec, SMOKE, STEPS, Section, Survey, SweepCounts, THROW,
    Throw, ThrowOutcome, ZOOMS, leaves_period1, periods_seen, reproduce, sum_rule, summary_rows,
    up_down_differ,
};
use jeffcott_analysis::simulate::{RubOutputs, SimulateResult};
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::lyapunov::Spectrum;
use jeffcott_core::model::{Params, VX_R, VX_S, X_R, X_S, Y_R, Y_S};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `jeffcott reproduce`.
#[derive(Args, Debug)]
pub struct ReproduceArgs {
    /// Reduced resolution that finishes in under 10 minutes on a 2-core CPU (the default).
    #[arg(long, conflicts_with = "full")]
    pub quick: bool,
    /// Publication resolution (2000 speeds, a 1000 x 1000 basin): meant for a GPU.
    #[arg(long)]
    pub full: bool,
    /// A tiny resolution that only checks the pipeline (for tests).
    #[arg(long, hide = true, conflicts_with_all = ["quick", "full"])]
    pub smoke: bool,
    /// Backend of the ensembles (brute force, basins, surveys).
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Lane precision [default: f64 on the CPU, f32 on a GPU].
    #[arg(long, value_enum)]
    pub precision: Option<Precision>,
    /// Output directory (created if missing). An unfinished reproduce of the same mode
    /// there is resumed (its finished studies are not computed again).
    #[arg(long, value_name = "DIR", default_value = "jeffcott-out/reproduce")]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: super::rundir::RunArgs,
    /// Print nothing but errors (no progress bars).
    #[arg(long)]
    pub quiet: bool,
}

struct Report {
    text: String,
    started: Instant,
}

impl Report {
    fn figure(&mut self, title: &str, file: &str, found: &str, command: &str, seconds: f64) {
        let _ = write!(
            self.text,
            "## {title}\n\n![{title}]({file})\n\n{found}\n\nCommand: `{command}`  \nTime: {seconds:.1} s\n\n"
        );
    }
}

fn describe(cat: &Catalogue) -> String {
    let list: Vec<String> = cat.attractors.iter().map(legend_name).collect();
    let mut s = format!(
        "{} attractor{} from {} start states: {}",
        cat.attractors.len(),
        if cat.attractors.len() == 1 { "" } else { "s" },
        cat.lanes,
        list.join("; ")
    );
    if cat.diverged > 0 {
        let _ = write!(s, "; {:.1} % diverged", 100.0 * cat.diverged_fraction);
    }
    s
}

/// The "Lyapunov spectra" section of REPORT.md: all eight exponents with their error
/// estimates, the sum against the sum rule, the accumulation time.
fn spectra_table(spectra: &[Spectrum], params: &Params, seconds: f64, cmd: &str) -> String {
    let rule = sum_rule(params);
    let mut t = format!(
        "\n## Lyapunov spectra at the article's speeds\n\nAll eight exponents [1/s] from the static equilibrium (`lyapunov::spectrum`: eight tangent vectors with the state, saltation at every contact switch, QR every period), each +- its error estimate (the larger of the batch-means standard error and the change over the last window). Sum rule (MODEL.md 6): the exponents sum to {rule:.2} 1/s. Command: `{cmd}`; the five spectra took {seconds:.1} s in all (in parallel).\n\n| W [rad/s] | lambda_1 | lambda_2 | lambda_3 | lambda_4 | lambda_5 | lambda_6 | lambda_7 | lambda_8 | sum (rule {rule:.1}) | accumulated [s] | stop | wall [s] |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    );
    for s in spectra {
        let _ = write!(t, "| {} |", s.omega);
        for (e, err) in s.exponents.iter().zip(&s.errors) {
            let _ = write!(t, " {e:.3} +- {err:.3} |");
        }
        let _ = writeln!(
            t,
            " {:.2} ({:+.3} %) | {:.1} ({} periods) | {:?} | {:.1} |",
            s.sum,
            100.0 * (s.sum - rule) / rule.abs(),
            s.integration_time,
            s.periods,
            s.stop,
            s.wall_time_s
        );
    }
    t + "\n"
}

/// Runs `jeffcott reproduce`: the sections below in order, each adding its figures to
/// the report, then REPORT.md with the summary table at the top.
pub fn run_reproduce(a: &ReproduceArgs) -> Result<()> {
    let preset = if a.full {
        FULL
    } else if a.smoke {
        SMOKE
    } else {
        QUICK
    };
    let precision = a.precision.unwrap_or_else(|| default_precision(a.backend));
    let spec = ReproduceSpec::new(preset, a.backend, precision);
    let dir = a.out.as_path();
    // One run directory for the whole figure set; each study keeps its units under its
    // own prefix, so an interrupted reproduce resumes where it stopped.
    let rd = super::rundir::open(
        dir,
        "reproduce",
        &RunSpec {
            mode: preset.name,
            precision,
        },
        &["REPORT.md"],
        a.run,
        a.quiet,
    )?;
    let mut c = Ctx {
        a,
        spec: &spec,
        dir,
        rd: &rd,
        mode: format!("--{}", preset.name),
        backend: format!("{:?}", a.backend).to_lowercase(),
        rep: Report {
            text: String::new(),
            started: Instant::now(),
        },
    };
    let ReproduceResult {
        survey,
        static_class,
    } = reproduce(&spec, &mut c)?;
    let Ctx {
        ref mode,
        ref backend,
        ref rep,
        ..
    } = c;
    let (p, cfg) = (&spec.preset, &spec.catalogue);

    // REPORT.md.
    say(a, &format!("[{STEPS}/{STEPS}] REPORT.md"));
    let mut head = String::new();
    let _ = write!(
        head,
        "# jeffcott reproduce {mode}\n\nThe figure set of \"Nonlinear Dynamics and Chaos of a Nonsmooth Rotor-Stator System\" (Mathematical Problems in Engineering, 2017), regenerated with `jeffcott` {} (Table 1 parameters, the corrected model of MODEL.md). Ensembles on backend `{backend}`, {:?}; {} CPU threads. Total time {:.1} s.\n\n",
        env!("CARGO_PKG_VERSION"),
        spec.precision,
        rayon::current_num_threads(),
        rep.started.elapsed().as_secs_f64()
    );
    head += "## Summary at the article's speeds\n\n| W [rad/s] | article | from the static equilibrium | lambda_1 [1/s] (full spectrum) | survey of seeded start states |\n|---|---|---|---|---|\n";
    for row in summary_rows(&survey, &static_class) {
        let _ = writeln!(
            head,
            "| {} | {} | {} | {} | {} |",
            row.omega,
            row.article,
            row.static_class.map_or("-".to_string(), |c| c.label()),
            l1_text(row.spectrum),
            describe(row.survey)
        );
    }
    head += &spectra_table(
        &survey.spectra,
        &spec.params,
        survey.spectra_seconds,
        &spectrum_cmd(&spec),
    );
    let _ = write!(
        head,
        "\nSurvey: {} start states per speed (static equilibrium + seeded random rotor states within the gap), {} transient and {} recorded periods ({}; {:.1} s). Classification: period-n up to n = 32 with tolerances relative to the attractor size; otherwise quasiperiodic (|lambda_1| < {} 1/s) or chaotic (lambda_1 above), lambda_1 per lane from one tangent vector over the recorded periods (attractor entries show the mean over their lanes).\n\n",
        p.survey_ics,
        p.survey_transient,
        p.survey_periods,
        survey_cmd(p, 0.0).replace("--omega 0 ", "--omega W "),
        survey.seconds,
        cfg.lambda_tol
    );
    let text = head + &rep.text;
    jeffcott_analysis::output::write_atomically(&dir.join("REPORT.md"), |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;
    rd.finish(
        &super::rundir::WallTime {
            wall_time_s: rep.started.elapsed().as_secs_f64(),
        },
        &super::rundir::files_under(dir)?,
    )?;
    if !a.quiet {
        println!(
            "reproduce {mode}: figures and REPORT.md in {} ({:.1} s)",
            dir.display(),
            rep.started.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// A figure set's specification as `run.json` records it: the preset and the lanes'
/// precision.
#[derive(serde::Serialize)]
struct RunSpec {
    mode: &'static str,
    precision: Precision,
}

/// The command line as the figure set's host: the arguments, the set's specification,
/// the output directory and its run (every study's units under its own prefix), and the
/// report being written. Each section draws its figures, writes its studies' files into
/// a sub-folder as the study's own command would, and adds its text.
struct Ctx<'a> {
    a: &'a ReproduceArgs,
    spec: &'a ReproduceSpec,
    dir: &'a Path,
    rd: &'a jeffcott_analysis::run::RunDir,
    mode: String,
    backend: String,
    rep: Report,
}

impl jeffcott_analysis::run::Host for Ctx<'_> {
    fn store(&self) -> &dyn jeffcott_analysis::run::UnitStore {
        self.rd
    }

    fn progress<T>(
        &self,
        label: &str,
        total: u64,
        per_lane: u64,
        work: impl FnOnce(jeffcott_core::control::Control) -> Result<T>,
    ) -> Result<T> {
        super::rundir::progress(label, total, per_lane, self.a.quiet, work)
    }
}

impl Host for Ctx<'_> {
    fn begin(&mut self, step: usize, what: &str) {
        say(self.a, &format!("[{step}/{STEPS}] {what}"));
    }

    fn section(&mut self, section: Section<'_>) -> Result<()> {
        match section {
            Section::Bifurcation { spec, res } => bifurcation_figures(self, spec, res),
            Section::Zoom {
                k,
                spec,
                res,
                seconds,
            } => enlargement(self, k, spec, res, seconds),
            Section::Portrait {
                figure,
                omega,
                res,
                class,
                survey,
                seconds,
            } => portrait(self, figure, omega, res, class, survey, seconds),
            Section::Basin {
                outcome,
                class,
                survey,
                seconds,
            } => basin_section(
                self,
                &BasinFigures {
                    outcome,
                    class,
                    survey,
                    seconds,
                },
            ),
            Section::Section {
                index,
                omega,
                res,
                class,
                survey,
                seconds,
            } => section_figures(self, index, omega, res, class, survey, seconds),
            Section::DesignChart {
                spec,
                res,
                findings,
                seconds,
            } => design_chart(self, spec, res, findings, seconds),
            Section::Continuation {
                spec,
                res,
                ramps,
                seconds,
            } => continuation_section(self, spec, res, ramps, seconds),
            Section::RubMap {
                spec,
                res,
                regimes,
                throws,
                soft_modes,
                seconds,
            } => rub_map(self, spec, res, regimes, throws, soft_modes, seconds),
            Section::Cascade { spec, res, seconds } => cascade_section(self, spec, res, seconds),
            Section::Spectrum {
                omega,
                res,
                rub,
                seconds,
            } => spectrum_section(self, omega, res, rub, seconds),
        }
    }
}

/// The command behind the full spectra.
fn spectrum_cmd(spec: &ReproduceSpec) -> String {
    let scfg = spec.spectrum_config();
    format!(
        "jeffcott lyapunov --omega W --transient {} --min-time {} --time {}",
        scfg.transient, scfg.min_time, scfg.max_time
    )
}

/// lambda_1 of a full spectrum with its error ("-" without one).
fn l1_text(s: Option<&Spectrum>) -> String {
    s.map_or("-".into(), |s| {
        format!("{:.3} +- {:.3} 1/s", s.exponents[0], s.errors[0])
    })
}

/// The command behind the survey at speed `w`.
fn survey_cmd(p: &Preset, w: f64) -> String {
    format!(
        "jeffcott ensemble --omega {w} --lyapunov --transient {} --periods {} (x {} seeded start states)",
        p.survey_transient, p.survey_periods, p.survey_ics
    )
}

/// Copies a study's picture `from` to `to` in the report's folder `dir` (atomically).
fn copy(dir: &Path, from: &Path, to: &str) -> Result<()> {
    let bytes = std::fs::read(from).map_err(|source| Error::Io {
        path: from.to_path_buf(),
        source,
    })?;
    jeffcott_analysis::output::write_atomically(&dir.join(to), |w| {
        std::io::Write::write_all(w, &bytes)
    })
}

/// A progress line on stderr (not with --quiet).
fn say(a: &ReproduceArgs, s: &str) {
    if !a.quiet {
        eprintln!("{s}");
    }
}

/// What a sweep found: how many speeds are period-1, periodic, aperiodic (quasiperiodic,
/// chaotic) and diverged.
fn sweep_found(sw: &[jeffcott_analysis::bifurcation::SweepPoint]) -> String {
    let n = SweepCounts::of(sw);
    format!(
        "{} of {} speeds period-1, {} periodic with period > 1, {} aperiodic (no period up to 32: {} quasiperiodic, {} chaotic by lambda_1), {} diverged",
        n.period1, n.speeds, n.higher_period, n.aperiodic, n.quasiperiodic, n.chaotic, n.diverged
    )
}

/// Figs. 3 and 4, the down sweep and the brute-force diagram: one bifurcation study over
/// [130, 141].
fn bifurcation_figures(c: &mut Ctx, spec: &BifurcationSpec, res: &BifurcationResult) -> Result<()> {
    let Ctx {
        dir,
        ref backend,
        ref mut rep,
        ..
    } = *c;
    let (p, cfg) = (c.spec.preset, c.spec.catalogue);
    write_bifurcation(&dir.join("bifurcation"), spec, res, &[VX_S, VX_R], true)?;
    let bif_cmd = format!(
        "jeffcott bifurcation --omega 130:141:{} --coord vx_s,vx_r --sweep both --ics {} --transient {} --transient-first {} --brute-transient {} --periods {} --max-seeds {} --backend {backend} --out {}/bifurcation",
        p.speeds,
        p.ics,
        p.sweep_transient,
        p.sweep_first,
        p.brute_transient,
        p.periods,
        p.max_seeds,
        dir.display()
    );
    let w = (130.0, 141.0);
    // What the lambda_1 row under a sweep shows.
    let l1_row = |sw: &[jeffcott_analysis::bifurcation::SweepPoint]| -> String {
        let r = Lambda1Row::of(sw, cfg.lambda_tol, &[131.7, 140.0]);
        let at =
            |a: Option<(f64, f64)>| a.map_or("-".into(), |(l, w)| format!("{l:.2} 1/s at {w:.3}"));
        format!(
            "positive (> {} 1/s) at {} of {} speeds, largest {:.1} 1/s; {} and {}",
            r.tol,
            r.positive,
            r.finite,
            r.largest,
            at(r.at[0]),
            at(r.at[1])
        )
    };
    let first_non_p1 = leaves_period1(&res.up);
    for (fig, coord, name) in [
        (
            "fig03_bifurcation_vx_s.png",
            VX_S,
            "Fig. 3: bifurcation diagram of vx_s, W increasing",
        ),
        (
            "fig04_bifurcation_vx_r.png",
            VX_R,
            "Fig. 4: bifurcation diagram of vx_r, W increasing",
        ),
    ] {
        plot::bifurcation_diagram(
            &dir.join(fig),
            &format!("{name} (quasistatic sweep, {} speeds)", p.speeds),
            &[coord],
            w,
            &diagram_series(spec, res, true, false, false),
            &lambda1_series(spec, res, true, false, false),
        )?;
        rep.figure(
            name,
            fig,
            &format!(
                "Quasistatic sweep from the static equilibrium at 130 rad/s, each speed started from the last state of the previous one: {}. Leaving the period-1 branch first at W = {}. The panel underneath: lambda_1 of each sweep point (one tangent vector over its {} recorded periods), {}. Arrays (`bifurcation_lambda1.npy`) and per-speed classes in `bifurcation/`.",
                sweep_found(&res.up),
                first_non_p1.map_or("-".into(), |w| format!("{w:.3} rad/s")),
                p.periods,
                l1_row(&res.up)
            ),
            &bif_cmd,
            res.sweep_seconds,
        );
    }
    let differ = up_down_differ(res);
    plot::bifurcation_diagram(
        &dir.join("fig_down_sweep.png"),
        "Up and down quasistatic sweeps (hysteresis shows where they differ)",
        &[VX_S, VX_R],
        w,
        &diagram_series(spec, res, true, true, false),
        &lambda1_series(spec, res, true, true, false),
    )?;
    rep.figure(
        "Down sweep (not in the article): W decreasing, over the up sweep",
        "fig_down_sweep.png",
        &format!(
            "Down sweep: {}. Up and down differ (class without the lambda_1 refinement) at {} of {} speeds{}.",
            sweep_found(&res.down),
            differ.len(),
            res.up.len(),
            if differ.is_empty() {
                String::new()
            } else {
                format!(
                    " (e.g. {})",
                    differ
                        .iter()
                        .take(8)
                        .map(|w| format!("{w:.3}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        ),
        &bif_cmd,
        res.sweep_seconds,
    );
    plot::bifurcation_diagram(
        &dir.join("fig_brute_force.png"),
        &format!(
            "Brute force: {} start states per W plus the attractors of the neighbouring W",
            p.ics
        ),
        &[VX_S, VX_R],
        w,
        &diagram_series(spec, res, false, false, true),
        &lambda1_series(spec, res, false, false, true),
    )?;
    let brute = BruteCounts::of(res);
    rep.figure(
        "Brute-force diagram (not in the article)",
        "fig_brute_force.png",
        &format!(
            "Coexisting attractors at {} of {} speeds; at most {} (at W = {:.3} rad/s). Aperiodic clouds from different lanes count as one attractor when they cover each other (see `analysis::catalogue`). Backend: {}.",
            brute.multistable,
            brute.speeds,
            brute.most,
            brute.most_at,
            res.brute_info
                .as_ref()
                .map_or("-".to_string(), |i| format!("{} ({}), {:?}", i.backend, i.device, i.precision))
        ),
        &bif_cmd,
        res.brute_seconds,
    );
    Ok(())
}

/// Enlargement `k` of Fig. 3 (an up sweep over one of the article's zoom ranges).
fn enlargement(
    c: &mut Ctx,
    k: usize,
    zspec: &BifurcationSpec,
    zres: &BifurcationResult,
    seconds: f64,
) -> Result<()> {
    let Ctx {
        dir, ref mut rep, ..
    } = *c;
    let p = c.spec.preset;
    let (lo, hi) = ZOOMS[k];
    {
        let fig = format!("fig03{}_zoom_{lo}-{hi}.png", ["b", "c"][k]);
        plot::bifurcation_diagram(
            &dir.join(&fig),
            &format!(
                "Fig. 3 enlarged: vx_s over {lo}..{hi} rad/s, W increasing ({} speeds)",
                p.zoom_speeds
            ),
            &[VX_S],
            (lo, hi),
            &diagram_series(zspec, zres, true, false, false),
            &lambda1_series(zspec, zres, true, false, false),
        )?;
        let periods = periods_seen(&zres.up);
        rep.figure(
            &format!("Fig. 3 enlarged over {lo}..{hi} rad/s"),
            &fig,
            &format!(
                "{}. Periods seen: {:?}.",
                sweep_found(&zres.up),
                periods
            ),
            &format!(
                "jeffcott bifurcation --omega {lo}:{hi}:{} --coord vx_s --sweep up --ics 0 --transient {} --transient-first {} --periods {} --out {}/zoom{k}",
                p.zoom_speeds, p.sweep_transient, p.sweep_first, p.periods, dir.display()
            ),
            seconds,
        );
    }
    Ok(())
}

/// Fig. 5 or 6: the phase portrait at 131.7 or 132.2 rad/s from the static equilibrium.
fn portrait(
    c: &mut Ctx,
    figure: usize,
    omega: f64,
    r: &SimulateResult,
    class: Class,
    survey: &Survey,
    seconds: f64,
) -> Result<()> {
    let Ctx {
        dir, ref mut rep, ..
    } = *c;
    let p = c.spec.preset;
    let i = figure - 5;
    let fig = ["fig05_phase_131.7.png", "fig06_phase_132.2.png"][i];
    let class = class.label();
    plot::phase_portraits(
        &dir.join(fig),
        &format!("Fig. {figure}: W = {omega} rad/s from the static equilibrium: {class}"),
        &r.timeseries,
        &r.poincare,
    )?;
    rep.figure(
        &format!("Fig. {figure}: phase spaces and Poincare section at W = {omega} rad/s"),
        fig,
        &format!(
            "From the static equilibrium after 1000 periods: **{class}**, lambda_1 = {} (full spectrum in the table at the top) (the article: {}). Survey of {} start states: {}.",
            l1_text(survey.spectrum(omega)),
            ARTICLE_SPEEDS[i].1,
            p.survey_ics,
            describe(&survey.catalogues[i])
        ),
        &format!("jeffcott simulate --omega {omega} --transient 1000 --periods 64 --timeseries-periods 4"),
        seconds,
    );
    Ok(())
}

/// The basin section's results ([`Section::Basin`]).
struct BasinFigures<'a> {
    outcome: &'a BasinOutcome,
    class: Class,
    survey: &'a Survey,
    seconds: f64,
}

/// Figs. 7 and 8: the basin at 133 rad/s (refined at its boundary), its coexisting
/// attractors and its measures.
fn basin_section(c: &mut Ctx, f: &BasinFigures) -> Result<()> {
    let Ctx {
        dir,
        ref backend,
        ref mut rep,
        ..
    } = *c;
    let p = c.spec.preset;
    let o = f.outcome;
    let (bres, refined, reint) = (&o.result, o.refined.as_ref(), o.reintegration.as_ref());
    let n = o.coarse.x.n;
    let bdir = dir.join("basin_133");
    let refine_text = match refined {
        Some(f) => {
            let lanes: usize = f.levels.iter().map(|l| l.lanes).sum();
            format!(
                " Refined {} level(s) around the boundary to {} x {} points: {} lanes besides the {n} x {n} grid, {:.0} % of the {} of the full fine grid (`--refine {}`, refined.npy).",
                f.levels.len(),
                f.nx,
                f.ny,
                lanes,
                100.0 * (lanes + n * n) as f64 / (f.nx * f.ny) as f64,
                f.nx * f.ny,
                f.levels.len()
            )
        }
        None => String::new(),
    };
    let basin_rub = write_basin_files(&bdir, o, true, false)?;
    let bmetrics = &o.metrics;
    copy(dir, &bdir.join("basin.png"), "fig07_basin_133.png")?;
    let basin_s = f.seconds;
    let basin_cmd = format!(
        "jeffcott basin --omega 133 --x x_r:-0.006:0.006:{n} --y vx_r:-1:1:{n} --transient {} --periods {} --refine {} --uncertainty-samples {} --backend {backend} --out {}/basin_133",
        p.basin_transient,
        p.basin_periods,
        p.basin_refine,
        p.uncertainty_samples,
        dir.display()
    );
    rep.figure(
        "Fig. 7: basin of attraction at W = 133 rad/s over the rotor's initial x_r and vx_r",
        "fig07_basin_133.png",
        &format!(
            "{n} x {n} start states (other coordinates at the static equilibrium): {}. From the static equilibrium itself: **{}**, lambda_1 = {}. Rub on the attractors: {basin_rub}.{refine_text} Basin measures (`basin_133/basin_metrics.json`, docs/basin-measures.md; f(eps) of both methods in `basin_133/uncertainty.png`): {}{}.",
            describe(&bres.catalogue),
            f.class.label(),
            l1_text(f.survey.spectrum(133.0)),
            bmetrics.summary(),
            reint.map(|r| format!("; {}", r.summary())).unwrap_or_default()
        ),
        &basin_cmd,
        basin_s,
    );
    if bdir.join("attractors.png").exists() {
        copy(
            dir,
            &bdir.join("attractors.png"),
            "fig08_attractors_133.png",
        )?;
        rep.figure(
            "Fig. 8: the coexisting attractors at W = 133 rad/s",
            "fig08_attractors_133.png",
            &format!(
                "{} attractor(s) coexist; each drawn over one pass from a point of its Poincare set (same run as Fig. 7). Survey of {} seeded start states: {}.",
                bres.catalogue.attractors.len(),
                p.survey_ics,
                describe(&f.survey.catalogues[2])
            ),
            &basin_cmd,
            basin_s,
        );
    }
    Ok(())
}

/// Figs. 9 to 12: the phase portrait and Poincare sections at 135 or 140 rad/s.
fn section_figures(
    c: &mut Ctx,
    i: usize,
    omega: f64,
    r: &SimulateResult,
    class: Class,
    sv: &Survey,
    seconds: f64,
) -> Result<()> {
    let Ctx {
        dir, ref mut rep, ..
    } = *c;
    let (p, cfg) = (c.spec.preset, c.spec.catalogue);
    {
        let class = class.label();
        let found = format!(
            "From the static equilibrium, {} Poincare points after {} periods: **{class}** (no period up to 32; lambda_1 = {} from the full spectrum, quasiperiodic when |lambda_1| < {} 1/s, chaotic above) (the article: {}). Survey of {} start states (lambda_1 per lane): {}.",
            p.section_points,
            p.section_transient,
            l1_text(sv.spectrum(omega)),
            cfg.lambda_tol,
            ARTICLE_SPEEDS[i].1,
            p.survey_ics,
            describe(&sv.catalogues[i])
        );
        let cmd = format!(
            "jeffcott simulate --omega {omega} --transient {} --periods {} --timeseries-periods 8",
            p.section_transient, p.section_points
        );
        if omega == 135.0 {
            plot::phase_portraits(
                &dir.join("fig09_phase_135.png"),
                &format!("Fig. 9: W = 135 rad/s, last 8 periods: {class}"),
                &r.timeseries,
                &r.poincare,
            )?;
            plot::poincare_sections(
                &dir.join("fig10_section_135.png"),
                "Fig. 10: Poincare section at W = 135 rad/s",
                &r.poincare,
                &[(X_S, VX_S), (X_R, VX_R)],
                None,
            )?;
            plot::poincare_sections(
                &dir.join("fig10b_section_135_zoom.png"),
                "Fig. 10 enlarged: 30 % of each axis around the median point",
                &r.poincare,
                &[(X_S, VX_S), (X_R, VX_R)],
                Some(0.3),
            )?;
            let s = seconds;
            rep.figure(
                "Fig. 9: phase spaces at W = 135 rad/s",
                "fig09_phase_135.png",
                &found,
                &cmd,
                s,
            );
            rep.figure(
                "Fig. 10: Poincare section at W = 135 rad/s",
                "fig10_section_135.png",
                &found,
                &cmd,
                s,
            );
            rep.figure(
                "Fig. 10, enlarged",
                "fig10b_section_135_zoom.png",
                "The central 30 % of each axis of the section above.",
                &cmd,
                s,
            );
        } else {
            plot::poincare_sections(
                &dir.join("fig11_section_stator_140.png"),
                "Fig. 11: stator Poincare section at W = 140 rad/s",
                &r.poincare,
                &[(X_S, VX_S), (X_S, Y_S)],
                None,
            )?;
            plot::poincare_sections(
                &dir.join("fig12_section_rotor_140.png"),
                "Fig. 12: rotor Poincare section at W = 140 rad/s",
                &r.poincare,
                &[(X_R, VX_R), (X_R, Y_R)],
                None,
            )?;
            let s = seconds;
            rep.figure(
                "Fig. 11: stator section at W = 140 rad/s",
                "fig11_section_stator_140.png",
                &found,
                &cmd,
                s,
            );
            rep.figure(
                "Fig. 12: rotor section at W = 140 rad/s",
                "fig12_section_rotor_140.png",
                &found,
                &cmd,
                s,
            );
        }
    }
    Ok(())
}

/// Beyond the article: a design chart over (W, e).
fn design_chart(
    c: &mut Ctx,
    mspec: &MapSpec,
    mres: &MapResult,
    f: &MapFindings,
    seconds: f64,
) -> Result<()> {
    let Ctx {
        dir,
        ref backend,
        ref mut rep,
        ..
    } = *c;
    let p = c.spec.preset;
    let mdir = dir.join("map_w_e");
    super::map::write_map(&mdir, mspec, mres, true)?;
    copy(dir, &mdir.join("map_period.png"), "map_w_e_period.png")?;
    copy(
        dir,
        &mdir.join("map_multistability.png"),
        "map_w_e_multistability.png",
    )?;
    let map_cmd = format!(
        "jeffcott map --x omega:128:142:{} --y e:0.0002:0.002:{} --ics {} --transient {} --periods {} --backend {backend} --out {}/map_w_e",
        p.map_nx,
        p.map_ny,
        p.map_ics,
        p.map_transient,
        p.map_periods,
        dir.display()
    );
    rep.figure(
        "Design chart (beyond the article): response over rotor speed W and unbalance e",
        "map_w_e_period.png",
        &format!(
            "{} x {} cells (W 128..142 rad/s, e 0.2..2 mm), {} start state(s) per cell. From the static equilibrium: period-1 in {} cells, chaotic in {}, quasiperiodic in {}, the rest periodic of higher period or undecided; the rotor rubs in {} cells (peak normal contact force up to {:.0} N), {} cells hold coexisting attractors. At e = {:.2} mm (the row nearest the article's 1 mm) it rubs at {} of {} speeds{}. Contact fraction, peak force and every cell's attractors are in `map_w_e/` (docs/maps.md); the multistability map is `map_w_e_multistability.png`.",
            p.map_nx,
            p.map_ny,
            p.map_ics,
            f.period1,
            f.chaotic,
            f.quasiperiodic,
            f.rubbing,
            f.peak_force,
            f.multistable,
            f.row_value * 1e3,
            f.rub_speeds.len(),
            p.map_nx,
            match (f.rub_speeds.first(), f.rub_speeds.last()) {
                (Some(a), Some(b)) => format!(", between {a:.2} and {b:.2} rad/s"),
                _ => String::new(),
            }
        ),
        &map_cmd,
        seconds,
    );
    Ok(())
}

/// Beyond the article: the attractor continuation over 130..141 rad/s, run-up and run-down.
fn continuation_section(
    c: &mut Ctx,
    cspec: &ContinuationSpec,
    cres: &ContinuationResult,
    ramps: &[RampFindings],
    seconds: f64,
) -> Result<()> {
    let Ctx {
        dir,
        ref backend,
        ref mut rep,
        ..
    } = *c;
    let p = c.spec.preset;
    let cdir = dir.join("continuation");
    super::continuation::write_continuation(&cdir, cspec, cres, true)?;
    copy(dir, &cdir.join("continuation.png"), "continuation.png")?;
    let ramp_text: Vec<String> = ramps
        .iter()
        .map(|f| {
            let w = f.worst;
            format!(
                "run-{}: {} attractors followed, at most {} at one speed; basins shared by two or more at {} of {} speeds{}; largest one-step tipping probability {:.2} (attractor #{} at {:.2} rad/s to {} at the next speed)",
                f.direction.name(),
                f.ids,
                f.most,
                f.coexist.len(),
                f.steps,
                match (f.coexist.first(), f.coexist.last()) {
                    (Some(a), Some(b)) => format!(" (from {a:.2} to {b:.2} rad/s)"),
                    _ => String::new(),
                },
                w.probability,
                w.from,
                w.value,
                if w.to == f.ids { "divergence".to_string() } else { format!("#{}", w.to) },
            )
        })
        .collect();
    rep.figure(
        "Attractor continuation over W (beyond the article): run-up and run-down",
        "continuation.png",
        &format!(
            "{} speeds, {} fresh start states each plus one seed per attractor of the previous speed (Attractors.jl's seeded find-and-match). {}. Fractions, errors and tipping matrices are in `continuation/` (docs/maps.md).",
            p.cont_values,
            p.cont_ics,
            ramp_text.join("; ")
        ),
        &format!(
            "jeffcott continuation --vary omega:130:141:{} --ics {} --transient {} --periods {} --backend {backend} --out {}/continuation",
            p.cont_values,
            p.cont_ics,
            p.cont_transient,
            p.cont_periods,
            dir.display()
        ),
        seconds,
    );
    Ok(())
}

/// Rub regimes beyond the article's range: the (W, mu) map and the backward throws.
#[allow(clippy::too_many_arguments)]
fn rub_map(
    c: &mut Ctx,
    rspec: &MapSpec,
    rres: &MapResult,
    regimes: &[RegimeCells],
    throws: &[Throw],
    soft_modes: &[(String, f64)],
    seconds: f64,
) -> Result<()> {
    let Ctx {
        dir,
        ref backend,
        ref mut rep,
        ..
    } = *c;
    let p = c.spec.preset;
    let rdir = dir.join("map_w_mu");
    super::map::write_map(&rdir, rspec, rres, true)?;
    copy(dir, &rdir.join("map_regime.png"), "rub_regimes_w_mu.png")?;
    let found: Vec<String> = regimes
        .iter()
        .map(|r| match (r.x, r.y) {
            (Some((lo, hi)), Some((mlo, mhi))) => format!(
                "{}: {} cells, W {lo:.0}..{hi:.0} rad/s, mu {mlo:.2}..{mhi:.2}",
                r.regime.label(),
                r.cells
            ),
            _ => format!("{}: nowhere", r.regime.label()),
        })
        .collect();
    // Backward whirl from a backward throw, stiff and soft contact (docs/rub.md).
    let thrown: Vec<String> = throws
        .iter()
        .map(|t| {
            let (mu, k_c) = (t.mu, t.k_c);
            let cmd = format!(
                "`jeffcott simulate --omega 140 --param mu={mu},k_c={k_c:e} --init x_r={},vy_r={}`",
                THROW.0, THROW.1
            );
            match &t.outcome {
                ThrowOutcome::Diverged { status, periods } => {
                    format!("diverged ({status:?}) within the {periods} periods integrated ({cmd})")
                }
                ThrowOutcome::Settled(o) => format!(
                    "settles on {} ({cmd}): {}",
                    o.figures.regime.label(),
                    super::rubout::rub_sentence(o)
                ),
                ThrowOutcome::StretchDiverged => "diverges".to_string(),
            }
        })
        .collect();
    rep.figure(
        "Rub regimes over speed and friction (beyond the article)",
        "rub_regimes_w_mu.png",
        &format!(
            "The response from the static equilibrium over W = 60..300 rad/s and mu = 0..0.3 ({} x {} cells), labelled by the documented rules of docs/rub.md (contact fraction, contact arc, whirl from the full spectrum): {}. Backward whirl does not start from the static equilibrium: it needs the rotor thrown backward into the stator. With the article's contact stiffness, permanent-contact backward whirl (dry whip) is a self-excited instability without amplitude limit in this penalty model: thrown backward at W = 140 rad/s with mu = 0.3 the rotor {}. With a soft contact (k_c = 1e6 N/m, mu = 0.25, same start) it {} The coupled contact modes of that soft contact are at {:.0} and {:.0} rad/s, the rotor alone at {:.0} rad/s.",
            p.rub_nx,
            p.rub_ny,
            found.join("; "),
            thrown[0],
            thrown[1],
            soft_modes[2].1,
            soft_modes[3].1,
            soft_modes[0].1,
        ),
        &format!(
            "jeffcott map --x omega:60:300:{} --y mu:0:0.3:{} --no-lyapunov --transient {} --periods {} --backend {backend} --out {}/map_w_mu",
            p.rub_nx,
            p.rub_ny,
            p.map_transient,
            p.map_periods,
            dir.display()
        ),
        seconds,
    );
    Ok(())
}

/// The full-spectrum cascade over 100..200 rad/s.
fn cascade_section(
    c: &mut Ctx,
    cspec: &CascadeSpec,
    cres: &CascadeResult,
    seconds: f64,
) -> Result<()> {
    let Ctx {
        dir, ref mut rep, ..
    } = *c;
    let p = c.spec.preset;
    let kdir = dir.join("cascade");
    super::cascade::write_cascade(&kdir, cspec, cres, true, false)?;
    copy(dir, &kdir.join("cascade_up.png"), "cascade_up.png")?;
    copy(dir, &kdir.join("cascade_down.png"), "cascade_down.png")?;
    let regimes = jeffcott_analysis::cascade::regime_summary(cres);
    rep.figure(
        "Full-spectrum cascade over 100..200 rad/s, run-up (run-down: cascade_down.png)",
        "cascade_up.png",
        &format!(
            "Rotor full spectrum at each speed of a quasistatic run-up (24 periods per spectrum, forward whirl above 0 Hz, backward below), with the 1X line and the natural frequencies of rotor, stator and the coupled contact system. Rub regimes along the sweeps: {regimes}."
        ),
        &format!(
            "jeffcott cascade --omega 100:200:{} --out {}/cascade",
            p.cascade_speeds,
            dir.display()
        ),
        seconds,
    );
    Ok(())
}

/// The full spectrum and contact loads at 132.2 rad/s (nothing when its stretch
/// diverged).
fn spectrum_section(
    c: &mut Ctx,
    omega: f64,
    r: &SimulateResult,
    rub: Option<&RubOutputs>,
    seconds: f64,
) -> Result<()> {
    let Ctx {
        dir, ref mut rep, ..
    } = *c;
    let Some(o) = rub else { return Ok(()) };
    let fdir = dir.join(format!("spectrum_{omega}"));
    jeffcott_analysis::output::ensure_dir(&fdir)?;
    super::rubout::write_rub_outputs(
        &fdir,
        &format!("W = {omega} rad/s"),
        &c.spec.params,
        o,
        &r.timeseries,
        true,
        false,
    )?;
    copy(
        dir,
        &fdir.join("full_spectrum.png"),
        &format!("full_spectrum_{omega}.png"),
    )?;
    copy(
        dir,
        &fdir.join("contact.png"),
        &format!("contact_{omega}.png"),
    )?;
    rep.figure(
        &format!("Full spectrum and contact loads at W = {omega} rad/s (period-2)"),
        &format!("full_spectrum_{omega}.png"),
        &format!(
            "{} The orbit relative to the stator with the clearance circle and the contact force history: contact_{omega}.png.",
            super::rubout::rub_sentence(o)
        ),
        &format!("jeffcott simulate --omega {omega}"),
        seconds,
    );
    Ok(())
}
