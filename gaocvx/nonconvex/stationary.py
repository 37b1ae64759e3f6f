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
   pressed flat onto an obstacle at gap 0;
5. with one mode, the sign bound of :mod:`.completeness` proves that no zero
   of ``F'`` is missing (:attr:`Equilibrium.complete`), sampling more where the
   grid does not suffice and listing the zeros it reveals.

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

import numpy as np

from ..discrete import DiscreteProblem
from ..errors import SceneError, SolverError
from ..scene import check_solve_arguments, numbers_of, whole
from .bounds import check_bounded, equilibrium_box, estimate_boxes, zoom_boxes
from . import stationary1 as line
from .equilibrium import Equilibrium, check_has_minimum, check_mountain_pass, same_point
from .near_flat import near_flat, unresolved
from .images import complete_beams
from .at_limit import flat_at_limit
from .probes import classify as classify_zero, hessian_stability
from .roundoff import label_threshold, round_off, settled, widened
from .obstacle_checks import check_contact, exact_flat, global_minimisers
from .whole_beam import polisher, settle
from .zero_step import zero_floor
from .zooms import own_scale

__all__ = ["Equilibrium", "equilibria", "GRID", "MAX_GRID"]

log = logging.getLogger(__name__)

# Grid points of F' over the amplitude range (odd: s = 0 is one of them, the
# trivial equilibrium of an unloaded beam).
GRID = 121
# At most this many (each is a solve of the reduced function): a bound on the
# work a typo can ask for, far above any grid that resolves more roots.
MAX_GRID = 100_000


def flat_classifier(dp, dF, S, out, probe_tol=0.0, c=0.0):
    """``classify(s) -> (stable, curvature, known)`` for the flat beam, ``s = 0``,
    on an obstacle (:func:`.obstacle_checks.exact_flat`), from F' one mode along
    (``dF``, the memoised reduced function of :func:`.stationary1.memoised`).

    Probes 1e-6 ``S`` either side (:func:`.probes.classify`; a quarter of
    the way to the nearest other listed equilibrium of ``out`` where that is
    closer), widened fourfold while F' at them is within its round-off or the
    slices' accuracy ``probe_tol`` (:func:`.roundoff.label_threshold`, with the
    concave coefficient ``c``), up to a quarter of the way to that equilibrium
    (a probe past an end of the admissible range is inadmissible, and that side
    counts as rising); ``known`` is False where they never rise above it.
    (Fixed at 1e-6 S before, as :mod:`.stationary1`'s probes were until F' near
    P_bar_h, round-off there, labelled stable beams unstable.)
    """
    threshold = label_threshold(lambda t, u: round_off(dp, u, t), probe_tol, c, S)

    def probed(t):
        return settled(dF, threshold, t)

    def classify(s):
        # (entries within MERGE S of s = 0 are the flat beam itself: exact_flat
        # merges them into it)
        others = [abs(float(e.amplitudes[0])) for e in out
                  if e is not None and not same_point(e.amplitudes, 0.0, S)]
        h = min([1e-6 * S] + [0.25 * q for q in others])
        # (not capped by the range's ends: a probe past one is inadmissible, and
        # that side counts as rising)
        cap = min([0.25 * q for q in others] + [0.25 * S])
        h, noisy = widened(probed, 0.0, h, cap)
        if noisy:
            log.warning("equilibria: F' next to the flat beam is within its round-off or the "
                        "slices' accuracy as far as the probes reach (%.3g); its stability "
                        "is not known", h)
        stable, curvature = classify_zero(dF, 0.0, h)
        return stable, curvature, not noisy
    return classify


def _convex_equilibrium(scene, elements, dp) -> list:
    from ..solve import solve
    r = solve(scene, "global", elements=elements)
    return [Equilibrium(r.energy, True, [], r.x, r.w, r.slope, 0.0, r.status,
                        float(scene.load.axial), complete=True)]


