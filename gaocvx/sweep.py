"""Solve one scene for many values of one key: obstacle-contact experiments.

:func:`sweep` changes one dotted scene key (or the pseudo-key ``load.scale``,
a factor on every vertical load) over a range of values and solves each
scene, reusing what can be reused: the deflection scale of the first scene is
kept, so Newton starts each value from the previous answer and the convex
program is compiled once with Parameters and only re-solved.  Values can be
spread over worker processes (``jobs``) or over a Dask cluster (``dask``),
each taking a contiguous block so that reuse still works inside it.  Several
keys vary together over the points of a grid (:func:`grid`), e.g. a map of
foundation stiffness against gap.

Examples
--------
>>> from gaocvx import Scene
>>> scene = Scene.from_dict({"beam": {"supports": "P1", "length": 1.0, "E": 2.1e11,
...     "nu": 0.3, "half_thickness": 0.1, "width": 1.0}, "load": {"q": -5e8},
...     "foundation": {"gap": 0.007, "stiffness": 5e8}, "mesh": {"elements": 16}})
>>> values = parse_range("5e8:5e12:3:log")
>>> depth = [-0.007 - r.min["w"] for v, r in sweep(scene, "foundation.stiffness", values)]
>>> depth[0] > depth[1] > depth[2] > 0    # the stiffer foundation lets the beam sink less
True

A stiffness-gap map: each point sets both keys.

>>> keys = ("foundation.stiffness", "foundation.gap")
>>> points = grid(parse_range("5e8:5e12:3:log"), parse_range("0.005:0.007:2"))
>>> points.shape
(6, 2)
>>> rows = [summary_row(v, r, keys) for v, r in sweep(scene, keys, points)]
>>> rows[0]["foundation.stiffness"], rows[0]["foundation.gap"], rows[0]["status"]
(500000000.0, 0.005, 'optimal')
"""

from __future__ import annotations

import logging
import time
from typing import Iterator

import numpy as np

from .discrete import DiscreteProblem
from .errors import SceneError, SolverError
from .linalg import one_blas_thread
from .progress import ProgressBar
from .ranges import count_of, grid, parse_range
from .scene import Scene
from .solve import choose_method, solve

__all__ = ["parse_range", "count_of", "grid", "sweep", "scene_at", "summary_row", "LOAD_SCALE",
           "ProgressBar"]

log = logging.getLogger(__name__)

LOAD_SCALE = "load.scale"
# Values per block of a parallel sweep at least (each block starts cold; later
# values in it start from their neighbour's answer).
BLOCK = 25


def _keys(key) -> tuple[str, ...]:
    """``key`` as a tuple of keys (one dotted key, or a sequence of them)."""
    return (key,) if isinstance(key, str) else tuple(key)


def scene_at(scene: Scene, key, value) -> Scene:
    """The scene with ``key`` set to ``value`` (``load.scale`` multiplies the loads).

    ``key`` may be a sequence of keys and ``value`` the sequence of their values.
    """
    if not isinstance(key, str):
        pairs = dict(zip(key, value, strict=True))
        scale = pairs.pop(LOAD_SCALE, None)
        scene = scene.with_overrides(pairs) if pairs else scene   # one validation for all
        # the scale applies to the loads the other keys set, whatever the keys' order
        return scene if scale is None else scene_at(scene, LOAD_SCALE, scale)
    if key == LOAD_SCALE:
        load = scene.load
        q = load.q
        if load.is_table:
            q = [[x, v * value] for x, v in q]
        elif q is not None:
            q = q * value
        overrides = {"load.points": [[x, F * value] for x, F in load.points]}
        if q is not None:
            overrides["load.q"] = q
        return scene.with_overrides(overrides)
    return scene.with_overrides({key: value})


def _check_keys(scene: Scene, keys: tuple[str, ...], values: np.ndarray) -> None:
    """Fail fast on keys no value could make valid, or values that do not fit them."""
    if not keys:
        raise SceneError("--vary", "needs at least one key", keys)
    for key in keys:
        if not isinstance(key, str):
            raise SceneError("--vary", "a key must be a string like foundation.stiffness", key)
        _check_key(scene, key)
        if keys.count(key) > 1:
            raise SceneError(key, "is varied twice", key)
    if values.ndim != 2 or values.shape[1] != len(keys):
        raise SceneError("--vary", f"needs one value per key for each point ({len(keys)} "
                         f"keys, values of shape {values.shape})", list(keys))


