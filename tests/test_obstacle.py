"""Rigid obstacle (Signorini): closed forms, optimality conditions, and the k_F -> inf limit."""

import numpy as np
import pytest

from conftest import EI_THESIS, compressed_scene, scene_dict
from exact import ExactBeam
from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.mixed import MixedForm


@pytest.mark.parametrize("supports, factor", [("P4", 48.0), ("P1", 192.0)])
@pytest.mark.parametrize("solver", ["clarabel", "osqp"])
def test_point_contact_closed_form(supports, factor, solver):
    """A centre point load presses the beam onto the obstacle at midspan only.

    The midspan deflection is (F + R) L^3 / (factor EI) = -gap, so the
    reaction is R = -F - factor EI gap / L^3 and the shape is that of the
    free beam under F + R.
    """
    F, gap = -4e7, 1e-3
    R = -F - factor * EI_THESIS * gap
    assert R > 0
    d = scene_dict(supports, "euler-bernoulli", q=None, points=[(0.5, F)], obstacle=gap,
                   elements=16)
    result = solve(Scene.from_dict(d), "convex", solver=solver)
    assert result.success, result.message
    exact = ExactBeam(supports, 1.0, EI_THESIS, 0.0, [(0.5, F + R)])
    assert np.abs(result.w - exact(result.x)).max() <= 1e-6 * gap
    mid = int(np.argmin(np.abs(result.x - 0.5)))
    assert result.reaction[mid] == pytest.approx(R, rel=1e-5)
    others = np.delete(result.reaction, mid)
    assert np.abs(others).max() <= 1e-6 * R
    assert result.zones == [[0.5, 0.5]]


@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
@pytest.mark.parametrize("model", ["gao", "euler-bernoulli"])
def test_optimality_conditions(supports, model):
    """w >= g, reaction >= 0, reaction = 0 where the beam is clear, complementarity."""
    q = -5e7 if supports == "P3" else -5e8
    gap = 0.02 if supports == "P3" else 0.007
    scene = Scene.from_dict(scene_dict(supports, model, q=q, points=[(0.7, -2e7)], obstacle=gap))
    result = solve(scene, "convex")
    assert result.success, result.message
    dp = DiscreteProblem(scene)
    W = dp.W
    # Feasibility at the nodes and at the Gauss points between them.
    assert result.w.min() >= -gap - 1e-7 * W
    points = MixedForm(dp).con_points * scene.beam.length
    assert np.min(result.deflection(points)) >= -gap - 1e-7 * W
    assert result.reaction.min() >= -1e-7 * np.abs(result.reaction).max()
    # The load reaches the obstacle.  (Zones list nodes in contact; a cubic
    # element may touch the obstacle between its nodes only, so check the reaction.)
    assert result.reaction.max() > 0
    # Reaction vanishes at nodes whose neighbouring elements stay clear of the obstacle.
    xs = np.linspace(0, 1, 2001)
    clear = result.deflection(xs) > -gap + 1e-6 * W
    for i, xi in enumerate(result.x):
        lo, hi = result.x[max(i - 1, 0)], result.x[min(i + 1, len(result.x) - 1)]
        near = (xs >= lo) & (xs <= hi)
        if clear[near].all():
            assert abs(result.reaction[i]) <= 1e-6 * np.abs(result.reaction).max()
    assert result.residual["complementarity"] <= 1e-7


def test_foundation_tends_to_obstacle():
    """Remark 2.5: as k_F grows the foundation solution approaches the obstacle solution."""
    base = dict(supports="P1", model="gao", q=-5e8)
    obstacle = solve(Scene.from_dict(scene_dict(**base, obstacle=0.007)), "convex")
    dists, energies = [], []
    for k in (1e10, 1e12, 1e14, 1e16):
        r = solve(Scene.from_dict(scene_dict(**base, foundation=(0.007, k))), "convex")
        assert r.success, r.message
        dists.append(np.abs(r.w - obstacle.w).max() / np.abs(obstacle.w).max())
        energies.append(r.energy)
    assert all(a > b for a, b in zip(dists, dists[1:])), dists
    assert dists[-1] < 1e-3
    # The obstacle's energy bounds the foundation's from above (K is smaller than V),
    # and the foundation's energy increases with k_F.
    assert all(e < obstacle.energy for e in energies)
    assert all(a < b for a, b in zip(energies, energies[1:]))
    assert energies[-1] == pytest.approx(obstacle.energy, rel=1e-4)


