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

import time

import numpy as np

from .convex import solve_convex
from .cvm import solve_cvm
from .discrete import DiscreteProblem
from .errors import SceneError, SolverError
from .newton import solve_newton
from .result import Result, contact_zones
from .scene import METHODS, Scene, check_solve_arguments

__all__ = ["solve", "choose_method", "make_result"]

# Tolerance (relative to the deflection scale) for "in contact" with a rigid obstacle.
OBSTACLE_CONTACT_TOL = 1e-6


def choose_method(scene: Scene, method: str | None = None) -> str:
    """The method that ``method`` (default: the scene's) resolves to.

    ``auto`` is the fastest exact method for every scene kind: Newton (one
    banded solve when the energy is quadratic; the method of multipliers for a
    rigid obstacle).
    """
    method = method or scene.solve.method
    return "newton" if method == "auto" else method


def solve(scene: Scene, method: str | None = None, *, elements: int | None = None,
          solver: str | None = None, problem: DiscreteProblem | None = None,
          warm: dict | None = None, reuse: bool = False) -> Result:
    """Solve a scene and return its :class:`Result`.

    Parameters
    ----------
    scene : Scene
    method : {"auto", "convex", "newton"}, optional
        Overrides ``scene.solve.method``.
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
        For input the method cannot accept (e.g. P >= P_bar_h).
    SolverError
        If the method returns no solution at all.  A solution that fails its
        optimality test is returned with ``status == "inaccurate"``.
    """
    scene = check_solve_arguments(scene, method, elements, solver)
    t0 = time.perf_counter()
    if method is not None and method not in METHODS:
        raise SceneError("solve.method", "must be one of " + ", ".join(map(repr, METHODS)), method)
    chosen = choose_method(scene, method)
    extra = None
    dp = problem if problem is not None else DiscreteProblem(scene, elements=elements)
    if dp.n == 0:  # every DOF fixed by the supports: the answer is w = 0
        raw = solve_newton(dp)
    elif chosen == "convex":
        raw = solve_convex(dp, solver or scene.solve.solver, reuse=reuse)
    elif chosen == "newton":
        raw = solve_newton(dp, warm)
    elif chosen == "cvm":
        opts = scene.solve
        raw = solve_cvm(dp, opts.transform, opts.control, opts.minimizer, opts.bound)
        # The energy gap against the convex ground truth of the same mesh.
        truth = solve_convex(dp, "clarabel")
        gap = (dp.energy(raw["u"]) - dp.energy(truth["u"])) * dp.E0
        info = {k: raw["cvm"][k] for k in ("transform", "control", "minimizer", "iterations",
                                           "control_bound_active", "bound", "bound_unit")}
        info["energy_gap"] = gap
        info["ground_truth_status"] = truth["status"]
        extra = {"cvm": info}
    else:  # pragma: no cover - validated above
        raise SolverError(f"unknown method {chosen!r}")
    return make_result(dp, raw, chosen, time.perf_counter() - t0, extra=extra)


def make_result(dp: DiscreteProblem, raw: dict, method: str, elapsed: float,
                extra: dict | None = None) -> Result:
    """Turn a solver's raw output on ``dp`` into a :class:`Result` in physical units."""
    u = raw["u"]
    w, slope = dp.to_physical(u)
    # Energies from the better-conditioned mixed variables when the solver has them.
    mf = raw.get("mixed")
    parts = mf.energy_parts(raw["z"]) if mf is not None else dp.energy_parts(u)
    parts = {k: v * dp.E0 for k, v in parts.items()}
    beam = dp.scene.beam
    zones = reaction = None
    if dp.contact == "foundation":
        g = -dp.scene.foundation.gap
        zones = contact_zones(dp.x, w < g)
        reaction = dp.k_F * np.maximum(g - w, 0.0)
    elif dp.contact == "obstacle":
        g = -dp.scene.obstacle.gap
        touching = w <= g + OBSTACLE_CONTACT_TOL * dp.W
        # With gap = 0 a support sits on the obstacle's level; it counts as
        # contact only where the contact continues into the span.
        supported = np.setdiff1d(np.arange(dp.n_nodes), dp.free[dp.free % 2 == 0] // 2)
        nxt = np.r_[touching[1:], False]
        prev = np.r_[False, touching[:-1]]
        touching[supported] &= (nxt | prev)[supported]
        zones = contact_zones(dp.x, touching)
        lam = raw["lam"]
        force = mf.A_hermite.T @ lam  # consistent nodal forces, non-dimensional
        reaction = force[0::2] * (dp.E0 / dp.W) / beam.load_factor
    return Result(
        scene=dp.scene, method=method, status=raw["status"], message=raw["message"],
        x=dp.x.copy(), w=w, slope=slope, energy=float(sum(parts.values())),
        energy_parts=parts, zones=zones, reaction=reaction, problem=dp,
        time_s=elapsed, nit=raw.get("nit"), solver=raw.get("solver"),
        residual=raw.get("residual", {}),
        extra={**(extra or {}), **({"warm": raw["warm"]} if "warm" in raw else {})},
    )
