"""How far the thesis's CVM (piecewise-linear control) is from the convex minimiser,
as the mesh is refined, for every support and transform; and (``--scale``) CVM's run
time, iterations and memory up to 16384 elements.

    python benchmarks/cvm_convergence.py [--output docs/cvm-convergence.md]
    python benchmarks/cvm_convergence.py --scale [--output docs/cvm-scale.md]

The piecewise-linear control reaches only a subspace of the Hermite states, so
the CVM optimum is a different discretisation; the table shows the relative
max nodal difference |w_cvm - w_convex| / max |w_convex| and the relative energy
gap, with the order fitted over the meshes where the difference is above 1e-12.
"""

import argparse
import itertools
import statistics
import sys
import time
import tracemalloc

import numpy as np
import scipy.sparse.linalg as spla

from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.cvm import solve_cvm
from gaocvx.mixed import clear_cache

BEAM = {"model": "gao", "length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1,
        "width": 1.0}
SIZES = [4, 8, 16, 32, 64, 128]
FLOOR = 1e-9  # differences below this are the solvers' own tolerance, not discretisation
CASES = [
    ("P1", "T1", "bending", {"q": -1e8, "axial": 1e9}, None),
    ("P2", "T1", "bending", {"q": -1e8, "axial": 5e8}, None),
    ("P3", "T1", "bending", {"q": -1e8, "axial": 5e7}, None),
    ("P3", "T2", "bending", {"q": -1e8, "axial": 5e7}, None),
    ("P4", "T1", "bending", {"q": -1e8, "axial": 5e8}, None),
    ("P4", "T3", "bending", {"q": -1e8, "axial": 5e8}, None),
    ("P1", "T1", "foundation", {"q": -5e8}, {"gap": 0.007, "stiffness": 5e10}),
    ("P2", "T1", "foundation", {"q": -5e8}, {"gap": 0.007, "stiffness": 5e10}),
    ("P3", "T2", "foundation", {"q": -5e7}, {"gap": 0.02, "stiffness": 5e8}),
    ("P4", "T3", "foundation", {"q": -1e8}, {"gap": 0.007, "stiffness": 5e10}),
]


def run():
    rows = []
    for supports, transform, kind, load, found in CASES:
        errs, gaps = [], []
        for n in SIZES:
            data = {"beam": {**BEAM, "supports": supports}, "load": load, "mesh": {"elements": n},
                    "solve": {"method": "cvm", "transform": transform, "control": "P1"}}
            if found:
                data["foundation"] = found
            scene = Scene.from_dict(data)
            cvm = solve(scene)
            truth = solve(scene, "newton")
            if not (cvm.success and truth.success):
                raise SystemExit(f"not certified: {supports} {transform} {n}: {cvm.message}")
            errs.append(np.abs(cvm.w - truth.w).max() / np.abs(truth.w).max())
            gaps.append(cvm.extra["cvm"]["energy_gap"] / abs(truth.energy))
        errs = np.array(errs)
        # Fit over the leading run of meshes above the solvers' accuracy floor.
        k = 1 if errs[0] < FLOOR else 0
        start = k
        while k < len(errs) and errs[k] > FLOOR:
            k += 1
        order = (-np.polyfit(np.log(SIZES[start:k]), np.log(errs[start:k]), 1)[0]
                 if k - start >= 2 else float("nan"))
        rows.append((supports, transform, kind, errs, gaps, order))
        print(supports, transform, kind, " ".join(f"{e:.1e}" for e in errs), f"order {order:.1f}",
              file=sys.stderr)
    return rows


def markdown(rows, command):
    head = "| supports | transform | scene | " + " | ".join(f"N={n}" for n in SIZES) + \
        " | fitted order | energy gap at N=128 |"
    out = ["# CVM with the piecewise-linear control: convergence to the convex minimiser", "",
           f"Made by `{command}`. Gao beam (L = 1 m, h = 0.1 m, b = 1 m, nu = 0.3, E = 2.1e11 Pa); "
           "'bending' is q = -1e8 N/m with a compressive axial force, 'foundation' a loaded beam "
           "on a unilateral foundation. Entries: max |w_cvm - w_convex| / max |w_convex| at the "
           f"nodes. The order is fitted (log-log least squares) over the leading run of meshes "
           f"whose difference is above {FLOOR:g}; below that it is the solvers' tolerance, not "
           "the discretisation (P1 with 4 elements has almost as many controls as states and is "
           "left out of the fit for that reason too). The energy gap "
           "Pi_T(w_cvm) - Pi_T(w_convex) is relative to |Pi_T(w_convex)|.", "",
           head, "|" + "---|" * (len(SIZES) + 5)]
    for supports, transform, kind, errs, gaps, order in rows:
        out.append(f"| {supports} | {transform} | {kind} | " + " | ".join(f"{e:.1e}" for e in errs)
                   + f" | {order:.1f} | {gaps[-1]:.1e} |")
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------- scale (--scale)
SCALE_SIZES = [8, 32, 128, 512, 2048, 8192, 16384]
SCALE_CASES = [  # label, supports, transform, control, load, foundation
    ("P1 T1 full, foundation", "P1", "T1", "full", {"q": -5e8}, {"gap": 0.007, "stiffness": 5e10}),
    ("P1 T1 P1, foundation", "P1", "T1", "P1", {"q": -5e8}, {"gap": 0.007, "stiffness": 5e10}),
    ("P4 T1 P1, foundation", "P4", "T1", "P1", {"q": -5e8, "axial": 1e8},
     {"gap": 0.007, "stiffness": 5e10}),
    ("P3 T1 P1, bending", "P3", "T1", "P1", {"q": -1e8, "axial": 5e7}, None),
    ("P3 T2 P1, foundation", "P3", "T2", "P1", {"q": -5e7}, {"gap": 0.02, "stiffness": 5e8}),
    ("P4 T3 P1, foundation", "P4", "T3", "P1", {"q": -1e8}, {"gap": 0.007, "stiffness": 5e10}),
]
CG_SIZES = [8, 32, 128]  # the conditional gradient: 2000 iterations take seconds per mesh


