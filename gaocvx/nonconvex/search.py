"""One search for the certified minimiser, in the problem's units (steps 4-9 of
:mod:`.minimum`).

:func:`run` takes the node programs (dense, fast, or fast with an obstacle), a
first upper bound (``w = 0`` and the one-mode estimate either way), the box of
amplitudes (:mod:`.bounds`), then the dual bound (:mod:`.dual`) or the branch and
bound (:mod:`.bnb`), the polish (:mod:`.polish`) and the other minimisers
(:mod:`.alternatives`), and judges the answer: ``optimal`` only where the
certified gap lies within :data:`GAP_TOL` of the energy scale, every node
program was solved, the modes passed their checks and, with an obstacle, the gap
resolves the energy of the beam on it (:data:`RESOLVE`).  :func:`.minimum.solve_global`
decides in which units it runs and whether it runs again.
"""

from __future__ import annotations

import math

import numpy as np

from ..mixed import MixedForm
from ..certificate import answer, passes
from . import bnb, dual
from .alternatives import other_minimisers
from .basin import BasinProver
from .bnb import branch_and_bound
from .bounds import amplitude_box
from .node import NodeProgram
from .obstacle_scale import obstacle_energy
from .scales import channel_reach, one_mode_amplitude, scene_energy
from .polish import answer_certificate, feasible_energy, flat_answer, polish, search_best

__all__ = ["run", "time_limit", "GAP_TOL", "GAP_TARGET"]

# A result is optimal only if its certified gap is at most GAP_TOL of the energy
# scale (sum of |energy parts|, at least ENERGY_FLOOR of scene_energy); branch and
# bound aims at GAP_TARGET, which node programs solved to 1e-12 reach in a few
# dozen nodes (the spec's example: 2.5e-10 of |Pi| in 47 nodes).
GAP_TOL = 1e-8
GAP_TARGET = 1e-11
# The energy scale's floor, as a fraction of the scene's own energy (see
# scene_energy): an answer whose energy is far below it (a beam pressed flat onto
# an obstacle: w = 0, energy 0) has its gap measured against this instead.
ENERGY_FLOOR = 1.0
# A negative gap (a bound above the answer) is measured against the answer's own
# energy, at least this fraction of the scene's (below it, the answer is the
# scene's round-off: a beam lying flat).
OWN_FLOOR = 1e-6
# A node program's cost grows with the mesh (banded solves in the fast path), and
# so does the branch and bound's wall-clock limit: bnb.TIME_LIMIT per TIME_ELEMENTS
# elements (measured at 8192 elements on a loaded machine: 2 to 10 s a node, and
# every scene stopped at 120 s with 13 to 31 of its 40 to 60 nodes).
TIME_ELEMENTS = 2048
# Whether the dual bound is tried before the branch and bound (step 5 of
# :mod:`.minimum`); False: the branch and bound alone (tests and benchmarks
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
# (the linear beam on the obstacle's and the buckled one's; see run).
RESOLVE = 1e-3


def time_limit(dp, k: int = 1) -> float:
    """The branch and bound's wall-clock limit [s] on the mesh of ``dp`` with ``k`` modes.

    bnb.TIME_LIMIT per TIME_ELEMENTS elements, doubled for every mode beyond
    three (each one multiplies the boxes to search).
    """
    return bnb.TIME_LIMIT * max(1.0, (dp.n_nodes - 1) / TIME_ELEMENTS) * 2.0 ** max(0, k - 3)


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


def run(dp, modes, max_nodes, t0, fast=False, prior=None, stalled=None, linear=None,
        on_obstacle=False):
    """One search in the units of ``dp``; see :func:`.minimum._solve_in` for the arguments.

    Returns ``(raw, info, size, out)``: the raw result, the ``global`` block, the
    answer's size in units of W (its largest nodal |w|, or its deflection size
    with a load) and the search's :class:`.bnb.BnBResult`.
    """
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
    # (in a channel, of the beam buckled as far as the channel lets it: scales.channel_reach)
    reach = channel_reach(dp, prog, modes)
    obstacle_floor = obstacle_energy(dp, modes, linear, reach)
    if obstacle_floor is not None:
        obstacle_floor *= ENERGY_FLOOR
    floor = ENERGY_FLOOR * scene_energy(dp, modes, reach)
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
