"""The discrete energy above P_bar_h, assembled apart from gaocvx, with local searches.

Written for the verification of the global method (issue 10): the Shor
relaxation (tests/shor.py) and the random campaign
(tests/nonconvex_campaign_support.py) both need the discrete energy of a scene
with every contact model gaocvx accepts, in float64 and fast enough for many
local minimisations.  The element arrays come from tests/independent.py
(physics.md's K_e, G_e, Hermite shape functions and 5-point Gauss rule, written
from the spec); what is added here is written from docs/model.md and
scene-format.md alone:

* surface profiles: a foundation's or obstacle's ``gap`` and a foundation's
  ``stiffness`` may be piecewise-linear tables, constant beyond their rows,
  evaluated at each contact point (``np.interp`` does exactly that);
* a bonded foundation: ``1/2 c (w - g)^2`` at every Gauss point;
* an obstacle: ``w >= -gap(x)`` at the nodes and the 5 Gauss points of every
  element; a channel adds ``w <= gap_above`` on the same points.

The energy and its gradient are evaluated element by element from each
element's own four DOFs (its end curvatures and Gauss-point slopes through the
differences ``w2 - w1``, ``h theta``), summed in long double: their round-off
grows like N eps.  The globally assembled float64 ``K``, ``G`` (kept as
attributes for the eigen-solves and the Shor relaxation) multiply nodal values
by ``12 / h^3``: through them the energy was 3e-8 of its scale off at 256
elements and 5e-8 at 1024, above the campaign's 1e-8, and the KKT check's
stationarity floor was 6e-8 at 512 elements
(tests/test_nonconvex_independent_accuracy.py: against 40 digits, 0 and 1e-14).

Nothing of gaocvx's numerics is imported; the node positions come from
``gaocvx.DiscreteProblem(scene).x`` (through :class:`independent.BeamProblem`),
as for the independent reference.

Units: free Hermite DOFs ``x`` of ``w / W`` and ``w' L / W`` (``L = 1`` after
``xi = x / L``), energies in ``E0 = EI W^2 / L^3``, as tests/independent.py.

Examples
--------
>>> from gaocvx import Scene
>>> beam = {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
...         "half_thickness": 0.1, "width": 1.0}
>>> en = Discrete(Scene.from_dict({"beam": beam, "load": {"axial": 1.3e9},
...                                "mesh": {"elements": 4}}), W=0.01)
>>> e, g = en(np.zeros(en.n))
>>> float(e), float(abs(g).max())           # w = 0 is an equilibrium without load
(0.0, 0.0)
>>> en.unstable_modes()                      # 1.3e9 N is above P_bar_h = 1.17e9 N
1
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla
import scipy.optimize as so

from independent import BeamProblem

LD = np.longdouble

__all__ = ["Discrete", "MARGIN"]

# A mode whose load lies within this relative distance below P counts as unstable
# (nonconvex.md's margin).
MARGIN = 1e-8


def _at(profile, xs):
    """A number or a piecewise-linear table [[x, v], ...] (constant beyond it) at xs."""
    if isinstance(profile, (tuple, list)):
        t = np.asarray(profile, float)
        return np.interp(xs, t[:, 0], t[:, 1])
    return np.full(np.shape(xs), float(profile))


class Discrete:
    """The discrete energy of a scene in the deflection scale ``W`` [m].

    Parameters
    ----------
    scene : gaocvx.scene.Scene
    W : float
        Deflection scale [m] (the unknowns are ``w / W``).

    Attributes
    ----------
    n : int
        Number of free DOFs.
    K, G : ndarray
        Bending and geometric matrices on the free DOFs (``G``: ``x'Gx = ∫(w')^2``).
    A, lower, upper : ndarray or None
        Obstacle rows (values of w at the nodes and Gauss points), their levels
        ``A x >= lower`` and, for a channel, ``A x <= upper``.
    E0 : float
        Energy unit [J].
    """

    def __init__(self, scene, W: float):
        bp = BeamProblem(scene)
        self.bp, self.W, self.L = bp, float(W), bp.L
        self.E0 = bp.EI * self.W**2 / bp.L**3
        n_all = bp.ndof
        self.free = free = bp.free
        self.n = len(free)
        self.K, self.G, _ = pencil(bp)

        def stack(B):  # (ne, 5, 4) element rows -> dense (5 ne, free) matrix
            M = np.zeros((bp.ne * 5, n_all))
            for e in range(bp.ne):
                M[5 * e:5 * e + 5, bp.dofs[e]] = np.asarray(B[e], float)
            return M[:, free]

        self.D = stack(bp.D5)                       # w' at the Gauss points (L = 1)
        self.N = stack(bp.N5)                       # w at the Gauss points
        self.wq = np.asarray(bp.w5, float).ravel()  # Gauss weights (xi units)
        # element-local evaluation (long double): see _local
        self.h = np.asarray(bp.h, LD)
        self.t5 = np.asarray(np.polynomial.legendre.leggauss(5)[0] / 2 + 0.5, LD)
        self.w5l = np.asarray(bp.w5, LD)
        xq = np.asarray(bp.xq, float).ravel()       # Gauss points [m]
        self.p = bp.P * bp.mu * bp.L**2 / bp.EI
        self.a = bp.Ealpha * self.W**2 / bp.EI
        scale = np.zeros(n_all)
        scale[0::2] = bp.L**3 / (bp.EI * self.W)
        scale[1::2] = bp.L**2 / (bp.EI * self.W)
        self.f = (np.asarray(bp.F_phys, float) * scale)[free]
        fl = np.asarray(bp.F_phys, LD) * scale.astype(LD)
        fl[bp.fixed] = 0
        self.fl = fl                                # all DOFs, long double
        fnd, obs = scene.foundation, scene.obstacle
        self.kind = ("bonded" if fnd is not None and fnd.bilateral else
                     "foundation" if fnd is not None else "obstacle" if obs is not None else None)
        self.cq = np.zeros(len(xq))
        self.gq = np.zeros(len(xq))
        if fnd is not None:
            self.cq = bp.lf * _at(fnd.stiffness, xq) * bp.L**4 / bp.EI
            self.gq = -_at(fnd.gap, xq) / self.W
        self.cql = self.cq.reshape(bp.ne, 5).astype(LD)
        self.gql = self.gq.reshape(bp.ne, 5).astype(LD)
        self.pl = LD(bp.P) * LD(bp.mu) * LD(bp.L) ** 2 / LD(bp.EI)
        self.al = LD(bp.Ealpha) * LD(self.W) ** 2 / LD(bp.EI)
        self.A = self.lower = self.upper = None
        if obs is not None:
            nodes = np.zeros((bp.nn, n_all))
            nodes[np.arange(bp.nn), 2 * np.arange(bp.nn)] = 1.0
            rows = np.vstack([nodes[:, free], self.N])
            pts = np.concatenate([bp.x, xq])
            keep = np.any(rows != 0, axis=1)  # a node fixed at w = 0 has no row
            self.A = rows[keep]
            self.points = pts[keep]
            self.lower = -_at(obs.gap, self.points) / self.W
            if obs.gap_above is not None:
                self.upper = np.full(len(self.points), float(obs.gap_above) / self.W)

    # ------------------------------------------------------------ conversions
    def from_nodal(self, w, slope) -> np.ndarray:
        """Free DOFs of nodal deflections [m] and slopes."""
        u = np.zeros(self.bp.ndof)
        u[0::2] = np.asarray(w, float) / self.W
        u[1::2] = np.asarray(slope, float) * self.L / self.W
        return u[self.free]

    def nodal_w(self, x) -> np.ndarray:
        """Nodal deflections [m] of free DOFs x."""
        u = np.zeros(self.bp.ndof)
        u[self.free] = x
        return u[0::2] * self.W

    # ------------------------------------------------------------ energy
    def stiffness(self) -> np.ndarray:
        """The convex quadratic part's matrix: K, plus c M for a bonded foundation."""
        if self.kind != "bonded":
            return self.K
        return self.K + self.N.T @ ((self.wq * self.cq)[:, None] * self.N)

    def _local(self, x):
        """Each element's quantities from its own four DOFs, in long double.

        With ``d = w2 - w1``, ``t1 = h theta1``, ``t2 = h theta2`` (xi units) the
        element's cubic is ``w1 + t1 t + a2 t^2 + a3 t^3`` (``a2 = 3d - 2 t1 - t2``,
        ``a3 = t1 + t2 - 2d``, ``t`` in [0, 1]): its curvatures at both ends
        ``2 a2 / h^2`` and ``(2 a2 + 6 a3) / h^2`` and its slopes at the Gauss points
        carry round-off of the size of the element's own differences, not of the
        nodal values (the assembled Hermite matrices multiply nodal values by
        ``12 / h^3``: their energy's round-off grows like N^4 eps, measured up to
        3e-8 of the energy scale at 256 elements and 5e-8 at 1024).
        """
        u = np.zeros(self.bp.ndof, LD)
        u[self.free] = np.asarray(x, float)
        w, th, h = u[0::2], u[1::2], self.h
        d = w[1:] - w[:-1]
        t1, t2 = th[:-1] * h, th[1:] * h
        a2 = 3 * d - 2 * t1 - t2
        a3 = t1 + t2 - 2 * d
        T = self.t5[None, :]
        s = (t1[:, None] + 2 * a2[:, None] * T + 3 * a3[:, None] * T**2) / h[:, None]
        wq = w[:-1, None] + t1[:, None] * T + a2[:, None] * T**2 + a3[:, None] * T**3
        k0 = 2 * a2 / h**2
        k1 = (2 * a2 + 6 * a3) / h**2
        return u, h, k0, k1, s, wq

    def _parts(self, x, grad=False):
        """Energy parts (long double, E0) and, with ``grad``, the gradient (float64)."""
        u, h, k0, k1, s, wq = self._local(x)
        W5 = self.w5l
        parts = {"bending": np.sum(h * (k0 * k0 + k0 * k1 + k1 * k1)) / 6,
                 "axial": -self.pl / 2 * np.sum(W5 * s * s),
                 "gao": self.al / 12 * np.sum(W5 * s**4),
                 "load": -np.dot(self.fl, u),
                 "foundation": LD(0)}
        if self.kind in ("foundation", "bonded"):
            pen = self.gql - wq
            if self.kind == "foundation":
                pen = np.maximum(pen, 0)
            parts["foundation"] = np.sum(W5 * self.cql * pen * pen) / 2
        if not grad:
            return parts, None
        # back through the element's local quantities to its four DOFs
        T = self.t5[None, :]
        dk0 = h * (2 * k0 + k1) / 6
        dk1 = h * (k0 + 2 * k1) / 6
        da2 = 2 * (dk0 + dk1) / h**2
        da3 = 6 * dk1 / h**2
        ds = W5 * (-self.pl * s + self.al / 3 * s**3) / h[:, None]  # dE/ds_q, per 1/h
        dt1 = np.sum(ds, axis=1)
        da2 = da2 + np.sum(ds * 2 * T, axis=1)
        da3 = da3 + np.sum(ds * 3 * T**2, axis=1)
        dw1 = np.zeros_like(h)
        if self.kind in ("foundation", "bonded"):
            dwq = -W5 * self.cql * pen                                 # dE/dw_q
            dw1 = np.sum(dwq, axis=1)
            dt1 = dt1 + np.sum(dwq * T, axis=1)
            da2 = da2 + np.sum(dwq * T**2, axis=1)
            da3 = da3 + np.sum(dwq * T**3, axis=1)
        dd = 3 * da2 - 2 * da3
        dt2 = -da2 + da3
        dt1 = dt1 - 2 * da2 + da3
        ge = np.stack([dw1 - dd, h * dt1, dd, h * dt2], axis=1)
        g = np.zeros(self.bp.ndof, LD)
        np.add.at(g, self.bp.dofs, ge)
        g = g[self.free] - self.fl[self.free]
        return parts, np.asarray(g, float)

    def __call__(self, x):
        """Energy (in E0) and its gradient at free DOFs x (element by element, long double)."""
        parts, g = self._parts(x, grad=True)
        return float(sum(parts.values())), g

    def energy(self, x) -> float:
        """Energy [J] of free DOFs x."""
        parts, _ = self._parts(x)
        return float(sum(parts.values()) * LD(self.E0))

    def parts(self, x) -> dict:
        """Energy parts (in E0) of free DOFs x: bending, axial, gao, load, foundation."""
        return {k: float(v) for k, v in self._parts(x)[0].items()}

    def parts_scale(self, x) -> float:
        """Sum of |energy parts| (in E0): the scale energy tolerances are relative to."""
        return float(sum(abs(v) for v in self._parts(x)[0].values()))

    def norm_K(self, x) -> float:
        """sqrt(x' stiffness() x) from the element curvatures (and a bonded bed's w_q)."""
        u, h, k0, k1, s, wq = self._local(x)
        q = np.sum(h * (k0 * k0 + k0 * k1 + k1 * k1)) / 3
        if self.kind == "bonded":
            q = q + np.sum(self.w5l * self.cql * wq * wq)
        return math.sqrt(max(float(q), 0.0))

    def hessian(self, x, less_stiffness: bool = False) -> np.ndarray:
        """(Generalised) Hessian at x (a unilateral foundation: its active Gauss points).

        Assembled from element matrices.  ``less_stiffness``: ``H - stiffness()``
        (slopes and deflections only, no 12 / h^3 entries), for the eigenvalues of
        (H, stiffness()) as 1 + those of (H - stiffness(), stiffness()).
        """
        bp = self.bp
        _, _, _, _, s, wq = self._local(x)
        D5, N5 = bp.D5, bp.N5
        He = -self.pl * bp.Ge + self.al * np.einsum("eqi,eq,eqj->eij", D5, bp.w5 * s**2, D5)
        if self.kind in ("foundation", "bonded"):
            act = np.ones_like(s)
            if self.kind == "foundation":
                act = (self.gql - wq > 0).astype(LD)
            if not (less_stiffness and self.kind == "bonded"):
                He = He + np.einsum("eqi,eq,eqj->eij", N5, bp.w5 * self.cql * act, N5)
        if not less_stiffness:
            He = He + bp.Ke
        n_all = bp.ndof
        H = np.zeros((n_all, n_all))
        np.add.at(H, (bp.dofs[:, :, None], bp.dofs[:, None, :]), np.asarray(He, float))
        return H[np.ix_(self.free, self.free)]

    # ------------------------------------------------------------ structure
    def modes(self, count: int):
        """The first ``count`` eigenpairs of (stiffness(), G), G-normalised."""
        count = min(count, self.n)
        return sla.eigh(self.stiffness(), self.G, subset_by_index=[0, count - 1])

    def unstable_modes(self) -> int:
        """k: the number of modes with load at most p (1 + MARGIN)."""
        lam = sla.eigh(self.stiffness(), self.G, eigvals_only=True)
        return int(np.sum(lam <= self.p * (1.0 + MARGIN)))

    def constraints(self):
        """(rows, levels) of every obstacle inequality as ``R x >= r`` (empty without one)."""
        if self.A is None:
            return np.zeros((0, self.n)), np.zeros(0)
        R, r = [self.A], [self.lower]
        if self.upper is not None:
            R.append(-self.A)
            r.append(-self.upper)
        return np.vstack(R), np.concatenate(r)

    # ------------------------------------------------------------ checks
    def kkt(self, x) -> dict:
        """Optimality measures of x as a local minimiser (relative, in the K metric).

        ``stationarity``: ``||g - R_T' lam||_{K^-1} / ||x||_K`` (``||x||_K`` at least
        1e-6 of the unsupported linear answer's) with multipliers
        ``lam >= 0`` of the touching rows (slack <= 1e-9 of max |x|, 1) from a
        non-negative least-squares fit; ``feasibility``: the largest violation
        relative to max(|x|, 1); ``lowest``: the smallest eigenvalue of the
        Hessian relative to K's (generalised), restricted to the null space of
        the rows that carry a clear reaction (a necessary second-order
        condition only without an obstacle; with one it is reported, not
        judged).
        """
        _, g = self(x)
        R, r = self.constraints()
        size = max(float(np.max(np.abs(x), initial=0.0)), 1.0)
        Kc = np.linalg.cholesky(self.stiffness())
        slack = R @ x - r
        touch = np.flatnonzero(slack <= 1e-9 * size)
        lam = np.zeros(len(r))
        y = sla.solve_triangular(Kc, g, lower=True)
        if len(touch):
            M = sla.solve_triangular(Kc, R[touch].T, lower=True)
            lam_t, _ = so.nnls(M, y, maxiter=50 * len(touch) + 500)
            lam[touch] = lam_t
            y = y - M @ lam_t
        norm_x = max(self.norm_K(x), 1e-150)
        # An answer pressed flat onto an obstacle is w = 0 to round-off: relative to its
        # own norm (1e-32) any residual is huge.  Floor: 1e-6 of the unsupported linear
        # answer's norm, ||K^-1 g(0)||_K (the floor the package documents for such answers).
        _, g0 = self(np.zeros_like(x))
        floor = 1e-6 * float(np.linalg.norm(sla.solve_triangular(Kc, g0, lower=True)))
        norm_x = max(norm_x, floor)
        # (H, S) as 1 + (H - S, S): H - S has no 12 / h^3 entries, whose round-off in
        # H would shift the lowest eigenvalue by ~ N^3 eps relative (1e-7 at 1024 elements)
        A = self.hessian(x, less_stiffness=True)
        strong = np.flatnonzero(lam > 1e-6 * max(float(np.max(lam, initial=0.0)), 1e-300))
        Z = sla.null_space(R[strong]) if len(strong) else np.eye(self.n)
        S = self.stiffness()
        lowest = (1.0 + float(sla.eigh(Z.T @ A @ Z, Z.T @ S @ Z, eigvals_only=True)[0])
                  if Z.shape[1] else 0.0)
        return {"stationarity": float(np.linalg.norm(y)) / norm_x,
                "feasibility": float(max(0.0, -np.min(slack, initial=0.0))) / size,
                "lowest": lowest, "touching": int(len(touch)), "multipliers": lam}

    # ------------------------------------------------------------ local search
    SLSQP_ITER = 400  # the campaign's --slsqp-iter sets it
    # An end point outside the rows by more than this (relative to max(|x|, 1)) is
    # no evidence of a minimum (the campaign's own rule).
    ADMISSIBLE = 1e-10
    # Search such end points again by trust-constr (the campaign's --trust-constr):
    # 40 times SLSQP's time on the test suite's campaign scenes at 32 elements, so
    # off there
    TRUST_CONSTR = False

    def local_min(self, x0, maxiter: int = 3000, slsqp_iter: int | None = None,
                  trust_constr: bool | None = None):
        """A local minimiser from x0: trust-region Newton, or SLSQP with an obstacle
        (then, with ``trust_constr`` (default :attr:`TRUST_CONSTR`), trust-constr
        where SLSQP ends inadmissible).

        Returns (x, energy in E0, converged).  With an obstacle the start is first
        shrunk towards w = 0 (admissible: gaps are >= 0) until it is admissible;
        SLSQP stops after ``slsqp_iter`` iterations (measured: up to 100 s for 24
        starts at 32 elements otherwise), its end point is still an admissible
        energy, an upper bound of the minimum, which is all the campaign uses.
        """
        slsqp_iter = self.SLSQP_ITER if slsqp_iter is None else slsqp_iter
        R, r = self.constraints()
        if len(r) == 0:
            res = so.minimize(self, x0, jac=True, hess=self.hessian, method="trust-exact",
                              options=dict(maxiter=maxiter, gtol=1e-11))
            return res.x, float(res.fun), bool(res.success)
        x0 = np.asarray(x0, float)
        for _ in range(60):
            if np.all(R @ x0 - r >= 0):
                break
            x0 = 0.7 * x0
        res = so.minimize(lambda x: self(x)[0], x0, jac=lambda x: self(x)[1],
                          constraints=[dict(type="ineq", fun=lambda x: R @ x - r,
                                            jac=lambda x: R)],
                          method="SLSQP", options=dict(maxiter=slsqp_iter, ftol=1e-16))
        x = res.x
        trust_constr = self.TRUST_CONSTR if trust_constr is None else trust_constr
        size = max(1.0, float(np.max(np.abs(x))))
        if trust_constr and np.min(R @ x - r) < -self.ADMISSIBLE * size:
            # SLSQP ends outside the rows in channels with four or five modes (campaign
            # scenes 133:14 and 133:18: every end point 1e-7..6e-2 out, none evidence);
            # the interior-point trust-constr keeps its iterates admissible there
            res = so.minimize(lambda x: self(x)[0], x0, jac=lambda x: self(x)[1],
                              hess=self.hessian, method="trust-constr",
                              constraints=[so.LinearConstraint(R, r, np.inf)],
                              options=dict(maxiter=maxiter, gtol=1e-12, xtol=1e-14))
            x = res.x
        return x, float(self(x)[0]), bool(res.success)

    def starts(self, rng, count: int, amplitude: float, extra=()):
        """Starting points: ± each of the first modes scaled, random mode mixtures, noise.

        ``amplitude``: the expected buckled size in W units (max |w|).  Every
        eigenvector of the first six is taken with both signs at 0.3, 1 and 2
        times it; then random mixtures of them; ``extra`` points are added as
        given and with a little noise.
        """
        _, vecs = self.modes(6)
        wrows = np.flatnonzero(self.free % 2 == 0)
        peak = np.max(np.abs(vecs[wrows]), axis=0) if len(wrows) else np.ones(vecs.shape[1])
        vecs = vecs / np.where(peak > 0, peak, 1.0)
        out = [np.zeros(self.n)]
        for x in extra:
            out.append(np.asarray(x, float))
            out.append(np.asarray(x, float) * (1 + 1e-3 * rng.normal(size=self.n)))
        for j in range(vecs.shape[1]):
            for m in (1.0, 0.3, 2.0):
                for sign in (1.0, -1.0):
                    out.append(sign * m * amplitude * vecs[:, j])
        while len(out) < count:
            mix = vecs @ rng.normal(size=vecs.shape[1])
            mix /= max(float(np.max(np.abs(mix[wrows]) if len(wrows) else np.abs(mix))), 1e-300)
            out.append(amplitude * rng.uniform(0.2, 3.0) * mix
                       + 0.05 * amplitude * rng.normal(size=self.n))
        return out[:max(count, 1)]


