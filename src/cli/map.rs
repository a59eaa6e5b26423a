//! `jeffcott map`: a two-parameter map (design chart) over any two of the speed, the
//! model parameters and the start coordinates, run in work units committed to --out
//! (resumable, shardable): period.npy, lambda1.npy, attractors.npy, contact.npy,
//! peak_force.npy, map.json and three pictures.

use super::study::{self};
use crate::plot::{MapGrid, basin_map, category_map, lambda1_map};
use clap::Args;
use jeffcott_analysis::defaults;
use jeffcott_analysis::map::{MapAxis, MapResult, MapSpec, MapVar, code};
use jeffcott_analysis::output;
use jeffcott_core::error::Result;
use std::path::Path;

/// Arguments of `jeffcott map`.
#[derive(Args, Debug)]
pub struct MapArgs {
    /// Horizontal axis, NAME:lo:hi:n: `omega`, a model parameter (omega_r, ..., phi0,
    /// omega_rx, ..., alpha_c: docs/parameters.md) or a start coordinate
    /// (x_r, vx_r, ...), n values from lo to hi inclusive, e.g. omega:130:141:200.
    #[arg(long, value_name = "NAME:lo:hi:n", allow_hyphen_values = true)]
    pub x: String,
    /// Vertical axis, NAME:lo:hi:n, e.g. e:0.0001:0.002:100.
    #[arg(long, value_name = "NAME:lo:hi:n", allow_hyphen_values = true)]
    pub y: String,
    /// Space the x values geometrically (lo > 0).
    #[arg(long)]
    pub log_x: bool,
    /// Space the y values geometrically (lo > 0).
    #[arg(long)]
    pub log_y: bool,
    /// Rotor speed W of every cell when neither axis is omega [rad/s].
    #[arg(long, value_name = "W")]
    pub omega: Option<f64>,
    /// Start states per cell: the static equilibrium of the cell's parameters plus K - 1
    /// seeded ones (rotor positions within the gap, velocities within W delta of the
    /// cell's W, drawn as the brute-force bifurcation draws them; the same draws in every
    /// cell). K = 1 is the
    /// classical diagram from the static equilibrium.
    #[arg(long, default_value_t = defaults::map::ICS, value_name = "K")]
    pub ics: u32,
    /// Seed of the start states.
    #[arg(long, default_value_t = defaults::map::SEED)]
    pub seed: u64,
    /// Forcing periods integrated and discarded.
    #[arg(long, default_value_t = defaults::map::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded per lane (at least 2 n to see period n).
    #[arg(long, default_value_t = defaults::map::PERIODS, value_name = "P")]
    pub periods: u32,
    /// Skip lambda_1 (then lambda1.npy is NaN and aperiodic cells are not told apart as
    /// quasiperiodic or chaotic); lambda_1 costs about 1.8x the run time on the CPU.
    #[arg(long)]
    pub no_lyapunov: bool,
    /// Cells per work unit [default: at most 1/20 of the map and about 25 s of CPU work].
    #[arg(long, value_name = "CELLS")]
    pub chunk: Option<usize>,
    #[command(flatten)]
    pub study: super::StudyArgs,
    /// Skip the pictures.
    #[arg(long)]
    pub no_plot: bool,
}

impl MapArgs {
    /// The map these arguments describe, validated.
    pub fn spec(&self) -> Result<MapSpec> {
        let lane = self.study.settings(!self.no_lyapunov)?;
        let x = MapAxis::parse("x", &self.x, self.log_x)?;
        let y = MapAxis::parse("y", &self.y, self.log_y)?;
        let overridden = self.study.run.model.overridden()?;
        x.var.check_not_overridden("x", "param", &overridden)?;
        y.var.check_not_overridden("y", "param", &overridden)?;
        jeffcott_analysis::map::check_size(&x, &y, self.ics)?;
        let spec = MapSpec {
            lane,
            omega: self.omega,
            x,
            y,
            ics: self.ics,
            seed: self.seed,
            transient: self.transient,
            periods: self.periods,
            cells_per_unit: self.chunk,
        };
        spec.validate()?;
        Ok(spec)
    }
}

/// Final files of a map (run.json aside).
pub const OUTPUTS: &[&str] = &[
    "period.npy",
    "class.npy",
    "lambda1.npy",
    "attractors.npy",
    "contact.npy",
    "peak_force.npy",
    "regime.npy",
    "x.npy",
    "y.npy",
    "map.json",
    "map_period.png",
    "map_lambda1.png",
    "map_multistability.png",
    "map_regime.png",
];

study::plot_study! {
    Map, "map", MapArgs => run_map,
    jeffcott_analysis::map::run, MapSpec, MapResult,
    write: write_map, summary: human_summary
}

/// Axis label with unit, and the plotted range (log10 of the values on a log axis).
fn axis_label(axis: &MapAxis) -> (String, (f64, f64)) {
    let name = format!("{} [{}]", axis.var.name(), axis.var.unit());
    let hi = if axis.n > 1 {
        axis.hi
    } else {
        axis.lo * 1.0001 + 1e-12
    };
    if axis.log {
        (format!("log10 {name}"), (axis.lo.log10(), hi.log10()))
    } else {
        (name, (axis.lo, hi))
    }
}

