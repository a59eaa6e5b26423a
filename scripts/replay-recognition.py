#!/usr/bin/env python3
"""Replays early exit's recognition rule on full-length Poincare records (how its
tolerances were chosen; docs/early-exit.md).

How far can the recognition tolerance go before a lane is retired on the wrong
attractor, and what does each setting save? Answered offline, without re-running the
basin for every setting: run the basin's start states once full length with
`jeffcott ensemble`, then replay the rule of `jeffcott_analysis::early::Recogniser` on
the records for any (streak, diameter fraction, separation cap) and compare each
recognised label with the lane's full-length label.

    jeffcott basin --omega 133 --x x_r:-0.006:0.006:100 --y vx_r:-1:1:100 \\
        --transient 250 --periods 32 --uncertainty-samples 0 --no-plot --out B
    python3 scripts/replay-recognition.py lanes B > lanes.csv
    jeffcott ensemble --lanes lanes.csv --omega 133 --transient 0 --periods 282 --out E
    python3 scripts/replay-recognition.py replay B E --streak 16 --sep 0.25 0.45 1.0
    python3 scripts/replay-recognition.py replay B E --streak 8 --sep 0.75 1.0 --rho 0.8

The replay has no rounds (every lane sees the basin's whole catalogue from its start),
so its share of periods is that of a real run less its first round's full-length lanes
(at 133 rad/s 32.4 % replayed against 33.7 % run). A streak is any run of points in
one cycle's order (all cycles and phases at once, vectorised); where a cap of half the
separation or more lets a point match two cycles, a lane takes the one whose streak
completes first, where the recogniser takes the first it matched (at 133, streak 8,
cap 1.0: 191 lanes wrong against the loop's 186). `--rho` adds the contraction guard.
Needs numpy. docs/early-exit.md, "Replaying the rule", has what it found.
"""
import argparse
import json
import os
import sys

import numpy as np


def lanes(basin):
    """The basin's start states as an ensemble lane table (x fastest, as labels.npy)."""
    run = json.load(open(os.path.join(basin, "run.json")))
    x = np.load(os.path.join(basin, "x.npy"))
    y = np.load(os.path.join(basin, "y.npy"))
    cx, cy = run["spec"]["x"]["coord"], run["spec"]["y"]["coord"]
    print(f"{cx},{cy}")
    for yv in y:
        for xv in x:
            print(f"{float(xv)!r},{float(yv)!r}")


def run_lengths(ok):
    """For each lane and period, how many points in a row up to it are `ok`."""
    out = np.zeros(ok.shape, np.int32)
    r = np.zeros(ok.shape[0], np.int32)
    for p in range(ok.shape[1]):
        r = np.where(ok[:, p], r + 1, 0)
        out[:, p] = r
    return out


def sliding_max(e, width):
    """max(e[:, p - width + 1 .. p]) for each p (fewer at the start)."""
    out = e.copy()
    for s in range(1, width):
        out[:, s:] = np.maximum(out[:, s:], e[:, :-s])
    return out


def replay(basin, ensemble, streaks, rels, seps, rhos, after):
    att = json.load(open(os.path.join(basin, "attractors.json")))
    w = att["omega"]
    cfg = att["catalogue_config"]
    labels = np.load(os.path.join(basin, "labels.npy")).reshape(-1)
    # The catalogue's metric (classify::distance): largest coordinate difference,
    # velocities divided by W.
    scale = np.array([1.0, w] * 4)
    pts = np.load(os.path.join(ensemble, "poincare.npy")) / scale
    n, k, _ = pts.shape
    if n != labels.size:
        sys.exit(f"{ensemble}: {n} lanes, the basin has {labels.size} cells")
    cycles = [
        (a["id"], np.array(a["points"]) / scale, a["size_m"])
        for a in att["attractors"]
        if a["class"].startswith("period-")
    ]
    # A streak in cyclic order is a run of points p, p + 1, ... within the tolerance
    # of cycle points p + phi, p + 1 + phi, ... for one phase phi: e[i][phi][lane, p]
    # is point p's distance to cycle point (p + phi) mod P.
    e = {}
    for i, c, _ in cycles:
        d = np.abs(pts[:, :, None, :] - c[None, None]).max(-1)
        e[i] = [d[:, np.arange(k), (np.arange(k) + phi) % len(c)] for phi in range(len(c))]

    def separation(i, c):
        return min(
            (np.abs(c[:, None] - d[None]).max(-1).min() for j, d, _ in cycles if j != i),
            default=np.inf,
        )

    for streak in streaks:
        for rel in rels:
            for sepf in seps:
                for rho in rhos:
                    tol = {}
                    for i, c, size in cycles:
                        ident = max(cfg["match_rel"] * size, cfg["match_abs"])
                        sep = separation(i, c)
                        cap = sepf * sep
                        # Never recognised within four identity tolerances, the floor
                        # at most 1 um (catalogue::separation_identity, SEPARATION_ABS).
                        if max(cfg["match_rel"] * size, min(cfg["match_abs"], 1e-6)) > 0.25 * sep:
                            continue
                        tol[i] = min(max(ident, min(rel * size, cap)), cap)
                    ret = np.full(n, k)
                    lab = np.full(n, -1)
                    for i in tol:
                        period = len(e[i])
                        need = max(streak, 2 * period)
                        for ei in e[i]:
                            fire = run_lengths(ei <= tol[i]) >= need
                            if rho is not None:
                                # The streak's last cycle no farther than rho times its
                                # first (each the largest distance over a cycle).
                                m = sliding_max(ei, period)
                                first = np.full_like(m, np.inf)
                                first[:, need - 1:] = m[:, period - 1: k - need + period]
                                fire &= m <= rho * first
                            fire[:, : after - 1] = False
                            p = np.where(fire.any(1), fire.argmax(1), k)
                            sooner = p + 1 < ret
                            ret = np.where(sooner, p + 1, ret)
                            lab = np.where(sooner, i, lab)
                    done = lab >= 0
                    wrong = int((lab[done] != labels[done]).sum())
                    print(
                        f"streak {streak:3d} rel {rel:5.2f} sep {sepf:5.2f} "
                        f"rho {rho if rho is not None else '-':>4}: "
                        f"retired {int(done.sum())} of {n}, wrong {wrong}, "
                        f"periods {100 * ret.sum() / (n * k):.1f} %, "
                        f"median retirement {np.median(ret[done]) if done.any() else 0:.0f}"
                    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("lanes", help="write the basin's start states as a lane table")
    a.add_argument("basin")
    r = sub.add_parser("replay", help="replay the rule on full-length records")
    r.add_argument("basin")
    r.add_argument("ensemble")
    r.add_argument("--streak", type=int, nargs="+", default=[16])
    r.add_argument("--rel", type=float, nargs="+", default=[0.1])
    r.add_argument("--sep", type=float, nargs="+", default=[0.45])
    r.add_argument(
        "--rho",
        type=float,
        nargs="+",
        default=[None],
        help="also require the streak's last cycle within RHO times its first",
    )
    r.add_argument("--after", type=int, default=30)
    o = ap.parse_args()
    if o.cmd == "lanes":
        lanes(o.basin)
    else:
        replay(o.basin, o.ensemble, o.streak, o.rel, o.sep, o.rho, o.after)


if __name__ == "__main__":
    main()
