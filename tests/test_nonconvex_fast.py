"""The global method's fast path at any N (issue 10): sparse modes, k <= 3, obstacles.

References come from outside the code under test: dense eigen-solves of the
independent matrices of tests/independent.py, the dense CVXPY + Clarabel
node programs (the ground truth), closed-form eigenvalues and optimality
conditions.
"""

import math

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from conftest import bed_scene_above_the_limit, scene_dict
from independent import BeamProblem

from gaocvx import DiscreteProblem, Scene


def independent_pencil(scene):
    """K (bending only: no foundation) and G of tests/independent.py, dense, free DOFs."""
    bp = BeamProblem(scene)
    n = bp.ndof
    K = np.zeros((n, n))
    G = np.zeros((n, n))
    np.add.at(K, (bp.dofs[:, :, None], bp.dofs[:, None, :]), np.asarray(bp.Ke, float))
    np.add.at(G, (bp.dofs[:, :, None], bp.dofs[:, None, :]), np.asarray(bp.Ge, float))
    return K[np.ix_(bp.free, bp.free)], G[np.ix_(bp.free, bp.free)]


def hermite_mass(scene):
    """The consistent mass matrix int N_i N_j of the cubic Hermite elements (closed
    form, h / 420 [...]), on the free DOFs of tests/independent.py."""
    bp = BeamProblem(scene)
    M = np.zeros((2 * (bp.ne + 1),) * 2)
    for e, h in enumerate(np.asarray(bp.h, float)):
        m = h / 420 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h**2, 13 * h, -3 * h**2],
                                [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h**2, -22 * h, 4 * h**2]])
        M[np.ix_(bp.dofs[e], bp.dofs[e])] += m
    return M[np.ix_(bp.free, bp.free)]


# --------------------------------------------------------------------- step 1: modes
@pytest.mark.parametrize("supports, axial, k", [("P4", 1.3e9, 1), ("P1", 1.1e10, 2),
                                                ("P3", 6e8, 1), ("P2", 1.5e10, 3)])
def test_sparse_modes_agree_with_a_dense_solve_of_the_independent_pencil(supports, axial, k):
    from gaocvx.nonconvex.modes import unstable_modes

    scene = Scene.from_dict(scene_dict(supports, q=-1e7, axial=axial, elements=48))
    dp = DiscreteProblem(scene, check_convexity=False)
    m = unstable_modes(dp, solver="sparse")
    K, G = independent_pencil(scene)
    vals, vecs = sla.eigh(K, G, subset_by_index=[0, k])
    assert m.k == k and m.verified and m.checks["sturm"] == k
    assert np.allclose(m.lam, vals[:k], rtol=1e-10) and m.lam_next == pytest.approx(vals[k], rel=1e-10)
    # same modes up to sign (distinct eigenvalues), G-normalised in the independent G
    for i in range(k):
        cos = abs(vecs[:, i] @ G @ m.phi[:, i])
        assert cos == pytest.approx(1.0, abs=1e-10)
    # the margin added to c covers round-off only: the allowance for that of the
    # residual's terms (modecheck.residual_gram, (1e3 N + N^2) eps of the largest
    # eigenvalue, k times, over gamma), 2.3e-8 of the smallest c here
    assert 0 <= m.delta <= 1e-7 * float(np.min(m.c))


