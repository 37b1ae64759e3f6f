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
"""

from __future__ import annotations

import copy
import dataclasses
import math
import numbers
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .errors import SceneError

__all__ = [
    "Beam", "Load", "Foundation", "Obstacle", "MeshSpec", "SolveOptions", "Scene",
    "load_scene", "parse_set", "read_text", "check_solve_arguments", "MODELS", "SUPPORTS",
    "METHODS", "MAX_ELEMENTS",
]

MODELS = ("gao", "euler-bernoulli")
SUPPORTS = ("P1", "P2", "P3", "P4")
METHODS = ("auto", "convex", "newton", "cvm", "global")
TRANSFORMS = ("auto", "T1", "T2", "T3")
CONTROLS = ("P1", "full")
FOUNDATION_KINDS = ("unilateral", "bilateral")
MINIMIZERS = ("projected-newton", "conditional-gradient")
SOLVERS = ("clarabel", "osqp")
MAX_ELEMENTS = 1_000_000
MAX_POINT_FORCES = MAX_ELEMENTS

# Effective-length factors L_ef / L of the continuum buckling loads (physics.md).
EFFECTIVE_LENGTH = {"P1": 0.5, "P2": 0.699157, "P3": 2.0, "P4": 1.0}


# --------------------------------------------------------------------------- checks
def _plain(value):
    """A numpy scalar or array as the Python float, int or (nested) list it holds."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _number(key: str, value, *, lo=None, hi=None, lo_open=False, hi_open=False) -> float:
    """Return ``value`` as a finite float, or raise SceneError naming ``key``.

    Python and numpy integers and reals are accepted (a 0-d array too); bools,
    strings and containers are not.
    """
    value = _plain(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SceneError(key, "must be a number", value)
    try:
        value = float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise SceneError(key, "is too large for a double-precision number "
                         "(about 1.8e308 at most)", value) from None
    if not math.isfinite(value):
        raise SceneError(key, "must be finite", value)
    if lo is not None and (value <= lo if lo_open else value < lo):
        raise SceneError(key, f"must be {'>' if lo_open else '>='} {lo:g}", value)
    if hi is not None and (value >= hi if hi_open else value > hi):
        raise SceneError(key, f"must be {'<' if hi_open else '<='} {hi:g}", value)
    return value


def _whole(key: str, value, lo: int, hi: int) -> int:
    """Return ``value`` as an int in [lo, hi], or raise SceneError naming ``key``.

    Integers (Python or numpy) and integral floats such as ``8.0`` are
    accepted; bools, strings and fractions such as ``2.5`` are not.
    """
    v = _plain(value)
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    if isinstance(v, bool) or not isinstance(v, numbers.Integral):
        raise SceneError(key, "must be a whole number", value)
    v = int(v)
    if not lo <= v <= hi:
        raise SceneError(key, f"must be between {lo} and {hi}", v)
    return v


def _choice(key: str, value, options) -> str:
    if not isinstance(value, str) or value not in options:
        listed = ", ".join(repr(o) for o in options)
        raise SceneError(key, f"must be one of {listed}", value)
    return value


def _table(key: str, value) -> Mapping:
    if not isinstance(value, Mapping):
        raise SceneError(key, "must be a table", value)
    return value


def _pairs(key: str, value) -> list:
    """``value`` as a list of (x, value) float pairs, or SceneError naming the bad entry.

    Plain float pairs take a fast path (a million point forces validate in about a
    second); anything else goes through :func:`_number`.
    """
    value = _plain(value)
    if not isinstance(value, (list, tuple)):
        raise SceneError(key, "must be a list of [x, value] pairs", value)
    out = []
    append, isfinite = out.append, math.isfinite
    for i, pair in enumerate(value):
        if type(pair) not in (list, tuple):
            pair = _plain(pair)
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise SceneError(f"{key}[{i}]", "must be a pair [x, value]", pair)
        a, b = pair
        if isinstance(a, float) and isinstance(b, float) and isfinite(a) and isfinite(b):
            append((float(a), float(b)))  # float() turns np.float64 into float
        else:
            append((_number(f"{key}[{i}][0]", a), _number(f"{key}[{i}][1]", b)))
    return out


def _profile(key: str, value, lo: float, lo_open: bool = False):
    """A number, or a piecewise-linear table ``[[x, v], ...]`` (a profile, or a load).

    A table has at least two rows, strictly increasing x, and every value in
    range (``lo=None``: any).  Between its rows v is linear; beyond them a
    surface profile is constant (:func:`profile_at`) and a load is zero.
    """
    value = _plain(value)
    if not isinstance(value, (list, tuple)):
        return _number(key, value, lo=lo, lo_open=lo_open)
    table = _pairs(key, value)
    if len(table) < 2:
        raise SceneError(key, "a table needs at least two [x, value] rows", value)
    for i, (x, v) in enumerate(table):
        _number(f"{key}[{i}][1]", v, lo=lo, lo_open=lo_open)
        if i and not x > table[i - 1][0]:
            raise SceneError(f"{key}[{i}][0]", "table x must be strictly increasing", x)
    return tuple(table)


def profile_at(value, x) -> np.ndarray:
    """A number or a :func:`_profile` table evaluated at ``x`` (an array)."""
    x = np.asarray(x, float)
    if isinstance(value, tuple):
        xs, vs = zip(*value)
        return np.interp(x, xs, vs)
    return np.full(x.shape, float(value))


def _check_on_beam(key: str, value, L: float) -> None:
    if isinstance(value, tuple):
        for i, (x, _) in enumerate(value):
            if not 0.0 <= x <= L:
                raise SceneError(f"{key}[{i}][0]", f"x must lie on the beam [0, {L:g}]", x)


def _reject_unknown(section: str, data: Mapping, known) -> None:
    for name in data:
        if name not in known:
            where = f"{section}.{name}" if section else str(name)
            listed = ", ".join(known)
            raise SceneError(where, f"unknown key (known: {listed})", data[name])


# --------------------------------------------------------------------------- parts
@dataclass(frozen=True)
class Beam:
    """The beam: model, supports, geometry and material.

    Parameters
    ----------
    model : {"gao", "euler-bernoulli"}
        The Gao beam or its special case alpha = 0, nu = 0.
    supports : {"P1", "P2", "P3", "P4"}
        Clamped-clamped, clamped-pinned, cantilever (free right end),
        pinned-pinned.
    length, E, nu, half_thickness, width : float
        L [m], Young's modulus [Pa], Poisson's ratio, h [m] (the section is
        2h thick), b [m].
    EI, E_alpha, mu : float or None
        Explicit overrides of the derived coefficients.
    """

    supports: str
    length: float
    E: float | None = None
    nu: float | None = None
    half_thickness: float | None = None
    width: float | None = None
    model: str = "gao"
    EI: float | None = None
    E_alpha: float | None = None
    mu: float | None = None

    KEYS = ("model", "supports", "length", "E", "nu", "half_thickness", "width",
            "EI", "E_alpha", "mu")

    def __post_init__(self):
        s = "beam"
        _choice(f"{s}.model", self.model, MODELS)
        _choice(f"{s}.supports", self.supports, SUPPORTS)
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen dataclass)
        set_("length", _number(f"{s}.length", self.length, lo=0, lo_open=True))
        for name in ("E", "half_thickness", "width", "EI"):
            value = getattr(self, name)
            if value is not None:
                set_(name, _number(f"{s}.{name}", value, lo=0, lo_open=True))
        if self.nu is not None:
            set_("nu", _number(f"{s}.nu", self.nu, lo=0, hi=0.5, hi_open=True))
        if self.mu is not None:
            set_("mu", _number(f"{s}.mu", self.mu, lo=0, lo_open=True))
        if self.E_alpha is not None:
            if self.model == "euler-bernoulli":
                raise SceneError(f"{s}.E_alpha", "is not used by the euler-bernoulli model "
                                 "(alpha = 0); remove it or use model = \"gao\"", self.E_alpha)
            set_("E_alpha", _number(f"{s}.E_alpha", self.E_alpha, lo=0))
        # Every derived coefficient must be computable: name what is missing.
        section = ("E", "half_thickness", "width")
        if self.EI is None:
            self._require(section, "to compute EI (or give beam.EI)")
        if self.model == "gao":
            self._require(("nu",), "for the gao model")
            if self.E_alpha is None:
                self._require(section, "to compute E_alpha (or give beam.E_alpha)")
        # The derived coefficients must be finite and nonzero numbers too (a
        # half thickness of 1e102 overflows h^3; one of 1e-120 underflows it).
        for name, derived, inputs in (("EI", lambda: self.EI_eff, section),
                                      ("E_alpha", lambda: self.E_alpha_eff, section)):
            try:
                value = derived()
            except OverflowError:
                value = math.inf
            if not math.isfinite(value) or (name == "EI" and value <= 0):
                given = {k: getattr(self, k) for k in inputs if getattr(self, k) is not None}
                raise SceneError(f"beam.{name}", "cannot be computed within double precision "
                                 "from the given values", given)

    def _require(self, names, why):
        for name in names:
            if getattr(self, name) is None:
                raise SceneError(f"beam.{name}", f"missing: needed {why}")

    @property
    def is_gao(self) -> bool:
        return self.model == "gao"

    @property
    def EI_eff(self) -> float:
        """Bending stiffness EI = E (2/3) h^3 b, or the override."""
        if self.EI is not None:
            return self.EI
        return self.E * (2.0 / 3.0) * self.half_thickness**3 * self.width

    @property
    def E_alpha_eff(self) -> float:
        """E alpha = 3 E h b (1 - nu^2) for Gao, 0 for Euler-Bernoulli."""
        if not self.is_gao:
            return 0.0
        if self.E_alpha is not None:
            return self.E_alpha
        return self.E * 3.0 * self.half_thickness * self.width * (1.0 - self.nu**2)

    @property
    def mu_eff(self) -> float:
        """mu = (1 + nu)(1 - nu^2) for Gao, 1 for Euler-Bernoulli, or the override."""
        if self.mu is not None:
            return self.mu
        return (1.0 + self.nu) * (1.0 - self.nu**2) if self.is_gao else 1.0

    @property
    def load_factor(self) -> float:
        """The factor (1 - nu^2) that scales loads and foundation stiffness (1 for EB)."""
        return 1.0 - self.nu**2 if self.is_gao else 1.0

    def P_bar(self) -> float:
        """Continuum convexity limit P_bar = pi^2 EI / (L_ef^2 mu) [N]."""
        l_ef = EFFECTIVE_LENGTH[self.supports] * self.length
        return math.pi**2 * self.EI_eff / l_ef**2 / self.mu_eff


