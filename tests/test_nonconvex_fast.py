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

from conftest import scene_dict
from independent import BeamProblem

from gaocvx import DiscreteProblem, Scene


def independent_pencil(scene):
    """K (with a bonded foundation's c M) and G of tests/independent.py, dense, free DOFs."""
    bp = BeamProblem(scene)
    n = bp.ndof
    K = np.zeros((n, n))
    G = np.zeros((n, n))
    np.add.at(K, (bp.dofs[:, :, None], bp.dofs[:, None, :]), np.asarray(bp.Ke, float))
    np.add.at(G, (bp.dofs[:, :, None], bp.dofs[:, None, :]), np.asarray(bp.Ge, float))
    return K[np.ix_(bp.free, bp.free)], G[np.ix_(bp.free, bp.free)]


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
    assert m.k == k and m.verified and m.checks["sturm"] == (k, k)
    assert np.allclose(m.lam, vals[:k], rtol=1e-10) and m.lam_next == pytest.approx(vals[k], rel=1e-10)
    # same modes up to sign (distinct eigenvalues), G-normalised in the independent G
    for i in range(k):
        cos = abs(vecs[:, i] @ G @ m.phi[:, i])
        assert cos == pytest.approx(1.0, abs=1e-10)
    # the margin added to c covers round-off only
    assert 0 <= m.delta <= 1e-12 * float(np.min(m.c))


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


def test_sparse_modes_on_fine_meshes_keep_the_continuum_eigenvalues():
    """At 2048 elements the Hermite forms lose N^4 eps; the Ritz values from first
    differences still give the continuum's pi^2 (P4), and 4 pi^2 and (2x)^2 with
    tan x = x (P1's antisymmetric mode) to 1e-9."""
    import scipy.optimize as so

    from gaocvx.nonconvex.modes import unstable_modes

    x = so.brentq(lambda t: math.tan(t) - t, 4.4, 4.6)
    for supports, axial, expected in (("P4", 1.3e9, [math.pi**2]),
                                      ("P1", 1.1e10, [4 * math.pi**2, (2 * x) ** 2])):
        dp = DiscreteProblem(Scene.from_dict(scene_dict(supports, q=-1e7, axial=axial,
                                                        elements=2048)), check_convexity=False)
        m = unstable_modes(dp)
        assert m.verified and m.k == len(expected)
        assert np.allclose(m.lam, expected, rtol=1e-9)
