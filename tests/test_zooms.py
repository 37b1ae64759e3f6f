"""The second search near the flat beam in its own scale (gaocvx.nonconvex.zooms.own_scale).

Hand-made lists and problems: when the search runs (two modes: the flat beam
listed stable and `optimal`; one: its own scale below NEAR_FLAT of the range) and
when not, the scale it measures the problem
in (the linearised energy's peak along a mode, worked out by hand), and what
of its finds is listed, in whose units.  The campaign scenes it was made for
are in tests/test_nonconvex_equilibria.py.
"""

from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest
import scipy.sparse as sp

from gaocvx.nonconvex import node
from gaocvx.nonconvex.equilibrium import MERGE
from gaocvx.nonconvex.zooms import NEAR_FLAT, OWN_BOX, own_scale, peak_amplitude


def _problem():
    # H_0 = diag(-4, -1): along e_1 the load's work 2 t against the fall 2 t^2
    # peaks at t = 1/2; along e_2 (t/4 against t^2/2) at t = 1/4
    f = np.array([-2.0, 0.25])
    return NS(contact="obstacle", f=f, hessian=lambda u: sp.diags([-4.0, -1.0]), W=3.0,
              rescaled=lambda W: NS(W=W)), NS(phi=np.eye(2), k=2)


def _eq(stable, w, s, status="optimal", energy=0.0, W=3.0, polished=False):
    w = np.asarray(w, float)
    return NS(stable=stable, status=status, w=w, slope=np.r_[w[1:], 0.0] - w,
              x=np.arange(len(w), dtype=float),
              amplitudes=list(s), W=W, energy=energy, whole_beam=polished)


def _minima():
    return [_eq(True, [0.0, 0.0], [0.0, 0.0]), _eq(True, [5.0, 1.0], [40.0, 2.0], energy=-1.0)]


def test_peak_amplitude_is_the_largest_over_the_falling_modes():
    dp, modes = _problem()
    assert peak_amplitude(dp, modes) == pytest.approx(0.5, rel=1e-15)
    # a rising mode has no peak
    dp.hessian = lambda u: sp.diags([4.0, 1.0])
    assert np.isnan(peak_amplitude(dp, modes))


@pytest.mark.parametrize("out", [
    [_eq(True, [1.0, 0.0], [1.0, 0.0]), _eq(True, [5.0, 1.0], [40.0, 2.0])],  # no flat beam
    [_eq(False, [0.0, 0.0], [0.0, 0.0]), _eq(True, [5.0, 1.0], [40.0, 2.0])],  # flat unstable
    [_eq(True, [0.0, 0.0], [0.0, 0.0], "inaccurate"), _eq(True, [5.0, 1.0], [40.0, 2.0])],
])
def test_not_searched_unless_the_flat_beam_is_listed_stable_and_optimal(monkeypatch, out):
    # (nor, with two modes, where its own size, here the rows' reach 10 along
    # either mode, is not below NEAR_FLAT of S: R = 40 against 0.1)
    dp, modes = _problem()
    monkeypatch.setattr(node, "obstacle_rows", lambda dp: (np.eye(2), np.full(2, -10.0)))

    def search(d):
        raise AssertionError("searched")
    assert own_scale(dp, modes, out, 100.0, np.full(2, -100.0), np.full(2, 100.0),
                     search) is out


def test_two_modes_are_searched_without_a_flat_beam_where_their_size_is_small(monkeypatch):
    # the rows' reach 10 along either mode: R = 40, below NEAR_FLAT of S = 1e5
    dp, modes = _problem()
    monkeypatch.setattr(node, "obstacle_rows", lambda dp: (np.eye(2), np.full(2, -10.0)))
    seen = []

    def search(d):
        seen.append(d.W)
        return []
    S = 1e5
    own_scale(dp, modes, [_eq(True, [5.0, 1.0], [40.0, 2.0])], S, np.full(2, -S),
              np.full(2, S), search)
    assert seen == [pytest.approx(dp.W * OWN_BOX * 10.0, rel=1e-15)]


def test_its_finds_are_listed_in_the_problems_units():
    dp, modes = _problem()
    R = OWN_BOX * 0.5
    seen = []

    def search(d):
        seen.append(d.W)
        return [_eq(True, [0.0, 0.0], [0.0, 0.0], W=d.W),                 # the flat beam
                _eq(False, [1e-3, 0.0], [0.2, -0.1], energy=1e-4, W=d.W),  # the saddle
                _eq(False, [1e-3, 0.0], [0.2, -0.1 + 1e-8], energy=1e-4, W=d.W),  # again
                _eq(False, [2e-3, 0.0], [0.3, 0.3], "inaccurate", W=d.W),  # not resolved
                _eq(True, [4e-3, 0.0], [1.0, 0.5], energy=-1e-3, W=d.W),   # on the square's side
                _eq(True, [4e-3, 0.0], [0.5, -1.0], energy=-1e-3, W=d.W)]  # where the box ends
    # the first search's saddle elsewhere stays; its unresolved one at the
    # second's saddle gives way
    first = _minima() + [_eq(False, [0.1, 0.0], [3.0, 3.0]),
                         _eq(False, [1e-3, 0.0], [0.2 * R, -0.1 * R + 1e-7], "inaccurate")]
    out = own_scale(dp, modes, first, 100.0, np.array([-100.0, -R]),
                    np.full(2, 100.0), search)
    assert seen == [pytest.approx(dp.W * R, rel=1e-15)]
    assert [id(e) for e in out[:3]] == [id(e) for e in first[:3]]
    added = out[3:]
    assert len(added) == 2
    assert added[0].amplitudes == pytest.approx([0.2 * R, -0.1 * R], rel=1e-15)
    assert added[1].amplitudes == pytest.approx([0.5 * R, -R], rel=1e-15)
    assert all(e.W == dp.W for e in added)       # (the finds came in d's, 6.0)


