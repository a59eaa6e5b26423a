//! `jeffcott bifurcation`: quasistatic sweeps up and down in W and a brute-force ensemble
//! per W, with attractor catalogues, arrays, `summary.json` and `bifurcation.png`.

use super::rundir::{self, CommandHost, Execution};
use super::study::{self, StudyCommand};
use crate::plot::{DotSeries, Lambda1Series, bifurcation_diagram};
use clap::Args;
use jeffcott_analysis::bifurcation::portrait::{Portrait, PortraitSource, portrait};
use jeffcott_analysis::bifurcation::{BifurcationResult, BifurcationSpec, Sweep, SweepPoint};
use jeffcott_analysis::catalogue::CatalogueConfig;
use jeffcott_analysis::classify::{Class, ClassifyConfig};
use jeffcott_analysis::defaults;
use jeffcott_analysis::output;
use jeffcott_analysis::run::RunDir;
use jeffcott_core::ensemble::Precision;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{COORD_NAMES, STATE_DIM, State, coord_index};
use plotters::style::RGBColor;

/// Attractor classification tolerances shared by the analysis commands.
#[derive(Args, Debug, Clone)]
pub struct CatalogueArgs {
    /// Largest period the classifier looks for.
    #[arg(long, default_value_t = ClassifyConfig::DEFAULT.n_max)]
    pub n_max: usize,
    /// Repeat tolerance relative to the Poincare set's diameter (velocities count as
    /// v / W, so everything is in metres).
    #[arg(long, default_value_t = ClassifyConfig::DEFAULT.rel_tol)]
    pub rel_tol: f64,
    /// Repeat tolerance floor [m] [default: 1e-7 for f64 lanes, 1e-6 for f32 lanes].
    #[arg(long)]
    pub abs_tol: Option<f64>,
    /// Two cycles are one attractor when they match within this fraction of their size.
    #[arg(long, default_value_t = CatalogueConfig::DEFAULT.match_rel)]
    pub match_rel: f64,
    /// Floor of the cycle match tolerance [m] [default: 1e-6 for f64 lanes, 1e-5 for f32].
    #[arg(long)]
    pub match_abs: Option<f64>,
}

impl CatalogueArgs {
    /// The validated configuration for lanes of `precision`.
    pub fn config(&self, precision: Precision) -> Result<CatalogueConfig> {
        let d = CatalogueConfig::for_precision(precision);
        let c = CatalogueConfig {
            classify: ClassifyConfig {
                n_max: self.n_max,
                rel_tol: self.rel_tol,
                abs_tol: self.abs_tol.unwrap_or(d.classify.abs_tol),
            },
            match_rel: self.match_rel,
            match_abs: self.match_abs.unwrap_or(d.match_abs),
            ..d
        };
        c.validate()?;
        Ok(c)
    }
}

/// The `--sweep` values: the library's [`Sweep`] kinds, or none.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SweepArg {
    /// W increasing.
    Up,
    /// W decreasing.
    Down,
    /// Both (concurrently).
    Both,
    /// No quasistatic sweep (brute force only).
    None,
}

impl SweepArg {
    /// The sweeps to run (`None`: none).
    pub fn sweep(self) -> Option<Sweep> {
        match self {
            SweepArg::Up => Some(Sweep::Up),
            SweepArg::Down => Some(Sweep::Down),
            SweepArg::Both => Some(Sweep::Both),
            SweepArg::None => None,
        }
    }
}

