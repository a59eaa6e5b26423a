//! Two-parameter maps (design charts): a grid over any two of the rotor speed, the model
//! parameters and the start coordinates; per cell, K start states (the static
//! equilibrium of the cell's parameters plus seeded ones, as the brute-force bifurcation
//! draws them), the attractors they reach with class, lambda_1 and rub figures.
//!
//! One parameter set per cell goes to the backend as lane data
//! ([`EnsembleSpec::param_sets`]), so a GPU runs the whole map from one kernel. The grid
//! is cut into work units of whole cells ([`crate::run`]); each unit keeps its cells'
//! figures and attractor lists, so a map resumes and shards like a basin, and a cell's
//! figures depend on that cell alone (lanes are independent).

use crate::catalogue::CatalogueBuilder;
use crate::classify::Class;
use crate::rub::{RubFigures, rub_on_attractor, rub_periods};
use crate::run::Host;
use crate::run::lanes::{Control, LaneUnits, Split};
use crate::run::{Array, Unit, Units};
use crate::settings::LaneSettings;
use jeffcott_core::ensemble::{EnsembleResult, EnsembleSpec, LaneSpec, RunInfo};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{
    COORD_NAMES, Params, State, X_R, X_S, Y_R, Y_S, coord_index, validate_omega,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// What an axis of a map varies (the files record it by name).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapVar {
    /// The rotor speed W [rad/s].
    Omega,
    /// A model parameter, by its TOML key ([`Params::names`]).
    Param(&'static str),
    /// A start coordinate (index into the state), set in every start state of the cell.
    Coord(usize),
}

impl MapVar {
    /// Refuses an override (`override_option`, e.g. `param`) of the model parameter
    /// this axis (`axis_option`) varies: the axis sets it at every value, so the
    /// override would be recorded in run.json and never used. `overridden` lists the
    /// names the override sets.
    pub fn check_not_overridden<S: AsRef<str>>(
        &self,
        axis_option: &str,
        override_option: &str,
        overridden: &[S],
    ) -> Result<()> {
        let MapVar::Param(name) = self else {
            return Ok(());
        };
        if overridden.iter().any(|o| o.as_ref() == *name) {
            return Err(Error::invalid(
                override_option,
                name,
                format!(
                    "`{axis_option}` varies {name}, which sets it at every value; leave {name} out of `{override_option}`"
                ),
            ));
        }
        Ok(())
    }

    /// Parses a name: `omega`, a parameter key or a coordinate name.
    pub fn parse(option: &str, name: &str) -> Result<MapVar> {
        if name == "omega" {
            return Ok(MapVar::Omega);
        }
        if let Some(k) = Params::names().find(|k| *k == name) {
            return Ok(MapVar::Param(k));
        }
        if let Some(i) = coord_index(name) {
            return Ok(MapVar::Coord(i));
        }
        Err(Error::invalid(
            option,
            name,
            format!(
                "unknown axis; valid names: omega, {}, or a start coordinate {}",
                Params::names_list(),
                COORD_NAMES.join(", ")
            ),
        ))
    }

    /// The name as given on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            MapVar::Omega => "omega",
            MapVar::Param(k) => k,
            MapVar::Coord(i) => COORD_NAMES[*i],
        }
    }

    /// Unit of the variable, for axis labels.
    pub fn unit(&self) -> &'static str {
        match self {
            MapVar::Omega => "rad/s",
            MapVar::Coord(i) => jeffcott_core::model::COORD_UNITS[*i],
            MapVar::Param(k) => jeffcott_core::model::Params::unit(k),
        }
    }
}

impl Serialize for MapVar {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for MapVar {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        MapVar::parse("var", &name).map_err(serde::de::Error::custom)
    }
}

/// One axis of a map: `n` values of a variable from `lo` to `hi` inclusive, evenly
/// spaced, or geometrically with `log`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapAxis {
    /// What the axis varies.
    pub var: MapVar,
    /// First value.
    pub lo: f64,
    /// Last value.
    pub hi: f64,
    /// Number of values.
    pub n: usize,
    /// Geometric spacing (lo, hi > 0).
    pub log: bool,
}

