"""Polishing the global method's candidates: the reduced function's minimum, the
obstacle's tiny box and contact polish, Newton on the full energy, and images.

The branch and bound (:mod:`.minimum`) ends with a point whose energy is within
the certified gap of the minimum; the optimality conditions are met only to the
node programs' tolerance.  These functions bring it to a point that passes the
certificate (:mod:`.certificate`, :mod:`.fast_check`) without raising its energy
beyond round-off, and give the images (-u, x -> L - x) checked for another
minimiser.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.optimize as so

from ..mixed import MixedForm
from ..certificate import passes
from .certificate import certify_answer, certify_flat, contact_polish

__all__ = ["to_mixed", "polish", "feasible_energy", "size_floor", "reflections",
           "answer_certificate", "search_best", "flat_answer", "SLACK"]

log = logging.getLogger(__name__)

# A node's answer may violate an obstacle by its solver's tolerance, which lowers
# its energy by force x violation (measured: 3e-9 of it for a point contact): a
# polished point is taken within this fraction of its energy (search.GAP_TOL).
SLACK = 1e-8


def to_mixed(mf: MixedForm, u) -> np.ndarray:
    """Mixed variables ``z`` (relative to ``mf.origin``) of free Hermite DOFs ``u``."""
    dp = mf.dp
    full = dp.full(u)
    w = full[0::2]
    zf = np.zeros(mf.nz)
    zf[0::3], zf[1::3] = w, full[1::2]
    zf[2::3] = np.diff(w) / np.diff(dp.xi)
    return zf[mf.free] - mf.origin


def _newton_polish(dp, u, max_iter: int = 30):
    """Newton on the full energy from ``u`` (no obstacle) in the mixed variables; the new ``u``.

    Only used near a minimiser (the Hessian must be positive definite there:
    the Gao term stiffens a buckled beam); a step must not raise the energy
    beyond round-off, else the last point stands.  The mixed form, not the
    Hermite DOFs: their Hessian loses N^4 eps (measured: a polished answer
    1.3e-6 off at 2048 elements, which the certificate then rejected).
    """
    mf = MixedForm(dp)
    z = to_mixed(mf, u)
    energy = lambda z: sum(mf.energy_parts(z).values())  # noqa: E731
    e = energy(z)
    for _ in range(max_iter):
        g = mf.gradient(z)
        H = mf.hessian(z)
        try:
            d, _ = mf.kkt_factor(H).solve(-g, -mf.link(z))
        except np.linalg.LinAlgError:
            break
        dec = float(d @ (H @ d))
        if not dec >= 0:   # not positive definite here: no Newton step
            break
        trial = z + d
        et = energy(trial)
        if not et <= e + 1e-12 * max(abs(e), 1.0):
            break
        z, e = trial, et
        if dec <= 1e-28 * max(abs(e), 1.0):
            break
    return mf.to_hermite(z)


def _minimise_reduced(prog, s, lo, hi):
    """Minimise the reduced function F over ``[lo, hi]`` from ``s``; returns (F, s, u, ok)."""
    cache = {}

    def fun(x):
        key = tuple(x)
        if key not in cache:
            cache[key] = prog.reduced(x)
        F, dF, _, _ = cache[key]
        if not math.isfinite(F):
            # No admissible beam has these amplitudes (an obstacle bounds them):
            # a huge value makes the line search step back.
            return 1e30, np.zeros_like(x)
        return F, dF

    res = so.minimize(fun, np.clip(s, lo, hi), jac=True, method="L-BFGS-B",
                      bounds=list(zip(lo, hi)), options=dict(ftol=1e-15, gtol=1e-11, maxiter=60))
    F, _, u, ok = prog.reduced(res.x)
    return F, np.asarray(res.x, float), u, ok


def feasible_energy(dp, prog):
    """The energy of free DOFs ``u``; inf where an obstacle is violated beyond round-off."""
    if prog.rows is None:
        return getattr(prog, "energy", dp.energy)

    base = getattr(prog, "energy", dp.energy)   # the fast path's: in the mixed form
    floor = size_floor(dp)

    def energy(u):
        return math.inf if _inside(prog, u, floor) else base(u)

    return energy


def polish(dp, prog, s, u, lam, lo, hi):
    """Polish a candidate: the reduced function's minimum near ``s``, then Newton.

    Returns the amplitudes, free DOFs and obstacle multipliers of one and the
    same solve.
    """
    out = _polish_with(dp, prog, s, u, lam, lo, hi, dp.energy)
    if dp.contact == "obstacle" and _violates(dp, prog, out[1]):
        # A candidate inside the obstacle, taken for its lower energy, that the
        # contact polish could not bring out: again, with candidates judged by
        # their admissible energy.  (At gap 0 one 3.4e-12 inside, 1e-5 of its own
        # size, replaced the search's w = 0: campaign scene 11:31 at 96 elements.
        # Not always so judged: node answers inside by the solver's tolerance are
        # what the contact polish starts from, campaign scene 1:38.)
        log.info("global: the polished point violates the obstacle; again, by admissible "
                 "energies")
        out = _polish_with(dp, prog, s, u, lam, lo, hi, feasible_energy(dp, prog))
    return out


def _violates(dp, prog, u) -> bool:
    """``u`` lies inside the obstacle by more than 1e-9 of its size (at least the
    certificate's floor, :func:`size_floor`: a beam pressed flat at gap 0 has no
    size of its own)."""
    return _inside(prog, u, size_floor(dp))


def size_floor(dp) -> float:
    """:attr:`MixedForm.size_floor` of ``dp`` with an obstacle (the zero floor where a
    load acts, else 0): deflections below it are zero to the certificate."""
    return MixedForm.on_obstacle(dp).size_floor


def _inside(prog, u, floor) -> bool:
    """``u`` lies inside the obstacle by more than 1e-9 of its size, at least ``floor``.

    The size is the point's own, not the obstacle's levels: a channel's far surface
    (4.8 cm above a P1 beam pressed flat at gap 0, campaign scene 8801:133) let a
    point 3e-13 m inside the near one count as admissible, its energy 4.2e-7 J
    below the certified lower bound, and it was reported as another minimiser.
    """
    gap = prog.rows @ u - prog.levels
    size = max(float(np.max(np.abs(u))), floor, 1e-300)
    return float(np.min(gap, initial=0.0)) < -1e-9 * size


def _polish_with(dp, prog, s, u, lam, lo, hi, judge):
    """:func:`polish` with candidates taken when ``judge(candidate)`` is lower."""
    F, s2, u2, ok = _minimise_reduced(prog, s, lo, hi)
    # (a point inside the obstacle by the solver's tolerance is taken within SLACK:
    # the gap is computed from the point returned, so it stays honest)
    slack = SLACK * max(abs(dp.energy(u)), 1.0) if dp.contact == "obstacle" else 0.0
    if u2 is not None and judge(u2) <= dp.energy(u) + slack:
        s, u = s2, u2
        lam = prog.obstacle_multipliers()
    if dp.contact == "obstacle":
        # At a minimiser in contact, F is often not differentiable (the contact
        # starts there), and the fixed-amplitude program's multipliers balance
        # only the complement.  The node program on a tiny box around s has the
        # full problem's optimality conditions up to its chord error c delta^2:
        # its minimiser and multipliers are those of the beam.
        # Its minimiser off the box's centre leaves a gradient error of c times the
        # offset, so the box is centred on it and narrowed while it moves (a P1 beam
        # in a channel, k = 2, 256 elements: stationarity 1.4e-6 from one box).
        delta = 1e-7 * (1.0 + float(np.max(np.abs(s))))
        # (its energy may exceed the reduced minimum's by the solver's tolerance;
        # contact_polish then brings it down again)
        e = dp.energy(u)
        for _ in range(3):
            sol = prog.solve_box(np.maximum(s - delta, lo), np.minimum(s + delta, hi))
            if not (sol.ok and sol.u is not None and judge(sol.u) <= e + slack):
                break
            moved = float(np.max(np.abs(sol.s - s)))
            s, u, lam = sol.s, sol.u, sol.lam
            if moved <= 0.01 * delta:
                break
            delta *= 0.1
        if lam is not None:   # (dense; the fast path's own polish at any N)
            u, lam = getattr(prog, "contact_polish", contact_polish)(dp, u, lam, prog.rows,
                                                                     prog.levels)
    polished = _newton_polish(dp, u)
    if dp.contact != "obstacle":
        return s, polished, lam
    # With an obstacle, Newton without it serves when the beam lifts off
    # everywhere: the answer stays feasible and its multipliers are zero.
    gap = prog.rows @ polished - prog.levels
    reach = max(float(np.max(np.abs(polished))), float(np.max(np.abs(prog.levels))))
    # (the energy compared up to round-off of its parts: just above P_bar_h bending
    # and axial terms of 6e-3 cancel to -1.5e-8, and the polished point, 9e-17
    # "higher", was refused for an unpolished one with stationarity 1.2e-6 that
    # failed the certificate: campaign scene 1:52)
    parts = dp.energy_size(u)
    if np.min(gap, initial=np.inf) > 1e-9 * reach \
            and dp.energy(polished) <= dp.energy(u) + 1e-12 * parts:
        return s, polished, np.zeros(prog.rows.shape[0])
    return s, u, lam


def reflections(dp, u) -> list:
    """``u`` mirrored in x -> L - x, and its negative ([] unless mesh and supports allow it)."""
    x = dp.xi
    if not np.allclose(x[::-1], x[-1] - x, rtol=0.0, atol=1e-12 * x[-1]):
        return []
    full = dp.full(u)
    r = np.empty_like(full)
    r[0::2], r[1::2] = full[0::2][::-1], -full[1::2][::-1]
    fixed = np.setdiff1d(np.arange(len(full)), dp.free)
    if np.any(r[fixed] != 0):   # (P2, P3: the supports are not symmetric)
        return []
    return [r[dp.free], -r[dp.free]]


def answer_certificate(dp, prog, mf, u, lam):
    """The certificate of the answer ``u`` (:func:`.certificate.certify_answer`).

    Parameters
    ----------
    dp : DiscreteProblem
    prog : NodeProgram or FastProgram or FastContactProgram
        The search's node program.
    mf : MixedForm
        The mixed form the answer is certified in.
    u : ndarray
        Free Hermite DOFs of the answer.
    lam : ndarray or None
        Its obstacle multipliers (None: none known).

    Returns
    -------
    z : ndarray
        The mixed variables of ``u`` (on the mixed form's manifold).
    residual : dict
        The optimality measures (:func:`gaocvx.certificate.passes` judges them).
    lam : ndarray or None
        The multipliers that met them best.
    """
    z = mf.on_manifold(to_mixed(mf, u))
    return (z,) + certify_answer(dp, prog, mf, z, lam)


def search_best(dp, prog, mf, out, polished, lam, slack) -> tuple:
    """Whether the search's best point ``out.u`` is the answer instead of the ``polished`` one.

    ``polished`` are free DOFs with multipliers ``lam``; ``out`` the branch and
    bound's outcome; ``slack`` the energy (in ``dp``'s unit) by which the best may
    lie above the polished point.  The polish may take a point up to its own
    slack (:data:`SLACK`) above the best, for answers inside the obstacle by a
    solver's tolerance, that is no minimiser: the best is kept where the polished
    point fails its certificate, the best passes, and its energy is at most
    ``slack`` above the polished one's (a P3 beam pressed flat at gap 0 by two
    forces of 1.7e8 N: w = 0 passed, the polished point, 2.9e-4 J higher with no
    contact force, did not).

    Returns
    -------
    kept : bool
        Whether ``out.u`` (with ``out.lam``) is the answer.
    certificate : tuple or None
        :func:`answer_certificate` of the answer chosen, where it was computed
        here (None: not computed), so that it need not be computed again.
    """
    if out.u is None or polished is out.u:
        return False, None
    mine = answer_certificate(dp, prog, mf, polished, lam)
    if passes(mine[1]):
        return False, mine
    energy = feasible_energy(dp, prog)(out.u)
    if not energy <= dp.energy(polished) + slack:
        return False, mine
    theirs = answer_certificate(dp, prog, mf, out.u, out.lam)
    return (True, theirs) if passes(theirs[1]) else (False, mine)


def flat_answer(dp, prog, mf, bound):
    """The flat beam ``w = 0`` as the answer, where it is admissible, its energy at most
    ``bound`` (in ``dp``'s unit) and it passes the certificate; else None.

    Only with an obstacle and up to :data:`.whole_beam.MAX_UNKNOWNS` free DOFs (the
    dense certificate, :func:`.certificate.certify_flat`, as for
    :func:`.obstacle_checks.exact_flat`).  A beam pressed flat onto an obstacle at
    gap 0 just above ``P_bar_h`` is measured in a metric whose margin along the
    first mode is ``p - lambda_1``: there the search's answers, zero to round-off
    (9.6e-18 of W), failed it (the fast path's solve not resolving the step; the
    dense programs' polished point 1e-4 of the floor inside the obstacle), while
    ``w = 0`` itself, its contact forces recomputed on the touching rows, passes
    (a P1 beam in a channel at gap 0 at 1.0000017 ``P_bar_h``, a random campaign).

    Returns
    -------
    tuple or None
        ``(z, residual, lam)`` as :func:`answer_certificate`.
    """
    from .whole_beam import MAX_UNKNOWNS

    if dp.contact != "obstacle" or dp.n > MAX_UNKNOWNS:
        return None
    u0 = np.zeros(dp.n)
    if not dp.energy(u0) <= bound:
        return None
    flat = certify_flat(dp, prog.modes, prog.rows, prog.levels, mf.size_floor)
    return None if flat is None else (mf.on_manifold(to_mixed(mf, u0)),) + flat
