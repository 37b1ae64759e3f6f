"""Solve a scene: choose the method, run it, and build the :class:`Result`.

Examples
--------
>>> from gaocvx import Scene, solve
>>> scene = Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P1",
...     "length": 1.0, "E": 2.1e11, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -5e7}})
>>> result = solve(scene)
>>> result.status, result.method
('optimal', 'newton')
>>> round(result.min["w"] / (-5e7 / (384 * 1.4e8)), 9)   # q L^4 / (384 EI)
1.0
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from .convex import log_outcome, solve_convex
from .cvm import solve_cvm
from .discrete import DiscreteProblem
from .errors import SceneError, SolverError
from .mixed import MixedForm
from .newton import solve_newton
from .result import Result, contact_zones
from .scene import Scene, check_solve_arguments

__all__ = ["solve", "choose_method", "make_result", "cvm_verdict"]

# The exact methods re-solve in the answer's own scale when it differs from the
# first guess by more than this factor (see _solve_exact).
RESCALE = 10.0
# A CVM answer whose energy lies more than this fraction of the energy scale above
# the certified minimum of its mesh is "far from the beam's minimiser" (cvm_verdict):
# 1 % with the thesis's P1 control, whose space does not contain the minimiser;
# with the full control CVM's problem is the beam's own, and a gap is second order
# in the error, so 1e-8 already allows a deflection error of about 1e-4.
CVM_FAR_GAP = 1e-2
CVM_FULL_GAP = 1e-8

log = logging.getLogger(__name__)


def choose_method(scene: Scene, method: str | None = None, elements: int | None = None) -> str:
    """The method that ``method`` (default: the scene's) resolves to.

    ``auto`` is the fastest exact method for every scene kind: Newton (one
    banded solve when the energy is quadratic; the method of multipliers for a
    rigid obstacle), and the certified global method (:mod:`gaocvx.nonconvex`)
    when the axial force is not provably below ``P_bar_h`` of the mesh.
    """
    method = method or scene.solve.method
    if method == "auto":
        from .nonconvex import above_limit
        return "global" if above_limit(scene, elements) else "newton"
    return method


def solve(scene: Scene, method: str | None = None, *, elements: int | None = None,
          solver: str | None = None, problem: DiscreteProblem | None = None,
          warm: dict | None = None, reuse: bool = False) -> Result:
    """Solve a scene and return its :class:`Result`.

    Parameters
    ----------
    scene : Scene
    method : {"auto", "convex", "newton", "cvm", "global"}, optional
        Overrides ``scene.solve.method``.  ``"global"``: the certified global
        minimiser, also above ``P_bar_h`` (:mod:`gaocvx.nonconvex`);
        ``"auto"`` takes it where P is not provably below ``P_bar_h``, else
        Newton (:func:`choose_method`).
    elements : int, optional
        Overrides ``scene.mesh.elements``.
    solver : {"clarabel", "osqp"}, optional
        Convex solver; overrides ``scene.solve.solver``.
    problem : DiscreteProblem, optional
        A discretisation of this scene to reuse.
    warm : dict, optional
        Newton only: ``result.extra["warm"]`` of an earlier solve on the same
        mesh and scale, to start from (sweeps).
    reuse : bool
        Convex only: keep and reuse the compiled parametric program (sweeps).

    Raises
    ------
    SceneError
        For input the method cannot accept, naming the argument or scene key:

        - a bad argument (``scene``, ``method``, ``elements``, ``solver``), or
          a mesh that would not fit in memory;
        - ``"convex"``, ``"newton"`` and ``"cvm"``: an axial force not provably
          below the convexity limit ``P_bar_h`` of the mesh (``P_hat_h`` on a
          bonded foundation); ``"cvm"`` also a bonded foundation or a
          gap or stiffness profile;
        - ``"global"``, and ``"auto"``, which uses it where P is not provably
          below the limit, solve there; they refuse there
          (:mod:`gaocvx.nonconvex`) a scene without a minimiser, i.e.
          without the quartic term (Euler-Bernoulli, or Gao with
          ``E_alpha = 0``) whatever it rests on (with a bonded foundation:
          at or above ``P_hat_h``), more than six unstable buckling modes,
          and more than ``nonconvex.api.MAX_FAST_ELEMENTS`` (8192) elements.
    SolverError
        If the method returns no solution at all.  A solution that fails its
        optimality test is returned with ``status == "inaccurate"``.

    Examples
    --------
    Above the convexity limit (``P_bar_h = 1.168e9`` N here) ``auto`` takes the
    global method; the convex methods refuse the force:

    >>> beam = {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
    ...         "half_thickness": 0.1, "width": 1.0}
    >>> scene = Scene.from_dict({"beam": beam, "load": {"q": -1e6, "axial": 1.3e9},
    ...                          "mesh": {"elements": 8}})
    >>> solve(scene).method
    'global'
    >>> solve(scene, "newton")                     # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gaocvx.errors.SceneError: load.axial: P = 1.3e+09 N is not below the convexity limit ...

    The Euler-Bernoulli beam above its own limit (1.38e9 N) has no minimiser:

    >>> eb = scene.with_overrides({"beam.model": "euler-bernoulli", "load.axial": 2e9})
    >>> solve(eb)                                  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gaocvx.errors.SceneError: load.axial: ... unbounded below ...: there is no minimiser ...
    """
    scene = check_solve_arguments(scene, method, elements, solver)
    t0 = time.perf_counter()
    chosen = choose_method(scene, method, elements)
    if chosen == "global":
        from .nonconvex import solve_global_result
        return solve_global_result(scene, elements=elements, problem=problem, solver=solver)
    extra = None
    dp = problem if problem is not None else DiscreteProblem(scene, elements=elements)
    solver = solver or scene.solve.solver
    if chosen == "cvm" and dp.n == 0:
        # Every DOF fixed by the supports: w = 0 is the answer, for CVM as for all.
        dp, raw = _solve_exact(dp, "newton")
        extra = {"cvm": cvm_verdict_trivial()}
    elif chosen == "cvm":
        if dp.bilateral:
            raise SceneError("foundation.kind", "cvm (the thesis's transforms) handles a "
                             "unilateral foundation; solve a bonded one with newton or convex",
                             "bilateral")
        if scene.has_profile:
            key = "foundation.gap" if isinstance(scene.foundation.gap, tuple) \
                else "foundation.stiffness"
            raise SceneError(key, "cvm (the thesis's transforms) handles a constant gap and "
                             "stiffness; solve a profile with newton or convex", "a table")
        opts = scene.solve
        if not MixedForm(dp).has_load:
            # w = 0 is the exact minimiser (every energy term >= 0, zero there), as
            # newton and convex answer it; CVM's iterations left 9.4e-17 m (a P4 beam
            # loaded only at its clamped end: campaign seed 8, scene 31).
            dp, raw = _solve_exact(dp, "newton")
            extra = {"cvm": cvm_verdict_trivial("no load: w = 0 exactly")}
        else:
            raw = solve_cvm(dp, opts.transform, opts.control, opts.minimizer, opts.bound)
            extra = {"cvm": cvm_verdict(dp, raw)}
            if extra["cvm"]["far_from_minimizer"] is not False:
                raw = {**raw, "message": raw["message"] + "; " + extra["cvm"]["verdict"]}
                log.warning("%s", extra["cvm"]["verdict"])
    elif chosen in ("convex", "newton"):
        first = dp
        dp, raw = _solve_exact(dp, chosen, solver, warm, reuse)
        if chosen == "newton" and raw["status"] != "optimal" \
                and (method or scene.solve.method) == "auto":
            dp, raw, chosen = _convex_fallback(first, dp, raw, solver)
    else:  # pragma: no cover - validated above
        raise SolverError(f"unknown method {chosen!r}")
    return make_result(dp, raw, chosen, time.perf_counter() - t0, extra=extra)


def _convex_fallback(first: DiscreteProblem, dp: DiscreteProblem, raw: dict, solver: str):
    """``auto``: when Newton cannot certify its answer, the convex ground truth's if it can.

    Newton's method of multipliers can stall short of complementarity 1e-12 on a
    point contact carrying a force thousands of times the beam's own load (a
    clamped-pinned Gao beam pressed at x = 0.05 by 3e8 N onto a gap-0 obstacle
    under an upward 4e7 N/m, 12 and 24 elements; found by a property test), where
    Clarabel certifies.  Returns (problem, raw result, method used).
    """
    try:
        quadratic_only = solver == "osqp" and first.needs_gao   # OSQP: QPs only
        cdp, craw = _solve_exact(first, "convex", "clarabel" if quadratic_only else solver,
                                 final=False)   # returned only if certified
    except (SceneError, SolverError) as exc:
        log.info("auto: newton not certified, convex failed too: %s", exc)
        return dp, raw, "newton"
    if craw["status"] != "optimal":
        log.info("auto: neither newton nor convex certified; newton's answer is returned")
        return dp, raw, "newton"
    log.info("auto: newton not certified (%s); convex certified", raw["message"])
    craw = {**craw, "message": f"auto: newton was not certified ({raw['message']}); "
                               + craw["message"]}
    return cdp, craw, "convex"


def _solve_exact(dp: DiscreteProblem, method: str, solver: str = "clarabel",
                 warm: dict | None = None, reuse: bool = False,
                 final: bool = True) -> tuple[DiscreteProblem, dict]:
    """Newton or the convex program, in the answer's own deflection scale.

    The scale W of ``dp`` is a first guess (the unsupported linear answer's
    size, or a sweep's).  A stiff foundation, an obstacle or the Gao term's
    stiffening can make the answer many times smaller or larger; absolute
    tolerances in units of W (the convex solver's, the obstacle's feasibility)
    would then be loose or unreachable against the answer itself.  So the
    problem is solved again, from the first answer, measured in its own size,
    whenever that differs from W by more than RESCALE (at most twice).
    Returns the problem as last scaled and its raw result.
    """
    def run(problem, start):
        if problem.n == 0:  # every DOF fixed by the supports: the answer is w = 0
            return solve_newton(problem)
        if method == "convex":
            # Not final: a re-solve below may replace it (logged once, at the end).
            return solve_convex(problem, solver, reuse=reuse, final=False)
        return solve_newton(problem, start)

    raw = run(dp, warm)
    replaced = 0
    for _ in range(2):
        # An answer below the zero floor (a beam pressed onto an obstacle) is
        # measured in the floor's units, where the certificate measures it.
        size = raw["mixed"].deflection_size(raw["z"])
        if not math.isfinite(size) or 1.0 / RESCALE <= size <= RESCALE:
            break
        try:
            scaled = dp.rescaled(dp.W * size)
            again = run(scaled, raw.get("warm"))
        except (SolverError, ArithmeticError) as exc:  # the first answer stands, as certified
            log.info("re-solve in the answer's own scale failed: %s", exc)
            break
        if raw["status"] == "optimal" and again["status"] != "optimal":
            break
        # Iterations count every pass: the first one's are work done too.
        if raw.get("nit") is not None and again.get("nit") is not None:
            again = {**again, "nit": raw["nit"] + again["nit"]}
        replaced += raw["status"] != "optimal"
        dp, raw = scaled, again
    if method == "convex":
        log_outcome(raw, final, replaced)
    return dp, raw


def cvm_verdict_trivial(why: str = "no free degrees of freedom: w = 0 exactly") -> dict:
    """The CVM verdict where w = 0 is exact (nothing to transform): no free DOFs, or no load."""
    return {"transform": None, "control": None, "minimizer": None, "iterations": 0,
            "control_bound_active": False, "bound": None, "bound_unit": None,
            "energy_gap": 0.0, "energy_gap_rel": 0.0, "ground_truth_status": "optimal",
            "ground_truth_method": "banded-kkt", "far_from_minimizer": False,
            "verdict": why}


def cvm_verdict(dp: DiscreteProblem, raw: dict) -> dict:
    """How far a CVM answer on ``dp`` is from the beam's certified minimiser on the same mesh.

    CVM's own status describes its discrete problem (the controls, the
    transform); whether its answer minimises the beam's energy is decided
    here, by the energy gap against the ground truth (Newton, or the convex
    program when Newton is not certified).  A relative gap above CVM_FAR_GAP
    (P1 control) or CVM_FULL_GAP (full control) is "far from the minimiser": the result then says so, and is not a
    success; neither is an answer that no certified minimiser can be compared
    with (``far_from_minimizer`` None).
    """
    info = {k: raw["cvm"][k] for k in ("transform", "control", "minimizer", "iterations",
                                       "control_bound_active", "bound", "bound_unit")}
    truth_dp, truth = _solve_exact(dp, "newton")
    if truth["status"] != "optimal":
        truth_dp, truth = _solve_exact(dp, "convex")
    parts = truth["mixed"].energy_parts(truth["z"])
    e_truth = sum(parts.values()) * truth_dp.E0
    size = max(abs(e_truth), sum(abs(v) for v in parts.values()) * truth_dp.E0) or 1.0
    gap = dp.energy(raw["u"]) * dp.E0 - e_truth
    rel = gap / size
    # Without a certified minimiser nothing shows the answer is close to it: that
    # is no success either (far_from_minimizer None).
    limit = CVM_FULL_GAP if raw["cvm"]["control"] == "full" else CVM_FAR_GAP
    far = rel > limit if truth["status"] == "optimal" else None
    # The deflection's distance too: near P_bar_h the energy is so flat along the
    # buckling mode that a 0.1 % gap allows a deflection wrong by 100 %.
    w_truth = truth_dp.to_physical(truth["u"])[0]
    dw = float(np.max(np.abs(dp.to_physical(raw["u"])[0] - w_truth), initial=0.0))
    dw_rel = dw / (float(np.max(np.abs(w_truth), initial=0.0)) or 1.0)
    info.update(energy_gap=gap, energy_gap_rel=rel, deflection_error_rel=dw_rel,
                ground_truth_status=truth["status"],
                ground_truth_method=truth["solver"],
                far_from_minimizer=None if far is None else bool(far))
    if truth["status"] != "optimal":
        info["verdict"] = "no certified minimiser to compare with: the energy gap is not certified"
    elif far:
        info["verdict"] = (f"far from the beam's minimiser: its energy is {gap:.4g} J "
                           f"({rel:.2%} of the energy scale) above the certified minimum "
                           f"{e_truth:.6g} J of this mesh; deflection off by {dw_rel:.2%}")
    else:
        info["verdict"] = (f"within {limit:.0e} of the beam's minimum energy "
                           f"(gap {gap:.3g} J, relative {rel:.2g}); deflection off by "
                           f"{dw_rel:.2g} of the minimiser's")
    return info


def make_result(dp: DiscreteProblem, raw: dict, method: str, elapsed: float,
                extra: dict | None = None) -> Result:
    """Turn a solver's raw output on ``dp`` into a :class:`Result` in physical units."""
    log.info("%s: %s (%s, %s iterations, %.1f ms, %d elements)", method, raw["status"],
             raw.get("solver"), raw.get("nit"), elapsed * 1e3, dp.n_nodes - 1)
    u = raw["u"]
    w, slope = dp.to_physical(u)
    # Energies from the better-conditioned mixed variables when the solver has them.
    mf = raw.get("mixed")
    parts = mf.energy_parts(raw["z"]) if mf is not None else dp.energy_parts(u)
    parts = {k: v * dp.E0 for k, v in parts.items()}
    zones = reaction = forces = None
    if dp.contact == "foundation":
        g = -dp.scene.foundation.gap_at(dp.x)
        k_F = dp.scene.foundation.stiffness_at(dp.x)
        # Nodes below the surface (scene-format.md; the thesis's tables count
        # nodes too): every nodal reaction lies in a zone.
        # A bonded foundation's reaction is signed: it pulls where w > g.
        reaction = k_F * (g - w if dp.bilateral else np.maximum(g - w, 0.0))
        zones = contact_zones(dp.x, w < g)
    elif dp.contact == "obstacle":
        zones, forces, reaction = _obstacle_contact(dp, raw, w)
    return Result(
        scene=dp.scene, method=method, status=raw["status"], message=raw["message"],
        x=dp.x.copy(), w=w, slope=slope, energy=float(sum(parts.values())),
        energy_parts=parts, zones=zones, reaction=reaction, problem=dp,
        time_s=elapsed, nit=raw.get("nit"), solver=raw.get("solver"),
        residual=raw.get("residual", {}), contact_forces=forces,
        extra={**(extra or {}), **({"warm": raw["warm"]} if "warm" in raw else {})},
    )


