"""The convex ground truth: the discrete energy as a CVXPY program.

The program is written on the well-conditioned mixed variables of
:class:`~gaocvx.mixed.MixedForm` (deflections, slopes and chord slopes tied
by sparse linear constraints) and contains only the terms a scene needs:

* bending ``1/2 z' K z`` with K the (banded) bending form of the curvatures
  at Gauss points, which are first differences in these variables; with a
  compressive axial force the bending and axial parts are one quadratic form,
  positive definite only on the constraints, so ``Q + rho C'C`` is used
  (``C z = 0`` on the feasible set), proved definite by a banded Cholesky;
* the Gao term ``a/12 Σ w_q s_q^4`` with slopes at 5 Gauss points, as
  ``a sigma^4/12 Σ w_q u_q^2`` with ``u_q >= (s_q/sigma)^2`` (one rotated
  second-order cone per point; sigma is the slope scale of the linear answer);
* the foundation term ``c/2 Σ w_q v_q^2`` with ``v >= g - w_q`` at 5 Gauss
  points (``v = pos(g - w_q)`` at the optimum: minimising v_q^2 makes v >= 0
  hold by itself);
* for a rigid obstacle, ``w >= g`` at the nodes and the same Gauss points.

The Gao and foundation terms are ``quad_form``s of diagonal matrices, which
CVXPY passes to Clarabel's quadratic objective as they are (``sum_squares``
would add a variable and an equality per quadrature point: at 2048 elements
51198 variables instead of 26622, and about 1.6x the run time, measured).
Bending is the exception: as ``sum_squares`` of the weighted curvatures it
adds 2 variables and equalities per element, but as a ``quad_form`` of the
banded bending matrix Clarabel needed 21 iterations instead of 15 (2048
elements on a foundation, measured).  At 2048 elements on a foundation the
program has 30718 variables and 47104 rows: 5 points per element for the Gao
cones (3 rows each), 5 for the foundation, the curvatures and the links.
Five cones per element are the fewest for the exact quartic: ``∫ s^4`` over
an element, s quadratic, is a quartic form whose moment (catalecticant)
matrix, the Hankel matrix of ``∫ t^k``, k <= 8, has rank 5, so it is no sum
of fewer fourth powers of linear forms.

A factor on the load, the foundation level and stiffness, the Gao
coefficient and a tensile axial force can be CVXPY Parameters (the program is
DPP), so a sweep over them reuses the compiled problem: with ``reuse=True``
:func:`solve_convex` keeps the last few programs keyed by their structure.
Euler-Bernoulli scenes are quadratic programs and may use OSQP; anything else
uses Clarabel.  The solver's status is mapped honestly and every answer is
checked against the optimality conditions of the discrete problem before it
is called optimal.
"""

from __future__ import annotations

import logging
import time
import warnings

import numpy as np
import scipy.sparse as sp

from .discrete import DiscreteProblem
from .errors import SceneError, SolverError
from .linalg import BandedCholesky, NotPositiveDefinite
from .cache import LRU
from .mixed import MixedForm, structure_key
from .newton import answer, certify, passes, shortfall

__all__ = ["solve_convex", "ConvexProgram", "log_outcome"]

log = logging.getLogger(__name__)

