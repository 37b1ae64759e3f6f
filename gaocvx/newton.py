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

from .discrete import (COMPLEMENTARITY_TOL, FEASIBILITY_TOL, STATIONARITY_TOL, DiscreteProblem,
                       complementarity)
from .mixed import MixedForm

__all__ = ["solve_newton", "certify", "passes", "line_search", "answer"]

log = logging.getLogger(__name__)

# Newton converges quadratically: it stops at round-off (a decrement that stops
# falling fast once below ROUNDOFF), not at the certificate's tolerance, so that
# the answer is as accurate as double precision allows.
TOL = 1e-14
MAX_ITER = 100
ROUNDOFF = 1e-11   # a decrement that stops falling below this is round-off
# Relative round-off of p = P L^2 / EI as the solver receives it: about four
# roundings of eps (EI from E, width and thickness, then L^2 / EI and P).
DATA_ROUNDOFF = 4 * np.finfo(float).eps
# A decrement from which one full Newton step on the Gao energy reaches round-off.
QUADRATIC_RANGE = 1e-10
# A step the line search cuts by less than this is full: along a quadratic the
# minimum sits at t = 1 - O(eps * cond), which the search finds as 0.9999999999.
FULL_STEP = 1.0 - 1e-6
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
# A multiplier update moves lambda by rho * (g - A z); with A z known to ~1e-13
# (round-off), rho beyond ~1e10 turns round-off into multiplier noise.
RHO_CAP = 1e10
# The constraint points nearest a node are the contact Gauss points 0.047 h from it.
GAUSS_OFFSET = 0.5 * (1.0 - 0.9061798459386640)
# The method of multipliers stops when every measure of the certificate is below
# this fraction of its tolerance.
MARGIN = {"stationarity": 1e-3, "feasibility": 1e-3, "dual": 1e-3, "complementarity": 1e-2}
# Rounds of the contact step's active set (:func:`_contact_step`).
CONTACT_ROUNDS = 6
TOLERANCES = {"stationarity": STATIONARITY_TOL, "feasibility": FEASIBILITY_TOL,
              "dual": FEASIBILITY_TOL, "complementarity": COMPLEMENTARITY_TOL}


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
    from .contact_newton import continuation, solve_obstacle  # it uses this module's steps
    method = continuation if OBSTACLE_METHOD == "continuation" else solve_obstacle
    z, lam, nit, note, residual = method(mf, z, lam, tol, max_iter)
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


def _penalty(mf: MixedForm) -> tuple[float, float]:
    """Initial and largest penalty of the method of multipliers.

    A point force F bends an element of length h by about F h^3 / 12 (EI = 1
    here), so 10 * 12 / h^3 is ten times stiffer than the beam at one point:
    each multiplier update then cuts the violation by about ten.  Started
    there, the first inner problem (from an undeformed beam far from contact)
    takes Newton hundreds of damped steps on fine meshes, so the penalty
    starts at the beam's global stiffness (about 1 in these units) and grows
    tenfold per update; it may reach 1e3 * 12 / (0.047 h)^3 if the violation
    falls slowly.  The constraint point nearest a node is the contact Gauss
    point 0.047 h away, so a point force at a node is resisted there by a
    stiffness of order 12 / (0.047 h)^3: with a cap of 12 / h^3 a tiny force
    on an obstacle at gap 0 on 12 elements was still violating by 1e-6 W after
    40 updates.
    """
    h = float(np.min(np.diff(mf.dp.xi)))
    # Both caps are for forces of the answer's size.  An answer held far below
    # the unsupported one (an obstacle close under a heavily loaded beam) carries
    # forces W_linear / W larger, which need (and whose round-off allows) a
    # penalty larger by as much: with the plain caps the violations, and with
    # them complementarity, stayed at 1e-9..1e-5 of the answer.
    ratio = max(1.0, mf.dp.W_linear / mf.dp.W)
    return 10.0, min(1e3 * 12.0 / (GAUSS_OFFSET * h) ** 3, RHO_CAP) * ratio


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
                return z, it, "full Newton step on a settled active set"
    return z, max_iter, f"stopped after {max_iter} iterations"


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