def test_eb_obstacle_two_solvers_agree():
    d = scene_dict("P2", "euler-bernoulli", q=-5e8, points=[(0.3, 1e7)], obstacle=0.007)
    a = solve(Scene.from_dict(d), "convex", solver="clarabel")
    b = solve(Scene.from_dict(d), "convex", solver="osqp")
    assert a.success and b.success
    assert np.abs(a.w - b.w).max() <= 1e-6 * np.abs(a.w).max()
    assert np.abs(a.reaction - b.reaction).max() <= 1e-4 * np.abs(a.reaction).max()
    assert a.zones == b.zones


def test_flat_contact_zone():
    """A simply supported beam pressed flat onto the obstacle: a zone of nodes at w = g."""
    scene = Scene.from_dict(scene_dict("P4", "euler-bernoulli", q=-5e8, obstacle=0.007))
    result = solve(scene, "convex")
    assert result.success
    (a, b), = result.zones
    assert a < 0.5 < b and a + b == pytest.approx(1.0)
    inside = (result.x >= a) & (result.x <= b)
    assert np.allclose(result.w[inside], -0.007, atol=1e-9)
    assert np.all(result.w[~inside] > -0.007)
    # Rigid contact concentrates forces at the zone's ends (physics.md).
    ends = [int(np.argmin(abs(result.x - a))), int(np.argmin(abs(result.x - b)))]
    assert result.reaction[ends].min() > result.reaction[inside].mean()


def test_gap_zero_obstacle():
    """A beam pushed down onto an obstacle at its own level stays at w = 0 and the
    obstacle carries the whole load; pushed up, it leaves the obstacle (supports alone
    do not count as contact)."""
    down = solve(Scene.from_dict(scene_dict("P4", q=-5e7, obstacle=0.0)), "newton")
    assert down.success and down.zones == [[0.0, 1.0]]
    assert np.abs(down.w).max() < 1e-15
    # Clarabel leaves curvature noise of ~1e-9 of the unsupported answer on a beam
    # lying flat at w = 0: measured against the answer itself, that is not certified.
    convex = solve(Scene.from_dict(scene_dict("P4", q=-5e7, obstacle=0.0)), "convex")
    assert convex.status == "inaccurate" and np.abs(convex.w).max() < 1e-9
    up = solve(Scene.from_dict(scene_dict("P3", q=5e7, obstacle=0.0)), "convex")
    assert up.success and up.zones == [] and up.w.min() >= 0.0


@pytest.mark.parametrize("elements", [1024, 2048])
@pytest.mark.parametrize("kind", ["point contact", "flat contact"])
def test_clarabel_certifies_fine_meshes(elements, kind):
    """Fine meshes: a node in contact and the Gauss points 0.047 h beside it.

    Their nearly parallel constraint rows left Clarabel's answers from 1024
    elements on with complementarity ~1e-10 (not certified); the answers
    must now be certified and agree with the method of multipliers.  The flat
    contact at 2048 elements was not certified while Clarabel equilibrated the
    program (stationarity 1.9e-6; gaocvx.convex.CLARABEL_LADDER).
    """
    supports, q = ("P1", -5e8) if kind == "point contact" else ("P4", -5e8)
    scene = Scene.from_dict(scene_dict(supports, "gao", q=q, obstacle=0.007, elements=elements))
    a, b = solve(scene, "convex"), solve(scene, "newton")
    assert b.success, b.message
    assert a.success, a.message
    assert np.abs(a.w - b.w).max() <= 1e-7 * np.abs(b.w).max()
    assert a.zones == b.zones


def test_clarabel_ladder_settings_do_not_leak():
    """A cantilever lifted off an obstacle under compression: the first rung of the
    ladder (static regularisation 1e-12) fails, and the next rungs must run with
    their own settings (CVXPY kept the first rung's for later solves of the
    same problem, so every rung failed)."""
    scene = compressed_scene(0.5, "P3", "euler-bernoulli", q=100.0, points=[(0.25, 0.0)],
                             elements=10, obstacle=0.0)
    a, b = solve(scene, "convex"), solve(scene, "newton")
    assert a.success and b.success, a.message
    assert np.abs(a.w - b.w).max() <= 1e-7 * np.abs(b.w).max()


@pytest.mark.parametrize("contact", ["foundation", "obstacle"])
def test_no_load_is_exactly_zero(contact):
    """No load: every energy term is >= 0 and vanishes at w = 0 (also under compression)."""
    extra = dict(foundation=(0.03, 1e10)) if contact == "foundation" else dict(obstacle=0.0)
    scene = compressed_scene(0.5, "P1", "euler-bernoulli", q=0.0, elements=10, **extra)
    for method in ("convex", "newton"):
        r = solve(scene, method)
        assert r.success and np.abs(r.w).max() == 0.0, (method, r.message)
