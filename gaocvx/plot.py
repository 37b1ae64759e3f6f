"""Pictures of results and comparisons (matplotlib, imported only here).

:func:`plot` draws the deflection of one result on an Axes and returns it;
:func:`plot_loads` draws what acts on the beam (the distributed load's
profile, point forces, the axial force, the support reactions).  Nothing here
calls ``show()``.  :func:`save_plot` and :func:`save_compare_plot` write files (PNG or SVG by
suffix) for the command line; sweeps are drawn by :mod:`gaocvx.sweep_plot`.

Examples
--------
>>> import matplotlib
>>> matplotlib.use("Agg")
>>> from gaocvx import Scene, solve
>>> scene = Scene.from_dict({"beam": {"model": "euler-bernoulli", "supports": "P3",
...     "length": 1.0, "E": 2.1e11, "half_thickness": 0.1, "width": 1.0},
...     "load": {"q": -5e7}})
>>> ax = plot(solve(scene))
>>> ax.get_xlabel()
'x [m]'
>>> [t.get_text() for t in ax.figure.axes[0].texts if t.get_text()]   # -q L, -q L^2 / 2
['R = 5e+07 N', 'M = 2.5e+07 N m ↺']
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import SceneError

__all__ = ["plot", "plot_loads", "result_figure", "compare_figure", "save_plot",
           "save_compare_plot", "PANELS", "UNITS"]

PANELS = ("slope", "moment", "shear", "reaction")
_SUFFIXES = (".png", ".svg")
DEFAULT_METHOD = "newton"   # what "auto" solves with; other methods are named on the plot
# More point forces than this are drawn as plain lines, without a value each.
MAX_LABELLED_FORCES = 12

# The unit of each scene key a sweep may vary (the x-axis label).
UNITS = {
    "beam.length": "m", "beam.E": "Pa", "beam.nu": "-", "beam.half_thickness": "m",
    "beam.width": "m", "beam.EI": "N m^2", "beam.E_alpha": "N", "beam.mu": "-",
    "load.q": "N/m", "load.axial": "N", "load.scale": "-",
    "foundation.gap": "m", "foundation.stiffness": "N/m^2", "obstacle.gap": "m",
}

_SUPPORT_KINDS = {"P1": ("clamped", "clamped"), "P2": ("clamped", "pinned"),
                  "P3": ("clamped", "free"), "P4": ("pinned", "pinned")}


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


def _xlim(ax, L):
    ax.set_xlim(-0.06 * L, 1.06 * L)   # room for the support glyphs and the axial arrow


def _ha(x, L):
    """Horizontal alignment that keeps a label at x inside the axes."""
    return "left" if x < 0.35 * L else "right" if x > 0.65 * L else "center"


def _draw_supports(ax, result, size):
    """Clamped ends as hatched walls, pinned ends as triangles; a free end has none."""
    from matplotlib.patches import Polygon, Rectangle
    kinds = _SUPPORT_KINDS[result.scene.beam.supports]
    L = result.scene.beam.length
    for x, kind, side in ((0.0, kinds[0], -1), (L, kinds[1], 1)):
        if kind == "clamped":
            ax.add_patch(Rectangle((x if side > 0 else x - 0.02 * L, -size), 0.02 * L, 2 * size,
                                   hatch="///", fill=False, lw=1.0, color="0.3"))
        elif kind == "pinned":
            ax.add_patch(Polygon([[x, 0], [x - 0.015 * L, -0.8 * size], [x + 0.015 * L, -0.8 * size]],
                                 closed=True, fill=False, lw=1.2, color="0.3"))


def _zones_text(zones, L) -> str:
    parts = [f"{a:.3g} (point)" if b - a <= 1e-12 * L else f"[{a:.3g}, {b:.3g}]" for a, b in zones]
    text = ", ".join(parts[:3]) + (f" (+{len(parts) - 3} more)" if len(parts) > 3 else "")
    return text or "none"


def _title(result) -> str:
    beam = result.scene.beam
    method = "" if result.method == DEFAULT_METHOD else f", method {result.method}"
    return (f"{beam.model}, supports {beam.supports}{method}, energy {result.energy:.4g} J "
            f"({result.status})")


def plot(result, ax=None, label: str | None = None, annotate: bool = True, color=None,
         loads: bool = True):
    """Draw the deflection of a result with supports, foundation/obstacle and contact zones.

    Parameters
    ----------
    result : Result
    ax : matplotlib Axes, optional
        Drawn on; by default a new figure, with the loads (:func:`plot_loads`)
        in a panel above the deflection.
    label : str, optional
        Legend label of the curve.
    annotate : bool
        Draw what several results on one Axes share once: the undeformed beam,
        the surface, the supports and the extreme deflections.
    color : optional
        Colour of the curve and of its contact zones.
    loads : bool
        With ``ax=None``: add the loads panel.

    Returns
    -------
    matplotlib Axes
        The deflection's Axes.
    """
    L = result.scene.beam.length
    if ax is None:
        plt = _pyplot()
        if loads:
            _, (top, ax) = plt.subplots(2, 1, figsize=(8, 6), sharex=True,
                                        gridspec_kw={"height_ratios": [1, 2]})
            plot_loads(result, top)
        else:
            _, ax = plt.subplots(figsize=(8, 4))
    scene, model = result.scene, result.scene.beam.model
    xs = surface_points(scene)
    part = scene.foundation or scene.obstacle
    w = result.deflection(xs)
    level = None if part is None else -np.asarray(part.gap_at(xs), float)
    above = getattr(scene.obstacle, "gap_above", None)
    span = max(np.abs(w).max(), 0.0 if level is None else np.abs(level).max(),
               above or 0.0) or 1.0
    if annotate:
        ax.axhline(0.0, color="0.6", lw=1.0, ls="--", label="undeformed beam")
    ax.plot(xs, w, lw=2.0, color=color, label=label or f"{model} deflection")
    if part is not None:
        if annotate:  # drawn once when several results share the Axes
            draw_surfaces(ax, scene, xs, span)
        zones = result.zones or []
        for i, (a, b) in enumerate(zones):
            lo, hi = (a, b) if b > a else (a - 0.004 * L, b + 0.004 * L)
            ax.axvspan(lo, hi, color=color or "tab:red", alpha=0.12, lw=0,
                       label=f"{model} contact: {_zones_text(zones, L)}" if i == 0 else None)
        if not zones:  # say so: an empty legend entry would read as "not computed"
            ax.plot([], [], lw=0, label=f"{model} contact: none")
    if annotate:
        _draw_supports(ax, result, 0.12 * span)
        # The extremes in the legend, not as text on the curve: nothing to overlap.
        for name, ext, marker in (("min", result.min, "v"), ("max", result.max, "^")):
            if abs(ext["w"]) > 1e-12 * span:
                ax.plot([ext["x"]], [ext["w"]], marker, color="k", ms=5,
                        label=f"{name} w = {ext['w']:.4g} m at x = {ext['x']:.4g} m")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("w [m] (up positive)")
    ax.set_title(_title(result), fontsize=10)
    _xlim(ax, L)
    low = min(w.min(), np.inf if level is None else level.min())
    high = max(w.max(), 0.0, -np.inf if above is None else above)
    # Room below for the obstacle's shading, above for the legend.
    ax.set_ylim(low - 0.3 * span, high + (0.8 if above is not None else 0.6) * span)
    ax.legend(fontsize=8, loc="best", ncol=2)
    return ax


def surface_points(scene, n: int = 801) -> np.ndarray:
    """Points along the beam to draw a deflection and surface at: ``n`` and a gap profile's knots."""
    xs = np.linspace(0.0, scene.beam.length, n)
    part = scene.foundation or scene.obstacle
    if part is not None and isinstance(part.gap, tuple):   # a profile's knots exactly
        xs = np.union1d(xs, [x for x, _ in part.gap])
    return xs


