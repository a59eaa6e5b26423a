//! What every lane study shares (docs/numerics.md-5): the model parameters, how a lane is
//! integrated (stepper, precision, backend), how its Poincare records are classified,
//! and whether its largest Lyapunov exponent is computed. Each study's spec holds one
//! [`LaneSettings`], flattened: run.json keeps its flat keys (`params`, `stepper`, ...).

use crate::catalogue::CatalogueConfig;
use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, State};
use serde::{Deserialize, Serialize};

/// The lane settings of a study.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaneSettings {
    /// Model parameters (before a study's axes or ramps set theirs).
    pub params: Params,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Lane precision (a bifurcation's sweeps are f64 whatever it says).
    pub precision: Precision,
    /// Backend (not recorded: units computed on any backend combine).
    #[serde(skip)]
    pub backend: Backend,
    /// Classification tolerances.
    pub catalogue: CatalogueConfig,
    /// Compute every lane's largest Lyapunov exponent lambda_1 (aperiodic attractors
    /// are then told apart as quasiperiodic or chaotic).
    pub lyapunov: bool,
}

impl LaneSettings {
    /// The defaults of `precision`: default parameters, stepper and tolerances for that
    /// precision, automatic backend, no lambda_1.
    pub fn new(precision: Precision) -> LaneSettings {
        LaneSettings {
            params: Params::default(),
            stepper: StepperConfig::DEFAULT,
            precision,
            backend: Backend::Auto,
            catalogue: CatalogueConfig::for_precision(precision),
            lyapunov: false,
        }
    }

    /// Checks the parameters, the stepper and the tolerances; errors name the option
    /// and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.params.validate()?;
        self.stepper.validate()?;
        self.catalogue.validate()
    }

    /// Whether the lanes exit early (`crate::early`): asked for (`early_exit_streak` >
    /// 0). With lambda_1 the lanes that run whole give it (a study that needs every
    /// lane's, a basin's lambda_1 map, runs without: `BasinSpec::early_exit`).
    pub fn early_exit(&self) -> bool {
        self.stepper.early_exit_streak > 0
    }

    /// The ensemble of one parameter set `params` at one speed `omega`, a lane from each
    /// of `starts`, integrated with these settings' stepper and precision: what a basin
    /// grid and a continuation step integrate (one speed, many start states).
    pub fn ensemble_at(
        &self,
        params: Params,
        omega: f64,
        starts: impl IntoIterator<Item = State>,
        transient: u32,
        recorded: u32,
    ) -> EnsembleSpec {
        EnsembleSpec {
            param_sets: vec![params],
            lanes: starts
                .into_iter()
                .map(|x0| LaneSpec {
                    omega,
                    x0,
                    param_set: 0,
                })
                .collect(),
            transient,
            recorded,
            stepper: self.stepper,
            precision: self.precision,
        }
    }
}