def pencil(bp):
    """The independent K and G (non-dimensional, L = 1 units) on the free DOFs, dense."""
    S = bp.scaled(1.0)
    n = bp.ndof
    K = np.zeros((n, n))
    G = np.zeros((n, n))
    np.add.at(K, (bp.dofs[:, :, None], bp.dofs[:, None, :]), np.asarray(bp.Ke, float))
    np.add.at(G, (bp.dofs[:, :, None], bp.dofs[:, None, :]), np.asarray(bp.Ge, float))
    free = bp.free
    return K[np.ix_(free, free)], G[np.ix_(free, free)], S


def first_mode(bp):
    """lambda_1 [N], the G-normalised mode phi (all DOFs) and int phi'^2, int phi'^4 (L = 1).

    Dense generalised eigen-solve of the independent pencil (tests/independent.py),
    for the one-mode amplitude A^2 = (P - lambda_1) mu I2 / ((E alpha / 3) I4).
    """
    K, G, _ = pencil(bp)
    lam, vec = sla.eigh(K, G, subset_by_index=[0, 0])
    lam1 = lam[0] * bp.EI / (bp.mu * bp.L**2)
    phi = np.zeros(bp.ndof)
    phi[bp.free] = vec[:, 0]
    slopes = np.einsum("eqi,ei->eq", np.asarray(bp.D5, float), phi[bp.dofs])
    w5 = np.asarray(bp.w5, float)
    return lam1, phi, float(np.sum(w5 * slopes**2)), float(np.sum(w5 * slopes**4))
