"""A proof that a two-mode list of equilibria misses none: the monotone gradient's ellipses.

With two unstable modes the energy is ``Psi(s, v) - c_1 s_1^2 - c_2 s_2^2`` with
``Psi`` convex (nonconvex.md), so ``Phi(s) = F(s) + s'Cs`` (``C = diag(c)``) is
convex and its gradient ``∇F(s) + 2 C s`` is a monotone operator:
``(∇F(x) + 2Cx - ∇F(p) - 2Cp) . (x - p) >= 0``.  At a zero ``x`` of ``∇F``
this reads ``2 d'Cd >= g . d`` with ``d = x - p`` and ``g = ∇F(p)``, so no zero
lies in the open ellipse

    ``R_p = {x : 2 d'Cd + t |d| < g . d}``

(``t``: the accuracy of ``g``; a true gradient within ``t`` of ``g`` gives the
same), which has ``p`` on its boundary and reaches ``|g| / (2 min c)`` from it.
``R_p`` is convex and ``p`` lies in its closure when ``|g| > t``, so a
rectangle none of whose corners but ``p`` lies outside ``R_p`` lies in
``R_p ∪ {p}``, and ``p`` is no zero.  One ellipse seldom holds a whole grid
cell (its tangent at ``p`` runs along ``p``'s edges when ``g`` points along an
axis): a cell is split in sub-rectangles (no solves), each held by the ellipse
of any sample, and where that fails it is sampled at its middle and the middles
of its edges and split in four, until every cell is held, or lies within
``rho`` of a zero already found (or, smaller than ``rho / 10``, within ``2 rho``:
the ellipses that hold points on the rim of the disc of radius ``rho`` come
from samples inside it, which no cell there takes).  This is the one-mode sign
bound (:mod:`.completeness`) in the plane: the grid's sampling becomes a proof
that every equilibrium in the rectangle lies within ``2 rho`` of a listed one,
given the fixed-amplitude solves' accuracy.  A cell that shrinks below
``rho / 10`` far from every known zero holds a zero not yet found (or round-off
defeats the ellipses there): :func:`proven_zeros` hands its middle to the
caller's search and tries again.

With an obstacle or channel the amplitudes are those of a convex polygon ``A``
(:mod:`.polygon`), ``Phi + I_A`` is convex, and at an equilibrium ``x`` (a zero
of ``∇F`` in ``A``, or a point of its rim where the obstacle holds the beam)
``2Cx`` is one of its subgradients: the same ellipses hold, for samples in
``A``.  Cells outside the outer polygon hold no equilibrium; a cell across its
rim is held when its part inside is; the rim's points are held by samples on
the rim (next to an equilibrium there the gradient points inward, and samples
inside reach no point between them and the rim).

Examples
--------
``F(s) = (s_1^2 + s_2^2)^2 / 4 - s_1^2 - s_2^2 / 2 + s_1 / 10`` (``c = (1, 1/2)``:
``F + s_1^2 + s_2^2 / 2`` is convex) has five stationary points: three on
``s_2 = 0`` (the real zeros of ``s^3 - 2 s + 0.1``) and ``(0.1, ±0.99^0.5)``.
Given all five, the ellipses prove that there is no other in ``[-2, 2]^2``; with
one of them left out they do not:

>>> import numpy as np
>>> grad = lambda s: np.array([s[0] * (s @ s) - 2 * s[0] + 0.1, s[1] * (s @ s) - s[1]])
>>> zeros = [[r, 0.0] for r in np.roots([1, 0, -2, 0.1]).real] + [[0.1, 0.99**0.5],
...                                                                  [0.1, -0.99**0.5]]
>>> axes = [np.linspace(-2, 2, 9)] * 2
>>> ok, _, _ = cover(grad, axes, zeros, c=[1.0, 0.5], tol=1e-12, rho=1e-6, budget=20000)
>>> missing, _, open_cells = cover(grad, axes, zeros[1:], c=[1.0, 0.5], tol=1e-12,
...                                rho=1e-6, budget=20000)
>>> ok, missing, bool(min(np.linalg.norm(o - zeros[0]) for o in open_cells) < 2e-6)
(True, False, True)
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["cover", "proven_zeros", "prove", "BUDGET"]

# More solves the proof may take (a two-mode list takes 700-2000 on its grids; the
# proof 2000 for well-separated zeros, 4000-12700 next to saddles whose Hessian has
# an eigenvalue 0.1-0.3 of 2c, seed 9001 of the campaign).
BUDGET = 12000
# Sub-rectangles of a cell tried before it is sampled again: 2^GEOMETRY a side.
GEOMETRY = 3
# Samples on each ring around a known zero.
RING_POINTS = 8
# Failed solves (within the admissible amplitudes) after which the proof gives up:
# a region where they fail is not covered, and splitting it would only spend the
# budget.  (A failed solve gives no ellipse, and the proof goes on without it: the
# others may hold its cell.  Next to the rim of a narrow wedge of admissible
# amplitudes the slices fail 1e-8 of the way inwards, where the beams that respect
# the obstacle are one or none: a P4 beam on an obstacle 3.7 mm below, two modes,
# 12 elements, had 146 of 764 solves fail when the proof gave up at 20, and its list
# was not proven; at 200 it is, 1742 solves in all.)
MAX_FAILED = 200
# With an obstacle, a sample beyond the admissible amplitudes' outer polygon is
# moved onto its rim, and where the solve fails there, these fractions of the way
# on to the inner polygon's middle.
INSETS = (1e-12, 1e-10, 1e-8)


def cover(grad, axes, known, c, tol, rho, budget, samples=(), region=None) -> tuple:
    """Whether the ellipses prove that ``∇F`` has no zero beyond ``rho`` of ``known``.

    Parameters
    ----------
    grad : callable
        ``grad(s) -> ∇F(s)`` (a 2-vector; NaN where the fixed-amplitude solve
        failed); cached by the caller.
    axes : pair of sorted sequences
        The grid whose cells are to be covered: the rectangle from its first to
        its last points.
    known : sequence of 2-vectors
        Zeros already found: cells within ``rho`` of one are not bounded further.
    c : pair of float
        The concave coefficients (``modes.c``, >= 0).
    tol : float or callable
        The gradient's accuracy: ``tol(p, g)`` at a sample ``p`` with gradient ``g``.
    rho : float
        The distance from a known zero within which zeros are not told apart.
    budget : int
        At most this many more evaluations of ``grad``.
    samples : sequence of 2-vectors
        More points already solved (their ellipses help; no solve is spent).
    region : Polygon, optional
        The admissible amplitudes (:mod:`.polygon`; with an obstacle): no
        equilibrium lies outside its outer polygon, so parts of cells there need
        no ellipse, and samples beyond it are taken on its rim (and where the rim
        crosses the cells' quarters); a failed solve outside the inner polygon is
        no failure (a slice there may be empty).

    Returns
    -------
    complete : bool
        True when every cell is held by ellipses or lies within ``rho`` of ``known``
        (within ``2 rho`` for cells smaller than ``rho / 10``): no zero of ``∇F``
        lies in the rectangle farther than ``2 rho`` from ``known``.
    sampled : list of ndarray
        The points sampled here.
    open_cells : list of ndarray
        The middles of cells smaller than ``rho / 10`` far from every known zero (a
        zero not found yet), and of cells the budget left undecided.
    """
    c = np.asarray(c, float)
    bound = tol if callable(tol) else (lambda p, g: tol)
    known = np.asarray(known, float).reshape(-1, 2)
    P, G, T, own = [], [], [], []   # (own: may hold itself, :func:`_inside`)
    seen = set()
    sampled, open_cells = [], []
    failures = 0

    def add(p, count=True) -> bool:
        nonlocal failures
        key = (float(p[0]), float(p[1]))
        if key in seen:
            return True
        seen.add(key)
        if region is not None and region.outside(np.array(key))[0]:
            return True       # (no admissible amplitude: nothing to solve)
        g = np.asarray(grad(np.array(key)), float)
        if not np.all(np.isfinite(g)):
            # (no ellipse; between the inner and outer polygons a slice may be empty)
            failures += count and (region is None or region.within(np.array(key)))
            return False
        P.append(key)
        G.append(g)
        T.append(float(bound(np.array(key), g)))
        own.append(region is None or region.interior(np.array(key)))
        return True

    def sample(p):
        # p's solve; on the rim, where round-off may put p just outside, tried
        # again inwards (only the last failure counts)
        sampled.append(np.array(p, float))
        if add(p, count=region is None) or region is None:
            return
        for f in INSETS:
            q = region.inwards(p, f)
            sampled.append(q)
            if add(q, count=f == INSETS[-1]):
                return

    ax0, ax1 = (np.asarray(a, float) for a in axes)
    for p in [(a, b) for a in ax0 for b in ax1] + list(samples):
        add(p)
    # (only the cover's own failures count: the searches' slices failed where
    # they failed, and no ellipse comes from them)
    failures = 0
    # rings around each known zero, radii doubling from rho / 2 to the grid's step,
    # RING_POINTS on each: at a distance r from a zero the ellipses that hold a
    # point come from samples between it and the zero (0.3 r to r from it), which
    # the cells' own splits, square and skipping the disc within rho, spread too
    # thinly (a P1 beam with five equilibria: 3100 solves; with the rings, 1900)
    step = max(float(np.max(np.diff(ax0))), float(np.max(np.diff(ax1))))
    for z in known:
        r = 0.5 * rho
        while r < step and len(sampled) < budget:
            for a in np.arange(RING_POINTS) * (2.0 * np.pi / RING_POINTS):
                p = (z[0] + r * math.cos(a), z[1] + r * math.sin(a))
                if region is not None:
                    # (onto the rim: next to a zero on it, the rim's points are held
                    # only by samples on it)
                    p = tuple(region.onto(p))
                if ax0[0] <= p[0] <= ax0[-1] and ax1[0] <= p[1] <= ax1[-1] and \
                        (float(p[0]), float(p[1])) not in seen:
                    sample(p)
            r *= 2.0
    cells = [(ax0[i], ax0[i + 1], ax1[j], ax1[j + 1])
             for i in range(len(ax0) - 1) for j in range(len(ax1) - 1)]
    # in rounds, all cells of a size together: a cell is split only after its
    # neighbours' samples of that size are in (one at a time, depth first, a cell
    # was split down to 1e-7 of its size that its neighbours' samples held)
    while cells and failures <= MAX_FAILED:
        arrays = _usable(np.array(P).reshape(-1, 2), np.array(G).reshape(-1, 2), np.array(T),
                         np.array(own, bool), c)
        cells = [q for q in cells if not _near(q, known, rho) and
                 not _held(q, arrays, c, region)]
        children = []
        for cell in cells:
            x0, x1, y0, y1 = cell
            mx, my = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
            if max(x1 - x0, y1 - y0) < 0.1 * rho or not (x0 < mx < x1 and y0 < my < y1):
                # (a cell on the disc's rim: the ellipses that hold points there come
                # from samples inside it, which no cell there takes; the proof's
                # resolution is 2 rho)
                if not _near((mx, mx, my, my), known, 2.0 * rho):
                    open_cells.append(np.array([mx, my]))   # (a zero not found, or round-off)
                continue
            if len(sampled) >= budget:
                open_cells.append(np.array([mx, my]))
                continue
            new = [(mx, my), (mx, y0), (mx, y1), (x0, my), (x1, my)]
            if region is not None:
                # (beyond the outer polygon, onto its rim -- 1e-9 of the way inwards,
                # samples held none of the rim's points within 1e-4 of the square of
                # a zero on it; and where the rim crosses the quarters' edges, whose
                # points the middles' projections held none of near a zero)
                rim = [v for q in _quarters(cell) for v in region.rim_points(*q)]
                new = [tuple(region.onto(p)) for p in new + rim]
            fresh = [p for p in new if (float(p[0]), float(p[1])) not in seen]
            for p in fresh:
                sample(p)     # (a failed solve: no ellipse there, the cell split all the same)
            children += _quarters(cell)
        cells = children
    return failures <= MAX_FAILED and not cells and not open_cells, sampled, open_cells


def proven_zeros(grad, axes, zeros, search, c, tol, rho, budget=None, rounds=3,
                 samples=(), region=None) -> tuple:
    """The zeros of ``∇F`` with the ellipses' proof that none is missing.

    :func:`cover` with ``zeros`` known; where a cell shrinks below ``rho / 10`` far
    from them, ``search`` (the caller's Newton's method) is started at its
    middle and the zeros it returns are added, and the proof tried again,
    ``rounds`` times at most (the samples are kept: a second round costs only
    the cells the first left open).

    Parameters
    ----------
    grad, axes, c, tol, rho
        As :func:`cover`.
    zeros : sequence of 2-vectors
        The zeros found so far.
    search : callable
        ``search(seeds) -> list of 2-vectors``: zeros found from ``seeds``.
    budget : int, optional
        Solves for all rounds' bounds together (default :data:`BUDGET`).
    rounds : int
        Bounds tried at most.
    samples : sequence of 2-vectors
        Points already solved (the searches' grids).
    region : Polygon, optional
        As :func:`cover`.

    Returns
    -------
    zeros : list of ndarray
        The zeros, with those the open cells revealed.
    complete : bool
        The last round's verdict.
    """
    budget = BUDGET if budget is None else budget
    zeros = [np.asarray(z, float) for z in zeros]
    samples = [np.asarray(p, float) for p in samples]
    complete = False
    for _ in range(rounds):
        complete, sampled, open_cells = cover(grad, axes, zeros, c, tol, rho, budget, samples,
                                               region)
        budget -= len(sampled)
        samples += sampled
        if complete or not open_cells or budget <= 0:
            break
        count = len(zeros)
        for z in search(open_cells):
            z = np.asarray(z, float)
            if all(np.linalg.norm(z - q) > rho for q in zeros):
                zeros.append(z)
        if len(zeros) == count:
            break       # (nothing new: another round would only repeat this one)
    return zeros, complete


def prove(grad, search, zeros, axes, samples, c, dtol, S, rho, region=None) -> bool:
    """Whether the ellipses prove a two-mode list complete (:func:`proven_zeros`).

    Parameters
    ----------
    grad : callable
        ``grad(s) -> (F, ∇F, beam, ok)``: the fixed-amplitude solve (cached by the
        caller); a slice that failed (``F`` not finite) or is not accurate
        (``ok`` false) counts as unknown.
    search : callable
        ``search(seeds) -> amplitudes`` of the zeros found from ``seeds`` and
        listed by the caller.
    zeros : sequence of 2-vectors
        The listed zeros' amplitudes.
    axes : pair of arrays
        The grid over ``[-S, S]^2``.
    samples : sequence of 2-vectors
        Amplitudes already solved.
    c : pair of float
        The modes' concave coefficients.
    dtol : float
        The gradient's accuracy relative to its local size (the concave part's
        ``2 max(c) S``, or ``|∇F|``), as with one mode.
    S, rho : float
        The amplitude bound and the distance within which zeros are one.
    region : Polygon, optional
        With an obstacle, the admissible amplitudes (:mod:`.polygon`).
    """
    c = np.asarray(c, float)

    def trusted(s):
        F, d, _, ok = grad(s)
        return np.asarray(d, float) if math.isfinite(F) and ok else np.full(2, np.nan)

    def tol(p, d):
        return dtol * (2.0 * float(np.max(c)) * S + float(np.linalg.norm(d)))

    _, complete = proven_zeros(trusted, axes, zeros, search, c, tol, rho,
                               samples=[np.asarray(p, float) for p in samples], region=region)
    return complete


def _usable(P, G, T, own, c):
    """The samples whose gradient exceeds its accuracy, with their ellipses' boxes.

    ``R_p`` lies in ``{d : (d - m)'C(d - m) < g'C^-1 g / 16}``, ``m = C^-1 g / 4``:
    the box ``m +- (g'C^-1 g / (16 c_i))^(1/2)`` around ``p`` (unbounded where
    ``c_i = 0``).
    """
    keep = np.linalg.norm(G, axis=1) > T
    P, G, T, own = P[keep], G[keep], T[keep], own[keep]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(c > 0, 1.0 / np.where(c > 0, c, 1.0), np.inf)
        size = (G * G) @ np.where(np.isfinite(inv), inv, 0.0) / 16.0
        centre = P + np.where(np.isfinite(inv), G * inv, 0.0) / 4.0
        half = np.sqrt(size[:, None] * inv[None, :])
    lo = np.where(np.isfinite(half), centre - half, -np.inf)
    hi = np.where(np.isfinite(half), centre + half, np.inf)
    return P, G, T, own, lo, hi


def _held(cell, arrays, c, region=None) -> bool:
    """Whether every sub-rectangle of ``cell`` (2^j a side, j <= GEOMETRY) is held
    by one sample's ellipse (its corners inside, but the sample itself); with a
    ``region``, or lies outside its outer polygon, or its part inside that
    polygon is held (that part's vertices inside one ellipse)."""
    P, G, T, own, lo, hi = arrays
    x0, x1, y0, y1 = cell
    if region is not None and region.beyond([[x0, y0], [x0, y1], [x1, y0], [x1, y1]]):
        return True
    # the samples whose ellipse's box meets the cell
    near = (lo[:, 0] < x1) & (hi[:, 0] > x0) & (lo[:, 1] < y1) & (hi[:, 1] > y0)
    if not np.any(near):
        return False
    P, G, T, own = P[near], G[near], T[near], own[near]
    todo = np.ones((1, 1), bool)      # sub-rectangles not held yet, on the finest lattice
    for j in range(GEOMETRY + 1):
        m = 2 ** j
        if j:
            todo = np.repeat(np.repeat(todo, 2, axis=0), 2, axis=1)
        xs, ys = np.linspace(x0, x1, m + 1), np.linspace(y0, y1, m + 1)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        corners = np.stack([X.ravel(), Y.ravel()], axis=1)
        inside = _inside(corners, P, G, T, own, c).reshape(m + 1, m + 1, -1)
        held = np.any(inside[:-1, :-1] & inside[1:, :-1] & inside[:-1, 1:] & inside[1:, 1:],
                      axis=2)
        if region is not None:
            cut = region.cut(corners).reshape(m + 1, m + 1, -1)
            held |= np.any(cut[:-1, :-1] & cut[1:, :-1] & cut[:-1, 1:] & cut[1:, 1:], axis=2)
            # across the outer polygon's rim: its part inside, clipped (by the
            # half-planes that cut a corner: the others hold the whole rectangle)
            some = cut[:-1, :-1] | cut[1:, :-1] | cut[:-1, 1:] | cut[1:, 1:]
            for a, b in zip(*np.nonzero(todo & ~held & np.any(some, axis=2))):
                part = region.clip(xs[a], xs[a + 1], ys[b], ys[b + 1], np.nonzero(some[a, b])[0])
                held[a, b] = not len(part) or bool(np.any(np.all(_inside(part, P, G, T, own, c),
                                                                   axis=0)))
        todo &= ~held
        if not todo.any():
            return True
    return False


def _quarters(cell) -> list:
    x0, x1, y0, y1 = cell
    mx, my = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    return [(x0, mx, y0, my), (mx, x1, y0, my), (x0, mx, my, y1), (mx, x1, my, y1)]


def _inside(points, P, G, T, own, c) -> np.ndarray:
    """``(points, samples)``: whether each point lies in each sample's ellipse
    (or is the sample itself, when ``own``: no zero, ``|g| > t``; not on the
    admissible amplitudes' rim, where the obstacle may hold an equilibrium
    whose gradient is not zero -- a review's)."""
    # (by components, the same numbers: numpy's norm and einsum over a trailing
    # axis of 2 took 305 s here against 228 s, most of the two-mode proof's time on
    # a P4 beam 1e-6 above lambda_2, 8 elements)
    points = np.asarray(points, float)
    d0 = points[:, 0, None] - P[None, :, 0]
    d1 = points[:, 1, None] - P[None, :, 1]
    q0, q1 = d0 * d0, d1 * d1
    dist = np.sqrt(q0 + q1)
    inside = 2.0 * (c[0] * q0 + c[1] * q1) + T * dist < d0 * G[None, :, 0] + d1 * G[None, :, 1]
    return inside | ((dist == 0.0) & own[None, :])


def _near(cell, known, rho) -> bool:
    # the cell's corners all within rho of one known zero (the disc is convex)
    if not len(known):
        return False
    x0, x1, y0, y1 = cell
    corners = np.array([[x0, y0], [x0, y1], [x1, y0], [x1, y1]])
    d = np.linalg.norm(corners[None, :, :] - known[:, None, :], axis=2)
    return bool(np.any(np.all(d <= rho, axis=1)))
