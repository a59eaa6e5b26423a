"""Type stubs of the Rust extension (python/src/lib.rs)."""

from typing import Any, Callable, Dict, List, Literal, Mapping, Optional, Sequence, Tuple, Union

from typing_extensions import TypedDict, Unpack

import numpy as np
import numpy.typing as npt

__version__: str
COORD_NAMES: List[str]
PARAM_KEYS: List[str]
LANES_COLUMNS: List[str]
STEPPER_DEFAULTS: Dict[str, Union[int, float, bool]]
DEFAULTS: Dict[str, Dict[str, Any]]

class StepperOptions(TypedDict, total=False):
    """The lane stepper's settings, keywords of every function that integrates
    (``**stepper``); absent ones take ``STEPPER_DEFAULTS`` (the command line's defaults;
    docs/convergence.md, docs/performance.md)."""

    steps_per_period: int  # macro steps per forcing period N
    max_segments: int  # cap on contact switches per macro step
    divergence_bound: float  # |position| [m] beyond which a lane has diverged
    contact_substeps: int  # contact refinement R: 1, 2, 4, 8 or 16
    early_exit_after: int  # periods before a lane may retire on a known attractor
    early_exit_streak: int  # points in a row on a known attractor that retire a lane; 0: off
    exact_free_flight: bool  # macro steps begun in free flight take the exact flow map
    lyapunov_align: int  # lambda_1: periods the tangent aligns before the record; 0: whole transient

# Bad input raises ValueError (a value out of range; a request too large for memory,
# refused before anything is allocated) or TypeError (the wrong kind of value), naming
# the keyword and what it accepts.

Progress = Callable[[int, int], Any]
Speeds = Union[float, Sequence[float], str]
AxisSpec = Union[Tuple[str, float, float, int], str]
Backend = Literal["auto", "cpu", "gpu"]
Precision = Optional[Literal["f32", "f64"]]
Direction = Literal["up", "down", "both"]

