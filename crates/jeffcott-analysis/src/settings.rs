//! What every lane study shares (MODEL.md 4-5): the model parameters, how a lane is
//! integrated (stepper, precision, backend), how its Poincare records are classified,
//! and whether its largest Lyapunov exponent is computed. Each study's spec holds one
//! [`LaneSettings`], flattened: run.json keeps its flat keys (`params`, `stepper`, ...).

use crate::catalogue::CatalogueConfig;
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::Params;
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
}
