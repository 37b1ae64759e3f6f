"""Equilibria above the convexity limit with a rigid obstacle or channel on the fast path.

Beyond the dense programs' 128 elements ``equilibria`` takes the reduced
function from exact amplitude slices of the fast contact program's mixed form
(:class:`gaocvx.nonconvex.slices.ContactSlices`).  References from outside
the code under test: the dense CVXPY + Clarabel programs on small meshes (the
ground truth: count, stability, energies, amplitudes), the obstacle's and the
channel's geometry (a beam held at the floor or the ceiling), the flat beam's
closed form (w = 0, energy 0), and the convergence of the energies with the mesh.
"""

import numpy as np
import pytest

from conftest import scene_dict

from gaocvx import DiscreteProblem, Scene, SceneError
from gaocvx.nonconvex import equilibria, equilibrium_path


def _scene(supports="P4", q=-1e7, axial=None, fraction=1.3, gap=0.01, above=None, elements=16):
    if axial is None:
        probe = DiscreteProblem(Scene.from_dict(scene_dict(supports, q=q, elements=elements)),
                                check_convexity=False)
        axial = fraction * probe.P_bar_h
    d = scene_dict(supports, q=q, axial=axial, obstacle=gap, elements=elements)
    if above is not None:
        d["obstacle"]["gap_above"] = above
    return Scene.from_dict(d)


def _same(fast, dense):
    """The fast equilibria are the dense programs' (sorted by energy both)."""
    assert len(fast) == len(dense)
    scale = max(abs(e.energy) for e in dense)
    S = max(abs(e.amplitudes[0]) for e in dense)
    for f, e in zip(fast, dense):
        assert f.stable == e.stable
        assert f.status == e.status == "optimal"
        # (measured: 1e-14 to 8e-10 of the energy; the dense programs' own accuracy
        # is Clarabel's 1e-10 to 1e-12 of the scale)
        assert abs(f.energy - e.energy) <= 1e-8 * max(abs(e.energy), 1e-6 * scale)
        # (measured: at most 2e-9 of the largest amplitude)
        assert abs(f.amplitudes[0] - e.amplitudes[0]) <= 1e-7 * S
        assert np.max(np.abs(f.w - e.w)) <= 1e-6 * np.max(np.abs(e.w)) + 1e-12


@pytest.mark.parametrize("kw", [
    dict(supports="P4", gap=1.0),        # obstacle never touched: three equilibria
    pytest.param(dict(supports="P2", gap=0.01), marks=pytest.mark.slow),  # the lowest held: three
    pytest.param(dict(supports="P1", gap=0.01), marks=pytest.mark.slow),     # three
    pytest.param(dict(supports="P3", gap=0.01), marks=pytest.mark.slow),     # held at the tip: one
])
def test_fast_equilibria_are_the_dense_programs_equilibria(kw):
    scene = _scene(**kw)
    dense = equilibria(scene, fast=False)
    fast = equilibria(scene, fast=True)
    assert len(dense) in (1, 3)
    _same(fast, dense)


@pytest.mark.slow
@pytest.mark.parametrize("kw", [
    dict(supports="P4", q=-1e8, axial=1.5e9, gap=0.01),      # a point contact: one
    dict(supports="P4", gap=0.01),                             # three
    dict(supports="P4", q=0.0, axial=4.5552e9, gap=0.002, above=0.003),   # narrow channel
    dict(supports="P1", q=0.0, gap=0.002, above=0.003),
    dict(supports="P2", q=0.0, gap=0.002, above=0.003),
    dict(supports="P3", q=0.0, gap=0.002, above=0.003),
])
def test_fast_equilibria_are_the_dense_programs_equilibria_more(kw):
    scene = _scene(**kw)
    dense, fast = equilibria(scene, fast=False), equilibria(scene, fast=True)
    if kw.get("above"):
        # w = 0 without load: the dense programs return 1e-13 m and 1e-16 J, the
        # fast slices 0 to round-off; the two held beams are compared
        assert len(dense) == len(fast) == 3 and not dense[2].stable and not fast[2].stable
        assert max(abs(fast[2].min["w"]), abs(fast[2].max["w"])) < 1e-9
        dense, fast = dense[:2], fast[:2]
    _same(fast, dense)


