#!/usr/bin/env python
"""Are the ``optimal`` equilibria above P_bar_h zeros of the gradient in their own scale?

``gaocvx.nonconvex.equilibria(scene)`` may call an entry ``optimal`` only when
the whole beam's Newton step of the energy, taken at the entry, moves its
deflection by at most 1e-6 of its largest |w|.  Near the limit the entries can
be 1e-16 m and smaller: the gradient there is a difference of terms many
orders of magnitude above it.  So the step is taken in 40-digit arithmetic:
tests/nonconvex_reference40.py gives the gradient and the Hessian element by
element from the float nodes and nodal DOFs (its Gauss rule and EI, mu, E alpha
exact), in units of the entry's own max|w|, and mpmath solves; the independent
energy's data (tests/nonconvex_independent.py::Discrete: load vector, beds,
obstacle rows) are float64.

Checked against a step computed wholly apart in 40 digits (its own Hermite
element assembly and LU: the seeds 5101-5102 campaign's mpcheck) on the 24
entries of that campaign's eleven finding scenes (P1-P4, 4-32 elements, 1e-10 to
1e-6 above P_bar_h, no bed; free, on an obstacle at gap 0 or 4e-9): the five
flat beams pressed on the obstacle have step 0 in both; 17 steps (4e-11 to
1.2e-6) agree to 6 digits; a 1.6e-17 m beam's 2.1e-14 within 0.2 per cent and
a 1.3e-16 m beam's 4.3e-16 against 2.5e-16 (round-off).  The float64 Hessian
solved against the 40-digit gradient (recorded as ``step_f64H``) gave the same
steps within 12 per cent there, and 0.25 to 1.2 times them 1e-13 to 1e-11 above
the limit (seeds 5201-5202); but with the float64 Gauss weights and
constants P mu / EI (1e-16 relative) the steps were 0.02 to 7.7 times those:
1e-10 above the limit the step moves by about eps / (2 (P / P_bar_h - 1)) of the
beam's size, 5e-7, with every ulp of the data.

With an obstacle or a channel the step is taken on the face of the touching
rows (slack <= 1e-9 of max|w|): on the null space of those rows, as the
entry could move only along them.

Per scene (random ``rand`` scenes: P1-P4, 4-40 elements, no load to 1e6 N/m,
uniform / table / point loads, no bed, unilateral and bonded beds, obstacles and
channels, P between P_bar_h and the second mode's load; ``near`` scenes:
P = P_bar_h (1 + 1e-13 … 1e-4), tiny or no loads; ``near2`` scenes, with
``--near2-seed``: two modes, P = lambda_2 (1 + 1e-13 … 1e-3), 4-12 elements,
no obstacle):

* ``equilibria`` (``python -m gaocvx equilibria SCENE --json`` of the tree
  ``--src``, in a subprocess with a timeout) and ``solve(scene, "global")``
  (likewise) are run;
* each entry gets its step.  ``optimal`` and step > 1e-6: WRONG (a finding);
  so is an ``optimal`` entry whose step moves any DOF (slopes times L too) by more
  than 1e-6 of its largest, or whose stability the independent Hessian decides
  otherwise (no obstacle row touching, every bed point clear of the bed's edge:
  the least eigenvalue of (H, K) beyond 1e-8); ``inaccurate`` and step <= 1e-6:
  a false alarm (counted; conservative, not wrong);
* the lowest stable ``optimal`` entry is compared with an ``optimal`` global
  answer: energy within 1e-9 of the energy scale, deflection within 2e-6 of
  max|w| (against the answer, its mirror images and its listed alternatives).

Findings are written as scene files ``<out>/findings/<name>.toml`` (a header
comment says what was wrong); every scene is ``<out>/scenes/<name>.toml`` and
its record a line of ``<out>/results.jsonl``.  A summary table is printed.

Usage (from the repository's root; ``--src`` another tree of gaocvx to test)::

    OMP_NUM_THREADS=1 python benchmarks/equilibria_own_scale.py --src /path/to/tree \\
        --out /tmp/own --rand-seed 5201 --near-seed 5202 --count 30 --budget 3300
    python benchmarks/equilibria_own_scale.py --out /tmp/own2 --files /tmp/own/findings/*.toml
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--src", default=ROOT, help="source tree of gaocvx under test")
ap.add_argument("--tests", default=os.path.join(ROOT, "tests"),
                help="directory of the independent reference (nonconvex_independent.py, ...)")
ap.add_argument("--out", required=True, help="output directory (scenes/, findings/, results.jsonl)")
ap.add_argument("--files", nargs="*", default=None, help="run only these scene TOML files")
ap.add_argument("--rand-seed", type=int, default=5201, help="seed of the random scenes (0: none)")
ap.add_argument("--near-seed", type=int, default=5202, help="seed of the near-limit scenes (0: none)")
ap.add_argument("--near2-seed", type=int, default=0,
                help="seed of the two-mode scenes just above lambda_2 (0: none)")
ap.add_argument("--count", type=int, default=30, help="scenes per seed (interleaved)")
ap.add_argument("--first", type=int, default=0, help="index of the first scene of each seed")
ap.add_argument("--budget", type=float, default=3300.0, help="wall seconds for the whole run")
ap.add_argument("--eq-timeout", type=float, default=300.0, help="seconds for one equilibria call")
ap.add_argument("--solve-timeout", type=float, default=150.0, help="seconds for one global solve")
ap.add_argument("--tol", type=float, default=1e-6, help="the step rule: relative to max|w|")
args = ap.parse_args()

SRC = os.path.abspath(args.src)
sys.path.insert(0, SRC)
sys.path.insert(1, os.path.abspath(args.tests))

import mpmath  # noqa: E402
import numpy as np  # noqa: E402
import scipy.linalg as sla  # noqa: E402

import gaocvx  # noqa: E402

assert os.path.abspath(gaocvx.__file__).startswith(SRC), gaocvx.__file__
from gaocvx import DiscreteProblem, Scene  # noqa: E402

from campaign import _loguniform as logu  # noqa: E402
from nonconvex_independent import Discrete  # noqa: E402
from nonconvex_reference40 import reference  # noqa: E402

try:
    import tomllib
except ImportError:  # pragma: no cover
    import tomli as tomllib

BEAM = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}
OUT = os.path.abspath(args.out)
for sub in ("scenes", "findings"):
    os.makedirs(os.path.join(OUT, sub), exist_ok=True)
T_START = time.time()
ACTIVE = 1e-9    # a row touches when its slack is at most this of max|w|
EIG = 1e-8       # a stability is checked where the least eigenvalue of (H, K) is beyond this


# ---------------------------------------------------------------- scene files
def toml_text(data, header=()):
    """A scene dict (tables of numbers, strings, lists) as TOML, ``header`` as comments."""
    def val(v):
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(map(val, v)) + "]"
        return json.dumps(v) if isinstance(v, (str, bool)) else repr(v)
    body = [f"[{sec}]\n" + "".join(f"{k} = {val(v)}\n" for k, v in tab.items())
            for sec, tab in data.items()]
    return "".join(f"# {h}\n" for h in header) + "\n".join(body)


def write_scene(path, data, header=()):
    with open(path, "w") as fh:
        fh.write(toml_text(data, header))
    return path


# ---------------------------------------------------------------- scenes
def at_zero_axial(data):
    d = json.loads(json.dumps(data))
    d["load"]["axial"] = 0.0
    return d


def limits(data):
    """(P_bar_h [N] of the library, the first two loads [N] of (K (+ c M bonded), mu G))."""
    d0 = at_zero_axial(data)
    scene = Scene.from_dict(d0)
    pb = float(DiscreteProblem(scene, check_convexity=False).P_bar_h)
    en = Discrete(scene, 1.0)
    lam, _ = en.modes(2)
    bp = en.bp
    return pb, [float(v) * bp.EI / (bp.mu * bp.L**2) for v in lam]


def contact(rng, data, cuts, gap_zero, above):
    """A bed or an obstacle drawn by ``cuts`` (none, unilateral, bilateral, obstacle)."""
    c = rng.random()
    kind = ("none" if c < cuts[0] else "unilateral" if c < cuts[1] else "bilateral" if c < cuts[2]
            else "obstacle" if c < cuts[3] else "channel")
    gap = 0.0 if rng.random() < gap_zero else logu(rng, 1e-9, 1e-3)
    if kind in ("unilateral", "bilateral"):
        data["foundation"] = {"gap": gap, "stiffness": logu(rng, 1e6, 1e11)}
        if kind == "bilateral":
            data["foundation"]["kind"] = "bilateral"
    elif kind in ("obstacle", "channel"):
        data["obstacle"] = {"gap": gap}
        if kind == "channel":
            data["obstacle"]["gap_above"] = logu(rng, 1e-9 if above else 1e-8, 1e-4 if above else 1e-3)
    return kind, gap


def gen_rand(rng):
    """P between P_bar_h (the bonded bed's own limit) and the second mode's load."""
    sup = str(rng.choice(["P1", "P2", "P3", "P4"]))
    n = int(rng.integers(4, 41))
    kind = str(rng.choice(["none", "uniform", "table", "points"], p=[0.2, 0.4, 0.2, 0.2]))
    sign = -1.0 if rng.random() < 0.7 else 1.0
    Q = logu(rng, 1e-30, 1e6)
    load = {}
    if kind == "uniform":
        load["q"] = sign * Q
    elif kind == "table":
        xs = np.unique(np.r_[0.0, np.sort(rng.uniform(0, 1, 2)), 1.0])
        load["q"] = [[float(x), sign * float(rng.uniform(-0.3, 1.0)) * Q] for x in xs]
    elif kind == "points":
        load["points"] = [[float(rng.uniform(0, 1)), sign * Q * float(rng.uniform(0.05, 1.0))]
                          for _ in range(int(rng.integers(1, 3)))]
    data = {"beam": {"model": "gao", "supports": sup, **BEAM}, "load": load, "mesh": {"elements": n}}
    bed, gap = contact(rng, data, (0.3, 0.6, 0.8, 0.9), 0.35, False)
    pb, (l1, l2) = limits(data)
    if bed == "bilateral":
        pb = max(pb, l1)
    u = logu(rng, 1e-4, 0.9)
    data["load"]["axial"] = pb + u * (l2 - pb)
    return data, ["rand", sup, f"n{n}", kind, f"Q{sign * Q:.2g}", bed, f"gap{gap:.2g}", f"u{u:.3g}"]


def gen_near(rng):
    """P = P_bar_h (1 + eps), eps 1e-13 .. 1e-4 (a bonded bed: its own limit)."""
    sup = str(rng.choice(["P1", "P2", "P3", "P4"]))
    n = int(rng.integers(4, 41))
    eps = logu(rng, 1e-13, 1e-4)
    load, qk = {}, "none"
    if rng.random() >= 0.3:
        Q = logu(rng, 1e-30, 1e-3)
        sign = -1.0 if rng.random() < 0.7 else 1.0
        if rng.random() < 0.75:
            load["q"], qk = sign * Q, f"q{sign * Q:.2g}"
        else:
            load["points"], qk = [[float(rng.uniform(0, 1)), sign * Q]], f"F{sign * Q:.2g}"
    data = {"beam": {"model": "gao", "supports": sup, **BEAM}, "load": load, "mesh": {"elements": n}}
    bed, gap = contact(rng, data, (0.35, 0.65, 0.8, 0.92), 0.5, True)
    pb, (l1, _) = limits(data)
    if bed == "bilateral":
        pb = max(pb, l1)
    data["load"]["axial"] = pb * (1 + eps)
    return data, ["near", sup, f"n{n}", qk, bed, f"gap{gap:.2g}", f"eps{eps:.2g}"]


def gen_near2(rng):
    """Two unstable modes: P = lambda_2 (1 + eps), eps 1e-13 .. 1e-3, 4-12 elements,
    tiny to moderate loads, no bed or a bed (no obstacle: two-mode obstacle lists
    take minutes).  The second mode's saddles there have amplitudes
    sqrt(eps) of the first's, along a curvature eps of the stiffness."""
    sup = str(rng.choice(["P1", "P2", "P3", "P4"]))
    n = int(rng.integers(4, 13))
    eps = logu(rng, 1e-13, 1e-3)
    load, qk = {}, "none"
    if rng.random() >= 0.2:
        Q = logu(rng, 1e-12, 1e3)
        sign = -1.0 if rng.random() < 0.7 else 1.0
        load["q"], qk = sign * Q, f"q{sign * Q:.2g}"
    data = {"beam": {"model": "gao", "supports": sup, **BEAM}, "load": load, "mesh": {"elements": n}}
    bed, gap = contact(rng, data, (0.4, 0.75, 1.01, 1.01), 0.3, False)
    _, (_, l2) = limits(data)
    data["load"]["axial"] = l2 * (1 + eps)
    return data, ["near2", sup, f"n{n}", qk, bed, f"gap{gap:.2g}", f"eps{eps:.2g}"]


def scene_stream():
    """(name, data, tags) in the order to run: the two seeds interleaved."""
    if args.files is not None:
        for f in args.files:
            with open(f, "rb") as fh:
                yield os.path.splitext(os.path.basename(f))[0], tomllib.load(fh), ["file", f]
        return
    plan = [(s, m) for s, m in ((args.rand_seed, "rand"), (args.near_seed, "near"),
                                (args.near2_seed, "near2")) if s]
    make = {"rand": (gen_rand, "r"), "near": (gen_near, "n"), "near2": (gen_near2, "m")}
    for i in range(args.first, args.first + args.count):
        for seed, mode in plan:
            rng = np.random.default_rng([seed, i])
            gen, letter = make[mode]
            data, tags = gen(rng)
            yield f"{seed}_{letter}{i}", data, tags


# ---------------------------------------------------------------- the library, apart
def gaocvx_cli(argv, timeout):
    """``python -m gaocvx ARGV`` of the tree under test: (rc or None on timeout, stdout, stderr, s)."""
    env = dict(os.environ, PYTHONPATH=SRC, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    try:
        # (in SRC: ``-m`` puts the working directory first on the path, before
        # PYTHONPATH, and a run from another checkout tested that one)
        p = subprocess.run([sys.executable, "-m", "gaocvx"] + argv, capture_output=True, text=True,
                           timeout=timeout, env=env, cwd=SRC)
        return p.returncode, p.stdout, p.stderr, time.perf_counter() - t0
    except subprocess.TimeoutExpired:
        return None, "", "TIMEOUT", time.perf_counter() - t0


# ---------------------------------------------------------------- the step
def newton_step(scene, w, slope):
    """The whole beam's Newton step at nodal (w, slope): its largest |w| over max|w|.

    In units of the entry's own max|w| (the independent energy's unknowns are then of
    order one); gradient and Hessian in 40 digits, solved in 40 digits.  Touching
    obstacle rows: the step on their null space.  Returns (step, the step of the
    float64 Hessian against the 40-digit gradient, touching rows, the step's largest
    DOF over the entry's largest, slopes L / max|w| included, and the stability
    the independent Hessian decides or None).

    The stability: where no obstacle row touches and every point of a unilateral
    bed lies farther than 1e-6 of the largest |g - w| from the bed's edge (the
    energy smooth around the entry), the least eigenvalue of (H, stiffness()) above
    ``EIG`` is a strict minimum ("stable"), below -``EIG`` a saddle ("unstable");
    else None (not checked).
    """
    size = float(np.max(np.abs(w)))
    en = Discrete(scene, size if size > 0 else scene.beam.length)
    x = en.from_nodal(w, slope)
    _, g, H = reference(en, x, hessian=True)
    R, r = en.constraints()
    act = np.flatnonzero(R @ x - r <= ACTIVE * (1.0 if size > 0 else 0.0)) if len(r) else []
    if len(act):
        Z = sla.null_space(R[act])
        if Z.shape[1] == 0:
            return 0.0, 0.0, len(act), 0.0, None
        Zm = mpmath.matrix(Z.tolist())
        du40 = Zm * mpmath.lu_solve(Zm.T * H * Zm, Zm.T * mpmath.matrix(g.tolist()))
        Hf = Z.T @ en.hessian(x) @ Z
        du64 = Z @ np.linalg.solve(Hf, Z.T @ g)
    else:
        du40 = mpmath.lu_solve(H, mpmath.matrix(g.tolist()))
        du64 = np.linalg.solve(en.hessian(x), g)

    def rel(du):
        top = float(np.max(np.abs(en.nodal_w(np.asarray(du, float)))))      # [m]
        return top / size if size > 0 else (math.inf if top > 0 else 0.0)
    du = np.asarray([float(v) for v in du40])
    top = float(np.max(np.abs(x), initial=0.0))
    step_all = float(np.max(np.abs(du), initial=0.0)) / top if top > 0 else rel(du)
    label = None
    if not len(act) and size > 0:
        clear = True
        if en.kind == "foundation":
            depth = np.asarray(en.gql - en._local(x)[5], float)
            clear = float(np.min(np.abs(depth))) > 1e-6 * float(np.max(np.abs(depth)))
        if clear:
            least = float(sla.eigh(en.hessian(x), en.stiffness(), eigvals_only=True)[0])
            label = "stable" if least > EIG else "unstable" if least < -EIG else None
    return rel(du), rel(du64), len(act), step_all, label


# ---------------------------------------------------------------- one scene
def run_scene(name, data, tags):
    path = write_scene(os.path.join(OUT, "scenes", f"{name}.toml"), data)
    rec = {"name": name, "file": path, "tags": tags, "P": data["load"]["axial"], "wrong": [],
           "disagree": [], "errors": [], "false_alarms": 0, "justified": 0}
    rc, out, err, dt = gaocvx_cli(["equilibria", path, "--json"], args.eq_timeout)
    rec.update(eq_rc=rc, eq_s=round(dt, 2))
    if rc is None:
        rec["errors"].append(f"equilibria timeout ({args.eq_timeout:g} s)")
    elif rc not in (0, 1) or "Traceback" in err:
        rec["errors"].append(f"equilibria rc {rc}: {err.strip()[-600:]}")
    rc2, out2, err2, dt2 = gaocvx_cli(["solve", path, "--method", "global", "--json"], args.solve_timeout)
    rec.update(solve_rc=rc2, solve_s=round(dt2, 2))
    if rc2 is None:
        rec["errors"].append(f"solve timeout ({args.solve_timeout:g} s)")
    elif rc2 not in (0, 1, 2) or "Traceback" in err2:
        rec["errors"].append(f"solve rc {rc2}: {err2.strip()[-600:]}")
    r = json.loads(out2) if rc2 in (0, 1) and out2.strip() else None
    if r is not None:
        rec.update(solve_status=r["status"], solve_E=r["energy"], P_bar=r.get("P_bar"),
                   k=r.get("global", {}).get("unstable_modes"))
    if rc not in (0, 1):
        return rec
    eqs = [json.loads(line) for line in out.splitlines() if line.strip()]
    scene = Scene.from_dict(data)
    rec["entries"] = ents = []
    for q in eqs:
        w, slope = q["nodes"]["w"], q["nodes"]["slope"]
        e = {"rank": q["rank"], "stability": q["stability"], "status": q["status"],
             "energy": q["energy"], "max_w": float(np.max(np.abs(w)))}
        try:
            e["step"], e["step_f64H"], e["touching"], e["step_all"], e["label"] = \
                newton_step(scene, w, slope)
        except Exception as exc:  # noqa: BLE001
            e["step"] = math.nan
            rec["errors"].append(f"step of rank {q['rank']}: {exc!r}"[:300])
        ents.append(e)
        what = f"rank {e['rank']} {e['stability']} {e['status']}: step {e['step']:.3g} " \
               f"(float64 Hessian {e.get('step_f64H', math.nan):.3g}), max|w| {e['max_w']:.3g} m"
        if e["step"] != e["step"]:
            continue
        if e["status"] == "optimal" and e["step"] > args.tol:
            rec["wrong"].append(what)
        elif e["status"] == "optimal" and e["step_all"] > args.tol:
            rec["wrong"].append(what + f"; in all DOFs {e['step_all']:.3g}")
        elif e["status"] == "optimal" and e["label"] not in (None, e["stability"]):
            rec["wrong"].append(what + f"; {e['label']} by the independent Hessian")
        elif e["status"] == "inaccurate":
            small = e["step"] <= args.tol
            rec["false_alarms" if small else "justified"] += 1
    compare_with_solve(rec, scene, r, eqs)
    return rec


def compare_with_solve(rec, scene, r, eqs):
    """The lowest stable optimal entry against an optimal global answer (energy, deflection)."""
    stab = [q for q in eqs if q["stability"] == "stable" and q["status"] == "optimal"]
    if r is None or r["status"] != "optimal":
        return
    if not stab:
        rec["notes"] = "solve optimal, no stable optimal entry"
        return
    lo = min(stab, key=lambda q: q["energy"])
    ws, wl = np.asarray(r["nodes"]["w"]), np.asarray(lo["nodes"]["w"])
    size = max(float(np.max(np.abs(ws))), float(np.max(np.abs(wl))), 1e-300)
    en = Discrete(scene, size)
    scale = en.parts_scale(en.from_nodal(ws, r["nodes"]["slope"])) * en.E0
    rel = re.search(r"\(([0-9.e+-]+) of the energy scale\)", r.get("message") or "")
    gap = re.search(r"certified gap ([0-9.e+-]+) J", r.get("message") or "")
    if rel and gap and float(rel.group(1)) > 0:
        scale = max(scale, float(gap.group(1)) / float(rel.group(1)))
    cands = [ws, -ws, ws[::-1], -ws[::-1]]
    cands += [np.asarray(a["w"]) for a in (r.get("global", {}).get("alternatives") or [])]

    def dist(q):
        wq = np.asarray(q["nodes"]["w"])
        top = max(float(np.max(np.abs(ws))), float(np.max(np.abs(wq))), 1e-300)
        return min(float(np.max(np.abs(wq - c))) for c in cands if len(c) == len(wq)) / top
    dw = dist(lo)
    dE = (lo["energy"] - r["energy"]) / max(scale, 1e-300)
    rec.update(cmp_dE=dE, cmp_dw=dw, cmp_scale=scale)
    if abs(dE) > 1e-9:
        rec["disagree"].append(f"energy: lowest stable optimal {lo['energy']!r} J, solve "
                               f"{r['energy']!r} J ({dE:.3g} of the scale {scale:.3g} J)")
    if dw > 2e-6:
        rec["disagree"].append(f"deflection: lowest stable optimal (rank {lo['rank']}) and solve "
                               f"differ by {dw:.3g} of max|w| {size:.3g} m")
    low = min((q for q in eqs if q["stability"] == "stable"), key=lambda q: q["energy"])
    if rec["disagree"] and low is not lo:
        # which entry solve found: the lowest stable one, whatever its status
        rec["disagree"][-1] += (f"; the lowest stable entry, rank {low['rank']} {low['status']} "
                                f"({low['energy']!r} J), differs from solve by {dist(low):.3g}")


def write_finding(rec, data):
    what = rec["wrong"] + [f"disagrees with solve, {d}" for d in rec["disagree"]]
    head = [f"equilibria in their own scale: {rec['name']} ({' '.join(map(str, rec['tags']))})",
            f"library under test: {SRC}", f"P = {rec['P']!r} N, P_bar_h = {rec.get('P_bar')!r} N"]
    head += [("WRONG " if i < len(rec["wrong"]) else "") + w for i, w in enumerate(what)]
    return write_scene(os.path.join(OUT, "findings", f"{rec['name']}.toml"), data, head)


# ---------------------------------------------------------------- summary
def summary(recs, elapsed):
    ents = [e for r in recs for e in r.get("entries", [])]
    opt = [e for e in ents if e["status"] == "optimal"]
    top = max(opt, key=lambda e: e["step"] if e["step"] == e["step"] else math.inf, default=None)
    inside = max((e for e in opt if e["step"] <= args.tol), key=lambda e: e["step"], default=None)
    cmp_ = [r for r in recs if "cmp_dE" in r]
    ratio = [e["step_f64H"] / e["step"] for e in ents if e.get("step_f64H") is not None
             and math.isfinite(e["step"]) and e["step"] > 1e-12]
    kinds = " / ".join(str(sum(r["tags"][0] == k for r in recs)) for k in ("rand", "near", "near2"))
    rows = [("scenes (rand / near / near2)", f"{len(recs)} ({kinds})"),
            ("entries (stable / unstable)", f"{len(ents)} ({sum(e['stability'] == 'stable' for e in ents)}"
                                            f" / {sum(e['stability'] != 'stable' for e in ents)})"),
            ("optimal entries", str(len(opt))),
            ("largest step of an optimal entry",
             f"{top['step']:.3g} (max|w| {top['max_w']:.3g} m)" if top else "-"),
            ("... of those within the rule",
             f"{inside['step']:.3g} (max|w| {inside['max_w']:.3g} m)" if inside else "-"),
            ("WRONG (optimal: step, all-DOF step or label)", str(sum(len(r["wrong"]) for r in recs))),
            ("inaccurate entries: justified / false alarms",
             f"{sum(r['justified'] for r in recs)} / {sum(r['false_alarms'] for r in recs)}"),
            ("compared with solve (max |dE| / scale, max dw / max|w|)",
             f"{len(cmp_)} ({max((abs(r['cmp_dE']) for r in cmp_), default=0):.2g}, "
             f"{max((r['cmp_dw'] for r in cmp_), default=0):.2g})" if cmp_ else "0"),
            ("float64 Hessian's step / step (min, max; steps > 1e-12)",
             f"{min(ratio, default=math.nan):.3g}, {max(ratio, default=math.nan):.3g}"),
            ("... on the other side of the rule", str(sum(
                (e["step"] > args.tol) != (e.get("step_f64H", math.nan) > args.tol) for e in ents))),
            ("disagreements with solve", str(sum(bool(r["disagree"]) for r in recs))),
            ("solve optimal, no stable optimal entry", str(sum("notes" in r for r in recs))),
            ("timeouts / other errors", f"{sum('timeout' in x for r in recs for x in r['errors'])} / "
                                        f"{sum('timeout' not in x for r in recs for x in r['errors'])}"),
            ("time: equilibria / solve / total [s]",
             f"{sum(r.get('eq_s') or 0 for r in recs):.0f} / {sum(r.get('solve_s') or 0 for r in recs):.0f}"
             f" / {elapsed:.0f}")]
    wd = max(len(a) for a, _ in rows)
    lines = [f"| {'':{wd}} | value |", f"|{'-' * (wd + 2)}|-------|"]
    lines += [f"| {a:{wd}} | {b} |" for a, b in rows]
    return "\n".join(lines)


def main():
    print(f"gaocvx from {gaocvx.__file__}; tests from {args.tests}", flush=True)
    recs, findings = [], []
    with open(os.path.join(OUT, "results.jsonl"), "a") as log:
        for name, data, tags in scene_stream():
            if time.time() - T_START > args.budget:
                print("budget reached", flush=True)
                break
            t0 = time.perf_counter()
            try:
                rec = run_scene(name, data, tags)
            except Exception:  # noqa: BLE001
                rec = {"name": name, "tags": tags, "wrong": [], "disagree": [], "false_alarms": 0,
                       "justified": 0, "errors": ["harness: " + traceback.format_exc()[-900:]]}
            rec["total_s"] = round(time.perf_counter() - t0, 1)
            if rec["wrong"] or rec["disagree"]:
                findings.append(write_finding(rec, data))
            recs.append(rec)
            log.write(json.dumps(rec, default=float) + "\n")
            log.flush()
            steps = ", ".join(f"{e['stability'][0]}{e['status'][0]} {e['step']:.2g}"
                              for e in rec.get("entries", []))
            print(f"[{len(recs):3d} {time.time() - T_START:6.0f}s] {name} {' '.join(map(str, tags))} | "
                  f"eq {rec.get('eq_s')}s solve {rec.get('solve_s')}s {rec.get('solve_status')} | "
                  f"[{steps}] | wrong {len(rec['wrong'])} disagree {len(rec['disagree'])} "
                  f"false alarms {rec['false_alarms']}" + "".join(f"\n     {x}" for x in
                                                                rec["wrong"] + rec["disagree"]
                                                                + rec["errors"]), flush=True)
    print("\n" + summary(recs, time.time() - T_START))
    for f in findings:
        print("  finding:", f)
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
