"""An equilibrium with an obstacle polished on the whole beam and certified in its own scale.

The equilibrium searches find zeros of the reduced gradient ``∇F`` through
fixed-amplitude slices (:mod:`.slices`), whose accuracy is relative to the
scene's energy.  An equilibrium whose own energy is far smaller is then found
but not resolved: a saddle 7.2e-6 m from the flat beam at gap 0 (P1, two
modes, 9 elements; 0.76 J against the scene's 3.6e8 J) had ``|∇F| |s|`` 6e-4
of its own energy's parts after Newton's method on ``∇F``, and was dropped,
although the slice's beam was that equilibrium to 5e-11.

Here the slice's beam ``u`` is taken as the start of Newton's method on the
optimality conditions of the full energy with the touching rows as equalities

    ∇Π(u) = A_actᵀ λ,    A_act u = levels_act,

(the rows touching within ``TOUCH_TOL`` of ``u``'s own size; the systems solved
in the least-squares sense, as touching rows of a flat contact are dependent).
The end is an equilibrium only if it passes the global method's certificate
(:func:`.certificate.psi_certificate`: stationarity of the Lagrangian in the
convex part's metric, feasibility, the multipliers' sign, complementarity)
*relative to its own size* (no floor), and lies within ``MOVE`` of ``u`` (the
root found is this equilibrium, not a neighbour's).  Its stability comes from
the Hessian on the touching rows' null space ``Z``: a negative eigenvalue of
``Zᵀ H Z`` is a direction, admissible both ways, along which the energy falls
(unstable); all eigenvalues positive with every touching row's multiplier
positive is the second-order sufficient condition of a strict local minimum
(stable); anything else (a weakly active row, an eigenvalue within round-off
of zero) is undecided, and no answer is given.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.linalg as la

from ..certificate import passes
from ..tolerances import TOUCH_TOL
from .certificate import psi_certificate
from .equilibrium import Equilibrium

__all__ = ["polish_equilibrium", "polisher", "MAX_UNKNOWNS", "MOVE", "EIG_TOL"]

log = logging.getLogger(__name__)

#: Unknowns (DOFs plus touching rows) of the dense systems solved, at most: the
#: least-squares KKT solve costs their cube (about 0.5 s at 2000).
MAX_UNKNOWNS = 2000
#: The polished beam lies within this fraction of its size from the slice's: the
#: slices are accurate relative to the scene, not to the beam (the saddle above:
#: 5.3e-5 from the search's warm-started slice, 5e-11 from a slice solved afresh).
MOVE = 1e-3
#: Eigenvalues of ``Zᵀ H Z`` (and multipliers) within this fraction of the largest
#: are taken as zero (round-off of the eigenvalues is about 1e-13 of the largest).
EIG_TOL = 1e-8
MAX_ITER = 20


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
        residual the certificate's stationarity and its curvature NaN (no
        reduced function's); None where Newton's method does not converge,
        moves further than ``MOVE``, the certificate fails or the stability is
        undecided.

    Examples
    --------
    Two DOFs with energy ``|u|^2 / 2 + u_1 - u_2``, the first held by ``u_1 >= 0``:
    the equilibrium ``(0, 1)``, pressed with multiplier 1, is stable.

    >>> import numpy as np, scipy.sparse as sp
    >>> from types import SimpleNamespace
    >>> f = np.array([-1.0, 1.0])
    >>> dp = SimpleNamespace(gradient=lambda u: u - f, hessian=lambda u: sp.eye(2),
    ...     energy=lambda u: 0.5 * u @ u - f @ u, _w_rows=lambda: np.arange(2), G=sp.eye(2),
    ...     to_physical=lambda u: (u, 0 * u), x=np.zeros(2), E0=1.0, P=0.0, W=1.0)
    >>> modes = SimpleNamespace(phi=np.zeros((2, 1)), c=np.zeros(1))
    >>> e = polish_equilibrium(dp, modes, np.array([0.0, 1.0 + 1e-9]),
    ...                        sp.csr_matrix([[1.0, 0.0]]), np.zeros(1))
    >>> e.stable, e.status, [float(v) for v in e.w]
    (True, 'optimal', [0.0, 1.0])
    """
    u = np.asarray(u, float)
    n = len(u)
    size = float(np.max(np.abs(u[dp._w_rows()]), initial=0.0))
    if not (math.isfinite(size) and size > 0.0):
        return None     # (the flat beam itself: obstacle_checks.exact_flat)
    act = np.flatnonzero(rows @ u - levels <= TOUCH_TOL * size)
    m = len(act)
    if n + m > MAX_UNKNOWNS:
        return None
    A = rows[act].toarray()
    x = u.copy()
    # (the least-squares multipliers of the start: Newton's first step then only
    # corrects them)
    mult = la.lstsq(A.T, dp.gradient(x))[0] if m else np.zeros(0)
    for _ in range(MAX_ITER):
        g = dp.gradient(x)
        H = dp.hessian(x)
        H = H.toarray() if hasattr(H, "toarray") else np.asarray(H)
        kkt = np.block([[H, -A.T], [A, np.zeros((m, m))]])
        rhs = np.r_[-(g - A.T @ mult), -(A @ x - levels[act])]
        step = la.lstsq(kkt, rhs, cond=1e-14)[0]
        if not np.all(np.isfinite(step)):
            return None
        x, mult = x + step[:n], mult + step[n:]
        if np.linalg.norm(step[:n]) <= 1e-13 * np.linalg.norm(x):
            break
    else:
        log.debug("whole-beam polish: Newton's method did not converge")
        return None
    moved = float(np.linalg.norm(x - u))
    if not moved <= MOVE * float(np.linalg.norm(x)):
        log.debug("whole-beam polish: moved %.3g (the beam's norm %.3g)", moved,
                  float(np.linalg.norm(x)))
        return None
    lam = np.zeros(rows.shape[0])
    lam[act] = mult
    residual = psi_certificate(dp, modes, x, lam, rows, levels, 0.0)
    if not passes(residual):
        log.debug("whole-beam polish: the certificate fails (%s)", residual)
        return None
    stable, least = _stability(dp, x, A, mult)
    if stable is None:
        log.debug("whole-beam polish: the stability is undecided")
        return None
    w, slope = dp.to_physical(x)
    amplitudes = np.asarray(dp.G @ modes.phi).T @ x
    return Equilibrium(float(dp.energy(x) * dp.E0), stable, [float(a) for a in amplitudes],
                       dp.x.copy(), w, slope, float(residual["stationarity"]), "optimal",
                       float(dp.P), math.nan, float(dp.W), whole_beam=True)


