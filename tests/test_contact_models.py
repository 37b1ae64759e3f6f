"""Contact models of issue 12: the bonded (bilateral) foundation, surface profiles.

References from outside the code: the closed-form solution of an
Euler-Bernoulli beam on a Winkler foundation (Hetényi), with an axial force,
for every support: EI w'''' + P w'' + k (w - g) = q, solved as exponentials
and a 4x4 system for the boundary conditions; and mesh-convergence orders.
"""

import numpy as np
import pytest

from gaocvx import DiscreteProblem, Scene, SceneError, solve

EXACT = ("newton", "convex")
BEAM = {"model": "euler-bernoulli", "length": 1.0, "E": 2.1e11, "nu": 0.3,
        "half_thickness": 0.1, "width": 1.0}
# Boundary conditions per support: (which end, what) with what in
# w, slope, moment (w''), shear (EI w''' + P w').
BCS = {"P1": [(0, "w"), (0, "slope"), (1, "w"), (1, "slope")],
       "P2": [(0, "w"), (0, "slope"), (1, "w"), (1, "moment")],
       "P3": [(0, "w"), (0, "slope"), (1, "moment"), (1, "shear")],
       "P4": [(0, "w"), (0, "moment"), (1, "w"), (1, "moment")]}


def hetenyi(supports, EI, k, q, level, P, L, x):
    """w(x) of EI w'''' + P w'' + k (w - level) = q with the supports' conditions."""
    roots = np.roots([EI, 0.0, P, 0.0, k]).astype(complex)
    # e^{r (x - x0)} with x0 the end where it is largest: no overflow for stiff foundations
    x0 = np.where(roots.real > 0, L, 0.0)

    def basis(xv, d):
        return roots**d * np.exp(roots * (xv - x0))

    rows, rhs = [], []
    wp = (q + k * level) / k
    for end, what in BCS[supports]:
        xv = end * L
        if what == "w":
            rows.append(basis(xv, 0)); rhs.append(-wp)
        elif what == "slope":
            rows.append(basis(xv, 1)); rhs.append(0.0)
        elif what == "moment":
            rows.append(basis(xv, 2)); rhs.append(0.0)
        else:
            rows.append(EI * basis(xv, 3) + P * basis(xv, 1)); rhs.append(0.0)
    C = np.linalg.solve(np.array(rows), np.array(rhs, complex))
    w = wp + np.array([basis(xv, 0) @ C for xv in np.atleast_1d(x)])
    assert np.abs(w.imag).max() <= 1e-9 * np.abs(w.real).max()
    return w.real


def bonded(supports, n, q=-5e7, k=5e10, gap=0.0, axial=0.0):
    return Scene.from_dict({"beam": {**BEAM, "supports": supports},
                            "load": {"q": q, "axial": axial},
                            "foundation": {"gap": gap, "stiffness": k, "kind": "bilateral"},
                            "mesh": {"elements": n}})


def _error(r, gap=0.0, q=-5e7, k=5e10, axial=0.0):
    EI = r.scene.beam.EI_eff
    exact = hetenyi(r.scene.beam.supports, EI, k, q, -gap, axial, 1.0, r.x)
    return np.abs(r.w - exact).max() / np.abs(exact).max()


@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
@pytest.mark.parametrize("method", EXACT)
def test_bonded_foundation_is_hetenyis_beam(supports, method):
    """Every support, uniform load, no axial force: O(h^4) to the closed form."""
    errors = [_error(solve(bonded(supports, n), method)) for n in (16, 64)]
    assert errors[1] <= 2e-7, errors
    order = np.log(errors[0] / errors[1]) / np.log(4)
    assert order >= 3.5, (errors, order)


@pytest.mark.parametrize("supports", ["P1", "P3", "P4"])
def test_bonded_foundation_pulls_and_carries_axial_force(supports):
    """A surface 1 mm below with no load pulls the beam down to it (w = g away from
    the supports); and with compression P = P_bar / 2 the closed form has P w''."""
    r = solve(bonded(supports, 64, q=0.0, gap=1e-3), "newton")
    assert r.success
    assert _error(r, gap=1e-3, q=0.0) <= 1e-6
    assert r.reaction[0] == pytest.approx(-5e10 * 1e-3)   # it pulls at the support (w = 0)
    P = 0.5 * bonded(supports, 64).beam.P_bar()
    for method in EXACT:
        r = solve(bonded(supports, 64, axial=P), method)
        assert r.success, r.message
        assert _error(r, axial=P) <= 1e-6


def test_bonded_foundation_energy_at_rest_and_scene_keys():
    """E(w) includes 1/2 k (w - g)^2 everywhere: w = 0 costs 1/2 k g^2 L."""
    r = solve(bonded("P4", 32, q=0.0, gap=1e-3), "newton")
    assert r.energy < 0.5 * 5e10 * 1e-6 * 1.0
    with pytest.raises(SceneError) as info:
        Scene.from_dict({"beam": {**BEAM, "supports": "P4"},
                         "foundation": {"gap": 0, "stiffness": 1e9, "kind": "glued"}})
    assert info.value.key == "foundation.kind"
    with pytest.raises(SceneError) as info:
        solve(bonded("P4", 8), "cvm")
    assert info.value.key == "foundation.kind"


@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
def test_bonded_foundation_above_p_bar_below_p_hat(supports):
    """Between P_bar_h and P_hat_h the bonded beam is convex: both methods solve it,
    against Hetényi's closed form with the axial force; above P_hat_h it is refused."""
    dp = DiscreteProblem(bonded(supports, 64))
    P_hat, P_bar = dp.P_hat_h, dp.P_bar_h
    assert P_hat > 1.5 * P_bar
    P = 0.5 * (P_bar + P_hat)
    for method in EXACT:
        r = solve(bonded(supports, 64, axial=P), method)
        assert r.success, r.message
        assert _error(r, axial=P) <= 1e-6
    for method in EXACT:
        with pytest.raises(SceneError) as info:
            solve(bonded(supports, 64, axial=1.001 * P_hat), method)
        assert info.value.key == "load.axial" and "P_hat_h" in str(info.value)


def test_p_hat_is_the_continuum_limit():
    """P4: P_hat = min_n EI (n pi / L)^2 + k (L / n pi)^2 (thesis (2.44)); the discrete
    value lies above it by O(h^4) (Rayleigh-Ritz) and converges to it."""
    EI = bonded("P4", 8).beam.EI_eff
    for k in (5e8, 5e10, 5e12):
        exact = min(EI * (n * np.pi) ** 2 + k / (n * np.pi) ** 2 for n in range(1, 200))
        errors = [DiscreteProblem(bonded("P4", n, k=k)).P_hat_h / exact - 1 for n in (16, 32)]
        assert 0 <= errors[1] <= errors[0] and errors[1] <= 1e-4, (k, errors)
