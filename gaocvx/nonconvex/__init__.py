"""Beyond the convexity limit: certified global minimisers and all equilibria.

Above ``P_bar_h`` the discrete energy is convex except along the k unstable
buckling modes (docs/nonconvex.md):

``modes``      the k unstable modes of (K, mu G), G-normalised
``bounds``     the box of mode amplitudes containing every minimiser; refusal
               of energies unbounded below
``dual``       a second certificate: the Gao term's tangents (canonical dual
               bound), tried before the branch and bound
``node``       the convex node programs (dense CVXPY + Clarabel, DPP)
``bnb``        branch and bound with a certified gap
``minimum``    the global minimiser, certified: in which units a search runs,
               and again (``search``: one search and its verdict;
               ``polish``: the answer polished, its images)
``api``        ``solve(scene, "global")``'s results
``stationary`` every equilibrium for one unstable mode (zeros of F'(s));
               ``stationary2`` for two, ``slices`` F(s) with an obstacle
``path``       equilibrium paths against the axial force
"""

from .api import above_limit, solve_global_result
from .path import EquilibriumPath, equilibrium_path
from .equilibrium import Equilibrium
from .stationary import equilibria
from .modes import unstable_modes

__all__ = ["above_limit", "solve_global_result", "unstable_modes", "Equilibrium", "equilibria",
           "EquilibriumPath", "equilibrium_path"]
