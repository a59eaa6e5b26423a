//! An orbits study as the front ends ask for it (`jeffcott orbits`, Python's
//! `orbits`, `reproduce`): the request checked into a study, and its run: settle and
//! continue one branch, or shoot an earlier result's periodic attractors at once and
//! continue a branch from each; the doubled branches when asked.

use super::{Branch, BranchSpec, Crossing, continue_branch, doubled_branch};
use crate::map::MapVar;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{Params, State};
use jeffcott_core::orbit::{Flows, ShootConfig, Start, Want, shoot_many};

/// Parses the continued parameter and its range, `NAME:lo:hi` (`option` names it in
/// errors): W (`omega`) or a model parameter, finite bounds.
pub fn parse_param(option: &str, text: &str) -> Result<(MapVar, f64, f64)> {
    let (name, lo, hi) = crate::basin::parse_name_bounds(option, text, "omega:131.7:132.4")?;
    let var = match MapVar::parse(option, name) {
        Ok(MapVar::Coord(_)) => Err("continue omega or a model parameter, not a start coordinate"),
        Ok(var) => Ok(var),
        Err(_) => Err("unknown parameter"),
    }
    .map_err(|why| {
        Error::invalid(
            option,
            name,
            format!(
                "{why}; valid names: omega, {}",
                jeffcott_core::model::Params::names_list()
            ),
        )
    })?;
    Ok((var, lo, hi))
}

/// A branch study: `branch`, whose start state is first integrated `settle` periods at
/// the branch's first value so Newton starts near the attractor there (0: shoot from
/// the start state itself). The one way the front ends continue orbits.
#[derive(Clone, Debug)]
pub struct OrbitsStudy {
    /// The branch.
    pub branch: BranchSpec,
    /// Periods integrated before shooting.
    pub settle: u32,
    /// Also continue the period-2n branch born at each period doubling of the branch
    /// ([`doubled_branch`]; one level).
    pub follow_doublings: bool,
    /// Periodic attractors of an earlier result to start from, all shot at once, a
    /// branch continued from each (empty: one branch from `branch.start`, settled).
    pub starts: Vec<crate::orbit_starts::AttractorStart>,
}

/// Branch points at most (each costs a few shots: about a second per hundred points at
/// the default steps).
pub const MAX_POINTS: usize = 1_000_000;

/// What a front end asks for: the continued parameter as `NAME:lo:hi`, W when it is
/// not W, and the rest as the defaults of [`crate::defaults::orbits`].
#[derive(Clone, Debug)]
pub struct OrbitsRequest<'a> {
    /// Model parameters.
    pub params: Params,
    /// `NAME:lo:hi`.
    pub param: &'a str,
    /// The front end's name for `param` in error messages (the CLI's `vary`, Python's
    /// `param`).
    pub param_field: &'static str,
    /// W when the parameter is not W (field `omega`).
    pub omega: Option<f64>,
    /// Period in forcing periods.
    pub period: u32,
    /// The parameter first increases (from lo) or, when false, decreases (from hi).
    pub up: bool,
    /// Periods integrated before shooting.
    pub settle: u32,
    /// The start state before settling.
    pub start: State,
    /// Branch points at most.
    pub max_points: usize,
    /// First arclength step.
    pub ds: f64,
    /// Largest arclength step.
    pub ds_max: f64,
    /// The lane stepper.
    pub stepper: jeffcott_core::integrate::lane::StepperConfig,
    /// Continue the doubled branches too.
    pub follow_doublings: bool,
    /// A basin or bifurcation output directory whose periodic attractors start the
    /// branches (field `from`; `start`, `period` and `settle` then do not apply).
    pub from: Option<&'a std::path::Path>,
}

