"""What a new user meets first: log messages that agree with the result, the
top-level exports, the pictures of equilibria."""

import logging

import pytest

from conftest import scene_dict
from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.convex import log_outcome, solve_convex


# ---------------------------------------------------------------- convex warnings

def _records(caplog, level):
    return [r for r in caplog.records if r.name.startswith("gaocvx") and r.levelno == level]


def _tip_on_obstacle(force: float) -> Scene:
    """A Gao cantilever pressed by a tip force onto a rigid obstacle 1 mm below.

    With this force the convex program's first answer, in the deflection
    scale of the free beam (~100 times the 1 mm it ends at), is not
    certified; with -1e8 N the re-solve in the answer's own scale certifies,
    with -1e9 N it does not either (found by trying forces and gaps, Clarabel
    0.11, 16 elements).
    """
    return Scene.from_dict(scene_dict("P3", q=None, points=[(1.0, force)], axial=1e6,
                                      obstacle=0.001, elements=16))


def test_log_outcome_warns_only_for_a_final_uncertified_answer(caplog):
    caplog.set_level(logging.DEBUG, logger="gaocvx")
    bad = {"status": "inaccurate", "message": "optimality conditions NOT met"}
    good = {"status": "optimal", "message": "optimality conditions verified"}

    log_outcome(bad, final=False)
    assert not _records(caplog, logging.WARNING)
    (info,) = _records(caplog, logging.INFO)
    assert "NOT met" in info.getMessage() and "may solve again" in info.getMessage()

    caplog.clear()
    log_outcome(good, replaced=2)
    assert not _records(caplog, logging.WARNING)
    (info,) = _records(caplog, logging.INFO)
    assert "certified, replacing 2 earlier attempts" in info.getMessage()

    caplog.clear()
    log_outcome(good)   # certified at the first attempt: nothing to say
    assert not caplog.records

    caplog.clear()
    log_outcome(bad)
    (warning,) = _records(caplog, logging.WARNING)
    assert "not certified optimal" in warning.getMessage()


def test_solve_convex_warns_only_when_its_answer_is_final(caplog):
    """An uncertified answer that the caller may replace is an INFO, a final one a WARNING."""
    caplog.set_level(logging.INFO, logger="gaocvx")
    dp = DiscreteProblem(_tip_on_obstacle(-1e8))
    raw = solve_convex(dp, final=False)
    if raw["status"] == "optimal":
        pytest.skip("this Clarabel certifies the first-scale answer: the scene reproduces nothing")
    assert not _records(caplog, logging.WARNING)
    # Every rung but the last says another follows; the outcome says it is not final.
    messages = [r.getMessage() for r in _records(caplog, logging.INFO)]
    assert sum("the next settings follow" in m for m in messages) >= 1
    assert "no settings left" in messages[-2]
    assert "not final" in messages[-1] and raw["message"] in messages[-1]

    caplog.clear()
    raw = solve_convex(dp)   # the default: the caller returns it as it is
    assert raw["status"] == "inaccurate"
    (warning,) = _records(caplog, logging.WARNING)
    assert raw["message"] in warning.getMessage()


def test_no_warning_when_the_returned_convex_answer_is_certified(caplog):
    caplog.set_level(logging.INFO, logger="gaocvx")
    result = solve(_tip_on_obstacle(-1e8), "convex")
    assert result.status == "optimal", result.message
    assert not _records(caplog, logging.WARNING)
    infos = [r.getMessage() for r in _records(caplog, logging.INFO)]
    # (a Clarabel that certifies the first attempt replaces nothing: as in the test above)
    if any("not final" in m for m in infos):
        assert any("certified, replacing" in m for m in infos)


def test_one_warning_for_a_returned_uncertified_convex_answer(caplog):
    caplog.set_level(logging.INFO, logger="gaocvx")
    result = solve(_tip_on_obstacle(-1e9), "convex")
    if result.status == "optimal":
        pytest.skip("this Clarabel certifies the scene: nothing uncertified to report")
    (warning,) = _records(caplog, logging.WARNING)
    assert result.message in warning.getMessage()


# ---------------------------------------------------------------- top-level exports

NONCONVEX_NAMES = ("equilibria", "equilibrium_path", "Equilibrium", "EquilibriumPath")


def test_equilibria_and_paths_are_exported_from_the_package():
    import gaocvx
    import gaocvx.nonconvex as nonconvex
    from gaocvx import Equilibrium, EquilibriumPath, equilibria, equilibrium_path

    assert (equilibria, equilibrium_path) == (nonconvex.equilibria, nonconvex.equilibrium_path)
    assert (Equilibrium, EquilibriumPath) == (nonconvex.Equilibrium, nonconvex.EquilibriumPath)
    for name in NONCONVEX_NAMES:
        assert name in gaocvx.__all__ and name in dir(gaocvx)
        assert name in gaocvx.__doc__    # help(gaocvx)'s public API lists it
    with pytest.raises(AttributeError, match="no attribute 'equilibrium'"):
        gaocvx.equilibrium   # noqa: B018 - a near miss is still an error


def test_the_package_imports_nonconvex_only_on_first_use():
    """``import gaocvx`` stays as fast as without the exports (no scipy.optimize)."""
    import subprocess
    import sys

    code = ("import sys, gaocvx; print('gaocvx.nonconvex' in sys.modules); "
            "gaocvx.equilibria; print('gaocvx.nonconvex' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True"]


# ---------------------------------------------------------------- pictures of equilibria

def _buckled(elements=8):
    """The unloaded pinned Gao beam above its limit: two mirror images and w = 0."""
    return Scene.from_dict(scene_dict("P4", q=None, axial=1.3e9, elements=elements))


