"""jeffcott: nonsmooth dynamics of a rubbing Jeffcott rotor-stator system.

The functions run the Rust library (``jeffcott-core``, ``jeffcott-gpu``,
``jeffcott-analysis``) with the GIL released and return numpy arrays and plain
dictionaries whose keys are those of the command line's JSON files:

- :func:`simulate` one trajectory (``jeffcott simulate``),
- :func:`ensemble` many lanes on the CPU or a GPU (``jeffcott ensemble``),
- :func:`bifurcation` sweeps up/down and brute force over W (``jeffcott bifurcation``),
- :func:`basin` a basin of attraction over two start coordinates, refined at its
  boundary, with its measures (``jeffcott basin``),
- :func:`basin_metrics` the basin measures of any 2-D label array,
- :func:`lyapunov` the full Lyapunov spectrum at one speed (``jeffcott lyapunov``),
- :func:`map` a two-parameter design chart (``jeffcott map``),
- :func:`continuation` attractors followed over a parameter (``jeffcott continuation``),
- :func:`basin_stability` fractions of a box of start states (``jeffcott basin-stability``),
- :func:`cascade` full spectra along a run-up and run-down (``jeffcott cascade``),
- :func:`orbits` a branch of periodic orbits, stable and unstable, with its Floquet
  multipliers and bifurcations (``jeffcott orbits``),
- :func:`parameters` and :func:`adapters` the model's parameters and the GPU adapters.

``backend`` is ``"auto"`` (a hardware GPU if present, else all CPU cores), ``"cpu"`` or
``"gpu"`` (any adapter, Mesa's lavapipe included); ``precision=None`` is f64 on the CPU
and f32 on a GPU. ``progress`` takes a callable ``f(done, total)`` (lane-periods).
Every function that integrates takes the lane stepper's settings as keywords
(``steps_per_period``, ``max_segments``, ``divergence_bound``, ``contact_substeps``,
``exact_free_flight``, ...: the
command line's options of those names), their defaults in ``STEPPER_DEFAULTS``; every
keyword's default is in ``DEFAULTS``.
Ctrl-C stops a run cleanly (KeyboardInterrupt), within a forcing period; bad input
raises ``ValueError`` (a value out of range, a request too large for memory) or
``TypeError`` (the wrong kind of value), naming the keyword and what it accepts, before
any work or large allocation; GPU problems raise ``RuntimeError``.
"""

import os as _os

# As the command line does (src/main.rs): Mesa's Vulkan device-select layer probes the
# Wayland and X displays while wgpu lists adapters and, without a desktop session,
# prints "XDG_RUNTIME_DIR is invalid" on stderr; jeffcott picks its adapter itself. A
# user who configures the layer keeps it.
if not any(
    v in _os.environ for v in ("NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME")
):
    _os.environ["NODEVICE_SELECT"] = "1"

from ._jeffcott import (  # noqa: E402
    COORD_NAMES,
    DEFAULTS,
    LANES_COLUMNS,
    PARAM_KEYS,
    STEPPER_DEFAULTS,
    __version__,
    adapters,
    basin,
    basin_metrics,
    basin_stability,
    bifurcation,
    cascade,
    continuation,
    ensemble,
    lyapunov,
    map,
    orbits,
    parameters,
    simulate,
)


# The extension's signatures show a default that is a named constant of the library as
# `...`; the functions exported here carry their real defaults (from DEFAULTS), so
# `inspect.signature` and `help()` show the numbers a call uses.
import functools as _functools  # noqa: E402
import inspect as _inspect  # noqa: E402

# The group of DEFAULTS whose values a function's keywords take, where its name differs.
_STUDY = {"basin_stability": "stability"}
# Keywords whose default is a configuration's field of another name.
_FIELD = {
    ("simulate", "article_steps"): ("article", "steps_per_period"),
    ("simulate", "article_alpha"): ("article", "alpha"),
    ("lyapunov", "time"): ("spectrum", "max_time"),
}
# Configurations whose fields are keywords of the same name.
_CONFIGS = ("classify", "spectrum")


def _library_default(function, keyword):
    """The default the library declares for `function`'s `keyword` (KeyError: none)."""
    if (function, keyword) in _FIELD:
        group, field = _FIELD[(function, keyword)]
        return DEFAULTS[group][field]
    study = DEFAULTS.get(_STUDY.get(function, function), {})
    if keyword in study:
        return study[keyword]
    for group in _CONFIGS:
        if keyword in DEFAULTS[group]:
            return DEFAULTS[group][keyword]
    raise KeyError(f"{function}({keyword}=...)")


def _with_defaults(f):
    sig = _inspect.signature(f)
    params = [
        p.replace(default=_library_default(f.__name__, p.name)) if p.default is Ellipsis else p
        for p in sig.parameters.values()
    ]

    @_functools.wraps(f)
    def call(*args, **kwargs):
        return f(*args, **kwargs)

    call.__signature__ = sig.replace(parameters=params)
    return call


(basin, basin_metrics, basin_stability, bifurcation, cascade, continuation, ensemble,
 lyapunov, map, orbits, simulate) = (
    _with_defaults(f)
    for f in (basin, basin_metrics, basin_stability, bifurcation, cascade, continuation,
              ensemble, lyapunov, map, orbits, simulate)
)

# `map` is not in __all__: a star import would shadow the builtin map.
__all__ = [
    "COORD_NAMES",
    "DEFAULTS",
    "LANES_COLUMNS",
    "PARAM_KEYS",
    "STEPPER_DEFAULTS",
    "__version__",
    "adapters",
    "basin",
    "basin_metrics",
    "basin_stability",
    "bifurcation",
    "cascade",
    "continuation",
    "ensemble",
    "lyapunov",
    "orbits",
    "parameters",
    "simulate",
]

