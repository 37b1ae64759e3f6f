"""The discrete energy, its gradient and Hessian in 40-digit arithmetic, element by element.

Written apart from tests/nonconvex_independent.py's evaluation (which it checks:
tests/test_nonconvex_independent_accuracy.py): every element's energy in 40
digits (mpmath) from the textbook Hermite shape functions and the closed-form
element bending matrix, at the 5-point Gauss rule and with EI, mu, E alpha, all
in 40 digits from the scene's own numbers; only the data of the scene that are
tables or sums (node positions, load vector, foundation profiles at the Gauss
points) and the units are read from a :class:`nonconvex_independent.Discrete`.

Also used by benchmarks/equilibria_own_scale.py: the gradient of a tiny
equilibrium near the convexity limit is a difference of terms many orders of
magnitude larger than itself, so float64 leaves only round-off there; and
1e-16 relative in the Gauss weights or in p moves a Newton step taken
P_bar_h (1 + 1e-10) by 5e-7 of the beam's size (the float64 rule and constants
gave steps 0.02 to 7.7 times those of the exact ones on the seeds 5101-5102
campaign's near-limit scenes).
"""

import mpmath
import numpy as np

mp = mpmath.mp

__all__ = ["constants", "gauss5", "reference"]


def gauss5():
    """The 5-point Gauss rule on [0, 1] in 40 digits: ascending points, weights.

    Exact, not the float64 rule rounded: 1e-16 relative in the weights moves the
    buckling loads by as much, and a step taken 1e-10 above the limit by 1e-6.
    """
    r = mp.sqrt(mp.mpf(10) / 7)
    a, b = mp.sqrt(5 - 2 * r) / 3, mp.sqrt(5 + 2 * r) / 3
    c = 13 * mp.sqrt(70)
    outer, inner = (322 - c) / 900, (322 + c) / 900
    x = [-b, -a, mp.mpf(0), a, b]
    w = [outer, inner, mp.mpf(128) / 225, inner, outer]
    return [(t + 1) / 2 for t in x], [v / 2 for v in w]


def constants(beam):
    """EI, mu, E alpha of a scene's beam in 40 digits from its own numbers (docs/model.md)."""
    gao = beam.model == "gao"
    nu = mp.mpf(beam.nu) if gao else mp.mpf(0)
    E, h, b = (mp.mpf(v) for v in (beam.E, beam.half_thickness, beam.width))
    EI = mp.mpf(beam.EI) if beam.EI is not None else E * 2 / 3 * h**3 * b
    mu = mp.mpf(beam.mu) if beam.mu is not None else ((1 + nu) * (1 - nu**2) if gao else mp.mpf(1))
    Ealpha = (mp.mpf(beam.E_alpha) if beam.E_alpha is not None else 3 * E * h * b * (1 - nu**2)) \
        if gao else mp.mpf(0)
    return EI, mu, Ealpha


def reference(en, x, hessian=False):
    """Energy (E0) and gradient of free DOFs x, element by element in 40 digits.

    ``hessian``: also the (generalised: a unilateral bed's touching Gauss points) Hessian
    on the free DOFs, an mpmath matrix in 40 digits: rounded to float64 its entries
    (12 / h^3 of the bending terms) would lose a curvature 1e-10 of the stiffness's.
    """
    mp.dps = 40
    bp = en.bp
    u = [mp.mpf(0)] * bp.ndof
    for i, v in zip(en.free, np.asarray(x, float)):
        u[int(i)] = mp.mpf(float(v))
    t5, wg = gauss5()
    EI, mu, Ealpha = constants(bp.scene.beam)
    p = mp.mpf(bp.P) * mu * mp.mpf(bp.L) ** 2 / EI
    a = Ealpha * mp.mpf(en.W) ** 2 / EI
    xi = [mp.mpf(float(v)) / mp.mpf(bp.L) for v in bp.x]
    cq, gq = en.cq.reshape(bp.ne, 5), en.gq.reshape(bp.ne, 5)
    E = mp.mpf(0)
    g = [mp.mpf(0)] * bp.ndof
    H = mp.zeros(bp.ndof, bp.ndof) if hessian else None
    for e in range(bp.ne):
        h = xi[e + 1] - xi[e]
        dofs = [2 * e, 2 * e + 1, 2 * e + 2, 2 * e + 3]
        ue = [u[k] for k in dofs]
        Ke = [[12, 6 * h, -12, 6 * h], [6 * h, 4 * h**2, -6 * h, 2 * h**2],
              [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h**2, -6 * h, 4 * h**2]]
        Ku = [sum(Ke[i][j] * ue[j] for j in range(4)) / h**3 for i in range(4)]
        E += sum(ue[i] * Ku[i] for i in range(4)) / 2
        ge = list(Ku)
        He = [[Ke[i][j] / h**3 for j in range(4)] for i in range(4)]
        for q in range(5):
            t = t5[q]
            N = [(1 - t) ** 2 * (1 + 2 * t), h * t * (1 - t) ** 2, t**2 * (3 - 2 * t),
                 -h * t**2 * (1 - t)]
            D = [(6 * t**2 - 6 * t) / h, 1 - 4 * t + 3 * t**2, (6 * t - 6 * t**2) / h,
                 3 * t**2 - 2 * t]
            s = sum(D[i] * ue[i] for i in range(4))
            w = sum(N[i] * ue[i] for i in range(4))
            wq = h * wg[q]
            E += wq * (-p / 2 * s**2 + a / 12 * s**4)
            ds = wq * (-p * s + a / 3 * s**3)
            dw = d2w = mp.mpf(0)
            if en.kind in ("foundation", "bonded"):
                pen = mp.mpf(float(gq[e, q])) - w
                if en.kind == "foundation":
                    pen = max(pen, mp.mpf(0))
                c = mp.mpf(float(cq[e, q]))
                d2w = wq * c if pen > 0 or en.kind == "bonded" else d2w
                E += wq * c * pen**2 / 2
                dw = -wq * c * pen
            d2s = wq * (-p + a * s**2)
            for i in range(4):
                ge[i] += ds * D[i] + dw * N[i]
                for j in range(4 if hessian else 0):
                    He[i][j] += d2s * D[i] * D[j] + d2w * N[i] * N[j]
        for i in range(4):
            g[dofs[i]] += ge[i]
            for j in range(4 if hessian else 0):
                H[dofs[i], dofs[j]] += He[i][j]
    for i in range(bp.ndof):
        f = mp.mpf(float(en.fl[i]))  # the load vector is data of the scene, not evaluated
        E -= f * u[i]
        g[i] -= f
    grad = np.array([float(g[int(i)]) for i in en.free])
    if not hessian:
        return E, grad
    free = [int(i) for i in en.free]
    Hf = mp.matrix(len(free), len(free))
    for a_, i in enumerate(free):
        for b_, j in enumerate(free):
            Hf[a_, b_] = H[i, j]
    return E, grad, Hf