def test_equilibria_picture_draws_the_hermite_interpolant():
    """Between nodes the curve is the cubic through the nodal values and slopes."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from gaocvx.nonconvex import equilibria
    from gaocvx.nonconvex.pictures import equilibria_figure

    scene = _buckled()
    eqs = equilibria(scene)
    fig = equilibria_figure(eqs, scene)
    curves = [ln for ln in fig.axes[0].lines if not ln.get_label().startswith("_")]
    assert len(curves) == len(eqs)
    for e, line in zip(eqs, curves):
        x, w_mm = (np.asarray(v, float) for v in line.get_data())
        # The cubic Hermite interpolant at an element's midpoint: the mean of the
        # end values plus h (s_left - s_right) / 8.
        h = np.diff(e.x)
        mid = e.x[:-1] + h / 2
        expected = (e.w[:-1] + e.w[1:]) / 2 + h * (e.slope[:-1] - e.slope[1:]) / 8
        drawn = np.interp(mid, x, w_mm * 1e-3)
        scale = max(np.abs(e.w).max(), 1e-300)
        assert np.abs(drawn - expected).max() <= 1e-3 * scale
    # (a buckled shape bends between nodes: a polygon would miss by h (s_l - s_r) / 8)
    e = eqs[0]
    assert np.abs(np.diff(e.slope)).max() * np.diff(e.x).min() / 8 > 1e-2 * np.abs(e.w).max()
    plt.close(fig)


def _equilibrium(energy, stable=True):
    import numpy as np

    from gaocvx import Equilibrium
    x = np.linspace(0.0, 1.0, 5)
    return Equilibrium(energy, stable, [0.0], x, np.sin(np.pi * x) * 1e-3,
                       np.pi * np.cos(np.pi * x) * 1e-3, 0.0, "optimal", 1.3e9)


def _legend(eqs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gaocvx.nonconvex.pictures import equilibria_figure
    fig = equilibria_figure(eqs, _buckled())
    texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    plt.close(fig)
    return texts


def test_equilibria_legend_tells_close_energies_apart():
    # The new user's two equilibria: -1.114e+09 J both, 2.7e5 J apart.
    energies = [-1.1140e9, -1.1140e9 + 2.7e5, 3.0e4]
    texts = _legend([_equilibrium(v) for v in energies])
    printed = [float(t.split(", ")[1].split(" J")[0]) for t in texts]
    assert len(set(printed)) == 3
    for value, shown in zip(energies, printed):   # each nearer its own energy than the next
        assert abs(shown - value) < 2.7e5 / 2
    assert [" (global minimum)" in t for t in texts] == [True, False, False]


def test_equilibria_legend_marks_mirror_images_both_global():
    energies = [-6.7e7, -6.7e7 * (1 - 1e-15), -1.0e7]   # equal but for round-off
    texts = _legend([_equilibrium(v) for v in energies])
    assert [" (global minimum)" in t for t in texts] == [True, True, False]
    assert texts[0].split(", ")[1] == texts[1].split(", ")[1]   # no round-off digits shown


def test_equilibria_legend_ties_images_relative_to_the_energy_scale():
    """Just above the limit the total energy is far below its parts: mirror images
    whose energies differ by 1.9e-9 of the total (round-off against parts 4e6
    times larger) are both global, and print alike."""
    energies = [-1.6651343634e-05, -1.6651343603e-05, 0.0]
    eqs = [_equilibrium(v, stable=v < 0) for v in energies]
    for e in eqs:
        e.energy_scale = 66.6
    texts = _legend(eqs)
    assert [" (global minimum)" in t for t in texts] == [True, True, False]
    assert texts[0].split(", ")[1] == texts[1].split(", ")[1]


# ---------------------------------------------------------------- documented JSON Lines

def _documented_fields(marker: str, saying: str = "") -> set:
    """The names in the first column of the table after ``marker`` in scene-format.md
    (of the rows whose text contains ``saying``)."""
    import re
    from pathlib import Path

    text = (Path(__file__).parent.parent / "docs" / "scene-format.md").read_text()
    table = text.split(marker, 1)[1].split("\n\n", 2)[1]
    return {name for row in table.splitlines()[2:] if saying in row
            for name in re.findall(r"`([A-Za-z_]+)`", row.split("|")[1])}


@pytest.mark.parametrize("command, extra", [("equilibria", []),
                                            ("path", ["--axial", "1.2e9:1.4e9:2"])])
def test_json_lines_fields_are_those_documented(command, extra, capsys):
    import json
    from pathlib import Path

    from gaocvx.cli import main

    example = Path(__file__).parent.parent / "examples" / "buckled_pinned.toml"
    assert main([command, str(example), "--json", *extra]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert len(lines) >= 3   # the example has three equilibria at 1.3e9 N and 1.4e9 N
    for obj in lines:
        assert set(obj) == _documented_fields(f"`gaocvx {command} --json` writes")


def test_global_certificate_fields_are_those_documented():
    """Above the limit every documented field; below it those not marked 'above P̄_h only'."""
    from pathlib import Path

    from gaocvx import load_scene

    documented = _documented_fields("For `global`, the object `global`")
    above_only = _documented_fields("For `global`, the object `global`", "above P̄_h only")
    assert above_only and above_only < documented
    scene = load_scene(Path(__file__).parent.parent / "examples" / "buckled_pinned.toml")
    above = solve(scene)
    assert above.method == "global" and above.extra["global"]["unstable_modes"] == 1
    assert set(above.to_dict()["global"]) == documented
    below = solve(scene.with_overrides({"load.axial": 1e9}), "global")
    assert below.extra["global"]["unstable_modes"] == 0
    assert set(below.to_dict()["global"]) == documented - above_only