/// Cells per map axis at most (the basin's bound).
pub use crate::basin::MAX_CELLS_PER_AXIS;

impl MapAxis {
    /// Parses `NAME:lo:hi:n`; `option` names the CLI option in errors.
    pub fn parse(option: &str, text: &str, log: bool) -> Result<MapAxis> {
        let (name, lo, hi, n) =
            crate::basin::parse_named_range(option, text, "omega:130:141:200 or e:0:0.002:100")?;
        let axis = MapAxis {
            var: MapVar::parse(option, name)?,
            lo,
            hi,
            n,
            log,
        };
        axis.validate(option)?;
        Ok(axis)
    }

    /// Checks count, order and (for `log`) positivity; `option` names the axis.
    pub fn validate(&self, option: &str) -> Result<()> {
        crate::basin::check_axis(option, self.lo, self.hi, self.n)?;
        if self.log && self.lo <= 0.0 {
            return Err(Error::invalid(
                option,
                self.lo,
                "a logarithmic axis needs lo > 0",
            ));
        }
        Ok(())
    }

    /// The i-th value: `lo + (hi - lo) i / (n - 1)`, the arithmetic of the `a:b:n`
    /// ranges of the other commands (so a map over omega hits the very speeds of a
    /// bifurcation over the same range), or `lo (hi/lo)^(i/(n-1))` with `log`.
    pub fn value(&self, i: usize) -> f64 {
        if self.n == 1 {
            return self.lo;
        }
        if self.log {
            self.lo * (self.hi / self.lo).powf(i as f64 / (self.n - 1) as f64)
        } else {
            jeffcott_core::ensemble::range_value(self.lo, self.hi, self.n as u64, i as u64)
        }
    }

    /// All values.
    pub fn values(&self) -> Vec<f64> {
        (0..self.n).map(|i| self.value(i)).collect()
    }

    /// The axis as `map.json` records it, with its unit.
    pub fn record(&self) -> AxisRecord {
        AxisRecord {
            var: self.var.name(),
            unit: Some(self.var.unit()),
            lo: self.lo,
            hi: self.hi,
            n: self.n,
            log: Some(self.log),
        }
    }
}

/// An axis of a map or a continuation as the files record it: the variable by name,
/// its unit (in the summaries), the range, and the spacing (for a map).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AxisRecord {
    /// The variable's name (`omega`, `mu`, `x_r`, ...).
    pub var: &'static str,
    /// Its unit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unit: Option<&'static str>,
    /// First value.
    pub lo: f64,
    /// Last value.
    pub hi: f64,
    /// Number of values.
    pub n: usize,
    /// Geometric spacing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub log: Option<bool>,
}

/// What a map computes. It is its own record: `run.json` holds it as
/// [`MapSpec::resolved`] serializes it (everything the cells depend on and the unit
/// size, as units of another size do not combine; not the backend), and it reads back
/// from there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapSpec {
    /// Model, stepper, precision, backend, classification, lambda_1.
    #[serde(flatten)]
    pub lane: LaneSettings,
    /// Rotor speed of every cell when no axis is `omega` [rad/s].
    pub omega: Option<f64>,
    /// Horizontal axis (cells along a row).
    pub x: MapAxis,
    /// Vertical axis (rows).
    pub y: MapAxis,
    /// Start states per cell: the static equilibrium plus `ics - 1` seeded ones.
    pub ics: u32,
    /// Seed of the start states (the same draws in every cell).
    pub seed: u64,
    /// Forcing periods integrated and discarded.
    pub transient: u32,
    /// Forcing periods recorded per lane.
    pub periods: u32,
    /// Cells per work unit (`None`: [`crate::run::unit_lanes`] in cells; recorded
    /// resolved).
    #[serde(rename = "unit_cells")]
    pub cells_per_unit: Option<usize>,
}

/// Start states per cell at most.
pub const MAX_ICS: u32 = 10_000;

