"""The Shor semidefinite relaxation of the discrete energy (nonconvex.md, issue 10).

Written apart from gaocvx from the independent energy of
tests/nonconvex_independent.py.  With free DOFs u and a matrix X standing for
uu', the lifted problem is ::

    min  1/2 tr((K - p G) X) + a/12 sum_q w_q (d_q' X d_q)^2 - f'u + F(u) [+ bonded part]
    s.t. [[X, u], [u', 1]] PSD,   obstacle rows:  A u >= lower  (and A u <= upper),

where d_q' X d_q stands for (w'_q)^2 (linear in X, so its square is convex), the
unilateral foundation's ``c/2 sum w_q ((g_q - w_q)^+)^2`` is kept in u (convex),
and a bonded foundation's ``c/2 sum w_q (g_q - w_q)^2`` is written through X
(``(n_q'u)^2 -> n_q'X n_q``).  At ``X = uu'`` every term is the energy's own, and
the PSD condition is a relaxation of ``X = uu'``: the optimal value is a **lower
bound** of the discrete minimum.  When the optimal ``Z = [[X, u], [u', 1]]`` has
rank one, ``u`` is admissible with energy equal to that bound, i.e. a global
minimiser: the relaxation is then *tight*.

Examples
--------
>>> from gaocvx import Scene
>>> beam = {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
...         "half_thickness": 0.1, "width": 1.0}
>>> from nonconvex_independent import Discrete
>>> en = Discrete(Scene.from_dict({"beam": beam, "load": {"q": -1e8, "axial": 5e8},
...                                "mesh": {"elements": 4}}), W=0.01)
>>> out = shor(en)                     # below P_bar_h: convex, the relaxation is exact
>>> out["status"], out["rank_ratio"] < 1e-6
('optimal', True)
"""

from __future__ import annotations

import warnings

import cvxpy as cp
import numpy as np

__all__ = ["shor", "relax", "SOLVER_OPTIONS"]

# Clarabel to tight tolerances: the relaxation's value is compared with a
# certified minimum to 1e-7 of the energy scale (1e-10 made Clarabel fail or stop
# "inaccurate" on a cantilever, measured).
SOLVER_OPTIONS = dict(tol_gap_abs=1e-9, tol_gap_rel=1e-9, tol_feas=1e-9, max_iter=400)


def shor(en, solver: str = "CLARABEL", cuts: bool = True) -> dict:
    """Solve the Shor relaxation of ``en`` (a :class:`nonconvex_independent.Discrete`).

    ``cuts``: add the channel's product cuts (see the code); without a channel
    nothing changes.

    Returns
    -------
    dict
        ``status`` (the solver's), ``value`` (in E0 units), ``u`` (free DOFs),
        ``X``, ``eigenvalues`` of Z (descending) and ``rank_ratio`` = second /
        first eigenvalue of Z (0 for a rank-one Z).
    """
    n = en.n
    Z = cp.Variable((n + 1, n + 1), PSD=True)
    X, u = Z[:n, :n], Z[:n, n]
    # The quadratic part with its symmetric matrix: tr(M X) = sum(M * X).
    M = en.K - en.p * en.G
    M = 0.5 * (M + M.T)
    y = cp.sum(cp.multiply(en.D @ X, en.D), axis=1)  # d_q' X d_q, one per Gauss point
    obj = 0.5 * cp.sum(cp.multiply(M, X)) - en.f @ u + en.a / 12.0 * (en.wq @ cp.square(y))
    cons = [Z[n, n] == 1]
    if en.kind == "foundation":
        obj = obj + 0.5 * ((en.wq * en.cq) @ cp.square(cp.pos(en.gq - en.N @ u)))
    elif en.kind == "bonded":
        nxn = cp.sum(cp.multiply(en.N @ X, en.N), axis=1)  # n_q' X n_q
        wc = en.wq * en.cq
        obj = obj + 0.5 * (wc @ (nxn - 2 * cp.multiply(en.gq, en.N @ u)) + wc @ en.gq**2)
    if en.A is not None:
        cons.append(en.A @ u >= en.lower)
        if en.upper is not None:
            cons.append(en.A @ u <= en.upper)
            if cuts:
                # (a'u - lower)(upper - a'u) >= 0 on every row of a channel, with
                # (a'u)^2 -> a'X a: a valid cut of the lifted set (both factors are
                # >= 0 for every admissible u), which bounds X where PSD alone cannot
                axa = cp.sum(cp.multiply(en.A @ X, en.A), axis=1)
                cons.append(axa <= cp.multiply(en.lower + en.upper, en.A @ u)
                            - en.lower * en.upper)
    prob = cp.Problem(cp.Minimize(obj), cons)
    opts = SOLVER_OPTIONS if solver == "CLARABEL" else dict(eps=1e-9, max_iters=200000)
    try:
        prob.solve(solver=solver, **opts)
    except cp.error.SolverError as exc:
        return {"status": f"solver error: {exc}", "value": np.nan, "u": None, "X": None,
                "eigenvalues": None, "rank_ratio": np.nan}
    if Z.value is None:
        return {"status": prob.status, "value": np.nan, "u": None, "X": None,
                "eigenvalues": None, "rank_ratio": np.nan}
    Zv = 0.5 * (Z.value + Z.value.T)
    ev = np.linalg.eigvalsh(Zv)[::-1]
    return {"status": prob.status, "value": float(prob.value), "u": np.array(Zv[:n, n]),
            "X": np.array(Zv[:n, :n]), "eigenvalues": ev,
            "rank_ratio": float(max(ev[1], 0.0) / ev[0]) if n else 0.0}


def relax(scene, W: float, Discrete=None) -> tuple:
    """The relaxation of ``scene`` in the scale W, else 10 W, W / 10 (first "optimal" solve).

    The value does not depend on the scale (it is an exact change of variables);
    the conditioning of the conic program does, and Clarabel stops
    "inaccurate" in some scales (measured: a cantilever with W = max |w|).

    Returns
    -------
    en : nonconvex_independent.Discrete
        The energy in the scale that was solved.
    out : dict
        As :func:`shor`; ``value_J`` added (the value in J).
    """
    if Discrete is None:
        from nonconvex_independent import Discrete
    out = None
    for scale in (1.0, 10.0, 0.1):
        en = Discrete(scene, W * scale)
        with warnings.catch_warnings():
            # CVXPY warns of an inaccurate solve; it is reported in the status
            warnings.simplefilter("ignore", UserWarning)
            out = shor(en)
        if out["status"] == "optimal":
            break
    out["value_J"] = out["value"] * en.E0
    return en, out


def admissible(en, u) -> np.ndarray:
    """u shrunk towards w = 0 (admissible: every gap is >= 0) until every obstacle row holds.

    The relaxation's u satisfies the rows only to the solver's tolerance; an
    exactly admissible point has an energy that is a true upper bound of the
    discrete minimum.
    """
    R, r = en.constraints()
    if len(r) == 0:
        return np.asarray(u, float)
    t = 1.0
    Ru = R @ u
    for _ in range(80):
        if np.all(t * Ru - r >= 0):
            return t * u
        bad = t * Ru - r < 0
        # r <= 0 on every row: the row holds for t <= r / (R u) where R u < r <= 0
        t = min(t, float(np.min(r[bad] / Ru[bad]))) * (1.0 - 1e-15)
    raise ValueError("no admissible multiple of u (a gap below zero?)")
