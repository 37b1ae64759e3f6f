"""Results of the global method: the glue between :mod:`.minimum` and :mod:`gaocvx.solve`.

``solve(scene, "global")`` lands in :func:`solve_global_result`; ``auto``
picks the global method exactly when :func:`above_limit` says the energy is
not provably convex on the scene's mesh.

Examples
--------
>>> from gaocvx import Scene, solve
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"axial": 1.3e9}, "mesh": {"elements": 16}})
>>> r = solve(scene)                    # auto: above P_bar_h, so "global"
>>> r.method, r.status, r.extra["global"]["unique"]      # q = 0: two mirror images
('global', 'optimal', False)
"""

from __future__ import annotations

import logging
import time

from ..discrete import DiscreteProblem
from ..errors import SceneError, apart
from ..result import extremum

__all__ = ["above_limit", "provably_convex", "solve_global_result"]

log = logging.getLogger(__name__)

# The fast path (up to minimum.MAX_MODES modes) beyond the dense programs' 128 elements, up to
# here: measured at 2048 elements, P4 with one mode in 5 s, P1 with two in 54 s (one
# thread); at 8192, P4 with one mode in 24 s.  Beyond, the Hermite pencil's Sturm
# count (modecheck) and the node programs lose their accuracy (at 32768 elements
# node programs failed; at 16384 the count moved lambda_3 by 1e-3 of itself).
MAX_FAST_ELEMENTS = 8192
# The continuum P_bar lies below P_bar_h (Rayleigh-Ritz); below this fraction of it
# no mesh needs a look (EFFECTIVE_LENGTH of P2 is 2e-6 off the exact root).
_CONTINUUM_MARGIN = 1e-4


def provably_convex(dp) -> bool:
    """True when ``P < P_bar_h`` is proved on the mesh of ``dp`` (:func:`gaocvx.limit.check`)."""
    # The discrete problem's own proof: P < P_bar_h, or below a bonded
    # foundation's P_hat_h.
    return dp.convexity_proved()


def above_limit(scene, elements=None) -> bool:
    """True when the scene's axial force is not provably below ``P_bar_h`` of its mesh."""
    P = scene.load.axial
    if not P > 0 or P < scene.beam.P_bar() * (1.0 - _CONTINUUM_MARGIN):
        return False
    return not provably_convex(DiscreteProblem(scene, elements=elements, check_convexity=False))


def _statement(dp) -> str:
    """What the convex methods say of a P at or above the limit (gaocvx.limit's words;
    a bonded bed's limit is P_hat_h, which the bed raises)."""
    beam = dp.scene.beam
    if getattr(dp, "bilateral", False):
        P, limit = apart(dp.P, dp.P_hat_h)
        return (f"P = {P} N is not below the bonded beam's convexity limit "
                f"P_hat_h = {limit} N for {beam.supports}")
    P, limit = apart(dp.P, dp.P_bar_h)
    return (f"P = {P} N is not below the convexity limit P_bar_h = {limit} N "
            f"for {beam.supports} (continuum P_bar = {beam.P_bar():.4g} N)")


def _physical(dp, u) -> dict:
    w, slope = dp.to_physical(u)
    return {"w": w.tolist(), "slope": slope.tolist(),
            "min": extremum(dp.x, w, largest=False), "max": extremum(dp.x, w, largest=True)}


