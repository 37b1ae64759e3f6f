"""The CVM transforms T1, T2, T3: state, cost, adjoint and gradient (see :mod:`gaocvx.cvm`)."""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import fem
from ..discrete import DiscreteProblem
from ..errors import SceneError
from ..linalg import BandedCholesky
from .algebra import BendingSolver, nonlinear_gradient, nonlinear_hessian, saddle_inverse
from .spaces import (broken_linear_matrix, hat_matrix, load_knots, moment_to_hermite,
                     quadratic_matrix, z_to_hermite)

__all__ = ["make_transform", "shear_load", "moment_load", "AUTO", "ALLOWED"]

AUTO = {"P1": "T1", "P2": "T1", "P3": "T2", "P4": "T3"}
ALLOWED = {"T1": ("P1", "P2", "P3", "P4"), "T2": ("P3",), "T3": ("P4",)}


# ------------------------------------------------------------------ transformed loads
def _load_primitives(dp: DiscreteProblem):
    """Functions Q1(x) = ∫_0^x q and Q2(x) = ∫_0^x (x - s) q(s) ds of the non-dim load."""
    table = dp.q_table
    if table is None:
        zero = lambda x: np.zeros_like(np.asarray(x, float))  # noqa: E731
        return zero, zero
    # The table is zero outside its range: add those pieces explicitly.
    xs, qs = list(table[:, 0]), list(table[:, 1])
    if xs[0] > 0:
        xs, qs = [0.0, xs[0]] + xs, [0.0, 0.0] + qs
    if xs[-1] < 1:
        xs, qs = xs + [xs[-1], 1.0], qs + [0.0, 0.0]
    xs, qs = np.array(xs), np.array(qs)
    dx = np.diff(xs)
    q1 = np.concatenate([[0.0], np.cumsum(0.5 * dx * (qs[:-1] + qs[1:]))])
    q2 = np.concatenate([[0.0], np.cumsum(dx * q1[:-1] + dx**2 * (2 * qs[:-1] + qs[1:]) / 6)])

    def piece(x):
        x = np.asarray(x, float)
        k = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, len(xs) - 2)
        while np.any(dx[k] == 0):  # a zero-length piece (a jump): step over it
            k = np.where(dx[k] == 0, k + 1, k)
        s = x - xs[k]
        slope = (qs[k + 1] - qs[k]) / dx[k]
        return k, s, slope

    def Q1(x):
        k, s, slope = piece(x)
        return q1[k] + qs[k] * s + slope * s**2 / 2

    def Q2(x):
        k, s, slope = piece(x)
        return q2[k] + q1[k] * s + qs[k] * s**2 / 2 + slope * s**3 / 6

    return Q1, Q2


def shear_load(dp: DiscreteProblem, x) -> np.ndarray:
    """T2's transformed load G(x) = ∫_x^1 f + Σ_{x_k > x} F_k (non-dimensional)."""
    Q1, _ = _load_primitives(dp)
    x = np.asarray(x, float)
    G = Q1(1.0) - Q1(x)
    for xk, Fk in dp.point_forces:
        G = G + Fk * (xk > x)
    return G


def moment_load(dp: DiscreteProblem, x) -> np.ndarray:
    """T3's transformed load: -G'' = f, G(0) = G(1) = 0 (non-dimensional)."""
    _, Q2 = _load_primitives(dp)
    x = np.asarray(x, float)
    pts = dp.point_forces
    c = Q2(1.0) + sum(Fk * (1.0 - xk) for xk, Fk in pts)
    G = c * x - Q2(x)
    for xk, Fk in pts:
        G = G - Fk * np.maximum(x - xk, 0.0)
    return G


