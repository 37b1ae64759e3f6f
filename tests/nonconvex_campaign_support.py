"""A seeded random campaign above P_bar_h: the global method against independent local searches.

Each scene drawn by :func:`random_scene` (all four supports, the Gao model and
a few Euler-Bernoulli ones, uniform / table / point loads or none, unilateral
and bonded foundations, obstacles and channels, gap and stiffness profiles,
P from just above the convexity limit to several times it, 8-32 elements) is
solved by ``solve(scene, "global")``.  The references come from outside the
code under test (tests/nonconvex_independent.py: the discrete energy written
apart from gaocvx, local searches with scipy.optimize), and the rules are:

* ``below``: no local minimum found by the multi-start lies below the certified
  lower bound (``lower_bound``, J) by more than ``TOL_E`` of the energy scale;
  for an ``optimal`` answer, ``energy - bound_gap`` is that bound;
* ``energy``: the reported energy is the independent energy of the reported
  deflection (``TOL_E``);
* ``kkt``: an ``optimal`` minimiser is a KKT point of the independent energy
  (relative dual norm of the gradient less the obstacle's non-negative
  multipliers <= ``TOL_KKT``, feasibility <= 1e-9) and, without an obstacle, a
  local minimum (the generalised Hessian's lowest eigenvalue relative to K's
  >= -``TOL_HESS``);
* ``alternative``: every other minimiser reported (``unique`` false) has the
  independent energy of the answer within the gap plus ``TOL_E`` and is a KKT
  point; a scene without load and contact (its mirror image -w has the same
  energy) with a buckled answer must not be called unique; a distinct local
  minimum of the search with an energy within the gap of an ``optimal`` unique
  answer (distinct also after Newton's steps on the independent energy, without
  an obstacle: the search's trust region stops short where the energy is flat)
  is a missed alternative;
* ``refusal``: a SceneError is justified only for a scene without a quartic
  term (Euler-Bernoulli, which has no minimiser above its limit), more than
  ``MAX_MODES`` unstable modes (counted independently) or a mesh beyond the
  documented 8192 elements (the fast path's; the dense node programs stop at 128); any other refusal is a violation, and so is an
  Euler-Bernoulli answer above its limit;
* ``crash``: any exception other than SceneError / SolverError (a solve stopped
  by the campaign's own ``--solve-limit`` is recorded as ``timeout``, no violation);
* ``slow``: more than ``SLOW`` seconds (reported, not a violation of
  correctness).

Why these tolerances: the certified gap is at most 1e-8 of the energy scale
(the package's GAP_TOL) and the local searches converge to ~1e-12 (trust-region
Newton) or ~1e-10 (SLSQP); ``TOL_E = 1e-8`` of the scale is the package's own
statement.  ``TOL_KKT = 1e-6`` is the stationarity the package certifies
(relative Newton decrement) and the campaign below P_bar (tests/campaign.py).

Examples
--------
>>> import numpy as np
>>> case = random_scene(np.random.default_rng([0, 3]))
>>> sorted(case.data)[:2], case.id
(['beam', 'load'], '')
"""

from __future__ import annotations

import math
import time
import traceback

import numpy as np

from gaocvx import Scene, SceneError, SolverError, solve

from campaign import Case, _loguniform as _logu  # the scenes of the campaign below P_bar
from nonconvex_independent import Discrete

__all__ = ["Case", "random_scene", "run_case", "TOL_E", "TOL_KKT", "TOL_HESS", "SLOW",
           "MAX_MODES", "THESIS_BEAM"]

TOL_E = 1e-8
TOL_KKT = 1e-6
TOL_HESS = 1e-8
SLOW = 60.0
MAX_MODES = 6        # documented in docs/nonconvex.md (global method)
MAX_ELEMENTS = 8192  # documented: the fast path (the dense node programs stop at 128)
THESIS_BEAM = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}


def _table(rng, L, lo, hi, k=None):
    """A piecewise-linear table on [0, L] with values in [lo, hi] (log-uniform if lo > 0)."""
    k = k or int(rng.integers(2, 5))
    xs = np.unique(np.r_[0.0, np.sort(rng.uniform(0, L, k - 2)), L])
    vals = [(_logu(rng, lo, hi) if lo > 0 else float(rng.uniform(lo, hi))) for _ in xs]
    return [[float(x), float(v)] for x, v in zip(xs, vals)]


