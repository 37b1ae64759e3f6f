"""The discrete, non-dimensional energy of a scene.

:class:`DiscreteProblem` turns a :class:`~gaocvx.scene.Scene` into arrays on
the free degrees of freedom, in units where the beam has unit length and unit
bending stiffness and the deflection is measured in a scale ``W`` of the
answer's size: the mesh, the scaling, the coefficients (p, a, c, g), the load
vector and the convexity limit P_bar_h.  The energy, gradient and Hessian in
Hermite DOFs (:class:`~gaocvx.hermite.HermiteEnergy`, a part of this class)
serve CVM and the scoring of results; the ground-truth
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

import numpy as np
import scipy.sparse as sp

from . import fem
from .errors import SceneError, apart
from .hermite import CONTACT_POINTS, HermiteEnergy
from .linalg import BandedCholesky
from .scene import Scene

__all__ = ["DiscreteProblem"]


class DiscreteProblem(HermiteEnergy):
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
        The deflection scale [m]; by default the size of the linear answer, or
        a bonded foundation's largest gap where larger.

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
    bonded_pull : float
        A bonded foundation's largest gap [m] (0 without one): it pulls the beam
        that far whatever the load.
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
                P, limit = apart(self.P, self.P_hat_h)
                raise SceneError(
                    "load.axial", f"P = {P} N is not provably below the convexity "
                    f"limit P_hat_h = {limit} N of the beam on its bonded "
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
        # A bonded foundation with a gap pulls the beam towards it, a load the
        # linear answer above leaves out: the gap is the first guess where larger
        # (a P2 beam on a bonded bed 1.06 mm below under a weak load table: W =
        # 1.0e-7 m, the answer's 1e4 times that, and every Clarabel rung failed).
        bonded = scene.contact == "foundation" and scene.foundation.bilateral
        pull = float(np.max(scene.gap_at(np.linspace(0.0, L, 65)))) if bonded else 0.0
        self.bonded_pull = pull
        if W_fixed is not None:
            self.W = float(W_fixed)  # a sweep keeps one scale for all its scenes
        elif max(w_lin, pull) > 0:
            self.W = max(float(w_lin), pull)
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

