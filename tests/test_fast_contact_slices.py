"""The fast obstacle path's reduced function and its method of multipliers at gap 0.

References from outside the code under test: the dense CVXPY + Clarabel node
programs (``NodeProgram.reduced``, the ground truth on small meshes), a
ContactSlices started afresh, and the certificate of the final answer (a beam
pressed flat onto an obstacle at gap 0 has w = 0 and energy 0).
"""

import numpy as np
import pytest

from conftest import scene_dict

from gaocvx import DiscreteProblem, Scene, solve


def _data(supports="P4", q=-1e8, axial=1.5e9, gap=0.01, above=None, elements=16):
    d = scene_dict(supports, q=q, axial=axial, obstacle=gap, elements=elements)
    if above is not None:
        d["obstacle"]["gap_above"] = above
    return d


def _programs(dense=True, **kw):
    from gaocvx.nonconvex.fast_contact import FastContactProgram
    from gaocvx.nonconvex.minimum import rescale_for
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.node import NodeProgram

    dp = DiscreteProblem(Scene.from_dict(_data(**kw)), check_convexity=False)
    m = unstable_modes(dp)
    dp = rescale_for(dp, m)
    return dp, m, FastContactProgram(dp, m), NodeProgram(dp, m) if dense else None


POINT = dict()
UNTOUCHED = dict(q=-1e7, axial=1.3e9, gap=0.1)
CHANNEL = dict(q=-1e7, above=0.02)
GAP0 = dict(gap=0.0)
# P1 at 1.5 P_bar (P_bar_h = 5.527e9 N) on an obstacle at gap 0
P1_GAP0 = dict(supports="P1", q=-1e7, axial=8.3e9, gap=0.0)


@pytest.mark.parametrize("kw", [POINT, UNTOUCHED, CHANNEL, GAP0])
def test_reduced_slope_agrees_with_the_dense_programs(kw):
    """F' from the exact slices: within 1e-7 of the dense programs' (measured 6e-12 to
    3e-8 at 16 and 24 elements; the box rows' multipliers it replaces were up to 5.5e-6
    off, 1.7e-6 at s = 1.5 on the untouched obstacle)."""
    dp, m, fast, dense = _programs(**kw)
    points = [s for s in (-0.3, 0.2, 0.7, 1.5) if fast.smin[0] < s < fast.smax[0]]
    assert len(points) >= 3
    for s in points:
        F, dF, u, ok = fast.reduced([s])
        G, dG, _, _ = dense.reduced([s])
        assert ok and u is not None
        assert F == pytest.approx(G, rel=1e-9, abs=1e-9)
        assert abs(dF[0] - dG[0]) <= 1e-7 * (abs(dG[0]) + 1.0), (s, dF, dG)
        # the answer is a beam with these amplitudes, and the obstacle multipliers
        # reported are those of this slice
        assert float(m.phi[:, 0] @ (dp.G @ u)) == pytest.approx(s, abs=1e-9)
        assert np.all(fast.obstacle_multipliers() >= 0)


def test_warm_started_slice_is_the_slices_minimum():
    """A neighbouring slice's forces held the beam on rows it leaves: feasible but not
    complementary (P1 at gap 0, from s = -1 to -0.3: F 2e-6 and F' 1e-6 too high, no
    row violated).  The updates go on until the forces' work on open gaps is round-off."""
    from gaocvx.nonconvex.fast_contact import FastContactProgram
    from gaocvx.nonconvex.slices import ContactSlices

    dp, m, fast, dense = _programs(**P1_GAP0)
    for s in (-3.0, -1.0):
        fast.reduced([s])
    F, dF, _, ok = fast.reduced([-0.3])
    F0, dF0, _, ok0 = ContactSlices(FastContactProgram(dp, m)).reduced([-0.3])
    G, dG, _, _ = dense.reduced([-0.3])
    assert ok and ok0
    assert F == pytest.approx(F0, rel=1e-11) and F == pytest.approx(G, rel=1e-9)
    assert dF[0] == pytest.approx(dF0[0], rel=1e-9) and dF[0] == pytest.approx(dG[0], rel=1e-8)


