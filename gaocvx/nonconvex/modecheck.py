"""Checks of computed buckling modes: eigenvalue counts and the concave coefficients' margin.

The node problems rest on one property of the modes ``Phi`` (G-orthonormal,
``Phi' K Phi = diag(lambda)`` by Rayleigh-Ritz): with
``c_i >= (p - lambda_i) / 2`` the function

    Psi(u) = Pi(u) + sum_i c_i (phi_i' G u)^2

is convex, i.e. ``K - p G + 2 G Phi diag(c) Phi' G`` is positive
semidefinite (the Gao and contact terms are convex).  With exact eigenvectors
``c_i = (p - lambda_i) / 2`` makes it so exactly.  Computed ones leave a
residual ``R = K Phi - G Phi diag(lambda)``; for ``u = Phi s + v``,
``Phi' G v = 0``, the form is ``s'(2 diag(c) - (p - lambda)) s + 2 s'R'v +
v'(K - p G) v``, and ``v'(K - p G) v >= gamma v'K v`` on the complement with
``gamma ~ 1 - p / lambda_{k+1}``.  It stays semidefinite when each ``c_i``
exceeds ``(p - lambda_i) / 2`` by ``delta = lambda_max(R'K^-1 R) / gamma``
(:func:`concave_margin`; ``gamma`` is taken as half its estimate from the
computed ``lambda_{k+1}``).  The residual's ``K^-1`` norm is computed with a
banded Cholesky factor of K.

A sparse eigen-solve may also miss an eigenvalue.  Sylvester's law of
inertia counts them: the number of negative pivots of an ``LDL'``
factorisation of ``K - sigma G`` is the number of eigenvalues below
``sigma`` (:func:`count_below`; the classical Sturm count of structural
mechanics, unpivoted on the band; a pivot too small to trust its sign gives
no count).

Examples
--------
>>> import scipy.sparse as sp
>>> K = sp.diags([[-1.0] * 4, [2.0] * 5, [-1.0] * 4], [-1, 0, 1]).tocsr()
>>> G = sp.identity(5, format="csr")
>>> count_below(K, G, 1.5), count_below(K, G, 5.0)   # eigenvalues 2 - 2cos(j pi/6)
(2, 5)
>>> count_below(K, G, 1.0) is None          # sigma = 1 is one: no sign to count
True
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from ..linalg import BandedCholesky, NotPositiveDefinite, bandwidth

__all__ = ["count_below", "concave_margin", "margin_of", "residual_gram", "inverse_iteration",
           "ritz", "accurate_ritz"]

# A pivot smaller than this (relative to its row's diagonal entries) has no
# trustworthy sign: no count is given then.
PIVOT_TOL = 1e-13


def count_below(K, G, sigma: float) -> int | None:
    """The number of eigenvalues of the pencil ``(K, G)`` below ``sigma`` (None: undecided).

    Unpivoted ``LDL'`` of the banded ``K - sigma G`` (Sylvester's law of
    inertia); ``G`` must be positive definite.
    """
    A = sp.csr_matrix(K - sigma * G)
    n = A.shape[0]
    b = max(bandwidth(A), 0)
    dense_rows = A.tolil()
    # Band storage: W[j, t] = A[j, j - b + t] for t = 0..b (lower band with diagonal).
    W = np.zeros((n, b + 1))
    scale = np.zeros(n)
    for j, (cols, vals) in enumerate(zip(dense_rows.rows, dense_rows.data)):
        for c, v in zip(cols, vals):
            if j - b <= c <= j:
                W[j, c - j + b] = v
        scale[j] = abs(W[j, b])
    L = np.zeros((n, b + 1))   # L[j, t] = l_{j, j - b + t}
    d = np.zeros(n)
    negative = 0
    for j in range(n):
        lo = max(0, j - b)
        for i in range(lo, j):
            # l_ji d_i = a_ji - sum_{m < i} l_jm l_im d_m
            acc = W[j, i - j + b]
            for m in range(max(lo, i - b), i):
                acc -= L[j, m - j + b] * L[i, m - i + b] * d[m]
            L[j, i - j + b] = acc / d[i]
        acc = W[j, b]
        for m in range(lo, j):
            acc -= L[j, m - j + b] ** 2 * d[m]
        if not math.isfinite(acc) or abs(acc) <= PIVOT_TOL * max(scale[j], 1e-300):
            return None
        d[j] = acc
        negative += acc < 0
    return int(negative)


def ritz(K, G, V) -> tuple[np.ndarray, np.ndarray]:
    """Rayleigh-Ritz on the columns of ``V``: G-orthonormal ``Phi`` with ``Phi'K Phi`` diagonal."""
    Kr = V.T @ (K @ V)
    Gr = V.T @ (G @ V)
    vals, Y = la.eigh(0.5 * (Kr + Kr.T), 0.5 * (Gr + Gr.T))
    return vals, V @ Y


