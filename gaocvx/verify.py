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
import numpy as np

from . import fem
from .discrete import DiscreteProblem
from .errors import SceneError
from .scene import MAX_ELEMENTS, Scene, number, read_text, whole
from .solve import solve

__all__ = ["verify", "read_result_csv", "reference_method", "check_reference_elements",
           "thresholds_exceeded", "REFERENCE_ELEMENTS"]

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
    key = str(path)
    text = read_text(path, "result file")
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
    if not np.all(np.isfinite(x)):
        i = int(np.argmin(np.isfinite(x)))
        raise SceneError(f"{key}: x[{i}]", "must be finite", float(x[i]))
    if np.any(np.diff(x) <= 0):
        i = int(np.argmax(np.diff(x) <= 0)) + 1
        raise SceneError(f"{key}: x[{i}]", "x must be strictly increasing", float(x[i]))
    tol = 1e-9 * L
    if abs(x[0]) > tol or abs(x[-1] - L) > tol:
        raise SceneError(f"{key}: x", f"the nodes must cover the beam [0, {L:g}]",
                         [float(x[0]), float(x[-1])])
    if len(w) != len(x) or (slope is not None and len(slope) != len(x)):
        raise SceneError(key, "x, w and slope must have the same length", len(w))
    for name, values in (("w", w), ("slope", slope)):
        if values is not None and not np.all(np.isfinite(values)):
            i = int(np.argmin(np.isfinite(values)))
            raise SceneError(f"{key}: {name}[{i}]", "must be finite", float(values[i]))


def reference_method(scene: Scene) -> str:
    """The method of the ground truth: the scene's own, except that CVM is never one.

    A scene that asks for ``cvm`` is scored against ``auto`` (the fastest
    exact method); ``convex`` and ``newton`` are kept.
    """
    return "auto" if scene.solve.method == "cvm" else scene.solve.method


def check_reference_elements(scene: Scene, elements, key: str = "reference_elements") -> int:
    """``elements`` as the size of a ground-truth mesh that fits, or SceneError naming ``key``.

    The allowed range is 1 to :data:`~gaocvx.scene.MAX_ELEMENTS`, and no more
    than the largest mesh whose memory estimate (:mod:`gaocvx.memory`) fits in
    the memory available now.
    """
    from .memory import available_memory, max_elements_that_fit

    upper, why = MAX_ELEMENTS, ""
    fit = max_elements_that_fit(reference_method(scene), scene.contact)
    if fit is not None and fit - len(scene.load.points) < upper:
        upper = fit - len(scene.load.points)
        why = (f" (the largest mesh that fits in the {available_memory() / 1e9:.3g} GB of "
               "memory available)")
    if upper < 1:
        raise SceneError(key, f"no ground-truth mesh fits{why}", elements)
    try:
        return whole(key, elements, 1, upper)
    except SceneError:
        raise SceneError(key, f"must be a whole number from 1 to {upper}{why}",
                         elements) from None


def _column(key: str, values) -> np.ndarray:
    """A 1-D float array from a column of the result, or SceneError naming it."""
    try:
        out = np.array(values, dtype=float)  # a copy: the caller's array is not touched
    except (TypeError, ValueError):
        raise SceneError(key, "must be a list of numbers", values) from None
    if out.ndim != 1:
        raise SceneError(key, "must be a one-dimensional list of numbers", values)
    return out


def thresholds_exceeded(report: dict, max_gap: float | None = None,
                        max_error: float | None = None) -> list[str]:
    """The thresholds a verify report exceeds, each as a short sentence.

    ``max_gap`` bounds ``|energy_gap_rel|`` (the energy gap relative to
    ``|Pi_T|`` of the ground truth); ``max_error`` bounds ``max_error_rel``
    (the largest deflection error relative to ``max |w|`` of the ground
    truth).  Both are relative, so one threshold serves every scene.

    Examples
    --------
    >>> thresholds_exceeded({"energy_gap_rel": 2e-3, "max_error_rel": 1e-5}, 1e-3, 1e-3)
    ['relative energy gap 0.002 exceeds --max-gap 0.001']
    """
    out = []
    if max_gap is not None and not abs(report["energy_gap_rel"]) <= max_gap:
        out.append(f"relative energy gap {report['energy_gap_rel']:.4g} exceeds "
                   f"--max-gap {max_gap:.4g}")
    if max_error is not None and not report["max_error_rel"] <= max_error:
        out.append(f"relative deflection error {report['max_error_rel']:.4g} exceeds "
                   f"--max-error {max_error:.4g}")
    return out


