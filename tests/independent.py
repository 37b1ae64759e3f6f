"""An independent reference solver of gaocvx's discrete problem, written from physics.md only.

It shares nothing with the code under test but the input: a validated
:class:`gaocvx.scene.Scene` and the node positions ``gaocvx.DiscreteProblem(scene).x``
(gaocvx puts a node at every point force; the reference must discretise on the
same mesh to be comparable).  No module of gaocvx's numerics (fem, discrete,
mixed, newton, convex, cvm) is imported.

The discrete problem (physics.md, chapter 3)
--------------------------------------------
Hermite cubic elements, DOFs ``[w_0, theta_0, w_1, theta_1, ...]``.  With
``x = L xi``, ``w = W w_hat`` (W: a deflection scale) and energies in units of
``E0 = EI W^2 / L^3``::

    Pi_hat(u) = 1/2 u'Ku - p/2 u'Gu + a/12 ∫ (w')^4 - f'u + c/2 ∫ ((g - w)^+)^2

``K``, ``G``: the element matrices (3.27) and (3.40) of the spec, ``p = P mu L^2/EI``,
``a = E alpha W^2 / EI``, ``c = c_F L^4 / EI``, ``g = -gap / W``, ``f`` the load vector
of ``(1 - nu^2) q`` (formula (3.29) per element for a uniform q; a load table is
split at its knots and each piece integrated exactly by 3-point Gauss) and of
``(1 - nu^2) F_k`` through the shape functions at ``x_k``.  The quartic and the
foundation term use 5-point Gauss per element.  A rigid obstacle adds
``w >= g`` at the nodes and at the same 5 Gauss points per element.

Solvers (none of them gaocvx's)
-------------------------------
* no contact / foundation: damped semismooth Newton on the Hermite DOFs with
  banded Cholesky solves and a line search on the derivative along the step.
  Gradients are evaluated element by element in 80-bit ``long double``, so
  Newton's iteration doubles as iterative refinement and stops at
  double-precision round-off even where the Hessian is ill-conditioned (fine
  meshes, P near P_bar_h, very stiff foundations).
* obstacle: a guess from CVXPY + Clarabel on the Hermite formulation (in the
  scale of min(contact-free answer, gap)), made feasible, then an exact
  feasible-descent method: each step is the Newton step of the local QP with the
  touching constraints as inequalities, i.e. the projection onto a polyhedral
  cone, computed by a (bounded) non-negative least-squares problem, which needs no
  independence of the active constraints (a beam lying flat on the obstacle has
  7 touching points per element and 4 DOFs); the step is cut at the first
  constraint it would cross.  The multipliers are carried from step to step and
  the residual ``g - A'lam`` is formed in long double, so the large constraint
  forces of a beam pressed onto the obstacle cancel exactly.  Last, an exact
  equality-constrained Newton polish on an independent subset of the
  force-carrying constraints; the better certified of the two is kept.
* scaling: one solve in the scale of the linear answer, then the scale is
  reset to the answer's own size (max |w| at nodes and element midpoints) and
  the problem solved again from the rescaled answer, so every measure is
  relative to the answer itself.

Certificate
-----------
:func:`solve_reference` returns an :class:`Answer` only when its own
optimality conditions hold (``CERTIFY``; typical values are 1e-14); otherwise
it raises :class:`Refused`.  Measures (relative, in the answer's own scale):

* ``stationarity``: ``||g - A'lam||_{H^-1} / ||u||_H`` (the relative Newton
  decrement; for an energy that is quadratic near the answer it is the
  relative energy-norm error), multipliers ``lam >= 0`` from a non-negative
  least-squares fit in the H^-1 norm over the touching constraints, refined
  with long-double residuals (<= 1e-9);
* ``nodal``: max |w| of the Newton correction (in the null space of the
  touching constraints) / max |w| (<= 1e-9);
* ``feasibility`` (obstacle): largest violation of ``w >= g`` / max |w| (<= 1e-10);
* ``complementarity`` (obstacle): the multiplier-weighted mean gap of the
  constraints that carry a reaction / max |w| (<= 1e-10): the answer is exact
  for an obstacle moved by at most that much;
* ``sensitivity``: the relative change of the answer when P changes by one unit
  of round-off (<= 1e-9; near P_bar_h the scene itself is ill-posed in double
  precision and the reference refuses: ``kind = "ill-posed"``);
* ``convexity_margin``: ``1 - P / P_bar_h`` with ``P_bar_h`` from inverse
  iteration and a long-double Rayleigh quotient of sums of squares (checked
  against 40-digit arithmetic to ~1e-17); above the limit ``kind = "nonconvex"``.

These tolerances leave three orders of magnitude below the campaign's 1e-6.

Examples
--------
>>> from gaocvx.scene import Scene
>>> scene = Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P4",
...     "length": 1.0, "E": 2.1e11, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -5e7}, "mesh": {"elements": 4}})
>>> ans = solve_reference(scene)
>>> bool(abs(ans.w.min() / (-5 * 5e7 / (384 * 1.4e8)) - 1) < 1e-12)   # 5 q L^4 / (384 EI), nodally exact
True
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.optimize as sopt

__all__ = ["Refused", "Answer", "BeamProblem", "solve_reference", "reference", "sample", "CERTIFY"]

LD = np.longdouble

# The reference certifies itself only below these (relative, answer's own scale).
CERTIFY = {"stationarity": 1e-9, "nodal": 1e-9, "feasibility": 1e-10,
           "complementarity": 1e-10, "sensitivity": 1e-9}
# A constraint closer than this to the obstacle (relative to max |w|) is touching.
TOUCH = 1e-12
# Largest problem the dense obstacle solver takes (free DOFs).
MAX_OBSTACLE_DOFS = 300
# Finest mesh whose P_bar_h (inverse iteration, ~1e-14) and solves were validated.
MAX_ELEMENTS = 8192


class Refused(RuntimeError):
    """The reference cannot certify an answer (the reason is the message)."""

    def __init__(self, reason: str, kind: str = "refused"):
        self.kind = kind
        super().__init__(reason)


@dataclass
class Answer:
    """A certified reference answer in physical units."""

    x: np.ndarray
    w: np.ndarray
    slope: np.ndarray
    energy: float
    parts: dict
    residuals: dict
    W: float
    W_linear: float
    P_bar_h: float
    iterations: int = 0
    reaction: np.ndarray | None = field(default=None, repr=False)

    @property
    def wmax(self) -> float:
        """max |w| [m] at the nodes and element midpoints."""
        return float(np.max(np.abs(sample(self.x, self.w, self.slope)), initial=0.0))


# ---------------------------------------------------------------- the element
def _gauss(n):
    t, wt = np.polynomial.legendre.leggauss(n)
    return 0.5 * (t + 1.0), 0.5 * wt


def _shape(t, h):
    """Hermite cubics on an element of length h at local t in [0, 1]: values, d/dx, d2/dx2."""
    t = np.asarray(t, LD)[None, :]
    h = np.asarray(h, LD)[:, None]
    s = 1 - t  # factored forms: no cancellation near either end of the element
    N = np.stack([s**2 * (1 + 2 * t) + 0 * h, h * t * s**2, t**2 * (3 - 2 * t) + 0 * h,
                  -h * t**2 * s], axis=-1)
    D1 = np.stack([(6 * t**2 - 6 * t) / h, 1 - 4 * t + 3 * t**2 + 0 * h,
                   (6 * t - 6 * t**2) / h, 3 * t**2 - 2 * t + 0 * h], axis=-1)
    D2 = np.stack([(12 * t - 6) / h**2, (6 * t - 4) / h, (6 - 12 * t) / h**2, (6 * t - 2) / h],
                  axis=-1)
    return N, D1, D2


def element_K(h):
    """Bending matrix (3.27) per unit EI, shape (ne, 4, 4), long double."""
    h = np.asarray(h, LD)[:, None, None]
    one = np.ones_like(h)
    m = [[12 * one, 6 * h, -12 * one, 6 * h], [6 * h, 4 * h**2, -6 * h, 2 * h**2],
         [-12 * one, -6 * h, 12 * one, -6 * h], [6 * h, 2 * h**2, -6 * h, 4 * h**2]]
    return np.block(m) / h**3


def element_G(h):
    """Geometric matrix (3.40 / EI), shape (ne, 4, 4), long double."""
    h = np.asarray(h, LD)[:, None, None]
    one = np.ones_like(h)
    m = [[36 * one, 3 * h, -36 * one, 3 * h], [3 * h, 4 * h**2, -3 * h, -(h**2)],
         [-36 * one, -3 * h, 36 * one, -3 * h], [3 * h, -(h**2), -3 * h, 4 * h**2]]
    return np.block(m) / (30 * h)


def element_load_uniform(h, q1, q2):
    """Load vector (3.29) of q linear from q1 to q2 on elements of length h."""
    h = np.asarray(h, LD)
    q1, q2 = np.asarray(q1, LD), np.asarray(q2, LD)
    return np.stack([h * (7 * q1 / 20 + 3 * q2 / 20), h**2 * (q1 / 20 + q2 / 30),
                     h * (3 * q1 / 20 + 7 * q2 / 20), -(h**2) * (q1 / 30 + q2 / 20)], axis=-1)


# ---------------------------------------------------------------- the problem
class BeamProblem:
    """The discrete problem of a scene, in physical and scaled units.

    Parameters
    ----------
    scene : gaocvx.scene.Scene
    nodes : array_like, optional
        Node positions [m]; by default ``gaocvx.DiscreteProblem(scene).x``.
    """

    def __init__(self, scene, nodes=None):
        self.scene = scene
        b = scene.beam
        gao = b.model == "gao"
        nu = b.nu if gao else 0.0
        self.L = float(b.length)
        self.EI = float(b.EI) if b.EI is not None else b.E * (2.0 / 3.0) * b.half_thickness**3 * b.width
        if gao:
            self.Ealpha = (float(b.E_alpha) if b.E_alpha is not None
                           else 3.0 * b.E * b.half_thickness * b.width * (1.0 - nu**2))
        else:
            self.Ealpha = 0.0
        self.mu = float(b.mu) if b.mu is not None else ((1 + nu) * (1 - nu**2) if gao else 1.0)
        self.lf = 1.0 - nu**2
        self.P = float(scene.load.axial)
        self.contact = ("foundation" if scene.foundation is not None
                        else "obstacle" if scene.obstacle is not None else None)
        self.gap = (scene.foundation or scene.obstacle).gap if self.contact else None
        self.kF = scene.foundation.stiffness if self.contact == "foundation" else 0.0
        if nodes is None:
            import gaocvx  # only for the node positions (see the module docstring)
            try:
                nodes = gaocvx.DiscreteProblem(scene, check_convexity=False).x
            except Exception as exc:  # noqa: BLE001 - no mesh, nothing to compare with
                raise Refused(f"gaocvx builds no mesh for this scene: {exc!r}", "no-mesh") from None
        self.x = np.asarray(nodes, float)
        if self.x[0] != 0.0 or abs(self.x[-1] - self.L) > 1e-12 * self.L or np.any(np.diff(self.x) <= 0):
            raise Refused("the node positions are not a mesh of [0, L]")
        self.nn = len(self.x)
        self.ne = self.nn - 1
        self.ndof = 2 * self.nn
        fixed = {"P1": (0, 1, -2, -1), "P2": (0, 1, -2), "P3": (0, 1), "P4": (0, -2)}[b.supports]
        self.fixed = np.array(sorted(i % self.ndof for i in fixed))
        self.free_mask = np.ones(self.ndof, bool)
        self.free_mask[self.fixed] = False
        self.free = np.flatnonzero(self.free_mask)
        self.dofs = 2 * np.arange(self.ne)[:, None] + np.arange(4)[None, :]
        # Non-dimensional mesh; everything below is per element, in long double.
        xi = self.x / self.L
        self.h = (xi[1:] - xi[:-1]).astype(LD)
        self.Ke = element_K(self.h)
        self.Ge = element_G(self.h)
        t5, w5 = _gauss(5)
        self.N5, self.D5, _ = _shape(t5, self.h)
        self.w5 = self.h[:, None] * np.asarray(w5, LD)[None, :]
        self.xq = (xi[:-1, None] + np.asarray(self.h, float)[:, None] * t5[None, :]) * self.L
        t2, w2 = _gauss(2)
        _, _, self.C2 = _shape(t2, self.h)
        self.w2 = self.h[:, None] * np.asarray(w2, LD)[None, :]
        self.F_phys = self._load_vector()  # [N] on w DOFs, [N m] on theta DOFs

    # -------------------------------------------------------------- loads
    def _load_vector(self):
        """Consistent nodal load of (1 - nu^2)(q, F) in physical units, long double."""
        F = np.zeros(self.ndof, LD)
        x = self.x
        hx = np.diff(x).astype(LD)
        q = self.scene.load.q
        if q is not None and not isinstance(q, tuple):
            fe = element_load_uniform(hx, np.full(self.ne, q, LD), np.full(self.ne, q, LD))
            np.add.at(F, self.dofs, fe)
        elif q is not None:
            F += self._table_load(np.array(q, float))
        for xk, Fk in self.scene.load.points:
            e = min(max(int(np.searchsorted(x, xk, side="right")) - 1, 0), self.ne - 1)
            # t and 1 - t from the positions, in long double: a force 1e-9 of an
            # element from a node has shape-function values ~1e-18, kept to full precision
            t = (LD(xk) - LD(x[e])) / hx[e]
            r = (LD(x[e + 1]) - LD(xk)) / hx[e]
            N = np.array([r**2 * (1 + 2 * t), hx[e] * t * r**2, t**2 * (1 + 2 * r),
                          -hx[e] * t**2 * r], dtype=LD)
            F[self.dofs[e]] += LD(Fk) * N
        return F * LD(self.lf)

    def _table_load(self, table):
        """Exact load vector of a piecewise-linear table (zero outside its range)."""
        F = np.zeros(self.ndof, LD)
        x = self.x
        tx, tq = table[:, 0], table[:, 1]
        t3, w3 = _gauss(3)
        for e in range(self.ne):
            a, b = x[e], x[e + 1]
            cuts = np.unique(np.concatenate([[a, b], tx[(tx > a) & (tx < b)]]))
            for s0, s1 in zip(cuts[:-1], cuts[1:]):
                mid = 0.5 * (s0 + s1)
                if mid < tx[0] or mid > tx[-1]:
                    continue  # outside the table: q = 0
                k = min(int(np.searchsorted(tx, mid, side="right")) - 1, len(tx) - 2)
                slope = (tq[k + 1] - tq[k]) / (tx[k + 1] - tx[k])
                xs = s0 + (s1 - s0) * t3
                qs = tq[k] + slope * (xs - tx[k])
                N, _, _ = _shape((xs - a) / (b - a), np.array([b - a]))
                F[self.dofs[e]] += np.einsum("qi,q->i", N[0], np.asarray(qs * w3 * (s1 - s0), LD))
        return F

    # -------------------------------------------------------------- scaling
    def scaled(self, W: float) -> "Scaled":
        return Scaled(self, W)

    def linear_scale(self) -> float:
        """Largest nodal |w| [m] of the EB, P = 0, contact-free answer (0 without load)."""
        S = self.scaled(1.0)
        chol = S.factor(S.hessian_band(np.zeros(self.ndof, LD), quadratic_only=True, p=0.0))
        u = sla.cho_solve_banded(chol, np.asarray(S.f, float))
        return _size(u, self)

    # -------------------------------------------------------------- physical energy
    def energy_parts_physical(self, w, slope) -> dict:
        """Energy parts [J] of a deflection given by nodal (w [m], slope) (fixed DOFs as given)."""
        u = np.empty(self.ndof, LD)
        u[0::2] = np.asarray(w, LD)
        u[1::2] = np.asarray(slope, LD) * LD(self.L)
        S = self.scaled(1.0)
        return {k: float(v * LD(S.E0)) for k, v in S.energy_parts(u, keep_fixed=True).items()}


class Scaled:
    """The non-dimensional energy of a :class:`BeamProblem` in the deflection scale W [m]."""

    def __init__(self, bp: BeamProblem, W: float):
        self.bp = bp
        self.W = float(W)
        L, EI = bp.L, bp.EI
        self.E0 = EI * self.W**2 / L**3
        self.p = LD(bp.P) * LD(bp.mu) * LD(L) ** 2 / LD(EI)
        self.a = LD(bp.Ealpha) * LD(self.W) ** 2 / LD(EI)
        self.c = LD(bp.lf) * LD(bp.kF) * LD(L) ** 4 / LD(EI)
        self.g = LD(0.0) if bp.gap is None else -LD(bp.gap) / LD(self.W)
        scale = np.zeros(bp.ndof, LD)
        scale[0::2] = LD(L) ** 3 / (LD(EI) * LD(self.W))
        scale[1::2] = LD(L) ** 2 / (LD(EI) * LD(self.W))
        self.f = bp.F_phys * scale
        self.f[bp.fixed] = 0

    # -------------------------------------------------------------- pieces
    def _local(self, u):
        return np.asarray(u, LD)[self.bp.dofs]

    def energy_parts(self, u, keep_fixed=False) -> dict:
        """Non-dimensional energy parts (long double)."""
        bp = self.bp
        u = np.asarray(u, LD).copy()
        if not keep_fixed:
            u[bp.fixed] = 0
        U = self._local(u)
        curv = np.einsum("eqi,ei->eq", bp.C2, U)
        s = np.einsum("eqi,ei->eq", bp.D5, U)
        parts = {"bending": 0.5 * np.sum(bp.w2 * curv**2),
                 "gao": self.a / 12 * np.sum(bp.w5 * s**4),
                 "axial": -0.5 * self.p * np.sum(bp.w5 * s**2),
                 "load": -np.dot(self.f_all(keep_fixed), u),
                 "foundation": LD(0.0)}
        if bp.contact == "foundation":
            wq = np.einsum("eqi,ei->eq", bp.N5, U)
            pen = np.maximum(self.g - wq, 0)
            parts["foundation"] = 0.5 * self.c * np.sum(bp.w5 * pen**2)
        return parts

    def f_all(self, keep_fixed=False):
        if not keep_fixed:
            return self.f
        # loads acting on prescribed DOFs do work only if those DOFs move (scoring
        # a foreign answer that does not respect the supports)
        scale = np.zeros(self.bp.ndof, LD)
        scale[0::2] = LD(self.bp.L) ** 3 / (LD(self.bp.EI) * LD(self.W))
        scale[1::2] = LD(self.bp.L) ** 2 / (LD(self.bp.EI) * LD(self.W))
        return self.bp.F_phys * scale

    def energy(self, u) -> LD:
        return sum(self.energy_parts(u).values())

    def gradient(self, u):
        """Gradient (long double), zero on the fixed DOFs."""
        bp = self.bp
        U = self._local(u)
        ge = np.einsum("eij,ej->ei", bp.Ke, U)
        if self.p != 0:
            ge -= self.p * np.einsum("eij,ej->ei", bp.Ge, U)
        if self.a != 0:
            s = np.einsum("eqi,ei->eq", bp.D5, U)
            ge += self.a / 3 * np.einsum("eqi,eq->ei", bp.D5, bp.w5 * s**3)
        if bp.contact == "foundation":
            wq = np.einsum("eqi,ei->eq", bp.N5, U)
            pen = np.maximum(self.g - wq, 0)
            ge -= self.c * np.einsum("eqi,eq->ei", bp.N5, bp.w5 * pen)
        g = np.zeros(bp.ndof, LD)
        np.add.at(g, bp.dofs, ge)
        g -= self.f
        g[bp.fixed] = 0
        return g

    def element_hessians(self, u, quadratic_only=False, p=None):
        bp = self.bp
        p = self.p if p is None else p
        He = bp.Ke - p * bp.Ge if p != 0 else bp.Ke.copy()
        if quadratic_only:
            return He
        U = self._local(u)
        if self.a != 0:
            s = np.einsum("eqi,ei->eq", bp.D5, U)
            He = He + self.a * np.einsum("eqi,eq,eqj->eij", bp.D5, bp.w5 * s**2, bp.D5)
        if bp.contact == "foundation":
            wq = np.einsum("eqi,ei->eq", bp.N5, U)
            act = (self.g - wq > 0).astype(LD)
            He = He + self.c * np.einsum("eqi,eq,eqj->eij", bp.N5, bp.w5 * act, bp.N5)
        return He

    def hessian_band(self, u, quadratic_only=False, p=None):
        """Upper banded (3 super-diagonals) generalised Hessian, identity on fixed DOFs."""
        bp = self.bp
        He = np.asarray(self.element_hessians(u, quadratic_only, p), float)
        ab = np.zeros((4, bp.ndof))
        for i in range(4):
            for j in range(i, 4):
                np.add.at(ab, (3 + i - j, bp.dofs[:, j]), He[:, i, j])
        for k in bp.fixed:
            for off in range(4):  # column k, and row k (entries in later columns)
                ab[3 - off, k] = 0.0
                if k + off < bp.ndof:
                    ab[3 - off, k + off] = 0.0
            ab[3, k] = 1.0
        return ab

    def hessian_dense(self, u):
        """Generalised Hessian on the free DOFs (dense, double)."""
        bp = self.bp
        He = np.asarray(self.element_hessians(u), float)
        H = np.zeros((bp.ndof, bp.ndof))
        np.add.at(H, (bp.dofs[:, :, None], bp.dofs[:, None, :]), He)
        return H[np.ix_(bp.free, bp.free)]

    @staticmethod
    def factor(ab):
        return sla.cholesky_banded(ab, lower=False, check_finite=True), False

    @staticmethod
    def solve(chol, r):
        return sla.cho_solve_banded(chol, np.asarray(r, float))


# ---------------------------------------------------------------- convexity
def smallest_eigenvalue(bp: BeamProblem) -> float:
    """Smallest eigenvalue of (K, G) on the free DOFs (non-dimensional), to ~1e-15.

    Inverse iteration with the banded Cholesky factor of K, then the Rayleigh
    quotient of the converged vector evaluated in long double.
    """
    S = bp.scaled(1.0)
    zero = np.zeros(bp.ndof, LD)
    chol = S.factor(S.hessian_band(zero, quadratic_only=True, p=0.0))

    def bend(v):  # v'Kv as a sum of squares of Gauss-point curvatures (no cancellation)
        c = np.einsum("eqi,ei->eq", bp.C2, np.asarray(v, LD)[bp.dofs])
        return np.sum(bp.w2 * c**2)

    def geom(v):  # v'Gv as a sum of squares of Gauss-point slopes
        s = np.einsum("eqi,ei->eq", bp.D5, np.asarray(v, LD)[bp.dofs])
        return np.sum(bp.w5 * s**2)

    def gmul(v):
        V = np.asarray(v, LD)[bp.dofs]
        out = np.zeros(bp.ndof, LD)
        np.add.at(out, bp.dofs, np.einsum("eij,ej->ei", bp.Ge, V))
        out[bp.fixed] = 0
        return out

    def kmul(v):
        V = np.asarray(v, LD)[bp.dofs]
        out = np.zeros(bp.ndof, LD)
        np.add.at(out, bp.dofs, np.einsum("eij,ej->ei", bp.Ke, V))
        out[bp.fixed] = 0
        return out

    def ksolve(b):  # K x = b with iterative refinement on long-double residuals
        x = np.asarray(S.solve(chol, np.asarray(b, float)), LD)
        x[bp.fixed] = 0
        for _ in range(3):
            dx = S.solve(chol, np.asarray(b - kmul(x), float))
            dx[bp.fixed] = 0
            x = x + np.asarray(dx, LD)
        return x

    v = np.zeros(bp.ndof, LD)
    v[bp.free] = 1.0 + 0.1 * np.sin(np.arange(len(bp.free)))  # generic start
    lam_old = None
    lam = math.inf
    for _ in range(300):
        v = ksolve(gmul(v))
        v /= np.max(np.abs(v))
        lam = float(bend(v) / geom(v))
        if lam_old is not None and abs(lam - lam_old) <= 4e-16 * lam:
            break
        lam_old = lam
    return lam


# ---------------------------------------------------------------- Newton
def _line_search(dphi, slope0, tmax=1.0, rtol=0.1, max_eval=60):
    """Step in (0, tmax] along a descent direction of a convex function, from phi'(t)."""
    if not slope0 < 0:
        return 0.0
    hi, fhi = tmax, dphi(tmax)
    if fhi <= 0:
        return tmax
    lo, flo = 0.0, slope0
    for _ in range(max_eval):
        t = (lo * fhi - hi * flo) / (fhi - flo)
        if not lo < t < hi:
            t = 0.5 * (lo + hi)
        ft = dphi(t)
        if ft <= 0:
            lo, flo = t, ft
            if ft >= rtol * slope0:
                return t
            fhi *= 0.5 if ft < 0.5 * flo else 1.0
        else:
            hi, fhi = t, ft
            flo *= 0.5
        if hi - lo <= 1e-15 * tmax:
            break
    return lo


