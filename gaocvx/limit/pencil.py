"""The slope pencil of one mesh: evaluation, banded factorisations and the check.

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
enclosure (:mod:`.enclosure`) then decides (:meth:`ConvexityLimit.verdict`): P is
accepted below its lower end, refused as "not below" the limit above its
upper end, and refused as "not provably below" it in between.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from .element import (A_REF, B_REF, BETA, CONTINUUM, EPS, _GAMMA, _LAM_D, _LAM_DIAG, _U,
                      _DK, _DS, _T2, _T3, _W2, _W3, dot as _dot, identity_rows as _identity_rows)
from .enclosure import EnclosureMethods

__all__ = ["ConvexityLimit"]


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


class ConvexityLimit(EnclosureMethods):
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

