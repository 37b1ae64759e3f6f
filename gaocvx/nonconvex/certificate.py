"""The local certificate of a global minimiser that an obstacle holds in place.

:func:`gaocvx.certificate.certify` measures the Newton decrement in the energy's
own Hessian, which is positive definite at every minimiser below ``P_bar_h``
and at a free buckled minimiser above it (the Gao term stiffens it).  A
buckled beam pressed onto an obstacle is different: the obstacle, not the
energy, stops it along the unstable modes, and the Hessian there has
negative curvature (measured: an infinite "decrement" for a minimiser whose
Hermite KKT residual was 1e-7).

The energy is ``-sum c_i s_i^2 + Psi(u)`` with ``Psi`` convex
(nonconvex.md), so the Hessian of ``Psi``,
``H + 2 sum c_i (G phi_i)(G phi_i)'``, is positive semidefinite everywhere.
Only semidefinite: at ``w = 0`` its curvature along ``phi_i`` is
``lambda_i - p + 2 c_i``, the eigenvectors' margin ``2 delta`` (about 1e-19 of
``c``), and a beam lying flat on an obstacle has ``w = 0`` (measured: a residual
of 1e-16 became a stationarity of 1e-4 of the answer's floor).  So the metric is
``H_psi = H + 4 sum c_i (G phi_i)(G phi_i)'``, the Hessian of
``Psi + sum c_i s_i^2``: positive definite with the margin
``min(p - lambda_k, lambda_{k+1} - p)`` at ``w = 0``, and within a factor of
about two of the convex part's along the modes at a buckled answer (where the
Gao term adds about ``4 c_i``).  The measures are the project's (stationarity
of the Lagrangian as a relative dual norm, feasibility, the multipliers' sign,
complementarity), with ``H_psi`` in place of ``H``.  The global gap is
certified separately, by branch and bound.

Examples
--------
>>> import numpy as np, scipy.sparse as sp
>>> from types import SimpleNamespace
>>> dp = SimpleNamespace(gradient=lambda u: 2 * u - 1, hessian=lambda u: sp.eye(1) * 2.0,
...                      G=sp.eye(1), g=-1.0)
>>> modes = SimpleNamespace(phi=np.ones((1, 1)), c=np.array([0.0]))
>>> out = psi_certificate(dp, modes, np.array([0.5]), None, None)
>>> out["stationarity"] < 1e-15
True
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as la
import scipy.optimize as so

from ..certificate import certify
from ..tolerances import TOUCH_TOL, complementarity

__all__ = ["psi_certificate", "contact_multipliers", "certify_contact", "certify_answer",
           "certify_flat", "modes_size", "beam_size"]


def psi_certificate(dp, modes, u, lam, rows, levels=None, floor: float = 0.0) -> dict:
    """Optimality measures of free Hermite DOFs ``u`` in the metric of the convex part ``Psi``.

    Parameters
    ----------
    dp : DiscreteProblem
    modes : Modes
    u : ndarray
        Free Hermite DOFs of the answer.
    lam : ndarray or None
        Obstacle multipliers (rows of ``rows``).
    rows : sparse matrix or None
        The obstacle's constraint rows on the free DOFs.
    levels : ndarray, optional
        The obstacle's level at each row.
    floor : float
        The least size an answer is measured against (non-dimensional, as
        :attr:`gaocvx.mixed.MixedForm.zero_floor`): a beam lying flat on an
        obstacle has an answer that is zero to round-off, and relative measures
        of it would compare round-off with round-off.

    Returns
    -------
    dict
        ``stationarity`` (relative to the answer's norm in ``H_psi``) and, with
        an obstacle, ``feasibility``, ``dual``, ``complementarity`` as in
        :func:`gaocvx.certificate.certify`.
    """
    r = dp.gradient(u)
    if lam is not None:
        r = r - rows.T @ lam
    L = _psi_factor(dp, modes, u)  # (a bonded foundation's c M included)
    if L is None:
        return {"stationarity": math.inf}
    Lu = L.T @ u
    scale = max(math.sqrt(max(float(Lu @ Lu), 0.0)), floor) or 1.0
    y = la.solve_triangular(L, r, lower=True)
    out = {"stationarity": math.sqrt(max(float(y @ y), 0.0)) / scale}
    if lam is not None:
        gap = rows @ u - levels
        size = _size(dp, u, floor, rows)
        lam_scale = float(np.max(np.abs(lam), initial=0.0)) or 1.0
        out.update(feasibility=float(max(-np.min(gap, initial=0.0), 0.0) / size),
                   dual=float(max(-np.min(lam, initial=0.0), 0.0) / lam_scale),
                   complementarity=complementarity(lam, gap, scale, size))
    return out


def beam_size(dp, u, rows) -> float:
    """The beam's largest |w| at the nodes and at the obstacle rows' points (``rows``:
    :func:`.node.obstacle_rows`, whose rows are ``±w`` at points; 0 for the flat beam).

    (The rows' points too: a beam resting on the obstacle but lifted 1.1e-12 m
    within its first element, its nodes at 1e-28 m, was measured against its
    round-off at the nodes -- P4 near P_bar_h under an upward load at one end.)
    """
    return max(float(np.max(np.abs(u[dp._w_rows()]), initial=0.0)),
               float(np.max(np.abs(rows @ u), initial=0.0)))


def _size(dp, u, floor, rows):
    """:func:`beam_size`, at least ``floor``."""
    return max(beam_size(dp, u, rows), floor, 1e-300)


def _psi_factor(dp, modes, u):
    """Cholesky factor of ``H_psi`` at ``u`` (None where it is not positive definite)."""
    GPhi = np.asarray(dp.G @ modes.phi)
    H = dp.hessian(u)
    H = H.toarray() if hasattr(H, "toarray") else np.asarray(H)
    # 4 c, not 2 c: the convex part's own Hessian is singular along the modes at
    # w = 0 (the module's notes)
    H = H + 4.0 * (GPhi * modes.c) @ GPhi.T
    try:
        return la.cholesky(0.5 * (H + H.T), lower=True)
    except la.LinAlgError:
        return None


def contact_multipliers(dp, modes, u, rows, levels, floor: float = 0.0) -> list:
    """Obstacle multipliers of ``u`` recomputed on the rows it actually touches.

    A row whose gap exceeds ``TOUCH_TOL`` of the answer's size carries no force
    (complementarity); on the touching rows, non-negative multipliers that
    minimise the stationarity residual (non-negative least squares).  An
    interior-point solver leaves its multipliers on rows far from the obstacle
    at its own tolerance instead (measured: 1e-9 of nothing on a channel's
    ceiling 0.08 m away, a complementarity residual of 6.8e-12 against the
    certificate's 1e-12), although the point meets the optimality conditions.

    Returns
    -------
    list of ndarray
        Two candidates, one multiplier per row (zero off contact): the residual
        minimised in the certificate's own metric ``r' H_psi^-1 r`` (after the
        Cholesky factor), and in the Euclidean norm.  The second is far better
        conditioned (measured on a beam lying flat on 8 elements: the metric
        problem's condition number 2e9 left a residual 3e-4 of the answer's
        floor; the Euclidean one is exact to round-off when the touching rows
        can balance the load).
    """
    gap = rows @ u - levels
    act = np.flatnonzero(gap <= TOUCH_TOL * _size(dp, u, floor, rows))
    if len(act) == 0:
        return [np.zeros(rows.shape[0])]
    g = dp.gradient(u)
    At = rows[act].toarray().T
    systems = [(At, g)]
    L = _psi_factor(dp, modes, u)
    if L is not None:
        systems.insert(0, (la.solve_triangular(L, At, lower=True),
                           la.solve_triangular(L, g, lower=True)))
    out = []
    for M, b in systems:
        lam = np.zeros(rows.shape[0])
        try:
            lam[act] = so.nnls(M, b, maxiter=50 * len(act))[0]
        except RuntimeError:  # no convergence within maxiter: no candidate
            continue
        out.append(lam)
    return out


def certify_contact(dp, modes, u, lam, rows, levels, floor: float = 0.0) -> tuple:
    """The certificate of :func:`psi_certificate` with the best of several sets of multipliers.

    The optimality conditions hold when *some* multipliers satisfy them: those
    of the solver (``lam``) and those recomputed on the touching rows
    (:func:`contact_multipliers`) are all tried, each checked in full, and the
    measures of the first that passes (the recomputed ones first) are returned.

    Returns
    -------
    residual : dict
    lam : ndarray or None
        The multipliers the measures belong to.
    """
    from ..certificate import passes

    tried = []
    for cand in contact_multipliers(dp, modes, u, rows, levels, floor) + [lam]:
        if cand is None:
            continue
        res = psi_certificate(dp, modes, u, cand, rows, levels, floor)
        if passes(res):
            return res, cand
        tried.append((res, cand))
    return tried[-1] if tried else ({"stationarity": math.inf}, lam)


def certify_flat(dp, modes, rows, levels, floor: float = 0.0):
    """The certificate of the flat beam ``w = 0``: ``(residual, lam)`` of
    :func:`certify_contact` (multipliers recomputed on the touching rows), or None
    where ``w = 0`` violates a row (a gap below 0) or fails the certificate."""
    from ..certificate import passes

    u0 = np.zeros(rows.shape[1])
    if np.any(rows @ u0 < levels):
        return None
    residual, lam = certify_contact(dp, modes, u0, None, rows, levels, floor)
    return (residual, lam) if passes(residual) else None


def certify_answer(dp, prog, mf, z, lam) -> tuple:
    """Residuals and multipliers of the global method's answer ``z`` (mixed variables of ``mf``).

    Without an obstacle, :func:`gaocvx.certificate.certify`.  An obstacle may
    hold the beam against its unstable modes, where the energy's Hessian is
    indefinite: measured in the convex part's metric.  The multipliers are
    recomputed on the touching rows too (an interior-point solver leaves its
    tolerance on rows far from the obstacle): either set that meets every
    condition certifies the answer.  ``prog`` is the node program (the fast
    path's has a ``certify`` of its own, the same measures in the mixed form).
    """
    if dp.contact != "obstacle":
        return certify(mf, z, lam, size=modes_size(mf, prog.modes, z)), lam
    zfloor = mf.size_floor
    if hasattr(prog, "certify"):
        return prog.certify(z, mf.no_contact_forces() if lam is None else lam, zfloor)
    return certify_contact(dp, prog.modes, mf.to_hermite(z), lam, prog.rows, prog.levels, zfloor)


def modes_size(mf, modes, z) -> float:
    """The answer's size with the modes' part of :func:`psi_certificate`'s metric:
    ``sqrt(|z|^2 + 4 sum c_i s_i^2)``, ``|z|`` the energy's own norm.

    Above ``P_bar_h`` the energy's own norm (:meth:`gaocvx.mixed.MixedForm.energy_norm`)
    is no size: its bending and axial terms are indefinite, and where a bed (not
    the Gao term) holds the beam against its buckling, and counts only on its
    penetration, it is negative (measured just above the limit on a stiff bed:
    bending minus axial -1.0e-4, Gao 4.2e-6, the bed 1.5e-6).  The certificate
    then fell back on the zero floor and measured a Newton step of round-off
    against it.  ``4 sum c_i s_i^2`` (the modes' part of ``H_psi``, with ``s_i``
    the amplitudes ``(G phi_i)' u``) makes it the size of the convex part's
    metric, as with an obstacle.
    """
    H = mf.hessian(z)
    s = np.asarray(mf.dp.G @ modes.phi).T @ mf.to_hermite(z)
    norm2 = mf.energy_norm2(z, H) + 4.0 * float(np.sum(modes.c * s * s))
    return math.sqrt(max(norm2, 0.0))


def contact_polish(dp, u, lam, rows, levels, max_iter: int = 12):
    """Newton on the energy with the obstacle's touching rows as equalities.

    A node program's answer meets the optimality conditions only to its solver's
    tolerance (measured: stationarity 1e-4, complementarity 1e-9 in the metric of
    :func:`psi_certificate` for a buckled beam pressed onto an obstacle).  With
    the active set taken from it (rows that touch or carry a force), Newton's
    method on ``min Pi(u)`` subject to ``rows_act u = g`` converges
    quadratically; the KKT systems are solved in the least-squares sense, as
    touching rows of a flat contact are dependent.  The polished point is kept
    only if it stays feasible, its multipliers stay non-negative and its
    energy does not rise beyond round-off.

    Returns
    -------
    u, lam : ndarray
    """
    gap = rows @ u - levels
    size = max(float(np.max(np.abs(u[dp._w_rows()]), initial=0.0)),
               float(np.max(np.abs(levels))), 1e-300)
    # Touching as in the certificate (TOUCH_TOL), or carrying a force that is not
    # the solver's round-off (interior-point multipliers of rows 6e-6 off the
    # obstacle were 1e-9 of the largest, and as equalities made the rows inconsistent).
    act = np.flatnonzero((gap <= 1e-9 * size) | (lam > 1e-6 * max(float(np.max(lam)), 1e-300)))
    if len(act) == 0:
        return u, lam
    A = rows[act].toarray()
    n, m = len(u), len(act)
    x = u.copy()
    mult = lam[act].copy()
    e0 = dp.energy(u)
    for _ in range(max_iter):
        g = dp.gradient(x)
        H = dp.hessian(x).toarray()
        kkt = np.block([[H, -A.T], [A, np.zeros((m, m))]])
        rhs = np.r_[-(g - A.T @ mult), -(A @ x - levels[act])]
        step = la.lstsq(kkt, rhs, cond=1e-14)[0]
        x = x + step[:n]
        mult = mult + step[n:]
        if np.linalg.norm(step[:n]) <= 1e-15 * max(np.linalg.norm(x), 1e-300):
            break
    new_gap = rows @ x - levels
    if (np.all(np.isfinite(x)) and np.min(new_gap) >= -1e-12 * size and np.min(mult) >= 0
            and dp.energy(x) <= e0 + 1e-12 * max(abs(e0), 1.0)):
        out = np.zeros_like(lam)
        out[act] = mult
        return x, out
    return u, lam