def test_sturm_count_matches_the_eigenvalues_and_flags_a_missed_mode():
    from gaocvx.nonconvex.modecheck import concave_margin, count_below

    scene = Scene.from_dict(scene_dict("P1", q=-1e7, elements=16))
    K, G = independent_pencil(scene)
    vals = sla.eigh(K, G, eigvals_only=True)
    Ks, Gs = sp.csr_matrix(K), sp.csr_matrix(G)
    for sigma in (0.5 * vals[0], 0.5 * (vals[0] + vals[1]), 0.5 * (vals[4] + vals[5]),
                  1.01 * vals[-1]):
        assert count_below(Ks, Gs, sigma) == int(np.sum(vals < sigma))
    # a vector that is no eigenvector has a residual, and the margin grows with it
    _, vecs = sla.eigh(K, G, subset_by_index=[0, 1])
    bad = vecs[:, :1] + 1e-3 * vecs[:, 1:2]
    bad /= math.sqrt(float(bad[:, 0] @ G @ bad[:, 0]))
    lam = np.array([float(bad[:, 0] @ K @ bad[:, 0])])
    good_delta, good = concave_margin(Ks, Gs, vecs[:, :1], vals[:1], 1.2 * vals[0], vals[1])
    delta, info = concave_margin(Ks, Gs, bad, lam, 1.2 * vals[0], vals[1])
    assert info["residual"] > 1e-4 > 1e-8 > good["residual"] and delta > 1e6 * max(good_delta, 1e-30)
    # and it is enough: K - p G + 2 G phi (c + delta) phi' G is positive semidefinite
    p = 1.2 * vals[0]
    c = (p - lam[0]) / 2 + delta
    Gphi = G @ bad
    H = K - p * G + 2 * c * Gphi @ Gphi.T
    assert sla.eigh(H, G, eigvals_only=True, subset_by_index=[0, 0])[0] >= -1e-9 * vals[0]
    c0 = (p - lam[0]) / 2
    H0 = K - p * G + 2 * c0 * Gphi @ Gphi.T
    assert sla.eigh(H0, G, eigvals_only=True, subset_by_index=[0, 0])[0] < 0   # without it: not


@pytest.mark.parametrize("elements", [2048, 8192])
def test_sparse_modes_on_fine_meshes_keep_the_continuum_eigenvalues(elements):
    """At 2048 elements the Hermite forms lose N^4 eps; the Ritz values from first
    differences still give the continuum's pi^2 (P4), and 4 pi^2 and (2x)^2 with
    tan x = x (P1's antisymmetric mode), to 1e-8: the Ritz value's error is the square
    of the eigenvector's (measured 3e-5 at 2048 elements, from the Hermite solve).
    At 8192 the residual evaluated in the Hermite DOFs was 2e-3 of exact modes (its
    round-off alone), above the check's 1e-3, and the modes failed; from first
    differences and mixed solves (modecheck.residual_gram) they pass."""
    import scipy.optimize as so

    from gaocvx.nonconvex.modes import RESIDUAL_TOL, unstable_modes

    x = so.brentq(lambda t: math.tan(t) - t, 4.4, 4.6)
    for supports, axial, expected in (("P4", 1.3e9, [math.pi**2]),
                                      ("P1", 1.1e10, [4 * math.pi**2, (2 * x) ** 2])):
        dp = DiscreteProblem(Scene.from_dict(scene_dict(supports, q=-1e7, axial=axial,
                                                        elements=elements)),
                             check_convexity=False)
        m = unstable_modes(dp)
        assert m.verified and m.k == len(expected)
        assert m.checks["residual"] <= 0.5 * RESIDUAL_TOL and m.checks["sturm"] == m.k
        assert np.allclose(m.lam, expected, rtol=1e-8)
        assert 0 <= m.delta <= 1e-5 * float(np.min(m.c))


@pytest.mark.parametrize("supports, axial, foundation", [("P1", 1.1e10, None),
                                                         ("P2", 1.5e10, (1e11, 0.001))])
