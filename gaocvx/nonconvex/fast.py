"""The fast path: node problems through the mixed form's banded Newton machinery (any N).

For fixed amplitudes ``s`` of the unstable modes the reduced function is
``F(s) = min Pi(z)`` over the mixed variables ``z`` with the linking
constraints ``C z = 0`` and the k constraints ``B z = s``
(``B = (G Phi)' T``, ``T`` mapping ``z`` to the Hermite DOFs): on that slice
the energy is strictly convex (the unstable directions are fixed), so damped
Newton converges from anywhere on it.  Each step solves the banded KKT system
of :class:`gaocvx.mixed.MixedForm` (LU, so the Hessian need not be definite
off the slice) bordered by the k rows of ``B`` (a Schur complement of size k).
The envelope theorem gives ``dF/ds = -nu``, the multipliers of ``B z = s``.

A node problem is then the minimum over a box of the convex function
``G(s) = F(s) + sum c_i s_i^2 + chord(s)``; for one mode it is found by Brent's
method on the monotone ``G'``, and ``G(s0) + min_box G'(s0)(s - s0)`` is a
lower bound by convexity.  Obstacles are not handled here (the dense programs
of :mod:`.node` are).

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> from gaocvx.nonconvex.modes import unstable_modes
>>> from gaocvx.nonconvex.node import NodeProgram
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 16}})
>>> dp = DiscreteProblem(scene, check_convexity=False)
>>> m = unstable_modes(dp)
>>> F, dF, u, ok = FastProgram(dp, m).reduced([1.0])
>>> G, dG, _, _ = NodeProgram(dp, m).reduced([1.0])     # the dense program agrees
>>> ok, abs(F - G) < 1e-8 * abs(G), bool(abs(dF[0] - dG[0]) < 1e-6 * abs(dG[0]))
(True, True, True)
"""

from __future__ import annotations

import math

import numpy as np
import scipy.optimize as so
import scipy.sparse as sp

from ..mixed import MixedForm
from .minimum import to_mixed
from .node import NodeSolution

__all__ = ["FastProgram"]


class FastProgram:
    """Node programs of one problem (no obstacle) by banded Newton on slices.

    Parameters
    ----------
    dp : DiscreteProblem
    modes : Modes
    """

    rows = levels = None  # no obstacle

    def __init__(self, dp, modes):
        self.dp, self.modes, self.k = dp, modes, modes.k
        self.mf = mf = MixedForm(dp)
        # T: free mixed z -> free Hermite u (w_i, theta_i); B = (G Phi)' T.
        nn = dp.n_nodes
        rows, cols = [], []
        for i in range(nn):
            rows += [2 * i, 2 * i + 1]
            cols += [3 * i, 3 * i + 1]
        T_full = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(2 * nn, mf.nz))
        self.T = T_full[dp.free][:, mf.free].tocsr()
        self.B = np.asarray((self.T.T @ np.asarray(dp.G @ modes.phi)).T)
        self.solves = 0
        self._z = np.zeros(mf.n)

    def energy(self, u) -> float:
        """The energy of free Hermite DOFs ``u`` in the mixed form (non-dimensional)."""
        return sum(self.mf.energy_parts(to_mixed(self.mf, u)).values())

    def _slice(self, s, z, max_iter=60):
        mf, B = self.mf, self.B
        ok = False
        nu = np.zeros(self.k)
        previous = math.inf
        for it in range(max_iter):
            g = mf.gradient(z)
            H = mf.hessian(z)
            factor = mf.kkt_factor(H)
            r0, _ = factor.solve(-g, -mf.link(z))
            X = np.column_stack([factor.solve(B[i], np.zeros(mf.N))[0] for i in range(self.k)])
            S = B @ X
            nu = np.linalg.solve(S, B @ r0 - (s - B @ z))
            d = r0 - X @ nu
            feasible = np.linalg.norm(B @ z - s) <= 1e-12 * (1 + np.linalg.norm(s)) and \
                np.linalg.norm(mf.link(z)) <= 1e-12 * (1 + np.linalg.norm(z))
            dec = float(d @ (H @ d))
            if not feasible:
                z = z + d  # the first step lands on the slice (linear constraints)
                continue
            # damped Newton on the slice: the energy is convex there
            t, e0 = 1.0, sum(mf.energy_parts(z).values())
            slope = float(g @ d)
            while t > 1e-10:
                e1 = sum(mf.energy_parts(z + t * d).values())
                if e1 <= e0 + 1e-4 * t * slope or abs(dec) < 1e-20 * max(abs(e0), 1.0):
                    break
                t *= 0.5
            z = z + t * d
            # Converged at round-off: a decrement (squared energy-norm step) below
            # 1e-16 of the energy that no longer falls quadratically, or a step
            # below round-off (the decrement's round-off floor grows with N).
            small = abs(dec) <= 1e-16 * max(abs(e0), 1e-300)
            if (small and (abs(dec) > 0.01 * previous or abs(dec) <= 1e-26 * abs(e0))) or \
                    np.linalg.norm(t * d) <= 1e-15 * max(np.linalg.norm(z), 1e-300):
                ok = True
                break
            previous = abs(dec)
        return z, nu, ok

    def reduced(self, s0):
        """``F(s0)``, its gradient ``-nu``, the free Hermite DOFs and convergence."""
        s0 = np.asarray(s0, float)
        self.solves += 1
        z, nu, ok = self._slice(s0, self._z.copy())
        if not np.all(np.isfinite(z)):
            z, nu, ok = self._slice(s0, np.zeros(self.mf.n))
        self._z = z
        F = sum(self.mf.energy_parts(z).values())
        return float(F), -nu, self.mf.to_hermite(z), ok

    def obstacle_multipliers(self):
        return None

    def solve_box(self, lo, hi) -> NodeSolution:
        """Minimise ``G(s) = F(s) + c s^2 + chord`` on ``[lo, hi]`` (one mode); bound by convexity."""
        if self.k != 1:
            raise ValueError("the fast path handles one unstable mode")
        c = float(self.modes.c[0])
        a, b = float(lo[0]), float(hi[0])
        slope, offset = -c * (a + b), c * a * b

        def G(s):
            F, dF, u, ok = self.reduced([s])
            return F + c * s * s + slope * s + offset, float(dF[0]) + 2 * c * s + slope, u, ok

        ga, gb = G(a), G(b)
        if ga[1] >= 0:
            s0, best = a, ga
        elif gb[1] <= 0:
            s0, best = b, gb
        else:
            s0 = so.brentq(lambda s: G(s)[1], a, b, xtol=1e-14 * max(abs(a), abs(b), 1.0))
            best = G(s0)
        value, d, u, ok = best
        # convexity: G(s) >= G(s0) + G'(s0)(s - s0) on the box
        lower = value + min(d * (a - s0), d * (b - s0), 0.0)
        lower -= 1e-13 * max(abs(value), 1.0)
        return NodeSolution(lower, value, np.array([s0]), u, None, ok, "optimal" if ok
                            else "inaccurate")
