"""The global method's fast path with a rigid obstacle or a channel (issue 10).

References from outside the code under test: the dense CVXPY + Clarabel node
programs (the ground truth on small meshes), the Hermite-DOF certificate of
certificate.py, the independent energy and multi-start local searches of the
campaign (tests/nonconvex_independent.py through nonconvex_campaign_support.py),
and the convergence of the certified energies with the mesh.
"""

import math

import numpy as np
import pytest

from conftest import scene_dict

from gaocvx import DiscreteProblem, Scene, SceneError, solve


def _data(supports="P4", q=-1e8, axial=1.5e9, gap=0.01, above=None, elements=16):
    d = scene_dict(supports, q=q, axial=axial, obstacle=gap, elements=elements)
    if above is not None:
        d["obstacle"]["gap_above"] = above
    return d


def _programs(**kw):
    from gaocvx.nonconvex.fast_contact import FastContactProgram
    from gaocvx.nonconvex.minimum import rescale_for
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.node import NodeProgram

    dp = DiscreteProblem(Scene.from_dict(_data(**kw)), check_convexity=False)
    m = unstable_modes(dp)
    dp = rescale_for(dp, m)
    return dp, m, FastContactProgram(dp, m), NodeProgram(dp, m)


# The scenes: a point contact, a channel holding the beam against its ceiling, the
# obstacle never touched, gap 0, a flat contact zone, a channel just above the limit.
POINT = dict()
CHANNEL = dict(q=-1e7, above=0.02)
UNTOUCHED = dict(q=-1e7, axial=1.3e9, gap=0.1)
GAP0 = dict(gap=0.0)
FLAT = dict(q=-1e9, gap=0.001)
NEAR_LIMIT = dict(q=-1e7, axial=1.1685e9, gap=0.01, above=0.01)   # P_bar_h = 1.1683e9 N


@pytest.mark.parametrize("kw", [POINT, CHANNEL, GAP0])
def test_node_values_and_bounds_agree_with_the_dense_programs(kw):
    dp, m, fast, dense = _programs(**kw)
    assert m.k == 1
    for lo, hi in ((-3.0, 3.0), (-1.0, 0.5), (0.5, 2.0), (-0.3, -0.3), (1.0, 1.0), (-40.0, -20.0)):
        a, b = fast.solve_box([lo], [hi]), dense.solve_box([lo], [hi])
        if b.status == "infeasible":   # no admissible beam has these amplitudes
            assert a.lower == math.inf
            continue
        assert a.ok and b.ok
        scale = abs(b.value) + 1.0
        # each method's bound lies below the energy of the other's minimiser (a beam with
        # amplitudes in the box; the relaxations differ by the fast one's margin
        # delta sum s_i^2 >= 0, see test_nonconvex_fast), and the values agree (the
        # dense programs take the chord on the box's admissible part: so does the
        # fast one given that part)
        assert a.lower <= dp.energy(b.u) + 1e-11 * scale
        assert b.lower <= dp.energy(a.u) + 1e-11 * scale
        part = fast.solve_box([max(lo, float(dense.smin[0]))], [min(hi, float(dense.smax[0]))])
        assert part.value == pytest.approx(b.value, rel=1e-9, abs=1e-9)
        assert a.value - a.lower <= 1e-11 * scale
        assert lo - 1e-10 <= a.s[0] <= hi + 1e-10   # (the box rows are met to FEASIBLE)