def _obstacle_contact(dp: DiscreteProblem, raw: dict, w) -> tuple:
    """Contact zones, contact forces and nodal reactions of an obstacle answer.

    The constraint points (nodes and Gauss points) are in contact where they
    touch the obstacle (within OBSTACLE_CONTACT_TOL of the answer's size) or
    carry a force; zones are the runs of consecutive such points, so a beam
    touching between two nodes has a zone there, and one point alone is a
    point contact [x, x].  A support at the obstacle's level (gap 0) counts
    only where the contact continues into the span.  In a channel, forces from
    the surface above are negative (they push down).
    """
    mf, lam, z = raw["mixed"], raw["lam"], raw["z"]
    to_newton = dp.E0 / dp.W / dp.scene.beam.load_factor  # multiplier -> force [N]
    touching, carrying = mf.in_contact(z, lam)
    signed = lam.copy()
    points = mf.con_points
    supported = np.setdiff1d(np.arange(dp.n_nodes), dp.free[dp.free % 2 == 0] // 2)
    at_support = w[supported] <= -dp.scene.obstacle.gap_at(dp.x[supported])
    if dp.g_above is not None:
        # A channel: the upper surface's rows follow the lower's, on the same
        # points; a point is in contact with either, its force is signed.
        m = mf.n_below
        touching, carrying = touching[:m] | touching[m:], carrying[:m] | carrying[m:]
        signed, points = lam[:m] - lam[m:], points[:m]
        at_support |= w[supported] >= dp.scene.obstacle.gap_above
    x = np.r_[points * dp.L, dp.x[supported]]
    flag = np.r_[touching, at_support]
    order = np.argsort(x, kind="stable")
    x, flag = x[order], flag[order]
    ends = np.flatnonzero(order >= len(touching))  # the supports among the points
    neighbour = np.r_[flag[1:], False] | np.r_[False, flag[:-1]]
    flag[ends] &= neighbour[ends]
    zones = contact_zones(x, flag)
    forces = np.column_stack([points[carrying] * dp.L, signed[carrying] * to_newton])
    force = mf.A_hermite.T @ lam  # consistent nodal forces, non-dimensional
    return zones, forces[np.argsort(forces[:, 0])], force[0::2] * to_newton


