//! `jeffcott basin`: basin of attraction over two initial coordinates at one W, streamed
//! in work units committed to --out (resumable); `labels.npy`, `attractors.json`, `basin.png` and `attractors.png`.

use super::files::Documented;
use super::parse_assignment_lists;
use super::rundir::{self, CommandHost, Execution};
use super::study::{self, StudyCommand};
use crate::plot::{
    AttractorTrace, MapGrid, attractor_color, basin_map, coexisting_attractors, coord_axis,
    lambda1_map,
};
use clap::Args;
use jeffcott_analysis::backend::Engine;
use jeffcott_analysis::basin::study::{BasinOutcome, BasinStudy, run};
use jeffcott_analysis::basin::{Axis, BasinResult, BasinSpec};
use jeffcott_analysis::catalogue::Attractor;
use jeffcott_analysis::defaults;
use jeffcott_analysis::output;
use jeffcott_analysis::rub::RubEntry;
use jeffcott_analysis::run::RunDir;
use jeffcott_analysis::simulate::AttractorTrace as SimTrace;
use jeffcott_core::error::Result;
use jeffcott_core::model::COORD_NAMES;
use serde::Serialize;
use std::path::Path;

/// Arguments of `jeffcott basin`.
///
/// Memory stays bounded for any grid: the labels take 4 bytes per cell and one unit of
/// lanes at a time is held, about unit x (periods x 64 + 400) bytes (the default unit
/// is at most 1/20 of the grid and ~25 s of CPU work), so a 2000 x 2000 grid needs
/// roughly 16 MB + 10 MB.
#[derive(Args, Debug)]
pub struct BasinArgs {
    /// Rotor speed W [rad/s].
    #[arg(long, value_name = "W")]
    pub omega: f64,
    /// Horizontal axis: a start coordinate, its range and count, NAME:lo:hi:n (values
    /// from lo to hi inclusive) [m or m/s], e.g. x_r:-0.006:0.006:200.
    #[arg(long, value_name = "NAME:lo:hi:n", allow_hyphen_values = true)]
    pub x: String,
    /// Vertical axis, NAME:lo:hi:n, e.g. vx_r:-1:1:200.
    #[arg(long, value_name = "NAME:lo:hi:n", allow_hyphen_values = true)]
    pub y: String,
    /// Fix other start coordinates (default: the static equilibrium), e.g.
    /// `--fix y_r=0.001,vy_r=0.2` (repeatable).
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub fix: Vec<String>,
    /// Forcing periods integrated and discarded.
    #[arg(long, default_value_t = defaults::basin::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded per cell (at least 2 n to see period n).
    #[arg(long, default_value_t = defaults::basin::PERIODS, value_name = "P")]
    pub periods: u32,
    /// Lanes per work unit, the piece of the run committed to --out as it finishes
    /// [default: at most 1/20 of the grid and about 25 s of CPU work].
    #[arg(long, value_name = "LANES")]
    pub chunk: Option<usize>,
    #[command(flatten)]
    pub study: super::StudyArgs,
    /// Also compute every cell's largest Lyapunov exponent lambda_1 (one tangent vector
    /// per lane, either backend): lambda1.npy, basin_lambda1.png, lambda_1 per attractor,
    /// and aperiodic attractors split into quasiperiodic and chaotic. Costs about 1.8x
    /// the run time on the CPU (see docs/analysis.md).
    #[arg(long)]
    pub lyapunov: bool,
    /// Side of the boxes of the basin entropy, in cells (basin_metrics.json; Daza et al.
    /// 2016) [default: 5, or the grid's shorter side if smaller; the value used is in
    /// basin_metrics.json as entropy.eps].
    #[arg(long, value_name = "CELLS")]
    pub entropy_box: Option<usize>,
    /// Boundary refinement: K levels of 2 x 2 subdivision around every point with a
    /// differently labelled neighbour, interiors filled from their parent; labels.npy at
    /// the finest ((n - 1) 2^K + 1 points per axis), refined.npy marking computed points,
    /// the measures on the fine grid (not with --lyapunov).
    #[arg(long, default_value_t = 0, value_name = "K")]
    pub refine: u32,
    /// Also draw basin_boundary.png: the basin with its boundary points (a 4-neighbour of
    /// another label) in dark grey.
    #[arg(long)]
    pub highlight_boundary: bool,
    /// Draws of the uncertainty exponent by re-integration (Grebogi et al. 1983): each
    /// draw is integrated as it is and displaced by +-eps along both axes for eps =
    /// 1e-1 .. 1e-7 of the box side (29 lanes a draw); 0 skips it. f(eps) cannot go below
    /// 1/M, so smooth boundaries need many draws.
    #[arg(long, default_value_t = defaults::basin::UNCERTAINTY_SAMPLES, value_name = "M")]
    pub uncertainty_samples: usize,
    /// Skip basin.png, basin_lambda1.png, attractors.png and uncertainty.png.
    #[arg(long)]
    pub no_plot: bool,
}

