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
- :func:`parameters` and :func:`adapters` the model's parameters and the GPU adapters.

``backend`` is ``"auto"`` (a hardware GPU if present, else all CPU cores), ``"cpu"`` or
``"gpu"`` (any adapter, Mesa's lavapipe included); ``precision=None`` is f64 on the CPU
and f32 on a GPU. ``progress`` takes a callable ``f(done, total)`` (lane-periods).
Ctrl-C stops a run cleanly (KeyboardInterrupt); bad input raises ``ValueError`` naming
the field and its allowed range; GPU problems raise ``RuntimeError``.
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
    LANES_COLUMNS,
    PARAM_KEYS,
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
    parameters,
    simulate,
)

import functools as _functools
import inspect as _inspect
import re as _re

import numpy as _np

# What a keyword accepts, where its default does not say it (see _named).
_ACCEPTS = {
    "params": "a dict of model parameter names (PARAM_KEYS) to numbers, or None",
    "init": "a dict of start coordinate names (COORD_NAMES) to numbers, or None",
    "fix": "a dict of start coordinate names (COORD_NAMES) to numbers, or None",
    "progress": "a callable f(done, total), or None",
    "precision": "'f32', 'f64' or None",
    "lanes": "a 2-D array of numbers [lanes, columns], or None",
    "columns": "a list of column names, or None",
    "omega": "a speed in rad/s, a sequence of speeds or \"a:b:n\"",
    "labels": "a 2-D integer array of attractor ids",
    "timeseries_periods": "a whole number of forcing periods, or None",
    "min_time": "a time in s, or None",
    "match_threshold": "a positive number, or None",
    "start_box": "\"NAME:lo:hi,...\" or None",
}


def _accepts(f, name):
    """What keyword `name` of `f` accepts, from the table or its default's type."""
    if name in _ACCEPTS:
        return _ACCEPTS[name]
    try:
        default = _inspect.signature(f).parameters[name].default
    except (TypeError, ValueError, KeyError):
        return "see help(jeffcott.%s)" % f.__name__
    if isinstance(default, bool):
        return "True or False"
    if isinstance(default, int):
        return "a whole number >= 0 (%s by default)" % default
    if isinstance(default, float):
        return "a number (%s by default)" % default
    if isinstance(default, str):
        return "a string (%r by default)" % default
    return "see help(jeffcott.%s)" % f.__name__


def _named(f):
    """`f` with argument conversion errors naming the keyword and what it accepts.

    PyO3 raises a bare OverflowError for -1 given as a count and a TypeError without the
    keyword for a wrong type; it notes the keyword (``while processing 'x'``) on Python
    >= 3.11, which this reads. A negative or too large count becomes a ValueError, a
    wrong type a TypeError, both naming the keyword. ``progress`` is checked for being
    callable before the run starts.
    """

    @_functools.wraps(f)
    def call(*args, **kwargs):
        progress = kwargs.get("progress")
        if progress is not None and not callable(progress):
            raise TypeError(
                "invalid value for `progress`: %r (expected %s)"
                % (progress, _ACCEPTS["progress"])
            )
        lanes = kwargs.get("lanes")
        if lanes is not None:
            # Any numeric dtype and memory order, as numpy reads it (row by row).
            try:
                lanes = _np.ascontiguousarray(lanes, dtype=_np.float64)
            except (TypeError, ValueError) as e:
                raise TypeError(
                    "invalid value for `lanes`: %s (expected %s)" % (e, _ACCEPTS["lanes"])
                ) from e
            if lanes.ndim != 2:
                raise ValueError(
                    "invalid value for `lanes`: an array of shape %s (expected %s)"
                    % (lanes.shape, _ACCEPTS["lanes"])
                )
            kwargs["lanes"] = lanes
        try:
            return f(*args, **kwargs)
        except (TypeError, OverflowError) as e:
            for note in getattr(e, "__notes__", ()):
                m = _re.match(r"while processing '(\w+)'", note)
                if m:
                    name = m.group(1)
                    kind = ValueError if isinstance(e, OverflowError) else TypeError
                    raise kind(
                        "invalid value for `%s`: %s (expected %s)"
                        % (name, e, _accepts(f, name))
                    ) from e
            raise

    return call


# `map` is not in __all__: a star import would shadow the builtin map.
__all__ = [
    "COORD_NAMES",
    "LANES_COLUMNS",
    "PARAM_KEYS",
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
    "parameters",
    "simulate",
]

# Every function of the package (`map` too) with conversion errors that name the keyword.
for _name in __all__ + ["map"]:
    if callable(globals()[_name]):
        globals()[_name] = _named(globals()[_name])
del _name
