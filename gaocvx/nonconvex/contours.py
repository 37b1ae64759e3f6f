"""Zeros of ``∇F`` in the plane found along the zero curves of one component.

With an obstacle or a channel the reduced function ``F(s1, s2)`` of two
unstable modes has narrow curved valleys: a beam pressed onto a surface rises
by 1e3 J within 1e-2 of an amplitude across the valley and by 10 J along it
(a P2 beam in a 2 mm channel, 24 elements).  A zero of ``∇F`` there lies
between the grid's points without both components changing sign on the
corners of one cell, and Newton's method, its Hessian jumping wherever the
contact changes, does not converge from the cell's centre.  A trial's
independent multi-start found such stable equilibria missed in 3 of 20 scenes.

The zero set of one component, ``∂F/∂s_j = 0`` (the valley floors and the
ridges along ``s_j``), is a set of curves.  Along the grid lines of the other
amplitude ``c = s_i``, each sign change of ``∂F/∂s_j`` between neighbouring
points is refined to a point of such a curve; the points on neighbouring lines
are paired (the nearest), and where the other component ``∂F/∂s_i`` changes
sign between a pair, the curve crosses ``∂F/∂s_i = 0`` in between: the
crossing is located by nested bracketing (Brent's method in ``c``, at each
``c`` again along ``s_j`` for the curve's point).  Two zeros close together
(a minimum and a saddle) give no sign change between two lines: where
``|∂F/∂s_i|`` along a curve is smaller at a point than at its neighbours, the
curve is sampled on finer lines on both sides, twice over.  Only ``F``'s
gradient is used, continuous where the contact changes (the envelope of a
convex program, where its multipliers are unique); no Hessian is needed.
Still a sampling: a curve that leaves between two grid lines and comes back,
a pair matched across two curves, zeros closer than the finest lines, or a
zero between the last admissible grid point and the edge of the admissible
amplitudes (both ends of a bracket must be admissible) can be missed.  It
costs about 1500-9000 more solves per scene (10-24 elements, measured).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.optimize as so

__all__ = ["curve_zeros", "line_zeros", "sampled_roots"]


def curve_zeros(grad, axes, S, fine: int = 8) -> list:
    """Zeros of ``∇F`` on the zero curves of ``∂F/∂s_0`` and ``∂F/∂s_1`` (see the module).

    Parameters
    ----------
    grad : callable
        ``grad(s) -> (F, ∇F, u, ok)`` (``F = inf`` at inadmissible amplitudes;
        cached by the caller: grid points cost nothing again).
    axes : pair of ndarray
        The grid's two axes.
    S : float
        The amplitudes' scale (tolerances are relative to it).
    fine : int
        Lines sampled between two of the grid's where a curve is refined.

    Returns
    -------
    list of ndarray
        Amplitudes found, not yet classified nor merged
        (:func:`.plane_newton.at_roots` checks their residual).

    Notes
    -----
    Where ``|∂F/∂s_i|`` along a curve is smaller at a point than at both its
    neighbours, with or without a sign change beside it (two zeros close
    together: a P2 beam in a channel has two minima and a saddle within 0.03 S
    on one valley floor, the lines 0.34 S apart), the curve is sampled on
    ``fine`` lines on each side of it, twice over (:func:`_scan`).
    """
    out = []
    for j in range(2):
        cs = _spaced(axes[1 - j])
        lines = [[(c, a, e) for a, e in _curve_points(grad, axes[j], c, j, S)] for c in cs]
        step = float(np.max(np.diff(axes[j]))) if len(axes[j]) > 1 else S
        # each curve point's successor on the next line (the nearest, if near)
        succ = {}
        for k in range(len(lines) - 1):
            for m, p in enumerate(lines[k]):
                if lines[k + 1]:
                    n = min(range(len(lines[k + 1])), key=lambda i: abs(lines[k + 1][i][1] - p[1]))
                    if abs(lines[k + 1][n][1] - p[1]) <= 2.0 * step:
                        succ[k, m] = (k + 1, n)
        seen = set()
        for k in range(len(lines)):
            for m in range(len(lines[k])):
                if (k, m) in seen:
                    continue
                chain, key = [lines[k][m]], (k, m)
                seen.add(key)
                while key in succ:
                    key = succ[key]
                    chain.append(lines[key[0]][key[1]])
                    if key in seen:
                        break     # (joins a chain already scanned: the pair is new)
                    seen.add(key)
                out += _scan(grad, j, chain, step, S, fine, 2)
    return out


def _spaced(axis) -> list:
    """The axis less points within a quarter of its step of the one before (``s = 0``
    kept): a line 0.002 S from s = 0 hid a curve's smallest ``|∂F/∂s_i|`` at s = 0
    (two zeros 0.1 S apart beside it were not looked for)."""
    axis = list(axis)
    if len(axis) < 3:
        return axis
    gap = 0.25 * float(np.median(np.diff(axis)))
    out = [axis[0]]
    for c in axis[1:]:
        if c - out[-1] >= gap:
            out.append(c)
        elif c == 0.0:
            out[-1] = c
    return out


def _scan(grad, j, pts, step, S, fine, depth) -> list:
    """The zeros on a curve through the points ``pts`` (``(c, a, ∂F/∂s_i)``, in
    order): a crossing between neighbours where ``∂F/∂s_i`` changes sign; where
    ``|∂F/∂s_i|`` is smaller at a point than at both its neighbours (two more
    zeros may hide on either side, with or without a sign change), the curve is
    sampled on ``fine`` lines on each side of it and scanned again (``depth``
    times)."""
    out = []
    for q0, q1 in zip(pts[:-1], pts[1:]):
        if q0[2] * q1[2] <= 0.0:
            s = _crossing(grad, j, q0, q1, step, S)
            if s is not None:
                out.append(s)
    if depth <= 0:
        return out
    for b, q, n in zip(pts[:-2], pts[1:-1], pts[2:]):
        if abs(q[2]) < min(abs(b[2]), abs(n[2])):
            finer = [b] + _between(grad, j, b, q, step, S, fine) + [q] + \
                _between(grad, j, q, n, step, S, fine) + [n]
            out += _scan(grad, j, finer, step, S, fine, depth - 1)
    return out


def _between(grad, j, p0, p1, step, S, fine) -> list:
    """The curve's points on ``fine`` lines between its points ``p0`` and ``p1``."""
    pts = (_on_curve(grad, j, p0, p1, c, step, S)
           for c in np.linspace(p0[0], p1[0], fine + 2)[1:-1])
    return [q for q in pts if q is not None]


