"""A second certificate of global optimality: the Gao term's tangents (the canonical dual bound).

At every Gauss point ``q`` of the Gao rule the quartic is a square of the
squared slope ``y_q = s_q^2``, and a square lies above each of its tangents,
``y^2 >= 2 t y - t^2`` for every ``t``.  So for any ``t``

    Pi(u) >= L_t(u) = 1/2 u'M(t) u - f'u + F(u) - a/12 sum_q w_q t_q^2,
    M(t)  = K - p G + (a/3) B1' diag(w t) B1   (+ c N' W N for a bonded bed),

with ``F`` the unilateral foundation (convex).  When ``M(t)`` is positive
definite, ``L_t`` is convex, and its minimum, computed to a certified accuracy,
is a lower bound on the global minimum of ``Pi``.  Taken at a candidate's own
squared slopes, ``t = y(u*)``, the tangents touch: ``L_t(u*) = Pi(u*)`` and the
gradients agree, so a stationary ``u*`` is the minimiser of ``L_t``, and the
bound meets ``Pi(u*)``: ``u*`` is the global minimiser.  This is D. Y. Gao's
canonical duality (the "triality" criterion) in the discrete form.

It is a *sufficient* condition, independent of the buckling modes and of the
branch and bound: ``M(y*)`` is ``Pi``'s Hessian with the Gao term's curvature
taken a third, so it holds for a beam buckled into one dominant mode under a
transverse load (measured: one or two unstable modes, all four supports, at up
to 5 P_bar_h), and fails where several modes compete (P1 at 5 P_bar_h with
three; a bonded bed from two) or by symmetry (without load ``M(y*)`` is
singular: its null vector is the answer, whose mirror image is a minimiser
too).  Where it fails, :mod:`.minimum` runs the branch and bound as before.

The bound, for any ``x`` and ``r = grad L_t(x)``: ``L_t(u) >= L_t(x) + r'(u -
x) + 1/2 (u - x)'M (u - x)`` (``F`` convex), so ``min L_t >= L_t(x) - 1/2 r'M^-1
r >= L_t(x) - r'G^-1 r / (2 m)`` once ``M >= m G`` is proved (below), with
``L_t(x) = Pi(x) - a/12 sum w (y(x) - t)^2`` (the tangents' exact error,
evaluated as accurately as the energy itself).  Positive definiteness
with a margin ``m`` (``M - m G >= 0``) is proved by a Cholesky factorisation
of ``M - m G`` and its backward error (:func:`proved_margin`): a bound, not
an estimate, so it gives out on fine meshes (measured: at 512 to 1024
elements for a margin of 0.1, 256 for 0.005), where the branch and bound
serves.  Then every point whose energy is within the gap ``g`` of the minimum
lies within ``sqrt(2 g / m)`` (in the norm ``sqrt(u'G u)``) of the minimiser
of ``L_t``.

Examples
--------
nonconvex.md's P4 example, buckled under its load (one unstable mode):

>>> import numpy as np
>>> from gaocvx import DiscreteProblem, Scene, solve
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 16}})
>>> r = solve(scene, "global")
>>> r.extra["global"]["certificate"], r.extra["global"]["nodes"]
('dual bound', 0)
>>> dp = DiscreteProblem(scene, check_convexity=False)
>>> u = dp.from_physical(r.w, r.slope)
>>> bound = tangent_bound(dp, u)
>>> bool(0 <= dp.energy(u) - bound.lower <= 1e-10 * abs(dp.energy(u)))
True
>>> tangent_bound(dp, np.zeros(dp.n)) is None   # at w = 0, M = K - p G: indefinite
True
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..linalg import BandedCholesky, NotPositiveDefinite
from .bnb import BnBResult
from .polish import polish

__all__ = ["DualBound", "tangent_matrix", "tangent_bound", "proved_margin", "metric_floor",
           "shortcut", "UNIQUE_RADIUS"]

log = logging.getLogger(__name__)

# The dual bound certifies a unique minimiser when every point within its gap
# lies this close to the answer, relative to its size sqrt(u'G u) (measured on
# loaded beams, one or two modes, 16-1024 elements: 4e-5 at most).
UNIQUE_RADIUS = 1e-3
EPS = np.finfo(float).eps
# Eigenvalue estimates by a dense solve up to this many DOFs, shift-invert Lanczos beyond.
DENSE = 200
# Newton steps on L_t (convex; quadratic without a unilateral foundation: one step).
MAX_STEPS = 30


@dataclass(frozen=True)
class DualBound:
    """A certified lower bound on the global minimum (non-dimensional energies).

    ``lower`` bounds ``min Pi`` from below; ``x`` minimises ``L_t`` (to the
    accuracy that ``lower`` accounts for); ``margin`` is a verified lower bound
    on the smallest eigenvalue of ``(M(t), G)``.
    """

    lower: float
    x: np.ndarray
    margin: float

    def radius(self, upper: float) -> float:
        """Every ``u`` with ``Pi(u) <= upper`` lies within this G-norm distance of ``x``.

        Such a ``u`` has ``L_t(u) <= upper``, and ``L_t`` grows at least like
        ``margin / 2`` times the squared distance from its minimiser, which
        lies within the same distance of ``x`` (``L_t(x) <= upper`` too).
        """
        return 2.0 * math.sqrt(2.0 * max(upper - self.lower, 0.0) / self.margin)


def tangent_matrix(dp, t, magnitude: bool = False) -> sp.csr_matrix:
    """``M(t)``: the quadratic part of ``L_t`` (with a bonded bed's stiffness).

    With ``magnitude``, the same sums of absolute values (``|K| + |B1|' diag(w
    |a t/3 - p|) |B1|``, ...): what the round-off of assembling ``M`` is relative to.
    """
    f = abs if magnitude else (lambda X: X)
    sigma = dp.wq_gao * (dp.a / 3.0 * np.asarray(t) - dp.p)
    M = f(dp.K) + f(dp.B1T) @ sp.diags(f(sigma)) @ f(dp.B1)
    if dp.contact == "foundation" and dp.bilateral:
        M = M + f(dp.NqT) @ sp.diags(np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape)) @ f(dp.Nq)
    return M.tocsr()


def _tangent_error(dp, u, t):
    """``Pi(u) - L_t(u) = a/12 sum w (y - t)^2`` and its gradient."""
    s = dp.B1 @ u
    d = s * s - t
    return dp.a / 12.0 * float(dp.wq_gao @ (d * d)), (dp.a / 3.0) * (dp.B1T @ (dp.wq_gao * d * s))


def _hessian(dp, M, u):
    """``L_t``'s (generalised) Hessian: ``M`` plus the unilateral foundation's active part."""
    if dp.contact != "foundation" or dp.bilateral:
        return M
    active = ((dp.g - dp.Nq @ u) > 0).astype(float)
    return (M + dp.NqT @ sp.diags(dp.c * dp.wq_c * active) @ dp.Nq).tocsr()


def _smallest(M, G) -> float | None:
    """An estimate of the smallest eigenvalue of ``(M, G)`` (``M`` positive definite).

    Only a trial value: :func:`proved_margin` proves or refuses it.
    """
    from scipy.sparse.linalg import ArpackError, eigsh
    try:
        if M.shape[0] <= DENSE:
            val = sla.eigh(M.toarray(), G.toarray(), eigvals_only=True, subset_by_index=[0, 0])
        else:
            val = eigsh(M.tocsc(), k=1, M=G.tocsc(), sigma=0.0, which="LM",
                        return_eigenvectors=False)
    except (ArpackError, RuntimeError, ValueError, TypeError, np.linalg.LinAlgError):
        return None
    return float(val[0]) if np.isfinite(val[0]) else None


def _gamma(n: int) -> float:
    """Higham's ``gamma_n = n eps / (1 - n eps)``."""
    return n * EPS / (1.0 - n * EPS)