def _factor_damped(S, ab):
    """Banded Cholesky of the Hessian; if round-off makes it indefinite (P within ~1e-12 of
    P_bar_h, where the energy is still convex), of the Hessian plus a small multiple of its
    diagonal: a descent direction all the same, and exact Newton again once the Gao term
    stiffens the iterate."""
    try:
        return S.factor(ab)
    except np.linalg.LinAlgError:
        pass
    for tau in (1e-12, 1e-10, 1e-8, 1e-6, 1e-4):
        damped = ab.copy()
        damped[3] = damped[3] * (1 + tau)
        try:
            return S.factor(damped)
        except np.linalg.LinAlgError:
            continue
    raise Refused("the Hessian is not positive definite even with damping")


def _newton(S: Scaled, u, max_iter=300):
    """Damped semismooth Newton from u (long double, full DOFs); returns (u, iterations).

    Stops at round-off: when the relative Newton decrement falls below 1e-15,
    or stops falling once it is below 1e-10 (an iterate of a piecewise-quadratic
    energy may see it rise while the active Gauss points change).
    """
    bp = S.bp
    best = None
    stall = 0
    for it in range(1, max_iter + 1):
        g = S.gradient(u)
        ab = S.hessian_band(u)
        chol = _factor_damped(S, ab)
        d = -S.solve(chol, g)
        d[bp.fixed] = 0
        dec2 = -float(np.dot(g, d))
        uHu = float(np.dot(np.asarray(u, float), _band_mul(ab, np.asarray(u, float))))
        size2 = max(uHu, 1e-300)
        if best is None or dec2 < best:
            best, stall = dec2, 0
        elif dec2 <= 1e-20 * size2:
            stall += 1
        if dec2 <= 1e-30 * size2 or stall >= 3:
            return u, it
        dL = np.asarray(d, LD)
        t = _line_search(lambda t: float(np.dot(S.gradient(u + LD(t) * dL), dL)), -dec2)
        if t <= 0:
            return u, it
        u = u + LD(t) * dL
    return u, max_iter


