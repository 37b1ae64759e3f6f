"""Rigid obstacle: the method of multipliers, started from a coarse mesh's answer.

The obstacle ``A z >= g`` (nodes and contact Gauss points, :mod:`gaocvx.mixed`)
is imposed by the augmented Lagrangian

    E(z) + 1/(2 rho) sum max(0, lam_i - rho gap_i(z))^2,

whose inner problems are semismooth (a foundation with a shifted level) and are
solved by :func:`gaocvx.newton._newton_step`.  It needs no linearly
independent active constraints: a beam lying flat on the obstacle has seven
active rows per element on a cubic, and a primal-dual active-set method,
whose multipliers there are not unique, chatters (measured: 30 steps without
settling at 2048 elements) or, from an over-predicted contact set, releases
a few points per step.

What costs iterations is finding the contact set.  The continuation
(:func:`continuation`) finds it by raising the penalty tenfold per update
from the beam's own stiffness (13-22 Newton steps, 30-60 factorisations at
128-2048 elements).  From 128 elements on, the contact set comes instead from
the answer on a mesh 16 times coarser, from 8 to 127 elements on one 4 times
coarser (recursively; the coarsest, of 2-7 elements, by thousandfold penalty
jumps, and not certified: it is only a start).  Its deflection, evaluated on
this mesh, is within the coarse discretisation error of the answer, so Newton
at the largest penalty, started there without multipliers (a stiff
foundation), meets only local changes of the contact set, and one to three
multiplier updates at that penalty end the violation.  A warm start (a sweep's previous value, or this answer in another
scale) is tried at the largest penalty first.  Under 8 elements the
continuation itself solves the scene, as before.

Every multiplier update at the largest penalty is judged by the certificate
(:func:`gaocvx.certificate.certify`'s measures); the first iterate within the
stopping margins is the answer.  If none is within FAST_BUDGET
factorisations, or progress stalls, the continuation runs from the original
start (:func:`continuation`), as before; the message says so.

Examples
--------
>>> from gaocvx import Scene, solve
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P1", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -5e8}, "obstacle": {"gap": 0.007}, "mesh": {"elements": 512}})
>>> r = solve(scene, "newton")
>>> r.status, "from the 32-element answer" in r.message, r.nit <= 8
('optimal', True, True)
"""

from __future__ import annotations

import logging
import math

import numpy as np

from . import fem
from .certificate import _obstacle_measures, _stationarity, certify, passes, penalty_range, shortfall
from .discrete import DiscreteProblem
from .mixed import MixedForm

__all__ = ["solve_obstacle", "continuation", "coarse_elements", "polish"]

log = logging.getLogger(__name__)

# Continuation on the coarsest mesh: the penalty starts at about the beam's
# global stiffness (a soft foundation, which Newton solves from any start) and
# jumps thousandfold per update (tenfold took 8-14 updates).
RHO_START = 10.0
RHO_JUMP = 1e3
# The multipliers are updated once the inner Newton step starts below this
# decrement (its end is then ~its square), or settles a piecewise-quadratic energy.
UPDATE_DECREMENT = 1e-4
# Re-solves per step with the active set predicted at its end: on flat contact at
# the largest penalty the predictions chatter (8 allowed: 4-9 factorisations a
# step without settling; 2: 1.2x fewer factorisations over the scenes of
# benchmarks/obstacle.py and 4 continuations instead of 7).
ROUNDS = 2
# A mesh of N >= COARSE_RATIO * COARSE_MIN elements starts from the answer on
# N // COARSE_RATIO elements; a smaller one of N >= SMALL_RATIO * SMALL_MIN from
# N // SMALL_RATIO (8 and 32 elements: 13 Newton steps of the continuation, 3
# factorisations from 2 and 8 elements; the deeper recursion of ratio 4 alone
# cost 1.7x at 512 elements, measured).
COARSE_RATIO = 16
COARSE_MIN = 8
SMALL_RATIO = 4
SMALL_MIN = 2
# Factorisations (on this mesh) before the continuation takes over (24 sent two
# gaps of the benchmark's sweep at 256 elements and a flat contact at 1024 to
# it), before a warm start gives way to the coarse start, and the updates at
# the largest penalty without halving the merit that count as a stall.
FAST_BUDGET = 40
WARM_BUDGET = 4
STALL = 4
# Factorisations for :func:`polish` (an interior-point answer 1.5e-6 of its size
# off a flat zone without force: 10 factorisations in 8 steps, measured).
POLISH_BUDGET = 20
# Stop when every measure of the certificate is within this fraction of its
# tolerance.  Feasibility: a violation of w >= g up to 1e-9 of the answer (the
# certificate allows 1e-7; the continuation asked 1e-10, for which a long flat
# contact needs tens of updates: the multipliers of its redundant rows converge
# by a few per cent per update).  Not 1e-8: on a flat contact at 1024 elements
# a violation of 1.05e-9 left nodes 1.2e-7 of the answer from Clarabel's
# (near the zone's end, where the violation moves the free boundary), 5.3e-10
# left 3.2e-8.
MARGIN = {"stationarity": 1e-3, "feasibility": 1e-2, "dual": 1e-3, "complementarity": 1e-2}


