"""Mirror images (x -> L - x) of equilibria (:mod:`.stationary2`, :mod:`.stationary`).

Where mesh and supports are symmetric (:func:`.polish.reflections`), the mirror
image of an equilibrium is one of the same energy and stability if the load is
symmetric too.  The two-mode search uses images three times: as seeds where an
image was not found (:func:`seeds`), to settle an entry that is not ``optimal``
where it stands for the image of an ``optimal`` one (:func:`settle_twins`), and
to try once more the image of an ``optimal`` entry that is still not listed
(:func:`complete_pairs`).  After every search with an obstacle (one mode or
two), the mirrored beam of each entry polished on the whole beam is polished in
turn, an entry there that is not ``optimal`` giving way to it
(:func:`complete_beams`).  None assumes the load symmetric: a seed is only a
seed, and an image is listed only where it passes the search's own tests.
"""

from __future__ import annotations

import logging
from types import SimpleNamespace

import numpy as np

from .equilibrium import MERGE, same_point
from .polish import reflections
from .whole_beam import same_beam
from .zooms import SAME_BEAM

__all__ = ["seeds", "settle_twins", "complete_pairs", "complete_beams"]

log = logging.getLogger(__name__)


def _image(dp, modes, grad, e):
    """The amplitudes of the mirror image of equilibrium ``e`` (None: no symmetry, or
    no slice at its amplitudes)."""
    u = grad(np.asarray(e.amplitudes, float))[2]
    if u is None:
        return None
    return next((np.asarray(modes.phi.T @ (dp.G @ r), float) for r in reflections(dp, u)[:1]),
                None)


def seeds(dp, modes, grad, out, S) -> list:
    """Amplitudes of the mirror images of the equilibria ``out``, less those found
    already (within MERGE S).

    ``grad(s)`` is the search's cached ``(F, ∇F, u, ok)``; ``S`` the square's size.
    """
    have = [np.asarray(e.amplitudes) for e in out]
    images = []
    for e in out:
        s = _image(dp, modes, grad, e)
        if s is not None and not any(same_point(s, h, S) for h in have + images):
            images.append(s)
    return images


def settle_twins(dp, modes, grad, out, S, settle) -> list:
    """``out`` with each entry that is not ``optimal`` but is the mirror image of an
    ``optimal`` one (within MERGE of its own amplitudes' size) settled by that image.

    ``settle(s)`` is the search's equilibrium at amplitudes ``s`` if it is a zero of
    ``∇F`` to the tolerance that passes the optimality conditions (``optimal``), else
    None.  Where an ``optimal`` entry already stands at the image, the twin is
    dropped (a copy of it); where ``settle`` returns one, it replaces the twin;
    else the twin stays as it is (the load is not symmetric, or the image is no
    equilibrium the search can certify).

    (A P1 beam at gap 0 under a uniform load, 16 elements: near the flat beam a
    saddle listed ``optimal`` and, 1e-7 of its size from its exact image, the
    image ``inaccurate`` -- the same equilibrium, one failing the check by
    round-off at 1.3e-5 m of deflection.)
    The distance is relative to the entry's own amplitudes, not to ``S``: near
    the flat beam distinct equilibria lie closer than MERGE S (:mod:`.zooms`), and
    the flat beam itself is left to :func:`.obstacle_checks.exact_flat`.
    """
    def twin(s, a):
        size = float(np.linalg.norm(a))
        return size > MERGE * S and same_point(s, a, size)

    optimal = [e for e in out if e.status == "optimal"]
    if not optimal or all(e.status == "optimal" for e in out):
        return out
    images = [s for s in (_image(dp, modes, grad, e) for e in optimal) if s is not None]
    result = []
    for e in out:
        s = None if e.status == "optimal" else next(
            (s for s in images if twin(s, e.amplitudes)), None)
        if s is None:
            result.append(e)
            continue
        if any(twin(s, o.amplitudes) for o in optimal):
            log.info("equilibria: the entry at s = %s is a copy of an image listed: dropped",
                     e.amplitudes)
            continue
        new = settle(s)
        if new is not None:
            log.info("equilibria: the entry at s = %s settled by its mirror image", e.amplitudes)
        result.append(e if new is None else new)
    return result


