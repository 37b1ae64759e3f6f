"""The discrete convexity limit P_bar_h, computed and checked in well-conditioned variables.

P_bar_h is the smallest eigenvalue of ``K u = lambda mu G u`` on the free
Hermite DOFs (physics.md).  In the Hermite DOFs (w_i, theta_i) that pencil is
hopeless on fine meshes: K has condition number ~N^4, and a shift-invert
eigen-solver returned 4.826e9 N at 16384 elements, 5.96e12 N at 10^6, for a
limit of 4.672e9 N.  Here the same pencil is written in the slope
``s = w'``, a continuous piecewise quadratic, with the variables of
:mod:`gaocvx.mixed`: nodal slopes ``theta_i`` and chord slopes ``D_e``.  On
element e (local t in [0, 1], length h)::

    s   = theta_e + 6t(1 - t) (D_e - theta_e) + (3t^2 - 2t) (theta_{e+1} - theta_e)
    s'  = ((6 - 12t) (D_e - theta_e) + (6t - 2) (theta_{e+1} - theta_e)) / h

so the curvature is a first difference of O(1) numbers.  With ``L = 1`` and
``EI = 1`` the limit is ``lambda_1 EI / (mu L^2)``, where

    lambda_1 = min ∫ s'^2 / ∫ s^2   over  theta_0 = 0 (P1, P2, P3),
               theta_N = 0 (P1),  ∫ s = sum_e h_e D_e = w_N = 0 (P1, P2, P4).

This is the Hermite pencil exactly (``w = ∫ s``, w_0 = 0 for every support),
not an approximation of it.  The end condition ``w_N = 0`` is the only
non-local constraint.  The deflections ``w_i`` carry it as a chain of local
links ``w_{e+1} - w_e - h_e D_e`` with a penalty.  Minimised over w, the
penalty ``sum_e (rho / h_e) (w_{e+1} - w_e - h_e D_e)^2`` with w_0 = w_N = 0
is exactly ``rho (sum_e h_e D_e)^2``, a rank-one term, while the matrix stays
banded (bandwidth 4 in the order [w_i, theta_i, D_i]).

It is split by concept:

* :mod:`gaocvx.limit.element` -- the reference element, quadrature and
  round-off constants, the continuum's eigenvalues;
* :mod:`gaocvx.limit.pencil` -- :class:`ConvexityLimit`: the pencil, its
  banded factorisations and the check that ``P < P_bar_h``;
* :mod:`gaocvx.limit.enclosure` -- the value of P_bar_h with rigorous bounds
  (:class:`Enclosure`);
* :mod:`gaocvx.limit.bonded` -- a bonded foundation's limit P_hat_h
  (:class:`~gaocvx.limit.bonded.BondedLimit`);
* this module -- the glue to :class:`~gaocvx.discrete.DiscreteProblem`
  (:func:`analysis`, :func:`p_bar_h`, :func:`check`).

>>> import numpy as np
>>> lim = ConvexityLimit(np.linspace(0.0, 1.0, 65), "P1")
>>> enc = lim.enclosure()
>>> f"{enc.value / (4 * np.pi**2) - 1:.2e}"     # above the continuum's 4 pi^2 by O(h^4)
'1.29e-07'
>>> bool(enc.lower <= enc.value <= enc.upper and enc.upper - enc.lower < 1e-12 * enc.value)
True
>>> lim.prove_below(0.999 * enc.value), lim.prove_below(enc.value)
(True, False)
"""

from __future__ import annotations

from ..errors import SceneError, apart
from .element import CONTINUUM, continuum_eigenvalues
from .enclosure import Enclosure
from .pencil import ConvexityLimit

__all__ = ["ConvexityLimit", "Enclosure", "CONTINUUM", "continuum_eigenvalues", "analysis",
           "check", "p_bar_h"]


def analysis(dp) -> ConvexityLimit:
    """The :class:`ConvexityLimit` of a :class:`~gaocvx.discrete.DiscreteProblem` (kept on it)."""
    lim = dp.__dict__.get("_convexity_limit")
    if lim is None:
        lim = dp.__dict__["_convexity_limit"] = ConvexityLimit(dp.xi, dp.scene.beam.supports)
    return lim


def _to_newtons(dp, lam: float) -> float:
    return lam * dp.EI / dp.L**2 / dp.mu


def p_bar_h(dp) -> float:
    """P_bar_h [N] of a problem's mesh and supports."""
    return _to_newtons(dp, analysis(dp).enclosure().value)


def check(dp) -> None:
    """Raise :class:`SceneError` on ``load.axial`` unless P < P_bar_h is proved.

    One banded factorisation when P is clear of the limit by more than its
    round-off margin; otherwise the enclosure of P_bar_h decides.  A P that
    lies inside the enclosure is refused as "not provably below".
    """
    if not dp.P > 0:
        return
    lim = analysis(dp)
    verdict = lim.verdict(dp.p)
    if verdict == "below":
        return
    beam = dp.scene.beam
    enc = lim.enclosure()
    what = "is not below" if verdict == "not below" else \
        f"is not provably below (within the enclosure's {enc.error:.1g} relative error of)"
    P, limit = apart(dp.P, _to_newtons(dp, enc.value))
    raise SceneError(
        "load.axial",
        f"P = {P} N {what} the convexity limit P_bar_h = "
        f"{limit} N for {beam.supports} "
        f"(continuum P_bar = {beam.P_bar():.4g} N)"
        + ("; the global method (method 'global', or 'auto') solves the Gao beam there"
           if dp.needs_gao else ""),
        dp.P)
