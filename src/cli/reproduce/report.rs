//! REPORT.md of `jeffcott reproduce`: the report being written, its wording (summary,
//! spectra table, commands, what each sweep found) and writing it out.

use crate::cli::basin::legend_name;
use jeffcott_analysis::catalogue::Catalogue;
use jeffcott_analysis::reproduce::{
    ArticleComparison, BIT, Floquet, FloquetRow, Preset, ReproduceResult, ReproduceSpec,
    SweepCounts, article_comparison, sum_rule, summary_rows,
};
use jeffcott_core::error::Result;
use jeffcott_core::lyapunov::Spectrum;
use jeffcott_core::model::Params;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// REPORT.md as it is written: the figures' sections in order, and the start time.
pub(super) struct Report {
    pub(super) text: String,
    pub(super) started: Instant,
}

impl Report {
    pub(super) fn figure(
        &mut self,
        title: &str,
        file: &str,
        found: &str,
        command: &str,
        seconds: f64,
    ) {
        let _ = write!(
            self.text,
            "## {title}\n\n![{title}]({file})\n\n{found}\n\nCommand: `{command}`  \nTime: {seconds:.1} s\n\n"
        );
    }

    /// Writes REPORT.md into `dir`: the title, the summary table at the article's speeds,
    /// the spectra table, the survey note, the article's spectra and the Floquet spectra
    /// on top of the figures' sections.
    pub(super) fn write(
        &self,
        dir: &Path,
        spec: &ReproduceSpec,
        result: &ReproduceResult,
        mode: &str,
        backend: &str,
        total_s: f64,
    ) -> Result<()> {
        let ReproduceResult {
            survey,
            static_class,
            floquet,
        } = result;
        let (p, cfg) = (&spec.preset, &spec.catalogue);
        let mut head = String::new();
        let _ = write!(
            head,
            "# jeffcott reproduce {mode}\n\nThe figure set of \"Nonlinear Dynamics and Chaos of a Nonsmooth Rotor-Stator System\" (Mathematical Problems in Engineering, 2017), regenerated with `jeffcott` {} (Table 1 parameters, the corrected model of docs/model.md). Ensembles on backend `{backend}`, {:?}; {} CPU threads. Total time {:.1} s.\n\n",
            env!("CARGO_PKG_VERSION"),
            spec.precision,
            rayon::current_num_threads(),
            total_s
        );
        head += "## Summary at the article's speeds\n\n| W [rad/s] | article | from the static equilibrium | lambda_1 [1/s] (full spectrum) | survey of seeded start states |\n|---|---|---|---|---|\n";
        for row in summary_rows(survey, static_class) {
            let _ = writeln!(
                head,
                "| {} | {} | {} | {} | {} |",
                row.omega,
                row.article,
                row.static_class.map_or("-".to_string(), |c| c.label()),
                l1_text(row.spectrum),
                describe(row.survey)
            );
        }
        head += &spectra_table(
            &survey.spectra,
            &spec.params,
            survey.spectra_seconds,
            &spectrum_cmd(spec),
        );
        let _ = write!(
            head,
            "\nSurvey: {} start states per speed (static equilibrium + seeded random rotor states within the gap), {} transient and {} recorded periods ({}; {:.1} s). Classification: period-n up to n = 32 with tolerances relative to the attractor size; otherwise quasiperiodic (|lambda_1| < {} 1/s) or chaotic (lambda_1 above), lambda_1 per lane from one tangent vector over the recorded periods (attractor entries show the mean over their lanes).\n\n",
            p.survey_ics,
            p.survey_transient,
            p.survey_periods,
            survey_cmd(p, 0.0).replace("--omega 0 ", "--omega W "),
            survey.seconds,
            cfg.lambda_tol
        );
        head += &article_table(&article_comparison(survey), sum_rule(&spec.params));
        head += &floquet_table(floquet);
        let text = head + &self.text;
        jeffcott_analysis::output::write_atomically(&dir.join("REPORT.md"), |w| {
            std::io::Write::write_all(w, text.as_bytes())
        })
    }
}