impl BasinArgs {
    /// The grid these arguments describe (validated with the study).
    fn spec(&self) -> Result<BasinSpec> {
        let lane = self.study.settings(self.lyapunov)?;
        let x = Axis::parse("x", &self.x)?;
        let y = Axis::parse("y", &self.y)?;
        let base = jeffcott_analysis::basin::base_state(
            &lane.params,
            &x,
            &y,
            &parse_assignment_lists("fix", &self.fix)?,
            self.study.run.stepper.divergence_bound,
        )?;
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        jeffcott_core::limits::check_periods("periods", self.periods, 2)?;
        Ok(BasinSpec {
            lane,
            omega: self.omega,
            x,
            y,
            base,
            transient: self.transient,
            periods: self.periods,
            lanes_per_unit: self.chunk,
        })
    }

    /// The study these arguments describe (the basin and its stages), validated.
    pub fn study(&self) -> Result<BasinStudy> {
        let study = BasinStudy {
            refine: self.refine,
            uncertainty_samples: self.uncertainty_samples,
            entropy_box: self.entropy_box,
            traces: if self.no_plot {
                0
            } else {
                defaults::basin::TRACES
            },
            ..BasinStudy::new(self.spec()?)
        };
        study.validate()?;
        Ok(study)
    }
}

/// Final files of a basin (run.json aside).
pub const OUTPUTS: &[&str] = &[
    "labels.npy",
    "lambda1.npy",
    "x.npy",
    "y.npy",
    "attractors.json",
    "basin_metrics.json",
    "refined.npy",
    "uncertainty.png",
    "basin_boundary.png",
    "basin.png",
    "basin_lambda1.png",
    "attractors.png",
];

/// What run.json records of a finished basin besides its specification.
/// What a basin's `run.json` adds once complete: backend and wall time, and with
/// `--refine` what the refinement computed.
#[derive(Serialize)]
struct RunResult<'a> {
    #[serde(flatten)]
    run: rundir::BackendTime<'a>,
    #[serde(skip_serializing_if = "Option::is_none")]
    refinement: Option<RefinementRecord<'a>>,
    /// The same for the uncertainty exponent's re-integrated draws (the refinement's
    /// are in `refinement.levels`).
    #[serde(skip_serializing_if = "Option::is_none")]
    uncertainty_early_exit: Option<jeffcott_analysis::early::EarlySaved>,
}

/// Runs `jeffcott basin`: the study's units committed to --out, then its files.
pub fn run_basin(a: &BasinArgs) -> Result<()> {
    let exec = a
        .study
        .exec
        .execution(Basin::COMMAND, a.study.run.backend)?;
    let write = BasinWrite {
        entropy_box: a.entropy_box,
        plot: !a.no_plot,
        highlight_boundary: a.highlight_boundary,
    };
    study::execute::<Basin>(&a.study()?, &write, &exec)
}

/// What `jeffcott basin` writes besides the study's result.
#[derive(Clone, Copy, Debug, Serialize, serde::Deserialize)]
pub struct BasinWrite {
    /// `--entropy-box` (the measures are computed from the units on every run).
    pub entropy_box: Option<usize>,
    /// Draw the pictures (and compute the attractors' traces for `attractors.png`).
    pub plot: bool,
    /// `--highlight-boundary`.
    pub highlight_boundary: bool,
}

/// `jeffcott basin` as a study command.
pub struct Basin;

