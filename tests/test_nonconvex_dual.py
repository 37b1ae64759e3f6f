"""The dual bound (gaocvx.nonconvex.dual): a lower bound below every energy, and its certificates.

References from outside the code under test: the discrete energy of
tests/nonconvex_independent.py (written from physics.md, long double) at
random points and at the local minima of its own multi-start search, and the
branch and bound's answer (the dual bound switched off) for the same scene.
"""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import scene_dict
from nonconvex_independent import Discrete

from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.nonconvex import dual, search
from gaocvx.nonconvex.modes import unstable_modes


def scene_at(supports, q, factor, elements=16, foundation=None):
    """A Gao scene ``factor`` times its convexity limit (P_hat_h for a bonded bed)."""
    d = scene_dict(supports=supports, q=q, axial=1.0, elements=elements)
    if foundation is not None:
        d["foundation"] = foundation
    dp = DiscreteProblem(Scene.from_dict(d), check_convexity=False)
    d["load"]["axial"] = factor * (dp.P_hat_h if dp.bilateral else dp.P_bar_h)
    return Scene.from_dict(d)


def answer_dofs(result, dp):
    return dp.from_physical(result.w, result.slope)


LOADED = [("P1", -1e6, 1.5), ("P1", -1e5, 3.0), ("P2", -1e6, 3.0), ("P3", -1e5, 3.0),
          ("P4", -1e6, 1.5)]


@pytest.mark.parametrize("supports,q,factor", LOADED)
def test_dual_bound_lies_below_every_energy_of_the_independent_formulation(supports, q, factor):
    scene = scene_at(supports, q, factor)
    dp = DiscreteProblem(scene, check_convexity=False)
    res = solve(scene, "global")
    u = answer_dofs(res, dp)
    bound = dual.tangent_bound(dp, u)
    assert bound is not None
    en = Discrete(scene, W=dp.W)
    e_star = en(u)[0]                                      # in E0, as dp's energies
    scale = en.parts_scale(u)
    # the bound meets the answer's energy (it is the global minimum) ...
    assert abs(e_star - bound.lower) <= 1e-9 * scale
    # ... and no point lies below it: random points around the answer and far away
    rng = np.random.default_rng(7)
    size = np.max(np.abs(u))
    for spread in (1e-3, 0.1, 1.0, 3.0):
        for _ in range(40):
            x = u + spread * size * rng.normal(size=dp.n)
            assert en(x)[0] >= bound.lower - 1e-9 * scale
    # ... nor any point of the independent local searches (converged or not)
    for x0 in en.starts(rng, 16, size):
        x, e, _ = en.local_min(x0, maxiter=200)
        assert e >= bound.lower - 1e-9 * scale


def test_dual_certificate_gives_the_branch_and_bounds_answer(monkeypatch):
    scene = scene_at("P1", -1e5, 3.0, elements=32)          # two unstable modes
    fast = solve(scene, "global")
    g = fast.extra["global"]
    assert fast.status == "optimal" and g["certificate"] == "dual bound" and g["nodes"] == 0
    assert g["unique"] is True and g["unstable_modes"] == 2
    monkeypatch.setattr(search, "DUAL_BOUND", False)
    ref = solve(scene, "global")
    r = ref.extra["global"]
    assert ref.status == "optimal" and r["certificate"] == "branch and bound" and r["nodes"] > 0
    gap = max(g["bound_gap"], r["bound_gap"], 0.0) + 1e-9 * abs(ref.energy)
    assert abs(fast.energy - ref.energy) <= gap
    assert np.max(np.abs(fast.w - ref.w)) <= 1e-6 * np.max(np.abs(ref.w))
    # either lower bound lies below the other answer's energy
    assert g["lower_bound"] <= ref.energy + 1e-9 * abs(ref.energy)
    assert r["lower_bound"] <= fast.energy + 1e-9 * abs(fast.energy)


def test_a_local_minimum_that_is_not_global_gets_no_dual_certificate():
    # A P4 beam on a bonded bed 1.5 P_hat_h, loaded downwards: the independent
    # search finds two minima (buckled with and against the load).
    scene = scene_at("P4", -1e6, 1.5, elements=32,
                     foundation={"kind": "bilateral", "gap": 0.0, "stiffness": 1e9})
    dp = DiscreteProblem(scene, check_convexity=False)
    en = Discrete(scene, W=dp.W)
    modes = unstable_modes(dp)
    amp = 10 * float(np.max(np.abs(solve(scene, "global").w))) / dp.W
    phi = modes.phi[:, 0] / np.max(np.abs(modes.phi[:, 0]))
    minima = sorted((en.local_min(sign * amp * phi)[1::-1] for sign in (1.0, -1.0)),
                    key=lambda m: m[0])
    (e_glob, u_glob), (e_loc, u_loc) = minima
    scale = en.parts_scale(u_glob)
    assert e_loc > e_glob + 1e-3 * scale                   # two distinct minima
    at_global = dual.tangent_bound(dp, u_glob)
    assert at_global is not None and abs(at_global.lower - e_glob) <= 1e-9 * scale
    at_local = dual.tangent_bound(dp, u_loc)
    # at the higher minimum the bound cannot certify it: M(t) is indefinite there,
    # or its bound lies below the global minimum
    assert at_local is None or at_local.lower <= e_glob + 1e-9 * scale


@pytest.mark.parametrize("supports", ["P1", "P4"])
def test_without_load_the_mirror_minima_are_left_to_the_branch_and_bound(supports):
    res = solve(scene_at(supports, 0.0, 1.5), "global")
    g = res.extra["global"]
    assert res.status == "optimal"
    assert g["certificate"] == "branch and bound" and g["unique"] is False


