"""Pictures of equilibria and equilibrium paths (matplotlib).

Stable equilibria and branches are drawn solid, unstable ones dashed; on a
path the global minimiser at each axial force is marked.

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

__all__ = ["save_equilibria_plot", "save_path_plot"]


def _title(scene) -> str:
    b, load = scene.beam, scene.load
    q = "table" if isinstance(load.q, tuple) else ("0" if load.q is None else f"{load.q:.3g}")
    extra = ""
    if scene.foundation is not None:
        extra = f", foundation gap {scene.foundation.gap}"
    elif scene.obstacle is not None:
        extra = f", obstacle gap {scene.obstacle.gap}"
    return f"{b.model} {b.supports}, q = {q} N/m{extra}"


def save_equilibria_plot(eqs, path, scene):
    """Deflections of every equilibrium (stable solid, unstable dashed); returns the path."""
    from ..plot import _check_file, _pyplot, _write

    path = _check_file(path)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, e in enumerate(eqs):
        ax.plot(e.x, e.w * 1e3, "-" if e.stable else "--", lw=2 if i == 0 else 1.2,
                label=f"{'stable' if e.stable else 'unstable'}, {e.energy:.4g} J"
                      + (" (global minimum)" if i == 0 else ""))
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("w [mm]")
    ax.set_title(f"equilibria at P = {scene.load.axial:.4g} N: {_title(scene)}", fontsize=9)
    ax.legend(fontsize=8)
    return _write(plt, fig, Path(path))


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
