"""The energy of a :class:`~gaocvx.discrete.DiscreteProblem` in Hermite DOFs.

The Hermite-DOF energy, gradient, Hessian and residual serve CVM and the
scoring of results given in Hermite DOFs (:mod:`gaocvx.verify`); the solvers
of the ground truth work on the same energy in the better-conditioned
variables of :class:`~gaocvx.mixed.MixedForm`.  :class:`HermiteEnergy` is the
part of :class:`~gaocvx.discrete.DiscreteProblem` that evaluates them: it
reads the problem's mesh (``xi``, ``free``), matrices (``K``, ``G``), load
``f`` and coefficients (``p``, ``a``, ``c``, ``g``, ``contact``,
``bilateral``).

Examples
--------
>>> import numpy as np
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> scene = Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P4",
...     "length": 1.0, "E": 2.1e11, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -5e7}, "mesh": {"elements": 8}})
>>> dp = DiscreteProblem(scene)
>>> u = np.linalg.solve(dp.K.toarray(), dp.f)       # the quadratic energy's minimiser
>>> dp.residual(u)["stationarity"] < 1e-12
True
>>> bool(np.isclose(dp.energy(u), -0.5 * dp.f @ u))
True
"""

from __future__ import annotations

import functools
import math

import numpy as np
import scipy.sparse as sp

from . import fem
from .linalg import BandedCholesky, NotPositiveDefinite

__all__ = ["HermiteEnergy", "GAO_POINTS", "CONTACT_POINTS"]

GAO_POINTS = 5       # exact for the degree-8 integrand (w')^4
CONTACT_POINTS = 5   # Gauss points of the foundation term (and obstacle constraints)


class HermiteEnergy:
    """Energy, gradient, Hessian and residual at free Hermite DOFs (a part of DiscreteProblem)."""

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

    def energy_size(self, u) -> float:
        """The energy's scale at ``u``: the sum of the parts' magnitudes.

        The parts cancel (the axial term against the bending and Gao terms above
        the limit), so the total's round-off is eps times this, not times the
        total: every relative tolerance on an energy or a residual force's work is
        taken against it.
        """
        return sum(abs(v) for v in self.energy_parts(u).values())

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

    def hessian(self, u, active=None) -> sp.csr_matrix:
        """(Generalised) Hessian of the non-dimensional energy; banded, SPD below P_bar_h.

        ``active`` marks the foundation's quadrature points whose term is held
        (default: those with ``g - w > 0``, every one on a bilateral bed); the
        near-flat searches hold or release points at the bed's edge by it.
        """
        u = np.asarray(u, float)
        H = self.K - self.p * self.G if self.p else self.K.copy()
        if self.needs_gao:
            s = self.B1 @ u
            H = H + self.B1T @ sp.diags(self.a * self.wq_gao * s**2) @ self.B1
        if self.contact == "foundation":
            if active is None:
                active = (self.g - self.Nq @ u) > 0 if not self.bilateral else 1.0
            H = H + self.NqT @ sp.diags(self.c * self.wq_c * active) @ self.Nq
        return H.tocsr()

    def residual(self, u) -> dict:
        """Optimality measure of free Hermite DOFs ``u`` (no obstacle).

        ``stationarity`` is the dual norm ``sqrt(r' H^-1 r)`` of the gradient,
        relative to the size of the problem (the energy norm of the solution or
        of the load): for a quadratic energy it is exactly the relative error in
        the energy norm.  The solvers of the ground truth certify on the better
        conditioned mixed form (:func:`gaocvx.certificate.certify`); this one serves
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