def sample(x, w, slope):
    """Deflection at the nodes and at the element midpoints of the Hermite interpolant."""
    x, w, slope = (np.asarray(a, float) for a in (x, w, slope))
    h = np.diff(x)
    mid = 0.5 * (w[:-1] + w[1:]) + h * (slope[:-1] - slope[1:]) / 8.0
    return np.concatenate([w, mid])


def _size(u, bp):
    """max |w| at the nodes and element midpoints of full DOFs u (in u's units)."""
    uf = np.asarray(u, float)
    return float(np.max(np.abs(sample(bp.x / bp.L, uf[0::2], uf[1::2])), initial=0.0))


def _band_mul(ab, v):
    """Product of a symmetric upper-banded matrix (3 super-diagonals) with v."""
    n = len(v)
    out = ab[3] * v
    for off in range(1, 4):
        d = ab[3 - off, off:]
        out[:-off] += d * v[off:]
        out[off:] += d * v[:-off]
    return out


def _certify_smooth(S: Scaled, u) -> dict:
    """Certificate measures of u for the unconstrained energy (relative, S's scale)."""
    bp = S.bp
    g = S.gradient(u)
    ab = S.hessian_band(u)
    chol = S.factor(ab)
    d = S.solve(chol, g)
    d[bp.fixed] = 0
    uf = np.asarray(u, float)
    size = math.sqrt(max(float(uf @ _band_mul(ab, uf)), 0.0))
    wmax = _size(uf, bp)
    dec = math.sqrt(max(float(np.dot(g, d)), 0.0))
    out = {"stationarity": dec / size if size > 0 else (0.0 if dec == 0 else math.inf),
           "nodal": (_size(d, bp) / wmax if wmax > 0
                     else (0.0 if not np.any(d) else math.inf))}
    # Sensitivity of the answer to a round-off change of P (ill-posed near P_bar_h).
    if S.p != 0:
        gu = np.zeros(bp.ndof, LD)
        np.add.at(gu, bp.dofs, np.einsum("eij,ej->ei", bp.Ge, S._local(u)))
        gu[bp.fixed] = 0
        du = S.solve(chol, np.asarray(gu, float)) * float(S.p) * 2.2e-16
        out["sensitivity"] = float(np.max(np.abs(du[0::2]))) / wmax if wmax > 0 else 0.0
    else:
        out["sensitivity"] = 0.0
    return out


