"""A KKT point's stability on the cone of its weakly touching rows (one negative curvature).

:func:`.whole_beam.second_order` proves a strict local minimum where the
Hessian is positive on the null space of the rows carrying a force, and an
unstable point where it is negative on the null space of every touching row.
Between the two lie points whose rows touch without a force: a direction may
lift them off one way only, and the Hessian need be positive only on the cone
``{d : A_strong d = 0, A_weak d >= 0}``.  The flat beam on an obstacle at gap 0
under a point force (P1, 40 elements, one row pressed, every other touching)
has one negative curvature, -2.1e-4 of K, on the pressed row's null space,
along a direction that pushes touching rows into the obstacle either way; it
was labelled by the probes of the reduced function, unstable and `optimal`,
where it is a strict local minimum (a helper's campaign: on the cone the least
curvature is +0.068 and +127 of K along either sign of that direction).

With exactly one negative eigenvalue ``mu_1`` of ``(Zᵀ H Z, Zᵀ K Z)`` (``Z`` the
null space of the pressed rows, the others clearly positive), write
``d = a v_1 + Σ b_i v_i`` in its K-orthonormal eigenvectors:
``dᵀ H d = mu_1 a² + Σ mu_i b_i²``.  With ``a = 0`` it is positive; with
``a = ±1`` its least over the cone is ``mu_1`` plus a convex QP's value (Clarabel).
Where both exceed the threshold, ``dᵀ H d > 0`` on the cone: a strict local
minimum (the cone holds the critical cone: a touching row with a small force
counted as weak only widens it).  Nothing is concluded otherwise.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as la

__all__ = ["stable_on_cone", "restricted_pencil", "CONE_TOL"]

#: The least curvature on the cone (relative to K) must exceed this as well as
#: the caller's threshold: the QP's value is Clarabel's, accurate to about 1e-8.
CONE_TOL = 1e-6


def restricted_pencil(H, K, rows, idx, vectors: bool = False) -> tuple:
    """``(mu, Y)``: the eigenvalues of ``H`` relative to ``K`` on the null space of
    ``rows[idx]`` (ascending; none where that space is empty) and, with ``vectors``,
    their eigenvectors in the DOFs (``K``-orthonormal; else None)."""
    Z = la.null_space(rows[idx].toarray()) if len(idx) else np.eye(H.shape[0])
    if Z.shape[1] == 0:
        return np.zeros(0), (np.zeros((H.shape[0], 0)) if vectors else None)
    M, N = Z.T @ H @ Z, Z.T @ K @ Z
    # (Jacobi-scaled: unscaled, the least eigenvalue at 480 elements, cond K 7e10,
    # was 2.3e-7 off the scaled one and 1 + that of (H - K, K), which agree -- a
    # review; at 30 elements all three agree to 6e-12)
    s = 1.0 / np.sqrt(np.abs(np.diag(N)))
    if not vectors:
        return la.eigh(s[:, None] * M * s, s[:, None] * N * s, eigvals_only=True), None
    mu, V = la.eigh(s[:, None] * M * s, s[:, None] * N * s)
    return mu, Z @ (s[:, None] * V)


def stable_on_cone(H, K, rows, strong, weak, tol: float) -> bool | None:
    """True where ``dᵀ H d > 0`` for every ``d != 0`` of the cone
    ``rows[strong] d = 0``, ``rows[weak] d >= 0`` is proved (one negative
    curvature on the pressed rows' null space, the others above ``tol``, and
    ``mu_1`` plus each QP's value above ``tol`` and ``CONE_TOL``); None otherwise.

    Examples
    --------
    Two DOFs, ``H = diag(-1, 4)``.  One touching row ``d_1 + d_2 >= 0``: the
    direction ``(1, 0)`` is admissible and lowers the energy -- not proved.  Two,
    ``d_2 >= 3 d_1`` and ``d_2 >= -3 d_1``: every admissible direction has
    ``d_2 >= 3 |d_1|``, where ``dᵀ H d >= 35 d_1²`` -- proved.

    >>> import numpy as np, scipy.sparse as sp
    >>> H, K = np.diag([-1.0, 4.0]), np.eye(2)
    >>> print(stable_on_cone(H, K, sp.csr_matrix([[1.0, 1.0]]), [], [0], 1e-8))
    None
    >>> stable_on_cone(H, K, sp.csr_matrix([[-3.0, 1.0], [3.0, 1.0]]), [], [0, 1], 1e-8)
    True
    """
    import cvxpy as cp

    strong, weak = np.asarray(strong, int), np.asarray(weak, int)
    if len(weak) == 0:
        return None
    mu, Y = restricted_pencil(H, K, rows, strong, vectors=True)
    if len(mu) < 2 or not (mu[0] < -tol and mu[1] > tol):
        return None
    W = rows[weak].toarray() @ Y
    norms = np.linalg.norm(W, axis=1)
    W = W[norms > 0] / norms[norms > 0, None]
    b = cp.Variable(len(mu) - 1)
    for sign in (1.0, -1.0):
        prob = cp.Problem(cp.Minimize(mu[1:] @ cp.square(b)), [sign * W[:, 0] + W[:, 1:] @ b >= 0])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            try:
                prob.solve(solver=cp.CLARABEL)
            except cp.error.SolverError:
                return None
        if prob.status == "infeasible":
            continue    # (no admissible direction with that sign of a)
        if prob.status != "optimal" or prob.value is None:
            return None
        # (the least of dᵀ H d over the cone with a = ±1, against dᵀ K d >= 1 there)
        if not float(mu[0] + prob.value) > max(tol, CONE_TOL):
            return None
    return True
