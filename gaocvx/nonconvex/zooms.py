"""Second searches of the two-mode plane on finer grids (:mod:`.stationary2`).

The first search samples the admissible amplitudes on a ``GRID2 x GRID2`` grid.
Two places need a finer one, and each gets a second search of its own:

- near the flat beam (:func:`near_flat`): equilibria closer together than the
  merging distance (``MERGE S``) are one to the first search, and its probes
  reach past them;
- clusters of equilibria (:func:`clusters`): with an obstacle or channel a
  valley along a surface holds a row of minima, one for each node that touches
  it, and saddles between them, closer together than the grid's step.

Both take the search as an argument (``search(S, box=, starts=, minimisers=)``,
:func:`.stationary2.find_plane` without zooms of its own) and return the
merged list.

A third place needs a finer *scale*, not a finer grid: the beam near w = 0 on an
obstacle, whose equilibria lie so near it, and so low, that the scene's slices
cannot resolve its reduced gradient at all (:func:`own_scale`: the search again
in a problem measured in their own size, wherever that size is below
``NEAR_FLAT`` of the amplitude range, and with two modes where the flat beam is
pressed at gap 0).
"""

from __future__ import annotations

import logging
import math

import numpy as np
from scipy.sparse.csgraph import connected_components

from .equilibrium import MERGE, same_point
from .whole_beam import same_beam

__all__ = ["near_flat", "clusters", "own_scale", "own_sizes", "peak_amplitude", "NEAR_FLAT",
           "CLUSTER_STEPS", "CLUSTER_GRID", "MAX_CLUSTERS", "OWN_BOX", "SAME_BEAM"]

log = logging.getLogger(__name__)

# Equilibria within this fraction of the box's size S of the flat beam are searched
# again in a square of their own size (near_flat).
NEAR_FLAT = 1e-3
# Equilibria closer than this many grid steps (in each amplitude) are one cluster,
# and its box reaches one step beyond its outermost members.
CLUSTER_STEPS = 1.5
# A cluster's box is searched on a grid of CLUSTER_GRID x CLUSTER_GRID points (its
# box spans three or more steps of the first grid: a quarter step or finer).
CLUSTER_GRID = 13
# The clusters searched again at most, the lowest first (each cost 0.4 to 1 times
# the first search in the scenes measured: its zero curves, descents and edge
# minima more than its grid).
MAX_CLUSTERS = 3
# The square searched in the flat beam's own scale spans this many times the
# linearised energy's peak amplitude (own_scale: the saddles found there lay at
# 0.1 to 0.3 of it in the campaign's scenes).
OWN_BOX = 4.0
# An entry not polished on the whole beam whose deflection and slope lie within
# this fraction of a polished one's is that equilibrium (own_scale).
SAME_BEAM = 1e-4