def coarse_elements(N: int) -> int | None:
    """Elements of the mesh whose answer starts an N-element solve (None: no coarser start).

    >>> coarse_elements(2048), coarse_elements(128), coarse_elements(127), coarse_elements(8)
    (128, 8, 31, 2)
    >>> coarse_elements(7) is None
    True
    """
    if N >= COARSE_RATIO * COARSE_MIN:
        return N // COARSE_RATIO
    return N // SMALL_RATIO if N >= SMALL_RATIO * SMALL_MIN else None


def solve_obstacle(mf: MixedForm, z, lam, tol: float, max_iter: int, start_only: bool = False):
    """Minimise the energy of ``mf`` over ``A z >= g``; (z, lam, iterations, note, residual).

    ``z``, ``lam``: the start (``lam`` non-zero: a warm start, at the largest
    penalty).  ``iterations`` counts the KKT factorisations of the Newton
    steps on this mesh (a step with a predicted active set may take several);
    ``residual`` is the certificate of ``(z, lam)`` (z on the linking
    constraints), or None when only the continuation's best iterate, not yet
    certified, is returned.  ``start_only``: the answer only starts a finer
    mesh's solve; it is returned within the stopping margins of feasibility,
    dual sign and complementarity, without the stationarity's two
    factorisations (residual None) and without the continuation.
    """
    _, rho_max = penalty_range(mf)
    start = (z, lam)
    coarse, note = 0, ""
    n_c = coarse_elements(mf.dp.n_nodes - 1)
    if n_c is None and not start_only:
        # A mesh under SMALL_RATIO * SMALL_MIN elements: the continuation itself
        # (started cold by thousandfold jumps, or warm at the largest penalty, with
        # no coarser start such meshes fell back to it for 34 and 18 of 150 random
        # scenes of tests/campaign.py, and saved no time).
        return continuation(mf, z, lam, tol, max_iter)
    warm_nf = 0
    if np.any(lam) and not start_only:
        # A warm start (the previous value of a sweep, or this answer in another
        # scale): at the largest penalty directly.  From a neighbour whose contact
        # set differs much, Newton at that penalty crawls (a sweep over the gap at
        # 256 elements: 20 factorisations a value); after WARM_BUDGET the coarse
        # start follows.
        z, lam, warm_nf, steps, residual = _iterate(mf, z, lam, rho_max, rho_max,
                                                    min(WARM_BUDGET, max_iter))
        if residual is not None:
            return z, lam, warm_nf, f"{steps} Newton steps from the warm start", residual
        z, lam = -mf.origin, mf.no_contact_forces()
        note = f" after {warm_nf} factorisations from the warm start"
    if n_c is not None:
        z, coarse = _coarse_start(mf, n_c, tol, max_iter)
        note += f" from the {n_c}-element answer ({coarse} factorisations there)"
        rho = rho_max
    else:  # the coarsest mesh of a start: its answer need not be certified
        rho = min(RHO_START, rho_max)
    z, lam, nf, steps, residual = _iterate(mf, z, lam, rho, rho_max, min(FAST_BUDGET, max_iter),
                                           start_only)
    nf += warm_nf
    if residual is not None or start_only:
        return z, lam, nf, f"{steps} Newton steps{note}", residual
    log.info("obstacle: not certified after %d factorisations%s; the continuation", nf, note)
    z, lam, n_old, note_old, residual = continuation(mf, *start, tol, max_iter)
    return z, lam, nf + n_old, f"{note_old}; the continuation, after {nf} factorisations " \
        f"without a certified answer{note}", residual