def certify(mf: MixedForm, z, lam=None) -> dict:
    """Optimality measures of ``z`` (and obstacle multipliers) in the mixed form.

    ``stationarity``: relative Newton decrement of the Lagrangian on the
    linking constraints (for a quadratic energy, the relative error in the
    energy norm), relative to the answer's own energy norm; for an obstacle
    also ``feasibility`` (largest violation of w >= g relative to the answer's
    largest deflection), ``dual`` (most negative multiplier, relative) and
    ``complementarity`` (relative to the answer's energy).
    """
    if mf.n == 0:
        return {"stationarity": 0.0}
    H = mf.hessian(z)
    out = {"stationarity": _stationarity(mf, z, lam, H)}
    # w = 0 is admissible with energy 0 (g <= 0; a bonded foundation's 1/2 c g^2 L),
    # so the minimum is at most that: more beyond round-off is no minimiser.
    energy = sum(mf.energy_parts(z).values()) - mf.energy_at_rest()
    if energy > COMPLEMENTARITY_TOL * mf.scale(z, H) ** 2:
        out["stationarity"] = math.inf
    if lam is not None:
        out.update(_obstacle_measures(mf, z, lam, mf.gap(z), H))
    return out


def _stationarity(mf: MixedForm, z, lam, H) -> float:
    """Relative Newton decrement of the Lagrangian at (z, lam); H: the energy's Hessian.

    The decrement is computed by a solve with H, which near P_bar_h (H nearly
    singular) can lose every digit: the solve's own residual is then solved
    for once more, and a correction that is not small against the step shows
    that the decrement cannot be trusted (infinite: not certified).
    """
    g = mf.gradient(z)
    if lam is not None:
        g = g - mf.AT @ lam
    factor = mf.quadratic_factor if mf.dp.is_quadratic else mf.kkt_factor(H)
    rhs_z, rhs_c = -g, -mf.link(z)
    d, mu = factor.solve(rhs_z, rhs_c)
    scale = mf.scale(z, H)
    decrement = _decrement(d, H, scale) * scale
    check, _ = factor.solve(rhs_z - (H @ d + mf.C.T @ mu), rhs_c - mf.C @ d)
    error = math.sqrt(abs(float(check @ (H @ check))))
    # The step's own error must be small against the step, or against what the
    # certificate can notice (the stationarity tolerance): else the decrement
    # is no measure of anything.
    if not (error <= 0.1 * decrement or error <= 1e-3 * STATIONARITY_TOL * scale):
        return math.inf
    # The step is the first-order error of z, and the energy norm can be blind
    # to its nodal size: a Gao beam stiffened by its own large slopes had a convex
    # answer 2.5e-5 off at its nodes with a decrement of 2.7e-7.  Its largest
    # deflection, relative to the answer's, is measured too.
    size = mf.deflection_size(z)
    if lam is not None:
        d = _contact_step(mf, z, lam, H, rhs_z, rhs_c)
        if d is None:
            return math.inf
    nodal = float(np.max(np.abs(d[mf.w_index]), initial=0.0)) / size
    return max(decrement / scale, nodal, _axial_sensitivity(mf, z, factor, size))


def _contact_step(mf: MixedForm, z, lam, H, rhs_z, rhs_c) -> np.ndarray:
    """The Lagrangian's Newton step, the obstacle holding the points it touches.

    With the multipliers fixed and nothing holding the contact points, the step
    of a beam lying flat on an obstacle answers the multipliers' own spread
    (not unique there) by moving through the obstacle: 3e-6 of the answer for
    a certified-accurate one.  So the points on the obstacle are held (a stiff
    penalty).  Every other point is free at the minimiser, with no force: its
    multiplier is taken out of the residual, and the point is held only where
    the step would move it into the obstacle (a few rounds of an active set).
    An interior-point answer keeps ~sqrt(tol) of force and gap on points whose
    exact force and gap are both about zero; along a soft direction (an
    unloaded end tilting about its last contact) those forces held the beam
    1.6e-6 of its size off the minimiser, unseen while every point within 1e-6
    of the obstacle was held with its multiplier (campaign seed 1, scene 459).
    The step is the first-order error of the answer as the obstacle lets it
    move; None if the rounds do not settle which points it holds.
    """
    _, rho = _penalty(mf)
    bed = None if H.foundation is None else H.foundation > 0
    gap = mf.gap(z)
    # Held from the start: points on the obstacle to within this (an answer's
    # genuine contact; interior-point gaps there are ~tol / force), and any
    # point the step moves into the obstacle by more than it.
    allowance = 1e-3 * STATIONARITY_TOL * mf.deflection_size(z)
    on = gap <= allowance
    held = on.copy()
    for _ in range(CONTACT_ROUNDS):
        # A free point's multiplier leaves the residual.  A point let down onto the
        # obstacle by an earlier round aims at it (its penalty rho (gap + A d)^2 / 2),
        # not at its present place; one on it already stays (its gap, within the
        # allowance, is the answer's feasibility, which the certificate measures).
        pull = np.where(held, np.where(on, 0.0, -rho * gap), -lam)
        Hc = mf.hessian(z, rho=rho, active=(bed, held))
        d, _ = mf.kkt_factor(Hc).solve(rhs_z + mf.AT @ pull, rhs_c)
        into = ~held & (gap + mf.A @ d < -allowance)
        if not into.any():
            return d
        held |= into
    # The contact set did not settle: no first-order error to measure.
    return None


