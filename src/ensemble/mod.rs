//! Ensembles: many independent lanes (each its own speed W, start state and, optionally,
//! parameter set) run by one call on either backend, with results identical in shape.
//! Bifurcation sweeps, basins and parameter-plane maps are all ensembles (DESIGN.md 1).

pub mod cpu;

use crate::error::{Error, Result};
use crate::integrate::lane::{Counters, Lane, LaneConsts, Status, StepperConfig};
use crate::model::{COORD_NAMES, Params, STATE_DIM, State, validate_omega};
use crate::real::Real;
use serde::Serialize;

/// Floating-point precision of the lanes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// Single precision (the GPU default).
    F32,
    /// Double precision (the CPU default; on the GPU only with `SHADER_F64`).
    F64,
}

/// One lane: its speed, its start state, and which parameter set it uses.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LaneSpec {
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// Start state at t = 0.
    pub x0: State,
    /// Index into [`EnsembleSpec::param_sets`].
    pub param_set: u32,
}

/// What an ensemble run integrates.
#[derive(Clone, Debug, Serialize)]
pub struct EnsembleSpec {
    /// Parameter sets the lanes refer to (at least one).
    pub param_sets: Vec<Params>,
    /// The lanes.
    pub lanes: Vec<LaneSpec>,
    /// Forcing periods integrated and discarded.
    pub transient: u32,
    /// Forcing periods recorded (one Poincare point per lane each).
    pub recorded: u32,
    /// Lane stepper settings (N, refinement cap, divergence bound).
    pub stepper: StepperConfig,
    /// Precision of the lanes.
    pub precision: Precision,
}

impl EnsembleSpec {
    /// Checks every input; errors name the field (and lane) and the allowed range.
    /// Non-finite start states are *not* errors: such lanes end `non_finite`, flagged,
    /// without touching their neighbours.
    pub fn validate(&self) -> Result<()> {
        if self.param_sets.is_empty() {
            return Err(Error::invalid(
                "param_sets",
                0,
                "at least one parameter set is needed",
            ));
        }
        for p in &self.param_sets {
            p.validate()?;
        }
        self.stepper.validate()?;
        if self.lanes.is_empty() {
            return Err(Error::invalid(
                "lanes",
                0,
                "an ensemble needs at least one lane",
            ));
        }
        if self.recorded == 0 {
            return Err(Error::invalid(
                "periods",
                0,
                "at least one period must be recorded",
            ));
        }
        let cells = self.lanes.len() as u128 * self.recorded as u128 * STATE_DIM as u128;
        if cells > (1u128 << 34) {
            return Err(Error::invalid(
                "periods",
                self.recorded,
                format!(
                    "{} lanes x {} recorded periods x 8 values do not fit in memory; record fewer periods",
                    self.lanes.len(),
                    self.recorded
                ),
            ));
        }
        for (i, l) in self.lanes.iter().enumerate() {
            validate_omega(l.omega).map_err(|_| {
                Error::invalid(
                    &format!("omega (lane {i})"),
                    l.omega,
                    "rotor speed must be finite and > 0 rad/s",
                )
            })?;
            if l.param_set as usize >= self.param_sets.len() {
                return Err(Error::invalid(
                    &format!("param_set (lane {i})"),
                    l.param_set,
                    format!("must be < {}", self.param_sets.len()),
                ));
            }
        }
        Ok(())
    }

    /// Lane constants in precision `R`.
    pub fn lane_consts<R: Real>(&self, i: usize) -> LaneConsts<R> {
        let l = &self.lanes[i];
        LaneConsts::new(
            &self.param_sets[l.param_set as usize],
            l.omega,
            &self.stepper,
        )
    }

    /// The initial lane in precision `R`.
    pub fn initial_lane<R: Real>(&self, i: usize) -> Lane<R> {
        let l = &self.lanes[i];
        Lane::new(&l.x0, self.param_sets[l.param_set as usize].delta)
    }
}

/// Per-lane results of an ensemble run, the same for both backends.
#[derive(Clone, Debug)]
pub struct EnsembleResult {
    /// Poincare points, shape [lanes, recorded, 8], C order (lane-major).
    pub poincare: Vec<f64>,
    /// Number of recorded periods per lane.
    pub recorded: usize,
    /// Final state of each lane.
    pub final_state: Vec<State>,
    /// Outcome of each lane.
    pub status: Vec<Status>,
    /// Counters of each lane.
    pub counters: Vec<Counters>,
}

impl EnsembleResult {
    /// The recorded Poincare points of lane `i`.
    pub fn lane_points(&self, i: usize) -> &[f64] {
        let n = self.recorded * STATE_DIM;
        &self.poincare[i * n..(i + 1) * n]
    }

    /// Lane `i`'s points as states.
    pub fn lane_states(&self, i: usize) -> Vec<State> {
        self.lane_points(i)
            .chunks_exact(STATE_DIM)
            .map(|c| {
                let mut s = [0.0; STATE_DIM];
                s.copy_from_slice(c);
                s
            })
            .collect()
    }
}

/// Column names of the lane table (`lanes.npy`): W, the parameter set and the start state.
pub fn lane_table_columns() -> Vec<String> {
    let mut c = vec!["omega".to_string(), "param_set".to_string()];
    c.extend(COORD_NAMES.iter().map(|n| format!("{n}0")));
    c
}
