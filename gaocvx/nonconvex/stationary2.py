"""Equilibria with two unstable modes (k = 2): zeros of the reduced gradient in the plane.

The equilibria are the stationary points of ``F(s1, s2)`` (nonconvex.md; see
:mod:`.stationary` for k = 1).  In two dimensions no bracketing finds every
zero, so this search is a careful sampling; the monotone gradient's ellipses
(:mod:`.completeness2`, step 7) then prove that none is missing, or say that
they could not:

1. ``∇F`` on a ``GRID2 x GRID2`` grid of the square ``[-S, S]^2``
   (:func:`.bounds.equilibrium_box`: every equilibrium has ``|s| <= S``; with
   an obstacle, of its part within the admissible amplitudes' box), with
   ``s = 0`` exactly among the points; with an obstacle or channel also on
   finer grids of the boxes where a mode alone reaches a surface of it
   (:func:`.bounds.zoom_boxes`); and on a finer grid of the box where the
   one-mode estimates put the buckled beam, when it is far smaller than the
   square (:func:`.bounds.estimate_boxes`);
2. every grid cell on whose corners both components of ``∇F`` change sign
   seeds Newton's method on ``∇F = 0`` (the Hessian of F by central
   differences of the envelope gradient), damped to stay in the square, and
   so do ``s = 0`` and the given starts (with an obstacle: the certified global
   minimiser's amplitudes, :func:`.obstacle_checks.global_minimisers`); on lines of
   symmetry ``s_j = 0`` (``∂F/∂s_j`` zero to round-off along them) the zeros of
   the other component are found along the line (:func:`.contours.line_zeros`)
   and polished by Newton's method; and the ends of descents of ``F`` from every
   saddle along its falling direction (:mod:`.descents`: a minimum in the same
   grid cell as a saddle, or in a strip narrower than a cell), and the saddles
   between those minima and their nearest neighbours;
   with an obstacle or channel, also the zeros found by following the zero
   curves of one component of ``∇F`` across each grid (:mod:`.contours`:
   narrow valleys, where Newton's method does not converge from a cell);
3. zeros are merged when closer than 1e-6 S; each is classified by the
   eigenvalues of its Hessian and by one-sided probes in 16 directions (64,
   refined, where those 16 rise): both
   eigenvalues positive and ``∇F`` rising away from the zero in every
   direction is a local minimum of the energy (stable), else unstable (a
   saddle or a maximum of F; the probes see a kink of F's curvature that the
   central differences average away; where the probes rise all round and the
   Hessian does not, F's own values decide, :func:`.probes.curvature`);
4. with an obstacle or channel, a local minimum of ``F`` at a kink or at the
   edge of the admissible amplitudes (a beam resting on the obstacle, or
   pressed flat onto it at gap 0) is no zero of ``∇F``: every grid point whose
   ``F`` is lowest among its admissible neighbours, and every start, is refined
   by Nelder-Mead on ``F`` (inadmissible amplitudes count as ``+inf``) and,
   when it is no zero found by step 2, reported as a stable equilibrium if no
   admissible probe around it within 1e-9 S is lower (a local minimum of ``F``
   is one of the energy: ``Pi(s, v) >= F(s) >= F(s*)`` nearby; :mod:`.edges`).
   Unstable equilibria at a kink or an edge are not searched;
5. with an obstacle, the mirror images (x -> L - x) of the equilibria found,
   where mesh and supports are symmetric, seed steps 2 and 4 again, and every
   equilibrium called ``optimal`` must pass the global method's optimality
   conditions (:func:`.obstacle_checks.check_contact`), else it is ``inaccurate``
   unless polished on the whole beam (:mod:`.whole_beam`, as are zeros of step 3
   resolved to the scene's accuracy but not to their own -- near the flat beam --
   and, last, every ``optimal`` entry where that succeeds, entries so polished
   that are one beam listed once);
   one at the certified global minimiser's amplitudes is stable, and the
   certified minimiser is listed itself where no `optimal` stable entry as low is
   that close (:func:`.obstacle_checks.at_global`);
   and the flat beam ``w = 0`` is checked as an equilibrium of its own
   (:func:`.obstacle_checks.exact_flat`); last, an entry that is not ``optimal``
   at the mirror image of one that is is settled by the exact image
   (:func:`.images.settle_twins`);
6. with an obstacle, second searches on finer grids (:mod:`.zooms`): before
   step 5, over the box of each of the three lowest clusters of equilibria
   closer than 1.5 grid steps with two or more minima among them (a row of
   minima along a surface); after it, near the flat beam, in a square of the
   size of the equilibria found there; their ``optimal`` equilibria are added.
   And where the flat beam is listed stable and ``optimal``, :func:`.stationary.equilibria`
   searches its neighbourhood again in a problem of its own scale
   (:func:`.zooms.own_scale`);
7. (``proof``) the ellipses of :mod:`.completeness2` cover the square (with an
   obstacle or channel, its part in the admissible amplitudes' polygon,
   :mod:`.polygon`), Newton's method starting from every cell they leave open,
   and the list is proven complete or not; in a proven list, ``inaccurate``
   entries are dropped when the ``optimal`` ones alone are proven complete.

Examples
--------
>>> from gaocvx import Scene
>>> from gaocvx.nonconvex import equilibria
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P1", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"axial": 1.1e10}, "mesh": {"elements": 8}})
>>> eqs = equilibria(scene)           # q = 0 above the second mode load
>>> sum(e.stable for e in eqs), eqs[-1].energy      # two mirror minima; w = 0 highest
(2, 0.0)
"""