/// One line naming the attractors of a catalogue (and the diverged fraction).
pub(super) fn describe(cat: &Catalogue) -> String {
    let list: Vec<String> = cat.attractors.iter().map(legend_name).collect();
    let mut s = format!(
        "{} attractor{} from {} start states: {}",
        cat.attractors.len(),
        if cat.attractors.len() == 1 { "" } else { "s" },
        cat.lanes,
        list.join("; ")
    );
    if cat.diverged > 0 {
        let _ = write!(s, "; {:.1} % diverged", 100.0 * cat.diverged_fraction);
    }
    s
}

/// The "Lyapunov spectra" section of REPORT.md: all eight exponents with their error
/// estimates, the sum against the sum rule, the accumulation time.
pub(super) fn spectra_table(
    spectra: &[Spectrum],
    params: &Params,
    seconds: f64,
    cmd: &str,
) -> String {
    let rule = sum_rule(params);
    let mut t = format!(
        "\n## Lyapunov spectra at the article's speeds\n\nAll eight exponents [1/s] from the static equilibrium (`lyapunov::spectrum`: eight tangent vectors with the state, saltation at every contact switch, QR every period), each +- its error estimate (the larger of the batch-means standard error and the change over the last window). Sum rule (docs/model.md 6): the exponents sum to {rule:.2} 1/s. Command: `{cmd}`; the five spectra took {seconds:.1} s in all (in parallel).\n\n"
    );
    t += &exponent_columns(
        &["W [rad/s]"],
        &[
            &format!("sum (rule {rule:.1})"),
            "accumulated [s]",
            "stop",
            "wall [s]",
        ],
    );
    for s in spectra {
        let _ = write!(t, "| {} |", s.omega);
        for (e, err) in s.exponents.iter().zip(&s.errors) {
            let _ = write!(t, " {e:.3} +- {err:.3} |");
        }
        let _ = writeln!(
            t,
            " {:.2} ({:+.3} %) | {:.1} ({} periods) | {:?} | {:.1} |",
            s.sum,
            100.0 * (s.sum - rule) / rule.abs(),
            s.integration_time,
            s.periods,
            s.stop,
            s.wall_time_s
        );
    }
    t + "\n"
}

/// The header and separator of a table whose columns are `first`, lambda_1 .. lambda_8
/// and `last`.
fn exponent_columns(first: &[&str], last: &[&str]) -> String {
    let lambdas = (1..=8).map(|i| format!("lambda_{i}"));
    let cols: Vec<String> = first
        .iter()
        .map(|c| c.to_string())
        .chain(lambdas)
        .chain(last.iter().map(|c| c.to_string()))
        .collect();
    format!("| {} |\n|{}\n", cols.join(" | "), "---|".repeat(cols.len()))
}

/// The section setting the article's spectra beside jeffcott's at the same speeds: the
/// article's as printed (bits/s) and in 1/s, jeffcott's in bits/s, each sum against the
/// trace rule `rule` [1/s].
pub(super) fn article_table(rows: &[ArticleComparison], rule: f64) -> String {
    let mut t = format!(
        "## The article's Lyapunov spectra beside jeffcott's\n\nThe article prints its spectra at 135 and 140 rad/s in bits/s (base-2 rates): 1 bit/s = ln 2 1/s = {BIT:.3} 1/s. Its exponents are shown as printed and times ln 2, jeffcott's (the table above, by decreasing value, +- its error) divided by ln 2; the sums check the trace rule, {rule:.2} 1/s = {:.2} bits/s.\n\n",
        rule / BIT
    );
    t += &exponent_columns(&["W [rad/s]", "spectrum"], &["sum", "sum against the rule"]);
    let against = |sum: f64| format!("{:+.2} %", 100.0 * (sum - rule) / rule.abs());
    for r in rows {
        let w = r.article.omega;
        let cells = |v: &[f64], prec: usize| -> String {
            v.iter().map(|x| format!(" {x:.prec$} |")).collect()
        };
        let _ = writeln!(
            t,
            "| {w} | article, as printed [bits/s] |{} {:.1} | |",
            cells(&r.article.bits, 1),
            r.article.sum_bits
        );
        let _ = writeln!(
            t,
            "| {w} | article x ln 2 [1/s] |{} {:.2} | {} |",
            cells(&r.article_per_s, 3),
            r.article_sum_per_s,
            against(r.article_sum_per_s)
        );
        match &r.jeffcott {
            Some(j) => {
                let _ = write!(t, "| {w} | jeffcott / ln 2 [bits/s] |");
                for (e, err) in j.exponents.iter().zip(&j.errors) {
                    let _ = write!(t, " {e:.2} +- {err:.2} |");
                }
                let _ = writeln!(t, " {:.2} | {} |", j.sum, against(j.sum * BIT));
            }
            None => {
                let _ = writeln!(
                    t,
                    "| {w} | jeffcott: no spectrum at this speed in this run |{} - | - |",
                    " - |".repeat(8)
                );
            }
        }
    }
    t + "\n"
}

