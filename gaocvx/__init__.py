"""gaocvx: the Gao and Euler-Bernoulli beam, bending and contact, solved verifiably.

Public API
----------
Scene, load_scene      validated scene description (TOML or dict)
solve                  solve a scene; returns a Result
Result                 nodal values, energies, contact, evaluators
DiscreteProblem        the non-dimensional discrete energy of a scene
SceneError, SolverError
"""

from .errors import SceneError, SolverError
from .scene import Scene, load_scene
from .discrete import DiscreteProblem
from .result import Result
from .solve import solve

__all__ = ["Scene", "load_scene", "solve", "Result", "DiscreteProblem", "SceneError",
           "SolverError"]
__version__ = "0.1.0"
