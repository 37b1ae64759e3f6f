"""The vocabulary of a scene and the checks of its values.

Every check raises :class:`~gaocvx.errors.SceneError` naming the dotted key
and the offending value; :func:`number` and :func:`whole` are also used for
command-line options and the arguments of :func:`gaocvx.solve`.

Examples
--------
>>> number("beam.nu", 0.3, lo=0, hi=0.5, hi_open=True)
0.3
>>> number("beam.nu", 0.5, lo=0, hi=0.5, hi_open=True)
Traceback (most recent call last):
...
gaocvx.errors.SceneError: beam.nu: must be < 0.5 (got 0.5)
"""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Iterable
from typing import Mapping

import numpy as np

from ..errors import SceneError

MODELS = ("gao", "euler-bernoulli")
SUPPORTS = ("P1", "P2", "P3", "P4")
METHODS = ("auto", "convex", "newton", "cvm", "global")
TRANSFORMS = ("auto", "T1", "T2", "T3")
CONTROLS = ("P1", "full")
FOUNDATION_KINDS = ("unilateral", "bilateral")
MINIMIZERS = ("projected-newton", "conditional-gradient")
SOLVERS = ("clarabel", "osqp")
MAX_ELEMENTS = 1_000_000
MAX_POINT_FORCES = MAX_ELEMENTS

# Effective-length factors L_ef / L of the continuum buckling loads (physics.md).
EFFECTIVE_LENGTH = {"P1": 0.5, "P2": 0.699157, "P3": 2.0, "P4": 1.0}


def _plain(value):
    """A numpy scalar or array as the Python float, int or (nested) list it holds."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def number(key: str, value, *, lo=None, hi=None, lo_open=False, hi_open=False) -> float:
    """Return ``value`` as a finite float, or raise SceneError naming ``key``.

    Python and numpy integers and reals are accepted (a 0-d array too); bools,
    strings and containers are not.
    """
    value = _plain(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SceneError(key, "must be a number", value)
    try:
        value = float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise SceneError(key, "is too large for a double-precision number "
                         "(about 1.8e308 at most)", value) from None
    if not math.isfinite(value):
        raise SceneError(key, "must be finite", value)
    if lo is not None and (value <= lo if lo_open else value < lo):
        raise SceneError(key, f"must be {'>' if lo_open else '>='} {lo:g}", value)
    if hi is not None and (value >= hi if hi_open else value > hi):
        raise SceneError(key, f"must be {'<' if hi_open else '<='} {hi:g}", value)
    return value


def whole(key: str, value, lo: int, hi: int) -> int:
    """Return ``value`` as an int in [lo, hi], or raise SceneError naming ``key``.

    Integers (Python or numpy) and integral floats such as ``8.0`` are
    accepted; bools, strings and fractions such as ``2.5`` are not.
    """
    v = _plain(value)
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    if isinstance(v, bool) or not isinstance(v, numbers.Integral):
        raise SceneError(key, "must be a whole number", value)
    v = int(v)
    if not lo <= v <= hi:
        raise SceneError(key, f"must be between {lo} and {hi}", v)
    return v


def numbers_of(key: str, values) -> list:
    """``values`` as a list of finite floats (:func:`number` each), or SceneError naming ``key`` and the bad entry.

    A sequence, 1-d array or other iterable of real numbers; one number is a
    list of one (as numpy's ``array_like``).  Strings, mappings, bools, NaN
    and infinities are refused.

    Examples
    --------
    >>> numbers_of("P_values", np.array([0.0, 2e9])), numbers_of("P_values", 1e9)
    ([0.0, 2000000000.0], [1000000000.0])
    >>> numbers_of("P_values", [1e9, float("nan")])
    Traceback (most recent call last):
    ...
    gaocvx.errors.SceneError: P_values[1]: must be finite (got nan)
    """
    if isinstance(values, (numbers.Number, np.generic)) or \
            (isinstance(values, np.ndarray) and values.ndim == 0):
        return [number(key, values)]
    if isinstance(values, (str, bytes, Mapping)) or not isinstance(values, Iterable):
        raise SceneError(key, "must be a number or a sequence of numbers", values)
    return [number(f"{key}[{i}]", v) for i, v in enumerate(values)]


def _choice(key: str, value, options) -> str:
    if not isinstance(value, str) or value not in options:
        listed = ", ".join(repr(o) for o in options)
        raise SceneError(key, f"must be one of {listed}", value)
    return value


def _table(key: str, value) -> Mapping:
    if not isinstance(value, Mapping):
        raise SceneError(key, "must be a table", value)
    return value


def _pairs(key: str, value) -> list:
    """``value`` as a list of (x, value) float pairs, or SceneError naming the bad entry.

    Plain float pairs take a fast path (a million point forces validate in about a
    second); anything else goes through :func:`number`.
    """
    value = _plain(value)
    if not isinstance(value, (list, tuple)):
        raise SceneError(key, "must be a list of [x, value] pairs", value)
    out = []
    append, isfinite = out.append, math.isfinite
    for i, pair in enumerate(value):
        if type(pair) not in (list, tuple):
            pair = _plain(pair)
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise SceneError(f"{key}[{i}]", "must be a pair [x, value]", pair)
        a, b = pair
        if isinstance(a, float) and isinstance(b, float) and isfinite(a) and isfinite(b):
            append((float(a), float(b)))  # float() turns np.float64 into float
        else:
            append((number(f"{key}[{i}][0]", a), number(f"{key}[{i}][1]", b)))
    return out


def _profile(key: str, value, lo: float, lo_open: bool = False):
    """A number, or a piecewise-linear table ``[[x, v], ...]`` (a profile, or a load).

    A table has at least two rows, strictly increasing x, and every value in
    range (``lo=None``: any).  Between its rows v is linear; beyond them a
    surface profile is constant (:func:`profile_at`) and a load is zero.
    """
    value = _plain(value)
    if not isinstance(value, (list, tuple)):
        return number(key, value, lo=lo, lo_open=lo_open)
    table = _pairs(key, value)
    if len(table) < 2:
        raise SceneError(key, "a table needs at least two [x, value] rows", value)
    for i, (x, v) in enumerate(table):
        number(f"{key}[{i}][1]", v, lo=lo, lo_open=lo_open)
        if i and not x > table[i - 1][0]:
            raise SceneError(f"{key}[{i}][0]", "table x must be strictly increasing", x)
    return tuple(table)


def profile_at(value, x) -> np.ndarray:
    """A number or a :func:`_profile` table evaluated at ``x`` (an array)."""
    x = np.asarray(x, float)
    if isinstance(value, tuple):
        xs, vs = zip(*value)
        return np.interp(x, xs, vs)
    return np.full(x.shape, float(value))


def _check_on_beam(key: str, value, L: float) -> None:
    if isinstance(value, tuple):
        for i, (x, _) in enumerate(value):
            if not 0.0 <= x <= L:
                raise SceneError(f"{key}[{i}][0]", f"x must lie on the beam [0, {L:g}]", x)


def _reject_unknown(section: str, data: Mapping, known) -> None:
    for name in data:
        if name not in known:
            where = f"{section}.{name}" if section else str(name)
            listed = ", ".join(known)
            # (a misspelling is the usual cause: "beam.lenght")
            close = difflib.get_close_matches(str(name), list(known), n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise SceneError(where, f"unknown key ({hint}known: {listed})", data[name])