# ---------------------------------------------------------------- obstacle
def _constraints(bp: BeamProblem):
    """Rows of w at the nodes and the 5 Gauss points per element, on the free DOFs."""
    rows = []
    for i in range(bp.nn):
        r = np.zeros(bp.ndof)
        r[2 * i] = 1.0
        rows.append(r)
    N5 = np.asarray(bp.N5, float)
    for e in range(bp.ne):
        for q in range(5):
            r = np.zeros(bp.ndof)
            r[bp.dofs[e]] = N5[e, q]
            rows.append(r)
    A = np.array(rows)[:, bp.free]
    keep = np.any(A != 0, axis=1)
    return A[keep]


def _range_null(AW, n):
    """Orthonormal bases of the row space and null space of AW (SVD, rank-revealing)."""
    if AW.shape[0] == 0:
        return np.zeros((n, 0)), np.eye(n), None
    U, s, Vt = np.linalg.svd(AW, full_matrices=True)
    r = int(np.sum(s > 1e-12 * s[0])) if len(s) else 0
    return Vt[:r].T, Vt[r:].T, (U[:, :r], s[:r])


def _conic_guess(S: Scaled, A):
    """The obstacle problem as a conic program on the Hermite DOFs (CVXPY + Clarabel).

    Only a guess of the active set: the answer is the exact polish that follows.
    The quadratic part is written as ||R u||^2 with R'R = K - pG (dense
    Cholesky on the free DOFs), the quartic as a sum of 4th powers of the
    Gauss-point slopes, all in the scale S (deflections of order one).
    """
    import cvxpy as cp

    bp = S.bp
    n = len(bp.free)
    H0 = np.zeros((bp.ndof, bp.ndof))
    He = np.asarray(S.element_hessians(None, quadratic_only=True), float)
    np.add.at(H0, (bp.dofs[:, :, None], bp.dofs[:, None, :]), He)
    H0 = H0[np.ix_(bp.free, bp.free)]
    R = np.linalg.cholesky(H0).T
    f = np.asarray(S.f, float)[bp.free]
    u = cp.Variable(n)
    obj = 0.5 * cp.sum_squares(R @ u) - f @ u
    if S.a != 0:
        D = np.zeros((bp.ne * 5, bp.ndof))
        D5 = np.asarray(bp.D5, float)
        for e in range(bp.ne):
            D[5 * e:5 * e + 5, bp.dofs[e]] = D5[e]
        D = D[:, bp.free]
        wq = np.asarray(bp.w5, float).ravel() * float(S.a) / 12.0
        obj = obj + cp.sum(cp.multiply(wq, cp.power(D @ u, 4)))
    con = A @ u >= float(S.g)
    prob = cp.Problem(cp.Minimize(obj), [con])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "inaccurate" is fine for a guess
            prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12,
                       max_iter=500)
    except Exception:  # noqa: BLE001 - a failed guess only means a worse start
        return None
    if u.value is None or con.dual_value is None:
        return None
    return np.asarray(u.value, float), np.asarray(con.dual_value, float)


