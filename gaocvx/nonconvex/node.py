"""Node programs: the convex relaxation of the energy on a box of mode amplitudes.

With ``u = Phi s + v``, ``Phi'G v = 0`` (:mod:`.modes`) the energy is
``-sum c_i s_i^2 + Psi(s, v)`` with ``Psi`` jointly convex (nonconvex.md).
On a box ``lo <= s <= hi`` the concave part lies above its chord,
``-c_i s_i^2 >= -c_i (lo_i + hi_i) s_i + c_i lo_i hi_i``, so

    min  Psi(s, v) + slope's + offset   over the box,  Phi'G v = 0

is a convex program whose value bounds the energy on the box from below, and
whose minimiser is a feasible point (an upper bound).

The program is dense CVXPY + Clarabel (the ground truth, for small meshes):

* ``1/2 v'(K - p G) v`` is convex only on ``Phi'G v = 0``, which DCP cannot
  see; there it equals ``1/2 v'A_rho v`` with
  ``A_rho = K - p G + rho (G Phi)(G Phi)'``, positive definite for
  ``rho > p - lambda_1``.  ``rho = lambda_{k+1} - lambda_1`` lifts the
  unstable modes' eigenvalues to at least ``lambda_{k+1} - p``, the
  complement's smallest, so the form is no worse conditioned than the stable
  part.  It enters as a ``quad_form`` (Clarabel's quadratic objective);
* the Gao term ``a/12 Σ w_q (w'_q)^4`` as ``a/12 Σ w_q y_q^2`` with
  ``y_q >= (w'_q)^2`` (one second-order cone per point);
* the foundation as ``c/2 Σ w_q t_q^2``, ``t >= 0``, ``t >= g - w_q``;
* an obstacle as ``w >= g`` at the nodes and the foundation's Gauss points
  (the rows of :class:`gaocvx.mixed.MixedStructure`, same order, so that its
  multipliers serve the mixed form's certificate).

The box ends and the chord's slope and offset are CVXPY Parameters (DPP): the
program compiles once and every node is a re-solve.  A second program with
the amplitudes fixed (``s == s0``, a Parameter) gives the reduced function
``F(s) = min_v Psi(s, v) - sum c_i s_i^2`` and, by the envelope theorem, its
gradient from the constraint's multiplier: the equilibria are its zeros.

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> from gaocvx.nonconvex.modes import unstable_modes
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"axial": 1.3e9}, "mesh": {"elements": 8}})
>>> dp = DiscreteProblem(scene, check_convexity=False)
>>> prog = NodeProgram(dp, unstable_modes(dp))
>>> F, dF, u, ok = prog.reduced([0.0])       # w = 0: an equilibrium (q = 0)
>>> ok, abs(F) < 1e-9, bool(abs(dF[0]) < 1e-6)
(True, True, True)
"""

from __future__ import annotations

import logging
import math
import warnings

import numpy as np
import scipy.sparse as sp

from .. import fem

__all__ = ["NodeProgram", "NodeSolution", "obstacle_rows", "CLARABEL_SETTINGS"]

log = logging.getLogger(__name__)

# Gap tolerances near double precision first: a node's lower bound is the program's
# value less Clarabel's duality-gap tolerance, so that tolerance is the
# certificate's accuracy (the spec's example closed to 2.5e-10 of |Pi|).  Boxes far
# from the minimiser (amplitudes several times the answer's) do not always reach
# it (measured: 'optimal_inaccurate' at 1e-12 and 1e-10 on 16 elements); their
# bounds lie far above the best energy, so a looser solve still prunes them.
CLARABEL_SETTINGS = [dict(tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-10, max_iter=400),
                     dict(tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-9, max_iter=400),
                     dict(tol_gap_abs=1e-8, tol_gap_rel=1e-8, tol_feas=1e-8, max_iter=400)]


# Clarabel's reduced gap tolerances (reduced_tol_gap_abs/rel), met at "optimal_inaccurate".
INACCURATE_GAP = 5e-5


def obstacle_rows(dp) -> tuple[sp.csr_matrix, np.ndarray]:
    """Obstacle rows ``A u >= levels``: ``w`` at the nodes and the foundation's Gauss points.

    Rows touching no free DOF (a support at the obstacle's level) are dropped,
    as in :class:`gaocvx.mixed.MixedStructure`, whose constraint rows these are.
    The level (non-dimensional, <= 0) is the obstacle's at each row's point (a
    gap profile varies along the beam).
    """
    A = sp.vstack([fem.eval_matrix(dp.xi, dp.xi, 0)[:, dp.free], dp.Nq]).tocsr()
    A.eliminate_zeros()
    keep = np.flatnonzero(np.diff(A.indptr) > 0)
    levels = np.r_[dp.level_at(dp.xi), np.broadcast_to(dp.g, (dp.Nq.shape[0],))]
    A, levels = A[keep].tocsr(), np.asarray(levels[keep], float)
    if getattr(dp, "g_above", None) is not None:
        # A channel: w <= g_above on the same points, as -w >= -g_above, stacked
        # after the rows below (the mixed form's order: multipliers >= 0 each).
        A = sp.vstack([A, -A]).tocsr()
        levels = np.r_[levels, np.full(len(levels), -dp.g_above)]
    return A, levels


