"""Euler-Bernoulli closed forms for every support, load kind and method.

Hermite cubics reproduce the exact nodal values of the Euler-Bernoulli beam
for any load integrated consistently (the Green's functions lie in the finite
element space), so the nodal agreement is checked to round-off.
"""

import numpy as np
import pytest

from conftest import EI_THESIS, scene_dict
from exact import ExactBeam
from gaocvx import Scene, solve

LOADS = {
    "uniform": dict(q=-5e7),
    "point-at-node": dict(q=None, points=[(0.25, -5e7)]),
    "point-between-nodes": dict(q=None, points=[(0.4, -3e7), (0.83, 2e7)]),
    "table": dict(q=[[0.0, 0.0], [0.25, 5e7], [0.75, -1.7e7], [1.0, 0.0]]),
    "partial-table": dict(q=[[0.33, -2e7], [0.61, -4e7]]),
    "mixed": dict(q=-1e7, points=[(0.7, -1e7), (1.0, 5e6)]),
}


def exact_for(d):
    load = d["load"]
    return ExactBeam(d["beam"]["supports"], 1.0, EI_THESIS, load.get("q", 0.0) or 0.0,
                     load["points"], load["axial"])


@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
@pytest.mark.parametrize("load", sorted(LOADS))
@pytest.mark.parametrize("method", ["newton", "convex"])
def test_nodal_values_are_exact(supports, load, method):
    d = scene_dict(supports, "euler-bernoulli", elements=16, **LOADS[load])
    result = solve(Scene.from_dict(d), method)
    assert result.success, result.message
    exact = exact_for(d)
    w_ref = exact(result.x)
    scale = np.abs(w_ref).max()
    tol = 1e-9 if method == "newton" else 1e-6
    assert np.abs(result.w - w_ref).max() <= tol * scale
    assert np.abs(result.slope - exact(result.x, 1)).max() <= tol * 10 * np.abs(exact(result.x, 1)).max()


@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
def test_moment_and_shear_are_exact(supports):
    """M and V from element equilibrium equal the exact ones at arbitrary points, on any mesh.

    The end forces K_e u_e - f_e of the nodally exact answer are exact, and the
    load carries them across each element; only round-off remains, which grows
    like N^3 eps for V (nodal deflections differenced over h^3).
    """
    xs = np.linspace(0.013, 0.987, 41)
    for n in (8, 16, 32, 64):
        d = scene_dict(supports, "euler-bernoulli", elements=n, q=-5e7, points=[(0.37, -2e7)])
        r = solve(Scene.from_dict(d))
        ex = exact_for(d)
        far = np.abs(xs - 0.37) > 1e-9
        m_ref, v_ref = EI_THESIS * ex(xs, 2), EI_THESIS * ex(xs[far], 3)
        assert np.abs(r.moment(xs) - m_ref).max() <= 1e-11 * np.abs(m_ref).max()
        assert np.abs(r.shear(xs[far]) - v_ref).max() <= 10 * n**3 * 2.2e-16 * np.abs(v_ref).max()


@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
@pytest.mark.parametrize("axial", [-2e8, 1.5e8])
def test_axial_force_mesh_convergence(supports, axial):
    """With an axial force the nodal error falls at the rate of cubic elements (>= 4)."""
    errs, hs = [], []
    for n in (4, 8, 16, 32):
        d = scene_dict(supports, "euler-bernoulli", elements=n, q=-5e7, axial=axial)
        r = solve(Scene.from_dict(d))
        assert r.success
        ex = exact_for(d)
        errs.append(np.abs(r.w - ex(r.x)).max() / np.abs(ex(r.x)).max())
        hs.append(1.0 / n)
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert order > 3.5, (order, errs)
    assert errs[-1] < 1e-6


def test_energy_equals_minus_half_work():
    """Clapeyron: at the linear minimiser the energy is -1/2 of the load's work."""
    d = scene_dict("P2", "euler-bernoulli", q=-5e7, points=[(0.6, 1e7)])
    r = solve(Scene.from_dict(d))
    assert r.energy == pytest.approx(0.5 * r.energy_parts["load"], rel=1e-10)
    assert r.energy_parts["bending"] == pytest.approx(-0.5 * r.energy_parts["load"], rel=1e-10)
