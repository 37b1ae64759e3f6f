"""The stability of a zero of the reduced function, from probes of F and F'.

:func:`classify` labels a zero ``r`` of one mode's F' (:mod:`.stationary1`) from
F' at ``r -+ h``.

:func:`curvature` classifies a zero ``s`` of ``∇F`` (:mod:`.stationary2`): the
least eigenvalue of F's Hessian (central differences) and the least one-sided
rise of F around ``s`` (:func:`least_rise`), and, where the two disagree (a kink
of F through ``s``, or a saddle closer than the probes), F's own values at two
shorter steps.  ``grad(s)`` is the search's cached ``(F, ∇F, u, ok)``.

:func:`hessian_stability` decides the stability of an equilibrium without an
obstacle from the energy's own Hessian on the whole beam, where that energy is
twice differentiable around it: at its own scale, where the probes' 1e-6 S may
be far larger than the beam.
"""

from __future__ import annotations

import math

import numpy as np

from .roundoff import LABEL_NOISE, NOISE, round_off

__all__ = ["classify", "curvature", "least_rise", "probe_noise", "hessian_stability",
           "HESSIAN_ELEMENTS"]


def classify(dF, r, h) -> tuple:
    """``(stable, curvature)`` of a zero ``r`` of F' from F' at ``r -+ h``.

    A minimum of F has F' < 0 to its left and > 0 to its right; a side
    outside the admissible amplitudes (an obstacle's edge: ``F = inf`` there)
    counts as rising, for F cannot be lowered that way.  (Taking the probe's
    F' = 0 outside the range for a slope labelled a flat beam held by a gap-0
    obstacle, the certified global minimiser, unstable: a trial's P4 beam under
    a load table with unloaded ends at 1.02 P_bar_h.)
    """
    mid = dF(r)[1]
    left, right = (dF(r + t) for t in (-h, h))
    fl, fr = math.isfinite(left[0]), math.isfinite(right[0])
    if fl and fr:
        # (the lesser one-sided curvature: at a kink of F's curvature -- a flat
        # beam lifting off a bed at gap 0 -- the central difference averages a
        # falling side with a rising one, and the label is the sides')
        curvature = min(right[1] - mid, mid - left[1]) / h
        if right[1] != left[1]:
            return bool(left[1] < 0 < right[1]), curvature
        return bool(curvature > 0), curvature
    if not (fl or fr):
        return False, math.nan
    curvature = (right[1] - mid) / h if fr else (mid - left[1]) / h
    return bool(right[1] > 0 if fr else left[1] < 0), curvature


def curvature(grad, H, s, h) -> float:
    """The curvature that classifies the zero ``s``: the least of the Hessian's
    eigenvalues and of the one-sided probes (:func:`least_rise`), unless the
    two disagree, where F itself decides (:func:`_rises`).

    For a smooth F the probes' least rise is the least eigenvalue to O(h).
    Probes rising everywhere while the Hessian has a negative eigenvalue mean
    a kink of F's curvature, across which the Hessian's columns (central
    differences along the axes, symmetrised) mix the two sides: a P3 beam in a
    channel at gap 0 with two modes (10 elements) had a strict minimum (F rising
    as +5.4 h^2 in every direction, independently second-order sufficient)
    with eigenvalues -6.1 and 838, listed unstable; its saddle lies 1.3e-6 S
    beside it.  There the zero is a minimum if F rises at ``h`` and ``h / 10``.
    The other way round, a positive definite Hessian while a probe falls, means
    a saddle closer than ``h`` that the probe reached past: a P3 beam held at a
    channel's ceiling under a load table (10 elements) had a strict minimum
    (eigenvalues 3.88 and 660, F rising as at least 15.3 step^2 at h / 10 and
    h / 100, independently second-order sufficient) whose probe at h fell by
    1.6e-5, listed unstable.  There the zero is a minimum if F rises at
    ``h / 10`` and ``h / 100``.
    """
    eig, vec = np.linalg.eigh(H)
    least = least_rise(grad, s, h)
    if least > 0 and not eig[0] > 0:
        return least if _rises(grad, s, vec[:, 0], (h, 0.1 * h)) else float(eig[0])
    if eig[0] > 0 and not least > 0:
        return float(eig[0]) if _rises(grad, s, vec[:, 0], (0.1 * h, 0.01 * h)) else least
    return min(float(eig[0]), least)


