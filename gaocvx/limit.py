"""The discrete convexity limit P_bar_h, computed and checked in well-conditioned variables.

P_bar_h is the smallest eigenvalue of ``K u = lambda mu G u`` on the free
Hermite DOFs (physics.md).  In the Hermite DOFs (w_i, theta_i) that pencil is
hopeless on fine meshes: K has condition number ~N^4, and a shift-invert
eigen-solver returned 4.826e9 N at 16384 elements, 5.96e12 N at 10^6, for a
limit of 4.672e9 N.  Here the same pencil is written in the slope
``s = w'``, a continuous piecewise quadratic, with the variables of
:mod:`gaocvx.mixed`: nodal slopes ``theta_i`` and chord slopes ``D_e``.  On
element e (local t in [0, 1], length h)::

    s   = theta_e + 6t(1 - t) (D_e - theta_e) + (3t^2 - 2t) (theta_{e+1} - theta_e)
    s'  = ((6 - 12t) (D_e - theta_e) + (6t - 2) (theta_{e+1} - theta_e)) / h

so the curvature is a first difference of O(1) numbers.  With ``L = 1`` and
``EI = 1`` the limit is ``lambda_1 EI / (mu L^2)``, where

    lambda_1 = min ∫ s'^2 / ∫ s^2   over  theta_0 = 0 (P1, P2, P3),
               theta_N = 0 (P1),  ∫ s = sum_e h_e D_e = w_N = 0 (P1, P2, P4).

This is the Hermite pencil exactly (``w = ∫ s``, w_0 = 0 for every support),
not an approximation of it.  The end condition ``w_N = 0`` is the only
non-local constraint.  The deflections ``w_i`` carry it as a chain of local
links ``w_{e+1} - w_e - h_e D_e`` with a penalty.  Minimised over w, the
penalty ``sum_e (rho / h_e) (w_{e+1} - w_e - h_e D_e)^2`` with w_0 = w_N = 0
is exactly ``rho (sum_e h_e D_e)^2``, a rank-one term, while the matrix stays
banded (bandwidth 4 in the order [w_i, theta_i, D_i]).

The check (:meth:`ConvexityLimit.prove_below`)
    A quadratic form that is positive definite where ``w_N = 0`` is positive
    definite with the penalty for every large enough rho, and conversely
    (rho ~ sigma for P1 and P4, ~2 lambda_1 / (lambda_1 - sigma) for P2; see
    :meth:`ConvexityLimit._penalty`).  So one banded Cholesky factorisation of
    ``A - sigma B + penalty`` proves ``P < P_bar_h`` when it succeeds.  It is
    done at ``sigma = p + Delta``, where Delta bounds the effect of round-off:
    the Cholesky backward error ``|E| <= gamma |R'| |R|`` (Higham, Thm 10.3),
    ``(|R'||R|)_ij <= sqrt(m_ii m_jj)``, and ``sum_i m_ii v_i^2 <= S ∫ s^2``
    on the constraint manifold, element by element (:meth:`roundoff_shift`).
    Delta grows like N^2 eps: as a fraction of the limit it is about 1e-9 at
    64 elements, 1e-4 at 16384 and 0.1 to 2 at 10^6 (most for P3, whose
    limit is smallest).  A failed factorisation proves nothing; the
    enclosure below then decides (:meth:`ConvexityLimit.verdict`): P is
    accepted below its lower end, refused as "not below" the limit above its
    upper end, and refused as "not provably below" it in between.

The value (:meth:`ConvexityLimit.enclosure`)
    LOBPCG with the exact shift-invert preconditioner: a banded factor (the
    check's when its shift suits) plus one bordered solve for the
    constraint.  The Rayleigh quotient and the residual are evaluated from the
    first differences above, so they carry round-off of a few eps, not N^2
    eps; the factor's own error only slows convergence.  The Rayleigh quotient
    is an upper bound of lambda_1 (Rayleigh-Ritz).  Temple's inequality gives
    the lower bound, with l_2 the continuum's second eigenvalue (a lower bound
    of the discrete one, again by Rayleigh-Ritz), in two norms: the residual's
    norm dual to ∫ s^2 (a Cholesky factor of the mass matrix, condition number
    independent of N), and its norm dual to ``A - sigma B``, which does not
    see the round-off of storing the eigenvector in doubles (in the first norm
    that costs ~(N^2 eps)^2).  The enclosure is 2e-14 to 3e-14 wide (relative)
    at every N from 1 to 10^6 elements (tests/test_limit.py); it costs about
    1.5 sparse solves of the Euler-Bernoulli system after the check.

Examples
--------
>>> import numpy as np
>>> lim = ConvexityLimit(np.linspace(0.0, 1.0, 65), "P1")
>>> enc = lim.enclosure()
>>> f"{enc.value / (4 * np.pi**2) - 1:.2e}"     # above the continuum's 4 pi^2 by O(h^4)
'1.29e-07'
>>> bool(enc.lower <= enc.value <= enc.upper and enc.upper - enc.lower < 1e-12 * enc.value)
True
>>> lim.prove_below(0.999 * enc.value), lim.prove_below(enc.value)
(True, False)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from .errors import SceneError

__all__ = ["ConvexityLimit", "Enclosure", "CONTINUUM", "continuum_eigenvalues", "analysis",
           "check", "p_bar_h"]

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


def _dot(a, b) -> float:
    # Not BLAS: a threaded ddot on a loaded machine costs milliseconds per call,
    # and numpy's pairwise sum is at least as accurate.
    return float(np.sum(a * b))


def _identity_rows(ab, rows) -> None:
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


@dataclass(frozen=True)
class Enclosure:
    """The discrete limit lambda_1 (non-dimensional) with rigorous-in-exact-arithmetic bounds.

    Attributes
    ----------
    value : float
        The Rayleigh quotient of the computed eigenvector (upper bound up to round-off).
    lower, upper : float
        ``lower <= lambda_1 <= upper``: Temple's bound and the Rayleigh quotient,
        each widened by the estimated round-off of its evaluation.
    iterations : int
        LOBPCG iterations (one banded solve each).
    """

    value: float
    lower: float
    upper: float
    iterations: int

    @property
    def error(self) -> float:
        """Relative width of the enclosure (an error bound of ``value``)."""
        if math.isinf(self.value):
            return 0.0
        return (self.upper - self.lower) / self.value


class _Factor:
    """Banded Cholesky factor of the penalised ``A - sigma B`` and constrained solves."""

    def __init__(self, lim: "ConvexityLimit", cb, sigma: float):
        self.lim, self.cb, self.sigma = lim, cb, sigma
        self._yc = None

    def _solve_z(self, x):
        lim = self.lim
        z = np.zeros(3 * lim.N + 2)
        z[1::3] = x[0::2]
        z[2::3] = x[1::2]
        z[lim.z_fixed] = 0.0
        z = sla.cho_solve_banded((self.cb, False), z, check_finite=False)
        y = np.empty(2 * lim.N + 1)
        y[0::2] = z[1::3]
        y[1::2] = z[2::3]
        y[~lim.free] = 0.0
        return y

    def solve(self, b) -> np.ndarray:
        """The solution of ``(A - sigma B) y = b + mu c`` with ``c'y = 0`` (reduced variables)."""
        lim = self.lim
        y = self._solve_z(b)
        if lim.constrained:
            # Bordering on a positive definite matrix is stable: c'M^-1 c > 0.
            if self._yc is None:
                self._yc = self._solve_z(lim.c)
            y -= _dot(lim.c, y) / _dot(lim.c, self._yc) * self._yc
        return y


