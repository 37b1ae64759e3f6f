"""The ``gaocvx equilibria`` and ``gaocvx path`` subcommands.

``add_commands(sub, common)`` registers them on the main parser
(:mod:`gaocvx.cli`); each returns the exit status of the project's contract
(README, docs/getting-started.md): 0 when every answer is accurate, 1 when one
is not (a solver failure), 2 for bad input (raised as SceneError).  A path
whose forces are partly out of range (three or more unstable modes, no
minimiser) prints the others and exits 2, as a sweep with invalid values does;
a force where a solver failed (SolverError) is reported likewise and makes it
1.  With several kinds the larger status wins, as for a sweep or several
scenes.  ``path --json`` writes a ``{"P", "status": "error", "error"}`` line
for each such force, in its place, as ``sweep --json`` does for a value.

Examples
--------
>>> import argparse
>>> parser = argparse.ArgumentParser()
>>> add_commands(parser.add_subparsers(), lambda p: None)
>>> sorted(parser._subparsers._group_actions[0].choices)
['equilibria', 'path']
"""

from __future__ import annotations

import csv
import functools
import logging
import sys

import numpy as np

from ..cli.common import EXIT_INPUT, EXIT_OK, EXIT_SOLVER
from ..errors import SceneError

__all__ = ["add_commands", "parse_range"]

log = logging.getLogger(__name__)


def parse_range(text: str) -> np.ndarray:
    """``START:STOP:NUM`` -> NUM equally spaced forces.

    Raises
    ------
    SceneError
        Naming ``--axial`` and the text.

    Examples
    --------
    >>> parse_range("0:2e9:3").tolist()
    [0.0, 1000000000.0, 2000000000.0]
    """
    from ..ranges import count_of

    parts = str(text).split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        start, stop, num = float(parts[0]), float(parts[1]), count_of(parts[2])
    except ValueError:
        raise SceneError("--axial", "must be START:STOP:NUM, NUM a whole number, e.g. 0:3e9:31",
                         text) from None
    if not (np.isfinite(start) and np.isfinite(stop)) or not 1 <= num <= 10000:
        raise SceneError("--axial", "needs finite START and STOP and 1 <= NUM <= 10000", text)
    if num == 1 and stop != start:   # (linspace would drop STOP without a word)
        raise SceneError("--axial", "NUM = 1 traces START only: give STOP = START, or NUM >= 2",
                         text)
    values = np.linspace(start, stop, num)
    if len(np.unique(values)) < num:   # (a path takes each force once)
        raise SceneError("--axial", "repeats a force: START and STOP must differ when NUM > 1, "
                         "by more than round-off", text)
    return values


def _count(n: int, one: str, many: str) -> str:
    """``n`` and the noun's singular or plural: "1 equilibrium", "3 equilibria"."""
    return f"{n} {one if n == 1 else many}"


def _scene(args):
    from ..cli.common import _overrides
    from ..scene import load_scene
    return load_scene(args.scene, _overrides(args))


def _cmd_equilibria(args) -> int:
    from ..cli.common import _check_output, _dumps
    from .stationary import equilibria

    if args.plot:
        _check_output("--plot", args.plot, suffixes=True)
    scene = _scene(args)
    eqs = equilibria(scene)
    for rank, e in enumerate(eqs):
        if args.json:
            print(_dumps({"rank": rank, **e.to_dict()}), flush=True)
        else:
            print(f"{rank:2d}  {'stable  ' if e.stable else 'unstable'}  energy {e.energy:14.8g} J"
                  f"  min w {e.min['w']:11.5g} m at {e.min['x']:.4g}  max w {e.max['w']:11.5g} m"
                  f" at {e.max['x']:.4g}  {e.status}")
    if args.plot:
        from .pictures import save_equilibria_plot
        save_equilibria_plot(eqs, args.plot, scene)
    if eqs and eqs[0].complete is not True:
        why = ("two unstable modes with an obstacle: the admissible amplitudes could not "
               "be bounded, the plane of amplitudes is sampled"
               if eqs[0].complete is None
               else "the reduced gradient's bounds did not cover every amplitude")
        print(f"note: {args.scene}: the list is not proven complete ({why})", file=sys.stderr)
    bad = [e for e in eqs if e.status != "optimal"]
    if bad:
        print(f"error: {args.scene}: {_count(len(bad), 'equilibrium', 'equilibria')} not found "
              "accurately", file=sys.stderr)
    return EXIT_SOLVER if bad else EXIT_OK