def test_residual_gram_from_first_differences_is_the_hermite_residuals(supports, axial,
                                                                       foundation):
    """R'K^-1 R of vectors that are no eigenvectors, from modecheck.residual_gram (forms
    from first differences and mixed solves, without R) against R formed from the
    independent pencil of tests/independent.py and a dense solve (exact enough at 24
    elements), a bonded foundation's c M included."""
    from gaocvx.nonconvex.modecheck import residual_gram

    d = scene_dict(supports, q=-1e7, axial=axial, elements=24)
    if foundation:
        d["foundation"] = {"kind": "bilateral", "stiffness": foundation[0], "gap": foundation[1]}
    scene = Scene.from_dict(d)
    dp = DiscreteProblem(scene, check_convexity=False)
    K, G = independent_pencil(scene)
    if foundation:
        # (tests/independent.py has no bonded foundation: its c M from the closed-form
        # Hermite mass matrix, with the problem's non-dimensional c)
        K = K + float(np.max(dp.c)) * hermite_mass(scene)
    vals, vecs = sla.eigh(K, G, subset_by_index=[0, 2])
    rng = np.random.default_rng(2)
    V = vecs[:, :2] + 1e-3 * vecs @ rng.standard_normal((3, 2))
    lam = np.array([float(V[:, i] @ K @ V[:, i] / (V[:, i] @ G @ V[:, i])) for i in range(2)])
    R = K @ V - G @ V * lam
    expected = R.T @ np.linalg.solve(K, R)
    M, Gr, noise = residual_gram(dp, V, lam)
    assert np.allclose(Gr, V.T @ G @ V, rtol=1e-12, atol=1e-12 * np.max(np.abs(Gr)))
    assert np.max(np.abs(expected)) > 1e-7 * np.max(lam)      # a residual to measure
    assert np.allclose(M, expected, rtol=1e-6, atol=1e-12 * np.max(lam))
    assert noise < 1e-3 * np.max(np.abs(expected))


# --------------------------------------------------------------------- step 2: k <= 5
def _programs(supports, axial, elements, **kw):
    from gaocvx.nonconvex.fast import FastProgram
    from gaocvx.nonconvex.minimum import rescale_for
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.node import NodeProgram

    dp = DiscreteProblem(Scene.from_dict(scene_dict(supports, axial=axial, elements=elements,
                                                    **kw)), check_convexity=False)
    m = unstable_modes(dp)
    dp = rescale_for(dp, m)
    return dp, m, FastProgram(dp, m), NodeProgram(dp, m)


def _slices_agree(fast, dense, k, rng, count=3):
    """The fast program's reduced values, gradients and Hessians at ``count`` random
    amplitudes agree with the dense program's (the Hessian with central differences
    of the dense gradient)."""
    for _ in range(count):
        s = rng.uniform(-2, 2, size=k)
        F1, g1, H1, u1, ok1 = fast.reduced_hessian(s)
        F0, g0, u0, ok0 = dense.reduced(s)
        assert ok0 and ok1
        assert F1 == pytest.approx(F0, rel=1e-9, abs=1e-9)
        assert np.allclose(g1, g0, rtol=1e-6, atol=1e-6 * np.max(np.abs(g0)))
        h = 1e-4
        Hd = np.column_stack([(dense.reduced(s + h * e)[1] - dense.reduced(s - h * e)[1]) / (2 * h)
                              for e in np.eye(k)])
        assert np.allclose(H1, Hd, rtol=1e-4, atol=1e-4 * np.max(np.abs(Hd)))


@pytest.mark.parametrize("supports, axial, k", [("P1", 1.1e10, 2), ("P2", 1.5e10, 3),
                                                ("P1", 3.5e10, 4), ("P4", 3.2e10, 5)])
def test_fast_node_values_gradients_and_hessians_agree_with_the_dense_programs(supports, axial, k):
    dp, m, fast, dense = _programs(supports, axial, 16, q=-5e7)
    assert m.k == k
    _slices_agree(fast, dense, k, np.random.default_rng(1))
    # node problems on boxes: each method's lower bound lies below the energy of the
    # other's minimiser (a beam with amplitudes in the box), and the relaxations'
    # values agree (they differ by the fast one's margin delta sum s_i^2 >= 0: its
    # Psi carries the c_i with delta, the dense one's A_rho the exact (p - lambda_i) / 2)
    for lo, hi in ((-2 * np.ones(k), 2 * np.ones(k)),
                   (np.r_[-3.0, -1.0, 0.5, -0.5, 0.0][:k], np.r_[-1.0, 1.0, 2.0, 0.5, 1.0][:k])):
        a, b = fast.solve_box(lo, hi), dense.solve_box(lo, hi)
        assert a.ok and b.ok
        scale = abs(b.value) + 1.0
        assert a.lower <= dp.energy(b.u) + 1e-12 * scale and b.lower <= dp.energy(a.u) + 1e-12 * scale
        assert a.value == pytest.approx(b.value, rel=1e-8, abs=1e-8)
        assert np.all(a.s >= lo) and np.all(a.s <= hi)


