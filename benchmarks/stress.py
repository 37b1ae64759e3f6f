"""Where each method stops being certified: stiffness, axial force, loads, gaps, mesh size.

    python benchmarks/stress.py [--output docs/stress.md]

For each case every method is run; the table gives its status ("optimal" means
its optimality certificate passed; anything else is the method saying it could
not), the run time, and, where Newton and the convex program both claim
optimality, their difference relative to the scene's deflection scale W.
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from gaocvx import DiscreteProblem, Scene, SolverError, solve
from gaocvx.tolerances import ZERO_ANSWER

BEAM = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}


def case(supports="P1", model="gao", q=-5e8, n=64, axial=0.0, foundation=None, obstacle=None,
         points=()):
    d = {"beam": {**BEAM, "model": model, "supports": supports},
         "load": {"q": q, "axial": axial, "points": [list(p) for p in points]},
         "mesh": {"elements": n}}
    if foundation:
        d["foundation"] = {"gap": foundation[0], "stiffness": foundation[1]}
    if obstacle is not None:
        d["obstacle"] = {"gap": obstacle}
    return Scene.from_dict(d)


def run(scene, methods=("newton", "convex")):
    out = {}
    for m in methods:
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = solve(scene, m)
            out[m] = (r.status, time.perf_counter() - t0, r)
        except SolverError as exc:
            out[m] = (f"failed ({exc.status})", time.perf_counter() - t0, None)
    rs = [v[2] for v in out.values() if v[2] is not None and v[2].success]
    diff = None
    if len(rs) == 2:
        # Relative to the answer itself (or the certificate's zero floor below it),
        # not to the unsupported linear answer.
        floor = ZERO_ANSWER * DiscreteProblem(scene).W_linear
        diff = float(np.abs(rs[0].w - rs[1].w).max() / max(np.abs(rs[0].w).max(), floor))
    return out, diff


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--output")
    args = ap.parse_args()
    rows = []

    def record(group, label, scene, methods=("newton", "convex")):
        out, diff = run(scene, methods)
        rows.append((group, label, out, diff))
        cells = "  ".join(f"{m}: {s} {t:.2f}s" for m, (s, t, _) in out.items())
        print(f"{group:22s} {label:28s} {cells}  diff {diff}", file=sys.stderr)

    for k in [1e10, 1e12, 1e14, 1e16, 1e18, 1e20]:
        record("foundation stiffness", f"k_F = {k:g} N/m^2", case(foundation=(0.007, k)))
    probe = DiscreteProblem(case(model="euler-bernoulli", q=-5e7, n=64))
    for f in [0.9, 0.99, 0.999, 0.9999, 0.99999]:
        record("axial force", f"P = {f} P_bar_h (P1, EB)",
               case(model="euler-bernoulli", q=-5e7, axial=f * probe.P_bar_h))
    for q in [-1e2, -1e5, -1e8, -2e9]:
        record("load", f"q = {q:g} N/m", case(q=q, foundation=(0.007, 5e10)))
    for gap in [0.0, 1e-6, 1e-3, 0.1, 10.0]:
        record("gap", f"obstacle gap {gap:g} m", case(supports="P4", obstacle=gap))
    for n in [4, 64, 1024, 4096, 16384]:
        record("mesh size", f"N = {n}, foundation", case(foundation=(0.007, 5e8), n=n))
    for n in [64, 1024, 4096, 8192]:
        record("mesh size", f"N = {n}, obstacle", case(supports="P4", obstacle=0.007, n=n))
    record("point forces", "at nodes", case(q=None, points=[(0.25, -5e8), (0.5, -5e8)], obstacle=0.002))
    record("point forces", "between nodes", case(q=None, points=[(0.2501, -5e8), (0.613, -5e8)],
                                                 obstacle=0.002))

    lines = ["# Stress: where each method stops being certified\n",
             "Made by `python benchmarks/stress.py" + (f" --output {args.output}`" if args.output else "`")
             + f" on {time.strftime('%Y-%m-%d')}. Gao beam, P1, q = -5e8 N/m unless stated; 64 elements "
             "unless stated. *optimal*: the method's optimality certificate passed "
             "(docs/model.md). *inaccurate* or *failed*: it says it could not. *diff*: "
             "max |w_newton - w_convex| relative to max |w| (or, below it, the zero floor 1e-6 of the unsupported linear answer) when both claim optimal.\n",
             "| group | case | newton | convex | diff |", "|---|---|---|---|---|"]
    for group, label, out, diff in rows:
        cells = [f"{out[m][0]} ({out[m][1]:.2f} s)" if m in out else "" for m in ("newton", "convex")]
        lines.append(f"| {group} | {label} | {cells[0]} | {cells[1]} | "
                     f"{'' if diff is None else f'{diff:.1e}'} |")
    text = "\n".join(lines) + "\n"
    if args.output:
        Path(args.output).write_text(text)
    print(text)


if __name__ == "__main__":
    main()