def effective_stiffness(dp) -> sp.csr_matrix:
    """The quadratic form that the modes diagonalise: bending, plus a bonded foundation's c M.

    A bonded foundation's ``1/2 ∫ c (w - g)^2`` is quadratic: its ``c M`` part
    belongs with the bending (nonconvex.md), its linear part with the load.
    """
    if dp.contact == "foundation" and dp.bilateral:
        weights = np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape)
        return (dp.K + dp.NqT @ sp.diags(weights) @ dp.Nq).tocsr()
    return dp.K


class NodeSolution:
    """One node program's answer (non-dimensional).

    Attributes
    ----------
    lower : float
        A lower bound of the relaxation's value on the box (its value less the
        solver's duality-gap tolerance); +inf when the box is infeasible.
    s, u : ndarray
        The minimiser's amplitudes and free Hermite DOFs.
    lam : ndarray or None
        The obstacle's multipliers.
    ok : bool
        The solver reported an optimal solve.
    """

    __slots__ = ("lower", "value", "s", "u", "lam", "ok", "status")

    def __init__(self, lower, value, s, u, lam, ok, status):
        self.lower, self.value, self.s, self.u, self.lam = lower, value, s, u, lam
        self.ok, self.status = ok, status


class NodeProgram:
    """The dense DPP node programs of one discrete problem above ``P_bar_h``.

    Parameters
    ----------
    dp : DiscreteProblem
        Non-dimensional problem (``check_convexity=False``).
    modes : Modes
        Its unstable modes (``k >= 1``).
    """

    def __init__(self, dp, modes):
        import cvxpy as cp

        self.dp, self.modes = dp, modes
        self.k = k = modes.k
        Phi = modes.phi
        self.GPhi = GPhi = np.asarray(dp.G @ Phi)
        lam1 = float(modes.lam[0])
        rho = (modes.lam_next - lam1) if math.isfinite(modes.lam_next) else (dp.p - lam1) + 1.0
        rho = max(rho, 1.01 * (dp.p - lam1) + 1e-12)
        A = (effective_stiffness(dp) - dp.p * dp.G).toarray() + rho * (GPhi @ GPhi.T)
        self.A_rho = 0.5 * (A + A.T)
        self.rows, self.levels = obstacle_rows(dp) if dp.contact == "obstacle" else (None, None)
        self.smin, self.smax = self._amplitude_range()
        self.solves = 0

        # Box program.
        self.lo = cp.Parameter(k, name="lo")
        self.hi = cp.Parameter(k, name="hi")
        self.slope = cp.Parameter(k, name="slope")
        self.offset = cp.Parameter(name="offset")
        s, v, objective, cons, self._obs = self._psi(cp)
        self.box = dict(s=s, v=v, obs=self._obs)
        self.box_problem = cp.Problem(
            cp.Minimize(objective + self.slope @ s + self.offset),
            cons + [s >= self.lo, s <= self.hi])

        # Fixed-amplitude program: F(s0) and its gradient.
        self.s0 = cp.Parameter(k, name="s0")
        s, v, objective, cons, obs = self._psi(cp)
        self._fix = s == self.s0
        self.fixed = dict(s=s, v=v, obs=obs)
        self.fixed_problem = cp.Problem(cp.Minimize(objective), cons + [self._fix])

    def _psi(self, cp):
        """Variables, the objective Psi and the constraints, as CVXPY expressions."""
        dp, k = self.dp, self.k
        s = cp.Variable(k, name="s")
        v = cp.Variable(dp.n, name="v")
        u = self.modes.phi @ s + v
        terms = [0.5 * cp.quad_form(v, cp.psd_wrap(self.A_rho)), -(dp.f @ u)]
        cons = [self.GPhi.T @ v == 0]
        if dp.needs_gao:
            y = cp.Variable(len(dp.wq_gao), name="y")
            cons.append(cp.square(dp.B1 @ u) <= y)
            terms.append(dp.a / 12.0 * cp.quad_form(y, sp.diags(dp.wq_gao)))
        obs = None
        weights = np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape) if dp.contact else None
        if dp.contact == "foundation" and dp.bilateral:
            # c M is in A_rho (effective_stiffness); what is left is linear in u.
            g = np.broadcast_to(dp.g, dp.wq_c.shape)
            terms.append(-((dp.NqT @ (weights * g)) @ u) + 0.5 * float(weights @ g**2))
        elif dp.contact == "foundation":
            t = cp.Variable(len(dp.wq_c), name="t", nonneg=True)
            cons.append(t >= dp.g - dp.Nq @ u)
            terms.append(0.5 * cp.quad_form(t, sp.diags(weights)))
        elif dp.contact == "obstacle":
            obs = self.rows @ u >= self.levels
            cons.append(obs)
        return s, v, cp.sum(terms), cons, obs

    def admissible_lp(self):
        """The admissible amplitudes as linear programs' data ``(D, origin, A_ub,
        b_ub, A_eq, b_eq)``: ``s = D u + origin`` over ``A_ub u <= b_ub, A_eq u =
        b_eq`` (the amplitude range's and the two-mode polygon's, :mod:`.polygon`).

        In ``u = Phi s + v`` with ``(G Phi)'v = 0``, ``s = ((G Phi)'Phi)^-1 (G
        Phi)'u``, over the obstacle's rows ``u >= levels``.  (Not in ``(s, v)``
        with the equality rows: their round-off entries, 2e-17, made HiGHS fail,
        "Solve error", on a P1 beam.)  None without an obstacle.
        """
        if self.rows is None:
            return None
        D = np.linalg.solve(self.GPhi.T @ self.modes.phi, self.GPhi.T)
        return (D, np.zeros(self.k), -sp.csr_matrix(self.rows), -np.asarray(self.levels, float),
                sp.csr_matrix((0, D.shape[1])), np.zeros(0))

    def _amplitude_range(self):
        """Each amplitude's range over the admissible set, as the fast path's
        (:func:`.fast_check.amplitude_range`): infinite without an obstacle.

        Why: Clarabel does not always prove a box without an admissible beam
        infeasible.  P3 in a 0.44 mm channel at gap 0 under a 3e7 N point force
        (two modes, 10 elements): it stopped with "error" or
        "infeasible_inaccurate" on 87 of 204 boxes beyond the channel's ceiling,
        each kept its parent's bound, and the search split them to its 4000
        nodes without closing (gap 53 in the energy's units from the first
        hundred nodes on).  A box outside the range is infeasible; one across
        its end is cut to it (no admissible point is lost: the range is a
        superset).
        """
        if self.rows is None:
            return np.full(self.k, -math.inf), np.full(self.k, math.inf)
        from .fast_check import lp_ranges, padded

        D, origin, *lp = self.admissible_lp()
        lo, hi = lp_ranges(D, *lp)
        return padded(lo + origin, hi + origin)

    def _solve(self, problem):
        """Solve down the ladder; returns the status and the gap tolerance that was met."""
        import cvxpy as cp

        self.solves += 1
        status, settings = "error", CLARABEL_SETTINGS[-1]
        for settings in CLARABEL_SETTINGS:
            try:
                with warnings.catch_warnings():
                    # "Solution may be inaccurate": the status says so, and is used.
                    warnings.simplefilter("ignore", UserWarning)
                    problem.solve(solver=cp.CLARABEL, **settings)
            except cp.error.SolverError as exc:
                log.debug("clarabel failed at %s: %s", settings, exc)
                continue
            status = problem.status
            if status in ("optimal", "infeasible"):
                break
        return status, settings

    def _lower(self, problem, settings) -> float:
        """A lower bound of the program's value from Clarabel's duality-gap tolerance.

        At "optimal" Clarabel's primal and dual objectives (without CVXPY's
        constant, here the chord's offset) differ by at most
        ``abs + rel * min(|primal|, |dual|)``; the dual objective is a lower
        bound.  CVXPY does not pass the dual objective on, so the value less
        that tolerance (with the offset counted in, which only widens it) is used.
        """
        value = float(problem.value)
        offset = float(self.offset.value) if problem is self.box_problem else 0.0
        margin = settings["tol_gap_abs"] + settings["tol_gap_rel"] * (abs(value) + abs(offset))
        if problem.status != "optimal":
            # "optimal_inaccurate": Clarabel met its reduced tolerances (5e-5 on the
            # gap, 1e-4 on feasibility); ten times those as the margin.  Such solves
            # happen on boxes far out (amplitudes many times the answer's), whose
            # bounds lie far above the best energy; near it the box is split anyway.
            margin = 10.0 * INACCURATE_GAP * (1.0 + abs(value) + abs(offset))
        return value - margin

    def solve_box(self, lo, hi) -> NodeSolution:
        """Minimise the relaxation on the box ``[lo, hi]`` (chord of each concave term)."""
        # The box's admissible part (the chord on it lies above the chord on the box:
        # a bound as valid, and tighter; with the box's own chord the P3 beam of
        # _amplitude_range ended with an answer whose certificate failed).
        lo = np.maximum(np.asarray(lo, float), self.smin)
        hi = np.minimum(np.asarray(hi, float), self.smax)
        if np.any(lo > hi):   # no admissible beam has these amplitudes
            return NodeSolution(math.inf, math.inf, None, None, None, True, "infeasible")
        c = self.modes.c
        self.lo.value, self.hi.value = lo, hi
        self.slope.value = -c * (lo + hi)
        self.offset.value = float(np.sum(c * lo * hi))
        status, settings = self._solve(self.box_problem)
        if status == "infeasible":
            return NodeSolution(math.inf, math.inf, None, None, None, True, status)
        if status not in ("optimal", "optimal_inaccurate"):
            return NodeSolution(-math.inf, math.nan, None, None, None, False, status)
        s = np.asarray(self.box["s"].value, float)
        u = self.modes.phi @ s + np.asarray(self.box["v"].value, float)
        lam = None if self._obs is None else np.maximum(np.asarray(self._obs.dual_value), 0.0)
        value = float(self.box_problem.value)
        # The program's model of Psi (A_rho's quadratic form, eigenvectors exact only
        # to round-off) differs from the true energy by round-off that grows with N:
        # measured at the program's own minimiser, twice that difference comes off
        # the bound (at 128 elements a bound lay 2e-11 of the energy above the
        # true minimum without it).
        model = 2.0 * self.model_error(s, u)
        # An inaccurate solve's bound carries a wide margin (see _lower): it is used.
        return NodeSolution(self._lower(self.box_problem, settings) - model, value,
                            s, u, lam, True, status)

    def model_error(self, s, u) -> float:
        """|model - truth| of the quadratic part at ``u = Phi s + v``: the program's
        ``1/2 v'A_rho v - sum c_i s_i^2`` against ``1/2 u'(K - p G)u`` evaluated
        from curvatures and slopes (as the energy is; a bonded foundation's
        ``c M`` part added).  The other terms are the same functions in both; the
        solver's own slack is in the duality-gap margin."""
        dp = self.dp
        v = u - self.modes.phi @ s
        model = 0.5 * float(v @ (self.A_rho @ v)) - float(np.sum(self.modes.c * s**2))
        parts = dp.energy_parts(u)
        truth = parts["bending"] + parts["axial"]
        if dp.contact == "foundation" and dp.bilateral:
            w = dp.Nq @ u
            truth += 0.5 * float(np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape) @ w**2)
        return abs(model - truth)

    def reduced(self, s0):
        """The reduced function ``F(s0)``, its gradient, the minimiser ``u`` and the solve's status.

        ``F(s0) = min_v Psi(s0, v) - sum c_i s0_i^2`` (the energy's minimum over
        the complement at these amplitudes, ``c_i = (p - lambda_i) / 2``);
        ``dF = d Psi/ds - 2 c s0`` with
        ``d Psi/ds`` the multiplier of ``s == s0`` (envelope theorem).

        Returns
        -------
        F : float
        dF : ndarray
        u : ndarray
        ok : bool
        """
        s0 = np.asarray(s0, float)
        # The program's Psi is Pi + sum (p - lambda_i) / 2 s_i^2 exactly (A_rho's form
        # on the complement), not with the c_i, which carry a margin
        # (:attr:`Modes.c`): that is subtracted.
        c = (self.modes.p - self.modes.lam) / 2.0
        self.s0.value = s0
        status, _ = self._solve(self.fixed_problem)
        if status not in ("optimal", "optimal_inaccurate"):
            return math.nan, np.full(self.k, math.nan), None, False
        u = self.modes.phi @ s0 + np.asarray(self.fixed["v"].value, float)
        # CVXPY's multiplier of s == s0 is the value's derivative in -s0 ... sign
        # fixed by the Lagrangian convention L = f + y'(s - s0): dV/ds0 = -y.
        dpsi = -np.asarray(self._fix.dual_value, float).reshape(self.k)
        F = float(self.fixed_problem.value) - float(np.sum(c * s0**2))
        return F, dpsi - 2.0 * c * s0, u, status == "optimal"

    def obstacle_multipliers(self):
        """The fixed program's obstacle multipliers (None without an obstacle)."""
        obs = self.fixed["obs"]
        return None if obs is None else np.maximum(np.asarray(obs.dual_value), 0.0)
