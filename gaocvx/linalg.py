"""Banded symmetric positive-definite algebra for Hermite beam matrices.

With the DOF ordering ``[w_0, theta_0, w_1, ...]`` every matrix of the beam
(bending, geometric, the Gao and foundation Hessians) couples a DOF only with
its three neighbours on either side, so a banded Cholesky factorisation costs
O(N) and needs no fill-reducing ordering.  A failed factorisation is the
cheapest proof that a matrix is not positive definite.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

__all__ = ["to_banded", "BandedCholesky", "NotPositiveDefinite"]


class NotPositiveDefinite(np.linalg.LinAlgError):
    """The matrix handed to :class:`BandedCholesky` is not positive definite."""


def bandwidth(A: sp.spmatrix) -> int:
    """Upper bandwidth of a sparse matrix."""
    A = sp.coo_matrix(A)
    return int(np.max(A.col - A.row, initial=0))


def to_banded(A: sp.spmatrix, u: int | None = None) -> np.ndarray:
    """Upper banded storage ``ab[u + i - j, j] = A[i, j]`` of a symmetric matrix."""
    A = sp.coo_matrix(A)
    if u is None:
        u = bandwidth(A)
    n = A.shape[0]
    ab = np.zeros((u + 1, n))
    keep = A.col >= A.row
    np.add.at(ab, (u + A.row[keep] - A.col[keep], A.col[keep]), A.data[keep])
    return ab


class BandedCholesky:
    """Cholesky factor ``A = R^T R`` of a sparse banded SPD matrix.

    Parameters
    ----------
    A : sparse matrix
        Symmetric positive definite.

    Raises
    ------
    NotPositiveDefinite
        If the factorisation breaks down.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> A = sp.diags([[-1.0] * 3, [2.0] * 4, [-1.0] * 3], [-1, 0, 1])
    >>> c = BandedCholesky(A)
    >>> c.solve([1.0, 0.0, 0.0, 1.0]).round(6).tolist()
    [1.0, 1.0, 1.0, 1.0]
    """

    def __init__(self, A: sp.spmatrix):
        self.u = max(bandwidth(A), 0)
        ab = to_banded(A, self.u)
        try:
            self.cb = sla.cholesky_banded(ab, lower=False, check_finite=True)
        except np.linalg.LinAlgError as exc:
            raise NotPositiveDefinite(str(exc)) from None
        self.n = A.shape[0]

    def solve(self, b) -> np.ndarray:
        """Solve ``A x = b``."""
        return sla.cho_solve_banded((self.cb, False), np.asarray(b, float), check_finite=False)

    def factor(self) -> sp.csr_matrix:
        """The upper-triangular factor R as a sparse matrix (``A = R^T R``)."""
        u, n = self.u, self.n
        diags = [self.cb[u - k, k:] for k in range(u + 1)]
        return sp.diags(diags, list(range(u + 1)), shape=(n, n), format="csr")
