"""The result of a solve: nodal values, energies, contact, and evaluators.

Field names follow scipy.optimize where they overlap (``success``,
``status``, ``message``, ``fun``, ``nit``); :meth:`Result.to_dict` gives the
JSON object of scene-format.md.
"""

from __future__ import annotations

import functools
import logging
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from . import fem
from .errors import format_value
from .scene import Scene

if TYPE_CHECKING:
    from .statics import Statics

__all__ = ["Result", "contact_zones", "extremum"]


def extremum(x, w, largest: bool) -> dict:
    """The largest (or smallest) nodal deflection and its node, the first on ties."""
    i = int(np.argmax(w) if largest else np.argmin(w))
    return {"w": float(w[i]), "x": float(x[i])}

log = logging.getLogger(__name__)


def contact_zones(x, in_contact) -> list[list[float]]:
    """Maximal runs of consecutive points in contact, as ``[x_first, x_last]``.

    The points (nodes, and the Gauss points where contact is integrated or
    imposed) are taken in the order of ``x``; a run of one point is a point
    contact ``[x, x]``.

    Examples
    --------
    >>> contact_zones([0, 1, 2, 3, 4], [False, True, True, False, True])
    [[1.0, 2.0], [4.0, 4.0]]
    >>> contact_zones([0, 2, 1.5], [False, False, True])
    [[1.5, 1.5]]
    """
    x = np.asarray(x, float)
    order = np.argsort(x, kind="stable")
    x = x[order]
    flag = np.concatenate([[False], np.asarray(in_contact, bool)[order], [False]])
    edges = np.flatnonzero(np.diff(flag.astype(int)))
    return [[float(x[a]), float(x[b - 1])] for a, b in zip(edges[0::2], edges[1::2])]


