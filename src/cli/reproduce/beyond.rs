//! The sections of `jeffcott reproduce` beyond the article: the (W, e) design chart,
//! the attractor continuation, the rub-regime map, the cascade and the full spectrum.

use super::{Ctx, copy};
use jeffcott_analysis::cascade::{CascadeResult, CascadeSpec};
use jeffcott_analysis::continuation::{ContinuationResult, ContinuationSpec};
use jeffcott_analysis::map::{MapResult, MapSpec};
use jeffcott_analysis::reproduce::{
    MapFindings, RampFindings, RegimeCells, THROW, Throw, ThrowOutcome,
};
use jeffcott_analysis::simulate::{RubOutputs, SimulateResult};
use jeffcott_core::error::Result;

/// Beyond the article: a design chart over (W, e).
pub(super) fn design_chart(
    c: &mut Ctx,
    mspec: &MapSpec,
    mres: &MapResult,
    f: &MapFindings,
    seconds: f64,
) -> Result<()> {
    let (dir, backend, p, rep) = (c.dir, c.backend.as_str(), c.spec.preset, &mut c.rep);
    let mdir = dir.join("map_w_e");
    crate::cli::map::write_map(&mdir, mspec, mres, true)?;
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
pub(super) fn continuation_section(
    c: &mut Ctx,
    cspec: &ContinuationSpec,
    cres: &ContinuationResult,
    ramps: &[RampFindings],
    seconds: f64,
) -> Result<()> {
    let (dir, backend, p, rep) = (c.dir, c.backend.as_str(), c.spec.preset, &mut c.rep);
    let cdir = dir.join("continuation");
    crate::cli::continuation::write_continuation(&cdir, cspec, cres, true)?;
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

/// The periodic orbits behind the bifurcation diagram (beyond the article): the period-1
/// branch over 130..141 rad/s and the period-2 branches of its doublings, drawn over the
/// brute force, their files in `orbits/`.
pub(super) fn orbits_section(
    c: &mut Ctx,
    study: &jeffcott_analysis::orbits::OrbitsStudy,
    branches: &[jeffcott_analysis::orbits::Branch],
    background: &jeffcott_analysis::bifurcation::BifurcationResult,
    seconds: f64,
) -> Result<()> {
    use jeffcott_core::model::{STATE_DIM, VX_S};
    let (dir, rep) = (c.dir, &mut c.rep);
    crate::cli::orbits::write_files(&dir.join("orbits"), "omega", branches)?;
    let sweep = |s: &[jeffcott_analysis::bifurcation::SweepPoint]| -> Vec<(f64, f64)> {
        s.iter()
            .flat_map(|sp| sp.points.iter().map(move |x| (sp.omega, x[VX_S])))
            .collect()
    };
    let under = crate::plot::orbits::Backdrop {
        brute: background
            .brute
            .iter()
            .flat_map(|bp| {
                bp.points
                    .chunks_exact(STATE_DIM)
                    .map(move |x| (bp.omega, x[VX_S]))
            })
            .collect(),
        up: sweep(&background.up),
        down: sweep(&background.down),
    };
    crate::cli::orbits::draw(
        &dir.join("fig_orbits.png"),
        study,
        branches,
        VX_S,
        Some(&under),
    )?;
    let found = |b: &jeffcott_analysis::orbits::Branch| -> String {
        let list = b.found("", 4, "no bifurcation");
        let (from, to) = b.span();
        format!(
            "period-{} branch, {} points from {from:.3} to {to:.3} rad/s ({}): {}",
            b.period,
            b.points.len(),
            b.stop,
            list
        )
    };
    let text: Vec<String> = branches.iter().map(found).collect();
    rep.figure(
        "Periodic orbits behind the diagram (beyond the article): stable solid, unstable dashed",
        "fig_orbits.png",
        &format!(
            "Newton shooting with the exact monodromy matrix, continued by pseudo-arclength through folds, bifurcations located to 1e-8 rad/s (docs/orbits.md), over the brute force of Fig. 3 (grey) and its up (blue) and down (red) sweeps. {}. Files in `orbits/`.",
            text.join("; ")
        ),
        &format!(
            "jeffcott orbits --vary omega:130:141 --max-points {} --follow-doublings --coord vx_s --over {}/bifurcation --out {}/orbits",
            study.branch.max_points,
            dir.display(),
            dir.display()
        ),
        seconds,
    );
    Ok(())
}

/// Rub regimes beyond the article's range: the (W, mu) map and the backward throws.
#[allow(clippy::too_many_arguments)]
pub(super) fn rub_map(
    c: &mut Ctx,
    rspec: &MapSpec,
    rres: &MapResult,
    regimes: &[RegimeCells],
    throws: &[Throw],
    soft_modes: &[(String, f64)],
    seconds: f64,
) -> Result<()> {
    let (dir, backend, p, rep) = (c.dir, c.backend.as_str(), c.spec.preset, &mut c.rep);
    let rdir = dir.join("map_w_mu");
    crate::cli::map::write_map(&rdir, rspec, rres, true)?;
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
                    crate::cli::rubout::rub_sentence(o)
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
pub(super) fn cascade_section(
    c: &mut Ctx,
    cspec: &CascadeSpec,
    cres: &CascadeResult,
    seconds: f64,
) -> Result<()> {
    let (dir, p, rep) = (c.dir, c.spec.preset, &mut c.rep);
    let kdir = dir.join("cascade");
    crate::cli::cascade::write_cascade(&kdir, cspec, cres, true, false)?;
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
pub(super) fn spectrum_section(
    c: &mut Ctx,
    omega: f64,
    r: &SimulateResult,
    rub: Option<&RubOutputs>,
    seconds: f64,
) -> Result<()> {
    let (dir, rep) = (c.dir, &mut c.rep);
    let Some(o) = rub else { return Ok(()) };
    let fdir = dir.join(format!("spectrum_{omega}"));
    jeffcott_analysis::output::ensure_dir(&fdir)?;
    crate::cli::rubout::write_rub_outputs(
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
            crate::cli::rubout::rub_sentence(o)
        ),
        &format!("jeffcott simulate --omega {omega}"),
        seconds,
    );
    Ok(())
}
