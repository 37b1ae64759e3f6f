"""The global method above the convexity limit: cost against certified gap and mesh size, and paths.

    python benchmarks/nonconvex.py table [--output docs/nonconvex-benchmark.md]
    OPENBLAS_NUM_THREADS=1 python benchmarks/nonconvex.py fine [--output FILE] [--sizes ...] [--cases ...]
    python benchmarks/nonconvex.py paths [--output docs/nonconvex-paths.png] [--elements 12]
    OPENBLAS_NUM_THREADS=1 python benchmarks/nonconvex.py modes [--output FILE] [--sizes 16,32,64]
    OPENBLAS_NUM_THREADS=1 python benchmarks/nonconvex.py early [--output FILE] [--sizes 16,32]
    OPENBLAS_NUM_THREADS=1 python benchmarks/nonconvex.py dual [--output FILE] [--sizes ...] [--cases ...]
    OPENBLAS_NUM_THREADS=1 python benchmarks/nonconvex.py grid [--output FILE] [--sizes 100,256]

``table``: for each scene and mesh, the global method's run time, node
programs, unstable modes and certified gap (in J and relative to the energy
scale, the sum of |energy parts|), with its status, by the dense node
programs.  ``fine``: the same by the fast path (:mod:`gaocvx.nonconvex.fast`)
for nonconvex.md's P4 example, the k = 2 P1 example and the P4 obstacle example
(``--cases``) at 128 to 8192 elements (``--sizes``); ``modes``: four and five
unstable modes (MODE_CASES) at 8 to 64 elements, with the node programs that
``solve_global`` picks (the fast path; no second try by the other kind), on
their own and with basins off (``search.BASINS``), both in one run, four of them
free and two on a bonded bed; ``early``: the same scenes with a box to be split
stopping early (``fast.EARLY``) and with its node problem solved to the end,
in one run;
``dual``: the dual bound (:mod:`gaocvx.nonconvex.dual`) against the branch
and bound alone on the same scene (CASES without obstacle, ``--cases``; the
fast path), the two run times measured in one run, their ratio and the
difference of their energies relative to the scale
``grid``: every support at 1.5, 3 and 5 times its P_bar_h, free, on an
obstacle 1 cm below and on a unilateral bed 5 mm below (1e10 N/m^2), under
q = -1e7 N/m, solved as a user would (``solve(scene, "global")``: the node
programs, the dual bound and the second try it picks), each time also as a
ratio to the same scene's solve at 0.5 P_bar_h (convex: Newton) in the same run
(one BLAS thread: on a shared machine OpenBLAS's threads made a dot product
of 10^4 numbers take 24 ms instead of 6 us).  ``paths``: the
equilibrium path of each support (P1..P4) with and without a transverse load,
and of P4 on a foundation and on an obstacle, from tension to 3 P_bar (forces
with three unstable modes would be left out: equilibria are found for one or two).
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from gaocvx import DiscreteProblem, Scene

BEAM = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}


def scene(supports, q=None, axial=0.0, n=16, foundation=None, obstacle=None, points=(),
          bonded=None):
    d = {"beam": {**BEAM, "model": "gao", "supports": supports},
         "load": {"axial": axial, "points": [list(p) for p in points]}, "mesh": {"elements": n}}
    if q is not None:
        d["load"]["q"] = q
    if foundation:
        d["foundation"] = {"gap": foundation[0], "stiffness": foundation[1]}
    if bonded:
        d["foundation"] = {"gap": 0.0, "stiffness": bonded, "kind": "bilateral"}
    if obstacle is not None:
        d["obstacle"] = {"gap": obstacle}
    return Scene.from_dict(d)


CASES = [
    ("P4, q = -1e7 N/m, P = 1.3e9 N (nonconvex.md)", dict(supports="P4", q=-1e7, axial=1.3e9)),
    ("P4, q = 0, P = 1.3e9 N (mirror images)", dict(supports="P4", axial=1.3e9)),
    ("P1, q = -5e7 N/m, P = 1.1e10 N (k = 2)", dict(supports="P1", q=-5e7, axial=1.1e10)),
    ("P3, tip force -1e5 N, P = 6e8 N", dict(supports="P3", points=[(1.0, -1e5)], axial=6e8)),
    ("P2, foundation 2 mm / 1e10, P = 4e9 N", dict(supports="P2", q=-2e7, axial=4e9,
                                                    foundation=(0.002, 1e10))),
    ("P4, obstacle 1 cm, q = -1e8 N/m, P = 1.5e9 N", dict(supports="P4", q=-1e8, axial=1.5e9,
                                                         obstacle=0.01)),
]

# Far above the limit: lambda_n of P1 ~ 1, 2.05, 4.0, 6.05, 9.0 lambda_1 and of P4 n^2 lambda_1.
MODE_CASES = [
    ("P1, q = -1e7 N/m, P = 3.5e10 N (k = 4)", dict(supports="P1", q=-1e7, axial=3.5e10)),
    ("P4, q = -1e7 N/m, P = 3.2e10 N (k = 5)", dict(supports="P4", q=-1e7, axial=3.2e10)),
    # a bonded bed of the thesis's stiffness (P_hat_h = 6.62e9 N for P4, 1.008e10 N for P1)
    ("P4, bonded bed 1e11 N/m^2, q = -5e7 N/m, P = 1.99e10 N (3 P_hat_h, k = 4)",
     dict(supports="P4", q=-5e7, axial=1.9861e10, bonded=1e11)),
    ("P1, bonded bed 1e11 N/m^2, q = -5e7 N/m, P = 5.04e10 N (5 P_hat_h, k = 5)",
     dict(supports="P1", q=-5e7, axial=5.0385e10, bonded=1e11)),
]


def _global(s, fast):
    """The global method with the node programs chosen (dense or fast), as a dict of figures."""
    from gaocvx.nonconvex.minimum import solve_global

    t0 = time.perf_counter()
    dp, raw, info = solve_global(DiscreteProblem(s, check_convexity=False), fast=fast)
    t = time.perf_counter() - t0
    parts = raw["mixed"].energy_parts(raw["z"])
    scale = sum(abs(v) for v in parts.values()) * dp.E0
    return dict(k=info["unstable_modes"], nodes=info["nodes"], time=t, gap=info["bound_gap"],
                rel=info["bound_gap"] / scale, unique=info["unique"], status=raw["status"],
                energy=sum(parts.values()) * dp.E0, scale=scale, certificate=info["certificate"])


def _write(lines, out):
    """The table's lines printed, and written to ``out`` if given."""
    text = "\n".join(lines) + "\n"
    if out:
        Path(out).write_text(text)
    print(text)


