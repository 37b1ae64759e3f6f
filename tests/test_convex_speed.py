"""The convex program's size and Clarabel's first rung (issue 11): what made it slow or inaccurate.

Measured causes, each tested here: Clarabel's Ruiz equilibration of an already
scaled program (a clamped Gao beam at 2048 elements took 108 iterations with it,
16 without; an obstacle at 8192 elements was not certified with it), and rows
the foundation did not need (v >= 0 is implied by minimising v^2 over v >= g - w).
"""

import warnings

import cvxpy as cp
import numpy as np
import pytest

from gaocvx import DiscreteProblem, Scene, solve
from gaocvx import convex
from gaocvx.mixed import MixedForm
from gaocvx.certificate import certify, passes

BEAM = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}


def gao_scene(supports, elements, contact=None, q=-5e8):
    data = {"beam": {**BEAM, "model": "gao", "supports": supports}, "load": {"q": q},
            "mesh": {"elements": elements}}
    if contact == "foundation":
        data["foundation"] = {"gap": 0.007, "stiffness": 5e10}
    elif contact == "obstacle":
        data["obstacle"] = {"gap": 0.007}
    return Scene.from_dict(data)


def test_foundation_needs_one_row_per_contact_point():
    """min c/2 sum w_q v_q^2 over v >= g - w_q is c/2 sum w_q pos(g - w_q)^2: v >= 0 is implied.

    The program has one inequality row per contact point, and the same minimiser and
    energy as with the v >= 0 rows added back.
    """
    mf = MixedForm(DiscreteProblem(gao_scene("P1", 64, "foundation")))
    program = convex.ConvexProgram(mf)
    data, _, _ = program.problem.get_problem_data(cp.CLARABEL)
    assert data["dims"].nonneg == len(mf.wqc)
    depth = next(v for v in program.problem.variables() if v.name() == "depth")
    with_rows = cp.Problem(program.problem.objective, program.problem.constraints + [depth >= 0])
    settings = dict(tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with_rows.solve(solver=cp.CLARABEL, **settings)
        z_rows, value_rows = program.z.value.copy(), with_rows.value
        program.problem.solve(solver=cp.CLARABEL, **settings)
    assert program.problem.value == pytest.approx(value_rows, rel=1e-9)
    assert np.abs(program.z.value - z_rows).max() <= 1e-7 * np.abs(z_rows).max()
    assert np.all(depth.value >= -1e-9)   # v = pos(g - w) at the minimum, never negative


def test_first_rung_does_not_equilibrate():
    """Clarabel's equilibration of the scaled program: 108 iterations on a clamped Gao
    beam without contact at 2048 elements; the first rung, without it, certifies in ~16."""
    for kind in ("smooth", "obstacle"):
        assert convex.CLARABEL_LADDER[kind][0]["equilibrate_enable"] is False
    dp = DiscreteProblem(gao_scene("P1", 2048))
    raw = convex.solve_convex(dp)
    assert raw["status"] == "optimal", raw["message"]
    assert raw["nit"] <= 30


@pytest.mark.parametrize("supports", ["P1", "P4"])
@pytest.mark.slow
def test_obstacle_certified_at_8192_elements(supports):
    """A node in point contact (P1) and a flat contact zone (P4) at 8192 elements: with
    equilibration Clarabel left stationarity 1.4e-5 (P1), a node 7e-11 W inside the
    obstacle; the first rung now certifies both, and they agree with Newton."""
    scene = gao_scene(supports, 8192, "obstacle")
    a = solve(scene, "convex")
    assert a.success, a.message
    b = solve(scene, "newton")
    assert b.success, b.message
    assert np.abs(a.w - b.w).max() <= 1e-6 * np.abs(b.w).max()


def test_first_rung_is_checked_not_trusted(monkeypatch):
    """The smooth first rung skips iterative refinement: whatever it returns is certified,
    and an uncertified answer still goes up the ladder (here a rung made useless)."""
    useless = dict(convex.CLARABEL_LADDER["smooth"][0], max_iter=2)
    monkeypatch.setitem(convex.CLARABEL_LADDER, "smooth",
                        [useless] + convex.CLARABEL_LADDER["smooth"][1:])
    dp = DiscreteProblem(gao_scene("P2", 128, "foundation"))
    raw = convex.solve_convex(dp)
    assert raw["status"] == "optimal" and passes(raw["residual"])
    mf = raw["mixed"]
    assert passes(certify(mf, raw["z"]))

