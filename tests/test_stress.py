"""Stress tests: extreme stiffness, axial force, loads, gaps, mesh sizes and point forces.

Each method either returns an accurate answer or says that it could not: an
answer called optimal must agree with an independent certified one (the other
method, or a closed form).  Marked slow; benchmarks/stress.py prints where each
method stops being certified (docs/stress.md).
"""

import numpy as np
import pytest

from conftest import EI_THESIS, scene_dict
from exact import ExactBeam
from gaocvx import DiscreteProblem, Scene, SolverError, solve
from gaocvx.tolerances import ZERO_ANSWER
from gaocvx.certificate import passes

pytestmark = pytest.mark.slow


def both(d, tol=1e-6):
    """Solve with Newton and convex; every 'optimal' answer must agree with the other."""
    scene = Scene.from_dict(d)
    out = {}
    for method in ("newton", "convex"):
        try:
            out[method] = solve(scene, method)
        except SolverError as exc:  # an honest failure
            out[method] = exc
    ok = {m: r for m, r in out.items() if not isinstance(r, Exception) and r.success}
    if len(ok) == 2:
        a, b = ok["newton"], ok["convex"]
        # Accuracy is certified relative to the answer itself, or to the zero floor
        # (1e-6 of the unsupported linear answer) for an answer below it.
        scale = max(np.abs(a.w).max(), ZERO_ANSWER * DiscreteProblem(scene).W_linear)
        assert np.abs(a.w - b.w).max() <= tol * scale, (d, np.abs(a.w - b.w).max() / scale)
    for r in out.values():
        if not isinstance(r, Exception):
            # The status is the certificate's verdict, and the measures come with it.
            assert r.success == passes(r.residual), (r.status, r.residual)
            assert "stationarity" in r.residual
    return out


@pytest.mark.parametrize("k", [1e6, 1e9, 1e12, 1e13, 1e14])
@pytest.mark.parametrize("supports", ["P1", "P3"])
def test_foundation_stiffness(k, supports):
    q, gap = (-5e8, 0.007) if supports == "P1" else (-5e7, 0.02)
    out = both(scene_dict(supports, "gao", q=q, foundation=(gap, k), elements=64))
    assert out["newton"].success  # Newton certifies the whole range


@pytest.mark.parametrize("fraction", [0.5, 0.9, 0.99, 0.999])
@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
def test_axial_force_near_the_limit(fraction, supports):
    probe = DiscreteProblem(Scene.from_dict(scene_dict(supports, "euler-bernoulli", elements=32)))
    d = scene_dict(supports, "euler-bernoulli", q=-5e7, elements=32, axial=fraction * probe.P_bar_h)
    out = both(d, tol=1e-6 / (1 - fraction))  # the problem's condition grows like 1/(1 - P/P_bar)
    r = out["newton"]
    assert r.success
    # The closed form with the axial force.  Near the limit the response is amplified
    # by 1/(1 - P/P_bar): the discrete limit P_bar_h, a little above the continuum's
    # P_bar, then shows up as an error of about (P_bar_h/P_bar - 1)/(1 - P/P_bar).
    P = fraction * probe.P_bar_h
    exact = ExactBeam(supports, 1.0, EI_THESIS, -5e7, [], P)
    err = np.abs(r.w - exact(r.x)).max() / np.abs(exact(r.x)).max()
    P_bar = probe.scene.beam.P_bar()
    assert err < 1e-5 + 3 * (probe.P_bar_h / P_bar - 1) / (1 - P / P_bar), err


@pytest.mark.parametrize("q", [-1e2, -1e5, -1e8, -2e9])
@pytest.mark.parametrize("model", ["gao", "euler-bernoulli"])
def test_load_magnitudes(q, model):
    out = both(scene_dict("P1", model, q=q, foundation=(0.007, 5e10), elements=32))
    assert out["newton"].success
    if model == "euler-bernoulli" and q > -1e6:
        # Far from the foundation: the closed form q x^2 (L - x)^2 / (24 EI).
        r = out["newton"]
        assert r.min["w"] == pytest.approx(q / (384 * EI_THESIS), rel=1e-9)


