"""Newton and the convex program reach the same minimiser on every scene kind."""

import numpy as np
import pytest

from conftest import scene_dict
from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.solve import choose_method

KINDS = {
    "uniform": dict(q=-5e7),
    "points": dict(q=None, points=[(0.25, -5e7), (0.6, 3e7)]),
    "table": dict(q=[[0.0, 0.0], [0.25, 5e7], [0.75, -1.7e7], [1.0, 0.0]]),
    "foundation": dict(q=-5e8, foundation=(0.007, 5e8)),
    "stiff-foundation": dict(q=-5e8, points=[(0.4, -1e8)], foundation=(0.002, 1e12)),
}


@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
@pytest.mark.parametrize("model", ["gao", "euler-bernoulli"])
@pytest.mark.parametrize("kind", sorted(KINDS))
@pytest.mark.parametrize("axial_fraction", [0.0, -0.5, 0.6])
def test_newton_matches_convex(supports, model, kind, axial_fraction):
    args = dict(KINDS[kind])
    if supports == "P3" and "foundation" in args:
        args["q"] = -5e7
        args["foundation"] = (0.02, args["foundation"][1])
    probe = DiscreteProblem(Scene.from_dict(scene_dict(supports, model, elements=16, **args)))
    scene = Scene.from_dict(scene_dict(supports, model, elements=16,
                                       axial=axial_fraction * probe.P_bar_h, **args))
    a = solve(scene, "newton")
    b = solve(scene, "convex")
    assert a.success, a.message
    assert b.success, b.message
    scale = np.abs(b.w).max()
    assert np.abs(a.w - b.w).max() <= 1e-6 * scale
    assert a.energy == pytest.approx(b.energy, rel=1e-8, abs=1e-10 * abs(b.energy_parts["load"]))
    assert a.zones == b.zones or kind == "stiff-foundation"


def test_auto_picks_the_cheapest_exact_method():
    eb = Scene.from_dict(scene_dict("P4", "euler-bernoulli"))
    r = solve(eb)
    assert r.method == "newton" and r.nit == 1 and "one banded Cholesky" in r.message
    assert choose_method(Scene.from_dict(scene_dict(obstacle=0.01))) == "convex"
    assert choose_method(Scene.from_dict(scene_dict(foundation=(0.01, 1e9)))) == "newton"


def test_newton_converges_quadratically_with_gao():
    scene = Scene.from_dict(scene_dict("P3", "gao", q=-1e8))
    r = solve(scene, "newton")
    assert r.success and r.nit <= 8
    assert r.residual["stationarity"] < 1e-9


def test_newton_refuses_obstacle():
    from gaocvx import SceneError
    with pytest.raises(SceneError, match="^solve.method"):
        solve(Scene.from_dict(scene_dict(obstacle=0.01)), "newton")


@pytest.mark.parametrize("method", ["newton", "convex"])
def test_degenerate_scenes(method):
    """No free DOF (one clamped-clamped element) and no load: w = 0, status optimal."""
    r = solve(Scene.from_dict(scene_dict("P1", elements=1)), method)
    assert r.success and r.P_bar == np.inf and np.all(r.w == 0) and r.energy == 0
    r = solve(Scene.from_dict(scene_dict("P4", q=None)), method)
    assert r.success and np.all(r.w == 0)
