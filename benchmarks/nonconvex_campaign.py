"""The random campaign above P_bar_h: the global method against independent searches.

    python benchmarks/nonconvex_campaign.py --seed 1 --count 200 [--starts 24]
                                            [--shor 40] [--output docs/nonconvex-campaign.md]
                                            [--json records.json] [--elements 48,64|48-128]
                                            [--first 0] [--solve-limit 0] [--slsqp-iter 0]
                                            [--modes 4,5] [--trust-constr]

Every scene of tests/nonconvex_campaign_support.py's generator (``count`` from
``seed``) is solved by ``solve(scene, "global")`` and checked by the rules of
that module (an independent multi-start local search finds nothing below the
certified bound, the minimiser is a KKT point / local minimum of the
independent energy, mirror minimisers agree, refusals are justified, nothing
crashes); then ``--shor`` scenes on 4-12 elements are compared with the Shor
relaxation (tests/shor.py).  ``--modes 4,5`` redraws each Gao scene's axial
force so that it has four or five unstable modes (the others are left out).  The table lists the counts, every violation,
inaccurate answer and slow solve with a reproducer, and times.
"""

import argparse
import copy
import json
import logging
import platform
import statistics
import sys
import time
import warnings
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))  # this tree's gaocvx, also from a clone beside an editable install

from nonconvex_campaign_support import (MAX_MODES, SLOW, TOL_E, TOL_KKT,  # noqa: E402
                                        random_scene, run_case)

log = logging.getLogger("nonconvex_campaign")


def reproducer(data) -> str:
    """A command that solves the scene again."""
    return ("python -c 'import json; from gaocvx import Scene, solve; "
            f"r = solve(Scene.from_dict(json.loads(\"\"\"{json.dumps(data)}\"\"\")), \"global\"); "
            "print(r.status, r.time_s, r.message)'")


def parse_elements(text):
    """Element counts from "48,64,96" or ranges "48-128" (every multiple of 8 in it) mixed."""
    if not text:
        return None
    out = []
    for part in text.split(","):
        part = part.strip()
        if "-" in part:
            a, b = (int(v) for v in part.split("-"))
            out += list(range(a, b + 1, 8))
        elif part:
            out.append(int(part))
    return sorted(set(out))


class SolveTimeout(Exception):
    """The global solve ran past --solve-limit seconds (recorded as status "timeout")."""


def _limited(limit):
    """gaocvx.solve with a wall-clock limit (SIGALRM), for the support module's run_case."""
    import signal

    import nonconvex_campaign_support as ncs
    from gaocvx import solve as plain

    def handler(signum, frame):
        raise SolveTimeout(f"solve ran past {limit:g} s")

    def solve(scene, method):
        old = signal.signal(signal.SIGALRM, handler)
        signal.alarm(int(limit))
        try:
            return plain(scene, method)
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, old)

    ncs.solve = solve


def with_modes(case, rng, modes):
    """``case`` with its axial force redrawn so that the independent pencil has k in
    ``modes`` unstable modes (among 80 forces from 0.2 to 60 times the drawn one);
    None for an Euler-Bernoulli scene or when no force gives the k drawn."""
    from nonconvex_independent import Discrete

    from gaocvx import Scene

    if case.data["beam"]["model"] != "gao":
        return None
    target, P0 = int(rng.choice(modes)), case.data["load"]["axial"]
    good = []
    for f in np.geomspace(0.2, 60.0, 80):
        d = copy.deepcopy(case.data)
        d["load"]["axial"] = float(P0 * f)
        if Discrete(Scene.from_dict(d), 1.0).unstable_modes() == target:
            good.append(float(P0 * f))
    if not good:
        return None
    d = copy.deepcopy(case.data)
    d["load"]["axial"] = float(rng.choice(good))
    return type(case)(data=d, tags=case.tags + (f"k={target}",), id=case.id,
                      info={**case.info, "axial_fraction": None})


