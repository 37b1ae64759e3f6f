"""Pictures of equilibria and equilibrium paths (matplotlib, imported only to draw).

Stable equilibria and branches are drawn solid, unstable ones dashed; on a
path the global minimiser at each axial force is marked.  An equilibrium's
deflection is drawn as the Hermite cubic interpolant of its nodal values and
slopes (as ``solve --plot`` draws a result), not as straight segments.

Examples
--------
>>> import tempfile, os
>>> from gaocvx import Scene
>>> from gaocvx.nonconvex import equilibria
>>> scene = Scene.from_dict({"beam": {"model": "gao", "supports": "P4", "length": 1.0,
...     "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
...     "load": {"axial": 1.3e9}, "mesh": {"elements": 8}})
>>> with tempfile.TemporaryDirectory() as d:
...     out = save_equilibria_plot(equilibria(scene), os.path.join(d, "eq.png"), scene)
...     os.path.getsize(out) > 0
True
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .equilibrium import TIE, global_minima

__all__ = ["save_equilibria_plot", "equilibria_figure", "save_path_plot", "energy_digits"]

# Points per picture along the beam (and every node): smooth at any mesh.
SAMPLES = 801


def _title(scene) -> str:
    b, load = scene.beam, scene.load
    q = "table" if isinstance(load.q, tuple) else ("0" if load.q is None else f"{load.q:.3g}")
    extra = ""
    part = scene.foundation or scene.obstacle
    if part is not None:
        gap = "profile" if isinstance(part.gap, tuple) else f"{part.gap:g} m"
        extra = f", {scene.contact} gap {gap}"
        if getattr(part, "gap_above", None) is not None:   # a channel
            extra += f", gap_above {part.gap_above:g} m"
    return f"{b.model} {b.supports}, q = {q} N/m{extra}"


def energy_digits(energies, least: int = 4, most: int = 12, scale: float = 0.0) -> int:
    """Significant digits that print every two distinct energies differently.

    Energies within ``TIE`` times the largest ``|energy|`` (or ``scale``, where
    larger) of each other are one value (mirror images) and may print alike.

    Parameters
    ----------
    energies : sequence of float
    least, most : int
        The range of digits returned.
    scale : float
        The energies' round-off scale [J] (:attr:`.equilibrium.Equilibrium.energy_scale`;
        just above the limit the total is far below its parts), as
        :func:`.equilibrium.global_minima` ties them.

    Returns
    -------
    int
        The fewest digits from ``least`` that print every two energies
        further apart than the tie differently (``most`` if none up to it do).

    Examples
    --------
    >>> energy_digits([-1.1140e9, -1.1137e9, 2.2e4])    # 4 digits: both -1.114e+09
    5
    >>> energy_digits([-6.7e7, -6.7e7 * (1 + 1e-15), 3.0])   # a tie to round-off
    4
    """
    e = np.sort(np.asarray(energies, float))
    tie = TIE * max(float(np.max(np.abs(e), initial=0.0)), scale)
    # Rounding is monotone: neighbours printed apart keep every pair apart.
    pairs = [(a, b) for a, b in zip(e[:-1], e[1:]) if b - a > tie]
    for digits in range(least, most):
        if all(f"{a:.{digits}g}" != f"{b:.{digits}g}" for a, b in pairs):
            return digits
    return most


def _smooth(e, xs):
    """Points along the beam and the deflection there: the Hermite interpolant of ``e``."""
    xs = np.union1d(xs, e.x)
    return xs, e.deflection_at(xs)


def save_equilibria_plot(eqs, path, scene):
    """Write :func:`equilibria_figure` to ``path`` (.png or .svg); returns the path."""
    from ..plot import _check_file, _pyplot, _write

    path = _check_file(path)
    return _write(_pyplot(), equilibria_figure(eqs, scene), Path(path))


def equilibria_figure(eqs, scene):
    """Deflections of every equilibrium (stable solid, unstable dashed): a Figure.

    The legend gives each energy to as many digits as tell the listed ones
    apart (:func:`energy_digits`) and marks every global minimum (mirror
    images tie).  The caller saves or closes the figure.
    """
    from ..plot import _pyplot, draw_surfaces, surface_points

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(10, 4))
    xs = surface_points(scene)
    span = max([float(np.max(np.abs(e.w))) for e in eqs] + [0.0]) * 1e3 or 1.0
    draw_surfaces(ax, scene, xs, span, scale=1e3)
    energies = [e.energy for e in eqs]
    scales = [e.energy_scale for e in eqs if np.isfinite(e.energy_scale)]
    digits = energy_digits(energies, scale=max(scales, default=0.0))
    for e, best in zip(eqs, global_minima(eqs)):
        x, w = _smooth(e, xs)
        ax.plot(x, w * 1e3, "-" if e.stable else "--", lw=2 if best else 1.2,
                label=f"{'stable' if e.stable else 'unstable'}, {e.energy:.{digits}g} J"
                      + (" (global minimum)" if best else ""))
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("w [mm]")
    ax.set_title(f"equilibria at P = {scene.load.axial:.4g} N: {_title(scene)}", fontsize=9)
    # Beside the axes: inside, it covered the largest deflection or a channel's
    # upper surface (a new user's trial), whatever its corner.
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    fig.tight_layout()
    return fig


def draw_path(ax, path, label_branches: bool = True):
    """Draw an :class:`~.path.EquilibriumPath` on ``ax``: P against w_c."""
    first = {True: True, False: True}
    for br in path.branches():
        w = np.array([p["w_c"] for p in br]) * 1e3
        P = np.array([p["P"] for p in br])
        stable = br[0]["stable"]
        ax.plot(w, P, "-" if stable else "--", color="C0" if stable else "C3", lw=1.6,
                label=("stable" if stable else "unstable") if first[stable] and label_branches
                else None)
        first[stable] = False
    glob = [p for p in path.points if p["global"]]
    ax.plot([p["w_c"] * 1e3 for p in glob], [p["P"] for p in glob], "o", ms=3.5, color="k",
            label="global minimiser" if label_branches else None)
    ax.set_xlabel(f"w({path.x_c:.3g} m) [mm]")
    ax.set_ylabel("P [N]")


def save_path_plot(path, file, scene, P_bar: float | None = None):
    """The equilibrium path diagram of one scene; returns the file's path."""
    from ..plot import _check_file, _pyplot, _write

    file = _check_file(file)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    draw_path(ax, path)
    if P_bar is not None:
        ax.axhline(P_bar, color="0.5", lw=0.8, ls=":", label="P_bar_h")
    ax.set_title(f"equilibrium path: {_title(scene)}", fontsize=9)
    ax.legend(fontsize=8)
    return _write(plt, fig, Path(file))