# ------------------------------------------------------------------ transforms
class _Transform:
    """The affine state map ``U(u) = U0 + S u`` with the thesis's cost and adjoint.

    Subclasses set ``m`` (number of controls), ``scale`` (physical value of one
    non-dimensional control unit, for reporting ``bound``), and implement
    ``_state``, ``_cost``, ``_adjoint_gradient``, ``apply_S`` and ``apply_ST``.
    """

    name = ""
    unit = ""

    def __init__(self, dp: DiscreteProblem, control: str):
        self.dp = dp
        self.control = control

    def state(self, u) -> np.ndarray:
        """Hermite free DOFs (non-dimensional) of the state for control ``u``."""
        return self.U0 + self.apply_S(u)

    def cost(self, u, U=None) -> float:
        """The thesis's transformed cost J(u)."""
        U = self.state(u) if U is None else U
        return self._cost(u, U)

    def gradient(self, u, U=None) -> np.ndarray:
        """Gradient of J via the discrete adjoint."""
        U = self.state(u) if U is None else U
        return self._adjoint_gradient(u, U)

    def state_hessian(self, U) -> sp.csr_matrix:
        """The nonlinear part ``Hn`` of the beam's (generalised) Hessian at U (banded).

        The beam's Hessian is ``K + Hn``; :meth:`hessian_vector` applies the
        K part through the state equation, without multiplying a state by K.
        """
        return nonlinear_hessian(self.dp, U)

    def hessian_vector(self, Hn, v) -> np.ndarray:
        """The reduced Hessian times v, ``S'(K + Hn)S v``: one state and one adjoint solve.

        ``J(u) = Pi(U0 + S u) + const`` (tested), so this is the exact
        (generalised) Hessian of the reduced cost; it is never formed.
        """
        raise NotImplementedError

    def bending_preconditioner(self, free):
        """``g -> (S_F' K S_F)^-1 g``: the inverse reduced Hessian of the bending energy alone.

        ``S_F`` is S restricted to the controls ``free`` (a boolean mask) and K
        the bending matrix.  The reduced Hessian ``S'HS`` differs from
        ``S'KS`` by the Gao, axial and foundation terms, which are of lower
        order, so the preconditioned operator has eigenvalues in
        ``[theta, 1 + (lower-order terms)]`` independent of N, where ``S'HS``
        itself has condition number ~N^4 (T1).  Built once per free set: a
        sparse factorisation, O(N) memory.
        """
        raise NotImplementedError

    def curvature_floor(self) -> float:
        """theta > 0 with ``v'Hv >= theta v'Kv`` for every v and every state: proved.

        H = K - p G + (Gao and foundation terms, positive semidefinite), so
        ``theta = 1 - p / p_bar_h`` for compression, with p_bar_h the lower
        end of the enclosure of the convexity limit (:mod:`gaocvx.limit`), and
        1 otherwise.
        """
        dp = self.dp
        if not dp.p > 0:
            return 1.0
        from .. import limit
        lower = limit.analysis(dp).enclosure().lower
        return max(1.0 - dp.p / lower, 0.0) or math.nan

    def nonlinear(self, U) -> float:
        parts = self.dp.energy_parts(U)
        return parts["gao"] + parts["axial"] + parts["foundation"]


class _T1(_Transform):
    name = "T1"

    def __init__(self, dp, control):
        super().__init__(dp, control)
        self.chol = BendingSolver(dp)
        n = dp.n
        if control == "full":
            self.B = sp.identity(n, format="csr")
            self.unit = "N (load-vector entries)"
            self.scale = dp.EI * dp.W / dp.L**3
        else:
            # Hat functions on the nodes: (u_h, v) for Hermite test functions v.
            xq, wq, e = fem.gauss_points(dp.xi, 3)
            hats = hat_matrix(dp.xi, xq, e)
            N = fem.eval_matrix(dp.xi, xq, 0, e)[:, dp.free]
            self.B = (N.T @ sp.diags(wq) @ hats).tocsr()
            if dp.scene.beam.supports == "P3":
                # The thesis's end control r: a point force -r at the free end (1.114).
                end = np.zeros((n, 1))
                end[list(dp.free).index(2 * (dp.n_nodes - 1)), 0] = -1.0
                self.B = sp.hstack([self.B, sp.csr_matrix(end)]).tocsr()
            self.unit = "N/m"
            self.scale = dp.EI * dp.W / dp.L**4
        self.m = self.B.shape[1]
        self.U0 = self.chol.solve(dp.f)  # w_hat = w(0)

    def apply_S(self, u):
        return self.chol.solve(self.B @ u)

    def hessian_vector(self, Hn, v):
        # K S v = B v exactly: the state equation, no product with K.
        return self.apply_ST(self.B @ v + Hn @ self.apply_S(v))

    def bending_preconditioner(self, free):
        # S'KS = B'K^-1 K K^-1 B = B'K^-1 B
        return self.chol.saddle_inverse(self.B[:, np.flatnonzero(free)])

    def apply_ST(self, y):
        return self.B.T @ self.chol.solve(y)

    def _cost(self, u, U):
        return 0.5 * (self.B @ u) @ (U - self.U0) + self.nonlinear(U)

    def _adjoint_gradient(self, u, U):
        # p + (w - w_hat)/2 with p = K^-1 (Bu/2 + grad N) and w - w_hat = K^-1 B u, in one
        # solve: w - w_hat taken from the state would carry the state solve's round-off
        # unsmoothed into the gradient (a decrement of 6e-7 at 2048 elements, P4).
        return self.B.T @ self.chol.solve(self.B @ u + nonlinear_gradient(self.dp, U))