def polish(mf: MixedForm, z, lam, budget: int = POLISH_BUDGET):
    """The method of multipliers at its largest penalty, from another solver's answer.

    An interior-point answer of an obstacle problem keeps ~sqrt(tol) of force
    and gap on points where both are zero at the minimiser; along a soft
    direction that leaves the beam measurably off it (the certificate refuses
    such an answer).  The multipliers' update ``max(0, lam - rho gap)`` sets
    those forces to exactly zero, and a few Newton steps let the beam settle.

    Returns
    -------
    tuple or None
        ``(z, lam, factorisations, residual)``, the answer on the linking
        constraints and its certificate, if it passes within ``budget``
        factorisations; else None.
    """
    _, rho = penalty_range(mf)
    z, lam, nf, _, residual = _iterate(mf, z, lam, rho, rho, budget)
    if residual is None:
        return None
    z = mf.on_manifold(z)
    residual = certify(mf, z, lam)
    return (z, lam, nf, residual) if passes(residual) else None


def _coarse_start(mf: MixedForm, n_c: int, tol, max_iter):
    """The answer on ``n_c`` elements as variables of ``mf``, and its factorisations."""
    dp = mf.dp
    # Same scene, scale and level; the convexity limit of a coarser mesh is higher.
    coarse = DiscreteProblem(dp.scene, elements=n_c, check_convexity=False)
    if coarse.W != dp.W:
        coarse = coarse.rescaled(dp.W)
    mf_c = MixedForm.on_obstacle(coarse)
    z_c, _, nf, _, _ = solve_obstacle(mf_c, -mf_c.origin, mf_c.no_contact_forces(), tol,
                                      max_iter, start_only=True)
    # Its Hermite interpolant at this mesh's nodes (deflection and slope), chords from them.
    u = coarse.full(mf_c.to_hermite(z_c))
    full = np.zeros(mf.nz)
    full[0::3] = fem.eval_matrix(coarse.xi, dp.xi, 0) @ u
    full[1::3] = fem.eval_matrix(coarse.xi, dp.xi, 1) @ u
    full[2::3][: dp.n_nodes - 1] = np.diff(full[0::3]) / np.diff(dp.xi)
    return full[mf.free] - mf.origin, nf


def _iterate(mf: MixedForm, z, lam, rho, rho_max, budget, start_only=False):
    """Newton steps on the augmented Lagrangian, multipliers updated as each inner problem ends.

    Returns (z, lam, factorisations, steps, residual or None).  An iterate
    within the margins ends the loop; when progress stalls (round-off) or the
    budget is spent, the best certified iterate within ten times the margins
    is the answer, as in the continuation.
    """
    from . import newton as nw
    total, steps, stalled = 0, 0, 0
    best, best_cheap = None, math.inf
    while total < budget:
        steps += 1
        z, decrement, nf, settled = nw._newton_step(mf, z, {"shift": lam, "rho": rho}, ROUNDS)
        total += nf
        log.debug("obstacle step %d: penalty %.0e, decrement %s, %d factorisations", steps, rho,
                  decrement, nf)
        if decrement is None:  # the line search stalled: round-off
            break
        if decrement > UPDATE_DECREMENT and not settled:
            continue
        gap = mf.gap(z)
        lam = np.maximum(lam - rho * gap, 0.0)
        if rho < rho_max:
            rho = min(RHO_JUMP * rho, rho_max)
            continue
        z = mf.on_manifold(z)  # the certified function is the one reported
        gap = mf.gap(z)
        H = mf.hessian(z)
        residual = _obstacle_measures(mf, z, lam, gap, H)
        cheap = _merit(residual)
        log.log(logging.DEBUG if start_only else logging.INFO,
                "newton: multiplier update at step %d (penalty %.1e, %d factorisations): "
                "feasibility %.1e, merit %.1e", steps, rho, total, residual["feasibility"], cheap)
        if cheap <= 1.0 and start_only:
            return z, lam, total, steps, None
        if cheap <= 10.0:  # the stationarity too (two more factorisations)
            residual = {"stationarity": _stationarity(mf, z, lam, H), **residual}
            merit = _merit(residual)
            if merit <= 1.0:
                return z, lam, total, steps, residual
            if passes(residual) and (best is None or merit < best[0]):
                best = (merit, z, lam, residual)
        # Progress is a halving of the measures; none for STALL updates is round-off.
        stalled = 0 if cheap < 0.5 * best_cheap else stalled + 1
        best_cheap = min(best_cheap, cheap)
        if stalled >= STALL:
            break
    if best is not None and best[0] <= 10.0:
        return best[1], best[2], total, steps, best[3]
    return z, lam, total, steps, None


