"""The second search near the flat beam in its own scale (gaocvx.nonconvex.zooms.own_scale).

Hand-made lists and problems: when the search runs (the flat beam a certified
minimum) and when not, the scale it measures the problem
in (the linearised energy's peak along a mode, worked out by hand), and what
of its finds is listed, in whose units.  The campaign scenes it was made for
are in tests/test_nonconvex_equilibria.py.
"""

from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest
import scipy.sparse as sp

from gaocvx.nonconvex.zooms import OWN_BOX, own_scale, peak_amplitude


def _problem():
    # H_0 = diag(-4, -1): along e_1 the load's work 2 t against the fall 2 t^2
    # peaks at t = 1/2; along e_2 (t/4 against t^2/2) at t = 1/4
    f = np.array([-2.0, 0.25])
    return NS(contact="obstacle", f=f, hessian=lambda u: sp.diags([-4.0, -1.0]), W=3.0,
              rescaled=lambda W: NS(W=W)), NS(phi=np.eye(2))


def _eq(stable, w, s, status="optimal", energy=0.0):
    return NS(stable=stable, status=status, w=np.asarray(w, float), amplitudes=list(s),
              W=3.0, energy=energy)


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
def test_not_searched_unless_the_flat_beam_is_a_certified_minimum(out):
    dp, modes = _problem()

    def search(d):
        raise AssertionError("searched")
    assert own_scale(dp, modes, out, 100.0, np.full(2, -100.0), np.full(2, 100.0),
                     search) is out


def test_its_finds_are_listed_in_the_problems_units():
    dp, modes = _problem()
    R = OWN_BOX * 0.5
    seen = []

    def search(d):
        seen.append(d.W)
        return [_eq(True, [0.0, 0.0], [0.0, 0.0]),                       # the flat beam
                _eq(False, [1e-3, 0.0], [0.2, -0.1], energy=1e-4),       # the saddle
                _eq(False, [1e-3, 0.0], [0.2, -0.1 + 1e-8], energy=1e-4),  # itself again
                _eq(False, [2e-3, 0.0], [0.3, 0.3], "inaccurate"),       # not resolved
                _eq(True, [4e-3, 0.0], [1.0, 0.5], energy=-1e-3),        # on the square's side
                _eq(True, [4e-3, 0.0], [0.5, -1.0], energy=-1e-3)]       # on a side the box ends
    # the first search's saddle elsewhere stays; its unresolved one at the
    # second's saddle gives way
    first = _minima() + [_eq(False, [0.1, 0.0], [3.0, 3.0]),
                         _eq(False, [1e-3, 0.0], [0.2 * R, -0.1 * R + 1e-7], "inaccurate")]
    out = own_scale(dp, modes, first, 100.0, np.array([-100.0, -R]),
                    np.full(2, 100.0), search)
    assert seen == [pytest.approx(dp.W * R, rel=1e-15)]
    assert out[:3] == first[:3]
    added = out[3:]
    assert len(added) == 2
    assert added[0].amplitudes == pytest.approx([0.2 * R, -0.1 * R], rel=1e-15)
    assert added[1].amplitudes == pytest.approx([0.5 * R, -R], rel=1e-15)
    assert all(e.W == dp.W for e in added)


def test_not_searched_where_the_peak_is_beyond_the_square():
    dp, modes = _problem()

    def search(d):
        raise AssertionError("searched")
    out = _minima()
    assert own_scale(dp, modes, out, 1.5, np.full(2, -1.5), np.full(2, 1.5), search) is out
