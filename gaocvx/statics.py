"""Statics of a result: element end forces, shear force and bending moment.

:class:`Statics` is what :attr:`gaocvx.result.Result` uses for its support
reactions, shear and moment (see the class's notes for how they are made
exact for the Euler-Bernoulli beam).
"""

from __future__ import annotations

import numpy as np

from . import fem

__all__ = ["Statics"]


_GAUSS5 = np.polynomial.legendre.leggauss(5)
_T5, _W5 = 0.5 * (_GAUSS5[0] + 1.0), 0.5 * _GAUSS5[1]   # on [0, 1]
_POWERS = np.array([0, 1, 0, 1])                          # powers of h per Hermite DOF


def _local(m, h, denominator_power):
    h = h[:, None, None]
    return m[None] * h ** (_POWERS[None, :, None] + _POWERS[None, None, :]) / h**denominator_power


def _bending_local(h):
    """Element bending matrices K_e / EI (physics.md (3.27)), shape (ne, 4, 4)."""
    m = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], float)
    return _local(m, h, 3)


def _geometric_local(h):
    """Element geometric matrices G_e of ``∫ w' v'`` (physics.md (3.40)), shape (ne, 4, 4)."""
    m = np.array([[36, 3, -36, 3], [3, 4, -3, -1], [-36, -3, 36, -3], [3, -1, -3, 4]], float)
    return _local(m, h, 1) / 30.0


def _element_vectors(x, xq, values, elem):
    """Per-element consistent vectors ``Σ_q values_q N(x_q)``, shape (ne, 4)."""
    h = x[elem + 1] - x[elem]
    out = np.zeros((len(x) - 1, 4))
    np.add.at(out, elem, fem.shape_functions((xq - x[elem]) / h, h, 0) * values[:, None])
    return out


