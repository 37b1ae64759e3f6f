"""The result of a solve: nodal values, energies, contact, and evaluators.

Field names follow scipy.optimize where they overlap (``success``,
``status``, ``message``, ``fun``, ``nit``); :meth:`Result.to_dict` gives the
JSON object of scene-format.md.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from . import fem
from .errors import format_value
from .scene import Scene

__all__ = ["Result", "contact_zones"]


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
        return float(self.problem.P_bar_h)

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
        i = int(np.argmax(self.w))
        return {"w": float(self.w[i]), "x": float(self.x[i])}

    @property
    def min(self) -> dict:
        """Smallest nodal deflection and its node (the first on ties)."""
        i = int(np.argmin(self.w))
        return {"w": float(self.w[i]), "x": float(self.x[i])}

    # ------------------------------------------------------------- evaluators
    def _dofs(self) -> np.ndarray:
        d = np.empty(2 * len(self.x))
        d[0::2], d[1::2] = self.w, self.slope
        return d

    def _eval(self, xs, deriv):
        """Values of the ``deriv``-th derivative of the Hermite interpolant at ``xs``.

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
        flat = np.atleast_1d(xs).ravel()
        out = fem.eval_matrix(self.x, flat, deriv) @ self._dofs()
        return out.reshape(xs.shape) if xs.ndim else float(out[0])

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

    def moment(self, xs):
        """Bending moment M = EI w'' [N m] (piecewise linear between nodes; ``xs`` as for
        :meth:`deflection`)."""
        return self.scene.beam.EI_eff * self._eval(xs, 2)

    def shear(self, xs):
        """Shear force V = (EI w'')' [N] (piecewise constant between nodes; ``xs`` as for
        :meth:`deflection`)."""
        return self.scene.beam.EI_eff * self._eval(xs, 3)

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
            "P_bar": float(self.P_bar),
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
        if self.zones is not None:
            zones = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in self.zones) or "none"
            lines.append(f"contact  {zones}")
        verdict = self.extra.get("cvm", {}).get("verdict")
        if verdict:  # CVM's status is about its own problem; this is about the beam
            lines.append(f"verdict  {verdict}")
        if not self.success and not verdict:
            lines.append(f"note     {self.message}")
        return "\n".join(lines)
