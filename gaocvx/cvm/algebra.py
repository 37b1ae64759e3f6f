"""Accurate linear algebra for CVM's reduced problem on fine meshes.

The Hermite bending matrix K has condition number ~N^4, and ``K U`` cancels
terms of size N^3: anything CVM computes as a product with K or a banded
Cholesky solve with it loses ~N^4 eps (everything at 16384 elements).  This
module provides what :mod:`gaocvx.cvm` and :mod:`gaocvx.cvm.minimizers` use
instead, each in O(N) time and memory:

* :func:`nonlinear_gradient` and :func:`nonlinear_hessian`: the Gao, axial and
  foundation parts of the beam's gradient and Hessian, from slopes and
  deflections at quadrature points (never ``grad Pi - (K U - f)``);
* :class:`BendingSolver`: ``K^-1 b`` in the well-conditioned mixed variables
  of :mod:`gaocvx.mixed`;
* :func:`saddle_inverse` and :meth:`BendingSolver.saddle_inverse`:
  ``(B' A^-1 B)^-1 g`` by a sparse bordered system, the bending preconditioner
  of the matrix-free projected Newton method (T2's A = E, T1's A = K in the
  mixed variables).
"""

from __future__ import annotations

import copy

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..discrete import DiscreteProblem

__all__ = ["nonlinear_gradient", "nonlinear_hessian", "BendingSolver", "saddle_inverse"]


def nonlinear_gradient(dp: DiscreteProblem, U) -> np.ndarray:
    """Gradient of the Gao, axial and foundation energies at free Hermite DOFs U.

    From slopes and deflections at quadrature points, never as
    ``grad Pi - (K U - f)``: K U cancels terms of size N^3, which would put
    ~N^4 eps of noise into the controls' gradient on fine meshes.
    """
    r = np.zeros(dp.n)
    if dp.needs_gao or dp.p:
        s = dp.B1 @ U
        r += dp.B1T @ (dp.wq_gao * ((dp.a / 3.0) * s**3 - dp.p * s))
    if dp.contact == "foundation":
        pen = dp.penetration(dp.g - dp.Nq @ U)
        r -= dp.NqT @ (dp.c * dp.wq_c * pen)
    return r


def nonlinear_hessian(dp: DiscreteProblem, U) -> sp.csr_matrix:
    """(Generalised) Hessian of the Gao, axial and foundation energies at U; banded.

    The beam's Hessian is ``K + nonlinear_hessian``; kept apart so that K is
    never applied to a state (see :func:`nonlinear_gradient`).
    """
    H = sp.csr_matrix((dp.n, dp.n))
    if dp.needs_gao or dp.p:
        s = dp.B1 @ U
        H = H + dp.B1T @ sp.diags(dp.wq_gao * (dp.a * s**2 - dp.p)) @ dp.B1
    if dp.contact == "foundation":
        active = (dp.g - dp.Nq @ U) > 0 if not dp.bilateral else 1.0
        H = H + dp.NqT @ sp.diags(dp.c * dp.wq_c * active) @ dp.Nq
    return H.tocsr()


