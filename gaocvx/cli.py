"""The ``gaocvx`` command line.

``main(argv) -> int`` runs one subcommand; tests call it directly.  Exit
status: 0 solved, 1 solver failure (or a result that is not certified
optimal), 2 bad input, with ``error: <key>: <what> (got <value>)`` on stderr.
"""

from __future__ import annotations

import argparse
import functools
import json
import logging
import math
import os
import sys
from pathlib import Path

from .errors import SceneError, SolverError

__all__ = ["main"]

EXIT_OK, EXIT_SOLVER, EXIT_INPUT = 0, 1, 2
# Output closed early (``gaocvx solve ... --json | head -1``): stop quietly with the
# status of a process ended by SIGPIPE, as other Unix tools do.
EXIT_PIPE = 128 + 13
log = logging.getLogger(__name__)


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors in the project's one-line format."""

    def error(self, message):  # noqa: D401 - argparse API
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
        from .plot import _check_file
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
    from .scene import parse_set
    out = {}
    for text in args.set or ():
        key, value = parse_set(text)
        out[key] = value
    for option, key in (("elements", "mesh.elements"), ("method", "solve.method"),
                        ("solver", "solve.solver")):
        if getattr(args, option, None) is not None:
            out[key] = getattr(args, option)
    return out


def _cmd_solve(args) -> int:
    from .scene import load_scene
    from .solve import solve

    overrides = _overrides(args)
    several = len(args.scenes) > 1
    panels = [p.strip() for p in (args.panels or "").split(",") if p.strip()]
    if args.plot:
        for path in args.scenes:
            _check_output("--plot", _plot_name(args.plot, path, len(args.scenes)), suffixes=True)
    worst = EXIT_OK
    for path in args.scenes:
        record, code = {"scene": path}, EXIT_OK
        try:
            scene = load_scene(path, overrides)
            log.info("%s: solving (%s, supports %s, %d elements, method %s)", path,
                     scene.beam.model, scene.beam.supports, scene.mesh.elements,
                     scene.solve.method)
            result = solve(scene)
            record.update(result.to_dict())
            if not result.success:
                code = EXIT_SOLVER
                verdict = result.extra.get("cvm", {}).get("verdict")
                if result.status == "optimal" and verdict:
                    # CVM solved its own problem; the verdict says why that is not enough.
                    why = f"cvm answer not accepted: {verdict}"
                else:
                    why = f"solve not certified optimal: {result.message}"
                print(f"error: {path}: {why}", file=sys.stderr)
            if args.plot:
                from .plot import save_plot
                name = _plot_name(args.plot, path, len(args.scenes))
                save_plot(result, name, panels)
                log.info("%s: picture written to %s", path, name)
        except SceneError as exc:
            code = EXIT_INPUT
            record.update(status="error", error=str(exc))
            # With several scenes the line names the file: error: b.toml: load.axial: ...
            text = str(exc)
            if several and not text.startswith(f"{path}:"):
                text = f"{path}: {text}"
            print(f"error: {text}", file=sys.stderr)
        except SolverError as exc:
            code = EXIT_SOLVER
            record.update(status="error", error=str(exc))
            print(f"error: {path}: {exc}", file=sys.stderr)
        except (BrokenPipeError, KeyboardInterrupt):
            raise
        except Exception as exc:  # noqa: BLE001 - one line per scene, the others still run
            code = EXIT_SOLVER
            text = _unexpected(exc)
            record.update(status="error", error=text)
            print(f"error: {path}: {text}", file=sys.stderr)
        worst = max(worst, code)
        if args.json:
            print(_dumps(record), flush=True)
        elif "error" not in record:
            if several:
                print(f"== {path}")
            print(result.summary(), flush=True)
    return worst


def _unexpected(exc: BaseException) -> str:
    """One line for an exception that is not the input's or a solver's known failure."""
    log.debug("unexpected error", exc_info=exc)
    if isinstance(exc, MemoryError):
        return "out of memory (try fewer elements)"
    if isinstance(exc, RecursionError):
        return "input nested too deeply"
    return f"internal error: {type(exc).__name__}: {exc} (run with -vv for the traceback)"


