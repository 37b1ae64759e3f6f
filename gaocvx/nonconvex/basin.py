"""A box of amplitudes around a local minimiser on which no deflection lies below it.

The branch and bound (:mod:`.bnb`) bounds a box by the chord of the concave
part ``-sum c_i s_i^2``, whose error ``c_i w_i^2 / 4`` falls only as the box
shrinks.  Around a strict local minimiser ``u*`` the energy is convex, yet the
chord bound lies below ``Pi(u*)`` on every box near it until the boxes are tiny:
measured on a P4 beam on a bonded bed (k = 4, 32 elements), nine tenths of the
slice solves went to boxes whose bounds lay within 1e-9 of the minimum.  This
module proves a box ``B*`` of amplitudes around ``s* = Phi'G u*`` on which every
admissible deflection has ``Pi(u) >= Pi(u*) - r'G^-1 r / (2 m)`` (``r`` the
residual at ``u*``): the branch and bound closes every box inside it without a
node program.

The argument (no obstacle; any foundation):

1. For ``s`` in ``B*`` the slice ``{u : Phi'G u = s}`` has a unique minimiser
   ``u(s)``: on it the energy is strongly convex, with modulus ``gamma`` in two
   norms, ``(lambda_{k+1} - p) / 2`` in ``|d|_G = sqrt(d'G d)`` and
   ``(1 - p / lambda_{k+1}) / 2`` in the bending norm ``|d|_K`` (the complement's
   estimated margin, halved, as the modes' check takes it), and
   ``Pi(u) >= Pi(u(s))`` for every ``u`` with those amplitudes.
2. ``w1 = u* + Z (s - s*)`` lies on the slice, ``Z = Phi~ + V`` with
   ``Phi~ = Phi (Phi'G Phi)^-1`` and ``V`` the slice's linear response (the
   quadratic model at ``u*`` minimised over the slice's directions: a
   bordered solve), so ``|u(s) - w1| <= |grad Pi(w1)|_* / gamma`` in either
   norm, the dual norm over the slice's directions (any multiple of ``G Phi``
   may be taken off the gradient: those directions have ``Phi'G d = 0``).
   ``grad Pi(w1)`` is the residual ``r``, plus what the linear model leaves of
   ``H* Z ds`` (``H*`` the Hessian at ``u*``; its rounding), plus the Gao
   term's remainder ``a/3 B1'W (3 y d^2 + d^3)`` (``d`` the slopes' change
   along ``Z``, ``|d_q| <= D_q = sum_i |b_q'Z_i| rho_i``), plus a unilateral
   bed's change at points whose contact the box may switch (at most
   ``2 |n_q'Z ds|`` from the model's).
3. So every slope of ``u(s)`` lies within ``eta_q = D_q + min over the norms of
   sqrt(b_q'A^-1 b_q) |u(s) - w1|_A`` of ``u*``'s, where the Gao term's curvature
   is at least ``a (|y_q| - eta_q)_+^2``; with
   ``H_low = K - p G + a B1' diag(w (|y| - eta)_+^2) B1 >= m G`` proved (a
   Cholesky factorisation and its backward error, :func:`.dual.proved_margin`)
   the energy is ``m``-strongly convex on that set of deflections (a convex
   set, containing ``u*`` and every ``u(s)``), and
   ``Pi(u(s)) >= Pi(u*) - |r|_*^2 / (2 m)``.

Every number is computed at ``u*`` once; a box is tried at a scale ``tau`` and
halved until the proof holds.  The residual and ``H* Z`` are evaluated in
extended precision with a bound of their rounding (in double precision the
residual of a minimiser's DOFs is as large as its rounding on fine meshes).
What is not proved: like the node programs it trusts the modes'
``lambda_{k+1}``, and the round-off of the quadratic forms in ``G^-1`` and
``K^-1`` is allowed for from the matrices' condition (``(L/h_min)^2``,
``(L/h_min)^4``), not enclosed; ``H_low``'s margin is proved.

Examples
--------
nonconvex.md's P4 example (one mode, 16 elements), at its polished minimiser:

>>> import numpy as np
>>> from gaocvx import DiscreteProblem, Scene, solve
>>> from gaocvx.nonconvex.modes import unstable_modes
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 16}})
>>> r = solve(scene, "global")
>>> dp = DiscreteProblem(scene, check_convexity=False)
>>> u = dp.from_physical(r.w, r.slope)
>>> b = basin(dp, unstable_modes(dp), u)
>>> bool(b.lo[0] < b.s[0] < b.hi[0]), bool(0 <= dp.energy(u) - b.lower < 1e-10 * abs(dp.energy(u)))
(True, True)
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..linalg import BandedCholesky, NotPositiveDefinite
from .dual import EPS, _smallest, proved_margin, tangent_matrix
from .metric import Metric
from .node import effective_stiffness

__all__ = ["Basin", "BasinProver", "basin"]

log = logging.getLogger(__name__)

# Trials of the box's scale: halved from the first until the proof holds, then
# refined between the last success and failure.
HALVINGS = 24
REFINE = 4
# The box's half-widths are proportional to 1/sqrt(c_i) (as the branch and bound's
# boxes: equal chord errors), at most this many times the narrowest.
SHAPE_CAP = 8.0


@dataclass(frozen=True)
class Basin:
    """A box of amplitudes ``[lo, hi]`` on which ``Pi >= lower`` (non-dimensional).

    ``s`` and ``u`` are the local minimiser's amplitudes and free DOFs,
    ``margin`` the proved modulus ``m`` of strong convexity around it, and
    ``eta`` the proved bound on how far (at each Gauss point of the Gao rule)
    the slope of the energy's minimiser on any slice of the box lies from
    ``u``'s.
    """

    lo: np.ndarray
    hi: np.ndarray
    lower: float
    s: np.ndarray
    u: np.ndarray
    margin: float
    eta: np.ndarray

    def contains(self, lo, hi) -> bool:
        """Whether the box ``[lo, hi]`` lies inside this one."""
        return bool(np.all(self.lo <= lo) and np.all(hi <= self.hi))


class _Proof:
    """The quantities at ``u*`` that do not depend on the box (see the module's notes).

    The slice's correction is bounded in two norms, that of ``G`` and that of
    the (effective) bending matrix ``K``; a slope takes the smaller of the two
    bounds.  In ``G`` a slope can concentrate at one Gauss point
    (``b'G^-1 b ~ N``); in ``K`` it cannot (``b'K^-1 b = O(1)``), but the
    round-off of ``K``'s factor grows like ``N^4``.
    """

    def __init__(self, shared, u):
        dp, modes = shared.dp, shared.modes
        self.dp, self.modes, self.u = dp, modes, u
        G, Phi = dp.G, modes.phi
        K = shared.K
        self.metrics, self.kappa, self.gamma = shared.metrics, shared.kappa, shared.gamma
        self.S, self.floor = shared.S, shared.floor
        self.Pm = Phi.T @ (G @ Phi)
        Phit = np.linalg.solve(self.Pm, Phi.T).T              # Phi (Phi'G Phi)^-1
        self.s = Phi.T @ (G @ u)
        self.y = dp.B1 @ u
        self.unilateral = dp.contact == "foundation" and not dp.bilateral
        if self.unilateral:
            self.depth = dp.g - dp.Nq @ u
            self.cw = np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape)
        H = self._hessian(K)
        # The slice minimiser's first-order response to the amplitudes: u* + Z ds with
        # Z = Phi~ + V, V the minimiser over the slice's directions of the quadratic model.
        Z = Phit + self._response(H, Phit)
        self.slopes = np.abs(dp.B1 @ Z)                         # |b_q' Z_i|
        if self.unilateral:
            self.values = np.abs(dp.Nq @ Z)                     # |n_q' Z_i|
        self.linear = self._coupling(Z)
        r, r_mag = _residual(dp, u)
        # (the computed residual, and a bound of its rounding: same size at fine meshes)
        self.r_norm = [m.dual(r) + m.bound(r_mag) for m in self.metrics]
        self.energy = dp.energy(u)
        parts = dp.energy_size(u)
        # (the energy's round-off, as the dual bound allows for it)
        self.allowance = 10.0 * (dp.n_nodes + 10) * EPS * (parts + abs(self.energy))

    def _hessian(self, K):
        """``H*``, the energy's Hessian at ``u*`` (a unilateral bed where it presses)."""
        dp = self.dp
        H = K - dp.p * dp.G + dp.B1T @ sp.diags(dp.a * dp.wq_gao * self.y**2) @ dp.B1
        if self.unilateral:
            H = H + dp.NqT @ sp.diags(self.cw * (self.depth > 0)) @ dp.Nq
        return H.tocsr()

    def _response(self, H, Phit) -> np.ndarray:
        """``V``: ``Phi'G V = 0`` and ``H (Phit + V)`` along ``G Phi`` only (bordered solve)."""
        GPhi = np.asarray(self.dp.G @ self.modes.phi)
        k = GPhi.shape[1]
        A = sp.bmat([[H, sp.csr_matrix(GPhi)], [sp.csr_matrix(GPhi.T), None]], format="csc")
        rhs = np.vstack([-(H @ Phit), np.zeros((k, k))])
        V = np.asarray(spla.spsolve(A, rhs)).reshape(A.shape[0], k)[: H.shape[0]]
        # exactly on the slices (to round-off): the part along Phi~ removed
        return V - Phit @ (self.modes.phi.T @ (self.dp.G @ V))

    def _coupling(self, Z) -> list:
        """Per metric, the dual norms over the slice of the columns of ``H* Z`` (their part
        along ``G Phi`` removed), each plus its round-off: what the linear model leaves.

        ``H* Z`` from curvatures, slopes and contact values in extended precision, as
        :func:`_residual` (the assembled ``H*`` rounds its entries of size ``N^3``, and
        the rounding bound of a product with it grew to 0.07 at 1024 elements).
        """
        dp, ld = self.dp, np.longdouble
        Phi, Zl, aZ = self.modes.phi, np.asarray(Z, ld), np.abs(Z)
        w2, w5 = dp.wq2[:, None], dp.wq_gao[:, None]
        X = dp.B2.T @ (w2 * (dp.B2 @ Zl)) + dp.B1T @ (
            w5 * (ld(dp.a) * np.asarray(self.y, ld)[:, None] ** 2 - ld(dp.p)) * (dp.B1 @ Zl))
        mag = abs(dp.B2.T) @ (w2 * (abs(dp.B2) @ aZ)) + abs(dp.B1T) @ (
            w5 * (dp.a * self.y[:, None] ** 2 + abs(dp.p)) * (abs(dp.B1) @ aZ))
        if dp.contact == "foundation":
            cw = np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape)
            act = np.ones(len(cw)) if dp.bilateral else (self.depth > 0).astype(float)
            X = X + dp.NqT @ ((cw * act)[:, None] * (dp.Nq @ Zl))
            mag = mag + abs(dp.NqT) @ ((cw * act)[:, None] * (abs(dp.Nq) @ aZ))
        GPhi = dp.G @ np.asarray(Phi, ld)
        beta = np.linalg.solve(self.Pm, Phi.T @ np.asarray(X, float))
        J = np.asarray(X - GPhi @ np.asarray(beta, ld), float)
        # (a few dozen roundings in extended precision of every term's magnitude, and
        # J's own conversion to double)
        err = 40.0 * float(np.finfo(ld).eps) * (mag + abs(dp.G) @ (np.abs(Phi) @ np.abs(
            beta))) + EPS * np.abs(J)
        return [np.array([m.dual(J[:, i]) + m.bound(err[:, i]) for i in range(J.shape[1])])
                for m in self.metrics]

    def _bed(self, E):
        """Per metric, a bound on the dual norm of a unilateral bed's change where its
        contact may switch (``|Delta_q| <= 2 |n_q' e|``, ``|n_q' e| <= E_q``)."""
        unsure = np.abs(self.depth) <= E
        if not np.any(unsure):
            return [0.0, 0.0]
        idx = np.flatnonzero(unsure)
        cw, force = self.cw[idx], 2.0 * E[idx]
        kap = [m.points(self.dp.Nq[idx]) for m in self.metrics]
        return [math.sqrt(float(np.sum(cw * kap[0] ** 2)) * float(np.sum(cw * force**2))),
                float(np.sum(cw * force * kap[1]))]

    def attempt(self, rho):
        """The proof for half-widths ``rho``: ``(margin, lower, eta)`` or None."""
        dp = self.dp
        D = self.slopes @ rho
        # the Gao term's gradient beyond its linear model, at each Gauss point
        rest = dp.a / 3.0 * (3.0 * np.abs(self.y) * D**2 + D**3) * (1.0 + 1e-8)
        quartic = [math.sqrt(float(dp.wq_gao @ rest**2)), float(dp.wq_gao @ (rest * self.kappa[1]))]
        bed = self._bed(self.values @ rho) if self.unilateral else [0.0, 0.0]
        deviation = np.full(len(D), np.inf)
        for i in range(2):
            radius = (self.r_norm[i] + float(self.linear[i] @ rho) + quartic[i] + bed[i]) \
                / self.gamma[i]
            deviation = np.minimum(deviation, self.kappa[i] * radius)
        eta = D + deviation
        t = 3.0 * np.maximum(np.abs(self.y) - eta, 0.0) ** 2   # (a/3) t = a (|y| - eta)_+^2
        M = tangent_matrix(dp, t)
        try:   # (the cheap refusal first: most trials that fail fail here)
            BandedCholesky(M)
        except NotPositiveDefinite:
            return None
        estimate = _smallest(M, dp.G)
        if estimate is None or not estimate > 0:
            return None
        margin = proved_margin(dp, M, t, 0.5 * estimate, self.S, self.floor)
        if not margin > 0:
            return None
        lower = self.energy - self.r_norm[0] ** 2 / (2.0 * margin) - self.allowance
        return margin, lower, eta


