#!/usr/bin/env python
"""k = 2 campaign: does gaocvx.nonconvex.equilibria miss a stable equilibrium
(a local minimiser of the energy) with an obstacle or a channel?

For every scene (two unstable buckling modes, an obstacle or channel, 8-24
elements):

* ``equilibria(scene)`` is run and timed (library under test from ``--src``);
* every reported equilibrium gets the independent verdict of
  tests/test_equilibria_obstacle_campaign.py::check (energy, KKT, stability);
* an independent multistart (tests/nonconvex_independent.py::Discrete, SLSQP with
  the obstacle) from ``Discrete.starts`` (two amplitudes: the reported size and the
  gap's) plus the reported equilibria perturbed; the distinct local minima that
  are KKT points (``Discrete.kkt``) and that ``check`` calls stable are compared
  with the reported list.  A MISS: no reported deflection within
  1e-6 max|w| + 1e-9 L (nodal w) and no reported energy within 1e-8 relative.
  A candidate within 1e-3 relative in deflection and 1e-6 in energy of a reported
  one is logged as ``near`` (a precision difference, not a miss).

Each miss is written to ``<out>/misses/<name>.toml`` (a scene file, header comment
giving the missed equilibrium and the reported list), ``<name>.npy`` (the
independent minimiser's nodal w [m]) and ``<name>.json`` (w, slope, energy, the
reported list).  Re-running with ``--files <out>/misses/*.toml`` re-checks those
scenes: the saved minimiser itself is compared with the new reported list (it is
re-verified as a stable KKT point first), and the multistart is run again.

Usage (from the repository's root; ``--src`` another tree of gaocvx to test)::

    python benchmarks/equilibria_campaign.py --out /tmp/k2 --seeds 11,12,13 --hand-seed 12
    python benchmarks/equilibria_campaign.py --out /tmp/k2b --files /tmp/k2/misses/*.toml

The numbers of docs/nonconvex.md's trial come from such runs (the command is
given there with each).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import traceback
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--src", default=ROOT,
                help="source tree of gaocvx under test (put first on the path)")
ap.add_argument("--tests", default=os.path.join(ROOT, "tests"),
                help="directory of the independent reference (nonconvex_independent.py, ...)")
ap.add_argument("--out", required=True, help="output directory (misses/, results.jsonl)")
ap.add_argument("--files", nargs="*", default=None,
                help="re-run only these scene TOML files (e.g. saved misses)")
ap.add_argument("--seeds", default="1,2,3,4,5,6,7,8,9,10",
                help="obstacle_scenes seeds (comma separated)")
ap.add_argument("--per-seed", type=int, default=40,
                help="obstacle_scenes(seed, count): k = 1..2 scenes drawn per seed (k = 2 kept)")
ap.add_argument("--hand", type=int, default=40, help="hand-made thesis-beam scenes")
ap.add_argument("--hand-seed", type=int, default=7)
ap.add_argument("--supports", default="P1,P2,P3,P4", help="supports of the hand-made scenes")
ap.add_argument("--channel-prob", type=float, default=0.25, help="hand-made: chance of a channel")
ap.add_argument("--elements", default="8,12,16,24")
ap.add_argument("--starts", type=int, default=50, help="multistart points (plus the reported ones)")
ap.add_argument("--slsqp-iter", type=int, default=300)
ap.add_argument("--budget", type=float, default=3000.0, help="wall seconds for the whole run")
ap.add_argument("--max-scenes", type=int, default=80)
ap.add_argument("--stop-misses", type=int, default=3,
                help="stop once this many misses were found and --min-scenes run (0: never)")
ap.add_argument("--min-scenes", type=int, default=25)
ap.add_argument("--only", default="", help="only 'hand' or 'campaign' scenes")
ap.add_argument("--seed", type=int, default=0, help="rng seed of the multistart")
args = ap.parse_args()

SRC = os.path.abspath(args.src)
os.environ["PYTHONPATH"] = SRC + os.pathsep + os.environ.get("PYTHONPATH", "")
sys.path.insert(0, SRC)
sys.path.insert(1, os.path.abspath(args.tests))

import numpy as np  # noqa: E402

import gaocvx  # noqa: E402

assert os.path.abspath(gaocvx.__file__).startswith(SRC), gaocvx.__file__
from gaocvx import Scene  # noqa: E402
from gaocvx.nonconvex import equilibria  # noqa: E402

import nonconvex_independent as NI  # noqa: E402
from nonconvex_independent import Discrete  # noqa: E402
from test_equilibria_obstacle_campaign import check, obstacle_scenes  # noqa: E402

sys.path.insert(2, HERE)
from face_newton import polish  # noqa: E402  (Newton on the touching rows' face)

try:
    import tomllib
except ImportError:  # pragma: no cover
    import tomli as tomllib

NI.Discrete.SLSQP_ITER = args.slsqp_iter
ELEMENTS = [int(v) for v in args.elements.split(",")]
THESIS = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}
OUT = os.path.abspath(args.out)
MISSDIR = os.path.join(OUT, "misses")
os.makedirs(MISSDIR, exist_ok=True)
T_START = time.time()


# ---------------------------------------------------------------- scenes
def mode_loads(data, count=3):
    """The first ``count`` buckling loads [N] of the scene's beam (independent pencil)."""
    d = json.loads(json.dumps(data))
    d["load"] = dict(d.get("load", {}))
    d["load"]["axial"] = 0.0
    en = Discrete(Scene.from_dict(d), 1.0)
    lam, _ = en.modes(count)
    bp = en.bp
    return [float(v) * bp.EI / (bp.mu * bp.L**2) for v in lam]