def draw_surfaces(ax, scene, xs, span: float, scale: float = 1.0):
    """Draw the foundation's (dotted) or obstacle's (solid, shaded) surface and a channel's upper one.

    ``span`` is the picture's height in the Axes' units; ``scale`` converts
    metres to them (1e3 for a picture in mm).  Returns the surface's level
    and the upper surface (None without), in the Axes' units.
    """
    part = scene.foundation or scene.obstacle
    if part is None:
        return None, None
    L = scene.beam.length
    level = -np.asarray(part.gap_at(xs), float) * scale
    above = getattr(scene.obstacle, "gap_above", None)
    kind = scene.contact
    if getattr(part, "kind", "unilateral") == "bilateral":
        kind = "bonded foundation"
    gaps = (f"gap {part.gap:g} m" if not isinstance(part.gap, tuple)
            else f"gap profile, {-level.max() / scale:.3g} to {-level.min() / scale:.3g} m")
    ax.plot(xs, level, color="saddlebrown", lw=1.5,
            ls=":" if scene.contact == "foundation" else "-", label=f"{kind} surface ({gaps})")
    if scene.contact == "obstacle":
        ax.fill_between(xs, level - 0.15 * span, level, color="saddlebrown", alpha=0.15, lw=0)
    if above is not None:
        ax.plot([0.0, L], [above * scale] * 2, color="saddlebrown", lw=1.5,
                label=f"upper surface (gap_above {above:g} m)")
        ax.fill_between([0.0, L], above * scale, (above + 0.15 * span / scale) * scale,
                        color="saddlebrown", alpha=0.15, lw=0)
        above = above * scale
    return level, above


