"""The hostile user's probe of the Python package, kept: a table of bad inputs for every
public function. What it proves: each raises ValueError or TypeError (never an
OverflowError, a crash, an abort or a long wait) whose message names the keyword; huge
ranges are refused before anything is allocated; Ctrl-C stops `simulate` and `lyapunov`
within a second; every public function has rows in the table, so the next one added is
probed too."""

import _thread
import threading
import time

import numpy as np
import pytest

import jeffcott

BOX = ("x_r", -0.006, 0.006, 4)
VBOX = ("vx_r", -1.0, 1.0, 4)

# (function name, call, exception type, text the message must contain)
CASES = [
    # simulate
    ("simulate", lambda: jeffcott.simulate(132.2, transient=-1), ValueError, "transient"),
    ("simulate", lambda: jeffcott.simulate(132.2, transient="10"), TypeError, "transient"),
    ("simulate", lambda: jeffcott.simulate(132.2, periods=2**40), ValueError, "periods"),
    ("simulate", lambda: jeffcott.simulate(132.2, params={"mu": "x"}), TypeError, "params"),
    ("simulate", lambda: jeffcott.simulate(132.2, params={"spin": 1.0}), ValueError, "spin"),
    ("simulate", lambda: jeffcott.simulate(132.2, init=[1, 2]), TypeError, "init"),
    ("simulate", lambda: jeffcott.simulate(float("nan")), ValueError, "omega"),
    ("simulate", lambda: jeffcott.simulate(132.2, steps_per_period=-5), ValueError, "steps_per_period"),
    # ensemble
    ("ensemble", lambda: jeffcott.ensemble("130:141:1000000000"), ValueError, "omega"),
    ("ensemble", lambda: jeffcott.ensemble("130:141:100000000"), ValueError, "omega"),
    ("ensemble", lambda: jeffcott.ensemble("130:130:4"), ValueError, "omega"),
    ("ensemble", lambda: jeffcott.ensemble(133.0, backend="tpu"), ValueError, "backend"),
    ("ensemble", lambda: jeffcott.ensemble(133.0, backend=3), TypeError, "backend"),
    ("ensemble", lambda: jeffcott.ensemble(133.0, progress=5), TypeError, "progress"),
    ("ensemble", lambda: jeffcott.ensemble(133.0, periods=-1), ValueError, "periods"),
    (
        "ensemble",
        lambda: jeffcott.ensemble(lanes=np.zeros((2, 2, 2)), columns=["omega", "mu"]),
        ValueError,
        "lanes",
    ),
    (
        "ensemble",
        lambda: jeffcott.ensemble(lanes=np.array([["a", "b"]]), columns=["omega", "mu"]),
        TypeError,
        "lanes",
    ),
    # bifurcation
    ("bifurcation", lambda: jeffcott.bifurcation("130:141:1000000000"), ValueError, "omega"),
    ("bifurcation", lambda: jeffcott.bifurcation("130:141:4", ics=-1), ValueError, "ics"),
    ("bifurcation", lambda: jeffcott.bifurcation("130:141:4", sweep=1), TypeError, "sweep"),
    # basin
    (
        "basin",
        lambda: jeffcott.basin(133, BOX, VBOX, uncertainty_samples=10**12),
        ValueError,
        "uncertainty_samples",
    ),
    ("basin", lambda: jeffcott.basin(133, BOX, VBOX, refine=-1), ValueError, "refine"),
    ("basin", lambda: jeffcott.basin(133, ("x_r", -0.006, 0.006, 1), VBOX), ValueError, "x"),
    # basin_metrics
    ("basin_metrics", lambda: jeffcott.basin_metrics(np.zeros((0, 0), np.int32)), ValueError, "labels"),
    ("basin_metrics", lambda: jeffcott.basin_metrics(np.zeros(4, np.int32)), TypeError, "labels"),
    # lyapunov
    ("lyapunov", lambda: jeffcott.lyapunov(140, time=-1.0), ValueError, "time"),
    ("lyapunov", lambda: jeffcott.lyapunov(140, window=-1), ValueError, "window"),
    ("lyapunov", lambda: jeffcott.lyapunov(140, time="long"), TypeError, "time"),
    # map
    ("map", lambda: jeffcott.map(("omega", 131, 134, 4), ("e", 0.0002, 0.002, 3), omega=133.0), ValueError, "omega"),
    ("map", lambda: jeffcott.map(("mu", 0, 0.3, 4), ("e", 0.0002, 0.002, 3), omega=float("nan")), ValueError, "omega"),
    ("map", lambda: jeffcott.map(("omega", 131, 134, 4), ("e", 0.0002, 0.002, 3), ics=-2), ValueError, "ics"),
    # continuation
    ("continuation", lambda: jeffcott.continuation("omega:130:141:1000000000000"), ValueError, "param"),
    ("continuation", lambda: jeffcott.continuation("omega:130:141:4", ics=-1), ValueError, "ics"),
    (
        "continuation",
        lambda: jeffcott.continuation("omega:130:141:4", start_box="x_r:-2:2"),
        ValueError,
        "start_box",
    ),
    # basin_stability
    ("basin_stability", lambda: jeffcott.basin_stability("130:141:1000000", "x_r:-0.006:0.006"), ValueError, "omega"),
    ("basin_stability", lambda: jeffcott.basin_stability(133.0, "spin:0:1"), ValueError, "start_box"),
    ("basin_stability", lambda: jeffcott.basin_stability(133.0, "x_r:-0.006:0.006", sample=1), ValueError, "sample"),
    # cascade
    ("cascade", lambda: jeffcott.cascade("141:130:4"), ValueError, "omega"),
    ("cascade", lambda: jeffcott.cascade("130:141:1000000000"), ValueError, "omega"),
    ("cascade", lambda: jeffcott.cascade("130:141:4", periods=-1), ValueError, "periods"),
    # parameters
    ("parameters", lambda: jeffcott.parameters({"mu": -1.0}), ValueError, "mu"),
    ("parameters", lambda: jeffcott.parameters({"mu": "x"}), TypeError, "params"),
    # adapters takes no input
    ("adapters", lambda: jeffcott.adapters(1), TypeError, "argument"),
]


