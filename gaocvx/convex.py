"""The convex ground truth: the discrete energy as a CVXPY program, solved and certified.

The program itself (its variables, terms and parameters) is
:class:`gaocvx.convex_program.ConvexProgram`: the energy on the
well-conditioned mixed variables with only the terms a scene needs.
With ``reuse=True`` :func:`solve_convex` reuses a compiled parametric program
of the same structure (a sweep).
Euler-Bernoulli scenes are quadratic programs and may use OSQP; anything else
uses Clarabel.  The solver's status is mapped honestly and every answer is
checked against the optimality conditions of the discrete problem before it
is called optimal.  An obstacle answer that fails them is polished by the
method of multipliers (:func:`gaocvx.contact_newton.polish`) and certified
again: an interior-point method leaves ~sqrt(tol) of force and gap where
both vanish at the minimiser.
"""

from __future__ import annotations

import logging
import time
import warnings

import numpy as np

from .contact_newton import polish
from .convex_program import ConvexProgram, clear_programs
from .convex_program import program as make_program
from .discrete import DiscreteProblem
from .errors import SceneError, SolverError
from .mixed import MixedForm
from .certificate import answer, certify, passes, shortfall

__all__ = ["solve_convex", "ConvexProgram", "clear_programs", "log_outcome"]

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
    program, reused = make_program(mf, solver, reuse)
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
    polished = ""
    if program.obstacle is not None and not passes(residual):
        # An interior-point answer off a zone where the beam touches without a
        # force (contact_newton.polish): the method of multipliers from it.
        found = polish(mf, z, lam)
        log.info("%s answer not certified (%s); polished by the method of multipliers: %s",
                 solver, _measures(residual), "certified" if found else "not certified")
        if found is not None:
            z, lam, nf, residual = found
            polished = f"; polished by the method of multipliers ({nf} factorisations)"
    # The status comes from the optimality conditions of the discrete problem
    # itself (a certificate independent of the solver's internal scaling); the
    # solver's own label is kept in the message.
    measures = _measures(residual)
    if passes(residual):
        message = f"{solver} status {status!r}; optimality conditions verified ({measures})"
    else:
        message = f"{solver} status {status!r}; optimality conditions NOT met ({measures})"
    message += polished
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