class _T2(_Transform):
    name = "T2"

    def __init__(self, dp, control):
        super().__init__(dp, control)
        xi = dp.xi
        h = np.diff(xi)
        xq, wq, e = fem.gauss_points(xi, 3)
        P = quadratic_matrix(xi, xq, e)
        D = quadratic_matrix(xi, xq, e, deriv=1)
        free = np.arange(1, P.shape[1])  # z(0) = 0
        W = sp.diags(wq)
        self.E = (D.T @ W @ D)[free][:, free].tocsr()
        self.echol = BandedCholesky(self.E)
        # (G, phi): G is piecewise quadratic with kinks at the load table's knots,
        # which may lie inside elements: split there for an exact integral.
        xg, wg, eg = fem.gauss_points_split(xi, load_knots(dp), 3)
        self.Gv = (quadratic_matrix(xi, xg, eg).T @ (wg * shear_load(dp, xg)))[free]
        if control == "full":
            self.Bz = sp.identity(len(free), format="csr")
            self.unit = "N (load-vector entries)"
        else:
            self.Bz = (P.T @ W @ hat_matrix(xi, xq, e))[free].tocsr()
            self.unit = "N"
        self.scale = dp.EI * dp.W / dp.L**3
        self.m = self.Bz.shape[1]
        # z -> Hermite DOFs: theta_i = z(x_i); w_{i+1} - w_i = h/6 (z_i + 4 z_mid + z_{i+1}).
        self.A_lu, self.C = z_to_hermite(dp, h)
        self.z0 = self.echol.solve(self.Gv)
        self.U0 = self.T(self.z0)

    def T(self, z):
        return self.A_lu.solve(np.asarray(self.C @ z))

    def TT(self, y):
        return self.C.T @ self.A_lu.solve(np.asarray(y), trans="T")

    def apply_S(self, u):
        return self.T(self.echol.solve(self.Bz @ u))

    def hessian_vector(self, Hn, v):
        # T'KT = E (w = ∫ z exactly), so S'KSv = Bz'E^-1 Bz v.
        return self.Bz.T @ self.echol.solve(self.Bz @ v + self.TT(Hn @ self.apply_S(v)))

    def bending_preconditioner(self, free):
        # w = ∫ z exactly, so the bending energy is ½ z'Ez and S'KS = Bz'E^-1 Bz.
        return saddle_inverse(self.E, self.Bz[:, np.flatnonzero(free)])

    def apply_ST(self, y):
        return self.Bz.T @ self.echol.solve(self.TT(y))

    def _cost(self, u, U):
        z = self.echol.solve(self.Gv + self.Bz @ u)
        return 0.5 * (self.Bz @ u) @ (z - self.z0) + self.nonlinear(U)

    def _adjoint_gradient(self, u, U):
        # p + (z - z_hat)/2 = E^-1 (Bz u + T' grad N) in one solve (see _T1._adjoint_gradient).
        return self.Bz.T @ self.echol.solve(self.Bz @ u + self.TT(nonlinear_gradient(self.dp, U)))


