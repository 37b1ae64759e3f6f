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
        xq = np.asarray(bp.xq, float).ravel()       # Gauss points [m]
        self.p = bp.P * bp.mu * bp.L**2 / bp.EI
        self.a = bp.Ealpha * self.W**2 / bp.EI
        scale = np.zeros(n_all)
        scale[0::2] = bp.L**3 / (bp.EI * self.W)
        scale[1::2] = bp.L**2 / (bp.EI * self.W)
        self.f = (np.asarray(bp.F_phys, float) * scale)[free]
        fnd, obs = scene.foundation, scene.obstacle
        self.kind = ("bonded" if fnd is not None and fnd.bilateral else
                     "foundation" if fnd is not None else "obstacle" if obs is not None else None)
        self.cq = np.zeros(len(xq))
        self.gq = np.zeros(len(xq))
        if fnd is not None:
            self.cq = bp.lf * _at(fnd.stiffness, xq) * bp.L**4 / bp.EI
            self.gq = -_at(fnd.gap, xq) / self.W
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

    def __call__(self, x):
        """Energy (in E0) and its gradient at free DOFs x."""
        s = self.D @ x
        Kx, Gx = self.K @ x, self.G @ x
        e = 0.5 * x @ Kx - 0.5 * self.p * x @ Gx + self.a / 12 * self.wq @ s**4 - self.f @ x
        g = Kx - self.p * Gx + self.a / 3 * self.D.T @ (self.wq * s**3) - self.f
        if self.kind in ("foundation", "bonded"):
            pen = self.gq - self.N @ x
            if self.kind == "foundation":
                pen = np.maximum(pen, 0.0)
            e += 0.5 * (self.wq * self.cq) @ pen**2
            g -= self.N.T @ (self.wq * self.cq * pen)
        return float(e), g

    def energy(self, x) -> float:
        """Energy [J] of free DOFs x."""
        return self(x)[0] * self.E0

    def parts_scale(self, x) -> float:
        """Sum of |energy parts| (in E0): the scale energy tolerances are relative to."""
        s = self.D @ x
        parts = [0.5 * x @ self.K @ x, 0.5 * self.p * x @ self.G @ x,
                 self.a / 12 * self.wq @ s**4, self.f @ x]
        if self.kind in ("foundation", "bonded"):
            pen = self.gq - self.N @ x
            if self.kind == "foundation":
                pen = np.maximum(pen, 0.0)
            parts.append(0.5 * (self.wq * self.cq) @ pen**2)
        return float(sum(abs(v) for v in parts))

    def hessian(self, x) -> np.ndarray:
        """(Generalised) Hessian at x (a unilateral foundation: its active Gauss points)."""
        s = self.D @ x
        H = self.K - self.p * self.G + self.a * self.D.T @ ((self.wq * s**2)[:, None] * self.D)
        if self.kind in ("foundation", "bonded"):
            act = np.ones(len(self.wq))
            if self.kind == "foundation":
                act = (self.gq - self.N @ x > 0).astype(float)
            H = H + self.N.T @ ((self.wq * self.cq * act)[:, None] * self.N)
        return H

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
        norm_x = math.sqrt(max(float(x @ self.stiffness() @ x), 1e-300))
        # An answer pressed flat onto an obstacle is w = 0 to round-off: relative to its
        # own norm (1e-32) any residual is huge.  Floor: 1e-6 of the unsupported linear
        # answer's norm, ||K^-1 g(0)||_K (the floor the package documents for such answers).
        _, g0 = self(np.zeros_like(x))
        floor = 1e-6 * float(np.linalg.norm(sla.solve_triangular(Kc, g0, lower=True)))
        norm_x = max(norm_x, floor)
        H = self.hessian(x)
        strong = np.flatnonzero(lam > 1e-6 * max(float(np.max(lam, initial=0.0)), 1e-300))
        Z = sla.null_space(R[strong]) if len(strong) else np.eye(self.n)
        lowest = (float(sla.eigh(Z.T @ H @ Z, Z.T @ self.stiffness() @ Z, eigvals_only=True)[0])
                  if Z.shape[1] else 0.0)
        return {"stationarity": float(np.linalg.norm(y)) / norm_x,
                "feasibility": float(max(0.0, -np.min(slack, initial=0.0))) / size,
                "lowest": lowest, "touching": int(len(touch)), "multipliers": lam}

    # ------------------------------------------------------------ local search
    def local_min(self, x0, maxiter: int = 3000, slsqp_iter: int = 400):
        """A local minimiser from x0: trust-region Newton, or SLSQP with an obstacle.

        Returns (x, energy in E0, converged).  With an obstacle the start is first
        shrunk towards w = 0 (admissible: gaps are >= 0) until it is admissible;
        SLSQP stops after ``slsqp_iter`` iterations (measured: up to 100 s for 24
        starts at 32 elements otherwise), its end point is still an admissible
        energy, an upper bound of the minimum, which is all the campaign uses.
        """
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
