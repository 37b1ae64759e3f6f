"""A zero of F' (one unstable mode) refined and measured in its beam's own scale.

:func:`.stationary1.find_line` brackets each zero of the reduced gradient F' by
Brent's method to ``1e-13 S`` (S the amplitude range's scale), and its residual
``|F'| |s|`` is measured against the scene's energy scale.  Both are the
scene's scale, not the equilibrium's: near the convexity limit under a small
load, a stable beam 1.3e-16 m deep had its amplitude ``s = 7.6e-9`` located to
``5.6e-14``, passed the residual test (1.2e-9 against 1e-8) and was listed
``optimal`` 7.4e-6 of its own size from the certified global minimiser (P2 on
a bed at gap 0, q = -1e-6 N/m, 1e-13 above P_bar_h; a random campaign).

:func:`own_step` takes Newton steps on F' from the bracketed zero, with F''
from F' at ``s -+ h`` (``h`` a thousandth of ``|s|``: the curvature where the
beam is), and returns the last step's size in the beam's own deflection: the
step ``|F'| / |F''|`` (``|F'|`` at least its error: its round-off,
``LABEL_NOISE`` eps own / size, :mod:`.roundoff`, and the dense programs'
accuracy) times ``max |dw/ds|``, over the beam's largest ``|w|`` (at least
``ZERO_ANSWER`` of the unsupported linear answer, the floor :func:`gaocvx.solve`
certifies a beam flat on an obstacle against; without load that of the
deflection the amplitude ``S`` makes).  That is the one-mode form of
:func:`gaocvx.solve`'s stationarity (a Newton step in the answer's own scale):
the entry is ``optimal`` only where it is at most :data:`STEP_TOL`.
"""

from __future__ import annotations

import math

import numpy as np

from ..mixed import MixedForm
from ..tolerances import STATIONARITY_TOL, ZERO_ANSWER
from .equilibrium import MERGE
from .roundoff import LABEL_NOISE, NOISE, round_off

__all__ = ["own_step", "plane_step", "zero_floor", "STEP_TOL"]

# The Newton step in the beam's deflection, relative to its largest |w|, at most
# (the convex ground truth's stationarity tolerance).
STEP_TOL = STATIONARITY_TOL
# F'' from F' at s -+ H_REL |s| (at least H_MIN S), widened tenfold while F'
# there differs by round-off only, up to WIDEST |s| or the stability probes' PROBE S
# (a symmetric P4 beam on a bonded bed under load, its unstable zero at s = 0).
H_REL = 1e-3
H_MIN = 1e-12
WIDEST = 0.1
PROBE = 1e-6
# Newton steps at most; each is kept only where it lowers |F'| and moves s by at
# most MOVE S (Brent's bracket was 1e-13 S: a longer step is F''s noise).
STEPS = 4
MOVE = 1e-11
# Two modes: Newton steps at most (the Hessian again at each), within the
# searches' merging distance MERGE S or PLANE_REACH of the zero's |s| of where
# it was found (the plane's Newton method stopped on steps of 1e-13 S).
PLANE_STEPS = 12
PLANE_REACH = 0.5


def own_step(dp, dF, r, S, error=None, zero_floor=None) -> tuple:
    """``(s, step)``: the zero ``r`` of F' refined by Newton's method, and its step.

    Parameters
    ----------
    dp : DiscreteProblem
        The problem in the units of the search.
    dF : callable
        ``dF(s) -> (F, F', u, ok)``, memoised (:func:`.stationary1.memoised`).
    r : float
        A zero of F' (Brent's, or a grid point where F' = 0).
    S : float
        The amplitude range's scale.
    error : callable, optional
        ``error(s, u)``: F''s error at ``s`` (its slice the beam ``u``), below
        which a nonzero F' tells nothing: :func:`.roundoff.label_threshold`'s (F''s
        round-off, and the dense programs' accuracy); by default the round-off,
        ``LABEL_NOISE`` eps own / size.
    zero_floor : float, optional
        Under load, the deflection [m] below which a beam counts as zero
        (:attr:`gaocvx.mixed.MixedForm.zero_floor` times ``W``: ``ZERO_ANSWER``
        of the unsupported linear answer).  None without load: ``ZERO_ANSWER``
        of the deflection the amplitude ``S`` makes.

    Returns
    -------
    s : float
        The refined zero (``r`` where no step lowered ``|F'|``).
    step : float
        The last Newton step's change of the deflection, relative to the beam's
        largest ``|w|``; ``inf`` where F'' could not be told from round-off or a
        probe's slice failed; 0 where F' is exactly 0.

    Examples
    --------
    A stand-in problem whose deflection is the amplitude, F' = 5.3 (s + 7.6e-9),
    and a zero located to the scene's 1e-13 S (S = 314), 7.4e-6 of itself off:

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> dp = SimpleNamespace(G=np.eye(1), energy_size=lambda u: 1e-15,
    ...                      to_physical=lambda u: (u, 0 * u))
    >>> dF = lambda t: (0.0, 5.3 * (t + 7.6e-9), np.array([t]), True)
    >>> s, step = own_step(dp, dF, -7.6e-9 + 5.6e-14, 314.0, zero_floor=1e-26)
    >>> bool(abs(s + 7.6e-9) < 1e-20), bool(step < 1e-9)
    (True, True)
    """
    _, d, u, ok = dF(r)
    if u is None or not ok:
        return r, math.inf
    if d == 0.0:
        return r, 0.0
    slope = _slope(dp, dF, r, S)
    if slope is None:
        return r, math.inf
    curvature, dwds = slope
    for _ in range(STEPS):
        t = r - d / curvature
        if not (0.0 < abs(t - r) <= MOVE * S):
            break
        _, dt, ut, okt = dF(t)
        if ut is None or not okt or not abs(dt) < abs(d):
            break
        r, d, u = t, dt, ut
        if d == 0.0:
            return r, 0.0
    size = _size(dp, u, S, dwds, zero_floor)
    # (|F'| at least its round-off: a zero F''s scatter makes is known only that
    # well -- without load 1e-12 above P_bar_h, 16 elements, F' was 3e-20 at a
    # buckled beam, its round-off 2e-18, and the beam 4.7e-5 of its size from a
    # zero of the whole beam's gradient)
    known = error(r, u) if error is not None else LABEL_NOISE / NOISE * round_off(dp, u, r)
    move = max(abs(d), known) / abs(curvature) * dwds
    return r, (move / size if size > 0.0 else math.inf)


