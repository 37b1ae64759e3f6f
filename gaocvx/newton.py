"""Damped (semismooth) Newton method for the discrete energy, every scene kind.

The energy of a scene below P_bar_h is strictly convex.  Without contact and
without the Gao term it is quadratic, and one solve is the whole answer.  With
the Gao term it is smooth, and with a deformable foundation its gradient is
semismooth (the positive part), so Newton's method with the generalised
Hessian and a line search is globally convergent and ends in a handful of O(N)
iterations.  A rigid obstacle is handled by the method of multipliers
(augmented Lagrangian, :mod:`gaocvx.contact_newton`): each inner problem is
exactly a foundation problem (a positive-part penalty shifted by the
multipliers), solved by the same semismooth Newton method
(:func:`_newton_step`, :func:`_newton`), and the multipliers are updated until
the obstacle is respected to round-off.  Unlike a primal-dual active-set
method this does not need linearly independent active constraints, which a
beam lying flat on the obstacle does not have.

All of it runs on :class:`~gaocvx.mixed.MixedForm`, the well-conditioned
variables (w, theta, chord slope), with banded KKT solves.  The stopping test
is the relative Newton decrement, the same measure the convex solver is
certified with.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from .certificate import _decrement, answer, certify
from .discrete import DiscreteProblem
from .mixed import MixedForm

__all__ = ["solve_newton", "line_search"]

log = logging.getLogger(__name__)

# Newton converges quadratically: it stops at round-off (a decrement that stops
# falling fast once below ROUNDOFF), not at the certificate's tolerance, so that
# the answer is as accurate as double precision allows.
TOL = 1e-14
MAX_ITER = 100
ROUNDOFF = 1e-11   # a decrement that stops falling below this is round-off
# A decrement from which one full Newton step on the Gao energy reaches round-off.
QUADRATIC_RANGE = 1e-10
# A step the line search cuts by less than this is full: along a quadratic the
# minimum sits at t = 1 - O(eps * cond), which the search finds as 0.9999999999.
FULL_STEP = 1.0 - 1e-6
# Steps of iterative refinement on a settled active set (see _refined).
REFINEMENTS = 3
# The obstacle's method: "coarse start" (contact_newton.solve_obstacle) or "continuation"
# (the former method, kept for comparison: benchmarks/obstacle.py).
OBSTACLE_METHOD = "coarse start"
MAX_OUTER = 40     # multiplier updates for the obstacle
RHO_GROWTH = 10.0  # the penalty's growth per multiplier update
# Each inner problem of the continuation is a step towards the next: it stops at
# a decrement 1e-3 below what the certificate asks (its stop margin), not at
# round-off, which took two more factorisations per update to recognise.  At the
# largest penalty they go to round-off: the energy norm can be blind to the
# nodal size of what is left (a Gao beam pressed flat 1e-6 m onto an obstacle
# kept a Newton step of 3e-6 of itself).
INNER_TOL = 1e-10
# The method of multipliers stops when every measure of the certificate is below
# this fraction of its tolerance.
MARGIN = {"stationarity": 1e-3, "feasibility": 1e-3, "dual": 1e-3, "complementarity": 1e-2}


def solve_newton(dp: DiscreteProblem, warm: dict | None = None, tol: float = TOL,
                 max_iter: int = MAX_ITER) -> dict:
    """Minimise the discrete energy of ``dp`` by damped (semismooth) Newton.

    Parameters
    ----------
    dp : DiscreteProblem
    warm : dict, optional
        ``{"z": ..., "lam": ...}`` from an earlier solve of a similar scene on
        the same mesh (see the ``warm`` entry of the returned dict).
    tol : float
        Relative Newton decrement at which to stop.
    max_iter : int
        Newton iterations (in total, for the obstacle).

    Returns
    -------
    dict
        ``u`` (free Hermite DOFs), ``lam`` (obstacle multipliers or None),
        ``status``, ``message``, ``residual``, ``nit``, ``solver``,
        ``solve_time`` and ``warm``.
    """
    t0 = time.perf_counter()
    warm = _rescaled_warm(warm, dp)
    mf = MixedForm(dp)
    if dp.contact is not None and mf.contact_out_of_reach:
        # The foundation or obstacle lies provably below anything the beam can
        # reach: it costs nothing, so the contact-free problem is solved (an
        # obstacle's origin 1e15 m away would turn every w - g into round-off)
        # and its answer certified on the problem with the contact.
        free = solve_newton(dp.without_contact(), warm, tol, max_iter)
        return _finish(mf, free["z"], mf.no_contact_forces(), free["nit"], t0,
                       free["message"].removeprefix("newton: ")
                       + f"; the {dp.contact} is out of the beam's reach")
    if dp.contact == "obstacle":
        mf = MixedForm.on_obstacle(dp)
    z = -mf.origin  # the undeformed beam
    if warm is not None and len(warm.get("z", ())) == mf.n:
        z = np.array(warm["z"], float) - mf.origin
    if dp.n == 0 or not mf.has_load:
        # No free DOF, or no load: every energy term is >= 0 below P_bar_h and
        # vanishes at w = 0, which is admissible (g <= 0): the exact minimiser.
        note = "no free degrees of freedom" if dp.n == 0 else "no load"
        return _finish(mf, -mf.origin, mf.no_contact_forces(), 0, t0, f"{note}: w = 0")
    if dp.contact != "obstacle":
        z, nit, note = _newton(mf, z, tol, max_iter, {})
        return _finish(mf, z, None, nit, t0, note)

    # Rigid obstacle: the method of multipliers (gaocvx.contact_newton).
    lam = mf.no_contact_forces()
    if warm is not None and warm.get("lam") is not None and len(warm["lam"]) == len(lam):
        lam = np.array(warm["lam"], float)
    from .contact_newton import continuation, polish, solve_obstacle  # they use this module's steps
    method = continuation if OBSTACLE_METHOD == "continuation" else solve_obstacle
    z, lam, nit, note, residual = method(mf, z, lam, tol, max_iter)
    if residual is not None and mf.deflection_size(z) <= mf.zero_floor:
        # A beam pressed onto the obstacle, its answer below the zero floor: the
        # certificate measures it against the floor, not itself, and the method
        # of multipliers stops as soon as that passes, at whatever penalty it has
        # reached (a P1 beam pressed at gap 0 by 100 N, 10 elements: at 1e4,
        # lifted 2.4e-6 of the floor, where the convex program's answer is
        # within 2e-9 of it).  Polished at the largest penalty it goes to round-off.
        polished = polish(mf, z, lam)
        if polished is not None:
            z, lam, extra, residual = polished
            nit += extra
            note += "; polished at the largest penalty (an answer below the zero floor)"
    return _finish(mf, z, lam, nit, t0, note, residual)


def _rescaled_warm(warm: dict | None, dp: DiscreteProblem) -> dict | None:
    """A warm start in the deflection scale of ``dp`` (it records the scale it was made in).

    Deflections scale as 1/W, and so do the multipliers (forces per unit of
    non-dimensional deflection in units of E0 = EI W^2 / L^3).
    """
    if warm is None or warm.get("W", dp.W) == dp.W:
        return warm
    r = warm["W"] / dp.W
    lam = warm.get("lam")
    return {"z": np.asarray(warm["z"], float) * r, "lam": None if lam is None else lam * r,
            "W": dp.W}




def _newton(mf: MixedForm, z, tol, max_iter, al):
    """Newton iterations on the (augmented) energy; returns (z, iterations, note)."""
    dp = mf.dp
    if dp.is_quadratic and not al:
        # One KKT solve: the energy is quadratic (its factor serves the certificate
        # too), and one step of iterative refinement with the residual of the
        # answer takes the solve's own round-off out of it.
        for _ in range(2):
            d, _ = mf.quadratic_factor.solve(-mf.gradient(z), -mf.link(z))
            z = z + d
        return z, 1, "one banded KKT solve and one refinement (quadratic energy)"
    previous = math.inf
    # Without the Gao term the (augmented) energy is quadratic on each active set.
    piecewise_quadratic = not dp.needs_gao
    for it in range(1, max(max_iter, 1) + 1):
        g = mf.gradient(z, **al)
        H = mf.hessian(z, **al)
        d, mu = mf.kkt_solve(H, -g, -mf.link(z))
        decrement = _decrement(d, H, mf.scale(z, H))
        log.debug("newton iteration %d: decrement %.2e", it, decrement)
        if decrement <= tol:
            return z, it - 1, "Newton decrement below tolerance"
        used = None
        if dp.contact is not None:
            predicted, mu_p, used = _predict_active_set(mf, z, d, al)
            if mu_p is not None and float(g @ predicted) < 0.5 * float(g @ d):
                d, mu = predicted, mu_p  # kept only if it descends
        if decrement < ROUNDOFF and decrement > 0.5 * previous:
            return z, it - 1, f"decrement stagnated at {decrement:.1e} (round-off)"
        previous = decrement
        # Along d the Lagrangian E + mu'(C z), not E, decreases: g has a part C'mu
        # of the size of the constraint forces, and C d = -link(z) is round-off,
        # so near the answer g'd alone is that round-off times the forces and
        # the line search would stall long before the answer is.
        if decrement == math.inf and float(g @ d) + float(mu @ (mf.C @ d)) > 0:
            d = -d  # H numerically indefinite (P within round-off of P_bar_h): go downhill
        shift = float(mu @ (mf.C @ d))
        dphi = mf.directional(z, d, **al)
        t = line_search(lambda s: dphi(s) + shift, float(g @ d) + shift)
        if t is None:
            return z, it, "line search stalled (round-off level)"
        z = z + t * d
        if t >= FULL_STEP and decrement < math.inf:
            # A full step on a quadratic whose active set it does not change lands
            # on the minimiser; from a decrement of 1e-10 a full Newton step on the
            # Gao energy leaves round-off (with 1e-7, a stiff obstacle penalty's
            # large second derivatives left a beam lying flat at gap 0 lifted by
            # 5e-12 of the unsupported deflection, above its floor).  Either way the
            # next factorisation would only confirm round-off; the certificate
            # checks the answer regardless.
            same = used is None or _same(mf.active_sets(z, **al), used)
            if same and (piecewise_quadratic or decrement <= QUADRATIC_RANGE):
                return _refined(mf, z, al) if piecewise_quadratic else z, it, \
                    "full Newton step on a settled active set"
    return z, max_iter, f"stopped after {max_iter} iterations"


def _refined(mf: MixedForm, z, al):
    """``z`` after one step of iterative refinement on its active set (a quadratic
    energy there), kept if the active set stays.

    The step's solve leaves its own round-off, amplified by the KKT matrix's
    condition (~N^4): an Euler-Bernoulli cantilever pressed at gap 0 by 5e6 N
    (256 elements) had its unloaded free end tilted 2.3e-10 m (5.6e-12 of the
    unsupported deflection, above the floor's 1e-12) with one dependency
    release and not with another.  The residual of the answer, solved for once
    more, takes it out, as for a quadratic energy; on a machine without
    AVX-512 (numpy's X86_V3 kernels) one step left the tilt, and up to
    REFINEMENTS steps are taken, each kept only while the active set stays.
    """
    sets = mf.active_sets(z, **al)
    for _ in range(REFINEMENTS):
        d, _ = mf.kkt_solve(mf.hessian(z, **al), -mf.gradient(z, **al), -mf.link(z))
        if not np.all(np.isfinite(d)):
            return z
        z2 = z + d
        if not _same(mf.active_sets(z2, **al), sets):
            return z
        z = z2
    return z


def _newton_step(mf: MixedForm, z, al, rounds):
    """One semismooth Newton step on the augmented energy ``al``.

    Returns (new z, decrement at z, factorisations, settled); the decrement is
    None when the line search stalled; settled: a full step that kept its
    predicted active set (on a piecewise-quadratic energy, the minimiser).
    """
    g = mf.gradient(z, **al)
    H = mf.hessian(z, **al)
    d, mu = mf.kkt_solve(H, -g, -mf.link(z))
    factorisations = 1
    decrement = _decrement(d, H, mf.scale(z, H))
    predicted, mu_p, used, n = _predict_active_set(mf, z, d, al, rounds, count=True)
    factorisations += n
    if mu_p is not None and float(g @ predicted) < 0.5 * float(g @ d):
        d, mu = predicted, mu_p
    if decrement == math.inf and float(g @ d) + float(mu @ (mf.C @ d)) > 0:
        d = -d
    shift = float(mu @ (mf.C @ d))
    dphi = mf.directional(z, d, **al)
    t = line_search(lambda s: dphi(s) + shift, float(g @ d) + shift)
    if t is None:
        return z, None, factorisations, False
    z = z + t * d
    settled = t >= FULL_STEP and _same(mf.active_sets(z, **al), used) and not mf.dp.needs_gao
    return z, decrement, factorisations, settled


def _same(a, b):
    return all((x is None and y is None) or (x is not None and np.array_equal(x, y))
               for x, y in zip(a, b))


def _predict_active_set(mf, z, d, al, rounds=8, count=False):
    """Semismooth Newton step with the active set predicted at the step's end.

    The contact forces are linearised on the points in contact at z + d
    (primal-dual active-set style) and the step recomputed until the set
    settles; the line search then judges the step on the true energy.
    Returns the step, its constraint multipliers (None if unchanged) and the
    active sets it was computed on.
    """
    used = mf.active_sets(z, **al)
    mu = None
    n = 0
    for _ in range(rounds):
        predicted = mf.active_sets(z + d, **al)
        if _same(predicted, used):
            break
        used = predicted
        g = mf.gradient(z, active=used, **al)
        H = mf.hessian(z, active=used, **al)
        d, mu = mf.kkt_solve(H, -g, -mf.link(z))
        n += 1
    return (d, mu, used, n) if count else (d, mu, used)


def line_search(dphi, slope0, rtol=0.1, max_eval=30):
    """Step length in (0, 1] along a descent direction from phi'(t) (``slope0 = phi'(0) < 0``).

    The energy is convex along the line, so phi' increases and phi'(t) <= 0
    proves a decrease without comparing energies (which drown in round-off on
    fine meshes).  The full step is taken when it does not overshoot the
    minimum along the line; otherwise Illinois (modified regula falsi) steps
    find t with ``rtol * phi'(0) <= phi'(t) <= 0`` (rtol = 0.1 for Newton; a
    small rtol approaches the exact line search of conditional gradient).
    Returns None when no such t > 0 is found.
    """
    if slope0 >= 0:
        return None
    hi, f_hi = 1.0, dphi(1.0)
    if f_hi <= 0.0:
        return 1.0
    lo, f_lo, side = 0.0, slope0, 0
    # A step many orders too long (Newton from w = 0 near P_bar_h, where only the
    # quartic term stops the buckling mode) leaves phi'(1) ~ 1e30: regula falsi
    # would need hundreds of steps, so the bracket is first shrunk tenfold at a time.
    for _ in range(60):
        t = 0.1 * hi
        f_t = dphi(t)
        if f_t > 0.0 and t > 1e-300:
            hi, f_hi = t, f_t
            continue
        if f_t <= 0.0 and t > 0:
            if f_t >= rtol * slope0:
                return t
            lo, f_lo = t, f_t
        break
    for _ in range(max_eval):
        t = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        if not lo < t < hi:
            t = 0.5 * (lo + hi)
        f_t = dphi(t)
        if f_t <= 0.0:
            lo, f_lo = t, f_t
            if f_t >= rtol * slope0:
                return t
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = t, f_t
            if side == 1:
                f_lo *= 0.5
            side = 1
        if hi - lo <= 1e-13:
            break
    return lo if lo > 0 else None




















def _finish(mf, z, lam, nit, t0, note, residual=None):
    """The result dict; ``residual``: the certificate of (z, lam) if already computed."""
    if residual is None or np.any(mf.link(z)):
        z = mf.on_manifold(z)
        residual = certify(mf, z, lam)
    return answer(mf, z, lam, residual, f"newton: {note}", nit, "banded-kkt", t0,
                  warm={"z": mf.absolute(z), "lam": lam, "W": mf.dp.W})
