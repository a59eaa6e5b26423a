//! Early exit: lanes recognised on a catalogued attractor retire and their
//! slots are refilled. What must hold: refill changes no lane's arithmetic (a lane not
//! retired has the record of the run without early exit, to the bit, in both
//! precisions, whatever the thread count); a GPU's slot pool ends the same lanes at the
//! same periods with the same records, states and counters;
//! a basin's labels agree with the full-length run's.

mod common;

use common::*;
use jeffcott_analysis::backend::Engine;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::early::{EarlyExit, Recognise, Then, Track};
use jeffcott_core::ensemble::{Backend, EnsembleResult, EnsembleSpec, LaneSpec, Precision, cpu};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, State, VX_R, X_R};

/// Lanes at 133 rad/s scattered over (x_r, vx_r), some far enough out to diverge with a
/// small divergence bound, a lane count that leaves a batch partly empty.
fn spec(precision: Precision, lanes: usize) -> EnsembleSpec {
    let p = Params::default();
    let lanes = (0..lanes)
        .map(|i| {
            let mut x0 = p.static_equilibrium();
            x0[X_R] = -0.006 + 0.012 * unit(i, 1);
            x0[VX_R] = -1.0 + 2.0 * unit(i, 2);
            LaneSpec {
                omega: 133.0,
                x0,
                param_set: 0,
            }
        })
        .collect();
    EnsembleSpec {
        param_sets: vec![p],
        lanes,
        transient: 30,
        recorded: 6,
        stepper: StepperConfig {
            steps_per_period: 200,
            divergence_bound: 0.0065,
            // lambda_1's tangent starts at period 18 (a lane recognised before then
            // starts it there and records 12 periods later), so the runs with lambda_1
            // below cover lanes moving from the batch without tangents to the one with
            // them, and a GPU pool writing fresh tangents into running slots.
            lyapunov_align: 12,
            ..StepperConfig::default()
        },
        precision,
    }
}

/// Never recognises anything.
struct Never;
impl Recognise for Never {
    fn observe(&self, _: usize, _: &mut Track, _: &State) -> Option<u32> {
        None
    }
}

/// Recognises a lane once its x_r has been above 0 for 3 points in a row: a rule that
/// retires some lanes and not others, at different periods.
struct XrPositive;
impl Recognise for XrPositive {
    fn observe(&self, _: usize, t: &mut Track, x: &State) -> Option<u32> {
        t.streak = if x[X_R] > 0.0 { t.streak + 1 } else { 0 };
        (t.streak >= 3).then_some(7)
    }
}

