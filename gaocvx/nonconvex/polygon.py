"""The admissible amplitudes of two modes with an obstacle: a polygon, bounded from both sides.

With a rigid obstacle or channel the beams that respect it form a polyhedron,
and their two unstable modes' amplitudes ``s = D z`` its projection ``A``, a
convex polygon (unbounded, in general: it is cut here to a box).  Its support
function ``h(n) = max {n . s : s in A}`` is a linear program; HiGHS's
solution gives both a point of ``A`` (the primal answer) and, by weak duality,
an upper bound of ``h(n)`` (:func:`.fast_check.lp_min`).  From a few
directions on, each edge of the hull of the points found so far is tried in
its outward normal: where the bound exceeds the edge by more than ``tol``, the
new point is a vertex and the hull grows; else the edge is final.  The result
is a pair:

* the *outer* polygon, the half-planes ``n . s <= h`` of every bound: ``A``
  lies inside it, whatever the solver's accuracy (a point outside it is no
  admissible amplitude, so no equilibrium);
* the *inner* polygon, the hull of the primal points: inside ``A`` to HiGHS's
  feasibility tolerance, within ``tol`` of the outer one where every edge is
  final.

Used by the two-mode proof with an obstacle (:mod:`.completeness2`): cells
outside the outer polygon hold no equilibrium, cells across its rim are
clipped to it, and samples beyond it are taken on its rim (or, where a slice
there is empty, a little inside).

Examples
--------
The triangle ``{z >= 0, z_1 + z_2 <= 1}`` seen through ``D = I``:

>>> import numpy as np
>>> from gaocvx.nonconvex.fast_check import lp_min
>>> A_ub, b_ub = np.array([[-1.0, 0.0], [0.0, -1.0], [1.0, 1.0]]), np.array([0.0, 0.0, 1.0])
>>> def support(n):
...     bound, z = lp_min(-n, A_ub, b_ub, np.zeros((0, 2)), np.zeros(0))
...     return -bound, z
>>> poly = admissible_polygon(support, [-2.0, -2.0], [2.0, 2.0])
>>> (np.round(poly.vertices, 12) + 0.0).tolist()
[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
>>> poly.outside(np.array([[0.6, 0.6], [0.2, 0.2]])).tolist()
[True, False]
>>> (np.round(poly.clip(0.5, 1.5, -0.5, 0.5), 12) + 0.0).tolist()   # across an edge
[[1.0, 0.0], [0.5, 0.5], [0.5, 0.0]]
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["Polygon", "admissible_polygon", "program_polygon"]

# Linear programs the polygon may take (measured: 12-13 where the obstacle is below
# only, the whole box; 113-177 for channels at 8 elements, 56-84 vertices).  Beyond
# it the outer polygon is looser, never wrong.
MAX_LPS = 200


class Polygon:
    """Outer half-planes and inner vertices of a convex polygon of amplitudes.

    Parameters
    ----------
    normals, offsets : arrays
        The outer polygon ``{s : normals @ s <= offsets}`` (unit normals).
    vertices : array
        The inner polygon's vertices, counter-clockwise (1, 2 or more).
    """

    def __init__(self, normals, offsets, vertices):
        self.normals = np.asarray(normals, float).reshape(-1, 2)
        self.offsets = np.asarray(offsets, float).ravel()
        self.vertices = np.asarray(vertices, float).reshape(-1, 2)

    def outside(self, points) -> np.ndarray:
        """Whether each point lies outside the outer polygon (so outside the amplitudes)."""
        return np.any(self.cut(points), axis=1)

    def cut(self, points) -> np.ndarray:
        """Whether each point lies outside at least one outer half-plane: a
        ``(points, half-planes)`` table (all corners of a rectangle outside one
        half-plane: the rectangle is outside)."""
        P = np.asarray(points, float).reshape(-1, 2)
        return P @ self.normals.T > self.offsets

    def interior(self, p, margin: float = 1e-9) -> bool:
        """Whether ``p`` lies inside the inner polygon farther than ``margin`` of its
        size from each edge (so inside the amplitudes, off their rim)."""
        V = self.vertices
        if len(V) < 3:
            return False
        size = float(np.max(np.abs(V - V.mean(axis=0))))
        return bool(np.all(_inner_distances(V, p) > margin * size))

    def within(self, p) -> bool:
        """Whether ``p`` lies in the inner polygon (so is an admissible amplitude)."""
        return len(self.vertices) >= 3 and bool(np.all(_inner_distances(self.vertices, p) >= 0))

    def clip(self, x0, x1, y0, y1, planes=None) -> np.ndarray:
        """The vertices of the rectangle's part inside the outer polygon (none: empty);
        ``planes``: the indices of the half-planes to clip by (default all)."""
        poly = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float)
        for i in range(len(self.offsets)) if planes is None else planes:
            if not len(poly):
                break
            poly = _clip_half_plane(poly, self.normals[i], self.offsets[i])
        return poly

    def onto(self, p) -> np.ndarray:
        """``p`` if it lies in the outer polygon, else the nearest point of its rim."""
        p = np.asarray(p, float)
        if not self.outside(p)[0]:
            return p
        V = self.outer_vertices()
        return _nearest_on_rim(V, p) if len(V) else p

    def inwards(self, p, f: float) -> np.ndarray:
        """``p`` moved the fraction ``f`` of the way to the inner vertices' mean."""
        p = np.asarray(p, float)
        return p + f * (self.vertices.mean(axis=0) - p)

    def beyond(self, corners) -> bool:
        """Whether all ``corners`` lie outside one outer half-plane (so does their hull)."""
        return bool(np.any(np.all(self.cut(corners), axis=0)))

    def rim_points(self, x0, x1, y0, y1) -> list:
        """The points where the outer polygon's rim crosses the rectangle's edges."""
        part = self.clip(x0, x1, y0, y1)
        return [tuple(v) for v in part if not (v[0] in (x0, x1) and v[1] in (y0, y1))]

    def outer_vertices(self) -> np.ndarray:
        """The outer polygon's vertices (counter-clockwise; a box around the inner
        vertices, ten times their size, cut by the half-planes)."""
        if getattr(self, "_outer", None) is None:
            r = 10.0 * (1.0 + float(np.max(np.abs(self.vertices), initial=0.0)))
            self._outer = self.clip(-r, r, -r, r)
        return self._outer