def sparse_solve_time(n, repeat=7):
    """One scipy spsolve of the Euler-Bernoulli system with n elements (as performance.py)."""
    data = {"beam": {**BEAM, "model": "euler-bernoulli", "supports": "P4"}, "load": {"q": -5e7},
            "mesh": {"elements": n}}
    dp = DiscreteProblem(Scene.from_dict(data))
    K, f = dp.K.tocsc(), dp.f
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        spla.spsolve(K, f)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def scale_scene(supports, transform, control, load, found, n, minimizer="projected-newton"):
    data = {"beam": {**BEAM, "supports": supports}, "load": load, "mesh": {"elements": n},
            "solve": {"method": "cvm", "transform": transform, "control": control,
                      "minimizer": minimizer}}
    if found:
        data["foundation"] = found
    return Scene.from_dict(data)


def timed_cvm(scene, transform, control, minimizer, repeat):
    """Median time of CVM alone (mesh matrices, transform, minimiser; a first solve: the
    cache of mesh structures is emptied), and its raw answer."""
    times, raw = [], None
    for _ in range(repeat):
        clear_cache()
        t0 = time.perf_counter()
        dp = DiscreteProblem(scene)
        raw = solve_cvm(dp, transform, control, minimizer)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), raw


def peak_memory(scene, transform, control):
    clear_cache()
    tracemalloc.start()
    try:
        solve_cvm(DiscreteProblem(scene), transform, control)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def run_scale(sizes):
    rows = []
    for n in sizes:
        base = sparse_solve_time(n)
        for label, supports, transform, control, load, found in SCALE_CASES:
            sc = scale_scene(supports, transform, control, load, found, n)
            t, raw = timed_cvm(sc, transform, control, "projected-newton", 3 if n <= 2048 else 1)
            full = solve(sc)  # the CVM verdict against the Newton ground truth (not timed)
            c = full.extra["cvm"]
            mem = peak_memory(sc, transform, control) if label.startswith("P1 T1 P1") else None
            rows.append({"case": label, "N": n, "time": t, "ratio": t / base,
                         "status": raw["status"], "newton": raw["nit"],
                         "cg": raw["cvm"]["cg_iterations"],
                         "measure": raw["cvm"]["optimality_measure"], "gap": c["energy_gap_rel"],
                         "dw": c["deflection_error_rel"], "memory": mem, "base": base})
            print(f"{label:26s} N={n:6d} {t*1e3:8.1f} ms ratio {t/base:8.1f} {raw['status']} "
                  f"it {raw['nit']} cg {raw['cvm']['cg_iterations']} gap {c['energy_gap_rel']:.1e}",
                  file=sys.stderr)
    cg_rows = []
    for n, (case, minimizer) in itertools.product(CG_SIZES, itertools.product(
            (1, 5), ("conditional-gradient", "accelerated-gradient"))):
        base = sparse_solve_time(n)
        label, supports, transform, control, load, found = SCALE_CASES[case]
        sc = scale_scene(supports, transform, control, load, found, n)
        t, raw = timed_cvm(sc, transform, control, minimizer, 1)
        gaps = np.array(raw["cvm"]["gaps"])
        k = np.arange(1, len(gaps) + 1)
        tail = (k >= 10) & (gaps > 0)
        rate = (-np.polyfit(np.log(k[tail]), np.log(gaps[tail]), 1)[0] if tail.sum() >= 3
                else float("nan"))
        # Against CVM's own optimum (projected Newton on the same problem), not the beam's
        # minimiser: the P1 control's discretisation difference is no error of the minimiser.
        dp = DiscreteProblem(sc)
        w = dp.to_physical(raw["u"])[0]
        best = dp.to_physical(solve_cvm(dp, transform, control)["u"])[0]
        dw = float(np.abs(w - best).max() / np.abs(best).max())
        cg_rows.append({"case": label, "minimizer": minimizer, "N": n, "time": t,
                        "ratio": t / base, "status": raw["status"], "iterations": raw["nit"], "gap10": gaps[min(9, len(gaps) - 1)],
                        "gap_last": gaps[-1], "rate": rate, "dw": dw})
        print(f"{label} {minimizer} N={n} {t:.2f} s rate {rate:.2f} dw {dw:.1e}", file=sys.stderr)
    return rows, cg_rows


