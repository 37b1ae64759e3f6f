"""The control variational method (CVM) of Sofonea, Tiba, Machalová and Netuka.

The nonlinear terms of the beam are hidden in a control ``u``; the state
solves a *linear* problem of order 4 (T1) or 2 (T2, T3), and the transformed
cost ``J`` is minimised over the box ``|u| <= C``.  Everything is written on
the non-dimensional arrays of :class:`~gaocvx.discrete.DiscreteProblem`.

Transforms (cvm.md):

* **T1** (any support): ``K w = f + B u`` with Hermite cubics,
  ``J1 = 1/2 (B u)'(w - w0) + N(w)``, adjoint ``K p = 1/2 B u + grad N(w)``,
  gradient ``B'(p + 1/2 (w - w0))``.  For P3 with the piecewise-linear control
  the free-end condition is nonlinear; the thesis's scalar end control ``r``
  (1.114) is appended to ``u`` (as the point force ``-r`` at x = L) and
  minimised jointly, which is equivalent to its fixed-point update.
* **T2** (P3): ``z = w'`` solves ``e(z, phi) = (G + u, phi)`` with
  ``G(x) = ∫_x^L f`` (the load's shear).  z is discretised with *continuous
  quadratic* elements, so that ``w = ∫_0^x z`` is exactly a Hermite cubic of
  the same mesh (with linear elements, as in the thesis, the reachable
  deflections are C1 piecewise quadratics only, and the full control could not
  reproduce the Hermite minimiser).  ``J2 = 1/2 (u, z - z0) + N(w)``,
  adjoint ``E p = 1/2 (u, .) + T' grad N(w)``.
* **T3** (P4): the moment ``m = Pi G + u`` (``G`` the load's moment,
  ``-G'' = f``; ``Pi`` the L2 projection onto discontinuous linears, which
  contains the controls) gives ``w'' = -m`` integrated exactly, again a
  Hermite cubic.  ``J3 = 1/2 ∫ u^2 + N(w)``; the cross term ``∫ (Pi G - G) u``
  vanishes by the projection, so ``J3`` equals the energy plus a constant.

Here ``N = Pi_N + Pi_P [+ Pi_F]`` are the Gao, axial and foundation energies.
In each case ``J(u) = Pi(w(u)) + const`` holds exactly in the discrete
setting, which the tests check, together with the adjoint gradient against
finite differences.

Controls: ``"P1"``, the thesis's continuous piecewise-linear control on the
mesh (for T3 vanishing at both ends, U_ad^0); ``"full"``, the whole discrete
load space of the state (every discrete state is reachable, so the CVM
optimum is the convex minimiser: the consistency check).

Minimisers (:mod:`gaocvx.cvm.minimizers`): ``"conditional-gradient"`` (the
thesis's) and ``"projected-newton"`` (Bertsekas's projected Newton method,
matrix-free: CG on the exact reduced Hessian ``S' H S``, preconditioned by its
bending part).  The accurate linear algebra both rely on is in
:mod:`gaocvx.cvm.algebra`.

One module per part: :mod:`.transforms` (T1, T2, T3 and their loads),
:mod:`.spaces` (the discrete control and state spaces' matrices),
:mod:`.algebra` (the accurate linear algebra), :mod:`.minimizers` and
:mod:`.driver` (:func:`solve_cvm`).
"""

from __future__ import annotations

from .driver import solve_cvm
from ..scene import CONTROLS, MINIMIZERS, TRANSFORMS
from .transforms import ALLOWED, AUTO, make_transform, moment_load, shear_load

__all__ = ["make_transform", "solve_cvm", "shear_load", "moment_load", "TRANSFORMS", "CONTROLS",
           "MINIMIZERS", "AUTO", "ALLOWED"]