def near_flat(search, S, out, lo, hi, minimisers) -> list:
    """Equilibria near the flat beam searched again in a square of their own size.

    Equilibria closer together than the merging distance (MERGE S) are one to the
    search, and its probes reach past them (P1 on an obstacle 8.4e-6 m below, no
    load, 10 elements: near the flat beam, |s| = 2.4e-5 S, a saddle, a pair of
    minima 2.25e-7 S beside it and another pair 1.3e-6 S away).  Where equilibria
    other than the flat beam lie within NEAR_FLAT of the searched square's size
    (``S``, or less where the admissible amplitudes end sooner: a channel) from
    it, the square of four times the largest such ``|s|``, ``R``, is searched with
    ``R`` as its size, seeded with what the first search found there.  Its
    ``optimal`` equilibria are listed beside the first search's; where both found
    one (within MERGE R), the second's stands, and a first one that is not
    ``optimal`` gives way to a second's within MERGE S (it stood for several).
    The flat beam stays the first search's (probes of 1e-6 and 1e-8 of ``R``
    would reach round-off), and minima on the square's sides, where the
    admissible amplitudes go on, are the square's, not F's.
    """
    size = float(np.max(np.abs(np.r_[lo, hi])))
    near = [float(np.linalg.norm(e.amplitudes)) for e in out
            if MERGE * S < float(np.linalg.norm(e.amplitudes)) <= NEAR_FLAT * size]
    if not near:
        return out
    R = 4.0 * max(near)

    def within(s):
        return float(np.max(np.abs(s))) <= R

    def on_cut_side(s):
        s, edge = np.asarray(s, float), (1.0 - 1e-6) * R
        return bool(np.any((s <= -edge) & (lo < -R)) or np.any((s >= edge) & (hi > R)))

    inner = search(R, box=(np.maximum(lo, -R), np.minimum(hi, R)),
                   starts=[np.asarray(e.amplitudes, float) for e in out if within(e.amplitudes)],
                   minimisers=[m for m in minimisers if within(m.amplitudes)])
    # (and only its `optimal` equilibria: on beams pressed at gap 0 its `inaccurate`
    # ones were a saddle repeated up to eight times 4e-6 to 9e-5 of the deflection
    # apart, or points beside a saddle that are no equilibrium -- a helper's check
    # of 120 campaign scenes)
    inner = [f for f in inner if f.status == "optimal"
             and not same_point(f.amplitudes, 0.0, S) and not on_cut_side(f.amplitudes)]
    # (a first entry goes where the second search found it again, within MERGE R,
    # and, not `optimal`, where a second one lies within MERGE S: it stood for several)
    kept = [e for e in out if not any(
        same_point(e.amplitudes, f.amplitudes, R if e.status == "optimal" else S) for f in inner)]
    log.info("equilibria (k = 2): near the flat beam searched again in a square of "
             "%.3g S: %d listed, %d before", R / S, len(kept) + len(inner), len(out))
    return kept + inner


def clusters(search, S, out, lo, hi, step, minimisers) -> list:
    """Clusters of equilibria searched again on a finer grid over their own box.

    Parameters
    ----------
    search : callable
        ``search(S, box=(a, b), starts=, minimisers=)``: the search of
        :func:`.stationary2.find_plane` on a grid of CLUSTER_GRID points over
        the box, without zooms, modes' boxes, images or the flat beam.
    S : float
        The searched square's size (its merging distance and probes stay).
    out : list of Equilibrium
        The first search's equilibria.
    lo, hi : ndarray
        The admissible amplitudes' box.
    step : ndarray
        The first grid's step in each amplitude.
    minimisers : list of Equilibrium
        The certified global minimisers.

    Returns
    -------
    list of Equilibrium
        ``out`` with the clusters' ``optimal`` equilibria added.

    Notes
    -----
    Equilibria (other than the flat beam) closer than CLUSTER_STEPS steps in
    both amplitudes are linked; every group with two or more stable ones (a row
    of minima) spans a box reaching one step beyond its outermost members,
    within ``[lo, hi]``.  The boxes of the MAX_CLUSTERS lowest groups are
    searched, seeded with the group.  Their ``optimal`` equilibria within the
    box (and a step around it) that the first search did not find (within
    MERGE S) are added; one found there before but not ``optimal`` gives way.
    (A campaign's P3 beam in a channel 2.5 mm high without load, 16 elements: a
    row of three minima and two saddles along the ceiling within one grid step,
    and a fourth minimum 0.6 steps beside them, 0.08 J lower, missed; so was one
    beside three minima of a P3 beam under a load table.)
    """
    step = np.asarray(step, float)
    pts = [np.asarray(e.amplitudes, float) for e in out]
    idx = [i for i, s in enumerate(pts) if not same_point(s, 0.0, S)]
    P = np.array([pts[i] for i in idx]).reshape(-1, 2)
    linked = np.all(np.abs(P[:, None, :] - P[None, :, :]) <= CLUSTER_STEPS * step, axis=2)
    count, label = connected_components(linked, directed=False)
    members = [[idx[j] for j in np.flatnonzero(label == c)] for c in range(count)]
    groups = sorted((g for g in members if sum(out[i].stable for i in g) >= 2),
                    key=lambda g: min(out[i].energy for i in g))[:MAX_CLUSTERS]
    for g in groups:
        s = np.array([pts[i] for i in g])
        a = np.maximum(lo, s.min(axis=0) - step)
        b = np.minimum(hi, s.max(axis=0) + step)

        def near(p, a=a, b=b):
            p = np.asarray(p, float)
            return bool(np.all(p >= a - step) and np.all(p <= b + step))

        found = search(S, box=(a, b), starts=list(s),
                       minimisers=[m for m in minimisers if near(m.amplitudes)])
        new = [f for f in found if f.status == "optimal" and near(f.amplitudes)
               and not same_point(f.amplitudes, 0.0, S)
               and not any(same_point(f.amplitudes, e.amplitudes, S)
                           for e in out if e.status == "optimal")]
        before = len(out)
        out = [e for e in out if not any(same_point(e.amplitudes, f.amplitudes, S)
                                          for f in new)] + new
        log.info("equilibria (k = 2): a cluster of %d searched again on [%s, %s]: %d more",
                 len(g), np.round(a, 4), np.round(b, 4), len(out) - before)
    return out