def _factor_error(A, S) -> float | None:
    """A bound on ``||S E S||_2`` where ``A + E = R'R`` exactly, ``R`` the computed banded
    Cholesky factor of ``A`` (None: the factorisation breaks down).

    Higham, *Accuracy and Stability of Numerical Algorithms* (2002), theorem 10.3:
    ``|E| <= gamma_{b+1} |R'||R|`` entrywise (``b`` the bandwidth: the length of
    every inner product); the symmetric ``S |R'||R| S`` has its 2-norm below its
    largest row sum (doubled for the round-off of forming it).
    """
    try:
        chol = BandedCholesky(A)
    except NotPositiveDefinite:
        return None
    R = abs(chol.factor())
    return 2.0 * _gamma(chol.u + 1) * _row_norm(R.T @ R, S)


def _row_norm(A, S) -> float:
    """The largest row sum of ``S |A| S``: a bound on its 2-norm (``A`` symmetric)."""
    return float(np.max(np.asarray(abs(S @ A @ S).sum(axis=1)), initial=0.0))


def metric_floor(G, S) -> float:
    """A proved lower bound on the smallest eigenvalue of ``S G S`` (0: none)."""
    Gs = (S @ G @ S).tocsr()
    eye = sp.identity(G.shape[0], format="csr")
    estimate = _smallest(Gs, eye)
    if estimate is None or not estimate > 0:
        return 0.0
    g = 0.5 * estimate
    err = _factor_error(Gs - g * eye, eye)
    if err is None:
        return 0.0
    # (forming S G S - g I: three roundings an entry)
    return max(g - err - _gamma(4) * (_row_norm(G, S) + g), 0.0)


