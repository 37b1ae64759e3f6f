"""Equilibria with an obstacle: the optimality conditions behind ``optimal``, and
the certified global minimiser as a start.

The reduced function's residuals (``|F'|`` times an amplitude) cannot see a
deflection that is no equilibrium of the beam; :func:`kkt_point` checks the
global method's optimality conditions on it.  With two unstable modes the
plane of amplitudes is only sampled (:mod:`.stationary2`): the certified
global minimiser, an equilibrium, is among its starts (:func:`global_minimisers`).
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import math

import numpy as np

from ..errors import SceneError, SolverError
from .equilibrium import Equilibrium, same_point

__all__ = ["at_global", "check_contact", "exact_flat", "global_minimisers", "kkt_point",
           "lift_off_curvature"]

log = logging.getLogger(__name__)


def global_minimisers(dp, modes) -> list:
    """The certified global minimiser (and its images) as stable
    :class:`.equilibrium.Equilibrium` objects, amplitudes in ``dp``'s units.

    With two modes and an obstacle the plane's sampling is no proof; the global
    minimum, an equilibrium, is then certain to be among the starts (a trial's
    P1 and P2 beams in channels: the global minimum was missed in 3 of 40 scenes).
    A failed or uncertified solve gives none (the sampling stands alone);
    uncertified, it is tried once more by the other node programs, as
    ``solve(scene, "global")`` does (:func:`.minimum.solve_certified`: a P3 beam
    in a channel at gap 0 under a load table, 12 elements, was certified so).
    Their ``residual`` is the certificate's stationarity, their curvature NaN;
    the certified minimiser is ``optimal``, its alternatives (mirror images or
    other contact states within the certified gap, without a certificate of
    their own) ``inaccurate``: starts only.
    """
    from .minimum import solve_certified
    try:
        dpg, raw, info = solve_certified(dp, modes)
    except (SceneError, SolverError, ArithmeticError, np.linalg.LinAlgError) as exc:
        # (only a start: the sampling goes on without it)
        log.warning("equilibria: no global minimiser to start from (%s)", exc)
        return []
    if raw.get("status") != "optimal":
        return []
    r = dpg.W / dp.W
    out = []
    for i, a in enumerate([{"u": raw["u"], "amplitudes": info["amplitudes"]}]
                          + info["alternatives"]):
        w, slope = dpg.to_physical(a["u"])
        out.append(Equilibrium(float(dpg.energy(a["u"]) * dpg.E0), True,
                               [float(x) * r for x in a["amplitudes"]], dp.x.copy(), w, slope,
                               float(raw["residual"]["stationarity"]),
                               "optimal" if i == 0 else "inaccurate", float(dp.P),
                               math.nan, float(dp.W)))
    return out


def at_global(dp, prog, out, minimisers, F, S) -> None:
    """The listed equilibria that are the certified global minimiser: stable
    (``out`` in place).

    An equilibrium within 1e-6 ``S`` of one of the ``minimisers``' amplitudes
    (:func:`global_minimisers`) whose ``F`` is no higher than there (1e-10 of
    its size) is a global minimiser, so a local one, whatever its probes say;
    ``optimal`` if it passes :func:`kkt_point`.  (A P3 beam in a channel at gap
    0 without load, two modes, 10 elements: the certified global minimiser,
    lying on the floor by the clamp and held at the ceiling at the free end,
    was listed unstable and ``inaccurate``: F's Hessian by central differences
    straddled the contacts' kinks, and Newton's residual stalled at 1.2e-6.)

    Where none within 1e-6 ``S`` is then ``optimal``, stable and as low, and the
    slice at the minimiser's amplitudes passes :func:`kkt_point`, the certified
    minimiser itself (not its alternatives) is listed, in place of the entries
    there that are not ``optimal`` (a P3 beam in a channel at gap 0 under a load table, 12
    elements: the global minimiser was listed only as an `inaccurate` point
    6e-13 S from it, F higher by 8e-9 of it, Newton's method stalled at a kink;
    and the slice there returned a beam 1e-6 of its energy higher than the
    certified one, which is listed instead).
    """
    for m in minimisers:
        s = np.asarray(m.amplitudes, float)
        top = F(s)
        # (not an entry certified on the whole beam: its stability is the
        # second-order conditions', which no F within 1e-10 overrides)
        near = [i for i, e in enumerate(out) if e is not None and not e.whole_beam
                and same_point(e.amplitudes, s, S)]
        for i in near:
            e = out[i]
            if not F(e.amplitudes) <= top + 1e-10 * abs(top):
                continue
            if not e.stable:
                log.info("equilibria: the certified global minimiser at s = %s: stable",
                         e.amplitudes)
                e.curvature = math.nan      # (the probes' value, which was wrong)
            e.stable = True
            if e.status != "optimal" and kkt_point(dp, prog, e.amplitudes):
                e.status = "optimal"
        # (only the certified one; where no `optimal` stable entry as low is that
        # close: an `optimal` saddle 1.3e-6 S beside a minimum is another
        # equilibrium, and is kept; an entry polished on the whole beam counts)
        close = near + [i for i, e in enumerate(out) if e is not None and e.whole_beam
                        and same_point(e.amplitudes, s, S)]
        if m.status != "optimal" or any(
                out[i].status == "optimal" and out[i].stable
                and F(out[i].amplitudes) <= top + 1e-10 * abs(top) for i in close) \
                or not kkt_point(dp, prog, s):
            continue
        log.info("equilibria: the certified global minimiser at s = %s listed", s)
        for i in sorted(near, reverse=True):
            if out[i].status != "optimal":
                del out[i]
        out.append(copy.copy(m))


def check_contact(dp, prog, out, polish=None, S: float = 0.0) -> None:
    """Equilibria with an obstacle: ``optimal`` only at a KKT point (``out`` in place).

    The reduced function's residuals (``|F'| |s|``, or ``|∇F|`` times a radius)
    cannot see a wrong deflection: on 40 campaign scenes the dense programs
    called 10 deflections optimal that are no KKT point of the independent
    energy (stationarity up to 5e5 at gap 0, a beam pressed flat returned as
    3e-12 m).  One that fails :func:`kkt_point` becomes ``inaccurate``.  Used
    for every search (the fast path with one mode since a campaign's zero
    4.3e-9 from s = 0, no KKT point, was called optimal on its residual).
    With ``polish`` (:func:`.whole_beam.polisher`) a failing entry is first
    polished on the whole beam from its slice's beam, and replaced by what
    that returns, if it does, at the entry's amplitudes (within ``MERGE S``:
    not a neighbouring equilibrium).
    """
    for e in out:
        # (one certified on the whole beam in its own scale passed a stricter test
        # than its slice's: near the flat beam the slices are accurate relative to
        # the scene only, and a saddle so certified failed its slice's -- P1 at gap
        # 0, two modes, 9 elements)
        if e is None or e.status != "optimal" or e.whole_beam:
            continue
        if not kkt_point(dp, prog, e.amplitudes):
            polished = _polished(prog, e.amplitudes, polish)
            if polished is not None and same_point(polished.amplitudes, e.amplitudes, S):
                log.info("equilibria: the equilibrium at s = %s polished on the whole beam",
                         e.amplitudes)
                # (at the zero's amplitudes during the search, as in
                # plane_newton.at_roots; whole_beam.settle gives the beam's at the end)
                for f in dataclasses.fields(e):
                    if f.name != "amplitudes":
                        setattr(e, f.name, getattr(polished, f.name))
                continue
            log.info("equilibria: the equilibrium at s = %s is no KKT point: inaccurate",
                     e.amplitudes)
            e.status = "inaccurate"


def _polished(prog, s, polish):
    """``polish`` of the slice's beam at amplitudes ``s`` (None where it fails)."""
    if polish is None:
        return None
    _, _, u, ok = prog.reduced(np.asarray(s, float))
    return polish(u) if u is not None and ok else None


