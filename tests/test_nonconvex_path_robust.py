"""Equilibrium paths that meet a solver failure, repeated forces, w_c between nodes,
and what ``gaocvx path`` writes for every requested force.

References from outside the code under test: ``gaocvx.solve`` at the same force
(the convex minimiser below P_bar_h, the certified global minimiser above it,
whose ``Result.deflection`` is the Hermite interpolant), the Hermite cubic through
an element's nodal values and slopes written out here, the closed-form Euler
load of a simply supported beam (above it an Euler-Bernoulli beam has no
minimiser), and the contract's convention for a failed item (multi-scene
``solve`` and ``sweep``: ``"status": "error"``, ``"error"``; exit status the worse).
"""

import csv
import json

import numpy as np
import pytest

from conftest import TRIAL_EULER, scene_dict, trial_eb_toml

import gaocvx.nonconvex.stationary as stationary
from gaocvx import Scene, SceneError, SolverError, solve
from gaocvx.cli import main
from gaocvx.nonconvex import EquilibriumPath, equilibria, equilibrium_path

# The P4 Gao beam of the path doctest with a load: P_bar_h ~ 1.04e9 N, three equilibria
# above it at 1.5e9 N (none mirror images: q != 0).
P4 = {"beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
               "half_thickness": 0.1, "width": 1.0},
      "load": {"q": -1e7}, "mesh": {"elements": 8}}
P4_TOML = """[beam]
model = "gao"
supports = "P4"
length = 1.0
E = 2.1e11
nu = 0.3
half_thickness = 0.1
width = 1.0
[load]
q = -1e7
[mesh]
elements = 8
"""
# The trial's Euler-Bernoulli P4 beam (conftest) under a uniform load.
EB_TOML = trial_eb_toml("-1000.0")
EULER = TRIAL_EULER


@pytest.fixture
def p4_file(tmp_path):
    path = tmp_path / "p4.toml"
    path.write_text(P4_TOML)
    return path


def _fail_at(monkeypatch, solver=(), scene=()):
    """The per-force search (stationary.equilibria) raises SolverError at the forces
    ``solver`` and SceneError (a refusal, as for too many modes) at ``scene``."""
    real = stationary.equilibria

    def patched(sc, *args, **kwargs):
        P = float(sc.load.axial)
        if P in solver:
            raise SolverError("equilibria: the reduced function's solve failed (test)", "error")
        if P in scene:
            raise SceneError("load.axial", "refused (test)", P)
        return real(sc, *args, **kwargs)

    monkeypatch.setattr(stationary, "equilibria", patched)


# --------------------------------------------------------------- 1. a solver failure

def test_a_solver_failure_at_one_force_keeps_the_others(monkeypatch):
    scene = Scene.from_dict(P4)
    _fail_at(monkeypatch, solver=(1.3e9,))
    path = equilibrium_path(scene, [0.5e9, 1.3e9, 1.5e9])
    assert path.P == [0.5e9, 1.3e9, 1.5e9]
    assert list(path.failures) == [1.3e9] and "failed" in path.failures[1.3e9]
    assert path.errors == {} and path.at(1.3e9) == []
    below, above = path.at(0.5e9), path.at(1.5e9)
    assert len(below) == 1 and len(above) == 3
    r = solve(scene.with_overrides({"load.axial": 0.5e9}))
    assert below[0]["energy"] == pytest.approx(r.energy, rel=1e-9)
    g = solve(scene.with_overrides({"load.axial": 1.5e9}), "global")
    (lowest,) = [p for p in above if p["global"]]
    assert lowest["energy"] == pytest.approx(g.energy, rel=1e-7)


def test_cli_path_reports_a_solver_failure_and_exits_1(p4_file, capsys, monkeypatch):
    _fail_at(monkeypatch, solver=(1e9,))
    code = main(["path", str(p4_file), "--axial", "0.5e9:1.5e9:3"])
    out, err = capsys.readouterr()
    assert code == 1
    lines = out.splitlines()
    assert lines[0].startswith("# 4 equilibria at 3 axial forces (1 failed); ")
    assert len(lines) == 1 + 1 + 1 + 3   # the failed force has its row, in force order
    assert lines[2].startswith("P        1e+09 N  failed: equilibria: the reduced function's")
    assert "w_c" in lines[1] and "w_c" in lines[3]
    assert err.startswith("error: P = 1e+09 N: equilibria: the reduced function's solve failed")