def test_the_bound_holds_with_wrong_multipliers():
    """The node bound is Lagrangian duality: any multipliers >= 0 give a valid bound
    (the inner solve may be inexact; it only gets weaker)."""
    dp, m, fast, dense = _programs(**CHANNEL)
    rng = np.random.default_rng(3)
    lo, hi = np.array([-3.0]), np.array([3.0])
    # (the dense relaxation with the box's own chord, as the fast path takes it: not
    # the chord on the box's admissible part)
    dense.smin, dense.smax = np.full(1, -math.inf), np.full(1, math.inf)
    truth = dense.solve_box(lo, hi).value
    sol = fast.solve_box(lo, hi)
    for _ in range(6):
        lam = sol.lam * rng.uniform(0, 3, size=sol.lam.shape) + rng.uniform(0, 1e-2, size=sol.lam.shape)
        eta = rng.uniform(0, 10, size=2)
        bound = fast.dual_bound(lo, hi, lam, eta)
        assert bound <= truth + 1e-12 * abs(truth)
    assert fast.dual_bound(lo, hi, sol.lam, np.zeros(2)) == pytest.approx(truth, rel=1e-10)


@pytest.mark.parametrize("kw", [POINT, CHANNEL, UNTOUCHED, GAP0])
def test_certified_minimum_equals_the_dense_one(kw):
    from gaocvx.nonconvex.minimum import solve_global

    out = {}
    for fast in (False, True):
        dp = DiscreteProblem(Scene.from_dict(_data(**kw)), check_convexity=False)
        dp, raw, info = solve_global(dp, fast=fast)
        assert raw["status"] == "optimal", raw["message"]
        energy = sum(raw["mixed"].energy_parts(raw["z"]).values()) * dp.E0
        out[fast] = (dp.to_physical(raw["u"])[0], info["lower_bound"], energy, info["unique"])
    (w0, lo0, e0, u0), (w1, lo1, e1, u1) = out[False], out[True]
    scale = max(abs(e0), 1e-3)
    assert abs(e1 - e0) <= 1e-9 * scale and lo0 <= e1 + 1e-9 * scale and lo1 <= e0 + 1e-9 * scale
    assert u0 and u1
    assert np.max(np.abs(w1 - w0)) <= 1e-6 * max(np.max(np.abs(w0)), 1e-12)


# A campaign's scene: P3 in a 0.44 mm channel at gap 0 under a 3e7 N point force
# (two modes, 10 elements).
_PRESSED_CHANNEL = {
    "beam": {"model": "gao", "supports": "P3", "length": 1.4003114729102153, "E": 2.1e11,
             "nu": 0.3, "half_thickness": 0.239635457004604, "width": 1.0},
    "load": {"points": [[1.0311919808750751, 31384765.5139572]], "axial": 48655831868.356544},
    "mesh": {"elements": 10}, "obstacle": {"gap": 0.0, "gap_above": 0.0004398835786167011}}


@pytest.mark.parametrize("kw", [CHANNEL, GAP0])
def test_dense_amplitude_ranges_equal_the_mixed_forms(kw):
    """The same linear program written on the Hermite DOFs and on the mixed form."""
    dp, m, fast, dense = _programs(**kw)
    for a, b in ((dense.smin, fast.smin), (dense.smax, fast.smax)):
        assert np.isfinite(a).tolist() == np.isfinite(b).tolist()
        ok = np.isfinite(a)
        assert np.allclose(a[ok], b[ok], rtol=1e-7, atol=1e-7)
    if kw is CHANNEL:
        assert np.all(np.isfinite(dense.smin)) and np.all(np.isfinite(dense.smax))


def test_dense_amplitude_range_of_an_unbounded_side_is_found_without_solver_failures(caplog):
    """P1 on an obstacle 8.4e-6 m below (two modes): every side is unbounded.  Written
    with the equality rows (G Phi)'v = 0, whose round-off entries are 2e-17, HiGHS
    failed ("Solve error") on one side by all its methods, and a warning said so."""
    import logging

    from gaocvx.nonconvex.minimum import rescale_for
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.node import NodeProgram

    d = scene_dict("P1", q=0.0, axial=15207024486.094387, obstacle=8.429096783427796e-06,
                   elements=10)
    dp = DiscreteProblem(Scene.from_dict(d), check_convexity=False)
    m = unstable_modes(dp)
    assert m.k == 2
    with caplog.at_level(logging.WARNING, logger="gaocvx.nonconvex.fast_check"):
        prog = NodeProgram(rescale_for(dp, m), m)
    assert not caplog.records
    assert np.all(prog.smin == -math.inf) and np.all(prog.smax == math.inf)


