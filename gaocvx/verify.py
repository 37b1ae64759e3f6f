"""Score any computed deflection, ours or one computed elsewhere, against the ground truth.

A result is a table of nodes ``x`` with deflections ``w`` and, optionally,
slopes.  It is turned into a C1 function:

* with slopes: the Hermite cubic interpolant of (w, slope) on its own nodes,
  which is exactly what a Hermite finite-element code computes;
* without slopes: the cubic spline through (x, w) with the supports' end
  conditions (w' = 0 at a clamped end, w'' = 0 at a pinned or free one); C2,
  O(h^4) accurate for smooth deflections.  Its slopes are then the Hermite data.

Its total energy Pi_T is integrated exactly on its own nodes (point forces
between them act through the shape functions), and compared with the energy
of the discrete minimiser on a fine mesh (the ground truth).  The deflection
error is the largest difference on a fine grid of points.

Examples
--------
>>> from gaocvx import Scene, solve
>>> scene = Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P4",
...     "length": 1.0, "E": 2.1e11, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -5e7}, "mesh": {"elements": 8}})
>>> coarse = solve(scene)
>>> report = verify(scene, coarse.x, coarse.w, coarse.slope)
>>> report["energy_gap"] >= 0, report["max_error_rel"] < 1e-3
(True, True)
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from . import fem
from .discrete import DiscreteProblem
from .errors import SceneError
from .scene import Scene
from .solve import solve

__all__ = ["verify", "read_result_csv", "REFERENCE_ELEMENTS"]

REFERENCE_ELEMENTS = 1024
GRID = 20001
# The spline's end conditions are the supports': w' = 0 at a clamped end, w'' = 0
# (no moment) at a pinned or free end.
_CLAMPED, _FREE_MOMENT = (1, 0.0), (2, 0.0)
SPLINE_ENDS = {"P1": (_CLAMPED, _CLAMPED), "P2": (_CLAMPED, _FREE_MOMENT),
               "P3": (_CLAMPED, _FREE_MOMENT), "P4": (_FREE_MOMENT, _FREE_MOMENT)}


def read_result_csv(path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read a result table with a header naming the columns ``x``, ``w`` and optionally ``slope``.

    Raises
    ------
    SceneError
        Naming the file (and column or row) for anything unreadable.
    """
    path = Path(path)
    key = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(key, f"cannot read the result file: {exc.strerror}", key) from None
    rows = [r for r in csv.reader(text.splitlines()) if r and any(c.strip() for c in r)]
    if not rows:
        raise SceneError(key, "the result file is empty")
    header = [c.strip().lower() for c in rows[0]]
    for name in ("x", "w"):
        if name not in header:
            raise SceneError(key, f"the header must name a column {name!r}", rows[0])
    unknown = [c for c in header if c not in ("x", "w", "slope")]
    if unknown:
        raise SceneError(key, "unknown column (known: x, w, slope)", unknown[0])
    cols = {name: [] for name in header}
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise SceneError(f"{key}:{i}", f"expected {len(header)} values", row)
        for name, cell in zip(header, row):
            try:
                value = float(cell)
            except ValueError:
                raise SceneError(f"{key}:{i}", f"column {name}: not a number", cell) from None
            if not math.isfinite(value):
                raise SceneError(f"{key}:{i}", f"column {name}: must be finite", value)
            cols[name].append(value)
    slope = np.array(cols["slope"]) if "slope" in cols else None
    return np.array(cols["x"]), np.array(cols["w"]), slope


def _check_nodes(scene: Scene, x, w, slope, key):
    L = scene.beam.length
    if len(x) < 2:
        raise SceneError(key, "a result needs at least two nodes", len(x))
    if np.any(np.diff(x) <= 0):
        i = int(np.argmax(np.diff(x) <= 0)) + 1
        raise SceneError(f"{key}: x[{i}]", "x must be strictly increasing", float(x[i]))
    tol = 1e-9 * L
    if abs(x[0]) > tol or abs(x[-1] - L) > tol:
        raise SceneError(f"{key}: x", f"the nodes must cover the beam [0, {L:g}]",
                         [float(x[0]), float(x[-1])])
    if len(w) != len(x) or (slope is not None and len(slope) != len(x)):
        raise SceneError(key, "x, w and slope must have the same length", len(w))


def verify(scene: Scene, x, w, slope=None, *, reference_elements: int = REFERENCE_ELEMENTS,
           key: str = "result") -> dict:
    """Energy gap and deflection error of a result against the fine-mesh ground truth.

    Parameters
    ----------
    scene : Scene
    x, w : array_like
        Nodes [m] covering [0, L] and nodal deflections [m].
    slope : array_like, optional
        Nodal slopes w'; without them a cubic spline supplies them.
    reference_elements : int
        Elements of the ground-truth mesh.

    Returns
    -------
    dict
        ``energy`` and ``energy_reference`` [J], ``energy_gap`` (>= 0 up to the
        reference's own discretisation error) and ``energy_gap_rel``,
        ``max_error`` [m], ``max_error_rel``, ``max_error_x`` [m],
        ``boundary_violation`` (largest prescribed support value, relative),
        ``penetration`` (obstacle scenes: largest w < g [m]), ``interpolant``,
        and ``reference`` (method, elements, status).
    """
    x = np.asarray(x, float)
    w = np.asarray(w, float)
    slope = None if slope is None else np.asarray(slope, float)
    _check_nodes(scene, x, w, slope, key)
    x[0], x[-1] = 0.0, scene.beam.length  # within the tolerance just checked
    if slope is None:
        from scipy.interpolate import CubicSpline
        spline = CubicSpline(x, w, bc_type=SPLINE_ENDS[scene.beam.supports])
        slope = spline(x, 1)
        interpolant = "cubic-spline"
    else:
        interpolant = "hermite"

    dp = DiscreteProblem(scene, nodes=x, check_convexity=False)
    full = np.empty(2 * len(x))
    full[0::2] = w / dp.W
    full[1::2] = slope * dp.L / dp.W
    fixed = np.setdiff1d(np.arange(2 * len(x)), dp.free)
    scale = max(np.abs(full[0::2]).max(), 1e-300)
    boundary = float(np.abs(full[fixed]).max(initial=0.0) / scale)
    energy = dp.energy(full[dp.free]) * dp.E0

    reference = solve(scene, elements=reference_elements)
    grid = np.union1d(np.linspace(0.0, scene.beam.length, GRID), np.union1d(x, reference.x))
    ours = fem.eval_matrix(x, grid, 0) @ np.ravel(np.column_stack([w, slope]))
    truth = reference.deflection(grid)
    diff = np.abs(ours - truth)
    i = int(np.argmax(diff))
    wmax = np.abs(truth).max() or 1.0
    out = {
        "status": "ok",
        "interpolant": interpolant,
        "nodes": len(x),
        "energy": energy,
        "energy_reference": reference.energy,
        "energy_gap": energy - reference.energy,
        "energy_gap_rel": (energy - reference.energy) / (abs(reference.energy) or 1.0),
        "max_error": float(diff[i]),
        "max_error_rel": float(diff[i] / wmax),
        "max_error_x": float(grid[i]),
        "boundary_violation": boundary,
        "reference": {"method": reference.method, "elements": len(reference.x) - 1,
                      "status": reference.status},
    }
    if scene.contact == "obstacle":
        out["penetration"] = float(max(-scene.obstacle.gap - ours.min(), 0.0))
    return out
