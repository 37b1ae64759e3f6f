"""The scene: one validated, immutable beam problem, and the arguments of a solve."""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..errors import SceneError
from .parts import _PARTS, Beam, Foundation, Load, MeshSpec, Obstacle, SolveOptions
from .values import (MAX_ELEMENTS, METHODS, SOLVERS, _check_on_beam, _choice, _reject_unknown,
                     _table, whole)

@dataclass(frozen=True)
class Scene:
    """One validated beam problem.  See :mod:`gaocvx.scene`."""

    beam: Beam
    load: Load = field(default_factory=Load)
    foundation: Foundation | None = None
    obstacle: Obstacle | None = None
    mesh: MeshSpec = field(default_factory=MeshSpec)
    solve: SolveOptions = field(default_factory=SolveOptions)

    def __post_init__(self):
        if self.foundation is not None and self.obstacle is not None:
            raise SceneError("obstacle", "a scene has either a foundation or an obstacle, "
                             "not both", "both given")
        L = self.beam.length
        transform = self.solve.transform
        if transform in ("T2", "T3") and self.beam.supports != {"T2": "P3", "T3": "P4"}[transform]:
            raise SceneError("solve.transform", f"{transform} is for supports "
                             f"{ {'T2': 'P3', 'T3': 'P4'}[transform] } only, not "
                             f"{self.beam.supports}", transform)
        if self.solve.method == "cvm" and self.obstacle is not None:
            raise SceneError("solve.method", "cvm handles a deformable foundation or none, "
                             "not a rigid obstacle", "cvm")
        _check_on_beam("load.q", self.load.q, L)
        for i, (x, _) in enumerate(self.load.points):
            if not 0.0 <= x <= L:
                raise SceneError(f"load.points[{i}][0]", f"x must lie on the beam [0, {L:g}]", x)
        if self.foundation is not None:
            _check_on_beam("foundation.gap", self.foundation.gap, L)
            _check_on_beam("foundation.stiffness", self.foundation.stiffness, L)
        if self.obstacle is not None:
            _check_on_beam("obstacle.gap", self.obstacle.gap, L)

    # ----------------------------------------------------------------- properties
    @property
    def contact(self) -> str | None:
        """``"foundation"``, ``"obstacle"`` or ``None``."""
        if self.foundation is not None:
            return "foundation"
        if self.obstacle is not None:
            return "obstacle"
        return None

    @property
    def gap(self) -> float | None:
        """The foundation's or obstacle's gap [m]; for a profile, its smallest (the nearest point)."""
        part = self.foundation or self.obstacle
        if part is None:
            return None
        return min(v for _, v in part.gap) if isinstance(part.gap, tuple) else part.gap

    @property
    def has_profile(self) -> bool:
        """True when the contact's gap or stiffness is a table."""
        part = self.foundation or self.obstacle
        return part is not None and any(isinstance(getattr(part, k, None), tuple)
                                         for k in ("gap", "stiffness"))

    def gap_at(self, x) -> np.ndarray | None:
        """The gap [m] at ``x`` (None without a foundation or obstacle)."""
        part = self.foundation or self.obstacle
        return None if part is None else part.gap_at(x)

    # ----------------------------------------------------------------- conversion
    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Scene":
        """Build a scene from a dict with the structure of a scene file.

        Raises
        ------
        SceneError
            For any unknown key, missing key, wrong type or value out of range.
        """
        _table("scene", data)
        _reject_unknown("", data, tuple(_PARTS))
        if "beam" not in data:
            raise SceneError("beam", "missing: every scene needs a [beam] table",
                             sorted(data))
        parts = {}
        for name, kind in _PARTS.items():
            if name not in data:
                continue
            section = _table(name, data[name])
            _reject_unknown(name, section, kind.KEYS)
            try:
                parts[name] = kind(**dict(section))
            except TypeError as exc:  # a required field is missing
                missing = [f.name for f in dataclasses.fields(kind)
                           if f.default is dataclasses.MISSING and f.name not in section]
                # (the table as given: a --set that made it, e.g. foundation.stiffness
                # alone, shows what the missing key was to go with)
                raise SceneError(f"{name}.{missing[0]}" if missing else name,
                                 "missing", {name: dict(section)}) from exc
        return cls(**parts)

    def to_dict(self) -> dict:
        """The scene as a dict that :meth:`from_dict` reads back (None values dropped)."""
        out = {}
        for name in _PARTS:
            part = getattr(self, name)
            if part is None:
                continue
            values = {}
            for f in dataclasses.fields(part):
                v = getattr(part, f.name)
                if v is None:
                    continue
                if isinstance(v, tuple):
                    v = [list(p) for p in v]
                values[f.name] = v
            out[name] = values
        return out

    def with_overrides(self, overrides: Mapping[str, Any]) -> "Scene":
        """A new scene with dotted-path values replaced, e.g. ``{"beam.nu": 0.25}``.

        Setting a key of a table the scene does not have creates that table
        (validation then asks for its other required keys).
        """
        data = copy.deepcopy(self.to_dict())
        for path, value in overrides.items():
            _assign(data, path, value)
        return Scene.from_dict(data)


def check_solve_arguments(scene, method=None, elements=None, solver=None) -> Scene:
    """Validate the arguments of :func:`gaocvx.solve` and return the scene to solve.

    Parameters
    ----------
    scene : Scene or Mapping
        A dict with the structure of a scene file is validated into a Scene.
    method : str, optional
        One of :data:`METHODS`.
    elements : int, optional
        A whole number of elements in [1, MAX_ELEMENTS]; integral floats such
        as ``8.0`` and numpy integers are accepted, ``2.5``, ``"8"`` and bools
        are not.
    solver : str, optional
        One of ``"clarabel"``, ``"osqp"``.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Naming the argument (``scene``, ``method``, ``elements``, ``solver``)
        or the scene key; ``mesh.elements`` when the mesh would need more
        memory than is available (:mod:`gaocvx.memory`).

    Examples
    --------
    >>> scene = check_solve_arguments({"beam": {"model": "euler-bernoulli",
    ...     "supports": "P4", "length": 1.0, "EI": 1e6}}, elements=8.0)
    >>> type(scene).__name__
    'Scene'
    >>> check_solve_arguments(scene, elements=2.5)
    Traceback (most recent call last):
    ...
    gaocvx.errors.SceneError: elements: must be a whole number (got 2.5)
    """
    if isinstance(scene, Mapping):
        scene = Scene.from_dict(scene)
    elif not isinstance(scene, Scene):
        raise SceneError("scene", "must be a Scene or a dict with the structure of a scene "
                         "file", type(scene).__name__)
    if method is not None:
        _choice("method", method, METHODS)
    if solver is not None:
        _choice("solver", solver, SOLVERS)
    n = scene.mesh.elements
    if elements is not None:
        n = whole("elements", elements, 1, MAX_ELEMENTS)
    from ..memory import check_memory
    chosen = method or scene.solve.method
    # Each point force may add a node: count them, the estimate is an upper bound.
    check_memory(n + len(scene.load.points), chosen, scene.contact, "mesh.elements", n)
    return scene


def _assign(data: dict, path: str, value) -> None:
    parts = path.split(".")
    if len(parts) != 2 or not all(parts):
        raise SceneError(path, "must be a dotted key section.name, e.g. beam.nu", path)
    section, key = parts
    if section not in _PARTS:
        raise SceneError(path, f"unknown table {section!r} (known: {', '.join(_PARTS)})", path)
    data.setdefault(section, {})[key] = value


