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
from ..certificate import answer, passes
from . import bnb, dual
from .alternatives import other_minimisers
from .basin import BasinProver
from .bnb import branch_and_bound
from .bounds import amplitude_box, check_bounded
from .modes import unstable_modes
from .node import NodeProgram
from .obstacle_scale import linear_on_obstacle, obstacle_energy
from .scales import global_units, one_mode_amplitude, rescale_for, scene_energy
from .polish import (answer_certificate, feasible_energy, flat_answer, polish, search_best,
                     to_mixed)

__all__ = ["solve_global", "solve_certified", "GAP_TOL", "GAP_TARGET", "MAX_ELEMENTS",
           "MAX_MODES", "to_mixed", "rescale_for"]

log = logging.getLogger(__name__)

# A result is optimal only if its certified gap is at most GAP_TOL of the energy
# scale (sum of |energy parts|, at least ENERGY_FLOOR of scene_energy); branch and
# bound aims at GAP_TARGET, which node programs solved to 1e-12 reach in a few
# dozen nodes (the spec's example: 2.5e-10 of |Pi| in 47 nodes).
GAP_TOL = 1e-8
GAP_TARGET = 1e-11
# Unstable modes the branch and bound takes, and its node programs at most with up
# to three of them (node_limit: four times more per further mode).  Measured on
# 32-64 elements: one mode ~50 nodes, two ~500, four 2700-4000 (P1 at 8 P_bar_h),
# five 7800-12400 (P1 at 12, P4 at 26 P_bar_h); six 17600 (P4 on a bonded bed,
# 8 elements, 265 s with the fast path's active-set box QP).
MAX_MODES = 6
MAX_NODES = 4000
# The energy scale's floor, as a fraction of the scene's own energy (see
# scene_energy): an answer whose energy is far below it (a beam pressed flat onto
# an obstacle: w = 0, energy 0) has its gap measured against this instead.
ENERGY_FLOOR = 1.0
# A negative gap (a bound above the answer) is measured against the answer's own
# energy, at least this fraction of the scene's (below it, the answer is the
# scene's round-off: a beam lying flat).
OWN_FLOOR = 1e-6
# The node programs are dense (A_rho is banded plus rank k, its factor dense), and
# their model of the quadratic part carries round-off growing with N (measured at
# nonconvex.md's example: 1e-12 of the energy at 64 elements, 1.2e-8 at 128, where
# a node program took 1 s; GAP_TOL is 1e-8).
MAX_ELEMENTS = 128
# With an obstacle the dense programs are the default up to here (fast_by_default).
DENSE_OBSTACLE_ELEMENTS = 32
# A node program's cost grows with the mesh (banded solves in the fast path), and
# so does the branch and bound's wall-clock limit: bnb.TIME_LIMIT per TIME_ELEMENTS
# elements (measured at 8192 elements on a loaded machine: 2 to 10 s a node, and
# every scene stopped at 120 s with 13 to 31 of its 40 to 60 nodes).
TIME_ELEMENTS = 2048
# Whether the dual bound is tried before the branch and bound (step 5 of the
# module's notes); False: the branch and bound alone (tests and benchmarks
# compare the two).
DUAL_BOUND = True
# Whether the branch and bound closes the boxes around its local minimisers by a
# proved basin (:mod:`.basin`); False: by node programs alone (tests compare).
BASINS = True
# Beyond this many elements no basin is tried: the residual's rounding makes their
# bounds too loose to close boxes (P1 with two modes: 4.4e-8 below the minimum at
# 1024 elements, against a tolerance of 5e-9), and their slopes' bounds cost O(N^2).
BASIN_ELEMENTS = 1024
# With an obstacle, the gap's largest fraction of the energy of the beam on it
# (the linear beam on the obstacle's and the buckled one's; see _run).
RESOLVE = 1e-3


