"""Euler-Bernoulli paths, argument checks of equilibria and equilibrium_path, the path command.

Found by a new-user trial: ``gaocvx path`` crashed on every Euler-Bernoulli
scene (the buckling-mode probe at P = 0 met a mesh structure without slope
rows), the Python functions took ``elements=True`` or ``P_values=[True]``
without a word, and a path with skipped forces exited 1 (a solver failure)
instead of 2 (input out of range).

References from outside the code under test: ``gaocvx.solve`` at the same
force (the convex minimiser below the limit), and the closed-form Euler load
``pi^2 EI / L^2`` of a simply supported (P4) beam with its first mode
``sin(pi x / L)``, whose peak is at mid-span.
"""

import math

import numpy as np
import pytest

from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.errors import SceneError
from gaocvx.nonconvex import equilibrium_path, unstable_modes

# The trial's beam: EI = 2.1e11 * 0.1 * 0.02^3 / 12 = 1.4e4 N m^2, L = 3 m.
EB = {"beam": {"model": "euler-bernoulli", "supports": "P4", "length": 3.0, "E": 2.1e11,
               "nu": 0.3, "half_thickness": 0.01, "width": 0.1},
      "load": {"q": -1000.0}, "mesh": {"elements": 16}}
EI = 2.1e11 * 0.1 * 0.02**3 / 12
EULER = math.pi**2 * EI / 3.0**2   # 1.535e4 N: the P4 beam's buckling load

EB_TOML = """[beam]
model = "euler-bernoulli"
supports = "P4"
length = 3.0
E = 2.1e11
nu = 0.3
half_thickness = 0.01
width = 0.1
[load]
q = [[0.0, 0.0], [3.0, -1000.0]]
[mesh]
elements = 16
"""


def eb_scene(**beam):
    d = {k: dict(v) for k, v in EB.items()}
    d["beam"].update(beam)
    return Scene.from_dict(d)


# --------------------------------------------------------------- Euler-Bernoulli paths

@pytest.mark.parametrize("beam", [{}, {"model": "gao", "E_alpha": 0.0}],
                         ids=["euler-bernoulli", "gao-E_alpha-0"])
def test_modes_of_a_beam_without_axial_or_gao_term(beam):
    """At P = 0 without the Gao term the energy has no slope term, yet the pencil's G is
    that term's form: the modes are those of (K, G) all the same."""
    scene = eb_scene(**beam).with_overrides({"load.axial": 0.0})
    dp = DiscreteProblem(scene, check_convexity=False)
    m = unstable_modes(dp, min_k=1)
    mu = dp.mu   # (the Gao beam's loads are those of (K, mu G))
    assert m.k == 1 and m.verified
    assert float(m.loads[0]) * mu == pytest.approx(EULER, rel=1e-5)
    w = dp.full(m.phi[:, 0])[0::2]
    exact = np.sin(np.pi * dp.x / 3.0)
    assert np.allclose(w / w[np.argmax(np.abs(w))], exact, atol=1e-4)


@pytest.mark.parametrize("beam", [{}, {"model": "gao", "E_alpha": 0.0}],
                         ids=["euler-bernoulli", "gao-E_alpha-0"])
def test_euler_bernoulli_path_below_the_limit_is_the_convex_minimiser(beam):
    scene = eb_scene(**beam)
    P = [-0.5 * EULER, 0.0, 0.4 * EULER, 0.8 * EULER]
    path = equilibrium_path(scene, P)
    assert not path.errors and path.P == P
    assert path.x_c == pytest.approx(1.5)   # the first mode's peak, mid-span
    for p in P:
        r = solve(scene.with_overrides({"load.axial": p}))
        (pt,) = path.at(p)
        assert pt["stable"] and pt["global"] and pt["status"] == "optimal"
        assert pt["energy"] == pytest.approx(r.energy, rel=1e-9)
        assert pt["w_c"] == pytest.approx(float(np.interp(1.5, r.x, r.w)), rel=1e-9)


def test_euler_bernoulli_path_above_the_limit_lists_the_refused_forces():
    """Above P_bar_h the energy without a quartic term is unbounded below: each such force
    is refused as solve() refuses it, and the forces below still have their minimiser."""
    scene = eb_scene()
    path = equilibrium_path(scene, [0.5 * EULER, 1.5 * EULER, 3.0 * EULER])
    assert [len(path.at(p)) for p in path.P] == [1, 0, 0]
    assert sorted(path.errors) == [1.5 * EULER, 3.0 * EULER]
    with pytest.raises(SceneError) as refused:
        solve(scene.with_overrides({"load.axial": 1.5 * EULER}), "global")
    assert path.errors[1.5 * EULER] == str(refused.value)
    assert "no minimiser" in path.errors[3.0 * EULER]