pub use jeffcott_analysis::map::class_name;

/// Periods drawn in colours of their own on the isoperiodic map; longer ones share one.
const OWN_COLOUR_PERIODS: i32 = 8;

/// Colour of a class code on the isoperiodic map: periods 1..=8 the palette's first
/// eight colours, longer periods one light grey, quasiperiodic cyan, chaotic dark
/// magenta, undecided aperiodic mid grey, unclassified white, diverged black.
fn class_colour(c: i32) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match c {
        n if (1..=OWN_COLOUR_PERIODS).contains(&n) => crate::plot::PALETTE[(n - 1) as usize],
        n if n > OWN_COLOUR_PERIODS => RGBColor(200, 200, 200),
        code::QUASIPERIODIC => crate::plot::PALETTE[8],
        code::CHAOTIC => RGBColor(110, 20, 80),
        code::APERIODIC => crate::plot::PALETTE[9],
        code::UNCLASSIFIED => RGBColor(255, 255, 255),
        _ => RGBColor(0, 0, 0),
    }
}

/// The isoperiodic map's legend: the classes present, periods in order (those beyond
/// [`OWN_COLOUR_PERIODS`] as one entry), then quasiperiodic, chaotic, aperiodic,
/// unclassified, diverged.
fn class_legend(classes: &[i32]) -> Vec<(i32, String)> {
    let has = |c: i32| classes.contains(&c);
    let mut legend: Vec<(i32, String)> = (1..=OWN_COLOUR_PERIODS)
        .filter(|&n| has(n))
        .map(|n| (n, class_name(n)))
        .collect();
    if let Some(top) = classes
        .iter()
        .copied()
        .filter(|&n| n > OWN_COLOUR_PERIODS)
        .max()
    {
        let low = OWN_COLOUR_PERIODS + 1;
        legend.push((low, format!("period {low}..{top}")));
    }
    for c in [
        code::QUASIPERIODIC,
        code::CHAOTIC,
        code::APERIODIC,
        code::UNCLASSIFIED,
        code::DIVERGED,
    ] {
        if has(c) {
            legend.push((c, class_name(c)));
        }
    }
    legend
}

/// Colour of a rub regime code on the regime map.
pub fn regime_colour(c: i32) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match c {
        0 => RGBColor(200, 220, 240),
        1 => RGBColor(255, 170, 60),
        2 => RGBColor(200, 30, 30),
        3 => RGBColor(110, 40, 160),
        _ => RGBColor(0, 0, 0),
    }
}

/// Legend of the regime codes present.
pub fn regime_legend(codes: &[i32]) -> Vec<(i32, String)> {
    use jeffcott_analysis::rub::RubRegime::*;
    [
        NoContact,
        PartialRub,
        FullAnnularRub,
        BackwardWhirl,
        Diverged,
    ]
    .iter()
    .filter(|r| codes.contains(&r.code()))
    .map(|r| (r.code(), r.label().replace('_', " ")))
    .collect()
}

/// Writes the arrays, map.json and the pictures.
pub fn write_map(dir: &Path, spec: &MapSpec, res: &MapResult, plot_it: bool) -> Result<()> {
    output::ensure_dir(dir)?;
    let (nx, ny) = (spec.x.n, spec.y.n);
    output::write_npy(&dir.join("period.npy"), &[ny, nx], &res.period)?;
    output::write_npy(&dir.join("class.npy"), &[ny, nx], &res.class)?;
    output::write_npy(&dir.join("lambda1.npy"), &[ny, nx], &res.lambda1)?;
    output::write_npy(&dir.join("attractors.npy"), &[ny, nx], &res.attractors)?;
    output::write_npy(&dir.join("contact.npy"), &[ny, nx], &res.contact)?;
    output::write_npy(&dir.join("peak_force.npy"), &[ny, nx], &res.peak_force)?;
    output::write_npy(&dir.join("regime.npy"), &[ny, nx], &res.regime)?;
    output::write_npy(&dir.join("x.npy"), &[nx], &spec.x.values())?;
    output::write_npy(&dir.join("y.npy"), &[ny], &spec.y.values())?;
    if plot_it {
        plot_map(dir, spec, res)?;
    }
    let json = super::files::Documented::new(jeffcott_analysis::map::summary(spec, res), MAP_FILES);
    output::write_json(&dir.join("map.json"), &json)
}

