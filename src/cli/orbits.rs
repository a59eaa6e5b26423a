//! `jeffcott orbits`: a branch of period-n orbits continued over W or a model parameter
//! by pseudo-arclength, with Floquet multipliers and located bifurcations
//! ([`jeffcott_analysis::orbits`]; shooting in [`jeffcott_core::orbit`]).

use super::{ModelArgs, StepperArgs, apply_init, rundir};
use crate::cli::choice::{choice, name_of};
use clap::{Args, ValueEnum};
use jeffcott_analysis::orbits::{Branch, OrbitsRequest, run};
use jeffcott_analysis::{defaults, output};
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::StepperConfig;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Which way the parameter first moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// Increasing.
    Up,
    /// Decreasing.
    Down,
}

/// Arguments of `jeffcott orbits`.
#[derive(Args, Debug)]
pub struct OrbitsArgs {
    /// The continued parameter and its range, NAME:lo:hi (NAME: omega or a model
    /// parameter), e.g. `--vary omega:131.7:132.4`, as `continuation --vary` names its
    /// parameter.
    #[arg(long, value_name = "NAME:lo:hi", allow_hyphen_values = true)]
    pub vary: Option<String>,
    /// Rotor speed W [rad/s] when the continued parameter is not omega.
    #[arg(long, value_name = "W")]
    pub omega: Option<f64>,
    /// Period of the orbits in forcing periods.
    #[arg(long, default_value_t = defaults::orbits::PERIOD, value_name = "N")]
    pub period: u32,
    /// Which way the parameter first moves; the branch starts at lo (up) or hi (down).
    #[arg(long, value_enum, default_value_t = Direction::Up)]
    pub direction: Direction,
    /// Forcing periods integrated from the start state before shooting, so Newton
    /// starts near the attractor there (0: shoot from the start state itself).
    #[arg(long, default_value_t = defaults::orbits::SETTLE, value_name = "P")]
    pub settle: u32,
    /// Override coordinates of the start state (default: static equilibrium), e.g.
    /// `--init x_r=0.005,vx_r=-0.5`.
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub init: Vec<String>,
    /// Start from the periodic attractors of an earlier result: a `jeffcott basin`
    /// output directory (every periodic attractor in attractors.json), a `jeffcott
    /// bifurcation` one (the brute force's periodic attractors at the speed nearest the
    /// branch's start) or a `jeffcott continuation` one over the same parameter (the
    /// step nearest the branch's start). Each attractor's orbit is shot (all at once)
    /// and a branch of its period continued from it; the model options must be the
    /// result's.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["init", "settle", "period"])]
    pub from: Option<PathBuf>,
    /// Branch points at most.
    #[arg(long, default_value_t = defaults::orbits::MAX_POINTS, value_name = "K")]
    pub max_points: usize,
    /// First arclength step (positions in metres, velocities over W, the parameter at
    /// 1 mm per its range).
    #[arg(long, default_value_t = defaults::orbits::DS, value_name = "DS", allow_hyphen_values = true)]
    pub ds: f64,
    /// Largest arclength step.
    #[arg(long, default_value_t = defaults::orbits::DS_MAX, value_name = "DS", allow_hyphen_values = true)]
    pub ds_max: f64,
    /// Also continue the period-2n branch born at each period doubling of the branch.
    #[arg(long)]
    pub follow_doublings: bool,
    /// The coordinate `branch.png` shows (each orbit's Poincare points in it).
    #[arg(long, default_value = "x_r", value_name = "NAME")]
    pub coord: String,
    /// A `jeffcott bifurcation` output directory over the same speeds: its brute force's
    /// and its up and down sweeps' Poincare points are drawn under the branches (W
    /// continuation only).
    #[arg(long, value_name = "DIR")]
    pub over: Option<PathBuf>,
    /// Do not draw `branch.png`.
    #[arg(long)]
    pub no_plot: bool,
    /// Where the flows run (always f64): cpu, gpu (the kernel's tangent variant, eight
    /// lanes per monodromy matrix; any adapter with SHADER_F64, software included), or
    /// auto (a hardware GPU if present). The CPU is the default: one branch asks for a
    /// few lanes per Newton step, too few to fill a GPU. Both give the same bits.
    #[arg(long, value_parser = choice::<Backend>(), default_value = name_of(Backend::Cpu))]
    pub backend: Backend,
    #[command(flatten)]
    pub model: ModelArgs,
    /// The former spelling of `--param NAME=VALUE` here; still read, with a warning.
    #[arg(long, value_name = "NAME=VALUE,...", hide = true)]
    pub set: Vec<String>,
    #[command(flatten)]
    pub stepper: StepperArgs,
    /// Output directory.
    #[arg(long, value_name = "DIR", default_value = "jeffcott-out/orbits")]
    pub out: PathBuf,
    #[command(flatten)]
    pub run: rundir::RunArgs,
}