impl StudyCommand for Basin {
    const COMMAND: &'static str = "basin";
    const OUTPUTS: &'static [&'static str] = OUTPUTS;
    type Spec = BasinStudy;
    type Write = BasinWrite;
    type Outcome = BasinOutcome;
    fn run(study: &BasinStudy, w: &BasinWrite, host: &CommandHost) -> Result<BasinOutcome> {
        let study = BasinStudy {
            entropy_box: w.entropy_box,
            traces: if w.plot { defaults::basin::TRACES } else { 0 },
            ..study.clone()
        };
        let engine = Engine::new(study.basin.lane.backend, study.basin.lane.precision)?;
        run(&study, &engine, host)
    }
    fn finish(
        _: &BasinStudy,
        w: &BasinWrite,
        o: BasinOutcome,
        run_dir: &RunDir,
        exec: &Execution,
    ) -> Result<()> {
        report_basin(&exec.out, w, &o, run_dir, exec.run.quiet)
    }
}

/// Writes a basin study's files, marks its run complete and says what it found.
fn report_basin(
    out: &Path,
    w: &BasinWrite,
    o: &BasinOutcome,
    run_dir: &RunDir,
    quiet: bool,
) -> Result<()> {
    let rub_line = write_basin_files(out, o, w.plot, w.highlight_boundary)?;
    let (spec, res) = (&o.spec, &o.result);
    let run_result = RunResult {
        run: rundir::BackendTime {
            backend: res.info.as_ref(),
            wall_time_s: res.seconds,
            // The grid's lanes (the refinement's are in `refinement.levels`).
            early_exit: res.early_exit,
        },
        refinement: o.refined.as_ref().map(|f| refinement_record(f, spec)),
        uncertainty_early_exit: o.reintegration.as_ref().and_then(|r| r.early_exit),
    };
    run_dir.finish(&run_result, &rundir::written(run_dir, OUTPUTS))?;
    if !quiet {
        println!("{}", human_summary(spec, res, out));
        if !rub_line.is_empty() {
            println!("Rub on the attractors (attractors.json, docs/rub.md): {rub_line}.");
        }
        let close = res.catalogue.close_pairs();
        if !close.is_empty() {
            let pairs: Vec<String> = close
                .iter()
                .map(|(a, b, d)| format!("#{a} and #{b} ({:.2} um)", d * 1e6))
                .collect();
            println!(
                "Entries within four identity tolerances of each other: {}. Near a bifurcation such entries are usually one attractor still converging; a longer --transient tells (docs/early-exit.md).",
                pairs.join(", ")
            );
        }
        if let Some(f) = &o.refined {
            println!(
                "Refined {} level(s) to {} x {}: {} lanes integrated besides the coarse grid, against {} for the full fine grid ({:.1} %).",
                f.levels.len(),
                f.nx,
                f.ny,
                f.lanes(),
                f.points(),
                100.0 * f.lanes() as f64 / f.points() as f64
            );
        }
        println!(
            "Basin measures (basin_metrics.json): {}{}",
            o.metrics.summary(),
            o.reintegration
                .as_ref()
                .map(|r| format!("; {}", r.summary()))
                .unwrap_or_default()
        );
    }
    Ok(())
}

/// Writes every file of a basin study's outcome (labels, axes, attractors.json,
/// refined.npy, basin_metrics.json and, with `plot_it`, the pictures; the boundary
/// picture with `boundary`); returns one line on the rub of each attractor for the
/// summary. Computes nothing.
pub fn write_basin_files(
    dir: &Path,
    o: &BasinOutcome,
    plot_it: bool,
    boundary: bool,
) -> Result<String> {
    if let Some(f) = &o.refined {
        output::ensure_dir(dir)?;
        output::write_npy(&dir.join("refined.npy"), &[f.ny, f.nx], &f.computed)?;
    }
    let rub_line = write_basin(dir, o, plot_it)?;
    if boundary && plot_it {
        boundary_picture(&dir.join("basin_boundary.png"), &o.spec, &o.result)?;
    }
    write_metrics(dir, o, plot_it)?;
    Ok(rub_line)
}

