"""Hermite cubic finite elements on a 1-D mesh.

Degrees of freedom are ordered ``[w_0, theta_0, w_1, theta_1, ...]`` with
``theta_i = w'(x_i)``.  Everything here is pure geometry and polynomials: no
material data and no units (callers pass non-dimensional meshes and scale the
matrices themselves).

The element matrices follow physics.md: the bending matrix (3.27) with unit
stiffness, the geometric matrix (3.40), and loads integrated exactly for
piecewise-linear load tables.

Examples
--------
>>> import numpy as np
>>> x = np.linspace(0.0, 1.0, 5)
>>> K = stiffness_matrix(x)
>>> K.shape
(10, 10)
>>> bool(abs(K - K.T).max() < 1e-12)
True
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp

__all__ = [
    "uniform_nodes_with_points", "stiffness_matrix", "geometric_matrix", "load_vector",
    "point_load_vector", "eval_matrix", "gauss_points", "gauss_points_split", "shape_functions",
    "element_of",
    "free_dofs",
]

# Essential conditions per support: which of (w0, theta0, wL, thetaL) are fixed.
FIXED_ENDS = {
    "P1": (True, True, True, True),
    "P2": (True, True, True, False),
    "P3": (True, True, False, False),
    "P4": (True, False, True, False),
}


def free_dofs(n_nodes: int, supports: str) -> np.ndarray:
    """Indices of the free degrees of freedom for the given supports."""
    w0, t0, wl, tl = FIXED_ENDS[supports]
    last = 2 * (n_nodes - 1)
    fixed = [d for d, f in zip((0, 1, last, last + 1), (w0, t0, wl, tl)) if f]
    mask = np.ones(2 * n_nodes, dtype=bool)
    mask[fixed] = False
    return np.flatnonzero(mask)


# Point forces closer than this fraction of an element to each other, or to an
# end, share one node.  A shorter element would make the bending matrix's
# entries (~1/h^3) differ by more than 1e6 between neighbours: its factorisation
# would lose more than 1e-10 and below ~3e-5 h it fails.
MERGE_FRACTION = 1e-2


def uniform_nodes_with_points(length: float, elements: int, points=()) -> np.ndarray:
    """Equal elements on [0, length], with a node at every point-force position.

    A force that lies within a quarter element of an interior node moves that
    node onto it (so the mesh keeps its number of elements and no element gets
    short); otherwise a node is inserted.  Forces closer than
    ``MERGE_FRACTION`` of an element (``h = length / elements``) to a force
    that already has its node, or to an end, get no node of their own: they
    share that node and act through the shape functions of their element (a
    force exactly at a node is the same as the sum of the forces there).  So
    no element is shorter than ``MERGE_FRACTION * h``.

    The placement is one sweep over the sorted positions: O(n log n) for n
    forces.

    Examples
    --------
    >>> uniform_nodes_with_points(1.0, 4, [0.3]).tolist()
    [0.0, 0.3, 0.5, 0.75, 1.0]
    >>> uniform_nodes_with_points(1.0, 4, [0.4]).tolist()
    [0.0, 0.25, 0.4, 0.5, 0.75, 1.0]
    >>> uniform_nodes_with_points(1.0, 4, [0.4, 0.4 + 1e-11, 1e-11]).tolist()
    [0.0, 0.25, 0.4, 0.5, 0.75, 1.0]
    """
    h = length / elements
    grid = np.linspace(0.0, length, elements + 1)
    merge = MERGE_FRACTION * h
    pts = np.unique(np.asarray(points, float).ravel())
    pts = pts[(pts > merge) & (pts < length - merge)]
    nodes: list[float] = []   # final nodes, increasing
    last_claimed = False      # whether nodes[-1] holds a force
    j = 0                     # the next grid node not yet in ``nodes`` (never moved)
    previous = -np.inf        # the last force that got a node
    for xp in pts.tolist():
        if xp - previous <= merge:
            continue          # shares the node of the previous force
        previous = xp
        while grid[j] <= xp:  # grid[-1] = length > xp ends the loop
            nodes.append(float(grid[j]))
            last_claimed = False
            j += 1
        d_left, d_right = xp - nodes[-1], grid[j] - xp
        if d_left <= d_right:  # the left node is the nearest (ties: left)
            if len(nodes) > 1 and not last_claimed and d_left < 0.25 * h:
                nodes[-1] = xp  # move that interior node onto the force
            else:
                nodes.append(xp)
        else:
            nodes.append(xp)   # moves grid node j onto the force, or inserts
            if j < elements and d_right < 0.25 * h:
                j += 1
        last_claimed = True
    nodes.extend(grid[j:].tolist())
    x = np.array(nodes)
    if np.any(np.diff(x) <= 0):
        raise ValueError("mesh has coincident nodes")
    return x


def _elements(x):
    h = np.diff(x)
    dofs = 2 * np.arange(len(h))[:, None] + np.arange(4)[None, :]
    return h, dofs


def _assemble(x, local) -> sp.csr_matrix:
    h, dofs = _elements(x)
    ke = local(h)  # (ne, 4, 4)
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    n = 2 * len(x)
    return sp.csr_matrix((ke.ravel(), (rows, cols)), shape=(n, n))


def stiffness_matrix(x) -> sp.csr_matrix:
    """Bending matrix of ``∫ w'' v''`` (unit stiffness), physics.md (3.27)."""
    def local(h):
        h = h[:, None, None]
        m = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], float)
        p = np.array([0, 1, 0, 1])  # powers of h per dof
        return m[None] * h ** (p[None, :, None] + p[None, None, :]) / h**3
    return _assemble(np.asarray(x, float), local)


def geometric_matrix(x) -> sp.csr_matrix:
    """Geometric matrix of ``∫ w' v'``, physics.md (3.40)."""
    def local(h):
        h = h[:, None, None]
        m = np.array([[36, 3, -36, 3], [3, 4, -3, -1], [-36, -3, 36, -3], [3, -1, -3, 4]], float)
        p = np.array([0, 1, 0, 1])
        return m[None] * h ** (p[None, :, None] + p[None, None, :]) / (30.0 * h)
    return _assemble(np.asarray(x, float), local)


@functools.lru_cache(maxsize=None)
def _unit_rule(n: int):
    """The n-point Gauss-Legendre rule on [0, 1] (cached: a sweep builds many meshes)."""
    t, wt = np.polynomial.legendre.leggauss(n)
    t, wt = 0.5 * (t + 1.0), 0.5 * wt
    t.flags.writeable = wt.flags.writeable = False
    return t, wt


def gauss_points(x, n: int):
    """Gauss-Legendre points and weights on every element.

    Returns
    -------
    xq : ndarray, shape (ne * n,)
    wq : ndarray, shape (ne * n,)
    elem : ndarray of int, the element of each point
    """
    t, wt = _unit_rule(n)
    x = np.asarray(x, float)
    h = np.diff(x)
    xq = (x[:-1, None] + h[:, None] * t[None, :]).ravel()
    wq = (h[:, None] * wt[None, :]).ravel()
    elem = np.repeat(np.arange(len(h)), n)
    return xq, wq, elem


def gauss_points_split(x, breaks, n: int):
    """Gauss points on every element, each element split at the ``breaks`` inside it.

    Exact integration of functions that are polynomial between the nodes and
    the breaks (e.g. a piecewise-linear load table's knots inside elements).

    Returns
    -------
    xq, wq : ndarray
    elem : ndarray of int, the element of each point
    """
    x = np.asarray(x, float)
    breaks = np.asarray(breaks, float).ravel()
    inner = breaks[(breaks > x[0]) & (breaks < x[-1])]
    cuts = np.union1d(x, inner)
    xq, wq, piece = gauss_points(cuts, n)
    elem = element_of(x, 0.5 * (cuts[:-1] + cuts[1:]))[piece]
    return xq, wq, elem


def shape_functions(t, h, deriv: int = 0, s=None) -> np.ndarray:
    """Hermite shape functions (or their x-derivatives) at local t in [0, 1].

    ``s`` is 1 - t, best computed from the right node, ``(x_b - x) / h``:
    as ``1 - t`` it carries an absolute error eps, a relative error
    eps / (1 - t) for a point 1e-9 h from that node.  Returns an array of
    shape ``t.shape + (4,)``.
    """
    t = np.asarray(t, float)
    h = np.broadcast_to(np.asarray(h, float), t.shape)
    one = np.ones_like(t)
    # Factored forms: expanded, 1 - 3t^2 + 2t^3 near t = 1 (a point force 1e-9 h
    # from a node) cancels to round-off of its size, ~eps / (1 - t)^2 relative.
    s = 1 - t if s is None else np.broadcast_to(np.asarray(s, float), t.shape)
    if deriv == 0:
        v = [s**2 * (1 + 2 * t), h * t * s**2, t**2 * (3 - 2 * t), -h * t**2 * s]
    elif deriv == 1:
        v = [-6 * t * s / h, s * (1 - 3 * t), 6 * t * s / h, t * (3 * t - 2)]
    elif deriv == 2:
        v = [(-6 + 12 * t) / h**2, (-4 + 6 * t) / h, (6 - 12 * t) / h**2, (-2 + 6 * t) / h]
    elif deriv == 3:
        v = [12 * one / h**3, 6 * one / h**2, -12 * one / h**3, 6 * one / h**2]
    else:
        raise ValueError("deriv must be 0, 1, 2 or 3")
    return np.stack(v, axis=-1)


def element_of(x, points) -> np.ndarray:
    """Index of the element containing each point (the left one at a node)."""
    x = np.asarray(x, float)
    e = np.searchsorted(x, np.asarray(points, float), side="right") - 1
    return np.clip(e, 0, len(x) - 2)


def eval_matrix(x, points, deriv: int = 0, elem=None) -> sp.csr_matrix:
    """Sparse matrix mapping the DOF vector to w (or a derivative) at ``points``."""
    x = np.asarray(x, float)
    points = np.asarray(points, float)
    e = element_of(x, points) if elem is None else np.asarray(elem)
    h = x[e + 1] - x[e]
    t = (points - x[e]) / h
    vals = shape_functions(t, h, deriv, s=(x[e + 1] - points) / h)
    rows = np.repeat(np.arange(len(points)), 4)
    cols = (2 * e[:, None] + np.arange(4)[None, :]).ravel()
    return sp.csr_matrix((vals.ravel(), (rows, cols)), shape=(len(points), 2 * len(x)))


def load_vector(x, q) -> np.ndarray:
    """Consistent load vector of ``∫ q v`` for a uniform or piecewise-linear q.

    ``q`` is a number (uniform), ``None`` (no load), or a sequence of
    ``(x, q)`` rows with increasing x; a table is zero outside its range.
    The integral is exact: elements are split at the table's breakpoints and
    each piece uses a 3-point Gauss rule (q linear times a cubic).
    """
    x = np.asarray(x, float)
    f = np.zeros(2 * len(x))
    if q is None:
        return f
    if np.isscalar(q):
        breaks = ()
        qfun = lambda s: np.full_like(s, float(q))  # noqa: E731
    else:
        table = np.asarray(q, float)
        breaks = table[:, 0]
        qfun = lambda s: np.interp(s, table[:, 0], table[:, 1], left=0.0, right=0.0)  # noqa: E731
    xq, wq, e = gauss_points_split(x, breaks, 3)
    h = x[e + 1] - x[e]
    vals = shape_functions((xq - x[e]) / h, h, 0) * (wq * qfun(xq))[:, None]
    np.add.at(f, (2 * e[:, None] + np.arange(4)[None, :]).ravel(), vals.ravel())
    return f


def point_load_vector(x, points) -> np.ndarray:
    """Consistent load vector of point forces ``[(x_k, F_k), ...]``: F_k N(x_k)."""
    x = np.asarray(x, float)
    f = np.zeros(2 * len(x))
    if len(points) == 0:
        return f
    pts = np.asarray(points, float)
    f += eval_matrix(x, pts[:, 0]).T @ pts[:, 1]
    return f
