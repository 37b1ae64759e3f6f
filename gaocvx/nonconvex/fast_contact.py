"""The fast path with a rigid obstacle or a channel: node problems by Newton and duality (any N).

A node problem on a box ``lo <= s <= hi`` of the unstable modes' amplitudes
is (nonconvex.md, :mod:`.node`), in the mixed variables ``z`` of
:class:`gaocvx.mixed.MixedForm` with ``s = B z`` (``B = (G Phi)' T``)::

    min  J(z) = Pi(z) + sum c_i s_i^2 + chord(s)    subject to
         C z = 0 (linking),  A z >= g (obstacle rows),  lo <= B z <= hi.

``Pi + sum c_i s_i^2 = Psi`` is convex, the chord is linear: a convex program
with linear constraints.  Unlike :class:`.fast.FastProgram` the amplitudes
are not fixed on slices: the box rows are inequalities of the same program,
and the Hessian ``H + 2 B' diag(c) B`` is the banded Hessian of the mixed
form plus a rank-k term, solved by the banded KKT LU and the Woodbury
identity (a k x k capacitance matrix).

**Primal.**  The method of multipliers (as :mod:`gaocvx.contact_newton`):
semismooth Newton on the augmented Lagrangian of the obstacle rows (penalty
``certificate.penalty_range``'s largest) and of the 2k box rows, multipliers updated
``lam <- max(0, lam - rho gap)`` until the rows are violated by at most
:data:`FEASIBLE` of the answer's size.  Its iterate gives the node's upper
bound (the true energy, judged feasible or not by the caller) and the
multipliers.

**Lower bound (the argument).**  For *any* ``lam >= 0`` (obstacle rows) and
``eta >= 0`` (box rows) and every admissible ``z`` of the node problem,
``L(z) = J(z) - lam'gap(z) - eta'boxgap(z) <= J(z)``, since the subtracted
terms are products of non-negative numbers.  So the node's minimum is at least
``min {L(z) : C z = 0}`` (weak duality; no convexity needed for this step).
``L`` is ``Psi`` plus linear terms: convex, and coercive (the quartic Gao term
bounds it in the modes' directions, ``K - p G`` on the complement), so its
minimum over the linking constraint is found by Newton's method, whose
iterate is checked to have converged to round-off.  The bound taken is
``L(z_L) - dec - 1e-12 max(|L|, T, 1)`` with ``dec = d'(Hd)`` the last squared
Newton decrement (for a convex function near its minimum ``L - min L`` is about
``dec / 2``) and ``T`` the sum of the magnitudes of the terms summed (energy
parts, multipliers times gaps, the chord): the round-off of sums of 10^4
quadrature terms at 2048 elements.
It is valid however inexact the multipliers are: inexact multipliers only
make it weaker (and the branch and bound then does not close, which shows
as ``inaccurate``).  With the multipliers of the last update, the augmented
Lagrangian's iterate is itself the minimiser of ``L`` (its gradient is
``grad J - A' lam_new - B_box' eta_new``), so this Newton starts converged,
and ``J - L = lam'gap + eta'boxgap`` at it is the node's own duality gap.

**Infeasible amplitudes.**  An obstacle bounds some amplitudes (a beam that
must stay above ``g`` cannot buckle down without limit; a channel bounds all
of them).  Each amplitude's range over the admissible set is found once by a
linear program (HiGHS) and widened by ``fast_check.RANGE_PAD``; a box outside it is
infeasible (bound +inf), a box across its end is cut to it (no admissible
point is lost: the range is a superset; :func:`.fast_check.amplitude_range`).  Within the range, a box with no
admissible point (k >= 2, a corner) still gets a valid bound from the
multipliers, which grow with each update.

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> from gaocvx.nonconvex.modes import unstable_modes
>>> from gaocvx.nonconvex.node import NodeProgram
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e8, "axial": 1.5e9}, "obstacle": {"gap": 0.01},
...     "mesh": {"elements": 8}})
>>> dp = DiscreteProblem(scene, check_convexity=False)
>>> m = unstable_modes(dp)
>>> fast, dense = FastContactProgram(dp, m), NodeProgram(dp, m)
>>> a, b = fast.solve_box([-3.0], [3.0]), dense.solve_box([-3.0], [3.0])
>>> # each bound below the energy of the other's minimiser (a beam in the box)
>>> bool(a.lower <= dp.energy(b.u) + 1e-9 and b.lower <= dp.energy(a.u) + 1e-9)
True
>>> bool(abs(a.value - b.value) < 1e-8 * abs(b.value))
True
"""

