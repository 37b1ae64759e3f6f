"""Equilibria near w = 0 on a bed or an obstacle at gap 0, found in their own scale.

A load far smaller than the buckled beam's scale presses the beam into a bed at
gap 0 by as little as 1e-13 of the amplitude range ``S``; there the bed's edge
(``g - w = 0``) splits the near-flat beam into several equilibria: pressed into
the bed (a strict local minimum where the bed outweighs the axial force),
lifted off it (the free beam's linear answer, which above the first mode's load
rises against the load: unstable), and some in between.  They lie far closer
than the searches' merging distance and the probes' 1e-6 S, whose slices are
accurate relative to the scene's energy: a P1 beam of 7 elements at 1.28
P_bar_h, pressed 9.5e-14 m by q = -2.7e-3 N/m, was listed once, unstable, where
it is a strict local minimum and its lifted twin 1.5e-13 m up the saddle
between it and the buckled beam.  On an obstacle at gap 0 the pressed beam is
w = 0 (:func:`.obstacle_checks.exact_flat`), and its lifted twin, the saddle
between it and the buckled beam, was missing the same way (one mode: the list
`inaccurate` by the mountain-pass rule).

Here Newton's method on the whole beam starts from the linear answers (with
every bed point held, and with every one released), and from those moved along
each unstable mode; on a bed also from the searches' own entries near s = 0,
whose beams were measured along the mode alone.  On a bed it is semismooth
Newton on the gradient (in extended precision, :func:`.basin._residual`; the
bed's Hessian on the points it holds); an end whose last step moves its DOFs
(deflections, and slopes times L) by at most ``STEP_TOL`` of their largest
(at least the zero floor), and whose stability the Hessian decides
(:func:`.probes.hessian_stability`), is an equilibrium certified in its own
scale.  On an obstacle (one unstable mode) the free beam's start is polished by
:func:`.whole_beam.polish_equilibrium` (active set, certificate and
second-order conditions in its own scale); where the polish moves too far from
it, the end of the active set's Newton's method from it is polished instead
(:func:`.whole_beam.settled_start`: a P2 beam at gap 0 under q = -2.7e-3 N/m,
whose free linear answer dips through the obstacle, missed its saddle touching
the obstacle, and the list was `inaccurate`).  Ends
within ``NEAR`` S of s = 0 are added where no listed one has their beam.
Nothing is claimed of other equilibria there: the list's completeness is the
searches' (within their merging distance of a listed one).
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .basin import _residual
from .equilibrium import Equilibrium
from .probes import HESSIAN_ELEMENTS, hessian_stability
from .node import obstacle_rows
from .whole_beam import MAX_UNKNOWNS, same_beam, settled_start
from .zero_step import STEP_TOL

__all__ = ["near_flat", "unresolved"]

log = logging.getLogger(__name__)

#: Newton steps from each start at most (the held points change one by one).
MAX_STEPS = 60
#: The starts' moves along each unstable mode, in units of the linear answer's
#: largest DOF (a P1 beam, two modes, 7 elements: the lifted beam was found from
#: the linear answers, the two saddles holding three points near one end only
#: from moves along the second mode).
MOVES = (-4.0, -1.0, -0.25, 0.25, 1.0, 4.0)
#: Ends farther from s = 0 than this times S are left to the searches.
NEAR = 1e-4
#: An end is `optimal` only where this times the gradient's round-off moves its DOFs
#: by at most ``STEP_TOL`` of their size (:func:`_round_off_step`: 3e-15 to 3e-14 of
#: them on 520 to 2048 elements, 3 to 20 times the rounding's effect measured in
#: exact arithmetic).
NOISE_MARGIN = 10.0
#: Beams within this (:func:`.whole_beam.same_beam`) of a listed one are that one.
SAME = 1e-4


def near_flat(dp, modes, out, S, zero_floor, polish=None) -> list:
    """``out`` with the near-flat equilibria on a unilateral bed or an obstacle added.

    Parameters
    ----------
    dp : DiscreteProblem
        The scene above P_bar_h, with a unilateral foundation or an obstacle, and
        a load (else ``out`` is returned as it is); on a bed at most
        :data:`.probes.HESSIAN_ELEMENTS` elements (the labels' reach), on an
        obstacle at most ``MAX_UNKNOWNS`` free DOFs (the polish's).
    modes : Modes
        Its unstable modes: the starts' directions, and the amplitudes of an
        added entry (``(G phi)ᵀ u``).
    out : list of Equilibrium
        The searches' list.
    S : float
        The amplitude range's scale: only ends within ``NEAR`` S of s = 0 are
        added (farther, the searches resolve the equilibria themselves).
    zero_floor : float or None
        The deflection [m] below which a beam counts as zero
        (:func:`.zero_step.zero_floor`; None without load).
    polish : callable, optional
        With an obstacle, :func:`.whole_beam.polisher`'s (else, or with two
        unstable modes, nothing is added).

    Returns
    -------
    list of Equilibrium
        ``out`` and the equilibria found that are not listed (``optimal``,
        ``whole_beam``; on a bed their residual the last Newton step, and
        ``inaccurate`` where ``NOISE_MARGIN`` times the gradient's round-off
        moves them by more than ``STEP_TOL``); a listed entry that is not
        ``optimal`` (or, on a bed, is the searches' own, measured along the mode
        alone) and has the beam of an ``optimal`` one found gives way to it.
    """
    bed = dp.contact == "foundation" and not dp.bilateral
    # (with an obstacle one mode only: two modes' second search in the flat beam's
    # own scale finds these, :func:`.zooms.own_scale`, and each polish is dense)
    obstacle = dp.contact == "obstacle" and polish is not None and modes.k == 1
    within = len(dp.x) - 1 <= HESSIAN_ELEMENTS if bed else dp.n <= MAX_UNKNOWNS
    if not (bed or obstacle) or zero_floor is None or dp.n == 0 or not within:
        return out
    out = list(out)
    added = []
    rows = None if bed else obstacle_rows(dp)
    starts = list(_starts(dp, modes, held=(True, False) if bed else (False,)))
    if bed:
        # (and the searches' near-flat entries: measured along the mode alone, their
        # beams are as accurate as their slices elsewhere -- a P4 beam 3.9e-14 m
        # deep on 520 elements, `optimal`, 1.5e-6 of itself off, a helper's campaign)
        starts += [dp.from_physical(o.w, o.slope) for o in out
                   if not o.whole_beam and float(np.linalg.norm(o.amplitudes)) <= NEAR * S]
    for u in starts:
        e = _bed_end(dp, modes, u, zero_floor) if bed else _obstacle_end(u, polish, dp, rows)
        if e is None or not float(np.linalg.norm(e.amplitudes)) <= NEAR * S:
            continue
        same = [o for o in out + added if same_beam(e, o, SAME)]
        # (an `optimal` end takes the place of listed ones that are not, or are the
        # searches' own; one that is not adds its beam only where none is listed)
        if same and (e.status != "optimal"
                     or any(o.status == "optimal" and o.whole_beam for o in same)):
            continue
        out = [o for o in out if all(o is not t for t in same)]
        added = [o for o in added if all(o is not t for t in same)]
        log.info("equilibria: a near-flat %s equilibrium, max|w| %.3g m, added%s",
                 "stable" if e.stable else "unstable", float(np.max(np.abs(e.w))),
                 f" in place of {len(same)} listed" if same else "")
        added.append(e)
    return out + added


def unresolved(dp, modes, u, S) -> bool:
    """Whether the beam of Hermite DOFs ``u`` lies where only the energy's Hessian
    can label it: within ``NEAR`` S of s = 0 with a unilateral bed's edge within
    that reach (``NEAR`` S along any unstable mode) of some quadrature point.

    There the probes of the reduced function, 1e-6 S wide, cross the bed's edge
    and may stand for another equilibrium: the P1 beam of the module's notes on
    520 elements, beyond the Hessian's reach then, was listed unstable and
    `optimal`, a strict minimum.  :func:`.stationary.equilibria` reports such an
    entry `inaccurate` where :func:`.probes.hessian_stability` leaves it undecided.
    """
    if not (dp.contact == "foundation" and not dp.bilateral and dp.n):
        return False
    if not float(np.linalg.norm(modes.phi.T @ (dp.G @ u))) <= NEAR * S:
        return False
    reach = NEAR * S * float(np.max(np.abs(dp.Nq @ modes.phi)))
    return bool(np.min(np.abs(dp.g - dp.Nq @ u)) <= reach)


def _starts(dp, modes, held):
    """The linear answers with every foundation point held (``True`` in ``held``)
    and released (``False``; with an obstacle, the free beam's), each also moved
    along each unstable mode by ``MOVES`` times its largest DOF."""
    bed = dp.contact == "foundation"
    for hold in held:
        # (at u = 0 the Gao term's Hessian is zero: the linear answer's system)
        zero, rhs = np.zeros(dp.n), dp.f
        if bed:
            points = np.full(dp.Nq.shape[0], float(hold))
            H0 = dp.hessian(zero, active=points)
            rhs = rhs + dp.NqT @ (dp.c * dp.wq_c * points * dp.g)
        else:
            H0 = dp.hessian(zero)
        u0 = _solve(H0, rhs)
        if u0 is None:
            continue
        size = float(np.max(np.abs(u0)))
        yield u0
        for j in range(modes.k):
            v = modes.phi[:, j] / float(np.max(np.abs(modes.phi[:, j])))
            for a in MOVES:
                yield u0 + a * size * v


def _bed_end(dp, modes, u, zero_floor):
    """The equilibrium Newton's method on a bed ends at from ``u``, certified in its
    own scale and of a decided stability, or None."""
    end = _newton(dp, u, zero_floor)
    if end is None:
        return None
    u, step = end
    stable = hessian_stability(dp, u)
    if stable is None:
        return None
    size = max(float(np.max(np.abs(u))), zero_floor / dp.W)
    noisy = NOISE_MARGIN * _round_off_step(dp, u) > STEP_TOL * size
    if noisy:
        log.info("equilibria: a near-flat equilibrium whose DOFs the gradient's round-off "
                 "moves by more than %g of their size: inaccurate", STEP_TOL / NOISE_MARGIN)
    w, slope = dp.to_physical(u)
    return Equilibrium(float(dp.energy(u) * dp.E0), bool(stable),
                       [float(a) for a in modes.phi.T @ (dp.G @ u)], dp.x.copy(), w, slope,
                       float(step), "inaccurate" if noisy else "optimal", float(dp.P),
                       math.nan, float(dp.W), whole_beam=True)


def _obstacle_end(u, polish, dp, rows):
    """The equilibrium :func:`.whole_beam.polish_equilibrium` certifies from ``u``,
    else from the end of the active set's Newton's method from ``u`` (the free
    beam's linear answer dips through the obstacle, too far from the saddle
    touching it for the polish), or None."""
    e = polish(u)
    if e is not None:
        return e
    x = settled_start(dp, u, *rows)
    return None if x is None else polish(x)


def _round_off_step(dp, u, draws: int = 2) -> float:
    """The largest DOF Newton's step moves ``u`` by for the rounding of
    :func:`.basin._residual`'s extended-precision gradient (the largest of
    ``draws`` draws of random signs, solved with the Hessian).

    The step measured at the end cannot see it: the computed gradient's zero
    lies that far from the exact data's.  The rounding is drawn where it is
    made: in the curvatures and slopes at the quadrature points (``eps`` times
    their terms' size, as the energy sums them), then carried to the DOFs by
    the energy's own transposes, and in the sums at the DOFs (``eps`` times the
    size of their terms, and the gradient's own in double).  Drawn at the DOFs alone, it overstated the step by
    seven orders on fine meshes: the curvatures' rounding reaches the gradient
    differentiated twice, with little of the low modes H⁻¹ magnifies.  (A
    helper's campaign: P4 on 1423 elements, bed at gap 0, q = -1.2e-6 N/m, the
    pressed beam 3e-17 m deep converged on the float64 gradient to a step of
    1e-7 where the independent energy's long-double step measures 1.7e-5 of
    it; Newton's method here takes the long-double gradient.)
    """
    eps = float(np.finfo(np.longdouble).eps)
    au = np.abs(u)
    kappa, y = np.abs(dp.B2 @ u), np.abs(dp.B1 @ u)
    dk, dy = abs(dp.B2) @ au, abs(dp.B1) @ au
    # (and its conversion to double: one rounding of the gradient itself)
    sums = (abs(dp.B2.T) @ (dp.wq2 * kappa) + np.abs(dp.f)
            + np.finfo(float).eps / eps * np.abs(_residual(dp, u)[0]))
    if dp.p or dp.a:
        sums = sums + abs(dp.B1T) @ (dp.wq_gao * y * (dp.a / 3.0 * y * y + abs(dp.p)))
    if dp.contact == "foundation":
        pen = dp.c * dp.wq_c * (np.abs(dp.g) + abs(dp.Nq) @ au)
        sums = sums + abs(dp.NqT) @ pen
    H = dp.hessian(u)
    rng = np.random.default_rng(0)

    def sign(v):
        return v * rng.choice([-1.0, 1.0], size=v.size)

    worst = 0.0
    for _ in range(draws):
        r = dp.B2.T @ (dp.wq2 * sign(dk)) + sign(sums)
        if dp.p or dp.a:
            r = r + dp.B1T @ (dp.wq_gao * sign(dy) * (dp.a * y * y + abs(dp.p)))
        if dp.contact == "foundation":
            r = r + dp.NqT @ sign(pen)
        du = _solve(H, eps * r)
        worst = max(worst, math.inf if du is None else float(np.max(np.abs(du))))
    return worst


def _newton(dp, u, zero_floor):
    """``(u, step)``: Newton's end from ``u`` and its last step (not taken)
    relative to the beam's size (the largest of its DOFs, at least the zero
    floor); None where it does not come within ``STEP_TOL``."""
    last = None
    for _ in range(MAX_STEPS):
        du = _solve(dp.hessian(u), -_residual(dp, u)[0])
        if du is None:
            break
        # (in all DOFs, deflections and slopes L / W alike: measured on the
        # deflections alone, a beam of 2 elements converged on its one inner
        # node's w with its slopes half their size off a zero)
        size = max(float(np.max(np.abs(u))), zero_floor / dp.W)
        step = float(np.max(np.abs(du))) / size if size > 0 else math.inf
        if last is not None and last[1] <= STEP_TOL and not step < last[1]:
            break      # (converged: round-off, or a point at the edge)
        last = (u, step)
        u = u + du
    return last if last is not None and last[1] <= STEP_TOL else None


def _solve(H, r):
    """``H⁻¹ r`` by a sparse LU, or None where ``H`` is singular."""
    try:
        x = spla.spsolve(sp.csc_matrix(H), r)
    except (RuntimeError, ValueError):
        return None
    return x if np.all(np.isfinite(x)) else None