def _limit(data) -> float:
    """The convexity limit [N] of the scene's mesh from the independent pencil
    (P_bar_h; P_hat_h, of (K + c M, G), for a bonded foundation)."""
    probe = dict(data, load=dict(data["load"], axial=0.0))
    en = Discrete(Scene.from_dict(probe), 1.0)
    lam = en.modes(1)[0][0]
    bp = en.bp
    return float(lam * bp.EI / (bp.mu * bp.L**2))


def random_scene(rng, elements=None) -> Case:
    """Draw one scene above its convexity limit (see the module's notes)."""
    tags = []
    model = "gao" if rng.random() < 0.93 else "euler-bernoulli"
    supports = str(rng.choice(["P1", "P2", "P3", "P4"]))
    beam = {"model": model, "supports": supports, **THESIS_BEAM}
    if rng.random() < 0.3:
        beam["length"] = _logu(rng, 0.5, 3.0)
        beam["half_thickness"] = _logu(rng, 0.02, 0.2) * beam["length"]
        beam["nu"] = float(rng.uniform(0.0, 0.45))
        tags.append("other-beam")
    L = beam["length"]
    tags += [model, supports]
    n = elements or int(rng.choice([8, 12, 16, 24, 32], p=[0.2, 0.15, 0.15, 0.15, 0.35]))
    # loads, in the size of the thesis's (1e7..1e8 N/m on its 1 m beam)
    Q = _logu(rng, 1e5, 2e8) * (beam["half_thickness"] / 0.1) ** 3 / L**2
    sign = -1.0 if rng.random() < 0.8 else 1.0
    kind = str(rng.choice(["none", "uniform", "table", "points", "mixed"],
                          p=[0.15, 0.3, 0.2, 0.2, 0.15]))
    tags.append("no-load" if kind == "none" else kind)
    load = {}
    if kind in ("uniform", "mixed"):
        load["q"] = sign * Q
    if kind == "table":
        t = _table(rng, L, -0.3 * Q, Q)
        load["q"] = [[x, sign * v] for x, v in t]
    if kind in ("points", "mixed"):
        load["points"] = [[float(rng.uniform(0, L)), sign * Q * L * float(rng.uniform(0.05, 1.0))]
                          for _ in range(int(rng.integers(1, 3)))]
    data = {"beam": beam, "load": load, "mesh": {"elements": n}}
    c = rng.random()
    contact = ("none" if c < 0.3 else "foundation" if c < 0.5 else "bonded" if c < 0.62
               else "obstacle" if c < 0.84 else "channel")
    tags.append(contact)
    gap_scale = 0.02 * L
    if contact in ("foundation", "bonded"):
        gap = (_table(rng, L, 0.0, 2 * gap_scale) if rng.random() < 0.3
               else (0.0 if rng.random() < 0.25 else _logu(rng, 1e-4, 3) * gap_scale))
        EI = beam["E"] * (2 / 3) * beam["half_thickness"] ** 3 * beam["width"]
        k0 = EI / L**4 * _logu(rng, 10, 1e5)
        stiff = _table(rng, L, k0 / 10, k0 * 10) if rng.random() < 0.3 else k0
        if isinstance(gap, list) or isinstance(stiff, list):
            tags.append("profile")
        data["foundation"] = {"gap": gap, "stiffness": stiff}
        if contact == "bonded":
            data["foundation"]["kind"] = "bilateral"
    elif contact in ("obstacle", "channel"):
        gap = (_table(rng, L, 0.0, 2 * gap_scale) if rng.random() < 0.3
               else (0.0 if rng.random() < 0.15 else _logu(rng, 1e-3, 3) * gap_scale))
        if isinstance(gap, list):
            tags.append("profile")
        data["obstacle"] = {"gap": gap}
        if contact == "channel":
            data["obstacle"]["gap_above"] = _logu(rng, 0.1, 3) * gap_scale
    # axial force: just above the limit, or up to several times it
    limit = _limit(data)
    a = rng.random()
    frac = (1.0 + 10 ** rng.uniform(-6, -1)) if a < 0.3 else float(rng.uniform(1.1, 5.0))
    tags.append("near-limit" if a < 0.3 else "far-above")
    data["load"]["axial"] = frac * limit
    return Case(data=data, tags=tuple(dict.fromkeys(tags)),
                info={"axial_fraction": frac, "limit": limit})