def peak_amplitude(dp, modes) -> float:
    """The largest amplitude, over the falling modes, at which the energy linearised at
    the flat beam peaks along a mode.

    The load's work rises linearly along a mode ``phi_i``, its fall (where
    ``phi_i' H_0 phi_i < 0``, ``H_0`` the Hessian at ``w = 0``) quadratically, and
    the quartic term is negligible so near the flat beam: the energy along it
    peaks at ``|f' phi_i / phi_i' H_0 phi_i|``.

    Parameters
    ----------
    dp : DiscreteProblem
        The problem (its load ``f`` and Hessian).
    modes : Modes
        Its unstable modes (columns of ``phi``).

    Returns
    -------
    float
        The largest such amplitude in ``dp``'s units; NaN without a falling mode.

    >>> import numpy as np, scipy.sparse as sp
    >>> from types import SimpleNamespace
    >>> dp = SimpleNamespace(f=np.array([-2.0, 0.0]),
    ...                      hessian=lambda u: sp.diags([-4.0, 1.0]))
    >>> peak_amplitude(dp, SimpleNamespace(phi=np.eye(2)[:, :1]))
    0.5
    """
    H0 = dp.hessian(np.zeros_like(dp.f))
    peaks = []
    for phi in np.asarray(modes.phi, float).T:
        curve = float(phi @ (H0 @ phi))
        if curve < 0.0:
            peaks.append(abs(float(dp.f @ phi) / curve))
    return max(peaks, default=math.nan)


def own_sizes(dp, modes, rows=None, peak=None) -> list:
    """The near-flat equilibria's amplitude scales on an obstacle, largest first:
    :func:`peak_amplitude` and the amplitudes at which each unstable mode alone
    first reaches a surface of the obstacle, either way.

    Pressed by a load far below the buckled beam's scale onto an obstacle a small
    gap below, the beam has a stable equilibrium about one gap deep, besides the
    free beam's linear answer near the peak (campaign: P4, 4 elements, gap
    9.6e-15 m, q = -4.6e-6 N/m: the pressed minimum at 1.0 and the saddle at 1.15
    times the mode's reach).  In a channel the ceiling's reach is a scale of its
    own, and so is the peak where the load lifts the beam far more than a gap.

    ``rows``: the obstacle's rows and levels (:func:`.node.obstacle_rows`'s, by
    default).  A mode ``(1, 0)`` under the rows ``u_1 >= -3`` and
    ``u_1 + u_2 <= 2`` (as ``-u_1 - u_2 >= -2``), without load:

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> rows = (np.array([[1.0, 0.0], [-1.0, -1.0]]), np.array([-3.0, -2.0]))
    >>> own_sizes(None, SimpleNamespace(phi=np.array([[1.0], [0.0]])), rows, peak=np.nan)
    [3.0, 2.0]
    """
    if rows is None:
        from .node import obstacle_rows
        rows = obstacle_rows(dp)
    A, levels = rows
    sizes = [peak_amplitude(dp, modes) if peak is None else peak]
    for phi in np.asarray(modes.phi, float).T:
        for reach in (A @ phi, -(A @ phi)):    # (s > 0 and s < 0: rows s t >= level)
            out = reach < 0.0
            if np.any(out):
                sizes.append(float(np.min(levels[out] / reach[out])))
    return sorted((x for x in sizes if math.isfinite(x) and x > 0.0), reverse=True)


