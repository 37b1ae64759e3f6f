"""Reuse across the scenes of a sweep: the parametric convex program and shared mesh structures.

Every reused solve must give the answer of a solve from scratch (and of Newton);
a scene the compiled program cannot represent must get a program of its own.
"""

import numpy as np
import pytest

from conftest import scene_dict
from gaocvx import DiscreteProblem, Scene, solve
from gaocvx import convex
from gaocvx.convex import solve_convex
from gaocvx.mixed import clear_cache
from gaocvx.sweep import scene_at

BASE = {
    "stiffness": (scene_dict("P1", "gao", q=-5e8, foundation=(0.007, 5e9), elements=24),
                  "foundation.stiffness", [5e9, 5e10, 5e11]),
    "foundation gap": (scene_dict("P3", "gao", q=-5e7, foundation=(0.01, 5e9), elements=24),
                       "foundation.gap", [0.01, 0.02, 0.005]),
    "load scale": (scene_dict("P2", "gao", q=-5e8, points=[(0.3, -1e8)], foundation=(0.007, 5e9),
                              elements=24), "load.scale", [1.0, 0.5, 2.0]),
    "obstacle gap": (scene_dict("P4", "gao", q=-5e8, obstacle=0.007, elements=24),
                     "obstacle.gap", [0.007, 0.003, 0.01]),
    "tension": (scene_dict("P1", "gao", q=-5e8, axial=-1e9, elements=24), "load.axial",
                [-1e9, -3e9, 0.0]),
}


@pytest.mark.parametrize("kind", sorted(BASE))
def test_reused_program_gives_the_fresh_answer(kind):
    d, key, values = BASE[kind]
    convex.clear_programs()
    base = Scene.from_dict(d)
    W = DiscreteProblem(base).W
    for i, v in enumerate(values):
        s = scene_at(base, key, v)
        dp = DiscreteProblem(s, W=W)
        raw = solve_convex(dp, reuse=True)
        assert raw["reused"] == (i > 0), kind
        fresh = solve(s, "convex")
        newton = solve(s, "newton")
        assert raw["status"] == "optimal" and fresh.success, raw["message"]
        reused = dp.to_physical(raw["u"])[0]
        scale = np.abs(newton.w).max()
        assert np.abs(reused - fresh.w).max() <= 1e-7 * scale
        assert np.abs(reused - newton.w).max() <= 1e-7 * scale


def test_load_of_another_shape_gets_its_own_program():
    """Changing q beside a point force changes the load's shape: not a Parameter change."""
    convex.clear_programs()
    base = Scene.from_dict(scene_dict("P1", "gao", q=-5e8, points=[(0.3, -1e8)],
                                      foundation=(0.007, 5e9), elements=24))
    W = DiscreteProblem(base).W
    first = solve_convex(DiscreteProblem(base, W=W), reuse=True)
    other = scene_at(base, "load.q", -1e8)
    raw = solve_convex(DiscreteProblem(other, W=W), reuse=True)
    assert not first["reused"] and not raw["reused"]
    newton = solve(other, "newton")
    w = DiscreteProblem(other, W=W).to_physical(raw["u"])[0]
    assert np.abs(w - newton.w).max() <= 1e-7 * np.abs(newton.w).max()


def test_structure_cache_does_not_change_answers():
    scene = Scene.from_dict(scene_dict("P2", "gao", q=-5e8, foundation=(0.007, 5e9), elements=40))
    clear_cache()
    first = solve(scene, "newton")
    again = solve(scene, "newton")
    assert np.array_equal(first.w, again.w)


def test_threads_do_not_share_programs():
    """Two sweeps of one structure in two threads (as in a threaded Dask worker)."""
    from concurrent.futures import ThreadPoolExecutor

    from gaocvx.sweep import sweep

    d, key, values = BASE["stiffness"]
    scenes = [Scene.from_dict(d), scene_at(Scene.from_dict(d), "load.scale", 0.5)]

    def run(scene):
        return [r.w for _, r in sweep(scene, key, values * 4, method="convex")]

    with ThreadPoolExecutor(2) as pool:
        threaded = list(pool.map(run, scenes))
    for scene, got in zip(scenes, threaded):
        for w, (_, r) in zip(got, sweep(scene, key, values * 4, method="newton")):
            assert np.abs(w - r.w).max() <= 1e-7 * np.abs(r.w).max()
