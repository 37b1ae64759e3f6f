"""Run time against error for every method, and the targets of the performance issue.

    python benchmarks/performance.py [--quick] [--output docs/performance.md]

Times are wall-clock medians of repeated runs on the machine that runs this;
each is also given as a ratio to one sparse solve (scipy spsolve) of the
Euler-Bernoulli system with the same number of elements, measured in the same
run, because shared machines are noisy.  Errors are the max nodal difference
from a converged reference (Newton on 16384 elements, certified), relative to
max |w|: discretisation and solver error together.
"""

import argparse
import platform
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import scipy
import scipy.sparse.linalg as spla

import gaocvx
from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.mixed import clear_cache
from gaocvx.sweep import sweep

BEAM = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}
GAO_FOUNDATION = {"beam": {**BEAM, "model": "gao", "supports": "P1"}, "load": {"q": -5e8},
                  "foundation": {"gap": 0.007, "stiffness": 5e10}}
EB_PLAIN = {"beam": {**BEAM, "model": "euler-bernoulli", "supports": "P4"}, "load": {"q": -5e7}}
OBSTACLE = {"beam": {**BEAM, "model": "gao", "supports": "P1"}, "load": {"q": -5e8},
            "obstacle": {"gap": 0.007}}
SIZES = [8, 32, 128, 512, 2048, 8192, 16384]
# Largest N per method: conditional gradient needs thousands of iterations (seconds
# per mesh, `inaccurate`); OSQP (ADMM) needs 35 s at 2048 elements (measured); beyond
# these sizes they take minutes.  CVM's projected Newton is matrix-free and runs to
# 16384 (docs/cvm-scale.md).
CAPS = {"cvm/conditional-gradient": 128, "convex/osqp": 512}


def scene(data, n, **solve_opts):
    d = {**data, "mesh": {"elements": n}}
    if solve_opts:
        d["solve"] = solve_opts
    return Scene.from_dict(d)


