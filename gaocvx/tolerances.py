"""What "optimal" means: the tolerances of every certificate in gaocvx.

An answer is ``optimal`` only when its optimality measures, each relative to
the answer's own size, are within these tolerances, whichever method produced
it (:mod:`gaocvx.certificate` for the ground truth's solvers,
:meth:`gaocvx.discrete.DiscreteProblem.residual` for answers given in Hermite
DOFs, :mod:`gaocvx.nonconvex.certificate` above the convexity limit).

Examples
--------
>>> import numpy as np
>>> complementarity(np.array([1.0, 2.0]), np.array([0.0, 1e-12]), scale=1.0, size=1.0)
0.0
"""

from __future__ import annotations

import numpy as np

__all__ = ["STATIONARITY_TOL", "FEASIBILITY_TOL", "COMPLEMENTARITY_TOL", "TOUCH_TOL",
           "ZERO_ANSWER", "OBSTACLE_CONTACT_TOL", "complementarity"]

# A solve is "optimal" only when its relative energy-norm residual (see
# DiscreteProblem.residual) is below this, whichever method produced it ...
STATIONARITY_TOL = 1e-6
# ... and, for an obstacle, feasibility and dual sign below this ...
FEASIBILITY_TOL = 1e-7
# ... and complementarity below this: it is an energy, whose square root bounds the
# error in the energy norm, so it must be below the square of STATIONARITY_TOL.
COMPLEMENTARITY_TOL = STATIONARITY_TOL**2
# In complementarity, a point closer to the obstacle than this (relative to the
# answer's own size, its largest |w|) is touching it: a beam lying flat on the
# obstacle sits at gaps of +-1e-11 of that from round-off alone, which would
# otherwise dominate the bound.
TOUCH_TOL = 1e-9
# An answer smaller than this fraction of the unsupported linear answer is measured
# against this floor instead of itself (only a beam pressed onto an obstacle has
# one): the forces acting (load and reaction) are those of the unsupported answer,
# and their round-off alone is ~1e-15 of it, so relative measures of a smaller
# answer would compare round-off with round-off.  Below the floor an answer is
# thus certified to an absolute fraction TOL * ZERO_ANSWER of the unsupported
# one (measured: at 1e-8 the method of multipliers no longer certifies a flexible
# beam lying flat on a gap-0 obstacle).
ZERO_ANSWER = 1e-6
# "In contact" with a rigid obstacle: a gap within this fraction of the answer's size.
OBSTACLE_CONTACT_TOL = 1e-6


def complementarity(lam, gap, scale, size) -> float:
    """Relative duality gap sum(lam * gap) / scale^2; gaps below TOUCH_TOL * size count as contact.

    ``scale`` is the answer's energy norm and ``size`` its largest deflection.
    The value bounds the answer's relative energy excess (and its square root
    the relative error in the energy norm).
    """
    gap = np.where(gap > TOUCH_TOL * size, gap, 0.0)
    return float(abs(lam @ gap) / scale**2)