/// The files of a map's directory and what each holds (map.json's `files`).
const MAP_FILES: &[(&str, &str)] = &[
    (
        "period.npy",
        "int32 [ny, nx]: period of the attractor reached from the static equilibrium; 0 aperiodic (quasiperiodic, chaotic or undecided), -1 diverged",
    ),
    (
        "class.npy",
        "int32 [ny, nx]: its class code: n > 0 period-n, 0 aperiodic, -1 diverged, -2 quasiperiodic, -3 chaotic, -4 unclassified",
    ),
    (
        "lambda1.npy",
        "f64 [ny, nx]: its mean largest Lyapunov exponent [1/s] (NaN when diverged or with --no-lyapunov)",
    ),
    (
        "attractors.npy",
        "int32 [ny, nx]: number of coexisting attractors found from the cell's start states",
    ),
    (
        "contact.npy",
        "f64 [ny, nx]: fraction of time in contact on the attractor from the static equilibrium (NaN when diverged)",
    ),
    (
        "peak_force.npy",
        "f64 [ny, nx]: peak normal contact force on it [N] (NaN when diverged)",
    ),
    (
        "regime.npy",
        "int32 [ny, nx]: its rub regime: 0 no_contact, 1 partial_rub, 2 full_annular_rub, 3 backward_whirl, -1 diverged (docs/rub.md)",
    ),
    ("map_regime.png", "regime.npy as a picture"),
    ("x.npy", "f64 [nx]: the x-axis values"),
    ("y.npy", "f64 [ny]: the y-axis values"),
    (
        "map.json",
        "this file; cell_attractors lists every cell's attractors (class, period, start states reaching it, lambda_1, rub figures: contact fraction, impacts per revolution, peak and mean normal force [N], peak penetration [m])",
    ),
    (
        "map_period.png",
        "isoperiodic map: class of the response from the static equilibrium",
    ),
    (
        "map_lambda1.png",
        "lambda1.npy (blue negative, white 0, red positive)",
    ),
    ("map_multistability.png", "attractors.npy"),
    (
        "run.json",
        "the run: state, command, specification, backend and wall time",
    ),
];

/// Draws the map's pictures: the response and rub regime maps, lambda_1 where it was
/// computed, and the number of coexisting attractors.
fn plot_map(dir: &Path, spec: &MapSpec, res: &MapResult) -> Result<()> {
    let (nx, ny) = (spec.x.n, spec.y.n);
    let (lx, x_range) = axis_label(&spec.x);
    let (ly, y_range) = axis_label(&spec.y);
    let grid = MapGrid {
        cells: (nx, ny),
        x_range,
        y_range,
        axes: (lx, ly),
    };
    let what = format!("{} x {} cells, {} start state(s) each", nx, ny, spec.ics);
    // A category map: file, quantity, codes, legend, colour of a code.
    type Category<'a> = (
        &'a str,
        &'a str,
        &'a [i32],
        Vec<(i32, String)>,
        fn(i32) -> plotters::style::RGBColor,
    );
    let categories: [Category; 2] = [
        (
            "map_period.png",
            "Response",
            &res.class,
            class_legend(&res.class),
            class_colour,
        ),
        (
            "map_regime.png",
            "Rub regime",
            &res.regime,
            regime_legend(&res.regime),
            regime_colour,
        ),
    ];
    for (file, quantity, codes, legend, colour) in categories {
        category_map(
            &dir.join(file),
            &format!("{quantity} from the static equilibrium ({what})"),
            codes,
            &grid,
            &legend,
            &colour,
        )?;
    }
    if spec.lane.lyapunov {
        lambda1_map(
            &dir.join("map_lambda1.png"),
            &format!("Largest Lyapunov exponent from the static equilibrium ({what})"),
            &res.lambda1,
            &grid,
        )?;
    }
    let most = res.attractors.iter().copied().max().unwrap_or(0).max(1);
    let counts: Vec<i32> = res.attractors.iter().map(|&n| n - 1).collect();
    let legend: Vec<(i32, String)> = (1..=most)
        .filter(|n| res.attractors.contains(n))
        .map(|n| {
            (
                n - 1,
                format!("{n} attractor{}", if n == 1 { "" } else { "s" }),
            )
        })
        .chain(
            res.attractors
                .contains(&0)
                .then(|| (-1, "none (all diverged)".to_string())),
        )
        .collect();
    basin_map(
        &dir.join("map_multistability.png"),
        &format!("Coexisting attractors ({what})"),
        &counts,
        &grid,
        &legend,
    )?;
    Ok(())
}

fn human_summary(spec: &MapSpec, res: &MapResult, dir: &Path) -> String {
    let mut tally: std::collections::BTreeMap<i32, usize> = Default::default();
    for &c in &res.class {
        *tally.entry(c).or_default() += 1;
    }
    let classes: Vec<String> = tally
        .iter()
        .map(|(&c, &n)| format!("{} {}", class_name(c), n))
        .collect();
    let var = |v: MapVar| v.name();
    format!(
        "Map over {} ({} values) and {} ({} values), {} start state(s) per cell: from the static equilibrium {}; {} cell(s) rub, {} multistable (at most {} attractors); {:.1} s. Files in {}.",
        var(spec.x.var),
        spec.x.n,
        var(spec.y.var),
        spec.y.n,
        spec.ics,
        classes.join(", "),
        res.contact.iter().filter(|&&c| c > 0.0).count(),
        res.attractors.iter().filter(|&&n| n > 1).count(),
        res.attractors.iter().copied().max().unwrap_or(0),
        res.seconds,
        dir.display()
    )
}
