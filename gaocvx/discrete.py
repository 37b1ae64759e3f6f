"""The discrete, non-dimensional energy of a scene.

:class:`DiscreteProblem` turns a :class:`~gaocvx.scene.Scene` into arrays on
the free degrees of freedom, in units where the beam has unit length and unit
bending stiffness and the deflection is measured in a scale ``W`` of the
answer's size: the mesh, the scaling, the coefficients (p, a, c, g), the load
vector and the convexity limit P_bar_h.  The energy, gradient and Hessian in
Hermite DOFs here serve CVM and the scoring of results; the ground-truth
solvers (convex, Newton) work on the same energy in the better-conditioned
variables of :class:`~gaocvx.mixed.MixedForm`, built from this object.

Scaling (x = L xi, w = W w_hat, energies in E0 = EI W^2 / L^3)::

    Pi_hat = 1/2 u'K u - p/2 u'G u + a/12 ∫ (w')^4 - f'u + c/2 ∫ ((g - w)^+)^2

with ``p = P mu L^2 / EI``, ``a = E_alpha W^2 / EI``, ``c = c_F L^4 / EI``,
``g = -gap / W`` and ``f`` the load vector of ``(1 - nu^2) q L^4 / (EI W)``
and ``(1 - nu^2) F L^3 / (EI W)``.

Examples
--------
>>> from gaocvx.scene import Scene
>>> scene = Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P4",
...     "length": 1.0, "E": 2.1e11, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -5e7}, "mesh": {"elements": 8}})
>>> dp = DiscreteProblem(scene)
>>> round(dp.P_bar_h / 1e9, 3)     # pi^2 EI / L^2 = 1.382e9 N, a little above
1.382
"""

from __future__ import annotations

import copy
import functools
import math

import numpy as np
import scipy.sparse as sp

from . import fem
from .errors import SceneError
from .linalg import BandedCholesky, NotPositiveDefinite
from .scene import Scene

__all__ = ["DiscreteProblem", "GAO_POINTS", "CONTACT_POINTS", "STATIONARITY_TOL", "FEASIBILITY_TOL",
           "COMPLEMENTARITY_TOL", "ZERO_ANSWER"]

GAO_POINTS = 5       # exact for the degree-8 integrand (w')^4
CONTACT_POINTS = 5   # Gauss points of the foundation term (and obstacle constraints)

# A solve is "optimal" only when its relative energy-norm residual (see
# DiscreteProblem.residual) is below this, whichever method produced it ...
STATIONARITY_TOL = 1e-6
# ... and, for an obstacle, feasibility and dual sign below this ...
FEASIBILITY_TOL = 1e-7
# ... and complementarity below this: it is an energy, whose square root bounds the
# error in the energy norm, so it must be below the square of STATIONARITY_TOL.
COMPLEMENTARITY_TOL = STATIONARITY_TOL**2
# In complementarity, a point closer to the obstacle than this (relative to the
# answer's own size, its largest |w|) is touching it: a beam lying flat on the
# obstacle sits at gaps of +-1e-11 of that from round-off alone, which would
# otherwise dominate the bound.
TOUCH_TOL = 1e-9
# An answer smaller than this fraction of the unsupported linear answer is measured
# against this floor instead of itself (only a beam pressed onto an obstacle has
# one): the forces acting (load and reaction) are those of the unsupported answer,
# and their round-off alone is ~1e-15 of it, so relative measures of a smaller
# answer would compare round-off with round-off.  Below the floor an answer is
# thus certified to an absolute fraction TOL * ZERO_ANSWER of the unsupported
# one (measured: at 1e-8 the method of multipliers no longer certifies a flexible
# beam lying flat on a gap-0 obstacle).
ZERO_ANSWER = 1e-6
# "In contact" with a rigid obstacle: a gap within this fraction of the answer's size.
OBSTACLE_CONTACT_TOL = 1e-6


def complementarity(lam, gap, scale, size) -> float:
    """Relative duality gap sum(lam * gap) / scale^2; gaps below TOUCH_TOL * size count as contact.

    ``scale`` is the answer's energy norm and ``size`` its largest deflection.
    The value bounds the answer's relative energy excess (and its square root
    the relative error in the energy norm).
    """
    gap = np.where(gap > TOUCH_TOL * size, gap, 0.0)
    return float(abs(lam @ gap) / scale**2)


