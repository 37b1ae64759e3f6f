"""The parts of a scene: beam, load, foundation, obstacle, mesh and solver options.

Each is a frozen dataclass whose ``__post_init__`` validates and normalises
its values (:mod:`.values`); ``KEYS`` lists the keys a scene file may give.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from .values import (CONTROLS, EFFECTIVE_LENGTH, FOUNDATION_KINDS, MAX_ELEMENTS, MAX_POINT_FORCES,
                     METHODS, MINIMIZERS, MODELS, SOLVERS, SUPPORTS, TRANSFORMS, _choice, _pairs,
                     _plain, _profile, number, profile_at, whole)

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
        set_("length", number(f"{s}.length", self.length, lo=0, lo_open=True))
        for name in ("E", "half_thickness", "width", "EI"):
            value = getattr(self, name)
            if value is not None:
                set_(name, number(f"{s}.{name}", value, lo=0, lo_open=True))
        if self.nu is not None:
            set_("nu", number(f"{s}.nu", self.nu, lo=0, hi=0.5, hi_open=True))
        if self.mu is not None:
            set_("mu", number(f"{s}.mu", self.mu, lo=0, lo_open=True))
        if self.E_alpha is not None:
            if self.model == "euler-bernoulli":
                raise SceneError(f"{s}.E_alpha", "is not used by the euler-bernoulli model "
                                 "(alpha = 0); remove it or use model = \"gao\"", self.E_alpha)
            set_("E_alpha", number(f"{s}.E_alpha", self.E_alpha, lo=0))
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
        set_("axial", number("load.axial", self.axial))

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
                               number("obstacle.gap_above", self.gap_above, lo=0))

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
                           whole("mesh.elements", self.elements, 1, MAX_ELEMENTS))


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
            object.__setattr__(self, "bound", number("solve.bound", self.bound, lo=0, lo_open=True))


_PARTS = {"beam": Beam, "load": Load, "foundation": Foundation, "obstacle": Obstacle,
          "mesh": MeshSpec, "solve": SolveOptions}

