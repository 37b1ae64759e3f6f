"""The command line: exit codes, JSON contract, errors on stderr."""

import json
from pathlib import Path

import pytest

from conftest import FOUNDATION_TOML
from gaocvx.cli import main

EXAMPLES = Path(__file__).parent.parent / "examples"

SCENE = FOUNDATION_TOML

JSON_KEYS = {"status", "method", "model", "supports", "elements", "nodes", "max", "min", "energy",
             "energy_parts", "contact", "P_bar", "time_s"}


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_solve_json_contract(capsys, scene):
    code, out, err = run(capsys, "solve", scene, "--json")
    assert code == 0, err
    data = json.loads(out)
    assert JSON_KEYS <= set(data)
    assert data["scene"] == str(scene)
    assert data["status"] == "optimal"
    assert set(data["energy_parts"]) == {"bending", "gao", "axial", "load", "foundation"}
    assert data["energy"] == pytest.approx(sum(data["energy_parts"].values()))
    # thesis table 4.13a: -0.008452 m at x = 0.5 (reference-cases.md: Gao within 1 %)
    assert data["min"]["x"] == 0.5 and data["min"]["w"] == pytest.approx(-0.008452, rel=1e-2)
    assert data["contact"]["zones"] == [[0.375, 0.625]]
    n = data["elements"] + 1
    assert len(data["nodes"]["x"]) == len(data["nodes"]["w"]) == len(data["nodes"]["slope"]) == n
    assert len(data["contact"]["reaction"]) == n
    assert data["P_bar"] == pytest.approx(4.672e9, rel=1e-3)


def test_human_summary(capsys, scene):
    code, out, _ = run(capsys, "solve", scene)
    assert code == 0
    assert "optimal" in out and "contact" in out and "P_bar_h" in out


def test_set_and_elements(capsys, scene):
    code, out, _ = run(capsys, "solve", scene, "--json", "--elements", "16",
                       "--set", "beam.model=euler-bernoulli", "--set", "foundation.stiffness=1e11")
    data = json.loads(out)
    assert code == 0 and data["elements"] == 16 and data["model"] == "euler-bernoulli"


@pytest.mark.parametrize("argv, key", [
    # above P_bar_h: the convex methods refuse it (auto solves it globally, below)
    (["--set", "load.axial=5e9", "--method", "newton"], "load.axial"),
    (["--set", "beam.nu=0.7"], "beam.nu"),
    (["--set", "beam.colour=1"], "beam.colour"),
    (["--set", "obstacle.gap=0.01"], "obstacle"),
    (["--set", "load.points=[[1.5, 1.0]]"], "load.points[0][0]"),
    (["--elements", "0"], "mesh.elements"),
    (["--method", "psychic"], "solve.method"),
    (["--method", "convex", "--solver", "osqp"], "solve.solver"),
])
def test_bad_input_exit_2_names_key(capsys, scene, argv, key):
    code, out, err = run(capsys, "solve", scene, *argv)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {key}: "), err
    assert "Traceback" not in err and out == ""


@pytest.mark.parametrize("argv, expected", [
    (["path", "{scene}", "--axial", "0:1e9:2", "--at", "abc"],
     "error: --at: must be a number (got 'abc')"),
    (["verify", "{scene}", "--max-gap", "1e"], "error: --max-gap: must be a number (got '1e')"),
    (["path", "{scene}", "--axial", "0:1e9:2", "--at", "a'b"],
     "error: --at: must be a number (got \"a'b\")"),
    (["sweep", "{scene}", "--vary", "load.q=0:1:2", "--jobs", "x"],
     "error: --jobs: must be a whole number (got 'x')"),
])
def test_an_option_of_the_wrong_type_is_named_with_its_value(capsys, scene, argv, expected):
    """As every other bad input: the option and the value, not argparse's "arguments:
    argument --at: invalid float value: 'abc'" (a new user's trial)."""
    code, out, err = run(capsys, *[a.format(scene=scene) for a in argv])
    assert code == 2 and out == "" and err.strip() == expected


def test_convexity_limit_message(capsys, scene):
    """Newton and convex refuse P >= P_bar_h with the limit in the message; auto takes the
    certified global method there (issue 10) instead of refusing."""
    for method in ("newton", "convex"):
        code, _, err = run(capsys, "solve", scene, "--set", "load.axial=5e9", "--method", method)
        assert code == 2
        assert "P_bar_h = 4.672e+09 N for P1" in err and "(got 5e+09)" in err
    code, out, _ = run(capsys, "solve", scene, "--set", "load.axial=5e9", "--json")
    data = json.loads(out)
    assert data["method"] == "global" and data["global"]["unstable_modes"] >= 1


def test_a_force_just_above_the_limit_is_told_apart_from_it(capsys, scene):
    """P and P_bar_h in the refusal are printed with digits enough to differ (a new
    user's trial: "P = 1.168e+09 N is not below ... P_bar_h = 1.168e+09 N")."""
    code, _, err = run(capsys, "solve", scene, "--set", "load.axial=4.67202e9", "--method",
                       "newton")
    assert code == 2
    assert "P = 4.67202e+09 N is not below the convexity limit P_bar_h = 4.67201e+09 N" in err


def test_several_scenes_json_lines(capsys, scene, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SCENE.replace("nu = 0.3", "nu = 3"))
    code, out, err = run(capsys, "solve", scene, bad, scene, "--json")
    lines = [json.loads(line) for line in out.strip().splitlines()]
    assert [r["scene"] for r in lines] == [str(scene), str(bad), str(scene)]
    assert [r["status"] for r in lines] == ["optimal", "error", "optimal"]
    assert lines[1]["error"].startswith("beam.nu: ")
    # With several scenes the error line names the file before the key.
    assert code == 2 and err.startswith(f"error: {bad}: beam.nu: ")


def test_missing_file_and_usage(capsys, tmp_path):
    code, _, err = run(capsys, "solve", tmp_path / "none.toml")
    assert code == 2 and err.startswith("error: ") and "cannot read" in err
    code, _, err = run(capsys, "solve")
    assert code == 2 and err.startswith("error: arguments:")
    code, _, err = run(capsys, "frobnicate")
    assert code == 2 and err.startswith("error: arguments:")


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.stem)
def test_examples_solve(capsys, path):
    code, out, err = run(capsys, "solve", path, "--json")
    assert code == 0, err
    assert json.loads(out)["status"] == "optimal"