@pytest.mark.parametrize("gap", [0.0, 1e-6, 1e-3, 0.1, 10.0])
@pytest.mark.parametrize("kind", ["foundation", "obstacle"])
def test_gaps(gap, kind):
    extra = {"foundation": (gap, 1e11)} if kind == "foundation" else {"obstacle": gap}
    out = both(scene_dict("P4", "gao", q=-5e8, elements=32, **extra))
    assert out["newton"].success
    if gap >= 0.1:  # out of reach: the contact-free answer
        free = solve(Scene.from_dict(scene_dict("P4", "gao", q=-5e8, elements=32)))
        assert np.abs(out["newton"].w - free.w).max() <= 1e-9 * np.abs(free.w).max()


@pytest.mark.parametrize("n", [4096, 8192])
@pytest.mark.parametrize("supports", ["P1", "P4"])
def test_obstacle_fine_meshes_newton(n, supports):
    """Point (P1) and flat (P4) contact on fine meshes: Newton certifies, and agrees
    with the 1024-element answer.  Flat contact at 4096 and 8192 elements used to
    end 'inaccurate' (the penalty's round-off spoiled stationarity)."""
    d = scene_dict(supports, "gao", q=-5e8, obstacle=0.007, elements=n)
    r = solve(Scene.from_dict(d), "newton")
    assert r.success, r.message
    ref = solve(Scene.from_dict({**d, "mesh": {"elements": 1024}}), "newton")
    assert ref.success
    assert r.deflection(ref.x) == pytest.approx(ref.w, rel=0, abs=1e-7 * np.abs(ref.w).max())


@pytest.mark.parametrize("n", [4, 16, 256, 2048, 16384])
def test_mesh_sizes_newton(n):
    """Newton certifies every size; nodal values agree with the 1024-element answer."""
    d = scene_dict("P1", "gao", q=-5e8, foundation=(0.007, 5e8), elements=n)
    r = solve(Scene.from_dict(d), "newton")
    assert r.success, r.message
    if n >= 256:
        ref = solve(Scene.from_dict(scene_dict("P1", "gao", q=-5e8, foundation=(0.007, 5e8),
                                               elements=1024)), "newton")
        tol = 1e-7 if n >= 1024 else 1e-5
        assert r.deflection(ref.x) == pytest.approx(ref.w, rel=0, abs=tol * np.abs(ref.w).max())


def test_smooth_scene_1024_against_8192():
    """The issue's check: nodal deflections at 1024 and 8192 elements agree to 1e-7,
    with both exact methods (round-off and solver error, not discretisation)."""
    base = dict(supports="P4", model="gao", q=-1e8, axial=5e8)
    for method in ("newton", "convex"):
        coarse = solve(Scene.from_dict(scene_dict(**base, elements=1024)), method)
        fine = solve(Scene.from_dict(scene_dict(**base, elements=8192)), method)
        assert coarse.success and fine.success, (coarse.message, fine.message)
        diff = np.abs(fine.deflection(coarse.x) - coarse.w).max() / np.abs(coarse.w).max()
        assert diff < 1e-7, (method, diff)


@pytest.mark.parametrize("points", [[(0.5, -3e7)], [(0.3333, -3e7), (0.77, 2e7)],
                                    [(1e-4, -1e8), (0.9999, -1e8)]])
def test_point_forces_at_and_between_nodes(points):
    d = scene_dict("P2", "euler-bernoulli", q=None, points=points, elements=16)
    r = solve(Scene.from_dict(d))
    exact = ExactBeam("P2", 1.0, EI_THESIS, 0.0, points)
    assert r.success
    assert np.abs(r.w - exact(r.x)).max() <= 1e-8 * np.abs(exact(r.x)).max()
    both(scene_dict("P2", "gao", q=-1e8, points=points, obstacle=0.001, elements=16))