def proved_margin(dp, M, t, m: float, S, floor: float) -> float:
    """A proved lower bound on the smallest eigenvalue of ``(M(t), G)`` in exact arithmetic,
    from a Cholesky factorisation of ``M - m G`` (``-inf``: none).

    ``M - m G`` as computed plus the factor's backward error ``E`` is
    ``R'R >= 0``; the computed matrix differs from the exact one by the round-off
    of assembling it, at most ``gamma_16`` of its magnitudes (sums of at most ten
    products of three factors, then two additions), which also covers the
    difference between ``K`` and the curvature form the energy is evaluated by.  So
    the exact ``M - m G >= -(e_1 + e_2) S^-2 >= -(e_1 + e_2) / floor G``, with
    ``floor`` a proved lower bound of the smallest eigenvalue of ``S G S``.
    """
    if not floor > 0:
        return -math.inf
    A = (M - m * dp.G).tocsr()
    e1 = _factor_error(A, S)
    if e1 is None:
        return -math.inf
    e2 = _gamma(16) * (_row_norm(tangent_matrix(dp, t, magnitude=True), S)
                       + abs(m) * _row_norm(dp.G, S))
    return m - (e1 + e2) / floor


def tangent_bound(dp, u) -> DualBound | None:
    """The canonical dual bound with tangents at the squared slopes of ``u`` (no obstacle).

    Parameters
    ----------
    dp : DiscreteProblem
        A scene without an obstacle, in its own non-dimensional units.
    u : ndarray
        Free Hermite DOFs of the candidate (the tangents' points).

    Returns
    -------
    DualBound or None
        None when ``M(t)`` is not verified positive definite (the bound does
        not apply: no conclusion) or the minimisation of ``L_t`` fails.
    """
    if dp.contact == "obstacle" or dp.n == 0 or not dp.a > 0:
        return None
    u = np.asarray(u, float)
    t = (dp.B1 @ u) ** 2
    M = tangent_matrix(dp, t)
    try:
        chol = BandedCholesky(M)
    except NotPositiveDefinite:
        return None
    estimate = _smallest(M, dp.G)
    if estimate is None or not estimate > 0:
        return None
    # Proved at half the estimate, in the metric of G's diagonal (Jacobi).
    S = sp.diags(1.0 / np.sqrt(dp.G.diagonal()))
    margin = proved_margin(dp, M, t, 0.5 * estimate, S, metric_floor(dp.G, S))
    if not margin > 0:
        log.info("global: M(t) not proved positive definite (estimate %.3g, proved %.3g)",
                 estimate, margin)
        return None

    def phi(x):
        err, derr = _tangent_error(dp, x, t)
        return dp.energy(x) - err, dp.gradient(x) - derr

    x = u.copy()
    value, r = phi(x)
    for _ in range(MAX_STEPS):
        H = _hessian(dp, M, x)
        try:
            step = (chol if H is M else BandedCholesky(H)).solve(-r)
        except NotPositiveDefinite:   # (cannot be: H >= M > 0)
            return None
        trial = x + step
        v2, r2 = phi(trial)
        if not v2 <= value + 1e-15 * abs(value):
            break
        stalled = float(np.max(np.abs(step))) <= 1e-14 * max(float(np.max(np.abs(x))), 1e-300)
        x, value, r = trial, v2, r2
        if stalled:
            break
    # (M >= margin G is proved, its computed factor only approximate: the residual's
    # dual norm is taken in G, r'M^-1 r <= r'G^-1 r / margin.  L_t(x) is a sum over
    # the Gauss points, rounded to about N eps of its parts: that much lower, so that
    # the bound lies below the energy as the certificate evaluates it, in the mixed
    # form (a new-user trial found it 5e-15 of the energy above, a negative gap).)
    parts = dp.energy_size(x) + abs(value)
    lower = (value - 0.5 * float(r @ BandedCholesky(dp.G).solve(r)) / margin
             - 10.0 * (dp.n_nodes + 10) * EPS * parts)
    if not math.isfinite(lower):
        return None
    return DualBound(lower=float(lower), x=x, margin=float(margin))