# Clarabel is asked for as little as the accuracy needs, and tighter only when the
# certificate fails.  A relative duality gap c bounds the relative energy excess,
# and so the energy-norm error by about sqrt(c): the certificate's 1e-6 needs
# c ~ 1e-12 in the worst case.  Without an obstacle 1e-10 usually certifies
# (2048 elements, P1 on a foundation: stationarity 9e-9 in 13 iterations) but not
# always (a cantilever on a foundation, 8192 elements: 3.7e-6); 1e-12 certifies
# it (3e-8) for two iterations more (15 at 2048 elements; measured).  With an
# obstacle, complementarity c must be below 1e-12: 1e-13 reaches that (1e-12
# left some at 1.1e-12; 1e-14 is beyond double precision).  Clarabel's default
# static regularisation of its KKT systems (1e-8) left obstacle answers from
# 1024 elements on with violations of ~1e-8 W and complementarity ~1e-10: a node
# in point contact and the Gauss points 0.047 h beside it give nearly parallel
# constraint rows.  1e-12 certifies them at no cost in iterations (measured).
# The first rungs switch off Clarabel's Ruiz equilibration: the program is scaled
# by construction (mixed variables, slopes over their scale sigma, depths and
# deflections in units of W), and equilibrating it again cost iterations and
# accuracy (measured on the Gao beam, q = -5e8 N/m: clamped, no contact, 2048
# elements, 108 iterations with it, 16 without; on an obstacle, stationarity
# 1.4e-5 with it and 1.2e-9 without (P1, 8192 elements), 1.9e-6 and 5e-7 (P4,
# 2048 elements): with it a node in point contact was left 7e-11 W below the
# obstacle, a kink that h^-1.5 magnifies in the energy norm).  Without an
# obstacle the first rung also skips iterative refinement of the KKT solves,
# which took a third of the iteration time: every support with and without a
# foundation at 2048 and 8192 elements certified so, in one iteration more
# (e.g. P1 on a foundation, 2048 elements: 16 iterations, stationarity 6e-10;
# measured).  With an obstacle it is needed (P4, 2048 elements: not certified
# without it).  The later rungs are the earlier ladder, equilibrated and refined.
# If Clarabel errors at a setting, the next one is tried.
CLARABEL_LADDER = {
    "smooth": [dict(tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-10, max_iter=400,
                    equilibrate_enable=False, iterative_refinement_enable=False),
               dict(tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10, max_iter=400),
               dict(tol_gap_abs=1e-13, tol_gap_rel=1e-13, tol_feas=1e-10, max_iter=400), {}],
    "obstacle": [dict(tol_gap_abs=1e-13, tol_gap_rel=1e-13, tol_feas=1e-10, max_iter=400,
                      static_regularization_constant=1e-12, equilibrate_enable=False),
                 dict(tol_gap_abs=1e-13, tol_gap_rel=1e-13, tol_feas=1e-10, max_iter=400,
                      static_regularization_constant=1e-12),
                 dict(tol_gap_abs=1e-13, tol_gap_rel=1e-13, tol_feas=1e-10, max_iter=400),
                 dict(tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-9, max_iter=400), {}],
}
# OSQP (ADMM) cannot reach 1e-10 on these programs within any sensible number of
# iterations (measured: 'user_limit' at 512 elements); its polishing step, an
# exact solve on the guessed active set, gives the accuracy from 1e-6 on.
# Its iterations are not interruptible from Python, so each rung has a time limit
# [s] (a 3059-element scene once ran 465 s); a rung that hits it is not certified
# and the next is tried.
OSQP_TIME_LIMIT = 60.0
OSQP_LADDER = [dict(eps_abs=1e-6, eps_rel=1e-6, max_iter=200_000, polishing=True,
                    time_limit=OSQP_TIME_LIMIT),
               dict(eps_abs=1e-8, eps_rel=1e-8, max_iter=400_000, polishing=True,
                    time_limit=OSQP_TIME_LIMIT)]


def _explicit(ladder: list) -> list:
    """Every rung with every setting the ladder touches, Clarabel's defaults filled in.

    A setting given once stays in force for later solves of the same CVXPY
    problem unless it is given again (measured: a static regularisation of
    1e-12 leaked into the next rung, which then failed as the first had).
    """
    import clarabel

    defaults = clarabel.DefaultSettings()
    keys = {k for rung in ladder for k in rung}
    return [{**{k: getattr(defaults, k) for k in keys}, **rung} for rung in ladder]