def kkt_point(dp, prog, s) -> bool:
    """Whether the beam of the slice at amplitudes ``s`` passes the global method's
    optimality conditions with an obstacle (stationarity of the Lagrangian in the
    convex part's metric, feasibility, the multipliers' sign, complementarity).

    The slice is solved again for its own multipliers.  The dense programs'
    (:class:`.node.NodeProgram`) are checked in the Hermite DOFs
    (:func:`.certificate.certify_contact`: the program's multipliers and those
    recomputed on the touching rows), the contact slices' in the mixed form
    (:func:`.fast_check.certify_contact`, the slice's multipliers) or else as
    the dense programs'.  A beam pressed flat at gap 0 passes neither (measured:
    stationarity 1e5 and 3e6 where the independent check measured 4e-13): it
    is then ``inaccurate``, which errs on the safe side.  A contact slice that
    fails is solved again from where it stopped, and then from the program's own
    start, before the point is called ``inaccurate``.
    """
    if _kkt_point(dp, prog, s):
        return True
    if not hasattr(prog, "cold"):
        return False
    # A contact slice warm-started from a distant one can stop on the wrong contact
    # set, its F right and its multipliers not (P4 pressed at gap 0, two modes, 12
    # elements: the mirror image of a saddle 2e-5 m deep failed with stationarity
    # 3.7e-4, and passed with 8e-9 solved once more from there): the slice again.
    if _kkt_point(dp, prog, s):
        return True
    # The contact slices warm-start from the nearest slice solved before, so the
    # multipliers found depend on the search's history: a beam resting on an
    # obstacle (P1 in a channel, 10 elements) passed or failed by the order of
    # the solves before it.  Once more from the program's own start.
    with prog.cold():
        return _kkt_point(dp, prog, s)


