//! Smooth or fractal: the verdict on a boundary from its entropy and uncertainty
//! exponent, with the criteria that fired.

use super::{
    ALPHA_RESOLUTION, BasinEntropy, BoxCountingDimension, LabelGrid, SMOOTH_ALPHA_BAND,
    UncertaintyExponent, basin_entropy, boundary_box_dimension, uncertainty_exponent,
};
use jeffcott_core::error::Result;
use serde::Serialize;

/// What a boundary is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundaryKind {
    /// One label: nothing to classify.
    NoBoundary,
    /// alpha within [`SMOOTH_ALPHA_BAND`] of 1 and S_bb <= ln 2.
    Smooth,
    /// S_bb > ln 2, or alpha clearly below 1.
    Fractal,
    /// Neither test is conclusive (e.g. alpha unavailable or between the bands).
    Undetermined,
}

impl BoundaryKind {
    /// The verdict in words, as the basin's summary line says it.
    pub fn words(self) -> &'static str {
        match self {
            BoundaryKind::NoBoundary => "no boundary",
            BoundaryKind::Smooth => "boundary smooth",
            BoundaryKind::Fractal => "boundary fractal",
            BoundaryKind::Undetermined => "boundary undetermined",
        }
    }
}

/// A boundary's class with the evidence.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoundaryClassification {
    /// The verdict.
    pub kind: BoundaryKind,
    /// Which criteria fired, in words.
    pub criteria: Vec<String>,
    /// S_bb > ln 2 fired.
    pub sbb_above_ln2: bool,
    /// alpha < 1 - max(2 se, [`ALPHA_RESOLUTION`]) fired (D clearly above 1).
    pub alpha_below_one: bool,
    /// |alpha - 1| <= [`SMOOTH_ALPHA_BAND`].
    pub alpha_near_one: bool,
    /// The basin entropy used.
    pub entropy: BasinEntropy,
    /// The uncertainty exponent used.
    pub uncertainty: UncertaintyExponent,
    /// The box-counting dimension (reported, not used in the verdict).
    pub box_counting: Option<BoxCountingDimension>,
}

/// Smooth or fractal from measures already computed.
///
/// Fractal when S_bb > ln 2 (sufficient, Daza et al. 2016) or when D = 2 - alpha exceeds
/// 1 by more than two standard errors *and* by more than [`ALPHA_RESOLUTION`] (the
/// grid's own systematic error on alpha; the fit's standard error alone is too small to
/// trust). Smooth when alpha is within [`SMOOTH_ALPHA_BAND`] of 1 and S_bb <= ln 2.
/// Fractal evidence wins when both fire (possible for alpha in [0.90, 0.95)).
pub fn classify_measures(
    entropy: &BasinEntropy,
    uncertainty: &UncertaintyExponent,
    box_counting: Option<&BoxCountingDimension>,
) -> BoundaryClassification {
    let ln2 = std::f64::consts::LN_2;
    let mut criteria = Vec::new();
    let sbb_above_ln2 = entropy.fractal_by_sbb;
    let (mut alpha_below_one, mut alpha_near_one) = (false, false);
    if let Some(s) = entropy.s_bb {
        criteria.push(if sbb_above_ln2 {
            format!(
                "S_bb = {s:.4} > ln 2 = {ln2:.4} (eps = {}): fractal",
                entropy.eps
            )
        } else {
            format!(
                "S_bb = {s:.4} <= ln 2 (eps = {}): not conclusive alone",
                entropy.eps
            )
        });
    }
    match uncertainty.fit {
        Some(fit) => {
            let (alpha, se) = (fit.slope, fit.slope_std_error);
            alpha_below_one = alpha < 1.0 - (2.0 * se).max(ALPHA_RESOLUTION);
            alpha_near_one = (alpha - 1.0).abs() <= SMOOTH_ALPHA_BAND;
            criteria.push(format!(
                "alpha = {alpha:.4} +- {se:.4} (D = {:.4}, eps {}..{}){}",
                fit.dimension,
                fit.eps_min,
                fit.eps_max,
                if alpha_below_one {
                    ": D > 1 beyond 2 standard errors and the grid's resolution, fractal"
                } else if alpha_near_one {
                    ": within 0.1 of 1, smooth-like"
                } else {
                    ": neither clearly below 1 nor within 0.1 of it"
                }
            ));
        }
        None => criteria.push(format!(
            "alpha: not fitted ({})",
            uncertainty.not_fitted.as_deref().unwrap_or("unknown")
        )),
    }
    let kind = if uncertainty.boundary_cells == 0 {
        criteria.push("no cell has a neighbour of another label".into());
        BoundaryKind::NoBoundary
    } else if sbb_above_ln2 || alpha_below_one {
        BoundaryKind::Fractal
    } else if alpha_near_one {
        BoundaryKind::Smooth
    } else {
        BoundaryKind::Undetermined
    };
    BoundaryClassification {
        kind,
        criteria,
        sbb_above_ln2,
        alpha_below_one,
        alpha_near_one,
        entropy: entropy.clone(),
        uncertainty: uncertainty.clone(),
        box_counting: box_counting.cloned(),
    }
}

/// Computes the basin entropy (boxes of `eps` cells), the uncertainty exponent and the
/// box-counting dimension, and classifies the boundary by [`classify_measures`].
pub fn classify_boundary(grid: &LabelGrid, eps: usize) -> Result<BoundaryClassification> {
    let entropy = basin_entropy(grid, eps)?;
    let uncertainty = uncertainty_exponent(grid);
    let boxes = boundary_box_dimension(grid);
    Ok(classify_measures(&entropy, &uncertainty, Some(&boxes)))
}