from __future__ import annotations

import logging
import math

import numpy as np

from ..certificate import penalty_range
from ..contact_newton import RHO_START
from ..linalg import one_blas_thread
from ..mixed import MixedForm
from ..newton import line_search
from .fast import FastProgram
from .node import NodeSolution, obstacle_rows

__all__ = ["FastContactProgram", "FEASIBLE"]

log = logging.getLogger(__name__)

# The multiplier updates stop when no row is violated by more than this fraction
# of the answer's size (contact_newton stops at 1e-9; the caller accepts 1e-9).
FEASIBLE = 1e-11
# A node answer violating the rows by more than this (relative to its size, as the
# caller's test of admissibility) is no beam: the reduced function is infinite there.
ADMISSIBLE = 1e-9
# Multiplier updates per node at most, Newton steps per inner problem at most.
MAX_UPDATES = 40
MAX_NEWTON = 60
# The round-off margin of a bound, relative to the sum of the magnitudes of the
# terms of the Lagrangian (ten times FastProgram's 1e-13 of the value: sums of 10^4
# quadrature terms at 2048 elements, multipliers times gaps).
ROUNDOFF = 1e-12
# Multiplier updates at the largest penalty without halving the violation that
# count as a stall (an infeasible box).
STALL = 6
# Node answers kept as starts.
CACHE = 64
# A stall at the largest penalty with a violation at most RAISE_BELOW (relative) is
# the redundant rows' drift, not an infeasible box: the penalty is raised RAISE-fold, once.
RAISE = 1e3
RAISE_BELOW = 1e-6