/// [`XrPositive`] for the even lanes only: the odd ones always run whole.
struct XrPositiveEven;
impl Recognise for XrPositiveEven {
    fn observe(&self, lane: usize, t: &mut Track, x: &State) -> Option<u32> {
        if lane % 2 == 1 {
            return None;
        }
        XrPositive.observe(lane, t, x)
    }
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn assert_same_lane(a: &EnsembleResult, b: &EnsembleResult, i: usize) {
    assert_eq!(bits(a.lane_points(i)), bits(b.lane_points(i)), "lane {i}");
    assert_eq!(a.status[i], b.status[i], "lane {i}");
}

fn in_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn refilled_batches_give_every_lane_not_retired_the_record_of_the_plain_run_to_the_bit() {
    for precision in [Precision::F64, Precision::F32] {
        let s = spec(precision, 45);
        let plain = cpu::run(&s, false, Control::none()).unwrap();
        assert!(
            plain.status.iter().any(|s| s.is_frozen()),
            "some lanes diverge"
        );
        // Nothing recognised: the whole result equals the plain run's.
        let never = EarlyExit {
            recognise: &Never,
            after: 0,
            then: Then::Retire,
        };
        let r = cpu::run_early(&s, &never, false, Control::none()).unwrap();
        assert!(r.retired.iter().all(Option::is_none));
        assert_eq!(bits(&r.result.poincare), bits(&plain.poincare));
        assert_eq!(r.result.counters, plain.counters);
        assert_eq!(
            bits(&r.result.final_state.concat()),
            bits(&plain.final_state.concat())
        );
        // Some lanes retired, their slots refilled: the others are untouched, and the
        // result does not depend on the number of threads.
        let early = EarlyExit {
            recognise: &XrPositive,
            after: 5,
            then: Then::Retire,
        };
        let one = in_one_and_three_threads(&s, &early);
        let retired = one.retired.iter().filter(|r| r.is_some()).count();
        assert!(retired > 0 && retired < s.lanes.len(), "{retired} retired");
        for (i, r) in one.retired.iter().enumerate() {
            match r {
                None => assert_same_lane(&one.result, &plain, i),
                Some(r) => {
                    assert_eq!(r.attractor, 7);
                    assert!(r.periods >= 5 + 2 && r.periods <= 36, "{r:?}");
                    assert!(one.result.lane_points(i).iter().all(|v| v.is_nan()));
                    // It retired where its own points first met the rule.
                    let replay = jeffcott_core::ensemble::early::replay(
                        &early,
                        i,
                        &plain_points_from(&s, i, early.after),
                        early.after,
                        (s.transient, s.recorded),
                    );
                    assert_eq!(replay, Some(*r), "lane {i}");
                }
            }
        }
    }
}

/// `s` run with `early` on 1 and on 3 threads: the same decisions and records (the
/// result does not depend on the number of threads); the 1-thread run.
fn in_one_and_three_threads(
    s: &EnsembleSpec,
    early: &EarlyExit,
) -> jeffcott_core::ensemble::early::EarlyResult {
    let one = in_threads(1, || {
        cpu::run_early(s, early, false, Control::none()).unwrap()
    });
    let three = in_threads(3, || {
        cpu::run_early(s, early, false, Control::none()).unwrap()
    });
    assert_eq!(one.retired, three.retired);
    assert_eq!(bits(&one.result.poincare), bits(&three.result.poincare));
    one
}

/// Lane `i`'s Poincare points from period `first` to the end, from a plain run.
fn plain_points_from(s: &EnsembleSpec, i: usize, first: u32) -> Vec<f64> {
    let long = EnsembleSpec {
        lanes: vec![s.lanes[i]],
        transient: first - 1,
        recorded: s.transient + s.recorded - first + 1,
        ..s.clone()
    };
    cpu::run(&long, false, Control::none()).unwrap().poincare
}

#[test]
fn a_lane_recorded_early_has_its_own_record_from_where_it_was_recognised_to_the_bit() {
    for precision in [Precision::F64, Precision::F32] {
        let s = spec(precision, 45);
        let plain = cpu::run(&s, false, Control::none()).unwrap();
        let early = EarlyExit {
            recognise: &XrPositive,
            after: 5,
            then: Then::Record,
        };
        let one = in_one_and_three_threads(&s, &early);
        let (rec, per) = (s.recorded as usize, s.recorded as usize * 8);
        let mut early_records = 0;
        for (i, r) in one.retired.iter().enumerate() {
            let Some(r) = r else {
                assert_same_lane(&one.result, &plain, i);
                continue;
            };
            // Recognised in the transient only; it ran its record from there.
            let at = r.periods - s.recorded;
            assert!(at >= 5 + 2 && at <= s.transient, "{r:?}");
            let own = plain_points_from(&s, i, early.after);
            let replay = jeffcott_core::ensemble::early::replay(
                &early,
                i,
                &own,
                early.after,
                (s.transient, s.recorded),
            );
            assert_eq!(replay, Some(*r), "lane {i}");
            // Its record: its own points of periods at + 1 ..= at + recorded, masked
            // from the period it froze in as a plain run masks them.
            let from = (at + 1 - early.after) as usize * 8;
            let got = one.result.lane_points(i);
            let want = &own[from..from + per];
            for k in 0..rec {
                let (g, w) = (&got[k * 8..k * 8 + 8], &want[k * 8..k * 8 + 8]);
                if !g[0].is_nan() {
                    assert_eq!(bits(g), bits(w), "lane {i} row {k}");
                }
            }
            if !one.result.status[i].is_frozen() {
                assert_eq!(bits(got), bits(want), "lane {i}");
                assert_eq!(bits(&one.result.final_state[i]), bits(&want[per - 8..]));
            }
            if at < s.transient {
                early_records += 1;
            }
        }
        assert!(early_records > 0, "some lanes were recorded early");
    }
}

#[test]
fn a_gpus_slot_pool_ends_every_lane_where_the_cpu_does_with_its_records_states_and_counters() {
    let Some(_) = gpu_f64_device() else {
        return;
    };
    let s = spec(Precision::F64, 29);
    for then in [Then::Retire, Then::Record] {
        let early = EarlyExit {
            recognise: &XrPositiveEven,
            after: 4,
            then,
        };
        for lambda1 in [false, true] {
            // 29 lanes through 29 slots, and through 5 (refilled as lanes end).
            let run = |backend, slots| {
                Engine::new(backend, Precision::F64)
                    .unwrap()
                    .with_pool_slots(slots)
                    .run_early(&s, &early, lambda1, Control::none())
                    .unwrap()
                    .0
            };
            let c = run(Backend::Cpu, 1);
            assert!(c.retired.iter().any(Option::is_some));
            assert!(c.retired.iter().any(Option::is_none));
            for slots in [29, 5] {
                let g = run(Backend::Gpu, slots);
                let case = format!("{then:?}, lambda1 {lambda1}, {slots} slots");
                assert_eq!(c.retired, g.retired, "{case}");
                let (cr, gr) = (&c.result, &g.result);
                assert_eq!(bits(&cr.poincare), bits(&gr.poincare), "{case}");
                assert_eq!(cr.status, gr.status, "{case}");
                assert_eq!(
                    bits(&cr.final_state.concat()),
                    bits(&gr.final_state.concat()),
                    "{case}"
                );
                // The GPU's counters are u32 (saturating), the same values here.
                assert_eq!(cr.counters, gr.counters, "{case}");
                // lambda_1 of every lane that ran whole or recorded early: the same
                // growths (the kernel's f64 arithmetic is the CPU's), summed alike.
                if lambda1 {
                    let (lc, lg) = (cr.lambda1.as_ref().unwrap(), gr.lambda1.as_ref().unwrap());
                    assert!(lc.iter().any(|l| l.is_finite()));
                    assert_eq!(bits(lc), bits(lg), "{case}");
                }
            }
        }
    }
}

#[test]
fn with_lambda1_every_lane_not_retired_has_the_plain_runs_exponent_to_the_bit() {
    for precision in [Precision::F64, Precision::F32] {
        let s = spec(precision, 45);
        let plain = cpu::run(&s, true, Control::none()).unwrap();
        let plain_l1 = plain.lambda1.as_ref().unwrap();
        let early = EarlyExit {
            recognise: &XrPositiveEven,
            after: 5,
            then: Then::Retire,
        };
        let r = cpu::run_early(&s, &early, true, Control::none()).unwrap();
        let l1 = r.result.lambda1.as_ref().unwrap();
        let mut whole = 0;
        for (i, ret) in r.retired.iter().enumerate() {
            match ret {
                Some(_) => assert!(l1[i].is_nan(), "a retired lane has no exponent"),
                None => {
                    assert_eq!(l1[i].to_bits(), plain_l1[i].to_bits(), "lane {i}");
                    assert_same_lane(&r.result, &plain, i);
                    whole += l1[i].is_finite() as usize;
                }
            }
        }
        assert!(whole > 0 && r.retired.iter().any(Option::is_some));
        // A lane recorded at the transient's end (recognised then or never) has the
        // plain run's exponent too.
        let record = EarlyExit {
            then: Then::Record,
            ..early
        };
        let r = cpu::run_early(&s, &record, true, Control::none()).unwrap();
        let l1 = r.result.lambda1.as_ref().unwrap();
        for (i, ret) in r.retired.iter().enumerate() {
            if ret.is_none_or(|ret| ret.periods == s.transient + s.recorded) {
                assert_eq!(l1[i].to_bits(), plain_l1[i].to_bits(), "lane {i}");
            }
        }
    }
}

/// Labels of a basin at `omega` with and without early exit, and run.json's count.
fn basin_pair(omega: f64, n: usize, extra: &str) -> (Vec<i32>, Vec<i32>, serde_json::Value) {
    let (full, early) = basin_runs(omega, n, &format!("--uncertainty-samples 0 {extra}"));
    labels_and_saved(&full.1, &early.1)
}

/// The labels of a full-length basin and of one with early exit, and the latter's
/// run.json count.
fn labels_and_saved(
    full: &std::path::Path,
    early: &std::path::Path,
) -> (Vec<i32>, Vec<i32>, serde_json::Value) {
    let labels = |dir: &std::path::Path| npy::<i32>(&dir.join("labels.npy")).1;
    let run = json(&early.join("run.json"));
    (labels(full), labels(early), run["early_exit"].clone())
}

/// A basin at `omega` run without and with early exit (`extra`: more options); each
/// run's temporary directory (kept alive) and output directory.
fn basin_runs(
    omega: f64,
    n: usize,
    extra: &str,
) -> (
    (tempfile::TempDir, std::path::PathBuf),
    (tempfile::TempDir, std::path::PathBuf),
) {
    plane_runs(
        &format!("--omega {omega} --x x_r:-0.006:0.006:{n} --y vx_r:-1:1:{n} {extra}"),
        250,
    )
}

/// A basin (`basin` with `args`: speed, plane, more options) run with transient
/// `transient` without and with early exit; each run's temporary directory (kept
/// alive) and output directory.
fn plane_runs(
    args: &str,
    transient: u32,
) -> (
    (tempfile::TempDir, std::path::PathBuf),
    (tempfile::TempDir, std::path::PathBuf),
) {
    let run = |streak: u32| {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        ok(&jeffcott(&words(&format!(
            "basin {args} --transient {transient} --periods 32 --backend cpu --no-plot --quiet \
             --early-exit-streak {streak} --out {}",
            out.display()
        ))));
        (tmp, out)
    };
    (run(0), run(16))
}

#[test]
fn a_basin_at_133_with_early_exit_has_the_labels_of_the_full_length_run() {
    let (full, early, saved) = basin_pair(133.0, 24, "");
    assert_eq!(full, early);
    assert!(full.contains(&0) && full.contains(&1), "two attractors");
    eprintln!("early exit: {saved}");
    let (run, all) = (
        saved["periods_run"].as_u64().unwrap(),
        saved["periods_full"].as_u64().unwrap(),
    );
    assert_eq!(saved["lanes"].as_u64(), Some(576));
    assert!(saved["retired"].as_u64().unwrap() > 400);
    assert!(run < all * 2 / 3, "{run} of {all} periods");
}

/// With friction (mu = 0.08) at 160 rad/s, above the rotor's natural frequency, three
/// attractors well apart share the plane of x_r and vy_r (an initial whirl forward or
/// backward): the free orbit (period-1, no contact), forward full annular rub (period-1)
/// and backward whirl (aperiodic, in contact nearly all the time; docs/early-exit.md,
/// "Three and four attractors well apart"). Lanes retire on the cycles only; the
/// backward whirl's run whole.
#[test]
fn a_basin_with_three_attractors_well_apart_has_with_early_exit_the_labels_of_the_full_length_run()
{
    let (full, early) = plane_runs(
        "--omega 160 --param mu=0.08 --x x_r:-0.006:0.006:12 --y vy_r:-3:3:12 \
         --uncertainty-samples 0",
        250,
    );
    let (full_labels, early_labels, saved) = labels_and_saved(&full.1, &early.1);
    assert_eq!(full_labels, early_labels);
    eprintln!("early exit: {saved}");
    let att = json(&early.1.join("attractors.json"));
    let mut kinds: Vec<(String, String)> = att["attractors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            (
                a["class"].as_str().unwrap().to_string(),
                a["rub"]["regime"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    kinds.sort();
    assert_eq!(
        kinds,
        [
            ("aperiodic".to_string(), "backward_whirl".to_string()),
            ("period-1".to_string(), "full_annular_rub".to_string()),
            ("period-1".to_string(), "no_contact".to_string()),
        ]
    );
    // Every lane of the two cycles' basins is the most early exit can retire.
    let on = |id: i64| full_labels.iter().filter(|&&l| l as i64 == id).count() as u64;
    let cycles: u64 = att["attractors"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["class"] == "period-1")
        .map(|a| on(a["id"].as_i64().unwrap()))
        .sum();
    let retired = saved["retired"].as_u64().unwrap();
    assert!(
        retired > 0 && retired <= cycles,
        "{retired} retired, {cycles} on cycles"
    );
}

/// At 240 rad/s with mu = 0.12 four attractors share the plane of x_r and vy_r, two of
/// them aperiodic (a chaotic partial rub and the backward whirl). Their clouds are
/// recognised once the lanes that stayed in them ended on them (one unit of 576 lanes,
/// so its second round has lanes to tell): more lanes retire than lie on the two
/// cycles, and every label is the full-length run's.
#[test]
fn chaotic_attractors_confirmed_by_their_lanes_retire_lanes_with_the_labels_of_the_full_length_run()
{
    let (full, early) = plane_runs(
        "--omega 240 --param mu=0.12 --x x_r:-0.006:0.006:24 --y vy_r:-3:3:24 \
         --uncertainty-samples 0 --chunk 576",
        250,
    );
    let (full_labels, early_labels, saved) = labels_and_saved(&full.1, &early.1);
    assert_eq!(full_labels, early_labels);
    eprintln!("early exit: {saved}");
    let att = json(&early.1.join("attractors.json"));
    let list = att["attractors"].as_array().unwrap();
    let on = |class: &str| {
        list.iter()
            .filter(|a| a["class"] == class)
            .map(|a| {
                let id = a["id"].as_i64().unwrap();
                full_labels.iter().filter(|&&l| l as i64 == id).count() as u64
            })
            .sum::<u64>()
    };
    let (cycles, clouds) = (on("period-1"), on("aperiodic"));
    assert!(clouds > 50, "{clouds} lanes on aperiodic attractors");
    let retired = saved["retired"].as_u64().unwrap();
    assert!(
        retired > cycles,
        "{retired} retired, {cycles} on the cycles"
    );
}

/// The refinement's and the uncertainty draws' lanes, labelled against the grid's
/// finished catalogue, confirm its clouds themselves (every 8th lane watches them
/// first): at 240 rad/s, mu = 0.12 the refined labels and f(eps) are the full-length
/// run's, and the draws' lanes retire on the clouds too. Their periods run are a count,
/// not a time: 45 % with the clouds here, 63 % on the binary before (cycles only).
#[test]
fn refined_and_reintegrated_lanes_confirm_and_recognise_the_clouds_with_the_full_length_labels() {
    let (full, early) = plane_runs(
        "--omega 240 --param mu=0.12 --x x_r:-0.006:0.006:16 --y vy_r:-3:3:16 \
         --steps-per-period 200 --refine 1 --uncertainty-samples 40",
        250,
    );
    let labels = |dir: &std::path::Path| npy::<i32>(&dir.join("labels.npy")).1;
    assert_eq!(labels(&full.1), labels(&early.1));
    let f_eps = |dir: &std::path::Path| {
        json(&dir.join("basin_metrics.json"))["uncertainty_reintegration"]["points"].clone()
    };
    assert_eq!(f_eps(&full.1), f_eps(&early.1));
    let draws = &json(&early.1.join("run.json"))["uncertainty_early_exit"];
    eprintln!("draws: {draws}");
    let (run, all) = (
        draws["periods_run"].as_u64().unwrap(),
        draws["periods_full"].as_u64().unwrap(),
    );
    assert!(run * 100 < all * 55, "{run} of {all} periods");
}

/// At 137.25 rad/s with T = 250 the lanes still in a long transient form "aperiodic"
/// entries (docs/early-exit.md, "Transient clouds"). Lanes that stayed in them for the
/// streak went on to the period-1 cycle, so no such cloud is recognised: no cell that
/// the full-length run puts on the cycle is called aperiodic with early exit (a lane
/// retired on a transient cloud would be). The converse happens: early exit labels lanes
/// by the cycle they reach where the full-length run leaves them in transient
/// (docs/early-exit.md).
#[test]
fn clouds_that_lanes_leave_are_never_recognised() {
    let (full, early) = plane_runs(
        "--omega 137.25 --x x_r:-0.006:0.006:24 --y vx_r:-1:1:24 --uncertainty-samples 0 \
         --chunk 576",
        250,
    );
    let (full_labels, early_labels, saved) = labels_and_saved(&full.1, &early.1);
    eprintln!("early exit: {saved}");
    let aperiodic = |dir: &std::path::Path| -> Vec<i32> {
        json(&dir.join("attractors.json"))["attractors"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|a| a["class"] == "aperiodic")
            .map(|a| a["id"].as_i64().unwrap() as i32)
            .collect()
    };
    let (in_full, in_early) = (aperiodic(&full.1), aperiodic(&early.1));
    let clouds = full_labels.iter().filter(|l| in_full.contains(l)).count();
    assert!(
        clouds > 100,
        "{clouds} cells in transient clouds at T = 250"
    );
    for (f, e) in full_labels.iter().zip(&early_labels) {
        assert!(!in_early.contains(e) || in_full.contains(f), "{f} -> {e}");
    }
}

#[test]
fn an_f32_basin_at_133_retires_lanes_as_f64_does_with_the_full_length_runs_attractors() {
    // f32 lanes raise the catalogue's identity floor to 10 um for their rounding noise;
    // the period-5 and period-4 cycles at 133 rad/s lie 28 um apart, so early exit once
    // took them for one attractor still converging and recognised neither (62 of 3600
    // lanes retired in a 60 x 60 basin against f64's 3483; docs/early-exit.md). Its
    // separation rule now keeps the f64 floor (catalogue::SEPARATION_ABS).
    let (full, early) = basin_runs(133.0, 24, "--uncertainty-samples 0 --precision f32");
    let classes = |dir: &std::path::Path| {
        let att = json(&dir.join("attractors.json"));
        let att = att.get("attractors").unwrap_or(&att).clone();
        let class_of: std::collections::HashMap<i64, String> = att
            .as_array()
            .unwrap()
            .iter()
            .map(|a| {
                (
                    a["id"].as_i64().unwrap(),
                    a["class"].as_str().unwrap().to_string(),
                )
            })
            .collect();
        let labels = npy::<i32>(&dir.join("labels.npy")).1;
        labels
            .iter()
            .map(|&l| class_of.get(&(l as i64)).cloned().unwrap_or_default())
            .collect::<Vec<_>>()
    };
    let (f, e) = (classes(&full.1), classes(&early.1));
    let period = |c: &str| c.strip_prefix("period-").map(|n| n.parse::<u32>().unwrap());
    let mut differing = 0;
    for (a, b) in f.iter().zip(&e) {
        if a != b {
            // Only where the full-length record saw a multiple of the cycle's period
            // (f32 rounding noise that kept a period-5 record from repeating after 5
            // periods but not after 10), and early exit the cycle itself.
            let (pa, pb) = (period(a).unwrap(), period(b).unwrap());
            assert!(pa > pb && pa % pb == 0, "full-length {a} against early {b}");
            differing += 1;
        }
    }
    assert!(
        differing * 100 <= f.len(),
        "{differing} of {} cells differ",
        f.len()
    );
    assert!(e.iter().any(|c| c == "period-5") && e.iter().any(|c| c == "period-4"));
    let saved = json(&early.1.join("run.json"))["early_exit"].clone();
    eprintln!("f32 early exit: {saved}, {differing} cells on a multiple period in the full run");
    assert_eq!(saved["lanes"].as_u64(), Some(576));
    assert!(saved["retired"].as_u64().unwrap() > 400, "{saved}");
}

#[test]
fn a_refined_and_reintegrated_basin_with_early_exit_has_the_labels_and_f_eps_of_the_full_length_run()
 {
    // The re-integrated points (the refinement's and the uncertainty draws') are
    // labelled against the coarse basin's whole catalogue, recognised lanes retiring.
    let (full, early) = basin_runs(133.0, 12, "--refine 1 --uncertainty-samples 12");
    let labels = |dir: &std::path::Path| npy::<i32>(&dir.join("labels.npy")).1;
    assert_eq!(labels(&full.1), labels(&early.1));
    assert_eq!(labels(&full.1).len(), 23 * 23);
    let metrics = |dir: &std::path::Path| json(&dir.join("basin_metrics.json"));
    let f = |dir: &std::path::Path| metrics(dir)["uncertainty_reintegration"]["points"].clone();
    assert_eq!(f(&full.1), f(&early.1));
    assert!(f(&full.1).as_array().unwrap().len() == 7);
    let run = json(&early.1.join("run.json"));
    let level = &run["refinement"]["levels"][0]["early_exit"];
    let draws = &run["uncertainty_early_exit"];
    eprintln!("refinement: {level}, draws: {draws}");
    for (saved, lanes) in [
        (
            level,
            run["refinement"]["levels"][0]["lanes"].as_u64().unwrap(),
        ),
        (draws, 12 * 29),
    ] {
        assert_eq!(saved["lanes"].as_u64(), Some(lanes));
        assert!(saved["retired"].as_u64().unwrap() > lanes / 2, "{saved}");
        assert!(saved["periods_run"].as_u64() < saved["periods_full"].as_u64());
    }
    // Without early exit neither stage records a count.
    let plain = json(&full.1.join("run.json"));
    assert!(plain["refinement"]["levels"][0].get("early_exit").is_none());
    assert!(plain.get("uncertainty_early_exit").is_none());
}

#[test]
fn a_refined_and_reintegrated_basin_with_early_exit_has_the_cpus_labels_on_a_gpu() {
    if !gpu_f64_present() {
        return;
    }
    // The GPU's slot pool ends the same lanes at the same periods as the CPU's refilled
    // batches: the same labels at every stage (every refined and re-integrated lane
    // retires here), in either form of the kernel (JEFFCOTT_GPU_CONSTS; the pool's lanes
    // share their constants, so the GPU reads one set for all).
    let run_form = |backend: &str, form: &str| {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_jeffcott"))
            .args(words(&format!(
                "basin --omega 133 --x x_r:-0.006:0.006:5 --y vx_r:-1:1:5 --transient 250 \
                 --periods 16 --steps-per-period 200 --refine 1 \
                 --uncertainty-samples 3 --backend {backend} --precision f64 --no-plot \
                 --quiet --out {}",
                out.display()
            )))
            .env(jeffcott_gpu::device::CONSTS_VAR, form)
            .output()
            .unwrap();
        ok(&o);
        let run = json(&out.join("run.json"));
        let f =
            json(&out.join("basin_metrics.json"))["uncertainty_reintegration"]["points"].clone();
        (npy::<i32>(&out.join("labels.npy")).1, f, run, tmp)
    };
    let cpu = run_form("cpu", "");
    for form in ["once", "each-step"] {
        let gpu = run_form("gpu", form);
        assert_eq!(gpu.2["backend"]["backend"], "gpu", "{}", gpu.2);
        assert_eq!(cpu.0, gpu.0, "{form}");
        assert_eq!(cpu.1, gpu.1, "{form}");
        for r in [&cpu.2, &gpu.2] {
            let level = &r["refinement"]["levels"][0];
            assert_eq!(level["early_exit"]["retired"], level["lanes"], "{level}");
        }
        assert_eq!(
            cpu.2["uncertainty_early_exit"], gpu.2["uncertainty_early_exit"],
            "{form}"
        );
    }
}

/// Runs `line` (a study command) in f64 on `backend` with early exit at `streak` (0:
/// off) into a temporary directory: the directory and the output path.
fn early_run(line: &str, backend: &str, streak: u32) -> (tempfile::TempDir, std::path::PathBuf) {
    jeffcott_ok(
        "out",
        &format!("{line} --precision f64 --backend {backend} --early-exit-streak {streak}"),
    )
}

/// [`early_run`] of `line` with early exit on, on the CPU and on a GPU (`None`, the
/// test skipped, without an f64 GPU; a failure when one is required).
#[allow(clippy::type_complexity)]
fn on_cpu_and_gpu(
    line: &str,
) -> Option<(
    (tempfile::TempDir, std::path::PathBuf),
    (tempfile::TempDir, std::path::PathBuf),
)> {
    gpu_f64_present().then(|| (early_run(line, "cpu", 16), early_run(line, "gpu", 16)))
}

/// The GPU's slot pool recognises clouds as the CPU's refilled batches do (the
/// recogniser runs on the host for both): at 240 rad/s, mu = 0.12, the same labels and
/// the same lanes retired, more of them than lie on the cycles.
#[test]
fn chaotic_attractors_are_recognised_on_a_gpu_as_on_the_cpu() {
    let Some((cpu, gpu)) = on_cpu_and_gpu(
        "basin --omega 240 --param mu=0.12 --x x_r:-0.006:0.006:16 --y vy_r:-3:3:16 \
         --transient 250 --periods 16 --steps-per-period 200 --chunk 256 \
         --uncertainty-samples 0 --no-plot --quiet",
    ) else {
        return;
    };
    let labels = |dir: &std::path::Path| npy::<i32>(&dir.join("labels.npy")).1;
    let run = |dir: &std::path::Path| json(&dir.join("run.json"));
    assert_eq!(run(&gpu.1)["backend"]["backend"], "gpu");
    assert_eq!(labels(&cpu.1), labels(&gpu.1));
    assert_eq!(run(&cpu.1)["early_exit"], run(&gpu.1)["early_exit"]);
    let att = json(&cpu.1.join("attractors.json"));
    let cycles: u64 = att["attractors"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["class"] == "period-1")
        .map(|a| a["lanes"].as_u64().unwrap())
        .sum();
    let retired = run(&cpu.1)["early_exit"]["retired"].as_u64().unwrap();
    assert!(
        retired > cycles,
        "{retired} retired, {cycles} on the cycles"
    );
}

/// A brute force over 131..134.5 rad/s (periodic and aperiodic speeds), for
/// [`early_run`].
const BRUTE_FORCE: &str = "bifurcation --omega 131:134.5:12 --ics 4 --brute-transient 300 \
    --periods 24 --max-seeds 4 --steps-per-period 200 --no-lyapunov --no-plot --quiet";

/// Per speed: each brute-force attractor's class and lane count, sorted.
fn brute_classes(dir: &std::path::Path) -> Vec<Vec<(String, u64)>> {
    json(&dir.join("summary.json"))["per_omega"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| class_counts(&w["brute_force"]["attractors"]))
        .collect()
}

/// An attractor list's (class, start-state count) pairs, sorted.
fn class_counts(attractors: &serde_json::Value) -> Vec<(String, u64)> {
    let mut c: Vec<(String, u64)> = attractors
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            (
                a["class"].as_str().unwrap().into(),
                a["lanes"].as_u64().unwrap(),
            )
        })
        .collect();
    c.sort();
    c
}

#[test]
fn a_brute_force_with_early_exit_records_lanes_that_classify_as_in_the_full_length_run() {
    // A lane recognised on a cycle of its speed during its transient records from
    // there; its record must classify as the full-length lane's does (it is recognised
    // only within half the classifier's repeat tolerance, and runs again whole if its
    // record does not repeat like the cycle).
    let (full, early) = (
        early_run(BRUTE_FORCE, "cpu", 0),
        early_run(BRUTE_FORCE, "cpu", 16),
    );
    let classes = brute_classes(&full.1);
    assert_eq!(classes, brute_classes(&early.1));
    let kinds: Vec<String> = classes.concat().into_iter().map(|c| c.0).collect();
    assert!(kinds.iter().any(|k| k.starts_with("period")));
    assert!(kinds.iter().any(|k| k == "aperiodic"));
    let saved = &json(&early.1.join("run.json"))["brute_force_early_exit"];
    eprintln!("{saved}");
    assert!(saved["retired"].as_u64() > Some(10), "{saved}");
    assert!(saved["periods_run"].as_u64() < saved["periods_full"].as_u64());
    assert!(
        json(&full.1.join("run.json"))
            .get("brute_force_early_exit")
            .is_none()
    );
}

/// Near a period doubling a cycle's lanes converge slowly, alternating: at 133.08 rad/s
/// (the period-9 cycle stable since 133.072, `jeffcott orbits`) the brute force's first
/// lane still looks period-18 at period 1000 and catalogues a "period-18" entry. Lanes
/// recognised on it and recorded early kept the alternation the full-length run's had
/// lost (one of 22 was period-18 instead of period-9). Such an entry, within four
/// identity tolerances of itself shifted by half its period, is not recognised.
#[test]
fn a_brute_force_does_not_record_early_on_a_period_doubled_entry_of_a_converging_cycle() {
    const LINE: &str = "bifurcation --omega 133.07:133.09:3 --ics 16 --brute-transient 1000 \
        --periods 48 --max-seeds 6 --no-lyapunov --no-plot --quiet";
    let (full, early) = (early_run(LINE, "cpu", 0), early_run(LINE, "cpu", 16));
    let classes = brute_classes(&full.1);
    assert_eq!(classes, brute_classes(&early.1));
    let at_133_08: Vec<&str> = classes[1].iter().map(|c| c.0.as_str()).collect();
    assert_eq!(
        at_133_08,
        ["period-18", "period-4", "period-9"],
        "{classes:?}"
    );
}

#[test]
fn a_brute_force_with_early_exit_has_the_cpus_records_on_a_gpu() {
    let Some((cpu, gpu)) = on_cpu_and_gpu(BRUTE_FORCE) else {
        return;
    };
    assert_eq!(
        json(&gpu.1.join("run.json"))["brute_force_backend"]["backend"],
        "gpu"
    );
    for file in ["bifurcation.npy", "bifurcation_rows.npy"] {
        let read = |d: &std::path::Path| bits(&npy::<f64>(&d.join(file)).1);
        assert_eq!(read(&cpu.1), read(&gpu.1), "{file}");
    }
    assert_eq!(
        json(&cpu.1.join("run.json"))["brute_force_early_exit"],
        json(&gpu.1.join("run.json"))["brute_force_early_exit"]
    );
}

/// Basin stability at 133 (two cycles) and 137.25 rad/s (a cycle and aperiodic clouds),
/// 128 draws per speed, for [`early_run`].
const STABILITY: &str = "basin-stability --omega 133:137.25:2 --sample 128 \
    --box x_r:-0.006:0.006,vx_r:-1:1 --transient 250 --periods 16 --no-plot --quiet";

/// Per speed: each attractor's class and fraction, and the diverged fraction.
fn stability_fractions(dir: &std::path::Path) -> Vec<(Vec<(String, f64)>, f64)> {
    json(&dir.join("basin_stability.json"))["per_omega"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| {
            let a = w["attractors"].as_array().unwrap().iter();
            let classes = a
                .map(|a| {
                    (
                        a["class"].as_str().unwrap().into(),
                        a["fraction"].as_f64().unwrap(),
                    )
                })
                .collect();
            (classes, w["diverged_fraction"].as_f64().unwrap())
        })
        .collect()
}

#[test]
fn basin_stability_with_early_exit_has_the_fractions_of_the_full_length_run() {
    // The continuation's fresh lanes (basin stability's draws) in rounds per speed,
    // with lambda_1 (aperiodic lanes run whole and are told apart by it as before).
    let (full, early) = (
        early_run(STABILITY, "cpu", 0),
        early_run(STABILITY, "cpu", 16),
    );
    assert_eq!(stability_fractions(&full.1), stability_fractions(&early.1));
    let saved = &json(&early.1.join("run.json"))["early_exit"];
    eprintln!("{saved}");
    assert_eq!(saved["lanes"].as_u64(), Some(256));
    assert!(saved["retired"].as_u64() > Some(100), "{saved}");
    assert!(json(&full.1.join("run.json")).get("early_exit").is_none());
}

#[test]
fn basin_stability_with_early_exit_has_the_cpus_fractions_on_a_gpu() {
    let Some((cpu, gpu)) = on_cpu_and_gpu(STABILITY) else {
        return;
    };
    let run = |d: &std::path::Path| json(&d.join("run.json"));
    assert_eq!(run(&gpu.1)["backend"]["backend"], "gpu");
    assert_eq!(run(&cpu.1)["early_exit"], run(&gpu.1)["early_exit"]);
    assert_eq!(stability_fractions(&cpu.1), stability_fractions(&gpu.1));
}

/// A map over speed and unbalance, 4 start states per cell (the first from the static
/// equilibrium), for [`early_run`].
const MAP: &str = "map --x omega:131:134.5:8 --y e:0.0008:0.0012:2 --ics 4 --transient 300 \
    --periods 24 --steps-per-period 200 --no-lyapunov --no-plot --quiet";

/// A map's per-cell figures of the equilibrium's attractor, then the attractor counts.
const MAP_FILES: [&str; 6] = [
    "class.npy",
    "period.npy",
    "contact.npy",
    "peak_force.npy",
    "regime.npy",
    "attractors.npy",
];

/// Asserts that `files` are the same bytes in directories `a` and `b`.
fn same_files(a: &std::path::Path, b: &std::path::Path, files: &[&str]) {
    for f in files {
        let read = |d: &std::path::Path| std::fs::read(d.join(f)).unwrap();
        assert_eq!(read(a), read(b), "{f}");
    }
}

/// Per cell: each attractor's class and start-state count, sorted.
fn map_cells(dir: &std::path::Path) -> Vec<Vec<(String, u64)>> {
    json(&dir.join("map.json"))["cell_attractors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| class_counts(&c["attractors"]))
        .collect()
}

/// Early exit in a map: each cell's first start state (the static
/// equilibrium) runs whole and catalogues the cell, the others are recognised on it and
/// record from there. The cells find the attractors of the full-length run, with the
/// same start-state counts; the per-cell figures of the equilibrium's attractor are
/// those of the full-length run to the byte (its lane ran whole in both).
#[test]
fn a_map_with_early_exit_finds_the_attractors_of_the_full_length_run_in_every_cell() {
    let (full, early) = (early_run(MAP, "cpu", 0), early_run(MAP, "cpu", 16));
    let cells = map_cells(&full.1);
    assert_eq!(cells, map_cells(&early.1));
    let kinds: Vec<String> = cells.concat().into_iter().map(|c| c.0).collect();
    assert!(kinds.iter().any(|k| k.starts_with("period")), "{kinds:?}");
    same_files(&full.1, &early.1, &MAP_FILES[..5]);
    let saved = &json(&early.1.join("run.json"))["early_exit"];
    eprintln!("{saved}");
    assert!(saved["retired"].as_u64() > Some(10), "{saved}");
    assert!(saved["periods_run"].as_u64() < saved["periods_full"].as_u64());
    assert!(json(&full.1.join("run.json")).get("early_exit").is_none());
}

/// A lane recorded early must classify as the full-length lane does, also where its
/// cycle's slowest multipliers are a complex pair near -1: at 133.19 rad/s the period-9
/// cycle's are -0.81 +- 0.31i (`jeffcott orbits`), so a deviation within the
/// recognition tolerance at the points the streak saw grows again as it turns, and
/// before the check 4 of the cell's 16 start states made a "period-18" entry beside
/// the full-length run's period-9 and period-4. Such lanes now run again whole.
#[test]
fn lanes_recorded_early_whose_record_does_not_repeat_like_their_cycle_run_whole() {
    const LINE: &str = "map --x omega:133.19:133.2:2 --y e:0.001:0.001:1 --ics 16 \
        --transient 1000 --no-lyapunov --no-plot --quiet";
    let (full, early) = (early_run(LINE, "cpu", 0), early_run(LINE, "cpu", 16));
    let cells = map_cells(&full.1);
    assert_eq!(cells, map_cells(&early.1));
    let kinds: Vec<String> = cells[0].iter().map(|c| c.0.clone()).collect();
    assert_eq!(kinds, ["period-4", "period-9"], "{cells:?}");
    let saved = &json(&early.1.join("run.json"))["early_exit"];
    assert!(saved["retired"].as_u64() > Some(10), "{saved}");
}

#[test]
fn a_map_with_early_exit_has_the_cpus_cells_on_a_gpu() {
    let Some((cpu, gpu)) = on_cpu_and_gpu(MAP) else {
        return;
    };
    same_files(&cpu.1, &gpu.1, &MAP_FILES);
    assert_eq!(map_cells(&cpu.1), map_cells(&gpu.1));
    assert_eq!(
        json(&cpu.1.join("run.json"))["early_exit"],
        json(&gpu.1.join("run.json"))["early_exit"]
    );
}