@pytest.mark.parametrize("open_side", [True, False])
def test_the_squares_own_minima_on_its_open_sides_do_not_keep_an_entry(monkeypatch, open_side):
    # (a two-mode trial, P2 at 6 elements 6.4e-15 m above an obstacle: the second
    # search found the four beams near the flat one `optimal` and two minima of the
    # square on its sides, no KKT points, `inaccurate`; the first search's
    # `inaccurate` flat beam stayed, and the list with it)  A side where the
    # admissible amplitudes go on is the square's: the entry gives way; where they
    # end there, the find is the problem's own and the entry stays
    dp, modes = _problem()
    monkeypatch.setattr(node, "obstacle_rows", lambda dp: (np.eye(2), np.full(2, -10.0)))
    S = 1e8
    R = OWN_BOX * 10.0
    assert R < MERGE * S

    def search(d):
        return [_eq(True, [-1e-3, 0.0], [-0.09, -0.002], W=d.W),
                _eq(True, [2e-3, 0.0], [1.0, 0.5], "inaccurate", W=d.W)]
    first = [_eq(True, [5.0, 1.0], [400.0, 20.0], energy=-1.0),
             _eq(True, [1e-3, 0.0], [0.0, 0.0], "inaccurate", energy=1.0)]
    hi = np.full(2, S) if open_side else np.array([R, S])
    verdicts = []
    out = own_scale(dp, modes, first, S, np.full(2, -S), hi, search, verdicts)
    assert (id(first[1]) in [id(e) for e in out]) is not open_side
    # (the list's proof holds only where each square's beams are all `optimal`)
    assert verdicts == [open_side]
    assert [e.amplitudes for e in out if e.status == "optimal" and abs(e.amplitudes[0]) < R] == [
        pytest.approx([-0.09 * R, -0.002 * R], rel=1e-15)]


@pytest.mark.parametrize("S, side", [(1.5, 1.5),     # R = 2 beyond the square
                                     (100.0, 1.9)])  # beyond half the admissible box
def test_not_searched_where_the_square_would_span_the_searched_one(S, side):
    dp, modes = _problem()

    def search(d):
        raise AssertionError("searched")
    out = _minima()
    assert own_scale(dp, modes, out, S, np.full(2, -side), np.full(2, side), search) is out


def test_an_unpolished_entry_at_a_polished_ones_beam_gives_way():
    """Within SAME_BEAM (1e-4) of a polished entry's deflection and slope, of its
    stability and inside the square, an entry not polished is that equilibrium to the
    slices' accuracy and is dropped; further away, of the other stability, or outside
    the square it stays."""
    dp, modes = _problem()
    R = OWN_BOX * 0.5
    w = np.array([1e-3, 5e-4, 0.0])

    def search(d):
        return [_eq(False, w, [0.2, 0.1], W=d.W, polished=True),
                _eq(False, w * (1 + 1e-3), [0.2, 0.1 + 1e-3], W=d.W)]       # 1e-3 off: stays
    first = _minima() + [
        _eq(False, w * (1 + 3e-5), [0.2 * R, 0.1 * R * (1 + 3e-5)]),            # dropped
        _eq(True, w * (1 + 3e-5), [0.2 * R, 0.1 * R * (1 + 4e-5)]),             # a minimum: stays
        _eq(False, np.r_[w[:2] * (1 + 3e-5), 0.0], [3.0 * R, 0.0])]             # outside: stays
    first[0].w, first[0].slope = np.zeros(3), np.zeros(3)
    first[1].w, first[1].slope = np.ones(3), np.zeros(3)
    out = own_scale(dp, modes, first, 100.0, np.full(2, -100.0), np.full(2, 100.0), search)
    ids = [id(e) for e in out]
    assert id(first[2]) not in ids
    assert all(id(e) in ids for e in first[:2] + first[3:])
    assert len(out) == len(first) + 1 and sum(e.whole_beam for e in out) == 1


def _one_mode(monkeypatch, f=-2.0, rows=((1.0,), (-3.0,))):
    # H_0 = -4, f = -2: the peak at 1/2; the obstacle row u >= -3: the mode reaches
    # it at s = -3, so the near-flat scale is 3 and R = OWN_BOX 3
    A, levels = np.array(rows[0])[:, None], np.array(rows[1])
    monkeypatch.setattr(node, "obstacle_rows", lambda dp: (A, levels))
    return (NS(contact="obstacle", f=np.array([f]), hessian=lambda u: sp.diags([-4.0]),
               W=3.0, rescaled=lambda W: NS(W=W)), NS(phi=np.eye(1), k=1))


