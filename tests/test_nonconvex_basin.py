"""Basins (gaocvx/nonconvex/basin.py): boxes of amplitudes proved to hold nothing below a
local minimiser, by which the branch and bound closes the boxes around its minimisers.

References from outside the code under test: the energy's minimum on each slice of
the box (amplitudes fixed) by an independent formulation (tests/nonconvex_independent.py)
and SLSQP, which must lie above the basin's bound and have its slopes within the
basin's proved ``eta``; the mirror image of a symmetric scene's minimiser (a second
global minimiser: no basin may reach it); a saddle (none proved at all); and the
branch and bound with and without basins (the same minimum, each bound below the
other's energy).
"""

import numpy as np
import pytest
import scipy.linalg as sla

from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.nonconvex import search
from gaocvx.nonconvex.basin import BasinProver, _Proof, basin
from gaocvx.nonconvex.modes import unstable_modes
from nonconvex_independent import Discrete

BEAM = {"model": "gao", "length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1,
        "width": 1.0}


def scene(supports, load, extra=None, elements=16):
    d = {"beam": dict(BEAM, supports=supports), "load": load, "mesh": {"elements": elements}}
    d.update(extra or {})
    return Scene.from_dict(d)


SCENES = {
    # nonconvex.md's example: one mode
    "P4 k=1": scene("P4", {"q": -1e7, "axial": 1.3e9}),
    # two modes (P1 at 2.4 P_bar_h)
    "P1 k=2": scene("P1", {"q": -5e7, "axial": 1.1e10}),
    # a unilateral bed 2 mm below: buckled up off it, and pressed into it (all but
    # the points next to the supports: there the contact may switch within the box)
    "P2 bed": scene("P2", {"q": -5e7, "axial": 6e9},
                    {"foundation": {"gap": 0.002, "stiffness": 1e10}}),
    "P2 bed pressed": scene("P2", {"q": -5e8, "axial": 6e9},
                            {"foundation": {"gap": 0.002, "stiffness": 1e10}}),
    # a bonded bed with three unstable modes
    "P4 bonded k=3": scene("P4", {"q": -5e7, "axial": 1.3e10},
                           {"foundation": {"gap": 0.0, "stiffness": 1e11, "kind": "bilateral"}},
                           elements=12),
}


def minimiser(sc):
    """The certified global minimiser's free DOFs, and the problem (its own units)."""
    r = solve(sc, "global")
    assert r.status == "optimal", r.message
    dp = DiscreteProblem(sc, check_convexity=False)
    return dp, unstable_modes(dp), dp.from_physical(r.w, r.slope)


def slice_minimum(en, dp, phi, s, x0):
    """The independent energy's minimum on the slice ``Phi'G x = s``: damped Newton with
    its own Hessian on the slice's null space, from ``x0`` (on the slice; the energy is
    strictly convex there)."""
    P = phi.T @ dp.G.toarray()
    x = x0 + np.linalg.lstsq(P, s - P @ x0, rcond=None)[0]
    N = sla.null_space(P)
    value, g = en(x)
    for _ in range(100):
        step = N @ np.linalg.solve(N.T @ en.hessian(x) @ N, -(N.T @ g))
        t = 1.0
        while t > 1e-12:
            v2, g2 = en(x + t * step)
            if v2 <= value:
                break
            t *= 0.5
        if not v2 <= value:
            break
        x, value, g = x + t * step, v2, g2
        if np.linalg.norm(t * step) <= 1e-14 * np.linalg.norm(x):
            break
    assert np.max(np.abs(P @ x - s)) <= 1e-9 * (1 + np.max(np.abs(s)))
    assert np.linalg.norm(N.T @ g) <= 1e-7 * max(np.linalg.norm(g), 1.0)
    return value, x