class DiscreteProblem:
    """Non-dimensional arrays of one scene on its mesh.

    Parameters
    ----------
    scene : Scene
        A validated scene.
    elements : int, optional
        Override of ``scene.mesh.elements``.
    check_convexity : bool
        Raise :class:`SceneError` on ``load.axial`` unless P < P_bar_h is
        proved (see Notes).
    nodes : array_like, optional
        An explicit mesh instead of equal elements.
    W : float, optional
        The deflection scale [m]; by default the size of the linear answer.

    Attributes
    ----------
    x : ndarray
        Physical node positions [m].
    free : ndarray
        Indices of the free DOFs in the full DOF vector.
    K, G : sparse matrices
        Bending and geometric matrices on the free DOFs (non-dimensional).
    f : ndarray
        Non-dimensional load vector on the free DOFs.
    W, E0 : float
        Deflection scale [m] and energy scale [J].
    p, a, c, g : float
        Non-dimensional axial force, Gao coefficient, foundation stiffness
        and foundation/obstacle level (0 when absent).
    P_bar_h : float
        The discrete convexity limit [N], computed on first access.

    Notes
    -----
    The convexity check and P_bar_h work in the slope variables of
    :mod:`gaocvx.limit` (nodal and chord slopes), never on the Hermite matrices
    K and G, whose condition number ~N^4 made an eigen-solver wrong by 3 %
    at 16384 elements and a factor 1000 at 10^6.  A compressive P is accepted
    only when it is *proved* below P_bar_h: by one banded Cholesky
    factorisation at P plus a bound of its round-off (at P = 0.99 P_bar_h a
    margin of 2e-8 P_bar_h at 64 elements, 1e-3 at 16384, 0.04 at 10^5), or
    else by the enclosure of P_bar_h, about 3e-14 wide.  A P within that
    enclosure is refused as "not provably below" the limit.

    Examples
    --------
    >>> from gaocvx.scene import Scene
    >>> d = {"beam": {"model": "euler-bernoulli", "supports": "P1", "length": 1.0,
    ...      "E": 2.1e11, "half_thickness": 0.1, "width": 1.0},
    ...      "load": {"q": -5e7, "axial": 5.52e9}, "mesh": {"elements": 16384}}
    >>> round(DiscreteProblem(Scene.from_dict(d)).P_bar_h / 5.526979e9, 6)   # 4 pi^2 EI / L^2
    1.0
    >>> d["load"]["axial"] = 5.53e9
    >>> DiscreteProblem(Scene.from_dict(d))
    Traceback (most recent call last):
    ...
    gaocvx.errors.SceneError: load.axial: P = 5.53e+09 N is not below the convexity limit P_bar_h = 5.527e+09 N for P1 (continuum P_bar = 5.527e+09 N) (got 5.53e+09)
    """

    def __init__(self, scene: Scene, elements: int | None = None, check_convexity: bool = True,
                 nodes=None, W: float | None = None):
        try:
            with np.errstate(over="raise", invalid="raise", divide="raise"):
                self._build(scene, elements, nodes, W)
        except (OverflowError, FloatingPointError, ZeroDivisionError):
            raise SceneError("scene", "its magnitudes (length, stiffness, loads) cannot be scaled "
                             "within double precision", _magnitudes(scene)) from None
        scales = [self.W, self.E0, self.p, self.a, np.max(self.c), np.min(self.g)]
        if not (np.all(np.isfinite(scales)) and np.all(np.isfinite(self.f)) and self.E0 > 0):
            raise SceneError("scene", "its magnitudes (length, stiffness, loads) cannot be scaled "
                             "within double precision", _magnitudes(scene))
        if check_convexity:
            self.check_convexity()

    def check_convexity(self) -> None:
        """Raise :class:`SceneError` on ``load.axial`` unless the energy is proved convex.

        One banded factorisation proves P < P_bar_h when P is clear of the limit
        by more than its round-off margin; nearer, the enclosure of P_bar_h
        decides, and a P inside it is refused (:mod:`gaocvx.limit`).  A bonded
        foundation raises the limit to P_hat_h (:mod:`gaocvx.limit.bonded`).
        """
        if not self.P > 0:
            return
        from . import limit
        try:
            limit.check(self)
        except SceneError:
            if not self.bilateral:
                raise
            from .limit.bonded import BondedLimit
            # With a stiffness profile, each element's smallest value at its
            # quadrature points bounds its foundation term from below.
            c = self.c if np.ndim(self.c) == 0 else \
                np.asarray(self.c).reshape(self.n_nodes - 1, CONTACT_POINTS).min(axis=1)
            if not BondedLimit(self.xi, self.scene.beam.supports, c).prove_below(self.p):
                raise SceneError(
                    "load.axial", f"P = {self.P:.4g} N is not provably below the convexity "
                    f"limit P_hat_h = {self.P_hat_h:.4g} N of the beam on its bonded "
                    f"foundation (P_bar_h = {self.P_bar_h:.4g} N without it)",
                    self.P) from None

    def convexity_proved(self) -> bool:
        """True when :meth:`check_convexity` passes."""
        try:
            self.check_convexity()
        except SceneError:
            return False
        return True

    def _build(self, scene, elements, nodes, W_fixed):
        self.scene = scene
        beam = scene.beam
        self.L = L = beam.length
        self.EI = EI = beam.EI_eff
        if nodes is not None:
            # An explicit mesh (e.g. the nodes of a result computed elsewhere);
            # point forces between its nodes act through the shape functions.
            self.x = np.asarray(nodes, float)
        else:
            n_el = scene.mesh.elements if elements is None else int(elements)
            # Nodes at point forces, and at the knots of a gap or stiffness profile:
            # the surface's kinks are then where the constraints and the quadrature
            # see them (a dent's corner is a constraint point).
            self.x = fem.uniform_nodes_with_points(
                L, n_el, [p[0] for p in scene.load.points] + _profile_knots(scene))
        self.xi = self.x / L
        self.n_nodes = len(self.x)
        self.free = fem.free_dofs(self.n_nodes, beam.supports)
        fr = self.free

        # Loads per unit W: f_unit * (1/W) is the non-dimensional load.
        lf = beam.load_factor
        q = scene.load.q
        if scene.load.is_table:
            q = [(xk / L, qk) for xk, qk in q]
        f_unit = fem.load_vector(self.xi, q) * (lf * L**4 / EI)
        if scene.load.points:
            # In physical x: xk / L rounds a point 1e-9 L from a node to an
            # absolute eps, a relative 1e-7 of its distance to the node, which
            # is what a force there acts through.  Slope DOFs then carry h = L dxi.
            pts = [(xk, Fk * lf * L**3 / EI) for xk, Fk in scene.load.points]
            f_pts = fem.point_load_vector(self.x, pts)
            f_pts[1::2] /= L
            f_unit = f_unit + f_pts
        f_unit = f_unit[fr]
        # The load as a function of xi (piecewise-linear table, knots in xi) and the
        # point forces, per unit W: the transformed loads of CVM integrate these.
        self._q_table_unit = None
        if q is not None:
            table = q if scene.load.is_table else [(0.0, q), (1.0, q)]
            self._q_table_unit = np.array([(t, v * lf * L**4 / EI) for t, v in table], float)
        self._points_unit = np.array([(xk / L, Fk * lf * L**3 / EI)
                                      for xk, Fk in scene.load.points], float).reshape(-1, 2)

        # Deflection scale: the size of the linear (EB, P = 0, contact-free) answer.
        # It is the unsupported linear answer's size: a first guess (solve()
        # rescales to the answer's own size) and the floor of "zero" answers
        # (MixedForm.zero_floor), never the size of the answer itself.
        w_lin = 0.0
        if self.n and W_fixed is None:
            u_lin = self._K_chol.solve(f_unit)
            w_lin = np.max(np.abs(u_lin[self._w_rows()]), initial=0.0)
            if w_lin == 0:  # no free deflection (one element, both ends pinned): slopes * L
                w_lin = np.max(np.abs(u_lin), initial=0.0)
        self.W_linear = float(w_lin) if W_fixed is None else float(W_fixed)
        if W_fixed is not None:
            self.W = float(W_fixed)  # a sweep keeps one scale for all its scenes
        elif w_lin > 0:
            self.W = float(w_lin)
        else:
            # No load: the answer is w = 0 and any scale serves; a gap of 1e-178 m
            # as the scale would underflow the energy scale.
            self.W = 1e-3 * L
        self._f_unit = f_unit
        self._set_scale(self.W)

        self.P = scene.load.axial
        self.mu = beam.mu_eff
        self.p = self.P * self.mu * L**2 / EI

        # Foundation / obstacle.
        self.contact = scene.contact
        self.c = 0.0
        self.bilateral = False  # a bonded foundation: 1/2 c (w - g)^2, pulling too
        if self.contact == "foundation":
            self.k_F = scene.foundation.stiffness
            if isinstance(self.k_F, tuple):
                # A stiffness profile: c at each contact point.
                self.c = lf * scene.foundation.stiffness_at(self._contact_points * L) * L**4 / EI
            else:
                self.c = lf * self.k_F * L**4 / EI
            self.bilateral = scene.foundation.bilateral

    def _set_scale(self, W: float) -> None:
        """Set the deflection scale W [m] and everything measured in it."""
        scene, L, EI = self.scene, self.L, self.EI
        self.W = float(W)
        self.E0 = EI * self.W**2 / L**3
        self.f = self._f_unit / self.W
        self.a = scene.beam.E_alpha_eff * self.W**2 / EI
        # The contact level g (<= 0): a number, or with a gap profile its value at
        # each contact point (the foundation's quadrature points); level_at gives
        # it anywhere.  g_max, the nearest point of the surface, decides reach.
        if scene.gap is None:
            self.g = 0.0
        elif isinstance((scene.foundation or scene.obstacle).gap, tuple):   # a gap profile
            self.g = -scene.gap_at(self._contact_points * self.L) / self.W
        else:
            self.g = -scene.gap / self.W
        self.g_max = 0.0 if scene.gap is None else -scene.gap / self.W
        # A channel: the obstacle's second surface, g_above (>= 0) over the beam.
        above = scene.obstacle.gap_above if scene.obstacle is not None else None
        self.g_above = None if above is None else above / self.W

    @functools.cached_property
    def _contact_points(self) -> np.ndarray:
        """The contact quadrature points (non-dimensional x), as the mixed form's."""
        return fem.gauss_points(self.xi, CONTACT_POINTS)[0]

    def level_at(self, xi) -> np.ndarray:
        """The contact level g (non-dimensional, <= 0) at non-dimensional ``xi``."""
        xi = np.asarray(xi, float)
        if self.scene.gap is None:
            return np.zeros(xi.shape)
        return -self.scene.gap_at(xi * self.L) / self.W

    def rescaled(self, W: float) -> "DiscreteProblem":
        """The same problem measured in the deflection scale ``W`` [m].

        The mesh, its matrices and the convexity limit do not depend on W and
        are shared; the load, the Gao coefficient and the contact level are
        rescaled.  Solvers take W from the answer's own size this way (see
        :func:`gaocvx.solve.solve`).
        """
        new = copy.copy(self)
        with np.errstate(over="raise", invalid="raise", divide="raise"):
            new._set_scale(W)
        return new

    def without_contact(self) -> "DiscreteProblem":
        """The same problem without its foundation or obstacle (for contact out of reach)."""
        new = copy.copy(self)
        new.contact, new.c, new.g, new.g_max, new.bilateral = None, 0.0, 0.0, 0.0, False
        new.g_above = None
        return new

    def penetration(self, depth) -> np.ndarray:
        """The foundation's compression from ``depth`` = g - w at its points.

        A unilateral foundation acts only where the beam has sunk below it,
        (g - w)^+; a bonded one everywhere, g - w (it pulls where w > g).
        """
        return depth if self.bilateral else np.maximum(depth, 0.0)

    # ------------------------------------------------------------------ quadrature
    # The Hermite-DOF matrices below serve CVM and the scoring of results; the
    # solvers of the ground truth work on the mixed form (gaocvx.mixed).  They
    # are built on first use.  Energies are evaluated from curvatures and slopes
    # at Gauss points, not as u'Ku: the quadratic form cancels terms of size N^3
    # down to O(1) and loses ~N^4 eps, curvatures lose only ~N^2 eps.
    @functools.cached_property
    def _curvature(self):
        xq, wq, eq = fem.gauss_points(self.xi, 2)  # w'' is linear per element: exact
        return fem.eval_matrix(self.xi, xq, 2, eq)[:, self.free].tocsr(), wq

    @functools.cached_property
    def _slope(self):
        # slopes at 5 points: exact for (w')^4 (degree 8) and (w')^2
        xq, wq, eq = fem.gauss_points(self.xi, GAO_POINTS)
        B1 = fem.eval_matrix(self.xi, xq, 1, eq)[:, self.free].tocsr()
        return B1, B1.T.tocsr(), wq  # transposes are cached: gradients are hot

    @functools.cached_property
    def _contact_quadrature(self):
        xq, wq, eq = fem.gauss_points(self.xi, CONTACT_POINTS)
        Nq = fem.eval_matrix(self.xi, xq, 0, eq)[:, self.free].tocsr()
        return Nq, Nq.T.tocsr(), wq

    B2 = property(lambda self: self._curvature[0])
    wq2 = property(lambda self: self._curvature[1])
    B1 = property(lambda self: self._slope[0])
    B1T = property(lambda self: self._slope[1])
    wq_gao = property(lambda self: self._slope[2])
    Nq = property(lambda self: self._contact_quadrature[0])
    NqT = property(lambda self: self._contact_quadrature[1])
    wq_c = property(lambda self: self._contact_quadrature[2])

    @functools.cached_property
    def K(self) -> sp.csr_matrix:
        """Bending matrix on the free DOFs (non-dimensional)."""
        return fem.stiffness_matrix(self.xi)[self.free][:, self.free].tocsr()

    @functools.cached_property
    def _K_chol(self):
        return BandedCholesky(self.K) if self.n else None

    @functools.cached_property
    def G(self) -> sp.csr_matrix:
        """Geometric matrix on the free DOFs (non-dimensional)."""
        return fem.geometric_matrix(self.xi)[self.free][:, self.free].tocsr()

    # ------------------------------------------------------------------ helpers
    def _w_rows(self) -> np.ndarray:
        """Positions, within the free DOFs, of the deflection DOFs."""
        return np.flatnonzero(self.free % 2 == 0)

    @property
    def n(self) -> int:
        """Number of free DOFs."""
        return len(self.free)

    @property
    def needs_gao(self) -> bool:
        return self.a > 0

    @property
    def is_quadratic(self) -> bool:
        """True when the energy is a quadratic (no Gao term, no contact)."""
        return not self.needs_gao and self.contact is None

    def full(self, u) -> np.ndarray:
        """The full DOF vector (zeros at supports) from the free DOFs."""
        out = np.zeros(2 * self.n_nodes)
        out[self.free] = u
        return out

    def to_physical(self, u):
        """Nodal deflection [m] and slope [-] from non-dimensional free DOFs."""
        full = self.full(u)
        return full[0::2] * self.W, full[1::2] * self.W / self.L

    def from_physical(self, w, slope) -> np.ndarray:
        """Non-dimensional free DOFs from nodal deflection [m] and slope."""
        full = np.empty(2 * self.n_nodes)
        full[0::2] = np.asarray(w, float) / self.W
        full[1::2] = np.asarray(slope, float) * self.L / self.W
        return full[self.free]

    @functools.cached_property
    def P_hat_h(self) -> float | None:
        """A bonded foundation's convexity limit [N] (thesis (2.44)); None for other scenes.

        The smallest eigenvalue of (K + c M, mu G), >= P_bar_h: see
        :mod:`gaocvx.limit.bonded`.
        """
        if not self.bilateral:
            return None
        from .limit.bonded import p_hat_h
        return p_hat_h(self)

    @functools.cached_property
    def P_bar_h(self) -> float:
        """Discrete convexity limit [N]: smallest eigenvalue of (K, mu G) on the free DOFs.

        Computed in the well-conditioned slope variables of :mod:`gaocvx.limit`
        (relative error below 1e-13 at every mesh size up to 10^6 elements;
        ``limit.analysis(dp).enclosure()`` gives its bounds); infinite when
        every DOF is fixed (one clamped-clamped element).
        """
        from . import limit
        return limit.p_bar_h(self)

    @property
    def q_table(self) -> np.ndarray | None:
        """Non-dimensional load q_hat as a piecewise-linear table [[xi, q], ...] (None: no q)."""
        return None if self._q_table_unit is None else self._q_table_unit * [1.0, 1.0 / self.W]

    @property
    def point_forces(self) -> np.ndarray:
        """Non-dimensional point forces [[xi_k, F_k], ...]."""
        return self._points_unit * [1.0, 1.0 / self.W]

    # ------------------------------------------------------------------ energy
    def nonlinear_gradient(self, u) -> np.ndarray:
        """Gradient of the Gao, axial and foundation parts only (what CVM hides in u)."""
        u = np.asarray(u, float)
        return self.gradient(u) - (self.K @ u - self.f)

    def energy_parts(self, u) -> dict:
        """Non-dimensional energy parts at free DOFs ``u`` (multiply by E0 for J)."""
        u = np.asarray(u, float)
        parts = {"bending": 0.5 * (self.wq2 @ (self.B2 @ u) ** 2), "gao": 0.0, "axial": 0.0,
                 "load": -(self.f @ u), "foundation": 0.0}
        if self.needs_gao or self.p:
            s = self.B1 @ u
            parts["gao"] = self.a / 12.0 * (self.wq_gao @ s**4)
            parts["axial"] = -0.5 * self.p * (self.wq_gao @ s**2)
        if self.contact == "foundation":
            pen = self.penetration(self.g - self.Nq @ u)
            parts["foundation"] = 0.5 * ((self.c * self.wq_c) @ pen**2)
        return {k: float(v) for k, v in parts.items()}

    def energy(self, u) -> float:
        """Non-dimensional total energy."""
        return sum(self.energy_parts(u).values())

    def gradient(self, u) -> np.ndarray:
        """Gradient of the non-dimensional energy (continuous; semismooth with a foundation)."""
        u = np.asarray(u, float)
        r = self.K @ u - self.f
        if self.p:
            r -= self.p * (self.G @ u)
        if self.needs_gao:
            s = self.B1 @ u
            r += (self.a / 3.0) * (self.B1T @ (self.wq_gao * s**3))
        if self.contact == "foundation":
            pen = self.penetration(self.g - self.Nq @ u)
            r -= self.NqT @ (self.c * self.wq_c * pen)
        return r

    def hessian(self, u) -> sp.csr_matrix:
        """(Generalised) Hessian of the non-dimensional energy; banded, SPD below P_bar_h."""
        u = np.asarray(u, float)
        H = self.K - self.p * self.G if self.p else self.K.copy()
        if self.needs_gao:
            s = self.B1 @ u
            H = H + self.B1T @ sp.diags(self.a * self.wq_gao * s**2) @ self.B1
        if self.contact == "foundation":
            active = (self.g - self.Nq @ u) > 0 if not self.bilateral else 1.0
            H = H + self.NqT @ sp.diags(self.c * self.wq_c * active) @ self.Nq
        return H.tocsr()

    def residual(self, u) -> dict:
        """Optimality measure of free Hermite DOFs ``u`` (no obstacle).

        ``stationarity`` is the dual norm ``sqrt(r' H^-1 r)`` of the gradient,
        relative to the size of the problem (the energy norm of the solution or
        of the load): for a quadratic energy it is exactly the relative error in
        the energy norm.  The solvers of the ground truth certify on the better
        conditioned mixed form (:func:`gaocvx.newton.certify`); this one serves
        answers given in Hermite DOFs (CVM).
        """
        u = np.asarray(u, float)
        if self.n == 0:
            return {"stationarity": 0.0}
        r = self.gradient(u)
        H = self.hessian(u)
        try:
            chol = BandedCholesky(H)
        except NotPositiveDefinite:
            return {"stationarity": math.inf}
        # The size of the problem: the solution's energy norm, or the load's when
        # the solution is (near) zero.  Without any load the answer is w = 0, and
        # W (the unit of u) is the scale.
        load = math.sqrt(max(self.f @ chol.solve(self.f), 0.0))
        scale = max(math.sqrt(max(u @ (H @ u), 0.0)), load) if load > 0 else 1.0
        return {"stationarity": float(math.sqrt(max(r @ chol.solve(r), 0.0)) / scale)}


def _profile_knots(scene: Scene) -> list:
    """The x of a gap or stiffness table's rows inside the beam."""
    part = scene.foundation or scene.obstacle
    knots = []
    for key in ("gap", "stiffness"):
        value = getattr(part, key, None)
        if isinstance(value, tuple):
            knots += [x for x, _ in value if 0.0 < x < scene.beam.length]
    return knots


def _magnitudes(scene: Scene) -> str:
    b = scene.beam
    return f"L = {b.length:.3g} m, EI = {b.EI_eff:.3g} N m^2"

