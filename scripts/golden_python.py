"""Part of scripts/golden.sh: calls every public function of the jeffcott package once,
at small sizes on the CPU, and writes what each returns under OUT/<function>/: every
numpy array as .npy, everything else as one sorted JSON file (run-to-run values such as
wall times are masked by golden.sh's manifest)."""

import json
import sys
from pathlib import Path

import numpy as np

import jeffcott

out = Path(sys.argv[1])
cpu = {"backend": "cpu"}


def save(name, value):
    d = out / name
    d.mkdir(parents=True, exist_ok=True)
    rest = {}

    def walk(v, path):
        if isinstance(v, np.ndarray):
            np.save(d / (path.replace("/", ".") + ".npy"), v)
            return f"<array {path}>"
        if isinstance(v, dict):
            return {k: walk(x, f"{path}/{k}" if path else str(k)) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [walk(x, f"{path}/{i}") for i, x in enumerate(v)]
        if isinstance(v, (np.integer, np.floating)):
            return v.item()
        return v

    rest = walk(value, "")
    (d / "result.json").write_text(json.dumps(rest, sort_keys=True, indent=1, default=repr))


save("simulate", jeffcott.simulate(132.2, transient=60, periods=24))
save("ensemble", jeffcott.ensemble("130:141:12", transient=40, periods=8, lyapunov=True, **cpu))
save(
    "ensemble_lanes",
    jeffcott.ensemble(
        lanes=np.array([[131.0, 0.1], [133.0, 0.15]]), columns=["omega", "mu"],
        transient=30, periods=8, **cpu,
    ),
)
save(
    "basin",
    jeffcott.basin(
        133.0, ("x_r", -0.006, 0.006, 10), "vx_r:-1:1:9", transient=120, periods=16,
        refine=1, uncertainty_samples=6, **cpu,
    ),
)
save(
    "basin_lyapunov",
    jeffcott.basin(
        137.25, ("x_r", -0.004, 0.004, 6), ("vx_r", -0.5, 0.5, 5), fix={"y_r": 5e-4},
        params={"mu": 0.12}, transient=80, periods=16, lyapunov=True, **cpu,
    ),
)
save(
    "bifurcation",
    jeffcott.bifurcation(
        "131:135:6", ics=2, transient=20, transient_first=40, brute_transient=40,
        periods=12, **cpu,
    ),
)
save("lyapunov", jeffcott.lyapunov(135.0, transient=40, time=3.0, min_time=3.0))
save(
    "map",
    jeffcott.map("omega:131:137:4", "e:2e-5:6e-5:3", ics=2, transient=60, periods=12, **cpu),
)
save(
    "continuation",
    jeffcott.continuation("omega:132:134:3", ics=6, transient=60, periods=12, **cpu),
)
save(
    "basin_stability",
    jeffcott.basin_stability(
        "132:134:2", "x_r:-0.004:0.004,vx_r:-0.5:0.5", sample=12, transient=60,
        periods=12, **cpu,
    ),
)
save(
    "cascade",
    jeffcott.cascade("130:140:4", transient_first=40, transient=20, periods=24),
)
save("basin_metrics", jeffcott.basin_metrics(np.array([[0, 0, 1], [0, 1, 1], [1, 1, -1]])))
save("parameters", jeffcott.parameters({"mu": 0.2}))
