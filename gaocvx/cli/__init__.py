"""The ``gaocvx`` command line.

``main(argv) -> int`` runs one subcommand; tests call it directly.  Exit
status: 0 solved, 1 solver failure (or a result that is not certified
optimal), 2 bad input, with ``error: <key>: <what> (got <value>)`` on stderr.

One module per part: :mod:`.common` (exit codes, argument types, output
checks, JSON), :mod:`.commands` (solve, verify, report, compare),
:mod:`.sweep` (sweep) and :mod:`gaocvx.nonconvex.cli` (equilibria, path);
this module builds the parser and runs it.
"""

from __future__ import annotations

import argparse
import functools
import logging
import os
import sys

from ..errors import SceneError, SolverError
from .commands import _cmd_compare, _cmd_report, _cmd_solve, _cmd_verify
from .common import (EXIT_INPUT, EXIT_OK, EXIT_PIPE, EXIT_SOLVER, _common, _count, _Parser,
                     _unexpected)
from .sweep import _cmd_sweep

__all__ = ["main", "run", "EXIT_OK", "EXIT_SOLVER", "EXIT_INPUT", "EXIT_PIPE"]


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="gaocvx", description="Gao and Euler-Bernoulli beams: bending and "
                     "contact, solved as convex programs.")
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="log progress to stderr (-vv for debug)")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)

    p = sub.add_parser("solve", help="solve one or more scene files")
    p.add_argument("scenes", nargs="+", metavar="SCENE", help="scene file(s) (TOML)")
    p.add_argument("--method", help="auto | convex | newton | cvm | global "
                   "(overrides solve.method)")
    p.add_argument("--solver", help="clarabel | osqp (convex method; overrides solve.solver)")
    p.add_argument("--elements", type=_count, help="number of elements (overrides mesh.elements)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override one scene value, e.g. --set beam.nu=0.25 (repeatable)")
    p.add_argument("--json", action="store_true", help="JSON (Lines) on stdout")
    p.add_argument("--plot", metavar="FILE", help="write a picture of the deflection (PNG/SVG)")
    p.add_argument("--panels", metavar="LIST",
                   help="extra plot panels, comma-separated: slope,moment,shear,reaction")
    p.set_defaults(func=_cmd_solve)

    p = sub.add_parser("compare", help="the scene with the Euler-Bernoulli and the Gao model")
    p.add_argument("scene", metavar="SCENE")
    _common(p)
    p.add_argument("--plot", metavar="FILE", help="write both deflections on one picture")
    p.set_defaults(func=_cmd_compare)

    p = sub.add_parser("sweep", help="solve the scene for each value of one key")
    p.add_argument("scene", metavar="SCENE")
    p.add_argument("--vary", required=True, action="append", metavar="KEY=START:STOP:NUM[:log]",
                   help="the key and its values, e.g. foundation.stiffness=1e8:1e12:20:log "
                   "(load.scale multiplies every vertical load); give it again for a grid "
                   "of every combination (a map)")
    _common(p)
    p.add_argument("--csv", metavar="FILE", help="write one row per value")
    p.add_argument("--plot", metavar="FILE", help="write max deflection, energy and contact "
                   "length against the value (for two keys: maps over the grid)")
    p.add_argument("--jobs", type=int, default=1, metavar="N", help="worker processes")
    p.add_argument("--dask", metavar="ADDRESS", help="send the values to a Dask scheduler "
                   "(needs dask[distributed])")
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("verify", help="score a computed deflection (CSV: x, w[, slope]) "
                       "against the ground truth")
    p.add_argument("scene", metavar="SCENE", help="the scene the result claims to solve")
    p.add_argument("result", metavar="RESULT.csv", help="columns x, w and optionally slope")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value")
    p.add_argument("--reference-elements", type=_count, default=1024, metavar="N",
                   help="elements of the ground-truth mesh (default 1024)")
    p.add_argument("--max-gap", type=float, metavar="G",
                   help="exit 1 when |relative energy gap| exceeds G")
    p.add_argument("--max-error", type=float, metavar="E",
                   help="exit 1 when the largest deflection error, relative to max |w| of the "
                   "ground truth, exceeds E")
    p.add_argument("--json", action="store_true", help="JSON on stdout")
    p.set_defaults(func=_cmd_verify)

    p = sub.add_parser("report", help="reproduce the thesis's published cases side by side")
    p.add_argument("which", choices=["thesis"], help="the report to make")
    p.add_argument("--output", metavar="FILE", help="write Markdown here instead of stdout")
    p.set_defaults(func=_cmd_report)
    from ..nonconvex.cli import add_commands  # equilibria, path (above the convexity limit)
    add_commands(sub, functools.partial(_common, method=False))
    for p in sub.choices.values():  # -v after the subcommand too; counts add up
        p.add_argument("-v", "--verbose", dest="verbose_after", action="count", default=0,
                       help="log phases and progress to stderr (-vv for debug)")
    return parser


def _quiet_stdout() -> None:
    """Point stdout at /dev/null, so that flushing it at exit cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # no real file behind stdout (tests)
        pass


def main(argv=None) -> int:
    """Run the command line; return the exit status."""
    parser = _build_parser()
    try:
        args = parser.parse_args(argv)
    except SceneError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    verbose = args.verbose + getattr(args, "verbose_after", 0)
    logging.basicConfig(level=[logging.WARNING, logging.INFO, logging.DEBUG][min(verbose, 2)],
                        format="%(levelname)s %(name)s: %(message)s")
    if args.version:
        from .. import __version__
        print(f"gaocvx {__version__}")
        return EXIT_OK
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_INPUT
    try:
        return args.func(args)
    except SceneError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except SolverError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_SOLVER
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_PIPE
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 128 + 2
    except Exception as exc:  # noqa: BLE001 - never a traceback on the command line
        print(f"error: {_unexpected(exc)}", file=sys.stderr)
        return EXIT_SOLVER


def run() -> None:  # console-script entry point
    from ..linalg import one_blas_thread
    with one_blas_thread():
        code = main()
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _quiet_stdout()
        code = EXIT_PIPE
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