class _T3(_Transform):
    name = "T3"

    def __init__(self, dp, control):
        super().__init__(dp, control)
        xi = dp.xi
        ne = len(xi) - 1
        h = np.diff(xi)
        xq, wq, e = fem.gauss_points(xi, 3)
        Pd = broken_linear_matrix(xi, xq, e)
        self.Md = (Pd.T @ sp.diags(wq) @ Pd).tocsc()
        # L2 projection of the load moment G onto discontinuous linears: G is
        # piecewise cubic with knots at the load table's, possibly inside elements.
        xq4, wq4, e4 = fem.gauss_points_split(xi, load_knots(dp), 3)
        self.Md_lu = spla.splu(self.Md)
        self.mG = self.Md_lu.solve(broken_linear_matrix(xi, xq4, e4).T
                                   @ (wq4 * moment_load(dp, xq4)))
        if control == "full":
            self.Q = sp.identity(2 * ne, format="csr")
        else:
            # Continuous linear control vanishing at both ends (U_ad^0): nodal values 1..N-1.
            r = np.concatenate([2 * np.arange(ne), 2 * np.arange(ne) + 1])
            c = np.concatenate([np.arange(ne), np.arange(ne) + 1])
            Q = sp.csr_matrix((np.ones(2 * ne), (r, c)), shape=(2 * ne, ne + 1))
            self.Q = Q[:, 1:ne].tocsr()
        self.unit = "N m"
        self.scale = dp.EI * dp.W / dp.L**2
        self.m = self.Q.shape[1]
        self.A_lu, self.C = moment_to_hermite(dp, h)
        self.U0 = self.A_lu.solve(self.C @ self.mG)

    def apply_S(self, u):
        return self.A_lu.solve(np.asarray(self.C @ (self.Q @ u)))

    def hessian_vector(self, Hn, v):
        # The bending energy is ½ ∫ m^2 (w'' = -m exactly): S'KSv = Q'Md Q v.
        return self.Q.T @ (self.Md @ (self.Q @ v)) + self.apply_ST(Hn @ self.apply_S(v))

    def bending_preconditioner(self, free):
        # w'' = -(Pi G + u) exactly, so the bending energy is ½ ∫ m^2 and
        # S'KS = Q'Md Q: tridiagonal, well conditioned (the mass matrix of the controls).
        idx = np.flatnonzero(free)
        if len(idx) == 0:
            return lambda g: np.zeros(0)
        lu = spla.splu((self.Q.T @ self.Md @ self.Q)[idx][:, idx].tocsc())
        return lu.solve

    def apply_ST(self, y):
        return self.Q.T @ (self.C.T @ self.A_lu.solve(np.asarray(y), trans="T"))

    def _cost(self, u, U):
        ud = self.Q @ u
        return 0.5 * ud @ (self.Md @ ud) + self.nonlinear(U)

    def _adjoint_gradient(self, u, U):
        # Adjoint state of the moment-deflection system, loaded by the nonlinear forces.
        p = self.C.T @ self.A_lu.solve(nonlinear_gradient(self.dp, U), trans="T")
        return self.Q.T @ (self.Md @ (self.Q @ u) + p)



def make_transform(dp: DiscreteProblem, transform: str = "auto", control: str = "P1") -> _Transform:
    """The CVM transform of a discrete scene.

    Raises
    ------
    SceneError
        For a transform that does not fit the supports, or a rigid obstacle.
    """
    supports = dp.scene.beam.supports
    if dp.contact == "obstacle":
        raise SceneError("solve.method", "cvm handles a deformable foundation or none, not a "
                         "rigid obstacle; use \"convex\" or \"auto\"", "cvm")
    name = AUTO[supports] if transform == "auto" else transform
    if supports not in ALLOWED[name]:
        raise SceneError("solve.transform", f"{name} is for supports "
                         f"{', '.join(ALLOWED[name])}, not {supports}", transform)
    return {"T1": _T1, "T2": _T2, "T3": _T3}[name](dp, control)

