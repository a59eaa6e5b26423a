//! `jeffcott ensemble`: many independent lanes (one per rotor speed, or one per row of a
//! lane table) on the CPU or a GPU, run in work units committed to --out, then
//! poincare.npy, status.npy, lanes.npy, params.npy and lambda1.npy assembled from them.

use super::files::Documented;
use super::{LaneArgs, NoOptions, apply_init, check_start_within_bound, parse_assignment_lists};
use super::{rundir, study};
use clap::Args;
use jeffcott_analysis::defaults;
use jeffcott_analysis::ensemble::{EnsembleStudy, LanesRecord, Totals};
use jeffcott_analysis::output;
use jeffcott_analysis::record::Span;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{Params, STATE_DIM, State};
use std::path::PathBuf;

/// Arguments of `jeffcott ensemble`.
#[derive(Args, Debug)]
pub struct EnsembleArgs {
    /// Rotor speeds: `a:b:n` is n speeds from a to b inclusive, evenly spaced, or one
    /// number [rad/s]. With --lanes: the speed of lanes whose table has no omega column.
    #[arg(
        long,
        value_name = "a:b:n",
        allow_hyphen_values = true,
        required_unless_present = "lanes"
    )]
    pub omega: Option<String>,
    /// Lanes from a table, one row each: a CSV file with a header, or a 2-D f64 .npy with
    /// --columns (a lanes.npy of an earlier run needs none; a params.npy beside it gives
    /// its param_set column's parameter sets). Columns: omega, any parameter key
    /// (omega_r, ..., phi0 and the machine variants' omega_rx, ..., alpha_c: docs/parameters.md),
    /// start coordinates (x_r, vx_r, ... or x_r0, ...), param_set. Absent columns take
    /// --omega, --config/--param and the static equilibrium with --init.
    #[arg(long, value_name = "FILE")]
    pub lanes: Option<PathBuf>,
    /// Column names of an .npy lane table, e.g. `--columns omega,mu,k_c`.
    #[arg(
        long,
        value_name = "NAME,...",
        value_delimiter = ',',
        requires = "lanes"
    )]
    pub columns: Option<Vec<String>>,
    /// Override coordinates of every lane's start state (default: static equilibrium),
    /// e.g. `--init x_r=0.005,vx_r=-0.5`.
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub init: Vec<String>,
    /// Forcing periods integrated and discarded.
    #[arg(long, default_value_t = defaults::ensemble::TRANSIENT, value_name = "Q")]
    pub transient: u32,
    /// Forcing periods recorded per lane.
    #[arg(long, default_value_t = defaults::ensemble::PERIODS, value_name = "P")]
    pub periods: u32,
    #[command(flatten)]
    pub lane: LaneArgs,
    #[command(flatten)]
    pub exec: rundir::StudyRunArgs,
    /// Also compute each lane's largest Lyapunov exponent lambda_1 [1/s] from a tangent
    /// vector renormalised every period (written to `lambda1.npy`).
    #[arg(long)]
    pub lyapunov: bool,
}

/// Final files of an ensemble (run.json aside).
pub(crate) const ENSEMBLE_OUTPUTS: &[&str] = &[
    "poincare.npy",
    "status.npy",
    "lanes.npy",
    "params.npy",
    "lambda1.npy",
];

