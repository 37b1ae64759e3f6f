"""Exceptions raised by gaocvx.

Bad input is a :class:`SceneError` (a :class:`ValueError`) that names the
offending key and value; the command line prints it as
``error: <key>: <what is wrong> (got <value>)`` and exits with status 2.
A solver that cannot deliver an accurate answer raises :class:`SolverError`
(exit status 1) or, when an answer exists but is not certified, returns a
result whose ``status`` says so.
"""

from __future__ import annotations

import math
import reprlib

__all__ = ["SceneError", "SolverError", "format_value", "apart"]


# Containers are shown only a few levels deep and a few items long: a value nested
# 3000 deep, or a list of a million rows, must not break (or flood) the message.
_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxtuple, _REPR.maxdict = 3, 6, 6, 4
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 80, 80, 40


def format_value(value) -> str:
    """Format a user-supplied value for an error message.

    Floats use a short general format, strings are quoted, integers too long
    to print are described by their number of digits, and containers are
    abbreviated (a few levels, a few items), so that any value gives a short
    line.

    Examples
    --------
    >>> format_value(5e9)
    '5e+09'
    >>> format_value("P7")
    "'P7'"
    >>> format_value(10**400)
    'an integer of 401 digits'
    >>> format_value([[[[[1.0]]]]])
    '[[[[...]]]]'
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return f"{value:.6g}"
    if isinstance(value, int) and abs(value) >= 10**40:
        # repr() refuses integers of more than 4300 digits; count them instead.
        digits = len(str(abs(value))) if value.bit_length() < 14000 else None
        if digits is None:
            return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
        return f"an integer of {digits} digits"
    if isinstance(value, str):
        return _REPR.repr(value)
    try:
        text = _REPR.repr(value)
    except (RecursionError, ValueError):  # pragma: no cover - defensive
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 80 else text[:77] + "..."


def apart(a: float, b: float, digits: int = 4) -> tuple[str, str]:
    """``a`` and ``b`` in ``g`` format with ``digits`` significant digits, or as many
    more as tell them apart (a force and the limit it lies above).

    Examples
    --------
    >>> apart(5e9, 4.672e9)
    ('5e+09', '4.672e+09')
    >>> apart(1.16801e9, 1168002927.17)     # 1.168e+09 twice at 4 digits
    ('1.16801e+09', '1.16800e+09')
    >>> apart(999999999, 1e9)
    ('999999999', '1.00000000e+09')
    """
    for n in range(digits, 18):
        # (beyond ``digits`` with the trailing zeros: 1.16800e+09, not 1.168e+09)
        form = f".{n}g" if n == digits else f"#.{n}g"
        # (the "#" form ends a whole number with its point: 999999999.)
        left, right = (format(v, form).rstrip(".") for v in (a, b))
        if left != right or a == b:
            break
    return left, right


class SceneError(ValueError):
    """A scene value is missing, of the wrong type, or out of range.

    Parameters
    ----------
    key : str
        Dotted path of the offending key, e.g. ``"load.axial"``.
    what : str
        What is wrong, in a few words.
    got : object, optional
        The offending value; omitted from the message when not given.

    Examples
    --------
    >>> str(SceneError("beam.nu", "must be in [0, 0.5)", 0.7))
    'beam.nu: must be in [0, 0.5) (got 0.7)'
    """

    _MISSING = object()

    def __init__(self, key: str, what: str, got=_MISSING):
        self.key = key
        self.what = what
        self.got = None if got is self._MISSING else got
        text = f"{key}: {what}"
        if got is not self._MISSING:
            text += f" (got {format_value(got)})"
        super().__init__(text)


class SolverError(RuntimeError):
    """A numerical method failed to produce a usable answer.

    Parameters
    ----------
    message : str
        What failed, including the solver's own status.
    status : str
        The status string of the failed solve.
    """

    def __init__(self, message: str, status: str = "error"):
        self.status = status
        super().__init__(message)