def test_cli_path_exit_status_the_worse_of_refusal_and_failure(p4_file, capsys, monkeypatch):
    """As ``sweep`` and multi-scene ``solve``: the worse code wins, 2 over 1."""
    _fail_at(monkeypatch, solver=(1e9,), scene=(1.5e9,))
    assert main(["path", str(p4_file), "--axial", "0.5e9:1.5e9:3"]) == 2
    out, err = capsys.readouterr()
    assert out.splitlines()[0].startswith("# 1 equilibrium at 3 axial forces "
                                          "(1 skipped, 1 failed); ")
    assert [e.split(":")[1] for e in err.splitlines()] == [" P = 1e+09 N", " P = 1.5e+09 N"]


# --------------------------------------------------------------- 2. every force in --json

def test_cli_path_json_has_a_record_for_each_force_it_could_not_trace(p4_file, capsys,
                                                                      monkeypatch):
    _fail_at(monkeypatch, solver=(1e9,))
    assert main(["path", str(p4_file), "--axial", "0.5e9:1.5e9:3", "--json"]) == 1
    records = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["P"] for r in records] == [0.5e9, 1e9, 1.5e9, 1.5e9, 1.5e9]
    failed = records[1]
    assert set(failed) == {"P", "status", "error"} and failed["status"] == "error"
    assert failed["error"].startswith("equilibria: the reduced function's solve failed")
    assert all(r["status"] == "optimal" for r in records if r is not failed)


def test_cli_path_json_and_csv_list_a_skipped_force_in_its_place(tmp_path, capsys):
    """The Euler-Bernoulli beam above its Euler load: refused (no minimiser), exit 2, and
    the JSON and CSV still have a line for it, as sweep writes a failed value's."""
    scene_file = tmp_path / "eb.toml"
    scene_file.write_text(EB_TOML)
    table = tmp_path / "p.csv"
    assert main(["path", str(scene_file), "--axial", f"{2 * EULER}:0:2", "--json",
                 "--csv", str(table)]) == 2
    records = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["P"] for r in records] == [2 * EULER, 0.0]
    assert records[0]["status"] == "error" and "no minimiser" in records[0]["error"]
    assert records[1]["status"] == "optimal"
    with open(table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["P"]) for r in rows] == [2 * EULER, 0.0]
    assert rows[0]["status"] == "error" and rows[0]["error"] == records[0]["error"]
    assert rows[0]["w_c"] == "" and rows[1]["error"] == ""


# --------------------------------------------------------------- 3. repeated forces

@pytest.mark.parametrize("P_values, key", [([0.5e9, 1.5e9, 0.5e9], "P_values[2]"),
                                           (np.array([1.5e9, 1.5e9]), "P_values[1]")])
def test_path_refuses_a_repeated_force_before_any_work(monkeypatch, P_values, key):
    monkeypatch.setattr(stationary, "equilibria", lambda *a, **k: pytest.fail("searched"))
    with pytest.raises(SceneError) as refused:
        equilibrium_path(Scene.from_dict(P4), P_values, x_c=0.5)
    assert refused.value.key == key and "repeats" in str(refused.value)


def test_cli_path_refuses_a_range_that_repeats_a_force(p4_file, capsys):
    assert main(["path", str(p4_file), "--axial", "1e9:1e9:3"]) == 2
    assert capsys.readouterr().err.startswith("error: --axial: repeats a force")
    assert main(["path", str(p4_file), "--axial", "1e9:1e9:1"]) == 0   # one force: fine
    capsys.readouterr()


# --------------------------------------------------------------- 4. w_c between nodes