def verify(scene: Scene, x, w, slope=None, *, reference_elements: int = REFERENCE_ELEMENTS,
           key: str = "result", max_gap: float | None = None,
           max_error: float | None = None) -> dict:
    """Energy gap and deflection error of a result against the fine-mesh ground truth.

    Parameters
    ----------
    scene : Scene
    x, w : array_like
        Nodes [m] covering [0, L] and nodal deflections [m], all finite.
    slope : array_like, optional
        Nodal slopes w'; without them a cubic spline supplies them.
    reference_elements : int
        Elements of the ground-truth mesh (:func:`check_reference_elements`).
    key : str
        The name of the result in error messages (e.g. its file).
    max_gap, max_error : float, optional
        Thresholds (>= 0) on ``|energy_gap_rel|`` and ``max_error_rel``; see
        :func:`thresholds_exceeded`.

    Returns
    -------
    dict
        ``energy`` and ``energy_reference`` [J], ``energy_gap`` (>= 0 up to the
        reference's own discretisation error) and ``energy_gap_rel``,
        ``max_error`` [m], ``max_error_rel``, ``max_error_x`` [m],
        (against the nearest of the reference's minimisers where it has several,
        certified: mirror images above ``P_bar_h``), ``boundary_violation`` (largest
        prescribed support value, relative),
        ``penetration`` (obstacle scenes: largest w < g [m]), ``interpolant``,
        ``reference`` (method, elements, status, ``minimisers`` its number of
        global minimisers and ``nearest`` the index of the one measured against,
        0 its answer and i its i-th alternative; the method is never CVM:
        :func:`reference_method`), and ``exceeded``, the thresholds exceeded
        (empty when none was given or all hold).

    Raises
    ------
    SceneError
        For a result that is not a table of finite values covering the beam,
        a reference mesh that is out of range or does not fit in memory, or a
        threshold that is not a number >= 0.
    """
    if isinstance(scene, dict):
        scene = Scene.from_dict(scene)
    limits = {name: None if value is None else number(name, value, lo=0)
              for name, value in (("max_gap", max_gap), ("max_error", max_error))}
    reference_elements = check_reference_elements(scene, reference_elements)
    x = _column(f"{key}: x", x)
    w = _column(f"{key}: w", w)
    slope = None if slope is None else _column(f"{key}: slope", slope)
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

    reference = solve(scene, reference_method(scene), elements=reference_elements)
    grid = np.union1d(np.linspace(0.0, scene.beam.length, GRID), np.union1d(x, reference.x))
    ours = fem.eval_matrix(x, grid, 0) @ np.ravel(np.column_stack([w, slope]))
    # Above P_bar_h the minimiser need not be unique (mirror images): the result is
    # measured against the nearest one (against the first alone, the mirror image of
    # a buckled minimiser was 200 % off -- a new user's trial).  Only certified ones:
    # an `inaccurate` reference's alternatives are candidates, not minimisers.
    others = (reference.extra.get("global", {}).get("alternatives", [])
              if reference.status == "optimal" else [])
    minimisers = [reference.deflection(grid)] + [
        fem.eval_matrix(reference.x, grid, 0) @ np.ravel(np.column_stack([a["w"], a["slope"]]))
        for a in others]
    nearest = int(np.argmin([np.max(np.abs(ours - t)) for t in minimisers]))
    truth = minimisers[nearest]
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
                      "status": reference.status, "minimisers": len(minimisers),
                      "nearest": nearest},
    }
    if scene.contact == "obstacle":
        out["penetration"] = float(max(np.max(-scene.obstacle.gap_at(grid) - ours), 0.0))
        if scene.obstacle.gap_above is not None:
            out["penetration"] = max(out["penetration"],
                                     float(max(np.max(ours) - scene.obstacle.gap_above, 0.0)))
    out["exceeded"] = thresholds_exceeded(out, limits["max_gap"], limits["max_error"])
    return out
