//! What REPORT.md sets beside jeffcott's QR spectra at the article's speeds: the
//! article's own spectra ([`ARTICLE_SPECTRA`], printed in bits/s), and,
//! where the response from the static equilibrium is periodic, the Floquet spectrum of
//! its orbit shot by Newton. A periodic orbit's Lyapunov exponents are its Floquet
//! exponents ln|mu| / (nT), so the QR average over thousands of periods and the
//! eigenvalues of one period's monodromy matrix check each other.

use super::*;
use jeffcott_core::model::STATE_DIM;
use jeffcott_core::orbit::{CpuFlows, Orbit, ShootConfig, Start, shoot_many};

/// 1 bit/s in 1/s: ln 2 = 0.693. The article's exponents are base-2 rates.
pub const BIT: f64 = std::f64::consts::LN_2;

/// A spectrum's exponents by decreasing value, each with its error [1/s]. The QR
/// columns come out descending only once the vectors have aligned, and a complex pair's
/// two exponents straddle their common real part, so they may come swapped; the article
/// and the Floquet exponents are sorted.
pub fn sorted(s: &Spectrum) -> ([f64; STATE_DIM], [f64; STATE_DIM]) {
    let mut pairs: Vec<(f64, f64)> = s.exponents.iter().copied().zip(s.errors).collect();
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
    (
        std::array::from_fn(|i| pairs[i].0),
        std::array::from_fn(|i| pairs[i].1),
    )
}

/// jeffcott's QR spectrum at one speed in bits/s (divided by ln 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InBits {
    /// The exponents by decreasing value [bits/s].
    pub exponents: [f64; STATE_DIM],
    /// Their errors [bits/s].
    pub errors: [f64; STATE_DIM],
    /// Their sum [bits/s].
    pub sum: f64,
}

impl InBits {
    /// Spectrum `s` in bits/s, sorted.
    pub fn of(s: &Spectrum) -> Self {
        let (e, err) = sorted(s);
        InBits {
            exponents: e.map(|v| v / BIT),
            errors: err.map(|v| v / BIT),
            sum: s.sum / BIT,
        }
    }
}

/// The article's spectrum at one speed beside jeffcott's there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArticleComparison {
    /// The article's spectrum, as printed [bits/s].
    pub article: ArticleSpectrum,
    /// The same in 1/s (times ln 2).
    pub article_per_s: [f64; STATE_DIM],
    /// The sum of the eight as printed, in 1/s: what the trace rule checks.
    pub article_sum_per_s: f64,
    /// jeffcott's spectrum at the same speed in bits/s; none where this run computed no
    /// spectrum there.
    pub jeffcott: Option<InBits>,
}

/// The article's spectra ([`ARTICLE_SPECTRA`]) beside `survey`'s at the same speeds.
pub fn article_comparison(survey: &Survey) -> Vec<ArticleComparison> {
    ARTICLE_SPECTRA
        .iter()
        .map(|&article| {
            let article_per_s = article.bits.map(|v| v * BIT);
            ArticleComparison {
                article,
                article_per_s,
                article_sum_per_s: article_per_s.iter().sum(),
                jeffcott: survey.spectrum(article.omega).map(InBits::of),
            }
        })
        .collect()
}

/// The Floquet spectrum of the periodic response from the static equilibrium at one
/// speed, beside the QR spectrum there.
#[derive(Clone, Debug)]
pub struct FloquetRow {
    /// Rotor speed [rad/s].
    pub omega: f64,
    /// The response's period [forcing periods].
    pub period: u32,
    /// The orbit shot from where the QR spectrum ended, or why shooting failed (the
    /// error's message).
    pub orbit: std::result::Result<Orbit, String>,
    /// The QR spectrum's exponents by decreasing value [1/s].
    pub qr: [f64; STATE_DIM],
    /// Their errors [1/s].
    pub qr_errors: [f64; STATE_DIM],
}

impl FloquetRow {
    /// The orbit's Floquet exponents ln|mu| / (nT) [1/s], by decreasing value (none
    /// where shooting failed).
    pub fn exponents(&self) -> Option<Vec<f64>> {
        self.orbit.as_ref().ok().map(Orbit::exponents)
    }

    /// Floquet minus QR per exponent [1/s] (none where shooting failed).
    pub fn differences(&self) -> Option<Vec<f64>> {
        self.exponents()
            .map(|f| f.iter().zip(&self.qr).map(|(f, q)| f - q).collect())
    }

    /// Floquet minus QR in units of the QR error, per exponent (infinite or NaN where
    /// the error is 0; none where shooting failed). An exponent whose QR estimate has
    /// settled to roundoff (an error of 1e-12 1/s) gives a large quotient of a
    /// negligible difference, so the report shows [`FloquetRow::differences`] too.
    pub fn deviations(&self) -> Option<Vec<f64>> {
        self.differences()
            .map(|d| d.iter().zip(&self.qr_errors).map(|(d, e)| d / e).collect())
    }
}