def _kkt_point(dp, prog, s) -> bool:
    """:func:`kkt_point` with the slice solved once, as the program starts it."""
    from ..certificate import passes
    from ..mixed import MixedForm
    from .certificate import certify_contact
    from .polish import to_mixed

    _, _, u, ok = prog.reduced(np.asarray(s, float))
    if u is None or not ok:
        return False
    fast = getattr(prog, "prog", None)
    if fast is not None and hasattr(fast, "certify"):    # ContactSlices
        mf = fast.mf
        floor = mf.size_floor
        residual, _ = fast.certify(to_mixed(mf, u), prog.lam, floor)
        if passes(residual):
            return True
        # (at a kink of F the slice's multipliers balance the amplitude rows too:
        # those recomputed on the touching rows may still pass)
        modes, lam, rows, levels = fast.modes, prog.lam, fast.rows, fast.levels
    else:
        mf = MixedForm.on_obstacle(dp)
        floor = mf.size_floor
        modes, lam, rows, levels = prog.modes, prog.obstacle_multipliers(), prog.rows, \
            prog.levels
    residual, _ = certify_contact(dp, modes, u, lam, rows, levels, floor)
    return passes(residual)


# lambda_i - p counts as negative below -CERTAIN p (and twice the modes' margin).
CERTAIN = 1e-13


def lift_off_curvature(dp, modes, rows, levels):
    """The unloaded flat beam's curvature along an unstable mode it can lift off along, or None.

    Without load the energy's gradient at ``w = 0`` is exactly zero, and along an
    unstable mode ``phi_i`` its curvature is ``lambda_i - p < 0`` (the modes'
    count verified).  Where ``phi_i`` (or ``-phi_i``) moves no touching row of the
    obstacle (``rows``, level 0) into it, ``t phi_i`` is admissible for small
    ``t > 0`` and lowers the energy: ``w = 0`` is an unstable equilibrium, whatever
    the probes of F' say.  Returns the least such ``lambda_i - p`` (program
    units, as :attr:`.equilibrium.Equilibrium.curvature`), None where no unstable
    mode lifts the beam off, none has ``lambda_i - p`` certainly negative (below
    ``-CERTAIN p`` and twice the modes' margin ``delta``), or a load acts.  (P1 on an obstacle at gap 0 without
    load, 1e-10 above P_bar_h, 8 and 15 elements: the curvature, 8.6e-10 of the
    stiffness, was below the second-order test's EIG_TOL, F' at the probes was the
    contact slices' error, and the flat beam was listed stable and `optimal` -- a
    campaign.)
    """
    if not modes.verified or np.any(dp.gradient(np.zeros(dp.n))):
        return None
    touching = np.asarray(levels, float) >= 0.0   # (rows @ 0 >= levels: gap 0)
    phi = np.asarray(modes.phi, float)[:, :modes.k]
    moved = rows[np.flatnonzero(touching)] @ phi
    lifting = np.all(moved >= 0.0, axis=0) | np.all(moved <= 0.0, axis=0)
    # (a curvature certainly negative only: the modes' count takes lambda_i up to
    # p (1 + MARGIN), and at P_bar_h itself the flat beam is the minimum)
    curvature = np.asarray(modes.lam, float)[:modes.k] - float(modes.p)
    lifting &= curvature < -max(2.0 * float(modes.delta), CERTAIN * float(modes.p))
    return float(np.min(curvature[lifting])) if np.any(lifting) else None