def _rises(grad, s, v, steps) -> bool:
    """Whether F rises from the zero ``s`` at both ``steps`` in 64 directions and both
    ways along ``v`` (the Hessian's least eigenvector), by more than 1e-12 of |F|,
    with its least rise over ``step^2`` at the second at least a quarter of that at
    the first (a kink's quadratic rise keeps it; a nearly flat saddle's, a quartic
    term's over ``-eps x^2``, collapses)."""
    F0 = grad(s)[0]
    dirs = [np.array([math.cos(t), math.sin(t)])
            for t in np.linspace(0.0, 2.0 * math.pi, 64, endpoint=False)] + [v, -v]
    rises = []
    for step in steps:
        rise = min(grad(s + step * e)[0] - F0 for e in dirs)
        if not rise > 1e-12 * abs(F0):
            return False
        rises.append(rise / step**2)
    return rises[1] >= 0.25 * rises[0]


def least_rise(grad, s, h, n: int = 16, fine: int = 64, kink: bool = False) -> float:
    """The least one-sided curvature ``e . (∇F(s + h e) - ∇F(s)) / h`` of F at the
    zero ``s`` over directions ``e`` (inadmissible probes left out; inf if none
    is admissible): a local minimum needs it positive.  ``kink``: ``s`` may lie
    on a kink of F (the flat beam at gap 0), where the slice's ``∇F(s)`` is one
    of many one-sided slopes and is left out: ``e . ∇F(s + h e) / h``, the
    slope along ``e`` beside ``s`` (a P4 beam pressed flat under a small point
    force, 8 elements: F fell like -h^2 over 40 degrees of directions, while
    ``∇F(s + h e) - ∇F(s)`` rose in all, and w = 0 was called stable).

    ``n`` directions first; where all rise, ``fine`` directions, and around each
    of them that rises least among its neighbours the least by Brent's method
    (a sampling: a falling cone narrower than the directions' spacing next to no
    such local least can still be missed).

    The central-difference Hessian averages the two sides of a kink of F's
    second derivative: a flat beam on a bed at gap 0 with two modes and no load
    has F = -c s1^2 lifting off (s1 > 0) and (K - c) s1^2 into the bed, and
    K - 2c > 0 called it stable where lifting off lowers the energy (a
    campaign's P4 beam on a bed of 3e12 N/m^2 at 5e9 N, 8 elements; a path
    called w = 0 unstable at 4e9 N and stable at 5e9 N).  With one mode the
    two sides are compared already (:func:`.probes.classify`).  Under a
    load that presses a beam flat at gap 0, F rises in most directions (the
    load's work) and falls only in a narrow cone where the beam lifts off its
    unloaded span: 10 degrees wide for a P2 beam under two point forces, between
    two of 16 directions, and w = 0 was called stable (a campaign's, 8 elements).
    """
    import scipy.optimize as so

    g0 = np.zeros(2) if kink else np.asarray(grad(s)[1], float)

    def rise(t):
        e = np.array([math.cos(t), math.sin(t)])
        F, d, _, _ = grad(s + h * e)
        return float(e @ (np.asarray(d, float) - g0)) / h if math.isfinite(F) else math.inf

    least = min(rise(t) for t in np.linspace(0.0, 2.0 * math.pi, n, endpoint=False))
    if not least > 0:
        return least
    ts = np.linspace(0.0, 2.0 * math.pi, fine, endpoint=False)
    vals = np.array([rise(t) for t in ts])
    step = ts[1] - ts[0]
    for i in range(fine):
        if math.isfinite(vals[i]) and vals[i] <= vals[i - 1] and vals[i] <= vals[(i + 1) % fine]:
            res = so.minimize_scalar(rise, bounds=(ts[i] - step, ts[i] + step), method="bounded",
                                     options=dict(xatol=1e-3 * step, maxiter=40))
            least = min(least, float(res.fun), float(vals[i]))
    return min(least, float(np.min(vals)))


def probe_noise(dp, grad, s, h, n: int = 16) -> float:
    """∇F's round-off at the probes ``s + h e`` of ``n`` directions (those
    :func:`least_rise` takes first), the largest: ``LABEL_NOISE`` eps own / size
    (:func:`.roundoff.round_off`) of each probe's beam, as the one-mode probes
    count F' (:func:`.roundoff.settled`).  At the probes, not at ``s``: the
    flat beam's slice at ``s = 0`` is w = 0, whose round-off is 0 (a review).
    """
    noise = 0.0
    for t in np.linspace(0.0, 2.0 * math.pi, n, endpoint=False):
        p = s + h * np.array([math.cos(t), math.sin(t)])
        F, _, u, _ = grad(p)
        if math.isfinite(F) and u is not None:
            noise = max(noise, LABEL_NOISE / NOISE * round_off(dp, u, float(np.linalg.norm(p))))
    return noise