@pytest.mark.parametrize("name,call,kind,needle", CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_every_bad_input_raises_value_or_type_error_naming_the_keyword(name, call, kind, needle):
    t0 = time.monotonic()
    with pytest.raises((ValueError, TypeError)) as e:
        call()
    assert isinstance(e.value, kind), f"{type(e.value).__name__}: {e.value}"
    assert needle in str(e.value), str(e.value)
    # Refused before any work: no integration, no huge allocation.
    assert time.monotonic() - t0 < 5.0


def test_every_public_function_has_rows_in_the_bad_input_table():
    public = {
        n
        for n in dir(jeffcott)
        if not n.startswith("_") and callable(getattr(jeffcott, n))
    }
    probed = {c[0] for c in CASES}
    assert public <= probed, f"not probed: {sorted(public - probed)}"


def interrupted_after(call, delay=1.0):
    """Runs `call`, sends Ctrl-C after `delay` s; returns seconds from signal to return."""
    fired = []

    def interrupt():
        fired.append(time.monotonic())
        _thread.interrupt_main()

    timer = threading.Timer(delay, interrupt)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        call()
    back = time.monotonic()
    timer.join()
    assert fired, "the interrupt never fired: the run ended first"
    return back - fired[0]


def test_ctrl_c_stops_simulate_within_a_second(sigint_raises):
    # 100000 transient periods: ~9 s of CPU work.
    late = interrupted_after(lambda: jeffcott.simulate(132.2, transient=100000))
    assert late < 1.0, f"control came back {late:.2f} s after Ctrl-C"


def test_ctrl_c_stops_lyapunov_within_a_second(sigint_raises):
    late = interrupted_after(lambda: jeffcott.lyapunov(140, time=3000.0, min_time=3000.0))
    assert late < 1.0, f"control came back {late:.2f} s after Ctrl-C"
