"""Descents of the reduced function from its saddles, and the passes between minima.

With two unstable modes the equilibria are sampled (:mod:`.stationary2`); a
minimum in the same grid cell as a saddle, or in a strip of the amplitudes
narrower than the grid's step where one more contact holds, is found by
descending ``F`` from the saddle along its falling direction, and the saddle
between such a minimum and its neighbour by the zeros of ``F``'s derivative on
the segment between them.  ``grad(s)`` is the search's cached
``(F, ∇F, u, ok)`` of the contact slices (``F = inf`` at inadmissible amplitudes).
"""

from __future__ import annotations

import math

import numpy as np

from .contours import sampled_roots
from .equilibrium import same_point

__all__ = ["descents", "flow", "passes", "in_square"]


def descents(grad, hessian, out, S, follow: bool = True) -> list:
    """End points of descents of ``F`` from each unstable equilibrium along its
    Hessian's falling direction on either side: Nelder-Mead from a step of
    1e-3 S, to 1e-8 S, and, if ``follow``, the gradient's flow from a step of
    1e-5 S (:func:`flow`); Newton's method polishes them.

    A saddle's falling paths end at minima (or the admissible edge): a P1 beam in
    a channel under a symmetric load table (10 elements) had a strict mirror pair
    of minima 0.009 S from a listed saddle pair, within one grid cell, missed by
    the cells, the zero curves and Newton's method alike (a review's
    independent multi-start found them, 210 J below the saddles).  The simplex
    steps over a basin narrower than itself, the flow does not: in a P1 channel
    under two point forces (16 elements) a minimum 6e-4 S from a saddle, in a
    strip 8e-6 S wide where a second contact holds, was missed by the simplex
    (the flow ends in it).
    """
    import scipy.optimize as so

    f = in_square(grad, S)
    ends = []
    for e in out:
        if e.stable:
            continue
        r = np.asarray(e.amplitudes, float)
        H = hessian(r)
        if H is None:
            continue
        lam, vec = np.linalg.eigh(H)
        if not lam[0] < 0:
            continue
        for sign in (1.0, -1.0):
            s0 = r + sign * 1e-3 * S * vec[:, 0]
            if not f(s0) < f(r):
                continue
            simplex = np.array([s0, s0 + [1e-3 * S, 0.0], s0 + [0.0, 1e-3 * S]])
            with np.errstate(invalid="ignore", over="ignore"):
                res = so.minimize(f, s0, method="Nelder-Mead",
                                  options=dict(initial_simplex=simplex, xatol=1e-8 * S,
                                               fatol=0.0, maxiter=300))
            if math.isfinite(res.fun):
                ends.append(np.asarray(res.x, float))
            end = flow(grad, r + sign * 1e-5 * S * vec[:, 0], S) if follow else None
            if end is not None:
                ends.append(end)
    return ends


def flow(grad, s, S, steps: int = 400):
    """The end of the gradient's flow ``s' = -∇F / |∇F|`` from ``s`` (None where
    ``F`` is not finite there), by steps that double while ``F`` falls and the
    gradient turns by less than 60 degrees over a step, and shrink fourfold
    otherwise: a step that lands across a basin finds ``∇F`` turned and is
    shortened (a step over a basin without such a turn is still possible: this is
    a search, not a proof).  It stops at a zero, at a kink (the step below
    1e-9 S: Newton's method, or the edge minima, go on from there) or after
    ``steps``.
    """
    F, d, _, _ = grad(s)
    if not math.isfinite(F):
        return None
    h = 1e-5 * S
    for _ in range(steps):
        g = float(np.linalg.norm(d))
        if g == 0.0 or h < 1e-9 * S:
            break
        t = s - h * d / g
        F1, d1, _, _ = grad(t)
        if np.all(np.abs(t) <= S) and math.isfinite(F1) and F1 < F \
                and d1 @ d >= 0.5 * float(np.linalg.norm(d1)) * g:
            s, F, d, h = t, F1, d1, min(2.0 * h, 1e-2 * S)
        else:
            h *= 0.25
    return s


def passes(grad, new, minima, S) -> list:
    """Seeds of the saddles between each of the ``new`` minima and the nearest
    other of the ``minima``: the zeros of ``F``'s derivative along the segment
    between them, sampled at steps growing geometrically from both ends (1e-6 of
    the segment to its middle: a minimum in a strip 8e-6 S wide has its saddle
    1e-5 S beside it, where the strip's second contact lets go).
    """
    tau = np.geomspace(1e-6, 0.5, 40)
    ts = np.union1d(tau, 1.0 - tau)
    seeds = []
    for a in map(np.asarray, new):
        others = [np.asarray(b) for b in minima if not same_point(b, a, S)]
        if not others:
            continue
        e = min(others, key=lambda b: float(np.linalg.norm(b - a))) - a

        def along(t, a=a, e=e):
            F, d, _, _ = grad(a + t * e)
            return float(d @ e) if math.isfinite(F) else math.nan
        seeds += [a + t * e for t in sampled_roots(along, ts, [along(t) for t in ts], 1.0)]
    return seeds


def in_square(grad, S):
    """``F`` for a minimiser: ``+inf`` outside the square ``[-S, S]^2`` and at
    inadmissible amplitudes."""
    def f(s):
        if np.any(np.abs(s) > S):
            return math.inf
        v = grad(np.asarray(s, float))[0]
        return v if math.isfinite(v) else math.inf
    return f