def _residual(dp, u):
    """The energy's gradient at ``u``, and a bound of its rounding at every entry.

    From curvatures and slopes, as the energy is evaluated, and in extended
    precision (``numpy.longdouble``): in double precision the rounding of the
    gradient of a minimiser's DOFs is as large as the gradient itself on fine
    meshes (terms of size ``N^3`` cancel), and it enters the basin's bound
    squared.  The bound is a few dozen roundings of the terms' magnitudes in
    that precision (the matrices' entries are the energy's own, exact as stored).
    """
    ld = np.longdouble
    x = np.asarray(u, ld)
    au = np.abs(np.asarray(u, float))
    kappa, y = dp.B2 @ x, dp.B1 @ x
    w5 = dp.wq_gao
    r = dp.B2.T @ (dp.wq2 * kappa) - dp.f
    mag = abs(dp.B2.T) @ (dp.wq2 * (abs(dp.B2) @ au)) + np.abs(dp.f)
    if dp.p or dp.a:
        r = r + dp.B1T @ (w5 * y * (ld(dp.a) / 3 * y * y - ld(dp.p)))
        ay = abs(dp.B1) @ au
        mag = mag + abs(dp.B1T) @ (w5 * ay * (dp.a / 3.0 * ay * ay + abs(dp.p)))
    if dp.contact == "foundation":
        cw = np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape)
        pen = dp.penetration(dp.g - dp.Nq @ x)
        r = r - dp.NqT @ (cw * pen)
        mag = mag + abs(dp.NqT) @ (cw * (np.abs(dp.g) + abs(dp.Nq) @ au))
    # (its conversion to double adds one rounding of r itself)
    r64 = np.asarray(r, float)
    return r64, 40.0 * float(np.finfo(ld).eps) * mag + EPS * np.abs(r64)


