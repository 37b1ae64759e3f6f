"""The flat beam at the limit: ``w = 0`` certified in closed form, without load, at ``P = P_bar_h``.

Without load or bonded bed, ``w = 0`` is an exact equilibrium (every part of
the gradient vanishes there; an obstacle or channel, its gaps at least 0,
admits it and needs no force to hold it), and below ``lambda_1`` the unique
minimiser.  Exactly at the limit it is a quartic minimum: no second-order
certificate proves it, and the branch and bound's points a round-off from it
(5.7e-9 m on a P4 beam) failed their certificates; the answer was `inaccurate`
after the dense programs' node limit (20 s at 6 elements, up to a minute at 16).

The energy bounds itself there.  With ``S(u) = ∫ w'^2`` (the axial term's
form, 5-point Gauss: exact) and ``lambda_1 >= lower`` (the enclosure of
:mod:`gaocvx.limit.enclosure`), the bending energy is at least
``lower S / 2``; the Gao term ``a/12 ∫ w'^4`` is at least ``a S^2 / 12``
(Cauchy-Schwarz on the unit length, with the same quadrature); a foundation's
term is not negative.  So, with ``delta = max(p - lower, 0)``, on every beam
(an obstacle's admissible ones among them)::

    Pi(u) >= -delta S / 2 + a S^2 / 12 >= -3 delta^2 / (4 a),

and every beam of energy at most 0 (every minimiser) has ``S <= 6 delta / a``,
so ``max |w| <= sqrt(6 delta / a)`` (``|w(x)| <= ∫|w'| <= sqrt(S)``, w = 0 at
x = 0 for every support).  So does every equilibrium, more so: the gradient's
work on the beam itself, ``u'Ku - p S + a/3 ∫ w'^4`` plus the foundation's
(not negative), is 0 there (with an obstacle or channel at most 0: it is
``lam' g - mu' g_above`` for the forces ``lam, mu >= 0`` below and above, and
``g <= 0 <= g_above``), so ``a S^2 / 3 <= delta S`` and ``S <= 3 delta /
a``; ``w = 0`` is the only equilibrium to within that
(:func:`.stationary.equilibria`).

``w = 0`` is certified where ``delta`` is at most AT_LIMIT of ``lambda_1`` (a
few times the enclosure's width, 2e-14 to 3e-14, and the data's round-off:
the window within which no computation in double precision tells ``p`` from
``lambda_1``) and ``sqrt(6 delta / a)`` at most REACH of the length (a weak
Gao term leaves the buckled beam astronomically large).  Every minimiser then
lies within ``sqrt(2 delta / lambda_1)`` (4.5e-7 at most) of ``w = 0``,
measured as ``sqrt(S)`` against ``sqrt(3 lambda_1 / a)``, the minimum of the
same bound at twice the limit load (the beam buckled there has a smaller
``S``, by ``∫ phi'^4 / (∫ phi'^2)^2``, 1.5 for a sine); its energy within
``3 delta^2 / (4 a)``.  Beyond the window the branch and bound runs, as for
any ``P``.

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

from ..certificate import answer, certify, passes
from ..mixed import MixedForm
from .polish import to_mixed

__all__ = ["flat_at_limit", "distance_bound", "AT_LIMIT", "REACH"]

# How far p may lie above the enclosure's lower bound of lambda_1, relative, for
# w = 0 to be the answer: a few times the enclosure's width (2e-14 to 3e-14)
# with the data's round-off (certificate.DATA_ROUNDOFF, 9e-16).
AT_LIMIT = 1e-13
# And every minimiser within this fraction of the length of w = 0 (sqrt(6 delta / a) W):
# a weak Gao term (a review's E_alpha = 1e-300) leaves the buckled beam, and the
# window's minimisers with it, astronomically large, a gap of 4.7e289 J.
REACH = 1e-6


def distance_bound(dp) -> tuple:
    """``(delta, relative)``: how far ``p`` may lie above ``lambda_1`` (non-dimensional,
    from the enclosure's lower bound) and the bound ``sqrt(2 delta / lambda_1)`` on
    every minimiser's distance from ``w = 0``, against the beam buckled at twice the
    limit (the module's notes)."""
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
        no load or bonded bed, has the Gao term, and ``p`` lies within
        AT_LIMIT of ``lambda_1`` (the module's notes); else None.
    """
    t0 = time.perf_counter()
    obstacle = dp.contact == "obstacle"
    mf = MixedForm.on_obstacle(dp) if obstacle else MixedForm(dp)
    if mf.has_load or getattr(dp, "bilateral", False) or not dp.a > 0:
        return None
    delta, relative = distance_bound(dp)
    reach = math.sqrt(6.0 * delta / dp.a) * dp.W     # [m]: every minimiser's max |w|
    if not (delta <= AT_LIMIT * dp.p and reach <= REACH * dp.L):
        return None
    z = mf.on_manifold(to_mixed(mf, np.zeros(dp.n)))
    lam = mf.no_contact_forces()      # (an obstacle or channel holds w = 0 with none)
    residual = certify(mf, z, lam)
    if not passes(residual):          # (w = 0 inadmissible: no gap below 0 gets here)
        return None
    gap = 0.75 * delta * delta / dp.a          # the lower bound's distance below Pi(0) = 0
    raw = answer(mf, z, lam, residual,
                 f"global: w = 0, without load at the limit (P above lambda_1 by at most "
                 f"{delta / dp.p:.1g} of it, by its enclosure): every minimiser within "
                 f"{relative:.1g} of it, against the beam buckled at twice the limit, and "
                 f"within {reach:.2g} m; certified gap {gap * dp.E0:.3g} J (closed form)",
                 0, "closed-form", t0)
    info = {"unstable_modes": int(modes.k), "mode_loads": [float(x) for x in modes.loads],
            "bound_gap": float(gap * dp.E0), "lower_bound": float(-gap * dp.E0),
            "unique": True, "nodes": 0, "certificate": "at the limit",
            "amplitudes": [0.0] * int(modes.k), "alternatives": []}
    return dp, raw, info
