"""Branch and bound over the unstable modes' amplitudes.

Each box ``[lo, hi]`` of amplitudes gets the lower bound of its node program
(:class:`.node.NodeProgram`, the concave part replaced by its chord) and
contributes an upper bound, the true energy at the program's minimiser.
The box with the smallest lower bound is split along the coordinate with the
largest chord error ``c_i (hi_i - lo_i)^2 / 4``, through its node program's
minimiser (kept within the middle half, :func:`split_point`); boxes
whose lower bound lies within ``tol`` of the best upper bound are closed.
The chord error on a box bounds the gap between its bounds, so the bounds
meet.  The search stops when the best upper bound minus the smallest lower
bound of every leaf (open or closed) is at most ``tol``, or when every box
left is so small that its chord error is below ``tol / 100`` or, where its
bound lies within the caller's ``accept`` of the best, a tenth of its node
program's own accuracy (the remaining gap is then that accuracy): the
difference is the
certificate, a global optimality gap, whatever stopped the search.

Examples
--------
A one-dimensional toy: ``F(s) = s^4 - s^2`` on [-2, 2] (minimum -1/4 at
``s = +-1/sqrt 2``), with exact convex node problems ``min s^4 + chord``:

>>> import numpy as np
>>> from types import SimpleNamespace
>>> class Toy:
...     modes = SimpleNamespace(c=np.array([1.0]))
...     def solve_box(self, lo, hi):
...         grid = np.linspace(lo[0], hi[0], 2001)
...         val = grid**4 - (lo[0] + hi[0]) * grid + lo[0] * hi[0]
...         i = int(np.argmin(val))
...         return SimpleNamespace(lower=float(val[i]) - 1e-6, s=grid[i:i+1], u=grid[i:i+1],
...                                lam=None, ok=True)
>>> out = branch_and_bound(Toy(), lambda u: float(u[0]**4 - u[0]**2), [-2.0], [2.0], tol=1e-4)
>>> round(out.upper, 4), out.gap <= 1e-4
(-0.25, True)
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

__all__ = ["Leaf", "BnBResult", "branch_and_bound", "components", "rescaled_leaves", "split_point"]

log = logging.getLogger(__name__)

# Seconds of branch and bound before it stops, uncertified (the answer is then
# `inaccurate` with the gap reached).
TIME_LIMIT = 120.0
# Node programs without the gap halving after which the caller's ``stalled`` is asked
# whether to end the search (the global method: when the answer lies far outside
# the problem's scale, so that a re-solve in its own scale follows).
STALL_NODES = 400
# Basins (the ``basin`` argument): tried at most MAX_BASINS times, on node answers
# within NEAR times the accepted gap of the best energy that lie outside every
# basin found and the points that polished to it.
MAX_BASINS = 16
NEAR = 1000.0


@dataclass
class Leaf:
    """A box of amplitudes with its node program's answer."""

    lower: float
    lo: np.ndarray
    hi: np.ndarray
    s: np.ndarray | None
    u: np.ndarray | None
    ok: bool
    noise: float = 0.0  # value - lower of its node program: what splitting cannot remove


@dataclass
class BnBResult:
    """The outcome of :func:`branch_and_bound` (non-dimensional energies).

    ``upper`` is the best energy found (at ``u``, amplitudes ``s``), ``lower``
    the smallest lower bound of any leaf, ``gap = upper - lower`` the
    certificate; ``leaves`` are the final boxes, ``nodes`` the node programs
    solved, ``failed`` those the solver did not report optimal among the leaves,
    ``basins`` the boxes proved around local minimisers (each holds one);
    ``stalled`` whether the caller's ``stalled`` ended the search.
    """

    upper: float
    lower: float
    u: np.ndarray
    s: np.ndarray
    lam: object
    nodes: int
    leaves: list = field(repr=False)
    converged: bool = True
    failed: int = 0
    certificate: str = "branch and bound"   # (dual.shortcut's: "dual bound", no nodes)
    basins: list = field(default_factory=list, repr=False)   # proved (see ``basin``)
    stalled: bool = False

    @property
    def gap(self) -> float:
        return self.upper - self.lower