def _logu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def hand_scene(rng):
    """A thesis-beam scene: P1-P4, gao, axial between the 2nd and 3rd mode loads,
    uniform / table / point load 1e5..1e8 N/m downward, obstacle gap 0..0.02 m
    (a channel now and then)."""
    supports = str(rng.choice(args.supports.split(",")))
    n = int(rng.choice(ELEMENTS))
    Q = _logu(rng, 1e5, 1e8)
    kind = str(rng.choice(["uniform", "table", "points"]))
    load = {}
    if kind == "uniform":
        load["q"] = -Q
    elif kind == "table":
        k = int(rng.integers(2, 5))
        xs = np.unique(np.r_[0.0, np.sort(rng.uniform(0, 1, k - 2)), 1.0])
        load["q"] = [[float(x), -Q * float(rng.uniform(0.0, 1.0))] for x in xs]
    else:
        load["points"] = [[float(rng.uniform(0.05, 0.95)), -Q * float(rng.uniform(0.05, 1.0))]
                          for _ in range(int(rng.integers(1, 3)))]
    gap = 0.0 if rng.random() < 0.15 else _logu(rng, 1e-4, 0.02)
    obstacle = {"gap": gap}
    if rng.random() < args.channel_prob:
        obstacle["gap_above"] = _logu(rng, 1e-3, 0.04)
    data = {"beam": {"model": "gao", "supports": supports, **THESIS}, "load": load,
            "obstacle": obstacle, "mesh": {"elements": n}}
    lam = mode_loads(data)
    u = float(rng.uniform(0.03, 0.97))
    data["load"]["axial"] = lam[1] + u * (lam[2] - lam[1])
    tag = f"hand {supports} {kind} gap {gap:.3g}{' channel' if 'gap_above' in obstacle else ''}"
    return data, tag