/// The Floquet spectra at the speeds of the spectra table: a row per periodic response,
/// and the speeds passed over.
#[derive(Clone, Debug)]
pub struct Floquet {
    /// One row per speed whose response from the static equilibrium is periodic.
    pub rows: Vec<FloquetRow>,
    /// The other speeds and their class (none where the run classified nothing there).
    pub skipped: Vec<(f64, Option<Class>)>,
    /// How the orbits were shot.
    pub config: ShootConfig,
    /// Wall time of the shooting [s].
    pub seconds: f64,
}

/// Shoots the periodic orbit at every speed of `survey`'s spectra whose response from
/// the static equilibrium is periodic (`static_class`: speed, class), with the period
/// found there. The start is the state where the spectrum ended: on the attractor the
/// QR exponents describe, at t = kT (the forcing's phase 0, as shooting wants). The
/// model parameters and the stepper are the spectrum's, so both routes see the same
/// discrete map. All the orbits are shot at once (`orbit::shoot_many`: each as it
/// would be alone). A speed where shooting fails gets its error's message in its row.
pub fn floquet(spec: &ReproduceSpec, survey: &Survey, static_class: &[(f64, Class)]) -> Floquet {
    let t = std::time::Instant::now();
    let cfg = ShootConfig {
        stepper: spec.spectrum_config().stepper,
        ..ShootConfig::default()
    };
    let (mut periodic, mut skipped) = (Vec::new(), Vec::new());
    for s in &survey.spectra {
        let class = static_class
            .iter()
            .find(|(w, _)| *w == s.omega)
            .map(|&(_, c)| c);
        match class.and_then(|c| c.period()) {
            Some(n) => periodic.push((s, n as u32)),
            None => skipped.push((s.omega, class)),
        }
    }
    let starts: Vec<Start> = periodic
        .iter()
        .map(|&(s, period)| Start {
            params: spec.params.clone(),
            omega: s.omega,
            x0: s.final_state,
            period,
        })
        .collect();
    // (Refused as a whole only for a period out of range: every row says so.)
    let orbits: Vec<std::result::Result<Orbit, String>> = match shoot_many(&CpuFlows, &starts, &cfg)
    {
        Ok(all) => all
            .into_iter()
            .map(|o| o.map_err(|e| e.to_string()))
            .collect(),
        Err(e) => vec![Err(e.to_string()); starts.len()],
    };
    let rows = periodic
        .iter()
        .zip(orbits)
        .map(|(&(s, period), orbit)| {
            let (qr, qr_errors) = sorted(s);
            FloquetRow {
                omega: s.omega,
                period,
                orbit,
                qr,
                qr_errors,
            }
        })
        .collect();
    Floquet {
        rows,
        skipped,
        config: cfg,
        seconds: t.elapsed().as_secs_f64(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_articles_sums_are_its_exponents_sums_and_in_1_per_s_the_trace_rule() {
        // The printed sums are the printed exponents' sums to the printing's rounding,
        // and times ln 2 they are the trace rule (-119.2 1/s): the article's unit is
        // bits/s. Eight exponents rounded to 0.05 bits/s each move the sum by 0.4 bits/s
        // = 0.28 1/s at most; the article's own sums stray a little further (its QR
        // spectrum's sum is no exact invariant): 0.40 and 0.19 1/s.
        let rule = sum_rule(&Params::default());
        assert!((rule + 119.2).abs() < 1e-9, "{rule}");
        for a in ARTICLE_SPECTRA {
            let sum: f64 = a.bits.iter().sum();
            assert!((sum - a.sum_bits).abs() < 0.05, "{}: {sum}", a.omega);
            assert!(a.bits.windows(2).all(|w| w[0] >= w[1]), "decreasing");
            let per_s = a.sum_bits * BIT;
            assert!((per_s - rule).abs() < 0.45, "{}: {per_s} 1/s", a.omega);
            // Read as 1/s, the printed spectrum would miss the rule by 52 1/s.
            assert!((a.sum_bits - rule).abs() > 50.0);
        }
        assert_eq!(
            ARTICLE_SPECTRA.map(|a| a.omega),
            [ARTICLE_SPEEDS[3].0, ARTICLE_SPEEDS[4].0]
        );
    }

    /// The spectrum from the static equilibrium at `omega` as the quick set computes it.
    fn quick_spectrum(omega: f64) -> (ReproduceSpec, Spectrum) {
        let spec = ReproduceSpec::new(QUICK, Backend::Cpu, Precision::F64);
        let eq = spec.params.static_equilibrium();
        let s = spectrum(&spec.params, omega, &eq, &spec.spectrum_config()).unwrap();
        (spec, s)
    }

    fn survey_of(spectra: Vec<Spectrum>) -> Survey {
        Survey {
            catalogues: Vec::new(),
            seconds: 0.0,
            spectra,
            spectra_seconds: 0.0,
        }
    }

    #[test]
    fn the_reported_floquet_exponents_are_the_orbits_ln_mu_over_nt_and_at_131_7_the_qr_spectrum() {
        // 131.7 rad/s: period-1 with contact; 132.2 rad/s: period-2, where a divisor T
        // instead of nT would double every exponent (and break the trace rule).
        for (w, n) in [(131.7, 1), (132.2, 2)] {
            let (spec, s) = quick_spectrum(w);
            let survey = survey_of(vec![s.clone()]);
            let f = floquet(&spec, &survey, &[(w, Class::Periodic(n))]);
            assert!(f.skipped.is_empty());
            let [row] = &f.rows[..] else {
                panic!("one row: {:?}", f.rows)
            };
            assert_eq!((row.omega, row.period), (w, n as u32));
            let orbit = row.orbit.as_ref().unwrap();
            assert_eq!(orbit.period, n as u32);
            assert!(
                orbit.stable() && orbit.min_clearance < 0.0,
                "{w}: a rubbing attractor"
            );
            // ln|mu| / (nT) straight from the multipliers, T = 2 pi / W.
            let nt = n as f64 * std::f64::consts::TAU / w;
            let mut want: Vec<f64> = orbit
                .multipliers
                .iter()
                .map(|m| m.norm().ln() / nt)
                .collect();
            want.sort_by(|a, b| b.total_cmp(a));
            let got = row.exponents().unwrap();
            assert_eq!(got.len(), STATE_DIM);
            for (g, w) in got.iter().zip(&want) {
                assert!((g - w).abs() <= 1e-12 * w.abs(), "{got:?} vs {want:?}");
            }
            // Their sum is ln det M / (nT), the trace rule (det S = 1 at every switch).
            let sum: f64 = got.iter().sum();
            let rule = sum_rule(&spec.params);
            assert!(
                (sum - rule).abs() < 1e-5 * rule.abs(),
                "{w}: {sum} vs {rule}"
            );
            // The QR column is the spectrum's, sorted, and the deviations are the
            // differences in its error bars.
            let (qr, err) = sorted(&s);
            assert_eq!((row.qr, row.qr_errors), (qr, err));
            let dev = row.deviations().unwrap();
            eprintln!("{w}: Floquet {got:?}\nQR {qr:?}\n+- {err:?}\ndeviations {dev:?}");
            let diff = row.differences().unwrap();
            for (k, d) in dev.iter().enumerate() {
                assert_eq!(diff[k], got[k] - qr[k]);
                assert_eq!(*d, diff[k] / err[k]);
                // At 131.7 within three error bars (tests/orbits.rs, with the default
                // spectrum); at 132.2 some QR errors are ~1e-4 1/s, below the
                // difference of the long average and one period's eigenvalues.
                assert!(
                    n > 1 || d.abs() <= 3.0,
                    "exponent {k}: {d} error bars ({got:?} vs {qr:?})"
                );
            }
            // In bits/s beside the article: the same spectrum divided by ln 2.
            let bits = InBits::of(&s);
            assert!((bits.sum * BIT - s.sum).abs() < 1e-12);
            for (b, q) in bits.exponents.iter().zip(&qr) {
                assert!(
                    (b * BIT - q).abs() <= 1e-12 * q.abs(),
                    "{b} bits/s vs {q} 1/s"
                );
            }
        }
    }

    #[test]
    fn a_speed_that_fails_to_shoot_says_why_and_an_aperiodic_one_is_passed_over() {
        let (spec, s) = quick_spectrum(131.7);
        let mut broken = s.clone();
        broken.final_state[0] = f64::NAN;
        let mut other = s;
        other.omega = 140.0;
        let survey = survey_of(vec![broken, other]);
        let f = floquet(
            &spec,
            &survey,
            &[(131.7, Class::Periodic(1)), (140.0, Class::Chaotic)],
        );
        assert_eq!(f.rows.len(), 1);
        let msg = f.rows[0].orbit.as_ref().unwrap_err();
        assert!(msg.contains("start"), "{msg}");
        let r = &f.rows[0];
        assert!(r.exponents().is_none() && r.differences().is_none());
        assert!(r.deviations().is_none());
        assert_eq!(f.skipped, [(140.0, Some(Class::Chaotic))]);
        // Without a class there (not simulated), nothing is shot either.
        let f = floquet(&spec, &survey, &[]);
        assert!(f.rows.is_empty());
        assert_eq!(f.skipped, [(131.7, None), (140.0, None)]);
        // The article's comparison has no jeffcott spectrum at 135 in this survey, and
        // the one at 140 (relabelled) in bits/s.
        let c = article_comparison(&survey);
        assert!(c[0].jeffcott.is_none());
        let j = c[1].jeffcott.unwrap();
        assert!((j.sum * BIT - survey.spectra[1].sum).abs() < 1e-12);
        assert!((c[1].article_sum_per_s - (-171.7 * BIT)).abs() < 0.05 * BIT);
    }
}
