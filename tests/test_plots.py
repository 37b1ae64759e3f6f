"""What the pictures show: loads, reactions, axial force, method, contact zones, sweep axes.

Each picture is also checked for annotations that leave their axes.  (Every
plot was looked at while it was made; these tests keep what was seen.)
"""

from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from conftest import scene_dict  # noqa: E402
from gaocvx import Scene, load_scene, solve  # noqa: E402
from gaocvx.plot import PANELS, compare_figure, result_figure  # noqa: E402
from gaocvx.sweep_plot import sweep_figure  # noqa: E402
from gaocvx.sweep import parse_range, summary_row, sweep  # noqa: E402

EXAMPLES = sorted((Path(__file__).parent.parent / "examples").glob("*.toml"))


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def texts(ax):
    return [t.get_text() for t in ax.texts if t.get_text()]


def outside(fig):
    """Texts (and annotations) whose box leaves their axes, as (axes index, text)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    bad = []
    for i, ax in enumerate(fig.axes):
        box = ax.get_window_extent(renderer)
        for t in ax.texts:
            if not t.get_text():
                continue
            b = t.get_window_extent(renderer)
            if b.x0 < box.x0 - 1 or b.x1 > box.x1 + 1 or b.y0 < box.y0 - 1 or b.y1 > box.y1 + 1:
                bad.append((i, t.get_text()))
    return bad


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_every_example_keeps_its_annotations_inside_the_axes(path):
    fig = result_figure(solve(load_scene(path)), PANELS)
    assert outside(fig) == []


def test_loads_panel_shows_profile_forces_axial_force_and_reactions():
    table = [[0.0, 0.0], [0.3, -6e7], [1.0, -1e7]]
    d = scene_dict("P1", "euler-bernoulli", q=table, points=[(0.25, -2e7), (0.8, 1e7)],
                   axial=3e8, elements=16)
    r = solve(Scene.from_dict(d))
    fig = result_figure(r)
    loads = fig.axes[0]
    shown = texts(loads)
    assert "F = -2e+07 N" in shown and "F = 1e+07 N" in shown
    assert "P = 3e+08 N (compression)" in shown
    for s in r.support_reactions:
        assert f"R = {s['force']:.4g} N" in shown
        assert any(t.startswith(f"M = {s['moment']:.4g} N m") for t in shown)
    # Arrows: two point forces, two reactions, the axial force.
    arrows = [t for t in loads.texts if getattr(t, "arrow_patch", None) is not None]
    assert len(arrows) == 5
    # The profile is the table, knots included.
    line = loads.lines[0]
    x, y = line.get_xdata(), line.get_ydata()
    assert y.min() == -6e7 and x[np.argmin(y)] == 0.3
    assert np.interp(0.65, x, y) == pytest.approx(np.interp(0.65, *np.array(table).T))
    assert "q from a table" in loads.get_title()


def test_tension_and_a_pinned_end_and_many_point_forces():
    points = [(x, -1e5) for x in np.linspace(0.05, 0.95, 40)]
    r = solve(Scene.from_dict(scene_dict("P4", "euler-bernoulli", q=None, points=points,
                                         axial=-2e8, elements=8)))
    fig = result_figure(r)
    shown = texts(fig.axes[0])
    assert "P = 2e+08 N (tension)" in shown
    assert not any(t.startswith("M = ") for t in shown)   # pins carry no moment
    assert not any(t.startswith("F = ") for t in shown)   # 40 forces: no value each ...
    assert "40 point forces, sum -4e+06 N" in fig.axes[0].get_title()   # ... but their sum
    assert outside(fig) == []


@pytest.mark.parametrize("method, named", [("newton", False), ("convex", True), ("cvm", True)])
def test_the_method_is_named_when_not_the_default(method, named):
    r = solve(Scene.from_dict(scene_dict("P1", "gao", elements=8)), method)
    title = result_figure(r).axes[1].get_title()
    assert (f"method {method}" in title) is named


def test_shear_panel_is_the_exact_line_not_a_staircase():
    q = -5e7
    r = solve(Scene.from_dict(scene_dict("P4", "euler-bernoulli", q=q, elements=4)))
    line = result_figure(r, ["shear"]).axes[2].lines[0]
    x, v = line.get_xdata(), line.get_ydata()
    assert np.abs(v - q * (x - 0.5)).max() <= 1e-10 * abs(q) / 2


def test_compare_names_both_contact_zones_and_draws_one_wall_per_support():
    d = scene_dict("P1", "gao", q=-5e8, foundation=(0.007, 5e8), elements=16)
    results = {m: solve(Scene.from_dict({**d, "beam": {**d["beam"], "model": m}}))
               for m in ("euler-bernoulli", "gao")}
    fig = compare_figure(results)
    assert outside(fig) == []
    ax = fig.axes[0]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    for model, r in results.items():
        a, b = r.zones[0]
        assert f"{model} contact: [{a:.3g}, {b:.3g}]" in legend
    walls = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_hatch()]
    assert len(walls) == 2


def test_compare_says_point_contact_and_no_contact():
    d = scene_dict("P4", "gao", q=None, points=[(0.5, -4e7)], obstacle=0.001, elements=16)
    results = {m: solve(Scene.from_dict({**d, "beam": {**d["beam"], "model": m}}))
               for m in ("euler-bernoulli", "gao")}
    legend = [t.get_text() for t in compare_figure(results).axes[0].get_legend().get_texts()]
    assert "euler-bernoulli contact: 0.5 (point)" in legend
    far = scene_dict("P4", "gao", q=-1e3, obstacle=0.01, elements=8)
    results = {m: solve(Scene.from_dict({**far, "beam": {**far["beam"], "model": m}}))
               for m in ("euler-bernoulli", "gao")}
    legend = [t.get_text() for t in compare_figure(results).axes[0].get_legend().get_texts()]
    assert "gao contact: none" in legend


def _rows(scene, key, spec):
    return [summary_row(v, r) for v, r in sweep(scene, key, parse_range(spec))]


def test_sweep_axis_has_the_unit_and_no_contact_panel_without_contact():
    scene = Scene.from_dict(scene_dict("P4", "euler-bernoulli", elements=8))
    fig = sweep_figure(_rows(scene, "load.axial", "-1e9:1e9:5"), "load.axial", scene=scene)
    assert outside(fig) == []
    assert len(fig.axes) == 2   # max |w| and energy; no contact panel
    assert fig.axes[-1].get_xlabel() == "load.axial [N]"
    # P_bar_h is marked: pi^2 EI / L^2 for P4 (the discrete limit lies a little above).
    marks = [ln for ln in fig.axes[0].lines if ln.get_label().startswith("P_bar_h")]
    p_bar = np.pi**2 * 1.4e8
    assert len(marks) == 1 and marks[0].get_xdata()[0] == pytest.approx(p_bar, rel=1e-3)


@pytest.mark.parametrize("key, unit", [("foundation.stiffness", "N/m^2"), ("foundation.gap", "m"),
                                       ("beam.nu", "-"), ("load.scale", "-")])
def test_sweep_axis_units(key, unit):
    scene = Scene.from_dict(scene_dict("P1", "gao", q=-5e8, foundation=(0.007, 5e8), elements=8))
    spec = {"foundation.stiffness": "1e8:1e10:2", "foundation.gap": "0:0.01:2",
            "beam.nu": "0:0.3:2", "load.scale": "0.5:1:2"}[key]
    fig = sweep_figure(_rows(scene, key, spec), key, scene=scene)
    assert fig.axes[-1].get_xlabel() == f"{key} [{unit}]"
    assert fig.axes[-1].get_ylabel() == "contact length [m]"


def test_sweep_counts_a_point_contact():
    """A beam touching an obstacle at one point has contact of length 0: counted and marked."""
    scene = Scene.from_dict(scene_dict("P4", "euler-bernoulli", q=None, points=[(0.5, -4e7)],
                                       obstacle=0.001, elements=16))
    rows = _rows(scene, "obstacle.gap", "0.001:0.002:3")
    assert [r["contact_zones"] for r in rows] == [1, 1, 1]
    assert [r["contact_length"] for r in rows] == [0.0, 0.0, 0.0]
    ax = sweep_figure(rows, "obstacle.gap", scene=scene).axes[-1]
    marked = [ln for ln in ax.lines if ln.get_label() == "point contact (length 0)"]
    assert len(marked) == 1 and list(marked[0].get_xdata()) == [0.001, 0.0015, 0.002]


def test_a_gap_profile_and_a_channel_are_drawn_as_they_are():
    """The surface follows the gap table (knots included); gap_above is a second surface."""
    table = [[0.0, 0.0005], [0.4, 0.0002], [0.6, 0.0002], [1.0, 0.0005]]
    d = scene_dict("P4", "euler-bernoulli", q=-5e7, elements=16)
    d["obstacle"] = {"gap": table}
    r = solve(Scene.from_dict(d))
    ax = result_figure(r).axes[1]
    surface = next(ln for ln in ax.lines if ln.get_label().startswith("obstacle surface"))
    x, y = surface.get_xdata(), surface.get_ydata()
    assert set(np.array(table)[:, 0]) <= set(x)
    assert np.array_equal(y, -np.interp(x, *np.array(table).T))
    assert "gap profile, 0.0002 to 0.0005 m" in surface.get_label()
    d = scene_dict("P4", "euler-bernoulli", q=None, points=[(0.3, -6e7), (0.7, 6e7)], elements=16)
    d["obstacle"] = {"gap": 0.001, "gap_above": 0.0005}
    fig = result_figure(solve(Scene.from_dict(d)))
    upper = [ln for ln in fig.axes[1].lines if ln.get_label().startswith("upper surface")]
    assert len(upper) == 1 and list(upper[0].get_ydata()) == [0.0005, 0.0005]
    legend = [t.get_text() for t in fig.axes[1].get_legend().get_texts()]
    assert any(t.startswith("max w = 0.0005 m") for t in legend)
    assert outside(fig) == []


def test_sweep_penetration_follows_a_gap_profile():
    """Penetration is the deepest sinking below the surface, not below its nearest point."""
    table = [[0.0, 0.0], [0.5, 0.004], [1.0, 0.0]]   # a dent under the middle
    d = scene_dict("P1", "euler-bernoulli", q=-5e8, elements=16)
    d["foundation"] = {"gap": table, "stiffness": 5e9}
    r = solve(Scene.from_dict(d))
    row = summary_row(1.0, r)
    level = -np.interp(r.x, *np.array(table).T)
    assert row["penetration"] == max(np.max(level - r.w), 0.0) > 0
    assert row["penetration"] < -0.0 - r.min["w"]   # the flat-surface formula would say more