def scene_stream():
    """(name, data, tag) in the order to run: hand-made and campaign scenes interleaved."""
    if args.files is not None:
        for f in args.files:
            with open(f, "rb") as fh:
                data = tomllib.load(fh)
            yield os.path.splitext(os.path.basename(f))[0], data, f"file {f}", f
        return
    hand, camp = [], []
    if args.only != "campaign":
        rng = np.random.default_rng([args.hand_seed, 2024])
        i = 0
        while len(hand) < args.hand:
            data, tag = hand_scene(rng)
            i += 1
            if Discrete(Scene.from_dict(data), 1.0).unstable_modes() == 2:
                hand.append((f"hand{args.hand_seed}_{i - 1}", data, tag, None))
    if args.only != "hand":
        for seed in [int(s) for s in args.seeds.split(",") if s]:
            for c in obstacle_scenes(seed, args.per_seed, elements=tuple(ELEMENTS)):
                if c.id.endswith("k = 2"):
                    draw = c.id.split("draw ")[1].split(",")[0]
                    camp.append((f"seed{seed}_draw{draw}", c.data,
                                 f"campaign {c.id} {' '.join(c.tags)}", None))
    for i in range(max(len(hand), len(camp))):
        for lst in (hand, camp):
            if i < len(lst):
                yield lst[i]


# ---------------------------------------------------------------- helpers
class Point:
    """An independent point dressed as gaocvx's Equilibrium for ``check``."""

    def __init__(self, w, slope, energy):
        self.w, self.slope, self.energy = np.asarray(w), np.asarray(slope), energy
        self.stable, self.status = True, "optimal"


def nodal(en, x):
    u = np.zeros(en.bp.ndof)
    u[en.free] = x
    return u[0::2] * en.W, u[1::2] * en.W / en.L


def same_w(wa, wb, L, rel=1e-6):
    top = max(float(np.max(np.abs(wa))), float(np.max(np.abs(wb))))
    return float(np.max(np.abs(wa - wb))) <= rel * top + 1e-9 * L


def rel_e(a, b):
    return abs(a - b) / max(abs(a), abs(b), 1e-300)


def touching(en, x):
    R, r = en.constraints()
    if not len(r):
        return 0, []
    size = max(float(np.max(np.abs(x))), 1.0)
    slack = R @ x - r
    t = np.flatnonzero(slack <= 1e-9 * size)
    pts = np.concatenate([en.points, en.points[:len(en.lower)]] if en.upper is not None
                         else [en.points])
    return len(t), sorted({round(float(p), 6) for p in pts[t]})


def eq_summary(e, c=None):
    d = {"energy": float(e.energy), "stable": bool(e.stable), "status": e.status,
         "max_w": float(np.max(np.abs(e.w)))}
    if c is not None:
        d["verdict"] = c.get("verdict")
    return d


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise TypeError(v)


def write_toml(path, data, header):
    lines = ["# " + h for h in header] + [""]
    for sec in ("beam", "load", "obstacle", "foundation", "mesh"):
        if sec not in data:
            continue
        lines.append(f"[{sec}]")
        for k, v in data[sec].items():
            if v is None or (isinstance(v, (list, tuple)) and not len(v)):
                continue
            lines.append(f"{k} = {toml_value(v)}")
        lines.append("")
    with open(path, "w") as fh:
        fh.write("\n".join(lines))


def describe(data):
    b, ld, ob = data["beam"], data.get("load", {}), data.get("obstacle", {})
    kinds = []
    if "q" in ld:
        kinds.append("table" if isinstance(ld["q"], list) else "uniform")
    if ld.get("points"):
        kinds.append("points")
    return {"supports": b["supports"], "load": "+".join(kinds) or "none",
            "gap": ob.get("gap"), "gap_above": ob.get("gap_above"),
            "elements": data["mesh"]["elements"], "axial": ld.get("axial", 0.0)}