@pytest.mark.parametrize("name", list(SCENES))
def test_slices_of_the_basin_lie_above_its_bound_with_slopes_within_eta(name):
    dp, modes, u = minimiser(SCENES[name])
    b = basin(dp, modes, u)
    assert b is not None
    assert np.all(b.lo < b.s) and np.all(b.s < b.hi)
    e = dp.energy(u)
    assert 0.0 <= e - b.lower <= 1e-9 * max(abs(e), 1.0)
    en = Discrete(dp.scene, W=dp.W)
    assert abs(en(u)[0] - e) <= 1e-9 * max(abs(e), 1.0)
    k = modes.k
    rng = np.random.default_rng(3)
    corners = [b.lo + (b.hi - b.lo) * np.array([(j >> i) & 1 for i in range(k)])
               for j in range(2**k)]
    points = corners[:8] + [b.lo + (b.hi - b.lo) * rng.random(k) for _ in range(4)]
    Phit = modes.phi @ np.linalg.inv(modes.phi.T @ (dp.G @ modes.phi))
    worst = 0.0
    for s in points:
        value, x = slice_minimum(en, dp, modes.phi, s, u + Phit @ (s - b.s))
        assert value >= b.lower - 1e-12 * abs(e), (s, value, b.lower)
        # claim (3) of the module: the slice minimiser's slopes lie within eta of u*'s
        dev = np.abs(dp.B1 @ x - dp.B1 @ u)
        worst = max(worst, float(np.max(dev / b.eta)))
        assert np.all(dev <= b.eta * (1 + 1e-6) + 1e-9), (s, float(np.max(dev - b.eta)))
    assert worst > 1e-3   # the bound is not vacuous: the slopes do move within the box


def test_no_basin_reaches_the_mirror_minimiser():
    """Without load the two buckled shapes +-u* are both global minimisers: a box
    around one that reached the other would be a false bound.  The proof must fail
    for every box wide enough to hold -s* (tried up to |2 s*|), and the proved
    basin stays on its own side."""
    sc = scene("P4", {"axial": 1.5e9})
    dp, modes, u = minimiser(sc)
    prover = BasinProver(dp, modes)
    b = prover.prove(u)
    assert b is not None and not b.contains(-b.s, -b.s)
    proof = _Proof(prover, u)
    reach = 2.0 * np.abs(b.s) * 1.01
    for factor in (1.0, 1.5, 3.0):
        assert proof.attempt(factor * reach) is None


def test_a_saddle_has_no_basin():
    """w = 0 without load above the limit is an equilibrium, unstable along the modes."""
    sc = scene("P4", {"axial": 1.5e9})
    dp = DiscreteProblem(sc, check_convexity=False)
    assert basin(dp, unstable_modes(dp), np.zeros(dp.n)) is None


def test_an_obstacle_is_left_to_the_node_programs():
    sc = scene("P4", {"q": -1e8, "axial": 1.5e9}, {"obstacle": {"gap": 0.01}})
    dp = DiscreteProblem(sc, check_convexity=False)
    assert basin(dp, unstable_modes(dp), np.zeros(dp.n)) is None


@pytest.mark.parametrize("name", ["P1 k=2", "P2 bed"])
def test_branch_and_bound_with_and_without_basins_agree(name, monkeypatch):
    sc = SCENES[name]
    monkeypatch.setattr(search, "DUAL_BOUND", False)
    with_basins = solve(sc, "global")
    monkeypatch.setattr(search, "BASINS", False)
    without = solve(sc, "global")
    for r in (with_basins, without):
        assert r.status == "optimal", r.message
    g1, g2 = with_basins.extra["global"], without.extra["global"]
    scale = abs(without.energy)
    assert abs(with_basins.energy - without.energy) <= 1e-9 * scale
    # each certified lower bound lies below the other's energy
    assert g1["lower_bound"] <= without.energy + 1e-12 * scale
    assert g2["lower_bound"] <= with_basins.energy + 1e-12 * scale
    assert g1["nodes"] < g2["nodes"]
    assert np.max(np.abs(with_basins.w - without.w)) <= 1e-6 * np.max(np.abs(without.w))