def table(out, cases=CASES, sizes=(8, 16, 32, 64, 128), fast=False):
    lines = ["| scene | N | k | nodes | time [s] | gap [J] | gap / scale | unique | status |",
             "|---|---|---|---|---|---|---|---|---|"]
    for label, kw in cases:
        for n in sizes:
            g = _global(scene(n=n, **kw), fast)
            lines.append(f"| {label} | {n} | {g['k']} | {g['nodes']} | {g['time']:.2f} | "
                         f"{g['gap']:.2e} | {g['rel']:.1e} | "
                         f"{'yes' if g['unique'] else 'no'} | {g['status']} |")
            print(lines[-1], file=sys.stderr, flush=True)
    _write(lines, out)


def _paired(out, cases, sizes, switch, header, row, module=None, values=(True, False)):
    """Each scene solved with ``module.<switch>`` (:mod:`gaocvx.nonconvex.search` by default) set to each of
    ``values`` (on, off) in one run, a row of each pair.

    ``row(label, n, on, off)`` formats a table row from the two :func:`_global` results.
    """
    import gaocvx.nonconvex.search as search

    module = search if module is None else module

    def run(s, value):
        setattr(module, switch, value)
        try:
            return _global(s, None)
        finally:
            setattr(module, switch, values[0])

    lines = list(header)
    for label, kw in cases:
        for n in sizes:
            s = scene(n=n, **kw)
            lines.append(row(label, n, run(s, values[0]), run(s, values[1])))
            print(lines[-1], file=sys.stderr, flush=True)
    _write(lines, out)


