"""The mirror image of a beam polished on the whole beam (gaocvx.nonconvex.images.complete_beams).

A real four-element problem (its mesh, supports and DOFs), hand-made beams and a
stand-in for the polish: what is mirrored, when the image is added, and when
not.  The campaign scene the function was made for is in
tests/test_nonconvex_equilibria.py.
"""

from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest

from conftest import scene_dict
from gaocvx import DiscreteProblem, Scene
from gaocvx.nonconvex.images import complete_beams


def _dp(supports="P1"):
    return DiscreteProblem(Scene.from_dict(scene_dict(supports, axial=2e10, obstacle=0.0,
                                                      elements=4)), check_convexity=False)


def _eq(w, slope, polished=True, status="optimal"):
    return NS(w=np.asarray(w, float), slope=np.asarray(slope, float),
              x=np.linspace(0.0, 1.0, len(w)), whole_beam=polished,
              status=status, amplitudes=[0.0, 0.0], energy=0.0, stable=False)


# a beam on five nodes clamped at both ends (P1), not symmetric
W = [0.0, 1e-7, 3e-7, 2e-7, 0.0]
SLOPE = [0.0, 3e-7, 1e-7, -5e-7, 0.0]


def _polish_to_itself(dp, calls):
    def polish(u):
        calls.append(u)
        w, slope = dp.to_physical(u)
        return _eq(w, slope)
    return polish


def test_the_image_of_a_polished_beam_is_added_as_the_polish_returns_it():
    dp, calls = _dp(), []
    out = complete_beams(dp, _polish_to_itself(dp, calls), [_eq(W, SLOPE)])
    assert len(out) == 2 and len(calls) == 1
    # x -> L - x: the deflection reversed, the slope reversed and negated
    np.testing.assert_allclose(out[1].w, W[::-1], rtol=0, atol=1e-20)
    np.testing.assert_allclose(out[1].slope, -np.asarray(SLOPE[::-1]), rtol=0, atol=1e-20)


@pytest.mark.parametrize("entry", [
    _eq(W, SLOPE, polished=False),                 # the slices' beam: the searches' images
    _eq(W, SLOPE, status="inaccurate"),
])
def test_only_optimal_polished_entries_are_mirrored(entry):
    dp, calls = _dp(), []
    assert complete_beams(dp, _polish_to_itself(dp, calls), [entry]) == [entry]
    assert not calls


def test_an_image_listed_already_is_not_polished_again():
    dp, calls = _dp(), []
    # listed to 1e-6 of the beam, within zooms.SAME_BEAM
    image = _eq(np.asarray(W[::-1]) * (1 + 1e-6), -np.asarray(SLOPE[::-1]), polished=False)
    out = [_eq(W, SLOPE), image]
    assert complete_beams(dp, _polish_to_itself(dp, calls), out) == out
    assert not calls


@pytest.mark.parametrize("polished", [False, True])
def test_an_image_listed_not_optimal_gives_way_to_the_polished_one(polished):
    # (a slice's beam near the flat one that failed its check, 1e-6 of its size off
    # the exact image: the polish from the mirrored beam certifies the image)
    dp, calls = _dp(), []
    e = _eq(W, SLOPE)
    twin = _eq(np.asarray(W[::-1]) * (1 + 1e-6), -np.asarray(SLOPE[::-1]), polished=polished,
               status="inaccurate")
    out = complete_beams(dp, _polish_to_itself(dp, calls), [e, twin])
    assert len(calls) == 1 and len(out) == 2 and out[0] is e and out[1] is not twin
    assert out[1].status == "optimal"
    np.testing.assert_allclose(out[1].w, W[::-1], rtol=0, atol=1e-20)


def test_an_entry_not_optimal_elsewhere_stays():
    dp = _dp()
    e = _eq(W, SLOPE)
    other = _eq(np.asarray(W) * 2.0, SLOPE, status="inaccurate")   # not the image's beam
    out = complete_beams(dp, _polish_to_itself(dp, []), [e, other])
    assert len(out) == 3 and out[0] is e and out[1] is other
    # and where the polish fails, the entry at the image stays as it is
    twin = _eq(W[::-1], -np.asarray(SLOPE[::-1]), status="inaccurate")
    kept = complete_beams(dp, lambda u: None, [e, twin])
    assert len(kept) == 2 and kept[0] is e and kept[1] is twin


def test_nothing_is_added_where_the_polish_fails_or_returns_a_listed_beam():
    dp = _dp()
    e = _eq(W, SLOPE)
    assert complete_beams(dp, lambda u: None, [e]) == [e]
    # (an asymmetric load: the polish from the image may end at an entry listed)
    assert complete_beams(dp, lambda u: e, [e]) == [e]


def test_no_image_without_symmetric_supports_or_polish():
    dp = _dp("P2")        # clamped at x = 0, pinned at x = L (its slope free)

    def polish(u):
        raise AssertionError("polished")
    e = _eq(W, SLOPE[:-1] + [-6e-7])
    assert complete_beams(dp, polish, [e]) == [e]
    assert complete_beams(_dp(), None, [_eq(W, SLOPE)])[1:] == []