def admissible_polygon(support, lo, hi, tol: float = 1e-7, max_lps: int = MAX_LPS):
    """The polygon of admissible amplitudes within the box ``[lo, hi]`` (see the module's notes).

    Parameters
    ----------
    support : callable
        ``support(n) -> (h, s)``: an upper bound ``h`` of ``max n . s`` over the
        amplitudes (``inf`` where unknown) and an amplitude ``s`` attaining it to the
        solver's accuracy (``None`` where unknown); ``n`` a unit vector.  The box's
        own sides must be among the program's rows (so that it is bounded).
    lo, hi : pairs of float
        The box.
    tol : float
        An edge is final when the bound in its normal exceeds it by at most this
        (relative to the box's size).

    Returns
    -------
    Polygon or None
        None where the amplitudes are empty or a bound could not be had in the
        first directions.
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    size = float(np.max(hi - lo))
    if not (math.isfinite(size) and size > 0):
        return None
    tol = tol * size
    normals, offsets, points = [], [], []
    lps = 0

    def ask(n):
        # the bound, and how far the point found reaches in n
        nonlocal lps
        lps += 1
        h, s = support(n)
        if math.isfinite(h):
            normals.append(n)
            offsets.append(h)
        if s is None or not np.all(np.isfinite(s)):
            return h, -math.inf
        points.append(np.asarray(s, float))
        return h, float(n @ s)

    for a in np.arange(8) * (np.pi / 4):
        if not math.isfinite(ask(np.array([math.cos(a), math.sin(a)]))[0]):
            return None
    final = set()
    while lps < max_lps:
        hull = _hull(np.array(points))
        if len(hull) < 2:
            break
        todo = []
        for i in range(len(hull)):
            a, b = hull[i], hull[(i + 1) % len(hull)]
            key = (tuple(a), tuple(b))
            if key in final:
                continue
            e = b - a
            n = np.array([e[1], -e[0]]) / np.linalg.norm(e)   # outward (counter-clockwise)
            todo.append((key, n, float(n @ a)))
        if not todo:
            break
        for key, n, level in todo:
            if lps >= max_lps:
                break
            h, reach = ask(n)
            # (final too where the point found reaches no farther: the bound is then
            # as tight as this solver makes it)
            if h <= level + tol or reach <= level + tol:
                final.add(key)
    hull = _hull(np.array(points))
    if not len(hull):
        return None
    return Polygon(normals, offsets, hull)


def program_polygon(prog, lo, hi, tol: float = 1e-7):
    """:func:`admissible_polygon` of a node program with an obstacle, in the box ``[lo, hi]``.

    ``prog``: a :class:`.fast_contact.FastContactProgram` (the mixed form's
    rows, ``s = B z + s_origin``; or the :class:`.slices.ContactSlices` around
    one) or a dense :class:`.node.NodeProgram` (``s = D u`` over ``u >= levels``),
    the same rows their amplitude ranges are computed from
    (:func:`.fast_check.amplitude_range`).  None without an obstacle.
    """
    import scipy.sparse as sp

    from .fast_check import lp_min

    prog = getattr(prog, "prog", prog)
    if getattr(prog, "rows", None) is None:
        return None
    D, origin, A_ub, b_ub, A_eq, b_eq = prog.admissible_lp()
    D, origin, A_ub = np.asarray(D, float), np.asarray(origin, float), sp.csr_matrix(A_ub)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    # the box's sides as rows (a bounded program), the directions normalised as
    # lp_ranges does (HiGHS's "numerical difficulties" with B's rows as they are)
    scale = max(float(np.max(np.abs(D))), 1e-300)
    Dn = D / scale
    A_box = sp.vstack([A_ub, sp.csr_matrix(Dn), sp.csr_matrix(-Dn)]).tocsr()
    b_box = np.r_[b_ub, (hi - origin) / scale, -(lo - origin) / scale]

    def support(n):
        bound, z = lp_min(-(n @ Dn), A_box, b_box, A_eq, b_eq)
        if not math.isfinite(bound):
            return math.inf, None
        return float(n @ origin) - scale * bound, (None if z is None else D @ z + origin)

    return admissible_polygon(support, lo, hi, tol)


def _hull(P) -> np.ndarray:
    """The convex hull's vertices, counter-clockwise (Andrew's monotone chain)."""
    if not len(P):
        return np.zeros((0, 2))
    P = np.unique(P, axis=0)
    if len(P) <= 2:
        return P

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in P:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in P[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def _clip_half_plane(poly, n, h) -> np.ndarray:
    """Sutherland-Hodgman: the convex polygon ``poly`` cut to ``n . s <= h``."""
    out = []
    m = len(poly)
    vals = poly @ n - h
    for i in range(m):
        p, q = poly[i], poly[(i + 1) % m]
        fp, fq = vals[i], vals[(i + 1) % m]
        if fp <= 0:
            out.append(p)
        if (fp < 0 < fq) or (fq < 0 < fp):
            out.append(p + fp / (fp - fq) * (q - p))
    return np.array(out).reshape(-1, 2)


def _inner_distances(V, p) -> np.ndarray:
    """``p``'s signed distances from the counter-clockwise polygon ``V``'s edges
    (positive inside)."""
    e = np.roll(V, -1, axis=0) - V
    d = np.asarray(p, float) - V
    return (e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0]) / np.linalg.norm(e, axis=1)


def _nearest_on_rim(V, p) -> np.ndarray:
    """The point of the polygon ``V``'s rim (a segment or a point, for fewer
    than three vertices) nearest to ``p``."""
    if len(V) == 1:
        return V[0].copy()
    best, far = V[0], math.inf
    for i in range(len(V)):
        a, b = V[i], V[(i + 1) % len(V)]
        e = b - a
        t = float(np.clip((p - a) @ e / max(float(e @ e), 1e-300), 0.0, 1.0))
        q = a + t * e
        d = float(np.linalg.norm(p - q))
        if d < far:
            best, far = q, d
    return best