def plane_step(dp, grad, hessian, r, S, zero_floor=None) -> tuple:
    """``(s, step)``: a zero ``r`` of two modes' ``∇F`` refined by Newton's method,
    and its step in the beam's own scale, as :func:`own_step` for one mode.

    The plane's Newton method (:func:`.plane_newton.newton`) takes its Hessian
    from differences 1e-6 S wide and stops at steps of 1e-13 S: at a saddle of
    the second mode just above its load (P4, 4 elements, q = -1e-9 N/m,
    lambda_2 (1 + 1e-13)), its amplitude 1.7e-6 S, that left the beam 6.8e-8 m
    high where the saddle is 3.2e-8 m, its residual 5.5e-10 of its energy's
    parts (which cancel to 1e-13 there), and it was listed ``optimal`` (the
    whole beam's Newton step, 0.28 of its size).  Here the Hessian comes from
    differences ``H_REL`` of ``|r|`` wide (widened as :func:`own_step`'s), the
    Hessian is taken again at each step, the steps are kept only where they
    lower ``|∇F|`` and stay within ``MERGE S`` or ``PLANE_REACH |r|`` of ``r``,
    and the last one is measured.

    Parameters
    ----------
    dp : DiscreteProblem
        The problem in the units of the search.
    grad : callable
        ``grad(s) -> (F, ∇F, u, ok)``, cached (:func:`.stationary2.find_plane`).
    hessian : callable
        ``hessian(s, h) -> H`` from differences of ``∇F`` ``h`` wide, or None.
    r : ndarray
        A zero of ``∇F``.
    S : float
        The amplitude range's scale.
    zero_floor : float, optional
        As :func:`own_step`'s.

    Returns
    -------
    s : ndarray
        The refined zero.
    step : float
        The last Newton step's change of the deflection, each component of ``∇F``
        counted at least its round-off (``LABEL_NOISE`` eps own / size), relative
        to the beam's largest ``|w|``; ``inf`` where the Hessian could not be told
        from round-off or a slice failed; 0 where ``∇F`` is exactly 0.

    Examples
    --------
    A stand-in whose deflection is the amplitudes, ``∇F = A (s - z)``:

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> A, z = np.array([[-5.7, 0.0], [0.0, 3e-12]]), np.array([1e-19, 8e-7])
    >>> grad = lambda s: (0.0, A @ (s - z), np.asarray(s, float), True)
    >>> hessian = lambda s, h: A
    >>> dp = SimpleNamespace(G=np.eye(2), energy_size=lambda u: 1e-30,
    ...                      to_physical=lambda u: (u, 0 * u))
    >>> s, step = plane_step(dp, grad, hessian, np.array([0.0, 1.7e-6]), 2.0, 1e-26)
    >>> bool(np.allclose(s, z, rtol=1e-9, atol=0)), bool(step < 1e-9)
    (True, True)
    """
    r = np.asarray(r, float)
    _, d, u, ok = grad(r)
    if u is None or not ok:
        return r, math.inf
    start, reach = r, max(MERGE * S, PLANE_REACH * float(np.linalg.norm(r)))
    for _ in range(PLANE_STEPS):
        if not np.any(d):
            return r, 0.0
        found = _plane_slope(dp, grad, hessian, r, S)
        if found is None:
            return r, math.inf
        H, dwds = found
        try:
            M = np.linalg.inv(H)
        except np.linalg.LinAlgError:
            return r, math.inf
        t = r - M @ d
        if not 0.0 < float(np.linalg.norm(t - start)) <= reach:
            break
        _, dt, ut, okt = grad(t)
        if ut is None or not okt or not np.linalg.norm(dt) < np.linalg.norm(d):
            break
        r, d, u = t, dt, ut
    size = _size(dp, u, S, float(np.max(dwds)), zero_floor)
    known = LABEL_NOISE / NOISE * round_off(dp, u, float(np.linalg.norm(r)))
    # (each amplitude's move: the Newton step's, and each component of ∇F's
    # round-off through the inverse Hessian; H and M at r unless the last step
    # was taken, where those at the point before it bound it as well)
    move = float((np.abs(M @ d) + np.abs(M) @ np.full(2, known)) @ dwds)
    return r, (move / size if size > 0.0 else math.inf)


