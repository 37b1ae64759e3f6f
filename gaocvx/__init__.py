"""gaocvx: the Gao and Euler-Bernoulli beam, bending and contact, solved verifiably.

Public API
----------
Scene, load_scene      validated scene description (TOML or dict)
solve                  solve a scene; returns a Result (``method="global"``: the
                       certified global minimiser, also above P_bar_h)
Result                 nodal values, energies, contact, evaluators
DiscreteProblem        the non-dimensional discrete energy of a scene
SceneError, SolverError
equilibria             every equilibrium (above P_bar_h: one or two unstable
                       modes), sorted by energy: a list of Equilibrium
                       (energy, stable, x, w, slope, status)
equilibrium_path       every equilibrium at each of a list of axial forces: an
                       EquilibriumPath (points, at(P), branches(), rows())
Equilibrium, EquilibriumPath

The last four live in :mod:`gaocvx.nonconvex` (docs/nonconvex.md) and are
imported from it on first use.

Examples
--------
>>> import gaocvx
>>> from gaocvx import equilibria, EquilibriumPath
>>> equilibria is gaocvx.nonconvex.equilibria
True
"""

from .errors import SceneError, SolverError
from .scene import Scene, load_scene
from .discrete import DiscreteProblem
from .result import Result
from .solve import solve

# Names of gaocvx.nonconvex exported here.  That subpackage imports
# scipy.optimize (about 0.2 s, measured with -X importtime: 0.37 s for gaocvx
# without it, 0.6 s with it), which a scene below the limit never needs: it is
# imported on first access (PEP 562), not with gaocvx.
_NONCONVEX = ("equilibria", "equilibrium_path", "Equilibrium", "EquilibriumPath")

__all__ = ["Scene", "load_scene", "solve", "Result", "DiscreteProblem", "SceneError",
           "SolverError", *_NONCONVEX]
__version__ = "0.1.0"


def __getattr__(name: str):
    """The names of ``_NONCONVEX``, imported from gaocvx.nonconvex on first access."""
    if name in _NONCONVEX:
        from . import nonconvex
        value = getattr(nonconvex, name)
        globals()[name] = value   # found directly from now on
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_NONCONVEX))
