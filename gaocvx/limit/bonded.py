"""The convexity limit P_hat_h of a beam on a bonded (bilateral) foundation.

A bonded foundation adds ``1/2 c_F ∫ (w - g)^2`` to the energy: the quadratic
part becomes ``K + c M - P mu G`` (M the mass matrix of w), and the energy is
convex below the smallest eigenvalue of ``(K + c M, mu G)``, the thesis's
P_hat (2.44).  c M >= 0, so P_hat_h >= P_bar_h, often by far (a rail on its
bed).

The check (:meth:`BondedLimit.prove_below`) is that of :mod:`gaocvx.limit`
with the foundation added: in its variables ``[w_i, theta_i, D_i]``, with the
links ``w_{e+1} - w_e - h_e D_e`` as a penalty, the foundation is
``c v' M_e v`` on each element's ``(w_e, theta_e, w_{e+1}, theta_{e+1})``
(the Hermite mass matrix; on the links, w is the cubic whose slope is s).
The penalty is >= 0 and vanishes on the links, so a successful Cholesky
factorisation of the penalised matrix at ``sigma + Delta`` proves the form
positive definite on the links at sigma, for any penalty; a few penalties
are tried.  Delta bounds the round-off as in :mod:`gaocvx.limit`, with the
foundation's diagonal added: ``|w_i|^2 <= x_i ∫ s^2`` (``w_i = ∫_0^x_i s``) and
``theta_i^2 <= ∫_e s^2 / (BETA h_e)``.

The value (:func:`p_hat_h`) is the Rayleigh quotient of a shift-invert
eigenvector in Hermite DOFs, evaluated from curvatures, slopes and
deflections at Gauss points: an upper bound of P_hat_h, accurate to the
square of the eigenvector's error.  It is reported; the proof above decides.

Examples
--------
>>> from gaocvx import DiscreteProblem, Scene
>>> d = {"beam": {"model": "euler-bernoulli", "supports": "P4", "length": 1.0, "EI": 1.0},
...      "foundation": {"gap": 0.0, "stiffness": 100.0, "kind": "bilateral"},
...      "mesh": {"elements": 64}}
>>> dp = DiscreteProblem(Scene.from_dict(d))
>>> round(p_hat_h(dp) / (np.pi**2 + 100.0 / np.pi**2), 8)   # (n pi)^2 + k / (n pi)^2 at n = 1
1.0
>>> lim = BondedLimit(dp.xi, "P4", dp.c)
>>> lim.prove_below(0.999 * p_hat_h(dp)), lim.prove_below(1.001 * p_hat_h(dp))
(True, False)
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .element import _GAMMA, _U, BETA, EPS, identity_rows as _identity_rows
from .pencil import ConvexityLimit

__all__ = ["BondedLimit", "p_hat_h"]

# Hermite mass matrix on the reference element, in (w_e, theta_e h, w_e+1, theta_e+1 h):
# ∫_e w^2 = h v' M_REF v with the slopes scaled by h.
M_REF = np.array([[156.0, 22.0, 54.0, -13.0], [22.0, 4.0, 13.0, -3.0],
                  [54.0, 13.0, 156.0, -22.0], [-13.0, -3.0, -22.0, 4.0]]) / 420.0
PENALTY_TRIES = 6


class BondedLimit(ConvexityLimit):
    """:class:`~gaocvx.limit.ConvexityLimit` with a bonded foundation ``c`` (non-dimensional)."""

    def __init__(self, xi, supports: str, c):
        super().__init__(xi, supports)
        # c per element (a stiffness profile: its smallest value at the element's
        # quadrature points, a lower bound of its foundation term), or one number.
        self.cf = np.broadcast_to(np.asarray(c, float), (self.N,)).copy()
        # The deflections carry the foundation: only w_0 (and the fixed slopes) stay fixed.
        keep = [i for i in self.z_fixed if i % 3 != 0 or i in (0, 3 * self.N)]
        if not self.constrained:
            keep = [i for i in keep if i != 3 * self.N]
        self.z_fixed = np.array(sorted(set(keep)))
        self.dim = int(self.free.sum())
        self._rho = 0.0

    def _penalty(self, sigma: float) -> float:
        return self._rho

    def _band(self, sigma: float) -> np.ndarray:
        ab = super()._band(sigma)
        h, N = self.h, self.N
        # (w_e, theta_e, w_e+1, theta_e+1) are z offsets (0, 1, 3, 4) of element e.
        offs = (0, 1, 3, 4)
        for i, a in enumerate(offs):
            for j, b in enumerate(offs):
                if a <= b:
                    hs = h ** (1 + (i % 2) + (j % 2))   # theta entries carry h each
                    ab[_U + a - b, b::3][:N] += self.cf * M_REF[i, j] * hs
        # The rows of fixed DOFs were set to the identity by the base; redo it.
        _identity_rows(ab, self.z_fixed)
        return ab

    def roundoff_shift(self, sigma: float) -> float:
        """The base's Delta with the foundation's and the penalty's deflection diagonal."""
        base = super().roundoff_shift(sigma)
        h, x = self.h, self.x
        inv = 1.0 / h
        reach = np.minimum(x[1:], 1.0 - x[1:]) if self.constrained else x[1:]
        # Diagonal of w_i (i >= 1): the foundation's c h 156/420 from each element
        # beside it, and the penalty's rho / h from each (the base counted the
        # penalty only where the deflections were variables: the constrained supports).
        # node i + 1 sits between element i (left) and element i + 1 (right)
        d_w = (156.0 / 420.0) * (self.cf * h + np.r_[self.cf[1:] * h[1:], 0.0])
        if not self.constrained:
            d_w = d_w + self._rho * (inv + np.r_[inv[1:], 0.0])
        S = float(np.sum(d_w * reach))
        # theta_i: c 4 h^3 / 420 per element, theta_i^2 <= ∫_e s^2 / (BETA h).
        S += float(np.max(self.cf * 8.0 / 420.0 * h**2 / BETA, initial=0.0))
        return base + (2 * _U + 1) * _GAMMA * S * (1 + _GAMMA)

    def prove_below(self, p: float) -> bool:
        """True if a factorisation proves ``p < lambda_1`` of (K + c M, G) despite round-off."""
        if self.dim == 0 or p <= 0:
            return True
        for k in range(PENALTY_TRIES):
            self._rho = (10.0 ** k) * 10.0 * max(p, float(np.max(self.cf)), 1.0)
            self._factors.clear()
            sigma = p * (1 + 4 * EPS)
            sigma += self.roundoff_shift(sigma)
            if self.factor(sigma) is not None:
                return True
        return False


def _rayleigh(dp, u) -> float:
    bend = dp.wq2 @ (dp.B2 @ u) ** 2
    found = (dp.c * dp.wq_c) @ (dp.Nq @ u) ** 2
    axial = dp.wq_gao @ (dp.B1 @ u) ** 2
    return float((bend + found) / axial)


def p_hat_h(dp) -> float:
    """P_hat_h [N]: the smallest eigenvalue of (K + c M, mu G) on the free DOFs.

    Infinite when every DOF is fixed.  ``dp`` must have a foundation.
    """
    if dp.n == 0:
        return float("inf")
    A = (dp.K + dp.NqT @ sp.diags(dp.c * dp.wq_c) @ dp.Nq).tocsc()
    G = dp.G.tocsc()
    if dp.n <= 400:  # small: dense and exact to round-off
        import scipy.linalg as sla
        _, vecs = sla.eigh(A.toarray(), G.toarray(), subset_by_index=[0, 0])
    else:
        _, vecs = spla.eigsh(A, k=1, M=G, sigma=0.0, which="LM")
    # lambda is p = P mu L^2 / EI in the problem's units
    return _rayleigh(dp, vecs[:, 0]) * dp.EI / (dp.mu * dp.L**2)
