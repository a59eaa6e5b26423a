//! Basins of attraction (docs/model.md 5): a grid over two initial coordinates at one W,
//! every other coordinate fixed, each cell labelled with the id of the attractor its
//! lane settles on (the catalogue of [`crate::catalogue`]), -1 for diverged lanes.
//!
//! The grid is cut into work units of lanes ([`crate::run`]): each unit is run,
//! catalogued on its own (labels plus a partial catalogue) and committed; the assembly
//! absorbs the partial catalogues in unit order. Memory is bounded by the labels
//! (4 bytes per cell) plus one unit's records (about `unit * (recorded * 64 + 400)`
//! bytes; on a GPU, one batch of units, at most 512 MB of records), e.g. 16 MB + a few MB
//! for a 2000 x 2000 grid with 64 recorded periods.
//! With `lyapunov` every lane also gives its largest Lyapunov exponent (the ensembles'
//! lambda_1 variant, either backend): 8 more bytes per cell (32 MB at 2000 x 2000), and
//! aperiodic attractors are told apart as quasiperiodic or chaotic.
//!
//! [`study`] runs a basin with every stage built on it (refinement, re-integration,
//! rub figures, traces, measures): the one way the front ends run a basin.

pub mod study;

use crate::catalogue::{Catalogue, CatalogueBuilder, part_unit, unit_parts};
use crate::run::lanes::{Control, LaneUnits, Split};
use crate::run::{Array, Units};
use crate::settings::LaneSettings;
use jeffcott_core::ensemble::{EnsembleSpec, RunInfo};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{COORD_NAMES, Params, State};
use serde::{Deserialize, Serialize};

/// Splits `NAME:lo:hi:n` into its name, finite bounds and count (the name unchecked);
/// `option` names the CLI option and `example` shows the form in errors.
pub fn parse_named_range<'a>(
    option: &str,
    text: &'a str,
    example: &str,
) -> Result<(&'a str, f64, f64, usize)> {
    let parts: Vec<&str> = text.split(':').map(str::trim).collect();
    let [name, lo, hi, n] = parts.as_slice() else {
        return Err(Error::invalid(
            option,
            text,
            format!("expected NAME:lo:hi:n, e.g. {example}"),
        ));
    };
    let num = |s: &str| finite_number(option, text, s);
    let n: usize = n
        .parse()
        .map_err(|_| Error::invalid(option, text, "the count n must be a positive integer"))?;
    Ok((name, num(lo)?, num(hi)?, n))
}

/// Splits `NAME:lo:hi` into its name and finite bounds (the name unchecked); `option`
/// names the CLI option and `example` shows the form in errors.
pub fn parse_name_bounds<'a>(
    option: &str,
    text: &'a str,
    example: &str,
) -> Result<(&'a str, f64, f64)> {
    let parts: Vec<&str> = text.split(':').map(str::trim).collect();
    let [name, lo, hi] = parts.as_slice() else {
        return Err(Error::invalid(
            option,
            text,
            format!("expected NAME:lo:hi, e.g. {example}"),
        ));
    };
    let num = |s: &str| finite_number(option, text, s);
    Ok((name, num(lo)?, num(hi)?))
}

/// The finite number `s`, a part of option `option`'s text `text` (named in the error).
pub fn finite_number(option: &str, text: &str, s: &str) -> Result<f64> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| Error::invalid(option, text, format!("`{s}` is not a finite number")))
}

/// Checks an axis of `n` values from `lo` to `hi`: n in 1..=[`MAX_CELLS_PER_AXIS`],
/// finite bounds, lo < hi (lo == hi only with n = 1); `option` names it in errors.
pub fn check_axis(option: &str, lo: f64, hi: f64, n: usize) -> Result<()> {
    if !(1..=MAX_CELLS_PER_AXIS).contains(&n) {
        return Err(Error::invalid(
            option,
            n,
            format!("the count n must be in 1..={MAX_CELLS_PER_AXIS}"),
        ));
    }
    if !(lo.is_finite() && hi.is_finite()) || (n > 1 && lo >= hi) {
        return Err(Error::invalid(
            option,
            format!("{lo}..{hi}"),
            "need finite lo < hi (lo == hi only with n = 1)",
        ));
    }
    if n == 1 && lo != hi {
        return Err(Error::invalid(
            option,
            format!("{lo}..{hi} with n = 1"),
            "one value needs lo == hi (NAME:v:v:1); give n >= 2 for a range",
        ));
    }
    Ok(())
}