class ConvexityLimit:
    """The convexity limit of one mesh and supports, non-dimensional (L = 1, EI = 1, mu = 1).

    Parameters
    ----------
    xi : array_like
        Node positions, 0 = xi_0 < ... < xi_N = 1.
    supports : {"P1", "P2", "P3", "P4"}

    Notes
    -----
    Variables are "reduced": ``[theta_0, D_0, theta_1, ..., D_{N-1}, theta_N]``
    with zeros at fixed slopes.  ``P_bar_h = lambda_1 EI / (mu L^2)``.

    Examples
    --------
    >>> import numpy as np
    >>> lim = ConvexityLimit(np.linspace(0.0, 1.0, 9), "P4")
    >>> f"{lim.enclosure().value / np.pi**2 - 1:.2e}"    # above the continuum's pi^2
    '3.28e-05'
    """

    def __init__(self, xi, supports: str):
        x = np.asarray(xi, float)
        if x.ndim != 1 or len(x) < 2 or not np.all(np.diff(x) > 0):
            raise ValueError("nodes must increase strictly")
        if abs(x[0]) > 1e-12 or abs(x[-1] - 1.0) > 1e-12:
            # The continuum's eigenvalues (the Temple bound, the penalty) are for L = 1.
            raise ValueError("nodes must span [0, 1]")
        self.x = x
        self.h = h = np.diff(x)
        self.N = N = len(h)
        self.hw2 = h[:, None] * _W2          # quadrature weights of s'^2 and s^2
        self.hw3 = h[:, None] * _W3
        self.supports = supports
        self.lam1_cont, self.lam2_cont = CONTINUUM[supports]
        fix_t0 = supports in ("P1", "P2", "P3")
        fix_tN = supports == "P1"
        self.constrained = supports in ("P1", "P2", "P4")   # w_N = sum h_e D_e = 0
        self.free = np.ones(2 * N + 1, dtype=bool)
        if fix_t0:
            self.free[0] = False
        if fix_tN:
            self.free[2 * N] = False
        self.c = np.zeros(2 * N + 1)
        if self.constrained:
            self.c[1::2] = h
        # Dimension of the constraint manifold: nothing to bound when it is {0}
        # (P1 on one element).
        self.dim = int(self.free.sum()) - int(self.constrained)
        # z = [w_0, theta_0, D_0, w_1, ...]: indices whose rows are replaced by the identity.
        z_fixed = [0]                                    # w_0 = 0 for every support
        if fix_t0:
            z_fixed.append(1)
        if fix_tN:
            z_fixed.append(3 * N + 1)
        if self.constrained:
            z_fixed.append(3 * N)                        # w_N = 0
            self.z_fixed = np.array(z_fixed)
        else:
            # No constraint (P3): the deflections are not needed at all.
            self.z_fixed = np.unique(np.concatenate([z_fixed, 3 * np.arange(N + 1)]))
        self._factors: dict = {}
        self._mass = None
        self._enclosure = None
        self._dense_l2 = None
        self._shifts: dict = {}
        self.factorizations = 0   # banded Cholesky factorisations of the pencil so far

    # ------------------------------------------------------------ evaluation
    def _differences(self, v):
        th, D = v[0::2], v[1::2]
        return th[:-1], D - th[:-1], th[1:] - th[:-1]

    def curvatures(self, v) -> np.ndarray:
        """s' at the 2-point Gauss points, shape (N, 2), from first differences."""
        _, a, b = self._differences(v)
        t = _T2[None, :]
        return ((6 - 12 * t) * a[:, None] + (6 * t - 2) * b[:, None]) / self.h[:, None]

    def slopes(self, v) -> np.ndarray:
        """s at the 3-point Gauss points, shape (N, 3)."""
        th, a, b = self._differences(v)
        t = _T3[None, :]
        return th[:, None] + (6 * t - 6 * t**2) * a[:, None] + (3 * t**2 - 2 * t) * b[:, None]

    def bending(self, v) -> float:
        """∫ s'^2 (exact quadrature, a few eps of round-off)."""
        k = self.curvatures(v)
        return float(np.sum(self.hw2 * k * k))

    def mass(self, v, u=None) -> float:
        """∫ s^2, or ∫ s_v s_u."""
        s = self.slopes(v)
        su = s if u is None else self.slopes(u)
        return float(np.sum(self.hw3 * s * su))

    def _assemble(self, vals_e) -> np.ndarray:
        """Reduced vector from per-element contributions to (theta_e, D_e, theta_{e+1})."""
        out = np.zeros(2 * self.N + 1)
        out[0:-1:2] += vals_e[:, 0]
        out[1::2] += vals_e[:, 1]
        out[2::2] += vals_e[:, 2]
        out[~self.free] = 0.0
        return out

    def residual(self, v, lam, k=None, s=None) -> np.ndarray:
        """``A v - lam B v`` in the reduced variables, from curvatures and slopes.

        ``k`` and ``s`` are v's curvatures and slopes when already known.
        """
        k = (self.curvatures(v) if k is None else k) * _W2   # h cancels the 1/h of ds'/dv
        s = (self.slopes(v) if s is None else s) * self.hw3
        return self._assemble(k @ _DK - lam * (s @ _DS))

    # ------------------------------------------------------------ factorisations
    def _penalty(self, sigma: float) -> float:
        """The penalty rho of ``rho (sum_e h_e D_e)^2`` for a factorisation at ``sigma``.

        rho must exceed ``-1/(c'M^-1 c)`` (M = A - sigma B on the slopes alone)
        wherever M is indefinite.  For P1 and P4 that is about sigma, because
        their first mode has ∫ s = 0 by symmetry; for P2 it grows like
        ``2 lambda_1 / (lambda_1 - sigma)`` (measured at 64 elements: 35, 217,
        2018 at 0.9, 0.99, 0.999 lambda_1).  The continuum's lambda_1, below the
        discrete one, makes this estimate conservative.  A larger rho widens
        the round-off margin (its diagonal enters :meth:`roundoff_shift`).
        """
        if not self.constrained:
            return 0.0
        gap = max(1.0 - sigma / self.lam1_cont, 1e-6)
        return 2.0 * max(sigma, 1.0) / gap

    def roundoff_shift(self, sigma: float) -> float:
        """Delta: round-off of a Cholesky factorisation of the penalised matrix, as a shift.

        If the factorisation at ``sigma + Delta`` succeeds, ``A - sigma B`` is
        positive definite on the constraint manifold.  Delta bounds
        ``|v'Ev| / ∫ s^2`` for the backward error E of the factorisation and of
        the assembly (see the module's notes).
        """
        h, x = self.h, self.x
        rho = self._penalty(sigma)
        # sum_i m_ii v_i^2 <= sum_e v_e' diag(4/h, 12/h + rho h, 4/h) v_e (each element's
        # own diagonal), and ∫_e s^2 = h v_e' B_REF v_e: element by element,
        # lambda_max(diag(4, 12 + rho h^2, 4), B_REF) / h^2 <= (_LAM_DIAG + rho h^2 _LAM_D) / h^2.
        S = float(np.max((_LAM_DIAG + rho * h**2 * _LAM_D) / h**2))
        if self.constrained:
            # The deflections: m_ii = rho (1/h_i-1 + 1/h_i), and
            # |w_i|^2 <= min(x_i, 1 - x_i) ∫ s^2 (w_i = ∫_0^x_i s = -∫_x_i^1 s).
            inv = 1.0 / h
            d_w = rho * (inv[:-1] + inv[1:])
            S += float(np.sum(d_w * np.minimum(x[1:-1], 1.0 - x[1:-1])))
        # The assembly of sigma B: |B_ij| <= sqrt(B_ii B_jj), B_ii <= 1.2 omega_i.
        S_B = 1.2 / BETA
        return (2 * _U + 1) * (_GAMMA * S * (1 + _GAMMA) + 4 * EPS * sigma * S_B)

    def _band(self, sigma: float) -> np.ndarray:
        """Upper band (LAPACK pbtrf storage) of A - sigma B + penalty in the z order."""
        h, N = self.h, self.N
        rho_e = self._penalty(sigma) / h
        # Element e couples z indices 3e + (0..4) = (w_e, theta_e, D_e, w_e+1, theta_e+1).
        entries: dict = {}
        idx = (1, 2, 4)
        for i, a in enumerate(idx):
            for j, b in enumerate(idx):
                if a <= b:
                    entries[a, b] = A_REF[i, j] / h - (sigma * B_REF[i, j]) * h
        g = {0: -1.0, 2: -h, 3: 1.0}                 # w_e+1 - w_e - h D_e
        for a in g:
            for b in g:
                if a <= b:
                    entries[a, b] = entries.get((a, b), 0.0) + rho_e * g[a] * g[b]
        ab = np.zeros((_U + 1, 3 * N + 2))
        for (a, b), val in entries.items():
            ab[_U + a - b, b::3][:N] += val           # column 3e + b, row 3e + a
        _identity_rows(ab, self.z_fixed)
        return ab

    def factor(self, sigma: float) -> _Factor | None:
        """The factor at ``sigma``, or None when the penalised matrix is not positive definite."""
        if sigma in self._factors:
            return self._factors[sigma]
        self.factorizations += 1
        try:
            cb = sla.cholesky_banded(self._band(sigma), lower=False, check_finite=False)
        except np.linalg.LinAlgError:
            cb = None
        f = None if cb is None or not np.all(np.isfinite(cb[_U])) else _Factor(self, cb, sigma)
        self._factors[sigma] = f
        return f

    # ------------------------------------------------------------ the check
    def prove_below(self, p: float) -> bool:
        """True if one factorisation proves ``p < lambda_1`` despite round-off.

        False proves nothing (p may be at the limit, or within the round-off
        margin :meth:`roundoff_shift` of it); :meth:`verdict` then decides from
        the enclosure.
        """
        if self.dim == 0 or p <= 0:
            return True
        if self.constrained and p >= self.lam1_cont * (1 - 1e-6):
            # Only coarse meshes have p in [lambda_1 continuum, lambda_1 discrete),
            # where no penalty is known to suffice: the enclosure decides (cheaply).
            return False
        sigma = p * (1 + 4 * EPS)
        sigma += self.roundoff_shift(sigma)
        if sigma >= max(self.lam2_cont, 2 * self.lam1_cont):
            return False  # far beyond the limit: spare the factorisation
        return self.factor(sigma) is not None

    def verdict(self, p: float) -> str:
        """"below" (proved), "not below" (p >= lambda_1 proved) or "unproven".

        Tries :meth:`prove_below` first (one factorisation); otherwise compares
        with the :meth:`enclosure`.
        """
        if self.prove_below(p):
            return "below"
        enc = self.enclosure()
        if p * (1 + 4 * EPS) < enc.lower:
            return "below"
        if p * (1 - 4 * EPS) >= enc.upper:
            return "not below"
        return "unproven"

    # ------------------------------------------------------------ the value
    def _mass_factor(self):
        if self._mass is None:
            h, N = self.h, self.N
            ab = np.zeros((3, 2 * N + 1))
            e2 = 2 * np.arange(N)
            for a in range(3):
                for b in range(a, 3):
                    ab[2 + a - b, e2 + b] += B_REF[a, b] * h
            _identity_rows(ab, np.flatnonzero(~self.free))
            cb = sla.cholesky_banded(ab, lower=False, check_finite=False)
            yc = sla.cho_solve_banded((cb, False), self.c) if self.constrained else None
            self._mass = (cb, yc)
        return self._mass

    def dual_norm(self, r) -> tuple[float, float]:
        """(||r||_*, mu): the norm of ``r`` dual to ∫ s^2 on the constraint manifold.

        ``||r||_* = min_mu ||r - mu c||_{B^-1}``; B is the mass matrix, whose
        condition number is bounded independently of N.
        """
        cb, yc = self._mass_factor()
        y = sla.cho_solve_banded((cb, False), r, check_finite=False)
        mu = 0.0
        if self.constrained:
            mu = _dot(self.c, y) / _dot(self.c, yc)
            y = y - mu * yc
            r = r - mu * self.c
        return math.sqrt(max(_dot(r, y), 0.0)), mu

    def _start_factor(self) -> _Factor:
        """The factor of the iteration: the check's if suitable, else one at lambda_1 / 2.

        Convergence wants a shift near lambda_1 (the rate is about
        ``(lambda_1 - sigma) / (lambda_2 - sigma)``), the energy-norm Temple
        bound wants the factor's round-off small against ``lambda_1 - sigma``
        (``roundoff_shift / (lambda_1 - sigma) < 0.3``; the continuum's
        lambda_1, below the discrete one, stands in for it).  Half the
        continuum's limit serves both, except for P2 near 10^6 elements
        (a larger penalty), which takes a quarter or zero.  A factor that is
        not positive definite in fact would only slow the iteration: the
        bounds never depend on it.
        """
        def suitable(sigma):
            return sigma < self.lam1_cont and \
                self._shift(sigma) < 0.3 * (self.lam1_cont - sigma)

        usable = [f for f in self._factors.values()
                  if f is not None and f.sigma >= 0.5 * self.lam1_cont and suitable(f.sigma)]
        if usable:
            return max(usable, key=lambda f: f.sigma)
        shifts = [frac * self.lam1_cont for frac in (0.5, 0.25, 0.0)]
        shifts.sort(key=lambda sigma: not suitable(sigma))   # stable: the largest suitable first
        for sigma in shifts:
            f = self.factor(sigma)
            if f is not None:
                return f
        raise np.linalg.LinAlgError("the penalised pencil has no positive definite shift")

    def _start_vector(self) -> np.ndarray:
        # A smooth slope without symmetry (exp): it is not orthogonal to any mode
        # of a symmetric mesh.
        v = np.empty(2 * self.N + 1)
        v[0::2] = np.exp(self.x)
        v[1::2] = (np.exp(self.x[1:]) - np.exp(self.x[:-1])) / self.h
        v[~self.free] = 0.0
        return v

    def enclosure(self, max_iter: int = 40) -> Enclosure:
        """lambda_1 with its bounds (computed once; a few banded solves).

        LOBPCG on the subspace [v, T r, previous step], T the constrained
        shift-invert solve, Rayleigh-Ritz with the exact first-difference
        forms.  It stops when Temple's gap is below 1e-3 eps of lambda_1, or
        when the bounds stop improving.
        """
        if self._enclosure is not None:
            return self._enclosure
        if self.dim == 0:
            self._enclosure = Enclosure(math.inf, math.inf, math.inf, 0)
            return self._enclosure
        T = self._start_factor()
        v = self._vector(T.solve(self._mass_apply(self._start_vector())))
        v = v.scaled(1.0 / math.sqrt(v.mass(v)))
        prev, best, stall = None, None, 0
        for it in range(1, max_iter + 1):
            # The quotient with numpy's pairwise sums (error ~ log2(N) eps).
            lam = float(np.sum(self.hw2 * v.k * v.k)) / float(np.sum(self.hw3 * v.s * v.s))
            r = self.residual(v.x, lam, v.k, v.s)
            eta, mu = self.dual_norm(r)
            t = T.solve(r)
            enc, temple = self._bounds(v, lam, eta, mu, _dot(r, t), T.sigma, it)
            if best is None or enc.lower > best.lower:
                best, stall = enc, 0
            else:
                stall += 1
            if stall >= 3 or temple <= 1e-2 * EPS * lam:
                break
            basis = [v, self._vector(t)] + ([prev] if prev is not None else [])
            y = self._ritz(basis)
            v = _combine(y, basis)
            prev = _combine(y[1:], basis[1:])
            v = v.scaled(1.0 / math.sqrt(v.mass(v)))
        self._enclosure = best
        return best

    def _vector(self, x) -> "_Vec":
        if self.constrained:
            # Keep w_N = 0 to the last bit the solves leave.
            x = x - _dot(self.c, x) / _dot(self.c, self.c) * self.c
        return _Vec(self, x, self.curvatures(x), self.slopes(x))

    def _bounds(self, v, lam, eta, mu, zeta2, sigma, it) -> tuple[Enclosure, float]:
        """The enclosure at the Ritz pair (lam, v), and the width of its Temple part.

        ``eta`` is the residual's norm dual to ∫ s^2 and ``zeta2`` the square
        of its norm dual to ``A - sigma B`` (computed with the factor at sigma).
        """
        # Round-off of the Rayleigh quotient: the curvatures and slopes carry a
        # few eps, the sums log2(N) eps; v misses w_N = 0 by |c'v|, which moves
        # the quotient by about 2 |mu c'v| (mu: the constraint's multiplier).
        d_eval = lam * EPS * (20 + 2 * math.log2(self.N + 1))
        d_con = 2 * abs(mu * _dot(self.c, v.x)) / v.mass(v) if self.constrained else 0.0
        upper = lam + d_eval + d_con
        l2 = self._second_bound(lam)
        if not lam < l2:
            # Without a lower bound of lambda_2 above the quotient, no lower bound.
            return Enclosure(lam, -math.inf, upper, it), math.inf
        # Temple's inequality in the mass norm.  Its residual norm cannot fall
        # below ~eps N^2: rounding v to doubles is a perturbation of relative
        # size eps at the mesh scale, whose residual is large in that norm.
        lower = lam - eta**2 / (l2 - lam)
        if lower > sigma:
            # Temple's inequality for the pencil (B, A - sigma B), whose largest
            # eigenvalue is 1/(lambda_1 - sigma): the residual's norm dual to
            # A - sigma B weighs that round-off by 1/lambda_j.  The factor's
            # relative error in that norm is at most ds (roundoff_shift), and a
            # factor 2 covers the bordered solve and the dot product.
            ds = self._shift(sigma) / (lower - sigma)
            if ds < 0.5:
                a, g = lam - sigma, l2 - sigma
                tau = 2 * (1 + ds) * max(zeta2, 0.0) * g / (a * (g - a))
                lower = max(lower, sigma + a / (1 + tau))
        return Enclosure(lam, lower - d_eval - d_con, upper, it), lam - lower

    def _shift(self, sigma: float) -> float:
        if sigma not in self._shifts:
            self._shifts[sigma] = self.roundoff_shift(sigma)
        return self._shifts[sigma]

    def _second_bound(self, lam: float) -> float:
        """A lower bound of the discrete lambda_2 above ``lam`` if one is known.

        The continuum's lambda_2 (Rayleigh-Ritz: the discrete one lies above).
        Coarse meshes can have lambda_1 above it; for up to 600 DOFs the dense
        generalised eigenvalue, lowered by 1e-8 of itself (far above the dense
        solver's error at that size), serves instead.
        """
        if lam < self.lam2_cont or self.dim > 600:
            return self.lam2_cont
        if self._dense_l2 is None:
            h = self.h
            n = 2 * self.N + 1
            A, B = np.zeros((n, n)), np.zeros((n, n))
            for e in range(self.N):
                idx = slice(2 * e, 2 * e + 3)
                A[idx, idx] += A_REF / h[e]
                B[idx, idx] += B_REF * h[e]
            f = self.free
            A, B = A[np.ix_(f, f)], B[np.ix_(f, f)]
            if self.constrained:
                Z = sla.null_space(self.c[f][None, :])
                A, B = Z.T @ A @ Z, Z.T @ B @ Z
            vals = sla.eigh(A, B, eigvals_only=True)
            self._dense_l2 = vals[1] * (1 - 1e-8) if len(vals) > 1 else math.inf
        return self._dense_l2

    def _mass_apply(self, v) -> np.ndarray:
        return self._assemble((self.slopes(v) * self.hw3) @ _DS)

    def _ritz(self, basis) -> np.ndarray:
        """Coefficients of the smallest Ritz vector of (A, B) on span(basis).

        The basis may be nearly dependent (the correction shrinks as the
        iteration converges): the mass Gram matrix is diagonalised and its
        directions below 1e-13 of its largest dropped.  Only the choice of
        vector depends on this; the bounds are evaluated afresh from it.
        """
        k = len(basis)
        GA, GB = np.empty((k, k)), np.empty((k, k))
        for i in range(k):
            for j in range(i, k):
                GA[i, j] = GA[j, i] = basis[i].bend(basis[j])
                GB[i, j] = GB[j, i] = basis[i].mass(basis[j])
        d = 1.0 / np.sqrt(np.diag(GB))
        GA, GB = GA * np.outer(d, d), GB * np.outer(d, d)
        vals, U = np.linalg.eigh(GB)
        keep = vals > 1e-13 * vals[-1]
        C = U[:, keep] / np.sqrt(vals[keep])
        _, Y = np.linalg.eigh(C.T @ GA @ C)
        return d * (C @ Y[:, 0])


