"""Newton on the face of the touching rows: refine an SLSQP end point to a KKT point.

Used by equilibria_campaign.py on the independent energy
(tests/nonconvex_independent.py's ``Discrete``): SLSQP stops about 1e-6 off a
minimiser whose contact rows are active; Newton's method on the face of the
rows that touch, with a ratio test on the others, reaches the KKT point.
"""
import numpy as np
import scipy.linalg as sla


def polish(en, x, iters=40, act_tol=1e-6):
    """``(x, how)``: ``x`` refined, ``how`` why it stopped (converged, no decrease,
    indefinite, iterations)."""
    R, r = en.constraints()
    x = np.asarray(x, float).copy()
    size = lambda z: max(float(np.max(np.abs(z))), 1.0)
    if len(r):  # onto the face of the touching (or violated) rows first
        slack = R @ x - r
        T = np.flatnonzero(slack <= act_tol * size(x))
        if len(T):
            x = x + np.linalg.lstsq(R[T], r[T] - R[T] @ x, rcond=None)[0]
    fx = en(x)[0]
    for it in range(iters):
        slack = R @ x - r if len(r) else np.zeros(0)
        T = np.flatnonzero(slack <= act_tol * size(x)) if len(r) else np.zeros(0, int)
        e, g = en(x)
        H = en.hessian(x)
        if len(T):
            A = R[T]
            rhs = r[T] - A @ x
            dx0 = np.linalg.lstsq(A, rhs, rcond=None)[0]
            Z = sla.null_space(A)
        else:
            dx0 = np.zeros(en.n)
            Z = np.eye(en.n)
        if Z.shape[1]:
            Hz = Z.T @ H @ Z
            gz = Z.T @ (g + H @ dx0)
            try:
                c = np.linalg.cholesky(Hz)
            except np.linalg.LinAlgError:
                return x, "indefinite"
            dz = -sla.cho_solve((c, True), gz)
            dx = dx0 + Z @ dz
        else:
            dx = dx0
        # ratio test on the rows not in T
        t = 1.0
        if len(r):
            Rd = R @ dx
            inact = np.setdiff1d(np.arange(len(r)), T)
            dec = inact[Rd[inact] < 0]
            if len(dec):
                ts = slack[dec] / -Rd[dec]
                t = min(1.0, float(np.min(ts)))
        xn = x + t * dx
        # back onto the face exactly (rows in T at their level)
        if len(T):
            xn = xn + np.linalg.lstsq(R[T], r[T] - R[T] @ xn, rcond=None)[0]
        fn = en(xn)[0]
        if fn > fx + 1e-12 * max(abs(fx), 1.0):
            return x, "no decrease"
        step = float(np.max(np.abs(xn - x)))
        x, fx = xn, fn
        if step <= 1e-14 * size(x):
            return x, "converged"
    return x, "iterations"
