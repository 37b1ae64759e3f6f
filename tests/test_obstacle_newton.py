"""Newton on a rigid obstacle from a coarse mesh's answer (gaocvx.contact_newton).

Correctness against a closed form, the convex program (Clarabel) and the former
continuation; iteration bounds on the benchmark's obstacle scene; the fallback.
"""

from pathlib import Path

import numpy as np
import pytest

from conftest import EI_THESIS, scene_dict
from exact import ExactBeam
from gaocvx import Scene, contact_newton, newton, solve
from gaocvx.scene import load_scene
from gaocvx.sweep import sweep

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
# benchmarks/performance.py's obstacle scene.
BENCH = dict(supports="P1", model="gao", q=-5e8, obstacle=0.007)


@pytest.fixture
def continuation(monkeypatch):
    """Solve with the former method (the penalty growing tenfold per update)."""
    monkeypatch.setattr(newton, "OBSTACLE_METHOD", "continuation")


@pytest.mark.parametrize("supports, factor", [("P4", 48.0), ("P1", 192.0)])
def test_point_contact_closed_form_on_a_fine_mesh(supports, factor):
    """A centre point load presses the beam onto the obstacle at midspan only.

    (F + R) L^3 / (factor EI) = -gap gives the reaction R; the shape is the free
    beam's under F + R (the cubic elements are nodally exact).
    """
    F, gap = -4e7, 1e-3
    R = -F - factor * EI_THESIS * gap
    scene = Scene.from_dict(scene_dict(supports, "euler-bernoulli", q=None, points=[(0.5, F)],
                                       obstacle=gap, elements=256))
    r = solve(scene, "newton")
    assert r.success and "from the 16-element answer" in r.message, r.message
    exact = ExactBeam(supports, 1.0, EI_THESIS, 0.0, [(0.5, F + R)])
    assert np.abs(r.w - exact(r.x)).max() <= 1e-7 * gap
    mid = int(np.argmin(np.abs(r.x - 0.5)))
    assert r.reaction[mid] == pytest.approx(R, rel=1e-6)
    assert np.abs(np.delete(r.reaction, mid)).max() <= 1e-6 * R


@pytest.mark.parametrize("elements", [512, 2048])
def test_benchmark_scene_in_a_few_iterations(elements):
    """The benchmark's obstacle scene: at most 8 factorisations on its mesh (former: 15-17
    Newton steps, 49-60 factorisations), and the former method's answer."""
    scene = Scene.from_dict(scene_dict(**BENCH, elements=elements))
    r = solve(scene, "newton")
    assert r.success, r.message
    assert f"from the {elements // 16}-element answer" in r.message
    assert r.nit <= 8, r.message
    newton.OBSTACLE_METHOD = "continuation"
    try:
        old = solve(scene, "newton")
    finally:
        newton.OBSTACLE_METHOD = "coarse start"
    assert old.success and "multiplier updates" in old.message
    assert np.abs(r.w - old.w).max() <= 1e-8 * np.abs(old.w).max()
    assert r.zones == old.zones


@pytest.mark.parametrize("supports, model", [("P4", "gao"), ("P2", "euler-bernoulli"),
                                             ("P3", "gao")])
def test_flat_and_point_contact_agree_with_clarabel(supports, model, monkeypatch):
    """Flat contact (P4, P2) and a cantilever's tip (P3) at 512 elements.

    Against Clarabel and the former continuation to the certificate's meaning
    (each optimal answer within about 1e-6 of the exact one at its nodes:
    docs/model.md).  Measured, relative to max |w|: this method 1.6e-7, 5e-10
    and 1.9e-10 from Clarabel (P2, P4, P3), the continuation 1.7e-7, 3.0e-8 and
    2.2e-7.
    """
    q = -5e7 if supports == "P3" else -5e8
    scene = Scene.from_dict(scene_dict(supports, model, q=q, points=[(0.7, -2e7)],
                                       obstacle=0.002, elements=512))
    a, b = solve(scene, "newton"), solve(scene, "convex")
    # (Re-solved in the answer's own scale: the second pass starts warm.)
    assert a.success and "Newton steps" in a.message, a.message
    assert b.success, b.message
    size = np.abs(b.w).max()
    assert np.abs(a.w - b.w).max() <= 1e-6 * size
    assert a.zones == b.zones
    assert a.residual["feasibility"] <= 1e-9  # the stopping margin, 1e-2 of the tolerance
    monkeypatch.setattr(newton, "OBSTACLE_METHOD", "continuation")
    c = solve(scene, "newton")
    assert c.success and "multiplier updates" in c.message
    assert np.abs(a.w - c.w).max() <= 1e-6 * size