_BEAM = 0.6      # height of the beam in the loads panel (axes fraction)
_ARROW = 0.33    # length of a force arrow (axes fraction)


def _arrow(ax, x, y_tail, text, color, L):
    """A force arrow at x from y_tail (axes fraction) onto the beam, its value beside the tail."""
    trans = ax.get_xaxis_transform()
    ax.annotate("", (x, _BEAM), xytext=(x, y_tail), xycoords=trans, textcoords=trans,
                arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.4})
    if text:
        left = x < 0.5 * L   # the label on the inner side of the arrow
        ax.text(x + (0.01 if left else -0.01) * L, y_tail, text, transform=trans,
                ha="left" if left else "right", va="top" if y_tail > _BEAM else "bottom",
                fontsize=7.5, color=color, clip_on=True)


def plot_loads(result, ax=None):
    """Draw what acts on the beam: the load profile, point forces, the axial force, reactions.

    The distributed load q(x) is drawn to scale (left axis, N/m), filled
    between the beam and q; point forces are blue arrows with their values,
    pointing the way they act (up positive); the axial force P is a green arrow
    at the right end (compression pushes into the beam); the support
    reactions are red arrows with their values, and a clamped end's moment is
    given with its sense (counter-clockwise positive).  The contact forces of a
    foundation or obstacle are in the ``reaction`` panel of :func:`save_plot`.

    Parameters
    ----------
    result : Result
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Axes
    """
    if ax is None:
        plt = _pyplot()
        _, ax = plt.subplots(figsize=(8, 2.4))
    scene = result.scene
    L = scene.beam.length
    load = scene.load
    # The distributed load to scale, the beam at height _BEAM; a table's knots exactly.
    xs = np.linspace(0.0, L, 801)
    qmax, what = 1.0, "no distributed load"
    if load.q is not None:
        table = np.array(load.q if load.is_table else [(0.0, load.q), (L, load.q)], float)
        xs = np.union1d(xs, table[:, 0])
        q = np.interp(xs, table[:, 0], table[:, 1], left=0.0, right=0.0)
        qmax = float(np.abs(q).max()) or 1.0
        ax.fill_between(xs, 0.0, q, color="tab:blue", alpha=0.2, lw=0)
        ax.plot(xs, q, color="tab:blue", lw=1.0)
        what = (f"q = {load.q:.4g} N/m" if not load.is_table
                else f"q from a table, {table[:, 1].min():.3g} to {table[:, 1].max():.3g} N/m")
        ax.set_ylabel("q [N/m]")
    else:
        ax.set_yticks([])
    unit = qmax / _ARROW
    ax.set_ylim(-_BEAM * unit, (1 - _BEAM) * unit)
    ax.plot([0, L], [0, 0], color="k", lw=3, solid_capstyle="butt", zorder=3)
    # Point forces: down from above, up from below.
    points = np.asarray(load.points, float).reshape(-1, 2)
    if 0 < len(points) <= MAX_LABELLED_FORCES:
        for i, (x, F) in enumerate(points[np.argsort(points[:, 0])]):
            stagger = 0.07 * (i % 2)   # neighbours' labels at two heights
            tail = (0.97 - stagger) if F < 0 else (_BEAM - _ARROW - stagger)
            _arrow(ax, x, tail, f"F = {F:.3g} N", "tab:blue", L)
    elif len(points):
        trans = ax.get_xaxis_transform()
        down, up = points[points[:, 1] < 0, 0], points[points[:, 1] >= 0, 0]
        ax.vlines(down, _BEAM, _BEAM + _ARROW, transform=trans, color="tab:blue", lw=0.5)
        ax.vlines(up, _BEAM - _ARROW, _BEAM, transform=trans, color="tab:blue", lw=0.5)
        what += f"; {len(points)} point forces, sum {points[:, 1].sum():.4g} N"
    # The axial force at x = L: compression (P > 0) pushes into the beam.
    P = load.axial
    if P:
        trans = ax.get_xaxis_transform()
        a, b = (1.055 * L, 1.004 * L) if P > 0 else (1.004 * L, 1.055 * L)
        ax.annotate("", (b, _BEAM), xytext=(a, _BEAM), xycoords=trans, textcoords=trans,
                    arrowprops={"arrowstyle": "-|>", "color": "tab:green", "lw": 1.6})
        kind = "compression" if P > 0 else "tension"
        ax.text(0.99 * L, _BEAM + 0.04, f"P = {abs(P):.4g} N ({kind})", transform=trans,
                ha="right", va="bottom", fontsize=7.5, color="tab:green", clip_on=True)
    # Support reactions: the force and moment the support exerts on the beam.
    trans = ax.get_xaxis_transform()
    for s in result.support_reactions:
        x, R, M = s["x"], s["force"], s["moment"]
        tail = 0.03 if R >= 0 else 0.97
        _arrow(ax, x, tail, f"R = {R:.4g} N", "tab:red", L)
        if _SUPPORT_KINDS[scene.beam.supports][0 if x < 0.5 * L else 1] == "clamped":
            left = x < 0.5 * L
            sense = "\u21ba" if M >= 0 else "\u21bb"   # counter-clockwise / clockwise
            ax.text(x + (0.01 if left else -0.01) * L, 0.5 * (tail + _BEAM),
                    f"M = {M:.4g} N m {sense}", transform=trans, ha="left" if left else "right",
                    va="center", fontsize=7.5, color="tab:red", clip_on=True)
    ax.set_title(f"loads: {what}{'; axial force P' if P else ''} | support reactions (red): "
                 "up and counter-clockwise positive", fontsize=8)
    _xlim(ax, L)
    return ax