/// Arguments of `jeffcott bifurcation`.
#[derive(Args, Debug)]
pub struct BifurcationArgs {
    /// Rotor speeds `a:b:n` (n speeds from a to b inclusive) [rad/s].
    #[arg(long, value_name = "a:b:n")]
    pub omega: String,
    /// Poincare coordinates to draw, one panel each (x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s,
    /// vy_s).
    #[arg(long, value_name = "NAME,...", default_value = "vx_s")]
    pub coord: String,
    /// Quasistatic sweeps: up, down or both (run concurrently), or none (brute force
    /// only; needs --ics >= 1).
    #[arg(long, value_enum, default_value_t = SweepArg::Both)]
    pub sweep: SweepArg,
    /// Skip the quasistatic sweeps (brute force only), the same as --sweep none.
    #[arg(long)]
    pub no_sweep: bool,
    /// Brute-force start states per W (the static equilibrium and a seeded random set);
    /// 0 disables brute force.
    #[arg(long, default_value_t = defaults::bifurcation::ICS, value_name = "K")]
    pub ics: u32,
    /// Seed of the random start states.
    #[arg(long, default_value_t = defaults::bifurcation::SEED)]
    pub seed: u64,
    /// Transient per W of the quasistatic sweeps [forcing periods].
    #[arg(long, default_value_t = defaults::bifurcation::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Transient at the first W of each sweep, from the static equilibrium.
    #[arg(long, default_value_t = defaults::bifurcation::TRANSIENT_FIRST, value_name = "Q")]
    pub transient_first: u32,
    /// Transient of the brute-force lanes.
    #[arg(long, default_value_t = defaults::bifurcation::BRUTE_TRANSIENT, value_name = "Q")]
    pub brute_transient: u32,
    /// Recorded periods (Poincare points) per lane.
    #[arg(long, default_value_t = defaults::bifurcation::PERIODS, value_name = "P")]
    pub periods: u32,
    /// Neighbour seeds per W in the brute force's second pass, at most.
    #[arg(long, default_value_t = defaults::bifurcation::MAX_SEEDS)]
    pub max_seeds: usize,
    #[command(flatten)]
    pub study: super::StudyArgs,
    /// Speeds at which to draw phase portraits of the attractors found there (the nearest
    /// speed of the grid), e.g. `--portraits 133,135`: `attractors_W.png`, coexisting
    /// attractors overlaid (from the brute force, or the sweeps with --ics 0).
    #[arg(long, value_name = "W,...", value_delimiter = ',')]
    pub portraits: Vec<f64>,
    /// Skip the largest Lyapunov exponent per lane (by default every sweep point and
    /// brute-force lane carries one tangent vector: lambda_1 in bifurcation_lambda1.npy,
    /// summary.json and a panel under the diagram, and aperiodic split into quasiperiodic
    /// and chaotic). It adds ~5 % to the sweeps and ~3x to a CPU brute force, whose
    /// lambda_1 lanes are not SIMD-batched (docs/analysis.md).
    #[arg(long)]
    pub no_lyapunov: bool,
    /// Skip bifurcation.png.
    #[arg(long)]
    pub no_plot: bool,
}

/// Parses a comma-separated list of coordinate names.
pub fn parse_coords(option: &str, text: &str) -> Result<Vec<usize>> {
    let v: Vec<usize> = text
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|n| {
            coord_index(n).ok_or_else(|| {
                Error::invalid(
                    option,
                    n,
                    format!(
                        "unknown coordinate; valid names: {}",
                        COORD_NAMES.join(", ")
                    ),
                )
            })
        })
        .collect::<Result<_>>()?;
    if v.is_empty() {
        return Err(Error::invalid(option, text, "name at least one coordinate"));
    }
    if let Some((_, c)) = v.iter().enumerate().find(|(i, c)| v[..*i].contains(c)) {
        return Err(Error::invalid(
            option,
            text,
            format!(
                "`{}` is named twice; name each coordinate once",
                COORD_NAMES[*c]
            ),
        ));
    }
    Ok(v)
}