impl OrbitsRequest<'_> {
    /// The study asked for, checked; errors name the field and the allowed range.
    pub fn study(&self) -> Result<OrbitsStudy> {
        let (var, lo, hi) = parse_param(self.param_field, self.param)?;
        let omega = match (var, self.omega) {
            (MapVar::Omega, Some(w)) => {
                return Err(Error::invalid(
                    "omega",
                    w,
                    "W is the continued parameter here; leave omega out",
                ));
            }
            (MapVar::Omega, None) => {
                for v in [lo, hi] {
                    jeffcott_core::model::validate_omega(v)?;
                }
                f64::NAN
            }
            (_, Some(w)) => {
                jeffcott_core::model::validate_omega(w)?;
                w
            }
            (_, None) if self.from.is_some() => f64::NAN, // the attractors' speed
            (_, None) => {
                return Err(Error::invalid(
                    "omega",
                    "missing",
                    "give the rotor speed W (omega) when continuing a model parameter",
                ));
            }
        };
        let starts = match self.from {
            Some(dir) => self.attractors(dir, var, (lo, hi), omega)?,
            None => Vec::new(),
        };
        let omega = match (var, starts.first()) {
            (MapVar::Param(_), Some(s)) => s.omega,
            _ => omega,
        };
        let branch = BranchSpec {
            params: self.params.clone(),
            omega,
            var,
            lo,
            hi,
            start_value: if self.up { lo } else { hi },
            start: self.start,
            period: self.period,
            direction: if self.up { 1.0 } else { -1.0 },
            max_points: self.max_points,
            ds: self.ds,
            ds_max: self.ds_max,
            shoot: ShootConfig {
                stepper: self.stepper,
                ..ShootConfig::default()
            },
        };
        jeffcott_core::limits::check_periods("settle", self.settle, 0)?;
        // A start beyond the divergence bound is the start's fault, not the settling's.
        self.stepper.validate()?;
        jeffcott_core::inputs::check_start_within_bound(
            "init",
            &self.start,
            self.stepper.divergence_bound,
        )?;
        branch.validate_as(self.param_field)?;
        Ok(OrbitsStudy {
            branch,
            settle: self.settle,
            follow_doublings: self.follow_doublings,
            starts,
        })
    }

    /// The periodic attractors of the result in `dir`, checked against this request:
    /// the same model, and each start inside the range (errors name `from`).
    fn attractors(
        &self,
        dir: &std::path::Path,
        var: MapVar,
        (lo, hi): (f64, f64),
        omega: f64,
    ) -> Result<Vec<crate::orbit_starts::AttractorStart>> {
        let bad = |why: String| Error::invalid("from", dir.display(), why);
        let near = match var {
            MapVar::Omega if self.up => lo,
            MapVar::Omega => hi,
            _ => omega,
        };
        let found = crate::orbit_starts::read(dir, var, near)?;
        crate::orbit_starts::check_same_model("from", dir, &self.params, &found.params)?;
        if found.starts.is_empty() {
            return Err(bad(
                "the result has no periodic attractor to start from".into()
            ));
        }
        for s in &found.starts {
            let value = s.value;
            if !(lo..=hi).contains(&value) {
                return Err(bad(format!(
                    "its {} lies at {} = {value}, outside the range {lo}..{hi}",
                    s.label,
                    var.name()
                )));
            }
            if !matches!(var, MapVar::Omega) && omega.is_finite() && s.omega != omega {
                return Err(Error::invalid(
                    "omega",
                    omega,
                    format!("the attractors of {} are at W = {}", dir.display(), s.omega),
                ));
            }
            jeffcott_core::orbit::check_period(s.period)?;
        }
        Ok(found.starts)
    }
}

/// An engine that stops once `cancel` is set: at its next call (every Newton iteration
/// and branch step asks for flows of a few periods) or, on the CPU, within a forcing
/// period of a long settle ([`Error::Interrupted`]).
struct Stoppable<'a> {
    engine: &'a dyn Flows,
    cancel: &'a jeffcott_core::control::Cancel,
}