@pytest.mark.slow
def test_narrow_channel_beyond_the_dense_programs():
    """The channel of 2 mm below and 3 mm above (three equilibria, two of three were
    once missed by the grid) at 136 elements, beyond the dense programs: held at the
    ceiling, held on the floor (both stable) and w = 0 (unstable)."""
    scene = _scene(q=0.0, axial=4.5552e9, gap=0.002, above=0.003, elements=136)
    from gaocvx.nonconvex.minimum import MAX_ELEMENTS
    with pytest.raises(SceneError, match=f"fast=False, at most {MAX_ELEMENTS}"):
        equilibria(scene, fast=False)           # the dense programs stop at 128
    eqs = equilibria(scene)
    assert [e.status for e in eqs] == ["optimal"] * 3
    assert [e.stable for e in eqs] == [True, True, False]
    assert eqs[0].max["w"] == pytest.approx(0.003, rel=1e-7)
    assert eqs[1].min["w"] == pytest.approx(-0.002, rel=1e-7)
    assert max(abs(eqs[2].min["w"]), abs(eqs[2].max["w"])) < 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("supports", ["P1", "P4"])
def test_beam_pressed_flat_at_gap_zero_is_a_stable_equilibrium(supports):
    """q = -1e8 N/m onto an obstacle at gap 0, 1.5 P_bar: the flat beam (w = 0,
    energy 0; every constraint point carries a force, so no admissible direction is
    free: a strict local minimum) lies at a kink (P1, F = 0.55 |s|) or at the end of
    the admissible amplitudes (P4, F = 0.44 s, s >= 0) of the reduced function,
    where F' does not vanish.  The dense programs report it as unstable and
    inaccurate (their slopes near it are round-off); the others agree."""
    scene = _scene(supports, q=-1e8, fraction=1.5, gap=0.0)
    fast = equilibria(scene, fast=True)
    assert [e.status for e in fast] == ["optimal"] * 3
    flat = [e for e in fast if np.max(np.abs(e.w)) < 1e-9]
    assert len(flat) == 1 and flat[0].stable
    scale = max(abs(e.energy) for e in fast)
    assert abs(flat[0].energy) <= 1e-10 * scale      # (measured: 4e-12 for P4, 3e-15 for P1)
    dense = equilibria(scene, fast=False)
    assert len(dense) == 3
    bent = [e for e in dense if np.max(np.abs(e.w)) > 1e-6]
    _same([e for e in fast if e is not flat[0]], bent)


def test_beyond_the_fast_paths_limit_is_refused():
    from gaocvx.nonconvex.api import MAX_FAST_ELEMENTS
    with pytest.raises(SceneError, match=str(MAX_FAST_ELEMENTS)):
        equilibria(_scene(elements=MAX_FAST_ELEMENTS + 1))


@pytest.mark.slow
def test_path_on_256_elements_with_an_obstacle():
    """A path with an obstacle beyond the dense programs: the second force, searched
    with the first force's equilibria as seeds, has the equilibria found without them
    (measured: 32 s, 10 s of slices per force)."""
    scene = _scene(supports="P4", q=-1e7, axial=0.0, gap=0.01, elements=256)
    P = [1.45e9, 1.5e9]
    path = equilibrium_path(scene, P)
    assert not path.errors and all(p["status"] == "optimal" for p in path.points)
    assert [len(path.at(p)) for p in P] == [3, 3]
    alone = equilibria(scene.with_overrides({"load.axial": P[1]}))
    for p, e in zip(path.at(P[1]), alone):
        assert p["energy"] == pytest.approx(e.energy, rel=1e-9)
        assert p["stable"] == e.stable
    assert sum(p["global"] for p in path.at(P[1])) == 1