def _on_off_table(out, cases, sizes, switch, off, module=None, values=(True, False)):
    """The global method with ``switch`` on and off (same scenes, one run): nodes, time,
    gap and status with it, nodes and time without (``off`` names that column), the
    time ratio and the difference of the two energies."""
    header = [f"| scene | N | k | nodes | time [s] | gap / scale | status | nodes, {off} "
              f"| time, {off} [s] | ratio | \\|ΔE\\| / scale |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    _paired(out, cases, sizes, switch, header, lambda label, n, a, b: (
        f"| {label} | {n} | {a['k']} | {a['nodes']} | {a['time']:.2f} | {a['rel']:.1e} | "
        f"{a['status']} | {b['nodes']} | {b['time']:.2f} | {b['time'] / a['time']:.1f} | "
        f"{abs(a['energy'] - b['energy']) / a['scale']:.1e} |"), module=module, values=values)


def modes_table(out, cases, sizes):
    """Four and five modes: the global method with and without basins (same scenes, one run)."""
    _on_off_table(out, cases, sizes, "BASINS", "without basins")


def early_table(out, cases, sizes):
    """A box to be split stopping early (``fast.EARLY``, 0.5) against its projected Newton
    run to BOUND_TOL (EARLY = 0), the same scenes in one run."""
    import gaocvx.nonconvex.fast as fast

    _on_off_table(out, cases, sizes, "EARLY", "EARLY = 0", module=fast, values=(fast.EARLY, 0.0))


def dual_table(out, cases, sizes):
    """The global method with and without the dual bound's shortcut (same scenes, one run)."""
    header = ["| scene | N | k | certificate | time [s] | branch and bound alone [s] | ratio | "
              "gap / scale | its gap / scale | \\|ΔE\\| / scale | status |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    _paired(out, cases, sizes, "DUAL_BOUND", header, lambda label, n, a, b: (
        f"| {label} | {n} | {a['k']} | {a['certificate']} | {a['time']:.2f} | "
        f"{b['time']:.2f} | {b['time'] / a['time']:.1f} | {a['rel']:.1e} | "
        f"{b['gap'] / a['scale']:.1e} | {abs(a['energy'] - b['energy']) / a['scale']:.1e} | "
        f"{a['status']} / {b['status']} |"))


