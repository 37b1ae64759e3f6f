"""The certified global minimiser above the convexity limit (method ``"global"``).

Steps (nonconvex.md):

1. the k unstable modes (:mod:`.modes`); k = 0 is the convex case, handled by
   the caller with the convex ground truth;
2. a refusal when nothing bounds the energy from below (:func:`.bounds.check_bounded`);
3. the deflection scale set to the expected answer's size: the larger of the
   linear answer and the one-mode buckling amplitude
   ``A^2 = 3 (p - lambda_1) / (a ∫ (phi_1')^4)`` (non-dimensional), or a
   channel's width where that is far smaller (:func:`.scales.rescale_for`);
4. a box of amplitudes containing every minimiser (:mod:`.bounds`), tightened
   by the best energy of a few fixed-amplitude solves;
5. the dual bound (:mod:`.dual`, no obstacle): the best first candidate
   polished to a local minimum, and the Gao term's tangents at it; where they
   certify it (a unique minimiser within the gap), step 6 is skipped;
6. else branch and bound (:mod:`.bnb`) to a certified gap of
   :data:`GAP_TARGET` of the energy scale (sum of |energy parts|, at least the
   scene's own energy, :func:`.scales.scene_energy`);
7. polishing (:mod:`.polish`): the reduced function ``F(s)`` minimised from the best point
   (L-BFGS-B with its envelope gradient), then, without an obstacle, Newton on
   the full energy; the energy only goes down (with an obstacle, up to the
   polish's slack), so the certificate stands; where the polished point fails
   its certificate and the search's best passes, the best stays
   (:func:`.polish.search_best`); where neither passes, the flat beam ``w = 0``
   if admissible, no higher and certified (:func:`.polish.flat_answer`);
8. other minimisers: every other group of leaves whose lower bound lies
   within the gap of the best is searched the same way; one within the
   tolerance of the best energy makes the minimiser not unique;
9. the answer certified like every other (:func:`gaocvx.certificate.certify`,
   stationarity in the mixed variables) and the gap checked: ``optimal`` only
   when both pass.

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 16}})
>>> dp, raw, info = solve_global(DiscreteProblem(scene, check_convexity=False))
>>> raw["status"], info["unstable_modes"], info["unique"]
('optimal', 1, True)
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from ..errors import SceneError
from ..mixed import MixedForm
from . import bnb
from .bounds import check_bounded
from .modes import unstable_modes
from .obstacle_scale import linear_on_obstacle
from .polish import to_mixed
from .scales import global_units, rescale_for
from .search import GAP_TARGET, GAP_TOL, run

__all__ = ["solve_global", "solve_certified", "GAP_TOL", "GAP_TARGET", "MAX_ELEMENTS",
           "MAX_MODES", "to_mixed", "rescale_for"]

log = logging.getLogger(__name__)

# Unstable modes the branch and bound takes, and its node programs at most with up
# to three of them (node_limit: four times more per further mode).  Measured on
# 32-64 elements: one mode ~50 nodes, two ~500, four 2700-4000 (P1 at 8 P_bar_h),
# five 7800-12400 (P1 at 12, P4 at 26 P_bar_h); six 17600 (P4 on a bonded bed,
# 8 elements, 265 s with the fast path's active-set box QP).
MAX_MODES = 6
MAX_NODES = 4000
# The node programs are dense (A_rho is banded plus rank k, its factor dense), and
# their model of the quadratic part carries round-off growing with N (measured at
# nonconvex.md's example: 1e-12 of the energy at 64 elements, 1.2e-8 at 128, where
# a node program took 1 s; GAP_TOL is 1e-8).
MAX_ELEMENTS = 128
# With an obstacle the dense programs are the default up to here (fast_by_default).
DENSE_OBSTACLE_ELEMENTS = 32



def node_limit(k: int) -> int:
    """Node programs at most with ``k`` unstable modes (MAX_NODES up to three)."""
    return MAX_NODES * 4 ** max(0, k - 3)


def fast_eligible(dp, k: int) -> bool:
    """The fast path (:mod:`.fast`, :mod:`.fast_contact` with an obstacle) serves up to
    MAX_MODES unstable modes."""
    return 1 <= k <= MAX_MODES


def fast_by_default(dp, k: int) -> bool:
    """Whether :func:`solve_global` takes the fast path unless told.

    Wherever it serves (docs/nonconvex.md has the measurements): for one to
    three modes it is faster than the dense programs (P1 at 5 P_bar_h, k = 3:
    11 s against 20 s at 16 elements; at 100 the dense programs stopped
    uncertified at their 120 s); from four modes on their bounds stall at
    Clarabel's accuracy (1.7e-7 of the energy scale at k = 5).  With an
    obstacle beyond DENSE_OBSTACLE_ELEMENTS (the dense programs, its ground
    truth, take 2.7 s a node at 128 elements; the seed-1 campaign with the
    fast path forced for every obstacle: 0 violations), and from three modes
    at every mesh (P4, k = 5, 10 elements: dense 480 s `inaccurate`, fast 33 s;
    the six-mode obstacles of seeds 61 and 62: 544-963 s dense, one
    `inaccurate`, against 138-241 s; channels are mixed, 60-1102 s against
    197-306 s; with three modes a hidden-scene trial's P4 beams on an obstacle
    at 15 P_bar_h, 24-32 elements, ran the dense programs to their 4000 nodes
    in 46-81 s, certified by the fast path in 2.1-2.5 s, the same energies).
    """
    n_el = dp.n_nodes - 1
    if dp.contact == "obstacle":
        return fast_eligible(dp, k) and (n_el > DENSE_OBSTACLE_ELEMENTS or k >= 3)
    return fast_eligible(dp, k)


def solve_global(dp, modes=None, max_nodes: int | None = None,
                 fast: bool | None = None, give_up: bool = False) -> tuple:
    """The certified global minimiser of ``dp`` (``P >= P_bar_h``, ``k >= 1`` unstable modes).

    Parameters
    ----------
    dp : DiscreteProblem
        Built with ``check_convexity=False``.
    modes : Modes, optional
        Its unstable modes (computed when not given).
    max_nodes : int, optional
        Node programs at most (by default :func:`node_limit` of k).
    fast : bool, optional
        Node problems through the banded Newton machinery (:mod:`.fast`); by
        default wherever it serves (:func:`fast_eligible`: one to six unstable
        modes; with an obstacle beyond DENSE_OBSTACLE_ELEMENTS or from four
        modes on), see :func:`fast_by_default`.
    give_up : bool
        End a search whose gap has stalled (:data:`.bnb.STALL_NODES`) with
        its answer uncertified, where the caller tries the other node programs
        next (:func:`solve_certified`).

    Returns
    -------
    dp : DiscreteProblem
        The problem as last scaled.
    raw : dict
        The raw result for :func:`gaocvx.solve.make_result`.
    info : dict
        ``unstable_modes``, ``mode_loads`` [N], ``bound_gap`` [J],
        ``lower_bound`` [J], ``unique``, ``nodes`` and, for every other
        minimiser, ``alternatives`` (free DOFs ``u`` and energy [J]).

    Raises
    ------
    SceneError
        When the energy is unbounded below, or the mesh is too fine for the
        dense node programs.
    """
    t0 = time.perf_counter()
    check_bounded(dp)
    n_el = dp.n_nodes - 1
    modes = modes if modes is not None else unstable_modes(dp)
    if max_nodes is None:
        max_nodes = node_limit(modes.k)
    if fast is None:
        fast = fast_by_default(dp, modes.k)
    if n_el > MAX_ELEMENTS and not fast_eligible(dp, modes.k):
        raise SceneError("mesh.elements", f"the global method's dense node programs take at most "
                         f"{MAX_ELEMENTS} elements (beyond, the fast path: up to {MAX_MODES} "
                         "unstable modes)", n_el)
    # (the linear beam on the obstacle: the floor of its energy scale, solved once;
    # where its QP fails, c0 = 0 and no size: w = 0 is admissible, so c0 >= 0, and a
    # floor too low only makes the gap's test stricter -- without it, the unsupported
    # beam's floor alone certified the flat beam under an absorbed force)
    linear = (linear_on_obstacle(dp) or (0.0, 0.0)) if dp.contact == "obstacle" else None
    first = _solve_in(rescale_for(dp, modes), modes, max_nodes, t0, fast, give_up, linear, False)
    if not first[1].get("unresolved"):
        return first
    # Certified in the unsupported beam's energy, but the gap does not resolve the
    # energy of anything the beam can do on the obstacle (an enormous load absorbed by
    # it): the search again in the units of the beam on the obstacle, its gap measured
    # against that energy.  (A P4 beam at gap 0 under a point force of 6.04e12 N: flat,
    # gap 8127 J against a buckled minimum at -1891 J; again, buckled, gap 5.4e-6 J.)
    log.info("global: the gap does not resolve the beam on the obstacle; again in its units")
    again = _solve_in(global_units(dp, modes, linear), modes, max_nodes, t0, fast, True, linear,
                      True)
    if again[1]["status"] == "optimal":
        return again
    # Neither certified: the lower answer (its energy, lower_bound + bound_gap [J]), the
    # first where equal or not comparable.  (Not the smaller gap: in the obstacle's units
    # the node programs can end with bounds above an admissible energy -- a P1 beam under
    # 6.04e12 N, a negative gap -- where the first search's answer stands.)
    e1, e2 = (o[2]["lower_bound"] + o[2]["bound_gap"] for o in (first, again))
    return again if math.isfinite(e2) and (not math.isfinite(e1) or e2 < e1) else first


def _solve_in(dp, modes, max_nodes, t0, fast, give_up, linear, on_obstacle) -> tuple:
    """:func:`solve_global` in the units of ``dp`` (re-solved once in the answer's own
    scale where it lies outside them); ``linear``: the linear beam on the obstacle
    (:func:`.obstacle_scale.linear_on_obstacle`), whose energy (:func:`obstacle_energy`)
    the gap must resolve, and with ``on_obstacle`` the energy scale's floor."""
    prior = None
    # Without load, at least W: the certificate's floor (MixedForm.zero_floor) is
    # 1 there, and a P2 beam 2.6e-6 above the limit buckled to 0.18 W accepted a
    # displacement of 4.6e-6 of itself along its mode (a helper's probe)
    low = 0.1 if MixedForm(dp).has_load else 1.0

    def in_units(size):
        # (no size of its own, zero or not finite: no other scale to go to)
        return not (math.isfinite(size) and size > 0.0) or low <= size <= 10.0

    def off_scale(u):
        # The search's best beam lies outside [low, 10] W (its largest nodal |w|), so a
        # re-solve in its own scale follows: a stalled gap need not wait for the time
        # limit.  (P3 on an obstacle just above the limit, 24 elements, the answer 20 W:
        # the gap stood at 6.1e-7 of the scale from node 201 to the limit at 2617, 118
        # s; the re-solve certified it in 17 s -- a campaign's scene 131:39.)
        return not in_units(float(np.max(np.abs(dp.full(u)[0::2]), initial=0.0)))

    def stop(u):
        return give_up or off_scale(u)

    for attempt in range(2):
        raw, info, size, out = run(dp, modes, max_nodes, t0, fast, prior,
                                    stalled=None if attempt else stop, linear=linear,
                                    on_obstacle=on_obstacle)
        in_scale = in_units(size)
        if attempt or (in_scale and (give_up or not out.stalled)):
            break
        if in_scale:
            # Stopped as stalled, but the polished answer lies within the units after
            # all: the search goes on in them, from its leaves, as it would have.
            log.info("global: the stalled search goes on in the same units")
            size = 1.0
        else:
            log.info("global: re-solving in the answer's own scale (size %.3g W)", size)
            dp = dp.rescaled(dp.W * size)
        # The search goes on from the first one's leaves (in the new units: lengths
        # over W grow by 1/size, energies by 1/size^2, multipliers by 1/size).
        r = 1.0 / size
        # (a dual bound's answer has no leaves: the new search starts afresh)
        prior = (bnb.rescaled_leaves(out.leaves, r) if out.leaves else None, out.u * r,
                 out.s * r, None if out.lam is None else out.lam * r)
    return dp, raw, info