@dataclass(frozen=True)
class Load:
    """Vertical loads and the axial force.

    Parameters
    ----------
    q : float, sequence of (x, q) pairs, or None
        Uniform load [N/m], or a piecewise-linear table with strictly
        increasing x in [0, L] (zero outside the table's range).
    points : sequence of (x, F)
        Point forces [N] at x in [0, L].
    axial : float
        Axial force P [N], compression positive.
    """

    q: float | tuple | None = None
    points: tuple = ()
    axial: float = 0.0

    KEYS = ("q", "points", "axial")

    def __post_init__(self):
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        if self.q is not None:  # a number, or a table as the surface profiles are
            set_("q", _profile("load.q", self.q, lo=None))
        points = _plain(self.points)
        if isinstance(points, (list, tuple)) and len(points) > MAX_POINT_FORCES:
            raise SceneError("load.points", f"at most {MAX_POINT_FORCES} point forces "
                             "(each may need a node of its own)", f"{len(points)} forces")
        set_("points", tuple(_pairs("load.points", points)))
        set_("axial", _number("load.axial", self.axial))

    @property
    def is_table(self) -> bool:
        return isinstance(self.q, tuple)


@dataclass(frozen=True)
class Foundation:
    """Deformable Winkler foundation: gap [m] >= 0, stiffness k_F [N/m^2] > 0.

    ``kind = "unilateral"`` (the default) pushes up only where the beam has
    sunk below its surface, 1/2 c_F ((g - w)^+)^2; ``"bilateral"`` is bonded
    to the beam (thesis (2.1), (2.43), "as for railway tracks"), 1/2 c_F (w - g)^2:
    it pulls as well as pushes, and raises the convexity limit to P_hat (2.44).
    """

    gap: float
    stiffness: float
    kind: str = "unilateral"
    KEYS = ("gap", "stiffness", "kind")

    def __post_init__(self):
        object.__setattr__(self, "gap", _profile("foundation.gap", self.gap, lo=0))
        object.__setattr__(self, "stiffness",
                           _profile("foundation.stiffness", self.stiffness, lo=0, lo_open=True))
        object.__setattr__(self, "kind", _choice("foundation.kind", self.kind, FOUNDATION_KINDS))

    def gap_at(self, x) -> np.ndarray:
        """The gap [m] at ``x`` (a number or a piecewise-linear table)."""
        return profile_at(self.gap, x)

    def stiffness_at(self, x) -> np.ndarray:
        """k_F [N/m^2] at ``x``."""
        return profile_at(self.stiffness, x)

    @property
    def bilateral(self) -> bool:
        return self.kind == "bilateral"