# ---------------------------------------------------------------- one scene
def run_scene(name, data, tag, path=None):
    rng = np.random.default_rng([args.seed, zlib.crc32(name.encode())])
    rec = {"name": name, "tag": tag, "data": data, "scene": describe(data), "violations": [], "misses": [],
           "near": []}
    scene = Scene.from_dict(data)
    L = scene.beam.length
    rec["k"] = Discrete(scene, 1.0).unstable_modes()
    rec["mode_loads"] = mode_loads(data)
    t0 = time.perf_counter()
    try:
        eqs = equilibria(scene)
    except Exception as exc:  # noqa: BLE001
        rec["eq_s"] = time.perf_counter() - t0
        rec["error"] = f"{type(exc).__name__}: {exc}"
        rec["violations"].append("equilibria raised " + rec["error"])
        eqs = []
    rec["eq_s"] = time.perf_counter() - t0
    reported = []
    for e in eqs:
        try:
            c = check(scene, e, rng)
        except Exception as exc:  # noqa: BLE001
            c = {"violations": [f"check crashed: {exc}"], "verdict": None}
        reported.append(eq_summary(e, c))
        rec["violations"] += [f"{e.energy:.10g} J: {v}" for v in c["violations"]]
        for v in c.get("notes", []):
            rec["violations"].append(f"(note, inaccurate) {e.energy:.10g} J: {v}")
    rec["reported"] = reported

    top = max([float(np.max(np.abs(e.w))) for e in eqs] + [0.0])
    W = top if top > 1e-6 * L else 1e-2
    en = Discrete(scene, W)
    t1 = time.perf_counter()
    # starts: the reported size (mode shapes 1-3 at 0.3, 1, 2 times, random mixtures),
    # the gap's size, the reported equilibria perturbed
    nrand = max(args.starts - 19 - 10, 4)
    s1 = en.starts(rng, 37 + nrand, 1.0)
    starts = [s1[0]] + s1[1:19] + s1[37:]
    obs = scene.obstacle
    gaps = [float(obs.gap)] if not isinstance(obs.gap, (list, tuple)) else [float(v) for _, v in obs.gap]
    g = float(np.mean(gaps))
    if obs.gap_above is not None:
        g = max(g, float(obs.gap_above))
    if g > 1e-9:
        s2 = en.starts(rng, 37 + 6, 1.5 * g / W)
        starts += s2[1:5] + s2[37:]
    for e in eqs:
        x = en.from_nodal(e.w, e.slope)
        sc = max(float(np.max(np.abs(x))), 1e-3)
        for eps in (1e-2, 1e-1):
            starts.append(x + eps * sc * rng.normal(size=en.n))
    mins = []
    for x0 in starts:
        try:
            x, f, ok = en.local_min(x0)
        except Exception as exc:  # noqa: BLE001
            rec.setdefault("local_errors", []).append(str(exc))
            continue
        R, r = en.constraints()
        if len(r) and np.min(R @ x - r) < -1e-4 * max(float(np.max(np.abs(x))), 1.0):
            continue  # (slightly infeasible SLSQP ends are polished below)
        mins.append((f, x))
    mins.sort(key=lambda a: a[0])
    # distinct minima (nodal w within 1e-4 relative)
    reps = []
    for f, x in mins:
        w, _ = nodal(en, x)
        if not any(same_w(w, nodal(en, y)[0], L, 1e-4) for _, y in reps):
            reps.append((f, x))
    rec["n_starts"] = len(starts)
    rec["n_minima"] = len(reps)
    found = []
    for f, x in reps:
        w, slope = nodal(en, x)
        energy = en.energy(x)
        strict = any(same_w(w, e.w, L) for e in eqs) or \
            any(rel_e(energy, e.energy) <= 1e-8 for e in eqs)
        if strict:
            found.append({"energy": energy, "max_w": float(np.max(np.abs(w))), "matched": True})
            continue
        # polish: another SLSQP from it, then Newton on the touching rows' face
        R, r = en.constraints()
        x2, f2, _ = en.local_min(x, slsqp_iter=1000)
        cands = [(x, "slsqp"), (x2, "slsqp2")]
        for xs_ in (x, x2):
            for tol in (1e-8, 1e-6, 1e-5):
                try:
                    xp, pst = polish(en, xs_, act_tol=tol)
                    cands.append((xp, f"newton {tol:g} {pst}"))
                except (np.linalg.LinAlgError, ValueError):
                    pass    # (one candidate fewer: SLSQP's own end points remain)
        best = None
        for xc, how in cands:
            try:
                kc = en.kkt(xc)
            except Exception:  # noqa: BLE001
                continue
            score = max(kc["stationarity"], kc["feasibility"] * 1e3)
            if best is None or score < best[0]:
                best = (score, xc, how)
        x, pst = best[1], best[2]
        f = en(x)[0]
        w, slope = nodal(en, x)
        energy = en.energy(x)
        kk = en.kkt(x)
        kkt_ok = kk["stationarity"] <= 1e-6 and kk["feasibility"] <= 1e-9
        c = check(scene, Point(w, slope, energy), rng, searches=6)
        nt, where = touching(en, x)
        item = {"energy": energy, "max_w": float(np.max(np.abs(w))), "touching": nt,
                "polish": pst,
                "touch_x": where, "stationarity": kk["stationarity"],
                "feasibility": kk["feasibility"], "verdict": c.get("verdict"),
                "check_kkt": c.get("kkt")}
        strict = any(same_w(w, e.w, L) for e in eqs) or \
            any(rel_e(energy, e.energy) <= 1e-8 for e in eqs)
        near = [i for i, e in enumerate(eqs) if same_w(w, e.w, L, 1e-3)
                and rel_e(energy, e.energy) <= 1e-6]
        if strict:
            item["matched"] = True
        elif near:
            item["near_of"] = near
            rec["near"].append(item)
        elif any(same_w(w, np.asarray(m["w"]), L, 1e-5) or (rel_e(energy, m["energy"]) <= 1e-9
                 and same_w(w, np.asarray(m["w"]), L, 1e-3)) for m in rec["misses"]):
            item["duplicate"] = True
        elif kkt_ok and c.get("kkt") and c.get("verdict") == "stable":
            dists = [float(np.max(np.abs(w - e.w))) for e in eqs]
            item["closest_reported_dw"] = min(dists) if dists else None
            item["w"], item["slope"] = w.tolist(), slope.tolist()
            rec["misses"].append(item)
        else:
            item["rejected"] = True
        found.append(item)
    rec["independent"] = [{k: v for k, v in d.items() if k not in ("w", "slope")} for d in found]
    rec["ms_s"] = time.perf_counter() - t1

    # a saved minimiser (re-run of a miss file): compare it with the new list directly
    if path is not None:
        js = os.path.splitext(path)[0] + ".json"
        if os.path.exists(js):
            with open(js) as fh:
                saved = json.load(fh)
            w, slope = np.asarray(saved["w"]), np.asarray(saved["slope"])
            en2 = Discrete(scene, max(float(np.max(np.abs(w))), 1e-3 * L))
            x = en2.from_nodal(w, slope)
            energy = en2.energy(x)
            c = check(scene, Point(w, slope, energy), rng, searches=6)
            kk = en2.kkt(x)
            hit = [i for i, e in enumerate(eqs) if same_w(w, e.w, L)
                   or rel_e(energy, e.energy) <= 1e-8]
            rec["saved"] = {"energy": energy, "verdict": c.get("verdict"),
                            "stationarity": kk["stationarity"], "matched_by": hit,
                            "still_missed": (not hit) and c.get("verdict") == "stable"
                            and bool(c.get("kkt"))}
            if rec["saved"]["still_missed"] and not any(
                    rel_e(m["energy"], energy) <= 1e-8 or same_w(w, np.asarray(m["w"]), L, 1e-5)
                    for m in rec["misses"]):
                rec["misses"].append({"energy": energy, "max_w": float(np.max(np.abs(w))),
                                      "touching": touching(en2, x)[0], "verdict": "stable",
                                      "saved": True, "w": w.tolist(), "slope": slope.tolist()})
    return rec


