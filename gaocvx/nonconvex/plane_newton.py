"""Newton's method on ``∇F = 0`` in the plane of two amplitudes (:mod:`.stationary2`).

Its seeds on a grid (:func:`grid_seeds`: cells where both components of ``∇F``
change sign), its steps (:func:`newton`, damped to stay in the square
``[-S, S]^2``), and the equilibria at its end points (:func:`at_roots`: zeros of
``∇F`` to the tolerance, merged, classified); ``grad(s)`` returns the slice's
``(F, ∇F, u, ok)`` and ``hessian(s)`` its central differences, as in
:func:`.stationary2.find_plane`.

Examples
--------
>>> import numpy as np
>>> from gaocvx.nonconvex.plane_newton import axis, newton
>>> axis(-1.0, 1.0, 4)                  # 0 added where linspace misses it
array([-1.        , -0.33333333,  0.        ,  0.33333333,  1.        ])
>>> grad = lambda s: (float(s @ s), 2 * s, None, True)
>>> hessian = lambda s: 2 * np.eye(2)
>>> [float(abs(x).max()) < 1e-12 for x in newton(grad, hessian, [np.array([0.3, -0.2])], 1.0)]
[True]
"""

from __future__ import annotations

import math

import numpy as np

from .equilibrium import Equilibrium, same_point
from .probes import curvature as _curvature, probe_noise
from .stationary1 import ROOT_TOL
from .zero_step import STEP_TOL, plane_step

__all__ = ["newton", "at_roots", "grid_seeds", "axis"]


def newton(grad, hessian, seeds, S) -> list:
    """Newton's method on ``∇F = 0`` from each seed; the end points (merged later,
    among those that are zeros: an end point where Newton did not converge must
    not hide a zero next to it)."""
    ends = []
    for s in seeds:
        for _ in range(30):
            F, d, _, _ = grad(s)
            H = hessian(s) if math.isfinite(F) else None
            if H is None:
                break
            try:
                step = -np.linalg.solve(H, d)
            except np.linalg.LinAlgError:
                break
            # stay in the square: damp a step that would leave it, and stop where
            # even the damped one would
            t = 1.0
            while np.any(np.abs(s + t * step) > S) and t > 1e-3:
                t *= 0.5
            if np.any(np.abs(s + t * step) > S):
                break
            s = s + t * step
            if np.linalg.norm(t * step) <= 1e-13 * S:
                break
        if math.isfinite(grad(s)[0]):
            ends.append(s)
    return ends


def at_roots(dp, grad, hessian, roots, S, known=(), strict=False, floor=0.0,
             polish=None, zero_floor=None) -> list:
    """The equilibria at Newton's end points that are zeros of ``∇F``
    (:mod:`.stationary2`, step 3), merged when closer than 1e-6 S (to each other or to ``known`` amplitudes);
    ``strict``: only those within the residual's tolerance.

    A zero to the scene's accuracy (the residual relative to ``floor``, the
    scene's energy) but not to its own is, with ``polish`` (an obstacle:
    :func:`.whole_beam.polish_equilibrium` on the slice's beam), polished on
    the whole beam and listed as that returns it, if it does.

    (End points where Newton did not converge, at a kink of F, are left to the
    edge minima: they once also kept the edge minima from reporting a beam
    resting on the obstacle there.)

    A zero is ``optimal`` only where, refined by Newton's method in its own
    scale, its last step moves the beam by at most ``STEP_TOL`` of its size
    (:func:`.zero_step.plane_step`; ``zero_floor`` the floor under its size).
    """
    out, have = [], [np.asarray(k, float) for k in known]

    def residual(r, d, u):
        # (|grad F| max(|s|, 1e-3 S), and that over the energy's parts)
        work = float(np.linalg.norm(d)) * max(float(np.linalg.norm(r)), 1e-3 * S)
        return work, work / (dp.energy_size(u) or 1.0)

    def polished(u, r):
        # the zero polished on the whole beam, listed unless listed already; False
        # where the polish fails or ends elsewhere
        e = polish(u)
        if e is None or not same_point(e.amplitudes, r, S):
            return False
        if not any(same_point(e.amplitudes, h, S) for h in have):
            # (listed at the zero's amplitudes, where its slices were solved,
            # during the search: the steps after it probe F there; the polished
            # beam's own replace them at the end, whole_beam.settle)
            e.amplitudes = [float(a) for a in r]
            have.append(np.asarray(r, float))
            out.append(e)
        return True

    for r in roots:
        if any(same_point(r, h, S) for h in have):
            continue
        F, d, u, ok = grad(r)
        size = dp.energy_size(u) or 1.0
        work, res = residual(r, d, u)
        if res > ROOT_TOL and polish is not None and ok and work <= ROOT_TOL * max(size, floor) \
                and polished(u, r):
            continue
        if res > (ROOT_TOL if strict else 1e3 * ROOT_TOL):  # Newton did not converge
            continue
        step = math.inf
        if ok and res <= ROOT_TOL:
            # (refined and measured in the beam's own scale; one that fails it goes
            # to the whole beam where there is an obstacle, as one mode's zeros)
            r, step = plane_step(dp, grad, hessian, r, S, zero_floor)
            F, d, u, ok = grad(r)
            res = residual(r, d, u)[1]
            if step > STEP_TOL and polish is not None and ok and polished(u, r):
                continue
            if any(same_point(r, h, S) for h in have):
                continue
        H = hessian(r)
        if H is None:
            continue
        have.append(r)
        w, slope = dp.to_physical(u)
        others = [q for q in list(known) + list(roots) if not same_point(q, r, S)]
        curvature, noisy = _label(dp, grad, hessian, r, H, S, others)
        status = ("optimal" if ok and res <= ROOT_TOL and step <= STEP_TOL and not noisy
                  else "inaccurate")
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), curvature > 0,
                               [float(x) for x in r], dp.x.copy(), w, slope, res, status,
                               float(dp.P), curvature, float(dp.W)))
    return out