impl BifurcationArgs {
    /// The study these arguments describe.
    pub fn spec(&self) -> Result<BifurcationSpec> {
        let range = jeffcott_core::ensemble::RangeSpec::parse("omega", &self.omega)?;
        let sweep = if self.no_sweep {
            None
        } else {
            self.sweep.sweep()
        };
        // Every count is checked before the speeds and lanes are allocated.
        jeffcott_core::limits::check_periods("transient-first", self.transient_first, 0)?;
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        jeffcott_core::limits::check_periods("brute-transient", self.brute_transient, 0)?;
        jeffcott_core::limits::check_periods("periods", self.periods, 2)?;
        let sweeps = match sweep {
            None => 0,
            Some(Sweep::Both) => 2,
            Some(_) => 1,
        };
        BifurcationSpec::check_size(
            &self.omega,
            range.len(),
            sweeps,
            self.ics,
            self.max_seeds,
            self.periods,
        )?;
        let omegas = range.values();
        let spec = BifurcationSpec {
            lane: self.study.settings(!self.no_lyapunov)?,
            omegas,
            sweep,
            transient_first: self.transient_first,
            transient: self.transient,
            ics: self.ics,
            brute_transient: self.brute_transient,
            periods: self.periods,
            seed: self.seed,
            max_seeds: self.max_seeds,
        };
        spec.validate()?;
        Ok(spec)
    }
}

/// Runs `jeffcott bifurcation`.
pub fn run_bifurcation(a: &BifurcationArgs) -> Result<()> {
    let spec = a.spec()?;
    for &w in &a.portraits {
        check_portrait_speed(&spec.omegas, w)?;
    }
    let exec = a
        .study
        .exec
        .execution(Bifurcation::COMMAND, a.study.run.backend)?;
    if exec.shard.is_some() && spec.ics == 0 {
        return Err(Error::invalid(
            "shard",
            a.study.exec.shard.as_deref().unwrap_or_default(),
            "only the brute force is sharded: give --ics >= 1",
        ));
    }
    let write = BifurcationWrite {
        coords: parse_coords("coord", &a.coord)?,
        portraits: a.portraits.clone(),
        plot: !a.no_plot,
    };
    study::execute::<Bifurcation>(&spec, &write, &exec)
}

/// What `jeffcott bifurcation` writes besides the study's result.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct BifurcationWrite {
    /// `--coord`: the coordinates drawn, by index (recorded as numbers).
    pub coords: Vec<usize>,
    /// `--portraits`: the speeds whose phase portraits are drawn.
    pub portraits: Vec<f64>,
    /// Draw the diagram.
    pub plot: bool,
}

/// `jeffcott bifurcation` as a study command.
pub struct Bifurcation;

impl StudyCommand for Bifurcation {
    const COMMAND: &'static str = "bifurcation";
    const OUTPUTS: &'static [&'static str] = OUTPUTS;
    type Spec = BifurcationSpec;
    type Write = BifurcationWrite;
    type Outcome = BifurcationResult;
    fn run(
        spec: &BifurcationSpec,
        _: &BifurcationWrite,
        host: &CommandHost,
    ) -> Result<BifurcationResult> {
        jeffcott_analysis::bifurcation::run(spec, host)
    }
    fn finish(
        spec: &BifurcationSpec,
        w: &BifurcationWrite,
        res: BifurcationResult,
        run_dir: &RunDir,
        exec: &Execution,
    ) -> Result<()> {
        let portraits = w
            .portraits
            .iter()
            .map(|&speed| portrait(spec, &res, speed))
            .collect::<Result<Vec<_>>>()?;
        write_bifurcation(&exec.out, spec, &res, &w.coords, w.plot)?;
        let mut outputs = rundir::written(run_dir, OUTPUTS);
        for p in &portraits {
            if let Some(f) = write_portrait(&exec.out, &res, p)? {
                outputs.push(f);
            }
        }
        run_dir.finish(&RunResult::of(&res), &outputs)?;
        if !exec.run.quiet {
            println!("{}", human_summary(spec, &res, &exec.out));
        }
        Ok(())
    }
}

/// Final files of a bifurcation study (run.json and the portraits aside).
pub const OUTPUTS: &[&str] = &[
    "omega.npy",
    "bifurcation.npy",
    "bifurcation_rows.npy",
    "bifurcation_lambda1.npy",
    "bifurcation.png",
    "summary.json",
];