def _cmd_path(args) -> int:
    from ..cli.common import _check_output, _dumps
    from ..progress import ProgressBar
    from .path import equilibrium_path

    values = parse_range(args.axial)
    for option, name in (("--plot", args.plot), ("--csv", args.csv)):
        if name:
            _check_output(option, name, suffixes=option == "--plot")
    scene = _scene(args)
    if args.at is not None:
        from ..scene import number
        number("--at", args.at, lo=0.0, hi=scene.beam.length)   # a point of the beam [m]
    bar = ProgressBar("path") if sys.stderr.isatty() else None
    path = equilibrium_path(scene, values, x_c=args.at, progress=bar)
    if args.json:
        for record in path.records():   # every force: its points or its error
            print(_dumps(record), flush=True)
    else:
        counts = [f"{len(path.errors)} skipped"] if path.errors else []
        counts += [f"{len(path.failures)} failed"] if path.failures else []
        skipped = f" ({', '.join(counts)})" if counts else ""
        print(f"# {_count(len(path.points), 'equilibrium', 'equilibria')} at "
              f"{_count(len(path.P), 'axial force', 'axial forces')}{skipped}; "
              f"w_c = w({path.x_c:.4g} m)")
        for p in path.records():   # in force order, a skipped or failed force in its place
            if p.get("status") == "error":
                kind = "skipped" if p["P"] in path.errors else "failed"
                print(f"P {p['P']:12.5g} N  {kind}: {p['error']}")
                continue
            print(f"P {p['P']:12.5g} N  w_c {p['w_c']:12.5g} m  energy {p['energy']:13.6g} J  "
                  f"{'stable  ' if p['stable'] else 'unstable'}{'  global' if p['global'] else ''}")
    for record in path.records():
        if record.get("status") == "error":
            print(f"error: P = {record['P']:.6g} N: {record['error']}", file=sys.stderr)
    if args.csv:
        with open(args.csv, "w", newline="") as fh:
            csv.writer(fh).writerows(path.rows())
    if args.plot:
        from ..discrete import DiscreteProblem
        from .pictures import save_path_plot
        P_bar = DiscreteProblem(scene, check_convexity=False).P_bar_h
        save_path_plot(path, args.plot, scene, P_bar)
    bad = [p for p in path.points if p["status"] != "optimal"]
    # Skipped forces are input out of range (SceneError: no minimiser, too many modes):
    # 2; a solver's failure (SolverError) or an inaccurate point: 1.  The worse wins,
    # as in a sweep (max over the values' codes).
    return max(EXIT_INPUT if path.errors else EXIT_OK,
               EXIT_SOLVER if path.failures or bad else EXIT_OK)


def _path_error(error, message: str):
    """The path parser's errors; ``--axial -1e9:...`` gets the form that parses.

    argparse takes a value that starts with '-' and is no plain number for an
    option, so a range from a tension gives "expected one argument".
    """
    if message.startswith("argument --axial") and "expected one argument" in message:
        message += ("; a range that starts below zero needs '=': --axial=START:STOP:NUM, "
                    "e.g. --axial=-1e9:2e9:4")
    error(message)


def add_commands(sub, common) -> None:
    """Register ``equilibria`` and ``path`` on the subparsers ``sub``.

    ``common(p)`` adds the options every scene command takes (--set, --elements, ...).
    """
    p = sub.add_parser("equilibria", help="every equilibrium above the convexity limit "
                       "(one or two unstable modes), sorted by energy")
    p.add_argument("scene", metavar="SCENE")
    common(p)
    p.add_argument("--plot", metavar="FILE", help="write every equilibrium's deflection")
    p.set_defaults(func=_cmd_equilibria)

    p = sub.add_parser("path", help="the equilibrium path: every equilibrium against P")
    p.error = functools.partial(_path_error, p.error)
    p.add_argument("scene", metavar="SCENE")
    p.add_argument("--axial", required=True, metavar="START:STOP:NUM",
                   help="axial forces [N], e.g. --axial=-1e9:4e9:51 (with '=' when START is "
                   "negative)")
    p.add_argument("--at", type=float, metavar="X",
                   help="where to take the deflection [m] (default: the first mode's peak)")
    common(p)
    p.add_argument("--csv", metavar="FILE", help="write one row per equilibrium")
    p.add_argument("--plot", metavar="FILE", help="write the path diagram (PNG/SVG)")
    p.set_defaults(func=_cmd_path)