def _windows(dp, modes, out, S, limit) -> list:
    """The second searches' sizes R, largest first (:func:`own_scale`)."""
    if modes.k == 2 and any(e.stable and e.status == "optimal" and not np.any(e.w)
                            for e in out):
        R = OWN_BOX * peak_amplitude(dp, modes)
        return [R] if math.isfinite(R) and 0.0 < R < limit else []
    windows = []
    for size in own_sizes(dp, modes):
        # (each a scale the search before cannot resolve: below NEAR_FLAT of it)
        if OWN_BOX * size < NEAR_FLAT * (windows[-1] if windows else limit):
            windows.append(OWN_BOX * size)
    return windows


def own_scale(dp, modes, out, S, lo, hi, search, verdicts=None) -> list:
    """The flat beam's neighbourhood searched again in a problem of its own scale.

    Wherever ``R = OWN_BOX`` times one of :func:`own_sizes` lies below
    ``NEAR_FLAT`` of the amplitude range ``S`` (and of half the admissible
    range), the equilibria near the flat beam lie closer together than the first
    search resolves (campaign, one mode: a stable beam pressed one gap deep,
    1e-14 m, was missing from lists called complete, within the merging distance
    of the saddle beside it; two modes: such beams missing from lists of one
    entry, not complete).  The largest such ``R`` is searched first, and each
    smaller size below ``NEAR_FLAT`` of the last one searched again (the floor's
    reach in a channel whose ceiling's is far larger, a gap far below the peak).
    With two modes, where ``out`` lists the flat beam as a stable ``optimal``
    equilibrium (pressed at gap 0), R is measured by :func:`peak_amplitude` alone
    and compared with ``S``: its neighbourhood holds the saddles between it and the buckled
    beam (the mountain pass, :func:`.equilibrium.check_mountain_pass`).  Pressed
    by a small load, they lie where the load's work and the unstable modes' fall
    balance, so near the flat beam and so low that the scene's slices, whose
    accuracy is relative to the scene's energy, cannot resolve ``∇F`` there at
    all (the campaign's seeds 7101-7108: in 12 of 96 scenes the list was two
    minima and no saddle, the saddles 1e-4 to 183 J against the scene's 1e7 to
    1e9 J; where one saddle was found, its mirror pairs beside it were not).
    The problem is measured again in ``R`` (``dp.rescaled``), and
    ``search(dp_R)`` searches its square of size 1 (:func:`.stationary2.find_plane`
    without zooms; one mode: the segment, :func:`.stationary1.find_line`).  Its
    ``optimal`` equilibria other than the flat beam, and not on a side of the
    square where the admissible amplitudes go on (minima there are the
    square's), are listed in ``dp``'s units unless one is there already (within
    ``MERGE R``); an entry of ``out`` there that is not ``optimal`` gives way
    (within ``MERGE R``; within ``MERGE S`` where it lies inside the square and
    every beam the second search found is ``optimal``, the square's own minima on
    its open sides aside: it stood for them), and so
    does one not polished on the whole beam within ``SAME_BEAM`` of one that is
    (deflection and slope, relative).

    Parameters
    ----------
    dp, modes : DiscreteProblem, Modes
        The problem with an obstacle and its one or two unstable modes.
    out : list of Equilibrium
        The search's equilibria.
    S : float
        The searched square's size (no second search where ``R`` is not below
        ``NEAR_FLAT`` of it and of half the admissible box's largest side; with
        two modes and the flat beam pressed, below them).  A search in a smaller
        square still lets the first search's entries give way within ``MERGE S``.
    lo, hi : ndarray
        The admissible amplitudes' box.
    search : callable
        ``search(dp_R) -> list of Equilibrium`` (amplitudes in ``dp_R``'s units).
    verdicts : list, optional
        Where given, each square searched appends whether every beam its search
        found (the square's own minima aside) is ``optimal``: a list's proof holds
        there only where it does.

    Returns
    -------
    list of Equilibrium
        ``out``, with what the second search found added.
    """
    if dp.contact != "obstacle":
        return out
    # (not where the square would span the admissible box: a narrow channel, whose
    # search is already measured in its width, scales.rescale_for)
    # (each square after the first search's S: the entries that give way are that
    # search's, and stood for what lies within its merging distance)
    for R in _windows(dp, modes, out, S, min(S, 0.5 * float(np.max(hi - lo)))):
        out = _own_scale(dp, modes, out, S, lo, hi, search, R, verdicts)
    return out