/// What run.json records of a finished study besides its specification.
#[derive(serde::Serialize)]
struct RunResult<'a> {
    brute_force_backend: Option<&'a jeffcott_core::ensemble::RunInfo>,
    sweep_wall_time_s: f64,
    brute_force_wall_time_s: f64,
    /// Brute-force lanes recorded early and periods integrated (with early exit).
    #[serde(skip_serializing_if = "Option::is_none")]
    brute_force_early_exit: Option<jeffcott_analysis::early::EarlySaved>,
}

impl<'a> RunResult<'a> {
    fn of(res: &'a BifurcationResult) -> Self {
        RunResult {
            brute_force_backend: res.brute_info.as_ref(),
            sweep_wall_time_s: res.sweep_seconds,
            brute_force_wall_time_s: res.brute_seconds,
            brute_force_early_exit: res.brute_early_exit,
        }
    }
}

/// Refuses a `--portraits` speed outside the `--omega` range (up to half a grid step
/// beyond either end, which still has a nearest grid speed on its side): the portrait
/// would be drawn at an end of the range, not at the speed asked for.
pub fn check_portrait_speed(omegas: &[f64], w: f64) -> Result<()> {
    let (Some(&lo), Some(&hi)) = (omegas.first(), omegas.last()) else {
        return Ok(());
    };
    let half_step = if omegas.len() > 1 {
        0.5 * (hi - lo) / (omegas.len() - 1) as f64
    } else {
        0.0
    };
    let slack = half_step + 1e-9 * hi.abs();
    if w.is_finite() && w >= lo - slack && w <= hi + slack {
        Ok(())
    } else {
        Err(Error::invalid(
            "portraits",
            jeffcott_core::model::short_number(w),
            format!("must be a speed within the --omega range {lo}..={hi} rad/s"),
        ))
    }
}

/// Draws a portrait computed by [`portrait`] (`attractors_W.png`): the brute force's
/// attractors with their legend, or the sweeps' final cycles; returns the file's name
/// when there was anything to draw. Computes nothing.
pub fn write_portrait(
    dir: &std::path::Path,
    res: &BifurcationResult,
    p: &Portrait,
) -> Result<Option<String>> {
    let traces = match p.source {
        PortraitSource::Brute => {
            super::basin::plot_traces(&p.traces, &res.brute[p.index].catalogue.attractors)
        }
        PortraitSource::Sweeps => p
            .traces
            .iter()
            .map(|t| {
                let (name, sweep) = if t.id == 0 {
                    ("up sweep", &res.up)
                } else {
                    ("down sweep", &res.down)
                };
                crate::plot::AttractorTrace {
                    name: format!("{name}: {}", sweep[p.index].class.class.label()),
                    color: crate::plot::attractor_color(t.id as i32),
                    timeseries: t.timeseries.clone(),
                    poincare: t.poincare.clone(),
                }
            })
            .collect(),
    };
    if traces.is_empty() {
        return Ok(None);
    }
    output::ensure_dir(dir)?;
    let omega = p.omega;
    let name = format!("attractors_{omega:.4}.png");
    crate::plot::coexisting_attractors(
        &dir.join(&name),
        &format!("Attractors at W = {omega:.4} rad/s (lines: one pass; dots: Poincare points)"),
        &traces,
    )
    .map(|()| Some(name))
}

