//! REPORT.md of `jeffcott reproduce`: the report being written, its wording (summary,
//! spectra table, commands, what each sweep found) and writing it out.

use crate::cli::basin::legend_name;
use jeffcott_analysis::catalogue::Catalogue;
use jeffcott_analysis::reproduce::{
    Preset, ReproduceResult, ReproduceSpec, SweepCounts, sum_rule, summary_rows,
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
    /// the spectra table and the survey note on top of the figures' sections.
    pub(super) fn write(
        &self,
        dir: &Path,
        spec: &ReproduceSpec,
        result: &ReproduceResult,
        mode: &str,
        backend: &str,
    ) -> Result<()> {
        let ReproduceResult {
            survey,
            static_class,
        } = result;
        let (p, cfg) = (&spec.preset, &spec.catalogue);
        let mut head = String::new();
        let _ = write!(
            head,
            "# jeffcott reproduce {mode}\n\nThe figure set of \"Nonlinear Dynamics and Chaos of a Nonsmooth Rotor-Stator System\" (Mathematical Problems in Engineering, 2017), regenerated with `jeffcott` {} (Table 1 parameters, the corrected model of MODEL.md). Ensembles on backend `{backend}`, {:?}; {} CPU threads. Total time {:.1} s.\n\n",
            env!("CARGO_PKG_VERSION"),
            spec.precision,
            rayon::current_num_threads(),
            self.started.elapsed().as_secs_f64()
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
        "\n## Lyapunov spectra at the article's speeds\n\nAll eight exponents [1/s] from the static equilibrium (`lyapunov::spectrum`: eight tangent vectors with the state, saltation at every contact switch, QR every period), each +- its error estimate (the larger of the batch-means standard error and the change over the last window). Sum rule (MODEL.md 6): the exponents sum to {rule:.2} 1/s. Command: `{cmd}`; the five spectra took {seconds:.1} s in all (in parallel).\n\n| W [rad/s] | lambda_1 | lambda_2 | lambda_3 | lambda_4 | lambda_5 | lambda_6 | lambda_7 | lambda_8 | sum (rule {rule:.1}) | accumulated [s] | stop | wall [s] |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
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