def _panel(ax, result, panel):
    L = result.scene.beam.length
    xs = np.linspace(0.0, L, 801)
    if panel in ("moment", "shear"):
        # Both sides of every node and point force: V jumps there, M kinks.
        jumps = np.r_[result.x, [p[0] for p in result.scene.load.points]]
        if result.contact_forces is not None:
            jumps = np.r_[jumps, result.contact_forces[:, 0]]
        xs = np.union1d(xs, np.clip(np.r_[jumps, jumps - 1e-9 * L], 0.0, L))
    if panel == "slope":
        ax.plot(xs, result.slope_at(xs))
        ax.set_ylabel("w' [-]")
    elif panel == "moment":
        ax.plot(xs, result.moment(xs))
        ax.set_ylabel("M = EI w'' [N m]")
        if result.scene.beam.model == "gao":
            # The Gao model's loads act as (1 - nu^2) q: M and V balance those,
            # the reactions the loads as given (docs/model.md, Support reactions).
            ax.text(0.99, 0.04, "gao: M and V balance the loads times (1 - nu^2)",
                    transform=ax.transAxes, ha="right", va="bottom", fontsize=7, color="0.35")
    elif panel == "shear":
        ax.plot(xs, result.shear(xs))
        ax.set_ylabel("V = dM/dx [N]")
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
    """Write the picture of a result (:func:`result_figure`) to ``path`` (.png or .svg)."""
    path = _check_file(path)
    fig = result_figure(result, panels)
    return _write(_pyplot(), fig, path)


def result_figure(result, panels=()):
    """The picture of a result: loads and reactions, deflection, then the ``panels``.

    The loads and support reactions (:func:`plot_loads`) on top, the deflection
    (:func:`plot`) below them, then the optional ``panels`` (PANELS).  Returns
    the matplotlib Figure (the caller saves or closes it).
    """
    for p in panels:
        if p not in PANELS:
            raise SceneError("--panels", f"unknown panel (known: {', '.join(PANELS)})", p)
    plt = _pyplot()
    n = 2 + len(panels)
    fig, axes = plt.subplots(n, 1, figsize=(8, 6 + 2.2 * len(panels)), sharex=True,
                             gridspec_kw={"height_ratios": [1, 2] + [1] * len(panels)},
                             squeeze=False)
    plot_loads(result, axes[0, 0])
    plot(result, axes[1, 0])
    for ax, panel in zip(axes[2:, 0], panels):
        _panel(ax, result, panel)
    for ax in axes[:-1, 0]:   # the shared x-axis is labelled once, at the bottom
        ax.set_xlabel("")
    axes[-1, 0].set_xlabel("x [m]")
    fig.tight_layout()
    return fig


def save_compare_plot(results: dict, path) -> Path:
    """Write :func:`compare_figure` to ``path`` (.png or .svg)."""
    path = _check_file(path)
    return _write(_pyplot(), compare_figure(results), path)


def compare_figure(results: dict):
    """Euler-Bernoulli and Gao deflections of one scene on one picture (a Figure).

    The supports, surface and undeformed beam are drawn once; each model's
    curve and contact zones have its colour and a legend entry.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    colors = {"euler-bernoulli": "tab:blue", "gao": "tab:orange"}
    for i, (model, result) in enumerate(results.items()):
        plot(result, ax, label=f"{model}: min {result.min['w']:.4g} m, energy {result.energy:.4g} J",
             annotate=i == 0, color=colors.get(model))
    methods = {r.method for r in results.values()} - {DEFAULT_METHOD}
    named = f", method {', '.join(sorted(methods))}" if methods else ""
    # (above the Euler-Bernoulli limit only the Gao answer is drawn)
    models = " and ".join({"euler-bernoulli": "Euler-Bernoulli", "gao": "Gao"}.get(m, m)
                          for m in results)
    ax.set_title(f"{models}, supports {result.scene.beam.supports}{named}", fontsize=10)
    fig.tight_layout()
    return fig