def scale_markdown(rows, cg_rows, command):
    out = ["# CVM at scale: run time, iterations and memory to 16384 elements", "",
           f"Made by `{command}` on {time.strftime('%Y-%m-%d')}. Gao beam (L = 1 m, h = 0.1 m, "
           "b = 1 m, nu = 0.3, E = 2.1e11 Pa); foundation scenes as in docs/cvm-convergence.md. "
           "*time* is CVM alone, a first solve on its mesh (the mesh-structure cache emptied): the "
           "discrete problem, the transform, the bound of P/P_bar_h for the certificate and the "
           "matrix-free projected Newton minimiser; median of 3 runs up to 2048 elements, one run "
           "above. *ratio* divides it by one `scipy.sparse.linalg.spsolve` of the Euler-Bernoulli "
           "system with the same N, measured in the same run. *Newton/CG* are projected-Newton "
           "iterations and the conjugate-gradient iterations (reduced Hessian-vector products) of "
           "all of them. *measure* is the certified bound of the reduced Newton decrement "
           "(optimal when <= 1e-10). *gap* and *dw* are the CVM verdict against the certified "
           "Newton minimiser of the same mesh (`gaocvx.solve.cvm_verdict`): the energy gap "
           "relative to the energy scale and the max nodal deflection difference relative to "
           "max |w|. *peak memory* is tracemalloc's peak during one CVM solve (Python and "
           "numpy allocations; SuperLU's and LAPACK's internal work arrays are not traced).", "",
           "| case | N | time | ratio | status | Newton | CG | measure | gap | dw | peak memory |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        mem = f"{r['memory'] / 2**20:.1f} MiB" if r["memory"] is not None else ""
        out.append(f"| {r['case']} | {r['N']} | {r['time']*1e3:.1f} ms | {r['ratio']:.0f}x | "
                   f"{r['status']} | {r['newton']} | {r['cg']} | {r['measure']:.1e} | "
                   f"{r['gap']:.1e} | {r['dw']:.1e} | {mem} |")
    out += ["", "One sparse solve: " + ", ".join(
        f"{n}: {b*1e3:.2f} ms" for n, b in dict((r["N"], r["base"]) for r in rows).items()) + ".",
        "", "## First-order methods: the thesis's conditional gradient and FISTA", "",
        "The conditional gradient (`minimizer = \"conditional-gradient\"`) and, for "
        "comparison, FISTA (accelerated projected gradient, `gaocvx.cvm.minimizers."
        "accelerated_gradient`, not a scene option), both stopped by the Frank-Wolfe gap "
        "g'(u - s) <= 1e-9 |I(u)| or 2000 iterations, with the default bound. *gap* is that "
        "gap relative to |I(u)| (an upper bound of the relative suboptimality) after 10 "
        "iterations and at the end; r is the rate of gap ~ k^-r fitted (log-log least "
        "squares) from iteration 10 on. *dw* is the max nodal deflection difference from "
        "CVM's own optimum (projected Newton on the same discrete problem) relative to its "
        "max |w|.", "",
        "| case | minimiser | N | time | ratio | status | iterations | gap at 10 | "
        "gap at end | rate r | dw |",
        "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in cg_rows:
        out.append(f"| {r['case']} | {r['minimizer']} | {r['N']} | {r['time']*1e3:.0f} ms | "
                   f"{r['ratio']:.0f}x | {r['status']} | "
                   f"{r['iterations']} | {r['gap10']:.1e} | {r['gap_last']:.1e} | "
                   f"{r['rate']:.2f} | {r['dw']:.1e} |")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--output")
    ap.add_argument("--scale", action="store_true",
                    help="run time, iterations and memory to 16384 elements (docs/cvm-scale.md)")
    ap.add_argument("--max-elements", type=int, default=16384)
    args = ap.parse_args()
    command = "python benchmarks/cvm_convergence.py" + (" --scale" if args.scale else "") + \
        (f" --max-elements {args.max_elements}" if args.max_elements != 16384 else "") + \
        (f" --output {args.output}" if args.output else "")
    if args.scale:
        text = scale_markdown(*run_scale([n for n in SCALE_SIZES if n <= args.max_elements]),
                              command)
    else:
        text = markdown(run(), command)
    if args.output:
        open(args.output, "w").write(text)
    print(text)
