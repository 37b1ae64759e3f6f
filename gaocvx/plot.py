"""Pictures of results, comparisons and sweeps (matplotlib, imported only here).

:func:`plot` draws one result on an Axes and returns it; nothing here calls
``show()``.  :func:`save_plot`, :func:`save_compare_plot` and
:func:`save_sweep_plot` write files (PNG or SVG by suffix) for the command line.

Examples
--------
>>> import matplotlib
>>> matplotlib.use("Agg")
>>> from gaocvx import Scene, solve
>>> scene = Scene.from_dict({"beam": {"supports": "P3", "length": 1.0, "E": 2.1e11,
...     "nu": 0.3, "half_thickness": 0.1, "width": 1.0}, "load": {"q": -5e7}})
>>> ax = plot(solve(scene))
>>> ax.get_xlabel()
'x [m]'
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import SceneError

__all__ = ["plot", "save_plot", "save_compare_plot", "save_sweep_plot", "PANELS"]

PANELS = ("slope", "moment", "shear", "reaction")
_SUFFIXES = (".png", ".svg")


def _pyplot():
    try:
        import matplotlib
    except ImportError:
        raise SceneError("--plot", "pictures need matplotlib: pip install 'gaocvx[plot]'",
                         "matplotlib not installed") from None
    if matplotlib.get_backend().lower() not in ("agg", "svg", "pdf", "module://matplotlib_inline.backend_inline"):
        matplotlib.use("Agg")  # files only: never open a window
    import matplotlib.pyplot as plt
    return plt


def _write(plt, fig, path: Path) -> Path:
    """Lay out, save and close a figure; returns its path."""
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _check_file(path) -> Path:
    path = Path(path)
    if path.suffix.lower() not in _SUFFIXES:
        raise SceneError("--plot", "the file name must end in .png or .svg", str(path))
    return path


def _draw_supports(ax, result, size):
    """Clamped ends as hatched walls, pinned ends as triangles; a free end has none."""
    from matplotlib.patches import Polygon, Rectangle
    kinds = {"P1": ("clamped", "clamped"), "P2": ("clamped", "pinned"),
             "P3": ("clamped", "free"), "P4": ("pinned", "pinned")}[result.scene.beam.supports]
    L = result.scene.beam.length
    for x, kind, side in ((0.0, kinds[0], -1), (L, kinds[1], 1)):
        if kind == "clamped":
            ax.add_patch(Rectangle((x if side > 0 else x - 0.02 * L, -size), 0.02 * L, 2 * size,
                                   hatch="///", fill=False, lw=1.0, color="0.3"))
        elif kind == "pinned":
            ax.add_patch(Polygon([[x, 0], [x - 0.015 * L, -0.8 * size], [x + 0.015 * L, -0.8 * size]],
                                 closed=True, fill=False, lw=1.2, color="0.3"))


def plot(result, ax=None, label: str | None = None, annotate: bool = True, color=None):
    """Draw the deflection of a result with supports, foundation/obstacle and contact zones.

    Parameters
    ----------
    result : Result
    ax : matplotlib Axes, optional
        Drawn on; a new figure's Axes by default.
    label : str, optional
        Legend label of the curve.
    annotate : bool
        Mark the extreme deflections.
    color : optional
        Colour of the curve.

    Returns
    -------
    matplotlib Axes
    """
    if ax is None:
        plt = _pyplot()
        _, ax = plt.subplots(figsize=(8, 4))
    L = result.scene.beam.length
    xs = np.linspace(0.0, L, 801)
    w = result.deflection(xs)
    span = max(np.abs(w).max(), result.scene.gap or 0.0) or 1.0
    ax.axhline(0.0, color="0.6", lw=1.0, ls="--", label="undeformed beam" if annotate else None)
    ax.plot(xs, w, lw=2.0, color=color, label=label or f"{result.scene.beam.model} deflection")
    gap = result.scene.gap
    if gap is not None:
        kind = result.scene.contact
        if annotate:  # drawn once when several results share the Axes
            ax.axhline(-gap, color="saddlebrown", lw=1.5, ls=":" if kind == "foundation" else "-",
                       label=f"{kind} surface (gap {gap:g} m)")
            if kind == "obstacle":
                ax.axhspan(-gap - 0.15 * span, -gap, color="saddlebrown", alpha=0.15, lw=0)
        for i, (a, b) in enumerate(result.zones or []):
            lo, hi = (a, b) if b > a else (a - 0.004 * L, b + 0.004 * L)
            ax.axvspan(lo, hi, color=color or "tab:red", alpha=0.12, lw=0,
                       label=(f"contact zone{'' if annotate else ' (' + result.scene.beam.model + ')'}"
                              if i == 0 else None))
    _draw_supports(ax, result, 0.12 * span)
    if annotate:
        for ext, va in ((result.min, "top"), (result.max, "bottom")):
            if abs(ext["w"]) > 1e-12 * span:
                ax.plot([ext["x"]], [ext["w"]], "o", color="k", ms=4)
                ax.annotate(f"{ext['w']:.4g} m\nat x = {ext['x']:.4g} m", (ext["x"], ext["w"]),
                            textcoords="offset points", xytext=(6, -8 if va == "top" else 8),
                            va=va, fontsize=8)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("w [m] (up positive)")
    ax.set_title(f"{result.scene.beam.model}, supports {result.scene.beam.supports}, "
                 f"energy {result.energy:.4g} J ({result.status})", fontsize=10)
    ax.set_xlim(-0.04 * L, 1.04 * L)
    ax.set_ylim(-1.3 * span, 1.3 * span if result.max["w"] > 0.02 * span else 0.4 * span)
    ax.legend(fontsize=8, loc="best")
    return ax


def _panel(ax, result, panel):
    L = result.scene.beam.length
    xs = np.linspace(0.0, L, 801)
    if panel == "slope":
        ax.plot(xs, result.slope_at(xs))
        ax.set_ylabel("w' [-]")
    elif panel == "moment":
        ax.plot(xs, result.moment(xs))
        ax.set_ylabel("M = EI w'' [N m]")
    elif panel == "shear":
        ax.plot(xs, result.shear(xs), drawstyle="steps-mid")
        ax.set_ylabel("V = (EI w'')' [N]")
    elif panel == "reaction":
        if result.reaction is None:
            ax.text(0.5, 0.5, "no foundation or obstacle", ha="center", transform=ax.transAxes)
        else:
            unit = "N/m" if result.scene.contact == "foundation" else "N (nodal force)"
            ax.stem(result.x, result.reaction, basefmt=" ")
            ax.set_ylabel(f"reaction [{unit}]")
    ax.axhline(0.0, color="0.7", lw=0.8)
    ax.set_xlabel("x [m]")


def save_plot(result, path, panels=()) -> Path:
    """Write the picture of a result (and optional panels) to ``path`` (.png or .svg)."""
    path = _check_file(path)
    for p in panels:
        if p not in PANELS:
            raise SceneError("--panels", f"unknown panel (known: {', '.join(PANELS)})", p)
    plt = _pyplot()
    n = 1 + len(panels)
    fig, axes = plt.subplots(n, 1, figsize=(8, 4 + 2.2 * len(panels)), sharex=True,
                             gridspec_kw={"height_ratios": [2] + [1] * len(panels)}, squeeze=False)
    plot(result, axes[0, 0])
    for ax, panel in zip(axes[1:, 0], panels):
        _panel(ax, result, panel)
    return _write(plt, fig, path)


def save_compare_plot(results: dict, path) -> Path:
    """Euler-Bernoulli and Gao deflections of one scene on one picture."""
    path = _check_file(path)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4))
    colors = {"euler-bernoulli": "tab:blue", "gao": "tab:orange"}
    for i, (model, result) in enumerate(results.items()):
        plot(result, ax, label=f"{model}: min {result.min['w']:.4g} m, energy {result.energy:.4g} J",
             annotate=i == 0, color=colors.get(model))
    ax.set_title(f"Euler-Bernoulli and Gao, supports {result.scene.beam.supports}", fontsize=10)
    return _write(plt, fig, path)


def save_sweep_plot(rows: list, key: str, path, reference: dict | None = None,
                    log: bool = False) -> Path:
    """How max deflection, energy and contact length move with the swept value.

    ``reference`` (e.g. the rigid obstacle's numbers for a foundation-stiffness
    sweep) is drawn as horizontal lines.
    """
    path = _check_file(path)
    plt = _pyplot()
    ok = [r for r in rows if r["status"] != "error"]
    x = np.array([r["value"] for r in ok])
    fig, axes = plt.subplots(3, 1, figsize=(7, 8), sharex=True)
    series = [("max |w| [m]", [max(abs(r["min_w"]), abs(r["max_w"])) for r in ok], "max_abs_w"),
              ("energy [J]", [r["energy"] for r in ok], "energy"),
              ("contact length [m]", [r["contact_length"] for r in ok], "contact_length")]
    for ax, (label, y, ref_key) in zip(axes, series):
        ax.plot(x, y, "o-", ms=3)
        if reference and ref_key in reference:
            ax.axhline(reference[ref_key], color="saddlebrown", ls="--",
                       label=reference.get("label", "reference"))
            ax.legend(fontsize=8)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if log:
            ax.set_xscale("log")
    axes[-1].set_xlabel(key)
    fig.suptitle(f"sweep of {key}", fontsize=10)
    return _write(plt, fig, path)
