"""Scenes: a validated, immutable description of one beam problem.

A scene holds the beam, its supports, its loads and what it may touch
(a deformable unilateral foundation or a rigid obstacle), the mesh size and
the solver options.  It is read from a TOML file (:func:`load_scene`), from a
dict with the same structure (:meth:`Scene.from_dict`), or built from the
dataclasses directly; every path goes through the same validation, and every
bad value raises :class:`~gaocvx.errors.SceneError` naming its dotted key.

Sign conventions (SI units): deflection ``w`` is positive **up**, distributed
loads and point forces are positive up, the axial force ``P`` is positive in
**compression**, and a foundation or obstacle is given by its ``gap`` >= 0
below the undeformed beam (its surface is at level ``g = -gap``).

Examples
--------
>>> scene = Scene.from_dict({
...     "beam": {"model": "euler-bernoulli", "supports": "P4", "length": 1.0,
...              "E": 2.1e11, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -5e7}})
>>> scene.beam.EI_eff
140000000.00000003
>>> scene.with_overrides({"load.axial": 1e8}).load.axial
100000000.0

One module per concept: :mod:`.values` (the vocabulary and the checks of
single values), :mod:`.parts` (beam, load, foundation, obstacle, mesh, solver
options), :mod:`.core` (:class:`Scene` and :func:`check_solve_arguments`) and
:mod:`.files` (TOML files, ``--set`` overrides, size limits).
"""

from __future__ import annotations

from .core import Scene, check_solve_arguments
from .files import MAX_FILE_BYTES, MAX_NESTING, load_scene, parse_set, read_text
from .parts import Beam, Foundation, Load, MeshSpec, Obstacle, SolveOptions
from .values import (CONTROLS, EFFECTIVE_LENGTH, FOUNDATION_KINDS, MAX_ELEMENTS, MAX_POINT_FORCES,
                     METHODS, MINIMIZERS, MODELS, SOLVERS, SUPPORTS, TRANSFORMS, number,
                     numbers_of, profile_at, whole)

__all__ = [
    "Beam", "Load", "Foundation", "Obstacle", "MeshSpec", "SolveOptions", "Scene",
    "load_scene", "parse_set", "read_text", "check_solve_arguments", "number", "numbers_of",
    "whole",
    "profile_at", "MODELS", "SUPPORTS", "METHODS", "TRANSFORMS", "CONTROLS", "FOUNDATION_KINDS",
    "MINIMIZERS", "SOLVERS", "MAX_ELEMENTS", "MAX_POINT_FORCES", "EFFECTIVE_LENGTH",
    "MAX_FILE_BYTES", "MAX_NESTING",
]
