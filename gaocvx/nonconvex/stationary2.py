"""Equilibria with two unstable modes (k = 2): zeros of the reduced gradient in the plane.

The equilibria are the stationary points of ``F(s1, s2)`` (nonconvex.md; see
:mod:`.stationary` for k = 1).  In two dimensions no bracketing proves that
every zero is found, so this search is a careful sampling, not a proof:

1. ``∇F`` on a ``GRID2 x GRID2`` grid of the square ``[-S, S]^2``
   (:func:`.bounds.equilibrium_box`: every equilibrium has ``|s| <= S``);
2. every grid cell on whose corners both components of ``∇F`` change sign
   seeds Newton's method on ``∇F = 0`` (the Hessian of F by central
   differences of the envelope gradient), damped to stay in the square;
3. zeros are merged when closer than 1e-6 S; each is classified by the
   eigenvalues of its Hessian: both positive is a local minimum of the energy
   (stable), else unstable (a saddle or a maximum of F);
4. with an obstacle or channel, a local minimum of ``F`` at a kink or at the
   edge of the admissible amplitudes (a beam pressed flat onto an obstacle at
   gap 0) is no zero of ``∇F``: every grid point whose ``F`` is lowest among
   its admissible neighbours is refined by Nelder-Mead on ``F`` (inadmissible
   amplitudes count as ``+inf``) and, when it is no zero found by step 2,
   reported as a stable equilibrium if no admissible probe around it within
   1e-9 S is lower (a local minimum of ``F`` is one of the energy:
   ``Pi(s, v) >= F(s) >= F(s*)`` nearby).  Unstable equilibria at a kink or
   an edge are not searched.

Examples
--------
>>> from gaocvx import Scene
>>> from gaocvx.nonconvex import equilibria
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P1", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"axial": 1.1e10}, "mesh": {"elements": 8}})
>>> eqs = equilibria(scene)           # q = 0 above the second mode load
>>> sum(e.stable for e in eqs), eqs[-1].energy      # two mirror minima; w = 0 highest
(2, 0.0)
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from .equilibrium import Equilibrium
from .stationary import ROOT_TOL

__all__ = ["find_plane", "GRID2"]

log = logging.getLogger(__name__)

GRID2 = 25  # odd: (0, 0) is a grid point


def find_plane(dp, prog, S, grid: int = GRID2, floor: float = 0.0) -> list:
    """Every zero of ``∇F`` found in ``[-S, S]^2`` (see the module's notes).

    ``floor`` [in the program's energy unit]: the smallest energy scale residuals are
    relative to (the scene's: a flat beam's own energy parts are 0).
    """
    t0 = time.perf_counter()
    cache = {}

    def grad(s):
        key = (float(s[0]), float(s[1]))
        if key not in cache:
            F, d, u, ok = prog.reduced(np.array(key))
            cache[key] = (F, np.asarray(d, float), u, ok)
        return cache[key]

    def hessian(s):
        h = 1e-6 * S
        H = np.empty((2, 2))
        for j in range(2):
            e = np.zeros(2)
            e[j] = h
            H[:, j] = (grad(s + e)[1] - grad(s - e)[1]) / (2 * h)
        return 0.5 * (H + H.T)

    axis = np.linspace(-S, S, grid)
    # (linspace's middle point is -4e-16 S, not 0: the unloaded beam's w = 0, an
    # exact zero of ∇F only at s = 0, was then missed -- a P2 beam, 9e9 N, k = 2)
    axis[grid // 2] = 0.0
    G = np.full((grid, grid, 2), np.nan)
    for i, a in enumerate(axis):
        for j, b in enumerate(axis):
            F, d, _, _ = grad(np.array([a, b]))
            if math.isfinite(F):
                G[i, j] = d
    seeds = []
    for i in range(grid - 1):
        for j in range(grid - 1):
            corners = G[i:i + 2, j:j + 2].reshape(4, 2)
            if np.isnan(corners).any():
                continue
            if all(corners[:, c].min() <= 0 <= corners[:, c].max() for c in range(2)):
                seeds.append(np.array([0.5 * (axis[i] + axis[i + 1]),
                                       0.5 * (axis[j] + axis[j + 1])]))
    # A grid point that is a zero itself (w = 0 without load: s = 0 exactly).
    norms = np.linalg.norm(G, axis=2)
    top = np.nanmax(norms) if np.isfinite(norms).any() else 0.0
    for i, j in zip(*np.nonzero(norms <= 1e-12 * top)):
        seeds.insert(0, np.array([axis[i], axis[j]]))
    if math.isfinite(grad(np.zeros(2))[0]):
        seeds.insert(0, np.zeros(2))   # the unloaded beam's trivial equilibrium, if any
    roots = []
    for s in seeds:
        for _ in range(30):
            F, d, _, _ = grad(s)
            if not math.isfinite(F):
                break
            try:
                step = -np.linalg.solve(hessian(s), d)
            except np.linalg.LinAlgError:
                break
            # stay in the square: damp a step that would leave it
            t = 1.0
            while np.any(np.abs(s + t * step) > S) and t > 1e-3:
                t *= 0.5
            s = s + t * step
            if np.linalg.norm(t * step) <= 1e-13 * S:
                break
        if math.isfinite(grad(s)[0]) and not any(np.linalg.norm(s - r) <= 1e-6 * S
                                                  for r in roots):
            roots.append(s)
    out = _edge_minima(dp, grad, axis, S, roots, floor) if dp.contact == "obstacle" else []
    for r in roots:
        F, d, u, ok = grad(r)
        size = sum(abs(v) for v in dp.energy_parts(u).values()) or 1.0
        res = float(np.linalg.norm(d)) * max(float(np.linalg.norm(r)), 1e-3 * S) / size
        if res > 1e3 * ROOT_TOL:  # Newton did not converge: no zero here
            continue
        eig = np.linalg.eigvalsh(hessian(r))
        w, slope = dp.to_physical(u)
        status = "optimal" if ok and res <= ROOT_TOL else "inaccurate"
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), bool(eig[0] > 0),
                               [float(x) for x in r], dp.x.copy(), w, slope, res, status,
                               float(dp.P), float(eig[0]), float(dp.W)))
    out.sort(key=lambda e: e.energy)
    log.info("equilibria (k = 2): %d found from %d seeds, %d solves in %.2f s", len(out),
             len(seeds), len(cache), time.perf_counter() - t0)
    return out


def _edge_minima(dp, grad, axis, S, roots, floor) -> list:
    """Stable equilibria at a kink or an edge of the admissible amplitudes (step 4).

    Without them a beam pressed flat onto an obstacle at gap 0 with two unstable
    modes had no equilibrium at all (campaign draws: P1 and P4 in a channel with
    gap 0, both methods returned an empty list).  Their residual is ``|∇F|``
    times the probes' radius relative to the energy scale, as for k = 1.
    """
    import scipy.optimize as so

    n = len(axis)
    F = np.array([[grad(np.array([a, b]))[0] for b in axis] for a in axis])
    F = np.where(np.isfinite(F), F, np.inf)
    out = []

    def f(s):
        if np.any(np.abs(s) > S):
            return math.inf
        v = grad(np.asarray(s, float))[0]
        return v if math.isfinite(v) else math.inf

    for i in range(n):
        for j in range(n):
            if not math.isfinite(F[i, j]) or \
                    F[i, j] > F[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2].min():
                continue
            h = axis[1] - axis[0]
            s0 = np.array([axis[i], axis[j]])
            simplex = np.array([s0, s0 + [0.5 * h, 0.0], s0 + [0.0, 0.5 * h]])
            res = so.minimize(f, s0, method="Nelder-Mead",
                              options=dict(initial_simplex=simplex, xatol=1e-12 * S,
                                           fatol=0.0, maxiter=400))
            s = np.asarray(res.x, float)
            if not math.isfinite(f(s)) or \
                    any(np.linalg.norm(s - r) <= 1e-6 * S for r in roots) or \
                    any(np.linalg.norm(s - np.asarray(e.amplitudes)) <= 1e-6 * S for e in out):
                continue
            F0, d, u, ok = grad(s)
            e = 1e-9 * S
            probes = [f(s + e * np.array([math.cos(t), math.sin(t)]))
                      for t in np.linspace(0, 2 * math.pi, 8, endpoint=False)]
            if min(probes) < F0:
                continue   # (not a minimum at this resolution: a zero of ∇F is step 2's)
            size = max(sum(abs(v) for v in dp.energy_parts(u).values()), floor) or 1.0
            resid = float(np.linalg.norm(d)) * e / size
            status = "optimal" if ok and resid <= ROOT_TOL else "inaccurate"
            w, slope = dp.to_physical(u)
            out.append(Equilibrium(float(dp.energy(u) * dp.E0), True, [float(x) for x in s],
                                   dp.x.copy(), w, slope, resid, status, float(dp.P),
                                   math.nan, float(dp.W)))
    return out