class ConvexProgram:
    """The CVXPY program of one problem structure.

    Parameters
    ----------
    mf : MixedForm
        Of the first scene with this structure.
    parametric : bool
        Make a factor on the load, the level, stiffness, Gao coefficient and
        tension CVXPY Parameters (DPP), so that :meth:`set` and a new solve
        reuse the compilation.
    """

    def __init__(self, mf: MixedForm, parametric: bool = False):
        import cvxpy as cp

        dp = mf.dp
        self.parametric = parametric

        def param(value, **kw):
            return cp.Parameter(value=value, **kw) if parametric else value

        self.z = z = cp.Variable(mf.n, name="z")
        # The load enters as a scalar times a fixed vector: a vector Parameter
        # made the DPP compilation ten times slower (2.3 s against 0.24 s at 1024
        # elements, measured); sweeps over anything but the load's shape keep it
        # parallel (see set()).
        self.load_shape = mf.f.copy()
        self.load_factor = param(1.0, name="load_factor")
        self.compressed = dp.p > 0
        terms = [-self.load_factor * (self.load_shape @ z)]
        # Quadratic terms are quad_forms of constant sparse matrices: CVXPY hands
        # them to Clarabel's quadratic objective as they are, where sum_squares
        # would add a variable and an equality per quadrature point.
        if self.compressed:
            # One quadratic form; it depends on p, which is then fixed.
            terms.append(0.5 * cp.quad_form(z, cp.psd_wrap(_compressed_form(mf))))
        else:
            terms.append(0.5 * cp.sum_squares(sp.diags(np.sqrt(mf.wq2)) @ mf.B2 @ z))
            if mf.has_slope and (parametric or dp.p < 0):
                self.tension = param(-dp.p, nonneg=True, name="tension")
                terms.append(0.5 * self.tension * cp.quad_form(z, cp.psd_wrap(mf.axial)))
        constraints = [mf.C @ z == 0]
        if dp.needs_gao:
            # a/12 sum w_q s_q^4 = a sigma^4/12 sum w_q u_q^2 with u_q >= (s_q/sigma)^2,
            # one rotated cone ||(2 s_q/sigma, u_q - 1)|| <= u_q + 1 per point.  The
            # slope scale sigma (of a Ritz estimate of the answer; in a parametric
            # program, of the first scene) brings u to about 1: unscaled,
            # slopes of 7 took Clarabel 71 iterations to 'optimal_inaccurate' where
            # scaled ones take 13 to 'optimal' (measured).  The power cone of
            # power(s, 4) is much less accurate in Clarabel.
            self.a = param(dp.a, nonneg=True, name="gao")
            sigma = _slope_scale(mf)
            u = cp.Variable(len(mf.wq5), name="slope_squared")
            constraints.append(cp.SOC(u + 1, cp.vstack([(mf.B1 * (2.0 / sigma)) @ z, u - 1]),
                                      axis=0))
            terms.append(self.a * (sigma**4 / 12.0)
                         * cp.quad_form(u, cp.psd_wrap(sp.diags(mf.wq5))))
        self.obstacle = None
        if dp.contact is not None and not (dp.bilateral and self.compressed):
            level = _level(mf)
            self.g = param(level, name="level") if np.ndim(level) == 0 else level
        self.bonded_in_form = dp.bilateral and self.compressed
        if self.bonded_in_form:
            # Bonded under compression: c/2 sum w_q (g - w_q)^2 has its quadratic part
            # in the compressed form (above P_bar_h it is what makes that form
            # positive definite); here its linear part and constant, as numbers
            # (c g is a product of two parameters, not DPP: such a program is
            # rebuilt for each scene, see set()).
            depth0 = mf.depth(np.zeros(mf.n))
            cwd = dp.c * mf.wqc * depth0
            terms.append(-((mf.NqT @ cwd) @ z) + 0.5 * float(cwd @ depth0))
        elif dp.contact == "foundation":
            # c/2 sum w_q pos(g - w_q)^2 = min c/2 sum w_q v_q^2 over v >= g - w_q: the
            # weights are positive, so the minimum over v_q is at v_q = max(g - w_q, 0)
            # and v >= 0 is implied (the same energy; the rows were dropped: at 2048
            # elements 14 Clarabel iterations instead of 17, 47104 rows instead of
            # 57344, measured).  Bonded (bilateral): v = g - w_q.  v keeps it DPP.
            self.c = param(dp.c, nonneg=True, name="stiffness") if np.ndim(dp.c) == 0 else 1.0
            weights = mf.wqc if np.ndim(dp.c) == 0 else dp.c * mf.wqc   # a stiffness profile
            v = cp.Variable(len(mf.wqc), name="depth")
            if dp.bilateral:
                constraints.append(v == self.g - mf.Nq @ z)
            else:
                constraints.append(v >= self.g - mf.Nq @ z)
            terms.append(0.5 * self.c * cp.quad_form(v, cp.psd_wrap(sp.diags(weights))))
        elif dp.contact == "obstacle":
            self.obstacle = mf.A @ z >= self.g
            constraints.append(self.obstacle)
        self.problem = cp.Problem(cp.Minimize(cp.sum(terms)), constraints)
        if not self.problem.is_dcp(dpp=parametric):  # a formulation bug, never the user's
            raise AssertionError("the convex formulation is not DCP/DPP")

    def set(self, mf: MixedForm) -> bool:
        """Load the values of a scene with this structure into the Parameters.

        Returns False (and changes nothing) if the scene's load vector is not a
        multiple of this program's, which the program cannot represent.
        """
        if not self.parametric:
            raise ValueError("a program built without parameters cannot be updated")
        if self.bonded_in_form:
            return False
        shape = self.load_shape
        norm2 = float(shape @ shape)
        factor = float(mf.f @ shape) / norm2 if norm2 > 0 else 0.0
        if np.linalg.norm(mf.f - factor * shape) > 1e-13 * max(np.linalg.norm(mf.f), 1e-300):
            return False
        dp = mf.dp
        self.load_factor.value = factor
        if not self.compressed and mf.has_slope:
            self.tension.value = -dp.p
        if dp.needs_gao:
            self.a.value = dp.a
        if dp.contact is not None:
            self.g.value = _level(mf)
        if dp.contact == "foundation":
            self.c.value = dp.c
        return True