/// The section setting the Floquet spectra of the periodic responses beside their QR
/// spectra: per speed the orbit, its exponents, the QR exponents and the difference in
/// QR error bars; a failed shot says why in its row.
pub(super) fn floquet_table(f: &Floquet) -> String {
    let mut t = format!(
        "## Floquet spectra of the periodic responses\n\nWhere the response from the static equilibrium is periodic (period n forcing periods T), its orbit is shot by Newton on P^n(x) - x (`orbit::shoot`, tolerance {:e} m, at most {} iterations; the spectrum's parameters and stepper) from the state where the spectrum ended (on the attractor, at t = kT), and its Floquet exponents ln|mu| / (nT) [1/s] (mu: the monodromy matrix's eigenvalues) are set beside the QR exponents of the table above, both by decreasing value, with their difference in 1/s and in units of the QR error (where a QR estimate has settled to roundoff, an error of ~1e-12 1/s, the quotient of a negligible difference is large). A periodic orbit's Lyapunov exponents are its Floquet exponents, so the two routes check each other (a complex pair's two QR exponents straddle their common real part until the pair's rotation averages out). Shooting took {:.1} s.\n\n",
        f.config.tol, f.config.max_iter, f.seconds
    );
    if !f.skipped.is_empty() {
        let list: Vec<String> = f
            .skipped
            .iter()
            .map(|(w, c)| format!("{w} ({})", c.map_or("not classified".into(), |c| c.label())))
            .collect();
        let _ = write!(
            t,
            "Not periodic from the static equilibrium, so no orbit shot: {}.\n\n",
            list.join(", ")
        );
    }
    if f.rows.is_empty() {
        return t + "No periodic response at these speeds.\n\n";
    }
    t += &exponent_columns(&["W [rad/s]", "orbit", "exponents"], &["sum"]);
    for r in &f.rows {
        t += &floquet_rows(r);
    }
    t + "\n"
}

/// The rows of one speed of the Floquet table: the orbit's exponents, the QR exponents
/// and their difference, or the failure.
fn floquet_rows(r: &FloquetRow) -> String {
    let w = r.omega;
    let orbit = match &r.orbit {
        Ok(o) => o,
        Err(e) => {
            let msg = e.replace('|', "\\|").replace('\n', " ");
            return format!(
                "| {w} | period {}: shooting failed: {msg} | - |{} - |\n",
                r.period,
                " - |".repeat(8)
            );
        }
    };
    let exponents = orbit.exponents();
    let differences = r.differences().unwrap_or_default();
    let deviations = r.deviations().unwrap_or_default();
    let contact = if orbit.min_clearance < 0.0 {
        format!(
            "in contact (deepest penetration {:.2e} m)",
            -orbit.min_clearance
        )
    } else {
        format!("no contact (least clearance {:.2e} m)", orbit.min_clearance)
    };
    let mut t = format!(
        "| {w} | period {}, {} (largest \\|mu\\| {:.4}), {contact}, {} Newton iterations, residual {:.1e} m | Floquet [1/s] |",
        r.period,
        if orbit.stable() { "stable" } else { "unstable" },
        orbit.max_multiplier(),
        orbit.iterations,
        orbit.residual
    );
    for e in &exponents {
        let _ = write!(t, " {e:.3} |");
    }
    let _ = write!(
        t,
        " {:.2} |\n| {w} | | QR [1/s] |",
        exponents.iter().sum::<f64>()
    );
    for (q, err) in r.qr.iter().zip(&r.qr_errors) {
        let _ = write!(t, " {q:.3} +- {err:.3} |");
    }
    let _ = write!(
        t,
        " {:.2} |\n| {w} | | Floquet - QR [1/s] |",
        r.qr.iter().sum::<f64>()
    );
    for d in &differences {
        let _ = write!(t, " {} |", signed(*d));
    }
    let _ = write!(t, " |\n| {w} | | (Floquet - QR) / error |");
    for d in &deviations {
        if d.is_finite() {
            let _ = write!(t, " {d:+.1} |");
        } else {
            let _ = write!(t, " - |");
        }
    }
    t + " |\n"
}