@pytest.mark.slow
def test_dense_programs_certify_the_beam_pressed_into_a_channel():
    """Clarabel did not prove the boxes beyond the channel's ceiling infeasible
    ("error", "infeasible_inaccurate"); each kept its parent's bound and the search
    ran to its 4000 nodes uncertified (84 s).  With the amplitudes' range those
    boxes close; the dense answer equals the fast path's."""
    from gaocvx.nonconvex.minimum import solve_global

    out = {}
    for fast in (False, True):
        dp = DiscreteProblem(Scene.from_dict(_PRESSED_CHANNEL), check_convexity=False)
        dp, raw, info = solve_global(dp, fast=fast)
        assert raw["status"] == "optimal", raw["message"]
        energy = sum(raw["mixed"].energy_parts(raw["z"]).values()) * dp.E0
        out[fast] = (dp.to_physical(raw["u"])[0], info["lower_bound"], energy, info["nodes"])
    (w0, lo0, e0, n0), (w1, lo1, e1, n1) = out[False], out[True]
    assert n0 < 1000
    assert abs(e1 - e0) <= 1e-9 * abs(e0) and lo0 <= e1 + 1e-9 * abs(e0) and lo1 <= e0 + 1e-9 * abs(e0)
    assert np.max(np.abs(w1 - w0)) <= 1e-6 * np.max(np.abs(w0))
    assert np.max(w0) <= 0.0004398835786167011 * (1 + 1e-9) and np.min(w0) >= -1e-12


def test_mirror_symmetric_channel_has_two_minimisers():
    """No load, a symmetric channel: buckled up or down alike (not unique)."""
    from gaocvx.nonconvex.minimum import solve_global

    dp = DiscreteProblem(Scene.from_dict(_data(q=0.0, above=0.01)), check_convexity=False)
    dp, raw, info = solve_global(dp, fast=True)
    assert raw["status"] == "optimal" and info["unique"] is False
    w = dp.to_physical(raw["u"])[0]
    other = dp.to_physical(info["alternatives"][0]["u"])[0]
    assert np.max(np.abs(other + w)) <= 1e-6 * np.max(np.abs(w))
    assert info["alternatives"][0]["energy"] == pytest.approx(
        sum(raw["mixed"].energy_parts(raw["z"]).values()) * dp.E0, rel=1e-9)


def test_mixed_certificate_agrees_with_the_hermite_one():
    from gaocvx.nonconvex.certificate import psi_certificate
    from gaocvx.nonconvex.fast_check import certify
    from gaocvx.nonconvex.minimum import solve_global, to_mixed

    dp = DiscreteProblem(Scene.from_dict(_data(elements=64, **CHANNEL)), check_convexity=False)
    dp, raw, info = solve_global(dp, fast=True)
    assert raw["status"] == "optimal"
    _, m, fast, _ = _programs(elements=64, **CHANNEL)
    # the same scale as the answer's
    from gaocvx.nonconvex.fast_contact import FastContactProgram
    fast = FastContactProgram(dp, m)
    mf = fast.mf
    z = mf.on_manifold(to_mixed(mf, raw["u"]))
    for lam in (raw["lam"], 1.001 * raw["lam"]):
        mixed = certify(fast, z, lam, mf.zero_floor)
        hermite = psi_certificate(dp, m, raw["u"], lam, fast.rows, fast.levels, mf.zero_floor)
        for key in ("stationarity", "feasibility", "dual", "complementarity"):
            assert mixed[key] == pytest.approx(hermite[key], rel=0.05, abs=1e-13), key