def time_limit(dp, k: int = 1) -> float:
    """The branch and bound's wall-clock limit [s] on the mesh of ``dp`` with ``k`` modes.

    bnb.TIME_LIMIT per TIME_ELEMENTS elements, doubled for every mode beyond
    three (each one multiplies the boxes to search).
    """
    return bnb.TIME_LIMIT * max(1.0, (dp.n_nodes - 1) / TIME_ELEMENTS) * 2.0 ** max(0, k - 3)


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
        raw, info, size, out = _run(dp, modes, max_nodes, t0, fast, prior,
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
    second search of up to :func:`time_limit` would end the same.

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


def _basins(dp, prog, lo, hi):
    """The branch and bound's ``basin`` (:mod:`.basin`): polish, then prove a box around
    the local minimiser (None with an obstacle, or with BASINS off)."""
    if not BASINS or dp.contact == "obstacle" or dp.n_nodes - 1 > BASIN_ELEMENTS:
        return None
    prover = BasinProver(dp, prog.modes)

    def find(u, s, lam):
        s2, u2, _ = polish(dp, prog, s, u, lam, lo, hi)
        return prover.prove(u2)
    return find


def _amplitudes(dp, modes, u) -> list:
    """The amplitudes ``s = (G Phi)'u`` of the beam ``u`` itself.

    (Not the search's ``s``: the polish moves the beam after the reduced
    function's minimum, and the answer is certified on the mixed form's
    manifold.  A P1 beam at gap 0 under a point force, 16 elements: the search's
    amplitudes were 9e-7 of their size off the answer's, whose equilibrium was
    listed twice -- the certified minimiser and, 2e-6 away, its own beam
    polished, :func:`.obstacle_checks.global_minimisers`.)
    """
    return [float(x) for x in np.asarray(dp.G @ modes.phi).T @ np.asarray(u, float)]


def _run(dp, modes, max_nodes, t0, fast=False, prior=None, stalled=None, linear=None,
         on_obstacle=False):
    k = modes.k
    if fast and dp.contact == "obstacle":
        from .fast_contact import FastContactProgram
        prog = FastContactProgram(dp, modes)
    elif fast:
        from .fast import FastProgram
        prog = FastProgram(dp, modes)
    else:
        prog = NodeProgram(dp, modes)
    # A first upper bound: w = 0 and the one-mode estimate on either side.  w = 0 is
    # admissible (gaps >= 0) but its energy is not always 0: a bonded bed with a gap
    # stores 1/2 c g^2 L there (taking 0 pruned boxes on a bound no point attains).
    A = one_mode_amplitude(dp, modes)
    start = (dp.energy(np.zeros(dp.n)), np.zeros(dp.n), np.zeros(k), None)
    for sign in (1.0, -1.0):
        s = np.zeros(k)
        s[0] = sign * A
        F, _, u, ok = prog.reduced(s)
        if u is not None and dp.energy(u) < start[0]:
            start = (dp.energy(u), u, s, prog.obstacle_multipliers())
    if prior is not None:
        e = feasible_energy(dp, prog)(prior[1])
        if e < start[0]:
            start = (e, prior[1], prior[2], prior[3])
    # lambda_1 of (K, G) bounds u'K u / t; with a bonded foundation the modes are
    # those of (K + c M, G), whose lambda_1 is no bound of it: none is used then.
    lam1 = 0.0 if getattr(dp, "bilateral", False) else float(modes.lam[0]) * (1.0 - 1e-9)
    lo, hi = amplitude_box(dp, k, upper=start[0], lam1=lam1)
    # (with an obstacle, the energy of the linear beam on it: checked against the gap
    # below; the floor itself where the search runs in its units)
    obstacle_floor = obstacle_energy(dp, modes, linear)
    if obstacle_floor is not None:
        obstacle_floor *= ENERGY_FLOOR
    floor = ENERGY_FLOOR * scene_energy(dp, modes)
    if on_obstacle and obstacle_floor is not None:
        floor = obstacle_floor
    scale = max(dp.energy_size(start[1]), floor, 1e-300)
    # The dual bound first (no obstacle): where it holds, no branch and bound is needed.
    # (taken within a tenth of GAP_TOL: its gap is the round-off of the residual,
    # with the energy's round-off allowed for: 6e-14 to 1.4e-12 of the scale at 16-512
    # elements, benchmarks/nonconvex.py dual)
    leaves = None if prior is None else prior[0]
    out, start = (None, start) if leaves is not None or not DUAL_BOUND else dual.shortcut(
        dp, prog, start, lo, hi, 0.1 * GAP_TOL * scale)
    if out is None:
        out = branch_and_bound(prog, feasible_energy(dp, prog), lo, hi, GAP_TARGET * scale,
                               max_nodes, start, leaves=leaves, time_limit=time_limit(dp, k),
                               accept=0.5 * GAP_TOL * scale, basin=_basins(dp, prog, lo, hi),
                               stalled=stalled)
    if out.s is None:
        out.s = start[2]
    best_s, best_u, lam = polish(dp, prog, out.s, out.u, out.lam, lo, hi)
    mf = MixedForm.on_obstacle(dp) if dp.contact == "obstacle" else MixedForm(dp)
    kept, certified = search_best(dp, prog, mf, out, best_u, lam, 0.5 * GAP_TOL * scale)
    if kept:
        best_s, best_u, lam = out.s, out.u, out.lam
    if certified is None:
        certified = answer_certificate(dp, prog, mf, best_u, lam)
    if not passes(certified[1]):
        # (a beam pressed flat at gap 0 just above the limit: its answer, zero to
        # round-off, fails where w = 0 itself passes -- polish.flat_answer)
        flat = flat_answer(dp, prog, mf, dp.energy(best_u) + 0.5 * GAP_TOL * scale)
        if flat is not None:
            best_s, best_u, lam, certified = np.zeros(k), np.zeros(dp.n), flat[2], flat
    chosen = best_u
    best_e = dp.energy(best_u)
    tol = max(out.gap, GAP_TARGET * scale)

    # Other minimisers: leaves within the gap of the best, and the images of the best.
    (best_e, best_u, best_s, lam), alternatives = other_minimisers(
        dp, prog, out, (best_e, best_u, best_s, lam), lo, hi, tol)

    # (the certificate above holds unless another minimiser replaced the answer)
    z, residual, lam = (certified if best_u is chosen
                        else answer_certificate(dp, prog, mf, best_u, lam))
    parts = mf.energy_parts(z)
    own = sum(abs(v) for v in parts.values())
    scale = max(own, floor, 1e-300)
    upper = sum(parts.values())
    # (a negative gap would be a bound above an admissible energy: reported as is)
    gap = upper - out.lower
    # The gap is the certificate, however the search ended (the node limit too).
    ok = -GAP_TOL * scale <= gap <= GAP_TOL * scale and out.failed == 0 and modes.verified
    # A bound above the answer is a node program less accurate than its margin: not
    # within GAP_TOL of the answer's own energy, the answer is not certified either
    # (a P2 beam held 3.7e-5 m above an obstacle: bounds 1.2e-6 J above the answer,
    # 3.2e-10 of the scene's energy but 2.4e-8 of the answer's -- a random campaign)
    ok = ok and gap >= -GAP_TOL * max(own, OWN_FLOOR * floor)
    # With an obstacle the gap must resolve the energy of the beam on it too (the linear
    # beam on the obstacle's and the buckled one's), to RESOLVE of it: an obstacle can
    # absorb a load whose unsupported energy is 1e12 times that (a point force of 6e12 N
    # pressing a P4 beam onto it: flat, certified gap 8127 J, 8.4e-12 of the unsupported
    # energy, against a buckled minimum at -1891 J).  Not to GAP_TOL: a beam pressed
    # flat into a channel just above the limit (campaign scene 8801:133) buckles by
    # 1.1e-6 J free, and its distributed load of 2981 J leaves a gap of 2.7e-11 J at the
    # round-off of the load, 2.4e-5 of that.
    resolved = obstacle_floor is None or gap <= RESOLVE * max(own, obstacle_floor, 1e-300)
    unresolved = ok and not resolved
    ok = ok and resolved
    how = (f"branch and bound: {out.nodes} node programs" if out.certificate != "dual bound"
           else "the Gao term's tangents (dual bound)")
    notes = [f"{how}, certified gap {gap * dp.E0:.3g} J ({gap / scale:.2g} of the energy scale)"
             if math.isfinite(gap) else
             # (no leaf with a bound: "certified gap inf J" read as a certificate)
             f"{how}, no gap certified (no lower bound)"]
    if out.stalled:
        notes.append(f"stopped at {out.nodes} nodes: the gap had not halved over "
                     f"{bnb.STALL_NODES}")
    elif not out.converged:
        notes.append(f"stopped at {out.nodes} nodes (limit {max_nodes} nodes, "
                     f"{time_limit(dp, k):g} s)")
    if out.failed:
        notes.append(f"{out.failed} node programs not solved to optimality")
    if not modes.verified:
        notes.append(f"the buckling modes failed their checks ({modes.checks})")
    if unresolved:
        notes.append(f"the gap is {gap / max(own, obstacle_floor, 1e-300):.2g} of the energy of "
                     f"the beam on the obstacle (at most {RESOLVE:g})")
    if not passes(residual):
        notes.append("the minimiser's own certificate failed")
    if kept:
        notes.append("the search's best point returned (the polished one failed its certificate)")
    raw = answer(mf, z, lam, residual, "global: " + "; ".join(notes), out.nodes,
                 "dual-bound" if out.certificate == "dual bound" else "clarabel-bnb", t0)
    if not ok:
        raw["status"] = "inaccurate"
    raw["stalled"] = bool(out.stalled)   # (for solve_certified: not part of the result)
    raw["unresolved"] = unresolved        # (for solve_global: not part of the result)
    info = {"unstable_modes": int(k), "mode_loads": [float(x) for x in modes.loads],
            "bound_gap": float(gap * dp.E0), "lower_bound": float(out.lower * dp.E0),
            "unique": not alternatives, "nodes": int(out.nodes),
            "certificate": out.certificate,
            "amplitudes": _amplitudes(dp, modes, raw["u"]),
            "alternatives": [{"u": a[1], "energy": float(a[0] * dp.E0),
                              "amplitudes": _amplitudes(dp, modes, a[1])} for a in alternatives]}
    if mf.has_load:
        size = mf.deflection_size(z)
        if size <= mf.zero_floor:
            size = 1.0  # zero to round-off (lying flat on an obstacle): no scale of its own
    else:
        # (not floored: without load the certificate's floor is 1, below the limit
        # the answer is w = 0 exactly, and an answer smaller than W is measured
        # against more than itself; solve_global re-solves it in its own scale)
        size = float(np.max(np.abs(mf.absolute(z)[mf.w_index]), initial=0.0))
    return raw, info, size, out