def simulate(
    omega: float,
    *,
    params: Optional[Mapping[str, float]] = None,
    init: Optional[Mapping[str, float]] = None,
    transient: int = 1000,
    periods: int = 64,
    timeseries_periods: Optional[int] = None,
    integrator: Literal["lane", "article"] = "lane",
    spectrum_periods: int = 24,
    n_max: int = 32,
    rel_tol: float = 1e-3,
    abs_tol: float = 1e-7,
    article_steps: int = 1000,
    article_alpha: float = 0.2,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """One trajectory: summary.json's keys plus poincare [periods, 8], timeseries [M, 9],
    full_spectrum [bins, 4] and contact_history [M, 5] (the last two unless it diverged)."""

def ensemble(
    omega: Optional[Speeds] = None,
    *,
    lanes: Optional[npt.ArrayLike] = None,
    columns: Optional[Sequence[str]] = None,
    params: Optional[Mapping[str, float]] = None,
    init: Optional[Mapping[str, float]] = None,
    transient: int = 500,
    periods: int = 64,
    backend: Backend = "auto",
    precision: Precision = None,
    lyapunov: bool = False,
    progress: Optional[Progress] = None,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """Many lanes (a speed range or sequence, or lanes: any 2-D array-like of numbers, read
    as float64): poincare [lanes, periods, 8], status [lanes] (uint32), lanes [lanes, 10],
    params [sets, 14] ([sets, 24], the columns of PARAM_KEYS, when a set uses a machine
    variant), lambda1 [lanes] (with lyapunov=True) and run (run.json's keys)."""

def basin(
    omega: float,
    x: AxisSpec,
    y: AxisSpec,
    *,
    fix: Optional[Mapping[str, float]] = None,
    params: Optional[Mapping[str, float]] = None,
    transient: int = 500,
    periods: int = 64,
    backend: Backend = "auto",
    precision: Precision = None,
    lyapunov: bool = False,
    refine: int = 0,
    uncertainty_samples: int = 100,
    entropy_box: Optional[int] = None,
    progress: Optional[Progress] = None,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """A basin: labels [ny, nx] (int32, -1 diverged, -2 an attractor a refinement found
    that the coarse grid did not), x [nx], y [ny], attractors (as attractors.json: each
    with its rub figures under "rub"),
    diverged, metrics (basin_metrics.json's keys: fractions, entropies, uncertainty
    exponent, box-counting dimension, Wada test; with uncertainty_samples > 0 the
    re-integration estimate), refined [ny, nx] (uint8, with refine > 0: 1 where the
    label was integrated), lambda1 [ny, nx] (with lyapunov=True), run."""

def bifurcation(
    omega: Speeds,
    *,
    sweep: Literal["up", "down", "both", "none"] = "both",
    ics: int = 8,
    seed: int = 1,
    transient: int = 200,
    transient_first: int = 1000,
    brute_transient: int = 500,
    periods: int = 64,
    max_seeds: int = 8,
    params: Optional[Mapping[str, float]] = None,
    backend: Backend = "auto",
    precision: Precision = None,
    lyapunov: bool = True,
    progress: Optional[Progress] = None,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """Sweeps and brute force: omega [W], rows [rows, 4] (W, sweep 0 up / 1 down / 2 brute
    force, lane, attractor id), points [rows, periods, 8], lambda1 [rows], summary."""

def lyapunov(
    omega: float,
    *,
    params: Optional[Mapping[str, float]] = None,
    init: Optional[Mapping[str, float]] = None,
    time: float = 100.0,
    min_time: Optional[float] = None,
    transient: int = 1000,
    tangent_transient: int = 50,
    tol: float = 2e-3,
    window: int = 100,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """The full spectrum: spectrum.json's keys plus history [periods, 9]."""

def orbits(
    param: str,
    *,
    omega: Optional[float] = None,
    period: int = 1,
    direction: Literal["up", "down"] = "up",
    settle: int = 300,
    init: Optional[Mapping[str, float]] = None,
    max_points: int = 5000,
    ds: float = 2e-5,
    ds_max: float = 2e-4,
    follow_doublings: bool = False,
    start_from: Optional[str] = None,
    backend: Backend = "cpu",
    params: Optional[Mapping[str, float]] = None,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """Branches of periodic orbits: branches.json's keys plus branch [points, 13] and
    multipliers [points, 8, 2]."""

def map(
    x: AxisSpec,
    y: AxisSpec,
    *,
    omega: Optional[float] = None,
    ics: int = 1,
    seed: int = 1,
    transient: int = 500,
    periods: int = 64,
    log_x: bool = False,
    log_y: bool = False,
    params: Optional[Mapping[str, float]] = None,
    backend: Backend = "auto",
    precision: Precision = None,
    lyapunov: bool = True,
    progress: Optional[Progress] = None,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """A two-parameter map: period, class, attractors, regime (int32 [ny, nx]), lambda1,
    contact, peak_force (f64 [ny, nx]), x, y and summary (map.json's keys)."""

def continuation(
    param: AxisSpec,
    *,
    omega: Optional[float] = None,
    ics: int = 32,
    start_box: Optional[str] = None,
    seed: int = 1,
    direction: Direction = "both",
    match_threshold: Optional[float] = None,
    transient: int = 500,
    periods: int = 64,
    params: Optional[Mapping[str, float]] = None,
    backend: Backend = "auto",
    precision: Precision = None,
    lyapunov: bool = True,
    progress: Optional[Progress] = None,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """Attractors followed over a parameter: values [n], fractions_<dir> [n, ids + 1],
    fraction_errors_<dir>, tipping_<dir> [n - 1, ids + 1, ids + 1], summary."""

def basin_stability(
    omega: Union[float, str],
    start_box: str,
    *,
    sample: int = 1000,
    seed: int = 1,
    transient: int = 500,
    periods: int = 64,
    params: Optional[Mapping[str, float]] = None,
    backend: Backend = "auto",
    precision: Precision = None,
    lyapunov: bool = True,
    progress: Optional[Progress] = None,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """Basin stability: omega [n], fractions [n, ids + 1], ci_low, ci_high (95 % Wilson),
    summary (basin_stability.json's keys)."""

def cascade(
    omega: str,
    *,
    params: Optional[Mapping[str, float]] = None,
    transient_first: int = 1000,
    transient: int = 100,
    periods: int = 24,
    max_order: float = 4.0,
    direction: Direction = "both",
    progress: Optional[Progress] = None,
    **stepper: Unpack[StepperOptions],
) -> Dict[str, Any]:
    """Full-spectrum cascade over "a:b:n": omega [n], orders [bins], cascade and
    cascade_stator [sweeps, n, bins] (amplitudes [m]), regime [sweeps, n] (int32),
    summary (cascade.json's keys; summary["sweeps"] names the blocks)."""

def basin_metrics(
    labels: npt.ArrayLike, *, entropy_box: Optional[int] = None
) -> Dict[str, Any]:
    """The basin measures of any non-empty 2-D integer label array, any integer dtype
    (basin_metrics.json's keys)."""

def parameters(params: Optional[Mapping[str, float]] = None) -> Dict[str, float]:
    """Table 1 with the given overrides, validated."""

def adapters() -> List[Dict[str, Any]]:
    """The GPU adapters wgpu finds, as `jeffcott info` lists them."""
