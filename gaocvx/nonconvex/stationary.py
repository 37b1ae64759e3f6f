"""Every equilibrium of a beam above the convexity limit (k = 1 unstable mode; k = 2 in
:mod:`.stationary2`).

At an equilibrium the gradient in the stable directions vanishes, and for
given amplitudes ``s`` of the unstable modes the energy is strictly convex in
the rest, so ``v*(s)`` is unique: the equilibria are exactly the stationary
points of the reduced function ``F(s) = min_v Psi(s, v) - c s^2``
(nonconvex.md), whose derivative comes with each fixed-amplitude solve
(envelope theorem): :meth:`.fast.FastProgram.reduced` (banded, no
obstacle) or, with an obstacle or channel, :class:`.slices.ContactSlices`
(banded, on a :class:`.fast_contact.FastContactProgram`), both the default
and up to ``api.MAX_FAST_ELEMENTS``; :meth:`.node.NodeProgram.reduced`
(dense CVXPY programs, at most ``minimum.MAX_ELEMENTS``) with ``fast=False``.
So:

1. every equilibrium has its amplitude in ``[-S, S]`` (:func:`.bounds.equilibrium_box`);
2. ``F'`` is sampled on a grid over it (and at ``seeds``, e.g. the previous
   load step's equilibria on a path); where it changes sign, or comes close
   to zero between grid points (two roots close together), Brent's method
   finds its zeros;
3. each zero is classified: ``F'' > 0`` (``F'`` rising through zero, or a
   kink from negative to positive, where an obstacle starts to hold the
   beam) is a local minimum of the energy (stable); ``F'' < 0`` an unstable
   equilibrium (for k = 1: a local maximum of ``F``);
4. with an obstacle, an end of the admissible amplitudes where ``F`` rises
   into the range is a local minimum of the energy too (stable): a beam
   pressed flat onto an obstacle at gap 0.

Below the limit (k = 0) the one equilibrium is the convex minimiser.

Examples
--------
>>> from gaocvx import Scene
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"axial": 1.3e9}, "mesh": {"elements": 8}})
>>> eqs = equilibria(scene)                 # q = 0: w = 0 between two mirror images
>>> [e.stable for e in eqs], round(eqs[2].energy, 6)
([True, True, False], 0.0)
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from ..discrete import DiscreteProblem
from ..errors import SceneError, SolverError
from ..scene import check_solve_arguments, numbers_of, whole
from .bounds import check_bounded, equilibrium_box, estimate_boxes, zoom_boxes
from .completeness import proven_roots
from .contours import sampled_roots
from .equilibrium import Equilibrium, check_has_minimum, check_mountain_pass, same_point
from .images import complete_beams
from .obstacle_checks import check_contact, exact_flat, global_minimisers
from .whole_beam import polisher, settle
from .zooms import own_scale

__all__ = ["Equilibrium", "equilibria", "GRID", "MAX_GRID"]

log = logging.getLogger(__name__)

# Grid points of F' over the amplitude range (odd: s = 0 is one of them, the
# trivial equilibrium of an unloaded beam).
GRID = 121
# At most this many (each is a solve of the reduced function): a bound on the
# work a typo can ask for, far above any grid that resolves more roots.
MAX_GRID = 100_000
# |F'(s)| |s| at a zero, relative to the equilibrium's energy scale (sum of
# |energy parts|), at most (the node programs' own accuracy is about 1e-10).
ROOT_TOL = 1e-8
# Zeros of F' closer than this (times the amplitude range S) to a listed one are
# not told apart by the proof that none is missing (the probes' distance).
RHO = 1e-6
# The fixed-amplitude solves' accuracy in F', relative to its local size (Newton's
# method to round-off on the slices; the proof takes it as given).
DERIVATIVE_TOL = 1e-9


def _convex_equilibrium(scene, elements, dp) -> list:
    from ..solve import solve
    r = solve(scene, "global", elements=elements)
    return [Equilibrium(r.energy, True, [], r.x, r.w, r.slope, 0.0, r.status,
                        float(scene.load.axial), complete=True)]


def equilibria(scene, elements: int | None = None, seeds=(), grid: int = GRID,
               fast: bool | None = None) -> list:
    """Every equilibrium of ``scene`` (k <= 2 unstable modes), sorted by energy.

    With one unstable mode the zeros of the reduced gradient are bracketed on a
    grid; with two the plane of amplitudes is sampled (:mod:`.stationary2`: no
    proof that none is missed; with an obstacle the certified global minimiser
    is among the starts).

    Parameters
    ----------
    scene : Scene or Mapping
        A dict with the structure of a scene file is validated into a Scene.
    elements : int, optional
        Overrides ``scene.mesh.elements``; checked as :func:`gaocvx.solve`
        checks it (a whole number in [1, 10^6]: ``8.0`` and numpy integers
        are accepted, ``2.5``, ``"8"`` and bools are not).
    seeds : sequence of float, optional
        Amplitudes [m] (:attr:`Equilibrium.amplitude_m`) to sample besides the
        grid: a path's previous equilibria (one unstable mode; two ignore them).
    grid : int
        Grid points over the amplitude range, 2 to :data:`MAX_GRID` (one
        unstable mode; two sample their own ``stationary2.GRID2`` square).
    fast : bool, optional
        The reduced function through the banded Newton machinery
        (:class:`.fast.FastProgram`; with an obstacle or channel
        :class:`.slices.ContactSlices`; any mesh up to ``api.MAX_FAST_ELEMENTS``)
        instead of the dense CVXPY programs (:class:`.node.NodeProgram`, the
        reference, at most ``minimum.MAX_ELEMENTS``).  By default the fast
        path, with or without an obstacle (see docs/nonconvex.md for the
        measured comparison).

    Returns
    -------
    list of Equilibrium

    Raises
    ------
    SceneError
        For an argument out of range (naming it: ``scene``, ``elements``,
        ``seeds``, ``grid``, ``fast``), for scenes with more than two unstable
        modes, without a minimiser, or on too fine a mesh (above
        ``api.MAX_FAST_ELEMENTS`` elements, or above ``minimum.MAX_ELEMENTS``
        with ``fast=False``).
    SolverError
        When a solve failed at a zero of the reduced gradient, or no
        equilibrium was found, on the dense programs or beyond them (the fast
        path hands such a scene to the dense programs where they serve).
    """
    from .api import MAX_FAST_ELEMENTS, provably_convex
    from .minimum import MAX_ELEMENTS, rescale_for, scene_energy
    from .modes import MAX_UNSTABLE, unstable_modes
    from .node import NodeProgram

    # The checks of solve(): below the limit the answer is solve(scene, "global")'s.
    scene = check_solve_arguments(scene, "global", elements)
    seeds = numbers_of("seeds", seeds)
    grid = whole("grid", grid, 2, MAX_GRID)
    if fast is not None and not isinstance(fast, (bool, np.bool_)):
        raise SceneError("fast", "must be True, False or None", fast)
    dp = DiscreteProblem(scene, elements=elements, check_convexity=False)
    if provably_convex(dp):
        return _convex_equilibrium(scene, elements, dp)
    check_bounded(dp)
    n_el = dp.n_nodes - 1
    obstacle = dp.contact == "obstacle"
    # The fast path by default, with an obstacle or channel too: on 40 random
    # campaign scenes of 8-32 elements checked against the independent energy
    # (tests/test_equilibria_obstacle_campaign.py) it missed nothing the dense
    # programs found and reported no wrong `optimal` answer, while the dense
    # programs missed equilibria and called non-stationary deflections optimal
    # (docs/nonconvex.md); and it is 1.5-50 times faster.
    fast = True if fast is None else bool(fast)
    cap = MAX_FAST_ELEMENTS if fast else MAX_ELEMENTS
    if n_el > cap:
        raise SceneError("mesh.elements", f"equilibria above the convexity limit take at most "
                         f"{MAX_FAST_ELEMENTS} elements (fast path; the dense programs, "
                         f"fast=False, at most {MAX_ELEMENTS})", n_el)
    modes = unstable_modes(dp)
    if modes.k == 0:
        modes = unstable_modes(dp, min_k=1)
    if modes.k > 2:
        count = f"more than {MAX_UNSTABLE}" if modes.k > MAX_UNSTABLE else str(modes.k)
        raise SceneError("load.axial", f"P = {dp.P:.4g} N leaves {count} unstable buckling "
                         "modes; equilibria are searched for one or two (P below the third "
                         f"mode load {float(modes.loads[2]):.4g} N)", dp.P)
    dp = rescale_for(dp, modes)

    def program(dp):
        if fast and obstacle:
            from .fast_contact import FastContactProgram
            from .slices import ContactSlices
            return ContactSlices(FastContactProgram(dp, modes), scene_energy(dp, modes))
        if fast:
            from .fast import FastProgram
            return FastProgram(dp, modes)
        return NodeProgram(dp, modes)

    def admissible(prog):
        # the admissible amplitudes' range of prog's node program
        ranged = prog.prog if fast else prog
        return np.asarray(ranged.smin, float), np.asarray(ranged.smax, float)

    prog = program(dp)
    polish = polisher(dp, modes)
    # (with a bonded foundation the modes' lambda_1 is that of K + c M: no bound
    # of u'K u / t, so none is used; equilibrium_box counts the foundation itself)
    lam1 = 0.0 if getattr(dp, "bilateral", False) else float(modes.lam[0]) * (1.0 - 1e-9)
    S = float(equilibrium_box(dp, lam1))
    lo, hi = np.full(modes.k, -S), np.full(modes.k, S)
    if obstacle:
        # The grid over the admissible amplitudes only: a channel of 2 mm in a scale
        # of 17 cm (the one-mode estimate's) left one grid point of 121 admissible
        # (s = 0), and two of three equilibria were missed; with two modes the dense
        # programs, without it, missed a stable pair in a 2 mm channel.  The range
        # is a linear program's, its ends bounds by weak duality
        # (:func:`.fast_check.lp_ranges`; both node programs compute it on
        # construction).
        smin, smax = admissible(prog)
        lo, hi = np.maximum(lo, smin), np.minimum(hi, smax)
    complete = None    # (two modes: a sampling, no proof)
    if modes.k == 2:
        from .stationary2 import find_plane
        glob = global_minimisers(dp, modes) if obstacle else []
        out = find_plane(dp, prog, S, floor=scene_energy(dp, modes), modes=modes,
                         starts=[np.asarray(e.amplitudes, float) for e in glob], box=(lo, hi),
                         minimisers=glob)

        def own_search(d):
            # the square [-1, 1]^2 of d's units, within its admissible amplitudes
            p = program(d)
            smin, smax = admissible(p)
            box = (np.maximum(-1.0, smin), np.minimum(1.0, smax))
            found = find_plane(d, p, 1.0, floor=scene_energy(d, modes), modes=modes, box=box,
                               zoom=False)
            # (polished on the whole beam where that succeeds, as the first search's)
            return settle(d, polisher(d, modes), found, 1.0, modes)

        if obstacle and None not in out:
            # the flat beam's neighbourhood again, in its own scale (:mod:`.zooms`)
            out = sorted(own_scale(dp, modes, out, S, lo, hi, own_search),
                         key=lambda e: e.energy)
    else:
        # finer grids where the one-mode estimate puts the buckled beam, when the
        # box is far wider (bounds.estimate_boxes), and, with an obstacle, where
        # the mode reaches a surface of it, as with two modes (a P3 beam held at
        # a ceiling 1.8e-5 m up, 48 elements: that stable equilibrium and an
        # unstable one lay within one step of the grid over S = 82 times the
        # amplitude there -- extreme-scale campaign)
        boxes = estimate_boxes(dp, modes, lo, hi) + (zoom_boxes(dp, modes, lo, hi)
                                                     if obstacle else [])
        points = np.concatenate([np.asarray(seeds, float) / dp.W]
                                + [np.linspace(a[0], b[0], grid) for a, b in boxes])
        out, complete = _find(dp, prog, S, points, grid, float(lo[0]), float(hi[0]),
                              scene_energy(dp, modes), float(modes.c[0]), polish)
        if obstacle:
            check_contact(dp, prog, out, polish, S)
        if obstacle and None not in out:
            def classify(s):
                def dF(t):   # (one solve per probe)
                    F, d = prog.reduced([t])[:2]
                    return F, float(d[0])
                return _classify(dF, 0.0, 1e-6 * S)
            # (the beams near the flat one polished on the whole beam, listed once)
            out = sorted(settle(dp, polish, exact_flat(dp, modes, out, classify, S=S), S,
                                modes),
                         key=lambda e: e.energy)
    if obstacle and None not in out:
        # the mirror image of each beam polished on the whole beam (:mod:`.images`)
        out = sorted(complete_beams(dp, polish, out), key=lambda e: e.energy)
    if out and all(e is not None for e in out):
        for e in out:
            parts = dp.energy_parts(dp.from_physical(e.w, e.slope))
            e.energy_scale = float(sum(abs(v) for v in parts.values()) * dp.E0)
            e.complete = complete
        check_has_minimum(out)
        check_mountain_pass(out)
        return out
    # A zero of F' whose slice failed, or no equilibrium at all (the global
    # minimiser is always one): the list would be wrong without saying so.  A
    # campaign scene (P1 pressed flat at gap 0, 16 elements) had its only
    # equilibrium's slice fail on the fast path.  The dense programs answer it
    # where they serve; beyond them, or when they were asked for, it is an error.
    if fast and obstacle and n_el <= MAX_ELEMENTS:
        log.warning("equilibria: a contact slice failed at a zero of F'; the dense programs "
                    "take over")
        return equilibria(scene, elements=elements, seeds=seeds, grid=grid, fast=False)
    raise SolverError("equilibria: the reduced function's solve failed at a zero of F' "
                      "(or no equilibrium was found); no list of equilibria is given",
                      "error")


def _classify(dF, r, h) -> tuple:
    """``(stable, curvature)`` of a zero ``r`` of F' from F' at ``r -+ h``.

    A minimum of F has F' < 0 to its left and > 0 to its right; a side
    outside the admissible amplitudes (an obstacle's edge: ``F = inf`` there)
    counts as rising, for F cannot be lowered that way.  (Taking the probe's
    F' = 0 outside the range for a slope labelled a flat beam held by a gap-0
    obstacle, the certified global minimiser, unstable: a trial's P4 beam under
    a load table with unloaded ends at 1.02 P_bar_h.)
    """
    mid = dF(r)[1]
    left, right = (dF(r + t) for t in (-h, h))
    fl, fr = math.isfinite(left[0]), math.isfinite(right[0])
    if fl and fr:
        # (the lesser one-sided curvature: at a kink of F's curvature -- a flat
        # beam lifting off a bed at gap 0 -- the central difference averages a
        # falling side with a rising one, and the label is the sides')
        curvature = min(right[1] - mid, mid - left[1]) / h
        if right[1] != left[1]:
            return bool(left[1] < 0 < right[1]), curvature
        return bool(curvature > 0), curvature
    if not (fl or fr):
        return False, math.nan
    curvature = (right[1] - mid) / h if fr else (mid - left[1]) / h
    return bool(right[1] > 0 if fr else left[1] < 0), curvature


def _find(dp, prog, S, seeds, grid, lo, hi, floor, c, polish=None) -> tuple:
    """The equilibria with amplitudes in ``[lo, hi]`` and whether the sign bound
    proved that the list misses none (:func:`.completeness.proven_roots`)."""
    t0 = time.perf_counter()
    cache = {}

    def dF(s):
        if s not in cache:
            F, d, u, ok = prog.reduced([s])
            cache[s] = (F, float(d[0]), u, ok)
        return cache[s]

    def at_an_end(t):
        # With one mode the admissible amplitudes are the interval [lo, hi] (the
        # linear program's, widened by fast_check.RANGE_PAD relative): F = inf
        # strictly inside it is a failed slice, no edge.  (A P1 beam in a channel
        # 1.2e-8 m high, 6 elements: slices failing inside the range made a fake
        # edge, reported as an `optimal` stable equilibrium where a feasible step
        # lowers the energy by 4 % -- a campaign at extreme scales.)
        from .fast_check import RANGE_PAD
        tol = max(1e-6 * (hi - lo), 4.0 * RANGE_PAD * (1.0 + max(abs(lo), abs(hi))))
        return t <= lo + tol or t >= hi - tol

    inside = seeds[(seeds >= lo) & (seeds <= hi)]
    if lo <= 0.0 <= hi:   # the trivial equilibrium of an unloaded beam
        inside = np.r_[inside, 0.0]
    sampled = [float(s) for s in np.union1d(np.linspace(lo, hi, grid), inside)]
    for s in sampled:
        dF(s)
    # An obstacle bounds the amplitudes (a beam lying flat on it has the smallest):
    # where the grid steps from infeasible to feasible, the boundary is found by
    # bisection and sampled just inside, else a beam pressed onto the obstacle
    # (a zero of F' right next to the boundary, where F' falls steeply) is missed.
    extra, ends = [], []
    for a, b in zip(sampled[:-1], sampled[1:]):
        va, vb = dF(a), dF(b)   # (a's may have been solved again below)
        if math.isfinite(va[0]) != math.isfinite(vb[0]):
            inside, outside = (b, a) if math.isfinite(vb[0]) else (a, b)
            for _ in range(40):
                mid = 0.5 * (inside + outside)
                # (an inaccurate solve counts as outside: at gap 0 the fast slices
                # accept a violation of 1e-9 as admissible but not accurate)
                if math.isfinite(dF(mid)[0]) and dF(mid)[3]:
                    inside = mid
                else:
                    outside = mid
            lost = b if math.isfinite(va[0]) else a
            if not at_an_end(lost) and hasattr(prog, "cold"):
                # A contact slice failed strictly inside the range: solved again, warm
                # from the bisection's slice next to it (P1 pressed flat in a channel
                # at gap 0 near P_bar_h: the slice at s = 0.0032, warm from the flat
                # beam's and cold, stalled at a violation of 1.9e-9; the bisection on
                # either side reached it, and its fake edge was listed as a stable
                # `inaccurate` entry, no equilibrium -- a random campaign)
                del cache[lost]
                if math.isfinite(dF(lost)[0]):
                    continue
            extra.append((inside, dF(inside)))
            ends.append((inside, outside))
    vals = sorted([(s, v) for s, v in [(s, dF(s)) for s in sampled] + extra
                   if math.isfinite(v[0])], key=lambda item: item[0])
    if not vals:
        raise SceneError("scene", "no admissible amplitude of the buckling mode (no solve "
                         "succeeded)")
    scale = max(max(abs(v[0]) for _, v in vals), 1e-300)
    # sign changes of F' and pairs of zeros between neighbouring grid points (a
    # local extremum of F' near zero: the test was once sign * F' < 0 at the
    # extremum, right for a minimum of F' only -- a flat beam held by a gap-0
    # obstacle, a stable equilibrium, and the unstable one next to it were missed
    # under a load table with unloaded ends)
    roots = sampled_roots(lambda s: dF(s)[1], [s for s, _ in vals], [v[1] for _, v in vals], S)
    # the sign bound's proof that no zero is missing (:mod:`.completeness`), with
    # the zeros its samples reveal.  F' counts as possibly zero within
    # DERIVATIVE_TOL of its local size (the concave part's 2 c S, or F' at the
    # interval's ends): the fixed-amplitude solves' accuracy.  (Not the zeros'
    # residual test, which passed |F'| up to 3e-4 of its size 2e-4 S from an
    # unstable zero; nor F''s largest size over the range, 4e5 next to an
    # obstacle's edge, for which the bound could not come within 1e-6 S of a
    # stable zero where F'' = 81 -- both campaign scenes.)
    def slope(s):
        return dF(s)[1] if math.isfinite(dF(s)[0]) and dF(s)[3] else math.nan

    roots, complete = proven_roots(
        slope, [s for s, _ in vals], roots, [inside for inside, _ in ends], c,
        lambda a, b: DERIVATIVE_TOL * (2.0 * c * S + max(abs(slope(a)), abs(slope(b)))),
        RHO * S)

    failed = [t for t in sampled if not math.isfinite(dF(t)[0]) and not at_an_end(t)]
    if failed and not complete:   # (proven complete, nothing lies there)
        # (the list may then miss equilibria there: a P4 beam in a channel 3.8e-6 m
        # high had its slices fail over most of the range -- extreme-scale campaign)
        log.warning("equilibria: the slices failed at %d of %d sampled amplitudes inside the "
                    "admissible range; equilibria there may be missing from the list",
                    len(failed), len(sampled))
    out = []
    # An end of the admissible amplitudes where F rises into the range (F' > 0 at
    # the lower end, < 0 at the upper) is a local minimum of F there, so of the
    # energy: every admissible beam nearby has amplitudes in the range.  A beam
    # pressed flat onto an obstacle at gap 0 is one (F(s) = 0.44 s at s >= 0 on 16
    # elements, P4): no zero of F' marks it.  Its residual is |F'| times the
    # bisection's bracket (the end lies in it).
    for inside, outside in ends:
        F, d0, u, ok = dF(inside)
        if u is None or not (d0 > 0 if outside < inside else d0 < 0):
            continue
        roots = [r for r in roots if abs(r - inside) > 1e-9 * S]
        w, slope = dp.to_physical(u)
        size = max(sum(abs(v) for v in dp.energy_parts(u).values()), floor) or scale
        res = abs(d0) * abs(outside - inside) / size
        status = "optimal" if ok and res <= ROOT_TOL and at_an_end(outside) else "inaccurate"
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), True, [float(inside)], dp.x.copy(),
                               w, slope, float(res), status, float(dp.P), math.nan, float(dp.W)))
    for r in sorted(set(roots)):
        if any(abs(r - e) <= 1e-9 * S for e in [q.amplitudes[0] for q in out]):
            continue
        F, d0, u, ok = dF(r)
        if u is None:   # (a slice that failed inside the range: no beam to report)
            log.warning("equilibria: no admissible slice at the zero s = %.17g", r)
            out.append(None)   # (the caller's: the list is incomplete)
            continue
        # (probes closer than the nearest other zero: a P2 beam 9.8e-10 m into a
        # bed 8.4e-10 m below, 1.8e-6 S from w = 0, was called unstable from
        # probes 3e-6 S wide that straddled w = 0 -- an extreme-scale campaign)
        # (other zeros only, beyond the merging distance: an edge's probe beyond
        # it counts as rising anyway)
        near = [abs(q - r) for q in set(roots) if abs(q - r) > 1e-9 * S]
        h = max(min([1e-6 * S] + [0.25 * q for q in near]), 1e-10 * S)
        stable, curvature = _classify(dF, r, h)
        # (an inadmissible probe counts as rising only at an end of the range:
        # inside it the slice failed, and the stability is not known)
        undecided = any(not math.isfinite(dF(t)[0]) and not at_an_end(t) for t in (r - h, r + h))
        w, slope = dp.to_physical(u)
        # |F'| times the amplitude: the work of the residual force, relative to
        # the equilibrium's energy scale (w = 0: the amplitude range's thousandth)
        # (at least the scene's own energy: a trivial equilibrium the dense
        # programs return as 1e-13 instead of 0 has energy parts of 1e-16, against
        # which any residual was too large)
        own = sum(abs(v) for v in dp.energy_parts(u).values())
        size = max(own, floor) or scale
        res = abs(d0) * max(abs(r), 1e-3 * S) / size
        if polish is not None and ok and res <= ROOT_TOL < res * size / max(own, 1e-300):
            # a zero to the scene's accuracy but not to its own (near the flat beam):
            # polished on the whole beam, and listed as that returns it, if it does
            # (:mod:`.whole_beam`)
            polished = polish(u)
            if polished is not None and same_point(polished.amplitudes, [r], S):
                out.append(polished)
                continue
        if res > ROOT_TOL:
            # A kink of F (the obstacle takes or releases the beam: a beam lying flat
            # at gap 0 between supports has F(s) = 0.55 |s| on 16 elements, P1): F'
            # jumps through zero (upwards: F is convex but for -c s^2) and |F'| at the
            # zero stays large.  The equilibrium lies between r - e and r + e when F'
            # changes sign there, and the energy within |F'| 2e of F(r).  (The
            # slices of amplitudes 1e-12 from a flat beam's are round-off: wider
            # windows after the narrowest.)
            # An edge of the admissible amplitudes within e of r (the obstacle holds
            # the beam flat: no amplitude on one side) with F rising into the range
            # is a minimum of F there, so of the energy, as at the ends above (a
            # trial's P4 beam at gap 0 under a load of 1e5 N/m at 2 P_bar_h: the
            # flat beam's zero had its left probe outside the range and was
            # reported unstable and inaccurate).
            for e in (1e-12 * S, 1e-10 * S, 1e-9 * S):
                a, b = dF(r - e), dF(r + e)
                fa, fb = math.isfinite(a[0]), math.isfinite(b[0])
                if fa and fb and a[1] * b[1] < 0:
                    res = min(res, max(abs(a[1]), abs(b[1])) * 2 * e / size)
                    stable = a[1] < 0
                    break
                if fa != fb and (b[1] > 0 if fb else a[1] < 0) and \
                        at_an_end(r + e if fa else r - e):
                    res = min(res, abs((b if fb else a)[1]) * e / size)
                    stable = True
                    break
        status = "optimal" if ok and res <= ROOT_TOL and not undecided else "inaccurate"
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), bool(stable), [float(r)], dp.x.copy(),
                               w, slope, float(res), status, float(dp.P), float(curvature),
                               float(dp.W)))
    if None in out:
        return [None], False
    out.sort(key=lambda e: e.energy)
    log.info("equilibria: %d found with %d solves in %.2f s (%s)", len(out), len(cache),
             time.perf_counter() - t0, "none missed" if complete else "not proven complete")
    return out, complete