def _cmd_verify(args) -> int:
    from .scene import load_scene, number
    from .verify import check_reference_elements, read_result_csv, verify

    scene = load_scene(args.scene, _overrides(args))
    elements = check_reference_elements(scene, args.reference_elements, "--reference-elements")
    max_gap = None if args.max_gap is None else number("--max-gap", args.max_gap, lo=0)
    max_error = None if args.max_error is None else number("--max-error", args.max_error, lo=0)
    x, w, slope = read_result_csv(args.result)
    report = verify(scene, x, w, slope, reference_elements=elements, key=args.result,
                    max_gap=max_gap, max_error=max_error)
    report = {"scene": args.scene, "result": args.result, **report}
    ok = report["reference"]["status"] == "optimal"
    if args.json:
        print(_dumps(report))
    else:
        print(f"result        {args.result} ({report['nodes']} nodes, {report['interpolant']})")
        print(f"energy        {report['energy']:.8g} J (ground truth {report['energy_reference']:.8g} J"
              f", {report['reference']['elements']} elements, {report['reference']['method']})")
        print(f"energy gap    {report['energy_gap']:.4g} J (relative {report['energy_gap_rel']:.3g})")
        print(f"max |w error| {report['max_error']:.4g} m (relative {report['max_error_rel']:.3g})"
              f" at x = {report['max_error_x']:.6g} m")
        if report["boundary_violation"] > 1e-9:
            print(f"note          support conditions violated by {report['boundary_violation']:.3g}"
                  " (relative to max |w|)")
        if report.get("penetration"):
            print(f"note          penetrates the obstacle by {report['penetration']:.4g} m")
    if not ok:
        print(f"error: {args.scene}: ground truth not certified ({report['reference']['status']})",
              file=sys.stderr)
        return EXIT_SOLVER
    if report["exceeded"]:
        print(f"error: {args.result}: {'; '.join(report['exceeded'])}", file=sys.stderr)
        return EXIT_SOLVER
    return EXIT_OK


def _cmd_report(args) -> int:
    from .report import thesis_markdown, thesis_rows

    if args.output:
        _check_output("--output", args.output)
    command = "gaocvx report thesis" + (f" --output {args.output}" if args.output else "")
    text = thesis_markdown(thesis_rows(), command)
    if args.output:
        Path(args.output).write_text(text)
    else:
        print(text, end="")
    return EXIT_OK


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
    from .scene import load_scene
    return load_scene(args.scene, _overrides(args))


def _cmd_compare(args) -> int:
    from .solve import solve

    scene = _load(args)
    if args.plot:
        _check_output("--plot", args.plot, suffixes=True)
    if scene.beam.nu is None:
        raise SceneError("beam.nu", "missing: the gao model needs Poisson's ratio")
    results = {model: solve(_with_model(scene, model)) for model in ("euler-bernoulli", "gao")}
    eb, gao = results["euler-bernoulli"], results["gao"]
    diff = {"min_w_ratio": gao.min["w"] / eb.min["w"] if eb.min["w"] else None,
            "energy_ratio": gao.energy / eb.energy if eb.energy else None}
    if args.json:
        print(_dumps({"scene": args.scene, "euler-bernoulli": eb.to_dict(), "gao": gao.to_dict(),
                      "comparison": diff}))
    else:
        for model, r in results.items():
            zones = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in r.zones) if r.zones else "-"
            print(f"{model:16s} {r.status:10s} min w {r.min['w']:.6g} m at x = {r.min['x']:.4g} m,"
                  f" max w {r.max['w']:.6g} m, energy {r.energy:.6g} J, contact {zones}")
        if diff["min_w_ratio"] is not None:
            print(f"gao / euler-bernoulli: min w x{diff['min_w_ratio']:.4f}, "
                  f"energy x{diff['energy_ratio']:.4f}")
    if args.plot:
        from .plot import save_compare_plot
        save_compare_plot(results, args.plot)
    return EXIT_OK if all(r.success for r in results.values()) else EXIT_SOLVER


def _with_model(scene, model):
    from .scene import Scene
    data = scene.to_dict()
    data["beam"]["model"] = model
    if model == "euler-bernoulli":
        data["beam"].pop("E_alpha", None)
    return Scene.from_dict(data)


def _sweep_outcome(key, keys, as_json, value, item):
    """One sweep value's table row, exit status and JSON line (None without --json)."""
    from .sweep import summary_row
    if isinstance(item, Exception):
        code = EXIT_INPUT if isinstance(item, SceneError) else EXIT_SOLVER
    else:
        code = EXIT_OK if item.success else EXIT_SOLVER
    record = None
    if as_json:
        where = ({"value": value, "key": key} if keys is None
                 else {"value": list(value), "key": list(keys)})
        record = _dumps({**where, "status": "error", "error": str(item)}
                        if isinstance(item, Exception) else {**where, **item.to_dict()})
    return summary_row(value, item, keys), code, record


