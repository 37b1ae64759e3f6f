"""The global search's units and energy scale.

The branch and bound's node programs are accurate to an absolute tolerance in
the units they are solved in, so the search runs in the expected answer's size
(:func:`rescale_for`; with an obstacle absorbing an enormous load, the size of
the beam on it, :func:`global_units`), and its gap is certified relative to the
scene's own energy (:func:`scene_energy`), which does not depend on the answer.
Used by :mod:`.minimum` (steps 3 and 6 of its notes) and by the equilibria's
searches, which run in the same units.

Examples
--------
>>> from gaocvx.scene import Scene
>>> from gaocvx.discrete import DiscreteProblem
>>> from gaocvx.nonconvex.modes import unstable_modes
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -1e3, "axial": 1.3e9}, "mesh": {"elements": 16}})
>>> dp = DiscreteProblem(scene, check_convexity=False)
>>> modes = unstable_modes(dp)
>>> big = rescale_for(dp, modes)       # the buckled beam is far larger than the linear one
>>> big.W > 100 * dp.W, scene_energy(big, modes) > 0
(True, True)
"""

from __future__ import annotations

import math
import sys

import numpy as np

from ..errors import SceneError
from .bounds import load_constant, mode_amplitudes

# The search squares its non-dimensional numbers (an energy's square, a * w^4
# with w near 1), so each must lie within the squares' range of doubles.
_SMALLEST = math.sqrt(sys.float_info.min)     # 1.5e-154
_LARGEST = math.sqrt(sys.float_info.max)      # 1.3e154
# A channel admitting less than this fraction of the one-mode amplitude caps the
# global search's energy scale (channel_reach).
NARROW = 1e-2

__all__ = ["one_mode_amplitude", "scene_energy", "channel_reach", "global_units",
           "rescale_for"]


def one_mode_amplitude(dp, modes) -> float:
    """The one-mode estimate ``A`` of the buckled amplitude (non-dimensional, G-normalised)."""
    return float(mode_amplitudes(dp, modes, 1)[0])


def scene_energy(dp, modes, reach: float = math.inf) -> float:
    """The scene's own energy scale (non-dimensional, in the units of ``dp``).

    ``c0 + c_1 A^2 / 2``: ``c0 = f'K^-1 f / 2`` is minus the energy of the
    unsupported linear answer, ``c_1 A^2 / 2`` minus that of the free beam
    buckled along its first mode at the one-mode amplitude ``A``.  Both are
    properties of the scene (load, beam, P), not of the answer; the node
    programs' accuracy is absolute in these units (Clarabel's 1e-12), so a gap
    can be certified relative to this energy, but not relative to an answer
    whose own energy is zero.  ``reach``: the largest admissible ``|s_1|``
    (:func:`channel_reach`), which caps ``A`` in a channel.
    """
    A = min(one_mode_amplitude(dp, modes), reach)
    return load_constant(dp) + 0.5 * float(modes.c[0]) * A * A


def channel_reach(dp, prog, modes) -> float:
    """The largest ``|s_1|`` of an admissible beam, in a channel that admits less
    than NARROW of the one-mode amplitude; ``inf`` otherwise.

    The first mode's amplitude range over the obstacle's rows (a linear program
    per side, :func:`.fast_check.amplitude_range`); ``inf`` without a second
    surface or where a side is not bounded.  A channel far narrower than the free
    beam's buckled amplitude holds every beam's energy far below
    :func:`scene_energy`'s: a gap certified against that (P4, q = 0, a channel
    1e-9 m above and below, 8 elements: the flat beam, a saddle, `optimal`, its
    gap 2.7e-9 J against the scene's 4e6 J, where two minima lie at
    -1.7e-9 J -- an extreme-scale trial) says nothing of the beams in it.  In a
    wider channel the scene's energy is at most 1/NARROW^2 = 1e4 times the
    buckled beam's in it, and a gap of GAP_TOL of it at most 1e-4 of that.
    """
    if dp.contact != "obstacle" or dp.g_above is None:
        return math.inf
    from .fast_check import amplitude_range

    lo, hi = amplitude_range(prog)
    reach = float(max(abs(lo[0]), abs(hi[0])))
    # (not in a wider one: a P1 beam in a channel of 0.083 of its amplitude, two
    # modes, 256 elements, certified against the scene's energy to 2.8e-12 of it,
    # was `inaccurate` against the channel's, its polished answer's certificate
    # failing after a deeper search)
    return reach if reach < NARROW * one_mode_amplitude(dp, modes) else math.inf