# ---------------------------------------------------------------- checks
def _justified(case, message, k) -> bool:
    """Whether a refusal names a reason the documentation gives and the scene has it."""
    beam = case.data["beam"]
    if beam["model"] != "gao" and "unbounded below" in message:
        return True
    channel = (case.data.get("obstacle") or {}).get("gap_above") is not None
    if beam["model"] != "gao" and channel and "does not take this scene" in message:
        return True   # (a documented limit: bounded below, but no quartic term for the box)
    if k > MAX_MODES and "unstable buckling modes" in message:
        return True
    return case.data["mesh"]["elements"] > MAX_ELEMENTS and "elements" in message


def _distinct(en, x, y) -> bool:
    """x and y differ by more than 1e-3 of the larger (in the G norm), or of 1e-6 of the
    unsupported linear answer: two answers pressed flat at w = 0 (1e-32 and 0) are one."""
    d = x - y
    _, g0 = en(np.zeros_like(x))
    lin = np.linalg.solve(en.stiffness(), g0)
    floor = 1e-6 * math.sqrt(max(float(lin @ en.G @ lin), 0.0))
    nx = math.sqrt(max(float(x @ en.G @ x), float(y @ en.G @ y), floor**2, 1e-300))
    return math.sqrt(max(float(d @ en.G @ d), 0.0)) > 1e-3 * nx


def _newton(en, x, steps: int = 5):
    """x after up to ``steps`` Newton steps on the independent energy (without an
    obstacle; with one, x as it is).  The trust region stops on an absolute gradient:
    just above the limit, where the energy is flat along the mode, it stopped 1.5e-3
    of the size from the minimiser (2e-14 J above it, a P3 beam on a bed 4.5e-8
    above the limit), which one Newton step reached."""
    if len(en.constraints()[1]):
        return x
    # (a step is kept only where the gradient falls: from a true second minimiser an
    # indefinite Hessian's step could jump anywhere, and must not hide it)
    _, g = en(x)
    for _ in range(steps):
        try:
            step = np.linalg.solve(en.hessian(x), -g)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(step)):
            break
        _, g2 = en(x + step)
        if not np.linalg.norm(g2) < np.linalg.norm(g):
            break
        x, g = x + step, g2
    return x