/// The basin with its boundary points (a 4-neighbour of another label) in dark grey.
/// The grid of a basin's maps: its axes in plot units (mm, m/s), a one-value axis
/// widened by 1e-12 so its range is not empty.
fn map_grid(spec: &BasinSpec) -> MapGrid {
    let (sx, lx) = coord_axis(spec.x.coord);
    let (sy, ly) = coord_axis(spec.y.coord);
    MapGrid {
        cells: (spec.x.n, spec.y.n),
        x_range: (spec.x.lo * sx, spec.x.hi.max(spec.x.lo + 1e-12) * sx),
        y_range: (spec.y.lo * sy, spec.y.hi.max(spec.y.lo + 1e-12) * sy),
        axes: (lx, ly),
    }
}

fn boundary_picture(path: &Path, spec: &BasinSpec, res: &BasinResult) -> Result<()> {
    const BOUNDARY: i32 = -3;
    let (nx, ny) = (spec.x.n, spec.y.n);
    let labels: Vec<i32> = (0..nx * ny)
        .map(|p| {
            if jeffcott_analysis::refine::on_boundary(&res.labels, nx, ny, p % nx, p / nx) {
                BOUNDARY
            } else {
                res.labels[p]
            }
        })
        .collect();
    let boundary = labels.iter().filter(|&&l| l == BOUNDARY).count();
    let mut legend: Vec<(i32, String)> = res
        .catalogue
        .attractors
        .iter()
        .map(|a| (a.id as i32, legend_name(a)))
        .collect();
    if res.catalogue.diverged > 0 {
        legend.push((-1, "diverged".into()));
    }
    legend.push((
        BOUNDARY,
        format!(
            "boundary, {:.1} % of the points",
            100.0 * boundary as f64 / labels.len() as f64
        ),
    ));
    crate::plot::category_map(
        path,
        &format!(
            "Basin boundary at W = {} rad/s ({} x {} start states)",
            spec.omega, nx, ny
        ),
        &labels,
        &map_grid(spec),
        &legend,
        &|l| {
            if l == BOUNDARY {
                plotters::style::RGBColor(60, 60, 60)
            } else {
                attractor_color(l)
            }
        },
    )
}

/// What `run.json` records of a refinement: its levels, the finest grid, the lanes it
/// integrated against the full fine grid's, and the labels the coarse catalogue lacked.
#[derive(Serialize)]
struct RefinementRecord<'a> {
    levels: &'a [jeffcott_analysis::refine::Level],
    finest: [usize; 2],
    lanes: usize,
    full_fine_grid_lanes: usize,
    computed_points: usize,
    not_in_the_coarse_catalogue: usize,
    x_n: usize,
    y_n: usize,
}

fn refinement_record<'a>(
    f: &'a jeffcott_analysis::refine::Refined,
    spec: &BasinSpec,
) -> RefinementRecord<'a> {
    RefinementRecord {
        levels: &f.levels,
        finest: [f.nx, f.ny],
        lanes: f.lanes(),
        full_fine_grid_lanes: f.nx * f.ny,
        computed_points: f.computed.iter().filter(|&&c| c == 1).count(),
        not_in_the_coarse_catalogue: f.labels.iter().filter(|&&l| l == -2).count(),
        x_n: spec.x.n,
        y_n: spec.y.n,
    }
}

/// Writes `basin_metrics.json` (with the re-integration estimate when computed) and,
/// with `plot_it`, `uncertainty.png`.
fn write_metrics(dir: &Path, o: &BasinOutcome, plot_it: bool) -> Result<()> {
    let (spec, m) = (&o.spec, &o.metrics);
    let reint = o.reintegration.as_ref();
    if plot_it {
        // The grid estimate's eps in cells, as a fraction of the box side (nx - 1 cells).
        let side = (spec.x.n.max(2) - 1) as f64;
        let grid: Vec<(f64, f64)> = m
            .uncertainty
            .points
            .iter()
            .map(|p| (p.eps as f64 / side, p.value))
            .collect();
        crate::plot::uncertainty(
            &dir.join("uncertainty.png"),
            &format!(
                "Uncertain fraction f(eps) at W = {} rad/s: f ~ eps^alpha, D = 2 - alpha",
                spec.omega
            ),
            &grid,
            m.uncertainty.fit.map(|f| f.slope),
            reint.map(|r| r.points.as_slice()).unwrap_or(&[]),
            reint.and_then(|r| r.alpha),
        )?;
    }
    output::write_json(&dir.join("basin_metrics.json"), &o.metrics_record())
}

