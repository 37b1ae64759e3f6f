"""Equilibrium paths: every equilibrium against the axial force.

:func:`equilibrium_path` finds every equilibrium (:func:`.stationary.equilibria`)
at each axial force of a list, from tension through ``P_bar`` up to several
times it, and marks the global minimiser at each.  Neighbouring forces reuse
each other's answers: the amplitudes of the previous step's equilibria are
sampled first (warm starts; the grid then catches branches that appear), and
the mesh's structure is cached by the solvers.  That saves little time: each
force's grid is sampled in full, since that is what finds the branches the
seeds do not lead to (a helper measured 0.85 to 1.07 times the forces solved
alone, docs/nonconvex-campaign.md).

A characteristic deflection is tracked along the path: ``w`` at a point
``x_c`` (default: where the first buckling mode's deflection is largest:
mid-span for P1 and P4, the tip for P3), signed, so that mirror-image branches
stay apart.  It is the finite-element deflection there (the Hermite cubic of
the element, :meth:`.equilibrium.Equilibrium.deflection_at`).

A force that cannot be traced does not end the path: one out of range is
listed in ``errors``, one where a solver failed in ``failures``, and the
other forces are traced all the same.

Examples
--------
>>> from gaocvx import Scene
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e6}, "mesh": {"elements": 8}})
>>> path = equilibrium_path(scene, [0.5e9, 1.5e9])
>>> [len(path.at(P)) for P in path.P]                 # one below P_bar, three above
[1, 3]
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, SolverError
from .equilibrium import global_minima

__all__ = ["EquilibriumPath", "equilibrium_path", "characteristic_point"]

log = logging.getLogger(__name__)


def characteristic_point(scene, elements=None) -> float:
    """Where the first buckling mode's deflection is largest [m] (the path's default x_c)."""
    from ..discrete import DiscreteProblem
    from .modes import unstable_modes

    dp = DiscreteProblem(scene.with_overrides({"load.axial": 0.0}), elements=elements,
                         check_convexity=False)
    if dp.n == 0:
        return 0.5 * dp.L
    probe = unstable_modes(dp, min_k=1)
    w = dp.full(probe.phi[:, 0])[0::2]
    return float(dp.x[int(np.argmax(np.abs(w)))])


@dataclass
class EquilibriumPath:
    """Equilibria along a list of axial forces.

    Attributes
    ----------
    P : list of float
        The axial forces [N].
    points : list of dict
        One per equilibrium: ``P``, ``w_c`` (deflection at ``x_c``), ``max_abs_w``,
        ``energy`` [J], ``stable``, ``global`` (the global minimiser at its P),
        ``amplitude`` (non-dimensional, in this force's deflection scale),
        ``amplitude_m`` (in metres: comparable between forces), ``status``,
        ``complete`` (its force's list proven to miss no equilibrium:
        :attr:`.Equilibrium.complete`).
    x_c : float
        Where ``w_c`` is taken [m].
    errors : dict
        P -> message, for the forces skipped as out of range (bad input, a
        SceneError): three or more unstable modes (:func:`.stationary.equilibria`
        searches one or two), no minimiser, or a mesh too fine above the limit.
    failures : dict
        P -> message, for the forces where a solver failed (a SolverError:
        a fixed-amplitude solve failed at a zero of the reduced gradient, or
        no equilibrium was found).  Such a force has no points; the others
        are traced all the same.
    """

    P: list
    points: list
    x_c: float
    errors: dict = field(default_factory=dict)
    failures: dict = field(default_factory=dict)

    def at(self, P) -> list:
        """The equilibria at force ``P``, sorted by energy."""
        return [p for p in self.points if p["P"] == P]

    def _by_force(self) -> dict:
        """P -> its points, every force of ``P`` in order (one pass over the points)."""
        groups = {P: [] for P in self.P}
        for p in self.points:
            groups.setdefault(p["P"], []).append(p)
        return groups

    def records(self) -> list:
        """Every force's outcome in the order of ``P``: its points (lowest energy first)
        or, for a force skipped or failed, one ``{"P", "status": "error", "error"}``
        (the JSON Lines of ``gaocvx path --json``)."""
        out = []
        for P, points in self._by_force().items():
            why = self.errors.get(P, self.failures.get(P))
            out.extend(points if why is None else
                       [{"P": P, "status": "error", "error": why}])
        return out

    def rows(self) -> list:
        """CSV rows (header first), one per record of :meth:`records`: booleans as
        ``true``/``false`` (as in the JSON), a missing value (a force's error
        row, an amplitude below the limit) as ``None`` (an empty cell)."""
        # (amplitude_m last: it came after the others, and columns keep their places)
        keys = ["P", "w_c", "max_abs_w", "energy", "stable", "global", "amplitude", "status",
                "complete", "error", "amplitude_m"]

        def cell(value):
            return ("true" if value else "false") if isinstance(value, (bool, np.bool_)) \
                else value

        return [keys] + [[cell(r.get(k)) for k in keys] for r in self.records()]

    def branches(self) -> list:
        """Equilibria joined into branches, forces in increasing order: each point
        is linked to an equilibrium of the same stability at the previous force,
        on the same side of w_c = 0 or within a fifth of the largest ``|w_c|``,
        the nearest (in ``w_c``) pairs first.  A flat beam (w_c = 0) continued
        by two beams of its stability on either side of w_c = 0 (a pitchfork:
        mirror images, or, where an obstacle or channel breaks the symmetry,
        the beams that left the flat one at the same buckling load) is linked
        to both.

        Returns lists of points, each a polyline of one stability; a pitchfork's
        second branch starts at the flat beam.
        """
        branches = []
        open_ = []
        # A link across w_c = 0 longer than this is no continuation but another
        # branch (an obstacle's pressed branch ends where a free one begins).
        largest = max((abs(p["w_c"]) for p in self.points), default=0.0)
        reach = 0.2 * largest
        for _, here in sorted(self._by_force().items()):
            here = sorted(here, key=lambda p: p["w_c"])
            # (the nearest pairs first: linked in the order of w_c, an image of a
            # mode-2 pair, w_c 1e-18 at mid-span, took the flat beam's branch
            # from the flat beam -- a trial's path through lambda_2)
            links = sorted((abs(br[-1]["w_c"] - pt["w_c"]), j, i)
                           for j, pt in enumerate(here) for i, br in enumerate(open_)
                           if br[-1]["stable"] == pt["stable"]
                           and (abs(br[-1]["w_c"] - pt["w_c"]) <= reach
                                or br[-1]["w_c"] * pt["w_c"] >= 0))
            linked = {}
            for _, j, i in links:
                if j not in linked and i not in linked.values():
                    linked[j] = i
            parents = [(here[j], open_[i][-1]) for j, i in linked.items()]
            new_open = []
            for j, pt in enumerate(here):
                if j in linked:
                    br = open_[linked[j]]
                    br.append(pt)
                else:
                    br = [pt]
                    branches.append(br)
                new_open.append(br)
            # (a pitchfork has two arms: a flat beam gets one more, the new beam
            # nearest w_c = 0, where the arm leaves it)
            forked = set()
            for br in sorted((b for b in new_open if len(b) == 1), key=lambda b: abs(b[0]["w_c"])):
                br[:0] = _pitchfork(br[0], parents, 1e-9 * largest, forked)
            open_ = new_open
        return branches


def _pitchfork(pt, parents, flat, forked) -> list:
    """``[the flat beam]`` where a beam of ``pt``'s stability on the other side of
    w_c = 0 has left a flat beam's branch (``|w_c| <= flat`` there, not at the
    beam) and that flat beam has no second arm yet (``forked``: ids of those that
    have; this one is added), else ``[]``.

    A flat beam (w_c = 0 to 1e-9 of the largest; so are mode-2 beams at
    mid-span) of an unloaded beam: its energy is even in w, so at a buckling
    load the beams w and -w leave it together.  Linked to one of them only, the
    path drew the stable flat beam below P_bar_h running to one buckled beam
    above it, the other a lone dot (an unloaded P4 beam's path through the
    limit).  Mirror images were asked for once; in a channel the two leave the
    flat beam as images, and one force later one is pressed onto the lower
    surface (-10 mm) while the other is free (+16 mm): it was drawn unconnected
    (a new user's trial).  A flat beam that stays flat (its w_c round-off of
    either sign) keeps its branch and gets no arm.
    """
    if abs(pt["w_c"]) <= flat:
        return []
    for image, prev in parents:
        if image["stable"] == pt["stable"] and abs(prev["w_c"]) <= flat < abs(image["w_c"]) \
                and image["w_c"] * pt["w_c"] < 0 and id(prev) not in forked:
            forked.add(id(prev))
            return [prev]
    return []


def equilibrium_path(scene, P_values, elements: int | None = None, x_c: float | None = None,
                     progress=None) -> EquilibriumPath:
    """Every equilibrium at each axial force of ``P_values`` [N].

    Parameters
    ----------
    scene : Scene or Mapping
        A dict with the structure of a scene file is validated into a Scene.
    P_values : array_like of float
        The axial forces [N] (compression positive), finite and each once
        (a repeated force is refused: ``list(dict.fromkeys(P_values))``
        drops repeats keeping the order); a sequence or 1-d array, or one
        number (a path of one force).
    elements : int, optional
        Overrides ``scene.mesh.elements``; checked as :func:`gaocvx.solve`
        checks it.
    x_c : float, optional
        Where to take the characteristic deflection [m], on the beam
        (``0 <= x_c <= L``).
    progress : callable, optional
        ``progress(done, total)`` after each force.

    Returns
    -------
    EquilibriumPath
        Forces that :func:`.stationary.equilibria` refuses are listed in
        ``errors`` and skipped: three or more unstable modes (one and two are
        searched), no minimiser (Euler-Bernoulli, or a Gao beam with
        ``E_alpha = 0``, at or above ``P_bar_h``; ``P_hat_h`` on a bonded
        foundation), or a mesh too fine for the search above the limit.
        Forces where it raises :class:`~gaocvx.errors.SolverError` are listed
        in ``failures``; the path goes on at the next force either way.

    Raises
    ------
    SceneError
        Before any work, naming the argument (``scene``, ``P_values[i]``,
        ``elements``, ``x_c``) and the offending value; a force given twice
        is refused naming its second place, ``P_values[j]``, and no force at
        all naming ``P_values``.
    """
    from ..scene import check_solve_arguments, number, numbers_of
    from .stationary import equilibria

    scene = check_solve_arguments(scene, "global", elements)
    P_values = numbers_of("P_values", P_values)
    if not P_values:   # (a path of no force: surely not what was meant)
        raise SceneError("P_values", "must hold at least one axial force", [])
    first = {}
    for j, P in enumerate(P_values):
        i = first.setdefault(P, j)
        if i != j:
            # (at(P) and branches() key the points by force: a repeat would merge them)
            raise SceneError(f"P_values[{j}]", f"repeats P_values[{i}]; give each force once "
                             "(list(dict.fromkeys(P_values)) drops repeats)", P)
    if x_c is None:
        x_c = characteristic_point(scene, elements)
    else:
        x_c = number("x_c", x_c, lo=0.0, hi=scene.beam.length)
    points, errors, failures = [], {}, {}
    seeds = np.zeros(0)
    for done, P in enumerate(P_values, start=1):
        try:
            eqs = equilibria(scene.with_overrides({"load.axial": P}), elements, seeds=seeds)
        except SceneError as exc:
            errors[P] = str(exc)
            log.info("path: P = %.4g N skipped: %s", P, exc)
            eqs = []
        except SolverError as exc:
            # One force's failure is that force's: the others are still traced.
            failures[P] = str(exc)
            log.warning("path: P = %.4g N failed: %s", P, exc)
            eqs = []
        # Mirror images are both global minimisers: ties within round-off count.
        for e, best in zip(eqs, global_minima(eqs)):
            points.append({"P": P, "w_c": e.deflection_at(x_c),
                           "max_abs_w": float(np.max(np.abs(e.w))), "energy": e.energy,
                           "stable": e.stable, "global": best,
                           "amplitude": e.amplitudes[0] if e.amplitudes else None,
                           "amplitude_m": e.amplitudes_m[0] if e.amplitudes else None,
                           "status": e.status, "complete": e.complete})
        # Warm start: the next force samples these amplitudes first (a force
        # with no equilibria passes on the last ones found).
        if eqs:
            seeds = np.array([e.amplitudes_m[0] for e in eqs if e.amplitudes])
        if progress:
            progress(done, len(P_values))
    return EquilibriumPath(P_values, points, x_c, errors, failures)
