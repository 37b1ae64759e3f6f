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

__all__ = ["SceneError", "SolverError", "format_value"]


def format_value(value) -> str:
    """Format a user-supplied value for an error message.

    Floats use a short general format, strings are quoted, anything else
    uses ``repr``.

    Examples
    --------
    >>> format_value(5e9)
    '5e+09'
    >>> format_value("P7")
    "'P7'"
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return f"{value:.6g}"
    if isinstance(value, str):
        return repr(value)
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


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