def _axial_sensitivity(mf: MixedForm, z, factor, size) -> float:
    """How far the answer moves, at its nodes, when p = P L^2 / EI moves by its round-off.

    p reaches the solver through a few roundings (EI, L^2, the load factors),
    a relative DATA_ROUNDOFF; near P_bar_h the answer amplifies that by the
    inverse of the Hessian's margin (1e-9 below P_bar_h: 5e-7 of the answer,
    measured against 50-digit arithmetic), and no residual can see it.  The
    first-order change H^-1 (dp axial z) is one more solve with the factor in
    hand; the Gao stiffness in H keeps it small where the quartic term holds
    the beam.
    """
    if not (mf.has_slope and mf.dp.p):
        return 0.0
    rhs = DATA_ROUNDOFF * abs(mf.dp.p) * (mf.axial @ mf.absolute(z))
    dz, _ = factor.solve(rhs, np.zeros(mf.C.shape[0]))
    return float(np.max(np.abs(dz[mf.w_index]), initial=0.0)) / size


def _decrement(d, H, scale) -> float:
    """sqrt(d'Hd) / scale; infinite where H is numerically indefinite along d.

    Near P_bar_h the computed H can have d'Hd < 0 along the buckling mode (at
    w = 0 there is no Gao stiffness yet): the "Newton step" then goes uphill and
    its decrement is no measure of anything.  Clipping d'Hd to 0 once certified
    w = 0 as the minimiser.
    """
    curvature = float(d @ (H @ d))
    if curvature < 0 and math.sqrt(-curvature) > 1e-3 * STATIONARITY_TOL * scale:
        return math.inf
    return math.sqrt(max(curvature, 0.0)) / scale


def _obstacle_measures(mf: MixedForm, z, lam, gap, H) -> dict:
    """Feasibility, dual sign and complementarity of ``z`` with multipliers ``lam``.

    All relative to the answer itself: the violation of w >= g to its largest
    deflection, the most negative multiplier to the largest, the duality gap
    to its energy.
    """
    size = mf.deflection_size(z)
    lam_scale = np.max(np.abs(lam), initial=0.0) or 1.0
    return {"feasibility": float(max(-np.min(gap, initial=0.0), 0.0) / size),
            "dual": float(max(-np.min(lam, initial=0.0), 0.0) / lam_scale),
            "complementarity": complementarity(lam, gap, mf.scale(z, H), size)}


def shortfall(residual: dict, margin: dict | None = None) -> float:
    """The largest measure of ``residual`` over its tolerance (times ``margin``'s fraction).

    At most 1: within the tolerances (or margins).  A NaN measure counts as
    infinitely far (``max`` with a NaN depends on the order).
    """
    ratios = [residual[k] / (TOLERANCES[k] * (margin[k] if margin else 1.0))
              for k in TOLERANCES if k in residual]
    return math.inf if any(math.isnan(r) for r in ratios) else max(ratios)


def passes(residual: dict) -> bool:
    """The certificate: every measure within its tolerance."""
    ok = residual["stationarity"] <= STATIONARITY_TOL
    for key, tol in (("feasibility", FEASIBILITY_TOL), ("dual", FEASIBILITY_TOL),
                     ("complementarity", COMPLEMENTARITY_TOL)):
        if key in residual:
            ok &= residual[key] <= tol
    return bool(ok)


def answer(mf: MixedForm, z, lam, residual: dict, message: str, nit, solver: str, t0: float,
           **extra) -> dict:
    """A solver's raw result on the mixed form, its status the certificate's verdict.

    ``residual`` must be the certificate of ``z`` as returned here: solvers
    put their answer on the linking constraints (:meth:`MixedForm.on_manifold`)
    before certifying it.
    """
    return {"u": mf.to_hermite(z), "lam": lam,
            "status": "optimal" if passes(residual) else "inaccurate", "message": message,
            "residual": residual, "nit": nit, "solver": solver,
            "solve_time": time.perf_counter() - t0, "mixed": mf, "z": z, **extra}


def _finish(mf, z, lam, nit, t0, note, residual=None):
    """The result dict; ``residual``: the certificate of (z, lam) if already computed."""
    if residual is None or np.any(mf.link(z)):
        z = mf.on_manifold(z)
        residual = certify(mf, z, lam)
    return answer(mf, z, lam, residual, f"newton: {note}", nit, "banded-kkt", t0,
                  warm={"z": mf.absolute(z), "lam": lam, "W": mf.dp.W})