def polisher(dp, modes):
    """``u -> polish_equilibrium(dp, modes, u, rows, levels)`` for ``dp``'s obstacle
    (:func:`.node.obstacle_rows`); None without an obstacle or modes."""
    if dp.contact != "obstacle" or modes is None:
        return None
    from .node import obstacle_rows

    rows, levels = obstacle_rows(dp)
    return lambda u: polish_equilibrium(dp, modes, u, rows, levels)


def _stability(dp, x, A, mult) -> tuple:
    """``(stable, least eigenvalue)`` from the second-order conditions, or ``(None, nan)``."""
    H = dp.hessian(x)
    H = H.toarray() if hasattr(H, "toarray") else np.asarray(H)
    Z = la.null_space(A) if len(A) else np.eye(len(x))
    if Z.shape[1] == 0:
        # (the touching rows fix the beam: a minimum if every one pushes)
        ok = len(mult) and np.min(mult) > EIG_TOL * np.max(np.abs(mult))
        return (True, math.inf) if ok else (None, math.nan)
    eig = np.linalg.eigvalsh(Z.T @ H @ Z)
    tol = EIG_TOL * max(float(np.max(np.abs(eig))), 1e-300)
    if eig[0] < -tol:
        return False, float(eig[0])
    pushing = not len(mult) or np.min(mult) > EIG_TOL * max(float(np.max(np.abs(mult))), 1e-300)
    if eig[0] > tol and pushing:
        return True, float(eig[0])
    return None, math.nan