class BendingSolver:
    """Solves ``K U = b`` with the Hermite bending matrix K in well-conditioned variables.

    K has condition number ~N^4: a banded Cholesky solve loses ~N^4 eps
    (1e-4 of a cantilever's tip deflection at 2048 elements, everything at
    16384).  The same system in the mixed variables of :mod:`gaocvx.mixed`
    (deflections, slopes, chord slopes; an exact re-parametrisation of the
    Hermite space) has only first differences and is solved by one banded LU
    of its KKT matrix, factored once per mesh and shared with the ground
    truth's solver.
    """

    def __init__(self, dp: DiscreteProblem):
        from ..mixed import MixedForm
        flat = copy.copy(dp)
        flat.p = 0.0  # K alone, without the axial part
        self.mf = MixedForm(flat)
        self.factor = self.mf.quadratic_factor
        self.dp = dp

    def solve(self, b) -> np.ndarray:
        """``K^-1 b`` for a load vector b on the free Hermite DOFs."""
        dp, mf = self.dp, self.mf
        F = np.zeros(2 * dp.n_nodes)
        F[dp.free] = b
        fz = np.zeros(mf.nz)
        fz[0::3] = F[0::2]  # the load acts on the deflections and slopes only
        fz[1::3] = F[1::2]
        z, _ = self.factor.solve(fz[mf.free], np.zeros(mf.N))
        return mf.to_hermite(z)

    def load_map(self) -> sp.csr_matrix:
        """The sparse 0/1 matrix taking a Hermite load vector to the mixed variables' load."""
        dp, mf = self.dp, self.mf
        herm = np.asarray(dp.free)
        position = -np.ones(mf.nz, dtype=int)
        position[mf.free] = np.arange(len(mf.free))
        rows = position[3 * (herm // 2) + herm % 2]  # w_i -> 3i, theta_i -> 3i + 1
        return sp.csr_matrix((np.ones(len(herm)), (rows, np.arange(len(herm)))),
                             shape=(len(mf.free), dp.n))

    def saddle_inverse(self, B):
        """``g -> (B' K^-1 B)^-1 g`` in O(N), B a sparse load map of full column rank.

        The bordered system of :func:`saddle_inverse` written in the mixed
        variables, ``[[Kb, C', Bm], [C, 0, 0], [Bm', 0, 0]]`` (Kb the bending
        matrix, C the chord-slope links, Bm = B's loads on them): with the
        Hermite K the same sparse LU left a residual of 300 % at 16384
        elements, here about 1e-9.  The columns of Bm are scaled to unit norm.
        """
        m = B.shape[1]
        if m == 0:
            return lambda g: np.zeros(0)
        mf = self.mf
        Bm = (self.load_map() @ B).tocsc()
        d2 = 1.0 / np.sqrt(np.asarray(Bm.multiply(Bm).sum(axis=0)).ravel())
        Bm = Bm @ sp.diags(d2)
        try:
            lu = spla.splu(sp.bmat([[mf.bending, mf.C.T, Bm], [mf.C, None, None],
                                    [Bm.T, None, None]]).tocsc())
        except RuntimeError:  # B not of full column rank: more controls than states
            return _dense_pseudo_inverse(B, self.solve)
        n = mf.bending.shape[0] + mf.C.shape[0]

        def solve(g):
            rhs = np.concatenate([np.zeros(n), d2 * np.asarray(g, float)])
            return -d2 * lu.solve(rhs)[n:]

        return solve


def saddle_inverse(A, B):
    """``g -> (B' A^-1 B)^-1 g`` for SPD sparse A and B of full column rank, in O(N).

    ``(B'A^-1B)^-1`` is dense, but ``[[A, B], [B', 0]] [y; z] = [0; g]`` gives
    ``z = -(B'A^-1B)^-1 g``; the bordered system is sparse and is factored
    once.  It is first scaled symmetrically (A to a unit diagonal, the columns
    of B to unit norm): the entries of A and B differ by ~N^4 on fine meshes.
    """
    m = B.shape[1]
    if m == 0:
        return lambda g: np.zeros(0)
    d1 = 1.0 / np.sqrt(A.diagonal())
    Bs = sp.diags(d1) @ B
    d2 = 1.0 / np.sqrt(np.asarray(Bs.multiply(Bs).sum(axis=0)).ravel())
    Bs = Bs @ sp.diags(d2)
    As = sp.diags(d1) @ A @ sp.diags(d1)
    try:
        lu = spla.splu(sp.bmat([[As, Bs], [Bs.T, None]]).tocsc())
    except RuntimeError:  # B not of full column rank: more controls than states
        return _dense_pseudo_inverse(B, spla.splu(sp.csc_matrix(A)).solve)
    n = A.shape[0]

    def solve(g):
        rhs = np.concatenate([np.zeros(n), d2 * np.asarray(g, float)])
        return -d2 * lu.solve(rhs)[n:]

    return solve


# Beyond this many controls a rank-deficient B is not expected (it needs more controls
# than states: one or two elements) and the dense fallback would cost O(m^2) memory.
DENSE_LIMIT = 400


def _dense_pseudo_inverse(B, solve_A):
    """``g -> (B' A^-1 B)^+ g``, dense, where B has more columns than its rank.

    On meshes of one or two elements the piecewise-linear control has more
    values than the state has DOFs, S is not injective and ``B'A^-1B`` is
    singular; the reduced gradient lies in its range, where the pseudo-inverse
    is the inverse, so the certificate's bound keeps its meaning.
    """
    m = B.shape[1]
    if m > DENSE_LIMIT:
        raise np.linalg.LinAlgError(f"the control map is rank-deficient with {m} controls")
    Bd = B.toarray()
    AinvB = np.column_stack([solve_A(Bd[:, j]) for j in range(m)]) if m else Bd
    pinv = np.linalg.pinv(Bd.T @ AinvB, hermitian=True)
    return lambda g: pinv @ np.asarray(g, float)