def branch_and_bound(prog, energy, lo, hi, tol: float, max_nodes: int = 4000,
                     start=None, leaves=None, time_limit: float = TIME_LIMIT,
                     accept: float | None = None, basin=None, stalled=None) -> BnBResult:
    """Minimise the energy over the box ``[lo, hi]`` of amplitudes, to a certified gap ``tol``.

    Parameters
    ----------
    prog : NodeProgram
        ``prog.solve_box(lo, hi)`` returns a node's ``lower``, ``s``, ``u``,
        ``lam`` and ``ok``; ``prog.modes.c`` are the concave coefficients.  A
        program with ``takes_cutoff`` true is called with ``cutoff``, the level
        above which its bound closes the box: it may stop as soon as its bound
        exceeds it.
    energy : callable
        The true (non-dimensional) energy of free DOFs ``u``.
    lo, hi : array_like
        A box that contains every global minimiser.
    tol : float
        The gap at which to stop.
    max_nodes : int
        Node programs at most (the result then has ``converged = False``).
    start : tuple, optional
        ``(energy, u, s, lam)`` of a known feasible point (an upper bound).
    leaves : list of Leaf, optional
        The final leaves of an earlier search of the same problem (measured in
        this one's units, see :func:`rescaled_leaves`), which tile ``[lo, hi]``:
        their bounds hold here too, so the search goes on from them instead of
        from the whole box.  Those whose bound is within reach of the best energy
        are solved again (their bound is kept if higher).
    time_limit : float
        Seconds before the search stops (``converged = False``).
    accept : float, optional
        The gap the caller certifies (at least ``tol``; by default ``tol``).  A box
        is closed at its node program's accuracy (its value less its bound) only if
        its bound lies within ``accept`` of the best energy: else it is split.
    basin : callable, optional
        ``basin(u, s, lam)`` polishes a candidate to a local minimiser and returns
        a box of amplitudes around it on which no deflection lies below a
        proved bound (:class:`.basin.Basin`), or None.  It is tried on the start
        and on node answers within ``NEAR`` times ``accept`` of the best energy
        that lie outside every basin found and the points that polished to it
        (at most ``MAX_BASINS`` tries); a box inside a basin takes the basin's
        bound without a node program.
    stalled : callable, optional
        ``stalled(u) -> bool`` of the best deflection, asked when the gap has not
        halved over ``STALL_NODES`` node programs: true ends the search
        (``converged = False``; its leaves are the caller's to go on from).
    """
    c = np.asarray(prog.modes.c, float)
    # A wall-clock limit: with constraints each node is a solve of its own, and a
    # gap that closes slowly must end as an uncertified answer, not a hang.
    deadline = time.perf_counter() + time_limit
    best = list(start) if start is not None else [math.inf, None, None, None]
    accept = tol if accept is None else max(accept, tol)
    counter = itertools.count()
    nodes = 0

    # Proved basins, and boxes around the points that polished to a minimiser already
    # tried (its basin, used or not, and those points: they are not tried again).
    basins, catchments, tries = [], [], [0]

    def try_basin(u, s, lam):
        """A proved basin around the local minimiser that ``(u, s)`` polishes to."""
        inside = lambda x, box: bool(np.all(box[0] <= x) and np.all(x <= box[1]))  # noqa: E731
        if basin is None or u is None or s is None or tries[0] >= MAX_BASINS:
            return
        if any(inside(s, box) for box in catchments):
            return
        tries[0] += 1
        found = basin(u, s, lam)
        if found is None:
            return
        for i, box in enumerate(catchments):
            if inside(found.s, box):   # a known minimiser again
                catchments[i] = (np.minimum(box[0], s), np.maximum(box[1], s))
                return
        catchments.append((np.minimum(found.lo, s), np.maximum(found.hi, s)))
        e = energy(found.u)
        if e < best[0]:
            best[:] = [e, found.u, found.s, None]
        # (a bound that does not close its boxes would only have them split again and
        # again: r'G^-1 r / 2m too large, the residual's rounding at fine meshes)
        if found.lower > best[0] - tol:
            basins.append(found)

    def evaluate(lo, hi, parent):
        nonlocal nodes
        for b in basins:
            if b.contains(lo, hi):
                # Proved: no deflection with these amplitudes lies below b.lower.
                return Leaf(max(b.lower, parent.lower), lo, hi, b.s, b.u, True, 0.0)
        # A program that can stop once its bound closes the box is told where that is.
        sol = (prog.solve_box(lo, hi, cutoff=best[0] - tol)
               if getattr(prog, "takes_cutoff", False) else prog.solve_box(lo, hi))
        nodes += 1
        if sol.u is not None:
            e = energy(sol.u)  # inf for a point that is not feasible
            if e < best[0]:
                best[:] = [e, sol.u, sol.s, sol.lam]
            if sol.ok and e <= best[0] + NEAR * accept:
                try_basin(sol.u, sol.s, sol.lam)
        if sol.ok:
            # A child lies inside its parent: the parent's bound holds for it too.
            noise = getattr(sol, "value", sol.lower) - sol.lower
            return Leaf(max(sol.lower, parent.lower), lo, hi, sol.s, sol.u, True,
                        noise if math.isfinite(noise) else 0.0)
        # A solve that is not optimal proves nothing: the parent's bound stands
        # (and is split further if it matters).
        return Leaf(parent.lower, lo, hi, sol.s, sol.u, parent.ok)

    if start is not None:
        try_basin(start[1], start[2], start[3])
    closed = []
    if leaves is None:
        root = evaluate(np.asarray(lo, float), np.asarray(hi, float),
                        Leaf(-math.inf, None, None, None, None, False))
        open_ = [(root.lower, next(counter), root)]
    else:
        # Why go on from an earlier search: re-solved in the answer's own scale, far
        # boxes (amplitudes hundreds of times the answer's) have values ~1e7 times
        # it, where Clarabel stops with "insufficient progress"; their bounds from
        # the first scale, where they were solved, are as valid in this one.
        open_ = []
        for old in leaves:
            leaf = evaluate(old.lo, old.hi, old) if old.lower <= best[0] else old
            if leaf.lower > best[0] - tol:
                closed.append(leaf)
            else:
                open_.append((leaf.lower, next(counter), leaf))
        heapq.heapify(open_)
    converged, stalled_out, next_log = True, False, 100
    mark = (math.inf, nodes)   # (the gap last halved, at so many nodes)
    while open_:
        lower, _, leaf = open_[0]
        if best[0] - lower <= tol:
            break
        if nodes >= max_nodes or time.perf_counter() > deadline:
            converged = False
            break
        if best[0] - lower <= 0.5 * mark[0]:
            mark = (best[0] - lower, nodes)
        elif nodes - mark[1] >= STALL_NODES and stalled is not None and best[1] is not None:
            if stalled(best[1]):
                log.info("branch and bound: %d nodes, gap %.3g, stalled", nodes, best[0] - lower)
                converged, stalled_out = False, True
                break
            mark = (mark[0], nodes)
        if nodes >= next_log:   # (nodes go up by two a split: no test of nodes % 100)
            log.info("branch and bound: %d nodes, gap %.3g", nodes, best[0] - lower)
            next_log += 100
        heapq.heappop(open_)
        width = leaf.hi - leaf.lo
        chord = float(np.sum(c * width**2)) / 4.0
        if chord <= 1e-2 * tol or (chord <= 0.1 * leaf.noise and best[0] - lower <= accept):
            # The chord is exact to far below tol here, or to a tenth of the node
            # program's own accuracy (its solver's margin and model error): what is left of
            # this box's gap is that accuracy, which splitting cannot reduce.  Not where
            # that leaves a gap beyond `accept`: a value far above its bound is a node
            # program that stopped short (the fast path's line search stalled at a box
            # corner, 815 J of non-dimensional noise on P1 at 3 P_bar_h on a unilateral
            # bed, 256 elements), and such a box closed would leave the answer
            # uncertified; its children are solved afresh.
            closed.append(leaf)
            continue
        i = int(np.argmax(c * width**2))
        mid = split_point(leaf, i)
        cut = _carve(leaf, basins, c)
        if cut is not None:
            i, mid = cut
        for a, b in ((leaf.lo[i], mid), (mid, leaf.hi[i])):
            clo, chi = leaf.lo.copy(), leaf.hi.copy()
            clo[i], chi[i] = a, b
            child = evaluate(clo, chi, leaf)
            if child.lower > best[0] - tol:
                closed.append(child)
            else:
                heapq.heappush(open_, (child.lower, next(counter), child))
    leaves = closed + [item[2] for item in open_]
    lower = min(leaf.lower for leaf in leaves)
    frontier = [leaf for leaf in leaves if leaf.lower <= best[0]]
    failed = sum(not leaf.ok for leaf in frontier)
    log.info("branch and bound: %d nodes, upper %.12g, lower %.12g, %d leaves", nodes, best[0],
             lower, len(leaves))
    return BnBResult(best[0], lower, best[1], best[2], best[3], nodes, leaves,
                     converged, failed, basins=basins, stalled=stalled_out)