def save_miss(rec, data, i, m):
    base = os.path.join(MISSDIR, f"{rec['name']}_miss{i}")
    rep = "; ".join(f"{r['energy']:.10g} J ({'stable' if r['stable'] else 'unstable'}, "
                    f"{r['status']}, max|w| {r['max_w']:.3g} m)" for r in rec["reported"])
    ml = ", ".join(f"{v:.4g}" for v in rec["mode_loads"])
    header = [f"k2 campaign miss: {rec['name']} ({rec['tag']})",
              f"library under test: {SRC}",
              f"P = {rec['scene']['axial']:.6g} N; mode loads (independent) {ml} N; k = {rec['k']}",
              f"MISSED stable equilibrium: energy {m['energy']:.12g} J, max|w| {m['max_w']:.6g} m, "
              f"{m.get('touching')} touching rows (nodes + Gauss points) at x = {m.get('touch_x')}",
              f"  stationarity {m.get('stationarity', float('nan')):.2g}, independent verdict "
              f"{m.get('verdict')}; nodal w in {os.path.basename(base)}.npy",
              f"reported by equilibria ({rec['eq_s']:.1f} s): {rep or 'nothing'}"]
    write_toml(base + ".toml", data, header)
    np.save(base + ".npy", np.asarray(m["w"]))
    with open(base + ".json", "w") as fh:
        json.dump({"name": rec["name"], "energy": m["energy"], "w": m["w"], "slope": m["slope"],
                   "touching": m.get("touching"), "reported": rec["reported"],
                   "mode_loads": rec["mode_loads"], "src": SRC}, fh, indent=1)
    return base + ".toml"


