"""The mixed energy's Hessian, kept as quadrature weights, and the banded KKT factor."""


from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as sla

if TYPE_CHECKING:
    from .form import MixedForm


__all__ = ["Hessian", "KKTFactor"]


class Hessian:
    """A (generalised) Hessian of the mixed energy, kept as its quadrature weights.

    ``H = H0 + B1' diag(gao) B1 + Nq' diag(foundation) Nq + A' diag(obstacle) A``;
    ``H @ x`` multiplies without assembling, and :meth:`band` gives the KKT
    matrix in band form.
    """

    def __init__(self, mf: "MixedForm", gao=None, foundation=None, obstacle=None):
        self.mf, self.gao, self.foundation, self.obstacle = mf, gao, foundation, obstacle

    def __matmul__(self, x):
        mf = self.mf
        y = mf.H0 @ x
        # (x may be a matrix, one column per vector: the weights then scale its rows)
        col = (lambda w: w) if np.ndim(x) == 1 else (lambda w: w[:, None])
        if self.gao is not None:
            y += mf.B1T @ (col(self.gao) * (mf.B1 @ x))
        if self.foundation is not None:
            y += mf.NqT @ (col(self.foundation) * (mf.Nq @ x))
        if self.obstacle is not None:
            y += mf.AT @ (col(self.obstacle) * (mf.A @ x))
        return y

    def band(self) -> np.ndarray:
        """``[[H, C'], [C, 0]]`` in LAPACK gbtrf band storage (interleaved order)."""
        s = self.mf.structure
        terms = tuple(name for name, w in (("slope", self.gao), ("contact", self.foundation),
                                           ("obstacle", self.obstacle)) if w is not None)
        if not terms:
            ab = self.mf.base_band.copy()
        else:
            # One mat-vec with the stacked maps of the terms present.
            weights = [w for w in (self.gao, self.foundation, self.obstacle) if w is not None]
            ab = s.stacked_map(terms) @ np.concatenate(weights)
            ab += self.mf.base_band
        return ab.reshape(s.band_shape)



class KKTFactor:
    """LU factor (LAPACK gbtrf) of a banded KKT matrix, for repeated solves."""

    def __init__(self, ab, lo, up, order, n, H=None, C=None, refine=0, CT=None):
        self.lu, self.piv, info = sla.lapack.dgbtrf(ab, lo, up)
        if info > 0:
            raise np.linalg.LinAlgError("singular KKT matrix")
        self.lo, self.up, self.order, self.n = lo, up, order, n
        self.H, self.C, self.refine = H, C, refine
        self.CT = CT if CT is not None or C is None else C.T.tocsr()

    def _solve(self, rhs_z, rhs_c):
        b = np.concatenate([rhs_z, rhs_c])[self.order]
        x, info = sla.lapack.dgbtrs(self.lu, self.lo, self.up, b, self.piv)
        sol = np.empty_like(x)
        sol[self.order] = x
        return sol[: self.n], sol[self.n:]

    def solve(self, rhs_z, rhs_c) -> tuple[np.ndarray, np.ndarray]:
        """Solve, with ``self.refine`` steps of iterative refinement.

        ``rhs_z`` and ``rhs_c`` are vectors, or matrices with one column per
        right-hand side (one LAPACK call for all: the k columns of a bordered
        solve).

        A stiff obstacle penalty (rho up to 1e10) makes the KKT matrix
        ill-conditioned, and the LU solution's error then lies in the soft
        directions that the energy norm weighs most: one refinement step (a
        residual from the unassembled H, one more banded solve) removes it.
        """
        d, mu = self._solve(rhs_z, rhs_c)
        for _ in range(self.refine):
            rz = rhs_z - (self.H @ d + self.CT @ mu)
            rc = rhs_c - self.C @ d
            dd, dmu = self._solve(rz, rc)
            d, mu = d + dd, mu + dmu
        return d, mu