/// The lanes of `jeffcott ensemble`: a speed range from one start state, or a table.
/// Returns the parameter sets, the lanes and what run.json records of them.
fn ensemble_lanes(
    a: &EnsembleArgs,
) -> Result<(
    Vec<Params>,
    Vec<jeffcott_core::ensemble::LaneSpec>,
    LanesRecord,
)> {
    use jeffcott_core::ensemble::LaneSpec;
    use jeffcott_core::ensemble::table::{
        LaneTable, TableDefaults, lanes_checksum, lanes_from_table, read_params_table,
    };
    let params = a.lane.model.params()?;
    let bound = a.lane.stepper.divergence_bound;
    if let Some(path) = &a.lanes {
        let table = LaneTable::read(path, a.columns.as_deref())?;
        jeffcott_core::limits::check_memory(
            "lanes",
            path.display(),
            jeffcott_core::ensemble::EnsembleSpec::memory_estimate_for(
                table.rows.len() as u64,
                a.periods as u64,
            ),
            &format!(
                "{} lanes x {} recorded periods",
                table.rows.len(),
                a.periods
            ),
            "use a shorter table or fewer --periods",
        )?;
        // A params.npy beside the table holds the sets its param_set column indexes.
        let beside = path.with_file_name("params.npy");
        let sets = if table.columns.iter().any(|c| c == "param_set") && beside.exists() {
            read_params_table(&beside)?
        } else {
            Vec::new()
        };
        table.refuse_set_by(
            "init",
            parse_assignment_lists("init", &a.init)?
                .iter()
                .map(|(n, _)| n.as_str()),
        )?;
        let overridden = a.lane.model.overridden()?;
        table.refuse_set_by("param", overridden.iter().map(String::as_str))?;
        let init = |x: &mut State| apply_init(x, &a.init);
        // --omega with a table: one speed for lanes without an omega column.
        let omega = match &a.omega {
            Some(text) => {
                let r = jeffcott_core::ensemble::RangeSpec::parse("omega", text)?;
                if r.n != 1 {
                    return Err(Error::invalid(
                        "omega",
                        text,
                        "with --lanes give one speed (for lanes without an omega column), not a range",
                    ));
                }
                Some(r.a)
            }
            None => None,
        };
        let (sets, lanes) = lanes_from_table(
            &table,
            &TableDefaults {
                params: &params,
                param_sets: &sets,
                omega,
                init: &init,
                divergence_bound: bound,
            },
        )?;
        let j = LanesRecord::Table {
            lanes: jeffcott_analysis::ensemble::TableRecord {
                table: path.display().to_string(),
                columns: table.columns,
                count: lanes.len(),
                checksum: lanes_checksum(&sets, &lanes),
            },
        };
        return Ok((sets, lanes, j));
    }
    let omega = a.omega.as_deref().unwrap_or_default();
    let mut x0 = params.static_equilibrium();
    apply_init(&mut x0, &a.init)?;
    check_start_within_bound("init", &x0, bound)?;
    let range = jeffcott_core::ensemble::RangeSpec::parse("omega", omega)?;
    jeffcott_core::ensemble::EnsembleSpec::check_size("omega", omega, range.len(), a.periods)?;
    let omegas = range.values();
    let j = LanesRecord::Range {
        omega: Span::of(&omegas),
        x0,
    };
    Ok((vec![params], LaneSpec::at_speeds(&omegas, x0), j))
}

/// Runs `jeffcott ensemble`: lanes in work units committed to --out, then the files
/// assembled from the units (poincare.npy streamed, one unit in memory at a time).
pub fn run_ensemble(a: &EnsembleArgs) -> Result<()> {
    jeffcott_core::limits::check_periods("transient", a.transient, 0)?;
    jeffcott_core::limits::check_periods("periods", a.periods, 1)?;
    let (param_sets, lanes, record) = ensemble_lanes(a)?;
    let spec = jeffcott_core::ensemble::EnsembleSpec {
        lanes,
        param_sets,
        transient: a.transient,
        recorded: a.periods,
        stepper: a.lane.stepper.config(),
        precision: a.lane.precision(),
    };
    spec.validate()?;
    let study = EnsembleStudy::of(spec, record, a.lyapunov, a.lane.backend);
    study::execute_args::<Ensemble>(&study, &NoOptions {}, &a.exec, a.lane.backend)
}

/// `jeffcott ensemble` as a study command.
pub struct Ensemble;

impl study::StudyCommand for Ensemble {
    const COMMAND: &'static str = "ensemble";
    const OUTPUTS: &'static [&'static str] = ENSEMBLE_OUTPUTS;
    type Spec = EnsembleStudy;
    type Write = NoOptions;
    /// How the run went, its wall time and the device set-up's part of it [s].
    type Outcome = (jeffcott_core::ensemble::RunInfo, f64, f64);
    fn run(
        study: &EnsembleStudy,
        _: &NoOptions,
        host: &rundir::CommandHost,
    ) -> Result<Self::Outcome> {
        let start = std::time::Instant::now();
        let engine = jeffcott_analysis::backend::Engine::new(study.backend, study.precision)?;
        let setup = start.elapsed().as_secs_f64();
        let info = jeffcott_analysis::ensemble::run(study, &engine, host)?;
        Ok((info, start.elapsed().as_secs_f64(), setup))
    }
    fn finish(
        study: &EnsembleStudy,
        _: &NoOptions,
        (info, elapsed, setup): Self::Outcome,
        run_dir: &jeffcott_analysis::run::RunDir,
        exec: &rundir::Execution,
    ) -> Result<()> {
        if !exec.run.quiet {
            println!(
                "backend: {} ({}; {}), precision {:?}",
                info.backend, info.device, info.reason, info.precision
            );
        }
        let info = jeffcott_core::ensemble::RunInfo {
            elapsed_s: elapsed,
            setup_s: setup,
            ..info
        };
        write_ensemble(study, &info, run_dir, exec.run.quiet)
    }
}