def test_channel_agrees_with_clarabel():
    """Both surfaces of a channel on a fine mesh (forces from below and above)."""
    scene = load_scene(EXAMPLES / "channel.toml", {"mesh.elements": 256})
    a, b = solve(scene, "newton"), solve(scene, "convex")
    assert a.success and "from the 16-element answer" in a.message, a.message
    assert b.success, b.message
    assert np.abs(a.w - b.w).max() <= 1e-6 * np.abs(b.w).max()
    forces = a.contact_forces[:, 1]
    assert forces.min() < 0 < forces.max()


def test_fallback_to_the_continuation(monkeypatch):
    """Out of budget, the continuation solves the scene from the original start."""
    scene = Scene.from_dict(scene_dict(**BENCH, elements=256))
    fast = solve(scene, "newton")
    monkeypatch.setattr(contact_newton, "FAST_BUDGET", 1)
    slow = solve(scene, "newton")
    assert fast.success and slow.success
    assert "the continuation, after" in slow.message
    assert np.abs(fast.w - slow.w).max() <= 1e-8 * np.abs(slow.w).max()


def test_small_meshes_start_from_a_mesh_four_times_coarser(continuation):
    """From 8 to 127 elements the start is the answer on N // 4 elements: at most 8
    factorisations on the scene's mesh (the continuation: 13 Newton steps), the same
    answer to the certificate's accuracy; under 8 elements the continuation itself."""
    for n in (8, 32, 64):
        scene = Scene.from_dict(scene_dict(**BENCH, elements=n))
        old = solve(scene, "newton")
        newton.OBSTACLE_METHOD = "coarse start"
        new = solve(scene, "newton")
        newton.OBSTACLE_METHOD = "continuation"
        assert old.success and new.success and old.nit >= 13
        assert new.nit <= 8, (n, new.nit, new.message)
        assert f"from the {n // 4}-element answer" in new.message
        assert np.abs(new.w - old.w).max() <= 1e-6 * np.abs(old.w).max()
    assert contact_newton.coarse_elements(7) is None


def test_gap_sweep():
    """A sweep's later values try the previous answer and multipliers at the largest
    penalty first, then the coarse start; all certified, as first solves."""
    base = Scene.from_dict(scene_dict(**BENCH, elements=256))
    gaps = [0.004, 0.005, 0.006]
    items = list(sweep(base, "obstacle.gap", gaps, method="newton"))
    for gap, r in items:
        assert r.success, r.message
        cold = solve(Scene.from_dict(scene_dict(**{**BENCH, "obstacle": gap}, elements=256)),
                     "newton")
        assert np.abs(r.w - cold.w).max() <= 1e-7 * np.abs(cold.w).max()
    assert all("warm start" in r.message for _, r in items[1:])
    assert not any("continuation" in r.message for _, r in items)


def test_kkt_factor_solves_several_right_hand_sides_at_once():
    """The banded KKT factor with refinement (an obstacle's penalty) takes a matrix of
    right-hand sides, one column each (the fast path's bordered solves): against a
    dense solve of the assembled [[H, C'], [C, 0]], H assembled column by column."""
    from gaocvx import DiscreteProblem
    from gaocvx.mixed import MixedForm

    data = scene_dict(supports="P2", model="gao", elements=12)
    data["load"] = {"q": -5e7}
    data["obstacle"] = {"gap": 1e-4}
    dp = DiscreteProblem(Scene.from_dict(data))
    mf = MixedForm.on_obstacle(dp)
    rng = np.random.default_rng(5)
    z = rng.normal(size=mf.n) * 1e-3
    H = mf.hessian(z, shift=np.abs(rng.normal(size=len(mf.gap(z)))), rho=1e6)
    assert H.obstacle is not None and np.any(H.obstacle > 0)
    factor = mf.kkt_factor(H)
    assert factor.refine == 1
    n, m = mf.n, mf.N
    Hd = np.column_stack([H @ e for e in np.eye(n)])
    C = mf.C.toarray()
    K = np.block([[Hd, C.T], [C, np.zeros((m, m))]])
    Rz, Rc = rng.normal(size=(n, 3)), rng.normal(size=(m, 3))
    X, Y = factor.solve(Rz, Rc)
    ref = np.linalg.solve(K, np.vstack([Rz, Rc]))
    assert X.shape == (n, 3) and Y.shape == (m, 3)
    assert np.allclose(X, ref[:n], rtol=1e-8, atol=1e-8 * np.max(np.abs(ref[:n])))
    assert np.allclose(Y, ref[n:], rtol=1e-8, atol=1e-8 * np.max(np.abs(ref[n:])))
    for j in range(3):   # and each column as the one-vector solve gives it
        x, y = factor.solve(Rz[:, j], Rc[:, j])
        assert np.allclose(X[:, j], x, rtol=1e-12, atol=1e-12 * np.max(np.abs(x)))
