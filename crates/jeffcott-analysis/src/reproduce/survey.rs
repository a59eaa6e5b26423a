//! The survey at the article's speeds (seeded start states, full Lyapunov spectra) and the
//! sum rule the spectra are checked against.

use super::*;

/// The survey at the article's speeds and their full spectra, which the sections and
/// the summary table quote.
#[derive(Clone, Debug)]
pub struct Survey {
    /// Per article speed, the catalogue of the seeded start states (lambda_1 per lane).
    pub catalogues: Vec<Catalogue>,
    /// Wall time of the survey [s].
    pub seconds: f64,
    /// Per article speed, the full spectrum from the static equilibrium.
    pub spectra: Vec<Spectrum>,
    /// Wall time of the spectra [s].
    pub spectra_seconds: f64,
}

impl Survey {
    /// The catalogues of a survey ensemble ([`ReproduceSpec::survey`]) run with
    /// lambda_1: its lanes split per speed, each speed's lanes catalogued.
    pub fn catalogues(spec: &ReproduceSpec, res: &EnsembleResult) -> Vec<Catalogue> {
        let k = spec.preset.survey_ics as usize;
        let per_lane = res.recorded * jeffcott_core::model::STATE_DIM;
        ARTICLE_SPEEDS
            .iter()
            .enumerate()
            .map(|(i, &(omega, _))| {
                let lanes = i * k..(i + 1) * k;
                let sub = EnsembleResult {
                    poincare: res.poincare[lanes.start * per_lane..lanes.end * per_lane].to_vec(),
                    recorded: res.recorded,
                    final_state: res.final_state[lanes.clone()].to_vec(),
                    status: res.status[lanes.clone()].to_vec(),
                    counters: res.counters[lanes.clone()].to_vec(),
                    lambda1: res.lambda1.as_ref().map(|l| l[lanes.clone()].to_vec()),
                };
                catalogue_result(omega, &sub, sub.lambda1.as_deref(), &spec.catalogue)
            })
            .collect()
    }

    /// Runs the survey ensemble on `engine` (with lambda_1 per lane, so aperiodic
    /// attractors are told apart as quasiperiodic or chaotic) and catalogues it;
    /// `ctl.progress` counts lane-periods. Returns the catalogues and the wall time.
    pub fn run_survey(
        spec: &ReproduceSpec,
        engine: &crate::backend::Engine,
        ctl: Control,
    ) -> Result<(Vec<Catalogue>, f64)> {
        let t = std::time::Instant::now();
        let (res, _) = engine.run(&spec.survey(), true, ctl)?;
        Ok((Self::catalogues(spec, &res), t.elapsed().as_secs_f64()))
    }

    /// The full spectrum at each article speed from the static equilibrium (independent,
    /// in parallel). Returns the spectra and the wall time.
    pub fn run_spectra(spec: &ReproduceSpec) -> Result<(Vec<Spectrum>, f64)> {
        use rayon::prelude::*;
        let t = std::time::Instant::now();
        let cfg = spec.spectrum_config();
        let eq = spec.params.static_equilibrium();
        let spectra = ARTICLE_SPEEDS
            .par_iter()
            .map(|&(omega, _)| spectrum(&spec.params, omega, &eq, &cfg))
            .collect::<Result<Vec<_>>>()?;
        Ok((spectra, t.elapsed().as_secs_f64()))
    }

    /// The spectrum at `omega`, if it is an article speed.
    pub fn spectrum(&self, omega: f64) -> Option<&Spectrum> {
        self.spectra.iter().find(|s| s.omega == omega)
    }

    /// The class from the static equilibrium at `omega`, an aperiodic one refined by the
    /// full spectrum's lambda_1: quasiperiodic when |lambda_1| < `lambda_tol`, chaotic
    /// above.
    pub fn refine(&self, class: Class, omega: f64, lambda_tol: f64) -> Class {
        match (class, self.spectrum(omega).map(|s| s.exponents[0])) {
            (Class::Aperiodic, Some(l)) if l.abs() < lambda_tol => Class::Quasiperiodic,
            (Class::Aperiodic, Some(l)) if l > lambda_tol => Class::Chaotic,
            (c, _) => c,
        }
    }
}

/// The sum of the Lyapunov exponents for viscous damping with no saltation (S = I),
/// docs/model.md 6: -2 (2 xi_r w_r + 2 xi_s w_s) [1/s], each direction's damping once
/// where the supports differ by direction (docs/model.md 7; for an isotropic machine the
/// same bits, as doubling is exact).
pub fn sum_rule(p: &Params) -> f64 {
    let ((wrx, wry), (xrx, xry)) = (p.omega_r_xy(), p.xi_r_xy());
    let ((wsx, wsy), (xsx, xsy)) = (p.omega_s_xy(), p.xi_s_xy());
    let rotor = 2.0 * xrx * wrx + 2.0 * xry * wry;
    let stator = 2.0 * xsx * wsx + 2.0 * xsy * wsy;
    -(rotor + stator)
}
