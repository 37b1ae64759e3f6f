"""Newton on a rigid obstacle: the coarse start against the former continuation.

    python benchmarks/obstacle.py [--quick] [--output docs/obstacle-newton.md]

For the obstacle scene of benchmarks/performance.py (Gao, P1, q = -5e8 N/m,
gap 7 mm) at 8 ... 8192 elements, its gap sweep (20 gaps from 2 to 10 mm at 256
and 2048 elements, each a first solve and as a sweep) and the obstacle scenes
of the tests, each method is run in turn in the same process:

* *iterations*: ``Result.nit``, the KKT factorisations of the Newton steps on
  the scene's mesh (both passes when the answer is re-solved in its own scale);
* *all factorisations*: every banded KKT factorisation of the solve, counted by
  wrapping ``MixedForm.kkt_factor``: coarse meshes, predicted active sets and
  the certificate included;
* *ratio*: median time of a first solve (mesh cache emptied) over one
  ``scipy.sparse.linalg.spsolve`` of the Euler-Bernoulli system of the same N,
  medians of repeats interleaved with the baseline in the same run.

The switch is ``gaocvx.newton.OBSTACLE_METHOD`` ("coarse start", the default,
or "continuation").
"""

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
sys.path.insert(0, str(HERE))

from conftest import compressed_scene, scene_dict  # noqa: E402
from performance import OBSTACLE, scene  # noqa: E402

from gaocvx import DiscreteProblem, Scene, mixed, newton, solve  # noqa: E402
from gaocvx.mixed import clear_cache  # noqa: E402
from gaocvx.scene import load_scene  # noqa: E402
from gaocvx.sweep import sweep  # noqa: E402

METHODS = ("coarse start", "continuation")
GAPS = np.linspace(0.002, 0.01, 20)

_count = [0]
_factor = mixed.MixedForm.kkt_factor


def _counted(self, H):
    _count[0] += 1
    return _factor(self, H)


mixed.MixedForm.kkt_factor = _counted


def run(sc, method, **kw):
    """(result, factorisations) of a first solve of ``sc`` by ``method``."""
    newton.OBSTACLE_METHOD = method
    clear_cache()
    _count[0] = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = solve(sc, "newton", **kw)
    return r, _count[0]


def timed(sc, n, repeat):
    """Median ratios of first solves to one sparse solve, methods interleaved."""
    dp = DiscreteProblem(sc)
    K, f = dp.K.tocsc(), dp.f
    times = {m: [] for m in ("base", *METHODS)}
    for _ in range(repeat):
        t0 = time.perf_counter()
        spla.spsolve(K, f)
        times["base"].append(time.perf_counter() - t0)
        for m in METHODS:
            t0 = time.perf_counter()
            run(sc, m)
            times[m].append(time.perf_counter() - t0)
    base = statistics.median(times["base"])
    return base, {m: statistics.median(times[m]) / base for m in METHODS}


def bench_rows(sizes):
    rows = []
    for n in sizes:
        sc = scene(OBSTACLE, n)
        base, ratio = timed(sc, n, 7 if n <= 2048 else 3)
        for m in METHODS:
            r, nf = run(sc, m)
            rows.append((n, m, r.status, r.nit, nf, ratio[m], base, r.message))
            print(f"N={n:5d} {m:13s} {r.status} nit {r.nit:3d} fact {nf:3d} {ratio[m]:7.1f}x",
                  file=sys.stderr)
    return rows


def gap_rows(sizes):
    rows = []
    for n in sizes:
        base_sc = scene(OBSTACLE, n)
        for m in METHODS:
            nits, facts, ok = [], [], 0
            for gap in GAPS:
                sc = Scene.from_dict({**OBSTACLE, "obstacle": {"gap": float(gap)},
                                      "mesh": {"elements": n}})
                r, nf = run(sc, m)
                nits.append(r.nit)
                facts.append(nf)
                ok += r.success
            newton.OBSTACLE_METHOD = m
            clear_cache()
            _count[0] = 0
            t0 = time.perf_counter()
            items = list(sweep(base_sc, "obstacle.gap", GAPS, method="newton"))
            t_sweep = time.perf_counter() - t0
            sweep_ok = all(not isinstance(r, Exception) and r.success for _, r in items)
            sweep_nit = [r.nit for _, r in items]
            rows.append((n, m, ok, max(nits), sum(nits), sum(facts), sweep_ok, max(sweep_nit),
                         sum(sweep_nit), _count[0], t_sweep))
            print(f"gaps N={n} {m}: first solves max nit {max(nits)}, sweep {t_sweep:.2f} s",
                  file=sys.stderr)
    return rows


