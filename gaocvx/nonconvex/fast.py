"""The fast path: node problems through the mixed form's banded Newton machinery (any N).

For fixed amplitudes ``s`` of the unstable modes the reduced function is
``F(s) = min Pi(z)`` over the mixed variables ``z`` with the linking
constraints ``C z = 0`` and the k constraints ``B z = s``
(``B = (G Phi)' T``, ``T`` mapping ``z`` to the Hermite DOFs): on that slice
the energy is strictly convex (the unstable directions are fixed), so damped
Newton converges from anywhere on it.  Each step solves the banded KKT system
of :class:`gaocvx.mixed.MixedForm` (LU, so the Hessian need not be definite
off the slice) bordered by the k rows of ``B`` (a Schur complement of size k;
once a slice fails, the whole bordered system by sparse LU: just above the
limit the Schur complement cancels to round-off).
The envelope theorem gives ``dF/ds = -nu``, the multipliers of ``B z = s``.

Differentiating the slice's optimality conditions gives its Hessian too,
``F'' = S^-1``.  A node problem is then the minimum over a box of the convex
function ``G(s) = F(s) + sum c_i s_i^2 + chord(s)`` (k <= 5 variables), found
by projected Newton with that Hessian, and ``G(s0) + min_box G'(s0)(s - s0)``
is a lower bound by convexity at whatever point ``s0`` it stops.  Obstacles
and channels are not handled here: :mod:`.fast_contact` (and the dense
programs of :mod:`.node`) handle them.

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> from gaocvx.nonconvex.modes import unstable_modes
>>> from gaocvx.nonconvex.node import NodeProgram
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 16}})
>>> dp = DiscreteProblem(scene, check_convexity=False)
>>> m = unstable_modes(dp)
>>> F, dF, u, ok = FastProgram(dp, m).reduced([1.0])
>>> G, dG, _, _ = NodeProgram(dp, m).reduced([1.0])     # the dense program agrees
>>> ok, abs(F - G) < 1e-8 * abs(G), bool(abs(dF[0] - dG[0]) < 1e-6 * abs(dG[0]))
(True, True, True)
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..mixed import MixedForm
from .polish import to_mixed
from .node import NodeSolution
from .slice_algebra import BorderedMatrix, box_qp

__all__ = ["FastProgram", "box_qp"]

# Projected Newton steps per node at most, and the relative gap between a node's
# value and its convexity bound at which they stop.
MAX_OUTER = 30
BOUND_TOL = 1e-14
# What a node's bound allows for the slice solves' own accuracy (Newton to
# round-off, ~1e-16 of the energy), relative to its value.
SLICE_ACCURACY = 1e-13
# Slices by the whole bordered system after a banded one fails, before the banded
# ones are tried again (doubled at every failure: FastProgram.reduced_hessian).
BORDERED_SLICES = 64
# A box whose value lies below the branch and bound's cutoff is split whatever its
# exact bound: its projected Newton stops once the bound lies within this fraction
# of the value's distance from the cutoff (the bound is one at any point, and
# orders the boxes).  Measured on the four-to-six-mode scenes in one run
# (benchmarks/nonconvex.py early): 1.7 to 2.4 times faster at 0.5 than at 0, nodes
# within 4 %, the same certified energies to 2e-16 of the scale; P1 at 5 P_bar_h
# (k = 3) twice as fast.  Most of a many-mode search's boxes are such, and took 4
# to 50 slices each.
EARLY = 0.5


class FastProgram:
    """Node programs of one problem (no obstacle) by banded Newton on slices.

    Parameters
    ----------
    dp : DiscreteProblem
    modes : Modes
    """

    rows = levels = None  # no obstacle

    def __init__(self, dp, modes):
        self.dp, self.modes, self.k = dp, modes, modes.k
        self.mf = mf = MixedForm(dp)
        # T: free mixed z -> free Hermite u (w_i, theta_i); B = (G Phi)' T.
        nn = dp.n_nodes
        rows, cols = [], []
        for i in range(nn):
            rows += [2 * i, 2 * i + 1]
            cols += [3 * i, 3 * i + 1]
        T_full = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(2 * nn, mf.nz))
        self.T = T_full[dp.free][:, mf.free].tocsr()
        self.B = np.asarray((self.T.T @ np.asarray(dp.G @ modes.phi)).T)
        self.solves = 0
        self._z = np.zeros(mf.n)
        self._s = None  # the last node's minimiser: the next node's start
        self.bordered = False  # slices by the whole bordered system (_bordered_step)
        self._border = None    # its sparsity pattern, built at the first such step
        self._slice_energy = None  # Pi of the last slice's z, where its search had it
        # (set by hand, bordered stays: a test of the bordered slices)
        self._bordered_until, self._bordered_run = math.inf, BORDERED_SLICES

    def energy(self, u) -> float:
        """The energy of free Hermite DOFs ``u`` in the mixed form (non-dimensional)."""
        return sum(self.mf.energy_parts(to_mixed(self.mf, u)).values())

    def _slice(self, s, z, max_iter=60):
        """Damped Newton on the slice ``B z = s``; returns ``z``, ``nu``, ``F''`` and convergence.

        ``F'' = S^-1`` (the Schur complement's inverse), or ``-Y`` from the
        whole bordered system (:meth:`_bordered_step`); a singular system ends
        the slice unconverged (the caller then tries the bordered one).
        """
        mf, B = self.mf, self.B
        ok = False
        nu = np.zeros(self.k)
        hess = np.full((self.k, self.k), np.nan)
        previous = math.inf
        # Pi(z) where known: the line search's last value is the next step's first
        # (about half of a slice's energy evaluations before), and the slice's F.
        energy = None
        for it in range(max_iter):
            g = mf.gradient(z)
            H = mf.hessian(z)
            try:
                if self.bordered:
                    d, nu, Y = self._bordered_step(H, g, mf.link(z), s - B @ z)
                    hess = -Y
                else:
                    factor = mf.kkt_factor(H)
                    # (the Newton right-hand side and B's k rows in one banded solve)
                    R, _ = factor.solve(np.column_stack([-g, B.T]),
                                        np.column_stack([-mf.link(z), np.zeros((mf.N, self.k))]))
                    r0, X = R[:, 0], R[:, 1:]
                    S = B @ X
                    nu = np.linalg.solve(S, B @ r0 - (s - B @ z))
                    d = r0 - X @ nu
                    hess = np.linalg.inv(S)
            except np.linalg.LinAlgError:
                self._slice_energy = energy
                return z, nu, np.full((self.k, self.k), np.nan), False
            feasible = np.linalg.norm(B @ z - s) <= 1e-12 * (1 + np.linalg.norm(s)) and \
                np.linalg.norm(mf.link(z)) <= 1e-12 * (1 + np.linalg.norm(z))
            dec = float(d @ (H @ d))
            if not feasible:
                # The first step lands on the slice (linear constraints), up to the
                # solve's round-off: on a stiff bed that left the link 2.5e-12 of |z|
                # from it (above the test's 1e-12) at every step, and every slice of
                # a P2 beam on 152 elements failed (gap inf, `inaccurate`).  The
                # chord slopes recomputed from w meet it to round-off (B z does not
                # involve them).
                z, energy = mf.on_manifold(z + d), None
                continue
            # damped Newton on the slice: the energy is convex there
            t = 1.0
            e0 = sum(mf.energy_parts(z).values()) if energy is None else energy
            slope = float(g @ d)
            descended = False
            while t > 1e-10:
                e1 = sum(mf.energy_parts(z + t * d).values())
                if e1 <= e0 + 1e-4 * t * slope or abs(dec) < 1e-20 * max(abs(e0), 1.0):
                    descended = True
                    break
                t *= 0.5
            z = z + t * d
            energy = e1 if descended else None
            # Converged at round-off: a decrement (squared energy-norm step) below
            # 1e-16 of the energy that no longer falls quadratically, or a step
            # below round-off (the decrement's round-off floor grows with N) that
            # the line search took, or took at a round-off decrement: a search cut
            # to t = 1e-10 without descent made any step look converged, and its
            # slice fed a node's lower bound (found by a review).
            small = abs(dec) <= 1e-16 * max(abs(e0), 1e-300)
            tiny_step = np.linalg.norm(t * d) <= 1e-15 * max(np.linalg.norm(z), 1e-300)
            if (small and (abs(dec) > 0.01 * previous or abs(dec) <= 1e-26 * abs(e0))) or \
                    (tiny_step and (descended or small)):
                ok = True
                break
            previous = abs(dec)
        self._slice_energy = energy
        return z, nu, hess, ok

    def _bordered_step(self, H, g, link, r):
        """The slice's Newton step from the whole bordered system
        ``[[H, C', B'], [C, 0, 0], [B, 0, 0]]`` by sparse LU.

        The Schur complement needs ``H^-1``, and just above the limit H is nearly
        singular along the mode: ``d = r0 - X nu`` then cancels all but round-off
        (P4 on a bed 3e-5 above the limit, 300 elements: ``|r0|`` 1e11 times
        ``|d|``, and no slice converged).  The bordered matrix is regular there
        (H is definite on the slice).

        Parameters
        ----------
        H : Hessian
            The mixed energy's Hessian at the slice's current ``z``.
        g, link : ndarray
            Its gradient and linking residual there.
        r : ndarray
            ``s - B z``, the slice's own residual.

        Returns
        -------
        d : ndarray
            The step in ``z``.
        nu : ndarray
            The multipliers of ``B z = s`` after it (``dF/ds = -nu``).
        Y : ndarray
            The multipliers' block of the solve with right-hand side ``(0, 0, I)``:
            ``-S^-1``, so ``F'' = -Y`` without inverting S (nearly singular along the
            mode just where this is used).
        """
        mf, k, st = self.mf, self.k, self.mf.structure
        ab = H.band()
        if self._border is None:
            self._border = BorderedMatrix(ab.shape, st.lo, st.up, self.B, st.order)
        M = self._border.matrix(ab)
        m = ab.shape[1]
        rhs = np.zeros((m + k, 1 + k))
        rhs[:m, 0] = np.concatenate([-g, -link])[st.order]
        rhs[m:, 0] = r
        rhs[m:, 1:] = np.eye(k)
        try:
            x = spla.splu(M).solve(rhs)
        except RuntimeError as exc:   # (SuperLU: "Factor is exactly singular")
            raise np.linalg.LinAlgError(str(exc)) from exc
        d = np.empty(m)
        d[st.order] = x[:m, 0]
        return d[:mf.n], x[m:, 0], x[m:, 1:]

    def reduced(self, s0):
        """``F(s0)``, its gradient ``-nu``, the free Hermite DOFs and convergence."""
        F, dF, _, u, ok = self.reduced_hessian(s0)
        return F, dF, u, ok

    def reduced_hessian(self, s0):
        """``F(s0)``, its gradient ``-nu``, its Hessian ``S^-1``, the free Hermite DOFs, convergence.

        The multipliers' sensitivity on the slice: ``dz = -X dnu``,
        ``B dz = ds``, so ``dnu/ds = -S^-1`` and ``F'' = S^-1`` (S, the bordered
        system's Schur complement, from the last Newton step).
        """
        s0 = np.asarray(s0, float)
        self.solves += 1
        # Without load, at s = 0 the straight beam is the slice's answer exactly:
        # started there it stays exactly straight, where the previous slice's answer
        # left w of 1e-187.  (Only then: with a load and a stiff unilateral bed the
        # start at w = 0 stalled the node bounds, campaign scene 8:3.)
        zero = not np.any(s0) and not self.mf.has_load
        start = np.zeros(self.mf.n) if zero else self._z.copy()
        if self.bordered and self.solves > self._bordered_until:
            self.bordered = False    # the banded slices tried again
        z, nu, hess, ok = self._slice(s0, start)
        if not np.all(np.isfinite(z)):
            start = np.zeros(self.mf.n)
            z, nu, hess, ok = self._slice(s0, start)
        if not ok and not self.bordered:
            # (the Schur complement's round-off, :meth:`_bordered_step`: the whole
            # bordered system, for the next BORDERED_SLICES solves, twice as many
            # at every new failure.  Just above the limit every banded slice fails,
            # and each retry costs a failed slice; elsewhere one slice may fail
            # for another reason, and the bordered ones cost 1.2 to 6 times more:
            # a five-mode bonded bed switched at its 40880th of 62914, 50 s with
            # the rest bordered, 41 s with that slice alone.)
            self.bordered = True
            self._bordered_until = self.solves + self._bordered_run
            self._bordered_run *= 2
            z, nu, hess, ok = self._slice(s0, start)
        self._z = z
        F = self._slice_energy
        if F is None:
            F = sum(self.mf.energy_parts(z).values())
        return float(F), -nu, 0.5 * (hess + hess.T), self.mf.to_hermite(z), ok

    def obstacle_multipliers(self):
        return None

    # bnb passes the level above which a node's bound closes its box (``cutoff``).
    takes_cutoff = True

    def solve_box(self, lo, hi, cutoff: float = math.inf) -> NodeSolution:
        """Minimise ``G(s) = F(s) + sum c_i s_i^2 + chord`` on ``[lo, hi]``; bound by convexity.

        Projected Newton with the exact Hessian ``S^-1 + 2 diag(c)``: each step
        minimises the quadratic model over the box exactly (:func:`box_qp`), and
        a backtracking line search on G keeps the values falling.  Whatever the
        last point ``s0``, ``G(s0) + min_box G'(s0)(s - s0)`` is a lower bound
        (G is convex); the iteration stops when it lies within
        :data:`BOUND_TOL` of ``G(s0)``, or as soon as it lies above ``cutoff``:
        the branch and bound closes such a box whatever its exact minimum (far
        boxes, most of a many-mode search, then take one or two slice solves
        instead of a dozen), or once its value lies below ``cutoff`` and the
        bound within :data:`EARLY` of the distance between them: such a box is
        split whatever its exact minimum.
        """
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        c = np.asarray(self.modes.c, float)
        slope, offset = -c * (lo + hi), float(np.sum(c * lo * hi))

        def G(s):
            F, dF, hess, u, ok = self.reduced_hessian(s)
            value = F + float(np.sum(c * s * s)) + float(slope @ s) + offset
            return value, dF + 2 * c * s + slope, hess + 2 * np.diag(c), u, ok

        def bound(s, value, grad):
            return value + float(np.sum(np.minimum(grad * (lo - s), grad * (hi - s))))

        s = np.clip(self._s if self._s is not None else 0.5 * (lo + hi), lo, hi)
        value, grad, hess, u, ok = G(s)
        lower = bound(s, value, grad)
        for _ in range(MAX_OUTER):
            if not (ok and np.all(np.isfinite(hess))):
                break
            if value - lower <= BOUND_TOL * max(abs(value), 1.0) or \
                    lower - SLICE_ACCURACY * max(abs(value), 1.0) > cutoff:
                break
            if value < cutoff < math.inf and value - lower <= EARLY * (cutoff - value):
                break     # (to be split: EARLY's notes)
            d = box_qp(hess, grad, lo - s, hi - s)
            t, slope_d = 1.0, float(grad @ d)
            while True:
                trial = np.clip(s + t * d, lo, hi)
                tv, tg, th, tu, tok = G(trial)
                # (a slice solve that failed is a step too long, not the node's end:
                # a full step from a box corner once failed where half of it did not,
                # and the node stopped at the corner 815 above its bound)
                if (tok and tv <= value + 1e-4 * t * slope_d) or t < 1e-8:
                    break
                t *= 0.5
            if not tok or not tv <= value:
                break
            moved = np.max(np.abs(trial - s)) > 1e-13 * max(float(np.max(hi - lo)), 1e-300)
            s, value, grad, hess, u, ok = trial, tv, tg, th, tu, tok
            if not moved:   # at round-off: the gradient's noise is the bound's floor
                lower = max(lower, bound(s, value, grad))
                break
            lower = max(lower, bound(s, value, grad))
        self._s = s
        # the slice solves' own accuracy (Newton to round-off, ~1e-16 of the energy)
        lower -= SLICE_ACCURACY * max(abs(value), 1.0)
        return NodeSolution(lower, value, s, u, None, ok, "optimal" if ok else "inaccurate")