def _check_key(scene: Scene, key: str) -> None:
    """Fail fast on a key no value could make valid."""
    if key == LOAD_SCALE:
        return
    from .scene.parts import _PARTS
    section, _, name = key.partition(".")
    if section not in _PARTS or name not in _PARTS[section].KEYS:
        raise SceneError(key, "unknown scene key (use section.name, e.g. foundation.stiffness, "
                         f"or {LOAD_SCALE})", key)
    if section == "mesh":
        raise SceneError(key, "a sweep keeps its mesh; vary a physical key", key)
    if section in ("foundation", "obstacle") and getattr(scene, section) is None:
        raise SceneError(key, f"the scene has no [{section}] table to vary", key)


def _solve_values(scene: Scene, key: str, values, method: str | None):
    """Solve values in order, reusing scale, warm starts and programs; yield (value, item)."""
    W = warm = None
    # The parametric (DPP) convex program compiles as fast as a constant one (the
    # load enters as a scalar factor) and saves about 30% of each later solve, so
    # it pays from the second value on; Clarabel's iterations remain.
    reuse = len(values) > 1
    for value in values:
        value = float(value) if isinstance(key, str) else tuple(float(v) for v in value)
        try:
            s = scene_at(scene, key, value)
            chosen = choose_method(s, method)
            with one_blas_thread():   # per value: the limit must not span a yield
                if chosen == "global":
                    # At or above P_bar_h (an axial sweep through the limit): the certified
                    # global minimiser, each value on its own (no scale or start carries).
                    result = solve(s, "global")
                else:
                    dp = DiscreteProblem(s, W=W)
                    if W is not None and dp.bonded_pull > W:
                        # A bonded bed whose gap lies beyond the kept scale pulls the
                        # beam that far: the scene's own scale, from here on (a P4
                        # beam under a weak load, gaps 0 then 1 cm: the convex
                        # program at the first scene's 1.2e-7 m failed at every rung)
                        dp, warm = DiscreteProblem(s), None
                    W = dp.W
                    # "auto" stays auto: an answer Newton cannot certify gets convex's.
                    asked = "auto" if (method or s.solve.method) == "auto" else chosen
                    result = solve(s, asked, problem=dp,
                                   warm=warm if chosen == "newton" else None,
                                   reuse=reuse and chosen == "convex")
                    warm = result.extra.get("warm")
            yield value, result
        except (SceneError, SolverError) as exc:
            yield value, exc


def _solve_block(scene: Scene, key, values, method: str | None, reduce=None) -> list:
    """A contiguous block of values, for a worker process or a Dask task."""
    return [_reduced(reduce, item) for item in _solve_values(scene, key, values, method)]


def _serial(scene: Scene, key, values, method: str | None, reduce):
    for item in _solve_values(scene, key, values, method):
        yield _reduced(reduce, item)


def _reduced(reduce, item):
    value, outcome = item
    return item if reduce is None else (value, reduce(value, outcome))


def _blocks(values, n):
    n = max(1, min(n, len(values)))
    edges = np.linspace(0, len(values), n + 1).astype(int)
    return [values[a:b] for a, b in zip(edges[:-1], edges[1:]) if b > a]