@pytest.mark.parametrize("f, rows, hi, windows", [
    # a channel: the floor's reach 3, the ceiling's 3e6 (u <= 3e6), beyond NEAR_FLAT
    # of half the admissible range: the floor's scale alone
    (-2.0, ((1.0, -1.0), (-3.0, -3e6)), 3e6, [OWN_BOX * 3.0]),
    # the peak 5e3 far above the reach 3: both, the larger first
    (-2e4, ((1.0,), (-3.0,)), 1e12, [OWN_BOX * 5e3, OWN_BOX * 3.0])])
def test_each_scale_the_search_before_cannot_resolve_is_searched(monkeypatch, f, rows, hi,
                                                                   windows):
    dp, modes = _one_mode(monkeypatch, f, rows)
    seen = []

    def search(d):
        seen.append(d.W)
        return []
    S = 1e12
    own_scale(dp, modes, [_eq(True, [5.0, 1.0], [0.9 * hi])], S, np.full(1, -3.0),
              np.full(1, hi), search)
    assert seen == [pytest.approx(dp.W * R, rel=1e-15) for R in windows]


@pytest.mark.parametrize("S, windows", [
    (1.01 * OWN_BOX * 3.0 / NEAR_FLAT, [OWN_BOX * 3.0]),
    # (the reach's square not below NEAR_FLAT of S: the peak's, 1/2, alone)
    (0.99 * OWN_BOX * 3.0 / NEAR_FLAT, [OWN_BOX * 0.5]),
    (0.99 * OWN_BOX * 0.5 / NEAR_FLAT, [])])
def test_one_mode_is_searched_where_its_scale_lies_below_near_flat_of_the_range(
        monkeypatch, S, windows):
    # (without a flat beam listed: at a gap above 0 it is no equilibrium)
    dp, modes = _one_mode(monkeypatch)
    seen = []

    def search(d):
        seen.append(d.W)
        return []
    out = [_eq(True, [5.0, 1.0], [0.9 * S])]
    own_scale(dp, modes, out, S, np.full(1, -S), np.full(1, S), search)
    assert seen == [pytest.approx(dp.W * R, rel=1e-15) for R in windows]


@pytest.mark.parametrize("resolved", [True, False])
def test_an_entry_not_optimal_gives_way_within_merge_S_where_every_find_is_optimal(
        monkeypatch, resolved):
    # the first search's entry stood for the pressed beam 0.1 R off it (within MERGE
    # S, not MERGE R): it gives way where the second search found every beam
    # `optimal`, and stays where one of them is not
    dp, modes = _one_mode(monkeypatch)
    S, R = 1e8, OWN_BOX * 3.0
    assert 0.1 * R < MERGE * S

    def search(d):
        return [_eq(True, [-1e-3, 0.0], [-0.25], W=d.W),
                _eq(False, [1e-3, 0.0], [0.05], "optimal" if resolved else "inaccurate",
                    W=d.W)]
    first = [_eq(True, [5.0, 1.0], [0.9 * S]),
             _eq(False, [-1e-3, 0.0], [-0.35 * R], "inaccurate"),
             # (outside the square, which the second search did not look at: stays)
             _eq(False, [-1e-3, 0.0], [-1.5 * R], "inaccurate")]
    assert 1.5 * R < MERGE * S
    out = own_scale(dp, modes, first, S, np.full(1, -S), np.full(1, S), search)
    ids = [id(e) for e in out]
    assert (id(first[1]) in ids) is not resolved
    assert id(first[2]) in ids
    assert sum(e.stable and e.amplitudes == pytest.approx([-0.25 * R]) for e in out) == 1


@pytest.mark.parametrize("f", [-2e4, -2.0])
def test_an_entry_gives_way_within_the_first_searchs_distance_in_every_square(monkeypatch, f):
    # (a review's mock) the floor's square R = 12 finds the pressed beam at -3; the
    # first search's `inaccurate` entry 0.1 from it, within MERGE S, gives way
    # whether or not the peak's square (5e3 for f = -2e4) was searched before
    dp, modes = _one_mode(monkeypatch, f)
    S, floor = 1e12, OWN_BOX * 3.0

    def search(d):
        return [_eq(True, [-1e-3, 0.0], [-0.25], W=d.W)] if d.W == pytest.approx(
            dp.W * floor, rel=1e-12) else []
    first = [_eq(True, [5.0, 1.0], [0.9 * S]), _eq(False, [-1e-3, 0.0], [-2.9], "inaccurate")]
    out = own_scale(dp, modes, first, S, np.full(1, -3.0), np.full(1, S), search)
    assert id(first[1]) not in [id(e) for e in out]
    assert [e.amplitudes for e in out if e.stable and e.amplitudes[0] < 0] == [
        pytest.approx([-3.0])]