/// One axis of the grid: a state coordinate from `lo` to `hi` inclusive in `n` values
/// (the files record the coordinate by name).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Axis {
    /// Index of the state coordinate.
    #[serde(with = "crate::record::coord_name")]
    pub coord: usize,
    /// First value.
    pub lo: f64,
    /// Last value.
    pub hi: f64,
    /// Number of values.
    pub n: usize,
}

/// Cells per axis at most.
pub const MAX_CELLS_PER_AXIS: usize = 100_000;

impl Axis {
    /// Parses `name:lo:hi:n`; `option` names the CLI option in errors.
    pub fn parse(option: &str, text: &str) -> Result<Axis> {
        let (name, lo, hi, n) = parse_named_range(option, text, "x_r:-0.006:0.006:200")?;
        let coord = jeffcott_core::inputs::coord(option, name)?;
        let axis = Axis { coord, lo, hi, n };
        axis.validate(option)?;
        Ok(axis)
    }

    /// Checks the axis; `option` names it in errors.
    pub fn validate(&self, option: &str) -> Result<()> {
        check_axis(option, self.lo, self.hi, self.n)
    }

    /// The i-th value ([`jeffcott_core::ensemble::range_value`]).
    pub fn value(&self, i: usize) -> f64 {
        jeffcott_core::ensemble::range_value(self.lo, self.hi, self.n as u64, i as u64)
    }
}

/// The start state of every cell before the axes set their coordinates: the static
/// equilibrium of `params` with `fix` (`--fix`: names and values of other start
/// coordinates) applied. Refuses a fixed axis coordinate, unknown names, non-finite
/// values and start positions (fixed or on an axis) beyond `bound`, the divergence
/// bound; errors name `fix`, `x` or `y`.
pub fn base_state(
    params: &Params,
    x: &Axis,
    y: &Axis,
    fix: &[(String, f64)],
    bound: f64,
) -> Result<State> {
    use jeffcott_core::inputs::{check_coord_within_bound, check_start_within_bound, coord};
    for (name, _) in fix {
        let i = coord("fix", name)?;
        if i == x.coord || i == y.coord {
            return Err(Error::invalid(
                "fix",
                name,
                "is an axis of the grid; fix only the other coordinates",
            ));
        }
    }
    let mut base = params.static_equilibrium();
    jeffcott_core::inputs::set_coords("fix", &mut base, fix)?;
    // Start states beyond the divergence bound would be "diverged" at once.
    check_start_within_bound("fix", &base, bound)?;
    for (option, axis) in [("x", x), ("y", y)] {
        for v in [axis.lo, axis.hi] {
            check_coord_within_bound(option, axis.coord, v, bound)?;
        }
    }
    Ok(base)
}

/// What a basin computes. It is its own record: `run.json` and `basin.json` hold it as
/// [`BasinSpec::resolved`] serializes it (everything the labels depend on, not the
/// backend: units computed on any backend may be combined), and it reads back from
/// there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BasinSpec {
    /// Model, stepper, precision, backend, classification, lambda_1.
    #[serde(flatten)]
    pub lane: LaneSettings,
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// Horizontal axis (cells along a row).
    pub x: Axis,
    /// Vertical axis (rows).
    pub y: Axis,
    /// The start state of every cell before the two axis coordinates are set.
    pub base: State,
    /// Forcing periods integrated and discarded.
    pub transient: u32,
    /// Forcing periods recorded per cell (>= 2 n to see period n).
    pub periods: u32,
    /// Lanes per work unit (`None`: [`crate::run::unit_lanes`]; recorded resolved, as
    /// units of another size do not combine).
    #[serde(rename = "unit_lanes")]
    pub lanes_per_unit: Option<usize>,
}

impl BasinSpec {
    /// Checks the inputs; errors name the option and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.lane.validate()?;
        jeffcott_core::model::validate_omega(self.omega)?;
        self.x.validate("x")?;
        self.y.validate("y")?;
        if self.x.coord == self.y.coord {
            return Err(Error::invalid(
                "y",
                COORD_NAMES[self.y.coord],
                "the two axes must be different coordinates",
            ));
        }
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        jeffcott_core::limits::check_periods("periods", self.periods, 2)?;
        if let Some((i, v)) = self.base.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::invalid(
                COORD_NAMES[i],
                v,
                "fixed coordinates must be finite",
            ));
        }
        if self.lanes_per_unit == Some(0) {
            return Err(Error::invalid("chunk", 0, "must be >= 1 lane"));
        }
        Ok(())
    }

    /// The lanes from `starts` at the basin's speed, with its periods and lane settings.
    pub fn ensemble(&self, starts: impl IntoIterator<Item = State>) -> EnsembleSpec {
        self.lane.ensemble_at(
            self.lane.params.clone(),
            self.omega,
            starts,
            self.transient,
            self.periods,
        )
    }

    /// Whether the basin's lanes exit early ([`LaneSettings::early_exit`]), never with
    /// lambda_1: its per-cell exponent map needs every lane's whole record.
    pub fn early_exit(&self) -> bool {
        self.lane.early_exit() && !self.lane.lyapunov
    }

    /// The start state of cell (ix, iy).
    pub fn start(&self, ix: usize, iy: usize) -> State {
        let mut x = self.base;
        x[self.x.coord] = self.x.value(ix);
        x[self.y.coord] = self.y.value(iy);
        x
    }
}