@dataclass(frozen=True)
class Obstacle:
    """Rigid obstacle (Signorini contact): gap [m] >= 0 below the undeformed beam.

    ``gap_above`` (optional, >= 0): a second rigid surface that far above the
    beam, w <= gap_above on the same points (a beam in a channel).
    """

    gap: float
    gap_above: float | None = None
    KEYS = ("gap", "gap_above")

    def __post_init__(self):
        object.__setattr__(self, "gap", _profile("obstacle.gap", self.gap, lo=0))
        if self.gap_above is not None:
            object.__setattr__(self, "gap_above",
                               _number("obstacle.gap_above", self.gap_above, lo=0))

    def gap_at(self, x) -> np.ndarray:
        """The gap [m] at ``x`` (a number or a piecewise-linear table)."""
        return profile_at(self.gap, x)


@dataclass(frozen=True)
class MeshSpec:
    """Number of equal elements (nodes are added at point-force positions)."""

    elements: int = 32
    KEYS = ("elements",)

    def __post_init__(self):
        object.__setattr__(self, "elements",
                           _whole("mesh.elements", self.elements, 1, MAX_ELEMENTS))


@dataclass(frozen=True)
class SolveOptions:
    """Solver options.

    Parameters
    ----------
    method : {"auto", "convex", "newton", "cvm"}
    solver : {"clarabel", "osqp"}
        Convex method only.
    transform : {"auto", "T1", "T2", "T3"}
        CVM only: auto is T2 for P3, T3 for P4, T1 otherwise.
    control : {"P1", "full"}
        CVM only: the thesis's piecewise-linear control, or the whole discrete
        load space (the consistency check).
    minimizer : {"projected-newton", "conditional-gradient"}
        CVM only.
    bound : float or None
        CVM only: the control bound C (> 0) in the control's physical units;
        by default chosen so that it is inactive.
    """

    method: str = "auto"
    solver: str = "clarabel"
    transform: str = "auto"
    control: str = "P1"
    minimizer: str = "projected-newton"
    bound: float | None = None
    KEYS = ("method", "solver", "transform", "control", "minimizer", "bound")

    def __post_init__(self):
        _choice("solve.method", self.method, METHODS)
        _choice("solve.solver", self.solver, SOLVERS)
        _choice("solve.transform", self.transform, TRANSFORMS)
        _choice("solve.control", self.control, CONTROLS)
        _choice("solve.minimizer", self.minimizer, MINIMIZERS)
        if self.bound is not None:
            object.__setattr__(self, "bound", _number("solve.bound", self.bound, lo=0, lo_open=True))