/// `run.json`'s specification of a branch.
#[derive(Serialize)]
struct Record<'a> {
    param: &'static str,
    lo: f64,
    hi: f64,
    omega: Option<f64>,
    period: u32,
    direction: Direction,
    settle: u32,
    start: [f64; 8],
    from: Option<&'a Path>,
    max_points: usize,
    ds: f64,
    ds_max: f64,
    tol: f64,
    params: &'a jeffcott_core::model::Params,
    #[serde(serialize_with = "StepperConfig::serialize_flow")]
    stepper: StepperConfig,
}

/// What `run.json` adds once a branch is written: where its flows ran (not part of
/// the specification: both backends give the same bits) and the wall time.
#[derive(Serialize)]
struct Finished {
    backend: &'static str,
    wall_time_s: f64,
}

/// `branches.json`: the branches and the list of files.
#[derive(Serialize)]
struct BranchesFile<'a> {
    #[serde(flatten)]
    record: jeffcott_analysis::orbits::BranchesRecord<'a>,
    files: std::collections::BTreeMap<&'static str, &'static str>,
}

const OUTPUTS: &[&str] = &[
    "branches.json",
    "branch.npy",
    "multipliers.npy",
    "branch.png",
];

/// Runs `jeffcott orbits`.
pub fn run_orbits(a: &OrbitsArgs) -> Result<()> {
    let (vary, model) = vocabulary(a)?;
    let params = model.params()?;
    let mut start = params.static_equilibrium();
    apply_init(&mut start, &a.init)?;
    let stepper = a.stepper.config();
    let study = OrbitsRequest {
        params: params.clone(),
        param: &vary,
        param_field: "vary",
        omega: a.omega,
        period: a.period,
        up: a.direction == Direction::Up,
        settle: a.settle,
        start,
        max_points: a.max_points,
        ds: a.ds,
        ds_max: a.ds_max,
        stepper,
        follow_doublings: a.follow_doublings,
        from: a.from.as_deref(),
    }
    .study()?;
    let spec = &study.branch;
    let (lo, hi) = (spec.lo, spec.hi);
    let var = spec.var;
    var.check_not_overridden("vary", "param", &model.overridden()?)?;
    let coord = jeffcott_core::inputs::coord("coord", &a.coord)?;
    // The diagram to draw under the branches, read (and refused) before any work.
    let background = match &a.over {
        Some(dir) if !a.no_plot => Some(diagram_points(dir, var, coord, &params, (lo, hi))?),
        _ => None,
    };
    let run_dir = rundir::open(
        &a.out,
        "orbits",
        &Record {
            param: var.name(),
            lo,
            hi,
            omega: a.omega,
            period: a.period,
            direction: a.direction,
            settle: a.settle,
            start,
            from: a.from.as_deref(),
            max_points: a.max_points,
            ds: a.ds,
            ds_max: a.ds_max,
            tol: spec.shoot.tol,
            params: &params,
            stepper,
        },
        OUTPUTS,
        a.run,
        rundir::Work::Whole,
    )?;
    let t0 = std::time::Instant::now();
    let engine = jeffcott_analysis::backend::Engine::new(a.backend, Precision::F64)?;
    let branches = run(&study, &engine, &rundir::cancel())?;
    write_files(&a.out, var.name(), &branches)?;
    if !a.no_plot {
        draw(
            &a.out.join("branch.png"),
            &study,
            &branches,
            coord,
            background.as_ref(),
        )?;
    }
    run_dir.finish(
        &Finished {
            backend: if engine.runner().is_some() {
                "gpu"
            } else {
                "cpu"
            },
            wall_time_s: t0.elapsed().as_secs_f64(),
        },
        &rundir::written(&run_dir, OUTPUTS),
    )?;
    if !a.run.quiet {
        for b in &branches {
            println!("{}", summary(var.name(), b));
        }
        println!("Files in {}.", a.out.display());
    }
    Ok(())
}