def solve_global_result(scene, elements=None, problem=None, solver=None):
    """Solve ``scene`` by the global method and return its :class:`~gaocvx.result.Result`.

    Below ``P_bar_h`` (k = 0) the answer is the convex ground truth (CVXPY +
    Clarabel, or OSQP if ``solver`` says so; where it is not certified, the
    Newton path's certified answer), with ``extra["global"]`` saying k = 0.
    Above, see :func:`.minimum.solve_global`.

    Raises
    ------
    SceneError
        For scenes without a minimiser (energy unbounded below) or too fine a mesh.
    """
    from ..convex import log_outcome
    from ..solve import _solve_exact, make_result
    from .at_limit import flat_at_limit
    from .bounds import check_bounded
    from .minimum import MAX_ELEMENTS, MAX_MODES, solve_certified
    from .modes import MAX_UNSTABLE, unstable_modes

    t0 = time.perf_counter()
    if problem is not None:
        dp = problem
    else:
        dp = DiscreteProblem(scene, elements=elements, check_convexity=False)
    if provably_convex(dp):
        dp, raw = _solve_exact(dp, "convex", solver or "clarabel", final=False)
        if raw["status"] != "optimal":
            # The convex program's minimiser is unique, and Newton's answer is certified
            # by the same conditions: where Clarabel stops short (a beam pressed flat onto
            # an obstacle at gap 0: "optimal_inaccurate", stationarity inf), it serves.
            dp2, raw2 = _solve_exact(dp, "newton")
            if raw2["status"] == "optimal":
                raw2["message"] = (f"the convex program not certified ({raw['message']}); "
                                   f"the Newton path: {raw2['message']}")
                dp, raw = dp2, raw2
            else:
                log_outcome(raw)   # (the convex answer is returned, uncertified: said once)
        info = {"unstable_modes": 0, "mode_loads": [], "bound_gap": 0.0, "unique": True,
                "nodes": 1}
        return make_result(dp, raw, "global", time.perf_counter() - t0, extra={"global": info})
    check_bounded(dp)
    n_el = dp.n_nodes - 1
    if n_el > MAX_FAST_ELEMENTS:
        raise SceneError("mesh.elements", f"{_statement(dp)}; above it the global method "
                         f"takes at most {MAX_FAST_ELEMENTS} elements (its fast path; the dense "
                         f"node programs at most {MAX_ELEMENTS})", n_el)
    modes = unstable_modes(dp)
    if modes.k > MAX_MODES:
        # (the count stops past MAX_UNSTABLE: then it is a lower bound)
        count = f"more than {MAX_UNSTABLE}" if modes.k > MAX_UNSTABLE else str(modes.k)
        raise SceneError("load.axial", f"{_statement(dp)}, with {count} unstable buckling modes; "
                         f"the global method's branch and bound takes at most {MAX_MODES}", dp.P)
    if modes.k == 0:
        # Not provably below the limit, yet the eigen-solve puts lambda_1 a hair above
        # P (within round-off): the first mode is treated as unstable (c_1 ~ 0).
        modes = unstable_modes(dp, min_k=1)
    # (without load at the limit, w = 0 in closed form: the search cannot prove a
    # quartic minimum)
    out = flat_at_limit(dp, modes)
    dp, raw, info = out if out is not None else solve_certified(dp, modes)
    # Amplitudes in metres too: the non-dimensional ones are in this answer's own
    # deflection scale, which differs from an equilibria list's (a channel: 0.02 m
    # here, 0.0527 m there, and one minimiser's amplitudes 2.229 and 0.846).
    info["amplitudes_m"] = [a * dp.W for a in info["amplitudes"]]
    alternatives = [{"energy": a["energy"], "amplitudes": a["amplitudes"],
                     "amplitudes_m": [s * dp.W for s in a["amplitudes"]], **_physical(dp, a["u"])}
                    for a in info.pop("alternatives")]
    info["alternatives"] = alternatives
    if alternatives and raw["status"] == "optimal":
        raw["message"] += (f"; not unique: {len(alternatives) + 1} minimisers within the "
                           "certified gap (mirror images or other contact states), all in "
                           "extra['global']['alternatives']")
    elif alternatives:   # (the answer is not certified: candidates only)
        raw["message"] += (f"; {len(alternatives) + 1} candidates within the gap, not "
                           "certified as minimisers, in extra['global']['alternatives']")
    return make_result(dp, raw, "global", time.perf_counter() - t0, extra={"global": info})
