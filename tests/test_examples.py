"""Every example runs and gives the answer its comment states (pinned to outside references)."""

import runpy
from pathlib import Path

import numpy as np
import pytest

from conftest import EI_THESIS
from exact import ExactBeam
from gaocvx import load_scene, solve

EXAMPLES = Path(__file__).parent.parent / "examples"


def run(name):
    result = solve(load_scene(EXAMPLES / name))
    assert result.success, result.message
    return result


def test_simply_supported_closed_form():
    r = run("simply_supported_eb.toml")
    assert r.min["w"] == pytest.approx(5 * -5e7 / (384 * EI_THESIS), rel=1e-10)
    assert r.min["x"] == 0.5


def test_clamped_pinned_table_points_exact():
    r = run("clamped_pinned_table_points.toml")
    exact = ExactBeam("P2", 1.0, EI_THESIS, [[0.0, 0.0], [0.5, -6e7], [1.0, 0.0]],
                      [(0.25, -2e7), (0.8, 1e7)])
    assert np.abs(r.w - exact(r.x)).max() <= 1e-9 * np.abs(r.w).max()
    assert r.min["w"] == pytest.approx(-1.6477e-3, rel=1e-4) and r.min["x"] == 0.53125


def test_cantilever_gao_tension_thesis():
    r = run("cantilever_gao_tension.toml")
    assert r.min["w"] == pytest.approx(-0.02922, rel=5e-3)   # thesis table 4.8a
    assert r.min["x"] == 1.0


def test_pinned_obstacle_point_closed_form():
    r = run("pinned_obstacle_point.toml")
    mid = int(np.argmin(np.abs(r.x - 0.5)))
    assert r.w[mid] == pytest.approx(-1e-3, rel=1e-7)
    assert r.reaction[mid] == pytest.approx(4e7 - 48 * EI_THESIS * 1e-3, rel=1e-5)


def test_cantilever_table_obstacle_methods_agree():
    scene = load_scene(EXAMPLES / "cantilever_table_obstacle.toml")
    a, b = solve(scene, "newton"), solve(scene, "convex")
    assert a.success and b.success
    assert a.min["w"] == pytest.approx(-0.02, rel=1e-7) and a.zones == [[1.0, 1.0]]
    assert np.abs(a.w - b.w).max() <= 1e-9
    # Sensitivity of the optimal energy to the obstacle's level: dPi*/dgap equals
    # minus the total reaction (scaled by the Gao factor 1 - nu^2, which the
    # reported reaction has removed): an independent check of the multipliers.
    d = 1e-6
    e_plus = solve(scene.with_overrides({"obstacle.gap": 0.02 + d}), "newton").energy
    e_minus = solve(scene.with_overrides({"obstacle.gap": 0.02 - d}), "newton").energy
    assert a.reaction.sum() == pytest.approx(-(e_plus - e_minus) / (2 * d) / (1 - 0.3**2),
                                             rel=1e-5)


def test_cvm_cantilever_thesis():
    r = run("cvm_cantilever_foundation.toml")
    assert r.method == "cvm" and r.extra["cvm"]["transform"] == "T2"
    assert r.min["w"] == pytest.approx(-0.03503, rel=2e-3)   # thesis table 4.21a
    assert r.zones == [[0.6875, 1.0]]
    assert abs(r.extra["cvm"]["energy_gap"]) < 1e-6 * abs(r.energy)


def test_clamped_foundation_thesis():
    r = run("clamped_foundation.toml")
    assert r.min["w"] == pytest.approx(-0.008452, rel=2e-3)   # thesis table 4.13a
    assert r.zones == [[0.375, 0.625]]


