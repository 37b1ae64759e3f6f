"""F''s round-off: where the reduced function's derivative tells nothing.

Near the convexity limit (and at the flat beam) F' along a mode is a sum of
terms of the energy's size that cancel; its value is then round-off, and its
sign changes make zeros of their own.  :func:`round_off` is that level at a
slice: the floor under the sign bound's tolerance (:mod:`.completeness`).
:func:`noise_clusters` takes zeros between which F' is round-off for one;
:func:`widened` moves the stability probes out until F' rises above it
(:func:`settled`).  Used by :mod:`.stationary1` and, for the flat beam on an
obstacle, by :mod:`.stationary`.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["round_off", "label_threshold", "settled", "widened", "noise_clusters", "NOISE",
           "LABEL_NOISE", "MERGE_NOISE", "EPS"]

# F''s round-off at a slice: NOISE eps_mach times its energy scale (the sum of
# |energy parts|) over the beam's size in the modes' norm (:func:`round_off`): F'
# is a sum of terms of about that size that cancel.  F''s scatter about a line
# through 9 amplitudes 1e-12 apart, measured (P4, 8 elements): 1.1 eps own / size
# without load 1e-11 above P_bar_h (1e-19 program units on 16 elements at 1e-12),
# up to 8.6 under loads of -1e2 to -1e6 N/m; ten times the larger.
NOISE = 100.0
# The probes' labels count F' only above LABEL_NOISE eps own / size (the largest
# measured scatter, 8.6, twice over); neighbouring zeros are one only where F'
# between them stays within MERGE_NOISE (copies made by round-off 1e-12 above
# P_bar_h: within 3 between them; a pair of true zeros 4.5e-6 from w = 0, 1e-14
# above it: 33 to 40, merged at NOISE).
LABEL_NOISE = 20.0
MERGE_NOISE = 10.0
EPS = float(np.finfo(float).eps)


def round_off(dp, u, t) -> float:
    """F''s round-off at the amplitude ``t`` whose slice is the beam ``u``.

    ``NOISE`` eps_mach times the beam's energy scale over its size in the modes'
    norm, ``max(|t|, sqrt(u'Gu))`` (the modes are G-normalised: ``|t|`` without
    load, larger where the load deflects the beam); 0 for the unloaded flat beam.
    """
    own = dp.energy_size(u)
    if own == 0.0:
        return 0.0
    size = max(abs(t), math.sqrt(max(float(u @ (dp.G @ u)), 0.0)))
    return NOISE * EPS * own / size if size > 0.0 else math.inf


def label_threshold(noise, dtol, c, S):
    """``noise(t, u)`` for the stability probes: F' counts beyond ``LABEL_NOISE``
    eps own / size (``noise(t, u)``, :func:`round_off` there, is ``NOISE`` eps
    own / size) and beyond the slices' accuracy ``dtol`` relative to the
    concave part's ``2 c S``.

    F' known to ``dtol (2 c S + |F'|)`` exceeds its error only where ``|F'| >
    dtol 2 c S / (1 - dtol)``.  (A slice error of half that reverses the slope
    1e-6 S either side of a degenerate minimum, F' = (s - s0)^3: a unit test.)
    At 1e-6 S the label is then known where ``|F''| > 2e6 dtol c``; zeros
    closer than about ``sqrt(32 dtol c S / (3 a))`` to a fold's partner (F' =
    a (s - s1)(s - s2)) are probed wider, or ``inaccurate``.  The dense programs
    (interior-point duals, ``dtol`` 1e-7: 0.2 c) take it; the Newton slices,
    whose F' scatters within its round-off, take ``dtol = 0`` (the sign bound's
    1e-9 and 1e-8 are margins: with them correct labels of fold pairs 2e-7 m
    apart, 1e-8 of the load from the fold, became `inaccurate` -- a trial).
    """
    accuracy = dtol * 2.0 * c * S / (1.0 - dtol)
    return lambda t, u: max(LABEL_NOISE / NOISE * noise(t, u), accuracy)


def settled(dF, noise, t) -> bool:
    """Whether ``|F'(t)|`` rises above ``noise(t, u)`` (:func:`round_off`), or
    ``t`` is inadmissible (``F = inf``: :func:`.probes.classify` takes
    that side as it is)."""
    F, d, u = dF(t)[:3]
    if not math.isfinite(F) or u is None:
        return True
    return abs(d) > noise(t, u)


def noise_clusters(roots, dF, noise, points) -> list:
    """``roots`` (sorted) in groups between which F' stays within round-off.

    Neighbouring zeros are one where F' at every sampled amplitude between them
    (``points``) and at their midpoint is round-off (:func:`settled`): the round-off
    of F' makes sign changes, each refined to a zero of its own.  (Without load
    1e-12 above P_bar_h, 13 zeros within 4e-4 of the buckled beam's amplitude, 12
    of them labelled unstable by probes in the noise: an equilibria trial.)
    """
    groups = []
    for r in roots:
        if groups:
            a = groups[-1][-1]
            between = [t for t in points if a < t < r] + [0.5 * (a + r)]
            if not any(settled(dF, noise, t) for t in between):
                groups[-1].append(r)
                continue
        groups.append([r])
    return groups


def widened(probed, mid, h, cap) -> tuple:
    """``(h, noisy)``: the probes' half-width around ``mid``, widened fourfold from
    ``h`` while ``probed(t)`` (F' above its round-off at ``t``) fails on either
    side and ``4 h <= cap``; ``noisy`` when it still fails there (the label is
    not known).  (Without load 1e-12 above P_bar_h, F' at 1e-6 S is 3e-20, its
    round-off 1e-19: stable beams were labelled unstable -- an equilibria trial.)
    """
    while not (probed(mid - h) and probed(mid + h)) and 4.0 * h <= cap:
        h *= 4.0
    return h, not (probed(mid - h) and probed(mid + h))
