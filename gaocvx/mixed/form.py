"""The mixed form of a discrete problem: energy, gradient, Hessian, scales of the certificate."""


from __future__ import annotations

import functools
import math

import numpy as np
import scipy.sparse as sp

from ..discrete import DiscreteProblem
from ..tolerances import OBSTACLE_CONTACT_TOL, ZERO_ANSWER
from .kkt import Hessian, KKTFactor
from .structure import structure_of


__all__ = ["MixedForm"]


class MixedForm:
    """The energy of a :class:`DiscreteProblem` in the variables (w, theta, D).

    Parameters
    ----------
    dp : DiscreteProblem
        Provides the mesh, the scaling and the coefficients.
    origin : ndarray, optional
        The variables are ``z - origin`` (default: zero); see :meth:`on_obstacle`.

    The mesh-dependent matrices (``B2``, ``B1``, ``Nq``, ``A``, ``C``, ...) are
    those of the shared :class:`MixedStructure`, reachable as attributes.
    """

    def __init__(self, dp: DiscreteProblem, origin=None):
        self.dp = dp
        self.structure = structure_of(dp)
        # Load: the Hermite load vector acts on (w_i, theta_i).
        F = np.zeros(2 * dp.n_nodes)
        F[dp.free] = dp.f
        fz = np.zeros(self.nz)
        fz[0::3] = F[0::2]
        fz[1::3] = F[1::2]
        self.f = fz[self.free]
        # The variables are z - origin.  Quantities that vanish at the answer
        # (w - g in a contact zone) are then computed from small numbers, not as
        # differences of large ones: with an obstacle penalty of 1e10 a round-off
        # of 1e-16 |g| in w - g would be a force error of 1e-6 |g|.
        self.origin = np.zeros(self.n) if origin is None else np.asarray(origin, float)
        o = self.origin
        self._curv0 = self.B2 @ o
        self._link0 = self.C @ o
        self._load0 = float(self.f @ o)
        if self.has_slope:
            self._slope0 = self.B1 @ o
        if dp.contact is not None:
            self._depth0 = dp.g - self.Nq @ o
        if dp.contact == "obstacle":
            self._gap0 = self.A @ o - self.level

    @classmethod
    def on_obstacle(cls, dp: DiscreteProblem) -> "MixedForm":
        """The form with its origin at the beam lying flat at the obstacle's level."""
        s = structure_of(dp)
        origin = np.zeros(s.nz)
        if dp.g_above is not None and dp.g_above < -dp.g_max:
            origin[0::3] = dp.g_above   # a channel whose upper surface is the nearer
        else:
            origin[0::3] = dp.level_at(dp.xi)
        return cls(dp, origin[s.free])

    def __getattr__(self, name):
        # Only reached for names not set on the instance: the mesh's matrices.
        if name == "structure":
            raise AttributeError(name)
        return getattr(self.structure, name)

    # ---------------------------------------------------------------- conversion
    def to_hermite(self, z) -> np.ndarray:
        """Free Hermite DOFs (w_i, theta_i) of ``z``."""
        full = np.zeros(self.nz)
        full[self.free] = self.absolute(z)
        u = np.empty(2 * (self.N + 1))
        u[0::2] = full[0::3]
        u[1::2] = full[1::3]
        return u[self.dp.free]

    def on_manifold(self, z) -> np.ndarray:
        """``z`` with every chord slope recomputed from its deflections (link residual zero).

        The answer a user gets is (w, theta): a solver's D that misses the
        linking constraint by its tolerance would make the energy and the
        certificate those of another function than the one reported.
        """
        z = np.array(z, float)
        z[self.d_index] += self.link(z) / np.diff(self.xi)
        return z

    def absolute(self, z) -> np.ndarray:
        """The mixed variables themselves (``z + origin``)."""
        return z + self.origin

    def curvatures(self, z) -> np.ndarray:
        """w'' at the 2-point Gauss points."""
        return self.B2 @ z + self._curv0

    def slopes(self, z) -> np.ndarray:
        """w' at the 5-point Gauss points."""
        return self.B1 @ z + self._slope0

    @functools.cached_property
    def level(self):
        """The obstacle's level g at its constraint points (a number without a profile or
        channel); a channel's upper rows carry -g_above (their rows are -A: -w >= -g_above)."""
        dp = self.dp
        if dp.g_above is None:
            return dp.level_at(self.con_points) if dp.scene.has_profile else dp.g
        m = self.n_below
        return np.r_[dp.level_at(self.con_points[:m]), np.full(len(self.con_points) - m,
                                                                 -dp.g_above)]

    def depth(self, z) -> np.ndarray:
        """g - w at the contact points (positive where the beam is below the level)."""
        return self._depth0 - self.Nq @ z

    def gap(self, z) -> np.ndarray:
        """w - g at the obstacle's constraint points (>= 0 when feasible)."""
        return self.A @ z + self._gap0

    def link(self, z) -> np.ndarray:
        """Residual of the linking constraint ``w_{e+1} - w_e - h_e D_e``."""
        return self.C @ z + self._link0

    # ---------------------------------------------------------------- energy
    def energy_parts(self, z) -> dict:
        """Non-dimensional energy parts (multiply by E0 for J)."""
        dp = self.dp
        kappa = self.curvatures(z)
        parts = {"bending": 0.5 * (self.wq2 @ (kappa * kappa)), "gao": 0.0,
                 "axial": 0.0, "load": -(self.f @ z + self._load0), "foundation": 0.0}
        if self.has_slope:
            s2 = self.slopes(z) ** 2
            parts["gao"] = dp.a / 12.0 * (self.wq5 @ (s2 * s2))
            parts["axial"] = -0.5 * dp.p * (self.wq5 @ s2)
        if dp.contact == "foundation":
            pen = dp.penetration(self.depth(z))
            parts["foundation"] = 0.5 * ((dp.c * self.wqc) @ (pen * pen))
        return {k: float(v) for k, v in parts.items()}

    def gradient(self, z, shift=None, rho=0.0, active=None) -> np.ndarray:
        """Gradient; with ``shift``/``rho``, of the obstacle's augmented Lagrangian too.

        ``active`` = (foundation mask, obstacle mask) linearises the contact
        forces on those points, ``c (g - w)`` instead of ``c (g - w)^+``: the
        model of a semismooth Newton step with a predicted active set.
        """
        dp = self.dp
        g = self.B2T @ (self.wq2 * self.curvatures(z)) - self.f
        if self.has_slope:
            s = self.slopes(z)
            g += self.B1T @ (self.wq5 * s * (dp.a / 3.0 * (s * s) - dp.p))
        if dp.contact == "foundation":
            pen = self.depth(z)
            pen = dp.penetration(pen) if active is None else pen * active[0]
            g -= self.NqT @ (dp.c * self.wqc * pen)
        if shift is not None:
            force = shift - rho * self.gap(z)
            force = np.maximum(force, 0.0) if active is None else force * active[1]
            g -= self.AT @ force
        return g

    def directional(self, z, d, shift=None, rho=0.0):
        """``t -> gradient(z + t d, shift, rho) @ d``, for a line search along ``d``.

        Every term is a function of linear images of z (curvatures, slopes,
        depths, gaps), so those of z and d are computed once and each trial
        step costs a few O(N) vector operations instead of six sparse products
        (a 256-element sweep value made 16 gradient calls, mostly here).  The
        same terms as :meth:`gradient` (the images of z + t d formed as
        image(z) + t image(d)): agreement to round-off is tested.
        """
        dp = self.dp
        c0, cd = self.curvatures(z), self.B2 @ d
        wc, fd = self.wq2 * cd, float(self.f @ d)
        if self.has_slope:
            s0, sd = self.slopes(z), self.B1 @ d
            ws = self.wq5 * sd
        if dp.contact == "foundation":
            p0, pd = self.depth(z), self.Nq @ d
            wp = dp.c * self.wqc * pd
        if shift is not None:
            g0, gd = self.gap(z), self.A @ d

        def dphi(t: float) -> float:
            out = float(wc @ (c0 + t * cd)) - fd
            if self.has_slope:
                s = s0 + t * sd
                out += float(ws @ (s * (dp.a / 3.0 * (s * s) - dp.p)))
            if dp.contact == "foundation":
                out -= float(wp @ dp.penetration(p0 - t * pd))
            if shift is not None:
                out -= float(gd @ np.maximum(shift - rho * (g0 + t * gd), 0.0))
            return out
        return dphi

    def active_sets(self, z, shift=None, rho=0.0):
        """Where the contact terms act at ``z``: (foundation mask, obstacle mask)."""
        dp = self.dp
        found = None
        if dp.contact == "foundation":  # a bonded foundation acts everywhere
            found = self.depth(z) > 0 if not dp.bilateral else np.ones(self.Nq.shape[0], bool)
        obst = (shift - rho * self.gap(z)) > 0 if shift is not None else None
        return found, obst

    def hessian(self, z, shift=None, rho=0.0, active=None) -> Hessian:
        """Generalised Hessian at ``z`` (contact terms on ``active``, default: where they act)."""
        dp = self.dp
        gao = None
        if dp.needs_gao:
            s = self.slopes(z)
            gao = self.wq5 * dp.a * (s * s)
        found, obst = self.active_sets(z, shift, rho) if active is None else active
        return Hessian(self, gao,
                       None if found is None else dp.c * self.wqc * found,
                       None if obst is None else rho * obst.astype(float))

    # ---------------------------------------------------------------- KKT solves
    @functools.cached_property
    def H0(self) -> sp.csr_matrix:
        """The bending and axial part of the Hessian: constant, so built once."""
        if self.has_slope and self.dp.p:
            return (self.bending - self.dp.p * self.axial).tocsr()
        return self.bending

    @functools.cached_property
    def base_band(self) -> np.ndarray:
        """Band array of the KKT matrix of H0 (flat)."""
        s = self.structure
        if self.has_slope and self.dp.p:
            return s.bending_band - self.dp.p * s.axial_band
        return s.bending_band

    def kkt_factor(self, H: Hessian) -> "KKTFactor":
        """Banded LU of ``[[H, C'], [C, 0]]`` in the interleaved order (reusable)."""
        s = self.structure
        # Iterative refinement only where the matrix is ill-conditioned: with the
        # obstacle's penalty.
        refine = 1 if H.obstacle is not None else 0
        return KKTFactor(H.band(), s.lo, s.up, s.order, s.n, H, self.C, refine, s.CT)

    def kkt_solve(self, H: Hessian, rhs_z, rhs_c) -> tuple[np.ndarray, np.ndarray]:
        """Solve ``[[H, C'], [C, 0]] [d; mu] = [rhs_z; rhs_c]`` as a banded system."""
        return self.kkt_factor(H).solve(rhs_z, rhs_c)

    @functools.cached_property
    def quadratic_factor(self) -> "KKTFactor":
        """KKT factor of H0 (the whole Hessian of a quadratic energy).

        H0 depends only on the mesh and p, so the factor is kept on the shared
        structure: the scenes of a sweep over load, gap or stiffness factor it once.
        """
        s = self.structure
        p = float(self.dp.p) if self.has_slope else 0.0
        factor = s.base_factors.get(p)
        if factor is None:
            factor = s.base_factors.put(p, KKTFactor(self.base_band.reshape(s.band_shape),
                                                      s.lo, s.up, s.order, s.n))
        return factor

    @functools.cached_property
    def has_load(self) -> bool:
        """True when any load acts: the load vector is not exactly zero, or a bonded
        foundation's surface lies below the beam (it pulls the beam down to it)."""
        return bool(np.any(self.f)) or bool(self.dp.bilateral and np.any(self.dp.g != 0))

    @functools.cached_property
    def load_scale(self) -> float:
        """Energy norm of the load, sqrt(f' H0^-1 f) on the constraint manifold; nan if not computable.

        H0 is the bending and axial part: the value is the size of the answer of
        the *unsupported linear* problem.  It serves only as a bound
        (:meth:`deflection_bound`), never as the size of the answer.  Near
        P_bar_h the KKT solve with H0 loses every digit: a value that is not
        positive and finite is returned as nan, never clipped.
        """
        if not self.has_load:
            return 0.0
        d, _ = self.quadratic_factor.solve(self.f, np.zeros(self.N))
        value = float(self.f @ d)
        return math.sqrt(value) if value > 0 and math.isfinite(value) else math.nan

    def deflection_bound(self) -> float:
        """An upper bound on max |w| of the minimiser (non-dimensional), from the load alone.

        The minimiser w* has energy <= 0 (w = 0 is admissible with energy 0,
        as g <= 0).  Dropping the nonnegative Gao and contact terms,
        ``1/2 |w*|_Q^2 - f'w* <= 0``, so ``|w*|_Q <= 2 |f|_{Q^-1}`` (Q: bending
        and axial; ``|f|_{Q^-1}`` is :attr:`load_scale`).  With
        ``Q >= (1 - P/P_bar_h) K`` and ``|w(x)| <= |w|_K sqrt(G(x, x))``, where G
        is the continuum Green's function (the Hermite space is a subspace) and
        ``G(x, x) <= 1/3`` for every support (the cantilever's tip, in units of
        L^3/EI), ``|w*(x)| <= 2 |f|_{Q^-1} / sqrt(3 (1 - P/P_bar_h))``.
        Infinite (no bound) when the load scale cannot be computed.
        """
        dp = self.dp
        if not self.has_load:
            return 0.0
        margin = 1.0 - dp.P / dp.P_bar_h if dp.P > 0 else 1.0
        bound = 2.0 * self.load_scale / math.sqrt(3.0 * margin) if margin > 0 else math.inf
        return bound if math.isfinite(bound) else math.inf

    @property
    def contact_out_of_reach(self) -> bool:
        """True when the foundation or obstacle lies provably below any deflection of the minimiser.

        Then the contact term vanishes near the answer and the problem is the
        contact-free one (:meth:`deflection_bound`, with a factor 2 of margin).
        """
        dp = self.dp
        if dp.bilateral:  # bonded: it acts at any distance
            return False
        bound = 2.0 * self.deflection_bound()
        above = dp.g_above is None or dp.g_above > bound   # a channel's upper surface too
        return dp.contact is not None and dp.g_max < -bound and above

    @property
    def zero_floor(self) -> float:
        """Deflection below which an answer counts as zero (non-dimensional).

        A fraction ZERO_ANSWER of the unsupported linear answer's size: only a
        beam pressed onto an obstacle (lying flat on it, or a very flexible beam
        on a very close one) has an answer that small, and relative measures of
        it would compare round-off with round-off.
        """
        if not self.has_load:
            return 1.0  # the answer is w = 0 exactly; any unit serves
        return ZERO_ANSWER * self.dp.W_linear / self.dp.W

    @property
    def size_floor(self) -> float:
        """The smallest size the global method's certificates measure an answer
        against (non-dimensional): :attr:`zero_floor` where a load acts; without
        one 0, the answer's own size (there is no linear answer to take a
        fraction of, and the floor of 1 would measure a beam buckled to less
        than W against more than itself).
        """
        return self.zero_floor if self.has_load else 0.0

    def energy_at_rest(self) -> float:
        """The energy of w = 0 (non-dimensional): 0, or a bonded foundation's 1/2 c g^2 L.

        w = 0 is admissible, so the minimiser's energy is at most this.
        """
        return float(sum(self.energy_parts(-self.origin).values())) if self.dp.bilateral else 0.0

    def no_contact_forces(self) -> np.ndarray | None:
        """Obstacle multipliers that are all zero (None without an obstacle)."""
        return np.zeros(self.A.shape[0]) if self.dp.contact == "obstacle" else None

    def in_contact(self, z, lam) -> tuple[np.ndarray, np.ndarray]:
        """Obstacle rows (touching, carrying a force) at ``z`` with multipliers ``lam``.

        Touching: within OBSTACLE_CONTACT_TOL of the answer's size.  Carrying: a
        force counts against the load it balances (interior-point multipliers
        of a beam that lifts off are ~1e-13 of it, not zero).
        """
        size = self.deflection_size(z)
        carrying = lam > 1e-9 * max(float(np.sum(np.abs(self.f))), float(np.sum(np.abs(lam))),
                                    1e-300)
        touching = (self.gap(z) <= OBSTACLE_CONTACT_TOL * size) | carrying
        return touching, carrying

    def deflection_size(self, z) -> float:
        """The answer's own size: its largest nodal |w| (non-dimensional), at least :attr:`zero_floor`."""
        w = self.absolute(z)[self.w_index]
        return max(float(np.max(np.abs(w), initial=0.0)), self.zero_floor)

    def energy_norm(self, z, H) -> float:
        """The answer's own energy norm: ``z' H z`` with the foundation counted on its penetration.

        H is the energy's Hessian (an obstacle's penalty left out).  Its
        foundation part c on the active points would weigh the whole deflection,
        c w^2, where the foundation stores only c (g - w)^2: on a very stiff
        foundation with a gap that made the scale, and with it every relative
        measure, far too large (a Newton answer 0.3-2.6 % wrong was certified).
        """
        return math.sqrt(max(self.energy_norm2(z, H), 0.0))

    def energy_norm2(self, z, H) -> float:
        """The square of :meth:`energy_norm`, not clipped: above ``P_bar_h`` the
        bending and axial terms are indefinite, and a beam a bed holds against
        its buckling has a negative one (the global method's certificate adds the
        modes' part, :func:`gaocvx.nonconvex.certificate.certify_answer`)."""
        base = Hessian(self, H.gao)
        za = self.absolute(z)
        norm2 = float(za @ (base @ za))
        if self.dp.bilateral:
            # Bonded: the foundation is part of the quadratic form (above P_bar_h
            # it is what keeps that form positive), weighing w itself.
            w = self.Nq @ za
            norm2 += float((self.dp.c * self.wqc) @ (w * w))
        elif H.foundation is not None:
            norm2 += float(H.foundation @ self.depth(z) ** 2)
        return norm2

    def scale(self, z, H) -> float:
        """The size of the answer: its own energy norm; 1 without any load.

        Relative measures divide by this.  It is the answer's own size, not the
        unsupported linear answer's: a stiff foundation or an obstacle can make
        the answer a millionth of that, and a residual small against the
        unsupported answer can then be as large as the answer itself.  The
        floor (:attr:`zero_floor`, in energy-norm units) applies only to an
        answer that is zero to within round-off.
        """
        if not self.has_load:
            return 1.0
        return max(self.energy_norm(z, H), self.zero_floor) or 1.0


