"""Many-scene throughput: a stiffness-gap map of a 256-element foundation scene.

    python benchmarks/throughput.py [--points 100] [--output docs/throughput.md]

Solves the Gao beam on a unilateral foundation (P1, q = -5e8 N/m, 256 elements)
at every point of a grid of foundation stiffness (1e8..1e13 N/m^2, log) and
gap (1..10 mm): 100 x 100 = 10^4 values by default, each certified as every
solve is.  The same sweep runs in one process, over ``--jobs 2`` worker
processes, and through a local Dask cluster of two single-threaded worker
processes, each sending back only its rows (``reduce``, as the command line
does).  Each time is also given per value and as a ratio to one sparse solve
(scipy spsolve) of the Euler-Bernoulli system of the same mesh, measured in the
same run, because shared machines are noisy.
"""

import argparse
import functools
import os
import platform
import statistics
import sys
import time

import numpy as np
import scipy

import gaocvx
from gaocvx import Scene
from gaocvx.sweep import grid, parse_range, summary_row, sweep
from performance import sparse_solve_time  # the same baseline as docs/performance.md

BEAM = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}
SCENE = {"beam": {**BEAM, "model": "gao", "supports": "P1"}, "load": {"q": -5e8},
         "foundation": {"gap": 0.007, "stiffness": 5e10}, "mesh": {"elements": 256}}
KEYS = ("foundation.stiffness", "foundation.gap")
TARGET_S = 30.0


def run(points, **how):
    scene = Scene.from_dict(SCENE)
    reduce = functools.partial(summary_row, keys=KEYS)
    t0 = time.perf_counter()
    rows = [row for _, row in sweep(scene, KEYS, points, method="newton", reduce=reduce, **how)]
    return time.perf_counter() - t0, rows


def dask_run(points, workers):
    from dask.distributed import LocalCluster
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        return run(points, dask=cluster.scheduler_address)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=100, help="values per key (default 100)")
    ap.add_argument("--output", help="Markdown file to write")
    args = ap.parse_args()
    points = grid(parse_range(f"1e8:1e13:{args.points}:log"),
                  parse_range(f"0.001:0.01:{args.points}"))
    base = sparse_solve_time(256, repeat=21)
    print(f"one sparse solve (N = 256): {base * 1e3:.3f} ms", file=sys.stderr)
    runs = []
    for label, fn in [("one process", lambda: run(points)),
                      ("--jobs 2", lambda: run(points, jobs=2)),
                      ("Dask, 2 worker processes", lambda: dask_run(points, 2))]:
        t, rows = fn()
        certified = sum(r["status"] == "optimal" for r in rows)
        runs.append((label, t, certified, len(rows)))
        print(f"{label:28s} {t:7.1f} s  {t / len(rows) * 1e3:6.2f} ms/value  "
              f"{certified}/{len(rows)} certified", file=sys.stderr)
        if label == "one process":
            serial = rows
        else:  # the same answers, whichever way the values were spread
            dev = max(abs(a["min_w"] - b["min_w"]) / abs(b["min_w"]) for a, b in zip(rows, serial))
            print(f"{'':28s} largest relative difference of min w from one process: {dev:.1e}",
                  file=sys.stderr)
    solve_ms = statistics.median(r["time_s"] for r in serial) * 1e3
    n = len(points)
    lines = [
        "# Throughput: a stiffness-gap map",
        "",
        f"Made by `python benchmarks/throughput.py --points {args.points} --output "
        f"{args.output or 'FILE'}` on {time.strftime('%Y-%m-%d')}. Machine: {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores; Python {platform.python_version()}, numpy {np.__version__}, "
        f"scipy {scipy.__version__}, gaocvx {gaocvx.__version__}.",
        "",
        f"The Gao beam on a unilateral foundation (P1, q = -5e8 N/m, 256 elements) at every "
        f"point of a {args.points} x {args.points} grid of foundation stiffness "
        f"(1e8..1e13 N/m^2, log) and gap (1..10 mm): {n} values, each certified as every "
        f"solve is (`status` optimal). Equivalent command: `gaocvx sweep SCENE --vary "
        f"foundation.stiffness=1e8:1e13:{args.points}:log --vary "
        f"foundation.gap=0.001:0.01:{args.points} --csv map.csv --jobs 2`.",
        "",
        f"One sparse solve of the same mesh (N = 256, Euler-Bernoulli, scipy spsolve): "
        f"{base * 1e3:.3f} ms. Median time of one value inside the sweep (Newton, warm-started "
        f"from its neighbour, certificate included): {solve_ms:.2f} ms.",
        "",
        "| how | time | per value | ratio per value | certified | target |",
        "|---|---|---|---|---|---|",
    ]
    for label, t, certified, total in runs:
        lines.append(f"| {label} | {t:.1f} s | {t / total * 1e3:.2f} ms | "
                     f"{t / total / base:.1f}x | {certified}/{total} | "
                     f"{'met' if t * 1e4 / total < TARGET_S else 'missed'} ({TARGET_S:.0f} s per 10^4) |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.output:
        with open(args.output, "w") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()