def test_obstacle_scenes_never_take_the_dual_bound():
    d = scene_dict(supports="P4", q=-1e6, axial=1.0, elements=16)
    d["obstacle"] = {"gap": 0.001}
    dp = DiscreteProblem(Scene.from_dict(d), check_convexity=False)
    assert dual.tangent_bound(dp, np.ones(dp.n)) is None


@pytest.mark.parametrize("supports,q,factor,elements", [("P4", -1e6, 1.5, 16), ("P1", -1e5, 3.0, 64),
                                                         ("P3", -1e5, 3.0, 32)])
def test_proved_margin_lies_below_the_smallest_eigenvalue(supports, q, factor, elements):
    """The proved margin of M(t) - m G >= 0 is below lambda_min(M, G) of a dense solve
    (scipy.linalg.eigh), and above zero where it is used."""
    import scipy.linalg as sla
    import scipy.sparse as sp
    scene = scene_at(supports, q, factor, elements)
    dp = DiscreteProblem(scene, check_convexity=False)
    u = answer_dofs(solve(scene, "global"), dp)
    t = (dp.B1 @ u) ** 2
    M = dual.tangent_matrix(dp, t)
    lam = sla.eigh(M.toarray(), dp.G.toarray(), eigvals_only=True)[0]
    S = sp.diags(1.0 / np.sqrt(dp.G.diagonal()))
    floor = dual.metric_floor(dp.G, S)
    assert 0 < floor <= sla.eigvalsh((S @ dp.G @ S).toarray())[0]
    for m in (0.5 * lam, 0.9 * lam):
        proved = dual.proved_margin(dp, M, t, m, S, floor)
        assert 0 < proved <= m < lam
    # above the smallest eigenvalue nothing is proved
    assert dual.proved_margin(dp, M, t, 1.01 * lam, S, floor) == -np.inf


def test_one_free_dof():
    """A P2 beam of one element has one free DOF (the slope at the pinned end): the
    eigenvalue estimate must not crash (scipy's eigsh refuses k >= N)."""
    scene = scene_at("P2", -1e5, 2.0, elements=1)
    res = solve(scene, "global")
    assert res.status == "optimal" and res.extra["global"]["unique"] is True


@pytest.mark.parametrize("P", [1.4951307588620628e9, 1.55e9])
def test_dual_bound_lies_below_the_reported_energy(P):
    """The reported lower bound lies below the reported energy.  A new-user trial saw
    negative gaps of 5e-15 of the energy on this bonded P4 beam (the bound from the
    Hermite energy, the answer's energy from the mixed form: their round-off)."""
    data = {"beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11,
                     "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
            "load": {"q": -1e7, "axial": P}, "mesh": {"elements": 16},
            "foundation": {"kind": "bilateral", "gap": 0.0, "stiffness": 1e9}}
    res = solve(Scene.from_dict(data), "global")
    g = res.extra["global"]
    assert res.status == "optimal" and g["certificate"] == "dual bound"
    assert g["bound_gap"] >= 0 and g["lower_bound"] <= res.energy


# ------------------------------------------------------------------ the tangent inequality

@settings(max_examples=40, deadline=None)
@given(supports=st.sampled_from(["P1", "P2", "P3", "P4"]),
       bed=st.sampled_from([None, "bilateral", "unilateral"]),
       gap=st.floats(0.0, 0.01), seed=st.integers(0, 2**31 - 1))
def test_tangent_function_is_below_the_energy_with_M_as_its_quadratic_part(supports, bed, gap,
                                                                          seed):
    """L_t(u), written out from M(t) (tangent_matrix) as 1/2 u'M u - f'u + F(u) -
    a/12 sum w t^2 with F the bed's energy, equals Pi(u) - a/12 sum w (y - t)^2 and so
    lies below Pi(u), for random u and t >= 0: M is the quadratic part the certificate
    needs, for every contact kind it takes."""
    foundation = None if bed is None else {"kind": bed, "gap": gap, "stiffness": 3e9}
    scene = scene_at(supports, -1e6, 2.0, elements=6, foundation=foundation)
    dp = DiscreteProblem(scene, check_convexity=False)
    rng = np.random.default_rng(seed)
    u = rng.normal(size=dp.n) * 10.0 ** rng.uniform(-2, 2)
    t = rng.uniform(0, 2, size=len(dp.wq_gao)) * float(np.mean((dp.B1 @ u) ** 2))
    M = dual.tangent_matrix(dp, t)
    quad = 0.5 * u @ (M @ u) - dp.f @ u - dp.a / 12.0 * float(dp.wq_gao @ t**2)
    c = np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape) if dp.contact == "foundation" else 0.0
    if bed == "bilateral":      # 1/2 c (g - Nu)^2 less its quadratic part, already in M
        w = dp.Nq @ u
        quad += float(np.sum(c * (0.5 * dp.g**2 - dp.g * w)))
    elif bed == "unilateral":   # not in M: the bed's own (convex) energy
        quad += 0.5 * float(np.sum(c * np.maximum(dp.g - dp.Nq @ u, 0.0) ** 2))
    y = (dp.B1 @ u) ** 2
    deficit = dp.a / 12.0 * float(dp.wq_gao @ (y - t) ** 2)
    energy = dp.energy(u)
    size = sum(abs(v) for v in dp.energy_parts(u).values()) + abs(quad) + deficit
    assert quad == pytest.approx(energy - deficit, abs=1e-11 * size)
    assert quad <= energy + 1e-11 * size