@pytest.mark.slow
def test_energies_converge_with_the_mesh_on_the_fast_path():
    """A point contact (P4, q = -1e8 N/m, 1.5e9 N, 1 cm below) on 64 to 512 elements:
    one equilibrium at each, whose energy's successive differences fall like h^4
    (Hermite cubics: measured ratios 16.0, 16.0 and 13.7 up to 1024 elements, where
    the difference, 3.7e-6 J of 6.8e5, nears the solves' round-off; 1024 to 2048
    changed it by -2e-7 J)."""
    energies = []
    for n in (64, 128, 256, 512):
        eqs = equilibria(_scene(q=-1e8, axial=1.5e9, gap=0.01, elements=n), fast=True)
        assert len(eqs) == 1 and eqs[0].stable and eqs[0].status == "optimal"
        assert eqs[0].min["w"] == pytest.approx(-0.01, rel=1e-9)     # on the obstacle
        energies.append(eqs[0].energy)
    diffs = np.abs(np.diff(energies))
    order = -np.polyfit(np.log([64, 128, 256]), np.log(diffs), 1)[0]
    assert 3.7 < order < 4.3, (order, diffs)


@pytest.mark.heavy
def test_two_unstable_modes_with_an_obstacle():
    """k = 2 (P1 above its second mode load, q = -5e7 N/m, an obstacle 1 cm below):
    every equilibrium the plane search lists on the contact slices is one of the
    independent energy (KKT point, its stability by second-order conditions), and
    the dense programs list the same ones.  Seven: the buckled global minimum, a
    beam resting on the obstacle just off the middle and its mirror image (both
    stable), the saddle at s2 = 0 between them (4.8e-4 from each in s2), two
    mirror unstable ones and a slightly bent unstable one.  (The search once
    listed two, with the dense programs agreeing: the three near the obstacle lie
    within the coarse grid's step of each other.  The saddle lies on the line of
    symmetry s2 = 0, where the sign of dF/ds2 is round-off: the contact slices
    missed it until the zeros on such lines were looked for along them.)"""
    from test_equilibria_obstacle_campaign import _checked
    scene = Scene.from_dict(scene_dict("P1", q=-5e7, axial=1.1e10, obstacle=0.01, elements=16))
    dense, fast = equilibria(scene, fast=False), equilibria(scene, fast=True)
    _checked(scene, fast)
    assert all(e.status == "optimal" for e in fast)
    assert len(fast) == 7 and sum(e.stable for e in fast) == 3
    resting = [e for e in fast if e.stable and abs(e.min["w"] + 0.01) < 1e-9]
    assert len(resting) == 2 and np.allclose(resting[0].w, resting[1].w[::-1], atol=1e-9)
    saddle = [e for e in fast if not e.stable and abs(e.min["w"] + 0.01) < 1e-9]
    assert len(saddle) == 1 and abs(saddle[0].amplitudes[1]) <= 1e-9
    _checked(scene, dense)
    scale = max(abs(e.energy) for e in dense)

    def same(a, b):
        return a.stable == b.stable and \
            abs(a.energy - b.energy) <= 1e-8 * max(abs(b.energy), 1e-6 * scale)
    assert len(dense) == len(fast)
    assert all(any(same(f, e) for e in dense) for f in fast)
    assert all(any(same(e, f) for f in fast) for e in dense)


def _flat_on_obstacle(monkeypatch):
    """P1 without load at 1.3 P_bar_h on an obstacle at gap 0 (8 elements): w = 0
    is an equilibrium, certified on the whole beam; the second-order conditions
    are switched off (as beyond 1000 unknowns), and so is the exact lift-off rule
    (``obstacle_checks.lift_off_curvature``: without load P1's first mode lifts the beam
    off, and it would call w = 0 unstable whatever the probes say), so the probes
    label it: these tests give stand-in labels, to follow them through."""
    from gaocvx.nonconvex.minimum import rescale_for
    from gaocvx.nonconvex.modes import unstable_modes
    monkeypatch.setattr("gaocvx.nonconvex.whole_beam.MAX_UNKNOWNS", -1)
    monkeypatch.setattr("gaocvx.nonconvex.obstacle_checks.lift_off_curvature",
                        lambda *args: None)
    dp = DiscreteProblem(_scene("P1", q=0.0, gap=0.0, elements=8), check_convexity=False)
    modes = unstable_modes(dp)
    return rescale_for(dp, modes), modes