def sweep(scene: Scene, key, values, method: str | None = None, jobs: int = 1,
          dask: str | None = None, progress=None,
          reduce=None) -> Iterator[tuple[object, object]]:
    """Solve ``scene`` for each value of ``key``; yield ``(value, Result or error)`` in order.

    Parameters
    ----------
    scene : Scene
    key : str or sequence of str
        Dotted scene key, e.g. ``"foundation.stiffness"``, or ``"load.scale"``;
        or several keys varied together.
    values : sequence of float, or array of shape (n, len(key))
        The values of one key; for several keys one row per point (e.g.
        :func:`grid`), and each yielded value is the tuple of the row.
    method : str, optional
        As in :func:`gaocvx.solve`.
    jobs : int
        Worker processes (each solves a contiguous block of values).
    dask : str, optional
        Address of a Dask scheduler (``"tcp://host:8786"``) to send the blocks
        to instead (needs the optional ``dask[distributed]``).
    progress : callable, optional
        Called as ``progress(done, total)`` after each value.
    reduce : callable, optional
        ``reduce(value, result_or_error)`` is yielded in place of the result,
        computed where the value is solved (in the worker process or Dask
        task): a large sweep over processes should send back only what it
        keeps (e.g. ``functools.partial(summary_row, keys=...)``) — a
        :class:`Result` with its discrete problem pickles to about 30 kB at
        256 elements.  It must be picklable (a module-level function).

    A value whose scene is invalid yields its :class:`SceneError` (or a
    :class:`SolverError`) in place of a result; the sweep goes on.  BLAS runs
    on one thread while values are solved (:func:`gaocvx.linalg.one_blas_thread`).
    """
    values = np.asarray(values, float)
    if not (isinstance(jobs, (int, np.integer)) and jobs >= 1):
        raise SceneError("--jobs", "must be a whole number of at least 1", jobs)
    if isinstance(key, str):
        _check_key(scene, key)
        if values.ndim != 1:
            raise SceneError(key, "needs a sequence of numbers", values.tolist())
    else:
        key = _keys(key)
        _check_keys(scene, key, values)
    total = len(values)
    if dask is None and jobs <= 1:
        stream = _serial(scene, key, values, method, reduce)
    else:
        # Several blocks per worker so that progress and the load balance are
        # seen as blocks finish; each keeps BLOCK values for its warm starts.
        blocks = _blocks(values, max(jobs, 1) * max(1, min(16, len(values) // (BLOCK * jobs))))
        mapped = (_dask_map(dask, scene, key, blocks, method, reduce) if dask is not None
                  else _process_map(jobs, scene, key, blocks, method, reduce))
        stream = (item for block in mapped for item in block)
    t0 = time.perf_counter()
    for done, item in enumerate(stream, start=1):
        value, outcome = item
        what = (f"error: {outcome}" if isinstance(outcome, Exception)
                else f"{outcome.status} ({outcome.method}, {outcome.time_s * 1e3:.1f} ms)"
                if reduce is None else "done")
        log.info("sweep %s = %s: %s [%d/%d, %.1f s]", key, _show(value), what, done, total,
                 time.perf_counter() - t0)
        if progress:
            progress(done, total)
        yield item


def _process_map(jobs, scene, key, blocks, method, reduce):
    from concurrent.futures import ProcessPoolExecutor
    pool = ProcessPoolExecutor(max_workers=jobs)
    try:
        futures = [pool.submit(_solve_block, scene, key, block, method, reduce)
                   for block in blocks]
        for f in futures:  # in order
            yield f.result()
    finally:   # a caller that stops early (or fails) does not wait for the other blocks
        pool.shutdown(wait=True, cancel_futures=True)


def _dask_map(address, scene, key, blocks, method, reduce):
    try:
        from dask.distributed import Client
    except ImportError:
        raise SceneError("--dask", "needs the optional dependency dask[distributed] "
                         "(pip install 'gaocvx[dask]')", address) from None
    try:
        client = Client(address, timeout=5)
    except OSError as exc:
        raise SceneError("--dask", f"cannot reach the Dask scheduler: {exc}", address) from None
    try:
        n = len(blocks)
        futures = client.map(_solve_block, [scene] * n, [key] * n, blocks, [method] * n,
                             [reduce] * n, pure=False)
        for f in futures:
            yield f.result()
    finally:
        client.close()


def _show(value) -> str:
    return f"{value:.6g}" if isinstance(value, float) else ", ".join(f"{v:.6g}" for v in value)


def summary_row(value, item, keys=None) -> dict:
    """The numbers a sweep reports for one value (or its error).

    With ``keys`` (several keys varied together) the row has one column per key
    in place of ``"value"``.
    """
    head = {"value": value} if keys is None else dict(zip(_keys(keys), value, strict=True))
    if isinstance(item, Exception):
        return {**head, "status": "error", "error": str(item)}
    r = item
    row = {**head, "status": r.status, "method": r.method,
           "min_w": r.min["w"], "min_x": r.min["x"], "max_w": r.max["w"], "max_x": r.max["x"],
           "energy": r.energy, "time_s": r.time_s}
    if r.scene.contact is not None:
        # (none without a foundation or obstacle, as solve's "contact" is null there)
        zones = r.zones or []
        row["contact_length"] = float(sum(b - a for a, b in zones))
        row["contact_zones"] = len(zones)   # a point contact [x, x] counts, though of length 0
        # How far the beam sinks below the surface, at its worst node (a gap
        # profile's surface is not level: the deepest point need not be the lowest).
        level = -np.asarray(r.scene.gap_at(r.x), float)
        row["penetration"] = float(max(np.max(level - r.w), 0.0))
    return row
