"""The value of P_bar_h with bounds: LOBPCG, Rayleigh-Ritz and Temple's inequality.

LOBPCG with the exact shift-invert preconditioner: a banded factor (the
check's when its shift suits) plus one bordered solve for the
constraint.  The Rayleigh quotient and the residual are evaluated from the
first differences of :mod:`gaocvx.limit`, so they carry round-off of a few eps, not N^2
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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as sla

from .element import A_REF, B_REF, EPS, _DS, dot as _dot, identity_rows as _identity_rows

if TYPE_CHECKING:
    from .pencil import _Factor

__all__ = ["Enclosure", "EnclosureMethods"]


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



class EnclosureMethods:
    """The enclosure's part of :class:`~gaocvx.limit.pencil.ConvexityLimit` (a mixin).

    It uses the pencil's evaluation (``curvatures``, ``slopes``, ``residual``,
    ``_assemble``), its factorisations (``factor``, ``roundoff_shift``) and
    its mesh data (``x``, ``h``, ``N``, ``free``, ``c``, ``constrained``,
    ``dim``, ``hw2``, ``hw3``, ``lam1_cont``, ``lam2_cont``).
    """

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