def test_the_flat_beam_whose_probes_tell_nothing_is_listed_inaccurate(monkeypatch):
    """exact_flat adds w = 0 with the probes' label; where they never rose above
    F''s round-off (``known`` False) the entry is `inaccurate`, not `optimal`."""
    from gaocvx.nonconvex.obstacle_checks import exact_flat
    dp, modes = _flat_on_obstacle(monkeypatch)
    unknown = exact_flat(dp, modes, [], lambda s: (True, 1.0, False), S=1.0)
    assert [(e.stable, e.status) for e in unknown] == [(True, "inaccurate")]
    assert np.max(np.abs(unknown[0].w)) == 0.0
    # (two modes' classify gives two values: the label stands)
    known = exact_flat(dp, modes, [], lambda s: (True, 1.0), S=1.0)
    assert [(e.stable, e.status) for e in known] == [(True, "optimal")]


def test_an_inaccurate_entry_merged_into_the_flat_beam_is_probed_again(monkeypatch):
    """An entry at w = 0 listed `inaccurate` and unstable (its probes in round-off:
    a guess) becomes the exact flat beam, `optimal`: its label is the probes' at
    s = 0, not the guess.  (Before, the guess stood under `optimal`: a review's
    P1 beam at gap 0, 1.3 P_bar_h.)"""
    from gaocvx.nonconvex.equilibrium import Equilibrium
    from gaocvx.nonconvex.obstacle_checks import exact_flat
    dp, modes = _flat_on_obstacle(monkeypatch)
    zeros = np.zeros(len(dp.x))
    guess = Equilibrium(0.0, False, [1e-9], dp.x.copy(), zeros, zeros.copy(), 1e-3,
                        "inaccurate", float(dp.P), -1.0, float(dp.W))
    calls = []
    out = exact_flat(dp, modes, [guess], lambda s: calls.append(s) or (True, 2.0, True), S=1.0)
    assert calls and [(e.stable, e.status) for e in out] == [(True, "optimal")]


@pytest.mark.parametrize("q, lifts", [(0.0, True), (-1e3, False)])
def test_lift_off_decides_the_unloaded_flat_beam_only(q, lifts):
    """``lift_off_curvature``: P1 at 1.3 P_bar_h on an obstacle at gap 0 (8 elements).
    Without load the gradient at w = 0 is zero and the first mode, of one sign,
    lifts the beam off: unstable, exactly, with the curvature lambda_1 - p along it
    (the Rayleigh quotient of the independent K, G at that mode).  Under a load
    pressing it down the gradient is not zero, and the rule says nothing (the
    second-order conditions decide)."""
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.node import obstacle_rows
    from gaocvx.nonconvex.obstacle_checks import lift_off_curvature
    from nonconvex_independent import Discrete
    scene = _scene("P1", q=q, gap=0.0, elements=8)
    dp = DiscreteProblem(scene, check_convexity=False)
    rows, levels = obstacle_rows(dp)
    curvature = lift_off_curvature(dp, unstable_modes(dp), rows, levels)
    if not lifts:
        assert curvature is None
        return
    ind = Discrete(scene, 1.0)
    lam1 = ind.modes(1)[0][0]                 # (K phi = lam G phi, G-normalised)
    assert curvature == pytest.approx(lam1 - ind.p, rel=1e-6) and curvature < 0


def test_lift_off_needs_a_curvature_certainly_negative():
    """The modes' count takes lambda_i up to p (1 + MARGIN): a mode that lifts the
    beam off with lambda_i = p (at P_bar_h itself the flat beam is the minimum) or
    within the modes' margin of it decides nothing."""
    import dataclasses
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.node import obstacle_rows
    from gaocvx.nonconvex.obstacle_checks import lift_off_curvature
    dp = DiscreteProblem(_scene("P1", q=0.0, gap=0.0, elements=8), check_convexity=False)
    rows, levels = obstacle_rows(dp)
    modes = unstable_modes(dp)
    assert lift_off_curvature(dp, modes, rows, levels) < 0
    at_limit = dataclasses.replace(modes, lam=np.full_like(modes.lam, modes.p))
    assert lift_off_curvature(dp, at_limit, rows, levels) is None
    margin = float(modes.p - modes.lam[0]) / 2
    assert lift_off_curvature(dp, dataclasses.replace(modes, delta=margin), rows, levels) is None