/// The continued parameter (`--vary`) and the model overrides (`--param`), read from
/// the spellings of earlier releases too, each with a warning that names the new one:
/// `--param NAME:lo:hi` (no `=`) for `--vary`, and `--set NAME=VALUE` for `--param`.
fn vocabulary(a: &OrbitsArgs) -> Result<(String, ModelArgs)> {
    let (old, param): (Vec<&String>, Vec<&String>) = a
        .model
        .param
        .iter()
        .partition(|p| !p.contains('=') && p.contains(':'));
    let vary = match (&a.vary, old.as_slice()) {
        (Some(v), []) => v.clone(),
        (None, [v]) => {
            deprecated(&format!("--param {v}"), &format!("--vary {v}"));
            (*v).clone()
        }
        (Some(_), [v, ..]) | (None, [_, v, ..]) => {
            return Err(Error::invalid(
                "param",
                v,
                "NAME=VALUE (the continued parameter is --vary NAME:lo:hi, given once)",
            ));
        }
        (None, []) => {
            return Err(Error::invalid(
                "vary",
                "(missing)",
                "NAME:lo:hi, the continued parameter and its range, e.g. --vary omega:131.7:132.4",
            ));
        }
    };
    for s in &a.set {
        deprecated(&format!("--set {s}"), &format!("--param {s}"));
    }
    let model = ModelArgs {
        config: a.model.config.clone(),
        param: param.into_iter().chain(&a.set).cloned().collect(),
    };
    Ok((vary, model))
}

/// Tells the user on stderr that a spelling of an earlier release was read.
fn deprecated(old: &str, new: &str) {
    eprintln!(
        "warning: `jeffcott orbits {old}` is read as `{new}`; the old spelling is deprecated and goes in the next release"
    );
}

/// Writes `branches.json`, `branch.npy` and `multipliers.npy`.
pub(crate) fn write_files(dir: &Path, name: &'static str, b: &[Branch]) -> Result<()> {
    output::ensure_dir(dir)?;
    let (rows, mu) = jeffcott_analysis::orbits::arrays(b);
    let n = rows.len() / jeffcott_analysis::orbits::ROW;
    output::write_npy(
        &dir.join("branch.npy"),
        &[n, jeffcott_analysis::orbits::ROW],
        &rows,
    )?;
    output::write_npy(&dir.join("multipliers.npy"), &[n, 8, 2], &mu)?;
    let files = [
        ("branches.json", "every branch: its points (parameter value, orbit state at t = 0, Floquet multipliers [re, im] by decreasing modulus, stable, smallest clearance [m]), its bifurcations (type, the parameter's value under its name, multipliers, state) and why it ended"),
        ("branch.npy", "f64 [points, 13]: branch index (in branches.json), parameter value, the orbit's state at t = 0 (8), largest multiplier modulus, smallest clearance [m], stable (1/0); the branches' points in order"),
        ("multipliers.npy", "f64 [points, 8, 2]: Floquet multipliers (re, im) by decreasing modulus"),
    ]
    .into_iter()
    .collect();
    output::write_json(
        &dir.join("branches.json"),
        &BranchesFile {
            record: jeffcott_analysis::orbits::record(name, b),
            files,
        },
    )
}

/// What the command prints of a branch.
fn summary(name: &str, b: &Branch) -> String {
    let (first, last) = b.span();
    let found = b.found(&format!("{name} = "), 8, "none");
    let shot = if b.minimal_period == b.period {
        String::new()
    } else {
        format!(
            " (asked for period {}: the orbit closes after {} forcing period{}, so this is the period-{} orbit; its multipliers are those of {} periods)",
            b.period,
            b.minimal_period,
            if b.minimal_period == 1 { "" } else { "s" },
            b.minimal_period,
            b.period
        )
    };
    format!(
        "Period-{} branch{shot}: {} points from {name} = {first} to {last} ({}); bifurcations: {}.",
        b.minimal_period,
        b.points.len(),
        b.stop,
        found
    )
}

