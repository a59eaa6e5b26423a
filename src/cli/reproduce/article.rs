//! The article's figure sections of `jeffcott reproduce` (Figs. 3-12): bifurcation
//! diagrams and their enlargements, phase portraits, the basin at 133 rad/s and the
//! Poincare sections.

use super::report::{describe, l1_text, sweep_found};
use super::{Ctx, copy};
use crate::cli::basin::write_basin_files;
use crate::cli::bifurcation::{diagram_series, lambda1_series, write_bifurcation};
use crate::plot;
use jeffcott_analysis::basin::study::BasinOutcome;
use jeffcott_analysis::bifurcation::{BifurcationResult, BifurcationSpec, SweepPoint};
use jeffcott_analysis::classify::Class;
use jeffcott_analysis::reproduce::{
    ARTICLE_SPEEDS, AtSpeed, BruteCounts, Lambda1Row, Preset, Survey, ZOOMS, leaves_period1,
    periods_seen, up_down_differ,
};
use jeffcott_core::error::Result;
use jeffcott_core::model::{VX_R, VX_S, X_R, X_S, Y_R, Y_S};

/// Figs. 3 and 4, the down sweep and the brute-force diagram: one bifurcation study over
/// [130, 141].
pub(super) fn bifurcation_figures(
    c: &mut Ctx,
    spec: &BifurcationSpec,
    res: &BifurcationResult,
) -> Result<()> {
    let (dir, backend, p, rep) = (c.dir, c.backend.as_str(), c.spec.preset, &mut c.rep);
    let cfg = c.spec.catalogue;
    write_bifurcation(&dir.join("bifurcation"), spec, res, &[VX_S, VX_R], true)?;
    let bif_cmd = bifurcation_command(dir, backend, &p);
    let w = (130.0, 141.0);
    let l1_row = |sw: &[SweepPoint]| lambda1_row(sw, cfg.lambda_tol);
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
            for_example(&differ)
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

/// The command that computes the bifurcation study of the set at preset `p`.
fn bifurcation_command(dir: &std::path::Path, backend: &str, p: &Preset) -> String {
    format!(
        "jeffcott bifurcation --omega 130:141:{} --coord vx_s,vx_r --sweep both --ics {} --transient {} --transient-first {} --brute-transient {} --periods {} --max-seeds {} --backend {backend} --out {}/bifurcation",
        p.speeds,
        p.ics,
        p.sweep_transient,
        p.sweep_first,
        p.brute_transient,
        p.periods,
        p.max_seeds,
        dir.display()
    )
}

/// What the lambda_1 row under a sweep shows (`tol`: the catalogue's lambda_tol).
fn lambda1_row(sw: &[SweepPoint], tol: f64) -> String {
    let r = Lambda1Row::of(sw, tol, &[131.7, 140.0]);
    let at = |a: Option<(f64, f64)>| a.map_or("-".into(), |(l, w)| format!("{l:.2} 1/s at {w:.3}"));
    format!(
        "positive (> {} 1/s) at {} of {} speeds, largest {:.1} 1/s; {} and {}",
        r.tol,
        r.positive,
        r.finite,
        r.largest,
        at(r.at[0]),
        at(r.at[1])
    )
}

/// " (e.g. W1, W2, ...)" for up to 8 of the speeds `differ`, empty when there are none.
fn for_example(differ: &[f64]) -> String {
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
}

/// Enlargement `k` of Fig. 3 (an up sweep over one of the article's zoom ranges).
pub(super) fn enlargement(
    c: &mut Ctx,
    k: usize,
    zspec: &BifurcationSpec,
    zres: &BifurcationResult,
    seconds: f64,
) -> Result<()> {
    let (dir, p, rep) = (c.dir, c.spec.preset, &mut c.rep);
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
pub(super) fn portrait(c: &mut Ctx, figure: usize, at: &AtSpeed) -> Result<()> {
    let (dir, p, rep) = (c.dir, c.spec.preset, &mut c.rep);
    let omega = at.omega;
    let i = figure - 5;
    let fig = ["fig05_phase_131.7.png", "fig06_phase_132.2.png"][i];
    let class = at.class.label();
    plot::phase_portraits(
        &dir.join(fig),
        &format!("Fig. {figure}: W = {omega} rad/s from the static equilibrium: {class}"),
        &at.res.timeseries,
        &at.res.poincare,
    )?;
    rep.figure(
        &format!("Fig. {figure}: phase spaces and Poincare section at W = {omega} rad/s"),
        fig,
        &format!(
            "From the static equilibrium after 1000 periods: **{class}**, lambda_1 = {} (full spectrum in the table at the top) (the article: {}). Survey of {} start states: {}.",
            l1_text(at.survey.spectrum(omega)),
            ARTICLE_SPEEDS[i].1,
            p.survey_ics,
            describe(&at.survey.catalogues[i])
        ),
        &format!("jeffcott simulate --omega {omega} --transient 1000 --periods 64 --timeseries-periods 4"),
        at.seconds,
    );
    Ok(())
}

/// The basin section's results ([`Section::Basin`]).
pub(super) struct BasinFigures<'a> {
    pub(super) outcome: &'a BasinOutcome,
    pub(super) class: Class,
    pub(super) survey: &'a Survey,
    pub(super) seconds: f64,
}

/// Figs. 7 and 8: the basin at 133 rad/s (refined at its boundary), its coexisting
/// attractors and its measures.
pub(super) fn basin_section(c: &mut Ctx, f: &BasinFigures) -> Result<()> {
    let (dir, backend, p, rep) = (c.dir, c.backend.as_str(), c.spec.preset, &mut c.rep);
    let o = f.outcome;
    let (bres, refined, reint) = (&o.result, o.refined.as_ref(), o.reintegration.as_ref());
    let n = o.coarse.x.n;
    let bdir = dir.join("basin_133");
    let refine_text = match refined {
        Some(f) => {
            format!(
                " Refined {} level(s) around the boundary to {} x {} points: {} lanes besides the {n} x {n} grid, {:.0} % of the {} of the full fine grid (`--refine {}`, refined.npy).",
                f.levels.len(),
                f.nx,
                f.ny,
                f.lanes(),
                100.0 * (f.lanes() + n * n) as f64 / f.points() as f64,
                f.points(),
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

/// A Poincare-section figure of Figs. 10 to 12: its file, the title drawn, the two
/// coordinate pairs, the enlargement (the central fraction of each axis), the report's
/// heading and text (`None`: the section's findings).
struct SectionFigure {
    file: &'static str,
    title: &'static str,
    axes: [(usize, usize); 2],
    zoom: Option<f64>,
    heading: &'static str,
    text: Option<&'static str>,
}

/// Fig. 10 and its enlargement, at 135 rad/s.
const SECTIONS_135: [SectionFigure; 2] = [
    SectionFigure {
        file: "fig10_section_135.png",
        title: "Fig. 10: Poincare section at W = 135 rad/s",
        axes: [(X_S, VX_S), (X_R, VX_R)],
        zoom: None,
        heading: "Fig. 10: Poincare section at W = 135 rad/s",
        text: None,
    },
    SectionFigure {
        file: "fig10b_section_135_zoom.png",
        title: "Fig. 10 enlarged: 30 % of each axis around the median point",
        axes: [(X_S, VX_S), (X_R, VX_R)],
        zoom: Some(0.3),
        heading: "Fig. 10, enlarged",
        text: Some("The central 30 % of each axis of the section above."),
    },
];

/// Figs. 11 and 12, at 140 rad/s.
const SECTIONS_140: [SectionFigure; 2] = [
    SectionFigure {
        file: "fig11_section_stator_140.png",
        title: "Fig. 11: stator Poincare section at W = 140 rad/s",
        axes: [(X_S, VX_S), (X_S, Y_S)],
        zoom: None,
        heading: "Fig. 11: stator section at W = 140 rad/s",
        text: None,
    },
    SectionFigure {
        file: "fig12_section_rotor_140.png",
        title: "Fig. 12: rotor Poincare section at W = 140 rad/s",
        axes: [(X_R, VX_R), (X_R, Y_R)],
        zoom: None,
        heading: "Fig. 12: rotor section at W = 140 rad/s",
        text: None,
    },
];

/// Figs. 9 to 12: the phase portrait and Poincare sections at 135 or 140 rad/s.
pub(super) fn section_figures(c: &mut Ctx, i: usize, at: &AtSpeed) -> Result<()> {
    let (dir, p, cfg, rep) = (c.dir, c.spec.preset, c.spec.catalogue, &mut c.rep);
    let (omega, r, sv, seconds) = (at.omega, &at.res, at.survey, at.seconds);
    {
        let class = at.class.label();
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
        let figures = if omega == 135.0 {
            plot::phase_portraits(
                &dir.join("fig09_phase_135.png"),
                &format!("Fig. 9: W = 135 rad/s, last 8 periods: {class}"),
                &r.timeseries,
                &r.poincare,
            )?;
            rep.figure(
                "Fig. 9: phase spaces at W = 135 rad/s",
                "fig09_phase_135.png",
                &found,
                &cmd,
                seconds,
            );
            &SECTIONS_135
        } else {
            &SECTIONS_140
        };
        for f in figures {
            plot::poincare_sections(&dir.join(f.file), f.title, &r.poincare, &f.axes, f.zoom)?;
            let text = f.text.unwrap_or(&found);
            rep.figure(f.heading, f.file, text, &cmd, seconds);
        }
    }
    Ok(())
}
