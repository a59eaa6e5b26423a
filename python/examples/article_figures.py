"""The article's Fig. 3 and Fig. 7 from Python, notebook style: each cell below is what
one would type into Jupyter. Run as a script:

    python python/examples/article_figures.py --out figures          # ~1 min on 2 cores
    python python/examples/article_figures.py --quick --out figures  # a few seconds

Fig. 3: the stator's vx_s at t = kT against W, a quasistatic sweep up from the static
equilibrium at 130 rad/s, with the largest Lyapunov exponent of each speed underneath
(as `jeffcott bifurcation --omega 130:141:400 --sweep up`).
Fig. 7: which start states (rotor x_r, vx_r; the rest at the static equilibrium) end on
which of the coexisting attractors at W = 133 rad/s (as `jeffcott basin --omega 133
--x x_r:-0.006:0.006:80 --y vx_r:-1:1:80 --transient 250 --periods 32`).
"""

import argparse
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import jeffcott

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--out", default="jeffcott-out/python", help="folder for the PNGs")
parser.add_argument("--quick", action="store_true", help="coarse grids (a smoke test)")
args = parser.parse_args()
out = Path(args.out)
out.mkdir(parents=True, exist_ok=True)
speeds, cells = (60, 16) if args.quick else (400, 80)

# %% Fig. 3: the sweep up in W (CPU: the quasistatic sweep is sequential in W).
t0 = time.perf_counter()
bif = jeffcott.bifurcation(f"130:141:{speeds}", sweep="up", ics=0)
t_bif = time.perf_counter() - t0
rows, points, lam = bif["rows"], bif["points"], bif["lambda1"]
up = rows[:, 1] == 0  # sweep 0: up
w = np.repeat(rows[up, 0], points.shape[1])
vx_s = points[up][:, :, jeffcott.COORD_NAMES.index("vx_s")].ravel()

fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(8, 6),
                                  gridspec_kw={"height_ratios": [3, 1]})
top.plot(w, vx_s, ",", color="tab:blue")
top.set_ylabel("vx_s at t = kT [m/s]")
top.set_title(f"Fig. 3: bifurcation diagram, W increasing ({speeds} speeds)")
bottom.plot(rows[up, 0], lam[up], color="tab:red", lw=1)
bottom.axhline(0, color="grey", lw=0.5)
bottom.set_xlabel("W [rad/s]")
bottom.set_ylabel("lambda_1 [1/s]")
fig.tight_layout()
fig.savefig(out / "fig3_bifurcation.png", dpi=120)
plt.close(fig)

# %% Fig. 7: the basin at 133 rad/s.
t0 = time.perf_counter()
b = jeffcott.basin(133.0, ("x_r", -0.006, 0.006, cells), ("vx_r", -1.0, 1.0, cells),
                   transient=250, periods=32)
t_basin = time.perf_counter() - t0
labels = np.ma.masked_less(b["labels"], 0)  # -1: diverged
fig, ax = plt.subplots(figsize=(6, 5))
im = ax.pcolormesh(b["x"] * 1e3, b["y"], labels, cmap="tab10", vmin=0, vmax=9,
                   shading="nearest")
for a in b["attractors"]:
    ax.plot([], [], "s", color=plt.cm.tab10(a["id"]),
            label=f"{a['class']} ({100 * a['basin_fraction']:.1f} %)")
ax.legend(loc="upper right")
ax.set_xlabel("x_r(0) [mm]")
ax.set_ylabel("vx_r(0) [m/s]")
ax.set_title(f"Fig. 7: basin of attraction at W = 133 rad/s ({cells} x {cells})")
fig.tight_layout()
fig.savefig(out / "fig7_basin.png", dpi=120)
plt.close(fig)

found = ", ".join(f"{a['class']} {100 * a['basin_fraction']:.1f} %" for a in b["attractors"])
print(f"Fig. 3: {speeds} speeds in {t_bif:.1f} s; Fig. 7: {cells} x {cells} cells in "
      f"{t_basin:.1f} s ({found}); pictures in {out}")
