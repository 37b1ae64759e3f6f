"""The control variational method: adjoints, consistency with the convex minimiser,
convergence of the piecewise-linear control, the bound, and both minimisers."""

import numpy as np
import pytest

from conftest import scene_dict
from gaocvx import DiscreteProblem, Scene, SceneError, solve
from gaocvx.cvm import make_transform, moment_load, shear_load

COMBOS = [("P1", "T1"), ("P2", "T1"), ("P3", "T1"), ("P4", "T1"), ("P3", "T2"), ("P4", "T3")]


def scene_for(supports, foundation=False, elements=16, **kw):
    kw.setdefault("axial", 0.0 if supports == "P3" else 1e8)
    kw.setdefault("points", [(0.3, -1e7)])
    if foundation:
        kw.setdefault("q", -5e7 if supports == "P3" else -5e8)
        kw["foundation"] = (0.02, 5e8) if supports == "P3" else (0.007, 5e10)
    return scene_dict(supports, "gao", elements=elements, **kw)


def cvm(d, transform="auto", control="P1", minimizer="projected-newton", bound=None):
    d = dict(d)
    d["solve"] = {"method": "cvm", "transform": transform, "control": control,
                  "minimizer": minimizer, **({} if bound is None else {"bound": bound})}
    return solve(Scene.from_dict(d))


@pytest.mark.parametrize("supports, transform", COMBOS)
@pytest.mark.parametrize("control", ["P1", "full"])
@pytest.mark.parametrize("foundation", [False, True])
def test_adjoint_gradient_and_cost_identity(supports, transform, control, foundation):
    """The discrete adjoint is the exact gradient of the discrete reduced cost
    (central differences), and J(u) - Pi(w(u)) does not depend on u."""
    dp = DiscreteProblem(Scene.from_dict(scene_for(supports, foundation)))
    tr = make_transform(dp, transform, control)
    rng = np.random.default_rng(7)
    u, v = 0.3 * rng.standard_normal(tr.m), rng.standard_normal(tr.m)
    eps = 1e-6
    fd = (tr.cost(u + eps * v) - tr.cost(u - eps * v)) / (2 * eps)
    assert tr.gradient(u) @ v == pytest.approx(fd, rel=1e-6)
    const = tr.cost(u) - dp.energy(tr.state(u))
    assert tr.cost(v) - dp.energy(tr.state(v)) == pytest.approx(const, abs=1e-10)
    y = rng.standard_normal(dp.n)  # S' is the transpose of S
    assert tr.apply_S(v) @ y == pytest.approx(v @ tr.apply_ST(y), rel=1e-10, abs=1e-12)


def test_transformed_loads_match_closed_forms():
    dp = DiscreteProblem(Scene.from_dict(scene_dict("P4", q=-5e7, points=[(0.25, 2e7)])))
    q = dp.q_table[0, 1]
    (xk, F), = dp.point_forces
    x = np.linspace(0, 1, 11)
    # G2 = ∫_x^1 q + F [x < xk];  G3: -G3'' = q + F delta, G3(0) = G3(1) = 0
    assert np.allclose(shear_load(dp, x), q * (1 - x) + F * (x < xk))
    g3 = q * x * (1 - x) / 2 + F * np.where(x < xk, x * (1 - xk), xk * (1 - x))
    assert np.allclose(moment_load(dp, x), g3)
    table = Scene.from_dict(scene_dict("P3", q=[[0.2, 0.0], [0.6, -4e7]]))
    dpt = DiscreteProblem(table)
    qs = dpt.q_table[1, 1]
    # resultant of the triangular patch on [0.2, 0.6]: qs * 0.4 / 2, all of it right of 0.1
    assert shear_load(dpt, np.array([0.1, 0.7]))[0] == pytest.approx(qs * 0.2)
    assert shear_load(dpt, np.array([0.7]))[0] == 0.0


@pytest.mark.parametrize("supports, transform", COMBOS)
@pytest.mark.parametrize("foundation", [False, True])
def test_full_control_equals_convex_minimiser(supports, transform, foundation):
    """The consistency check of cvm.md: every discrete state is reachable."""
    d = scene_for(supports, foundation, elements=32)
    r = cvm(d, transform, "full")
    truth = solve(Scene.from_dict(d), "convex")
    assert r.success, r.message
    assert np.abs(r.w - truth.w).max() <= 1e-6 * np.abs(truth.w).max()
    assert abs(r.extra["cvm"]["energy_gap"]) <= 1e-9 * abs(truth.energy)
    assert r.extra["cvm"]["control_bound_active"] is False
    assert r.extra["cvm"]["transform"] == transform


