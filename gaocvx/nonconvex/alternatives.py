"""Other global minimisers: mirror images and every other group of leaves within the gap.

After the branch and bound (:mod:`.bnb`) the answer is the best point found; a
scene may have several global minimisers (a symmetric one always has the
mirror image).  Every group of touching leaves whose lower bound lies within the
certified gap of the best energy, away from the answer, is polished to a local
minimiser (:func:`.polish.polish`); one within the gap and distinct from the
known ones is another global minimiser.  The answer's own images (``-u``, and
``x -> L - x`` with its negative where mesh and supports are symmetric) are
checked directly.

Two candidates are the same minimiser when their deflections differ by at most
:data:`DISTINCT` of their size, or when both have their amplitudes in one
proved basin (:mod:`.basin`), which holds only one.  Just above ``P_bar_h`` the
energy is so flat that two polishes of one minimiser differ by more (P4
without load at ``P_bar_h (1 + 1e-10)``: 1.9e-6 of its size, and no basin is
proved there): a group's polished point within :data:`IMAGE_MATCH` of an exact
image of the answer is taken as that image.
"""

from __future__ import annotations

import math

import numpy as np

from .bnb import components
from .polish import feasible_energy, polish, reflections, size_floor

__all__ = ["other_minimisers", "NEAR_LEAVES", "DISTINCT"]

# Leaves within the gap of the best that are grouped in search of other
# minimisers (those with the lowest bounds; grouping 5000 takes about a second).
NEAR_LEAVES = 5000
# Two minimisers are distinct when their deflections differ by more than this,
# relative to the larger one's G-norm (sqrt ∫ (w')^2).
DISTINCT = 1e-6
# Groups of leaves searched at most (those with the lowest bounds first).
GROUPS = 16
# A group's polished point this close to an exact image of the answer (relative to
# its size) is taken as that image, and an image that the polish moves no further
# is kept exact.
IMAGE_MATCH = 1e-4


def other_minimisers(dp, prog, out, best, lo, hi, tol):
    """The best point and every other global minimiser found.

    Parameters
    ----------
    dp : DiscreteProblem
    prog : node program of the search (its ``modes`` and reduced function)
    out : BnBResult
        The branch and bound's result (its leaves and basins).
    best : tuple
        ``(energy, u, s, lam)`` of the polished answer.
    lo, hi : ndarray
        The box of amplitudes searched.
    tol : float
        The certified gap: a minimiser within it of the best energy counts.

    Returns
    -------
    best : tuple
        ``(energy, u, s, lam)``: the answer (another candidate replaces it where lower).
    alternatives : list of tuple
        ``(energy, u, s, lam)`` of every other global minimiser.
    """
    best_e, best_u, best_s, lam = best
    phi = prog.modes.phi
    basins = getattr(out, "basins", [])
    # Sizes are at least the certificate's zero floor: below it every deflection is
    # zero (a P4 beam pressed flat at gap 0 had three polished points of 1e-21 of
    # it, each "distinct" relative to its own size: not unique was reported).
    floor = size_floor(dp)
    norm = lambda x: math.sqrt(max(float(x @ (dp.G @ x)), 0.0))  # noqa: E731
    size_of = lambda x: max(norm(x), floor)  # noqa: E731

    def basin_of(u):
        s = phi.T @ (dp.G @ u)
        return next((i for i, b in enumerate(basins) if b.contains(s, s)), None)

    def same(ua, ub, size):
        if norm(ua - ub) <= DISTINCT * size:
            return True
        i = basin_of(ua)
        return i is not None and i == basin_of(ub)   # a basin holds one minimiser

    near = [leaf for leaf in out.leaves if leaf.lower <= best_e + tol and leaf.s is not None]
    # (the NEAR_LEAVES lowest: with six modes some 10^5 leaves lay within the gap,
    # and grouping them took minutes)
    near = sorted(near, key=lambda leaf: leaf.lower)[:NEAR_LEAVES]
    alternatives = []
    feasible = feasible_energy(dp, prog)
    groups = sorted(components(near), key=lambda group: min(leaf.lower for leaf in group))
    for group in groups[:GROUPS]:
        glo = np.min([leaf.lo for leaf in group], axis=0)
        ghi = np.max([leaf.hi for leaf in group], axis=0)
        if np.all(glo <= best_s) and np.all(best_s <= ghi):
            continue
        seed = min(group, key=lambda leaf: leaf.lower)
        s2, u2, lam2 = polish(dp, prog, seed.s, seed.u, None, glo, ghi)
        # An exact image of the answer this close is the minimiser the polish was
        # after: it states it exactly (a flat minimum polishes to 1e-6 of its size).
        size2 = size_of(u2)
        image = next((x for x in [-best_u] + reflections(dp, best_u)
                      if norm(x - u2) <= IMAGE_MATCH * size2), None)
        if image is not None and feasible(image) <= best_e + tol:
            s2, u2, lam2 = phi.T @ (dp.G @ image), image, None
        e2 = dp.energy(u2)
        if e2 > best_e + tol:
            continue
        known = [best_u] + [a[1] for a in alternatives]
        if any(same(u2, x, max(size_of(u2), size_of(x))) for x in known):
            continue
        if e2 < best_e:  # the other one is lower: it becomes the answer
            alternatives.append((best_e, best_u, best_s, lam))
            best_e, best_u, best_s, lam = e2, u2, s2, lam2
        else:
            alternatives.append((e2, u2, s2, lam2))

    # The mirror image: near P_bar_h the leaves around +s and -s merge into one group
    # with the answer's (without load, 1e-9 above the limit, unique was reported).
    # Likewise the image in x -> L - x (and its negative): an antisymmetric mode's
    # small amplitude +-s_2 of a P1 beam in a channel (k = 2, 256 elements) fell in
    # one group, and unique was reported.  Each counts if admissible, within the
    # gap and distinct; for a scene without that symmetry its energy differs.
    # An image is polished first, as the groups' candidates are: a scene whose
    # asymmetry is below the gap (a P1 beam buckled 0.2 m under a small table load,
    # 2e-7 m from symmetric) has an image within the gap that is no equilibrium;
    # polished, it falls back onto the answer (campaign scene 1:66).
    # An exact image (a symmetric scene: the polish moves it by less than IMAGE_MATCH)
    # is kept as it is, else the polished point;
    # an exact image replaces a group's polished point in its basin (the same
    # minimiser, which the image states exactly).
    size = size_of(best_u)
    for u2 in [-best_u] + reflections(dp, best_u):
        e2 = feasible(u2)
        if not e2 <= best_e + tol or same(u2, best_u, size):
            continue
        s_img = phi.T @ (dp.G @ u2)
        twin = next((i for i, a in enumerate(alternatives) if same(u2, a[1], size)), None)
        if twin is not None and norm(alternatives[twin][1] - u2) <= DISTINCT * size:
            continue
        s2, p2, lam2 = polish(dp, prog, s_img, u2, None, lo, hi)
        # (an image the polish leaves where it was, to a flat minimum's accuracy)
        exact = norm(p2 - u2) <= IMAGE_MATCH * size
        if twin is not None:
            if exact:
                alternatives[twin] = (e2, u2, s_img, None)
            continue
        if any(norm(p2 - x) <= DISTINCT * size
               for x in [best_u] + [a[1] for a in alternatives]):
            continue   # no minimiser of its own: it falls back onto a known one
        if exact:
            alternatives.append((e2, u2, s_img, None))
        elif (ep := feasible(p2)) <= best_e + tol:
            alternatives.append((ep, p2, s2, lam2))
    return (best_e, best_u, best_s, lam), alternatives
