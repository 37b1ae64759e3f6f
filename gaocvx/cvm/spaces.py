"""Matrices of the discrete control and state spaces on the quadrature points."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["hat_matrix", "broken_linear_matrix", "quadratic_matrix", "load_knots",
           "z_to_hermite", "moment_to_hermite"]


def load_knots(dp) -> np.ndarray:
    """The load table's knots (non-dimensional); empty for a uniform load or none."""
    return np.empty(0) if dp.q_table is None else dp.q_table[:, 0]


def _element_matrix(xq, cols, vals, n) -> sp.csr_matrix:
    """Rows at the points ``xq``: ``vals[q, k]`` in column ``cols[q, k]`` (n columns)."""
    rows = np.repeat(np.arange(len(xq)), cols.shape[1])
    return sp.csr_matrix((vals.ravel(), (rows, cols.ravel())), shape=(len(xq), n))


def _local(xi, xq, e):
    """Local coordinate t in [0, 1] of the points ``xq`` in their elements ``e``, and h."""
    h = np.diff(xi)[e]
    return (xq - xi[e]) / h, h


def hat_matrix(xi, xq, e) -> sp.csr_matrix:
    """Values of the nodal hat functions at quadrature points ``xq`` (element ``e``)."""
    t, _ = _local(xi, xq, e)
    return _element_matrix(xq, np.stack([e, e + 1], 1), np.stack([1 - t, t], 1), len(xi))


def broken_linear_matrix(xi, xq, e) -> sp.csr_matrix:
    """Discontinuous linears, [m_L(e), m_R(e)] per element, at the points ``xq``."""
    t, _ = _local(xi, xq, e)
    return _element_matrix(xq, 2 * e[:, None] + np.arange(2), np.stack([1 - t, t], 1),
                           2 * (len(xi) - 1))


def quadratic_matrix(xi, xq, e, deriv: int = 0) -> sp.csr_matrix:
    """Continuous quadratic elements, or their x-derivatives (``deriv=1``), at ``xq``.

    Vertex i is DOF 2i, the midpoint of element e DOF 2e + 1.
    """
    t, h = _local(xi, xq, e)
    if deriv == 0:
        vals = np.stack([(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)], 1)
    else:
        vals = np.stack([4 * t - 3, 4 - 8 * t, 4 * t - 1], 1) / h[:, None]
    return _element_matrix(xq, 2 * e[:, None] + np.arange(3), vals, 2 * (len(xi) - 1) + 1)


def _free_index(dp):
    index = -np.ones(2 * dp.n_nodes, dtype=int)
    index[dp.free] = np.arange(dp.n)
    return index


def z_to_hermite(dp, h) -> sp.csr_matrix:
    """Sparse system ``A U = C z`` from free quadratic z-DOFs to free Hermite DOFs (P3)."""
    ne = len(h)
    idx = _free_index(dp)
    rows, cols, vals, crow, ccol, cval = [], [], [], [], [], []
    r = 0
    for i in range(1, ne + 1):  # theta_i = z(vertex i) = z-dof 2i (free index 2i - 1)
        rows.append(r); cols.append(idx[2 * i + 1]); vals.append(1.0)
        crow.append(r); ccol.append(2 * i - 1); cval.append(1.0)
        r += 1
    for e in range(ne):  # w_{e+1} - w_e = h/6 (z_e + 4 z_mid + z_{e+1})
        rows.append(r); cols.append(idx[2 * (e + 1)]); vals.append(1.0)
        if e > 0:
            rows.append(r); cols.append(idx[2 * e]); vals.append(-1.0)
        for k, wgt in ((2 * e, 1.0), (2 * e + 1, 4.0), (2 * e + 2, 1.0)):
            if k > 0:
                crow.append(r); ccol.append(k - 1); cval.append(h[e] * wgt / 6)
        r += 1
    A = sp.csc_matrix((vals, (rows, cols)), shape=(dp.n, dp.n))
    C = sp.csr_matrix((cval, (crow, ccol)), shape=(dp.n, 2 * ne))
    return spla.splu(A), C


def moment_to_hermite(dp, h):
    """Sparse system ``A U = C m`` for ``w'' = -m`` (discontinuous linear m), P4 supports."""
    ne = len(h)
    idx = _free_index(dp)
    rows, cols, vals, crow, ccol, cval = [], [], [], [], [], []

    def put(r, dof, v):
        if idx[dof] >= 0:
            rows.append(r); cols.append(idx[dof]); vals.append(v)

    for e in range(ne):
        r = 2 * e  # theta_{e+1} - theta_e = -h (mL + mR) / 2
        put(r, 2 * e + 3, 1.0); put(r, 2 * e + 1, -1.0)
        crow += [r, r]; ccol += [2 * e, 2 * e + 1]; cval += [-h[e] / 2, -h[e] / 2]
        r = 2 * e + 1  # w_{e+1} - w_e - h theta_e = -h^2 (2 mL + mR) / 6
        put(r, 2 * e + 2, 1.0); put(r, 2 * e, -1.0); put(r, 2 * e + 1, -h[e])
        crow += [r, r]; ccol += [2 * e, 2 * e + 1]; cval += [-h[e]**2 / 3, -h[e]**2 / 6]
    A = sp.csc_matrix((vals, (rows, cols)), shape=(dp.n, dp.n))
    C = sp.csr_matrix((cval, (crow, ccol)), shape=(dp.n, 2 * ne))
    return spla.splu(A), C

