"""Equilibria near w = 0 on a unilateral foundation, found in their own scale.

A load far smaller than the buckled beam's scale presses the beam into a bed at
gap 0 by as little as 1e-13 of the amplitude range ``S``; there the foundation's
edge (``g - w = 0``) splits the near-flat beam into several equilibria: pressed
into the bed (a strict local minimum where the bed outweighs the axial force),
lifted off it (the free beam's linear answer, which above the first mode's load
rises against the load: unstable), and some in between.  They lie far closer
than the searches' merging distance and the probes' 1e-6 S, whose slices are
accurate relative to the scene's energy: a P1 beam of 7 elements at 1.28
P_bar_h, pressed 9.5e-14 m by q = -2.7e-3 N/m, was listed once, unstable, where
it is a strict local minimum and its lifted twin 1.5e-13 m up the saddle
between it and the buckled beam.

Here Newton's method on the whole beam's gradient (semismooth: the bed's
Hessian on the points it holds) starts from the linear answers with every point
held and with every point released, and from those moved along each unstable
mode; an end within 1e-4 S of s = 0 whose last step moves the deflection
by at most ``STEP_TOL`` of its largest ``|w|`` (at least the zero floor), and
whose stability the Hessian decides (:func:`.probes.hessian_stability`), is an
equilibrium certified in its own scale, added where no listed one has its beam.
Nothing is claimed of other equilibria there: the list's completeness is the
searches' (within their merging distance of a listed one).
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .equilibrium import Equilibrium
from .probes import hessian_stability
from .whole_beam import MAX_UNKNOWNS, same_beam
from .zero_step import STEP_TOL

__all__ = ["near_flat"]

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
#: Beams within this (:func:`.whole_beam.same_beam`) of a listed one are that one.
SAME = 1e-4


def near_flat(dp, modes, out, S, zero_floor) -> list:
    """``out`` with the near-flat equilibria on a unilateral foundation added.

    Parameters
    ----------
    dp : DiscreteProblem
        The scene above P_bar_h, with a unilateral foundation and a load (else
        ``out`` is returned as it is), at most ``MAX_UNKNOWNS`` free DOFs.
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

    Returns
    -------
    list of Equilibrium
        ``out`` and the equilibria found that are not listed (``optimal``,
        ``whole_beam``, their residual the last Newton step); a listed entry
        that is not ``optimal`` and has the beam of one found gives way to it.
    """
    if (dp.contact != "foundation" or dp.bilateral or zero_floor is None
            or not 0 < dp.n <= MAX_UNKNOWNS):
        return out
    out = list(out)
    added = []
    for u, step in _ends(dp, modes, zero_floor):
        amplitudes = [float(a) for a in modes.phi.T @ (dp.G @ u)]
        if not float(np.linalg.norm(amplitudes)) <= NEAR * S:
            continue
        stable = hessian_stability(dp, u)
        if stable is None:
            continue
        w, slope = dp.to_physical(u)
        e = Equilibrium(float(dp.energy(u) * dp.E0), bool(stable), amplitudes, dp.x.copy(),
                        w, slope, float(step), "optimal", float(dp.P), math.nan, float(dp.W))
        e.whole_beam = True
        same = [o for o in out + added if same_beam(e, o, SAME)]
        if any(o.status == "optimal" for o in same):
            continue
        out = [o for o in out if all(o is not t for t in same)]
        log.info("equilibria: a near-flat %s equilibrium on the foundation, max|w| %.3g m, "
                 "added%s", "stable" if stable else "unstable", float(np.max(np.abs(w))),
                 f" in place of {len(same)} listed, not optimal" if same else "")
        added.append(e)
    return out + added


def _ends(dp, modes, zero_floor):
    """Newton's ends ``(u, step)`` from the linear answers with every foundation
    point held and with every one released, and from each moved along each
    unstable mode by 1/4, 1 and 4 times its largest DOF either way."""
    for held in (True, False):
        points = np.full(dp.Nq.shape[0], float(held))
        # (at u = 0 the Gao term's Hessian is zero: the linear answer's system)
        zero = np.zeros(dp.n)
        H0 = dp.hessian(zero) - _bed(dp, dp.g > 0) + _bed(dp, points)
        u0 = _solve(H0, dp.f + dp.NqT @ (dp.c * dp.wq_c * points * dp.g))
        if u0 is None:
            continue
        size = float(np.max(np.abs(u0)))
        for j in range(modes.k):
            v = modes.phi[:, j] / float(np.max(np.abs(modes.phi[:, j])))
            for a in ((0.0,) if j == 0 else ()) + MOVES:
                end = _newton(dp, u0 + a * size * v, zero_floor)
                if end is not None:
                    yield end


def _bed(dp, points):
    """The foundation's Hessian on the quadrature points marked by ``points``."""
    return dp.NqT @ sp.diags(dp.c * dp.wq_c * points) @ dp.Nq


def _newton(dp, u, zero_floor):
    """``(u, step)``: Newton's end from ``u`` and its last step (not taken)
    relative to the beam's size; None where it does not come within ``STEP_TOL``."""
    last = None
    for _ in range(MAX_STEPS):
        du = _solve(dp.hessian(u), -dp.gradient(u))
        if du is None:
            break
        w, dw = dp.to_physical(u)[0], dp.to_physical(du)[0]
        size = max(float(np.max(np.abs(w))), zero_floor)
        step = float(np.max(np.abs(dw))) / size if size > 0 else math.inf
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
