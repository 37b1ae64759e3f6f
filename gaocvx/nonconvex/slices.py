"""The reduced function with a rigid obstacle or channel at any N: exact amplitude slices.

``F(s0)``, the energy's minimum over the beams whose unstable modes have the
amplitudes ``s0``, and its gradient, on the mixed form of a
:class:`.fast_contact.FastContactProgram` (nonconvex.md, all equilibria).
Used by :func:`.stationary.equilibria` beyond the dense programs.
"""

from __future__ import annotations

import contextlib
import math

import numpy as np

from .fast_check import RANGE_PAD

__all__ = ["ContactSlices"]


def _norm(v) -> float:
    """``np.linalg.norm`` of a float vector, as numpy computes it (sqrt of its dot
    product: the same bits), without its dispatch: four per Newton step."""
    return math.sqrt(float(v.dot(v)))


class ContactSlices:
    """The reduced function with a rigid obstacle (or channel) at any N: banded Newton on slices.

    ``F(s0)`` is the energy's minimum over the slice ``B z = s0`` of the
    mixed variables of ``prog`` (a :class:`.fast_contact.FastContactProgram`,
    whose mixed form, amplitude rows ``B`` and admissible amplitude range
    are used as they are).  The amplitudes are fixed exactly, as by
    :class:`.fast.FastProgram`: each Newton step solves the banded KKT system
    bordered by the k rows of ``B`` (a Schur complement of size k), so that
    the gradient ``dF/ds = -nu`` is the multiplier of those rows from a
    linear solve.  The obstacle's rows are taken by the method of
    multipliers at the program's largest penalty (:mod:`gaocvx.contact_newton`),
    updated until no row is violated by more than ``FEASIBLE`` of the
    answer's size; at the inner minimiser with the multipliers ``lam`` the
    optimality conditions of the slice hold exactly with the updated
    multipliers ``max(0, lam - rho gap)``, so ``-nu`` is the gradient of
    the slice problem with the obstacle moved by at most that violation.

    (The node problem on the degenerate box ``[s0, s0]``, which read the
    gradient from the box rows' augmented-Lagrangian multipliers, was 1e-5 of
    ``F'``'s range off at 16 elements (untouched obstacle), against the dense
    programs' 1e-10; the amplitudes of its zeros were 1e-5 off and two of three
    stabilities wrong.  ``prog.reduced`` is this class now.)  ``F`` is the
    Lagrangian ``E - lam'gap`` at the answer, whose exact gradient ``-nu`` is.

    Parameters
    ----------
    prog : FastContactProgram
    energy_floor : float
        The scene's energy scale (non-dimensional, :func:`.scales.scene_energy`):
        a violation whose work is round-off against it is harmless (:meth:`_violation`).

    Examples
    --------
    >>> from gaocvx.discrete import DiscreteProblem
    >>> from gaocvx.nonconvex.fast_contact import FastContactProgram
    >>> from gaocvx.nonconvex.modes import unstable_modes
    >>> from gaocvx.nonconvex.node import NodeProgram
    >>> from gaocvx import Scene
    >>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
    ...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
    ...     "load": {"q": -1e8, "axial": 1.5e9}, "obstacle": {"gap": 0.01},
    ...     "mesh": {"elements": 8}})
    >>> dp = DiscreteProblem(scene, check_convexity=False)
    >>> m = unstable_modes(dp)
    >>> F, dF, u, ok = ContactSlices(FastContactProgram(dp, m)).reduced([-2.0])
    >>> G, dG, _, _ = NodeProgram(dp, m).reduced([-2.0])    # the dense program agrees
    >>> ok, abs(F - G) < 1e-9 * abs(G), bool(abs(dF[0] - dG[0]) < 1e-7 * abs(dG[0]))
    (True, True, True)
    """

    def __init__(self, prog, energy_floor: float = 0.0):
        from ..contact_newton import RHO_START
        self.prog, self.k, self.mf, self.B = prog, prog.k, prog.mf, prog.B
        self.smin, self.smax = prog.smin, prog.smax
        self.rho_start, self.rho_max = min(RHO_START, prog.rho), prog.rho
        # Newton's tolerances relative to the energy, but not to less than that of an
        # answer of the certificate's floor size (a beam lying flat at gap 0 has
        # energy ~0), as FastContactProgram's
        self.floor = self.mf.zero_floor ** 2 if self.mf.has_load else 1.0
        self.energy_floor = float(energy_floor)
        self._cache = []   # (amplitudes, z, lam) of admissible slices: starts
        self.solves = 0
        self.lam = None    # the obstacle rows' multipliers of the last admissible slice

    def reduced(self, s0):
        """``F(s0)``, its gradient ``-nu``, the free Hermite DOFs and success.

        ``inf`` (and success) where no admissible beam has the amplitudes ``s0``
        (outside the program's amplitude range, or the multipliers' updates
        stall with the rows violated by more than ``ADMISSIBLE``).
        """
        from ..linalg import one_blas_thread
        from .fast_contact import ADMISSIBLE, FEASIBLE

        s0 = np.asarray(s0, float)
        self.solves += 1
        if np.any(s0 < self.smin) or np.any(s0 > self.smax):
            return math.inf, np.zeros(self.k), None, True
        target = s0 - self.prog.s_origin        # B z = s0 - s_origin (z from the origin)
        mf = self.mf
        starts = []
        if self._cache:
            # a neighbouring slice's answer at the largest penalty: its contact set
            # differs little
            # (one array operation: a key function over the 64 entries was a tenth
            # of a two-mode equilibria search's time)
            amps = np.array([e[0] for e in self._cache])
            near = self._cache[int(np.argmin(np.sum((amps - s0) ** 2, axis=1)))]
            starts.append((near[1], near[2], near[3]))
        starts.append((-mf.origin, mf.no_contact_forces(), self.rho_start))
        best = None
        # With one mode every amplitude between the range's ends is admissible (the
        # admissible beams are convex, the ends the linear program's): a slice there
        # stalled at violations above 1e-6 of its size is the multipliers' slowness,
        # not an empty slice -- the penalty is raised there too (P1 in a channel 4 mm
        # high under a load table, 12 elements: a cold slice 0.005 of the range from
        # its end stalled at 1.18e-6 with forces of 7.7e5, and F was taken infinite).
        # (beyond ten times the ends' padding, which lies outside them; an end the
        # linear program failed on is infinite, and a slice beyond the true end then
        # costs the raise but stays empty: its violation cannot fall below its
        # distance from the admissible beams)
        ends = np.r_[self.smin, self.smax]
        margin = 10.0 * RANGE_PAD * (1.0 + float(np.max(np.abs(ends[np.isfinite(ends)]),
                                                        initial=0.0)))
        inside = self.k == 1 and bool(np.all((s0 > self.smin + margin) & (s0 < self.smax - margin)))

        def rank(out):
            return (not (out[2] and out[4] <= FEASIBLE), out[4])
        with one_blas_thread():   # O(N) work: BLAS threads cost more than they do
            for z, lam, rho in starts:
                out = self._multipliers(target, z.copy(), lam.copy(), rho, admissible=inside)
                # a converged feasible answer first, then the least violation (a
                # warm start that did not converge once left F' = +24 for -36 in
                # a Brent bracket: a false zero)
                if out is not None and (best is None or rank(out) < rank(best)):
                    best = out
                if best is not None and best[2] and best[4] <= FEASIBLE:
                    break
        if best is None or best[4] > ADMISSIBLE:
            return math.inf, np.zeros(self.k), None, True
        z, nu, converged, lam, violation, rho = best
        self.lam = lam
        if violation <= FEASIBLE:
            self._cache.append((s0.copy(), z, lam, rho))
            del self._cache[:-64]
        # F as the Lagrangian E - lam'gap with the multipliers that make z stationary:
        # -nu is its exact gradient (envelope theorem), and the energy alone differs
        # from it by the forces' work on the rows' tolerances, which moves with the
        # start (a P1 beam in a channel, 256 elements: the same s twice gave F 4.5e-12
        # apart, relative, and L-BFGS-B stopped 1e-5 off the minimiser on such noise)
        F = float(sum(mf.energy_parts(z).values())) - float(lam @ mf.gap(z))
        return F, -nu, mf.to_hermite(z), bool(converged and violation <= FEASIBLE)

    @contextlib.contextmanager
    def cold(self):
        """A context in which :meth:`reduced` starts from the program's own start,
        not from the nearest slice solved before (whose multipliers make the
        answer depend on the search's history); the warm starts are kept."""
        saved = list(self._cache)
        self._cache.clear()
        try:
            yield self
        finally:
            self._cache[:] = saved

    def _multipliers(self, target, z, lam, rho, updates=60, stall=5, admissible=False):
        """The method of multipliers on the slice; (z, nu, converged, lam, violation, rho) or None.

        When the violation stops halving at the program's largest penalty, the
        penalty is raised a thousandfold, once: where the beam lies flat
        on the obstacle next to a support, the active rows are linearly
        dependent and the multipliers drift instead of converging, the violation
        stuck at about a constant over the penalty (16 elements, P1 at gap 0:
        4e-12 at 1e10, 6e-17 at 1e13; the slope F' was 2e-6 off at the first,
        within 1e-8 of the dense program's at the second).  Stalled at the
        raised penalty, or with a violation far above round-off (1e-6 of the
        answer's size), the slice is taken as inadmissible, unless it is known
        to be ``admissible`` (then the penalty is raised there too).
        """
        from .fast_contact import FEASIBLE

        mf = self.mf
        history, out = [], None
        for _ in range(updates):
            z, nu, converged = self._newton(target, z, lam, rho)
            if not np.all(np.isfinite(z)):
                return out
            gap = mf.gap(z)
            lam = np.maximum(lam - rho * gap, 0.0)   # the slice's optimality holds with these
            if rho < self.rho_max:
                rho = min(1e3 * rho, self.rho_max)
                continue
            violation = self._violation(z, gap, lam)
            # Feasible is not yet optimal: a warm start's forces may hold the beam
            # on rows it would leave (P1 at gap 0, 16 elements, from the slice at
            # s = -1 to -0.3: no row violated, F 2e-6 and F' 1e-6 too high).  The
            # updates go on until the forces' work on open gaps is round-off too.
            settled = self._complementary(z, gap, lam)
            out = (z, nu, converged and settled, lam, violation, rho)
            history.append(violation)
            if violation <= FEASIBLE and settled:
                break   # (unconverged: more updates would not change the iterate)
            if len(history) > stall and history[-1] > 0.5 * history[-1 - stall]:
                # (a violation far above round-off is an inadmissible slice: no raise)
                if rho >= 1e3 * self.rho_max or (violation > 1e-6 and not admissible):
                    break
                rho, history = 1e3 * rho, []
        return out

    def _violation(self, z, gap, lam) -> float:
        """The rows' largest violation relative to the answer's size, or less if harmless.

        Slices of tiny amplitude (a beam lifting off a flat contact: 1e-9 of the
        buckled size, at the certificate's floor size) stall at violations of
        1e-15 in absolute terms, round-off, but 1e-8 of their own size.  A
        violation moves the energy by at most the work ``lam'(-gap)^+`` of the
        forces on it: when that is at most 1e-13 of the energy scale (the
        energy, at least the scene's ``energy_floor``) it counts as
        ``FEASIBLE`` (and 1e-11 as ``ADMISSIBLE``: linearly in between).
        """
        from .fast_contact import FEASIBLE

        mf = self.mf
        over = np.maximum(-gap, 0.0)
        relative = float(np.max(over, initial=0.0)) / mf.deflection_size(z)
        scale = max(abs(sum(mf.energy_parts(z).values())), self.energy_floor)
        if scale <= 0.0:
            return relative
        work = float(lam @ over)
        return min(relative, FEASIBLE * work / (1e-13 * scale))

    def _complementary(self, z, gap, lam) -> bool:
        """Whether the forces' work ``lam'(gap)^+`` on open gaps is round-off.

        At most 1e-13 of the energy scale (the energy, at least the scene's
        ``energy_floor``; the energy's Newton tolerance when both are 0), as
        :meth:`_violation` takes the work on closed ones.
        """
        scale = max(abs(sum(self.mf.energy_parts(z).values())), self.energy_floor, self.floor)
        return float(lam @ np.maximum(gap, 0.0)) <= 1e-13 * scale

    def _newton(self, target, z, lam, rho, max_iter=60):
        """Damped semismooth Newton on the augmented Lagrangian over the slice.

        Returns ``z``, the multipliers ``nu`` of ``B z = target`` and convergence
        (the squared Newton decrement at round-off of the energy).
        """
        from .. import newton as nw

        mf, B, k = self.mf, self.B, self.k
        al = {"shift": lam, "rho": rho}
        nu, previous, full = np.zeros(k), math.inf, False
        zeros, target_size = np.zeros((mf.N, k)), 1.0 + _norm(target)
        for _ in range(max_iter):
            g, H = mf.gradient(z, **al), mf.hessian(z, **al)
            link, Bz = mf.link(z), B @ z
            try:
                # (inside: far outside the admissible amplitudes the factor itself
                # can be singular -- a Newton step of 2e8 S in a trial's k = 2 search)
                factor = mf.kkt_factor(H)
                R, Rmu = factor.solve(np.column_stack([-g, B.T]), np.column_stack([-link, zeros]))
                r0, X, m0, Xmu = R[:, 0], R[:, 1:], Rmu[:, 0], Rmu[:, 1:]
                nu = np.linalg.solve(B @ X, B @ r0 - (target - Bz))
            except np.linalg.LinAlgError:
                return z, nu, False
            d, mu = r0 - X @ nu, m0 - Xmu @ nu
            on_slice = (_norm(Bz - target) <= 1e-12 * target_size
                        and _norm(link) <= 1e-12 * (1.0 + _norm(z)))
            if not on_slice:
                z = z + d   # the constraints are linear: one full step lands on them
                continue
            dec = float(d @ (H @ d))   # H is positive definite on the slice
            floor = max(abs(sum(mf.energy_parts(z).values())), self.floor)
            if abs(dec) <= 1e-20 * floor:
                return z, nu, True
            if abs(dec) <= 1e-16 * floor and abs(dec) > 0.01 * previous:
                return z, nu, True    # stagnated: round-off
            previous = abs(dec)
            # Along d the Lagrangian of the linear rows decreases (newton._newton):
            # C d and B d are round-off, the forces on them are not
            shift = float(mu @ (mf.C @ d)) + float(nu @ (B @ d))
            slope0 = float(g @ d) + shift
            dphi = mf.directional(z, d, **al)
            t = nw.line_search(lambda t: dphi(t) + shift, slope0)
            if t is None and not full:
                # No descent along d: the linear rows' residual (1e-11, against forces
                # of 1e3 at the end of a range) outweighs the decrement.  The full
                # step satisfies them to the solve's round-off; once.
                z, full = z + d, True
                continue
            if t is None:
                return z, nu, abs(dec) <= 1e-16 * floor
            z, full = z + t * d, False
        return z, nu, False
