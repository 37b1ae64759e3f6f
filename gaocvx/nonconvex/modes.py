"""The unstable buckling modes of a discrete problem at its axial force.

Above the convexity limit the discrete energy is convex except along the k
generalised eigenvectors of ``(K, G)`` (non-dimensional; the physical pencil
is ``(K, mu G)``) whose eigenvalue lies below the axial force ``p``
(nonconvex.md).  This module computes them, G-normalised
(``phi_i' G phi_j = delta_ij``), together with the first stable eigenvalue
``lambda_{k+1}``, which sets the conditioning of the node programs.

A mode whose eigenvalue lies within a relative :data:`MARGIN` of ``p`` counts
as unstable: the split ``u = Phi s + v`` then keeps the complement strictly
convex even when round-off puts the eigenvalue a hair above ``p``.

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 16}})
>>> m = unstable_modes(DiscreteProblem(scene, check_convexity=False))
>>> m.k, round(float(m.loads[0]) / 1.168e9, 3)   # one mode, at P_bar_h ~ P_bar
(1, 1.0)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

__all__ = ["Modes", "unstable_modes", "MARGIN", "MAX_DENSE_DOFS"]

# A mode with lambda_i <= p (1 + MARGIN) is counted as unstable (nonconvex.md).
MARGIN = 1e-8
# The dense generalised eigen-solve is exact to round-off (about N^4 eps relative
# to lambda_1, 3e-9 at 64 elements) and cheap up to this many free DOFs.
MAX_DENSE_DOFS = 1200


@dataclass(frozen=True)
class Modes:
    """The unstable modes of a problem at its axial force.

    Attributes
    ----------
    k : int
        Number of unstable modes (0: the energy is convex).
    lam : ndarray
        Their non-dimensional eigenvalues ``lambda_i`` (units of ``p``).
    phi : ndarray
        ``(n, k)`` G-normalised eigenvectors on the free Hermite DOFs.
    lam_next : float
        The first stable eigenvalue ``lambda_{k+1}`` (inf when there is none).
    p : float
        The non-dimensional axial force.
    loads : ndarray
        The mode loads ``lambda_i EI / (mu L^2)`` [N].
    """

    k: int
    lam: np.ndarray
    phi: np.ndarray
    lam_next: float
    p: float
    loads: np.ndarray

    @property
    def c(self) -> np.ndarray:
        """The concave coefficients ``c_i = (p - lambda_i) / 2 >= 0`` of ``-sum c_i s_i^2``."""
        return np.maximum(self.p - self.lam, 0.0) / 2.0


def _pencil(dp, count):
    """The ``count`` smallest eigenpairs of the dense pencil (K, G), G-normalised."""
    from .node import effective_stiffness

    K = effective_stiffness(dp).toarray()
    G = dp.G.toarray()
    count = min(count, dp.n)
    vals, vecs = la.eigh(K, G, subset_by_index=[0, count - 1])
    return vals, vecs


def unstable_modes(dp, min_k: int = 0) -> Modes:
    """The k modes of ``(K, G)`` with ``lambda_i <= p (1 + MARGIN)``, and ``lambda_{k+1}``.

    Parameters
    ----------
    dp : DiscreteProblem
        Built with ``check_convexity=False``.
    min_k : int
        Count at least this many modes as unstable (their ``c_i`` are then
        clipped at 0): for a P that the convexity check cannot prove below
        ``P_bar_h`` but the eigen-solve puts a hair below ``lambda_1``.

    Returns
    -------
    Modes

    Raises
    ------
    ValueError
        If the problem has more free DOFs than the dense eigen-solve takes
        (:data:`MAX_DENSE_DOFS`).
    """
    scale = dp.EI / (dp.mu * dp.L**2)
    empty = Modes(0, np.zeros(0), np.zeros((dp.n, 0)), np.inf, dp.p, np.zeros(0))
    if dp.n == 0:
        return empty
    if dp.n > MAX_DENSE_DOFS:
        raise ValueError(f"{dp.n} free DOFs: the dense eigen-solve takes at most {MAX_DENSE_DOFS}")
    count = 4
    while True:
        vals, vecs = _pencil(dp, count + 1)
        k = int(np.sum(vals <= dp.p * (1.0 + MARGIN))) if dp.p > 0 else 0
        k = max(k, min(min_k, len(vals) - 1))
        if k < len(vals) or len(vals) == dp.n:
            break
        count *= 2
    if k == 0:
        return Modes(0, np.zeros(0), np.zeros((dp.n, 0)), float(vals[0]), dp.p, np.zeros(0))
    phi = vecs[:, :k].copy()
    # A fixed sign (largest deflection entry positive) makes amplitudes reproducible.
    w_rows = dp._w_rows()
    for i in range(k):
        col = phi[w_rows, i] if len(w_rows) else phi[:, i]
        j = int(np.argmax(np.abs(col)))
        if col[j] < 0:
            phi[:, i] = -phi[:, i]
    lam_next = float(vals[k]) if k < len(vals) else np.inf
    return Modes(k, vals[:k].copy(), phi, lam_next, dp.p, vals[:k] * scale)