def _level(mf: MixedForm) -> float:
    """The contact level for the program: g, or a level the answer provably cannot reach.

    A foundation or obstacle millions of deflection scales below the beam puts
    numbers of that size into the program's constraints, and Clarabel fails.
    Below twice :meth:`MixedForm.deflection_bound` (and below -1, one
    deflection scale) the contact term vanishes near the answer, so raising
    the level there does not change the minimiser.
    """
    g = mf.level if mf.dp.contact == "obstacle" else mf.dp.g   # at the constraint points
    if mf.dp.bilateral:  # a bonded foundation pulls from any distance: g itself
        return g
    # At least one deflection scale below: with no load the bound is 0 (w = 0).
    return np.maximum(g, -max(2.0 * mf.deflection_bound(), 1.0))


def _slope_scale(mf: MixedForm) -> float:
    """Largest slope of a one-term Ritz approximation of the answer; 1 without load.

    Along the linear answer z (bending and axial only) the energy is
    ``A t^2/2 + B t^4/4 - A t`` with ``A = f'z`` and ``B = a/3 Σ w_q s_q^4``; its
    minimiser t (``t + (B/A) t^3 = 1``) accounts for the stiffening of the Gao
    term, which near P_bar_h keeps the answer far below the linear one.
    """
    z, _ = mf.quadratic_factor.solve(mf.f, np.zeros(mf.N))
    s = mf.B1 @ z
    A = float(mf.f @ z)
    peak = float(np.max(np.abs(s), initial=0.0))
    if not (np.isfinite(A) and np.isfinite(peak) and A > 0 and peak > 0):
        return 1.0
    ratio = mf.dp.a / 3.0 * float(mf.wq5 @ s**4) / A
    t = np.roots([ratio, 0.0, 1.0, -1.0]) if ratio > 0 else np.array([1.0])
    t = float(np.max(t[np.abs(t.imag) < 1e-12 * max(1.0, np.max(np.abs(t)))].real))
    return t * peak


def _compressed_form(mf: MixedForm) -> sp.csr_matrix:
    """bending - p axial (+ a bonded foundation's c M) + rho C'C, positive definite by Cholesky."""
    dp = mf.dp
    CtC = (mf.C.T @ mf.C).tocsr()
    H0 = mf.H0
    if dp.bilateral:
        H0 = H0 + mf.NqT @ sp.diags(dp.c * mf.wqc) @ mf.Nq
    # C z = 0 on the feasible set, so rho C'C changes nothing there; it makes the
    # form definite off it (the rigid rotation of P4, directions that violate C).
    rho = 1.0 / float(np.min(np.diff(dp.xi))) ** 2
    for _ in range(12):
        Q = (H0 + rho * CtC).tocsr()
        try:
            BandedCholesky(Q)
            return Q
        except NotPositiveDefinite:
            rho *= 4.0
    raise SceneError("load.axial", f"P = {dp.P:.4g} N leaves the discrete energy without a "
                     f"convex form (P_bar_h = {dp.P_bar_h:.4g} N)", dp.P)


# Compiled parametric programs by structure, one cache per thread: a program
# holds the parameter values of the scene being solved.
_PROGRAMS = LRU(4, per_thread=True)


def clear_programs() -> None:
    """Forget this thread's compiled parametric programs."""
    _PROGRAMS.clear()