def _slope_rows(mf):
    """The structure holding the slope rows ``B1`` (5-point Gauss) of ``mf``'s mesh.

    ``G`` is the form of the axial term, ``∫ (w')^2``, and the pencil needs it
    whatever the energy holds.  A mesh's structure is built for the energy
    (:func:`gaocvx.mixed.structure_key`): without the Gao term and at P = 0
    (an Euler-Bernoulli beam, or ``E_alpha = 0``, probed for its modes at P = 0
    by :func:`.path.characteristic_point`) it has no slope rows.  Then the same
    mesh's structure with them: the mixed variables are the same.
    """
    if mf.has_slope:
        return mf.structure
    from ..mixed import structure_of

    return structure_of(mf.dp, slope=True)


def _mixed(dp, V):
    """The mixed form, ``V``'s mixed variables, ``V'K V`` and ``V'G V`` from first differences,
    and the structure with the slope rows (:func:`_slope_rows`)."""
    from ..mixed import MixedForm
    from .polish import to_mixed

    mf = MixedForm(dp)
    rows = _slope_rows(mf)
    Z = np.column_stack([to_mixed(mf, V[:, i]) for i in range(V.shape[1])])
    kappa, slopes = mf.B2 @ Z, rows.B1 @ Z
    Kr = kappa.T @ (mf.wq2[:, None] * kappa)
    if dp.contact == "foundation" and dp.bilateral:
        w = dp.Nq @ V
        Kr = Kr + w.T @ (np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape)[:, None] * w)
    Gr = slopes.T @ (rows.wq5[:, None] * slopes)
    return mf, Z, 0.5 * (Kr + Kr.T), 0.5 * (Gr + Gr.T), rows


def accurate_ritz(dp, V) -> tuple[np.ndarray, np.ndarray]:
    """Rayleigh-Ritz with the forms evaluated from first differences (:mod:`gaocvx.mixed`).

    ``u'K u`` evaluated as ``K @ u`` in the Hermite DOFs cancels terms of size
    N^4 (measured: the Ritz value of P4's first mode 1.2e-8 off at 2048
    elements, 2.6e-4 at 8192); as ``∫ (w'')^2`` from the mixed variables'
    curvatures it carries round-off of order N eps (1e-11 at 2048).  A
    bonded foundation's ``c M`` is added from the deflections at its
    quadrature points.
    """
    _, _, Kr, Gr, _ = _mixed(dp, V)
    vals, Y = la.eigh(Kr, Gr)
    return vals, V @ Y


def _stiffness_solve(mf, dp, R) -> np.ndarray:
    """``K^-1 R`` for the columns of ``R`` (right-hand sides on the mixed variables).

    The banded KKT system of the bending form (and a bonded foundation's
    ``c M``) with the linking rows: the Hermite ``K`` has condition N^4
    (4e15 at 8192 elements), the mixed system is solved to about N eps.
    """
    from ..mixed.kkt import KKTFactor

    s = mf.structure
    ab = s.bending_band.copy()
    if dp.contact == "foundation" and dp.bilateral:
        ab += s.stacked_map(("contact",)) @ np.broadcast_to(dp.c * mf.wqc, mf.wqc.shape)
    factor = KKTFactor(ab.reshape(s.band_shape), s.lo, s.up, s.order, s.n)
    return np.column_stack([factor.solve(R[:, i], np.zeros(s.N))[0] for i in range(R.shape[1])])


def inverse_iteration(dp, V) -> np.ndarray:
    """One step of subspace inverse iteration, ``K^-1 G V``, in the mixed variables.

    The sparse eigen-solve factors the Hermite ``K``; beyond a few thousand
    elements its vectors carry that factor's round-off (measured on P4: a
    relative residual of 0.14 at 16384 elements).  Each step of this one
    shrinks the error in mode i by ``lambda_i / lambda_j`` of the first
    vector ``j`` left out of the subspace, at the cost of banded solves.
    """
    mf, Z, _, _, rows = _mixed(dp, V)
    Y = _stiffness_solve(mf, dp, rows.B1T @ (rows.wq5[:, None] * (rows.B1 @ Z)))
    return np.column_stack([mf.to_hermite(Y[:, i]) for i in range(Y.shape[1])])