def hermite(x, nodes, w, slope):
    """The Hermite cubic of the element holding ``x``, written out."""
    e = min(int(np.searchsorted(nodes, x, side="right")) - 1, len(nodes) - 2)
    h = nodes[e + 1] - nodes[e]
    t = (x - nodes[e]) / h
    return ((1 - 3 * t**2 + 2 * t**3) * w[e] + h * (t - 2 * t**2 + t**3) * slope[e]
            + (3 * t**2 - 2 * t**3) * w[e + 1] + h * (t**3 - t**2) * slope[e + 1])


X = 0.3   # between the nodes 0.25 and 0.375 of 8 elements


def test_deflection_between_nodes_is_the_hermite_interpolant():
    scene = Scene.from_dict(P4).with_overrides({"load.axial": 1.5e9})
    eqs = equilibria(scene)
    assert len(eqs) == 3
    for e in eqs:
        expected = hermite(X, e.x, e.w, e.slope)
        assert e.deflection_at(X) == pytest.approx(expected, rel=1e-12, abs=1e-15)
        # (the linear interpolant is far from it: the test tells them apart)
        assert abs(np.interp(X, e.x, e.w) - expected) > 1e-3 * abs(expected)
    assert e.deflection_at(np.array([X, 0.5])).shape == (2,)
    # at the ends the supports' zeros; off the beam the cubic would extrapolate: refused
    assert e.deflection_at(np.array([0.0, 1.0])) == pytest.approx([0.0, 0.0], abs=1e-15)
    for off in (-0.1, 1.2):
        with pytest.raises(SceneError, match="off the beam"):
            e.deflection_at(off)
    g = solve(scene, "global")
    assert eqs[0].deflection_at(X) == pytest.approx(g.deflection(X), rel=1e-6)


def test_path_w_c_between_nodes_is_that_of_the_fe_solution():
    scene = Scene.from_dict(P4)
    path = equilibrium_path(scene, [0.5e9, 1.5e9], x_c=X)
    (below,) = path.at(0.5e9)
    r = solve(scene.with_overrides({"load.axial": 0.5e9}))
    assert below["w_c"] == pytest.approx(r.deflection(X), rel=1e-9)
    g = solve(scene.with_overrides({"load.axial": 1.5e9}), "global")
    (lowest,) = [p for p in path.at(1.5e9) if p["global"]]
    assert lowest["w_c"] == pytest.approx(g.deflection(X), rel=1e-6)


