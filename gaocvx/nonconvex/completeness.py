"""A proof that a one-mode list of equilibria misses none: the reduced gradient's sign bound.

With one unstable mode the energy is ``Psi(s, v) - c s^2`` with ``Psi`` convex
(nonconvex.md), so ``Phi(s) = min_v Psi(s, v) = F(s) + c s^2`` is convex on the
admissible amplitudes and ``G(s) = F'(s) + 2 c s`` never falls (any
subgradient, at a kink too).  Between two sampled amplitudes ``a < b``:

* for ``s >= a``: ``F'(s) >= F'(a) - 2 c (s - a)``, so no zero of ``F'`` lies in
  ``[a, a + F'(a) / (2 c))`` when ``F'(a) > 0``;
* for ``s <= b``: ``F'(s) <= F'(b) + 2 c (b - s)``, so none lies in
  ``(b + F'(b) / (2 c), b]`` when ``F'(b) < 0``.

What neither bound excludes (the *undecided* part of ``[a, b]``) is sampled again
-- at the edge of what the ends exclude where both bound the same side, else at
its middle -- and both parts are bounded again, until every part is excluded or
lies within ``rho`` of a zero already found.  The grid's sampling then becomes a
proof: every equilibrium with one unstable mode lies within ``rho`` of a listed
one, given the fixed-amplitude solves' accuracy (``tol``: a derivative no larger
than it counts as possibly zero).  A failed solve between two solved amplitudes
is bounded by them; the proof fails where a solve it needed failed, or where
``budget`` more solves did not finish it: next to
an unstable zero the bound excludes a length ``|F'(s)| / (2 c)``, proportional to
the distance times ``1 - Phi'' / (2 c)``, which is small just above the mode's
load (``Phi''`` close to ``2 c``).

Examples
--------
``F(s) = s^4 - s^2`` (``c = 1``: ``F + s^2 = s^4`` is convex) has zeros of ``F'``
at 0 and ``+-1/sqrt(2)``; sampled at five points, the bound finds the list complete:

>>> import numpy as np
>>> dF = lambda s: 4 * s**3 - 2 * s
>>> r = 2 ** -0.5
>>> ok, points = cover(dF, [-1.0, -r, 0.0, r, 1.0], [-r, 0.0, r], c=1.0, tol=1e-12,
...                    rho=1e-6, budget=500)
>>> ok, len(points) < 200
(True, True)

A pair of zeros between two sampled points, with no sign change between them,
is not lost: the bound cannot exclude it, and :func:`proven_roots` searches the
points it sampled there (``F'`` has zeros at ``-0.809``, ``0.309`` and ``0.5``):

>>> dF = lambda s: 4 * s**3 - 2 * s + 0.5
>>> roots, ok = proven_roots(dF, [-1.0, 0.0, 1.0], [-0.8090169943749475], [], c=1.0,
...                          tol=1e-12, rho=1e-6)
>>> [round(r, 6) for r in sorted(roots)], ok
([-0.809017, 0.309017, 0.5], True)
"""

from __future__ import annotations

import math

__all__ = ["cover", "proven_roots"]

# More solves the proof may take (a one-mode list takes 60-300; a fast slice costs
# milliseconds, a dense program tens of them).
BUDGET = 600