@pytest.mark.parametrize("supports, transform", COMBOS)
@pytest.mark.parametrize("foundation", [False, True])
def test_piecewise_linear_control_converges(supports, transform, foundation):
    """With the thesis's control the CVM optimum is another discretisation:
    the difference from the convex minimiser shrinks under refinement."""
    kw = dict(q=-1e8) if not foundation else {}
    sizes, errs = [4, 8, 16], []
    for n in sizes:
        d = scene_for(supports, foundation, elements=n, **kw)
        r = cvm(d, transform, "P1")
        truth = solve(Scene.from_dict(d), "newton")
        assert r.success, r.message
        errs.append(np.abs(r.w - truth.w).max() / np.abs(truth.w).max())
        assert r.extra["cvm"]["energy_gap"] >= -1e-9 * abs(truth.energy)  # a subspace
    assert errs[-1] < errs[0]
    d = scene_for(supports, foundation, elements=128, **kw)
    r = cvm(d, transform, "P1")
    truth = solve(Scene.from_dict(d), "newton")
    err128 = np.abs(r.w - truth.w).max() / np.abs(truth.w).max()
    assert err128 < (1e-2 if foundation else 1e-3)


def test_bound_is_reported_when_active():
    d = scene_for("P3", False, q=-1e8)
    free = cvm(d, "T2", "P1")
    assert free.extra["cvm"]["control_bound_active"] is False
    tight = cvm(d, "T2", "P1", bound=1e6)
    assert tight.extra["cvm"]["control_bound_active"] is True
    assert tight.extra["cvm"]["bound"] == pytest.approx(1e6)
    assert "bound C is active" in tight.message
    assert tight.extra["cvm"]["energy_gap"] > 0


def test_minimisers_reach_the_same_answer():
    """Conditional gradient (given enough iterations) and projected Newton agree."""
    d = scene_for("P4", True, elements=16)
    pn = cvm(d, "T3", "P1")
    cg = cvm(d, "T3", "P1", minimizer="conditional-gradient")
    assert pn.success
    assert np.abs(cg.w - pn.w).max() <= 1e-5 * np.abs(pn.w).max()
    assert cg.nit > 10 * pn.nit
    # With an active bound both land on the same constrained optimum.
    pn_b = cvm(d, "T3", "P1", bound=3e6)
    cg_b = cvm(d, "T3", "P1", minimizer="conditional-gradient", bound=3e6)
    assert pn_b.extra["cvm"]["control_bound_active"] and cg_b.extra["cvm"]["control_bound_active"]
    assert np.abs(cg_b.w - pn_b.w).max() <= 1e-4 * np.abs(pn_b.w).max()


def test_cvm_scene_validation():
    with pytest.raises(SceneError, match="^solve.transform"):
        cvm(scene_for("P1", False), "T2")
    with pytest.raises(SceneError, match="^solve.method"):
        cvm(scene_dict("P4", obstacle=0.01))
    with pytest.raises(SceneError, match="^solve.control"):
        cvm(scene_for("P1", False), control="P2")
    with pytest.raises(SceneError, match="^solve.bound"):
        cvm(scene_for("P1", False), bound=-1.0)


@pytest.mark.parametrize("supports, transform", [("P3", "T2"), ("P4", "T3"), ("P2", "T1")])
@pytest.mark.parametrize("q", [[[0.0, 0.0], [0.37, -2e8], [1.0, 1e6]],   # knot inside an element
                               [[0.33, -2e7], [0.61, -4e7]]])             # jumps at both ends
def test_full_control_with_table_knots_inside_elements(supports, transform, q):
    """The transformed loads are integrated exactly across the table's knots."""
    d = scene_dict(supports, "euler-bernoulli", q=q, elements=8, axial=-1e8)
    r = cvm(d, transform, "full")
    truth = solve(Scene.from_dict(d), "newton")
    assert np.abs(r.w - truth.w).max() <= 1e-9 * np.abs(truth.w).max()


def test_no_load_is_answered_with_exactly_zero():
    """Loads only at a clamped end (the load vector is exactly zero): w = 0 exactly.

    CVM's iterations once returned 9.4e-17 m, called optimal, where the exact
    answer is zero (random campaign, seed 8, scene 31)."""
    data = {"beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11,
                     "nu": 0.417, "half_thickness": 0.00246, "width": 0.118},
            "load": {"points": [[0.0, -12451.9], [0.0, -3964.6]]}, "mesh": {"elements": 2},
            "foundation": {"gap": 0.0, "stiffness": 1.02e11}, "solve": {"control": "full"}}
    r = solve(Scene.from_dict(data), "cvm")
    assert r.status == "optimal" and r.method == "cvm"
    assert not np.any(r.w) and r.energy == 0.0
    assert "no load" in r.extra["cvm"]["verdict"]
