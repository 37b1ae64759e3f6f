"""The result object of the equilibrium search (:func:`.stationary.equilibria`).

One :class:`Equilibrium` per stationary point of the energy: its energy,
stability, amplitudes, nodal deflection and slope, and the accuracy of its
zero; used by :mod:`.stationary`, :mod:`.stationary2` and :mod:`.path`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from ..result import extremum

__all__ = ["Equilibrium", "MERGE", "TIE", "same_point", "global_minima", "check_has_minimum",
           "check_mountain_pass"]

log = logging.getLogger(__name__)

#: The searches' merging distance, as a fraction of the amplitude box's size ``S``:
#: zeros closer than this are taken as one equilibrium. Zeros are polished to far
#: below it; two equilibria closer than it would be merged (the closest pair met,
#: a minimum on a kink of F and its saddle, lie 1.3e-6 S apart).
MERGE = 1e-6


#: Energies closer than this fraction of the list's energy scale are one value to
#: round-off (mirror images are both global minima).
TIE = 1e-9


def global_minima(eqs) -> list:
    """Which of the equilibria ``eqs`` are global minima: an energy within TIE of the
    lowest, relative to the largest ``|energy|`` or :attr:`Equilibrium.energy_scale`.

    Mirror images have one energy, but their computed energies differ by round-off,
    which is relative to the energy's parts, not to the total: just above the
    limit the total is far smaller (a P4 beam without load at 1.000001 P_bar_h,
    12 elements: -1.665e-5 J, the images 3.1e-14 J apart, 1.9e-9 of the total).

    An ``optimal`` unstable equilibrium is not one (a global minimiser is a
    local one): within about 1e-12 of P_bar_h without load the flat beam,
    unstable, lies within TIE of the buckled pair and was marked beside them on
    a path.  An ``inaccurate`` entry may be one whatever its label (a campaign's
    global minimiser was listed unstable and ``inaccurate``), and where no entry
    is a candidate all are.

    >>> from types import SimpleNamespace as E
    >>> global_minima([E(energy=-1.0, energy_scale=1e6, stable=True),
    ...                E(energy=-1.0 + 1e-4, energy_scale=1e6, stable=True),
    ...                E(energy=-1.0 + 2e-4, energy_scale=1e6, stable=False),
    ...                E(energy=0.0, energy_scale=0.0, stable=True)])
    [True, True, False, False]
    """
    if not eqs:
        return []
    candidate = [bool(e.stable) or getattr(e, "status", "optimal") != "optimal" for e in eqs]
    if not any(candidate):
        candidate = [True] * len(eqs)
    top = min(e.energy for e, c in zip(eqs, candidate) if c) + _tie(eqs)
    return [c and e.energy <= top for e, c in zip(eqs, candidate)]


def _tie(eqs) -> float:
    """TIE times the list's energy scale: the largest ``|energy|`` or
    :attr:`Equilibrium.energy_scale`."""
    return TIE * max(max(abs(e.energy), _finite(getattr(e, "energy_scale", 0.0))) for e in eqs)


def check_has_minimum(eqs) -> None:
    """Without a stable equilibrium in ``eqs``, or with an ``optimal`` unstable one
    lower than every stable one (beyond TIE), every entry becomes ``inaccurate``
    (in place).

    The energy is coercive (a minimiser exists: the thesis's theorem 1.3), and a
    global minimiser is a stable equilibrium, as low as any: where none is
    listed, or an unstable one lies below it, one is missing or a stability is
    wrong, and no entry's ``optimal`` can stand for the list.  (At P = P_bar_h
    exactly, without load, a P4 beam's flat w = 0, a quartic minimum, was
    listed alone, unstable and `optimal`: the probes saw round-off.)
    """
    stable = [e.energy for e in eqs if e.stable]
    if not stable:
        _all_inaccurate(eqs, f"none of the {len(eqs)} equilibria found is stable, but a "
                             "global minimiser exists and is one")
        return
    below = min(stable) - _tie(eqs)
    if any(not e.stable and e.status == "optimal" and e.energy < below for e in eqs):
        _all_inaccurate(eqs, "an unstable equilibrium lies below every stable one found, but "
                             "a global minimiser is stable")


def check_mountain_pass(eqs) -> None:
    """With two or more stable ``optimal`` equilibria in ``eqs`` and no unstable one,
    every entry becomes ``inaccurate`` (in place).

    Between two strict local minima of the energy, which is continuous and
    coercive on a connected admissible set, lies an equilibrium of mountain-pass
    type, which is not a local minimum (the mountain-pass theorem): where two
    minima are listed and nothing unstable, one is missing or a stability is
    wrong, as :func:`check_has_minimum` says of a list without a minimum.  (A
    helper's campaign, seed 9501: P1 pressed at gap 0, two modes, 9 elements,
    listed the buckled beam and the flat one, both stable and `optimal`; the
    saddle between them, 7.2e-6 m high, 0.76 J, was missed: its reduced gradient
    lies below the slices' accuracy, relative to its own energy, 2e-9 of the
    scene's.)  Only ``optimal`` minima count (one that is not may be no
    equilibrium at all).  A stable label means that nothing nearby was found
    lower, so two points of one flat valley would also trip the rule: it errs
    on the safe side.  Unstable equilibria at a kink of F or an edge of the
    admissible amplitudes are not searched (:mod:`.stationary2`), so a list
    whose saddle lies there is ``inaccurate`` too.

    With one unstable mode the rule is sharper: along the mode's amplitude s,
    between two ``optimal`` stable entries an unstable one must lie.  The
    reduced function F(s) (the energy's least value at amplitude s, one beam
    each: the rest of the energy is strictly convex) is continuous, and F + c s^2
    convex, so F has no concave kink: its maximum between two minima is a zero
    of F', an equilibrium and not a minimum.  A list whose only saddle lies
    elsewhere (a near-flat one added, :mod:`.near_flat`) no longer passes.

    >>> from types import SimpleNamespace as E
    >>> eqs = [E(amplitudes=[s], stable=st, status="optimal")
    ...        for s, st in [(-1.0, True), (0.0, False), (1.0, True), (2.0, True)]]
    >>> check_mountain_pass(eqs); [e.status for e in eqs]
    ['inaccurate', 'inaccurate', 'inaccurate', 'inaccurate']
    """
    if eqs and all(len(getattr(e, "amplitudes", ())) == 1 for e in eqs):
        last = None      # (the last stable optimal entry since an unstable one)
        for e in sorted(eqs, key=lambda e: float(e.amplitudes[0])):
            if not e.stable:
                last = None
            elif e.status == "optimal":
                if last is not None:
                    _all_inaccurate(eqs, "two stable equilibria with no unstable one between "
                                         "them along the mode, but an unstable equilibrium "
                                         "lies between two minima (mountain pass)")
                    return
                last = e
        return
    if sum(bool(e.stable) and e.status == "optimal" for e in eqs) < 2 \
            or any(not e.stable for e in eqs):
        return
    _all_inaccurate(eqs, f"{len(eqs)} stable equilibria and no unstable one, but an unstable "
                         "equilibrium lies between two minima (mountain pass)")


def _all_inaccurate(eqs, why: str) -> None:
    """Every entry of a list that is wrong somewhere becomes ``inaccurate``, with a
    warning that says ``why``."""
    # A list proven complete misses nothing farther than the merging distance from
    # its entries (1e-6 S, 2e-6 S with two modes): `complete` true beside "misses it"
    # read as a contradiction (a campaign: P1 on a bed at gap 0, a flat minimum 1e-42
    # m deep and the zero beside it)
    missing = ("one within the merging distance of a listed one is missing"
               if eqs and all(getattr(e, "complete", None) is True for e in eqs)
               else "the list misses it")
    log.warning("equilibria: %s: %s or a stability is wrong; every entry is reported "
                "inaccurate", why, missing)
    for e in eqs:
        e.status = "inaccurate"


def _finite(x) -> float:
    return float(x) if math.isfinite(x) else 0.0


def same_point(a, b, S: float) -> bool:
    """Whether amplitudes ``a`` and ``b`` are one equilibrium (``|a - b| <= MERGE S``)."""
    return float(np.linalg.norm(np.asarray(a, float) - np.asarray(b, float))) <= MERGE * S


@dataclass
class Equilibrium:
    """One equilibrium of the discrete beam.

    Attributes
    ----------
    energy : float
        Total potential energy [J].
    stable : bool
        A local minimum of the energy (``F'' > 0``).
    amplitudes : list of float
        Its unstable modes' amplitudes ``s`` (non-dimensional).
    x, w, slope : ndarray
        Nodes [m], deflection [m], slope.
    residual : float
        ``|F'(s)| |s|`` relative to the energy scale (0 for the convex case);
        at a kink of ``F`` or an end of the admissible amplitudes (an obstacle
        holding the beam), ``|F'|`` times the width of the bracket that holds
        the equilibrium; for the certified global minimiser listed from the
        global method (with an obstacle), and for an equilibrium polished on
        the whole beam, its certificate's stationarity; for one found near
        w = 0 on a bed at gap 0 (:mod:`.near_flat`), its last Newton step over
        its largest DOF (at least the zero floor).
    status : str
        "optimal" when the fixed-amplitude solve and the zero are accurate (also
        in the beam's own scale: a Newton step on F', with two modes on ∇F,
        moves its deflection by at most 1e-6 of its largest |w|,
        :mod:`.zero_step`), else "inaccurate".
    P : float
        The axial force [N].
    curvature : float
        The least second derivative of the reduced function ``F`` at the
        equilibrium [program units]: ``F''`` with one mode, with two the least
        Hessian eigenvalue or one-sided directional curvature (on a kink of F
        through a zero the least one-sided one); NaN at an edge of the
        admissible amplitudes, where the certified global minimiser's
        label replaced the probes', or for an equilibrium polished on the
        whole beam (its label from the second-order conditions).
    W : float
        The deflection scale [m] of the amplitudes (see :attr:`amplitudes_m`).
    energy_scale : float
        The sum of the magnitudes of its energy's parts [J] (bending, Gao,
        axial, load, contact): the scale of the energy's round-off (NaN where
        not computed).
    whole_beam : bool
        Polished and certified on the whole beam, in its own scale
        (:mod:`.whole_beam`), not through a slice of the reduced function.
    complete : bool or None
        Of the list it belongs to: True where it is proven to miss no
        equilibrium (one unstable mode: every zero of the reduced gradient
        within ``stationary1.RHO`` times the amplitude bound S of a listed one's
        amplitude, by :mod:`.completeness`; two: within twice that, by
        :mod:`.completeness2`, with an obstacle or channel over the admissible
        amplitudes' polygon; below the limit the one equilibrium; without load
        at the limit w = 0 alone, by :mod:`.at_limit`), False where
        that proof failed, None where none is attempted (two unstable modes with
        an obstacle or channel whose polygon could not be bounded: a sampling).
    """

    energy: float
    stable: bool
    amplitudes: list
    x: np.ndarray
    w: np.ndarray
    slope: np.ndarray
    residual: float
    status: str
    P: float
    curvature: float = field(default=math.nan)
    W: float = field(default=math.nan)
    energy_scale: float = field(default=math.nan)
    whole_beam: bool = False
    complete: bool | None = None

    @property
    def amplitudes_m(self) -> list:
        """The amplitudes in metres (``s W``): comparable between axial forces, and
        with ``solve``'s ``global.amplitudes_m`` (the same name as in JSON)."""
        return [a * self.W for a in self.amplitudes]

    # (its first name, kept for code written against it)
    amplitude_m = amplitudes_m

    @property
    def min(self) -> dict:
        return extremum(self.x, self.w, largest=False)

    @property
    def max(self) -> dict:
        return extremum(self.x, self.w, largest=True)

    def deflection_at(self, x):
        """Deflection at ``x`` [m]: the finite-element deflection, the Hermite cubic
        through each element's nodal values and slopes (:func:`gaocvx.fem.eval_matrix`,
        as ``Result.deflection`` and the pictures).

        Parameters
        ----------
        x : float or array_like of float
            Points of the beam [m] (``x[0] <= x <= x[-1]``).

        Returns
        -------
        float or ndarray
            A float for a scalar ``x``, else an array of its shape.

        Raises
        ------
        SceneError
            For a point off the beam (the cubic would extrapolate).
        """
        from ..fem import eval_matrix

        points = np.asarray(x, float)
        ends = (float(self.x[0]), float(self.x[-1]))
        slack = 1e-12 * (ends[1] - ends[0])
        off = ~((points >= ends[0] - slack) & (points <= ends[1] + slack))
        if np.any(off):
            raise SceneError("x", f"off the beam [{ends[0]:g}, {ends[1]:g}] m",
                             float(points[off].ravel()[0]))
        points = np.clip(points, *ends)
        dofs = np.empty(2 * len(self.x))
        dofs[0::2], dofs[1::2] = self.w, self.slope
        values = eval_matrix(self.x, points.ravel()) @ dofs
        return float(values[0]) if points.ndim == 0 else values.reshape(points.shape)

    def to_dict(self) -> dict:
        """One JSON object: energy, stability, extrema, amplitudes (and in metres),
        nodal values."""
        return {"energy": self.energy, "stability": "stable" if self.stable else "unstable",
                "P": self.P, "min": self.min, "max": self.max, "amplitudes": self.amplitudes,
                "amplitudes_m": self.amplitudes_m, "status": self.status,
                "residual": self.residual, "complete": self.complete,
                "nodes": {"x": self.x.tolist(), "w": self.w.tolist(),
                          "slope": self.slope.tolist()}}