/// The lambda_1 series under a diagram: brute-force lanes (grey pixels), up sweep (blue
/// line), down sweep (red line), each included when asked for and computed.
pub fn lambda1_series(
    spec: &BifurcationSpec,
    res: &BifurcationResult,
    up: bool,
    down: bool,
    brute: bool,
) -> Vec<Lambda1Series> {
    let mut out = Vec::new();
    if !spec.lane.lyapunov {
        return out;
    }
    let (r_up, r_down) = if spec.omegas.len() > 600 {
        (1, 0)
    } else {
        (2, 1)
    };
    if brute && !res.brute.is_empty() {
        let points: Vec<(f64, f64)> = res
            .brute
            .iter()
            .flat_map(|b| b.lambda1.iter().flatten().map(move |&l| (b.omega, l)))
            .collect();
        out.push(Lambda1Series {
            label: "lambda_1, brute-force lanes".into(),
            color: RGBColor(110, 110, 110),
            radius: 0,
            line: false,
            points,
        });
    }
    for (on, sw, label, color, radius) in [
        (
            up,
            &res.up,
            "lambda_1, W increasing",
            RGBColor(31, 90, 200),
            r_up,
        ),
        (
            down,
            &res.down,
            "lambda_1, W decreasing",
            RGBColor(220, 40, 30),
            r_down,
        ),
    ] {
        if on && !sw.is_empty() {
            out.push(Lambda1Series {
                label: label.into(),
                color,
                radius,
                line: true,
                points: sw.iter().map(|p| (p.omega, p.lambda1)).collect(),
            });
        }
    }
    out
}

/// The dot series of a diagram: brute force (grey pixels), up sweep (blue), down sweep
/// (red), each included when asked for and present.
pub fn diagram_series(
    spec: &BifurcationSpec,
    res: &BifurcationResult,
    up: bool,
    down: bool,
    brute: bool,
) -> Vec<DotSeries> {
    let rec = spec.periods as usize;
    // Dots shrink for dense diagrams so 1000+ speeds stay readable; the down sweep is
    // drawn smaller on top of the up sweep, so both show where they coincide.
    let (r_up, r_down) = if spec.omegas.len() > 600 {
        (1, 0)
    } else {
        (2, 1)
    };
    let mut series = Vec::new();
    let dots = |sw: &[SweepPoint]| -> Vec<(f64, State)> {
        sw.iter()
            .filter(|p| !p.status.is_frozen())
            .flat_map(|p| p.points.iter().map(move |s| (p.omega, *s)))
            .collect()
    };
    if brute && !res.brute.is_empty() {
        let mut v = Vec::new();
        for b in &res.brute {
            for (li, &l) in b.catalogue.labels.iter().enumerate() {
                if l < 0 {
                    continue;
                }
                for s in b.points[li * rec * STATE_DIM..(li + 1) * rec * STATE_DIM]
                    .chunks_exact(STATE_DIM)
                {
                    let mut st = [0.0; STATE_DIM];
                    st.copy_from_slice(s);
                    v.push((b.omega, st));
                }
            }
        }
        series.push(DotSeries {
            label: format!("brute force ({} start states per W)", spec.ics),
            color: RGBColor(110, 110, 110),
            radius: 0,
            points: v,
        });
    }
    let sweeps = [
        (up, "increasing", RGBColor(31, 90, 200), r_up, &res.up),
        (down, "decreasing", RGBColor(220, 40, 30), r_down, &res.down),
    ];
    for (wanted, direction, color, radius, sw) in sweeps {
        if wanted && !sw.is_empty() {
            series.push(DotSeries {
                label: format!("quasistatic sweep, W {direction}"),
                color,
                radius,
                points: dots(sw),
            });
        }
    }
    series
}