def timed(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def first_solve(sc, method=None):
    """A solve that finds no mesh structure cached (a user's first solve on this mesh)."""
    clear_cache()
    return solve(sc, method)


def sparse_solve_time(n, repeat=7):
    dp = DiscreteProblem(scene(EB_PLAIN, n))
    K, f = dp.K.tocsc(), dp.f
    t, _ = timed(lambda: spla.spsolve(K, f), repeat)
    return t


def work_precision(data, methods, sizes, reference):
    rows = []
    for n in sizes:
        base = sparse_solve_time(n)
        for label, opts in methods:
            if n > CAPS.get(label, 10**9):
                continue
            sc = scene(data, n, **opts)
            repeat = 5 if n <= 512 and "conditional" not in label else 1
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    solve(sc)  # warm the imports once
                    t, r = timed(lambda: first_solve(sc), repeat)
            except gaocvx.SolverError as exc:
                rows.append({"method": label, "N": n, "time_s": float("nan"), "ratio": float("nan"),
                             "error": float("nan"), "status": f"failed: {exc}", "iterations": None})
                print(f"{label:26s} N={n:6d} failed: {exc}", file=sys.stderr)
                continue
            err = float(np.abs(r.w - reference.deflection(r.x)).max() / np.abs(reference.w).max())
            if label == "newton" and n == 16384 and reference is not None and \
                    np.array_equal(r.w, reference.w):
                r_status = "reference"  # compared with itself: error 0 by construction
            else:
                r_status = r.status
            rows.append({"method": label, "N": n, "time_s": t, "ratio": t / base,
                         "error": err, "status": r_status, "iterations": r.nit})
            print(f"{label:26s} N={n:6d} {t*1e3:9.1f} ms ratio {t/base:8.1f} "
                  f"error {err:.2e} {r.status}", file=sys.stderr)
    return rows


def targets():
    n = 2048
    base = sparse_solve_time(n, repeat=15)
    out = {}
    for name, data, method, target in [
            ("Euler-Bernoulli, no contact, auto", EB_PLAIN, None, 5),
            ("Gao on a foundation, Newton", GAO_FOUNDATION, "newton", 50),
            ("Gao on a foundation, convex (Clarabel)", GAO_FOUNDATION, "convex", 100)]:
        sc = scene(data, n)
        solve(sc, method)
        repeat = 5 if method != "convex" else 3
        t_first, r = timed(lambda: first_solve(sc, method), repeat)
        t_again, _ = timed(lambda: solve(sc, method), repeat)
        out[name] = (t_first, t_first / base, t_again / base, target, r.status, r.method)
    return base, out


def convex_breakdown(n=2048):
    """Where the time of one convex solve goes: its parts, each against one sparse solve.

    The program of the foundation scene is built, compiled and solved at the first
    rung of the Clarabel ladder by hand (as gaocvx.convex does), so that CVXPY's
    compilation, Clarabel's setup (equilibration, ordering, symbolic factorisation)
    and its iterations are timed apart.
    """
    import cvxpy as cp
    from gaocvx.convex import CLARABEL_LADDER, ConvexProgram, _explicit
    from gaocvx.mixed import MixedForm
    from gaocvx.certificate import certify
    base = sparse_solve_time(n, repeat=15)
    dp = DiscreteProblem(scene(GAO_FOUNDATION, n))
    settings = _explicit(CLARABEL_LADDER["smooth"])[0]
    runs = []
    for _ in range(3):
        clear_cache()
        t0 = time.perf_counter()
        mf = MixedForm(dp)
        program = ConvexProgram(mf)
        t1 = time.perf_counter()
        data, chain, inverse = program.problem.get_problem_data(cp.CLARABEL)
        t2 = time.perf_counter()
        raw = chain.solve_via_data(program.problem, data, False, False, settings)
        t3 = time.perf_counter()
        inverse[-1].solver_options = settings   # as Problem.solve records them
        program.problem.unpack_results(raw, chain, inverse)
        certify(mf, mf.on_manifold(program.z.value))
        t4 = time.perf_counter()
        runs.append((t1 - t0, t2 - t1, t3 - t2 - raw.solve_time, raw.solve_time, t4 - t3,
                     raw.iterations))
    parts = [statistics.median(r[i] for r in runs) for i in range(5)]
    A = data["A"]
    return {"base": base, "parts": parts, "iterations": runs[-1][5],
            "variables": A.shape[1], "rows": A.shape[0], "nnz": A.nnz + data["P"].nnz}


SUPPORT_SIZE = 8192


def convex_supports(n=SUPPORT_SIZE):
    """The convex method on every support and contact kind (Gao beam, q = -5e8 N/m)."""
    base = sparse_solve_time(n)
    rows = []
    for supports in ("P1", "P2", "P3", "P4"):
        for kind in ("none", "foundation", "obstacle"):
            data = {"beam": {**BEAM, "model": "gao", "supports": supports}, "load": {"q": -5e8}}
            if kind == "foundation":
                data["foundation"] = GAO_FOUNDATION["foundation"]
            elif kind == "obstacle":
                data["obstacle"] = OBSTACLE["obstacle"]
            sc = scene(data, n)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t, r = timed(lambda: first_solve(sc, "convex"), 1)
            rows.append((supports, kind, t, t / base, r.status, r.nit, r.residual["stationarity"]))
            print(f"convex {supports} {kind:10s} N={n} {t:.2f} s {t/base:.1f}x {r.status}",
                  file=sys.stderr)
    return base, rows


SWEEPS = [  # label, scene, key, values, method, N
    ("foundation stiffness, Newton", GAO_FOUNDATION, "foundation.stiffness",
     np.geomspace(1e8, 1e13, 20), "newton", (256, 2048)),
    ("obstacle gap, Newton", OBSTACLE, "obstacle.gap", np.linspace(0.002, 0.01, 20), "newton",
     (256, 2048)),
    ("load scale, Newton", GAO_FOUNDATION, "load.scale", np.linspace(0.2, 2.0, 20), "newton",
     (256, 2048)),
    ("foundation stiffness, convex (parametric)", GAO_FOUNDATION, "foundation.stiffness",
     np.geomspace(1e8, 1e13, 20), "convex", (256, 2048)),
]


def sweep_reuse():
    """Sweeps against the same values solved as first solves on a fresh mesh cache."""
    from gaocvx.sweep import scene_at
    out = []
    for label, data, key, values, method, sizes in SWEEPS:
        for n in sizes:
            sc = scene(data, n)
            clear_cache()
            t0 = time.perf_counter()
            items = list(sweep(sc, key, values, method=method))
            t_sweep = time.perf_counter() - t0
            t0 = time.perf_counter()
            cold = [first_solve(scene_at(sc, key, float(v)), method) for v in values]
            t_cold = time.perf_counter() - t0
            ok = all(not isinstance(r, Exception) and r.success for _, r in items)
            out.append((label, n, len(values), t_sweep, t_cold, ok,
                        sum(r.nit for _, r in items), sum(r.nit for r in cold)))
            print(f"sweep {label:42s} N={n:5d} {t_sweep:.2f} s / {t_cold:.2f} s", file=sys.stderr)
    return out


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 5))
    for label in dict.fromkeys(r["method"] for r in rows):
        rs = [r for r in rows if r["method"] == label and r["status"] != "reference"
              and np.isfinite(r["ratio"])]
        ax.loglog([r["ratio"] for r in rs], [max(r["error"], 1e-16) for r in rs], "o-", label=label)
        for r in rs:
            ax.annotate(str(r["N"]), (r["ratio"], max(r["error"], 1e-16)), fontsize=6)
    ax.set_xlabel("run time / one sparse solve of the same N")
    ax.set_ylabel("max nodal error (relative), against N = 16384")
    ax.set_title("Gao beam on a unilateral foundation: work against precision", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import clarabel
    import cvxpy
    import osqp
    return (f"{cpu}; Python {platform.python_version()}, numpy {np.__version__}, "
            f"scipy {scipy.__version__}, cvxpy {cvxpy.__version__}, clarabel {clarabel.__version__}, "
            f"osqp {osqp.__version__}, gaocvx {gaocvx.__version__}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="sizes up to 512 only")
    ap.add_argument("--output", help="Markdown file to write (a PNG is written beside it)")
    args = ap.parse_args()
    sizes = [n for n in SIZES if n <= 512] if args.quick else SIZES
    reference = solve(scene(GAO_FOUNDATION, 16384), "newton")
    assert reference.success, reference.message
    methods = [("newton", {"method": "newton"}),
               ("convex/clarabel", {"method": "convex"}),
               ("cvm/projected-newton", {"method": "cvm"}),
               ("cvm/conditional-gradient", {"method": "cvm", "minimizer": "conditional-gradient"})]
    rows = work_precision(GAO_FOUNDATION, methods, sizes, reference)
    eb_ref = solve(scene(EB_PLAIN, 16384))
    eb_rows = work_precision(EB_PLAIN, [("auto (one solve)", {}), ("convex/osqp", {"method": "convex", "solver": "osqp"}),
                                         ("convex/clarabel", {"method": "convex"})],
                             [n for n in sizes if n <= 8192], eb_ref)
    ob_ref = solve(scene(OBSTACLE, 16384), "newton")
    ob_rows = work_precision(OBSTACLE, [("newton", {"method": "newton"}), ("convex/clarabel", {"method": "convex"})],
                             [n for n in sizes if n <= 8192], ob_ref)
    base, target = targets()
    breakdown = convex_breakdown()
    support_base, support_rows = convex_supports(512 if args.quick else SUPPORT_SIZE)
    reuse = sweep_reuse()
    command = "python benchmarks/performance.py" + (" --quick" if args.quick else "") + \
        (f" --output {args.output}" if args.output else "")
    md = ["# Performance: run time against error\n",
          f"Made by `{command}` on {time.strftime('%Y-%m-%d')}. Machine: {machine()}.",
          "Times are medians of repeated runs of `gaocvx.solve` (setup, solve, certificate and",
          "result included), each a first solve on its mesh: the cache of mesh structures",
          "(`gaocvx.mixed.clear_cache`) is emptied before every run. *ratio* divides by one",
          "`scipy.sparse.linalg.spsolve` of the",
          "Euler–Bernoulli system with the same N, measured in the same run. *error* is the",
          "max nodal difference from a converged reference (Newton, 16384 elements, certified",
          "optimal) relative to max |w|: discretisation and solver error together.",
          "Some methods stop before 16384 elements (`CAPS` in the script): OSQP at 512",
          "(ADMM took 35 s at 2048) and CVM's conditional gradient at 128 (thousands of",
          "iterations).\n",
          "## Targets at N = 2048\n",
          f"One sparse solve: {base*1e3:.2f} ms.\n",
          "*ratio* is a first solve on the mesh; *again* a repeated solve on the same mesh",
          "(its structure cached, as in a sweep or a second call).\n",
          "| scene and method | time | ratio | again | target | status (method used) |",
          "|---|---|---|---|---|---|"]
    for name, (t, ratio, again, tgt, status, method) in target.items():
        md.append(f"| {name} | {t*1e3:.1f} ms | {ratio:.1f}x | {again:.1f}x | {tgt}x | "
                  f"{status} ({method}) |")
    for title, rs in [("Gao beam on a unilateral foundation (P1, q = -5e8 N/m, gap 7 mm, k_F = 5e10 N/m^2)", rows),
                      ("Euler–Bernoulli beam without contact (P4, q = -5e7 N/m)", eb_rows),
                      ("Gao beam on a rigid obstacle (P1, q = -5e8 N/m, gap 7 mm)", ob_rows)]:
        md += [f"\n## {title}\n", "| method | N | time | ratio | error | status | iterations |",
               "|---|---|---|---|---|---|---|"]
        for r in rs:
            md.append(f"| {r['method']} | {r['N']} | {r['time_s']*1e3:.1f} ms | {r['ratio']:.1f}x | "
                      f"{r['error']:.1e} | {r['status']} | {r['iterations']} |")
    b, parts = breakdown["base"], breakdown["parts"]
    md += ["\n## Where a convex solve's time goes (Gao on a foundation, N = 2048)\n",
           f"One sparse solve: {b*1e3:.2f} ms. The program has {breakdown['variables']} "
           f"variables and {breakdown['rows']} constraint rows ({breakdown['nnz']} nonzeros in "
           f"P and A), so Clarabel's KKT matrix has dimension "
           f"{breakdown['variables'] + breakdown['rows']}; "
           f"{breakdown['iterations']} interior-point iterations (first rung of the ladder).\n",
           "| part | time | ratio |", "|---|---|---|"]
    labels = ["mixed form and CVXPY expressions", "CVXPY compilation",
              "Clarabel setup (and CVXPY's interface)", "Clarabel iterations",
              "unpacking and certificate"]
    for label, t in zip(labels, parts):
        md.append(f"| {label} | {t*1e3:.1f} ms | {t/b:.1f}x |")
    md.append(f"| per iteration | {parts[3]/breakdown['iterations']*1e3:.1f} ms | "
              f"{parts[3]/breakdown['iterations']/b:.1f}x |")
    md.append(f"| total | {sum(parts)*1e3:.1f} ms | {sum(parts)/b:.1f}x |")
    n_sup = 512 if args.quick else SUPPORT_SIZE
    best = min(r[2] for r in support_rows)
    md += [f"\n## Convex on every support and contact kind (Gao, q = -5e8 N/m, N = {n_sup})\n",
           f"One sparse solve: {support_base*1e3:.2f} ms. A first solve each (one run: noisy); "
           "*of best* divides by the fastest of the twelve. *iterations* counts every pass: "
           "`gaocvx.solve` solves again in the answer's own deflection scale when the first "
           "answer is more than 10 times smaller or larger than the scale it was solved in "
           "(the cantilever, P3, held by a foundation or an obstacle).\n",
           "| supports | contact | time | ratio | of best | status | iterations | stationarity |",
           "|---|---|---|---|---|---|---|---|"]
    for sup, kind, t, ratio, status, nit, stat in support_rows:
        md.append(f"| {sup} | {kind} | {t*1e3:.0f} ms | {ratio:.1f}x | {t/best:.1f}x | {status} | "
                  f"{nit} | {stat:.1e} |")
    md += ["\n## Sweeps against first solves\n",
           "| sweep | N | values | sweep | first solves | ratio | all certified | "
           "iterations sweep / first |", "|---|---|---|---|---|---|---|---|"]
    for label, n, nv, ts, tc, ok, its, itc in reuse:
        md.append(f"| {label} | {n} | {nv} | {ts:.2f} s | {tc:.2f} s | {ts/tc:.2f}x | "
                  f"{'yes' if ok else 'no'} | {its} / {itc} |")
    md += ["\nA sweep keeps one deflection scale, starts Newton from the previous answer (and",
           "the obstacle's multipliers) and shares the mesh structure (quadrature matrices,",
           "KKT band maps and the factor of the constant Hessian); the first solves build all",
           "of it each time. Newton still takes about two iterations per value on a",
           "foundation, and the obstacle's method of multipliers restarts its penalty",
           "continuation, so those are the floors. The convex program is compiled once",
           "with Parameters (DPP; the load enters as a scalar factor, so this costs no",
           "more than a constant program), but Clarabel, an interior-point method,",
           "cannot warm-start: each value still takes its iterations.\n",
           "![work-precision](performance.png)\n"]
    text = "\n".join(md)
    if args.output:
        Path(args.output).write_text(text)
        plot(rows, Path(args.output).with_name("performance.png"))
    print(text)


if __name__ == "__main__":
    from gaocvx.linalg import one_blas_thread
    with one_blas_thread():   # as the command line runs (and the baseline solve too)
        main()
