"""The subcommand ``sweep``: one key or a grid of two, table, CSV, JSON Lines, plots."""

from __future__ import annotations

import functools
import math

from ..errors import SceneError
from .common import EXIT_INPUT, EXIT_OK, EXIT_SOLVER, _check_output, _dumps, _load


def _sweep_outcome(key, keys, as_json, value, item):
    """One sweep value's table row, exit status and JSON line (None without --json)."""
    from ..sweep import summary_row
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

    from ..sweep import ProgressBar, grid, parse_range, sweep

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
        # (max w too: a beam buckled upwards has min w 0 -- a new user's trial)
        print(" ".join(f"{c:>22s}" for c in columns) + f" {'status':10s} {'min w [m]':>12s} "
              f"{'at x':>7s} {'max w [m]':>12s} {'at x':>7s} {'energy [J]':>12s} "
              f"{'contact [m]':>11s} {'zones':>5s}")
        for r in rows:
            at = " ".join(f"{r[c]:22.6g}" for c in columns)
            if r["status"] == "error":
                print(f"{at} error      {r['error']}")
            else:
                contact = (f"{r['contact_length']:11.4g} {r['contact_zones']:5d}"
                           if "contact_zones" in r else f"{'-':>11s} {'-':>5s}")
                print(f"{at} {r['status']:10s} {r['min_w']:12.6g} {r['min_x']:7.4g} "
                      f"{r['max_w']:12.6g} {r['max_x']:7.4g} {r['energy']:12.6g} {contact}")
    if args.csv:
        fields = [*columns, "status", "method", "min_w", "min_x", "max_w", "max_x", "energy",
                  "contact_length", "contact_zones", "penetration", "time_s", "error"]
        with open(args.csv, "w", newline="") as fh:
            writer = csvmod.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(rows)
    if args.plot and keys is not None:
        from ..sweep_plot import save_sweep_map
        save_sweep_map(rows, keys, args.plot, log=[spec.endswith(":log") for _, spec, _ in axes],
                       scene=scene)
    elif args.plot:
        from ..sweep_plot import save_sweep_plot
        reference = None
        if key == "foundation.stiffness":
            # The limit k_F -> infinity: the rigid obstacle at the same gap.
            from ..solve import solve
            data = scene.to_dict()
            data["obstacle"] = {"gap": data.pop("foundation")["gap"]}
            if data.get("solve", {}).get("method") == "cvm":  # cvm has no rigid obstacle
                data["solve"]["method"] = "auto"
            from ..scene import Scene
            ob = solve(Scene.from_dict(data))
            reference = {"label": "rigid obstacle (k_F -> inf)", "energy": ob.energy,
                         "max_abs_w": max(abs(ob.min["w"]), abs(ob.max["w"])),
                         "contact_length": float(sum(b - a for a, b in ob.zones or [])),
                         "contact_zones": len(ob.zones or [])}
        save_sweep_plot(rows, key, args.plot, reference, log=spec.endswith(":log"), scene=scene)
    return worst