def test_flat_contact_multipliers_converge_past_the_drift():
    """P4 pressed flat at gap 0, 512 elements: the redundant rows next to the supports
    made the violation fall by 0.86 per update at the penalty 1e10 (1.0e-9 of the
    answer's size after 40 updates); the penalty raised once, it ends below FEASIBLE
    (2.9e-12)."""
    from gaocvx.nonconvex.fast_contact import FEASIBLE

    _, _, fast, _ = _programs(dense=False, elements=512, **GAP0)
    sol = fast.solve_box([-1e-7], [1e-7])
    assert sol.ok and fast._violation <= FEASIBLE
    assert sol.value - sol.lower <= 1e-10 * max(abs(sol.value), 1.0)


def _pressed_flat(elements, supports="P4", q=-1e8, axial=1.5e9):
    r = solve(Scene.from_dict(_data(supports, q=q, axial=axial, gap=0.0, elements=elements)),
              "global")
    assert r.status == "optimal", r.message
    # w = 0: the obstacle's surface, to round-off of the load's deflection scale
    assert np.max(np.abs(r.w)) <= 1e-12
    assert abs(r.energy) <= 1e-9
    assert r.residual["complementarity"] <= 1e-12
    return r


def test_pressed_flat_at_gap_0_is_certified_at_1024_elements():
    """Was `inaccurate` (complementarity 1.2e-3: rows gapping 1.4e-8 of the floor size
    with the load's forces on them, the multipliers' drift at the penalty 1e10)."""
    _pressed_flat(1024)


@pytest.mark.slow
@pytest.mark.parametrize("q", [-1e8, -1e9])
def test_pressed_flat_at_gap_0_is_certified_at_2048_elements(q):
    """Was `inaccurate` at q = -1e8 N/m (complementarity); 19 s on a loaded machine."""
    _pressed_flat(2048, q=q)


def test_one_mode_slices_are_admissible_and_of_the_dc_form_across_the_range():
    """With one mode the energy is Psi(u) - c s^2 with Psi convex (nonconvex.md), so
    F(s) + c s^2 is convex on the admissible amplitudes, an interval (the admissible
    beams are convex): every slice strictly inside the linear program's range is
    finite, and F' + 2 c s never falls.  P1 in a channel 4 mm high under a load
    table (12 elements): a slice solved afresh 0.005 of the range from its lower end
    stalled at a violation of 1.18e-6 of its size (forces of 7.7e5 in the
    program's units) and was taken as inadmissible, F = inf."""
    from gaocvx.nonconvex.fast_contact import FastContactProgram
    from gaocvx.nonconvex.scales import rescale_for, scene_energy
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.slices import ContactSlices

    data = scene_dict("P1", q=0.0, axial=9.0e9, obstacle=2e-3, elements=12)
    data["load"]["q"] = [[0.0, -3e6], [0.5, 2e6], [1.0, -1e6]]
    data["obstacle"]["gap_above"] = 4e-3
    dp = DiscreteProblem(Scene.from_dict(data), check_convexity=False)
    m = unstable_modes(dp)
    assert m.k == 1
    dp = rescale_for(dp, m)
    slices = ContactSlices(FastContactProgram(dp, m), scene_energy(dp, m))   # as equilibria's
    lo, hi = float(slices.smin[0]), float(slices.smax[0])
    s = np.linspace(lo, hi, 400)[1:-1]
    slopes = []
    for x in s:
        with slices.cold():
            F, dF, _, ok = slices.reduced([x])
        assert np.isfinite(F) and ok, x
        slopes.append(float(dF[0]) + 2.0 * float(m.c[0]) * x)
    rise = np.diff(slopes)
    assert rise.min() >= -1e-9 * np.max(np.abs(slopes)), (rise.min(), s[np.argmin(rise)])