def cover(dF, points, known, c, tol, rho, budget) -> tuple:
    """Whether the sign bound proves that ``F'`` has no zero beyond ``rho`` of ``known``.

    Parameters
    ----------
    dF : callable
        ``dF(s) -> F'(s)`` (NaN or inf where the fixed-amplitude solve failed or
        ``s`` is inadmissible); cached by the caller.
    points : sequence of float
        Sampled amplitudes, sorted or not: the bound covers ``[min, max]`` of the
        admissible ones.
    known : sequence of float
        Zeros already found, and the ends of the admissible amplitudes listed as
        equilibria (F rising into the range there): the parts within ``rho`` of
        one are not bounded further.
    c : float
        The concave coefficient (``modes.c[0]``, >= 0).
    tol : float or callable
        The derivative's accuracy: a value ``|F'| <= tol`` may be a zero; a
        callable ``tol(a, b)`` gives it per interval.
    rho : float
        The distance from a known zero within which zeros are not told apart.
    budget : int
        At most this many more evaluations of ``dF``.

    Returns
    -------
    complete : bool
        True when every part of ``[min(points), max(points)]`` was excluded or
        lies within ``rho`` of ``known``, with no sign change of ``F'`` between
        neighbouring sampled points but at ``known`` (a new sign change is a zero
        the caller has not found).
    sampled : list of float
        The amplitudes sampled here, for the caller to search for zeros.
    """
    known = sorted(float(k) for k in known)
    pts = sorted({float(p) for p in points if math.isfinite(_value(dF, p))})
    bound = tol if callable(tol) else (lambda a, b: tol)
    sampled = []
    complete = len(pts) > 0
    # (a, b, bisect): split at the edge of what the ends exclude, where both ends
    # bound the same side (a march, each point excluding |F'| / (2 c) more), else,
    # or where the last such point excluded less than half of what was left (the
    # march slows down next to a zero), at the middle of the undecided part
    stack = [(a, b, False) for a, b in zip(pts[:-1], pts[1:])]
    while stack:
        a, b, bisect = stack.pop()
        da, db = _value(dF, a), _value(dF, b)
        t = bound(a, b)
        ra, rb = _reach(da - t, c, b - a), _reach(-db - t, c, b - a)
        # (a reach capped at the width excludes all of [a, b]: a + (b - a) may round
        # below b)
        left = b if ra >= b - a else a + ra
        right = a if rb >= b - a else b - rb
        if left >= right or _near(left, right, known, rho):
            continue
        if len(sampled) >= budget:
            complete = False
            continue
        march = not bisect and (min(da, db) > t or max(da, db) < -t)
        m = (left if da > t else right) if march else 0.5 * (left + right)
        if march and not a < m < b:     # (a march step below round-off: the middle)
            march, m = False, 0.5 * (left + right)
        if not a < m < b:     # (round-off: the interval cannot be split)
            complete = False
            continue
        sampled.append(m)
        dm = _value(dF, m)
        if not math.isfinite(dm):
            complete = False     # (a failed solve inside: nothing is known there)
            continue
        if (dm * da < 0 and not _within(a, m, known, rho)) or \
                (dm * db < 0 and not _within(m, b, known, rho)) or \
                (dm == 0.0 and not _near(m, m, known, rho)):
            complete = False     # (a zero not found yet: the caller's to search first)
            break
        slow = march and _reach(abs(dm) - t, c, b - a) < 0.5 * (right - left)
        stack += [(a, m, slow and da < 0), (m, b, slow and da > 0)]
    # A sign change between neighbours with no known zero in between is a zero
    # the caller has not listed: the proof holds only once it is found.
    every = [p for p in sorted(set(pts) | set(sampled)) if math.isfinite(_value(dF, p))]
    for a, b in zip(every[:-1], every[1:]):
        if _value(dF, a) * _value(dF, b) < 0 and not _within(a, b, known, rho):
            complete = False
    if any(_value(dF, p) == 0.0 and not _near(p, p, known, rho) for p in every):
        complete = False
    return complete, sampled


def proven_roots(dF, points, roots, held, c, tol, rho, budget=None, rounds=3) -> tuple:
    """The zeros of ``F'`` with the sign bound's proof that none is missing.

    :func:`cover` over ``points`` with ``roots`` and ``held`` known; where the
    points it sampled show a sign change no zero accounts for, the zeros are
    searched again over all points (:func:`.contours.sampled_roots`) and the
    bound tried again, ``rounds`` times at most.

    Parameters
    ----------
    dF : callable
        ``dF(s) -> F'(s)``, NaN where unknown (cached by the caller).
    points, roots : sequence of float
        The sampled amplitudes and the zeros found among them.
    held : sequence of float
        Ends of the admissible amplitudes listed as equilibria.
    c, tol, rho, budget
        As :func:`cover` (``budget`` for all rounds' bounds together, by default
        :data:`BUDGET`; the zeros' searches of later rounds come on top).
    rounds : int
        Bounds tried at most, each after the zeros the last one revealed.

    Returns
    -------
    roots : list of float
        The zeros, with those the bound's samples revealed.
    complete : bool
        The bound's verdict on the last round.
    """
    from .contours import sampled_roots

    budget = BUDGET if budget is None else budget
    points = [float(p) for p in points]
    roots = list(roots)
    S = max((abs(p) for p in points), default=1.0) or 1.0
    complete = False
    for _ in range(rounds):
        complete, sampled = cover(dF, points + roots, roots + list(held), c, tol, rho, budget)
        budget -= len(sampled)
        if complete or not sampled:
            break
        points = sorted(set(points) | set(sampled))
        finite = [p for p in points if math.isfinite(_value(dF, p))]
        found = sampled_roots(dF, finite, [_value(dF, p) for p in finite], S)
        new = [r for r in found if not any(abs(r - q) <= rho for q in roots)]
        if not new:
            break        # (nothing new: more rounds would only repeat this one)
        roots += new
    return roots, complete


def _value(dF, s) -> float:
    v = dF(s)
    return float(v) if v is not None else math.nan


def _reach(excess, c, width) -> float:
    """The length ``excess / (2 c)`` a derivative beyond its accuracy excludes (capped)."""
    if not excess > 0:
        return 0.0
    return width if c <= 0 else min(excess / (2.0 * c), width)


def _near(left, right, known, rho) -> bool:
    # the undecided part [left, right] within rho of one known zero
    return any(k - rho <= left and right <= k + rho for k in known)


def _within(a, b, known, rho) -> bool:
    # a known zero in [a - rho, b + rho]: it accounts for a sign change there
    return any(a - rho <= k <= b + rho for k in known)