_PARTS = {"beam": Beam, "load": Load, "foundation": Foundation, "obstacle": Obstacle,
          "mesh": MeshSpec, "solve": SolveOptions}


@dataclass(frozen=True)
class Scene:
    """One validated beam problem.  See the module docstring."""

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
            raise SceneError("beam", "missing: every scene needs a [beam] table")
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
                raise SceneError(f"{name}.{missing[0]}" if missing else name,
                                 "missing") from exc
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
        n = _whole("elements", elements, 1, MAX_ELEMENTS)
    from .memory import check_memory
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


# A scene needs arrays two levels deep ([[x, q], ...]); this is far beyond any.
MAX_NESTING = 64
# Scene and result files are read whole; 10^6 point forces take ~40 MB of TOML.
MAX_FILE_BYTES = 256 << 20


def _nesting(text: str) -> tuple[int, int, str | None]:
    """The deepest bracket nesting of TOML text, its line, and the dotted key there.

    Brackets inside strings and comments are skipped roughly (a quote opens a
    string until the same quote, ``#`` outside one ends the line); table
    headers and ``key =`` count only outside any bracket.  Good enough to name
    the key of an absurdly deep array, which is all this is for.
    """
    depth = deepest = 0
    where, key_there = 1, None
    table, key = "", None
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if depth == 0 and stripped and not stripped.startswith("#"):
            header = re.fullmatch(r"\[\[?\s*([A-Za-z0-9_.\-\"' ]+?)\s*\]\]?\s*(#.*)?", stripped)
            if header:
                table, key = header.group(1).replace('"', "").replace("'", ""), None
            elif "=" in stripped:
                key = stripped.split("=", 1)[0].strip().strip("\"'")
        quote = None
        for ch in line:
            if quote:
                if ch == quote:
                    quote = None
            elif ch in "\"'":
                quote = ch
            elif ch == "#":
                break
            elif ch in "[{":
                depth += 1
                if depth > deepest:
                    deepest, where = depth, number
                    key_there = f"{table}.{key}" if table and key else (key or table or None)
            elif ch in "]}":
                depth = max(depth - 1, 0)
    return deepest, where, key_there


