"""Stable equilibria with two modes at a kink or an edge of the admissible amplitudes.

Step 4 of :mod:`.stationary2`: with an obstacle or channel a local minimum of
``F`` at a kink (the obstacle takes or releases the beam) or at the edge of the
admissible amplitudes (a beam resting on the obstacle, or pressed flat onto it
at gap 0) is no zero of ``∇F``.  Every grid point whose ``F`` is lowest among its
admissible neighbours, and every start, is refined by Nelder-Mead on ``F``
(inadmissible amplitudes count as ``+inf``) and, when no probe 1e-9 S around it is
lower, reported as a stable equilibrium: a local minimum of ``F`` is one of the
energy (``Pi(s, v) >= F(s) >= F(s*)`` nearby).
"""

from __future__ import annotations

import math

import numpy as np

from .descents import in_square
from .equilibrium import Equilibrium, same_point
from .stationary1 import ROOT_TOL

__all__ = ["edge_minima", "local_minima"]


def edge_minima(dp, grad, axes, S, roots, floor, starts=(), step=1e-3) -> list:
    """Stable equilibria at a kink or an edge of the admissible amplitudes.

    Without them a beam pressed flat onto an obstacle at gap 0 with two unstable
    modes had no equilibrium at all (campaign draws: P1 and P4 in a channel with
    gap 0, both methods returned an empty list).  Their residual is ``|∇F|``
    times the probes' radius relative to the energy scale, as for k = 1.
    """
    import scipy.optimize as so

    out = []
    f = in_square(grad, S)

    for s0, h in local_minima(grad, axes) if axes is not None else \
            [(np.asarray(x, float), np.full(2, step * S)) for x in starts]:
        simplex = np.array([s0, s0 + [0.25 * h[0], 0.0], s0 + [0.0, 0.25 * h[1]]])
        # (fatol 0 ran every search to maxiter: 5322 of a scene's 5267 solves;
        # F to 1e-14 of the scale is what the probes below can resolve anyway)
        with np.errstate(invalid="ignore", over="ignore"):
            res = so.minimize(f, s0, method="Nelder-Mead",
                              options=dict(initial_simplex=simplex, xatol=1e-12 * S,
                                           fatol=1e-14 * (abs(f(s0)) + floor + 1e-300),
                                           maxiter=400))
        s = np.asarray(res.x, float)
        if not math.isfinite(f(s)) or \
                any(same_point(s, r, S) for r in roots) or \
                any(same_point(s, e.amplitudes, S) for e in out):
            continue
        F0, d, u, ok = grad(s)
        e = 1e-9 * S
        probes = [f(s + e * np.array([math.cos(t), math.sin(t)]))
                  for t in np.linspace(0, 2 * math.pi, 8, endpoint=False)]
        if min(probes) < F0:
            continue   # (not a minimum at this resolution: a zero of ∇F is step 2's)
        size = max(dp.energy_size(u), floor) or 1.0
        resid = float(np.linalg.norm(d)) * e / size
        status = "optimal" if ok and resid <= ROOT_TOL else "inaccurate"
        w, slope = dp.to_physical(u)
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), True, [float(x) for x in s],
                               dp.x.copy(), w, slope, resid, status, float(dp.P),
                               math.nan, float(dp.W)))
    return out


def local_minima(grad, axes) -> list:
    """Grid points whose ``F`` is lowest among their admissible neighbours, each with
    the spans ``(h0, h1)`` of its neighbourhood (a Nelder-Mead simplex's size)."""
    n, m = len(axes[0]), len(axes[1])
    F = np.array([[grad(np.array([a, b]))[0] for b in axes[1]] for a in axes[0]])
    F = np.where(np.isfinite(F), F, np.inf)
    out = []
    for i in range(n):
        for j in range(m):
            if math.isfinite(F[i, j]) and \
                    F[i, j] <= F[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2].min():
                h = np.array([axes[0][min(i + 1, n - 1)] - axes[0][max(i - 1, 0)],
                              axes[1][min(j + 1, m - 1)] - axes[1][max(j - 1, 0)]])
                out.append((np.array([axes[0][i], axes[1][j]]), h))
    return out