/// Writes the arrays, summary.json and the picture.
pub fn write_bifurcation(
    dir: &std::path::Path,
    spec: &BifurcationSpec,
    res: &BifurcationResult,
    coords: &[usize],
    plot_it: bool,
) -> Result<()> {
    output::ensure_dir(dir)?;
    let rec = spec.periods as usize;
    let arrays = jeffcott_analysis::bifurcation::arrays(res);
    let (rows, pts, l1) = (&arrays.rows, &arrays.points, &arrays.lambda1);
    let nrows = rows.len() / 4;
    if spec.lane.lyapunov {
        output::write_npy(&dir.join("bifurcation_lambda1.npy"), &[nrows], l1)?;
    }
    output::write_npy(&dir.join("omega.npy"), &[spec.omegas.len()], &spec.omegas)?;
    output::write_npy(&dir.join("bifurcation.npy"), &[nrows, rec, STATE_DIM], pts)?;
    output::write_npy(&dir.join("bifurcation_rows.npy"), &[nrows, 4], rows)?;
    if plot_it {
        let series = diagram_series(spec, res, true, true, true);
        let w = (spec.omegas[0], spec.omegas[spec.omegas.len() - 1]);
        let title = format!(
            "Bifurcation diagram, W = {:.3}..{:.3} rad/s ({} speeds), Poincare section t = kT",
            w.0,
            w.1,
            spec.omegas.len()
        );
        let l1s = lambda1_series(spec, res, true, true, true);
        bifurcation_diagram(
            &dir.join("bifurcation.png"),
            &title,
            coords,
            w,
            &series,
            &l1s,
        )?;
    }
    let summary = super::files::Documented::new(
        jeffcott_analysis::bifurcation::summary(spec, res)?,
        &[
            ("omega.npy", "f64 [W], the speeds [rad/s]"),
            (
                "bifurcation.npy",
                "f64 [rows, periods, 8], Poincare points of each row's lane, state order x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s (m, m/s)",
            ),
            (
                "bifurcation_rows.npy",
                "f64 [rows, 4]: W [rad/s], sweep (0 quasistatic up, 1 quasistatic down, 2 brute force), lane (index among that W's brute-force lanes: < ics are the common start states, then the neighbour seeds; 0 for sweeps), attractor id in that W's brute-force catalogue (-1: diverged, or not found / no brute force)",
            ),
            (
                "bifurcation_lambda1.npy",
                "f64 [rows], aligned with bifurcation_rows.npy: the largest Lyapunov exponent of each row's lane over its recorded periods [1/s] (NaN: diverged); absent with --no-lyapunov",
            ),
            (
                "bifurcation.png",
                "the diagram: brute force grey, up sweep blue, down sweep red; lambda_1 against W in the panel underneath",
            ),
        ],
    );
    // Written last: its presence marks a complete run.
    output::write_json(&dir.join("summary.json"), &summary)?;
    Ok(())
}

fn human_summary(spec: &BifurcationSpec, res: &BifurcationResult, dir: &std::path::Path) -> String {
    let count =
        |sw: &[SweepPoint], f: &dyn Fn(&SweepPoint) -> bool| sw.iter().filter(|p| f(p)).count();
    let mut s = format!(
        "{} speeds from {} to {} rad/s: sweeps in {:.1} s, brute force in {:.1} s.",
        spec.omegas.len(),
        spec.omegas[0],
        spec.omegas[spec.omegas.len() - 1],
        res.sweep_seconds,
        res.brute_seconds
    );
    for (name, sw) in [("up", &res.up), ("down", &res.down)] {
        if sw.is_empty() {
            continue;
        }
        s += &format!(
            " Sweep {name}: {} period-1, {} other periodic, {} aperiodic ({} quasiperiodic, {} chaotic), {} diverged.",
            count(sw, &|p| p.class.class.period() == Some(1)),
            count(sw, &|p| p.class.class.period().is_some_and(|n| n > 1)),
            count(sw, &|p| p.class.class.period().is_none()
                && !p.status.is_frozen()),
            count(sw, &|p| p.class.class == Class::Quasiperiodic),
            count(sw, &|p| p.class.class == Class::Chaotic),
            count(sw, &|p| p.status.is_frozen()),
        );
    }
    if !res.brute.is_empty() {
        let multi = res
            .brute
            .iter()
            .filter(|b| b.catalogue.attractors.len() > 1)
            .count();
        s += &format!(
            " Brute force: coexisting attractors at {multi} of {} speeds.",
            res.brute.len()
        );
    }
    s + &format!(" Files in {}.", dir.display())
}