# ---------------------------------------------------------------- main
def main():
    print(f"gaocvx from {gaocvx.__file__}; tests from {args.tests}", flush=True)
    log = open(os.path.join(OUT, "results.jsonl" if args.files is None else "rerun.jsonl"), "a")
    n = nmiss = nstill = 0
    miss_files, viol = [], []
    for name, data, tag, path in scene_stream():
        if time.time() - T_START > args.budget or n >= args.max_scenes:
            print("budget / max scenes reached", flush=True)
            break
        try:
            rec = run_scene(name, data, tag, path)
        except Exception:  # noqa: BLE001
            print(f"[{name}] CRASH\n{traceback.format_exc()}", flush=True)
            continue
        n += 1
        nstill += bool(rec.get("saved", {}).get("still_missed"))
        for i, m in enumerate(rec["misses"]):
            if args.files is None:
                f = save_miss(rec, data, i, m)
                m["file"] = f
                miss_files.append(f)
            nmiss += 1
        for m in rec["misses"]:
            m.pop("w", None)
            m.pop("slope", None)
        if rec["violations"]:
            viol.append((name, rec["violations"]))
        log.write(json.dumps(rec, default=float) + "\n")
        log.flush()
        s = rec["scene"]
        rep = ", ".join(f"{r['energy']:.6g}{'s' if r['stable'] else 'u'}" for r in rec["reported"])
        print(f"[{n:3d} {time.time() - T_START:6.0f}s] {name}: {s['supports']} {s['load']} gap "
              f"{s['gap'] if not isinstance(s['gap'], list) else 'table'}"
              f"{' above ' + format(s['gap_above'], '.3g') if s['gap_above'] else ''} "
              f"n={s['elements']} P={s['axial']:.4g} modes={[round(v, -6) for v in rec['mode_loads']]} "
              f"| eq {rec['eq_s']:.1f}s [{rep}] | ms {rec['ms_s']:.1f}s {rec['n_minima']} minima"
              f" | MISSES {[round(m['energy'], 4) for m in rec['misses']]}"
              f" near {len(rec['near'])} viol {len(rec['violations'])}"
              + (f" | saved: {rec['saved']}" if 'saved' in rec else ""), flush=True)
        for v in rec["violations"]:
            print("     violation:", v, flush=True)
        if args.files is None and args.stop_misses and nmiss >= args.stop_misses \
                and n >= args.min_scenes:
            print("enough misses", flush=True)
            break
    if args.files is not None:
        print(f"\nsaved minimisers still missed: {nstill} of {n} files", flush=True)
    print(f"\n{n} scenes, {nmiss} misses, {len(viol)} scenes with check violations, "
          f"{time.time() - T_START:.0f} s", flush=True)
    for f in miss_files:
        print("  miss file:", f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