class _Vec:
    """A reduced vector with its curvatures and slopes (all linear in it)."""

    def __init__(self, lim, x, k, s):
        self.lim, self.x, self.k, self.s = lim, x, k, s

    def bend(self, o) -> float:
        """∫ s'_self s'_o (no BLAS: see _dot)."""
        return float(np.einsum("ij,ij,ij->", self.lim.hw2, self.k, o.k))

    def mass(self, o) -> float:
        """∫ s_self s_o."""
        return float(np.einsum("ij,ij,ij->", self.lim.hw3, self.s, o.s))

    def scaled(self, a) -> "_Vec":
        return _Vec(self.lim, a * self.x, a * self.k, a * self.s)

    def axpy(self, a, o) -> "_Vec":
        return _Vec(self.lim, self.x + a * o.x, self.k + a * o.k, self.s + a * o.s)


def _combine(coef, vectors) -> _Vec:
    out = vectors[0].scaled(coef[0])
    for a, u in zip(coef[1:], vectors[1:]):
        out = out.axpy(a, u)
    return out


# ---------------------------------------------------------------- DiscreteProblem glue
def analysis(dp) -> ConvexityLimit:
    """The :class:`ConvexityLimit` of a :class:`~gaocvx.discrete.DiscreteProblem` (kept on it)."""
    lim = dp.__dict__.get("_convexity_limit")
    if lim is None:
        lim = dp.__dict__["_convexity_limit"] = ConvexityLimit(dp.xi, dp.scene.beam.supports)
    return lim