/// A computed basin.
#[derive(Clone, Debug)]
pub struct BasinResult {
    /// Attractor id per cell, [ny, nx] row-major (row iy at y = y.value(iy)); -1 diverged.
    pub labels: Vec<i32>,
    /// The catalogue (its `labels` field is left empty: see `labels` above).
    pub catalogue: Catalogue,
    /// Largest Lyapunov exponent per cell [1/s], [ny, nx] as `labels`, when computed
    /// (NaN for diverged cells).
    pub lambda1: Option<Vec<f64>>,
    /// Backend information (wall time: the last batch's; `None` when every unit was
    /// already committed).
    pub info: Option<RunInfo>,
    /// What early exit saved (`None` when it was off).
    pub early_exit: Option<crate::early::EarlySaved>,
    /// Wall time [s].
    pub seconds: f64,
}

/// Stage name of a basin's units.
pub const STAGE: &str = "basin";

impl BasinSpec {
    /// Lanes per work unit: `chunk`, or [`crate::run::unit_lanes`] of the grid.
    pub fn unit_lanes(&self) -> usize {
        let per_lane = (self.transient + self.periods) as u64
            * self.lane.stepper.steps_per_period as u64
            * if self.lane.lyapunov { 2 } else { 1 };
        self.lanes_per_unit
            .unwrap_or_else(|| crate::run::unit_lanes(self.x.n * self.y.n, per_lane))
    }

    /// Lane-periods of the whole grid (for progress and estimates).
    pub fn lane_periods(&self) -> u64 {
        (self.x.n * self.y.n) as u64 * (self.transient + self.periods) as u64
    }
}

crate::record::unit_sized_spec!(
    BasinSpec,
    lanes_per_unit,
    unit_lanes,
    STAGE,
    BasinResult,
    basin_units
);

/// Most cells a basin may have: 1e9 (4 GB of labels, 12 GB with lambda_1; at the
/// default 564 periods per cell about 16 hours at 1e7 lane-periods/s, a large GPU).
/// Beyond it a grid is refused whatever the memory: 1e10 cells would take a week
/// on such a GPU and 40 GB of labels.
pub const MAX_BASIN_CELLS: u64 = 1_000_000_000;

/// Bytes a basin of `cells` cells holds at its peak, an upper estimate: 4 bytes of
/// labels per cell (+ 8 of lambda_1 with `lyapunov`), plus one chunk of `chunk` lanes
/// as an ensemble recording `recorded` periods.
pub fn memory_estimate(cells: u64, lyapunov: bool, chunk: u64, recorded: u64) -> u64 {
    let per_cell = if lyapunov { 12 } else { 4 };
    jeffcott_core::limits::product(&[cells, per_cell])
        .saturating_add(EnsembleSpec::memory_estimate_for(chunk, recorded))
}

impl BasinSpec {
    /// Refuses a grid of more than [`MAX_BASIN_CELLS`] cells, or one whose labels and
    /// work unit do not fit in the memory available (field `x, y`), before anything is
    /// allocated.
    pub fn check_size(&self) -> Result<()> {
        let (nx, ny) = (self.x.n as u64, self.y.n as u64);
        let cells = nx.saturating_mul(ny);
        let grid = format!("{nx} x {ny}");
        if cells > MAX_BASIN_CELLS {
            return Err(Error::invalid(
                "x, y",
                format!("{grid} = {cells} cells"),
                format!(
                    "a basin may have at most {MAX_BASIN_CELLS} cells (labels alone: {}); use a smaller grid",
                    jeffcott_core::limits::gb(memory_estimate(cells, self.lane.lyapunov, 0, 0))
                ),
            ));
        }
        let recorded = self.periods.max(1) as u64;
        let chunk = (self.unit_lanes() as u64).min(cells);
        jeffcott_core::limits::check_memory(
            "x, y",
            format!("{grid} = {cells} cells"),
            memory_estimate(cells, self.lane.lyapunov, chunk, recorded),
            &format!(
                "{} bytes of labels per cell{} plus a work unit of {chunk} lanes x {recorded} recorded periods",
                if self.lane.lyapunov { 12 } else { 4 },
                if self.lane.lyapunov {
                    " with lambda_1"
                } else {
                    ""
                }
            ),
            "use a smaller grid (fewer cells per axis) or a smaller --chunk",
        )
    }
}

