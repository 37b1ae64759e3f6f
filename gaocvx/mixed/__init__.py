"""The well-conditioned form of the discrete energy: deflections, slopes and chord slopes.

With the nodal DOFs (w_i, theta_i) the curvature on an element is a second
difference of deflections, ``(6 - 12t)(w_{i+1} - w_i)/h^2 + ...``: evaluating
the energy or its gradient cancels terms of size N^3 and the stiffness matrix
has condition number ~N^4, so beyond about 2000 elements no solver working in
double precision can certify an answer.

Here every element also carries its chord slope ``D_e = (w_{e+1} - w_e)/h_e``
as a variable, tied to the deflections by the sparse linear constraint
``w_{e+1} - w_e - h_e D_e = 0``.  On element e (local t in [0, 1])::

    w   = w_e + h (3t^2 - 2t^3) D_e + h (t - 2t^2 + t^3) th_e + h (t^3 - t^2) th_{e+1}
    w'  = (6t - 6t^2) D_e + (1 - 4t + 3t^2) th_e + (3t^2 - 2t) th_{e+1}
    w'' = ((6 - 12t) D_e + (6t - 4) th_e + (6t - 2) th_{e+1}) / h

Only first differences remain.  This is the same Hermite space (an exact
re-parametrisation), so the minimiser is the same; what changes is the
round-off: energies and gradients lose ~N eps instead of ~N^3 eps.

Variables ``z`` are ordered per node ``[w_i, th_i, D_i]`` (the last node has
no D); Newton solves the saddle-point (KKT) system of the linking constraint,
which is banded in the ordering ``[w_i, th_i, D_i, lambda_i]``.

Everything that depends only on the mesh and the supports (the quadrature
matrices, the KKT ordering, and linear maps from quadrature weights to the
entries of the banded KKT matrix) is a :class:`MixedStructure`, built once
and shared by every scene on that mesh (a sweep, the repeated solves of a
benchmark).  A Newton step then assembles its KKT matrix with a few sparse
matrix-vector products instead of sparse matrix-matrix products.

One module per part: :mod:`.structure` (what depends only on the mesh, cached),
:mod:`.kkt` (the Hessian kept as quadrature weights, the banded KKT factor) and
:mod:`.form` (:class:`MixedForm`: energy, gradient, Hessian, certificate scales).
"""

from __future__ import annotations

from .form import MixedForm
from .kkt import Hessian, KKTFactor
from .structure import MixedStructure, clear_cache, structure_key, structure_of

__all__ = ["MixedForm", "MixedStructure", "Hessian", "KKTFactor", "structure_of",
           "structure_key", "clear_cache"]
