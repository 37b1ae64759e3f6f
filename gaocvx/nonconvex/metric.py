"""A norm of the beam's free DOFs, ``|d|_A = sqrt(d'A d)``, with bounds that hold in exact arithmetic.

The basins (:mod:`.basin`) bound how far a slice's minimiser lies from a point
in the norms of the geometric matrix G and of the bending matrix, and from
that how far each slope can lie: ``|b'd| <= sqrt(b'A^-1 b) |d|_A``.  Their
dual norms come from a banded Cholesky factor, rounded up by an allowance for
its round-off; the dual norm of any vector within given magnitudes is bounded
through a proved lower bound of the smallest eigenvalue of the Jacobi-scaled
matrix (:func:`.dual.metric_floor`).

Examples
--------
>>> import numpy as np, scipy.sparse as sp
>>> A = sp.diags([[-1.0] * 3, [2.0] * 4, [-1.0] * 3], [-1, 0, 1]).tocsr()
>>> m = Metric(A, np.linspace(0.0, 1.0, 5), 2)
>>> g = np.array([1.0, 0.0, 0.0, 1.0])
>>> exact = float(np.sqrt(g @ np.linalg.solve(A.toarray(), g)))
>>> bool(exact <= m.dual(g) <= exact * (1 + 1e-9)), bool(m.bound(np.abs(g)) >= exact)
(True, True)
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from ..linalg import BandedCholesky
from .dual import EPS, metric_floor

__all__ = ["Metric"]

# Columns of A^-1 B' computed at a time (for the point bounds).
CHUNK = 512


class Metric:
    """The norm ``|d|_A = sqrt(d'A d)``: dual norms and the bounds ``|b'd| <= sqrt(b'A^-1 b) |d|_A``.

    The quadratic forms in ``A^-1`` come from a banded Cholesky factor; their
    round-off, at most about ``cond(A) n eps`` relative, is added, with
    ``cond ~ (L / h_min)^power`` for the beam's matrices (2 for G, 4 for the
    bending matrix; the shortest element rules where point forces grade the mesh).
    ``floor`` is a proved lower bound of the smallest eigenvalue of ``S A S``
    (``S = diag(A)^-1/2``), by which :meth:`bound` bounds the dual norm of every
    vector within given magnitudes.
    """

    def __init__(self, A, xi, power: int):
        self.chol = BandedCholesky(A)
        self.factor = 1.0 + 1e3 * (1.0 / float(np.min(np.diff(xi)))) ** power * EPS
        self.S = sp.diags(1.0 / np.sqrt(A.diagonal()))
        self.floor = metric_floor(A, self.S)

    def dual(self, g) -> float:
        """``sqrt(g'A^-1 g)``, rounded up."""
        g = np.asarray(g, float)
        return math.sqrt(max(float(g @ self.chol.solve(g)), 0.0) * self.factor)

    def bound(self, magnitudes) -> float:
        """A proved bound of ``sqrt(e'A^-1 e)`` over every ``|e| <= magnitudes``
        (``e'A^-1 e <= |S e|^2 / floor``); infinite without a floor."""
        if not self.floor > 0:
            return math.inf
        return float(np.linalg.norm(self.S @ np.asarray(magnitudes, float))) / math.sqrt(
            self.floor) * (1.0 + 1e-12)

    def points(self, rows) -> np.ndarray:
        """``sqrt(b_q'A^-1 b_q)`` for the rows ``b_q`` of a sparse matrix, rounded up."""
        out = np.empty(rows.shape[0])
        cols = rows.T.tocsc()
        for a in range(0, rows.shape[0], CHUNK):
            block = cols[:, a:a + CHUNK].toarray()
            out[a:a + CHUNK] = np.einsum("ij,ij->j", block, self.chol.solve(block))
        return np.sqrt(np.maximum(out, 0.0) * self.factor)
