"""Minimisers of CVM's reduced cost ``I(u) = J(w(u), u)`` over the box ``|u| <= C``.

The transforms of :mod:`gaocvx.cvm` provide the state map ``u -> U0 + S u``
(one banded state solve), its transpose (one adjoint solve), the cost, its
adjoint gradient and :meth:`bending_preconditioner`.  Two minimisers use them:

* :func:`projected_newton` (default): Bertsekas's projected Newton method,
  matrix-free.  The reduced Hessian ``S' H S`` is never formed: a product
  ``S' H S v`` costs one state solve, one banded product with the state
  Hessian H and one adjoint solve.  The Newton system on the free controls is
  solved by conjugate gradients preconditioned with the inverse of the
  *bending* part ``S' K S`` of the reduced Hessian (one sparse factorisation
  per free set, :mod:`gaocvx.cvm.algebra`).  The reduced Hessian inherits the
  N^4 conditioning of the state equation, but the preconditioned operator's
  eigenvalues are generalised Rayleigh quotients ``v'Hv / v'Kv`` of the
  beam's own Hessian against its bending matrix, which do not grow with N.
* :func:`conditional_gradient`: the thesis's method.
* :func:`accelerated_gradient`: FISTA (accelerated projected gradient), a
  first-order comparison for the conditional gradient (benchmarks only).

Every vector here has O(N) entries; no N x N array is allocated.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from ..newton import line_search

__all__ = ["projected_newton", "conditional_gradient", "accelerated_gradient", "pcg"]

log = logging.getLogger(__name__)

# Conjugate gradients stop at this many iterations per Newton step; with the
# bending preconditioner they need 5-60 (the preconditioned condition number
# is that of the beam's Hessian against its bending matrix, independent of N).
CG_MAX_ITER = 500


def pcg(apply_A, b, apply_P, rtol, max_iter=CG_MAX_ITER):
    """Preconditioned conjugate gradients for ``A x = b`` from ``x = 0``.

    Parameters
    ----------
    apply_A, apply_P : callable
        Products with the SPD matrix A and with the SPD preconditioner P ~ A^-1.
    b : ndarray
    rtol : float
        Stop when the residual's P-norm falls below ``rtol`` times that of b.
    max_iter : int

    Returns
    -------
    x : ndarray
        The last iterate.  Every iterate from 0 satisfies ``b'x = x'Ax > 0``,
        so ``-x`` solving ``A x = -g`` is a descent direction even when CG
        stops early.
    iterations : int
    converged : bool
        False at the iteration limit or where round-off made ``p'Ap <= 0``.
    """
    x = np.zeros_like(b)
    r = b.copy()
    z = apply_P(r)
    rz = float(r @ z)
    if rz <= 0.0:
        return x, 0, rz == 0.0
    stop = rtol * math.sqrt(rz)
    p = z
    for k in range(1, max_iter + 1):
        Ap = apply_A(p)
        pAp = float(p @ Ap)
        if not pAp > 0.0:  # the operator is SPD: only round-off can get here
            return x, k - 1, False
        alpha = rz / pAp
        x = x + alpha * p
        r = r - alpha * Ap
        z = apply_P(r)
        rz_new = float(r @ z)
        if math.sqrt(max(rz_new, 0.0)) <= stop:
            return x, k, True
        p = z + (rz_new / rz) * p
        rz = rz_new
    return x, max_iter, False


def _bounds(C, bounded):
    lo = np.where(bounded, -C, -np.inf)
    hi = np.where(bounded, C, np.inf)
    return lo, hi


def _held(u, g, lo, hi, C):
    """Controls held at their bound: within eps of it, with the gradient pushing outwards.

    eps follows Bertsekas: the distance to the projected-gradient point, at
    most 1e-8 of C, so the held set settles as u converges.
    """
    eps = min(1e-8 * C, float(np.linalg.norm(u - np.clip(u - g, lo, hi))))
    at_lo = (u <= lo + eps) & (g > 0)
    at_hi = (u >= hi - eps) & (g < 0)
    return at_lo | at_hi, np.where(at_lo, lo, hi)


def projected_newton(tr, u, C, bounded, tol, max_iter):
    """Matrix-free projected Newton on the box ``|u| <= C``.

    Each iteration: the state, the adjoint gradient g, the held set (controls
    at a bound that the gradient pushes outwards), the bending preconditioner
    of the free set (one sparse factorisation), the Newton system on the free
    controls by preconditioned CG, and a line search on the segment to the
    projected Newton point.

    The optimality test bounds the decrement instead of estimating it.  With
    ``P_F`` the preconditioner of the free set F and ``theta`` a proved lower
    bound of ``v'Hv / v'Kv`` (``1 - P / P_bar_h``, the lower end of its
    enclosure), ``S_F'HS_F >= theta S_F'KS_F`` gives

        g_F' (S_F'HS_F)^-1 g_F  <=  g_F' P_F g_F / theta,

    an upper bound (in exact arithmetic) of the squared reduced Newton
    decrement that does not depend on how well CG converged.  The measure is
    ``sqrt(that / |J|)``; it must be <= ``tol``, and the complementarity
    ``sum_held g_i (u_i - bound_i)`` (>= 0; the first-order decrease left by
    not moving the held controls onto their bounds) <= ``tol**2 |J|``, both in
    the reduced problem's own scale.
    The measure reaches ``tol`` = 1e-10 up to 16384 elements because
    nothing in it is computed from a difference of large numbers: the state
    solves of T1 run in the mixed variables, and the gradient is
    ``S'(B u + grad N(U))`` (T1), never ``K U - f`` or a difference of states.

    Returns
    -------
    u, iterations, ok, measure, note, stats
        ``stats`` counts CG iterations and products with the reduced Hessian.
    """
    lo, hi = _bounds(C, bounded)
    theta = tr.curvature_floor()
    measure = math.inf
    stats = {"cg_iterations": 0, "hessian_products": 0, "cg_unconverged": 0}
    pre, pre_free = None, None
    for it in range(1, max_iter + 1):
        U = tr.state(u)
        g = tr.gradient(u, U)
        cost0 = tr.cost(u, U)
        scale = abs(cost0) or 1.0
        held, bound_of = _held(u, g, lo, hi, C)
        free = ~held
        if pre is None or not np.array_equal(free, pre_free):
            pre, pre_free = tr.bending_preconditioner(free), free.copy()
        gf = g[free]
        Pg = pre(gf)
        measure = math.sqrt(max(float(gf @ Pg), 0.0) / theta / scale)
        compl = float(np.sum(g[held] * (u[held] - bound_of[held]))) / scale
        if measure <= tol and compl <= tol**2:
            return u, it - 1, True, measure, None, stats
        H = tr.state_hessian(U)
        idx = np.flatnonzero(free)

        def apply_A(v):
            full = np.zeros_like(u)
            full[idx] = v
            stats["hessian_products"] += 1
            return tr.hessian_vector(H, full)[idx]

        # Forcing term: a loose solve far away, an accurate one near the
        # optimum (superlinear convergence; Eisenstat-Walker style).
        rtol = min(0.1, max(measure, 1e-12))
        df, ncg, conv = pcg(apply_A, -gf, pre, rtol)
        stats["cg_iterations"] += ncg
        stats["cg_unconverged"] += not conv
        # The segment to the projected Newton point; where the projection spoils
        # descent (a Hessian far from diagonal), Bertsekas's arc: shorter Newton
        # steps, projected, until the segment descends (it does for small ones).
        for _ in range(40):
            trial = u.copy()
            trial[idx] = np.clip(u[idx] + df, lo[idx], hi[idx])
            trial[held] = bound_of[held]
            step = trial - u
            slope0 = float(g @ step)
            if slope0 < 0.0:
                break
            df = 0.5 * df
        else:
            return u, it, False, measure, ("no descent along the projected Newton arc "
                                           "(round-off)"), stats
        # The reduced cost is convex along the segment: its derivative, from the
        # adjoint gradient, locates the step without comparing costs (which lose
        # ~N^2 eps on fine meshes).  Always searched: a full step across a kink of
        # the foundation's force can cycle at a decrement of 1e-6.
        t = line_search(lambda s: float(tr.gradient(u + s * step) @ step), slope0,
                        rtol=0.1, max_eval=40)
        if t is None:
            return u, it, False, measure, "the projected line search failed", stats
        # The full step lands exactly on the bounds (u + (trial - u) may miss them by round-off).
        u = trial if t == 1.0 else u + t * step
        log.debug("projected newton %d: measure %.2e, %d CG iterations (%s), step %.3g, "
                  "%d held", it, measure, ncg, "converged" if conv else "not converged", t,
                  held.sum())
    U = tr.state(u)
    g = tr.gradient(u, U)
    held, bound_of = _held(u, g, lo, hi, C)
    free = ~held
    scale = abs(tr.cost(u, U)) or 1.0
    gf = g[free]
    measure = math.sqrt(max(float(gf @ tr.bending_preconditioner(free)(gf)), 0.0)
                        / theta / scale)
    compl = float(np.sum(g[held] * (u[held] - bound_of[held]))) / scale
    return u, max_iter, measure <= tol and compl <= tol**2, measure, None, stats


def _box_gap(u, g, C, bounded):
    """Frank-Wolfe gap g'(u - s), s the box vertex minimising g's (>= I(u) - I*)."""
    s = np.where(bounded, -C * np.sign(g), u)
    return float(g @ (u - s)), s


def conditional_gradient(tr, u, C, bounded, tol, max_iter):
    """The thesis's conditional gradient method, with an exact line search.

    Stops when the Frank-Wolfe gap ``g'(u - s)``, an upper bound of
    ``I(u) - min I``, falls below ``tol * |I(u)|``.  The gap scales with C,
    so a generous bound makes this test strict (and the method slow).

    Returns
    -------
    u, iterations, ok, measure, note, stats
        ``stats["gaps"]`` is the relative Frank-Wolfe gap of every iteration
        (its rate is measured in docs/cvm.md).
    """
    dp = tr.dp
    U = tr.state(u)
    scale = max(abs(tr.cost(u, U)), 1e-300)
    gaps = []
    stats = {"gaps": gaps}
    for it in range(1, max_iter + 1):
        g = tr.gradient(u, U)
        gap, s = _box_gap(u, g, C, bounded)
        gaps.append(gap / scale)
        if gap <= tol * scale:
            return u, it - 1, True, gap / scale, None, stats
        d = s - u
        # J = Pi(U(u)) + const with U affine: search along U + gamma S d,
        # phi'(gamma) = grad Pi(U + gamma Sd)' Sd, without further state solves.
        Sd = tr.apply_S(d)
        gamma = line_search(lambda t: float(dp.gradient(U + t * Sd) @ Sd), float(g @ d),
                            rtol=1e-8, max_eval=40)
        if gamma is None:  # no decrease along the vertex direction at this precision
            break
        u = u + gamma * d
        U = U + gamma * Sd
    gap, _ = _box_gap(u, tr.gradient(u, U), C, bounded)
    return u, it, gap <= tol * scale, gap / scale, None, stats


def accelerated_gradient(tr, u, C, bounded, tol, max_iter):
    """FISTA (Beck and Teboulle's accelerated projected gradient) on the box.

    A first-order comparison for the thesis's conditional gradient, with the
    same stopping test (the Frank-Wolfe gap <= ``tol * |I(u)|``).  Steps
    ``1/L`` in the controls' Euclidean metric, with L from a few power
    iterations on the reduced Hessian and doubled whenever the step's
    sufficient-decrease test fails (the Gao term stiffens).  Its rate is set
    by the condition number of ``S'HS`` (~N^4 for T1), which the benchmark
    measures (docs/cvm.md).

    Returns
    -------
    u, iterations, ok, measure, note, stats
    """
    lo, hi = _bounds(C, bounded)
    rng = np.random.default_rng(0)
    Hn = tr.state_hessian(tr.state(u))
    v = rng.standard_normal(tr.m)
    L = 0.0
    for _ in range(20):
        Av = tr.hessian_vector(Hn, v / np.linalg.norm(v))
        L, v = float(np.linalg.norm(Av)), Av
    L = max(L, 1e-300)
    x, y, t = u.copy(), u.copy(), 1.0
    scale = max(abs(tr.cost(u)), 1e-300)
    gaps = []
    stats = {"gaps": gaps}
    for it in range(1, max_iter + 1):
        gx = tr.gradient(x)
        gap, _ = _box_gap(x, gx, C, bounded)
        gaps.append(gap / scale)
        if gap <= tol * scale:
            return x, it - 1, True, gap / scale, None, stats
        gy, Iy = tr.gradient(y), tr.cost(y)
        for _ in range(60):
            xn = np.clip(y - gy / L, lo, hi)
            d = xn - y
            # Sufficient decrease of the quadratic upper model, with a round-off allowance.
            if tr.cost(xn) <= Iy + float(gy @ d) + 0.5 * L * float(d @ d) + 1e-15 * abs(Iy):
                break
            L *= 2.0
        tn = 0.5 * (1.0 + math.sqrt(1.0 + 4.0 * t * t))
        y = xn + ((t - 1.0) / tn) * (xn - x)
        x, t = xn, tn
    gap, _ = _box_gap(x, tr.gradient(x), C, bounded)
    return x, max_iter, gap <= tol * scale, gap / scale, None, stats