class FastContactProgram(FastProgram):
    """Node programs of a problem with a rigid obstacle (or channel), by banded Newton.

    Parameters
    ----------
    dp : DiscreteProblem
        Non-dimensional, ``dp.contact == "obstacle"``.
    modes : Modes
    """

    # (its node's bound comes from the method of multipliers at the end: no early stop)
    takes_cutoff = False

    def __init__(self, dp, modes):
        super().__init__(dp, modes)
        self.mf = mf = MixedForm.on_obstacle(dp)   # same structure; w - g from small numbers
        self.s_origin = self.B @ mf.origin         # s = B z + s_origin (z relative to the origin)
        self.rows, self.levels = obstacle_rows(dp)  # the same rows as mf.A, in Hermite DOFs
        _, self.rho = penalty_range(mf)
        self.c = np.asarray(modes.c, float)
        self._z = -mf.origin   # the undeformed beam
        self._lam = mf.no_contact_forces()
        self._eta = np.zeros(2 * self.k)
        self._cache = []   # (amplitudes, z, lam) of feasible node answers: starts
        self._margin = 0.0  # the last dual bound's margin (decrement and round-off)
        self._violation = math.inf  # the last node answer's largest relative violation
        # Newton's tolerances are relative to the energy, but not to less than that of
        # an answer of the certificate's floor size (a beam lying flat at gap 0 has
        # energy 1e-19: against 1 its slice answer, 3.7e-5 from stationary, passed)
        self._efloor = mf.zero_floor ** 2 if mf.has_load else 1.0
        self._last_lam = self._lam
        self._slices = None   # the exact amplitude slices of reduced (built when first used)
        from .fast_check import amplitude_range
        self.smin, self.smax = amplitude_range(self)

    def admissible_lp(self):
        """The admissible amplitudes as linear programs' data ``(D, origin, A_ub,
        b_ub, A_eq, b_eq)``: ``s = D z + origin`` over ``A_ub z <= b_ub, A_eq z =
        b_eq``, the mixed form's obstacle and linking rows (the amplitude range's,
        :func:`.fast_check.amplitude_range`, and the two-mode polygon's,
        :mod:`.polygon`)."""
        mf, zero = self.mf, np.zeros(self.mf.n)
        return self.B, self.s_origin, -mf.A, mf.gap(zero), mf.C, -mf.link(zero)

    # ------------------------------------------------------------------ pieces
    def _state(self, z, lam, eta, rho, rb, lo, hi, slope):
        """Value, gradient, banded Hessian and box weights of the (augmented) Lagrangian at z."""
        mf, B, c = self.mf, self.B, self.c
        s = B @ z + self.s_origin
        bgap = np.r_[s - lo, hi - s]
        parts = sum(mf.energy_parts(z).values()) + float(c @ (s * s) + slope @ s)
        gap = mf.gap(z)
        if rho > 0:
            f_obs = np.maximum(lam - rho * gap, 0.0)
            f_box = np.maximum(eta - rb * bgap, 0.0)
            value = parts + (float(f_obs @ f_obs - lam @ lam) / (2 * rho)
                             + float(f_box @ f_box - eta @ eta) / (2 * rb))
        else:
            f_obs, f_box = lam, eta
            value = parts - float(lam @ gap) - float(eta @ bgap)
        g = mf.gradient(z, shift=lam, rho=rho) + B.T @ (2 * c * s + slope - f_box[:self.k]
                                                         + f_box[self.k:])
        H = mf.hessian(z, shift=lam, rho=rho)
        active = (f_box > 0) if rho > 0 else np.zeros(2 * self.k, bool)
        D = 2 * c + rb * (active[:self.k] + active[self.k:])
        return value, g, H, D

    def _solve(self, H, D, rhs_z, rhs_c):
        """``[[H + B'DB, C'], [C, 0]] x = rhs`` by the banded LU and Woodbury (rank k)."""
        factor = self.mf.kkt_factor(H)
        # (the right-hand side and B's k rows in one banded solve)
        Y, Ymu = factor.solve(np.column_stack([rhs_z, self.B.T]),
                              np.column_stack([rhs_c, np.zeros((self.mf.N, self.k))]))
        y, X, ymu, Xmu = Y[:, 0], Y[:, 1:], Ymu[:, 0], Ymu[:, 1:]
        M = np.eye(self.k) + D[:, None] * (self.B @ X)
        t = np.linalg.solve(M, D * (self.B @ y))
        return y - X @ t, ymu - Xmu @ t

    def _newton(self, z, lam, eta, rho, rb, lo, hi, slope, tight):
        """Damped Newton on the (augmented) Lagrangian; (z, value, dec, converged)."""
        mf, B, c = self.mf, self.B, self.c
        previous = math.inf
        value, dec = math.nan, math.inf
        for _ in range(MAX_NEWTON):
            value, g, H, D = self._state(z, lam, eta, rho, rb, lo, hi, slope)
            try:
                d, mu = self._solve(H, D, -g, -mf.link(z))
            except np.linalg.LinAlgError:
                return z, value, math.inf, False
            Bd = B @ d
            dec = float(d @ (H @ d)) + float(D @ (Bd * Bd))
            # (the bound's Newton against 1: its decrement is subtracted from the bound)
            floor = max(abs(value), 1.0 if tight else self._efloor)
            if not math.isfinite(dec):
                return z, value, dec, False
            # The function is convex: a negative curvature along d is round-off (at
            # w = 0 the modes' curvature is 2 delta ~ 0), which no test below may
            # read as convergence (a decrement of -6e14 once did, and its bound lay
            # far above the node's value).
            convex = dec >= -1e-14 * floor
            if convex and (abs(dec) <= 1e-26 * floor or (not tight and abs(dec) <= 1e-20 * floor)):
                return z, value, abs(dec), True
            if convex and abs(dec) <= 1e-16 * floor and abs(dec) > 0.01 * previous:
                return z, value, abs(dec), True   # stagnated: round-off
            previous = abs(dec)
            # Along d the Lagrangian of the linking rows decreases (newton._newton)
            shift = float(mu @ (mf.C @ d))
            if float(g @ d) + shift > 0:   # (not a descent direction where dec < 0)
                d, mu, Bd, shift = -d, -mu, -Bd, -shift
            s0 = B @ z + self.s_origin
            dphi_e = mf.directional(z, d, shift=lam if rho > 0 else None, rho=rho)
            obs_d = mf.A @ d
            box_d = np.r_[Bd, -Bd]
            bgap0 = np.r_[s0 - lo, hi - s0]

            def dphi(t):
                s = s0 + t * Bd
                out = dphi_e(t) + float((2 * c * s + slope) @ Bd) + shift
                if rho > 0:
                    out -= float(box_d @ np.maximum(eta - rb * (bgap0 + t * box_d), 0.0))
                else:
                    out -= float(lam @ obs_d) + float(eta @ box_d)
                return out
            t = line_search(dphi, float(g @ d) + shift)
            if t is None:
                return z, value, abs(dec), convex and abs(dec) <= 1e-16 * floor
            z = z + t * d
        return z, value, dec, False

    # ------------------------------------------------------------------ node problems
    def solve_box(self, lo, hi) -> NodeSolution:
        """The node problem on ``[lo, hi]`` (see :meth:`_solve_box`), BLAS on one thread.

        Its work is O(N) vector operations: under load, BLAS threads cost more
        than they do (a node at 2048 elements spent 30 ms per line-search
        evaluation of 10^4-long dot products, :func:`gaocvx.linalg.one_blas_thread`).
        """
        with one_blas_thread():
            return self._solve_box(lo, hi)

    def _solve_box(self, lo, hi) -> NodeSolution:
        """The node problem on ``[lo, hi]``: its approximate minimiser and a dual lower bound.

        The method of multipliers starts at the largest penalty from the
        earlier node answer whose amplitudes lie nearest the box (a neighbour's
        contact set differs little); if that does not end feasible with a tight
        bound, it starts again from the undeformed beam with the penalty raised
        from the beam's own stiffness (a start from the mirror image crawled:
        a bound 4e4 below its node's value at 256 elements).  Both bounds are
        valid; the higher is kept.
        """
        lo0, hi0 = np.asarray(lo, float), np.asarray(hi, float)
        lo, hi = np.maximum(lo0, self.smin), np.minimum(hi0, self.smax)
        if np.any(lo > hi):   # no admissible beam has these amplitudes
            return NodeSolution(math.inf, math.inf, None, None, None, True, "infeasible")
        mf = self.mf
        starts = []
        if self._cache:
            centre = 0.5 * (lo + hi)
            near = min(self._cache, key=lambda e: float(np.sum((np.clip(centre, lo, hi) - e[0])**2)))
            starts.append((near[1].copy(), near[2].copy(), self.rho))
        starts.append((-mf.origin, mf.no_contact_forces(), min(RHO_START, self.rho)))
        lower, best = -math.inf, None
        for z, lam, rho in starts:
            out = self._attempt(lo, hi, lo0, hi0, z, lam, rho)
            if out is None:
                continue
            bound, J, z, s, lam, eta, violation = out
            lower = max(lower, bound)
            if best is None or violation < best[-1]:
                best = (J, z, s, lam, eta, violation)
            if violation <= FEASIBLE and J - lower <= 1e-10 * max(abs(J), 1.0):
                break
        if best is None:
            return NodeSolution(-math.inf, math.nan, None, None, None, False, "failed")
        J, z, s, lam, eta, violation = best
        self._z, self._lam, self._eta, self._violation = z, lam, eta, violation
        self._last_lam = lam
        if violation <= FEASIBLE:
            self._cache.append((s, z, lam))
            del self._cache[:-CACHE]
        ok = lower > -math.inf
        return NodeSolution(lower, J, s, mf.to_hermite(z), lam, ok,
                            "optimal" if ok else "inaccurate")

    def _attempt(self, lo, hi, lo0, hi0, z, lam, rho):
        """The method of multipliers on the box from ``(z, lam)``; None if nothing came out.

        Returns the best dual bound (``-inf`` if none converged), the node's
        value ``J`` at the last iterate, that iterate, its amplitudes and
        multipliers and its largest relative violation.
        """
        mf, k, c = self.mf, self.k, self.c
        slope = -c * (lo0 + hi0)
        offset = float(np.sum(c * lo0 * hi0))
        eta = np.zeros(2 * k)
        # the box rows' penalty: far stiffer than the energy along the modes
        rb = 1e8 * (1.0 + float(np.max(c)) + abs(self.dp.p))
        lower, best, history = -math.inf, None, []
        for update in range(MAX_UPDATES):
            z, _, _, _ = self._newton(z, lam, eta, rho, rb, lo, hi, slope, tight=False)
            if not np.all(np.isfinite(z)):
                return None
            s = self.B @ z + self.s_origin
            gap, bgap = mf.gap(z), np.r_[s - lo, hi - s]
            lam = np.maximum(lam - rho * gap, 0.0)
            eta = np.maximum(eta - rb * bgap, 0.0)
            if rho < self.rho:
                rho = min(1e3 * rho, self.rho)
                continue
            size = mf.deflection_size(z)
            scale_s = 1.0 + float(np.max(np.abs(s)))
            violation = max(-float(np.min(gap, initial=0.0)) / size,
                            -float(np.min(bgap)) / scale_s, 0.0)
            history.append(violation)
            log.debug("update %d: penalty %.0e, violation %.2e", update, rho, violation)
            # Stalled (an infeasible box, whose multipliers only grow): the bound
            # below is valid with any multipliers.
            stalled = len(history) > STALL and history[-1] > 0.5 * history[-1 - STALL]
            slow = len(history) > STALL and history[-1] > 0.1 * history[-1 - STALL]
            if slow and rho < RAISE * self.rho and violation <= RAISE_BELOW:
                # A beam flat on the obstacle next to a support: the active rows are
                # linearly dependent, the multipliers drift and the violation sticks
                # at about a constant over the penalty (as in .slices.ContactSlices).
                # Raised once (P4 at gap 0, 1024 elements: 4e-8 of the answer's size
                # at 1e10, rows that gap 1.4e-8 with forces on them, complementarity
                # 1.2e-3 in the certificate).
                rho, history = RAISE * rho, []
                continue
            if violation > FEASIBLE and update < MAX_UPDATES - 1 and not stalled:
                continue
            # The dual bound: the Lagrangian with these multipliers, minimised to round-off.
            bound = self.dual_bound(lo, hi, lam, eta, z, chord=(lo0, hi0))
            lower = max(lower, bound)
            J = sum(mf.energy_parts(z).values()) + float(c @ (s * s) + slope @ s) + offset
            best = (J, z, s, lam, eta, violation)
            # Weak duality: the bound lies below J at any admissible point; this one
            # violates rows by up to FEASIBLE, which lowers J by about the
            # multipliers times the violations (a beam pressed flat: 5e-10 of J).
            slack = float(lam @ np.maximum(-gap, 0.0)) + float(eta @ np.maximum(-bgap, 0.0))
            if violation <= FEASIBLE and lower > J + 2 * slack + 1e-10 * max(abs(J), 1.0):
                # A solve went wrong: no bound from this attempt.
                log.warning("fast contact node: bound %.17g above the value %.17g", lower, J)
                return -math.inf, *best
            # done when the bound is as close as its own round-off margin allows
            if (bound > -math.inf and J - lower <= 1e-12 * max(abs(J), 1.0) + 2 * self._margin) \
                    or stalled:
                break
        if best is None:
            return None
        return lower, *best

    def dual_bound(self, lo, hi, lam, eta, z=None, chord=None) -> float:
        """A lower bound of the node problem on ``[lo, hi]`` from any ``lam, eta >= 0``.

        ``min {L(z) : C z = 0}`` by Newton from ``z`` (the module's argument),
        less the last squared decrement and the round-off margin; ``-inf``
        when Newton does not converge.  ``chord``: the box whose chord replaces
        the concave terms (default ``[lo, hi]``; a superset of it is valid too).

        Examples
        --------
        Any multipliers give a bound, however wrong (see the module's example):

        >>> from gaocvx.scene import Scene
        >>> from gaocvx.discrete import DiscreteProblem
        >>> from gaocvx.nonconvex.modes import unstable_modes
        >>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4",
        ...     "length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
        ...     "load": {"q": -1e8, "axial": 1.5e9}, "obstacle": {"gap": 0.01},
        ...     "mesh": {"elements": 8}})
        >>> dp = DiscreteProblem(scene, check_convexity=False)
        >>> prog = FastContactProgram(dp, unstable_modes(dp))
        >>> sol = prog.solve_box([-3.0], [3.0])
        >>> wrong = prog.dual_bound([-3.0], [3.0], 2.0 * sol.lam, np.zeros(2))
        >>> bool(wrong <= sol.lower <= sol.value)
        True
        """
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        clo, chi = (lo, hi) if chord is None else map(np.asarray, chord)
        slope, offset = -self.c * (clo + chi), float(np.sum(self.c * clo * chi))
        lam, eta = np.maximum(lam, 0.0), np.maximum(eta, 0.0)
        z = self._z.copy() if z is None else z
        zl, value, dec, conv = self._newton(z, lam, eta, 0.0, 0.0, lo, hi, slope, tight=True)
        if not conv:
            return -math.inf
        value += offset
        # Round-off: relative to the terms summed, not to their (cancelling) total.
        s = self.B @ zl + self.s_origin
        terms = (sum(abs(v) for v in self.mf.energy_parts(zl).values())
                 + float(np.abs(lam) @ np.abs(self.mf.gap(zl)))
                 + float(eta @ np.abs(np.r_[s - lo, hi - s]))
                 + float(np.abs(self.c) @ (s * s)) + float(np.abs(slope) @ np.abs(s)) + abs(offset))
        self._margin = dec + ROUNDOFF * max(abs(value), terms, 1.0)
        return value - self._margin

    def reduced(self, s0):
        """``F(s0)`` (the energy's minimum on the slice ``s = s0``), its gradient, ``u``, success.

        By :class:`.slices.ContactSlices` on this program: the amplitudes fixed
        exactly in the bordered banded Newton system, ``F' = -nu`` from a
        linear solve.  (The node problem on the degenerate box ``[s0, s0]``
        read ``F'`` from the box rows' penalty multipliers, whose error is the
        box penalty times the rows' last violation: 1e-7 to 5e-6 off the dense
        programs' at 16 elements, against the slices' 1e-10 to 1e-7; the polish
        minimises F with a gradient tolerance of 1e-11.)  ``inf`` where no
        admissible beam has the amplitudes ``s0``; the obstacle multipliers of
        the answer are then :meth:`obstacle_multipliers`'.
        """
        if self._slices is None:
            from .scales import scene_energy
            from .slices import ContactSlices
            self._slices = ContactSlices(self, scene_energy(self.dp, self.modes))
        F, dF, u, ok = self._slices.reduced(s0)
        if u is not None:
            self._last_lam = self._slices.lam
        return F, dF, u, ok

    def contact_polish(self, dp, u, lam, rows, levels):
        """The final answer polished at any N (:func:`.fast_check.contact_polish`)."""
        from .fast_check import contact_polish
        return contact_polish(self, u, lam)

    def certify(self, z, lam, floor: float = 0.0) -> tuple:
        """The obstacle certificate in the mixed form: (measures, multipliers)
        (:func:`.fast_check.certify_contact`)."""
        from .fast_check import certify_contact
        return certify_contact(self, z, lam, floor)

    def obstacle_multipliers(self):
        """The last node's obstacle multipliers (rows of :attr:`rows`)."""
        return self._last_lam