def _equality_newton(S: Scaled, u, A, P, lam_guess=None, rounds=30):
    """Minimise the energy subject to A_P u = g exactly (Newton in the SVD null space)."""
    bp = S.bp
    AW = A[P]
    R, Z, svd = _range_null(AW, len(bp.free))
    gW = np.full(len(P), float(S.g))
    if svd is not None and Z.shape[1] == 0:
        # the working set pins every DOF: the min-norm solution of A_P u = g, exactly
        # (w = 0 when g = 0, with no round-off noise for the scaling to blow up)
        Ur, sr = svd
        u = np.zeros(bp.ndof, LD)
        u[bp.free] = R @ ((Ur.T @ gW) / sr)
        return u
    best, stall = None, 0
    for _ in range(rounds):
        H = S.hessian_dense(u)
        grad = S.gradient(u)[bp.free]
        dp = np.zeros(len(bp.free))
        if svd is not None:
            Ur, sr = svd
            resid = np.asarray(gW.astype(LD) - A[P].astype(LD) @ np.asarray(u, LD)[bp.free], float)
            dp = R @ ((Ur.T @ resid) / sr)
        if Z.shape[1]:
            # Z'g: the constraint forces drop out of it exactly (in long double)
            zg = np.asarray(Z.astype(LD).T @ grad, float)
            y = sla.solve(Z.T @ H @ Z, -(zg + Z.T @ (H @ dp)), assume_a="pos")
            d = dp + Z @ y
        else:
            d = dp
        dfull = np.zeros(bp.ndof, LD)
        dfull[bp.free] = d
        step = float(d @ H @ d)
        u = u + dfull
        if best is None or step < best * 0.5:
            best, stall = step, 0
        else:
            stall += 1
        if step == 0.0 or stall >= 2:
            break
    return u