class BasinProver:
    """Basins of one problem (what does not depend on the minimiser is computed once).

    Parameters
    ----------
    dp : DiscreteProblem
        Without an obstacle, in the units of the branch and bound.
    modes : Modes
        Its unstable modes (verified).
    """

    def __init__(self, dp, modes):
        self.dp, self.modes = dp, modes
        self.usable = (dp.contact != "obstacle" and modes.k > 0 and modes.verified
                       and dp.a > 0 and dp.n > 0)
        self._ready = False

    def _prepare(self):
        """The two metrics and the slopes' bounds in them (``O(N^2)``: once per problem)."""
        dp = self.dp
        self.K = effective_stiffness(self.dp)
        self.metrics = (Metric(dp.G, dp.xi, 2), Metric(self.K, dp.xi, 4))
        self.kappa = [m.points(dp.B1) for m in self.metrics]
        lam_next = float(self.modes.lam_next)
        # strong convexity on the slices: K - p G >= (lambda_{k+1} - p) G and
        # >= (1 - p / lambda_{k+1}) K on the complement of the modes; halved, as the
        # modes' margin takes it (lambda_{k+1} is an estimate)
        self.gamma = ((0.5 * (lam_next - dp.p), 0.5 * (1.0 - dp.p / lam_next))
                      if math.isfinite(lam_next) else (math.inf, math.inf))
        self.S, self.floor = self.metrics[0].S, self.metrics[0].floor
        self._ready = True

    def prove(self, u, scale: float | None = None) -> Basin | None:
        """The largest proved box of amplitudes around the local minimiser ``u`` (or None).

        Parameters
        ----------
        u : ndarray
            Free Hermite DOFs of a (polished) local minimiser.
        scale : float, optional
            The first half-width tried along the stiffest mode (default: the
            amplitudes' size ``|s*|``).

        Returns
        -------
        Basin or None
            None where no box is proved (not a strict local minimiser, an
            obstacle, modes that failed their checks).
        """
        if not self.usable:
            return None
        try:
            if not self._ready:
                self._prepare()
            proof = _Proof(self, np.asarray(u, float))
        except (NotPositiveDefinite, np.linalg.LinAlgError):
            return None
        if not min(self.gamma) > 0 or not self.floor > 0:
            return None
        c = np.asarray(self.modes.c, float)
        shape = np.minimum(np.sqrt(np.max(c) / np.maximum(c, 1e-300)), SHAPE_CAP)
        tau = float(scale) if scale else max(float(np.linalg.norm(proof.s)), 1e-300)
        good, bad = None, None
        for _ in range(HALVINGS):
            out = proof.attempt(tau * shape)
            if out is not None:
                good = (tau, out)
                break
            bad, tau = tau, 0.5 * tau
        if good is None:
            log.info("basin: no box proved around the candidate")
            return None
        if bad is not None:
            lo_tau, hi_tau = good[0], bad
            for _ in range(REFINE):
                mid = math.sqrt(lo_tau * hi_tau)
                out = proof.attempt(mid * shape)
                if out is None:
                    hi_tau = mid
                else:
                    lo_tau, good = mid, (mid, out)
        tau, (margin, lower, eta) = good
        # The dense node programs' amplitudes are (Phi'G Phi)^-1 Phi'G u, these Phi'G u:
        # the box is narrowed by what the two may differ by (~1e-10 of them).
        rho = tau * shape
        rho = rho - (float(np.max(np.abs(proof.Pm - np.eye(len(rho))).sum(axis=1))) + 1e-12) * (
            float(np.max(np.abs(proof.s))) + float(np.max(rho)))
        if not np.all(rho > 0):
            return None
        log.info("basin: box of half-widths %s proved around s = %s (margin %.3g)",
                 np.array2string(rho, precision=3), np.array2string(proof.s, precision=4),
                 margin)
        return Basin(proof.s - rho, proof.s + rho, float(lower), proof.s, proof.u,
                     float(margin), eta)


def basin(dp, modes, u, scale: float | None = None) -> Basin | None:
    """The largest proved box of amplitudes around the local minimiser ``u`` (or None).

    ``BasinProver(dp, modes).prove(u, scale)``: see :class:`BasinProver`.
    """
    return BasinProver(dp, modes).prove(u, scale)