def _parse_toml(text: str, where: str, *, value_key: str | None = None) -> dict:
    """Parse TOML text, turning every failure into one SceneError.

    ``where`` names the source (a file) for syntax errors; ``value_key`` is
    the dotted key when the text is one ``--set`` value.
    """
    depth, line, key = _nesting(text)
    if depth > MAX_NESTING:
        key = value_key or key or where
        raise SceneError(key, f"arrays or tables nested more than {MAX_NESTING} "
                         f"levels deep", f"{depth} levels at line {line}")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        raise
    except RecursionError:  # pragma: no cover - the depth check above comes first
        raise SceneError(value_key or where, "nested too deeply to read") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise SceneError(value_key or where, f"cannot read a value: {exc}") from None


def parse_set(text: str) -> tuple[str, Any]:
    """Parse a ``--set KEY=VALUE`` argument; VALUE uses TOML value syntax.

    A bare word that is not a TOML value (``beam.model=gao``) is taken as a
    string.

    Examples
    --------
    >>> parse_set("foundation.stiffness=5e12")
    ('foundation.stiffness', 5000000000000.0)
    >>> parse_set("beam.supports=P3")
    ('beam.supports', 'P3')
    """
    if "=" not in text:
        raise SceneError("--set", "must be KEY=VALUE", text)
    key, raw = (s.strip() for s in text.split("=", 1))
    if not key:
        raise SceneError("--set", "must be KEY=VALUE", text)
    try:
        value = _parse_toml(f"v = {raw}", "--set", value_key=key)["v"]
    except tomllib.TOMLDecodeError:
        if raw and all(c.isalnum() or c in "-_." for c in raw):
            value = raw
        else:
            raise SceneError(key, "is not a TOML value", raw) from None
    return key, value


def read_text(path, what: str = "scene file") -> str:
    """The text of a UTF-8 file of at most MAX_FILE_BYTES; a byte-order mark is skipped.

    Raises
    ------
    SceneError
        Keyed by the path, when the file cannot be read or is not UTF-8 text
        (a UTF-16 file is named as such).
    """
    path = Path(path)
    key = str(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise SceneError(key, f"cannot read the {what}: {exc.strerror or exc}", key) from None
    except MemoryError:
        raise SceneError(key, f"the {what} is too large to read") from None
    if len(data) > MAX_FILE_BYTES:
        raise SceneError(key, f"the {what} is larger than {MAX_FILE_BYTES >> 20} MB",
                         f"more than {MAX_FILE_BYTES} bytes")
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise SceneError(key, f"the {what} is UTF-16 text; save it as UTF-8", "UTF-16")
    nul = data.find(b"\x00")
    if nul >= 0:
        raise SceneError(key, f"the {what} contains NUL bytes (UTF-16 without a byte-order "
                         "mark, or binary data); save it as UTF-8 text", f"byte {nul}")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise SceneError(key, f"the {what} is not UTF-8 text: byte 0x{data[exc.start]:02x} "
                         f"at line {line} cannot be decoded; save it as UTF-8",
                         f"byte {exc.start}") from None


def load_scene(path, overrides: Mapping[str, Any] | None = None) -> Scene:
    """Read and validate a TOML scene file, applying dotted-key overrides.

    The file must be UTF-8 (a byte-order mark is allowed).

    Raises
    ------
    SceneError
        If the file cannot be read or parsed, or any value is invalid.
    """
    text = read_text(path)
    try:
        data = _parse_toml(text, str(path))
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(str(path), f"not valid TOML: {exc}") from None
    for key, value in (overrides or {}).items():
        _assign(data, key, value)
    return Scene.from_dict(data)