def test_a_box_that_cannot_close_stops_once_its_bound_is_known_well_enough():
    """A box whose value lies below the cutoff is split whatever its exact bound: its
    projected Newton stops once the bound is known to within the value's distance from
    the cutoff (EARLY of it), not to BOUND_TOL (P4 with five modes: about the same
    nodes in half the time, benchmarks/nonconvex.py early).  The bound stays a
    bound: below the box's minimum, solved fully."""
    from gaocvx.nonconvex import fast as fast_module

    dp, m, fast, dense = _programs("P4", 3.2e10, 16, q=-5e7)
    lo, hi = -2.0 * np.ones(m.k), 2.0 * np.ones(m.k)
    fast._s = None
    n0 = fast.solves
    full = fast.solve_box(lo, hi)
    full_solves = fast.solves - n0
    assert full.ok and full.value - full.lower <= 1e-12 * abs(full.value)
    cutoff = full.value + 0.5 * abs(full.value)       # far above: the box is split
    fast._s = None
    n0 = fast.solves
    early = fast.solve_box(lo, hi, cutoff=cutoff)
    early_solves = fast.solves - n0
    assert early.ok
    assert early.lower <= full.value + 1e-12 * abs(full.value)      # a bound still
    assert early_solves < full_solves, (early_solves, full_solves)
    assert early.value - early.lower <= fast_module.EARLY * (cutoff - early.value)


@pytest.mark.parametrize("supports, axial, k", [("P1", 1.1e10, 2), ("P4", 3.2e10, 5)])
def test_slices_by_the_whole_bordered_system_agree_with_the_dense_programs(supports, axial, k):
    """The fallback of a slice whose Schur complement fails (`_bordered_step`, sparse
    LU of the whole bordered system): the same values, gradients and Hessians."""
    dp, m, fast, dense = _programs(supports, axial, 16, q=-5e7)
    fast.bordered = True
    _slices_agree(fast, dense, k, np.random.default_rng(2))


def test_a_failed_banded_slice_hands_over_to_the_bordered_ones_for_a_while(monkeypatch):
    """After a banded slice fails, the bordered system solves the next BORDERED_SLICES
    slices, then the banded ones are tried again (a five-mode bonded bed had switched
    for good at its 40880th of 62914 slices: 50 s against 41 s), twice as long at
    every new failure; the answers stay the dense programs'."""
    from gaocvx.nonconvex import fast as fast_module

    monkeypatch.setattr(fast_module, "BORDERED_SLICES", 3, raising=False)
    dp, m, fast, dense = _programs("P1", 1.1e10, 16, q=-5e7)
    banded = fast_module.FastProgram._slice
    fail = {"left": 2}
    modes_used = []

    def slice_(self, s, z, max_iter=60):
        modes_used.append(self.bordered)
        if not self.bordered and fail["left"] and len(modes_used) in (1, 7):
            fail["left"] -= 1
            return z, np.zeros(self.k), np.full((self.k, self.k), np.nan), False
        return banded(self, s, z, max_iter)

    monkeypatch.setattr(fast_module.FastProgram, "_slice", slice_)
    fast = fast_module.FastProgram(dp, m)
    rng = np.random.default_rng(5)
    for _ in range(14):
        s = rng.uniform(-2.0, 2.0, size=m.k)
        F, dF, u, ok = fast.reduced(s)
        G, dG, _, _ = dense.reduced(s)
        assert ok and F == pytest.approx(G, rel=1e-9, abs=1e-9)
    # solve 1: banded, failed, bordered; 2-4 bordered; 5 banded; 6 banded, failed,
    # bordered; 7-12 bordered (twice as many); 13-14 banded
    B, T = False, True
    assert modes_used == [B, T, T, T, T, B, B, T] + [T] * 6 + [B, B]