def _point(j, a, c) -> np.ndarray:
    """The amplitudes with ``s_j = a`` and the other ``c``."""
    s = np.empty(2)
    s[j], s[1 - j] = a, c
    return s


def _component(grad, j, a, c, which):
    """``∂F/∂s_which`` at :func:`_point` ``(j, a, c)``, NaN where inadmissible."""
    F, d, _, _ = grad(_point(j, a, c))
    return float(d[which]) if math.isfinite(F) else math.nan


def _curve_points(grad, axis, c, j, S) -> list:
    """Points ``(a, ∂F/∂s_i)`` where ``∂F/∂s_j`` changes sign along the line ``s_i = c``."""
    vals = [_component(grad, j, a, c, j) for a in axis]
    out = []
    for a0, a1, v0, v1 in zip(axis[:-1], axis[1:], vals[:-1], vals[1:]):
        if not (math.isfinite(v0) and math.isfinite(v1)) or v0 * v1 > 0.0 or v1 == 0.0:
            continue
        a = _root(lambda x: _component(grad, j, x, c, j), a0, a1, v0, v1, S)
        if a is not None:
            out.append((a, _component(grad, j, a, c, 1 - j)))
    return [p for p in out if math.isfinite(p[1])]


def _on_curve(grad, j, p0, p1, c, step, S):
    """The curve's point ``(c, a, ∂F/∂s_i)`` on the line ``s_i = c`` between the
    curve points ``p0 = (c0, a0, e0)`` and ``p1``: near their chord, or None."""
    c0, a0, _ = p0
    c1, a1, _ = p1
    guess = a0 + (c - c0) / (c1 - c0) * (a1 - a0)
    half = abs(a1 - a0) + 0.5 * step
    f = lambda x: _component(grad, j, x, c, j)   # noqa: E731
    lo, hi = guess - half, guess + half
    flo, fhi = f(lo), f(hi)
    if not (math.isfinite(flo) and math.isfinite(fhi)) or flo * fhi > 0.0:
        return None
    a = _root(f, lo, hi, flo, fhi, S)
    if a is None:
        return None
    e = _component(grad, j, a, c, 1 - j)
    return (c, a, e) if math.isfinite(e) else None


def _crossing(grad, j, p0, p1, step, S):
    """Where the curve ``∂F/∂s_j = 0`` between its points ``p0 = (c0, a0, e0)`` and
    ``p1`` crosses ``∂F/∂s_i = 0`` (``e``: its values at the two points), or None."""
    for c, a, e in (p0, p1):
        if e == 0.0:
            return _point(j, a, c)

    def h(c):
        # (the ends' own values: a curve point found again at c0 or c1 within the
        # bracket may lie on another curve, and Brent's method would then stop)
        if c == p0[0]:
            return p0[2]
        if c == p1[0]:
            return p1[2]
        q = _on_curve(grad, j, p0, p1, c, step, S)
        return math.nan if q is None else q[2]

    c = _root(h, p0[0], p1[0], p0[2], p1[2], S)
    q = _on_curve(grad, j, p0, p1, c, step, S) if c is not None else None
    return None if q is None else _point(j, q[1], c)


