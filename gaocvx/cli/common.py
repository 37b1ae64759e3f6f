"""What the subcommands share: exit codes, argument types, output checks, JSON."""

from __future__ import annotations

import argparse
import ast
import json
import logging
import math
import re
from pathlib import Path

from ..errors import SceneError

EXIT_OK, EXIT_SOLVER, EXIT_INPUT = 0, 1, 2
# Output closed early (``gaocvx solve ... --json | head -1``): stop quietly with the
# status of a process ended by SIGPIPE, as other Unix tools do.
EXIT_PIPE = 128 + 13
log = logging.getLogger(__name__)


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors in the project's one-line format."""

    def error(self, message):  # noqa: D401 - argparse API
        # A value of the wrong type names its option and the value, as every other
        # bad input does ("--at: must be a number (got 'abc')", not argparse's
        # "argument --at: invalid float value: 'abc'")
        bad = re.fullmatch(r"argument (\S+): invalid (float|int) value: (.*)", message)
        if bad:
            option, kind, value = bad.groups()
            try:   # (argparse shows the value's repr: "a'b" in double quotes)
                value = ast.literal_eval(value)
            except (ValueError, SyntaxError):
                pass
            raise SceneError(option.split("/")[-1], "must be a number" if kind == "float"
                             else "must be a whole number", value)
        raise SceneError("arguments", message)


def _count(text: str):
    """An argparse type for element counts: ``100000``, ``1e5`` or ``2.5`` (refused later).

    The value is checked where it is used, so that the message names the
    option or key and the allowed range.
    """
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            pass
    return text


def _check_output(option: str, path, suffixes: bool = False) -> None:
    """Make sure ``path`` can be written, before any work is done.

    The directory must exist and the file must be writable: it is opened for
    appending (nothing is changed) and removed again if it did not exist.

    Raises
    ------
    SceneError
        Naming ``option`` and the path.
    """
    if suffixes:
        from ..plot import _check_file
        _check_file(path)  # .png or .svg
    p = Path(path)
    if p.is_dir():
        raise SceneError(option, "is a directory, not a file", str(p))
    parent = p.parent
    if not parent.is_dir():
        raise SceneError(option, f"cannot write the file: the directory {str(parent)!r} "
                         "does not exist", str(p))
    existed = p.exists()
    try:
        with open(p, "a"):
            pass
    except OSError as exc:
        raise SceneError(option, f"cannot write the file: {exc.strerror or exc}", str(p)) from None
    if not existed:
        try:
            p.unlink()
        except OSError:  # pragma: no cover - removed meanwhile
            pass


def _json_default(value):
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _dumps(obj) -> str:
    # JSON has no inf/nan; an honest null is better than invalid JSON.  A -0.0
    # (round-off's sign of a zero) is written 0.0: it reads as a sign that is not there.
    def clean(v):
        if isinstance(v, float):
            return v + 0.0 if math.isfinite(v) else None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        return v
    return json.dumps(clean(obj), default=_json_default)


def _overrides(args) -> dict:
    """Scene overrides from ``--set`` and the options that stand for keys."""
    from ..scene import parse_set
    out = {}
    for text in args.set or ():
        key, value = parse_set(text)
        out[key] = value
    for option, key in (("elements", "mesh.elements"), ("method", "solve.method"),
                        ("solver", "solve.solver")):
        if getattr(args, option, None) is not None:
            out[key] = getattr(args, option)
    return out


def _unexpected(exc: BaseException) -> str:
    """One line for an exception that is not the input's or a solver's known failure."""
    log.debug("unexpected error", exc_info=exc)
    if isinstance(exc, MemoryError):
        return "out of memory (try fewer elements)"
    if isinstance(exc, RecursionError):
        return "input nested too deeply"
    return f"internal error: {type(exc).__name__}: {exc} (run with -vv for the traceback)"


def _plot_name(name: str, scene_path: str, count: int) -> str:
    if count == 1:
        return name
    p = Path(name)
    return str(p.with_name(f"{p.stem}-{Path(scene_path).stem}{p.suffix}"))


def _common(p, method: bool = True):
    if method:   # equilibria and path have one method (the reduced function's zeros)
        p.add_argument("--method", help="auto | convex | newton | cvm | global (overrides "
                       "solve.method)")
    p.add_argument("--elements", type=_count, help="number of elements (overrides mesh.elements)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value")
    p.add_argument("--json", action="store_true", help="JSON on stdout")


def _load(args):
    from ..scene import load_scene
    return load_scene(args.scene, _overrides(args))