def run_case(case: Case, starts: int = 24, seed: int = 0) -> dict:
    """Solve one case by the global method and check it (the module's rules)."""
    rec = {"id": case.id, "tags": list(case.tags), "data": case.data, "info": dict(case.info),
           "violations": [], "notes": []}
    scene = case.scene
    t0 = time.perf_counter()
    try:
        r = solve(scene, "global")
        rec["status"] = r.status
    except SceneError as exc:
        r, rec["status"], rec["message"] = None, "refused", str(exc)
    except SolverError as exc:
        r, rec["status"], rec["message"] = None, "error", str(exc)
    except Exception as exc:  # noqa: BLE001 - a crash is what the campaign looks for
        if type(exc).__name__ == "SolveTimeout":  # the campaign's --solve-limit, not gaocvx's
            r, rec["status"], rec["message"] = None, "timeout", str(exc)
            rec["notes"].append(f"timeout: {exc}")
            rec["time_s"] = time.perf_counter() - t0
            return rec
        r, rec["status"] = None, "crash"
        rec["message"] = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        rec["violations"].append(("crash", rec["message"]))
    rec["time_s"] = time.perf_counter() - t0
    if rec["time_s"] > SLOW:
        rec["notes"].append(f"slow: {rec['time_s']:.0f} s")
    probe = Discrete(scene, 1.0)
    k = probe.unstable_modes()
    rec["k"] = k
    gao = case.data["beam"]["model"] == "gao"
    if r is None:
        if rec["status"] == "refused" and not _justified(case, rec["message"], k):
            rec["violations"].append(("refusal", rec["message"]))
        return rec
    glob = r.extra.get("global", {})
    rec.update(message=r.message, k_reported=glob.get("unstable_modes"),
               nodes=glob.get("nodes"), gap=glob.get("bound_gap"), unique=glob.get("unique"),
               certificate=glob.get("certificate"), energy=r.energy)
    if not gao and k >= 1 and r.status == "optimal":
        rec["violations"].append(("unbounded", "an Euler-Bernoulli scene above its limit solved"))
    if glob.get("unstable_modes") != k:
        rec["notes"].append(f"k: reported {glob.get('unstable_modes')}, independent {k}")
    W = max(float(np.max(np.abs(r.w))), 1e-3 * scene.beam.length * 1e-3)
    en = Discrete(scene, W)
    x = en.from_nodal(r.w, r.slope)
    scale = en.parts_scale(x) * en.E0
    rec["scale"] = scale
    tol = TOL_E * scale
    e_ind = en.energy(x)
    if abs(e_ind - r.energy) > tol:
        rec["violations"].append(("energy", f"reported {r.energy:.12g} J, independent "
                                            f"{e_ind:.12g} J of its deflection"))
    m = en.kkt(x)
    rec["kkt"] = {key: m[key] for key in ("stationarity", "feasibility", "lowest", "touching")}
    if r.status == "optimal":
        if m["stationarity"] > TOL_KKT or m["feasibility"] > 1e-9:
            rec["violations"].append(("kkt", f"stationarity {m['stationarity']:.2g}, "
                                             f"feasibility {m['feasibility']:.2g}"))
        if en.A is None and m["lowest"] < -TOL_HESS:
            rec["violations"].append(("kkt", f"not a local minimum: lowest Hessian eigenvalue "
                                             f"{m['lowest']:.2g} (relative to K)"))
    # The multi-start: modes with both signs, mixtures, the answer and its mirror image.
    rng = np.random.default_rng(seed)
    lam, vecs = en.modes(1)
    wrows = np.flatnonzero(en.free % 2 == 0)
    phi = vecs[:, 0] / max(float(np.max(np.abs(vecs[wrows, 0]))), 1e-300)
    sl = en.D @ phi
    # the one-mode amplitude A^2 = 3 (p - lambda_1) ∫phi'^2 / (a ∫phi'^4), phi of peak 1
    i2, i4 = float(en.wq @ sl**2), float(en.wq @ sl**4)
    amp = math.sqrt(max(3 * (en.p - lam[0]) * i2 / (en.a * i4), 0.0)) if en.a > 0 else 1.0
    pts = en.starts(rng, starts // 2, 1.0, extra=[x, -x]) + en.starts(rng, starts - starts // 2,
                                                                      max(amp, 1e-3))
    found = []
    t1 = time.perf_counter()
    for x0 in pts:
        xm, fm, _ = en.local_min(x0)
        R, rr = en.constraints()
        if len(rr) and np.min(R @ xm - rr) < -en.ADMISSIBLE * max(1.0, float(np.max(np.abs(xm)))):
            continue  # an inadmissible end point is no evidence
        found.append((fm * en.E0, xm))
    rec["search_s"] = time.perf_counter() - t1
    if found:
        best_e, best_x = min(found, key=lambda t: t[0])
        rec["search_best"] = best_e
        rec["search_reached"] = bool(abs(best_e - r.energy) <= tol)
        lower = glob.get("lower_bound", r.energy - glob.get("bound_gap", 0.0))
        if best_e < lower - tol:
            rec["violations"].append(("below", f"a local search found {best_e:.12g} J, below the "
                                               f"certified lower bound {lower:.12g} J by "
                                               f"{(lower - best_e) / scale:.2g} of the scale"))
        gap = max(glob.get("bound_gap", 0.0), 0.0)
        if r.status == "optimal" and glob.get("unique"):
            for e2, x2 in found:
                if abs(e2 - r.energy) <= gap + 1e-12 * scale and _distinct(en, x2, x) \
                        and _distinct(en, _newton(en, x2), x):
                    mk = en.kkt(x2)
                    if mk["stationarity"] <= TOL_KKT:
                        rec["violations"].append(("alternative", f"a distinct minimum at "
                                                  f"{e2:.12g} J (answer {r.energy:.12g} J) "
                                                  "while unique"))
                        break
    # Other minimisers reported
    alts = glob.get("alternatives", []) or []
    symmetric_pm = (not case.data["load"].get("q") and not case.data["load"].get("points")
                    and "foundation" not in case.data and "obstacle" not in case.data)
    if r.status == "optimal" and symmetric_pm and glob.get("unique") and \
            float(np.max(np.abs(r.w))) > 0:
        rec["violations"].append(("alternative", "no load, no contact: -w has the same energy, "
                                                 "yet unique"))
    for alt in alts:
        xa = en.from_nodal(alt["w"], alt["slope"])
        ea = en.energy(xa)
        if abs(ea - alt["energy"]) > tol or abs(ea - r.energy) > max(glob["bound_gap"], 0) + tol:
            rec["violations"].append(("alternative", f"alternative energy {alt['energy']:.12g} "
                                      f"(independent {ea:.12g}) vs answer {r.energy:.12g} J"))
        if r.status == "optimal" and en.kkt(xa)["stationarity"] > TOL_KKT:
            rec["violations"].append(("alternative", "an alternative is not a KKT point"))
    return rec