def _independent_subset(A, order, tol=1e-9):
    """The rows of A in ``order`` that are linearly independent of the earlier ones (greedy)."""
    n = A.shape[1]
    Q = np.zeros((n, 0))
    B = []
    for i in order:
        a = A[i]
        r = a - Q @ (Q.T @ a)
        r = r - Q @ (Q.T @ r)
        nr = np.linalg.norm(r)
        if nr > tol * np.linalg.norm(a):
            Q = np.column_stack([Q, r / nr])
            B.append(i)
            if len(B) == n:
                break
    return B


def _cone_step(Lc, grad, A, T):
    """Newton step of the QP with the touching constraints T as inequalities (A_T d >= 0).

    With H = L L' and y = L'd the step is the projection of y0 = -L^-1 g onto the
    cone {y : A_T L^-T y >= 0}; by Moreau's decomposition that is
    y = -L^-1 (g - A_T' lam) with lam = argmin_{lam >= 0} ||L^-1 (A_T' lam - g)||: a
    non-negative least-squares problem (Lawson and Hanson), which needs no
    independence of the touching constraints (a beam lying flat on the obstacle
    has 7 touching points per element and 4 DOFs).  The NNLS finds which
    constraints carry force; their multipliers are then refined by least squares
    on the residual ``g - A'lam`` evaluated in long double, and the step is formed
    from that residual: the large constraint forces of a beam pressed onto the
    obstacle cancel exactly in it, not in the step.  Returns (step, lam on T).
    """
    lam = np.zeros(len(T))
    r = np.asarray(grad, LD)
    if len(T):
        AT = A[T]
        M = sla.solve_triangular(Lc, AT.T, lower=True)
        norms = np.linalg.norm(M, axis=0)
        norms[norms == 0] = 1.0
        b = sla.solve_triangular(Lc, np.asarray(grad, float), lower=True)
        lam_n, _ = sopt.nnls(M / norms, b, maxiter=50 * M.shape[1] + 500)
        lam = lam_n / norms
        ALD = AT.astype(LD)
        r = grad - ALD.T @ lam.astype(LD)
        pos = np.flatnonzero(lam > 0)
        if len(pos):
            Mp = M[:, pos]
            for _ in range(3):
                corr = np.linalg.lstsq(Mp, sla.solve_triangular(Lc, np.asarray(r, float),
                                                                lower=True), rcond=1e-13)[0]
                trial = lam.copy()
                trial[pos] += corr
                if trial[pos].min() < 0:
                    break
                lam = trial
                r = grad - ALD.T @ lam.astype(LD)
    y = -sla.solve_triangular(Lc, np.asarray(r, float), lower=True)
    return sla.solve_triangular(Lc.T, y, lower=False), lam


def _cone_descent(S: Scaled, u, A, tau, lam, max_iter):  # noqa: ARG001 (lam: last step's)
    """Feasible descent by cone-projected Newton steps; constraints within tau touch.

    Each step solves the local QP with the touching constraints (gap <= tau
    max|w|) as inequalities, so they leave by themselves through the bounded least
    squares, and is cut where it would cross another constraint (which then
    touches).  The energy is convex along the step; its length comes from the
    derivative.  ``lam``: multipliers to start from (all constraints).  Returns u
    and the multipliers of the last step (0 off the touching set).
    """
    bp = S.bp
    gvec = np.full(A.shape[0], float(S.g))
    best, stall = None, 0
    lam = np.array(lam, float)
    for _ in range(max_iter):
        grad = S.gradient(u)
        H = S.hessian_dense(u)
        Lc = np.linalg.cholesky(H)
        uf = np.asarray(u, float)[bp.free]
        gap = A @ uf - gvec
        # relative to the answer, but never below the unit of S (the size of the
        # contact-free answer or the gap in the first pass): an answer that is
        # zero to round-off must not set the scale of "touching"
        ref = max(_size(u, bp), abs(float(S.g)), 1.0)
        T = np.flatnonzero(gap <= tau * ref)
        d, lamT = _cone_step(Lc, grad[bp.free], A, T)
        lam = np.zeros(A.shape[0])
        lam[T] = lamT
        dec2 = float(d @ H @ d)
        size2 = max(float(uf @ H @ uf), 1e-300)
        if best is None or dec2 < 0.5 * best:
            best, stall = dec2, 0
        elif dec2 <= 1e-18 * size2:  # only round-off is left: stop when it stops falling
            stall += 1
        if dec2 <= 1e-28 * size2 or stall >= 3:
            break
        Ad = A @ d
        amax, block = 1.0, None
        touching = np.zeros(A.shape[0], bool)
        touching[T] = True
        cand = np.flatnonzero(~touching & (Ad < 0))
        if len(cand):
            ratios = np.maximum(gap[cand], 0.0) / -Ad[cand]
            k = int(np.argmin(ratios))
            if ratios[k] < 1.0:
                amax, block = float(ratios[k]), int(cand[k])
        dfull = np.zeros(bp.ndof, LD)
        dfull[bp.free] = d
        slope0 = float(np.dot(grad, dfull))
        if slope0 >= 0:
            t = amax  # a step that only restores the touching constraints
        else:
            t = _line_search(lambda t: float(np.dot(S.gradient(u + LD(t) * dfull), dfull)),
                             slope0, tmax=amax)
        if t <= 0:
            break
        u = u + LD(t) * dfull
    return u, lam


def _make_feasible(S, u, A):
    """Shrink u towards 0 (feasible, g <= 0) until every constraint holds."""
    bp = S.bp
    g = float(S.g)
    Au = A @ np.asarray(u, float)[bp.free]
    bad = Au < g
    if not np.any(bad):
        return u
    t = float(np.min(g / Au[bad])) if g < 0 else 0.0
    return u * LD(min(max(t, 0.0), 1.0) * (1 - 1e-13))