/// The Poincare points (W, coordinate `coord`) of the `jeffcott bifurcation` run in
/// `dir` (field `over`): its brute force's and its sweeps'. The run must be of the
/// branch's model `params`, with speeds in the branch's range `lo..hi`.
fn diagram_points(
    dir: &Path,
    var: jeffcott_analysis::map::MapVar,
    coord: usize,
    params: &jeffcott_core::model::Params,
    range: (f64, f64),
) -> Result<crate::plot::orbits::Backdrop> {
    if !matches!(var, jeffcott_analysis::map::MapVar::Omega) {
        return Err(jeffcott_core::error::Error::invalid(
            "over",
            dir.display(),
            "a brute force is drawn under a branch over omega only",
        ));
    }
    jeffcott_analysis::orbit_starts::check_diagram("over", dir, params, range)?;
    let read = |name: &str| output::read_npy_f64("over", &dir.join(name));
    let (rs, rows) = read("bifurcation_rows.npy")?;
    let (ps, points) = read("bifurcation.npy")?;
    let bad = |what: &str| {
        jeffcott_core::error::Error::invalid("over", dir.display(), format!("unexpected {what}"))
    };
    if rs.len() != 2 || rs[1] != 4 || ps.len() != 3 || ps[2] != 8 || ps[0] != rs[0] {
        return Err(bad("array shapes"));
    }
    let recorded = ps[1] as usize;
    let mut out = crate::plot::orbits::Backdrop::default();
    for (r, row) in rows.chunks_exact(4).enumerate() {
        // Column 1: 0 the up sweep, 1 the down sweep, 2 the brute force.
        let layer = match row[1] {
            0.0 => &mut out.up,
            1.0 => &mut out.down,
            _ => &mut out.brute,
        };
        let lane = &points[r * recorded * 8..(r + 1) * recorded * 8];
        layer.extend(lane.chunks_exact(8).map(|x| (row[0], x[coord])));
    }
    Ok(out)
}

/// Draws the branches of `study` in coordinate `coord` to `path` over `background`
/// (a bifurcation diagram's points: W and the coordinate).
pub(crate) fn draw(
    path: &Path,
    study: &jeffcott_analysis::orbits::OrbitsStudy,
    branches: &[Branch],
    coord: usize,
    background: Option<&crate::plot::orbits::Backdrop>,
) -> Result<()> {
    use crate::plot::orbits::{BranchLine, Mark};
    let spec = &study.branch;
    // Each branch's points with its bifurcations in between (where the stability
    // changes, the solid and dashed stretches meet at the bifurcation itself).
    let lines: Vec<BranchLine> = branches
        .iter()
        .map(|b| {
            let cycle = |v: f64, x: &jeffcott_core::model::State| -> Vec<f64> {
                spec.cycle(v, x, b.period)
                    .iter()
                    .map(|x| x[coord])
                    .collect()
            };
            let mut points = Vec::new();
            for (k, p) in b.points.iter().enumerate() {
                points.push((p.value, cycle(p.value, &p.x), p.stable));
                for x in b.bifurcations.iter().filter(|x| x.after_point == k) {
                    points.push((x.value, cycle(x.value, &x.x), p.stable));
                }
            }
            BranchLine {
                label: format!("period-{} orbits", b.minimal_period),
                points,
            }
        })
        .collect();
    let marks: Vec<Mark> = branches
        .iter()
        .flat_map(|b| b.bifurcations.iter())
        .map(|x| Mark {
            value: x.value,
            y: x.x[coord],
            kind: x.kind.label().to_string(),
        })
        .collect();
    let name = spec.var.name();
    crate::plot::orbits::branches(
        path,
        &format!("Periodic orbits over {name}: stable solid, unstable dashed"),
        &format!("{name} [{}]", spec.var.unit()),
        coord,
        &lines,
        &marks,
        background.unwrap_or(&Default::default()),
    )
}
