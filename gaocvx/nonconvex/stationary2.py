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
   (stable), else unstable (a saddle or a maximum of F).

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

from .stationary import ROOT_TOL, Equilibrium

__all__ = ["find_plane", "GRID2"]

log = logging.getLogger(__name__)

GRID2 = 25  # odd: (0, 0) is a grid point


def find_plane(dp, prog, S, grid: int = GRID2) -> list:
    """Every zero of ``∇F`` found in ``[-S, S]^2`` (see the module's notes)."""
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
    out = []
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