def _obstacle_exact(S: Scaled, u, A):
    """From any start: feasible cone descent, then the exact equality-constrained polish on
    the force-carrying constraints; with a finer touch threshold while neither certifies."""
    n_con = A.shape[0]
    u = _make_feasible(S, u, A)
    lam = np.zeros(n_con)
    keys = ("stationarity", "nodal", "feasibility", "complementarity")
    worst = lambda mm: max(mm[k] / CERTIFY[k] for k in keys)  # noqa: E731
    best = None
    for tau in (1e-6, 1e-9, 1e-12):
        u, lam = _cone_descent(S, u, A, tau, lam, max_iter=3 * len(S.bp.free) + 50)
        m, lam_c = _certify_obstacle(S, u, A)
        cands = [(worst(m), 0, u, m, lam_c)]
        carry = np.flatnonzero(lam > 0)
        if len(carry):
            B = _independent_subset(A, carry[np.argsort(-lam[carry])])
            try:
                u2 = _equality_newton(S, u, A, np.array(sorted(B), int))
                m2, lam2 = _certify_obstacle(S, u2, A)
                cands.append((worst(m2), 1, u2, m2, lam2))
            except (np.linalg.LinAlgError, sla.LinAlgError):
                pass
        top = min(cands, key=lambda c: c[:2])
        if best is None or top[:2] < best[:2]:
            best = top
        if best[0] <= 1.0:
            break
    return best[2], best[3], best[4]


def _multipliers(S, u, A, touch, H, Lc):
    """Multipliers of the touching constraints: NNLS in the H^-1 norm, then refined.

    The refinement solves for corrections on the positive set with the residual
    g - A'lam evaluated in long double, so that the balance of large forces
    (a beam pressed onto the obstacle) is resolved to round-off.
    """
    bp = S.bp
    lam = np.zeros(A.shape[0])
    grad = S.gradient(u)[bp.free]
    if len(touch) == 0:
        return lam, grad
    M = sla.solve_triangular(Lc, A[touch].T, lower=True)
    norms = np.linalg.norm(M, axis=0)
    norms[norms == 0] = 1.0
    lam_n, _ = sopt.nnls(M / norms, sla.solve_triangular(Lc, np.asarray(grad, float), lower=True),
                         maxiter=50 * M.shape[1] + 500)
    lam[touch] = lam_n / norms
    ALD = A.astype(LD)
    r = grad - ALD.T @ lam.astype(LD)
    pos = touch[lam[touch] > 0]
    if len(pos):
        Mp = sla.solve_triangular(Lc, A[pos].T, lower=True)
        for _ in range(2):
            corr = np.linalg.lstsq(Mp, sla.solve_triangular(Lc, np.asarray(r, float), lower=True),
                                   rcond=1e-12)[0]
            trial = lam.copy()
            trial[pos] += corr
            if trial[pos].min() < 0:
                break
            r_new = grad - ALD.T @ trial.astype(LD)
            if np.linalg.norm(np.asarray(r_new, float)) >= np.linalg.norm(np.asarray(r, float)):
                break
            lam, r = trial, r_new
    return lam, r


def _certify_obstacle(S: Scaled, u, A):
    """KKT measures of u for the obstacle, with multipliers from NNLS in the H^-1 norm."""
    bp = S.bp
    gvec = np.full(A.shape[0], float(S.g))
    uf = np.asarray(u, float)[bp.free]
    wmax = _size(u, bp)
    H = S.hessian_dense(u)
    Lc = np.linalg.cholesky(H)
    gap = np.asarray(A.astype(LD) @ np.asarray(u, LD)[bp.free] - gvec.astype(LD), float)
    ref = wmax if wmax > 0 else abs(float(S.g))
    touch = np.flatnonzero(gap <= TOUCH * ref)
    lam, r = _multipliers(S, u, A, touch, H, Lc)
    r = np.asarray(r, float)
    y = sla.solve_triangular(Lc, r, lower=True)
    size = math.sqrt(max(float(uf @ H @ uf), 0.0))
    force = np.linalg.norm(sla.solve_triangular(Lc, A.T @ lam, lower=True))
    fn = np.linalg.norm(sla.solve_triangular(Lc, np.asarray(S.f, float)[bp.free], lower=True))
    scale = size if size > 0 else max(force, fn)
    stat = float(np.linalg.norm(y)) / scale if scale > 0 else 0.0
    # Newton correction on the touching set (estimate of the remaining nodal error)
    AT = A[touch] if len(touch) else np.zeros((0, len(uf)))
    _, Z, _ = _range_null(AT, len(uf))
    dz = Z @ sla.solve(Z.T @ H @ Z, -Z.T @ r, assume_a="pos") if Z.shape[1] else np.zeros(len(uf))
    dzf = np.zeros(bp.ndof)
    dzf[bp.free] = dz
    dsize = _size(dzf, bp)
    nodal = dsize / wmax if wmax > 0 else (0.0 if dsize == 0 else math.inf)
    viol = float(max(0.0, -gap.min())) if len(gap) else 0.0
    feas = viol / ref if ref > 0 else (0.0 if viol == 0 else math.inf)
    # complementarity: the multiplier-weighted mean gap of the constraints that
    # carry a reaction, relative to max |w| (an obstacle moved by this much makes
    # complementarity exact)
    tot = float(lam.sum())
    comp = float(lam @ np.maximum(gap, 0.0)) / (tot * ref) if tot > 0 and ref > 0 else 0.0
    return {"stationarity": stat, "nodal": nodal, "feasibility": feas, "complementarity": comp,
            "sensitivity": 0.0}, lam


# ---------------------------------------------------------------- driver
def _obstacle_solve(S, u, A, guess=True):
    """A conic guess (optional) as the start of the exact method (:func:`_obstacle_exact`)."""
    bp = S.bp
    if guess:
        found = _conic_guess(S, A)
        if found is not None:
            u = np.zeros(bp.ndof, LD)
            u[bp.free] = found[0]
    return _obstacle_exact(S, u, A)


def _smooth_solve(bp, W0):
    """Newton in the scale W0, then again in the answer's own scale."""
    S = bp.scaled(W0)
    u, nit = _newton(S, np.zeros(bp.ndof, LD))
    for _ in range(3):
        wmax = _size(u, bp)
        if wmax == 0.0:
            break
        W1 = S.W * wmax
        u = u * LD(S.W / W1)
        S = bp.scaled(W1)
        u, k = _newton(S, u)
        nit += k
        if abs(_size(u, bp) - 1.0) < 1e-3:
            break
    return S, u, _certify_smooth(S, u), nit