def _own_scale(dp, modes, out, S, lo, hi, search, R, verdicts=None) -> list:
    """:func:`own_scale` in one square of size ``R`` (``S``: the first search's)."""
    found = search(dp.rescaled(dp.W * R))
    edge = 1.0 - 1e-6

    def the_squares(f):
        # on a side of the square where the admissible amplitudes go on: a minimum
        # of the square, no equilibrium (not a KKT point, so `inaccurate`)
        s = np.asarray(f.amplitudes, float)
        return bool(np.any((s <= -edge) & (lo < -R)) or np.any((s >= edge) & (hi > R)))
    found = [f for f in found if np.any(f.w) and not the_squares(f)]
    added = []
    for f in found:
        if f.status != "optimal":
            continue
        s = np.asarray(f.amplitudes, float)
        f.amplitudes, f.W = [float(a) * R for a in s], float(dp.W)
        if not any(same_point(f.amplitudes, e.amplitudes, R)
                   for e in added + [e for e in out if e.status == "optimal"]):
            added.append(f)
    # (where the second search found every beam it lists accurately, an entry of the
    # first that is not `optimal` stood for what lies within its merging distance:
    # one mode, a beam pressed one gap deep listed 2e-4 R off, unstable, no KKT point;
    # the square's own minima on its open sides do not count: two modes, a trial's
    # lists kept the first search's `inaccurate` flat beam beside the four beams
    # found, for two such corners)
    clean = all(f.status == "optimal" for f in found)
    if verdicts is not None:
        verdicts.append(clean)

    def stood_for(e):
        near = S if clean and float(np.max(np.abs(e.amplitudes))) <= R else R
        return any(same_point(e.amplitudes, f.amplitudes, near) for f in added)
    kept = [e for e in out if e.status == "optimal" or not stood_for(e)]
    merged = _one_beam(kept + added, R)
    log.info("equilibria (k = %d): near the flat beam searched again in its own scale "
             "(%.3g S): %d more, %d replaced", modes.k, R / S, len(merged) - len(kept),
             len(out) - len(kept))
    return merged


def _one_beam(eqs, R) -> list:
    """``eqs`` without the entries in the square ``[-R, R]^2`` not polished on the whole
    beam that lie within ``SAME_BEAM`` of one there that is, of their stability (its
    beam is theirs to the slices' accuracy).

    Slices leave a saddle near the flat beam accurate to some 1e-9 of its
    stationarity, its amplitudes to some 1e-5 of their size where a contact is
    degenerate, far beyond ``MERGE R``: a review's P1 pressed at gap 0 at three
    times P_bar_h (12 elements) listed one saddle three times, 4.1e-10 m and
    1.7e-10 m apart at amplitudes of 3.5e-5 m, once polished.  Distinct
    equilibria near the flat beam lay 4e-3 of their size apart at the closest
    (the campaign's seeds 7101-7108).
    """
    def inside(e):
        return float(np.max(np.abs(e.amplitudes))) <= R

    polished = [e for e in eqs if e.whole_beam and inside(e)]
    return [e for e in eqs if e.whole_beam or not inside(e) or not any(
        p.stable == e.stable and same_beam(e, p, SAME_BEAM) for p in polished)]