/// Writes an ensemble's files from its units (poincare.npy streamed, one unit in memory
/// at a time) and its record, marks the run complete and, unless `quiet`, says what ran.
fn write_ensemble(
    study: &EnsembleStudy,
    info: &jeffcott_core::ensemble::RunInfo,
    run_dir: &jeffcott_analysis::run::RunDir,
    quiet: bool,
) -> Result<()> {
    use jeffcott_analysis::ensemble::STAGE;
    let n = study.lane_count();
    let units = study.split().count();
    let dir = run_dir.path();
    output::write_npy_parts(
        &dir.join("poincare.npy"),
        &[n, study.periods as usize, STATE_DIM],
        (0..units).map(|u| Ok(run_dir.load(STAGE, u)?.f64s("poincare")?.to_vec())),
    )?;
    let mut codes: Vec<u32> = Vec::with_capacity(n);
    let mut lambda1: Vec<f64> = Vec::new();
    let mut lanes: Vec<f64> = Vec::with_capacity(n * (2 + STATE_DIM));
    let mut totals = Totals::default();
    for u in 0..units {
        let unit = run_dir.load(STAGE, u)?;
        codes.extend_from_slice(unit.u32s("status")?);
        match unit.f64s("lanes") {
            Ok(l) => lanes.extend_from_slice(l),
            // A unit of an earlier version, without its lanes: this run has them.
            Err(_) if study.given.len() == n => {
                let given = &study.given[study.split().range(u)];
                lanes.extend(jeffcott_analysis::ensemble::lanes_table(given));
            }
            Err(e) => return Err(e),
        }
        if study.lyapunov {
            lambda1.extend_from_slice(unit.f64s("lambda1")?);
        }
        totals.add(&unit.meta_as::<Totals>()?);
    }
    output::write_npy(&dir.join("status.npy"), &[n], &codes)?;
    output::write_npy(&dir.join("lanes.npy"), &[n, 2 + STATE_DIM], &lanes)?;
    output::write_npy(
        &dir.join("params.npy"),
        &[
            study.params.len(),
            jeffcott_core::ensemble::table::params_columns(&study.params).len(),
        ],
        &jeffcott_core::ensemble::table::params_table(&study.params),
    )?;
    if study.lyapunov {
        output::write_npy(&dir.join("lambda1.npy"), &[n], &lambda1)?;
    }
    let record = jeffcott_analysis::ensemble::run_record(study.sizes(), &totals, &codes, info);
    let run_json = Documented::new(
        &record,
        &[
            (
                "poincare.npy",
                "f64 [lanes, periods, 8], state order x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s",
            ),
            ("status.npy", "u32 [lanes], codes in status_codes"),
            ("lanes.npy", "f64 [lanes, 10], columns in lanes_columns"),
            (
                "lambda1.npy",
                "f64 [lanes], largest Lyapunov exponent [1/s] over the recorded periods (NaN for frozen lanes; only with --lyapunov)",
            ),
        ],
    );
    run_dir.finish(&run_json, &rundir::written(run_dir, ENSEMBLE_OUTPUTS))?;
    if !quiet {
        let s = record.status_counts;
        println!(
            "{n} lanes x {} periods in {:.2} s ({:.3e} lane-steps/s); status ok {}, refinement_cap {}, diverged {}, non_finite {}; files in {}",
            study.transient + study.periods,
            info.elapsed_s,
            totals.macro_steps as f64 / info.elapsed_s,
            s.ok,
            s.refinement_cap,
            s.diverged,
            s.non_finite,
            dir.display()
        );
    }
    Ok(())
}
