"""The admissible amplitudes of two modes with an obstacle (gaocvx.nonconvex.polygon).

References from outside the code under test: zonotopes (the projections of a
cube), whose vertices are the hull of the cube's projected corners; on a
channel scene, beams that respect the channel drawn at random (their
amplitudes from the definition ``s = ((G Phi)'Phi)^-1 (G Phi)'u``), and the
two programs' polygons against each other.
"""

import itertools

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import linprog
from scipy.spatial import ConvexHull

from gaocvx import Scene
from gaocvx.discrete import DiscreteProblem
from gaocvx.nonconvex.fast_check import lp_min
from gaocvx.nonconvex.fast_contact import FastContactProgram
from gaocvx.nonconvex.modes import unstable_modes
from gaocvx.nonconvex.node import NodeProgram
from gaocvx.nonconvex.polygon import Polygon, admissible_polygon, program_polygon


def _zonotope(D, lo, hi):
    m = D.shape[1]
    A_ub = sp.vstack([sp.eye(m), -sp.eye(m), sp.csr_matrix(D), sp.csr_matrix(-D)]).tocsr()
    b_ub = np.r_[np.ones(2 * m), hi, -np.asarray(lo)]

    def support(n):
        bound, z = lp_min(-(n @ D), A_ub, b_ub, sp.csr_matrix((0, m)), np.zeros(0))
        return -bound, (None if z is None else D @ z)

    corners = np.array([D @ np.array(v) for v in itertools.product([-1.0, 1.0], repeat=m)])
    return support, corners


@pytest.mark.parametrize("seed", range(6))
def test_a_zonotopes_polygon_is_its_hull(seed):
    rng = np.random.default_rng(seed)
    D = rng.normal(size=(2, 3 + seed % 3))
    support, corners = _zonotope(D, [-50.0, -50.0], [50.0, 50.0])
    exact = corners[ConvexHull(corners).vertices]
    poly = admissible_polygon(support, [-50.0, -50.0], [50.0, 50.0])
    size = float(np.max(np.abs(corners)))
    # the inner polygon's vertices are the hull's, and the outer polygon holds them
    assert len(poly.vertices) == len(exact)
    for v in exact:
        assert np.min(np.linalg.norm(poly.vertices - v, axis=1)) < 1e-9 * size
    assert not poly.outside(exact * (1.0 - 1e-9)).any()
    # points just beyond a vertex or an edge's middle are outside, just inside them not
    centre = exact.mean(axis=0)
    mids = 0.5 * (exact + np.roll(exact, -1, axis=0))
    for p in np.r_[exact, mids]:
        assert poly.outside(centre + (1.0 + 1e-6) * (p - centre))[0]
        inner = centre + (1.0 - 1e-6) * (p - centre)
        assert not poly.outside(inner)[0] and poly.within(inner)


def test_a_box_cuts_the_polygon():
    support, corners = _zonotope(np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]]), [-1.0, -5.0],
                                 [0.5, 5.0])
    poly = admissible_polygon(support, [-1.0, -5.0], [0.5, 5.0])
    assert poly.vertices[:, 0].min() == pytest.approx(-1.0, abs=1e-9)
    assert poly.vertices[:, 0].max() == pytest.approx(0.5, abs=1e-9)
    assert poly.outside([[0.51, 0.0], [-1.01, 0.0], [0.0, 2.1]]).all()


def test_clipping_and_projecting():
    # the unit square cut by s1 + s2 <= 1.5
    poly = Polygon([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [2 ** -0.5, 2 ** -0.5]],
                   [1.0, 1.0, 0.0, 0.0, 1.5 * 2 ** -0.5],
                   [[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 1.0]])
    part = poly.clip(0.5, 2.0, 0.5, 2.0)
    assert ConvexHull(part).volume == pytest.approx(0.125)      # the triangle left
    assert not len(poly.clip(2.0, 3.0, 2.0, 3.0))
    assert np.allclose(poly.onto(np.array([2.0, 2.0])), [0.75, 0.75])
    assert np.allclose(poly.onto(np.array([2.0, 0.5])), [1.0, 0.5])
    p = poly.inwards(poly.onto(np.array([2.0, 2.0])), 1e-9)
    assert poly.within(p) and np.linalg.norm(p - [0.75, 0.75]) < 1e-9
    assert np.allclose(poly.onto(np.array([0.3, 0.4])), [0.3, 0.4])
    assert poly.rim_points(0.5, 2.0, 0.5, 2.0) == [(1.0, 0.5), (0.5, 1.0)] or \
        sorted(poly.rim_points(0.5, 2.0, 0.5, 2.0)) == [(0.5, 1.0), (1.0, 0.5)]
    assert poly.beyond([[2.0, 2.0], [3.0, 2.0]]) and not poly.beyond([[2.0, 2.0], [0.5, 0.5]])


CHANNEL = {"beam": {"model": "gao", "supports": "P1", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                    "half_thickness": 0.1, "width": 1.0},
           "load": {"axial": 1.1e10}, "obstacle": {"gap": 0.0005, "gap_above": 0.001},
           "mesh": {"elements": 8}}


def test_a_channels_polygon_holds_every_admissible_beams_amplitudes():
    dp = DiscreteProblem(Scene.from_dict(CHANNEL), check_convexity=False)
    modes = unstable_modes(dp)
    assert modes.k == 2
    dense = NodeProgram(dp, modes)
    lo, hi = np.array([-50.0, -50.0]), np.array([50.0, 50.0])
    poly = program_polygon(dense, lo, hi)
    fast = program_polygon(FastContactProgram(dp, modes), lo, hi)
    size = float(np.max(np.abs(poly.vertices)))
    # (the two programs' rows are the same obstacle)
    assert not poly.outside(fast.vertices * (1 - 1e-6)).any()
    assert not fast.outside(poly.vertices * (1 - 1e-6)).any()
    # a bounded polygon: the channel holds the modes' amplitudes
    assert size < 50.0 and len(poly.vertices) >= 8
    # beams respecting the channel, at random: inside the outer polygon, and
    # reaching near its rim
    rows, levels = dense.rows, dense.levels
    GPhi, Phi = np.asarray(dp.G @ modes.phi), modes.phi
    rng = np.random.default_rng(3)
    for k in range(400):
        # the modes' combinations (half of them with noise), as far as the channel lets them
        u = Phi @ rng.normal(size=2) + (k % 2) * 0.1 * rng.normal(size=dp.n) * np.abs(Phi).max()
        r = rows @ u
        u *= np.min(levels[r < 0] / r[r < 0])     # the largest multiple inside the channel
        assert np.all(rows @ u >= levels - 1e-12)
        s = np.linalg.solve(GPhi.T @ Phi, GPhi.T @ u)
        assert not poly.outside(s)[0]
    # and the inner polygon's vertices are amplitudes of beams in the channel, points
    # just beyond them are not (feasibility programs in the beam's own variables)
    D = np.linalg.solve(GPhi.T @ Phi, GPhi.T)
    centre = poly.vertices.mean(axis=0)
    for v in poly.vertices:
        for f, feasible in ((1.0 - 1e-7, True), (1.0 + 1e-5, False)):
            res = linprog(np.zeros(dp.n), A_ub=-rows, b_ub=-levels, A_eq=D,
                          b_eq=centre + f * (v - centre), bounds=(None, None))
            assert (res.status == 0) == feasible