def _program(mf: MixedForm, solver: str, reuse: bool) -> tuple[ConvexProgram, bool]:
    if not reuse or mf.dp.scene.has_profile or mf.dp.g_above is not None:
        # A profile's level and stiffness vary along the beam: they enter as
        # numbers, and such a program is not reused.
        return ConvexProgram(mf), False
    dp = mf.dp
    # The compressed form depends on p, fixed when the program is built.
    key = (structure_key(dp), dp.needs_gao, dp.p if dp.p > 0 else None, solver, dp.bilateral)
    program = _PROGRAMS.get(key)
    if program is not None and program.set(mf):
        return program, True
    return _PROGRAMS.put(key, ConvexProgram(mf, parametric=True)), False


def solve_convex(dp: DiscreteProblem, solver: str = "clarabel", verbose: bool = False,
                 reuse: bool = False, *, final: bool = True) -> dict:
    """Solve the discrete scene with CVXPY.

    Parameters
    ----------
    dp : DiscreteProblem
    solver : {"clarabel", "osqp"}
        OSQP only for quadratic programs (Euler-Bernoulli scenes).
    reuse : bool
        Keep the compiled (parametric) program and reuse it for later scenes
        of the same structure (sweeps over load, gap, stiffness, tension).
    final : bool
        The caller returns this answer as it is, so an answer that is not
        certified is logged as a WARNING.  False when the caller may replace
        it by another attempt (a re-solve in the answer's own scale): it is
        then logged at INFO, and the caller reports the answer it finally
        returns with :func:`log_outcome`.

    Returns
    -------
    dict
        ``u`` (free Hermite DOFs), ``lam`` (obstacle multipliers or None),
        ``status`` ("optimal" or "inaccurate"), ``message``, ``residual``,
        ``nit``, ``solver``, ``solve_time``, ``reused`` (the compiled program
        of an earlier scene with the same structure was reused).

    Raises
    ------
    SceneError
        If OSQP is asked for a scene that is not a quadratic program.
    SolverError
        If the solver returns no solution.
    """
    import cvxpy as cp

    t0 = time.perf_counter()
    mf = MixedForm(dp)
    if solver == "osqp" and dp.needs_gao:
        raise SceneError("solve.solver", "OSQP solves quadratic programs only; the gao "
                         "model's quartic term needs clarabel", solver)
    if not mf.has_load:
        # Every energy term is >= 0 below P_bar_h and vanishes at w = 0, which is
        # admissible (g <= 0): the exact minimiser.  Interior-point iterations on
        # an optimum of value 0 can stall (measured: Clarabel's InsufficientProgress
        # under compression), so the solver is not called.  "No load" is a load
        # vector that is exactly zero, never a quadratic form that rounds to zero.
        z = np.zeros(mf.n)
        lam = mf.no_contact_forces()
        raw = answer(mf, z, lam, certify(mf, z, lam),
                     "no load: w = 0 is the exact minimiser (every energy term is >= 0 and "
                     "vanishes there); the solver was not called", 0, solver, t0, reused=False)
        log_outcome(raw, final)
        return raw
    if mf.contact_out_of_reach:
        # A foundation or obstacle provably below anything the beam reaches costs
        # nothing: the contact-free program is solved and its answer certified on
        # the problem with the contact (numbers of the size of a far gap in the
        # program's constraints would make Clarabel fail).
        # The contact-free answer is not the one returned (it is certified again,
        # with the contact): its verdict is logged here, not as final.
        free = solve_convex(dp.without_contact(), solver, verbose, reuse, final=False)
        lam = mf.no_contact_forces()
        z = mf.on_manifold(free["z"])
        raw = answer(mf, z, lam, certify(mf, z, lam),
                     free["message"] + f"; the {dp.contact} is out of the beam's reach",
                     free["nit"], solver, t0, reused=free["reused"])
        log_outcome(raw, final)
        return raw
    program, reused = _program(mf, solver, reuse)
    if solver == "osqp":
        attempts = [dict(solver=cp.OSQP, **s) for s in OSQP_LADDER]
    else:
        kind = "obstacle" if dp.contact == "obstacle" else "smooth"
        attempts = [dict(solver=cp.CLARABEL, **s) for s in _explicit(CLARABEL_LADDER[kind])]
    best = None
    # Rungs tried so far: an answer certified at rung k replaced k - 1 answers
    # logged as not certified, and says so (log_outcome).
    tried = 0
    for rung, kwargs in enumerate(attempts, start=1):
        more = rung < len(attempts)
        tried = rung
        with warnings.catch_warnings():
            # An inaccurate solve is reported through the status below, not as a warning.
            warnings.simplefilter("ignore", UserWarning)
            try:
                program.problem.solve(verbose=verbose, **kwargs)
            except cp.error.SolverError as exc:
                log.info("%s failed at settings %s: %s%s", solver, kwargs, exc, _next(more))
                continue
        status = program.problem.status
        if program.z.value is None or status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            log.info("%s returned %s at settings %s%s", solver, status, kwargs, _next(more))
            continue
        z = mf.on_manifold(program.z.value)
        lam = (None if program.obstacle is None
               else np.asarray(program.obstacle.dual_value, float).ravel())
        attempt = (status, z, lam, certify(mf, z, lam))
        # A later rung is not always better (at 8192 elements on an obstacle the
        # last, Clarabel's defaults, left stationarity 0.92 where the first left
        # 7e-5): the answer is the attempt nearest to passing.
        if best is None or shortfall(attempt[3]) < shortfall(best[3]):
            best = attempt
        if passes(best[3]):
            break
        log.info("%s answer at settings %s not certified (%s)%s", solver, kwargs,
                 _measures(attempt[3]), _next(more))
    if best is None:
        raise SolverError(f"{solver} returned no solution (status {program.problem.status!r})",
                          program.problem.status or "error")
    status, z, lam, residual = best
    # The status comes from the optimality conditions of the discrete problem
    # itself (a certificate independent of the solver's internal scaling); the
    # solver's own label is kept in the message.
    measures = _measures(residual)
    if passes(residual):
        message = f"{solver} status {status!r}; optimality conditions verified ({measures})"
    else:
        message = f"{solver} status {status!r}; optimality conditions NOT met ({measures})"
    nit = getattr(program.problem.solver_stats, "num_iters", None)
    raw = answer(mf, z, lam, residual, message, nit, solver, t0, reused=reused)
    log_outcome(raw, final, replaced=tried - 1)
    return raw