@pytest.mark.slow
def test_slices_just_above_the_limit_on_a_fine_mesh_converge():
    """A helper's campaign (seed 9301, B2): P4 on a unilateral bed 3e-5 above the
    limit, 300 elements.  Every slice failed: the Hessian is nearly singular along
    the mode, and the Schur complement's step ``r0 - X nu`` (|r0| 1e11 times the
    step) cancelled to round-off; the answer was `inaccurate` at the node limit
    (4000 nodes, 72 s).  The slices fall back on the whole bordered system, and
    the answer passes the independent energy's checks (600 elements: 10 s, once
    124 s and `inaccurate`, is left to the campaign)."""
    from campaign import Case
    from nonconvex_campaign_support import run_case

    data = {"beam": {"model": "gao", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0, "supports": "P4"},
            "load": {"q": -1698.5420085720282, "axial": 1168037876.4997735},
            "mesh": {"elements": 300},
            "foundation": {"gap": 0.00015434084672528642, "stiffness": 16842158490.354544}}
    rec = run_case(Case(data, ("P4", "foundation", "near-limit"), "B2"), starts=4, seed=2)
    assert rec["status"] == "optimal" and not rec["violations"], rec
    assert rec["search_reached"]


def test_box_qp_is_exact_against_a_grid():
    from gaocvx.nonconvex.fast import box_qp

    rng = np.random.default_rng(0)
    grid = np.linspace(-1, 1, 41)
    for _ in range(5):
        M = rng.normal(size=(3, 3))
        H = M @ M.T + 0.1 * np.eye(3)
        g = rng.normal(size=3) * 3
        d = box_qp(H, g, -np.ones(3), np.ones(3))
        pts = np.stack(np.meshgrid(grid, grid, grid), -1).reshape(-1, 3)
        values = pts @ g + 0.5 * np.einsum("ij,jk,ik->i", pts, H, pts)
        assert np.all(np.abs(d) <= 1) and g @ d + 0.5 * d @ H @ d <= values.min() + 1e-12


