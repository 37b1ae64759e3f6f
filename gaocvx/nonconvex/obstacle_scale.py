"""The energy of the linear beam on the obstacle: the global certificate's floor there.

The branch and bound certifies its gap relative to the scene's energy, whose
floor is the unsupported linear answer's (:func:`.scales.scene_energy`).  An
obstacle can absorb a load whose unsupported energy is 1e12 times anything the
beam can do on it: a P4 beam at gap 0 under a point force of 6.04e12 N was
answered flat, 0 J, `optimal`, its gap 8127 J (8.4e-12 of that floor), where a
buckled minimum lies at -1891 J.  With an obstacle the gap must also resolve the
energy measured here (:data:`.search.RESOLVE`), and the search is repeated in
the units of the beam on the obstacle where it does not
(:func:`.scales.global_units`).
"""

from __future__ import annotations

import logging
import warnings

import numpy as np

from .bounds import load_constant, mode_amplitudes

__all__ = ["linear_on_obstacle", "obstacle_energy"]

log = logging.getLogger(__name__)


def linear_on_obstacle(dp) -> tuple[float, float] | None:
    """The linear beam on the obstacle: ``(c0, size)``, in J and m, solved in the
    units of ``dp`` (Clarabel's tolerances are absolute in them: a beam pressed
    flat measured 2e-5 m in a scene's first units and 2e-11 m in the buckled
    beam's; ``size`` only chooses the second search's units).

    ``c0 = -min 1/2 u'K u - f'u`` over the obstacle's rows (``A u >= levels``, a
    channel's too; a convex QP, Clarabel), at least 0 (``w = 0`` is admissible),
    and ``size`` the largest nodal ``|w|`` of its answer.  Where the obstacle
    absorbs the load (a point force pressing the beam onto it), ``c0`` is far
    below :func:`.bounds.load_constant`'s, the unsupported beam's: the energy
    of anything the beam can do on the obstacle is measured against this one.
    ``c0`` is the smaller of minus the primal value and minus the dual one
    (``-1/2 r'K^-1 r + lambda' levels``, ``r = f + A' lambda``, ``lambda >= 0``:
    a bound of the minimum from below, so its negative lies above ``c0``): an
    overestimated ``c0`` would loosen the certificate.  None where the QP is not
    solved (:func:`.minimum.solve_global` then takes ``c0 = 0``, which ``w = 0``
    bounds from below, and no size).
    """
    import cvxpy as cp

    from .node import obstacle_rows

    if dp.n == 0 or not np.any(dp.f):
        return 0.0, 0.0
    A, levels = obstacle_rows(dp)
    u = cp.Variable(dp.n)
    con = [A @ u >= levels]
    prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(u, dp.K, assume_PSD=True) - dp.f @ u), con)
    for tol in (1e-12, 1e-10, 1e-8):
        # (the node programs' ladder: a beam pressed flat at gap 0 in a channel is
        # degenerate, and Clarabel fails at 1e-12)
        try:
            with warnings.catch_warnings():
                # "Solution may be inaccurate": the status says so, and is used.
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=cp.CLARABEL, tol_gap_abs=tol, tol_gap_rel=tol, tol_feas=tol,
                           max_iter=400)
        except cp.error.SolverError:
            continue
        if prob.status in ("optimal", "optimal_inaccurate"):
            break
    if (prob.status not in ("optimal", "optimal_inaccurate") or u.value is None
            or con[0].dual_value is None):
        return None
    x = np.asarray(u.value, float)
    lam = np.maximum(np.asarray(con[0].dual_value, float), 0.0)
    r = dp.f + A.T @ lam
    dual = -0.5 * float(r @ dp._K_chol.solve(r)) + float(lam @ levels)
    primal = 0.5 * float(x @ (dp.K @ x)) - float(dp.f @ x)
    c0 = max(0.0, min(-primal, -dual))
    size = float(np.max(np.abs(dp.full(x)[0::2]), initial=0.0))
    log.info("global: the linear beam on the obstacle: c0 %.3g (unsupported %.3g), size %.3g W",
             c0, load_constant(dp), size)
    return c0 * dp.E0, size * dp.W


def obstacle_energy(dp, modes, linear, reach: float = float("inf")) -> float | None:
    """:func:`.scales.scene_energy` with the linear beam on the obstacle, in the
    units of ``dp``: ``linear`` is :func:`linear_on_obstacle`'s (None: None);
    ``reach`` caps the amplitude (:func:`.scales.channel_reach`)."""
    if linear is None:
        return None
    A = min(float(mode_amplitudes(dp, modes, 1)[0]), reach)
    return linear[0] / dp.E0 + 0.5 * float(modes.c[0]) * A * A