def test_scenes():
    """The obstacle scenes of tests/test_obstacle.py and the examples (name, scene)."""
    out = []
    for sup in ("P1", "P2", "P3", "P4"):
        for model in ("gao", "euler-bernoulli"):
            q, gap = (-5e7, 0.02) if sup == "P3" else (-5e8, 0.007)
            out.append((f"{sup} {model}, point force", Scene.from_dict(
                scene_dict(sup, model, q=q, points=[(0.7, -2e7)], obstacle=gap))))
            out.append((f"{sup} {model}, gap / 3", Scene.from_dict(
                scene_dict(sup, model, q=q, obstacle=gap / 3))))
    out.append(("P4 Gao at gap 0", Scene.from_dict(scene_dict("P4", q=-5e7, obstacle=0.0))))
    out.append(("P3 lifted off at gap 0", Scene.from_dict(scene_dict("P3", q=5e7, obstacle=0.0))))
    for n in (1024, 2048):
        out.append((f"P1 Gao point contact, {n}", Scene.from_dict(
            scene_dict("P1", "gao", q=-5e8, obstacle=0.007, elements=n))))
        out.append((f"P4 Gao flat contact, {n}", Scene.from_dict(
            scene_dict("P4", "gao", q=-5e8, obstacle=0.007, elements=n))))
    out.append(("P3 EB compressed, gap 0", compressed_scene(
        0.5, "P3", "euler-bernoulli", q=100.0, points=[(0.25, 0.0)], elements=10, obstacle=0.0)))
    out.append(("P1 Gao compressed (0.9 P_bar_h)", compressed_scene(
        0.9, "P1", "gao", q=-5e8, elements=64, obstacle=0.007)))
    for ex in ("obstacle_plateau", "channel", "cantilever_table_obstacle",
               "pinned_obstacle_point"):
        out.append((f"examples/{ex}", load_scene(HERE.parent / "examples" / f"{ex}.toml")))
    for sup, model, gap in (("P3", "gao", 1e-3), ("P1", "euler-bernoulli", 1e-4),
                            ("P4", "gao", 0.0)):
        out.append((f"flexible {sup} {model}, gap {gap}", Scene.from_dict(scene_dict(
            sup, model, half_thickness=0.005, q=-5e6, obstacle=gap, elements=64))))
    return out


def scene_rows():
    rows = []
    for name, sc in test_scenes():
        row = [name, sc.mesh.elements]
        for m in METHODS:
            r, nf = run(sc, m)
            row += [r.status, r.nit, nf, "the continuation" in r.message]
        rows.append(row)
        print(name, row[2:], file=sys.stderr)
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="sizes up to 512 only")
    ap.add_argument("--output", help="Markdown file to write")
    args = ap.parse_args()
    sizes = [8, 32, 128, 512] + ([] if args.quick else [2048, 8192])
    bench = bench_rows(sizes)
    gaps = gap_rows([256] + ([] if args.quick else [2048]))
    scenes = scene_rows()
    command = "python benchmarks/obstacle.py" + (" --quick" if args.quick else "") + \
        (f" --output {args.output}" if args.output else "")
    md = [f"Made by `{command}` on {time.strftime('%Y-%m-%d')}.\n",
          "### The obstacle scene of benchmarks/performance.py (Gao, P1, q = -5e8 N/m, gap 7 mm)\n",
          "| N | method | status | iterations | all factorisations | ratio to one sparse solve |"
          " one sparse solve |", "|---|---|---|---|---|---|---|"]
    for n, m, status, nit, nf, ratio, base, _ in bench:
        md.append(f"| {n} | {m} | {status} | {nit} | {nf} | {ratio:.1f}x | {base*1e3:.2f} ms |")
    md += ["\n### The gap sweep (20 gaps, 2-10 mm)\n",
           "| N | method | first solves certified | their iterations: max / total | all "
           "factorisations | sweep certified | sweep iterations: max / total | sweep "
           "factorisations | sweep time |", "|---|---|---|---|---|---|---|---|---|"]
    for n, m, ok, mx, tot, nf, sok, smx, stot, snf, ts in gaps:
        md.append(f"| {n} | {m} | {ok}/20 | {mx} / {tot} | {nf} | {'yes' if sok else 'no'} | "
                  f"{smx} / {stot} | {snf} | {ts:.2f} s |")
    md += ["\n### The obstacle scenes of the tests and examples\n",
           "| scene | N | coarse start: status | iterations | all factorisations | fell back |"
           " continuation: status | iterations | all factorisations |",
           "|---|---|---|---|---|---|---|---|---|"]
    for name, n, s1, n1, f1, fb1, s2, n2, f2, _ in scenes:
        md.append(f"| {name} | {n} | {s1} | {n1} | {f1} | {'yes' if fb1 else ''} | {s2} | {n2} "
                  f"| {f2} |")
    text = "\n".join(md)
    if args.output:
        path = Path(args.output)
        old = path.read_text() if path.exists() else ""
        marker = "<!-- benchmarks/obstacle.py -->"
        head = old.split(marker)[0] if marker in old else old
        path.write_text(head + marker + "\n" + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
