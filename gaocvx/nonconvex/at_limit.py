"""The flat beam at the limit: ``w = 0`` certified in closed form, without load, at ``P = P_bar_h``.

Without load, obstacle or bonded bed, ``w = 0`` is an exact equilibrium (every
part of the gradient vanishes there), and below ``lambda_1`` the unique
minimiser.  Exactly at the limit it is a quartic minimum: no second-order
certificate proves it, and the branch and bound's points a round-off from it
(5.7e-9 m on a P4 beam) failed their certificates; the answer was `inaccurate`
after the dense programs' node limit (20 s at 6 elements, up to a minute at 16).

The energy bounds itself there.  With ``S(u) = ∫ w'^2`` (the axial term's
form, 5-point Gauss: exact) and ``lambda_1 >= lower`` (the enclosure of
:mod:`gaocvx.limit.enclosure`), the bending energy is at least
``lower S / 2``; the Gao term ``a/12 ∫ w'^4`` is at least ``a S^2 / 12``
(Cauchy-Schwarz on the unit length, with the same quadrature); a foundation's
term is not negative.  So, with ``delta = max(p - lower, 0)``::

    Pi(u) >= -delta S / 2 + a S^2 / 12 >= -3 delta^2 / (4 a),

and every beam of energy at most 0 (every minimiser) has ``S <= 6 delta / a``,
so ``max |w| <= sqrt(6 delta / a)`` (``|w(x)| <= ∫|w'| <= sqrt(S)``).  The
same bound at twice the limit load (``delta = lambda_1``) has its minimum at
``S = 3 lambda_1 / a``, the size of the beam buckled there: against it,
every minimiser's slope norm ``sqrt(S)`` is at most ``sqrt(2 delta /
lambda_1)``.  So is every equilibrium's: the gradient's work on the beam
itself, ``u'Ku - p S + a/3 ∫ w'^4`` plus the foundation's (not negative), is
0 there, so ``a S^2 / 3 <= delta S`` and ``S <= 3 delta / a``; ``w = 0`` is
the only equilibrium to within that (:func:`.stationary.equilibria`).  ``w = 0`` is certified where that is at most the certificate's
STATIONARITY_TOL (``delta`` at most 5e-13 of ``lambda_1``: ``p`` at the
limit to within the enclosure, 2e-14 to 3e-14 wide, and the data's
round-off).

Examples
--------
>>> from gaocvx import Scene, solve
>>> d = {"beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11,
...      "nu": 0.3, "half_thickness": 0.1, "width": 1.0}, "mesh": {"elements": 16}}
>>> P = solve(Scene.from_dict(d)).P_bar      # P_bar_h of the mesh
>>> r = solve(Scene.from_dict({**d, "load": {"axial": P}}), "global")
>>> r.status, float(abs(r.w).max()), r.extra["global"]["certificate"]
('optimal', 0.0, 'at the limit')
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..certificate import answer, certify
from ..mixed import MixedForm
from ..tolerances import STATIONARITY_TOL
from .polish import to_mixed

__all__ = ["flat_at_limit", "distance_bound"]


def distance_bound(dp) -> tuple:
    """``(delta, relative)``: how far ``p`` may lie above ``lambda_1`` (non-dimensional,
    from the enclosure's lower bound) and the bound ``sqrt(2 delta / lambda_1)`` on
    every minimiser's distance from ``w = 0``, relative to the beam buckled at twice
    the limit (the module's notes)."""
    from .. import limit

    enclosure = limit.analysis(dp).enclosure()
    delta = max(dp.p - enclosure.lower, 0.0)
    return delta, math.sqrt(2.0 * delta / enclosure.lower) if enclosure.lower > 0 else math.inf


def flat_at_limit(dp, modes):
    """``w = 0`` as the certified global minimiser of an unloaded beam at the limit, or None.

    Parameters
    ----------
    dp : DiscreteProblem
        Above or at ``P_bar_h`` (``check_convexity=False``).
    modes : Modes
        Its unstable modes.

    Returns
    -------
    tuple or None
        ``(dp, raw, info)`` as :func:`.minimum.solve_global`, where the scene has
        no load, obstacle or bonded bed, has the Gao term, and ``w = 0`` lies
        within STATIONARITY_TOL of every minimiser (the module's notes); else None.
    """
    t0 = time.perf_counter()
    mf = MixedForm(dp)
    if (mf.has_load or dp.contact == "obstacle" or getattr(dp, "bilateral", False)
            or not dp.a > 0):
        return None
    delta, relative = distance_bound(dp)
    if not relative <= STATIONARITY_TOL:
        return None
    z = mf.on_manifold(to_mixed(mf, np.zeros(dp.n)))
    residual = certify(mf, z, None)
    gap = 0.75 * delta * delta / dp.a          # the lower bound's distance below Pi(0) = 0
    raw = answer(mf, z, None, residual,
                 f"global: w = 0, without load at the limit (P above lambda_1 by at most "
                 f"{delta / dp.p:.1g} of it, by its enclosure): every minimiser within "
                 f"{relative:.1g} of the beam buckled at twice the limit, certified gap "
                 f"{gap * dp.E0:.3g} J (closed form)", 0, "closed-form", t0)
    info = {"unstable_modes": int(modes.k), "mode_loads": [float(x) for x in modes.loads],
            "bound_gap": float(gap * dp.E0), "lower_bound": float(-gap * dp.E0),
            "unique": True, "nodes": 0, "certificate": "at the limit",
            "amplitudes": [0.0] * int(modes.k), "alternatives": []}
    return dp, raw, info
