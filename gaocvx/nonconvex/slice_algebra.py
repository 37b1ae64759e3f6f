"""The small linear algebra of the fast path (:mod:`.fast`): its bordered slice matrix and box QP.

- :class:`BorderedMatrix`: the slice's whole bordered system ``[[A, B'], [B, 0]]``
  (the banded KKT matrix of the mixed form bordered by the k mode rows), its
  sparsity pattern built once per program;
- :func:`box_qp`: each projected Newton step's quadratic model minimised over the
  node's box of amplitudes (k at most six), by a primal active set.

Examples
--------
>>> import numpy as np
>>> box_qp(np.eye(2), np.array([1.0, -3.0]), np.array([-0.5, -1.0]), np.array([1.0, 2.0]))
array([-0.5,  2. ])
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import scipy.sparse as sp

__all__ = ["BorderedMatrix", "box_qp"]


class BorderedMatrix:
    """The bordered matrix ``[[A, B'], [B, 0]]`` of :meth:`.fast.FastProgram._bordered_step`,
    its sparsity pattern built once.

    ``A`` comes in LAPACK gbtrf band storage ``ab`` (``A[i, j] = ab[lo + up + i - j, j]``;
    its first ``lo`` rows are the factorisation's fill-in workspace, not entries), in
    the banded order ``order`` of the mixed form; ``B`` (k rows, on the first columns)
    is fixed for a program.  Every step has the same pattern (the band's places, an
    entry that happens to be 0 among them), so only the values are gathered: built
    anew by ``sp.bmat`` from COO pieces, the matrix took half of each step's time
    (a five-mode bonded bed: 31 s of 61 s in the bordered steps).
    """

    def __init__(self, shape, lo: int, up: int, B, order):
        n = shape[1]
        rows, cols = np.indices(shape)
        i = rows - lo - up + cols
        keep = (rows >= lo) & (i >= 0) & (i < n)
        self._band = np.flatnonzero(keep)          # places in ab.ravel()
        Bp = np.zeros((B.shape[0], n))
        Bp[:, :B.shape[1]] = B
        Bp = Bp[:, order]
        r, c = np.nonzero(Bp)
        self._border = Bp[r, c]
        rr = np.concatenate([i[keep], n + r, c])
        cc = np.concatenate([cols[keep], c, n + r])
        size = n + B.shape[0]
        # (the COO entries' places in CSC order, read off a matrix of their numbers)
        numbered = sp.csc_matrix((np.arange(1.0, rr.size + 1.0), (rr, cc)), shape=(size, size))
        numbered.sort_indices()
        self._take = numbered.data.astype(np.int64) - 1
        self._indices, self._indptr, self._shape = numbered.indices, numbered.indptr, (size, size)

    def matrix(self, ab) -> sp.csc_matrix:
        """The bordered matrix with the band's values ``ab``."""
        values = np.concatenate([ab.ravel()[self._band], self._border, self._border])
        return sp.csc_matrix((values[self._take], self._indices, self._indptr),
                             shape=self._shape)


def box_qp(H, g, a, b) -> np.ndarray:
    """The minimiser of ``g'd + d'H d / 2`` over the box ``a <= d <= b`` (H positive definite, small k).

    A primal active-set method (Nocedal and Wright, algorithm 16.3) from
    ``d = 0`` (``a <= 0 <= b``: the box is around the current point): on the
    free coordinates the face's minimiser, a step to it as far as the box
    allows (the blocking bound joins the working set), and a bound whose
    multiplier has the wrong sign leaves it.  For a strictly convex QP it
    ends, exactly, at the face whose unconstrained minimiser it is, in a few
    iterations; the 3^k faces were once all solved (243 at k = 5: 20 ms a
    call, three quarters of a five-mode search's time).  Should it not end
    within its iterations (cycling on a degenerate face), every face is tried
    (:func:`_box_qp_faces`).

    Examples
    --------
    >>> box_qp(np.eye(2), np.array([-2.0, 1.0]), np.array([-1.0, -1.0]), np.array([1.0, 1.0]))
    array([ 1., -1.])
    """
    g, a, b = np.asarray(g, float), np.asarray(a, float), np.asarray(b, float)
    k = len(g)
    d = np.clip(np.zeros(k), a, b)
    # Working set: 0 free, -1 at the lower bound, +1 at the upper.
    side = np.zeros(k, int)
    for _ in range(8 * k + 8):
        free = side == 0
        step = np.zeros(k)
        if free.any():
            try:
                step[free] = np.linalg.solve(H[np.ix_(free, free)], -(g + H @ d)[free])
            except np.linalg.LinAlgError:
                break
        # The longest step within the box, and the bound that blocks it.
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(step < 0, (a - d) / step, np.where(step > 0, (b - d) / step, np.inf))
        room = np.where(free, np.maximum(room, 0.0), np.inf)
        j = int(np.argmin(room))
        if room[j] < 1.0:
            d = np.clip(d + room[j] * step, a, b)
            side[j] = -1 if step[j] < 0 else 1
            d[j] = a[j] if step[j] < 0 else b[j]
            continue
        # The face's minimiser: a bound whose multiplier pulls into the box leaves.
        d = np.clip(d + step, a, b)
        grad = g + H @ d
        wrong = np.where(side == -1, -grad, np.where(side == 1, grad, 0.0))
        j = int(np.argmax(wrong))
        if wrong[j] <= 0.0:
            return d
        side[j] = 0
    return _box_qp_faces(H, g, a, b)


def _box_qp_faces(H, g, a, b) -> np.ndarray:
    """:func:`box_qp` by trying every face of the box (3^k of them).

    The minimiser is the unconstrained minimiser of the face that contains it
    in its relative interior, so the best feasible face solution is exact.
    """
    k = len(g)
    best, best_val = np.clip(np.zeros(k), a, b), math.inf
    for face in itertools.product((0, 1, 2), repeat=k):
        d = np.where(np.array(face) == 1, a, np.where(np.array(face) == 2, b, 0.0))
        free = np.array(face) == 0
        if free.any():
            rhs = -(g[free] + H[np.ix_(free, ~free)] @ d[~free])
            try:
                d[free] = np.linalg.solve(H[np.ix_(free, free)], rhs)
            except np.linalg.LinAlgError:
                continue
        if np.any(d < a - 1e-15 * np.abs(a)) or np.any(d > b + 1e-15 * np.abs(b)):
            continue
        d = np.clip(d, a, b)
        val = float(g @ d + 0.5 * d @ H @ d)
        if val < best_val:
            best, best_val = d, val
    return best