def exact_flat(dp, modes, out, classify, relabel: bool = False, S: float = 0.0) -> list:
    """The flat beam ``w = 0`` where, with an obstacle, it is an equilibrium itself.

    ``w = 0`` is admissible (gaps >= 0); where it passes the global method's
    optimality conditions for the whole beam (multipliers recomputed on the
    touching rows, :func:`.certificate.certify_contact`, at the zero floor), a
    listed equilibrium within that floor of it (or within 1e-9 of the list's
    largest deflection, without load; or within 1e-6 ``S`` of it in amplitude)
    is that one, and is reported exactly:
    the slices at ``s = 0`` returned beams 1.3e-11 m off it, called `optimal`
    (a P3 beam pressed flat at gap 0 by 1e7 N/m, two modes: energy 1.4e-5 J
    against 0, independently no KKT point; one mode, P1 under a point force:
    7.7e-12 m, stationarity 9.4e-6), their amplitude rows' multipliers taking
    up the residual.  Where none is listed it is added, its stability from
    ``classify(s)`` -> ``(stable, curvature[, known])`` at ``s = 0`` (also
    where the entries reported as w = 0 disagree or one is not ``optimal``;
    where not ``known``, the entry is ``inaccurate``): without load at gap 0
    an unstable equilibrium the searches missed (P4, two modes; P1, one),
    lifting off along the first mode lowering the energy.  ``relabel``: the
    stability is ``classify``'s also where a listed entry is reported as
    w = 0 (two modes: the entry's label came from probes that do not see the
    kink of F at w = 0 -- central differences and 16 directions, or 8 probes
    1e-9 S around an edge minimum -- and a beam pressed flat by point forces,
    lifting off in a cone of directions 10 to 40 degrees wide, was called
    stable three times in a campaign of 22 such scenes).
    """
    from ..mixed import MixedForm
    from .certificate import certify_flat
    from .node import obstacle_rows
    from .whole_beam import MAX_UNKNOWNS, second_order

    rows, levels = obstacle_rows(dp)
    u0 = np.zeros(dp.n)
    mf = MixedForm.on_obstacle(dp)
    floor = mf.size_floor
    certified = certify_flat(dp, modes, rows, levels, floor)
    if certified is None:
        return out
    lam = certified[1]

    # The second-order conditions decide first where they can (whole_beam): pressed
    # by a small load, the flat beam is a strict minimum whose basin can be
    # narrower than the probes' 1e-8 S (P2 pressed at gap 0 by 10 N/m, two modes:
    # listed unstable and `optimal`, a review; independently stable).
    lift = lift_off_curvature(dp, modes, rows, levels)
    decided = False if lift is not None else None
    # (the curvature along the mode it lifts off along, else unknown: NaN)
    exact = lift if lift is not None else math.nan
    if decided is None and lam is not None and len(u0) <= MAX_UNKNOWNS:
        decided = second_order(dp, u0, rows, rows @ u0 - levels, np.asarray(lam, float), 0.0)
    top = max((float(np.max(np.abs(e.w))) for e in out if e is not None), default=0.0)
    near = max(floor * dp.W, 1e-9 * top)
    # (or within the searches' merging distance (MERGE S) of s = 0: a one-mode zero
    # 4.3e-9 from it, 5.8e-12 m off w = 0, no KKT point, was listed beside it --
    # P1 in a channel at gap 0 under two point forces, 10 elements)
    # (an entry certified on the whole beam is the flat beam only if its beam is:
    # its amplitudes are exact, and another equilibrium may lie within MERGE S)
    flat = [e for e in out if e is not None and (
        float(np.max(np.abs(e.w))) <= near
        or (same_point(e.amplitudes, 0.0, S) and not e.whole_beam))]
    energy = float(dp.energy(u0) * dp.E0)
    zeros = np.zeros(len(dp.x))
    if flat:
        # (an `inaccurate` entry's label may be a guess -- its probes in F''s
        # round-off -- and would pass as the flat beam's, `optimal`: a review)
        guessed = any(e.status != "optimal" for e in flat)
        keep = flat[0]
        keep.w, keep.slope, keep.energy = zeros, zeros.copy(), energy
        keep.amplitudes, keep.residual, keep.status = [0.0] * modes.k, 0.0, "optimal"
        keep.whole_beam = False
        if decided is not None:
            keep.stable, keep.curvature = bool(decided), exact
        elif relabel or guessed or len({e.stable for e in flat}) > 1:
            stable, curvature, *known = classify(np.zeros(modes.k))
            keep.stable, keep.curvature = bool(stable), float(curvature)
            if not all(known):   # (the probes' F' round-off: the label is not known)
                keep.status = "inaccurate"
        return [e for e in out if e is keep or all(e is not f for f in flat)]
    stable, curvature, *known = (decided, exact) if decided is not None else \
        classify(np.zeros(modes.k))
    log.info("equilibria: the flat beam w = 0, an equilibrium, added (%s)",
             "stable" if stable else "unstable")
    return out + [Equilibrium(energy, bool(stable), [0.0] * modes.k, dp.x.copy(), zeros,
                              zeros.copy(), 0.0, "optimal" if all(known) else "inaccurate",
                              float(dp.P), float(curvature), float(dp.W))]