def test_library_api_example(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(EXAMPLES / "library_api.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "cvm energy gap" in out and "penetration" in out
    png = EXAMPLES / "library_api.png"
    assert png.exists()
    png.unlink()


def test_every_example_is_covered():
    names = {p.name for p in EXAMPLES.glob("*.toml")}
    assert len(names) >= 6
    text = Path(__file__).read_text()
    assert all(name in text for name in names)


def test_bonded_rail_compressed_is_hetenyis():
    """Between P_bar_h and P_hat: the closed form of EI w'''' + P w'' + k w = q."""
    from test_contact_models import hetenyi
    r = run("bonded_rail_compressed.toml")
    exact = hetenyi("P4", EI_THESIS, 5e10, -5e7, 0.0, 4e9, 1.0, r.x)
    assert np.abs(r.w - exact).max() <= 1e-6 * np.abs(exact).max()
    assert r.min["w"] == pytest.approx(-2.610e-3, rel=1e-3) and r.min["x"] == 0.5
    assert r.P_bar < 4e9 < r.P_hat
    assert r.P_hat == pytest.approx(np.pi**2 * EI_THESIS + 5e10 / np.pi**2, rel=1e-6)


def test_obstacle_plateau_is_a_beam_on_two_props():
    """Touching the corners only: the closed form of the beam with two point forces R
    at 0.4 and 0.6 chosen so that w(0.4) = -0.2 mm (linear in R)."""
    r = run("obstacle_plateau.toml")
    free = ExactBeam("P4", 1.0, EI_THESIS, -5e7)
    unit = ExactBeam("P4", 1.0, EI_THESIS, 0.0, [(0.4, 1.0), (0.6, 1.0)])
    R = (-2e-4 - free(np.array([0.4]))[0]) / unit(np.array([0.4]))[0]
    exact = ExactBeam("P4", 1.0, EI_THESIS, -5e7, [(0.4, R), (0.6, R)])
    assert np.abs(r.w - exact(r.x)).max() <= 1e-9 * np.abs(r.w).max()
    assert r.zones == [[0.4, 0.4], [0.6, 0.6]]
    assert r.contact_forces[:, 1] == pytest.approx([R, R], rel=1e-6)
    assert R == pytest.approx(1.5857e7, rel=1e-4)


def test_channel_touches_below_and_above():
    """Touching each surface at one point: the closed form of the beam with its two
    loads and two contact forces, at the contact points, chosen so that it touches
    -1 mm and +0.5 mm there (a 2x2 linear system)."""
    r = run("channel.toml")
    assert len(r.x) - 1 == 34 and r.w.min() >= -1e-3 * (1 + 1e-7)
    assert r.w.max() <= 5e-4 * (1 + 1e-7)
    (x1, F1), (x2, F2) = r.contact_forces
    loads = [(0.3, -6e7), (0.7, 6e7)]
    base = ExactBeam("P4", 1.0, EI_THESIS, 0.0, loads)
    at = np.array([x1, x2])
    cols = [ExactBeam("P4", 1.0, EI_THESIS, 0.0, [(x, 1.0)])(at) for x in (x1, x2)]
    R = np.linalg.solve(np.column_stack(cols), np.array([-1e-3, 5e-4]) - base(at))
    exact = ExactBeam("P4", 1.0, EI_THESIS, 0.0, loads + [(x1, R[0]), (x2, R[1])])
    # A contact force between nodes is not one the Hermite FEM represents exactly
    # (its discretisation error, O(h^4), is ~3e-6 here; the props at nodes above
    # agree to round-off).
    assert [F1, F2] == pytest.approx(R, rel=2e-5)
    assert R[0] == pytest.approx(1.470e7, rel=1e-3) and R[1] == pytest.approx(-1.947e7, rel=1e-3)
    assert np.abs(r.deflection(np.linspace(0, 1, 201)) - exact(np.linspace(0, 1, 201))).max() \
        <= 2e-5 * 1e-3


def test_buckled_pinned_is_solved_globally():
    """Above P_bar_h auto takes the certified global method; the stated minimiser is the
    one an independent multi-start search finds (test_nonconvex.py::
    test_buckled_example_states_what_an_independent_search_finds)."""
    r = run("buckled_pinned.toml")
    assert r.method == "global" and r.extra["global"]["unstable_modes"] == 1
    assert r.P_bar < r.scene.load.axial
    assert r.deflection(0.5) == pytest.approx(-0.03664, rel=1e-3)
    assert r.energy == pytest.approx(-4.1604e5, rel=1e-4)
