"""The convex ground truth: the discrete energy as a CVXPY program.

The program is written on the non-dimensional arrays of
:class:`~gaocvx.discrete.DiscreteProblem` and contains only the terms a scene
needs:

* the quadratic part ``1/2 u'(K - pG)u`` as ``1/2 ||y||^2`` with the lifted
  variable ``y = R u`` (``R`` the banded Cholesky factor), so the solver never
  sees the N^4-conditioned matrix K itself;
* the Gao term ``a/12 Σ w_q s_q^4`` with slopes ``s = B1 u`` at 5 Gauss points
  (exact for the degree-8 integrand);
* the foundation term ``c/2 Σ w_q ((g - w_q)^+)^2`` at 5 Gauss points;
* for a rigid obstacle, ``w >= g`` at the nodes and the same Gauss points.

Euler-Bernoulli scenes are quadratic programs and may use OSQP; anything else
uses Clarabel.  The solver's status is mapped honestly and the answer is
checked against the optimality conditions of the discrete problem before it
is called optimal.
"""

from __future__ import annotations

import logging
import time
import warnings

import numpy as np

from .discrete import COMPLEMENTARITY_TOL, FEASIBILITY_TOL, STATIONARITY_TOL, DiscreteProblem
from .errors import SceneError, SolverError

__all__ = ["solve_convex", "build_problem", "STATIONARITY_TOL"]

log = logging.getLogger(__name__)


# A relative duality gap c allows an energy-norm error of about sqrt(c): the
# certificate asks 1e-6, so the gap must be below 1e-12 relative to the O(1)
# scaled energy; 1e-12 reaches that (measured), 1e-14 is beyond what Clarabel
# reaches in double precision.
CLARABEL_SETTINGS = dict(tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-10, max_iter=400)
OSQP_SETTINGS = dict(eps_abs=1e-10, eps_rel=1e-10, max_iter=200_000, polishing=True)


def build_problem(dp: DiscreteProblem):
    """The CVXPY problem of a discrete scene.

    Returns
    -------
    problem : cvxpy.Problem
    u : cvxpy.Variable
        The free DOFs.
    constraint : cvxpy.Constraint or None
        The obstacle constraint ``A u >= g`` (its dual is the reaction).
    """
    import cvxpy as cp

    u = cp.Variable(dp.n, name="u")
    R = dp.quadratic_factor.factor()
    terms = [0.5 * cp.sum_squares(R @ u), -dp.f @ u]
    if dp.needs_gao:
        s = dp.B1 @ u
        # s^4 as square(square(s)): two second-order cones, far more accurate in
        # Clarabel than the power cone that cp.power(s, 4) compiles to.
        terms.append(dp.a / 12.0 * (dp.wq_gao @ cp.square(cp.square(s))))
    constraint = None
    if dp.contact == "foundation":
        pen = cp.pos(dp.g - dp.Nq @ u)
        terms.append(0.5 * cp.sum_squares(cp.multiply(np.sqrt(dp.c * dp.wq_c), pen)))
    elif dp.contact == "obstacle":
        constraint = dp.A @ u >= dp.g
    problem = cp.Problem(cp.Minimize(cp.sum(terms)), [] if constraint is None else [constraint])
    if not problem.is_dcp():  # a formulation bug, never the user's
        raise AssertionError("the convex formulation is not DCP")
    return problem, u, constraint


def solve_convex(dp: DiscreteProblem, solver: str = "clarabel", verbose: bool = False) -> dict:
    """Solve the discrete scene with CVXPY.

    Parameters
    ----------
    dp : DiscreteProblem
    solver : {"clarabel", "osqp"}
        OSQP only for quadratic programs (Euler-Bernoulli scenes).

    Returns
    -------
    dict
        ``u`` (free DOFs), ``lam`` (obstacle multipliers or None), ``status``
        ("optimal" or "inaccurate"), ``message``, ``residual``, ``nit``,
        ``solver``, ``solve_time``.

    Raises
    ------
    SceneError
        If OSQP is asked for a scene that is not a quadratic program.
    SolverError
        If the solver returns no solution.
    """
    import cvxpy as cp

    t0 = time.perf_counter()
    problem, u, constraint = build_problem(dp)
    if solver == "osqp":
        if not problem.is_qp():
            raise SceneError("solve.solver", "OSQP solves quadratic programs only; the gao "
                             "model's quartic term needs clarabel", solver)
        kwargs = dict(solver=cp.OSQP, **OSQP_SETTINGS)
    else:
        kwargs = dict(solver=cp.CLARABEL, **CLARABEL_SETTINGS)
    with warnings.catch_warnings():
        # An inaccurate solve is reported through the status below, not as a warning.
        warnings.simplefilter("ignore", UserWarning)
        try:
            problem.solve(verbose=verbose, **kwargs)
        except cp.error.SolverError as exc:
            raise SolverError(f"{solver} failed: {exc}", "solver_error") from None
    status = problem.status
    if u.value is None or status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise SolverError(f"{solver} returned status {status!r}", status or "error")

    uval = np.asarray(u.value, float)
    lam = None
    if constraint is not None:
        lam = np.asarray(constraint.dual_value, float).ravel()
    residual = dp.residual(uval, lam)
    ok = residual["stationarity"] <= STATIONARITY_TOL
    if lam is not None:
        ok &= residual["feasibility"] <= FEASIBILITY_TOL
        ok &= residual["dual"] <= FEASIBILITY_TOL
        ok &= residual["complementarity"] <= COMPLEMENTARITY_TOL
    # The status comes from the optimality conditions of the discrete problem
    # itself (a KKT certificate independent of the solver's internal scaling);
    # the solver's own label is kept in the message.
    measures = ", ".join(f"{k}={v:.2e}" for k, v in residual.items())
    if ok:
        result_status = "optimal"
        message = f"{solver} status {status!r}; optimality conditions verified ({measures})"
    else:
        result_status = "inaccurate"
        message = f"{solver} status {status!r}; optimality conditions NOT met ({measures})"
        log.warning("convex solve not certified optimal: %s", message)
    stats = problem.solver_stats
    return {
        "u": uval, "lam": lam, "status": result_status, "message": message,
        "residual": residual, "nit": getattr(stats, "num_iters", None), "solver": solver,
        "solve_time": time.perf_counter() - t0,
    }