/// Computes a basin in memory; `ctl.progress` counts lane-periods.
pub fn basin(spec: &BasinSpec, ctl: Control) -> Result<BasinResult> {
    crate::run::in_memory(spec, ctl)
}

/// Computes a basin unit by unit into `store` (resuming from the units it holds), then
/// assembles the labels and the catalogue from the units in order. Each unit's lanes are
/// catalogued on their own ([`CatalogueBuilder::finish_part`]) and the unit keeps its
/// labels, lambda_1 and partial catalogue only; the assembly absorbs the partial
/// catalogues in unit order, so memory is the labels plus one unit, and the result
/// depends on the specification alone.
fn basin_units(spec: &BasinSpec, Units { engine, store, ctl }: Units) -> Result<BasinResult> {
    spec.validate()?;
    let t0 = std::time::Instant::now();
    let (nx, ny) = (spec.x.n, spec.y.n);
    let cells = nx * ny;
    let per_unit = spec.unit_lanes();
    let split = Split::new(cells, per_unit);
    let count = split.count();
    let ensemble = |u: usize| spec.ensemble(split.range(u).map(|c| spec.start(c % nx, c / nx)));
    let reduce = |_u: usize, _e: &EnsembleSpec, res: jeffcott_core::ensemble::EnsembleResult| {
        let mut b = CatalogueBuilder::new(spec.omega, spec.lane.catalogue);
        let labels = b.add_result_lanes(&res, 0..res.status.len());
        let (parts, labels, diverged) = b.finish_part(labels);
        let mut unit = part_unit(labels, &parts, diverged);
        if let Some(l) = res.lambda1 {
            unit = unit.with("lambda1", Array::F64(l));
        }
        Ok(unit)
    };
    // Early exit (crate::early): the unit's lanes in rounds, recognised lanes retired.
    // Not with lambda_1, whose per-lane exponent needs every lane's whole record.
    let early = |_u: usize, e: &EnsembleSpec, engine: &crate::backend::Engine, c: Control| {
        let r = crate::early::catalogue_lanes(e, spec.omega, spec.lane.catalogue, engine, c)?;
        let (parts, labels, diverged) = r.builder.finish_part(r.labels);
        let unit =
            part_unit(labels, &parts, diverged).with("early", Array::F64(r.saved.to_array()));
        Ok((unit, r.info))
    };
    let early_on = spec.early_exit();
    let info = LaneUnits::new(STAGE, split, &ensemble, &reduce)
        .lambda1(spec.lane.lyapunov)
        .computed_by(early_on.then_some(&early as &crate::run::lanes::ComputeUnit))
        .run(store, engine, ctl)?;
    // Assembly, in unit order.
    let mut labels = Vec::with_capacity(cells);
    let mut lambda1 = spec.lane.lyapunov.then(|| Vec::with_capacity(cells));
    let mut builder = CatalogueBuilder::new(spec.omega, spec.lane.catalogue);
    let mut saved = early_on.then(crate::early::EarlySaved::default);
    for u in 0..count {
        let unit = store.load(STAGE, u)?;
        if let Some(s) = saved.as_mut() {
            s.add(&crate::early::EarlySaved::from_array(unit.f64s("early")?));
        }
        let (parts, diverged) = unit_parts(&unit)?;
        let ids: Vec<i32> = parts
            .iter()
            .map(|p| builder.absorb(p, (u * per_unit) as u64))
            .collect();
        let lab = unit.i32s("labels")?;
        builder.add_lanes(lab.len() as u64, diverged);
        labels.extend(
            lab.iter()
                .map(|&l| if l >= 0 { ids[l as usize] } else { -1 }),
        );
        if let Some(all) = lambda1.as_mut() {
            all.extend_from_slice(unit.f64s("lambda1")?);
        }
    }
    // `finish` may merge aperiodic entries; it remaps the labels accordingly.
    let mut catalogue = builder.finish(labels);
    let labels = std::mem::take(&mut catalogue.labels);
    Ok(BasinResult {
        labels,
        catalogue,
        lambda1,
        info,
        early_exit: saved,
        seconds: t0.elapsed().as_secs_f64(),
    })
}