@pytest.mark.parametrize("fast", [False, True])
def test_the_answer_is_certified_once_and_the_certificate_is_its_own(fast, monkeypatch):
    """The polished answer's certificate, computed when deciding whether the
    search's best point is kept, is the one returned: it is not computed again,
    and it equals a fresh certificate of the point returned."""
    from gaocvx.nonconvex import polish
    from gaocvx.nonconvex.minimum import solve_global

    calls = []
    original = polish.certify_answer

    def counted(*args):
        calls.append(1)
        return original(*args)

    monkeypatch.setattr(polish, "certify_answer", counted)
    dp = DiscreteProblem(Scene.from_dict(_data(**POINT)), check_convexity=False)
    dp, raw, info = solve_global(dp, fast=fast)
    assert raw["status"] == "optimal" and info["unique"]
    assert len(calls) == 1
    from gaocvx.nonconvex.fast_contact import FastContactProgram
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.node import NodeProgram

    m = unstable_modes(dp)
    prog = FastContactProgram(dp, m) if fast else NodeProgram(dp, m)
    _, residual, _ = polish.answer_certificate(dp, prog, raw["mixed"], raw["u"], raw["lam"])
    for key, value in raw["residual"].items():
        assert residual[key] == pytest.approx(value, rel=1e-9, abs=1e-15), key


@pytest.mark.parametrize("kw", [FLAT, pytest.param(NEAR_LIMIT, marks=pytest.mark.slow)])
def test_independent_campaign_checker_finds_no_violation(kw, monkeypatch):
    """The campaign's rules (independent energy, KKT point, nothing found below the
    bound) with the fast path forced on a mesh the dense programs also take."""
    import gaocvx.nonconvex.minimum as minimum
    from campaign import Case
    from nonconvex_campaign_support import run_case

    monkeypatch.setattr(minimum, "fast_by_default", lambda dp, k: minimum.fast_eligible(dp, k))
    rec = run_case(Case(_data(**kw), ("obstacle",)), starts=8)
    assert rec["status"] == "optimal" and rec["violations"] == [], rec


def test_beyond_the_dense_programs_auto_takes_the_fast_path():
    r = solve(Scene.from_dict(_data(elements=256, **CHANNEL)))
    assert r.method == "global" and r.status == "optimal", r.message
    assert r.max["w"] == pytest.approx(0.02, rel=1e-9) and r.min["w"] >= -0.01 * (1 + 1e-9)
    r16 = solve(Scene.from_dict(_data(**CHANNEL)))
    assert r.energy == pytest.approx(r16.energy, rel=1e-4)


def test_beyond_the_fast_path_is_refused():
    from gaocvx.nonconvex.api import MAX_FAST_ELEMENTS

    with pytest.raises(SceneError, match="elements"):
        solve(Scene.from_dict(_data(elements=2 * MAX_FAST_ELEMENTS)), "global")


@pytest.mark.slow
def test_reflected_minimiser_of_a_symmetric_channel_is_reported():
    """P1 in a channel, k = 2, 256 elements: the minimiser is slightly asymmetric
    (3.4e-6 m against 1 cm) and its image in x -> L - x has the same energy; the
    two amplitudes +-s_2 fell in one group of leaves, and unique was reported."""
    from gaocvx.nonconvex.minimum import solve_global

    d = _data("P1", q=-1e7, axial=1.1e10, gap=0.005, above=0.01, elements=256)
    dp, raw, info = solve_global(DiscreteProblem(Scene.from_dict(d), check_convexity=False))
    assert raw["status"] == "optimal" and info["unstable_modes"] == 2
    w = dp.to_physical(raw["u"])[0]
    assert np.max(np.abs(w - w[::-1])) > 1e-4 * np.max(np.abs(w))
    assert info["unique"] is False
    other = dp.to_physical(info["alternatives"][0]["u"])[0]
    assert np.max(np.abs(other - w[::-1])) <= 1e-9 * np.max(np.abs(w))