def _cmd_sweep(args) -> int:
    import csv as csvmod

    from .sweep import ProgressBar, grid, parse_range, sweep

    axes = []
    for vary in args.vary:
        if "=" not in vary:
            raise SceneError("--vary", "must be KEY=START:STOP:NUM[:log]", vary)
        key, spec = (s.strip() for s in vary.split("=", 1))
        axes.append((key, spec, parse_range(spec, "--vary")))
    if len(axes) == 1:
        key, spec, values = axes[0]
        keys = None
    else:  # a grid: every combination, the first key outermost
        keys = key = tuple(k for k, _, _ in axes)
        points = math.prod(len(v) for _, _, v in axes)
        if points > 1_000_000:   # before the grid is built (two axes of 1e5 are 1e10 points)
            raise SceneError("--vary", "a grid of at most 10^6 points", points)
        values = grid(*(v for _, _, v in axes))
        if args.plot and len(axes) != 2:
            raise SceneError("--plot", "a map needs exactly two --vary keys", list(keys))
    if args.jobs < 1:
        raise SceneError("--jobs", "must be at least 1", args.jobs)
    scene = _load(args)
    if args.csv:
        _check_output("--csv", args.csv)
    if args.plot:
        _check_output("--plot", args.plot, suffixes=True)
    bar = ProgressBar(f"sweep {key if keys is None else ' x '.join(keys)}")
    rows, worst = [], EXIT_OK
    # Each value is reduced where it is solved (a worker sends back its row, not its Result).
    reduce = functools.partial(_sweep_outcome, key, keys, args.json)
    for _, (row, exit_code, record) in sweep(scene, key, values, jobs=args.jobs, dask=args.dask,
                                             progress=bar, reduce=reduce):
        rows.append(row)
        worst = max(worst, exit_code)
        if record is not None:
            print(record, flush=True)
    columns = ["value"] if keys is None else list(keys)
    if not args.json:
        print(" ".join(f"{c:>22s}" for c in columns) + f" {'status':10s} {'min w [m]':>12s} "
              f"{'at x':>7s} {'energy [J]':>12s} {'contact [m]':>11s} {'zones':>5s}")
        for r in rows:
            at = " ".join(f"{r[c]:22.6g}" for c in columns)
            if r["status"] == "error":
                print(f"{at} error      {r['error']}")
            else:
                print(f"{at} {r['status']:10s} {r['min_w']:12.6g} {r['min_x']:7.4g} "
                      f"{r['energy']:12.6g} {r['contact_length']:11.4g} {r['contact_zones']:5d}")
    if args.csv:
        fields = [*columns, "status", "method", "min_w", "min_x", "max_w", "max_x", "energy",
                  "contact_length", "contact_zones", "penetration", "time_s", "error"]
        with open(args.csv, "w", newline="") as fh:
            writer = csvmod.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(rows)
    if args.plot and keys is not None:
        from .sweep_plot import save_sweep_map
        save_sweep_map(rows, keys, args.plot, log=[spec.endswith(":log") for _, spec, _ in axes],
                       scene=scene)
    elif args.plot:
        from .sweep_plot import save_sweep_plot
        reference = None
        if key == "foundation.stiffness":
            # The limit k_F -> infinity: the rigid obstacle at the same gap.
            from .solve import solve
            data = scene.to_dict()
            data["obstacle"] = {"gap": data.pop("foundation")["gap"]}
            if data.get("solve", {}).get("method") == "cvm":  # cvm has no rigid obstacle
                data["solve"]["method"] = "auto"
            from .scene import Scene
            ob = solve(Scene.from_dict(data))
            reference = {"label": "rigid obstacle (k_F -> inf)", "energy": ob.energy,
                         "max_abs_w": max(abs(ob.min["w"]), abs(ob.max["w"])),
                         "contact_length": float(sum(b - a for a, b in ob.zones or [])),
                         "contact_zones": len(ob.zones or [])}
        save_sweep_plot(rows, key, args.plot, reference, log=spec.endswith(":log"), scene=scene)
    return worst


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
    from .nonconvex.cli import add_commands  # equilibria, path (above the convexity limit)
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
        from . import __version__
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
    from .linalg import one_blas_thread
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
