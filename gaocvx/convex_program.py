"""The convex ground truth: the discrete energy as a CVXPY program.

The program is written on the well-conditioned mixed variables of
:class:`~gaocvx.mixed.MixedForm` (deflections, slopes and chord slopes tied
by sparse linear constraints) and contains only the terms a scene needs:

* bending ``1/2 z' K z`` with K the (banded) bending form of the curvatures
  at Gauss points, which are first differences in these variables; with a
  compressive axial force the bending and axial parts are one quadratic form,
  positive definite only on the constraints, so ``Q + rho C'C`` is used
  (``C z = 0`` on the feasible set), proved definite by a banded Cholesky;
* the Gao term ``a/12 Σ w_q s_q^4`` with slopes at 5 Gauss points, as
  ``a sigma^4/12 Σ w_q u_q^2`` with ``u_q >= (s_q/sigma)^2`` (one rotated
  second-order cone per point; sigma is the slope scale of the linear answer);
* the foundation term ``c/2 Σ w_q v_q^2`` with ``v >= g - w_q`` at 5 Gauss
  points (``v = pos(g - w_q)`` at the optimum: minimising v_q^2 makes v >= 0
  hold by itself);
* for a rigid obstacle, ``w >= g`` at the nodes and the same Gauss points.

The Gao and foundation terms are ``quad_form``s of diagonal matrices, which
CVXPY passes to Clarabel's quadratic objective as they are (``sum_squares``
would add a variable and an equality per quadrature point: at 2048 elements
51198 variables instead of 26622, and about 1.6x the run time, measured).
Bending is the exception: as ``sum_squares`` of the weighted curvatures it
adds 2 variables and equalities per element, but as a ``quad_form`` of the
banded bending matrix Clarabel needed 21 iterations instead of 15 (2048
elements on a foundation, measured).  At 2048 elements on a foundation the
program has 30718 variables and 47104 rows: 5 points per element for the Gao
cones (3 rows each), 5 for the foundation, the curvatures and the links.
Five cones per element are the fewest for the exact quartic: ``∫ s^4`` over
an element, s quadratic, is a quartic form whose moment (catalecticant)
matrix, the Hankel matrix of ``∫ t^k``, k <= 8, has rank 5, so it is no sum
of fewer fourth powers of linear forms.

Parametric programs: a factor on the load, the foundation level and
stiffness, the Gao coefficient and a tensile axial force can be CVXPY
Parameters (the program is DPP), so a sweep over them reuses the compiled
problem; :func:`program` keeps the last few by their structure.  Solving,
the solver ladder and the certificate are in :mod:`gaocvx.convex`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .cache import LRU
from .errors import SceneError
from .linalg import BandedCholesky, NotPositiveDefinite
from .mixed import MixedForm, structure_key

__all__ = ["ConvexProgram", "program", "clear_programs"]


class ConvexProgram:
    """The CVXPY program of one problem structure.

    Parameters
    ----------
    mf : MixedForm
        Of the first scene with this structure.
    parametric : bool
        Make a factor on the load, the level, stiffness, Gao coefficient and
        tension CVXPY Parameters (DPP), so that :meth:`set` and a new solve
        reuse the compilation.
    """

    def __init__(self, mf: MixedForm, parametric: bool = False):
        import cvxpy as cp

        dp = mf.dp
        self.parametric = parametric

        def param(value, **kw):
            return cp.Parameter(value=value, **kw) if parametric else value

        self.z = z = cp.Variable(mf.n, name="z")
        # The load enters as a scalar times a fixed vector: a vector Parameter
        # made the DPP compilation ten times slower (2.3 s against 0.24 s at 1024
        # elements, measured); sweeps over anything but the load's shape keep it
        # parallel (see set()).
        self.load_shape = mf.f.copy()
        self.load_factor = param(1.0, name="load_factor")
        self.compressed = dp.p > 0
        terms = [-self.load_factor * (self.load_shape @ z)]
        # Quadratic terms are quad_forms of constant sparse matrices: CVXPY hands
        # them to Clarabel's quadratic objective as they are, where sum_squares
        # would add a variable and an equality per quadrature point.
        if self.compressed:
            # One quadratic form; it depends on p, which is then fixed.
            terms.append(0.5 * cp.quad_form(z, cp.psd_wrap(_compressed_form(mf))))
        else:
            terms.append(0.5 * cp.sum_squares(sp.diags(np.sqrt(mf.wq2)) @ mf.B2 @ z))
            if mf.has_slope and (parametric or dp.p < 0):
                self.tension = param(-dp.p, nonneg=True, name="tension")
                terms.append(0.5 * self.tension * cp.quad_form(z, cp.psd_wrap(mf.axial)))
        constraints = [mf.C @ z == 0]
        if dp.needs_gao:
            # a/12 sum w_q s_q^4 = a sigma^4/12 sum w_q u_q^2 with u_q >= (s_q/sigma)^2,
            # one rotated cone ||(2 s_q/sigma, u_q - 1)|| <= u_q + 1 per point.  The
            # slope scale sigma (of a Ritz estimate of the answer; in a parametric
            # program, of the first scene) brings u to about 1: unscaled,
            # slopes of 7 took Clarabel 71 iterations to 'optimal_inaccurate' where
            # scaled ones take 13 to 'optimal' (measured).  The power cone of
            # power(s, 4) is much less accurate in Clarabel.
            self.a = param(dp.a, nonneg=True, name="gao")
            sigma = _slope_scale(mf)
            u = cp.Variable(len(mf.wq5), name="slope_squared")
            constraints.append(cp.SOC(u + 1, cp.vstack([(mf.B1 * (2.0 / sigma)) @ z, u - 1]),
                                      axis=0))
            terms.append(self.a * (sigma**4 / 12.0)
                         * cp.quad_form(u, cp.psd_wrap(sp.diags(mf.wq5))))
        self.obstacle = None
        if dp.contact is not None and not (dp.bilateral and self.compressed):
            level = _level(mf)
            self.g = param(level, name="level") if np.ndim(level) == 0 else level
        self.bonded_in_form = dp.bilateral and self.compressed
        if self.bonded_in_form:
            # Bonded under compression: c/2 sum w_q (g - w_q)^2 has its quadratic part
            # in the compressed form (above P_bar_h it is what makes that form
            # positive definite); here its linear part and constant, as numbers
            # (c g is a product of two parameters, not DPP: such a program is
            # rebuilt for each scene, see set()).
            depth0 = mf.depth(np.zeros(mf.n))
            cwd = dp.c * mf.wqc * depth0
            terms.append(-((mf.NqT @ cwd) @ z) + 0.5 * float(cwd @ depth0))
        elif dp.contact == "foundation":
            # c/2 sum w_q pos(g - w_q)^2 = min c/2 sum w_q v_q^2 over v >= g - w_q: the
            # weights are positive, so the minimum over v_q is at v_q = max(g - w_q, 0)
            # and v >= 0 is implied (the same energy; the rows were dropped: at 2048
            # elements 14 Clarabel iterations instead of 17, 47104 rows instead of
            # 57344, measured).  Bonded (bilateral): v = g - w_q.  v keeps it DPP.
            self.c = param(dp.c, nonneg=True, name="stiffness") if np.ndim(dp.c) == 0 else 1.0
            weights = mf.wqc if np.ndim(dp.c) == 0 else dp.c * mf.wqc   # a stiffness profile
            v = cp.Variable(len(mf.wqc), name="depth")
            if dp.bilateral:
                constraints.append(v == self.g - mf.Nq @ z)
            else:
                constraints.append(v >= self.g - mf.Nq @ z)
            terms.append(0.5 * self.c * cp.quad_form(v, cp.psd_wrap(sp.diags(weights))))
        elif dp.contact == "obstacle":
            self.obstacle = mf.A @ z >= self.g
            constraints.append(self.obstacle)
        self.problem = cp.Problem(cp.Minimize(cp.sum(terms)), constraints)
        if not self.problem.is_dcp(dpp=parametric):  # a formulation bug, never the user's
            raise AssertionError("the convex formulation is not DCP/DPP")

    def set(self, mf: MixedForm) -> bool:
        """Load the values of a scene with this structure into the Parameters.

        Returns False (and changes nothing) if the scene's load vector is not a
        multiple of this program's, which the program cannot represent.
        """
        if not self.parametric:
            raise ValueError("a program built without parameters cannot be updated")
        if self.bonded_in_form:
            return False
        shape = self.load_shape
        norm2 = float(shape @ shape)
        factor = float(mf.f @ shape) / norm2 if norm2 > 0 else 0.0
        if np.linalg.norm(mf.f - factor * shape) > 1e-13 * max(np.linalg.norm(mf.f), 1e-300):
            return False
        dp = mf.dp
        self.load_factor.value = factor
        if not self.compressed and mf.has_slope:
            self.tension.value = -dp.p
        if dp.needs_gao:
            self.a.value = dp.a
        if dp.contact is not None:
            self.g.value = _level(mf)
        if dp.contact == "foundation":
            self.c.value = dp.c
        return True


def _level(mf: MixedForm) -> float:
    """The contact level for the program: g, or a level the answer provably cannot reach.

    A foundation or obstacle millions of deflection scales below the beam puts
    numbers of that size into the program's constraints, and Clarabel fails.
    Below twice :meth:`MixedForm.deflection_bound` (and below -1, one
    deflection scale) the contact term vanishes near the answer, so raising
    the level there does not change the minimiser.
    """
    g = mf.level if mf.dp.contact == "obstacle" else mf.dp.g   # at the constraint points
    if mf.dp.bilateral:  # a bonded foundation pulls from any distance: g itself
        return g
    # At least one deflection scale below: with no load the bound is 0 (w = 0).
    return np.maximum(g, -max(2.0 * mf.deflection_bound(), 1.0))


def _slope_scale(mf: MixedForm) -> float:
    """Largest slope of a one-term Ritz approximation of the answer; 1 without load.

    Along the linear answer z (bending and axial only) the energy is
    ``A t^2/2 + B t^4/4 - A t`` with ``A = f'z`` and ``B = a/3 Σ w_q s_q^4``; its
    minimiser t (``t + (B/A) t^3 = 1``) accounts for the stiffening of the Gao
    term, which near P_bar_h keeps the answer far below the linear one.

    A bonded foundation with a gap pulls the beam towards it, a load that ``f``
    leaves out: there z is the linear answer to both, with the foundation's
    stiffness in the form (a P4 beam under a weak load, 2.7e3 N/m, over a bed
    1 mm below: from ``f`` alone the slopes were 1/2500 of the answer's, the
    cones' variables 1e6 against an objective weight of 1e-17, and Clarabel
    failed at every setting).
    """
    z = None
    if mf.dp.bilateral and np.any(mf.dp.g != 0):
        f = -mf.gradient(np.zeros(mf.n))   # the load and the bed's pull at w = 0
        try:
            z = BandedCholesky(_compressed_form(mf)).solve(f)
        except SceneError:    # no convex form: the load's estimate below
            pass
    if z is None:
        f = mf.f
        z, _ = mf.quadratic_factor.solve(f, np.zeros(mf.N))
    s = mf.B1 @ z
    A = float(f @ z)
    peak = float(np.max(np.abs(s), initial=0.0))
    if not (np.isfinite(A) and np.isfinite(peak) and A > 0 and peak > 0):
        return 1.0
    ratio = mf.dp.a / 3.0 * float(mf.wq5 @ s**4) / A
    t = np.roots([ratio, 0.0, 1.0, -1.0]) if ratio > 0 else np.array([1.0])
    t = float(np.max(t[np.abs(t.imag) < 1e-12 * max(1.0, np.max(np.abs(t)))].real))
    return t * peak


def _compressed_form(mf: MixedForm) -> sp.csr_matrix:
    """bending - p axial (+ a bonded foundation's c M) + rho C'C, positive definite by Cholesky."""
    dp = mf.dp
    CtC = (mf.C.T @ mf.C).tocsr()
    H0 = mf.H0
    if dp.bilateral:
        H0 = H0 + mf.NqT @ sp.diags(dp.c * mf.wqc) @ mf.Nq
    # C z = 0 on the feasible set, so rho C'C changes nothing there; it makes the
    # form definite off it (the rigid rotation of P4, directions that violate C).
    rho = 1.0 / float(np.min(np.diff(dp.xi))) ** 2
    for _ in range(12):
        Q = (H0 + rho * CtC).tocsr()
        try:
            BandedCholesky(Q)
            return Q
        except NotPositiveDefinite:
            rho *= 4.0
    raise SceneError("load.axial", f"P = {dp.P:.4g} N leaves the discrete energy without a "
                     f"convex form (P_bar_h = {dp.P_bar_h:.4g} N)", dp.P)


# Compiled parametric programs by structure, one cache per thread: a program
# holds the parameter values of the scene being solved.
_PROGRAMS = LRU(4, per_thread=True)


def clear_programs() -> None:
    """Forget this thread's compiled parametric programs."""
    _PROGRAMS.clear()


def program(mf: MixedForm, solver: str, reuse: bool) -> tuple[ConvexProgram, bool]:
    """The program of ``mf`` (a cached parametric one when ``reuse``) and whether it was reused."""
    if not reuse or mf.dp.scene.has_profile or mf.dp.g_above is not None:
        # A profile's level and stiffness vary along the beam: they enter as
        # numbers, and such a program is not reused.
        return ConvexProgram(mf), False
    dp = mf.dp
    # The compressed form depends on p, fixed when the program is built.
    key = (structure_key(dp), dp.needs_gao, dp.p if dp.p > 0 else None, solver, dp.bilateral)
    program = _PROGRAMS.get(key)
    if program is not None and program.set(mf):
        return program, True
    return _PROGRAMS.put(key, ConvexProgram(mf, parametric=True)), False
