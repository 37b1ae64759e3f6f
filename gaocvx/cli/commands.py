"""The subcommands ``solve``, ``verify``, ``report`` and ``compare``."""

from __future__ import annotations

import logging
import sys
from pathlib import Path

from ..errors import SceneError, SolverError
from .common import (EXIT_INPUT, EXIT_OK, EXIT_SOLVER, _check_output, _dumps, _load,
                     _overrides, _plot_name, _unexpected)

log = logging.getLogger(__name__)


def _cmd_solve(args) -> int:
    from ..scene import load_scene
    from ..solve import solve

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
                from ..plot import save_plot
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


def _cmd_verify(args) -> int:
    from ..scene import load_scene, number
    from ..verify import check_reference_elements, read_result_csv, verify

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
        many = report["reference"]["minimisers"]
        print(f"max |w error| {report['max_error']:.4g} m (relative {report['max_error_rel']:.3g})"
              f" at x = {report['max_error_x']:.6g} m"
              + (f", against the nearest of {many} global minimisers" if many > 1 else ""))
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
    from ..report import thesis_markdown, thesis_rows

    if args.output:
        _check_output("--output", args.output)
    command = "gaocvx report thesis" + (f" --output {args.output}" if args.output else "")
    text = thesis_markdown(thesis_rows(), command)
    if args.output:
        Path(args.output).write_text(text)
    else:
        print(text, end="")
    return EXIT_OK


def _cmd_compare(args) -> int:
    from ..solve import solve

    scene = _load(args)
    if args.plot:
        _check_output("--plot", args.plot, suffixes=True)
    if scene.beam.nu is None:
        raise SceneError("beam.nu", "missing: the gao model needs Poisson's ratio")
    gao = solve(_with_model(scene, "gao"))
    try:
        eb = solve(_with_model(scene, "euler-bernoulli"))
    except SceneError as exc:
        # Above the Euler-Bernoulli limit (the Gao one is lower, so gao ran the global
        # method) the classical beam has no minimiser: the Gao answer is still given,
        # the refusal stands in the Euler-Bernoulli place, and the exit status is 2.
        eb, refusal = None, str(exc)
    results = {"euler-bernoulli": eb, "gao": gao} if eb is not None else {"gao": gao}
    diff = {"min_w_ratio": gao.min["w"] / eb.min["w"] if eb is not None and eb.min["w"] else None,
            "energy_ratio": gao.energy / eb.energy if eb is not None and eb.energy else None}
    if args.json:
        print(_dumps({"scene": args.scene,
                      "euler-bernoulli": eb.to_dict() if eb is not None
                      else {"status": "error", "error": refusal},
                      "gao": gao.to_dict(), "comparison": diff}))
    else:
        if eb is None:
            print(f"{'euler-bernoulli':16s} error      {refusal}")
        for model, r in results.items():
            zones = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in r.zones) if r.zones else "-"
            print(f"{model:16s} {r.status:10s} min w {r.min['w']:.6g} m at x = {r.min['x']:.4g} m,"
                  f" max w {r.max['w']:.6g} m, energy {r.energy:.6g} J, contact {zones}")
        if diff["min_w_ratio"] is not None:
            print(f"gao / euler-bernoulli: min w x{diff['min_w_ratio']:.4f}, "
                  f"energy x{diff['energy_ratio']:.4f}")
    if args.plot:
        from ..plot import save_compare_plot
        save_compare_plot(results, args.plot)
    if eb is None:
        print(f"error: euler-bernoulli: {refusal}", file=sys.stderr)
        return EXIT_INPUT
    return EXIT_OK if all(r.success for r in results.values()) else EXIT_SOLVER


def _with_model(scene, model):
    from ..scene import Scene
    data = scene.to_dict()
    data["beam"]["model"] = model
    if model == "euler-bernoulli":
        data["beam"].pop("E_alpha", None)
    return Scene.from_dict(data)