@dataclass(frozen=True)
class Result:
    """The solution of a scene.

    Attributes
    ----------
    scene : Scene
    method : str
        The method actually used ("convex", "newton").
    status : str
        "optimal" when the answer passed the optimality test of the discrete
        problem, "inaccurate" when it did not.
    message : str
    x, w, slope : ndarray
        Nodes [m], nodal deflection [m] (up positive) and slope w'.
    energy : float
        Total potential energy Pi_T [J] (the Gao model's f and c_F).
    energy_parts : dict
        "bending", "gao", "axial", "load", "foundation" [J].
    zones : list of [x_first, x_last] or None
        Contact zones (None without foundation or obstacle): runs of
        consecutive nodes below a foundation's surface, or of consecutive
        constraint points (nodes and Gauss points) touching an obstacle or
        carrying its force; ``[x, x]`` is a point contact.
    reaction : ndarray or None
        Foundation reaction k_F (g - w)^+ [N/m] per node, or obstacle reaction
        force [N] per node (consistent nodal force of the constraint's
        multipliers), in physical units.
    P_bar : float
        Discrete convexity limit P_bar_h [N] (computed on first access).
    time_s : float
    nit : int or None
        Iterations of the method.
    residual : dict
        Optimality measures (see :meth:`DiscreteProblem.residual`).
    extra : dict
        Method-specific information added to the JSON output.
    contact_forces : ndarray or None
        Obstacle only: the contact forces at the constraint points that carry
        one, rows ``[x, F]`` [m, N] (physical units); each lies in a zone.
    """

    scene: Scene
    method: str
    status: str
    message: str
    x: np.ndarray
    w: np.ndarray
    slope: np.ndarray
    energy: float
    energy_parts: dict
    zones: list | None
    reaction: np.ndarray | None
    problem: object = field(repr=False, compare=False)
    time_s: float
    nit: int | None = None
    solver: str | None = None
    residual: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    contact_forces: np.ndarray | None = None

    @functools.cached_property
    def P_bar(self) -> float:
        """Discrete convexity limit P_bar_h [N] of the mesh solved on."""
        t0 = time.perf_counter()
        value = float(self.problem.P_bar_h)
        log.info("P_bar_h = %.6g N (%d elements, %.1f ms)", value, len(self.x) - 1,
                 (time.perf_counter() - t0) * 1e3)
        return value

    @functools.cached_property
    def P_hat(self) -> float | None:
        """A bonded foundation's convexity limit P_hat_h [N] (thesis (2.44)); None otherwise."""
        value = getattr(self.problem, "P_hat_h", None)
        return None if value is None else float(value)

    @property
    def success(self) -> bool:
        """True when the status is "optimal" and nothing says the answer is far from the minimiser.

        A CVM answer may be optimal for CVM's own discrete problem and still lie
        far above the beam's minimum energy (``extra["cvm"]["far_from_minimizer"]``,
        see :func:`gaocvx.solve.cvm_verdict`): that is no success.
        """
        verdict = self.extra.get("cvm", {}).get("far_from_minimizer", False)
        return self.status == "optimal" and verdict is False

    @property
    def fun(self) -> float:
        """The total energy (scipy.optimize's name for the objective value)."""
        return self.energy

    @property
    def max(self) -> dict:
        """Largest nodal deflection and its node (the first on ties)."""
        return extremum(self.x, self.w, largest=True)

    @property
    def min(self) -> dict:
        """Smallest nodal deflection and its node (the first on ties)."""
        return extremum(self.x, self.w, largest=False)

    # ------------------------------------------------------------- evaluators
    def _dofs(self) -> np.ndarray:
        d = np.empty(2 * len(self.x))
        d[0::2], d[1::2] = self.w, self.slope
        return d

    def _points(self, xs) -> np.ndarray:
        """``xs`` as a float array, checked to be real numbers on the beam.

        Raises
        ------
        ValueError
            Naming ``xs``, for anything but real numbers on the beam: strings,
            bools, complex numbers, NaN, or points off [0, L].
        """
        try:
            arr = np.asarray(xs)
        except (ValueError, TypeError):  # a ragged list
            arr = np.asarray(None)
        if arr.dtype.kind not in "iuf":
            raise ValueError(f"xs: must be a number or an array of numbers "
                             f"(got {format_value(xs)})")
        xs = arr.astype(float)
        if np.isnan(xs).any():
            raise ValueError(f"xs: must not be NaN (got {format_value(xs.tolist())})")
        L = self.scene.beam.length
        if np.any((xs < 0) | (xs > L)):
            bad = xs[(xs < 0) | (xs > L)].ravel()[0]
            raise ValueError(f"xs: points must lie on the beam [0, {L:g}] "
                             f"(got {format_value(float(bad))})")
        return xs

    @staticmethod
    def _shaped(values, xs):
        return values.reshape(xs.shape) if xs.ndim else float(values[0])

    def _eval(self, xs, deriv):
        """Values of the ``deriv``-th derivative of the Hermite interpolant at ``xs``."""
        xs = self._points(xs)
        flat = np.atleast_1d(xs).ravel()
        return self._shaped(fem.eval_matrix(self.x, flat, deriv) @ self._dofs(), xs)

    def deflection(self, xs):
        """Deflection w [m] at any points of the beam (Hermite interpolation).

        Parameters
        ----------
        xs : float or array_like of float
            Points in [0, L] [m].

        Returns
        -------
        float or ndarray
            A float for a scalar ``xs``, else an array of its shape.

        Raises
        ------
        ValueError
            For anything but real numbers in [0, L] (strings and NaN included).
        """
        return self._eval(xs, 0)

    def slope_at(self, xs):
        """Slope w' at any points of the beam (``xs`` as for :meth:`deflection`)."""
        return self._eval(xs, 1)

    @functools.cached_property
    def _statics(self) -> "Statics":
        from .statics import Statics
        return Statics(self)

    def moment(self, xs):
        """Bending moment M = EI w'' [N m] from element equilibrium (``xs`` as for :meth:`deflection`).

        Not the cubic's own curvature: each element's end forces (K_e u_e - f_e)
        give M and the shear at its left node, and the element's loads carry
        them across it (see :class:`_Statics`).  For the Euler-Bernoulli beam
        at P = 0 this is the exact moment of the continuum (under a uniform load
        a parabola in every element), whatever the mesh.  At a node the value
        is the right-hand limit (the left one at x = L).

        Examples
        --------
        >>> from gaocvx import Scene, solve
        >>> r = solve(Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P4",
        ...     "length": 1.0, "EI": 1.0}, "load": {"q": -8.0}, "mesh": {"elements": 2}}))
        >>> round(r.moment(0.25), 12), round(r.moment(0.5), 12)   # -q x (L - x) / 2
        (0.75, 1.0)
        """
        xs = self._points(xs)
        V, M = self._statics.shear_and_moment(np.atleast_1d(xs).ravel())
        return self._shaped(M, xs)

    def shear(self, xs):
        """Shear force V = dM/dx [N] from element equilibrium (``xs`` as for :meth:`deflection`).

        V is linear in each element under a uniform load (exact for the
        Euler-Bernoulli beam at P = 0), and jumps by a point force.  With an
        axial force or the Gao term, the vertical force carried across a
        section is V + P mu w' - (E_alpha/3) w'^3 (docs/model.md, Support
        reactions); at P = 0 in the Euler-Bernoulli model the two agree.

        Examples
        --------
        >>> from gaocvx import Scene, solve
        >>> r = solve(Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P4",
        ...     "length": 1.0, "EI": 1.0}, "load": {"q": -8.0}, "mesh": {"elements": 2}}))
        >>> r.shear([0.0, 0.1, 0.75]).round(12).tolist()   # q (x - L/2)
        [4.0, 3.2, -2.0]
        """
        xs = self._points(xs)
        flat = np.atleast_1d(xs).ravel()
        st = self._statics
        V, _ = st.shear_and_moment(flat)
        if st.pmu or st.ea3:
            s = fem.eval_matrix(self.x, flat, 1) @ self._dofs()
            V = V - st.pmu * s + st.ea3 * s**3
        return self._shaped(V, xs)

    @functools.cached_property
    def support_reactions(self) -> list:
        """The force and moment each support exerts on the beam, from the discrete residual.

        A list of ``{"x": x, "force": R, "moment": M}`` [m, N, N m], one per
        supported end (a cantilever's free end has none).  R is positive up
        (as w), M counter-clockwise (as a positive slope w' turns), i.e. the
        residual of the discrete equations at the fixed degrees of freedom,
        with the Gao factor (1 - nu^2) removed so that they balance the loads
        as given.  A pinned end carries no moment (0).

        Euler-Bernoulli at P = 0: the reactions, the loads and the foundation
        or obstacle forces are in equilibrium exactly.  With an axial force or
        the Gao term the moment balance has two more terms (docs/model.md,
        Support reactions).

        Examples
        --------
        >>> from gaocvx import Scene, solve
        >>> r = solve(Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P3",
        ...     "length": 2.0, "EI": 1.0}, "load": {"points": [[2.0, -3.0]]}}))
        >>> [{k: round(v, 9) for k, v in s.items()} for s in r.support_reactions]
        [{'x': 0.0, 'force': 3.0, 'moment': 6.0}]
        """
        return self._statics.support_reactions(self.scene.beam.supports)

    # ------------------------------------------------------------- output
    def to_dict(self) -> dict:
        """The JSON object of scene-format.md (plus ``message`` and ``residual``)."""
        beam = self.scene.beam
        out = {
            "status": self.status,
            "method": self.method,
            "model": beam.model,
            "supports": beam.supports,
            "elements": int(len(self.x) - 1),
            "nodes": {"x": self.x.tolist(), "w": self.w.tolist(), "slope": self.slope.tolist()},
            "max": self.max,
            "min": self.min,
            "energy": float(self.energy),
            "energy_parts": {k: float(v) for k, v in self.energy_parts.items()},
            "contact": {
                "zones": self.zones,
                "reaction": None if self.reaction is None else self.reaction.tolist(),
                **({} if self.contact_forces is None
                   else {"forces": self.contact_forces.tolist()}),
            },
            "support_reactions": [dict(s) for s in self.support_reactions],  # copies: cached
            "P_bar": float(self.P_bar),
            **({} if self.P_hat is None else {"P_hat": self.P_hat}),
            "time_s": float(self.time_s),
            "iterations": self.nit,
            "solver": self.solver,
            "message": self.message,
            "residual": self.residual,
        }
        out.update({k: v for k, v in self.extra.items() if k != "warm"})
        return out

    def summary(self) -> str:
        """A short human-readable summary."""
        lines = [
            f"status   {self.status} ({self.method}{', ' + self.solver if self.solver else ''}; "
            f"{self.time_s * 1e3:.1f} ms)",
            f"model    {self.scene.beam.model}, supports {self.scene.beam.supports}, "
            f"{len(self.x) - 1} elements",
            f"min w    {self.min['w']:.6g} m at x = {self.min['x']:.6g} m",
            f"max w    {self.max['w']:.6g} m at x = {self.max['x']:.6g} m",
            f"energy   {self.energy:.6g} J",
            f"P_bar_h  {self.P_bar:.6g} N",
        ]
        if self.P_hat is not None:
            lines.append(f"P_hat_h  {self.P_hat:.6g} N (bonded foundation)")
        if self.zones is not None:
            zones = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in self.zones) or "none"
            lines.append(f"contact  {zones}")
        if self.support_reactions:  # force up, moment counter-clockwise, on the beam
            lines.append("supports " + "; ".join(
                f"x = {s['x']:.4g} m: {s['force']:.6g} N, {s['moment']:.6g} N m"
                for s in self.support_reactions))
        glob = self.extra.get("global")
        if glob:  # the global method's certificate (gaocvx.nonconvex)
            how = {"dual bound": "by the dual bound", "at the limit": "in closed form at the "
                   "limit"}.get(glob.get("certificate"), f"{glob['nodes']} nodes")
            lines.append(f"global   {glob['unstable_modes']} unstable mode(s), certified gap "
                         f"{glob['bound_gap']:.3g} J, {how}"
                         + _uniqueness(glob, self.status))
        verdict = self.extra.get("cvm", {}).get("verdict")
        if verdict:  # CVM's status is about its own problem; this is about the beam
            lines.append(f"verdict  {verdict}")
        if not self.success and not verdict:
            lines.append(f"note     {self.message}")
        return "\n".join(lines)


def _uniqueness(glob: dict, status: str) -> str:
    """The summary's word on other minimisers: none where unique; where the answer is
    not certified (``inaccurate``), candidates only (a P4 beam without load at exactly
    P_bar_h, stopped at the node limit, had five points 5.7e-9 m from w = 0, its one
    minimiser, and was said to be "NOT unique")."""
    if glob["unique"]:
        return ""
    n = len(glob.get("alternatives", [])) + 1
    if status != "optimal":
        return f", uniqueness not established ({n} candidates)"
    return f", NOT unique ({n} minimisers)"