def _carve(leaf: Leaf, basins, c):
    """``(i, x)``: a split of ``leaf`` along a face of a basin it overlaps, or None.

    A box across a basin's face is cut there (along the amplitude whose chord
    error is largest among those with a face inside the box, at most 2k cuts):
    the part inside then closes on the basin's bound without a node program.
    """
    best = None
    for b in basins:
        if np.any(leaf.lo >= b.hi) or np.any(leaf.hi <= b.lo):
            continue
        width = leaf.hi - leaf.lo
        for face in (b.lo, b.hi):
            inside = (face > leaf.lo + 1e-3 * width) & (face < leaf.hi - 1e-3 * width)
            for i in np.flatnonzero(inside):
                err = c[i] * width[i] ** 2
                if best is None or err > best[0]:
                    best = (err, int(i), float(face[i]))
    return None if best is None else best[1:]


def split_point(leaf: Leaf, i: int) -> float:
    """Where ``leaf`` is split along amplitude ``i``: at its node program's minimiser,
    kept within the middle half of the box (the midpoint when it has none).

    The chord of ``-c_i s_i^2`` is exact at the ends of a box, so a split through the
    relaxation's minimiser makes both children's chords exact there and raises their
    bounds where the parent's was lowest (omega-subdivision, as in alpha-BB).
    Measured at 32 elements, the same answers: P1 at 5 P_bar_h (k = 3) 951 -> 707
    nodes, a P4 beam on a bonded bed at 3 P_hat_h (k = 4) 5007 -> 3835, P1 on a
    unilateral bed (k = 2) 231 -> 179, P4 without load 87 -> 63.  Every child still
    has at most three quarters of its parent's width, so the search converges as
    with bisection.

    Examples
    --------
    >>> leaf = Leaf(0.0, np.array([0.0, 0.0]), np.array([4.0, 4.0]), np.array([0.2, 3.0]), None, True)
    >>> split_point(leaf, 0), split_point(leaf, 1)
    (1.0, 3.0)
    """
    lo, hi = float(leaf.lo[i]), float(leaf.hi[i])
    if leaf.s is None or not np.isfinite(leaf.s[i]):
        return 0.5 * (lo + hi)
    quarter = 0.25 * (hi - lo)
    return float(min(max(float(leaf.s[i]), lo + quarter), hi - quarter))