impl Flows for Stoppable<'_> {
    /// Its own `cancel` stops it; the one passed in is the default's, never set.
    fn flows_until(
        &self,
        asks: &[jeffcott_core::orbit::FlowAsk],
        stepper: &jeffcott_core::integrate::lane::StepperConfig,
        _unused: &jeffcott_core::control::Cancel,
    ) -> Result<Vec<jeffcott_core::orbit::Flow>> {
        if self.cancel.is_set() {
            // An orbits study commits no units: nothing is kept.
            return Err(Error::Interrupted {
                committed: 0,
                total: 1,
            });
        }
        self.engine.flows_until(asks, stepper, self.cancel)
    }
}

/// Runs an orbits study: settle, shoot, continue; then, if asked, the doubled branch of
/// every period doubling (a doubling whose doubled orbit is not found is skipped, its
/// reason in that branch's place is not invented: the main branch still lists it).
/// Errors name `settle` when the start state diverges while settling. Stops with
/// [`Error::Interrupted`] within one engine call once `cancel` is set.
pub fn run(
    study: &OrbitsStudy,
    engine: &dyn Flows,
    cancel: &jeffcott_core::control::Cancel,
) -> Result<Vec<Branch>> {
    let stoppable = Stoppable { engine, cancel };
    let engine: &dyn Flows = &stoppable;
    let mains = if study.starts.is_empty() {
        vec![(study.branch.clone(), run_main(study, engine)?)]
    } else {
        from_attractors(study, engine)?
    };
    let mut all = Vec::new();
    for (spec, main) in mains {
        let mut doubled = Vec::new();
        if study.follow_doublings {
            for b in main
                .bifurcations
                .iter()
                .filter(|b| b.kind == Crossing::PeriodDoubling)
            {
                match doubled_branch(&spec, b, engine) {
                    Ok(d) => doubled.push(d),
                    Err(e @ Error::Interrupted { .. }) => return Err(e),
                    Err(_) => {}
                }
            }
        }
        all.push(main);
        all.extend(doubled);
    }
    Ok(all)
}

/// The branches from `study.starts`: every attractor's orbit shot at once (one engine
/// call per Newton iteration for all of them), then each continued. An
/// attractor whose orbit is not found is an error naming `from` and the attractor.
fn from_attractors(study: &OrbitsStudy, engine: &dyn Flows) -> Result<Vec<(BranchSpec, Branch)>> {
    let spec = &study.branch;
    let shots: Vec<Start> = study
        .starts
        .iter()
        .map(|s| spec.start_at(&s.x, s.value, s.period))
        .collect();
    // Every orbit found before any branch is continued.
    let orbits = shoot_many(engine, &shots, &spec.shoot)?
        .into_iter()
        .zip(&study.starts)
        .map(|(o, s)| {
            o.map_err(|e| {
                Error::invalid(
                    "from",
                    &s.label,
                    format!("its period-{} orbit was not found: {e}", s.period),
                )
            })
        })
        .collect::<Result<Vec<_>>>()?;
    study
        .starts
        .iter()
        .zip(orbits)
        .map(|(s, o)| {
            let b = BranchSpec {
                start: o.x,
                start_value: s.value,
                period: s.period,
                ..spec.clone()
            };
            let branch = continue_branch(&b, engine)?;
            Ok((b, branch))
        })
        .collect()
}

/// The main branch of [`run`].
fn run_main(study: &OrbitsStudy, engine: &dyn Flows) -> Result<Branch> {
    let spec = &study.branch;
    spec.validate()?;
    let ask = spec.ask(&spec.start, spec.start_value, study.settle, Want::End);
    let settled = engine.flows(&[ask], &spec.shoot.stepper)?.remove(0);
    if !settled.finite {
        return Err(Error::invalid(
            "settle",
            study.settle,
            "the start state diverged while settling; start elsewhere (init) or settle less",
        ));
    }
    continue_branch(
        &BranchSpec {
            start: settled.end,
            ..spec.clone()
        },
        engine,
    )
}