def equilibria(scene, elements: int | None = None, seeds=(), grid: int = GRID,
               fast: bool | None = None) -> list:
    """Every equilibrium of ``scene`` (k <= 2 unstable modes), sorted by energy.

    With one unstable mode the zeros of the reduced gradient are bracketed on a
    grid, and a sign bound proves that none is missed (:mod:`.completeness`);
    with two the plane of amplitudes is searched (:mod:`.stationary2`: grid
    seeds, contours and descents; with an obstacle the certified global
    minimiser is among the starts) and the monotone gradient's ellipses prove
    that none is missed (:mod:`.completeness2`).  Where a proof fails the list
    says so (``complete`` below).

    Parameters
    ----------
    scene : Scene or Mapping
        A dict with the structure of a scene file is validated into a Scene.
    elements : int, optional
        Overrides ``scene.mesh.elements``; checked as :func:`gaocvx.solve`
        checks it (a whole number in [1, 10^6]: ``8.0`` and numpy integers
        are accepted, ``2.5``, ``"8"`` and bools are not).
    seeds : sequence of float, optional
        Amplitudes [m] (:attr:`Equilibrium.amplitudes_m`) to sample besides the
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
        Each with ``complete``, the list's: True when proven to miss no
        equilibrium (one mode, :mod:`.completeness`; two, :mod:`.completeness2`;
        below the limit the one minimiser), False where that proof failed, None
        with two modes and an obstacle or channel whose admissible amplitudes
        could not be bounded (:mod:`.polygon`).

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
    from .minimum import MAX_ELEMENTS
    from .scales import rescale_for, scene_energy, square_energy
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
    if modes.k == 1 and flat_at_limit(dp, modes) is not None:
        # (without load at the limit: w = 0, the only equilibrium, in closed form)
        return [Equilibrium(0.0, True, [0.0], dp.x.copy(), np.zeros(dp.n_nodes),
                            np.zeros(dp.n_nodes), 0.0, "optimal", float(dp.P), W=dp.W,
                            complete=True)]
    if modes.k > 2:
        count = f"more than {MAX_UNSTABLE}" if modes.k > MAX_UNSTABLE else str(modes.k)
        raise SceneError("load.axial", f"P = {dp.P:.4g} N leaves {count} unstable buckling "
                         "modes; equilibria are searched for one or two (P below the third "
                         f"mode load {float(modes.loads[2]):.4g} N)", dp.P)
    dp = rescale_for(dp, modes)

    def program(dp, floor=None):
        # (floor: the energy the slices' accuracy is measured against, by default
        # the scene's)
        if fast and obstacle:
            from .fast_contact import FastContactProgram
            from .slices import ContactSlices
            return ContactSlices(FastContactProgram(dp, modes),
                                 scene_energy(dp, modes) if floor is None else floor)
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
        # Every equilibrium lies in the admissible box, so it bounds S too: the
        # search's merging distance, differences and proof are fractions of S (a
        # P2 beam in a channel 3e-14 m high: S 2.5e13 times the channel, its
        # merging distance 2.5e7 times, and the list `complete` with one
        # `inaccurate` entry and three minima missing -- a review)
        S = min(S, float(np.max(np.abs(np.r_[lo, hi]))))
    dtol = (line.DENSE_DERIVATIVE_TOL if not fast else
            line.CONTACT_DERIVATIVE_TOL if obstacle else line.DERIVATIVE_TOL)
    # (the stability probes: the dense programs' accuracy; the Newton slices' F'
    # is known to its round-off, roundoff.label_threshold)
    probe_tol = dtol if not fast else 0.0
    if modes.k == 2:
        from .stationary2 import find_plane
        glob = global_minimisers(dp, modes) if obstacle else []
        # (the ellipses' proof, :mod:`.completeness2`; None where it is not tried:
        # an obstacle's admissible amplitudes not bounded, :mod:`.polygon`)
        proof = {"dtol": dtol, "complete": None}
        out = find_plane(dp, prog, S, floor=scene_energy(dp, modes), modes=modes,
                         starts=[np.asarray(e.amplitudes, float) for e in glob], box=(lo, hi),
                         minimisers=glob, proof=proof)
        complete = proof["complete"]
        squares = []

        def own_search(d):
            # the square [-1, 1]^2 of d's units, within its admissible amplitudes
            # (accurate to the square's energy, not the scene's: scales.square_energy)
            p = program(d, square_energy(d, modes))
            smin, smax = admissible(p)
            box = (np.maximum(-1.0, smin), np.minimum(1.0, smax))
            own = {"dtol": dtol, "complete": None}
            found = find_plane(d, p, 1.0, floor=square_energy(d, modes), modes=modes, box=box,
                               zoom=False, proof=own)
            squares.append(bool(own["complete"]))
            # (polished on the whole beam where that succeeds, as the first search's)
            return settle(d, polisher(d, modes), found, 1.0, modes)

        if obstacle and None not in out:
            # the flat beam's neighbourhood again, in its own scale (:mod:`.zooms`);
            # the list's proof holds there only where the square's does (its
            # ellipses, :mod:`.completeness2`) and every beam it found is `optimal`
            # (the first search's entries there may have given way to its finds)
            out = sorted(own_scale(dp, modes, out, S, lo, hi, own_search, squares),
                         key=lambda e: e.energy)
            complete = complete and all(squares)
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
        reduced = line.memoised(prog)
        out, complete = line.find_line(
            dp, prog, S, points, grid, float(lo[0]), float(hi[0]), scene_energy(dp, modes),
            float(modes.c[0]), polish, dtol=dtol, probe_tol=probe_tol, dF=reduced,
            zero_floor=zero_floor(dp))
    if complete is not None:
        # (the proof rests on F + c s^2 being convex: c from the verified modes)
        complete = complete and bool(modes.verified)
    if modes.k == 1:
        if obstacle:
            check_contact(dp, prog, out, polish, S)
        if obstacle and None not in out:
            # (sharing find_line's solves: s = 0 and the probes it made)
            classify = flat_classifier(dp, reduced, S, out, probe_tol, float(modes.c[0]))
            # (the beams near the flat one polished on the whole beam, listed once)
            out = sorted(settle(dp, polish, exact_flat(dp, modes, out, classify, S=S), S,
                                modes),
                         key=lambda e: e.energy)
        if obstacle and None not in out:
            own = {}

            def own_line(d):
                # the segment [-1, 1] of d's units, within its admissible amplitudes
                # (accurate to the square's energy, not the scene's: scales.square_energy)
                p, polish_d = program(d, square_energy(d, modes)), polisher(d, modes)
                a, b = (float(v[0]) for v in admissible(p))
                a, b = max(-1.0, a), min(1.0, b)
                found, proven = line.find_line(
                    d, p, 1.0, np.linspace(a, b, grid), grid, a, b, square_energy(d, modes),
                    float(modes.c[0]), polish_d, dtol=dtol, probe_tol=probe_tol,
                    zero_floor=zero_floor(d))
                failed = None in found
                found = [f for f in found if f is not None]
                check_contact(d, p, found, polish_d, 1.0)
                found = settle(d, polish_d, found, 1.0, modes)
                # (every square searched: the proof holds where each one's does, and
                # where every beam it found is `optimal` -- own_scale lists only those:
                # a review's mock, the beam pressed onto the obstacle found
                # `inaccurate` and nothing listed there, came out `complete`)
                own["complete"] = (own.get("complete", True) and bool(proven) and not failed
                                   and all(f.status == "optimal" for f in found if np.any(f.w)))
                return found

            # the flat beam's neighbourhood again, in its own scale (:mod:`.zooms`);
            # the list's proof holds there only where that search's does too
            out = sorted(own_scale(dp, modes, out, S, lo, hi, own_line), key=lambda e: e.energy)
            if complete is not None and "complete" in own:
                complete = complete and bool(own["complete"])
    if out and None not in out:
        # the beams near w = 0 on a bed or an obstacle at gap 0, in their own scale
        # (:mod:`.near_flat`)
        out = sorted(near_flat(dp, modes, out, S, zero_floor(dp), polish),
                     key=lambda e: e.energy)
    if obstacle and None not in out:
        # the mirror image of each beam polished on the whole beam (:mod:`.images`)
        out = sorted(complete_beams(dp, polish, out), key=lambda e: e.energy)
    if out and all(e is not None for e in out):
        for e in out:
            u = dp.from_physical(e.w, e.slope)
            e.energy_scale = float(dp.energy_size(u) * dp.E0)
            e.complete = complete
            # (the stability at the beam's own scale, where the energy's Hessian
            # decides it: the probes of F step 1e-6 S, :func:`.probes.hessian_stability`)
            verdict = hessian_stability(dp, u) if e.status == "optimal" else None
            if verdict is not None and verdict != bool(e.stable):
                log.info("equilibria: an entry at %.4g J is %s by the energy's Hessian, not "
                         "by the reduced function's probes", e.energy,
                         "stable" if verdict else "unstable")
                e.stable = verdict
            if verdict is None and e.status == "optimal" and unresolved(dp, modes, u, S):
                log.warning("equilibria: the entry at %.4g J lies near the flat beam at the "
                            "bed's edge, where the energy's Hessian leaves its stability "
                            "undecided: inaccurate", e.energy)
                e.status = "inaccurate"
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