from __future__ import annotations

import logging
import math
import time
from functools import partial

import numpy as np

from . import images as mirror, zooms
from .bounds import estimate_boxes, zoom_boxes
from .completeness2 import prove
from .contours import curve_zeros, line_zeros
from .descents import descents as _descents, passes as _passes
from .edges import edge_minima
from .obstacle_checks import at_global, check_contact, exact_flat
from .plane_newton import at_roots as _at_roots, axis as _axis, \
    grid_seeds as _grid_seeds, newton as _newton
from .polygon import program_polygon
from .probes import least_rise as _least_rise, probe_noise
from .stationary1 import RHO
from .whole_beam import polisher, settle as settle_beams
from .zero_step import zero_floor

__all__ = ["find_plane", "GRID2"]

log = logging.getLogger(__name__)

GRID2 = 25  # odd: (0, 0) is a grid point


def find_plane(dp, prog, S, grid: int = GRID2, floor: float = 0.0, modes=None,
               starts=(), box=None, minimisers=(), zoom: bool = True,
               flat: bool = True, proof: dict | None = None) -> list:
    """Every zero of ``∇F`` found in ``[-S, S]^2`` (see the module's notes).

    ``floor`` [in the program's energy unit]: the smallest energy scale residuals are
    relative to (the scene's: a flat beam's own energy parts are 0).  With an
    obstacle the grid spans only the admissible amplitudes' ``box`` (``(lo, hi)``:
    bounds by a linear program's duality, :func:`.fast_check.amplitude_range`;
    by default ``prog``'s own, if it has them), as for k = 1, and
    finer grids span the boxes where the unstable modes reach the obstacle
    (:func:`.bounds.zoom_boxes`, from ``modes``); ``starts`` (amplitudes: the
    certified global minimiser's) seed Newton's method and the edge minima, and
    ``minimisers`` (:func:`.obstacle_checks.global_minimisers`: the certified
    global minimiser, as an equilibrium) are listed stable
    (:func:`.obstacle_checks.at_global`).  With an obstacle the zeros on the
    zero curves of one component of ``∇F`` are added on every grid
    (:func:`.contours.curve_zeros`).  ``zoom``: the second searches of
    :mod:`.zooms`; ``flat``: ``s = 0`` among the seeds and tried as an edge
    minimum (False in a cluster's box).  ``proof``: a dict
    whose ``"dtol"`` (the gradient's accuracy, relative to its local size) asks
    for the ellipses' proof that no zero is missing (:mod:`.completeness2`, with
    ``modes``; with an obstacle over :func:`.polygon.program_polygon`'s polygon),
    its verdict returned in ``proof["complete"]`` (left as it is where the
    polygon could not be bounded).
    """
    t0 = time.perf_counter()
    cache = {}
    obstacle = dp.contact == "obstacle"

    def grad(s):
        key = (float(s[0]), float(s[1]))
        if key not in cache:
            F, d, u, ok = prog.reduced(np.array(key))
            cache[key] = (F, np.asarray(d, float), u, ok)
        return cache[key]

    def hessian(s, h=None):
        # central differences of the gradient, step h (1e-6 S); one-sided next to
        # an edge of the admissible amplitudes (F = inf and a gradient of zeros
        # beyond it, which once gave a Newton step of 6e11 from the flat beam at
        # gap 0); None where neither side is admissible
        h = 1e-6 * S if h is None else h
        H = np.empty((2, 2))
        mid = grad(s)
        for j in range(2):
            e = np.zeros(2)
            e[j] = h
            up, down = grad(s + e), grad(s - e)
            if math.isfinite(up[0]) and math.isfinite(down[0]):
                H[:, j] = (up[1] - down[1]) / (2 * h)
            elif math.isfinite(up[0]) or math.isfinite(down[0]):
                H[:, j] = (up[1] - mid[1]) / h if math.isfinite(up[0]) \
                    else (mid[1] - down[1]) / h
            else:
                return None
        return 0.5 * (H + H.T)

    # (zeros resolved to the scene's accuracy but not to their own: the whole beam)
    polish = polisher(dp, modes)
    own_floor = zero_floor(dp)   # (the floor under a zero's size in its own scale)

    def at_roots(roots, *args, **kwargs):
        return _at_roots(dp, grad, hessian, roots, *args, floor=floor, polish=polish,
                         zero_floor=own_floor, **kwargs)

    if box is None:
        box = (getattr(prog, "smin", [-S, -S]), getattr(prog, "smax", [S, S]))
    lo = np.maximum(-S, np.asarray(box[0], float))
    hi = np.minimum(S, np.asarray(box[1], float))
    boxes = [] if modes is None else estimate_boxes(dp, modes, lo, hi) + (
        zoom_boxes(dp, modes, lo, hi) if dp.contact == "obstacle" else [])
    grids = [[_axis(a[j], b[j], grid) for j in range(2)] for a, b in [(lo, hi)] + boxes]
    seeds = [np.asarray(x, float) for x in starts]
    for axes in grids:
        seeds += _grid_seeds(grad, axes)
    if flat and math.isfinite(grad(np.zeros(2))[0]):
        seeds.insert(0, np.zeros(2))   # the unloaded beam's trivial equilibrium, if any
    ends = _newton(grad, hessian, seeds, S)
    # the zeros on lines of symmetry s_j = 0, where the sign of ∂F/∂s_j is round-off,
    # polished by Newton's method (a line nearly one of symmetry, ∂F/∂s_j = 1e-7 of
    # |∇F| on it, gave a zero 2.9e-5 S off the true one, listed beside it as an
    # `inaccurate` duplicate: P1 under an asymmetric load table at gap 0)
    ends += _newton(grad, hessian, [z for axes in grids for z in line_zeros(grad, axes, S)], S)
    if dp.contact == "obstacle":
        # zeros in narrow valleys, where Newton's method does not converge from
        # a grid cell (:mod:`.contours`)
        ends += [z for axes in grids for z in curve_zeros(grad, axes, S)]
    out = at_roots(ends, S)
    # down both sides of every saddle's falling direction: a minimum next to a
    # saddle, in the same grid cell, is where that path ends
    # (only zeros to the tolerance: a descent's end at a kink of F is left to the
    # edge minima, which once lost a resting beam's `optimal` to an inaccurate zero)
    # (the gradient's flow only where F has kinks, where a contact comes or goes:
    # only there has a minimum been found in a strip narrower than the simplex;
    # 54 smooth two-mode campaign scenes, without obstacle or with a bonded bed,
    # listed the same equilibria without it, in 28 % less time)
    kinks = dp.contact == "obstacle" or (dp.contact == "foundation" and not dp.bilateral)
    descents = _descents(grad, hessian, out, S, follow=kinks)
    ends = at_roots(_newton(grad, hessian, descents, S), S,
                     [e.amplitudes for e in out], strict=True)
    out += ends
    # and the saddle between such a minimum and its nearest neighbour: two strict
    # minima have one between them, and beside a minimum in a narrow strip it is
    # as hard to find as the minimum was
    passes = _passes(grad, [e.amplitudes for e in ends if e.stable],
                     [e.amplitudes for e in out if e.stable], S)
    out += at_roots(_newton(grad, hessian, passes, S), S,
                     [e.amplitudes for e in out], strict=True)
    if dp.contact == "obstacle":
        def found():
            return [np.asarray(e.amplitudes) for e in out]
        for axes in grids:
            out += edge_minima(dp, grad, axes, S, found(), floor)
        out += edge_minima(dp, grad, None, S, found(), floor, list(starts) + descents)
        # The flat beam at gap 0 may be a minimum whose basin is far below the
        # grid's step (F rises over 1e-9 S, then falls: a P4 beam under a load
        # table, 8 elements): tried with a simplex of that size.
        if flat:
            out += edge_minima(dp, grad, None, S, found(), floor, [np.zeros(2)], 1e-8)
        if zoom:
            # rows of minima closer than the grid's step, searched again on a finer
            # grid over their box (:mod:`.zooms`; without the modes' boxes, images
            # and flat beam: the checks below, and the images, take its finds too)
            out = zooms.clusters(partial(find_plane, dp, prog, grid=zooms.CLUSTER_GRID,
                                         floor=floor, zoom=False, flat=False),
                                 S, out, lo, hi, (hi - lo) / (grid - 1), minimisers)
        # A symmetric scene's equilibria come in mirror pairs: an image not found
        # seeds both searches again (P1 on an obstacle 1 cm below, k = 2: a beam
        # resting on it just off the middle was found, its image was not)
        images = mirror.seeds(dp, modes, grad, out, S) if modes is not None else []
        if images:
            out += at_roots(_newton(grad, hessian, images, S), S, found())
            out += edge_minima(dp, grad, None, S, found(), floor, images)
        check_contact(dp, prog, out, polish, S)
        at_global(dp, prog, out, minimisers, lambda s: grad(np.asarray(s, float))[0], S)
        if modes is not None:
            out = exact_flat(dp, modes, out, flat_classifier(dp, grad, S), relabel=True, S=S)
        if zoom:
            # near the flat beam, a square of the equilibria's own size (:mod:`.zooms`)
            out = zooms.near_flat(partial(find_plane, dp, prog, grid=grid, floor=floor,
                                          modes=modes, zoom=False),
                                  S, out, lo, hi, minimisers)
        if modes is not None:
            # an entry that failed the check beside the exact mirror image of one
            # that passed it is that image (:mod:`.images`)
            def settle(s):
                new = at_roots([s], S, strict=True)
                check_contact(dp, prog, new, polish, S)
                return new[0] if new and new[0].status == "optimal" else None
            out = mirror.settle_twins(dp, modes, grad, out, S, settle)
            # (Newton's end is dropped where F is infinite there: no end, no image)
            out = mirror.complete_pairs(dp, modes, grad, out, S, lambda s: next(
                (settle(end) for end in _newton(grad, hessian, [s], S)), None))
    # (with an obstacle, over the admissible amplitudes: a polygon, :mod:`.polygon`)
    region = program_polygon(prog, lo, hi) if proof is not None and obstacle else None
    if proof is not None and modes is not None and (region is not None or not obstacle):
        found = []

        def search(seeds):   # (Newton's method from the proof's open cells)
            new = at_roots(_newton(grad, hessian, seeds, S), S,
                           [e.amplitudes for e in out + found])
            if obstacle:
                check_contact(dp, prog, new, polish, S)
            found.extend(new)
            return [e.amplitudes for e in new]

        proof["complete"] = prove(grad, search, [e.amplitudes for e in out], grids[0],
                                  list(cache), modes.c, proof["dtol"], S, RHO * S, region)
        out += found
    if zoom:
        # (near the flat beam the slices' beams are the scene's accuracy: each
        # polished on the whole beam, where that succeeds, and listed once)
        out = settle_beams(dp, polish, out, S, modes)
    sure = [e for e in out if e.status == "optimal"]
    if proof is not None and proof.get("complete") and sure and len(sure) < len(out):
        # `inaccurate` entries the proof does without (the `optimal` ones alone
        # proven complete) lie within 2e-6 S of those: none is an equilibrium of its
        # own (a P2 beam on a bonded bed at 1.001 lambda_2 listed a saddle twice, the
        # copy 5.4e-6 S off with a residual of 1.5e-6 -- a helper's campaign)
        if prove(grad, lambda seeds: [], [e.amplitudes for e in sure], grids[0], list(cache),
                 modes.c, proof["dtol"], S, RHO * S, region):
            out = sure
    out.sort(key=lambda e: e.energy)
    log.info("equilibria (k = 2): %d found from %d seeds, %d solves in %.2f s", len(out),
             len(seeds), len(cache), time.perf_counter() - t0)
    return out


def flat_classifier(dp, grad, S):
    """``classify(s) -> (stable, curvature, known)`` for the flat beam on an
    obstacle with two modes (:func:`.obstacle_checks.exact_flat`), ``grad`` the
    search's cached ``(F, ∇F, u, ok)``.

    w = 0 lies at a kink of F: the slopes beside it (:func:`.probes.least_rise`,
    ``kink``), in directions refined where they rise least; a fall at 1e-6 S is
    confirmed at 1e-8 S (a beam pressed flat may rise over a basin narrower
    than the first, then fall: the second decides; below it, round-off does).
    ``known`` where the slope at the probes, ``|least| h``, clears ∇F's
    round-off there (:func:`.probes.probe_noise`).
    """
    def classify(s):
        h = 1e-6 * S
        least = _least_rise(grad, s, h, kink=True)
        if not least > 0:
            fine = _least_rise(grad, s, 1e-8 * S, kink=True)
            if fine > least:
                least, h = fine, 1e-8 * S
        return least > 0, least, abs(least) * h > probe_noise(dp, grad, s, h)
    return classify