def run(seed, count, starts, elements=None, first=0, dump=None, modes=None):
    """``elements``: None (the generator's 8-32), or a list drawn from per scene
    (its own stream, so that the scene's other draws stay those of ``[seed, i]``).
    ``modes``: the axial force redrawn for k in ``modes`` (:func:`with_modes`, its
    own stream; scenes where it cannot are left out)."""
    records = []
    for i in range(first, first + count):
        n = None
        if elements:
            n = int(np.random.default_rng([seed, i, 77]).choice(elements))
        case = random_scene(np.random.default_rng([seed, i]), elements=n)
        case.id = f"{seed}:{i}"
        if modes:
            case = with_modes(case, np.random.default_rng([seed, i, 78]), modes)
            if case is None:
                continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rec = run_case(case, starts=starts, seed=i)
        log.info("%s %s %s k=%s nodes=%s %.1f s (search %.1f s) %s", case.id, ",".join(case.tags),
                 rec["status"], rec.get("k"), rec.get("nodes"), rec["time_s"],
                 rec.get("search_s", 0.0), rec["violations"] or "")
        records.append(rec)
        if dump is not None:   # as it goes: a long run stopped early keeps its records
            dump.write_text(json.dumps({"records": records}, default=str, indent=1))
    return records


def run_shor(seed, count):
    """Shor relaxation on small random scenes: (tags, tight, relative gap, rank ratio) each."""
    from test_nonconvex_shor import check

    from gaocvx import SceneError

    rows = []
    for i in range(count):
        rng = np.random.default_rng([seed, 1000 + i])
        case = random_scene(rng, elements=int(rng.choice([4, 6, 8, 12])))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                tight, rel, r, en, out = check(case.scene)
                rows.append({"tags": case.tags, "tight": bool(tight), "rel": float(rel),
                             "rank": float(out["rank_ratio"]), "unique": r.extra["global"]["unique"],
                             "data": case.data})
            except SceneError as exc:
                rows.append({"tags": case.tags, "refused": str(exc), "data": case.data})
            except AssertionError as exc:
                msg = str(exc)[:300]
                # check() asserts first that both solves ended "optimal": the global
                # method's own inaccurate answers are counted by the campaign, the
                # relaxation's unsolved ones are the reference's failure
                key = "unsolved" if "inaccurate" in msg or "infeasible" in msg or "error" in msg \
                    else "failed"
                rows.append({"tags": case.tags, key: msg, "data": case.data})
        log.info("shor %d %s %s", i, ",".join(case.tags), rows[-1].get("tight", "-"))
    return rows


def _kind(tags):
    for t in ("bonded", "foundation", "channel", "obstacle"):
        if t in tags:
            return t
    return "none"


