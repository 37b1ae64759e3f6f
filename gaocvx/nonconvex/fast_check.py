"""The fast obstacle path's amplitude ranges, final polish and certificate (any N).

Companions of :class:`.fast_contact.FastContactProgram` that the dense path
does with dense Hermite matrices (:mod:`.certificate`), which beyond a few
hundred elements are too slow (a dense least-squares KKT solve took 14 s of
15 at 512 elements) or lose the digits the certificate needs (condition
~N^4):

* :func:`amplitude_range`: each unstable mode's amplitude range over the
  admissible set (a linear program), so that boxes without an admissible beam
  are recognised as such;
* :func:`contact_polish`: the answer polished by
  :func:`gaocvx.contact_newton._iterate` at the largest penalty, on the mixed form;
* :func:`certify`: :func:`.certificate.psi_certificate`'s measures, the same
  definitions and tolerances, computed in the mixed form; :func:`certify_contact`
  tries the multipliers as :func:`.certificate.certify_contact` does.

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> from gaocvx.nonconvex.modes import unstable_modes
>>> from gaocvx.nonconvex.fast_contact import FastContactProgram
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"axial": 1.5e9}, "obstacle": {"gap": 0.01, "gap_above": 0.01},
...     "mesh": {"elements": 8}})
>>> dp = DiscreteProblem(scene, check_convexity=False)
>>> lo, hi = amplitude_range(FastContactProgram(dp, unstable_modes(dp)))
>>> bool(lo[0] < 0 < hi[0] and abs(lo[0] + hi[0]) < 1e-6 * hi[0])   # a channel: both ends
True
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import sys

import numpy as np
import scipy.optimize as so

from ..certificate import passes, shortfall
from ..linalg import one_blas_thread
from ..tolerances import STATIONARITY_TOL, TOUCH_TOL, complementarity

__all__ = ["amplitude_range", "contact_polish", "certify", "certify_contact", "lp_ranges",
           "lp_min", "padded", "RANGE_PAD", "POLISH_BUDGET"]

log = logging.getLogger(__name__)

# The amplitudes' ranges from the linear program are widened by this, relative to
# 1 + their size (HiGHS meets its tolerances to ~1e-9; the margin only costs tightness).
RANGE_PAD = 1e-6
# Factorisations of the final polish (contact_newton's updates at the largest penalty).
POLISH_BUDGET = 12


# The linear programs of amplitude_range: HiGHS's methods, the first also without presolve.
LP_ATTEMPTS = (("highs", {}), ("highs", {"presolve": False}), ("highs-ds", {}),
               ("highs-ipm", {}))


@contextlib.contextmanager
def _quiet_stdout():
    """The process's standard output (file descriptor 1) sent to /dev/null.

    HiGHS prints some failures there itself ("Highs::returnFromOptimizeModel:
    ... Solve error"), where ``gaocvx solve --json`` writes its JSON: a hidden-scene
    trial's JSON did not parse.  The failure is logged by the caller instead.
    The descriptor itself, whatever ``sys.stdout`` is (HiGHS writes to the C
    library's stdout); where it cannot be duplicated, nothing is redirected.
    """
    try:
        sys.stdout.flush()
    except (AttributeError, ValueError, OSError):
        pass
    try:
        saved = os.dup(1)
    except OSError:
        yield
        return
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
            _flush_c_stdio()   # (what HiGHS left in the C library's buffer goes there too)
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _flush_c_stdio() -> None:
    """``fflush(NULL)`` of the C library, where ctypes can reach it."""
    try:
        import ctypes
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):
        pass


def amplitude_range(prog):
    """Each amplitude's range ``(lo, hi)`` over the admissible set (LP), widened by RANGE_PAD.

    ``min / max  B_i z`` subject to the linking constraints and the obstacle's
    rows, by :func:`lp_ranges`, widened by RANGE_PAD.  Unbounded sides are
    infinite, and so is a side HiGHS fails on or whose dual residual is not
    round-off (a weaker range, never a narrower one).
    """
    D, origin, *lp = prog.admissible_lp()
    lo, hi = lp_ranges(D, *lp)
    return padded(lo + origin, hi + origin)


def padded(lo, hi):
    """``(lo, hi)`` widened by RANGE_PAD relative to 1 + their largest finite end."""
    ends = np.r_[lo, hi]
    size = 1.0 + np.max(np.abs(ends[np.isfinite(ends)]), initial=0.0)
    return lo - RANGE_PAD * size, hi + RANGE_PAD * size


def lp_ranges(D, A_ub, b_ub, A_eq, b_eq):
    """Bounds ``lo_i <= min d_i'z`` and ``hi_i >= max d_i'z`` over ``{A_ub z <= b_ub, A_eq z = b_eq}``.

    One linear program (HiGHS) per row ``d_i`` of ``D`` and side; each end is
    taken from the dual solution, a bound by weak duality whose residual is
    checked.  A side that is unbounded, that HiGHS fails on, or whose dual
    residual is not round-off is infinite (a weaker range, never a narrower one).

    Examples
    --------
    >>> lo, hi = lp_ranges(np.eye(2), np.array([[1.0, 1.0], [-1.0, 0.0], [0.0, -1.0]]),
    ...                    np.array([1.0, 0.0, 0.0]), np.zeros((0, 2)), np.zeros(0))
    >>> np.allclose(lo, 0.0) and np.allclose(hi, 1.0)     # the triangle's sides
    True
    """
    D = np.atleast_2d(np.asarray(D, float))
    k = D.shape[0]
    lo, hi = np.full(k, -math.inf), np.full(k, math.inf)
    for i in range(k):
        # (normalised: at 2048 elements HiGHS stopped on "numerical difficulties"
        # with the rows of B as they are, ~2e-3)
        scale = max(float(np.max(np.abs(D[i]))), 1e-300)
        direction = D[i] / scale
        lo[i] = scale * lp_min(direction, A_ub, b_ub, A_eq, b_eq)[0]
        hi[i] = -scale * lp_min(-direction, A_ub, b_ub, A_eq, b_eq)[0]
    return lo, hi


def lp_min(direction, A_ub, b_ub, A_eq, b_eq) -> tuple:
    """A lower bound of ``min direction'z`` over ``{A_ub z <= b_ub, A_eq z = b_eq}``, and a minimiser.

    The bound is taken from the dual solution (weak duality, its residual
    checked); ``-inf`` where the program is unbounded, HiGHS fails or the dual
    residual is not round-off, and the minimiser then ``None`` (a weaker bound,
    never a wrong one).
    """
    # (HiGHS's presolve failed, "Solve error", on a P1 beam's third mode with an
    # obstacle below, where the LP is unbounded; without presolve it says so)
    for method, options in LP_ATTEMPTS:
        with _quiet_stdout():
            res = so.linprog(direction, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq,
                             bounds=(None, None), method=method, options=options)
        if res.status in (0, 3):
            break
    if res.status != 0:
        if res.status != 3:   # 3: unbounded (no limit on that side)
            log.warning("amplitude range: linprog status %d (%s)", res.status, res.message)
        return -math.inf, None
    # The end is taken from the dual, a bound by weak duality: with y <= 0 for the
    # rows A_ub z <= b_ub and the equality multipliers,
    # d'z = y'A_ub z + y_eq'A_eq z + r'z >= y'b_ub + y_eq'b_eq + r'z,
    # r the dual residual, checked to be round-off (measured 2e-16 at 2048
    # elements; the primal and dual values agreed to 3e-16).
    y = np.minimum(res.ineqlin.marginals, 0.0)
    y_eq = res.eqlin.marginals
    r = direction - A_ub.T @ y - A_eq.T @ y_eq
    if float(np.max(np.abs(r))) > 1e-10:
        log.warning("amplitude range: dual residual %.1e; no end taken", float(np.max(np.abs(r))))
        return -math.inf, None
    return float(b_ub @ y + b_eq @ y_eq), np.asarray(res.x, float)


def contact_polish(prog, u, lam):
    """Newton on the full problem's augmented Lagrangian from ``(u, lam)`` (banded, any N).

    :func:`.certificate.contact_polish` does this with dense Hermite KKT
    systems.  Here :func:`gaocvx.contact_newton._iterate` at the largest
    penalty, on the mixed form, until feasibility, multipliers' sign and
    complementarity are within its margins (``start_only``: its own
    stationarity measure is :func:`gaocvx.certificate.certify`'s, whose metric, the
    energy's Hessian, is indefinite above ``P_bar_h``).  The iterate is judged
    by :func:`certify` and kept only if that passes, improves on the start's
    and the energy does not rise beyond round-off; otherwise ``(u, lam)``
    stand.  (The node program on a tiny box, which starts the polish, has a
    gradient error of ``c`` times the box's width: stationarity 7e-7 at 16
    elements.)
    """
    from ..contact_newton import _iterate
    from .polish import to_mixed

    mf = prog.mf
    floor = mf.size_floor
    z0 = mf.on_manifold(to_mixed(mf, u))
    lam = np.asarray(lam, float)
    before = certify(prog, z0, lam, floor)
    e0 = sum(mf.energy_parts(z0).values())
    # First to its margins of feasibility and complementarity; if that is not
    # certified, the whole budget (its last iterate; a beam lying flat at gap 0
    # met those margins at once, from a slice answer 3.7e-5 from stationary).
    for start_only in (True, False):
        try:
            with one_blas_thread():
                z, lam2, _, _, _ = _iterate(mf, z0, lam, prog.rho, prog.rho, POLISH_BUDGET,
                                            start_only=start_only)
        except (np.linalg.LinAlgError, FloatingPointError):
            continue
        z = mf.on_manifold(z)
        after = certify(prog, z, lam2, floor)
        e1 = sum(mf.energy_parts(z).values())
        if passes(after) and shortfall(after) < shortfall(before) \
                and e1 <= e0 + 1e-12 * max(abs(e0), 1.0):
            return mf.to_hermite(z), lam2
    return u, lam


def certify_contact(prog, z, lam, floor: float = 0.0) -> tuple:
    """:func:`certify` with the solver's multipliers and with those on the touching rows only.

    As :func:`.certificate.certify_contact`: the optimality conditions hold
    when *some* multipliers satisfy them, and each candidate is checked in
    full.  The second candidate is the solver's multipliers with those of rows
    that do not touch (gap above ``TOUCH_TOL`` of the answer's size) set to
    zero: the method of multipliers leaves forces of its own tolerance on rows
    just off the obstacle (measured: complementarity 1.9e-4 of a beam pressed
    flat at gap 0 on 2048 elements, whose answer is zero to round-off).

    Returns
    -------
    residual : dict
    lam : ndarray
        The multipliers the measures belong to.
    """
    mf = prog.mf
    touching = np.where(mf.gap(z) <= TOUCH_TOL * _size(mf, z, floor), lam, 0.0)
    for cand in (touching, lam):
        res = certify(prog, z, cand, floor)
        if passes(res):
            return res, cand
    return res, lam   # neither: the solver's own, as measured


def _size(mf, z, floor):
    """The answer's largest nodal |w|, at least ``floor`` (:func:`.certificate._size`
    also takes |w| at the obstacle rows' points, for the whole-beam polish's beams
    lifted within one element; the fast path's answers are measured at the nodes)."""
    return max(float(np.max(np.abs(mf.absolute(z)[mf.w_index]), initial=0.0)), floor, 1e-300)


def certify(prog, z, lam, floor: float = 0.0) -> dict:
    """:func:`.certificate.psi_certificate`'s measures, computed in the mixed form (any N).

    The same definitions and tolerances: stationarity of the Lagrangian
    ``r = grad Pi - A' lam`` as ``sqrt(r' H_psi^-1 r)`` relative to the
    answer's ``sqrt(u' H_psi u)`` (at least ``floor``), with
    ``H_psi = H + 4 B' diag(c) B``; feasibility, the multipliers' sign and
    complementarity as there.  In the Hermite DOFs ``H_psi`` has condition
    ~N^4 and its dense Cholesky factor does not resolve the residual beyond
    ~1000 elements (measured: 2.6e-7 at 1024, 5.5e-6 at 2048 elements for an
    answer these measures put at 1e-10); here it is the banded KKT LU of the
    mixed form and the Woodbury identity (``prog._solve``).  ``z`` must lie on
    the linking constraints (``mf.on_manifold``).  A solve whose own residual,
    solved once more, is not small against the step makes the stationarity
    infinite (as :func:`gaocvx.certificate.certify`).  ``H_psi`` is positive
    definite when the modes passed their checks (``Psi`` convex, plus
    ``2 B' diag(c) B``), which the caller requires for ``optimal``.
    """
    mf = prog.mf
    H = mf.hessian(z)
    D = 4.0 * prog.c
    r = mf.gradient(z) - mf.AT @ lam
    za = mf.absolute(z)
    try:
        with one_blas_thread():
            d, mu = prog._solve(H, D, -r, -mf.link(z))
            Bd, Bz = prog.B @ d, prog.B @ za
            step = float(d @ (H @ d)) + float(D @ (Bd * Bd))
            size2 = float(za @ (H @ za)) + float(D @ (Bz * Bz))
            # the solve's own error, solved for once more
            Hd = H @ d + prog.B.T @ (D * Bd)
            dd, _ = prog._solve(H, D, -r - (Hd + mf.C.T @ mu), -mf.link(z) - mf.C @ d)
            Bdd = prog.B @ dd
            error = math.sqrt(abs(float(dd @ (H @ dd)) + float(D @ (Bdd * Bdd))))
    except np.linalg.LinAlgError:
        return {"stationarity": math.inf}
    scale = max(math.sqrt(max(size2, 0.0)), floor) or 1.0
    # (H alone is indefinite, so a step that is zero to round-off can come out
    # negative: a flat beam at gap 0 had -2.8e-33 and its certificate failed as
    # infinite.  Below what the certificate can notice, as for the solve's own
    # error, it counts as 0; beyond that H_psi is not positive definite.)
    if -(1e-3 * STATIONARITY_TOL * scale) ** 2 <= step < 0.0:
        step = 0.0
    stationarity = math.sqrt(step) / scale if step >= 0 and size2 >= 0 else math.inf
    if not (error <= 0.1 * math.sqrt(max(step, 0.0)) or error <= 1e-3 * STATIONARITY_TOL * scale):
        stationarity = math.inf
    gap = mf.gap(z)
    size = _size(mf, z, floor)
    lam_scale = float(np.max(np.abs(lam), initial=0.0)) or 1.0
    return {"stationarity": stationarity,
            "feasibility": float(max(-np.min(gap, initial=0.0), 0.0) / size),
            "dual": float(max(-np.min(lam, initial=0.0), 0.0) / lam_scale),
            "complementarity": complementarity(lam, gap, scale, size)}