/// Legend text of an attractor: "#0 period-5, 64.2 %", with its mean lambda_1 when
/// computed ("#1 chaotic, 35.0 %, lambda_1 7.52 1/s").
pub fn legend_name(a: &Attractor) -> String {
    let mut s = format!("{}, {:.1} %", a.name(), 100.0 * a.basin_fraction);
    if let Some(l) = a.lambda1 {
        s += &format!(", lambda_1 {l:.2} 1/s");
    }
    s
}

/// The phase traces of a study as the attractor portrait draws them: each with its
/// attractor's legend text and colour.
pub fn plot_traces(traces: &[SimTrace], attractors: &[Attractor]) -> Vec<AttractorTrace> {
    traces
        .iter()
        .map(|t| AttractorTrace {
            name: attractors
                .iter()
                .find(|a| a.id == t.id)
                .map(legend_name)
                .unwrap_or_default(),
            color: attractor_color(t.id as i32),
            timeseries: t.timeseries.clone(),
            poincare: t.poincare.clone(),
        })
        .collect()
}

/// Writes labels.npy, attractors.json, basin.png and attractors.png; returns one line
/// on the rub of each attractor (its regime and loads) for the summary.
fn write_basin(dir: &Path, o: &BasinOutcome, plot_it: bool) -> Result<String> {
    let (spec, res) = (&o.spec, &o.result);
    output::ensure_dir(dir)?;
    let (nx, ny) = (spec.x.n, spec.y.n);
    output::write_npy(&dir.join("labels.npy"), &[ny, nx], &res.labels)?;
    if let Some(l1) = &res.lambda1 {
        output::write_npy(&dir.join("lambda1.npy"), &[ny, nx], l1)?;
    }
    let xs: Vec<f64> = (0..nx).map(|i| spec.x.value(i)).collect();
    let ys: Vec<f64> = (0..ny).map(|i| spec.y.value(i)).collect();
    output::write_npy(&dir.join("x.npy"), &[nx], &xs)?;
    output::write_npy(&dir.join("y.npy"), &[ny], &ys)?;
    let cat = &res.catalogue;
    if plot_it {
        plot_basin(dir, o)?;
    }
    let with_rub = o.attractors();
    let rub_line = with_rub
        .iter()
        .map(|a| match &a.rub {
            RubEntry::Figures(r) => format!(
                "#{} {} (contact {:.1} % of the time, peak normal force {:.0} N)",
                a.attractor.id,
                r.regime.label(),
                100.0 * r.contact_fraction,
                r.peak_force_n
            ),
            RubEntry::Diverged { regime } => format!("#{} {regime}", a.attractor.id),
        })
        .collect::<Vec<_>>()
        .join(", ");
    let fixed: std::collections::BTreeMap<&str, f64> = COORD_NAMES
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != spec.x.coord && *i != spec.y.coord)
        .map(|(i, &n)| (n, spec.base[i]))
        .collect();
    let json = Documented::new(
        AttractorsFile {
            omega: spec.omega,
            x: spec.x,
            y: spec.y,
            fixed,
            transient: spec.transient,
            periods: spec.periods,
            steps_per_period: spec.lane.stepper.steps_per_period,
            lyapunov: spec.lane.lyapunov,
            cells: nx * ny,
            diverged: cat.diverged,
            diverged_fraction: cat.diverged_fraction,
            attractors: with_rub,
            catalogue_config: &cat.config,
            params: &spec.lane.params,
        },
        BASIN_FILES,
    );
    output::write_json(&dir.join("attractors.json"), &json)?;
    Ok(rub_line)
}