impl MapSpec {
    /// Checks the inputs, every cell's parameter set included (through the extreme
    /// values of each axis); errors name the option and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.lane.validate()?;
        self.x.validate("x")?;
        self.y.validate("y")?;
        if self.x.var == self.y.var {
            return Err(Error::invalid(
                "y",
                self.y.var.name(),
                "the two axes must vary different things",
            ));
        }
        let has_omega = self.x.var == MapVar::Omega || self.y.var == MapVar::Omega;
        match (self.omega, has_omega) {
            (None, false) => {
                return Err(Error::invalid(
                    "omega",
                    "none",
                    "give --omega W when neither axis is omega",
                ));
            }
            (Some(w), false) => validate_omega(w)?,
            (Some(w), true) => {
                return Err(Error::invalid(
                    "omega",
                    w,
                    "an axis is omega, which sets the speed of every cell; leave --omega out",
                ));
            }
            (None, true) => {}
        }
        if !(1..=MAX_ICS).contains(&self.ics) {
            return Err(Error::invalid(
                "ics",
                self.ics,
                format!("must be in 1..={MAX_ICS}"),
            ));
        }
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        jeffcott_core::limits::check_periods("periods", self.periods, 2)?;
        if self.cells_per_unit == Some(0) {
            return Err(Error::invalid("chunk", 0, "must be >= 1 cell"));
        }
        // Every cell's parameters lie between those of the corners (each axis is
        // monotone), and the checks are ranges: the corners decide.
        for (ix, iy) in [
            (0, 0),
            (self.x.n - 1, 0),
            (0, self.y.n - 1),
            (self.x.n - 1, self.y.n - 1),
        ] {
            // Errors name the corner: which axis values make the cell invalid.
            let corner = || {
                format!(
                    "{} = {}, {} = {}",
                    self.x.var.name(),
                    self.x.value(ix),
                    self.y.var.name(),
                    self.y.value(iy)
                )
            };
            let (p, w) = self.cell_params(ix, iy);
            validate_omega(w).and_then(|_| p.validate()).map_err(|e| {
                Error::invalid(
                    "x, y",
                    corner(),
                    format!("a cell of the map is invalid: {e}"),
                )
            })?;
            let bound = self.lane.stepper.divergence_bound;
            for s in self.cell_starts(ix, iy) {
                for c in [X_R, Y_R, X_S, Y_S] {
                    if s[c].abs() > bound {
                        return Err(Error::invalid(
                            &format!("start {}", COORD_NAMES[c]),
                            s[c],
                            format!(
                                "start position beyond --divergence-bound {bound} m; must be in -{bound}..={bound} m"
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.x.n * self.y.n
    }

    /// The parameters and speed of cell (ix, iy).
    pub fn cell_params(&self, ix: usize, iy: usize) -> (Params, f64) {
        let mut p = self.lane.params.clone();
        let mut w = self.omega.unwrap_or(f64::NAN);
        for (axis, i) in [(&self.x, ix), (&self.y, iy)] {
            match axis.var {
                MapVar::Omega => w = axis.value(i),
                MapVar::Param(k) => {
                    p.set(k, axis.value(i))
                        .expect("MapVar::Param holds a known key");
                }
                MapVar::Coord(_) => {}
            }
        }
        (p, w)
    }

    /// The K start states of cell (ix, iy): the static equilibrium of the cell's
    /// parameters, then the seeded draws of [`crate::bifurcation::start_states`] with
    /// rotor velocities scaled by the cell's own speed (so a cell's start states, like
    /// its results, depend on the cell alone); a coordinate axis sets its coordinate in
    /// all of them.
    pub fn cell_starts(&self, ix: usize, iy: usize) -> Vec<State> {
        let (p, w) = self.cell_params(ix, iy);
        let mut starts = crate::bifurcation::start_states(&p, self.ics, w, self.seed);
        for (axis, i) in [(&self.x, ix), (&self.y, iy)] {
            if let MapVar::Coord(c) = axis.var {
                for s in &mut starts {
                    s[c] = axis.value(i);
                }
            }
        }
        starts
    }

    /// Cells per work unit: `chunk`, or [`crate::run::unit_lanes`] counted in cells.
    pub fn unit_cells(&self) -> usize {
        let per_cell = self.ics as u64
            * (self.transient + self.periods) as u64
            * self.lane.stepper.steps_per_period as u64
            * if self.lane.lyapunov { 2 } else { 1 };
        self.cells_per_unit
            .unwrap_or_else(|| crate::run::unit_lanes(self.cells(), per_cell))
    }

    /// Lane-periods of the whole map (for progress and estimates).
    pub fn lane_periods(&self) -> u64 {
        self.cells() as u64 * self.ics as u64 * (self.transient + self.periods) as u64
    }
}

crate::record::unit_sized_spec!(
    MapSpec,
    cells_per_unit,
    unit_cells,
    STAGE,
    MapResult,
    map_units
);

/// One attractor found in one cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellAttractor {
    /// Id within the cell (in the order its start states first reached them).
    pub id: u32,
    /// `period-N`, `aperiodic`, `quasiperiodic`, `chaotic`, `unclassified`.
    pub class: String,
    /// Period, when periodic.
    pub period: Option<usize>,
    /// Start states of the cell that reach it.
    pub lanes: u32,
    /// Mean lambda_1 of those lanes [1/s] (with lambda_1).
    pub lambda1: Option<f64>,
    /// Rub figures on the attractor (`None` if its rub stretch diverged).
    pub rub: Option<RubFigures>,
}

/// What a map found in one cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// Column and row.
    pub ix: usize,
    /// Row.
    pub iy: usize,
    /// Attractors of the cell, in the order its start states first reached them.
    pub attractors: Vec<CellAttractor>,
    /// Start states that diverged.
    pub diverged: u32,
    /// Index into `attractors` of the one reached from the static equilibrium (the
    /// cell's first start state); `None` when that start state diverged.
    pub equilibrium: Option<u32>,
}

/// Class codes of `class.npy`-style arrays: n > 0 period-n; these for the rest.
pub mod code {
    /// Aperiodic without a lambda_1 verdict.
    pub const APERIODIC: i32 = 0;
    /// Diverged (or non-finite).
    pub const DIVERGED: i32 = -1;
    /// Aperiodic with lambda_1 ~ 0.
    pub const QUASIPERIODIC: i32 = -2;
    /// Aperiodic with lambda_1 > 0.
    pub const CHAOTIC: i32 = -3;
    /// Too few points to classify.
    pub const UNCLASSIFIED: i32 = -4;
}

fn class_code(c: Class) -> i32 {
    match c {
        Class::Periodic(n) => n as i32,
        Class::Aperiodic => code::APERIODIC,
        Class::Quasiperiodic => code::QUASIPERIODIC,
        Class::Chaotic => code::CHAOTIC,
        Class::Diverged => code::DIVERGED,
        Class::Unclassified => code::UNCLASSIFIED,
    }
}

/// A computed map, arrays [ny, nx] row-major (row iy at y.value(iy)).
#[derive(Clone, Debug)]
pub struct MapResult {
    /// Class code of the attractor reached from the static equilibrium ([`code`]).
    pub class: Vec<i32>,
    /// Its period: n, 0 aperiodic (any kind), -1 diverged.
    pub period: Vec<i32>,
    /// Its mean lambda_1 [1/s] (NaN without lambda_1 or when diverged).
    pub lambda1: Vec<f64>,
    /// Number of coexisting attractors found from the K start states.
    pub attractors: Vec<i32>,
    /// Contact fraction of time on it (NaN when diverged).
    pub contact: Vec<f64>,
    /// Peak normal contact force on it [N] (NaN when diverged).
    pub peak_force: Vec<f64>,
    /// Its rub regime code ([`crate::rub::RubRegime::code`]; -1 diverged).
    pub regime: Vec<i32>,
    /// Every cell's attractors.
    pub cells: Vec<Cell>,
    /// Backend information of the last batch (`None` when every unit was committed).
    pub info: Option<RunInfo>,
    /// What early exit saved (`None`: it ran without; a cell needs two or more start
    /// states for it).
    pub early_exit: Option<crate::early::EarlySaved>,
    /// Wall time [s].
    pub seconds: f64,
}

/// Stage name of a map's units.
pub const STAGE: &str = "map";

/// Computes a map in memory; `ctl.progress` counts lane-periods.
pub fn map(spec: &MapSpec, ctl: Control) -> Result<MapResult> {
    crate::run::in_memory(spec, ctl)
}

/// The cells of one unit from its ensemble result: per cell, its K lanes catalogued
/// (the cell's own catalogue at the cell's speed), the rub figures of each attractor
/// from the final state of the first lane that reached it.
fn reduce_cells(
    spec: &MapSpec,
    first_cell: usize,
    e: &EnsembleSpec,
    res: &EnsembleResult,
) -> Result<Vec<Cell>> {
    let k = spec.ics as usize;
    let n_cells = e.lanes.len() / k;
    (0..n_cells)
        .into_par_iter()
        .map(|j| {
            let c = first_cell + j;
            let (ix, iy) = (c % spec.x.n, c / spec.x.n);
            let lanes = j * k..(j + 1) * k;
            let p = &e.param_sets[e.lanes[j * k].param_set as usize];
            let w = e.lanes[j * k].omega;
            let mut b = CatalogueBuilder::new(w, spec.lane.catalogue);
            let labels = b.add_result_lanes(res, lanes.clone());
            let cat = b.finish(labels);
            let mut attractors = Vec::with_capacity(cat.attractors.len());
            for a in &cat.attractors {
                let first = cat
                    .labels
                    .iter()
                    .position(|&l| l == a.id as i32)
                    .unwrap_or(0);
                let x0 = res.final_state[lanes.start + first];
                let rub = rub_on_attractor(p, w, &x0, rub_periods(a.period), &spec.lane.stepper)?;
                attractors.push(CellAttractor {
                    id: a.id,
                    class: a.class.clone(),
                    period: a.period,
                    lanes: a.lanes as u32,
                    lambda1: a.lambda1,
                    rub,
                });
            }
            Ok(Cell {
                ix,
                iy,
                attractors,
                diverged: cat.diverged as u32,
                equilibrium: u32::try_from(cat.labels[0]).ok(),
            })
        })
        .collect()
}

/// Runs a map under `host` (its units committed to the host's store, its progress on
/// the host's display as stage `map`): the front ends' entry point.
pub fn run(spec: &MapSpec, engine: &crate::backend::Engine, host: &impl Host) -> Result<MapResult> {
    crate::run::under_host(spec, engine, host)
}

/// Computes a map unit by unit into `store` (resuming from the units it holds), then
/// assembles the arrays from the units in order.
fn map_units(spec: &MapSpec, Units { engine, store, ctl }: Units) -> Result<MapResult> {
    spec.validate()?;
    let t0 = std::time::Instant::now();
    let cells = spec.cells();
    let per_unit = spec.unit_cells();
    let split = Split::new(cells, per_unit);
    let count = split.count();
    let k = spec.ics as usize;
    let ensemble = |u: usize| {
        let range = split.range(u);
        let mut param_sets = Vec::with_capacity(range.len());
        let mut lanes = Vec::with_capacity(range.len() * k);
        for c in range {
            let (ix, iy) = (c % spec.x.n, c / spec.x.n);
            let (p, w) = spec.cell_params(ix, iy);
            let set = param_sets.len() as u32;
            for x0 in spec.cell_starts(ix, iy) {
                lanes.push(LaneSpec {
                    omega: w,
                    x0,
                    param_set: set,
                });
            }
            param_sets.push(p);
        }
        EnsembleSpec {
            param_sets,
            lanes,
            transient: spec.transient,
            recorded: spec.periods,
            stepper: spec.lane.stepper,
            precision: spec.lane.precision,
        }
    };
    let cells_unit = |u: usize, e: &EnsembleSpec, res: &EnsembleResult| -> Result<Unit> {
        let cells = reduce_cells(spec, u * per_unit, e, res)?;
        Ok(Unit::new("")
            .with("n", Array::U32(vec![cells.len() as u32]))
            .with_meta(&CellsMeta { cells }))
    };
    let reduce = |u: usize, e: &EnsembleSpec, res: EnsembleResult| cells_unit(u, e, &res);
    // Early exit (crate::early, record mode, as the bifurcation's brute force): each
    // cell's first start state runs whole and catalogues the cell; the others are
    // recognised on that catalogue during their transient and record their periods from
    // there, then every lane is classified from its record as without early exit. Only
    // with two or more start states per cell (with one there is nothing to recognise).
    let early_on = spec.lane.early_exit() && k >= 2;
    let early = |u: usize, e: &EnsembleSpec, engine: &crate::backend::Engine, c: Control| {
        let group: Vec<usize> = (0..e.lanes.len()).map(|i| i / k).collect();
        let omegas: Vec<f64> = e.lanes.iter().step_by(k).map(|l| l.omega).collect();
        let (res, saved, info) = crate::early::records_by_group(
            e,
            &group,
            &omegas,
            crate::early::GroupRecognition::FirstLane,
            spec.lane.catalogue,
            spec.lane.lyapunov,
            engine,
            c,
        )?;
        let unit = cells_unit(u, e, &res)?.with("early", Array::F64(saved.to_array()));
        Ok((unit, info))
    };
    let info = LaneUnits::new(STAGE, split, &ensemble, &reduce)
        .lanes_per_item(k)
        .lambda1(spec.lane.lyapunov)
        .computed_by(early_on.then_some(&early as &crate::run::lanes::ComputeUnit))
        .run(store, engine, ctl)?;
    let mut out = MapResult {
        class: Vec::with_capacity(cells),
        period: Vec::with_capacity(cells),
        lambda1: Vec::with_capacity(cells),
        attractors: Vec::with_capacity(cells),
        contact: Vec::with_capacity(cells),
        peak_force: Vec::with_capacity(cells),
        regime: Vec::with_capacity(cells),
        cells: Vec::with_capacity(cells),
        info,
        early_exit: None,
        seconds: 0.0,
    };
    for u in 0..count {
        let unit = store.load(STAGE, u)?;
        crate::early::EarlySaved::accumulate(&mut out.early_exit, crate::early::unit_saved(&unit)?);
        for cell in unit.meta_as::<CellsMeta>()?.cells {
            out.push(cell);
        }
    }
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

impl MapResult {
    /// Appends one cell's figures (the cell from the static equilibrium decides class,
    /// period, lambda_1 and rub figures).
    fn push(&mut self, cell: Cell) {
        let eq = cell.equilibrium.map(|i| &cell.attractors[i as usize]);
        let (class, lambda1, rub) = match eq {
            Some(a) => (
                class_code(class_of(a)),
                a.lambda1.unwrap_or(f64::NAN),
                a.rub,
            ),
            None => (code::DIVERGED, f64::NAN, None),
        };
        self.class.push(class);
        self.period.push(match class {
            n if n > 0 => n,
            code::DIVERGED => -1,
            _ => 0,
        });
        self.lambda1.push(lambda1);
        self.attractors.push(cell.attractors.len() as i32);
        self.contact
            .push(rub.map(|r| r.contact_fraction).unwrap_or(f64::NAN));
        self.peak_force
            .push(rub.map(|r| r.peak_force_n).unwrap_or(f64::NAN));
        self.regime.push(
            rub.map(|r| r.regime)
                .unwrap_or(crate::rub::RubRegime::Diverged)
                .code(),
        );
        self.cells.push(cell);
    }
}

fn class_of(a: &CellAttractor) -> Class {
    match (a.period, a.class.as_str()) {
        (Some(n), _) => Class::Periodic(n),
        (None, "quasiperiodic") => Class::Quasiperiodic,
        (None, "chaotic") => Class::Chaotic,
        (None, "unclassified") => Class::Unclassified,
        _ => Class::Aperiodic,
    }
}

/// Name of a class code, for legends and map.json.
pub fn class_name(c: i32) -> String {
    match c {
        n if n > 0 => format!("period-{n}"),
        code::APERIODIC => "aperiodic".into(),
        code::QUASIPERIODIC => "quasiperiodic".into(),
        code::CHAOTIC => "chaotic".into(),
        code::UNCLASSIFIED => "unclassified".into(),
        _ => "diverged".into(),
    }
}

/// The metadata of a map unit: its cells' attractors.
#[derive(Serialize, Deserialize)]
struct CellsMeta {
    cells: Vec<Cell>,
}

/// The map as `map.json` holds it (the command line adds the list of files and the
/// version): the axes, the settings, the tally of classes from the static equilibrium,
/// multistable and rubbing cells, and every cell's attractors.
#[derive(Clone, Debug, Serialize)]
pub struct Summary<'a> {
    /// Horizontal axis.
    pub x: AxisRecord,
    /// Vertical axis.
    pub y: AxisRecord,
    /// Rotor speed when no axis is `omega` [rad/s].
    pub omega: Option<f64>,
    /// Start states per cell.
    pub ics: u32,
    /// Seed of the start states.
    pub seed: u64,
    /// Transient periods.
    pub transient: u32,
    /// Recorded periods.
    pub periods: u32,
    /// Macro steps per forcing period.
    pub steps_per_period: u32,
    /// Whether lambda_1 was computed.
    pub lyapunov: bool,
    /// Number of cells.
    pub cells: usize,
    /// Cells per class of the response from the static equilibrium.
    pub classes_from_static_equilibrium: std::collections::BTreeMap<String, usize>,
    /// Cells with more than one attractor.
    pub multistable_cells: usize,
    /// Cells whose response from the static equilibrium touches the stator.
    pub rubbing_cells: usize,
    /// Most attractors in one cell.
    pub max_attractors: i32,
    /// Every cell's attractors.
    pub cell_attractors: &'a [Cell],
    /// Model parameters.
    pub params: &'a Params,
}

/// The summary `map.json` holds.
pub fn summary<'a>(spec: &'a MapSpec, res: &'a MapResult) -> Summary<'a> {
    let mut tally: std::collections::BTreeMap<String, usize> = Default::default();
    for &c in &res.class {
        *tally.entry(class_name(c)).or_default() += 1;
    }
    Summary {
        x: spec.x.record(),
        y: spec.y.record(),
        omega: spec.omega,
        ics: spec.ics,
        seed: spec.seed,
        transient: spec.transient,
        periods: spec.periods,
        steps_per_period: spec.lane.stepper.steps_per_period,
        lyapunov: spec.lane.lyapunov,
        cells: spec.x.n * spec.y.n,
        classes_from_static_equilibrium: tally,
        multistable_cells: res.attractors.iter().filter(|&&n| n > 1).count(),
        rubbing_cells: res.contact.iter().filter(|&&c| c > 0.0).count(),
        max_attractors: res.attractors.iter().copied().max().unwrap_or(0),
        cell_attractors: &res.cells,
        params: &spec.lane.params,
    }
}

/// Most cells a map may have (its per-cell attractor lists are held in memory).
pub const MAX_MAP_CELLS: u64 = 100_000_000;

/// Refuses a map of more than [`MAX_MAP_CELLS`] cells, or one whose per-cell arrays and
/// attractor lists (with `ics` start states a cell) do not fit in memory.
pub fn check_size(x: &MapAxis, y: &MapAxis, ics: u32) -> Result<()> {
    let cells = x.n as u64 * y.n as u64;
    if cells > MAX_MAP_CELLS {
        return Err(Error::invalid(
            "x, y",
            format!("{} x {} = {cells} cells", x.n, y.n),
            format!("a map may have at most {MAX_MAP_CELLS} cells; use fewer per axis"),
        ));
    }
    jeffcott_core::limits::check_memory(
        "x, y",
        format!("{} x {} cells", x.n, y.n),
        // Per cell: the arrays (36 bytes) and its attractor list (~200 bytes per
        // attractor), plus one unit of lanes.
        cells.saturating_mul(36 + 200 * ics.min(8) as u64),
        "the per-cell arrays and attractor lists",
        "use fewer cells or fewer --ics",
    )?;
    Ok(())
}
