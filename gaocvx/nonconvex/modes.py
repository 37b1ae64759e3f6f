"""The unstable buckling modes of a discrete problem at its axial force.

Above the convexity limit the discrete energy is convex except along the k
generalised eigenvectors of ``(K, G)`` (non-dimensional; the physical pencil
is ``(K, mu G)``) whose eigenvalue lies below the axial force ``p``
(nonconvex.md).  This module computes them, G-normalised
(``phi_i' G phi_j = delta_ij``), together with the first stable eigenvalue
``lambda_{k+1}``, which sets the conditioning of the node programs.

A mode whose eigenvalue lies within a relative :data:`MARGIN` of ``p`` counts
as unstable: the split ``u = Phi s + v`` then keeps the complement strictly
convex even when round-off puts the eigenvalue a hair above ``p``.

Up to :data:`MAX_DENSE_DOFS` free DOFs the pencil is solved densely (exact to
round-off); beyond, by a sparse shift-invert Lanczos solve (``eigsh``,
shift 0: the factor of K) followed by Rayleigh-Ritz on the vectors it
returns.  Either way the modes are checked (:mod:`.modecheck`): their
residual gives the margin ``delta`` added to every concave coefficient
``c_i``, which keeps ``Psi`` provably convex with inexact eigenvectors, and,
for the sparse solve, a Sturm count (inertia of ``K - sigma G``) confirms
that no eigenvalue below ``p (1 + MARGIN)`` was missed.  Modes that fail a
check are flagged (``Modes.verified`` false): the global method's answer is
then ``inaccurate``.

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 16}})
>>> m = unstable_modes(DiscreteProblem(scene, check_convexity=False))
>>> m.k, round(float(m.loads[0]) / 1.168e9, 3)   # one mode, at P_bar_h ~ P_bar
(1, 1.0)
"""

from __future__ import annotations

import math

import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as la
import scipy.sparse.linalg as sla

from .modecheck import (accurate_ritz, count_below, inverse_iteration, margin_of, residual_gram,
                        ritz)

__all__ = ["Modes", "unstable_modes", "MARGIN", "MAX_DENSE_DOFS", "MAX_UNSTABLE"]

# More unstable modes than this are not resolved further (the global method takes
# six, minimum.MAX_MODES; equilibria two): the count only has to show that there
# are too many.
MAX_UNSTABLE = 8

log = logging.getLogger(__name__)

# A mode with lambda_i <= p (1 + MARGIN) is counted as unstable (nonconvex.md).
MARGIN = 1e-8
# The dense generalised eigen-solve is exact to round-off (about N^4 eps relative
# to lambda_1, 3e-9 at 64 elements) and cheap up to this many free DOFs; beyond,
# the sparse solve.
MAX_DENSE_DOFS = 1200
# Largest relative residual |r_i|_{K^-1} / |phi_i|_K accepted of a computed mode.
# Its measure includes the bound of its own round-off (modecheck.residual_gram),
# which dominates on fine meshes: P4 measured 3e-5 at 1024 elements, 2.6e-4 at 8192
# and 1e-3 at 32768.  (Evaluated in the Hermite DOFs it was 5e-3 at 8192.)
RESIDUAL_TOL = 1e-3
# The sparse solve's vectors are refined (:func:`.modecheck.inverse_iteration`)
# until their relative residuals are below REFINE_TOL, in at most REFINE_STEPS steps.
REFINE_TOL = 1e-7
REFINE_STEPS = 8


@dataclass(frozen=True)
class Modes:
    """The unstable modes of a problem at its axial force.

    Attributes
    ----------
    k : int
        Number of unstable modes (0: the energy is convex).
    lam : ndarray
        Their non-dimensional eigenvalues ``lambda_i`` (units of ``p``).
    phi : ndarray
        ``(n, k)`` G-normalised eigenvectors on the free Hermite DOFs.
    lam_next : float
        The first stable eigenvalue ``lambda_{k+1}`` (inf when there is none).
    p : float
        The non-dimensional axial force.
    loads : ndarray
        The mode loads ``lambda_i EI / (mu L^2)`` [N].
    delta : float
        The margin added to every ``c_i`` for the eigenvectors' inexactness
        (:func:`.modecheck.concave_margin`).
    verified : bool
        The checks of :mod:`.modecheck` passed.
    checks : dict
        Their measures (``residual``, ``gamma``, ``orthogonality``, ``sturm``).
    """

    k: int
    lam: np.ndarray
    phi: np.ndarray
    lam_next: float
    p: float
    loads: np.ndarray
    delta: float = 0.0
    verified: bool = True
    checks: dict = field(default_factory=dict)

    @property
    def c(self) -> np.ndarray:
        """The concave coefficients ``c_i = (p - lambda_i) / 2 + delta >= 0`` of ``-sum c_i s_i^2``."""
        return np.maximum(self.p - self.lam, 0.0) / 2.0 + self.delta


def _pencil(dp, count):
    """The ``count`` smallest eigenpairs of the dense pencil (K, G), G-normalised."""
    from .node import effective_stiffness

    K = effective_stiffness(dp).toarray()
    G = dp.G.toarray()
    count = min(count, dp.n)
    _, vecs = la.eigh(K, G, subset_by_index=[0, count - 1])
    # The values from first differences: the Hermite forms carry N^4 eps (4e-9 of
    # lambda_1 at 256 elements), and the margin's argument needs Phi'K Phi = diag(lambda).
    return accurate_ritz(dp, vecs)