def test_cli_path_csv_booleans_as_its_json_writes_them(p4_file, tmp_path, capsys):
    table = tmp_path / "p.csv"
    assert main(["path", str(p4_file), "--axial", "0.5e9:1.5e9:2", "--json",
                 "--csv", str(table), "--at", str(X)]) == 0
    records = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    with open(table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(records) == 4
    for row, record in zip(rows, records):
        for key in ("stable", "global"):
            assert row[key] == json.dumps(record[key])   # "true" / "false"
        assert float(row["w_c"]) == record["w_c"]


# --------------------------------------------------------------- 5. docs/api.md

def test_api_doc_import_line_names_the_equilibrium_functions():
    from pathlib import Path

    import gaocvx

    text = (Path(__file__).parent.parent / "docs" / "api.md").read_text()
    block = text.split("```python\n", 1)[1].split("```", 1)[0]   # the import lines
    names = {n.strip() for line in block.splitlines() if line.startswith("from gaocvx import ")
             for n in line[len("from gaocvx import "):].split(",")}
    assert {"equilibria", "equilibrium_path", "Equilibrium", "EquilibriumPath"} <= names
    assert all(hasattr(gaocvx, n) for n in names)


def test_mirror_minima_just_above_the_limit_are_both_global():
    """Without load a P4 beam's two buckled minima are mirror images (w -> -w): both
    are global minimisers at every force above the limit.  At 1.000001 P_bar_h
    (12 elements) the energy, -1.7e-5 J, is far below its parts (67 J), and the
    computed energies differed by 1.9e-9 of the total: a tie relative to the
    total marked one of them only."""
    data = {**P4, "load": {}, "mesh": {"elements": 12}}
    P = 1168009282.1544018   # P_bar_h (1 + 1e-6)
    pts = equilibrium_path(data, [P]).at(P)
    stable = [p for p in pts if p["stable"]]
    assert len(stable) == 2 and stable[0]["w_c"] == pytest.approx(-stable[1]["w_c"], rel=1e-6)
    assert all(p["global"] for p in stable)
    assert not any(p["global"] for p in pts if not p["stable"])
    r = solve(Scene.from_dict({**data, "load": {"axial": P}}), "global")
    assert r.status == "optimal" and r.extra["global"]["unique"] is False


def _point(P, w_c, stable, max_abs_w=None):
    return {"P": P, "w_c": w_c, "stable": stable,
            "max_abs_w": abs(w_c) if max_abs_w is None else max_abs_w}


def _polylines(path):
    return sorted([[(p["P"], p["w_c"]) for p in br] for br in path.branches()])


def test_a_pitchfork_links_the_flat_beam_to_both_mirror_images():
    """Without load the flat beam (w_c = 0) is stable below the limit, and above it
    the buckled beams w and -w are (w -> -w leaves the energy unchanged), with
    w = 0 unstable: the stable branch forks into both images.  (Linked to the
    nearer one only, the other image was a lone point; the images' computed
    w_c differ by round-off, 1.3e-6 relative just above P_bar_h.)"""
    a = 1.7e-3
    path = EquilibriumPath(P=[1.0, 2.0], x_c=0.5, points=[
        _point(1.0, 0.0, True),
        _point(2.0, -a, True), _point(2.0, a * (1.0 + 1.3e-6), True), _point(2.0, 0.0, False)])
    branches = sorted([[(p["P"], p["w_c"]) for p in br] for br in path.branches()])
    assert branches == [[(1.0, 0.0), (2.0, -a)], [(1.0, 0.0), (2.0, a * (1.0 + 1.3e-6))],
                        [(2.0, 0.0)]]


def test_a_pitchfork_onto_an_obstacle_joins_both_beams():
    """Beams at +1 mm and -0.4 mm after a flat one (unloaded: they left the flat
    beam together at the buckling load, the one below pressed onto an obstacle
    0.4 mm under it): both start at the flat beam.  (Only mirror images were
    joined once, and the beam of a channel's far side was drawn unconnected.)"""
    path = EquilibriumPath(P=[1.0, 2.0], x_c=0.5, points=[
        _point(1.0, 0.0, True), _point(2.0, -4e-4, True), _point(2.0, 1e-3, True)])
    assert _polylines(path) == [[(1.0, 0.0), (2.0, -4e-4)], [(1.0, 0.0), (2.0, 1e-3)]]


def test_a_flat_beam_that_stays_flat_is_no_pitchfork():
    """The flat beam stable at both forces and a stable pair of mirror images
    appearing beside it (at folds): the flat beam continues as the flat beam,
    and the images start branches of their own.  (Linked in the order of w_c,
    the image at -w_c took the flat beam's branch and the other was joined to
    it as a pitchfork: a review.)"""
    a = 1e-3
    path = EquilibriumPath(P=[1.0, 2.0], x_c=0.5, points=[
        _point(1.0, 0.0, True), _point(2.0, -a, True), _point(2.0, 0.0, True),
        _point(2.0, a, True), _point(2.0, -a / 2, False), _point(2.0, a / 2, False)])
    assert _polylines(path) == [[(1.0, 0.0), (2.0, 0.0)], [(2.0, -a)], [(2.0, -a / 2)],
                                [(2.0, a / 2)], [(2.0, a)]]


def test_a_pitchfork_is_joined_with_the_forces_in_decreasing_order():
    """The pitchfork's forces given from the top down: branches run in increasing
    force, and both images are joined to the flat beam.  (In the order given,
    the flat beam continued one image only: a review.)"""
    a = 1.7e-3
    pts = [_point(1.0, 0.0, True), _point(2.0, -a, True), _point(2.0, a, True),
           _point(2.0, 0.0, False)]
    up = EquilibriumPath(P=[1.0, 2.0], x_c=0.5, points=pts)
    down = EquilibriumPath(P=[2.0, 1.0], x_c=0.5, points=pts[1:] + pts[:1])
    assert _polylines(down) == _polylines(up) == [
        [(1.0, 0.0), (2.0, -a)], [(1.0, 0.0), (2.0, a)], [(2.0, 0.0)]]


def test_no_pitchfork_across_stabilities():
    """A stable flat beam followed by a stable beam at -1 mm and an unstable one at
    +1 mm: only the stable one continues it (a branch keeps its stability)."""
    path = EquilibriumPath(P=[1.0, 2.0], x_c=0.5, points=[
        _point(1.0, 0.0, True), _point(2.0, -1e-3, True), _point(2.0, 1e-3, False)])
    assert _polylines(path) == [[(1.0, 0.0), (2.0, -1e-3)], [(2.0, 1e-3)]]


def test_an_unloaded_beams_path_forks_at_the_limit():
    """An unloaded P4 aluminium beam (4 elements, P_bar_h = 1.555e5 N): flat and
    stable at 1.4e5 N; at 1.6e5 and 1.8e5 N two stable mirror images (w -> -w)
    and the unstable flat beam.  Both images' branches start at the flat beam."""
    data = {"beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 7e10, "nu": 0.33,
                     "half_thickness": 0.02, "width": 0.05}, "mesh": {"elements": 4}}
    path = equilibrium_path(data, [1.4e5, 1.6e5, 1.8e5])
    stable = [br for br in path.branches() if br[0]["stable"]]
    assert len(stable) == 2
    assert all([p["P"] for p in br] == [1.4e5, 1.6e5, 1.8e5] for br in stable)
    assert all(br[0]["w_c"] == 0.0 for br in stable)
    assert stable[0][-1]["w_c"] == pytest.approx(-stable[1][-1]["w_c"], rel=1e-6)
    assert stable[0][-1]["w_c"] != 0.0