@pytest.mark.slow
def test_solve_certifies_a_flat_contact_the_dense_programs_do_not():
    """16 elements, a beam pressed flat onto an obstacle 1 mm below: the dense programs
    end uncertified (2001 nodes and 121 s; later, going on from the first search's
    leaves, 10 s with stationarity 1.3e-4), and solve() then takes the fast path."""
    r = solve(Scene.from_dict(_data(**FLAT)), "global")
    assert r.status == "optimal", r.message
    assert r.min["w"] == pytest.approx(-0.001, rel=1e-7)


@pytest.mark.slow
@pytest.mark.parametrize("kw", [POINT, CHANNEL])
def test_certified_energies_converge_with_the_mesh(kw):
    """64..1024 elements on the fast path, all certified: successive differences of the
    energy fall like h^4 (fitted 3.94 for both; 64..2048 elements through solve() fitted
    3.9996 for the point contact, docs/nonconvex.md; solve() takes the dense programs up to 128
    elements, 80 s at 128, which made this test 110 s)."""
    from gaocvx.nonconvex.minimum import solve_global
    energies = []
    for n in (64, 128, 256, 512, 1024):
        dp = DiscreteProblem(Scene.from_dict(_data(elements=n, **kw)), check_convexity=False)
        dp, raw, _ = solve_global(dp, fast=True)
        assert raw["status"] == "optimal", (n, raw["message"])
        energies.append(dp.energy(raw["u"]) * dp.E0)
    # successive differences ~ h^order: log2 of them falls by `order` per halving of h
    d = np.abs(np.diff(energies))
    order = -np.polyfit(np.arange(len(d)), np.log2(d), 1)[0]
    assert order >= 3.5, (energies, order)


@pytest.mark.slow
def test_json_output_stays_json_when_highs_fails_in_presolve(capfd, tmp_path):
    """A hidden-scene trial's P1 beam on an obstacle with three modes: HiGHS's presolve
    failed ("Solve error") on the amplitude range of the third mode, an unbounded LP,
    and HiGHS printed the failure to the process's standard output, ahead of the JSON
    of ``gaocvx solve --json``, which then did not parse.  Standard output is kept for
    the JSON (captured at the file descriptor: HiGHS writes there, not to sys.stdout),
    and the LP is solved again without presolve: unbounded, as it is."""
    import json

    from gaocvx.cli import main
    path = tmp_path / "g1_12.toml"
    path.write_text('[beam]\nmodel = "gao"\nsupports = "P1"\nlength = 1.0\nE = 2.1e11\n'
                    'nu = 0.3\nhalf_thickness = 0.1\nwidth = 1.0\n[load]\n'
                    'points = [[0.4119, 2387334.941152279], [0.0659, -3798873.95063084]]\n'
                    'axial = 23667681669.613983\n[obstacle]\ngap = 0.019431968268937762\n'
                    '[mesh]\nelements = 16\n')
    code = main(["solve", str(path), "--json"])
    out, err = capfd.readouterr()
    data = json.loads(out)
    assert code == 0 and data["status"] == "optimal" and data["global"]["unstable_modes"] == 3
    assert "Highs" not in out + err and "linprog status" not in err


@pytest.mark.slow
def test_three_modes_on_an_obstacle_take_the_fast_path_on_coarse_meshes():
    """A hidden-scene trial's P4 beam on an obstacle 1 mm below at 15 P_bar_h (k = 3,
    24 elements): the dense programs ran to their 4000 nodes (46 s); the fast path,
    now the default from three modes, certifies it in a few hundred.  The
    independent checker of the campaign confirms the answer."""
    from campaign import Case
    from nonconvex_campaign_support import run_case
    data = _data("P4", q=-1e7, axial=17520014950.425335, gap=0.001, elements=24)
    rec = run_case(Case(data, ("P4", "obstacle")), starts=6)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal" and rec["k"] == 3, rec.get("message")
    assert rec["nodes"] < 1000, rec["nodes"]