def _to_newtons(dp, lam: float) -> float:
    return lam * dp.EI / dp.L**2 / dp.mu


def p_bar_h(dp) -> float:
    """P_bar_h [N] of a problem's mesh and supports."""
    return _to_newtons(dp, analysis(dp).enclosure().value)


def check(dp) -> None:
    """Raise :class:`SceneError` on ``load.axial`` unless P < P_bar_h is proved.

    One banded factorisation when P is clear of the limit by more than its
    round-off margin; otherwise the enclosure of P_bar_h decides.  A P that
    lies inside the enclosure is refused as "not provably below".
    """
    if not dp.P > 0:
        return
    lim = analysis(dp)
    verdict = lim.verdict(dp.p)
    if verdict == "below":
        return
    beam = dp.scene.beam
    enc = lim.enclosure()
    what = "is not below" if verdict == "not below" else \
        f"is not provably below (within the enclosure's {enc.error:.1g} relative error of)"
    raise SceneError(
        "load.axial",
        f"P = {dp.P:.4g} N {what} the convexity limit P_bar_h = "
        f"{_to_newtons(dp, enc.value):.4g} N for {beam.supports} "
        f"(continuum P_bar = {beam.P_bar():.4g} N)"
        + ("; the global method (method 'global', or 'auto') solves the Gao beam there"
           if dp.needs_gao else ""),
        dp.P)