def test_a_channels_pitchfork_joins_both_sides():
    """An unloaded P4 beam in a channel (1 cm below, 2 cm above; P_bar_h = 1.17e9 N):
    flat and stable at 1.0e9 N; at 1.2e9 N one stable beam on either side, no
    mirror images (the lower one pressed onto its surface, the upper one free).
    Both stable branches start at the flat beam (a new user's trial drew the
    upper one unconnected)."""
    d = scene_dict("P4", q=None, obstacle=0.01, elements=8)
    d["obstacle"]["gap_above"] = 0.02
    path = equilibrium_path(d, [1.0e9, 1.2e9])
    stable = [br for br in path.branches() if br[0]["stable"]]
    assert len(stable) == 2 and all(br[0]["w_c"] == 0.0 and br[0]["P"] == 1.0e9 for br in stable)
    ends = sorted(br[-1]["w_c"] for br in stable)
    assert ends[0] < 0 < ends[1] and abs(ends[0] + ends[1]) > 1e-3   # no mirror images


@pytest.mark.parametrize("flat", [1e-20, -1e-20])
def test_a_flat_beam_that_stays_flat_by_round_off_is_no_pitchfork(flat):
    """As above, the flat beam's w_c at the second force round-off of either sign
    (a review: a beam on the other side was joined to it as a second arm)."""
    a = 1e-3
    path = EquilibriumPath(P=[1.0, 2.0], x_c=0.5, points=[
        _point(1.0, 0.0, True), _point(2.0, -a, True), _point(2.0, flat, True),
        _point(2.0, a, True)])
    assert _polylines(path) == [[(1.0, 0.0), (2.0, flat)], [(2.0, -a)], [(2.0, a)]]


def test_a_pitchfork_has_two_arms():
    """A flat beam, then stable beams at -0.4, +1 and +3 mm: the arm across w_c = 0
    is the beam nearest it (+1 mm); the one at +3 mm was born elsewhere (a review:
    all three were joined)."""
    path = EquilibriumPath(P=[1.0, 2.0], x_c=0.5, points=[
        _point(1.0, 0.0, True), _point(2.0, -4e-4, True), _point(2.0, 1e-3, True),
        _point(2.0, 3e-3, True)])
    assert _polylines(path) == [[(1.0, 0.0), (2.0, -4e-4)], [(1.0, 0.0), (2.0, 1e-3)],
                                [(2.0, 3e-3)]]
