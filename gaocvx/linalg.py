"""Banded symmetric positive-definite algebra for Hermite beam matrices.

With the DOF ordering ``[w_0, theta_0, w_1, ...]`` every matrix of the beam
(bending, geometric, the Gao and foundation Hessians) couples a DOF only with
its three neighbours on either side, so a banded Cholesky factorisation costs
O(N) and needs no fill-reducing ordering.  A failed factorisation is the
cheapest proof that a matrix is not positive definite.
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

__all__ = ["to_banded", "BandedCholesky", "NotPositiveDefinite", "one_blas_thread", "VectorCSR"]

# Environment variables by which a user chooses the BLAS threads: when one is
# set, one_blas_thread() leaves the choice alone.
_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def one_blas_thread():
    """A context in which BLAS runs on one thread (where threadpoolctl can set it).

    The solvers' work is O(N) vector operations and banded factorisations,
    which gain nothing from BLAS threads; on a machine whose cores are busy
    the threads' hand-offs cost more than the work: a 10240-element dot
    product averaged 90 us against 2.4 us on one thread (measured under a
    load of 4 on 2 cores), and a 256-element sweep value took 109 ms against
    about 5 ms.  The command line and the sweeps use this context; a user's
    own choice (``OPENBLAS_NUM_THREADS`` and the like) is respected.

    Examples
    --------
    >>> with one_blas_thread():
    ...     pass
    """
    import contextlib
    import os
    if any(os.environ.get(v) for v in _THREAD_VARIABLES):
        return contextlib.nullcontext()
    controller = _controller()
    if controller is None:  # pragma: no cover - a dependency, but never fatal
        return contextlib.nullcontext()
    # The limit is process-wide: enter and leave it around work that does not yield
    # (sweeps limit each value's solve, not their generators).
    return controller.limit(limits=1, user_api="blas")


@functools.lru_cache(maxsize=1)
def _controller():
    """threadpoolctl's view of the loaded libraries, made once (4 ms; a limit then 13 us)."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover
        return None
    return ThreadpoolController()


try:   # scipy's own kernel behind ``csr_matrix @ vector`` (private, hence the fallback)
    from scipy.sparse._sparsetools import csr_matvec as _csr_matvec
except ImportError:  # pragma: no cover - a scipy without it: the public product
    _csr_matvec = None


class VectorCSR(sp.csr_matrix):
    """A CSR matrix whose product with a float vector calls scipy's kernel directly.

    ``A @ x`` of a scipy sparse matrix spends some 4 us of its 6 us in Python
    dispatch when ``A`` has a few hundred rows; the solvers above the
    convexity limit make millions of such products (a four-mode branch and
    bound on 32 elements: 2.8 million, a third of its time).  The kernel is the
    one ``A @ x`` ends in, so the result is the same to the bit; anything else
    (matrices, other dtypes, ``A.T``) goes through scipy as usual.

    Examples
    --------
    >>> A = VectorCSR(sp.csr_matrix(np.array([[1.0, 2.0], [0.0, 3.0]])))
    >>> A @ np.array([1.0, 1.0])
    array([3., 3.])
    """

    def __matmul__(self, other):
        if (_csr_matvec is not None and type(other) is np.ndarray and other.ndim == 1
                and other.dtype == np.float64 and self.dtype == np.float64
                and other.shape[0] == self.shape[1]):
            out = np.zeros(self.shape[0])
            _csr_matvec(self.shape[0], self.shape[1], self.indptr, self.indices, self.data,
                        other, out)
            return out
        return super().__matmul__(other)


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