def residual_gram(dp, phi, lam) -> tuple[np.ndarray, np.ndarray, float]:
    """``R'K^-1 R`` of the residuals ``R = K Phi - G Phi diag(lam)``, without forming ``R``.

    Expanded, ``R'K^-1 R = Phi'K Phi - Phi'G Phi L - L Phi'G Phi + L X L``
    with ``L = diag(lam)`` and ``X = Phi'G K^-1 G Phi``: every term is a form
    evaluated from first differences or a mixed solve, accurate to about N
    eps, whereas ``K @ Phi`` in the Hermite DOFs loses N^4 eps (it alone made
    the residual of exact modes 2e-3 at 8192 elements).  The terms cancel to
    the residual's size, so the sum's round-off is returned as well.

    Returns
    -------
    M : ndarray
        ``(k, k)``, the Gram matrix (symmetric).
    Gr : ndarray
        ``Phi'G Phi``.
    noise : float
        A bound on the round-off of ``M``'s entries.
    """
    if phi.shape[1] == 0:
        return np.zeros((0, 0)), np.zeros((0, 0)), 0.0
    mf, Z, Kr, Gr, rows = _mixed(dp, phi)
    Gz = rows.B1T @ (rows.wq5[:, None] * (rows.B1 @ Z))
    X = Gz.T @ _stiffness_solve(mf, dp, Gz)
    X = 0.5 * (X + X.T)
    L = np.diag(lam)
    M = Kr - Gr @ L - L @ Gr + L @ X @ L
    size = np.max(np.abs(Kr)) + 2 * np.max(np.abs(Gr @ L)) + np.max(np.abs(L @ X @ L))
    # The relative accuracy of the forms and the mixed solve.  Measured on converged
    # modes (P4, P1, 16 to 32768 elements), |M| / size was at most 0.15 N^2 eps and
    # 150 N eps at 1024 elements: the bound is 6 times the largest measured.
    N = mf.N
    noise = (1e3 * N + N * N) * np.finfo(float).eps * size
    return 0.5 * (M + M.T), Gr, float(noise)


def concave_margin(K, G, phi, lam, p: float, lam_next: float) -> tuple[float, dict]:
    """The margin ``delta`` to add to every ``c_i`` (module notes) and the measures behind it.

    Parameters
    ----------
    K, G : sparse matrix
        The pencil (K positive definite).
    phi : ndarray
        ``(n, k)`` computed modes, G-orthonormal, ``phi' K phi`` diagonal.
    lam : ndarray
        Their Ritz values.
    p : float
        The axial force (non-dimensional).
    lam_next : float
        The computed ``lambda_{k+1}`` (> p).

    Returns
    -------
    delta : float
        ``lambda_max(R'K^-1 R) / gamma`` (inf when it cannot be bounded).
    info : dict
        ``residual`` (largest relative residual ``|r_i|_{K^-1} / |phi_i|_K``),
        ``gamma``, ``orthogonality`` (``|Phi'G Phi - I|``).
    """
    k = phi.shape[1]
    if k == 0:
        return 0.0, {"residual": 0.0, "gamma": 1.0, "orthogonality": 0.0}
    R = np.asarray(K @ phi) - np.asarray(G @ phi) * lam
    try:
        chol = BandedCholesky(sp.csr_matrix(K))
    except NotPositiveDefinite:
        return math.inf, {"residual": math.inf, "gamma": 0.0, "orthogonality": math.inf}
    KR = np.column_stack([chol.solve(R[:, i]) for i in range(k)])
    return margin_of(R.T @ KR, phi.T @ (G @ phi), lam, p, lam_next)


def margin_of(M, Gr, lam, p: float, lam_next: float, noise: float = 0.0) -> tuple[float, dict]:
    """:func:`concave_margin` from the Gram matrix ``M = R'K^-1 R`` and ``Gr = Phi'G Phi``.

    ``noise`` bounds the round-off of ``M``'s entries (:func:`residual_gram`):
    it is added to ``M``'s largest eigenvalue and to each squared residual, so
    that neither is understated.
    """
    k = len(lam)
    M = 0.5 * (M + M.T)
    top = float(np.max(np.linalg.eigvalsh(M))) + k * noise
    rel = float(np.max(np.sqrt((np.maximum(np.diag(M), 0.0) + noise)
                               / np.maximum(np.abs(lam), 1e-300))))
    gamma = 0.5 * (1.0 - p / lam_next) if math.isfinite(lam_next) else 0.5
    ortho = float(np.max(np.abs(Gr - np.eye(k))))
    delta = max(top, 0.0) / gamma if gamma > 0 else math.inf
    return delta, {"residual": rel, "gamma": gamma, "orthogonality": ortho}