def _label(dp, grad, hessian, r, H, S, others) -> tuple:
    """``(curvature, noisy)`` of the zero ``r`` (:func:`.probes.curvature`), from
    probes 1e-6 ``S`` wide, widened fourfold while the change of ∇F across them,
    ``|curvature| h``, is within ∇F's round-off at the probes
    (:func:`.probes.probe_noise`), up to a quarter of the way to the nearest of
    ``others`` (or of ``S``); ``noisy`` where it never clears it (the label is
    not known), as the one-mode probes (:func:`.roundoff.widened`).
    """
    h = 1e-6 * S
    curvature, noise = _curvature(grad, H, r, h), probe_noise(dp, grad, r, h)
    cap = min([0.25 * float(np.linalg.norm(np.asarray(q, float) - r)) for q in others]
              + [0.25 * S])
    while not abs(curvature) * h > noise and 4.0 * h <= cap:
        H = hessian(r, 4.0 * h)
        if H is None:
            break
        h *= 4.0
        curvature, noise = _curvature(grad, H, r, h), probe_noise(dp, grad, r, h)
    return curvature, not abs(curvature) * h > noise


def grid_seeds(grad, axes) -> list:
    """Newton's seeds on one grid: cells where both components of ``∇F`` change
    sign, and grid points that are zeros themselves (w = 0 without load)."""
    G = np.full((len(axes[0]), len(axes[1]), 2), np.nan)
    for i, a in enumerate(axes[0]):
        for j, b in enumerate(axes[1]):
            F, d, _, _ = grad(np.array([a, b]))
            if math.isfinite(F):
                G[i, j] = d
    seeds = []
    for i in range(len(axes[0]) - 1):
        for j in range(len(axes[1]) - 1):
            corners = G[i:i + 2, j:j + 2].reshape(4, 2)
            if np.isnan(corners).any():
                continue
            if all(corners[:, c].min() <= 0 <= corners[:, c].max() for c in range(2)):
                seeds.append(np.array([0.5 * (axes[0][i] + axes[0][i + 1]),
                                       0.5 * (axes[1][j] + axes[1][j + 1])]))
    norms = np.linalg.norm(G, axis=2)
    top = np.nanmax(norms) if np.isfinite(norms).any() else 0.0
    for i, j in zip(*np.nonzero(norms <= 1e-12 * top)):
        seeds.insert(0, np.array([axes[0][i], axes[1][j]]))
    return seeds


def axis(lo: float, hi: float, grid: int) -> np.ndarray:
    """``grid`` points from ``lo`` to ``hi``, with 0 exactly when it lies between.

    (linspace's middle point of [-S, S] is -4e-16 S, not 0: the unloaded beam's
    w = 0, an exact zero of ∇F at s = 0 only, was then missed -- a P2 beam at
    9e9 N, k = 2)
    """
    axis = np.linspace(lo, hi, grid)
    if not lo <= 0.0 <= hi:
        return axis
    i = int(np.argmin(np.abs(axis)))
    if abs(axis[i]) <= 1e-9 * (hi - lo):
        axis[i] = 0.0
        return axis
    return np.union1d(axis, [0.0])