/// The files of a basin's directory and what each holds (attractors.json's `files`).
const BASIN_FILES: &[(&str, &str)] = &[
    (
        "labels.npy",
        "int32 [ny, nx]: attractor id per start state (row iy has y = y.npy[iy], column ix has x = x.npy[ix]); -1 diverged; -2 (with --refine) an attractor the coarse grid did not find",
    ),
    (
        "refined.npy",
        "uint8 [ny, nx] (with --refine): 1 where the label was integrated, 0 where it was filled from the parent point; labels.npy is at the finest resolution",
    ),
    ("x.npy", "f64 [nx], the x-axis start values"),
    ("y.npy", "f64 [ny], the y-axis start values"),
    (
        "lambda1.npy",
        "f64 [ny, nx]: largest Lyapunov exponent per start state over the recorded periods [1/s], NaN diverged (only with --lyapunov)",
    ),
    (
        "attractors.json",
        "this file: the catalogue (id, class, period, basin fraction, mean lambda_1 and its range over the attractor's cells with --lyapunov, representative Poincare points in state order, rub figures and regime on the attractor: docs/rub.md)",
    ),
    (
        "basin.png",
        "the labels as a picture, legend by class and period",
    ),
    (
        "basin_lambda1.png",
        "lambda1.npy as a picture (blue negative, white 0, red positive; only with --lyapunov)",
    ),
    (
        "attractors.png",
        "phase portraits of the attractors, overlaid",
    ),
    (
        "run.json",
        "the run: state (running or complete), command, specification, backend and wall time",
    ),
];

/// Draws basin.png, basin_lambda1.png (with lambda_1) and attractors.png (with traces).
fn plot_basin(dir: &Path, o: &BasinOutcome) -> Result<()> {
    let (spec, res) = (&o.spec, &o.result);
    let (nx, ny) = (spec.x.n, spec.y.n);
    let cat = &res.catalogue;
    let legend: Vec<(i32, String)> = cat
        .attractors
        .iter()
        .map(|a| (a.id as i32, legend_name(a)))
        .chain((cat.diverged > 0).then(|| {
            (
                -1,
                format!("diverged, {:.1} %", 100.0 * cat.diverged_fraction),
            )
        }))
        .collect();
    let grid = map_grid(spec);
    let title = format!(
        "Basin of attraction at W = {} rad/s ({} x {} start states, {} attractor{})",
        spec.omega,
        nx,
        ny,
        cat.attractors.len(),
        if cat.attractors.len() == 1 { "" } else { "s" }
    );
    basin_map(&dir.join("basin.png"), &title, &res.labels, &grid, &legend)?;
    if let Some(l1) = &res.lambda1 {
        lambda1_map(
            &dir.join("basin_lambda1.png"),
            &format!(
                "Largest Lyapunov exponent per start state at W = {} rad/s ({} x {})",
                spec.omega, nx, ny
            ),
            l1,
            &grid,
        )?;
    }
    if !o.traces.is_empty() {
        let traces = plot_traces(&o.traces, &cat.attractors);
        coexisting_attractors(
            &dir.join("attractors.png"),
            &format!(
                "Coexisting attractors at W = {} rad/s (lines: one pass over the attractor; dots: Poincare points)",
                spec.omega
            ),
            &traces,
        )?;
    }
    Ok(())
}

/// `attractors.json`: the grid, the settings, and the catalogue with each attractor's
/// rub figures (the command line adds the files and the version).
#[derive(Serialize)]
struct AttractorsFile<'a> {
    omega: f64,
    x: jeffcott_analysis::basin::Axis,
    y: jeffcott_analysis::basin::Axis,
    /// The start coordinates the grid does not vary, by name.
    fixed: std::collections::BTreeMap<&'static str, f64>,
    transient: u32,
    periods: u32,
    steps_per_period: u32,
    lyapunov: bool,
    cells: usize,
    diverged: u64,
    diverged_fraction: f64,
    attractors: Vec<jeffcott_analysis::rub::AttractorWithRub<'a>>,
    catalogue_config: &'a jeffcott_analysis::catalogue::CatalogueConfig,
    params: &'a jeffcott_core::model::Params,
}

fn human_summary(spec: &BasinSpec, res: &BasinResult, dir: &Path) -> String {
    let cat = &res.catalogue;
    let list: Vec<String> = cat.attractors.iter().map(legend_name).collect();
    format!(
        "W = {} rad/s, {} x {} start states over {} and {}: {} attractor(s) [{}], {:.1} % diverged; {:.1} s. Files in {}.",
        spec.omega,
        spec.x.n,
        spec.y.n,
        COORD_NAMES[spec.x.coord],
        COORD_NAMES[spec.y.coord],
        cat.attractors.len(),
        list.join("; "),
        100.0 * cat.diverged_fraction,
        res.seconds,
        dir.display()
    )
}
