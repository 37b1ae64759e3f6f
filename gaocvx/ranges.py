"""Ranges of values written ``START:STOP:NUM[:log]``, and the grid of several.

Used by :mod:`.sweep` (``--vary``) and by the path command (``--axial``,
:func:`.nonconvex.cli.parse_range`).  The values are computed in decimal
arithmetic from the endpoints as written, so that a decimal value is the
double one would type.

Examples
--------
>>> grid(parse_range("1:2:2"), parse_range("0:1:3")).tolist()
[[1.0, 0.0], [1.0, 0.5], [1.0, 1.0], [2.0, 0.0], [2.0, 0.5], [2.0, 1.0]]
"""

from __future__ import annotations

import decimal
import math

import numpy as np

from .errors import SceneError

__all__ = ["parse_range", "count_of", "grid"]


def parse_range(text: str, key: str = "--vary") -> np.ndarray:
    """Values of ``START:STOP:NUM[:log]`` (NUM >= 1; log spacing needs START, STOP > 0).

    The grid is computed in decimal arithmetic from the endpoints as written
    (40 digits) and each value rounded once to a double: a value that is a
    decimal number comes out as exactly the double one would type (0.8, not
    the 0.7999999999999999 of ``numpy.linspace(0, 1.6, 3)``), and log grids
    over whole decades give the powers of ten.

    Examples
    --------
    >>> parse_range("0:1:3").tolist()
    [0.0, 0.5, 1.0]
    >>> parse_range("0:1.6:5").tolist()
    [0.0, 0.4, 0.8, 1.2, 1.6]
    >>> parse_range("1e8:1e10:3:log").tolist()
    [100000000.0, 1000000000.0, 10000000000.0]
    """
    parts = text.split(":")
    if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] != "log"):
        raise SceneError(key, "must be START:STOP:NUM or START:STOP:NUM:log", text)
    try:
        start, stop = float(parts[0]), float(parts[1])
        num = count_of(parts[2])
    except ValueError:
        raise SceneError(key, "START and STOP must be numbers and NUM a whole number",
                         text) from None
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise SceneError(key, "START and STOP must be finite", text)
    if not 1 <= num <= 100_000:
        raise SceneError(key, "NUM must be between 1 and 100000", text)
    if num == 1 and stop != start:   # (the grid would drop STOP without a word)
        raise SceneError(key, "NUM = 1 gives START only: give STOP = START, or NUM >= 2", text)
    if len(parts) == 4 and (start <= 0 or stop <= 0):
        raise SceneError(key, "a log range needs START > 0 and STOP > 0", text)
    return _decimal_grid(parts[0], parts[1], num, log=len(parts) == 4)


def count_of(text: str) -> int:
    """NUM of a range: a whole number, written ``31``, ``31.0`` or ``3.1e1``.

    Raises
    ------
    ValueError
        Where it is no whole number (``2.5``, ``abc``, ``inf``).

    Examples
    --------
    >>> count_of("31"), count_of("3.0"), count_of("1e2")
    (31, 3, 100)
    """
    try:
        return int(text)
    except ValueError:
        # (read exactly: as a float "3.0000000000000001" was 3)
        try:
            value = decimal.Decimal(text.strip())
        except decimal.InvalidOperation:
            raise ValueError(text) from None
        if not value.is_finite() or value != value.to_integral_value():
            raise ValueError(text) from None
        # (1e1000000000 is whole too, but its int has a billion digits: any count
        # beyond 1e30 is as far beyond every caller's limit)
        if value.adjusted() > 30:
            return 10 ** 31 if value > 0 else -10 ** 31
        return int(value)


def _decimal_grid(start: str, stop: str, num: int, log: bool) -> np.ndarray:
    """``num`` values from ``start`` to ``stop`` (decimal strings), evenly or log spaced.

    Every value is start + i (stop - start) / (num - 1), or start (stop /
    start)^(i / (num - 1)), computed with 40 significant digits and rounded once
    to the nearest double; the endpoints are the numbers as written.
    """
    with decimal.localcontext() as ctx:
        ctx.prec = 40
        a, b = decimal.Decimal(start.strip()), decimal.Decimal(stop.strip())
        if num == 1:
            return np.array([float(a)])
        if log:
            ratio = b / a
            values = [a * ratio ** (decimal.Decimal(i) / (num - 1)) for i in range(num)]
        else:
            step = (b - a) / (num - 1)
            values = [a + i * step for i in range(num)]
        values[0], values[-1] = a, b
        return np.array([float(v) for v in values])


def grid(*axes) -> np.ndarray:
    """The points of the grid of several axes, one row per point, the first axis outermost.

    Parameters
    ----------
    *axes : sequence of float
        The values of each key, e.g. from :func:`parse_range`.

    Returns
    -------
    ndarray, shape (prod(len(axis)), len(axes))

    Examples
    --------
    >>> grid([1.0, 2.0], [10.0, 20.0, 30.0]).tolist()
    [[1.0, 10.0], [1.0, 20.0], [1.0, 30.0], [2.0, 10.0], [2.0, 20.0], [2.0, 30.0]]
    """
    if not axes:
        raise ValueError("grid needs at least one axis")
    mesh = np.meshgrid(*[np.asarray(a, float) for a in axes], indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=1)
