#!/usr/bin/env python
"""One-mode campaign on an obstacle a small gap below: does
gaocvx.nonconvex.equilibria miss a stable equilibrium near the flat beam?

Each scene (a seeded draw): the thesis's beam (1 m, h = 0.2 m, E = 2.1e11 Pa,
nu = 0.3) on supports P1-P4, 4-10 elements, an obstacle 10^U(-15, -12.5) m
below (``--bed``: a unilateral bed there), a uniform load q = -10^U(-7, -1) N/m
or one point force of that size at x in [0.1, 0.9] m, and P = U(1.02, 1.9)
P_bar_h (``--modes 2``: U(2, 6)); scenes with other than ``--modes`` unstable
modes (by the independent energy) are skipped.

* ``equilibria(scene)`` is run and timed (the library from ``--src``);
* the independent energy (tests/nonconvex_independent.py::Discrete, in units of
  the gap) is minimised locally (SLSQP with the obstacle's rows) from
  ``--starts`` random starts 0.1 to 30 gaps in size; an end that is a KKT point
  (stationarity <= 1e-7, infeasibility <= 1e-10 of max(|x|, 1)) with positive
  curvature on the null space of the rows carrying a force, within 1e4 gaps of
  w = 0, is a near-flat minimum;
* a MISS: such a minimum with no stable listed entry whose nodal deflections lie
  within 1e-3 of its largest (at least 1e-3 gap).

Prints one line per scene and a summary: misses, and misses in lists that are
all ``optimal`` and ``complete`` (wrong answers); writes ``<out>/<seed>.jsonl``.

Usage (from the repository's root)::

    OMP_NUM_THREADS=1 python benchmarks/small_gap_campaign.py --seed 1 --count 60 --out /tmp/sg
    OMP_NUM_THREADS=1 python benchmarks/small_gap_campaign.py --seed 1 --count 60 --out /tmp/sg0 \\
        --src /path/to/another/tree
    OMP_NUM_THREADS=1 python benchmarks/small_gap_campaign.py --modes 2 --seed 32 --count 24 --out /tmp/sg2

The numbers in docs/nonconvex-campaign.md come from such runs.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import time
import warnings

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--src", default=ROOT, help="source tree of gaocvx under test (put first on the path)")
ap.add_argument("--tests", default=os.path.join(ROOT, "tests"),
                help="directory of the independent reference (nonconvex_independent.py)")
ap.add_argument("--out", required=True, help="output directory")
ap.add_argument("--seed", type=int, default=1)
ap.add_argument("--count", type=int, default=60, help="scenes drawn")
ap.add_argument("--starts", type=int, default=40, help="independent local minimisations per scene")
ap.add_argument("--modes", type=int, default=1, choices=(1, 2),
                help="unstable modes: P = U(1.02, 1.9) P_bar_h for one, U(2, 6) for two")
ap.add_argument("--bed", action="store_true",
                help="a unilateral bed (stiffness 10^U(9, 12) N/m^2) instead of the obstacle")
args = ap.parse_args()
sys.path[:0] = [args.src, args.tests]

import numpy as np  # noqa: E402

from gaocvx import Scene  # noqa: E402
from gaocvx.discrete import DiscreteProblem  # noqa: E402
from gaocvx.nonconvex.stationary import equilibria  # noqa: E402
from nonconvex_independent import Discrete  # noqa: E402

BEAM = {"model": "gao", "length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1,
        "width": 1.0}


def draw(rng) -> dict:
    load = {}
    if rng.uniform() < 0.5:
        load["q"] = -float(10 ** rng.uniform(-7, -1))
    else:
        load["points"] = [[float(rng.uniform(0.1, 0.9)), -float(10 ** rng.uniform(-7, -1))]]
    data = {"beam": {**BEAM, "supports": str(rng.choice(["P1", "P2", "P3", "P4"]))},
            "load": {**load, "axial": 0.0}, "mesh": {"elements": int(rng.integers(4, 11))}}
    gap = float(10 ** rng.uniform(-15, -12.5))
    if args.bed:
        data["foundation"] = {"gap": gap, "stiffness": float(10 ** rng.uniform(9, 12))}
    else:
        data["obstacle"] = {"gap": gap}
    limit = DiscreteProblem(Scene.from_dict(data)).P_bar_h
    data["load"]["axial"] = float(limit * (rng.uniform(1.02, 1.9) if args.modes == 1
                                           else rng.uniform(2.0, 6.0)))
    return data


def near_flat_minima(en, rng, starts) -> list:
    """The independent near-flat minima: nodal w [m] of each distinct stable KKT end
    (on a bed, with every point clear of its edge: its stability is then known)."""
    minima = []
    for _ in range(starts):
        x, _, _ = en.local_min(rng.normal(size=en.n) * 10 ** rng.uniform(-1, 1.5), slsqp_iter=400)
        kkt = en.kkt(x)
        if (kkt["stationarity"] > 1e-7 or kkt["feasibility"] > 1e-10 or kkt["lowest"] <= 1e-9
                or np.abs(x).max() > 1e4):
            continue
        if args.bed:
            depth = np.asarray(en.gql - en._local(x)[5], float)
            if np.abs(depth).min() < 1e-6 * np.abs(depth).max():
                continue
        if not any(np.abs(x - v).max() < 1e-5 * max(np.abs(x).max(), 1.0) for v in minima):
            minima.append(x)
    return [en.nodal_w(x) for x in minima]


def main() -> None:
    warnings.filterwarnings("ignore")
    logging.disable(logging.WARNING)
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    rows = []
    with open(os.path.join(args.out, f"{args.seed}.jsonl"), "w") as fh:
        for i in range(args.count):
            data = draw(rng)
            scene = Scene.from_dict(data)
            gap = (data.get("obstacle") or data["foundation"])["gap"]
            en = Discrete(scene, W=gap)
            if en.unstable_modes() != args.modes:
                continue
            t = time.perf_counter()
            eqs = equilibria(scene)
            t = time.perf_counter() - t
            minima = near_flat_minima(en, rng, args.starts)
            missed = [w.tolist() for w in minima if not any(
                e.stable and np.max(np.abs(e.w - w)) <= 1e-3 * max(np.abs(w).max(), gap)
                for e in eqs)]
            rec = {"i": i, "data": data, "time": t, "entries": len(eqs),
                   "optimal": all(e.status == "optimal" for e in eqs),
                   "complete": eqs[0].complete if eqs else None,
                   "stable": [bool(e.stable) for e in eqs], "minima": len(minima),
                   "missed": missed}
            fh.write(json.dumps(rec) + "\n")
            fh.flush()
            rows.append(rec)
            print(f"{i:3d} {data['beam']['supports']} {data['mesh']['elements']:2d} el  gap "
                  f"{gap:8.2g}  {'q' if 'q' in data['load'] else 'point':5s}  {len(eqs)} entries"
                  f"  optimal {rec['optimal']!s:5s}  complete {rec['complete']!s:5s}  "
                  f"{t:5.1f} s  {'MISS' if missed else ''}", flush=True)
    wrong = [r for r in rows if r["missed"] and r["optimal"] and r["complete"]]
    print(f"\nseed {args.seed}: {len(rows)} scenes, {sum(bool(r['missed']) for r in rows)} with a "
          f"missed minimum ({len(wrong)} in lists `optimal` and `complete`), "
          f"{sum(r['optimal'] for r in rows)} lists all `optimal`, "
          f"{sum(bool(r['complete']) for r in rows)} `complete`, "
          f"equilibria {sum(r['time'] for r in rows):.0f} s")


if __name__ == "__main__":
    main()