def _merit(residual: dict) -> float:
    """The largest measure of ``residual`` over its stopping margin (<= 1: done)."""
    return shortfall(residual, MARGIN)


def continuation(mf: MixedForm, z, lam, tol, max_iter):
    """The method of multipliers with the penalty growing tenfold per update (the former method).

    Returns (z, lam, iterations, note, residual or None); the iterate is the
    best seen by the certificate.
    """
    from . import newton as nw
    rho, rho_max = penalty_range(mf)
    total = 0
    previous = math.inf
    best, stalled = None, 0
    for outer in range(1, nw.MAX_OUTER + 1):
        # The penalty starts gentle (a soft foundation, which Newton solves from
        # any start) and stiffens tenfold per update up to rho_max.
        inner = tol if rho >= rho_max else max(tol, nw.INNER_TOL)  # the last ones to round-off
        z, nit, note = nw._newton(mf, z, inner, max_iter - total, {"shift": lam, "rho": rho})
        total += nit
        gap = mf.gap(z)
        lam = np.maximum(lam - rho * gap, 0.0)
        # Iterates that could pass are judged by the whole certificate: a stiff
        # penalty ends the violation, but its round-off (rho eps) can spoil
        # stationarity on flat contact, so the best iterate seen is the answer.
        # The others skip the stationarity (one more factorisation).
        H = mf.hessian(z)
        residual = _obstacle_measures(mf, z, lam, gap, H)
        last = (z, lam, f"{note}; {outer} multiplier updates")
        merit = math.inf
        if passes({"stationarity": 0.0, **residual}):
            residual = {"stationarity": _stationarity(mf, z, lam, H), **residual}
            merit = shortfall(residual, nw.MARGIN)
            if best is None or merit < best[0]:
                # Progress is a halving of the merit: on a long flat contact the
                # multipliers converge by a few per cent per update at the largest
                # penalty (measured: 3.3e-10 -> 1.3e-10 of feasibility in 20).
                stalled = 0 if best is None or merit < 0.5 * best[0] else stalled + 1
                best = (merit, *last, residual)
            else:
                stalled += 1
        log.info("newton: multiplier update %d (penalty %.1e): %d iterations, feasibility "
                 "%.1e, stationarity %s", outer, rho, nit, residual["feasibility"],
                 f"{residual['stationarity']:.1e}" if "stationarity" in residual else "-")
        # Done when within the margins, or when a best within ten times them has
        # not been halved for three updates (round-off, or a slow crawl: a stiffer
        # penalty only hurts).
        if merit <= 1.0 or total >= max_iter or (best is not None and stalled >= 3
                                                  and best[0] <= 10.0):
            break
        violation = residual["feasibility"]
        if rho < rho_max or violation > 0.25 * previous:
            rho = min(nw.RHO_GROWTH * rho, rho_max)
        previous = violation
    if best is None:  # no iterate could pass: the last one, certified by the caller
        return last[0], last[1], total, last[2], None
    _, z, lam, note, residual = best
    return z, lam, total, note, residual