def paths(out, n):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gaocvx.nonconvex import equilibrium_path
    from gaocvx.nonconvex.pictures import draw_path

    panels = [(f"{sup}, q = {q:g} N/m" if q else f"{sup}, q = 0", dict(supports=sup, q=q))
              for sup in ("P1", "P2", "P3", "P4") for q in (0.0, -1e7)]
    panels += [("P4, q = -1e7 N/m, foundation 1 cm, k_F = 1e9 N/m^2",
                dict(supports="P4", q=-1e7, foundation=(0.01, 1e9))),
               ("P4, q = -1e7 N/m, obstacle 1 cm", dict(supports="P4", q=-1e7, obstacle=0.01))]
    fig, axes = plt.subplots(5, 2, figsize=(10, 19))
    for ax, (label, kw) in zip(axes.ravel(), panels):
        t0 = time.perf_counter()
        base = scene(n=n, q=kw.get("q") or None,
                     **{k: v for k, v in kw.items() if k != "q"})
        P_bar = DiscreteProblem(base, check_convexity=False).P_bar_h
        P = np.linspace(-0.5 * P_bar, 3.0 * P_bar, 36)
        path = equilibrium_path(base, P)
        draw_path(ax, path)
        ax.axhline(P_bar, color="0.5", lw=0.8, ls=":", label="P_bar_h")
        if path.errors:
            first = min(path.errors)
            ax.axhspan(first, P[-1], color="0.92", zorder=-1, label="3 unstable modes (not traced)")
        ax.set_title(label, fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
        print(f"{label}: {len(path.points)} equilibria, {len(path.errors)} forces skipped, "
              f"{time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    fig.tight_layout()
    fig.savefig(out, dpi=80)


GRID_CONTACTS = {"free": {}, "obstacle 1 cm": {"obstacle": {"gap": 0.01}},
                 "bed 5 mm": {"foundation": {"kind": "unilateral", "gap": 0.005,
                                             "stiffness": 1e10}}}


def grid(out, sizes):
    """The ``grid`` table: supports x P / P_bar_h x contact, by ``solve(scene, "global")``."""
    from gaocvx import solve

    lines = ["| supports | P / P̄_h | contact | N | k | certificate | nodes | time [s] | "
             "time / convex solve | gap / scale | status |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for n in sizes:
        for supports in ("P1", "P2", "P3", "P4"):
            for label, extra in GRID_CONTACTS.items():
                data = {"beam": {**BEAM, "model": "gao", "supports": supports},
                        "load": {"q": -1e7}, "mesh": {"elements": n}, **extra}
                bar = DiscreteProblem(Scene.from_dict(data), check_convexity=False).P_bar_h
                data["load"]["axial"] = 0.5 * bar
                solve(Scene.from_dict(data))   # (imports and caches warmed)
                t0 = time.perf_counter()
                solve(Scene.from_dict(data))
                reference = time.perf_counter() - t0
                for ratio in (1.5, 3.0, 5.0):
                    data["load"]["axial"] = ratio * bar
                    t0 = time.perf_counter()
                    r = solve(Scene.from_dict(data), "global")
                    t = time.perf_counter() - t0
                    g = r.extra["global"]
                    scale = sum(abs(v) for v in r.energy_parts.values())
                    lines.append(f"| {supports} | {ratio:g} | {label} | {n} | "
                                 f"{g['unstable_modes']} | {g['certificate']} | {g['nodes']} | "
                                 f"{t:.2f} | {t / reference:.3g} | "
                                 f"{g['bound_gap'] / scale:.1e} | {r.status} |")
                    print(lines[-1], file=sys.stderr, flush=True)
    _write(lines, out)


DEFAULT_SIZES = "128,512,2048,8192"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["table", "fine", "paths", "modes", "early", "dual", "grid"])
    ap.add_argument("--output")
    ap.add_argument("--elements", type=int, default=12)
    ap.add_argument("--sizes", default=DEFAULT_SIZES,
                    help="fine, modes, dual, grid: the meshes (comma-separated element counts; "
                         "modes: 16,32,64 by default; dual: 16,128,1024,4096; grid: 100,256)")
    ap.add_argument("--cases", default="0,2,5",
                    help="fine, dual: indices into CASES (fine's default: P4, P1 with k = 2, P4 "
                         "on an obstacle; dual's: 0,2,3, the scenes without an obstacle)")
    args = ap.parse_args(argv)
    if args.what == "table":
        table(args.output)
    elif args.what == "fine":
        cases = [CASES[int(i)] for i in args.cases.split(",")]
        table(args.output, cases, tuple(int(n) for n in args.sizes.split(",")), fast=True)
    elif args.what == "modes":
        sizes = "16,32,64" if args.sizes == DEFAULT_SIZES else args.sizes
        modes_table(args.output, MODE_CASES, tuple(int(n) for n in sizes.split(",")))
    elif args.what == "early":
        sizes = "16,32" if args.sizes == DEFAULT_SIZES else args.sizes
        early_table(args.output, MODE_CASES, tuple(int(n) for n in sizes.split(",")))
    elif args.what == "grid":
        sizes = "100,256" if args.sizes == DEFAULT_SIZES else args.sizes
        grid(args.output, tuple(int(n) for n in sizes.split(",")))
    elif args.what == "dual":
        sizes = "16,128,1024,4096" if args.sizes == DEFAULT_SIZES else args.sizes
        idx = "0,2,3" if args.cases == "0,2,5" else args.cases
        dual_table(args.output, [CASES[int(i)] for i in idx.split(",")],
                   tuple(int(n) for n in sizes.split(",")))
    else:
        paths(args.output or "docs/nonconvex-paths.png", args.elements)


if __name__ == "__main__":
    main()