def _pencil_sparse(dp, count):
    """The ``count`` smallest eigenpairs by shift-invert Lanczos, Rayleigh-Ritz refined."""
    from .node import effective_stiffness

    K = effective_stiffness(dp).tocsc()
    G = dp.G.tocsc()
    count = min(count, dp.n - 2)
    # Shift 0: the operator K^-1 G, whose largest eigenvalues are the wanted ones.
    # A few extra vectors make the Ritz values of the wanted ones converge.
    extra = min(count + 4, dp.n - 2)
    # (a fixed start vector: the same modes on every run)
    _, V = sla.eigsh(K, k=extra, M=G, sigma=0.0, which="LM", tol=1e-13,
                     ncv=min(dp.n - 1, max(2 * extra + 1, 20)), v0=np.ones(dp.n))
    # The Ritz values from first differences: the Hermite forms lose N^4 eps.
    vals, vecs = accurate_ritz(dp, ritz(K, G, V)[1])
    # The vectors carry the round-off of the Hermite K's factor: refined by inverse
    # iteration in the mixed variables until the wanted ones' residuals are small.
    for _ in range(REFINE_STEPS):
        M, _, noise = residual_gram(dp, vecs[:, :count], vals[:count])
        if np.max(np.maximum(np.diag(M), 0.0) / vals[:count]) <= REFINE_TOL**2:
            break
        vals, vecs = accurate_ritz(dp, inverse_iteration(dp, vecs))
    return vals[:count], vecs[:, :count]


def unstable_modes(dp, min_k: int = 0, solver: str | None = None) -> Modes:
    """The k modes of ``(K, G)`` with ``lambda_i <= p (1 + MARGIN)``, and ``lambda_{k+1}``.

    Parameters
    ----------
    dp : DiscreteProblem
        Built with ``check_convexity=False``.
    min_k : int
        Count at least this many modes as unstable (their ``c_i`` are then
        clipped at 0): for a P that the convexity check cannot prove below
        ``P_bar_h`` but the eigen-solve puts a hair below ``lambda_1``.
    solver : {None, "dense", "sparse"}
        The eigen-solve; by default dense up to :data:`MAX_DENSE_DOFS` free
        DOFs, sparse beyond.

    Returns
    -------
    Modes
    """
    scale = dp.EI / (dp.mu * dp.L**2)
    empty = Modes(0, np.zeros(0), np.zeros((dp.n, 0)), np.inf, dp.p, np.zeros(0))
    if dp.n == 0:
        return empty
    sparse = dp.n > MAX_DENSE_DOFS if solver is None else solver == "sparse"
    count = 4
    while True:
        vals, vecs = (_pencil_sparse if sparse else _pencil)(dp, count + 1)
        k = int(np.sum(vals <= dp.p * (1.0 + MARGIN))) if dp.p > 0 else 0
        k = max(k, min(min_k, len(vals) - 1))
        # Stop when a stable mode was found, the solver gave all it can (the sparse
        # one at most n - 2), or there are more unstable modes than anything takes
        # (the callers refuse beyond six): doubling on never ended on fine meshes.
        if k < len(vals) or len(vals) < count + 1 or k > MAX_UNSTABLE:
            break
        count *= 2
    if k == 0:
        return Modes(0, np.zeros(0), np.zeros((dp.n, 0)), float(vals[0]), dp.p, np.zeros(0))
    phi = vecs[:, :k].copy()
    # A fixed sign (largest deflection entry positive) makes amplitudes reproducible.
    w_rows = dp._w_rows()
    for i in range(k):
        col = phi[w_rows, i] if len(w_rows) else phi[:, i]
        j = int(np.argmax(np.abs(col)))
        if col[j] < 0:
            phi[:, i] = -phi[:, i]
    lam_next = float(vals[k]) if k < len(vals) else np.inf
    delta, checks, verified = _check(dp, phi, vals[:k], lam_next, sparse)
    return Modes(k, vals[:k].copy(), phi, lam_next, dp.p, vals[:k] * scale, delta, verified,
                 checks)


def _check(dp, phi, lam, lam_next, sparse):
    """The margin delta and whether the modes pass the checks of :mod:`.modecheck`."""
    from .node import effective_stiffness

    K = effective_stiffness(dp)
    M, Gr, noise = residual_gram(dp, phi, lam)
    delta, checks = margin_of(M, Gr, lam, dp.p, lam_next, noise)
    verified = checks["residual"] <= RESIDUAL_TOL and checks["orthogonality"] <= 1e-10 \
        and math.isfinite(delta)
    if sparse and dp.p > 0:
        # No eigenvalue missed below p (1 + MARGIN): none below the half-way point
        # between it and the computed lambda_{k+1} but the k found.  (Counted there,
        # not at p itself: the Hermite pencil's round-off moves its eigenvalues by
        # about N^4 eps, measured 1e-3 of lambda_3 at 16384 elements, and p may lie
        # within that of lambda_k; the half-way point lies half the gap away.)
        sigma = dp.p * (1.0 + MARGIN)
        top = 0.5 * (sigma + lam_next) if math.isfinite(lam_next) else sigma
        below = count_below(K, dp.G, top)
        checks["sturm"] = below
        verified = verified and below == int(np.sum(lam < top))
    if not verified:
        log.warning("buckling modes not verified: %s", checks)
    return delta, checks, verified
