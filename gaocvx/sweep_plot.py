"""Pictures of sweeps: quantities against one swept value, or maps over a grid of two.

Examples
--------
>>> import matplotlib
>>> matplotlib.use("Agg")
>>> from gaocvx import Scene
>>> from gaocvx.sweep import grid, parse_range, summary_row, sweep
>>> scene = Scene.from_dict({"beam": {"supports": "P1", "length": 1.0, "E": 2.1e11,
...     "nu": 0.3, "half_thickness": 0.1, "width": 1.0}, "load": {"q": -5e8},
...     "foundation": {"gap": 0.007, "stiffness": 5e8}, "mesh": {"elements": 8}})
>>> keys = ("foundation.stiffness", "foundation.gap")
>>> points = grid(parse_range("1e9:1e12:4:log"), parse_range("0.002:0.008:3"))
>>> rows = [summary_row(v, r, keys) for v, r in sweep(scene, keys, points)]
>>> fig = sweep_map_figure(rows, keys, log=(True, False), scene=scene)
>>> [ax.get_title() for ax in fig.axes if ax.get_title()]
['max |w| [m]', 'energy [J]', 'contact length [m]']
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .plot import UNITS, _check_file, _pyplot, _write

__all__ = ["sweep_figure", "save_sweep_plot", "sweep_map_figure", "save_sweep_map"]


def save_sweep_plot(rows: list, key: str, path, reference: dict | None = None,
                    log: bool = False, scene=None) -> Path:
    """Write :func:`sweep_figure` to ``path`` (.png or .svg)."""
    path = _check_file(path)
    return _write(_pyplot(), sweep_figure(rows, key, reference, log, scene), path)


def sweep_figure(rows: list, key: str, reference: dict | None = None, log: bool = False,
                 scene=None):
    """How max deflection, energy and contact length move with the swept value (a Figure).

    Parameters
    ----------
    rows : list of dict
        :func:`gaocvx.sweep.summary_row` of each value.
    key : str
        The swept key; its unit (UNITS) labels the x-axis.
    reference : dict, optional
        Numbers drawn as horizontal lines (e.g. the rigid obstacle's for a
        foundation-stiffness sweep).
    log : bool
        Logarithmic x-axis.
    scene : Scene, optional
        The swept scene: without a foundation or obstacle there is no contact
        panel, and an axial sweep marks the convexity limit P_bar_h.
    """
    plt = _pyplot()
    ok = [r for r in rows if r["status"] != "error"]
    x = np.array([r["value"] for r in ok])
    contact = (scene.contact is not None) if scene is not None else any("penetration" in r for r in ok)
    series = [("max |w| [m]", [max(abs(r["min_w"]), abs(r["max_w"])) for r in ok], "max_abs_w"),
              ("energy [J]", [r["energy"] for r in ok], "energy")]
    if contact:
        series.append(("contact length [m]", [r["contact_length"] for r in ok], "contact_length"))
    fig, axes = plt.subplots(len(series), 1, figsize=(7, 2.7 * len(series) + 0.6), sharex=True,
                             squeeze=False)
    axes = axes[:, 0]
    limits = {}   # the convexity limits an axial sweep runs into
    if scene is not None and key == "load.axial":
        from .discrete import DiscreteProblem
        dp = DiscreteProblem(scene, check_convexity=False)
        limits["P_bar_h"] = dp.P_bar_h
        if getattr(dp, "P_hat_h", None) is not None:   # a bonded foundation's limit
            limits["P_hat_h"] = dp.P_hat_h
    for ax, (label, y, ref_key) in zip(axes, series):
        ax.plot(x, y, "o-", ms=3)
        if ref_key == "contact_length":
            # A point contact has length 0 but is contact: mark it.
            pts = [(r["value"], r["contact_length"]) for r in ok
                   if r.get("contact_zones", 0) and r["contact_length"] == 0]
            if pts:
                px, py = zip(*pts)
                ax.plot(px, py, "v", color="tab:red", ms=6, label="point contact (length 0)")
        if reference and ref_key in reference:
            point = (ref_key == "contact_length" and reference[ref_key] == 0
                     and reference.get("contact_zones", 0) > 0)
            ax.axhline(reference[ref_key], color="saddlebrown", ls="--",
                       label=reference.get("label", "reference")
                       + (": point contact (length 0)" if point else ""))
        for (name, value), style in zip(limits.items(), (":", "-.")):
            ax.axvline(value, color="tab:red", ls=style, lw=1.2,
                       label=f"{name} = {value:.4g} N" if ax is axes[0] else None)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if log:
            ax.set_xscale("log")
    unit = UNITS.get(key, "-")
    axes[-1].set_xlabel(f"{key} [{unit}]")
    fig.suptitle(f"sweep of {key}", fontsize=10)
    fig.tight_layout()
    return fig


def _edges(values: np.ndarray, log: bool) -> np.ndarray:
    """Cell edges around sorted grid values: midpoints (geometric on a log axis).

    Each value is its cell's centre on the axis as drawn; a single value gets a
    cell of a tenth of itself (or of 1 at 0) on either side.

    >>> np.round(np.log10(_edges(np.array([1e8, 1e10]), log=True)), 12).tolist()
    [7.0, 9.0, 11.0]
    >>> _edges(np.array([0.003]), log=False).tolist()
    [0.0027, 0.0033]
    """
    v = np.asarray(values, float)
    if len(v) == 1:
        half = 0.1 * abs(v[0]) or 1.0
        return np.array([v[0] / 1.1, v[0] * 1.1]) if log else np.array([v[0] - half, v[0] + half])
    t = np.log(v) if log else v
    mid = 0.5 * (t[1:] + t[:-1])
    edges = np.concatenate([[2 * t[0] - mid[0]], mid, [2 * t[-1] - mid[-1]]])
    return np.exp(edges) if log else edges


def save_sweep_map(rows: list, keys, path, log=(False, False), scene=None):
    """Write :func:`sweep_map_figure` to ``path`` (.png or .svg)."""
    path = _check_file(path)
    return _write(_pyplot(), sweep_map_figure(rows, keys, log, scene), path)


def sweep_map_figure(rows: list, keys, log=(False, False), scene=None):
    """Maps of max |w|, energy and contact length over a grid of two keys (a Figure).

    Parameters
    ----------
    rows : list of dict
        :func:`gaocvx.sweep.summary_row` of each point, with one column per key
        (the points of :func:`gaocvx.sweep.grid`, in any order).
    keys : pair of str
        The two keys: the first on the x-axis, the second on the y-axis.
    log : pair of bool
        Logarithmic axes.
    scene : Scene, optional
        Without a foundation or obstacle there is no contact map.

    A point whose value failed (an error, or a status other than ``optimal``)
    is left blank and marked with a cross: a map never shows a number that was
    not certified.
    """
    plt = _pyplot()
    kx, ky = keys
    xs = np.unique([r[kx] for r in rows])
    ys = np.unique([r[ky] for r in rows])
    contact = (scene.contact is not None) if scene is not None else any("penetration" in r
                                                                       for r in rows)
    series = [("max |w| [m]", lambda r: max(abs(r["min_w"]), abs(r["max_w"]))),
              ("energy [J]", lambda r: r["energy"])]
    if contact:
        series.append(("contact length [m]", lambda r: r["contact_length"]))
    fig, axes = plt.subplots(1, len(series), figsize=(4.2 * len(series) + 0.6, 3.9),
                             squeeze=False)
    bad = [(r[kx], r[ky]) for r in rows if r["status"] != "optimal"]
    for ax, (label, value) in zip(axes[0], series):
        z = np.full((len(ys), len(xs)), np.nan)
        for r in rows:
            if r["status"] == "optimal":
                z[np.searchsorted(ys, r[ky]), np.searchsorted(xs, r[kx])] = value(r)
        mesh = ax.pcolormesh(_edges(xs, log[0]), _edges(ys, log[1]), z, shading="flat")
        fig.colorbar(mesh, ax=ax)
        if bad:
            bx, by = zip(*bad)
            ax.plot(bx, by, "x", color="tab:red", ms=6, label="not optimal")
            ax.legend(fontsize=8)
        ax.set_title(label, fontsize=10)
        ax.set_xlabel(f"{kx} [{UNITS.get(kx, '-')}]")
        ax.set_ylabel(f"{ky} [{UNITS.get(ky, '-')}]")
        if log[0]:
            ax.set_xscale("log")
        if log[1]:
            ax.set_yscale("log")
    fig.suptitle(f"map of {kx} x {ky} ({len(rows)} points)", fontsize=10)
    fig.tight_layout()
    return fig