def complete_pairs(dp, modes, grad, out, S, settle) -> list:
    """``out`` with the mirror image of each ``optimal`` entry added where none is
    listed (within MERGE S) and ``settle(s)`` (the search's Newton's method from
    ``s``, then as in :func:`settle_twins`) certifies one there that is not listed.

    The seeds of :func:`seeds` lead Newton's method to an image, but near the flat
    beam at gap 0 only ``optimal`` finds are kept (:func:`.zooms.near_flat`), and
    the second search there had found one of a pair ``inaccurate`` (the check
    failing by round-off) and missed another: a P1 beam pressed at gap 0 (8
    elements) listed two saddles at 6.34 J, 2e-5 m of deflection, without their
    images, which pass the check themselves.  Nothing is assumed of the load: an
    image is added only where it passes the search's own tests.
    """
    added = []
    for e in [e for e in out if e.status == "optimal"]:
        if float(np.linalg.norm(e.amplitudes)) <= MERGE * S:
            continue   # (the flat beam is its own image)
        s = _image(dp, modes, grad, e)
        if s is None or any(same_point(s, a.amplitudes, S) for a in out + added):
            continue
        new = settle(s)
        if new is None or any(same_point(new.amplitudes, a.amplitudes, S) for a in out + added):
            continue
        log.info("equilibria: the mirror image of the entry at s = %s added", e.amplitudes)
        added.append(new)
    return out + added


def complete_beams(dp, polish, out) -> list:
    """``out`` with the mirror image of each entry polished on the whole beam added where
    the image, polished in turn (``polish``, :func:`.whole_beam.polisher`), passes
    the certificate and is not listed (deflection and slope within ``SAME_BEAM``);
    an entry listed there that is not ``optimal`` gives way to it.

    The searches find an equilibrium through its amplitudes, and near the flat
    beam an image may be missed where the warm starts differ: a P1 beam pressed
    at gap 0 (9 elements, two modes) listed a saddle at 0.00163698 J, 2.2e-7 m
    high, without its image, which the search had found before the flat beam's
    label changed.  Here the image is not searched for but polished from the
    mirrored beam itself, and listed only as the polish returns it: nothing is
    assumed of the load (an asymmetric load's image is no equilibrium, and the
    polish fails or returns another, which is listed only if it is not).
    An entry at the image that failed its check (a slice's beam near the flat
    one, accurate to the scene only) is replaced by the polished image: a P1
    beam at gap 0 under a uniform load (16 elements) listed a saddle at
    4.70884767 J ``optimal`` and its image, whose own polish had failed from the
    slice's beam, ``inaccurate``.

    Parameters
    ----------
    dp : DiscreteProblem
        The (rescaled) problem with an obstacle.
    polish : callable or None
        ``u -> Equilibrium or None`` (None: ``out`` is returned as it is).
    out : list of Equilibrium
        The search's equilibria.

    Returns
    -------
    list of Equilibrium
        ``out`` and the images added, in that order.
    """
    if polish is None:
        return out
    out, added = list(out), []
    for e in [e for e in out if e is not None and e.whole_beam and e.status == "optimal"]:
        for r in reflections(dp, dp.from_physical(e.w, e.slope))[:1]:
            w, slope = dp.to_physical(r)
            image = SimpleNamespace(w=w, slope=slope, x=e.x)
            sure = [o for o in out + added if o is not None and o.status == "optimal"]
            if any(same_beam(image, o, SAME_BEAM) for o in sure):
                continue
            new = polish(r)
            if new is None or any(same_beam(new, o, SAME_BEAM) for o in sure):
                continue
            # (an entry at the polished image that is not `optimal` is that image, its
            # beam a slice's: it gives way to the polished one)
            stale = [o for o in out + added if o is not None and same_beam(new, o, SAME_BEAM)]
            out = [o for o in out if not any(o is t for t in stale)]
            added = [o for o in added if not any(o is t for t in stale)]
            log.info("equilibria: the mirror image of the polished entry at s = %s %s",
                     e.amplitudes, f"replaces {len(stale)} listed there, not optimal"
                     if stale else "added")
            added.append(new)
    return out + added