def test_box_qp_meets_its_optimality_conditions_up_to_seven_modes():
    """The active-set box QP: feasible, and its KKT conditions hold (a bound's
    multiplier has the right sign, the gradient vanishes on free coordinates);
    its value is that of trying every face."""
    from gaocvx.nonconvex.slice_algebra import _box_qp_faces, box_qp

    rng = np.random.default_rng(7)
    for k in range(1, 8):
        for trial in range(60):
            M = rng.normal(size=(k, k))
            H = M @ M.T + 10.0 ** rng.uniform(-6, 1) * np.eye(k)
            g = rng.normal(size=k) * 10.0 ** rng.uniform(-3, 3)
            a, b = -10.0 ** rng.uniform(-3, 1, size=k), 10.0 ** rng.uniform(-3, 1, size=k)
            if trial % 3 == 0:
                a[: k // 2 + 1] = 0.0   # the current point on a face of its box
            d = box_qp(H, g, a, b)
            grad = g + H @ d
            size = np.abs(g).max() + np.abs(H).max() * np.abs(d).max()
            assert np.all(d >= a) and np.all(d <= b)
            at_lo, at_hi = d <= a, d >= b
            free = ~(at_lo | at_hi)
            assert np.all(np.abs(grad[free]) <= 1e-9 * size)
            assert np.all(grad[at_lo & ~at_hi] >= -1e-9 * size)
            assert np.all(grad[at_hi & ~at_lo] <= 1e-9 * size)
            if k <= 5:
                e = _box_qp_faces(H, g, a, b)
                value = g @ d + 0.5 * d @ H @ d
                assert value <= g @ e + 0.5 * e @ H @ e + 1e-12 * (abs(value) + size * np.abs(d).max())


@pytest.mark.parametrize("kw", [dict(supports="P1", q=-5e7, axial=1.1e10),
                                pytest.param(dict(supports="P1", q=0.0, axial=1.1e10),
                                             marks=pytest.mark.slow)])
def test_two_modes_fast_certified_minimum_equals_the_dense_one(kw):
    from gaocvx.nonconvex.minimum import solve_global

    out = {}
    for fast in (False, True):
        dp = DiscreteProblem(Scene.from_dict(scene_dict(elements=8, **kw)), check_convexity=False)
        dp, raw, info = solve_global(dp, fast=fast)
        assert raw["status"] == "optimal" and info["unstable_modes"] == 2
        out[fast] = (dp.to_physical(raw["u"])[0], info["lower_bound"],
                     sum(raw["mixed"].energy_parts(raw["z"]).values()) * dp.E0, info["unique"])
    (w0, lo0, e0, u0), (w1, lo1, e1, u1) = out[False], out[True]
    assert abs(e1 - e0) <= 1e-10 * abs(e0) and lo0 <= e1 and lo1 <= e0 and u0 == u1
    if u0:   # (mirror images may be reported in either order)
        assert np.max(np.abs(w1 - w0)) <= 1e-7 * np.max(np.abs(w0))


@pytest.mark.slow
def test_two_modes_on_a_fine_mesh_converge_like_h4():
    """P1 with two unstable modes at 256 and 1024 elements (fast path, beyond the dense
    programs) against 64: the certified energies' differences fall like h^4."""
    from gaocvx import solve

    energies = []
    for n in (64, 256, 1024):
        r = solve(Scene.from_dict(scene_dict("P1", q=-5e7, axial=1.1e10, elements=n)))
        assert r.method == "global" and r.status == "optimal", r.message
        assert r.extra["global"]["unstable_modes"] == 2
        energies.append(r.energy)
    ref = solve(Scene.from_dict(scene_dict("P1", q=-5e7, axial=1.1e10, elements=16))).energy
    d = np.abs(np.diff([ref] + energies))
    assert np.all(d[1:] <= d[:-1] / 100), d


def test_sparse_modes_stop_when_every_computed_mode_is_unstable():
    """An axial force 1e4 times the limit (units typed wrong): the sparse solve returns
    at most n - 2 values, and the count doubled for ever (found by a review)."""
    from gaocvx.nonconvex.modes import unstable_modes
    limit = DiscreteProblem(Scene.from_dict(scene_dict(elements=4))).P_bar_h
    dp = DiscreteProblem(Scene.from_dict(scene_dict(elements=4, axial=1e4 * limit)),
                         check_convexity=False)
    assert unstable_modes(dp).k == dp.n                       # dense: every mode unstable
    assert unstable_modes(dp, solver="sparse").k > 3          # enough to refuse; it returns


def test_a_node_started_at_a_box_corner_reaches_its_minimum():
    """P1 at 3 P_bar_h on a unilateral bed, 256 elements (k = 2), the box
    [-1.92, 0] x [0, 1.92] of non-dimensional amplitudes: the full projected Newton
    step from the corner (-1.92, 1.92) has a slice solve that fails, and the node
    ended there, its value 51.8 against its bound -763.6 (a valid bound, 6.5 times
    looser than it could be).  The failed trial is now a step too long.  Started
    anywhere, the node program (a convex minimisation) reaches one minimum, each
    bound below every start's value, and its value within 1e-5 of its bound."""
    from gaocvx.nonconvex.fast import FastProgram
    from gaocvx.nonconvex.minimum import rescale_for
    from gaocvx.nonconvex.modes import unstable_modes

    data = bed_scene_above_the_limit()
    dp = DiscreteProblem(Scene.from_dict(data), check_convexity=False)
    modes = unstable_modes(dp)
    assert modes.k == 2
    prog = FastProgram(rescale_for(dp, modes), modes)
    lo, hi = np.array([-1.92382523, 0.0]), np.array([0.0, 1.92382523])
    sols = []
    for start in ([-1.92382523, 1.92382523], [0.0, 0.0], [-1.92382523, 0.0], [0.0, 1.92382523]):
        prog._s = np.array(start)   # the warm start the next node takes
        sols.append(prog.solve_box(lo, hi))
    values = np.array([s.value for s in sols])
    assert np.ptp(values) <= 1e-8 * np.max(np.abs(values)), values
    # (to the values' round-off: they differ by 1e-11 of themselves, energies whose
    # parts cancel; the branch and bound aims at 1e-11 of the parts' sum)
    assert max(s.lower for s in sols) <= np.min(values) + 1e-10 * np.max(np.abs(values))
    assert all(s.value - s.lower <= 1e-5 * abs(s.value) for s in sols), \
        [(s.value, s.lower) for s in sols]
