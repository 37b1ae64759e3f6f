"""Every equilibrium of a beam above the convexity limit (k = 1 unstable mode; k = 2 in
:mod:`.stationary2`).

At an equilibrium the gradient in the stable directions vanishes, and for
given amplitudes ``s`` of the unstable modes the energy is strictly convex in
the rest, so ``v*(s)`` is unique: the equilibria are exactly the stationary
points of the reduced function ``F(s) = min_v Psi(s, v) - c s^2``
(nonconvex.md), whose derivative comes with each fixed-amplitude solve
(envelope theorem): :meth:`.node.NodeProgram.reduced` (dense, the ground
truth, at most ``minimum.MAX_ELEMENTS``), :meth:`.fast.FastProgram.reduced`
(banded, no obstacle) or, with an obstacle or channel beyond the dense
programs, :class:`ContactSlices` (banded, on a
:class:`.fast_contact.FastContactProgram`), both up to
``api.MAX_FAST_ELEMENTS``.  So:

1. every equilibrium has its amplitude in ``[-S, S]`` (:func:`.bounds.equilibrium_box`);
2. ``F'`` is sampled on a grid over it (and at ``seeds``, e.g. the previous
   load step's equilibria on a path); where it changes sign, or comes close
   to zero between grid points (two roots close together), Brent's method
   finds its zeros;
3. each zero is classified: ``F'' > 0`` (``F'`` rising through zero, or a
   kink from negative to positive, where an obstacle starts to hold the
   beam) is a local minimum of the energy (stable); ``F'' < 0`` an unstable
   equilibrium (for k = 1: a local maximum of ``F``);
4. with an obstacle, an end of the admissible amplitudes where ``F`` rises
   into the range is a local minimum of the energy too (stable): a beam
   pressed flat onto an obstacle at gap 0.

Below the limit (k = 0) the one equilibrium is the convex minimiser.

Examples
--------
>>> from gaocvx import Scene
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"axial": 1.3e9}, "mesh": {"elements": 8}})
>>> eqs = equilibria(scene)                 # q = 0: w = 0 between two mirror images
>>> [e.stable for e in eqs], round(eqs[2].energy, 6)
([True, True, False], 0.0)
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize as so

from ..discrete import DiscreteProblem
from ..errors import SceneError
from ..result import extremum
from .bounds import check_bounded, equilibrium_box

__all__ = ["Equilibrium", "equilibria", "ContactSlices", "GRID"]

log = logging.getLogger(__name__)

# Grid points of F' over the amplitude range (odd: s = 0 is one of them, the
# trivial equilibrium of an unloaded beam).
GRID = 121
# |F'(s)| |s| at a zero, relative to the equilibrium's energy scale (sum of
# |energy parts|), at most (the node programs' own accuracy is about 1e-10).
ROOT_TOL = 1e-8


@dataclass
class Equilibrium:
    """One equilibrium of the discrete beam.

    Attributes
    ----------
    energy : float
        Total potential energy [J].
    stable : bool
        A local minimum of the energy (``F'' > 0``).
    amplitudes : list of float
        Its unstable modes' amplitudes ``s`` (non-dimensional).
    x, w, slope : ndarray
        Nodes [m], deflection [m], slope.
    residual : float
        ``|F'(s)| |s|`` relative to the energy scale (0 for the convex case);
        at a kink of ``F`` or an end of the admissible amplitudes (an obstacle
        holding the beam), ``|F'|`` times the width of the bracket that holds
        the equilibrium.
    status : str
        "optimal" when the fixed-amplitude solve and the zero are accurate,
        else "inaccurate".
    P : float
        The axial force [N].
    """

    energy: float
    stable: bool
    amplitudes: list
    x: np.ndarray
    w: np.ndarray
    slope: np.ndarray
    residual: float
    status: str
    P: float
    curvature: float = field(default=math.nan)
    W: float = field(default=math.nan)

    @property
    def amplitude_m(self) -> list:
        """The amplitudes in metres (``s W``): comparable between axial forces."""
        return [a * self.W for a in self.amplitudes]

    @property
    def min(self) -> dict:
        return extremum(self.x, self.w, largest=False)

    @property
    def max(self) -> dict:
        return extremum(self.x, self.w, largest=True)

    def deflection_at(self, x: float) -> float:
        """Nodal-interpolated deflection at ``x`` [m] (linear between nodes)."""
        return float(np.interp(x, self.x, self.w))

    def to_dict(self) -> dict:
        """One JSON object: energy, stability, extrema, amplitudes, nodal values."""
        return {"energy": self.energy, "stability": "stable" if self.stable else "unstable",
                "P": self.P, "min": self.min, "max": self.max, "amplitudes": self.amplitudes,
                "status": self.status, "residual": self.residual,
                "nodes": {"x": self.x.tolist(), "w": self.w.tolist(),
                          "slope": self.slope.tolist()}}


class ContactSlices:
    """The reduced function with a rigid obstacle (or channel) at any N: banded Newton on slices.

    ``F(s0)`` is the energy's minimum over the slice ``B z = s0`` of the
    mixed variables of ``prog`` (a :class:`.fast_contact.FastContactProgram`,
    whose mixed form, amplitude rows ``B`` and admissible amplitude range
    are used as they are).  The amplitudes are fixed exactly, as by
    :class:`.fast.FastProgram`: each Newton step solves the banded KKT system
    bordered by the k rows of ``B`` (a Schur complement of size k), so that
    the gradient ``dF/ds = -nu`` is the multiplier of those rows from a
    linear solve.  The obstacle's rows are taken by the method of
    multipliers at the program's largest penalty (:mod:`gaocvx.contact_newton`),
    updated until no row is violated by more than ``FEASIBLE`` of the
    answer's size; at the inner minimiser with the multipliers ``lam`` the
    optimality conditions of the slice hold exactly with the updated
    multipliers ``max(0, lam - rho gap)``, so ``-nu`` is the gradient of
    the slice problem with the obstacle moved by at most that violation.

    (``prog.reduced`` solves the node problem on the degenerate box
    ``[s0, s0]`` instead and reads the gradient from the box rows'
    augmented-Lagrangian multipliers: their accuracy is the box penalty times
    the rows' last violation, measured 1e-5 of ``F'``'s range at 16 elements
    (untouched obstacle), against the dense programs' 1e-10; the amplitudes of
    its zeros were 1e-5 off and two of three stabilities wrong.)

    Parameters
    ----------
    prog : FastContactProgram
    energy_floor : float
        The scene's energy scale (non-dimensional, :func:`.minimum.scene_energy`):
        a violation whose work is round-off against it is harmless (:meth:`_violation`).

    Examples
    --------
    >>> from gaocvx.discrete import DiscreteProblem
    >>> from gaocvx.nonconvex.fast_contact import FastContactProgram
    >>> from gaocvx.nonconvex.modes import unstable_modes
    >>> from gaocvx.nonconvex.node import NodeProgram
    >>> from gaocvx import Scene
    >>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
    ...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
    ...     "load": {"q": -1e8, "axial": 1.5e9}, "obstacle": {"gap": 0.01},
    ...     "mesh": {"elements": 8}})
    >>> dp = DiscreteProblem(scene, check_convexity=False)
    >>> m = unstable_modes(dp)
    >>> F, dF, u, ok = ContactSlices(FastContactProgram(dp, m)).reduced([-2.0])
    >>> G, dG, _, _ = NodeProgram(dp, m).reduced([-2.0])    # the dense program agrees
    >>> ok, abs(F - G) < 1e-9 * abs(G), bool(abs(dF[0] - dG[0]) < 1e-7 * abs(dG[0]))
    (True, True, True)
    """

    def __init__(self, prog, energy_floor: float = 0.0):
        from ..contact_newton import RHO_START
        self.prog, self.k, self.mf, self.B = prog, prog.k, prog.mf, prog.B
        self.smin, self.smax = prog.smin, prog.smax
        self.rho_start, self.rho_max = min(RHO_START, prog.rho), prog.rho
        # Newton's tolerances relative to the energy, but not to less than that of an
        # answer of the certificate's floor size (a beam lying flat at gap 0 has
        # energy ~0), as FastContactProgram's
        self.floor = self.mf.zero_floor ** 2 if self.mf.has_load else 1.0
        self.energy_floor = float(energy_floor)
        self._cache = []   # (amplitudes, z, lam) of admissible slices: starts
        self.solves = 0

    def reduced(self, s0):
        """``F(s0)``, its gradient ``-nu``, the free Hermite DOFs and success.

        ``inf`` (and success) where no admissible beam has the amplitudes ``s0``
        (outside the program's amplitude range, or the multipliers' updates
        stall with the rows violated by more than ``ADMISSIBLE``).
        """
        from ..linalg import one_blas_thread
        from .fast_contact import ADMISSIBLE, FEASIBLE

        s0 = np.asarray(s0, float)
        self.solves += 1
        if np.any(s0 < self.smin) or np.any(s0 > self.smax):
            return math.inf, np.zeros(self.k), None, True
        target = s0 - self.prog.s_origin        # B z = s0 - s_origin (z from the origin)
        mf = self.mf
        starts = []
        if self._cache:
            # a neighbouring slice's answer at the largest penalty: its contact set
            # differs little
            near = min(self._cache, key=lambda e: float(np.sum((e[0] - s0) ** 2)))
            starts.append((near[1], near[2], near[3]))
        starts.append((-mf.origin, mf.no_contact_forces(), self.rho_start))
        best = None

        def rank(out):
            return (not (out[2] and out[4] <= FEASIBLE), out[4])
        with one_blas_thread():   # O(N) work: BLAS threads cost more than they do
            for z, lam, rho in starts:
                out = self._multipliers(target, z.copy(), lam.copy(), rho)
                # a converged feasible answer first, then the least violation (a
                # warm start that did not converge once left F' = +24 for -36 in
                # a Brent bracket: a false zero)
                if out is not None and (best is None or rank(out) < rank(best)):
                    best = out
                if best is not None and best[2] and best[4] <= FEASIBLE:
                    break
        if best is None or best[4] > ADMISSIBLE:
            return math.inf, np.zeros(self.k), None, True
        z, nu, converged, lam, violation, rho = best
        if violation <= FEASIBLE:
            self._cache.append((s0.copy(), z, lam, rho))
            del self._cache[:-64]
        F = float(sum(mf.energy_parts(z).values()))
        return F, -nu, mf.to_hermite(z), bool(converged and violation <= FEASIBLE)

    def _multipliers(self, target, z, lam, rho, updates=60, stall=5):
        """The method of multipliers on the slice; (z, nu, converged, lam, violation, rho) or None.

        When the violation stops halving at the program's largest penalty, the
        penalty is raised a thousandfold, once: where the beam lies flat
        on the obstacle next to a support, the active rows are linearly
        dependent and the multipliers drift instead of converging, the violation
        stuck at about a constant over the penalty (16 elements, P1 at gap 0:
        4e-12 at 1e10, 6e-17 at 1e13; the slope F' was 2e-6 off at the first,
        within 1e-8 of the dense program's at the second).  Stalled at the
        raised penalty, or with a violation far above round-off (1e-6 of the
        answer's size), the slice is taken as inadmissible.
        """
        from .fast_contact import FEASIBLE

        mf = self.mf
        history, out = [], None
        for _ in range(updates):
            z, nu, converged = self._newton(target, z, lam, rho)
            if not np.all(np.isfinite(z)):
                return out
            gap = mf.gap(z)
            lam = np.maximum(lam - rho * gap, 0.0)   # the slice's optimality holds with these
            if rho < self.rho_max:
                rho = min(1e3 * rho, self.rho_max)
                continue
            violation = self._violation(z, gap, lam)
            out = (z, nu, converged, lam, violation, rho)
            history.append(violation)
            if violation <= FEASIBLE:
                break   # (unconverged: more updates would not change the iterate)
            if len(history) > stall and history[-1] > 0.5 * history[-1 - stall]:
                # (a violation far above round-off is an inadmissible slice: no raise)
                if rho >= 1e3 * self.rho_max or violation > 1e-6:
                    break
                rho, history = 1e3 * rho, []
        return out

    def _violation(self, z, gap, lam) -> float:
        """The rows' largest violation relative to the answer's size, or less if harmless.

        Slices of tiny amplitude (a beam lifting off a flat contact: 1e-9 of the
        buckled size, at the certificate's floor size) stall at violations of
        1e-15 in absolute terms, round-off, but 1e-8 of their own size.  A
        violation moves the energy by at most the work ``lam'(-gap)^+`` of the
        forces on it: when that is at most 1e-13 of the energy scale (the
        energy, at least the scene's ``energy_floor``) it counts as
        ``FEASIBLE`` (and 1e-11 as ``ADMISSIBLE``: linearly in between).
        """
        from .fast_contact import FEASIBLE

        mf = self.mf
        over = np.maximum(-gap, 0.0)
        relative = float(np.max(over, initial=0.0)) / mf.deflection_size(z)
        scale = max(abs(sum(mf.energy_parts(z).values())), self.energy_floor)
        if scale <= 0.0:
            return relative
        work = float(lam @ over)
        return min(relative, FEASIBLE * work / (1e-13 * scale))

    def _newton(self, target, z, lam, rho, max_iter=60):
        """Damped semismooth Newton on the augmented Lagrangian over the slice.

        Returns ``z``, the multipliers ``nu`` of ``B z = target`` and convergence
        (the squared Newton decrement at round-off of the energy).
        """
        from .. import newton as nw

        mf, B, k = self.mf, self.B, self.k
        al = {"shift": lam, "rho": rho}
        nu, previous, full = np.zeros(k), math.inf, False
        for _ in range(max_iter):
            g, H = mf.gradient(z, **al), mf.hessian(z, **al)
            factor = mf.kkt_factor(H)
            try:
                r0, m0 = factor.solve(-g, -mf.link(z))
                cols = [factor.solve(B[i], np.zeros(mf.N)) for i in range(k)]
                X = np.column_stack([x for x, _ in cols])
                Xmu = np.column_stack([m for _, m in cols])
                nu = np.linalg.solve(B @ X, B @ r0 - (target - B @ z))
            except np.linalg.LinAlgError:
                return z, nu, False
            d, mu = r0 - X @ nu, m0 - Xmu @ nu
            on_slice = (np.linalg.norm(B @ z - target) <= 1e-12 * (1.0 + np.linalg.norm(target))
                        and np.linalg.norm(mf.link(z)) <= 1e-12 * (1.0 + np.linalg.norm(z)))
            if not on_slice:
                z = z + d   # the constraints are linear: one full step lands on them
                continue
            dec = float(d @ (H @ d))   # H is positive definite on the slice
            floor = max(abs(sum(mf.energy_parts(z).values())), self.floor)
            if abs(dec) <= 1e-20 * floor:
                return z, nu, True
            if abs(dec) <= 1e-16 * floor and abs(dec) > 0.01 * previous:
                return z, nu, True    # stagnated: round-off
            previous = abs(dec)
            # Along d the Lagrangian of the linear rows decreases (newton._newton):
            # C d and B d are round-off, the forces on them are not
            shift = float(mu @ (mf.C @ d)) + float(nu @ (B @ d))
            slope0 = float(g @ d) + shift
            dphi = mf.directional(z, d, **al)
            t = nw.line_search(lambda t: dphi(t) + shift, slope0)
            if t is None and not full:
                # No descent along d: the linear rows' residual (1e-11, against forces
                # of 1e3 at the end of a range) outweighs the decrement.  The full
                # step satisfies them to the solve's round-off; once.
                z, full = z + d, True
                continue
            if t is None:
                return z, nu, abs(dec) <= 1e-16 * floor
            z, full = z + t * d, False
        return z, nu, False


def _convex_equilibrium(scene, elements, dp) -> list:
    from ..solve import solve
    r = solve(scene, "global", elements=elements)
    return [Equilibrium(r.energy, True, [], r.x, r.w, r.slope, 0.0, r.status,
                        float(scene.load.axial))]


def equilibria(scene, elements: int | None = None, seeds=(), grid: int = GRID,
               fast: bool | None = None) -> list:
    """Every equilibrium of ``scene`` (k <= 2 unstable modes), sorted by energy.

    Parameters
    ----------
    scene : Scene
    elements : int, optional
        Overrides ``scene.mesh.elements``.
    seeds : sequence of float, optional
        Amplitudes [m] (:attr:`Equilibrium.amplitude_m`) to sample besides the
        grid: a path's previous equilibria.
    grid : int
        Grid points over the amplitude range.
    fast : bool, optional
        The reduced function through the banded Newton machinery
        (:class:`.fast.FastProgram`; with an obstacle or channel
        :class:`ContactSlices`; any mesh up to ``api.MAX_FAST_ELEMENTS``)
        instead of the dense CVXPY programs (:class:`.node.NodeProgram`, the
        ground truth, at most ``minimum.MAX_ELEMENTS``).  By default the fast
        path without an obstacle; with one the dense programs up to
        ``minimum.MAX_ELEMENTS`` elements and the fast path beyond.

    Returns
    -------
    list of Equilibrium

    Raises
    ------
    SceneError
        For scenes with more than two unstable modes, without a minimiser, or
        on too fine a mesh (above ``api.MAX_FAST_ELEMENTS`` elements, or above
        ``minimum.MAX_ELEMENTS`` with ``fast=False``).
    """
    from .api import MAX_FAST_ELEMENTS, provably_convex
    from .minimum import MAX_ELEMENTS, rescale_for, scene_energy
    from .modes import unstable_modes
    from .node import NodeProgram

    dp = DiscreteProblem(scene, elements=elements, check_convexity=False)
    if provably_convex(dp):
        return _convex_equilibrium(scene, elements, dp)
    check_bounded(dp)
    n_el = dp.n_nodes - 1
    obstacle = dp.contact == "obstacle"
    # With an obstacle (or a channel) the dense programs stay the default where
    # they serve (the ground truth), the fast path beyond them.
    fast = (not obstacle or n_el > MAX_ELEMENTS) if fast is None else bool(fast)
    cap = MAX_FAST_ELEMENTS if fast else MAX_ELEMENTS
    if n_el > cap:
        raise SceneError("mesh.elements", f"equilibria above the convexity limit take at most "
                         f"{MAX_FAST_ELEMENTS} elements (fast path; the dense programs, "
                         f"fast=False, at most {MAX_ELEMENTS})", n_el)
    modes = unstable_modes(dp)
    if modes.k == 0:
        modes = unstable_modes(dp, min_k=1)
    if modes.k > 2:
        raise SceneError("load.axial", f"P = {dp.P:.4g} N leaves {modes.k} unstable buckling "
                         "modes; equilibria are searched for one or two (P below the third "
                         f"mode load {float(modes.loads[2]):.4g} N)", dp.P)
    dp = rescale_for(dp, modes)
    if fast and obstacle:
        from .fast_contact import FastContactProgram
        prog = ContactSlices(FastContactProgram(dp, modes), scene_energy(dp, modes))
    elif fast:
        from .fast import FastProgram
        prog = FastProgram(dp, modes)
    else:
        prog = NodeProgram(dp, modes)
    # (with a bonded foundation the modes' lambda_1 is that of K + c M: no bound
    # of u'K u / t, so none is used; equilibrium_box counts the foundation itself)
    lam1 = 0.0 if getattr(dp, "bilateral", False) else float(modes.lam[0]) * (1.0 - 1e-9)
    S = float(equilibrium_box(dp, lam1))
    if modes.k == 2:
        from .stationary2 import find_plane
        return find_plane(dp, prog, S)
    lo, hi = -S, S
    if dp.contact == "obstacle":
        # The grid over the admissible amplitudes only: a channel of 2 mm in a scale
        # of 17 cm (the one-mode estimate's) left one grid point of 121 admissible
        # (s = 0), and two of three equilibria were missed.  The range is a linear
        # program's, its ends bounds by weak duality (:func:`.fast_check.amplitude_range`).
        # (the fast program computes it on construction: with it, the same program)
        from .fast_contact import FastContactProgram
        ranged = prog if fast else FastContactProgram(dp, modes)
        lo, hi = max(-S, float(ranged.smin[0])), min(S, float(ranged.smax[0]))
    return _find(dp, prog, S, np.asarray(seeds, float) / dp.W, grid, lo, hi,
                 scene_energy(dp, modes))


def _find(dp, prog, S, seeds, grid, lo, hi, floor):
    t0 = time.perf_counter()
    cache = {}

    def dF(s):
        if s not in cache:
            F, d, u, ok = prog.reduced([s])
            cache[s] = (F, float(d[0]), u, ok)
        return cache[s]

    inside = seeds[(seeds >= lo) & (seeds <= hi)]
    if lo <= 0.0 <= hi:   # the trivial equilibrium of an unloaded beam
        inside = np.r_[inside, 0.0]
    pts = np.union1d(np.linspace(lo, hi, grid), inside)
    vals = [(float(s), dF(float(s))) for s in pts]
    # An obstacle bounds the amplitudes (a beam lying flat on it has the smallest):
    # where the grid steps from infeasible to feasible, the boundary is found by
    # bisection and sampled just inside, else a beam pressed onto the obstacle
    # (a zero of F' right next to the boundary, where F' falls steeply) is missed.
    extra, ends = [], []
    for (a, va), (b, vb) in zip(vals[:-1], vals[1:]):
        if math.isfinite(va[0]) != math.isfinite(vb[0]):
            inside, outside = (b, a) if math.isfinite(vb[0]) else (a, b)
            for _ in range(40):
                mid = 0.5 * (inside + outside)
                # (an inaccurate solve counts as outside: at gap 0 the fast slices
                # accept a violation of 1e-9 as admissible but not accurate)
                if math.isfinite(dF(mid)[0]) and dF(mid)[3]:
                    inside = mid
                else:
                    outside = mid
            extra.append((inside, dF(inside)))
            ends.append((inside, outside))
    vals = sorted([(s, v) for s, v in vals + extra if math.isfinite(v[0])],
                  key=lambda item: item[0])
    if not vals:
        raise SceneError("scene", "no admissible amplitude of the buckling mode (no solve "
                         "succeeded)")
    scale = max(max(abs(v[0]) for _, v in vals), 1e-300)
    roots = []

    def refine(a, b):
        try:
            r = so.brentq(lambda s: dF(s)[1], a, b, xtol=1e-13 * S, rtol=1e-14, maxiter=200)
        except ValueError:
            return
        roots.append(r)

    for (s0, v0), (s1, v1) in zip(vals[:-1], vals[1:]):
        d0, d1 = v0[1], v1[1]
        if d0 == 0.0:
            roots.append(s0)
        elif d0 * d1 < 0:
            refine(s0, s1)
    if vals[-1][1][1] == 0.0:
        roots.append(vals[-1][0])
    # Two zeros between neighbouring grid points: F' has a local extremum near zero
    # there without changing sign at the grid.  Look for its extremum.
    d = np.array([v[1] for _, v in vals])
    s_arr = np.array([s for s, _ in vals])
    for i in range(1, len(d) - 1):
        if (d[i] - d[i - 1]) * (d[i + 1] - d[i]) < 0 and abs(d[i]) < 0.05 * np.max(np.abs(d)):
            sign = 1.0 if d[i] > 0 else -1.0
            res = so.minimize_scalar(lambda s: sign * dF(s)[1], bounds=(s_arr[i - 1], s_arr[i + 1]),
                                     method="bounded", options=dict(xatol=1e-12 * S))
            if sign * res.fun < 0:
                refine(s_arr[i - 1], res.x)
                refine(res.x, s_arr[i + 1])
    out = []
    # An end of the admissible amplitudes where F rises into the range (F' > 0 at
    # the lower end, < 0 at the upper) is a local minimum of F there, so of the
    # energy: every admissible beam nearby has amplitudes in the range.  A beam
    # pressed flat onto an obstacle at gap 0 is one (F(s) = 0.44 s at s >= 0 on 16
    # elements, P4): no zero of F' marks it.  Its residual is |F'| times the
    # bisection's bracket (the end lies in it).
    for inside, outside in ends:
        F, d0, u, ok = dF(inside)
        if u is None or not (d0 > 0 if outside < inside else d0 < 0):
            continue
        roots = [r for r in roots if abs(r - inside) > 1e-9 * S]
        w, slope = dp.to_physical(u)
        size = max(sum(abs(v) for v in dp.energy_parts(u).values()), floor) or scale
        res = abs(d0) * abs(outside - inside) / size
        status = "optimal" if ok and res <= ROOT_TOL else "inaccurate"
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), True, [float(inside)], dp.x.copy(),
                               w, slope, float(res), status, float(dp.P), math.nan, float(dp.W)))
    for r in sorted(set(roots)):
        if any(abs(r - e) <= 1e-9 * S for e in [q.amplitudes[0] for q in out]):
            continue
        F, d0, u, ok = dF(r)
        if u is None:   # (a slice that failed inside the range: no beam to report)
            log.warning("equilibria: no admissible slice at the zero s = %.17g", r)
            continue
        h = 1e-6 * S
        left, right = dF(r - h)[1], dF(r + h)[1]
        curvature = (right - left) / (2 * h)
        stable = right > 0 and left < 0 if (right - left) != 0 else curvature > 0
        w, slope = dp.to_physical(u)
        # |F'| times the amplitude: the work of the residual force, relative to
        # the equilibrium's energy scale (w = 0: the amplitude range's thousandth)
        # (at least the scene's own energy: a trivial equilibrium the dense
        # programs return as 1e-13 instead of 0 has energy parts of 1e-16, against
        # which any residual was too large)
        size = max(sum(abs(v) for v in dp.energy_parts(u).values()), floor) or scale
        res = abs(d0) * max(abs(r), 1e-3 * S) / size
        if res > ROOT_TOL:
            # A kink of F (the obstacle takes or releases the beam: a beam lying flat
            # at gap 0 between supports has F(s) = 0.55 |s| on 16 elements, P1): F'
            # jumps through zero (upwards: F is convex but for -c s^2) and |F'| at the
            # zero stays large.  The equilibrium lies between r - e and r + e when F'
            # changes sign there, and the energy within |F'| 2e of F(r).  (The
            # slices of amplitudes 1e-12 from a flat beam's are round-off: wider
            # windows after the narrowest.)
            for e in (1e-12 * S, 1e-10 * S, 1e-9 * S):
                a, b = dF(r - e), dF(r + e)
                if math.isfinite(a[0]) and math.isfinite(b[0]) and a[1] * b[1] < 0:
                    res = min(res, max(abs(a[1]), abs(b[1])) * 2 * e / size)
                    break
        status = "optimal" if ok and res <= ROOT_TOL else "inaccurate"
        out.append(Equilibrium(float(dp.energy(u) * dp.E0), bool(stable), [float(r)], dp.x.copy(),
                               w, slope, float(res), status, float(dp.P), float(curvature),
                               float(dp.W)))
    out.sort(key=lambda e: e.energy)
    log.info("equilibria: %d found with %d solves in %.2f s", len(out), len(cache),
             time.perf_counter() - t0)
    return out
