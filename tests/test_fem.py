"""Hermite elements: the closed-form element matrices against quadrature, loads, symmetry."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st

from gaocvx import fem
from gaocvx.linalg import BandedCholesky


meshes = st.lists(st.floats(0.05, 1.0), min_size=1, max_size=12).map(
    lambda h: np.concatenate([[0.0], np.cumsum(h)]))


def quadrature_matrix(x, deriv):
    """∫ N^(d) N^(d) by 4-point Gauss: an independent path to K (d=2) and G (d=1)."""
    xq, wq, e = fem.gauss_points(x, 4)
    B = fem.eval_matrix(x, xq, deriv, e)
    return (B.T @ sp.diags(wq) @ B).toarray()


@settings(max_examples=50, deadline=None)
@given(meshes)
def test_element_matrices_match_quadrature(x):
    assert np.allclose(fem.stiffness_matrix(x).toarray(), quadrature_matrix(x, 2), rtol=1e-10,
                       atol=1e-8 * np.abs(quadrature_matrix(x, 2)).max())
    assert np.allclose(fem.geometric_matrix(x).toarray(), quadrature_matrix(x, 1), rtol=1e-10,
                       atol=1e-10 * np.abs(quadrature_matrix(x, 1)).max())


@settings(max_examples=50, deadline=None)
@given(meshes, st.sampled_from(["P1", "P2", "P3", "P4"]))
def test_matrices_symmetric_definite_on_free_dofs(x, supports):
    if supports == "P1" and len(x) < 3:
        x = np.array([0.0, 0.5 * x[-1], x[-1]])  # clamped-clamped needs an interior node
    free = fem.free_dofs(len(x), supports)
    for M in (fem.stiffness_matrix(x), fem.geometric_matrix(x)):
        A = M[free][:, free]
        assert abs(A - A.T).max() <= 1e-12 * abs(A).max()
        BandedCholesky(A)  # raises if not positive definite
    # Rigid motions are in the kernel of the full K.
    K = fem.stiffness_matrix(x)
    rigid = np.zeros(2 * len(x))
    rigid[0::2] = 0.3 + 0.7 * x
    rigid[1::2] = 0.7
    assert np.abs(K @ rigid).max() <= 1e-9 * abs(K).max()


def test_load_vector_matches_formula_3_29():
    x = np.array([0.0, 0.4])
    q1, q2 = 3.0, -5.0
    h = 0.4
    expected = h * np.array([7 * q1 / 20 + 3 * q2 / 20, (q1 / 20 + q2 / 30) * h,
                             3 * q1 / 20 + 7 * q2 / 20, -(q1 / 30 + q2 / 20) * h])
    assert np.allclose(fem.load_vector(x, [[0.0, q1], [0.4, q2]]), expected)
    assert np.allclose(fem.load_vector(x, 2.0), fem.load_vector(x, [[0.0, 2.0], [0.4, 2.0]]))


@settings(max_examples=40, deadline=None)
@given(meshes, st.lists(st.tuples(st.floats(0, 1), st.floats(-5, 5)), min_size=2, max_size=6,
                        unique_by=lambda r: round(r[0], 6)))
def test_table_load_resultants_are_exact(x, rows):
    """Total force and moment of a piecewise-linear table load are integrated exactly."""
    L = x[-1]
    table = sorted((r[0] * L, r[1]) for r in rows)
    if any(b[0] - a[0] < 1e-9 for a, b in zip(table, table[1:])):
        return
    f = fem.load_vector(x, table)
    t = np.array(table)
    force = np.trapezoid(t[:, 1], t[:, 0])
    # Moment about 0 of a piecewise-linear load: exact by Simpson on each piece.
    xm = 0.5 * (t[1:, 0] + t[:-1, 0])
    qm = 0.5 * (t[1:, 1] + t[:-1, 1])
    dx = np.diff(t[:, 0])
    moment = np.sum(dx / 6 * (t[:-1, 0] * t[:-1, 1] + 4 * xm * qm + t[1:, 0] * t[1:, 1]))
    rigid_w = np.zeros_like(f)
    rigid_w[0::2] = 1.0
    rot = np.zeros_like(f)
    rot[0::2], rot[1::2] = x, 1.0
    assert f @ rigid_w == pytest.approx(force, abs=1e-9)
    assert f @ rot == pytest.approx(moment, abs=1e-9)


def test_point_forces_get_nodes():
    x = fem.uniform_nodes_with_points(1.0, 4, [0.3, 0.4, 0.25 + 1e-15, 1.0])
    assert {0.3, 0.4, 0.25}.issubset(set(np.round(x, 12)))
    # 0.25+1e-15 holds node 0.25, so 0.3 cannot move it and is inserted; 0.4 is
    # more than a quarter element from 0.5 and is inserted too.
    assert len(x) == 7
    assert fem.uniform_nodes_with_points(1.0, 4, [0.3]).tolist() == [0.0, 0.3, 0.5, 0.75, 1.0]
    f = fem.point_load_vector(x, [(0.4, 2.0)])
    i = int(np.flatnonzero(np.isclose(x, 0.4))[0])
    assert f[2 * i] == pytest.approx(2.0) and np.count_nonzero(np.abs(f) > 1e-14) == 1


def test_shape_functions_interpolate():
    x = np.array([0.0, 0.3, 1.0])
    pts = np.linspace(0, 1, 17)
    dofs = np.zeros(6)
    # The cubic p(s) = s^3 - s is reproduced exactly, with its derivatives.
    dofs[0::2] = x**3 - x
    dofs[1::2] = 3 * x**2 - 1
    for d, ref in enumerate([pts**3 - pts, 3 * pts**2 - 1, 6 * pts, 6 + 0 * pts]):
        assert np.allclose(fem.eval_matrix(x, pts, d) @ dofs, ref)
