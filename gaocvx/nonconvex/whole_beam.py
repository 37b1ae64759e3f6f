"""An equilibrium with an obstacle polished on the whole beam and certified in its own scale.

The equilibrium searches find zeros of the reduced gradient ``∇F`` through
fixed-amplitude slices (:mod:`.slices`), whose accuracy is relative to the
scene's energy.  An equilibrium whose own energy is far smaller is then found
but not resolved: a saddle 7.2e-6 m from the flat beam at gap 0 (P1, two
modes, 9 elements; 0.76 J against the scene's 3.6e8 J) had ``|∇F| |s|`` 6e-4
of its own energy's parts after Newton's method on ``∇F``, and was dropped,
although the slice's beam was that equilibrium to 5e-5.

Here the slice's beam ``u`` starts an active-set Newton method on the
optimality conditions of the full energy

    ∇Π(u) = A_actᵀ λ,    A_act u = levels_act,

the active rows first those touching within ``TOUCH_TOL`` of ``u``'s own size
(its largest ``|w|`` at the nodes and the rows' points); after Newton's method
converges, a violated row is added, or else a row pulling (negative
multiplier) is dropped, and Newton's method runs again.  Where that does not
settle, it starts again with the rows within ``SCENE_TOUCH`` held (those the
slice, accurate relative to the scene, cannot tell from touching).  The
rows are scaled to unit norm and balanced against the Hessian, and dependent
rows (a flat contact: a cubic touching at four points of an element) are left
out by a pivoted QR, so the bordered system is solved exactly by a sparse LU
(unscaled, a least-squares solve cut the rows' directions away: Gauss rows
beside a pinned end have norms of 6e-3 against Hessian entries of 1e6, and
one saddle was listed twice, 2.8e-5 of its energy apart).  The end is an
equilibrium only if it passes the global method's certificate
(:func:`.certificate.psi_certificate`: stationarity of the Lagrangian in the
convex part's metric, feasibility, the multipliers' sign, complementarity)
*relative to its own size* (no floor), violates no row beyond round-off, and
lies within ``MOVE`` of ``u`` (relative, in the norm of all DOFs); callers also ask for its amplitudes to be the
zero's (within the searches' merging distance).

Its stability comes from the second-order conditions, with eigenvalues
relative to the bending stiffness ``K`` (generalised, ``Zᵀ H Z v = μ Zᵀ K Z v``:
relative to the largest they fall as h³, below any threshold beyond 100
elements; Jacobi-scaled): ``μ > eig_tol(N)`` on the null space of the rows
carrying a force (multiplier above ``EIG_TOL`` of the largest) is the
sufficient condition of a strict local minimum (stable); ``μ < -eig_tol(N)``
(``EIG_TOL``, larger beyond 178 elements: K's round-off) on the null space of every
touching row is a direction, admissible both ways, along which the energy
falls (unstable); anything else is undecided, and no answer is given.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..certificate import passes
from ..tolerances import TOUCH_TOL
from .certificate import beam_size, psi_certificate
from .cone import restricted_pencil, stable_on_cone
from .equilibrium import Equilibrium, same_point

__all__ = ["polish_equilibrium", "polisher", "settle", "same_beam", "second_order", "eig_tol",
           "MAX_UNKNOWNS", "MOVE", "EIG_TOL"]

log = logging.getLogger(__name__)

#: Free DOFs at most: the stability test's null spaces and eigenvalues are dense
#: (their cube: measured 0.6 s at 500 DOFs, 1.1 s at 1000, 13 s at 2000).
MAX_UNKNOWNS = 1000
#: The polished beam lies within this fraction of its size from the slice's: the
#: slices are accurate relative to the scene, not to the beam (the saddle above:
#: 5.3e-5 from the search's warm-started slice, 5e-11 from a slice solved afresh).
MOVE = 1e-3
#: Gaps (in the units of the problem polished: the scene's, or a second search's
#: own) within which a slice's row cannot be told from touching: its accuracy is
#: relative to that problem's scale.
SCENE_TOUCH = 1e-12
#: Generalised eigenvalues ``μ`` (relative to ``K``) and multipliers (relative to
#: the largest) within this of zero are taken as zero; eigenvalues within
#: :func:`eig_tol` on finer meshes.
EIG_TOL = 1e-8


def eig_tol(elements: int) -> float:
    """The threshold of ``μ`` on ``elements`` elements: ``EIG_TOL``, or ``1e-17 N^4``
    where larger (K's condition grows as N^4: three ways of computing one least
    ``μ`` at 480 elements -- the Jacobi-scaled and unscaled dense solves, and
    sparse Lanczos on (G, K) -- spread over 5e-8, at 30 elements over 6e-12;
    ``1e-17 N^4`` is 5.3e-7 at 480, 8e-8 at 300, and ``EIG_TOL`` to 178).

    >>> eig_tol(30) == EIG_TOL, round(eig_tol(480), 8)
    (True, 5.3e-07)
    """
    return max(EIG_TOL, 1e-17 * float(elements) ** 4)
#: Newton iterations per active set, and changes of the active set, at most (a set
#: met again ends the polish sooner: it cycles).  Changes move a contact's edge one
#: row at a time: a P4 beam lifted over 20 of its 32 elements in a channel at gap 0
#: (near P_bar_h) took 41 to 80 of them from its slice's beam, whose round-off
#: counted rows beyond the edge as touching (dropping every pulling row at once
#: oscillated instead).
MAX_ITER = 30
MAX_CHANGES = 100
#: Newton's steps below this fraction of the beam that no longer halve are round-off.
STALL = 1e-9
#: A row whose scaled pivot in the QR of the touching rows is below this is
#: dependent on the others.
RANK_TOL = 1e-10


def polish_equilibrium(dp, modes, u, rows, levels):
    """The equilibrium next to the free Hermite DOFs ``u``, polished and certified.

    Parameters
    ----------
    dp : DiscreteProblem
        The (rescaled) discrete problem with an obstacle.
    modes : Modes
        Its unstable modes (the certificate's metric; the amplitudes
        ``s = (G phi)' u``).
    u : ndarray
        Free Hermite DOFs of a beam near an equilibrium (a slice's).
    rows, levels : sparse matrix, ndarray
        The obstacle's rows ``rows u >= levels`` (:func:`.node.obstacle_rows`).

    Returns
    -------
    Equilibrium or None
        ``optimal``, with its stability from the second-order conditions, its
        residual the certificate's stationarity, its curvature NaN (no reduced
        function's) and ``whole_beam`` True; None where Newton's method does
        not converge, the active set does not settle, the beam moves further
        than ``MOVE`` (in the norm of all its DOFs, slopes included), the
        certificate fails, the stability is undecided, or ``u`` is the flat
        beam (its own check,
        :func:`.obstacle_checks.exact_flat`) or has more than ``MAX_UNKNOWNS``
        DOFs.

    Examples
    --------
    Two DOFs with energy ``|u|^2 / 2 + u_1 - u_2``, the first held by ``u_1 >= 0``:
    the equilibrium ``(0, 1)``, pressed with multiplier 1, is stable.

    >>> import numpy as np, scipy.sparse as sp
    >>> from types import SimpleNamespace
    >>> f = np.array([-1.0, 1.0])
    >>> dp = SimpleNamespace(gradient=lambda u: u - f, hessian=lambda u: sp.eye(2),
    ...     energy=lambda u: 0.5 * u @ u - f @ u, _w_rows=lambda: np.arange(2), G=sp.eye(2),
    ...     K=sp.eye(2), to_physical=lambda u: (u, 0 * u), x=np.zeros(2), E0=1.0, P=0.0,
    ...     W=1.0)
    >>> modes = SimpleNamespace(phi=np.zeros((2, 1)), c=np.zeros(1))
    >>> e = polish_equilibrium(dp, modes, np.array([0.0, 1.0 + 1e-9]),
    ...                        sp.csr_matrix([[1.0, 0.0]]), np.zeros(1))
    >>> e.stable, e.status, [float(v) for v in e.w]
    (True, 'optimal', [0.0, 1.0])
    """
    u = np.asarray(u, float)
    n = len(u)
    rows = sp.csr_matrix(rows)
    size = beam_size(dp, u, rows)
    if not (math.isfinite(size) and size > 0.0):
        return None     # (the flat beam itself: obstacle_checks.exact_flat)
    if n > MAX_UNKNOWNS:
        log.info("whole-beam polish: %d DOFs, above %d: not tried", n, MAX_UNKNOWNS)
        return None
    gap = rows @ u - levels
    x, lam = _active_set(dp, u, rows, levels, np.flatnonzero(gap <= TOUCH_TOL * size), size)
    if x is None and np.any((gap <= SCENE_TOUCH) & (gap > TOUCH_TOL * size)):
        # Again with the rows the slice cannot tell from touching (within its accuracy,
        # relative to the scene) held: a P4 beam at 1.000008 P_bar_h under an upward
        # load at one end (16 elements) rests on the obstacle but within its first
        # element, lifted 1.1e-12 m; its slice left the resting rows 1e-17 off (of
        # the scene's size), 1e-5 of the beam's, and the first Newton step without
        # them pushed it far through the obstacle, one row at a time never settling.
        x, lam = _active_set(dp, u, rows, levels, np.flatnonzero(gap <= SCENE_TOUCH), size)
    if x is None:
        return None
    moved = float(np.linalg.norm(x - u))
    if not moved <= MOVE * float(np.linalg.norm(x)):
        log.debug("whole-beam polish: moved %.3g (the beam's norm %.3g)", moved,
                  float(np.linalg.norm(x)))
        return None
    residual = psi_certificate(dp, modes, x, lam, rows, levels, 0.0)
    gap = rows @ x - levels
    if not passes(residual) or np.min(gap) < -1e-12 * size:
        log.debug("whole-beam polish: the certificate fails (%s, least gap %.3g of the size)",
                  residual, float(np.min(gap)) / size)
        return None
    stable = second_order(dp, x, rows, gap, lam, size)
    if stable is None:
        log.debug("whole-beam polish: the stability is undecided")
        return None
    w, slope = dp.to_physical(x)
    amplitudes = np.asarray(dp.G @ modes.phi).T @ x
    return Equilibrium(float(dp.energy(x) * dp.E0), stable, [float(a) for a in amplitudes],
                       dp.x.copy(), w, slope, float(residual["stationarity"]), "optimal",
                       float(dp.P), math.nan, float(dp.W), whole_beam=True)


def settled_start(dp, u, rows, levels):
    """The end of the active set's Newton's method from ``u`` with the rows it
    touches or violates held, or None where it does not settle.

    A start for :func:`polish_equilibrium` where ``u`` lies too far from any
    equilibrium for it (its ``MOVE``): the free beam's linear answer, which dips
    through an obstacle at gap 0 (a P2 beam of 7 elements, q = -2.7e-3 N/m, P =
    6e9 N: the saddle touching the obstacle beside the flat beam was missing).
    What :func:`polish_equilibrium` then certifies is an equilibrium however it
    was found; which one is the caller's to judge.
    """
    size = beam_size(dp, u, rows)
    if not (math.isfinite(size) and size > 0.0) or len(u) > MAX_UNKNOWNS:
        return None
    x, _ = _active_set(dp, np.asarray(u, float), rows, levels,
                       np.flatnonzero(rows @ u - levels <= 0.0), size)
    return x


def _active_set(dp, x, rows, levels, act, size) -> tuple:
    """Newton's method on the active rows ``act``, then the most violated row added or
    else the most pulling row dropped, until neither; ``(x, lam)``, or ``(None, None)``
    where Newton's method does not converge or the set does not settle within
    ``MAX_CHANGES`` (or comes back to one it had)."""
    act = set(np.asarray(act, int).tolist())
    seen = set()
    ref = float(np.linalg.norm(x))
    for _ in range(MAX_CHANGES):
        if frozenset(act) in seen:
            log.debug("whole-beam polish: the active set cycles")
            return None, None
        seen.add(frozenset(act))
        x, lam = _newton(dp, x, rows, levels, sorted(act), ref)
        if x is None:
            log.debug("whole-beam polish: Newton's method did not converge")
            return None, None
        gap = rows @ x - levels
        worst = int(np.argmin(gap))
        if gap[worst] < -1e-12 * size and worst not in act:
            log.debug("whole-beam polish: row %d added (gap %.3g of the size)", worst,
                      gap[worst] / size)
            act.add(worst)
            continue
        pull = int(np.argmin(lam))
        if lam[pull] < -EIG_TOL * max(float(np.max(np.abs(lam))), 1e-300):
            log.debug("whole-beam polish: row %d dropped (multiplier %.3g)", pull, lam[pull])
            act.discard(pull)
            continue
        return x, lam
    log.debug("whole-beam polish: the active set did not settle")
    return None, None


def _newton(dp, x, rows, levels, act, ref: float = 0.0) -> tuple:
    """Newton's method on ``∇Π = A_actᵀ λ, A_act x = levels_act``; ``(x, lam)`` with one
    multiplier per row of ``rows`` (zero off the independent active rows), or
    ``(None, None)`` where it does not converge.

    Steps are measured against the iterate's norm, at least ``ref`` (the polished
    beam's start): rows that pin every DOF hold the beam at w = 0 exactly, whose
    own norm (1e-39) is no measure, and the active set must go on from there (a
    P4 beam resting in a channel at gap 0, lifted 7.7e-13 m by a load table, 32
    elements: its slice's 184 touching rows dropped one by one).
    """
    A = rows[act].toarray() if act else np.zeros((0, len(x)))
    norms = np.linalg.norm(A, axis=1)
    keep = np.arange(len(act))
    if len(act):
        # independent rows (unit norm), by a QR with column pivoting of their transpose
        _, R, piv = la.qr((A / norms[:, None]).T, mode="economic", pivoting=True)
        d = np.abs(np.diag(R))
        keep = np.sort(piv[:int(np.sum(d > RANK_TOL * d[0]))])
    H0 = dp.hessian(x)
    beta = float(np.max(np.abs(H0.diagonal()))) or 1.0     # rows balanced against H
    scale = beta / norms[keep]
    B = sp.csr_matrix(A[keep] * scale[:, None])
    b = np.asarray(levels)[np.asarray(act, int)[keep]] * scale if len(keep) else np.zeros(0)
    m = B.shape[0]
    nu = np.zeros(m)
    if m:
        # the least-squares multipliers of the start: Newton then corrects them
        nu = la.lstsq(B.toarray().T, dp.gradient(x))[0]
    last = math.inf
    for _ in range(MAX_ITER):
        g = dp.gradient(x)
        H = sp.csr_matrix(dp.hessian(x))
        kkt = sp.bmat([[H, -B.T], [B, None]], format="csc")
        rhs = np.r_[-(g - B.T @ nu), -(B @ x - b)]
        try:
            step = spla.splu(kkt).solve(rhs)
        except RuntimeError:    # (singular: a degenerate set)
            return None, None
        if not np.all(np.isfinite(step)):
            return None, None
        x, nu = x + step[:len(x)], nu + step[len(x):]
        # converged: a step of round-off, or one no longer halving once below
        # STALL of the beam (the gradient's round-off grows like N^4 eps in the
        # Hermite DOFs: at 30 elements the steps stalled near 1e-12 of it)
        dx = float(np.linalg.norm(step[:len(x)]))
        size = max(float(np.linalg.norm(x)), ref)
        if dx <= 1e-13 * size or (dx <= STALL * size and dx > 0.5 * last):
            lam = np.zeros(rows.shape[0])
            lam[np.asarray(act, int)[keep]] = nu * scale
            return x, lam
        last = dx
    return None, None


def polisher(dp, modes):
    """``u -> polish_equilibrium(dp, modes, u, rows, levels)`` for ``dp``'s obstacle
    (:func:`.node.obstacle_rows`); None without an obstacle or modes."""
    if dp.contact != "obstacle" or modes is None:
        return None
    from .node import obstacle_rows

    rows, levels = obstacle_rows(dp)
    return lambda u: polish_equilibrium(dp, modes, u, rows, levels)


def settle(dp, polish, eqs, S, modes=None) -> list:
    """Every ``optimal`` entry of ``eqs`` (not the flat beam) polished on the whole beam
    where that succeeds at its amplitudes (within ``MERGE S``), and entries so
    polished that are one beam (deflections and slopes within 1e-9 of their
    size) listed once; with ``modes``, every polished entry's amplitudes are its
    beam's (during the search they are the zero's, where its slices were
    solved, :func:`.stationary2.find_plane`).

    Slices leave the beams of equilibria near the flat beam accurate to the
    scene only, and a second search near the flat beam merges within its own
    smaller square's distance: one saddle was listed twice, 7.2e-9 apart in
    ``s`` (P1 pressed at gap 0, two modes, 30 elements).  Entries whose polish
    fails stay as they are: near a contact that is degenerate (a row touching
    with no force, where the active set cycles) one equilibrium may still be
    listed several times, each passing the certificate (P1 pressed at gap 0
    under 2e6 N/m at three times P_bar_h, 12 elements: five entries within
    6e-5 of their amplitudes, stationarity up to 6e-9 in their own scale).
    """
    if polish is None:
        return eqs
    out = []
    for e in eqs:
        if e is not None and e.status == "optimal" and not e.whole_beam and np.any(e.w):
            p = polish(dp.from_physical(e.w, e.slope))
            if p is not None and same_point(p.amplitudes, e.amplitudes, S):
                e = p
        if e is not None and e.whole_beam and any(
                o.whole_beam and same_beam(o, e) for o in out if o is not None):
            continue
        if e is not None and e.whole_beam and modes is not None:
            u = dp.from_physical(e.w, e.slope)
            e.amplitudes = [float(a) for a in np.asarray(dp.G @ modes.phi).T @ u]
        out.append(e)
    return out


def same_beam(a, b, tol: float = 1e-9) -> bool:
    """Whether equilibria ``a`` and ``b`` (``w``, ``slope`` at the nodes ``x``) are one
    beam: deflections within ``tol`` of the larger ``|w|`` or ``|slope|`` times the
    shortest element, slopes within ``tol`` of the larger ``|slope|`` or of that
    ``|w|`` over the beam's length, where larger.

    (The element's: a P4 beam at gap 0 lifted within its first element only, 16
    elements, has nodal deflections of round-off, 1e-40 m, and slopes of 1.2e-10 at
    one end; found twice, it was listed twice, and the list `inaccurate` for two
    minima without a saddle.)

    (The length's: a P1 beam pressed flat onto an obstacle 5.5 cm below by
    3.2e13 N/m, 8 elements, has slopes of round-off, 1.7e-15, and its polished
    mirror image, the same beam, had them of the other sign: it was listed twice,
    and the list `inaccurate` for two minima without a saddle -- a campaign at
    extreme loads.)
    """
    top = max(float(np.max(np.abs(a.w))), float(np.max(np.abs(b.w))), 1e-300)
    turn = max(float(np.max(np.abs(a.slope))), float(np.max(np.abs(b.slope))))
    tilt = max(turn, top / float(a.x[-1] - a.x[0]), 1e-300)
    top = max(top, turn * float(np.min(np.diff(a.x))))
    return bool(np.max(np.abs(a.w - b.w)) <= tol * top
                and np.max(np.abs(a.slope - b.slope)) <= tol * tilt)


def second_order(dp, x, rows, gap, lam, size):
    """The stability of the KKT point ``x`` (multipliers ``lam``, gaps ``gap``, rows
    touching within ``TOUCH_TOL`` of ``size``) from the second-order conditions:
    True (a strict local minimum), False (unstable) or None (undecided); see the
    module's notes."""
    H = dp.hessian(x)
    H = H.toarray() if hasattr(H, "toarray") else np.asarray(H)
    K = dp.K.toarray() if hasattr(dp.K, "toarray") else np.asarray(dp.K)
    strong = np.flatnonzero(lam > EIG_TOL * max(float(np.max(lam, initial=0.0)), 1e-300))
    touch = np.flatnonzero(gap <= TOUCH_TOL * size)
    tol = eig_tol(len(dp.x) - 1)
    if _least(H, K, rows, strong) > tol:
        return True
    if _least(H, K, rows, touch) < -tol:
        return False
    # (between the two: rows touching without a force, one way only)
    return stable_on_cone(H, K, rows, strong, np.setdiff1d(touch, strong), tol)


def _least(H, K, rows, idx) -> float:
    """Least eigenvalue of ``H`` relative to ``K`` on the null space of ``rows[idx]``."""
    mu, _ = restricted_pencil(H, K, rows, idx)
    return float(mu[0]) if len(mu) else math.inf