def line_zeros(grad, axes, S) -> list:
    """Zeros of ``∇F`` on the lines ``s_j = 0`` that are lines of symmetry of ``F``.

    In a symmetric scene (mesh, supports, loads and obstacle unchanged by
    x -> L - x) a mode that is odd under the mirror makes ``F`` even in its
    amplitude: ``∂F/∂s_j = 0`` on the whole line ``s_j = 0`` (up to round-off,
    whose sign is arbitrary), so that line is a zero curve that :func:`curve_zeros`
    finds, or not, by the noise's signs.  A P1 beam over an obstacle 1 cm below
    (16 elements) has a saddle on it between two resting mirror minima 4.8e-4
    apart in ``s_j``: listed with the dense programs, missed with the fast ones.
    On such a line the zeros are those of ``∂F/∂s_i`` along it
    (:func:`sampled_roots` from the grid's points).  A line counts as one of
    symmetry where ``|∂F/∂s_j|`` at all its admissible grid points is at most
    1e-6 of the largest ``|∇F|`` there (a candidate on a line that is not one is
    no zero of ``∇F`` and is dropped by the caller's residual check).
    """
    out = []
    for j in range(2):
        if 0.0 not in axes[j]:
            continue
        i = 1 - j
        line = [(float(a), grad(_point(i, a, 0.0))) for a in axes[i]]
        line = [(a, v[1]) for a, v in line if math.isfinite(v[0])]
        if len(line) < 2:
            continue
        d = np.array([g for _, g in line])
        if np.max(np.abs(d[:, j])) > 1e-6 * max(np.max(np.abs(d)), 1e-300):
            continue
        out += [_point(i, r, 0.0) for r in sampled_roots(
            lambda a: _component(grad, i, a, 0.0, i), [a for a, _ in line], d[:, i], S)]
    return out


def sampled_roots(f, s, d, S, rtol=1e-14) -> list:
    """Zeros of a scalar function ``f`` from its values ``d`` at sorted points ``s``.

    Each sign change between neighbours is refined by Brent's method (to 1e-13
    ``S`` and ``rtol``), a point with ``d = 0`` is one; where ``d`` has a local
    extremum within 5 % of its largest size without changing sign (two zeros between
    neighbouring points), the extremum is located and, when it lies across
    zero, both zeros beside it are refined.  ``f`` may return NaN (an
    inadmissible point): a search that meets one is dropped.
    """
    s, d = np.asarray(s, float), np.asarray(d, float)
    roots = []

    def refine(a, b):
        r = _root(f, a, b, f(a), f(b), S, rtol=rtol)
        if r is not None:
            roots.append(r)

    for i in range(len(s) - 1):
        if d[i] == 0.0:
            roots.append(float(s[i]))
        elif d[i] * d[i + 1] < 0:
            refine(s[i], s[i + 1])
    if len(s) and d[-1] == 0.0:
        roots.append(float(s[-1]))
    top = np.max(np.abs(d)) if len(d) else 0.0
    for i in range(1, len(d) - 1):
        if (d[i] - d[i - 1]) * (d[i + 1] - d[i]) < 0 and abs(d[i]) < 0.05 * top:
            sign = 1.0 if d[i] > 0 else -1.0
            res = so.minimize_scalar(lambda x: sign * f(x), bounds=(s[i - 1], s[i + 1]),
                                     method="bounded", options=dict(xatol=1e-12 * S))
            if math.isfinite(res.fun) and res.fun < 0:
                refine(s[i - 1], res.x)
                refine(res.x, s[i + 1])
    return roots


class _Lost(Exception):
    """A function turned non-finite during a root's search."""


def _root(f, a, b, fa, fb, S, xtol=1e-13, rtol=None):
    """A root of ``f`` in ``[a, b]`` (``fa``, ``fb``: values of opposite signs) by
    Brent's method to ``xtol * S`` (and ``rtol``, by default brentq's); None
    where ``f`` turns non-finite (``grad`` is cached: the ends cost nothing
    again)."""
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    if not fa * fb < 0.0:
        return None

    def g(x):
        v = f(x)
        if not math.isfinite(v):
            raise _Lost
        return v

    try:
        tol = {} if rtol is None else {"rtol": rtol}
        return float(so.brentq(g, min(a, b), max(a, b), xtol=xtol * S, maxiter=200, **tol))
    except (_Lost, ValueError, RuntimeError):
        return None
