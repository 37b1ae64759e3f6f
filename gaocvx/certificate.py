"""The certificate of an answer on the mixed form: what makes it ``optimal``.

Every ground-truth solver (Newton, the method of multipliers, Clarabel's
answers polished on the mixed form, the global method above P_bar_h) puts its
answer on the linking constraints and hands it to :func:`certify`, which
measures it in the answer's own scale:

- ``stationarity``: the relative Newton decrement of the Lagrangian (for a
  quadratic energy, the relative error in the energy norm), the step's largest
  nodal deflection relative to the answer's, and the answer's sensitivity to
  the round-off of the axial force;
- with an obstacle, ``feasibility``, ``dual`` (multipliers' sign) and
  ``complementarity``.

:func:`passes` compares them with :mod:`gaocvx.tolerances`; :func:`answer`
makes a solver's raw result whose status is that verdict and nothing else.

Examples
--------
>>> passes({"stationarity": 2e-7, "feasibility": 0.0, "dual": 0.0, "complementarity": 0.0})
True
>>> shortfall({"stationarity": 2e-6}) > 1      # twice the tolerance
True
"""

from __future__ import annotations

import math
import time

import numpy as np

from .mixed import MixedForm
from .tolerances import COMPLEMENTARITY_TOL, FEASIBILITY_TOL, STATIONARITY_TOL, complementarity

__all__ = ["certify", "passes", "shortfall", "answer", "penalty_range", "TOLERANCES"]

# Relative round-off of p = P L^2 / EI as the solver receives it: about four
# roundings of eps (EI from E, width and thickness, then L^2 / EI and P).
DATA_ROUNDOFF = 4 * np.finfo(float).eps
# A multiplier update moves lambda by rho * (g - A z); with A z known to ~1e-13
# (round-off), rho beyond ~1e10 turns round-off into multiplier noise.
RHO_CAP = 1e10
# The constraint points nearest a node are the contact Gauss points 0.047 h from it.
GAUSS_OFFSET = 0.5 * (1.0 - 0.9061798459386640)
# Rounds of the contact step's active set (:func:`_contact_step`).
CONTACT_ROUNDS = 6
TOLERANCES = {"stationarity": STATIONARITY_TOL, "feasibility": FEASIBILITY_TOL,
              "dual": FEASIBILITY_TOL, "complementarity": COMPLEMENTARITY_TOL}


def penalty_range(mf: MixedForm) -> tuple[float, float]:
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


def certify(mf: MixedForm, z, lam=None, size: float = 0.0) -> dict:
    """Optimality measures of ``z`` (and obstacle multipliers) in the mixed form.

    ``stationarity``: relative Newton decrement of the Lagrangian on the
    linking constraints (for a quadratic energy, the relative error in the
    energy norm), relative to the answer's own energy norm; for an obstacle
    also ``feasibility`` (largest violation of w >= g relative to the answer's
    largest deflection), ``dual`` (most negative multiplier, relative) and
    ``complementarity`` (relative to the answer's energy).

    ``size`` is the answer's size in energy-norm units where the caller knows a
    better one than the energy's own norm (:meth:`MixedForm.scale`), which
    above ``P_bar_h`` is no norm (the global method's, without an obstacle:
    :func:`gaocvx.nonconvex.certificate.certify_answer`); the larger is used.
    """
    if mf.n == 0:
        return {"stationarity": 0.0}
    H = mf.hessian(z)
    scale = max(mf.scale(z, H), size)
    out = {"stationarity": _stationarity(mf, z, lam, H, scale)}
    # w = 0 is admissible with energy 0 (g <= 0; a bonded foundation's 1/2 c g^2 L),
    # so the minimum is at most that: more beyond round-off is no minimiser.
    energy = sum(mf.energy_parts(z).values()) - mf.energy_at_rest()
    if energy > COMPLEMENTARITY_TOL * scale ** 2:
        out["stationarity"] = math.inf
    if lam is not None:
        out.update(_obstacle_measures(mf, z, lam, mf.gap(z), H))
    return out


def _stationarity(mf: MixedForm, z, lam, H, scale=None) -> float:
    """Relative Newton decrement of the Lagrangian at (z, lam); H: the energy's Hessian,
    ``scale`` the answer's size (by default :meth:`MixedForm.scale`).

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
    scale = mf.scale(z, H) if scale is None else scale
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
    nodal = _relative(float(np.max(np.abs(d[mf.w_index]), initial=0.0)), size)
    return max(decrement / scale, nodal, _axial_sensitivity(mf, z, factor, size))


def _relative(step: float, size: float) -> float:
    """``step / size``; where the size is 0 (no free deflection and no load to give
    a floor: one clamped element), 0 for no step and infinite for any other (a
    ZeroDivisionError traceback before)."""
    if size > 0:
        return step / size
    return 0.0 if step == 0 else math.inf


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
    _, rho = penalty_range(mf)
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
    return _relative(float(np.max(np.abs(dz[mf.w_index]), initial=0.0)), size)


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