def square_energy(dp, modes) -> float:
    """The energy scale of the square ``[-1, 1]^k`` of amplitudes in ``dp``'s units.

    :func:`scene_energy` with the buckled amplitude 1: ``c0 + |c_1| / 2``.  A
    second search in the flat beam's own scale (:func:`.zooms.own_scale`) measures
    its slices' and zeros' accuracy against this, not against the scene's energy,
    which there is that of the free beam buckled to thousands of the square's size
    and more (a P4 beam in a channel 1e-6 m high, 9.6e-15 m above its floor: 1.5e22
    in the square's units, against energies of 0.01 there; the slices took beams
    2e-14 m through the floor as feasible).
    """
    return load_constant(dp) + 0.5 * abs(float(modes.c[0]))


def global_units(dp, modes, linear):
    """:func:`rescale_for`, with an obstacle in the size of the beam on it
    (``linear``: :func:`.obstacle_scale.linear_on_obstacle`'s, None without).

    The larger of the linear beam on the obstacle and the one-mode buckled
    amplitude, where either more than ten times larger or smaller than ``W``
    (the unsupported linear answer, which an obstacle absorbing an enormous
    point force makes 1e4 times the buckled beam: the node programs, their
    tolerances absolute in those units, then cannot resolve it).
    """
    if linear is None:
        return rescale_for(dp, modes)
    return _in_size(dp, max(linear[1] / dp.W, _buckled_size(dp, modes)), shrink=True)


def rescale_for(dp, modes):
    """``dp`` measured in the expected answer's size (step 3 of the module's notes).

    The one-mode amplitude, where larger than the linear answer; a channel holds
    the beam within its wider surface's distance, and that is the size where
    more than ten times smaller (the range within which a search's units serve,
    as for its second search: a P3 beam in a channel 2 cm wide buckled to 1/18
    of its free amplitude, and the dense programs, their tolerances absolute in
    those units, stalled at a gap of 0.077 of it for their 120 s, then certified
    in 1.4 s in the answer's own scale).
    """
    return _in_size(dp, _buckled_size(dp, modes))


def _buckled_size(dp, modes) -> float:
    """The largest nodal ``|w|`` of the first mode at the one-mode amplitude [W]."""
    A = one_mode_amplitude(dp, modes)
    return A * float(np.max(np.abs(modes.phi[dp._w_rows(), 0]), initial=0.0))


def _in_size(dp, size, shrink=False):
    """``dp`` in units of ``size`` [W] where larger (and with ``shrink`` more than
    ten times smaller); in a channel ten times narrower than that, of its wider
    surface's distance."""
    if dp.contact == "obstacle" and dp.g_above is not None:
        wall = max(float(np.max(np.abs(dp.g))), float(dp.g_above))
        if 0.0 < wall < 0.1 * max(size, 1.0):
            return _in_channel(dp, wall)
    if math.isfinite(size) and (size > 1.0 or (shrink and 0.0 < size < 0.1)):
        return dp.rescaled(dp.W * size)
    return dp


def _in_channel(dp, wall):
    """``dp`` in units of its channel's wider surface's distance ``wall`` [W],
    refused (:class:`.SceneError`, naming that surface's key) where those units
    put a number the search squares outside the range of doubles' squares: a
    ceiling 1e-200 m above a floor at gap 0 makes the Gao coefficient 0 and the
    load 8e197 there (an energy's square overflows); at 1e-100 m the energy
    unit is 1.4e-192 J."""
    try:
        new = dp.rescaled(dp.W * wall)
        numbers = {"the energy unit": new.E0,
                   "the Gao coefficient": new.a if dp.a else None,
                   "the load": float(np.max(np.abs(new.f))) if np.any(dp.f) else None}
        bad = [name for name, x in numbers.items()
               if x is not None and not _SMALLEST <= abs(x) <= _LARGEST]
    except FloatingPointError:
        bad = ["the load"]
    if not bad:
        return new
    key = "gap_above" if dp.g_above >= float(np.max(np.abs(dp.g))) else "gap"
    raise SceneError(f"obstacle.{key}",
                     f"a channel whose wider surface lies {wall * dp.W:.3g} m from the beam "
                     f"is too narrow to be searched: in that distance's units "
                     f"{' and '.join(bad)} lie outside {_SMALLEST:.1e} to {_LARGEST:.1e}, "
                     f"the range of floating point's squares",
                     getattr(dp.scene.obstacle, key))