def table(records, shor_rows, command, elapsed, elements=None) -> str:
    status = Counter(r["status"] for r in records)
    out = ["# Random campaign above the convexity limit (the global method)", "",
           "Generated by", "", "```", command, "```", "",
           f"on {platform.python_version()} / {platform.machine()}, 2 shared cores, "
           f"{len(records)} scenes in {elapsed:.0f} s.  Scenes: "
           "tests/nonconvex_campaign_support.py (all supports, Gao and a few Euler-Bernoulli, "
           "uniform / table / point loads or none, unilateral and bonded foundations, obstacles and "
           "channels, gap and stiffness profiles, P from 1 + 1e-6 to 5 times the limit, "
           f"{'8-32' if not elements else ', '.join(map(str, elements))} elements).  Each is solved by `solve(scene, \"global\")` and checked against the "
           "independent energy of tests/nonconvex_independent.py: a multi-start local search "
           "(trust-region Newton; SLSQP with an obstacle; starts: ± each of the first six "
           "buckling modes at three amplitudes, mixtures, the answer and its mirror image) may "
           f"find nothing below the certified lower bound by more than {TOL_E:g} of the energy "
           f"scale; an `optimal` minimiser must be a KKT point (relative dual norm <= {TOL_KKT:g}) "
           "and, without an obstacle, have a positive semidefinite independent Hessian; "
           "reported mirror minimisers must match in energy; refusals must be justified "
           f"(no quartic term, more than {MAX_MODES} unstable modes, more than 8192 elements).", "",
           "## Outcome", "",
           "| status | scenes |", "|---|---:|"]
    out += [f"| {k} | {v} |" for k, v in sorted(status.items())]
    viol = [r for r in records if r["violations"]]
    out += ["", f"**Violations: {len(viol)}** (wrong or unjustified answers, crashes).", ""]
    for r in viol:
        out += [f"- `{r['id']}` {', '.join(r['tags'])}: " +
                "; ".join(f"{k}: {v}" for k, v in r["violations"]), "",
                "  ```", "  " + reproducer(r["data"]), "  ```", ""]
    # by contact kind and support
    out += ["## By contact and support", "",
            "| contact | scenes | optimal | inaccurate | refused | median time [s] | max time [s] |",
            "|---|---:|---:|---:|---:|---:|---:|"]
    groups = defaultdict(list)
    for r in records:
        groups[_kind(r["tags"])].append(r)
    for k in sorted(groups):
        g = groups[k]
        t = [r["time_s"] for r in g]
        c = Counter(r["status"] for r in g)
        out.append(f"| {k} | {len(g)} | {c['optimal']} | {c['inaccurate']} | {c['refused']} | "
                   f"{statistics.median(t):.1f} | {max(t):.1f} |")
    by_sup = defaultdict(Counter)
    for r in records:
        sup = next(t for t in r["tags"] if t in ("P1", "P2", "P3", "P4"))
        by_sup[sup][r["status"]] += 1
    out += ["", "| support | " + " | ".join(sorted(status)) + " |",
            "|---|" + "---:|" * len(status)]
    for s in sorted(by_sup):
        out.append(f"| {s} | " + " | ".join(str(by_sup[s][k]) for k in sorted(status)) + " |")
    ks = Counter(r.get("k") for r in records)
    out += ["", "Unstable modes (independent count): " +
            ", ".join(f"k = {k}: {n}" for k, n in sorted(ks.items(), key=lambda t: str(t[0]))) + ".",
            ""]
    dual = [r for r in records
            if r["status"] == "optimal" and r.get("certificate") == "dual bound"]
    out += [f"Certified by the dual bound alone (no branch and bound): {len(dual)} of "
            f"{sum(r['status'] == 'optimal' for r in records)} optimal scenes, the multi-start "
            f"reaching the certified minimum in {sum(r.get('search_reached', False) for r in dual)} "
            "of them.", ""]
    reached = [r for r in records if r["status"] == "optimal" and "search_reached" in r]
    out += [f"The multi-start reached the certified minimum (within {TOL_E:g} of the scale) in "
            f"{sum(r['search_reached'] for r in reached)} of {len(reached)} optimal scenes "
            "(in the others it found only higher local minima: evidence of nothing, not a "
            "violation).", ""]
    times = [r["time_s"] for r in records]
    if times:
        out += [f"Time per scene (global solve): median {statistics.median(times):.1f} s, "
                f"mean {statistics.mean(times):.1f} s, max {max(times):.1f} s; "
                f"{sum(t > SLOW for t in times)} above {SLOW:g} s.", ""]
    # inaccurate, refused, slow
    for title, pick in (("Inaccurate answers (not certified; honest, but a user gets no answer)",
                         lambda r: r["status"] == "inaccurate"),
                        ("Refusals", lambda r: r["status"] in ("refused", "error", "timeout")),
                        (f"Slow solves (> {SLOW:g} s)", lambda r: r["time_s"] > SLOW)):
        rows = [r for r in records if pick(r)]
        out += [f"## {title}: {len(rows)}", ""]
        for r in rows:
            out += [f"- `{r['id']}` {', '.join(r['tags'])}, k = {r.get('k')}, "
                    f"{r['time_s']:.1f} s: {r.get('message', '')[:300]}", "",
                    "  ```", "  " + reproducer(r["data"]), "  ```", ""]
    notes = [r for r in records if r["notes"]]
    if notes:
        out += ["## Notes", ""]
        out += [f"- `{r['id']}`: {'; '.join(r['notes'])}" for r in notes]
        out.append("")
    if shor_rows:
        out += ["## Shor relaxation on small meshes (4-12 elements)", "",
                "tests/shor.py: the semidefinite relaxation with X for uu' (the Gao term "
                "convex in X, a channel's product cuts), a lower bound of the discrete minimum; "
                "tight when [[X, u], [u', 1]] has rank one (second eigenvalue <= 1e-6 of the "
                "first).  Checked as in tests/test_nonconvex_shor.py: the certified minimum never "
                "lies below the bound (1e-7 of the scale); where tight, the relaxation's u is "
                "the certified minimiser (1e-4) and nothing lower.", "",
                "| contact | scenes | tight | loose | relative gap of the loose ones | refused | "
                "unsolved | failed |",
                "|---|---:|---:|---:|---|---:|---:|---:|"]
        sg = defaultdict(list)
        for row in shor_rows:
            sg[_kind(row["tags"])].append(row)
        for k in sorted(sg):
            g = sg[k]
            loose = [row["rel"] for row in g if row.get("tight") is False]
            span = f"{min(loose):.1e} .. {max(loose):.1e}" if loose else "-"
            out.append(f"| {k} | {len(g)} | {sum(row.get('tight') is True for row in g)} | "
                       f"{len(loose)} | {span} | {sum('refused' in row for row in g)} | "
                       f"{sum('unsolved' in row for row in g)} | {sum('failed' in row for row in g)} |")
        out += ["", "`unsolved`: the relaxation or the global method ended without \"optimal\" (the "
                "global method's inaccurate answers are listed above); `failed`: a rule broken.", ""]
        nl = [row for row in shor_rows if row.get("tight") is False and "no-load" in row["tags"]
              and _kind(row["tags"]) == "none"]
        if nl:
            out += [f"Loose without load and contact: {len(nl)}, relative gaps "
                    + ", ".join(f"{row['rel']:.1e}" for row in nl) + " (with one unstable mode "
                    "the relaxation averages the two mirror minimisers, u = 0 and Z of rank two, "
                    "at the minimum's value; with more it may lie below).", ""]
        for row in shor_rows:
            if "failed" in row:
                out += [f"- failed: {row['failed']}", "", "  ```",
                        "  " + reproducer(row["data"]), "  ```", ""]
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=100)
    ap.add_argument("--starts", type=int, default=24)
    ap.add_argument("--shor", type=int, default=0, help="small scenes for the Shor relaxation")
    ap.add_argument("--elements", default=None,
                    help='element counts drawn from per scene: "48,64,96,128" or "48-128"')
    ap.add_argument("--solve-limit", type=float, default=0,
                    help="stop a global solve after this many seconds (0: never)")
    ap.add_argument("--slsqp-iter", type=int, default=0,
                    help="cap the checker's SLSQP iterations (obstacles; default its 400)")
    ap.add_argument("--trust-constr", action="store_true",
                    help="search again by trust-constr where the checker's SLSQP ends "
                         "inadmissible (channels with four or five modes; slower)")
    ap.add_argument("--first", type=int, default=0, help="index of the first scene")
    ap.add_argument("--modes", default=None,
                    help='unstable mode counts to set the axial force for, e.g. "4,5"')
    ap.add_argument("--output", type=Path)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    logging.getLogger("gaocvx").setLevel(logging.WARNING)
    t0 = time.perf_counter()
    elements = parse_elements(args.elements)
    if args.solve_limit:
        _limited(args.solve_limit)
    if args.slsqp_iter:
        from nonconvex_independent import Discrete
        Discrete.SLSQP_ITER = args.slsqp_iter
    if args.trust_constr:
        from nonconvex_independent import Discrete
        Discrete.TRUST_CONSTR = True
    modes = [int(k) for k in args.modes.split(",")] if args.modes else None
    records = run(args.seed, args.count, args.starts, elements, args.first,
                  dump=args.json.with_suffix(".partial.json") if args.json else None,
                  modes=modes)
    shor_rows = run_shor(args.seed, args.shor) if args.shor else []
    elapsed = time.perf_counter() - t0
    command = "python benchmarks/nonconvex_campaign.py " + " ".join(argv or sys.argv[1:])
    text = table(records, shor_rows, command, elapsed, elements)
    if args.output:
        args.output.write_text(text + "\n")
    else:
        sys.stdout.write(text + "\n")
    if args.json:
        args.json.write_text(json.dumps({"records": records, "shor": shor_rows}, default=str,
                                        indent=1))
    return 1 if any(r["violations"] for r in records) else 0


if __name__ == "__main__":
    sys.exit(main())