def _measures(residual: dict) -> str:
    return ", ".join(f"{k}={v:.2e}" for k, v in residual.items())


def _next(more: bool) -> str:
    return "; the next settings follow" if more else "; no settings left"


def log_outcome(raw: dict, final: bool = True, replaced: int = 0) -> None:
    """Log the verdict on a convex answer: a WARNING only for one returned uncertified.

    An attempt that a later one replaces (a tighter rung of the solver's
    settings, a re-solve in the answer's own scale) is no answer the user
    gets: its failure is logged at INFO, and a WARNING would contradict the
    certified status the user sees next.

    Parameters
    ----------
    raw : dict
        The result of :func:`solve_convex` (its ``status`` and ``message``).
    final : bool
        Whether ``raw`` is the answer returned to the user.  False: an answer
        that is not certified is logged at INFO, saying that the caller may try
        again.
    replaced : int
        Attempts that came before this answer and were not certified: a
        certified answer says at INFO that it replaced them.

    Examples
    --------
    >>> import sys
    >>> show = logging.StreamHandler(sys.stdout)
    >>> show.setFormatter(logging.Formatter("%(levelname)s %(message)s"))
    >>> log.addHandler(show); log.setLevel(logging.INFO)
    >>> log_outcome({"status": "inaccurate", "message": "NOT met"}, final=False)
    INFO convex answer not certified (NOT met); not final: the caller may solve again
    >>> log_outcome({"status": "optimal", "message": "verified"}, replaced=1)
    INFO convex solve certified, replacing 1 earlier attempt not certified: verified
    >>> log_outcome({"status": "inaccurate", "message": "NOT met"})
    WARNING convex solve not certified optimal: NOT met
    >>> log.removeHandler(show); log.setLevel(logging.NOTSET)
    """
    if raw["status"] == "optimal":
        if replaced:
            log.info("convex solve certified, replacing %d earlier attempt%s not certified: %s",
                     replaced, "" if replaced == 1 else "s", raw["message"])
    elif final:
        log.warning("convex solve not certified optimal: %s", raw["message"])
    else:
        log.info("convex answer not certified (%s); not final: the caller may solve again",
                 raw["message"])
