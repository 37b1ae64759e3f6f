"""The reference element of the slope pencil, its quadrature and round-off constants.

On element e (local t in [0, 1], length h) the slope ``s`` is quadratic in
``(theta_e, D_e, theta_{e+1})`` (see :mod:`gaocvx.limit`).  The constants here
are shared by the check (:mod:`.pencil`) and the enclosure (:mod:`.enclosure`).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla

EPS = np.finfo(float).eps

# Positive roots of tan x = x (the clamped-clamped antisymmetric and the
# clamped-pinned modes); tests/test_limit.py checks them with mpmath.
_TAN_ROOT_1 = 4.493409457909064
_TAN_ROOT_2 = 7.725251836937707

# Continuum eigenvalues lambda_1 < lambda_2 of ∫ w''^2 = lambda ∫ w'^2 on (0, 1):
# P_bar = lambda_1 EI / (mu L^2).  (scene.EFFECTIVE_LENGTH's 0.699157 for P2 is
# pi / 4.4934094579 = 0.6991557 to 6 digits: 4e-6 off in P_bar.)
CONTINUUM = {
    "P1": ((2 * math.pi) ** 2, (2 * _TAN_ROOT_1) ** 2),
    "P2": (_TAN_ROOT_1**2, _TAN_ROOT_2**2),
    "P3": ((math.pi / 2) ** 2, (3 * math.pi / 2) ** 2),
    "P4": (math.pi**2, (2 * math.pi) ** 2),
}

# Reference element in (theta_e, D_e, theta_{e+1}): ∫ s'^2 = v' A_REF v / h and
# ∫ s^2 = h v' B_REF v.
A_REF = np.array([[4.0, -6.0, 2.0], [-6.0, 12.0, -6.0], [2.0, -6.0, 4.0]])
B_REF = np.array([[4.0, -3.0, -1.0], [-3.0, 36.0, -3.0], [-1.0, -3.0, 4.0]]) / 30.0
# Smallest eigenvalue of B_REF: ∫_e s^2 >= BETA h_e |(theta_e, D_e, theta_{e+1})|^2.
BETA = float(np.linalg.eigvalsh(B_REF)[0])
# Element bounds of the round-off analysis (roundoff_shift): the largest eigenvalue
# of (diag(4, 12, 4), B_REF), 50.49, and (B_REF^-1)_DD, the cost of the penalty's
# D-diagonal, each rounded up.
_LAM_DIAG = float(sla.eigh(np.diag([4.0, 12.0, 4.0]), B_REF, eigvals_only=True)[-1]) * (1 + 1e-12)
_LAM_D = float(np.linalg.inv(B_REF)[1, 1]) * (1 + 1e-12)

# Gauss rules on [0, 1]: 2 points integrate s'^2 (degree 2) exactly, 3 points s^2 (degree 4).
_T2, _W2 = (0.5 * (np.polynomial.legendre.leggauss(2)[0] + 1), 0.5 * np.polynomial.legendre.leggauss(2)[1])
_T3, _W3 = (0.5 * (np.polynomial.legendre.leggauss(3)[0] + 1), 0.5 * np.polynomial.legendre.leggauss(3)[1])

# d(h s')/d(theta_e, D_e, theta_e+1) at the 2 points, ds/d(...) at the 3 points.
_DK = np.stack([6 * _T2 - 4, 6 - 12 * _T2, 6 * _T2 - 2], 1)
_DS = np.stack([1 - 4 * _T3 + 3 * _T3**2, 6 * _T3 - 6 * _T3**2, 3 * _T3**2 - 2 * _T3], 1)

_U = 4          # upper bandwidth of the penalised matrix in the order [w_i, theta_i, D_i]
# Relative round-off of Cholesky with bandwidth _U (Higham's gamma_{U+2}), of the
# assembly, and a factor 2 of safety.
_GAMMA = 2.0 * (_U + 2 + 4) * EPS


def dot(a, b) -> float:
    # Not BLAS: a threaded ddot on a loaded machine costs milliseconds per call,
    # and numpy's pairwise sum is at least as accurate.
    return float(np.sum(a * b))


def identity_rows(ab, rows) -> None:
    """Make ``rows`` identity rows and columns of a symmetric upper band (in place).

    Fixed variables then decouple: the factorisation and the solves on the
    others are those of the matrix without them.
    """
    u, n = ab.shape[0] - 1, ab.shape[1]
    rows = np.asarray(rows, int)
    for d in range(1, u + 1):
        right = rows[rows + d < n]
        ab[u - d, right + d] = 0.0          # row r, column r + d
        left = rows[rows - d >= 0]
        ab[u - d, left] = 0.0               # column r, row r - d
    ab[u, rows] = 1.0


def continuum_eigenvalues(supports: str) -> tuple[float, float]:
    """The continuum's (lambda_1, lambda_2) for L = 1, EI = 1, mu = 1.

    Examples
    --------
    >>> round(continuum_eigenvalues("P1")[0] / math.pi**2, 12)
    4.0
    """
    return CONTINUUM[supports]