def shortcut(dp, prog, start, lo, hi, tol: float):
    """The global minimiser certified by the dual bound alone, or None (then: branch and bound).

    The best first candidate ``start = (energy, u, s, lam)`` of
    :func:`.minimum.solve_global` is polished to a local minimiser, and the
    tangent bound taken at it.  Taken only when the gap is within ``tol`` and
    every global minimiser lies within :data:`UNIQUE_RADIUS` of the answer's
    size (a unique minimiser; mirror images and close competitors are left to
    the branch and bound, which finds them all).

    Returns
    -------
    tuple
        ``(result, start)``: a :class:`.bnb.BnBResult` with no nodes, or None;
        and the start for the branch and bound, the polished point where lower.
    """
    e0, u0, s0, lam0 = start
    if dp.contact == "obstacle" or not np.any(s0):
        return None, start
    s, u, lam = polish(dp, prog, s0, u0, lam0, lo, hi)
    e = dp.energy(u)
    if not e <= e0:
        return None, start
    better = (e, u, s, lam)
    bound = tangent_bound(dp, u)
    if bound is None:
        log.info("global: the dual bound does not apply (M(t) not proved positive definite)")
        return None, better
    size = math.sqrt(max(float(u @ (dp.G @ u)), 0.0))
    # every global minimiser (energy <= e) lies within this distance of the answer
    radius = bound.radius(e)
    if not (e - bound.lower <= tol and radius <= UNIQUE_RADIUS * size):
        log.info("global: dual bound gap %.3g (tolerance %.3g), radius %.3g of the size; "
                 "branch and bound", e - bound.lower, tol, radius / max(size, 1e-300))
        return None, better
    log.info("global: certified by the dual bound (gap %.3g, margin %.3g)", e - bound.lower,
             bound.margin)
    return BnBResult(upper=e, lower=bound.lower, u=u, s=s, lam=lam, nodes=0, leaves=[],
                     certificate="dual bound"), better