class Statics:
    """Element equilibrium of a result: end forces, then the loads inside each element.

    The end forces of element e are ``F_e = K_e u_e - P mu G_e u_e + gao_e(u_e) - f_e``,
    with ``f_e`` every load acting inside the element (the distributed load,
    point forces between its nodes, the foundation's pressure, obstacle
    forces): what the neighbours, or a support, exert on the element.  Whatever
    u_e is, they balance the element's loads exactly (the element matrices
    annihilate rigid translations; a rigid rotation sees only the axial and Gao
    terms).  From them, for x in element e::

        V(x) = F_e[0] + ∫_{x_e}^x (f + foundation pressure) + Σ_{x_e < x_k <= x} F_k
        M(x) = -F_e[1] + ∫_{x_e}^x (V - P mu w' + E_alpha/3 w'^3)

    so M' = V - P mu w' + E_alpha/3 w'^3 exactly, and V' is the load itself.
    For the Euler-Bernoulli beam at P = 0 (nodally exact) both are the exact
    shear and moment.  Units are the energy's: loads carry the Gao factor
    1 - nu^2, M is EI w''.
    """

    def __init__(self, result):
        scene, beam = result.scene, result.scene.beam
        x = np.asarray(result.x, float)
        self.x, self.h, self.L = x, np.diff(x), beam.length
        self.dofs = result._dofs()
        self.lf = lf = beam.load_factor
        self.pmu = scene.load.axial * beam.mu_eff
        self.ea3 = beam.E_alpha_eff / 3.0
        ne = len(self.h)
        ue = np.stack([result.w[:-1], result.slope[:-1], result.w[1:], result.slope[1:]], 1)
        F = beam.EI_eff * np.einsum("eij,ej->ei", _bending_local(self.h), ue)
        if self.pmu:
            F -= self.pmu * np.einsum("eij,ej->ei", _geometric_local(self.h), ue)
        t5 = np.broadcast_to(_T5, (ne, 5))
        xq = x[:-1, None] + self.h[:, None] * t5
        wq = self.h[:, None] * _W5[None, :]
        if self.ea3:  # (E_alpha / 3) ∫ w'^3 v': exact with 5 points (degree 8)
            d1 = fem.shape_functions(t5, self.h[:, None], 1)
            s = np.einsum("eqi,ei->eq", d1, ue)
            F += self.ea3 * np.einsum("eq,eqi->ei", wq * s**3, d1)
        # The distributed load, integrated exactly (elements split at the table's knots).
        self.q_table = None
        q = scene.load.q
        if q is not None:
            self.q_table = (np.array(q, float) if scene.load.is_table
                            else np.array([[0.0, q], [self.L, q]], float))
            xs, ws, es = fem.gauss_points_split(x, self.q_table[:, 0], 3)
            F -= lf * _element_vectors(x, xs, ws * self._q(xs), es)
        # The foundation's pressure with the discrete problem's Gauss rule.
        self.foundation = None
        if scene.contact == "foundation":
            self.foundation = scene.foundation
            n0 = fem.shape_functions(t5, self.h[:, None], 0)
            pressure = self._pressure(xq.ravel()).reshape(xq.shape)
            F -= np.einsum("eq,eqi->ei", wq * pressure, n0)
        # Point and obstacle forces: at a node they act on the node (a jump of V
        # between elements, or a force on the support); between nodes, on the element.
        pts = [np.asarray(scene.load.points, float).reshape(-1, 2)]
        if result.contact_forces is not None:
            pts.append(np.asarray(result.contact_forces, float).reshape(-1, 2))
        pts = np.concatenate(pts)
        node = np.clip(np.searchsorted(x, pts[:, 0]), 1, len(x) - 1)
        node = np.where(x[node] - pts[:, 0] < pts[:, 0] - x[node - 1], node, node - 1)
        at_node = np.abs(x[node] - pts[:, 0]) <= 1e-12 * self.L
        self.nodal = np.zeros(len(x))
        np.add.at(self.nodal, node[at_node], lf * pts[at_node, 1])
        inner = pts[~at_node]
        order = np.argsort(inner[:, 0], kind="stable")
        self.inner_x, self.inner_F = inner[order, 0], lf * inner[order, 1]
        if len(inner):
            F -= _element_vectors(x, self.inner_x, self.inner_F, fem.element_of(x, self.inner_x))
        # Cumulative sums of the inner forces and of their moments about x = 0.
        self.cum_F = np.r_[0.0, np.cumsum(self.inner_F)]
        self.cum_Fx = np.r_[0.0, np.cumsum(self.inner_F * self.inner_x)]
        self.F = F

    # -------------------------------------------------------------- the loads
    def _q(self, s):
        t = self.q_table
        return np.interp(s, t[:, 0], t[:, 1], left=0.0, right=0.0)

    def _pressure(self, s):
        """The foundation's pressure c_F (g - w)^+ [N/m, energy units] at points s.

        (g - w) without the positive part for a bonded foundation; a gap or a
        stiffness given as a table [[x, value], ...] is interpolated linearly.
        """
        fd = self.foundation
        depth = -fd.gap_at(s) - fem.eval_matrix(self.x, s, 0) @ self.dofs
        # A bonded foundation ("bilateral") pulls too: its pressure is c_F (g - w).
        return self.lf * fd.stiffness_at(s) * (depth if fd.bilateral else np.maximum(depth, 0.0))

    def _q_integrals(self, a, b):
        """∫_a^b q and ∫_a^b (b - t) q(t) dt, exactly (Simpson on each piece of the table)."""
        t = self.q_table
        lo = np.clip(a[:, None], t[None, :-1, 0], t[None, 1:, 0])
        hi = np.clip(b[:, None], t[None, :-1, 0], t[None, 1:, 0])
        mid = 0.5 * (lo + hi)
        slope = np.diff(t[:, 1]) / np.diff(t[:, 0])
        qv = lambda s: t[None, :-1, 1] + slope[None, :] * (s - t[None, :-1, 0])  # noqa: E731
        d = hi - lo
        one = d * (qv(lo) + qv(hi)) / 2.0
        bb = b[:, None]
        lever = d / 6.0 * ((bb - lo) * qv(lo) + 4.0 * (bb - mid) * qv(mid) + (bb - hi) * qv(hi))
        return one.sum(1), lever.sum(1)

    def _gauss(self, a, b, fun):
        """∫_a^b fun with 5 Gauss points (per point pair), and the lever integral ∫ (b - t) fun."""
        d = b - a
        s = a[:, None] + d[:, None] * _T5[None, :]
        vals = fun(s.ravel()).reshape(s.shape) * (d[:, None] * _W5[None, :])
        return vals.sum(1), (vals * (b[:, None] - s)).sum(1)

    # -------------------------------------------------------------- V and M
    def shear_and_moment(self, xs):
        """(V, M) at points xs (right-hand limits at nodes and point forces; left at L)."""
        xs = np.asarray(xs, float)
        e = fem.element_of(self.x, xs)
        a = self.x[e]
        d = xs - a
        V = self.F[e, 0].copy()
        M = -self.F[e, 1] + self.F[e, 0] * d
        if self.q_table is not None:
            one, lever = self._q_integrals(a, xs)
            V += self.lf * one
            M += self.lf * lever
        if self.foundation is not None:
            one, lever = self._gauss(a, xs, self._pressure)
            V += one
            M += lever
        if len(self.inner_x):
            i0 = np.searchsorted(self.inner_x, a, side="right")
            i1 = np.searchsorted(self.inner_x, xs, side="right")
            sF = self.cum_F[i1] - self.cum_F[i0]
            V += sF
            M += xs * sF - (self.cum_Fx[i1] - self.cum_Fx[i0])
        if self.pmu:
            w = lambda s: fem.eval_matrix(self.x, s, 0) @ self.dofs  # noqa: E731
            M -= self.pmu * (w(xs) - w(a))
        if self.ea3:
            slope = lambda s: fem.eval_matrix(self.x, s, 1) @ self.dofs  # noqa: E731
            M += self.ea3 * self._gauss(a, xs, lambda s: slope(s) ** 3)[0]
        return V, M

    def support_reactions(self, supports) -> list:
        """Force [N] and moment [N m] each support exerts on the beam (physical units)."""
        w0, t0, wl, tl = fem.FIXED_ENDS[supports]
        out = []
        for fixed_w, fixed_t, row, i, fw, fm in ((w0, t0, 0, 0, 0, 1), (wl, tl, -1, -1, 2, 3)):
            if not (fixed_w or fixed_t):
                continue
            force = (self.F[row, fw] - self.nodal[i]) / self.lf if fixed_w else 0.0
            moment = self.F[row, fm] / self.lf if fixed_t else 0.0
            out.append({"x": float(self.x[i]), "force": float(force) + 0.0,
                        "moment": float(moment) + 0.0})
        return out
