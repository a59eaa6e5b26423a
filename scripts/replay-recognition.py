#!/usr/bin/env python3
"""Replays early exit's recognition rule on full-length Poincare records (issue 24).

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

The replay has no rounds (every lane sees the basin's whole catalogue from its start),
so its share of periods is that of a real run less its first round's full-length lanes
(at 133 rad/s 32.4 % replayed against 33.7 % run). Needs numpy. docs/early-exit.md,
"Replaying the rule", has what it found.
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


def replay(basin, ensemble, streaks, rels, seps, after):
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
    dist = {i: np.abs(pts[:, :, None, :] - c[None, None]).max(-1) for i, c, _ in cycles}

    def separation(i, c):
        return min(
            (np.abs(c[:, None] - d[None]).max(-1).min() for j, d, _ in cycles if j != i),
            default=np.inf,
        )

    for streak in streaks:
        for rel in rels:
            for sepf in seps:
                tol = {}
                for i, c, size in cycles:
                    ident = max(cfg["match_rel"] * size, cfg["match_abs"])
                    sep = separation(i, c)
                    cap = sepf * sep
                    # Never recognised within four identity tolerances, the floor at
                    # most 1 um (catalogue::separation_identity, SEPARATION_ABS).
                    if max(cfg["match_rel"] * size, min(cfg["match_abs"], 1e-6)) > 0.25 * sep:
                        continue
                    tol[i] = min(max(ident, min(rel * size, cap)), cap)
                ret = np.full(n, k)
                lab = np.full(n, -1)
                for lane in range(n):
                    cur, nxt, run = None, 0, 0
                    for p in range(after - 1, k):
                        if run > 0:
                            if dist[cur][lane, p, nxt] <= tol[cur]:
                                run += 1
                                nxt = (nxt + 1) % dist[cur].shape[2]
                            else:
                                run = 0
                        if run == 0:
                            for i in tol:
                                js = np.nonzero(dist[i][lane, p] <= tol[i])[0]
                                if js.size:
                                    cur, nxt, run = i, (js[0] + 1) % dist[i].shape[2], 1
                                    break
                        if run > 0 and run >= max(streak, 2 * dist[cur].shape[2]):
                            ret[lane], lab[lane] = p + 1, cur
                            break
                done = lab >= 0
                wrong = int((lab[done] != labels[done]).sum())
                print(
                    f"streak {streak:3d} rel {rel:5.2f} sep {sepf:5.2f}: "
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
    r.add_argument("--after", type=int, default=30)
    o = ap.parse_args()
    if o.cmd == "lanes":
        lanes(o.basin)
    else:
        replay(o.basin, o.ensemble, o.streak, o.rel, o.sep, o.after)


if __name__ == "__main__":
    main()