def solve_reference(scene, nodes=None, certify=None) -> Answer:
    """Solve ``scene``'s discrete problem independently and certify the answer.

    Raises
    ------
    Refused
        When the answer cannot be certified (``kind``: "refused", "nonconvex",
        "ill-posed", "no-mesh").
    """
    try:
        return _solve_reference(scene, nodes, certify)
    except (np.linalg.LinAlgError, sla.LinAlgError, FloatingPointError, ZeroDivisionError) as exc:
        near = _MARGIN.get("last", 1.0) < 1e-6
        raise Refused(f"linear algebra failed: {exc!r}" + (" (P within 1e-6 of P_bar_h)" if near
                                                            else ""),
                      "ill-posed" if near else "refused") from None


_MARGIN = {}  # the convexity margin of the scene being solved (to name a failure near P_bar_h)


def _solve_reference(scene, nodes=None, certify=None) -> Answer:
    """Solve ``scene``'s discrete problem independently and certify the answer.

    Raises
    ------
    Refused
        When the answer cannot be certified (``kind``: "refused", "nonconvex",
        "ill-posed").
    """
    tol = {**CERTIFY, **(certify or {})}
    bp = BeamProblem(scene, nodes)
    n_free = len(bp.free)
    if bp.ne > MAX_ELEMENTS:
        # Beyond the validated range of the eigenvalue and of the solves.  The
        # convexity limit is still decided when P is clearly above the continuum
        # P_bar (physics.md: P_bar_h lies above P_bar and converges to it as h^4;
        # the gap is < 1e-13 beyond 8192 elements, the margin here 1e-5).
        l_ef = {"P1": 0.5, "P2": 0.699157, "P3": 2.0, "P4": 1.0}[scene.beam.supports] * bp.L
        P_bar = math.pi**2 * bp.EI / l_ef**2 / bp.mu
        if bp.P > P_bar * (1 + 1e-5):
            raise Refused(f"P = {bp.P:.6g} N is above the continuum P_bar = {P_bar:.6g} N "
                          f"by more than P_bar_h can be on {bp.ne} elements: not convex",
                          "nonconvex")
        raise Refused(f"{bp.ne} elements: beyond the reference's validated {MAX_ELEMENTS}")
    S1 = bp.scaled(1.0)
    lam1 = smallest_eigenvalue(bp) if n_free else math.inf
    Pbar_h = lam1 * bp.EI / bp.L**2 / bp.mu
    margin = 1.0 - float(S1.p) / lam1 if n_free else 1.0
    _MARGIN["last"] = margin
    if margin < -1e-13:
        raise Refused(f"P = {bp.P:.6g} N is above P_bar_h = {Pbar_h:.10g} N: not convex", "nonconvex")
    if margin <= 1e-13:
        raise Refused(f"P = {bp.P:.6g} N is within round-off of P_bar_h = {Pbar_h:.10g} N",
                      "ill-posed")
    W_lin = bp.linear_scale() if n_free else 0.0
    zero = np.zeros(bp.ndof, LD)
    if n_free == 0 or not np.any(bp.F_phys[bp.free]):
        # no load on a free DOF: w = 0 is the exact minimiser (g <= 0 is below it)
        return _answer(bp, bp.scaled(W_lin or bp.L), zero, {k: 0.0 for k in CERTIFY},
                       W_lin, Pbar_h, 0, None, margin)
    # The contact-free minimiser (every scene kind starts from it), in its own scale.
    S, u, m, nit = _smooth_solve(bp, W_lin)
    lam = None
    if bp.contact == "obstacle":
        A = _constraints(bp)
        uf = np.asarray(u, float)[bp.free]
        gvec = np.full(A.shape[0], float(S.g))
        if A.shape[0] and np.min(A @ uf - gvec) < 0:
            if n_free > MAX_OBSTACLE_DOFS:
                raise Refused(f"{n_free} free DOFs: too many for the dense obstacle reference")
            # It crosses the obstacle: solve with contact, first in a scale no
            # larger than the gap, then in the answer's own scale.
            W0 = min(S.W, bp.gap) if bp.gap > 0 else S.W
            u = u * LD(S.W / W0)
            S = bp.scaled(W0)
            u, m, lam = _obstacle_solve(S, u, A, guess=True)
            if bp.gap == 0 and _size(u, bp) <= 1e-12:
                # zero to round-off in the scale of the contact-free answer: a beam pressed
                # flat onto an obstacle at its own level.  w = 0 exactly, if it is a KKT point.
                zero_u = np.zeros(bp.ndof, LD)
                mz, lz = _certify_obstacle(S, zero_u, A)
                if all(mz[k] <= CERTIFY[k] for k in ("stationarity", "nodal", "feasibility",
                                                      "complementarity")):
                    u, m, lam = zero_u, mz, lz
            for _ in range(2):
                wmax = _size(u, bp)
                if wmax == 0.0 or abs(wmax - 1.0) < 1e-3:
                    break
                u = u * LD(1.0 / wmax)
                S = bp.scaled(S.W * wmax)
                u, m, lam = _obstacle_solve(S, u, A, guess=False)
            nit += 1
        elif A.shape[0]:
            mo, lam = _certify_obstacle(S, u, A)
            m.update(feasibility=mo["feasibility"], complementarity=mo["complementarity"])
        m.setdefault("sensitivity", 0.0)
    m["convexity_margin"] = margin
    # ill-posedness first: near P_bar_h the other measures fail because of it
    for k, limit in sorted(tol.items(), key=lambda kv: kv[0] != "sensitivity"):
        if not m.get(k, 0.0) <= limit:
            kind = "ill-posed" if k == "sensitivity" else "refused"
            raise Refused(f"{k} = {m.get(k):.3g} > {limit:.0e} (measures {_fmt(m)})", kind)
    return _answer(bp, S, u, m, W_lin, Pbar_h, nit, lam, margin)


def _fmt(m):
    return ", ".join(f"{k} {v:.2g}" for k, v in m.items())


def _answer(bp, S, u, m, W_lin, Pbar_h, nit, lam, margin):
    uf = np.asarray(u, float)
    parts = {k: float(v * LD(S.E0)) for k, v in S.energy_parts(u).items()}
    w = uf[0::2] * S.W
    slope = uf[1::2] * S.W / bp.L
    m = dict(m)
    m.setdefault("convexity_margin", margin)
    return Answer(x=bp.x.copy(), w=w, slope=slope, energy=float(sum(parts.values())), parts=parts,
                  residuals=m, W=S.W, W_linear=W_lin, P_bar_h=Pbar_h, iterations=nit,
                  reaction=lam)


def reference(scene, nodes=None):
    """:func:`solve_reference`, or None when it refuses."""
    try:
        return solve_reference(scene, nodes)
    except Refused:
        return None