def solve_certified(dp, modes) -> tuple:
    """:func:`solve_global`, and where it is not certified once more by the other
    node programs (fast or dense) on meshes the dense ones take, up to three
    modes; the second answer where it is certified, else the first.

    The fast path's node bounds can stall where the dense programs certify (a
    stiff unilateral bed 0.17 mm below a P4 beam just above P_bar_h: gap 0.71
    of the energy scale fast, -3.5e-13 dense; campaign scene 8:3), and the dense
    ones where the fast path certifies (a beam pressed flat onto an obstacle,
    q = -1e9 N/m 1 mm above it: 2001 nodes, gap 1.1e-7 of the scale dense;
    certified fast).  Not beyond three modes: there the dense bounds stall at
    Clarabel's accuracy (k = 5: 1.7e-7 of the scale, above GAP_TOL), and a
    second search of up to :func:`.search.time_limit` would end the same.

    Where the second search follows, the first ends when its gap stalls
    (``give_up``): a P4 beam on an obstacle 2 mm below at 4 P_bar_h, 32
    elements, spent the dense programs' 120 s at a gap of 2.8e-5 of the scale
    (from node 101 to 3591) before the fast path certified it in 37 node
    programs; now 413 dense ones, 18 s in all against 125 s.  Should
    the second not certify either, the first runs again to its own limits, as
    it would have.
    """
    first = dp
    other = (dp.n_nodes - 1 <= MAX_ELEMENTS and fast_eligible(first, modes.k)
             and modes.k <= 3)
    out = solve_global(dp, modes, give_up=other)
    if out[1]["status"] != "optimal" and other:
        fast = not fast_by_default(first, modes.k)
        log.info("global: not certified (%s); again by the %s", out[1]["message"],
                 "fast path" if fast else "dense programs")
        again = solve_global(first, modes, fast=fast)
        if again[1]["status"] == "optimal":
            return again
        if out[1].get("stalled"):
            log.info("global: the stalled first search again, to its own limits")
            out = solve_global(first, modes)
    return out