/// A difference with its sign: three decimals, or two digits in exponent notation below
/// 1e-3 (where the two routes agree to roundoff).
fn signed(d: f64) -> String {
    if d == 0.0 || d.abs() >= 1e-3 {
        format!("{d:+.3}")
    } else {
        format!("{d:+.1e}")
    }
}

/// The command behind the full spectra.
pub(super) fn spectrum_cmd(spec: &ReproduceSpec) -> String {
    let scfg = spec.spectrum_config();
    format!(
        "jeffcott lyapunov --omega W --transient {} --min-time {} --time {}",
        scfg.transient, scfg.min_time, scfg.max_time
    )
}

/// lambda_1 of a full spectrum with its error ("-" without one).
pub(super) fn l1_text(s: Option<&Spectrum>) -> String {
    s.map_or("-".into(), |s| {
        format!("{:.3} +- {:.3} 1/s", s.exponents[0], s.errors[0])
    })
}

/// The command behind the survey at speed `w`.
pub(super) fn survey_cmd(p: &Preset, w: f64) -> String {
    format!(
        "jeffcott ensemble --omega {w} --lyapunov --transient {} --periods {} (x {} seeded start states)",
        p.survey_transient, p.survey_periods, p.survey_ics
    )
}

/// What a sweep found: how many speeds are period-1, periodic, aperiodic (quasiperiodic,
/// chaotic) and diverged.
pub(super) fn sweep_found(sw: &[jeffcott_analysis::bifurcation::SweepPoint]) -> String {
    let n = SweepCounts::of(sw);
    format!(
        "{} of {} speeds period-1, {} periodic with period > 1, {} aperiodic (no period up to 32: {} quasiperiodic, {} chaotic by lambda_1), {} diverged",
        n.period1, n.speeds, n.higher_period, n.aperiodic, n.quasiperiodic, n.chaotic, n.diverged
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use jeffcott_analysis::classify::Class;

    #[test]
    fn a_failed_shot_is_one_row_of_the_floquet_table_saying_why_and_the_rest_is_named() {
        let f = Floquet {
            rows: vec![FloquetRow {
                omega: 133.0,
                period: 5,
                orbit: Err("Newton stopped | at\nresidual 1e-3".into()),
                qr: [0.0; 8],
                qr_errors: [1.0; 8],
            }],
            skipped: vec![(135.0, Some(Class::Quasiperiodic)), (140.0, None)],
            config: Default::default(),
            seconds: 0.0,
        };
        let t = floquet_table(&f);
        assert!(
            t.contains("no orbit shot: 135 (quasiperiodic), 140 (not classified)."),
            "{t}"
        );
        let rows: Vec<&str> = t.lines().filter(|l| l.starts_with("| 133 |")).collect();
        let [row] = rows[..] else {
            panic!("one row at 133: {t}")
        };
        assert!(
            row.contains("period 5: shooting failed: Newton stopped \\| at residual 1e-3"),
            "{row}"
        );
        // As many cells as the header: the message's own bar is escaped.
        let cells = |l: &str| l.replace("\\|", "").matches('|').count();
        let header = t.lines().find(|l| l.starts_with("| W [rad/s] |")).unwrap();
        assert_eq!(cells(row), cells(header), "{row}");
    }
}