def rescaled_leaves(leaves, ratio: float) -> list:
    """``leaves`` measured in a deflection scale ``ratio`` times smaller (W_old / W_new).

    Amplitudes and DOFs are lengths over W, so they grow by ``ratio``; energies
    are over ``E0 ~ W^2``, so bounds grow by ``ratio**2``.  The change of units
    is exact: a bound that held before holds after.

    Examples
    --------
    >>> leaf = Leaf(-1.0, np.array([0.0]), np.array([1.0]), None, None, True, 0.5)
    >>> new = rescaled_leaves([leaf], 2.0)[0]
    >>> new.lower, new.hi, new.noise
    (-4.0, array([2.]), 2.0)
    """
    r, r2 = float(ratio), float(ratio) ** 2
    return [Leaf(leaf.lower * r2, leaf.lo * r, leaf.hi * r,
                 None if leaf.s is None else leaf.s * r, None if leaf.u is None else leaf.u * r,
                 leaf.ok, leaf.noise * r2) for leaf in leaves]


def components(leaves) -> list:
    """Groups of leaves whose boxes touch (connected components).

    The boxes are sorted by their lower end along one amplitude, so each is
    compared only with those that begin before it ends there (a sweep); the
    comparison of all pairs, in Python, took most of a six-mode search (near
    the minimum some 10^4 leaves: 5 10^7 pairs).

    Examples
    --------
    >>> box = lambda lo, hi: Leaf(0.0, np.array(lo, float), np.array(hi, float), None, None, True)
    >>> groups = components([box([0, 0], [1, 1]), box([3, 0], [4, 1]), box([1, 1], [2, 2])])
    >>> sorted(len(g) for g in groups)
    [1, 2]
    """
    n = len(leaves)
    if n == 0:
        return []
    lo = np.array([leaf.lo for leaf in leaves], float)
    hi = np.array([leaf.hi for leaf in leaves], float)
    eps = 1e-12 * (1.0 + float(np.max(np.abs(hi))))
    axis = int(np.argmax(np.max(hi, axis=0) - np.min(lo, axis=0)))
    order = np.argsort(lo[:, axis], kind="stable")
    lo, hi = lo[order], hi[order]
    rows, cols = [], []
    for i in range(n):
        # Boxes after i in the sweep that begin before i ends along the axis.
        end = int(np.searchsorted(lo[:, axis], hi[i, axis] + eps, side="right"))
        if end <= i + 1:
            continue
        touch = np.all(lo[i + 1:end] <= hi[i] + eps, axis=1) & \
            np.all(lo[i] <= hi[i + 1:end] + eps, axis=1)
        j = i + 1 + np.flatnonzero(touch)
        rows.append(np.full(len(j), i))
        cols.append(j)
    edges = (np.concatenate(rows), np.concatenate(cols)) if rows else ([], [])
    graph = sp.coo_matrix((np.ones(len(edges[0])), edges), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    groups = {}
    for i in range(n):
        groups.setdefault(int(label[i]), []).append(leaves[order[i]])
    return list(groups.values())