def _plane_slope(dp, grad, hessian, r, S):
    """``(H, max |dw/ds_j|)`` at ``r`` from differences ``h`` wide (``H_REL |r|``,
    widened tenfold while ``∇F``'s change across them along any of H's
    eigenvectors, ``|mu| h``, is within ten times its round-off, as
    :func:`_slope`), or None.  (Every direction: a flat second mode's curvature
    read from round-off, while the first mode's change cleared it, would shorten
    the step measured along it.)"""
    _, _, u, _ = grad(r)
    w = dp.to_physical(u)[0]
    h = H_REL * max(float(np.linalg.norm(r)), H_MIN * S)
    noise = round_off(dp, u, float(np.linalg.norm(r)))
    while h <= max(WIDEST * float(np.linalg.norm(r)), PROBE * S):
        H = hessian(r, h)
        if H is None:
            return None
        if np.all(np.isfinite(H)) and \
                float(np.min(np.abs(np.linalg.eigvalsh(H)))) * h > 10.0 * noise:
            dwds = np.zeros(2)
            for j in range(2):
                for t in (-h, h):
                    e = np.zeros(2)
                    e[j] = t
                    _, _, ut, okt = grad(r + e)
                    if ut is not None and okt:
                        dwds[j] = max(dwds[j],
                                      float(np.max(np.abs(dp.to_physical(ut)[0] - w))) / h)
            return H, dwds
        h *= 10.0
    return None


def _size(dp, u, S, dwds, zero_floor):
    """The beam ``u``'s largest ``|w|`` [m], at least ``zero_floor`` (without load,
    None: ``ZERO_ANSWER`` of the deflection the amplitude ``S`` makes, ``dwds``
    the largest ``|dw/ds|``)."""
    # (without load no linear answer: the floor is that fraction of the deflection
    # the range's amplitude S makes -- the flat beam of an unloaded bed 8.4e-10 m
    # below, listed 1.2e-30 m off w = 0, is zero, not 100 % off its own size)
    if zero_floor is None:
        zero_floor = ZERO_ANSWER * S * dwds
    return max(float(np.max(np.abs(dp.to_physical(u)[0]), initial=0.0)), zero_floor)


def zero_floor(dp):
    """The deflection [m] below which ``dp``'s beam counts as zero, or None without load.

    :attr:`gaocvx.mixed.MixedForm.zero_floor` in metres: ``ZERO_ANSWER`` of the
    unsupported linear answer, the floor :func:`gaocvx.solve` certifies a beam
    flat on an obstacle against.  Without load there is no linear answer
    (:func:`own_step` then takes the floor from the amplitude range).
    """
    mf = MixedForm(dp)
    return float(mf.zero_floor * dp.W) if mf.has_load else None


def _slope(dp, dF, r, S):
    """``(F'', max |dw/ds| [m per unit s])`` at ``r`` by central differences, or None.

    Where the two one-sided differences differ by more than a factor of two (a
    kink of F': the obstacle takes or releases the beam within ``h``) the one of
    smaller size is taken: the longer Newton step, the stricter measure.  Where
    one side's slice is inadmissible or failed (an edge of the admissible
    amplitudes within ``h``) the other side's difference serves; None where
    neither does.
    """
    _, d, u, _ = dF(r)
    w = dp.to_physical(u)[0]
    h = H_REL * max(abs(r), H_MIN * S)
    noise = round_off(dp, u, r)
    while h <= max(WIDEST * abs(r), PROBE * S):
        # (F'(r + t) - F'(r)) / t and (w(r + t) - w(r)) / t on each admissible side
        sides = []
        for t in (-h, h):
            _, dt, ut, okt = dF(r + t)
            if ut is not None and okt:
                sides.append(((dt - d) / t, dp.to_physical(ut)[0], dt))
        if not sides:
            return None
        if max(abs(dt - d) for _, _, dt in sides) > 10.0 * noise:
            slopes = [q for q, _, _ in sides]
            curvature = min(slopes, key=abs)
            if len(sides) == 2 and slopes[0] * slopes[1] > 0.0 and \
                    max(map(abs, slopes)) <= 2.0 * min(map(abs, slopes)):
                curvature = 0.5 * (slopes[0] + slopes[1])    # (the central difference)
            if curvature == 0.0:
                return None
            dwds = max(float(np.max(np.abs(wt - w))) for _, wt, _ in sides) / h
            return curvature, dwds
        h *= 10.0
    return None
