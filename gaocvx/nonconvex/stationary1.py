"""The equilibria of one unstable mode: the zeros of ``F'`` along its amplitude.

:func:`find_line` samples ``F'`` (the reduced gradient, one fixed-amplitude solve
per point) over the admissible amplitudes, refines each sign change and each
close pair of zeros (:func:`.contours.sampled_roots`), locates the edges an
obstacle puts to the amplitudes, proves that no zero is missing
(:mod:`.completeness`), takes zeros between which F' is round-off for one
(:func:`.roundoff.noise_clusters`), and labels each zero stable or unstable from
probes where F' rises above its round-off (:func:`.probes.classify`, :mod:`.roundoff`);
each zero is refined and measured in its beam's own scale (:mod:`.zero_step`).
:func:`.stationary.equilibria` calls it and polishes what it finds;
:mod:`.stationary2` is its counterpart for two modes.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from ..errors import SolverError
from .completeness import proven_roots
from .contours import sampled_roots
from .equilibrium import Equilibrium, same_point
from .probes import classify
from .roundoff import (EPS, LABEL_NOISE, MERGE_NOISE, NOISE, label_threshold, noise_clusters,
                       round_off, settled, widened)
from .zero_step import STEP_TOL, own_step

__all__ = ["find_line", "ROOT_TOL", "RHO", "DERIVATIVE_TOL", "DENSE_DERIVATIVE_TOL",
           "CONTACT_DERIVATIVE_TOL"]

log = logging.getLogger(__name__)

# |F'(s)| |s| at a zero, relative to the equilibrium's energy scale (sum of
# |energy parts|), at most (the node programs' own accuracy is about 1e-10).
ROOT_TOL = 1e-8
# Zeros of F' closer than this (times the amplitude range S) to a listed one are
# not told apart by the proof that none is missing (the probes' distance).
RHO = 1e-6
# The fixed-amplitude solves' accuracy in F', relative to its local size, as the
# proof takes it: Newton's method to round-off on the fast slices; the dense
# programs' duals (Clarabel) differ from those by up to 3.8e-9 (P4, 12 elements,
# with and without an obstacle).
DERIVATIVE_TOL = 1e-9
DENSE_DERIVATIVE_TOL = 1e-7
# The contact slices accept violations of 1e-9 and their active sets kink F':
# taken ten times looser than the smooth slices.
CONTACT_DERIVATIVE_TOL = 1e-8


def memoised(prog):
    """``dF(s) -> (F, F', u, ok)`` at a scalar amplitude ``s``, ``prog.reduced([s])``
    solved once per ``s``; the solves are kept in ``dF.cache`` (the grid, the
    bisections and the stability probes, of :func:`find_line` and of
    :func:`.stationary.flat_classifier`, share them).
    """
    cache = {}

    def dF(s):
        if s not in cache:
            F, d, u, ok = prog.reduced([s])
            cache[s] = (F, float(d[0]), u, ok)
        return cache[s]

    dF.cache = cache
    return dF


def find_line(dp, prog, S, seeds, grid, lo, hi, floor, c, polish=None,
              dtol=DERIVATIVE_TOL, probe_tol=0.0, dF=None, zero_floor=None) -> tuple:
    """The equilibria with amplitudes in ``[lo, hi]`` and the proof that none is missed.

    Parameters
    ----------
    dp : DiscreteProblem
        The problem in the units of the search (:func:`.scales.rescale_for`).
    prog
        The reduced function: ``prog.reduced([s]) -> (F, F', u, ok)`` (``F = inf``
        where no admissible beam has the amplitude ``s`` or the slice failed).
    S : float
        The amplitude range's scale (:func:`.bounds.equilibrium_box`).
    seeds : ndarray
        Amplitudes sampled besides the grid (a path's previous equilibria).
    grid : int
        Grid points over ``[lo, hi]``.
    lo, hi : float
        The admissible amplitudes (the linear program's range with an obstacle).
    floor : float
        The scene's energy scale (:func:`.scales.scene_energy`).
    c : float
        The concave coefficient ``modes.c[0]`` (F + c s^2 convex).
    polish : callable, optional
        Polishes a zero on the whole beam (:func:`.whole_beam.polisher`).
    dtol : float
        F''s accuracy relative to its local size, as the proof takes it.
    probe_tol : float
        The accuracy the stability probes' F' must clear, relative to ``2 c S``
        (:func:`.roundoff.label_threshold`): the dense programs' ``dtol``; 0 for
        the Newton slices, known to their round-off.
    dF : callable, optional
        ``prog``'s reduced function memoised (:func:`memoised`), to share its
        solves with the caller; a new one by default.
    zero_floor : float, optional
        Under load, the deflection [m] below which a beam counts as zero, the
        floor of each zero's own-scale Newton step (:func:`.zero_step.own_step`);
        None without load.

    Returns
    -------
    equilibria : list of Equilibrium
        Sorted by energy; ``[None]`` when a slice failed at a zero.
    complete : bool
        The sign bound's proof that no zero of F' lies farther than ``RHO S``
        from a listed one (:func:`.completeness.proven_roots`), the range's ends
        included.
    """
    t0 = time.perf_counter()
    dF = memoised(prog) if dF is None else dF
    cache = dF.cache

    def at_an_end(t):
        # With one mode the admissible amplitudes are the interval [lo, hi] (the
        # linear program's, widened by fast_check.RANGE_PAD relative): F = inf
        # strictly inside it is a failed slice, no edge.  (A P1 beam in a channel
        # 1.2e-8 m high, 6 elements: slices failing inside the range made a fake
        # edge, reported as an `optimal` stable equilibrium where a feasible step
        # lowers the energy by 4 % -- a campaign at extreme scales.)
        return at_lower(t) or at_upper(t)

    def end_tol():
        from .fast_check import RANGE_PAD
        return max(1e-6 * (hi - lo), 4.0 * RANGE_PAD * (1.0 + max(abs(lo), abs(hi))))

    def at_lower(t):
        return t <= lo + end_tol()

    def at_upper(t):
        return t >= hi - end_tol()

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
        # (w = 0 is admissible -- every surface lies at a gap >= 0 -- so this is the
        # solves' failure, not the scene's: a ceiling 1e-60 m above a floor at gap 0
        # under q = -1e7 N/m, a load of 8e57 in the channel's units)
        raise SolverError("equilibria: no fixed-amplitude solve of the buckling mode "
                          "succeeded", "solver_error")
    scale = max(max(abs(v[0]) for _, v in vals), 1e-300)
    # sign changes of F' and pairs of zeros between neighbouring grid points (a
    # local extremum of F' near zero: the test was once sign * F' < 0 at the
    # extremum, right for a minimum of F' only -- a flat beam held by a gap-0
    # obstacle, a stable equilibrium, and the unstable one next to it were missed
    # under a load table with unloaded ends)
    roots = sampled_roots(lambda s: dF(s)[1], [s for s, _ in vals], [v[1] for _, v in vals], S)
    # the sign bound's proof that no zero is missing (:mod:`.completeness`), with
    # the zeros its samples reveal.  F' counts as possibly zero within
    # dtol of its local size (the concave part's 2 c S, or F' at the
    # interval's ends): the fixed-amplitude solves' accuracy.  (Not the zeros'
    # residual test, which passed |F'| up to 3e-4 of its size 2e-4 S from an
    # unstable zero; nor F''s largest size over the range, 4e5 next to an
    # obstacle's edge, for which the bound could not come within 1e-6 S of a
    # stable zero where F'' = 81 -- both campaign scenes.)
    def trusted(s):   # F' where the slice is solved and accurate, else NaN
        return dF(s)[1] if math.isfinite(dF(s)[0]) and dF(s)[3] else math.nan

    noise_at = {}

    def noise(t, u):   # (F''s round-off at t: a floor under the proof's tolerance)
        if t not in noise_at:
            noise_at[t] = round_off(dp, u, t)
        return noise_at[t]

    def tol(a, b):
        # (at least F''s round-off: without load 1e-11 above P_bar_h it was 5e3
        # times dtol's share, and the proof took F' as known far below it)
        floor = max(noise(t, dF(t)[2]) if dF(t)[2] is not None else 0.0 for t in (a, b))
        return max(dtol * (2.0 * c * S + max(abs(trusted(a)), abs(trusted(b)))), floor)

    # (the ends listed as equilibria below only: F rising into the range there)
    held = [e for e, out in ends if dF(e)[2] is not None and
            (dF(e)[1] > 0 if out < e else dF(e)[1] < 0)]
    roots, complete = proven_roots(trusted, [s for s, _ in vals], roots, held, c, tol, RHO * S)

    failed = [t for t in sampled if not math.isfinite(dF(t)[0]) and not at_an_end(t)]
    # The proof spans the solved amplitudes; between the last of them and the
    # linear program's end of the range (where the slices failed, or the bisection
    # stopped at a failed slice) only the end's own bound speaks: no zero in
    # [lo, a) when F'(a) < -2c (a - lo), none in (b, hi] when F'(b) > 2c (hi - b),
    # and then no edge minimum either (F falls into the range).  (A P4 beam in a
    # channel 3.8e-6 m high, extreme-scale campaign: slices failed from s = 9.2e-4
    # up to the range's end, the bisection's edge there was taken for the range's,
    # and the list was called proven.)
    # A gap no wider than RHO S is the proof's resolution, where an end listed as an
    # equilibrium lies in it; each end is checked on its own side (a review's trial:
    # slices failing on all but the last 1e-7 of the range passed "at an end" at the
    # wrong one, and a fake edge was listed, `optimal`, in a list called proven).
    solved = [t for t, _ in vals if math.isfinite(trusted(t))]

    def closed(a, end, sign):   # the gap between the solved a and the range's end
        gap = abs(a - end)
        return gap == 0.0 or sign * trusted(a) > 2.0 * c * gap + tol(a, a) or \
            (gap <= RHO * S and any(abs(e - a) <= RHO * S for e in held))

    if not (solved and closed(solved[0], lo, -1.0) and closed(solved[-1], hi, 1.0)):
        complete = False
    if failed and not complete:   # (where the proof holds, nothing lies there)
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
        size = max(dp.energy_size(u), floor) or scale
        res = abs(d0) * abs(outside - inside) / size
        # (the end of its own side: a lower edge next to the upper end is a fake one --
        # slices failing on all but the last 1e-7 of the range, a review's trial)
        real = at_lower(outside) if outside < inside else at_upper(outside)
        status = "optimal" if ok and res <= ROOT_TOL and real else "inaccurate"
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), True, [float(inside)], dp.x.copy(),
                               w, slope, float(res), status, float(dp.P), math.nan, float(dp.W)))

    # (a zero within 1e-9 S of s = 0 where F' is exactly 0, w = 0 without load, is
    # that one: Brent's 1.9e-68 beside it was listed as a beam 3.4e-69 m high, its
    # own-scale Newton step its whole size -- P3 on a bed, unloaded: a campaign)
    if lo <= 0.0 <= hi and any(0.0 < abs(r) <= 1e-9 * S for r in roots):
        _, slope0, beam0, ok0 = dF(0.0)
        if slope0 == 0.0 and beam0 is not None and ok0:
            roots = [0.0 if abs(r) <= 1e-9 * S else r for r in roots]
    zeros = []   # (within 1e-9 S of an end or a zero before it: the same one)
    for r in sorted(set(roots)):
        if not any(abs(r - e) <= 1e-9 * S for e in [q.amplitudes[0] for q in out] + zeros):
            zeros.append(r)
    # (zeros between which F' is round-off are one equilibrium; the proof no longer
    # places every zero within RHO S of a listed one: the merged ones may lie as far
    # as the group is wide)
    groups = noise_clusters(zeros, dF, lambda t, u: MERGE_NOISE / NOISE * noise(t, u),
                            sorted(cache))
    if any(len(g) > 1 for g in groups):
        complete = False

    threshold = label_threshold(noise, probe_tol, c, S)

    def probed(t):   # F' at a probe beyond its round-off and the slices' accuracy
        return settled(dF, threshold, t)

    for g in groups:
        # (probes closer than the nearest other zero: a P2 beam 9.8e-10 m into a
        # bed 8.4e-10 m below, 1.8e-6 S from w = 0, was called unstable from
        # probes 3e-6 S wide that straddled w = 0 -- an extreme-scale campaign)
        # (other zeros only, beyond the merging distance: an edge's probe beyond
        # it counts as rising anyway)  A group is probed beyond its ends, from its
        # middle.
        mid, half = 0.5 * (g[0] + g[-1]), 0.5 * (g[-1] - g[0])
        near = [abs(q - mid) - half for q in zeros if q not in g]
        near = [q for q in near if q > 1e-9 * S]
        h = half + max(min([1e-6 * S] + [0.25 * q for q in near]), 1e-10 * S)
        # Probes where F' is round-off label nothing: widened (within a quarter of
        # the distance to the next zero or the range's end) until F' rises above
        # it, else the label is not known.  (Without load 1e-12 above P_bar_h, F'
        # 4 c h = 3e-20 at h = 1e-6 S, its round-off 1e-19: stable beams labelled
        # unstable -- an equilibria trial.)
        cap = half + min([0.25 * q for q in near] + [0.25 * (g[0] - lo), 0.25 * (hi - g[-1])])
        h, noisy = widened(probed, mid, h, cap)
        stable, curvature = classify(dF, mid, h)
        # A group's minimum of F (F falls into it and rises out of it) is at its
        # lowest zero, its maximum at its highest (with a threshold of 100 eps for
        # the merging, the flat beam -- F' = 0 exactly -- stood for it and the
        # buckled pair beside it, and was listed stable, 1e-14 above P_bar_h: a
        # review); zeros within the energy's round-off of it tie, and the one with the
        # least |F'| is listed (at P_bar_h the flat beam, not a copy 1.8e-10 m off it)
        solved = [q for q in g if dF(q)[2] is not None] or g
        if len(solved) < len(g):   # (the merge marked the list not proven; logged)
            log.warning("equilibria: %d of %d zeros merged at s = %.6g had no slice",
                        len(g) - len(solved), len(g), mid)
        r = solved[0]
        if len(solved) > 1:
            best = (min if stable else max)(dF(q)[0] for q in solved)
            tie = LABEL_NOISE * EPS * max(dp.energy_size(dF(q)[2]) for q in solved)
            r = min([q for q in solved if abs(dF(q)[0] - best) <= tie],
                    key=lambda q: abs(dF(q)[1]))
        # (refined by Newton's method, and the step measured, in the beam's own scale)
        # (F' counts at least its error, as the probes take it)
        r, step = own_step(dp, dF, r, S, threshold, zero_floor)
        F, d0, u, ok = dF(r)
        if u is None:   # (a slice that failed inside the range: no beam to report)
            log.warning("equilibria: no admissible slice at the zero s = %.17g", r)
            out.append(None)   # (the caller's: the list is incomplete)
            continue
        if noisy:
            log.warning("equilibria: F' at the zero s = %.6g is within its round-off or the "
                        "slices' accuracy as far as the probes reach (%.3g); its stability "
                        "is not known", r, h)
        # (an inadmissible probe counts as rising only at an end of the range:
        # inside it the slice failed, and the stability is not known)
        undecided = any(not math.isfinite(dF(t)[0]) and not at_an_end(t)
                        for t in (mid - h, mid + h))
        w, slope = dp.to_physical(u)
        # |F'| times the amplitude: the work of the residual force, relative to
        # the equilibrium's energy scale (w = 0: the amplitude range's thousandth)
        # (at least the scene's own energy: a trivial equilibrium the dense
        # programs return as 1e-13 instead of 0 has energy parts of 1e-16, against
        # which any residual was too large)
        own = dp.energy_size(u)
        size = max(own, floor) or scale
        res = abs(d0) * max(abs(r), 1e-3 * S) / size
        if polish is not None and ok and res <= ROOT_TOL and (
                ROOT_TOL < res * size / max(own, 1e-300) or step > STEP_TOL or undecided
                or noisy):
            # a zero to the scene's accuracy but not to its own (near the flat beam),
            # or one whose probes did not settle its stability: polished on the whole
            # beam (its label from the second-order conditions), and listed as that
            # returns it, if it does (:mod:`.whole_beam`).  (A P4 beam lifted 5.7e-9 m
            # in a channel at gap 0, 32 elements: a probe's slice failed inside the
            # range; once its zero was refined in its own scale, :mod:`.zero_step`,
            # it no longer went to the polish, and stayed `inaccurate`.)
            polished = polish(u)
            if polished is not None and same_point(polished.amplitudes, [r], S):
                out.append(polished)
                continue
        kink = res > ROOT_TOL
        if kink:
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
        # (a zero, not a kink's bracket, also in the beam's own scale: :mod:`.zero_step`)
        own_scale = kink or step <= STEP_TOL
        status = "optimal" if ok and res <= ROOT_TOL and own_scale and not (undecided or noisy) \
            else "inaccurate"
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), bool(stable), [float(r)], dp.x.copy(),
                               w, slope, float(res), status, float(dp.P), float(curvature),
                               float(dp.W)))
    if None in out:
        return [None], False
    out.sort(key=lambda e: e.energy)
    log.info("equilibria: %d found with %d solves in %.2f s (%s)", len(out), len(cache),
             time.perf_counter() - t0, "none missed" if complete else "not proven complete")
    return out, complete