#: Elements up to which :func:`hessian_stability` decides (beyond: None).  Its
#: threshold :func:`.whole_beam.eig_tol` grows as N^4 with K's condition; the
#: least ``mu`` of (H, K) at the three near-flat equilibria of the P1 beam on a
#: bed at gap 0 (docs/nonconvex.md), by three ways (dense, Jacobi-scaled dense,
#: shift-invert Lanczos; benchmarks/eig_tol_spread.py, docs/nonconvex.md), spreads
#: over up to 1.5e-7 at 480 elements, 4.2e-6 at 1024 and 1.1e-4 at 2048, within
#: eig_tol's 5.3e-7, 1.1e-5 and 1.8e-4 (the spread growing as N^4 too; not
#: measured beyond).
HESSIAN_ELEMENTS = 2048


def hessian_stability(dp, u, margin: float = 1e-3):
    """A strict local minimum (True), not a minimum (False), or undecided (None),
    from the least eigenvalue ``mu`` of the energy's Hessian at the whole beam's
    Hermite DOFs ``u`` relative to K, as :func:`.whole_beam.second_order`'s
    (``|mu|`` within :func:`.whole_beam.eig_tol`: undecided), by the
    definiteness of ``H -+ eig_tol K``.

    Why: the reduced function's probes classify at 1e-6 S, and a beam pressed
    1.5e-9 m into a stiff bed at gap 0 (S = 0.2; P4, two modes, 2 elements) lifts
    off within that step: listed unstable, a strict local minimum (the
    Hessian's eigenvalues 0.47-5.4 relative to K; a helper's campaign).

    No obstacle, and up to :data:`HESSIAN_ELEMENTS` elements, where eig_tol
    was measured (else None).  A unilateral foundation's points within ``margin``
    of the largest ``|g - w|`` and ``|w|`` of its edge (``g - w = 0``) may lie on
    either side of it at the equilibrium ``u`` stands for: the true energy lies
    between the one with them released and the one with them held (each point's
    term ``c/2 (g - w)_+^2`` is convex, its second-order growth at most ``c``),
    so the Hessian with them released decides "stable" and the one with them
    held "unstable".  (Before, any such point left the label undecided: a P1
    beam pressed 9.5e-14 m into a bed at gap 0 has its points beside the clamped
    ends 4.8e-4 of that from the edge, and the probes' "unstable" stood for a
    strict local minimum.)

    >>> from gaocvx import Scene
    >>> from gaocvx.discrete import DiscreteProblem
    >>> dp = DiscreteProblem(Scene.from_dict({"beam": {"model": "gao", "supports": "P4",
    ...     "length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
    ...     "load": {"axial": 3e9}, "mesh": {"elements": 8}}), check_convexity=False)
    >>> hessian_stability(dp, np.zeros(dp.n))     # the flat beam above the limit
    False
    """
    from ..linalg import BandedCholesky, NotPositiveDefinite
    from .whole_beam import eig_tol

    if dp.contact == "obstacle" or dp.n == 0 or len(dp.x) - 1 > HESSIAN_ELEMENTS:
        return None
    u = np.asarray(u, float)
    H = H_held = dp.hessian(u)
    if dp.contact == "foundation" and not dp.bilateral:
        w = dp.Nq @ u
        depth = dp.g - w
        size = max(float(np.max(np.abs(depth))), float(np.max(np.abs(w))))
        near = np.abs(depth) <= margin * size
        if np.any(near):
            # (the points near the edge released in H, held in H_held)
            H = dp.hessian(u, active=(depth > 0) & ~near)
            H_held = dp.hessian(u, active=(depth > 0) | near)
    K = dp.K
    tol = eig_tol(len(dp.x) - 1)

    def definite(A) -> bool:
        # (mu > t exactly when H - t K is positive definite: a banded Cholesky
        # factor, not the dense spectrum, 5.5 s at 1000 DOFs)
        try:
            BandedCholesky(A)
            return True
        except NotPositiveDefinite:
            return False

    if definite(H - tol * K):
        return True
    return None if definite(H_held + tol * K) else False
