"""Euler-Bernoulli paths, argument checks of equilibria and equilibrium_path, the path command.

Found by a new-user trial: ``gaocvx path`` crashed on every Euler-Bernoulli
scene (the buckling-mode probe at P = 0 met a mesh structure without slope
rows), the Python functions took ``elements=True`` or ``P_values=[True]``
without a word, and a path with skipped forces exited 1 (a solver failure)
instead of 2 (input out of range).

References from outside the code under test: ``gaocvx.solve`` at the same
force (the convex minimiser below the limit), and the closed-form Euler load
``pi^2 EI / L^2`` of a simply supported (P4) beam with its first mode
``sin(pi x / L)``, whose peak is at mid-span.
"""

import math

import numpy as np
import pytest

from conftest import trial_eb_toml

from gaocvx import DiscreteProblem, Scene, solve
from gaocvx.cli import main
from gaocvx.errors import SceneError
from gaocvx.nonconvex import equilibria, equilibrium_path, unstable_modes

# The trial's beam: EI = 2.1e11 * 0.1 * 0.02^3 / 12 = 1.4e4 N m^2, L = 3 m.
EB = {"beam": {"model": "euler-bernoulli", "supports": "P4", "length": 3.0, "E": 2.1e11,
               "nu": 0.3, "half_thickness": 0.01, "width": 0.1},
      "load": {"q": -1000.0}, "mesh": {"elements": 16}}
EI = 2.1e11 * 0.1 * 0.02**3 / 12
EULER = math.pi**2 * EI / 3.0**2   # 1.535e4 N: the P4 beam's buckling load

EB_TOML = trial_eb_toml("[[0.0, 0.0], [3.0, -1000.0]]")


def eb_scene(**beam):
    d = {k: dict(v) for k, v in EB.items()}
    d["beam"].update(beam)
    return Scene.from_dict(d)


# --------------------------------------------------------------- Euler-Bernoulli paths

@pytest.mark.parametrize("beam", [{}, {"model": "gao", "E_alpha": 0.0}],
                         ids=["euler-bernoulli", "gao-E_alpha-0"])
def test_modes_of_a_beam_without_axial_or_gao_term(beam):
    """At P = 0 without the Gao term the energy has no slope term, yet the pencil's G is
    that term's form: the modes are those of (K, G) all the same."""
    scene = eb_scene(**beam).with_overrides({"load.axial": 0.0})
    dp = DiscreteProblem(scene, check_convexity=False)
    m = unstable_modes(dp, min_k=1)
    mu = dp.mu   # (the Gao beam's loads are those of (K, mu G))
    assert m.k == 1 and m.verified
    assert float(m.loads[0]) * mu == pytest.approx(EULER, rel=1e-5)
    w = dp.full(m.phi[:, 0])[0::2]
    exact = np.sin(np.pi * dp.x / 3.0)
    assert np.allclose(w / w[np.argmax(np.abs(w))], exact, atol=1e-4)


@pytest.mark.parametrize("beam", [{}, {"model": "gao", "E_alpha": 0.0}],
                         ids=["euler-bernoulli", "gao-E_alpha-0"])
def test_euler_bernoulli_path_below_the_limit_is_the_convex_minimiser(beam):
    scene = eb_scene(**beam)
    P = [-0.5 * EULER, 0.0, 0.4 * EULER, 0.8 * EULER]
    path = equilibrium_path(scene, P)
    assert not path.errors and path.P == P
    assert path.x_c == pytest.approx(1.5)   # the first mode's peak, mid-span
    for p in P:
        r = solve(scene.with_overrides({"load.axial": p}))
        (pt,) = path.at(p)
        assert pt["stable"] and pt["global"] and pt["status"] == "optimal"
        assert pt["energy"] == pytest.approx(r.energy, rel=1e-9)
        assert pt["w_c"] == pytest.approx(float(np.interp(1.5, r.x, r.w)), rel=1e-9)


def test_euler_bernoulli_path_above_the_limit_lists_the_refused_forces():
    """Above P_bar_h the energy without a quartic term is unbounded below: each such force
    is refused as solve() refuses it, and the forces below still have their minimiser."""
    scene = eb_scene()
    path = equilibrium_path(scene, [0.5 * EULER, 1.5 * EULER, 3.0 * EULER])
    assert [len(path.at(p)) for p in path.P] == [1, 0, 0]
    assert sorted(path.errors) == [1.5 * EULER, 3.0 * EULER]
    with pytest.raises(SceneError) as refused:
        solve(scene.with_overrides({"load.axial": 1.5 * EULER}), "global")
    assert path.errors[1.5 * EULER] == str(refused.value)
    assert "no minimiser" in path.errors[3.0 * EULER]


# --------------------------------------------------------------- argument checks

BAD_ELEMENTS = [2.5, True, "8", 0, -4, np.float64(2.5), [8]]


@pytest.mark.parametrize("elements", BAD_ELEMENTS, ids=repr)
def test_equilibria_and_path_check_elements_as_solve_does(elements):
    scene = eb_scene()
    with pytest.raises(SceneError) as by_solve:
        solve(scene, elements=elements)
    for call in (lambda: equilibria(scene, elements=elements),
                 lambda: equilibrium_path(scene, [0.0], elements=elements)):
        with pytest.raises(SceneError) as exc:
            call()
        assert exc.value.key == "elements" and str(exc.value) == str(by_solve.value)


def test_integral_elements_are_accepted_and_used():
    scene = eb_scene()
    r = solve(scene, elements=8)
    for elements in (8, 8.0, np.int64(8)):
        (e,) = equilibria(scene, elements=elements)
        assert len(e.x) == 9 and e.energy == pytest.approx(r.energy, rel=1e-12)
        path = equilibrium_path(scene, [0.0], elements=elements)
        assert path.points[0]["energy"] == pytest.approx(r.energy, rel=1e-12)


@pytest.mark.parametrize("grid", [0, 1, 2.5, True, "121", 10**6], ids=repr)
def test_equilibria_checks_grid(grid):
    with pytest.raises(SceneError) as exc:
        equilibria(eb_scene(), grid=grid)
    assert exc.value.key == "grid" and exc.value.got == grid


@pytest.mark.parametrize("seeds", [["a"], [math.nan], "0.1"], ids=repr)
def test_equilibria_checks_seeds(seeds):
    with pytest.raises(SceneError) as exc:
        equilibria(eb_scene(), seeds=seeds)
    assert exc.value.key.startswith("seeds")


BAD_FORCES = [(["a", "b"], "P_values[0]"), ([True], "P_values[0]"),
              ([0.0, math.nan], "P_values[1]"), ([math.inf], "P_values[0]"),
              (np.array([0.0, -np.inf]), "P_values[1]"), ("12", "P_values"),
              ({"P": 1.0}, "P_values"), (None, "P_values"), (True, "P_values"),
              (np.array([[0.0, 1.0]]), "P_values[0]"),
              ([], "P_values"), (np.array([]), "P_values")]   # (a new user's trial: no force)


@pytest.mark.parametrize("P_values, key", BAD_FORCES, ids=[repr(b[0]) for b in BAD_FORCES])
def test_path_checks_its_forces_before_any_work(monkeypatch, P_values, key):
    import gaocvx.nonconvex.path as path_module

    def no_work(*args, **kwargs):
        raise AssertionError("work began before the arguments were checked")

    monkeypatch.setattr(path_module, "characteristic_point", no_work)
    monkeypatch.setattr("gaocvx.nonconvex.stationary.equilibria", no_work)
    with pytest.raises(SceneError) as exc:
        equilibrium_path(eb_scene(), P_values)
    assert exc.value.key == key


def test_path_of_one_number_is_a_path_of_one_force():
    scene = eb_scene()
    r = solve(scene.with_overrides({"load.axial": 5e3}))
    for P in (5e3, np.float64(5e3), np.array(5e3), 5000):
        path = equilibrium_path(scene, P)
        assert path.P == [5e3] and len(path.points) == 1
        assert path.points[0]["energy"] == pytest.approx(r.energy, rel=1e-9)


@pytest.mark.parametrize("x_c", [-0.1, 3.5, math.nan, "1.5"], ids=repr)
def test_path_checks_x_c(x_c):
    with pytest.raises(SceneError) as exc:
        equilibrium_path(eb_scene(), [0.0], x_c=x_c)
    assert exc.value.key == "x_c"


def test_equilibria_and_path_take_a_scene_dict_as_solve_does():
    r = solve(EB)
    assert equilibria(EB)[0].energy == pytest.approx(r.energy, rel=1e-9)
    assert equilibrium_path(EB, [0.0]).points[0]["energy"] == pytest.approx(r.energy, rel=1e-9)


# --------------------------------------------------------------- what a path skips

@pytest.mark.slow
def test_path_takes_two_unstable_modes_and_skips_three():
    """The documented limit: k = 2 is searched (stationary2), k >= 3 is skipped.

    A clamped-clamped (P1) Gao beam without load buckles at 4 pi^2, 80.76 and
    16 pi^2 times EI / (mu L^2) (its symmetric and antisymmetric modes): 1.1e10 N
    lies between the second and the third, 2.2e10 N between the third and the
    fourth (238.2 EI / (mu L^2)).
    """
    beam = {"model": "gao", "supports": "P1", "length": 1.0, "E": 2.1e11, "nu": 0.3,
            "half_thickness": 0.1, "width": 1.0}
    scene = Scene.from_dict({"beam": beam, "load": {"q": 0.0}, "mesh": {"elements": 8}})
    unit = 2.1e11 * (2.0 / 3.0) * 0.1**3 / DiscreteProblem(scene).mu   # EI / (mu L^2)
    assert 80.76 * unit < 1.1e10 < 16 * math.pi**2 * unit < 2.2e10 < 238.2 * unit
    path = equilibrium_path(scene, [1.1e10, 2.2e10])
    # w = 0, the two mirror minima along the first mode, the two saddles along the second
    assert len(path.at(1.1e10)) == 5 and 1.1e10 not in path.errors
    assert path.at(2.2e10) == [] and "3 unstable buckling modes" in path.errors[2.2e10]


# --------------------------------------------------------------- the path command

@pytest.fixture
def eb_file(tmp_path):
    path = tmp_path / "eb.toml"
    path.write_text(EB_TOML)
    return path


def test_cli_euler_bernoulli_path_below_the_limit(eb_file, capsys):
    from gaocvx.scene import load_scene

    scene = load_scene(str(eb_file))
    assert main(["path", str(eb_file), "--axial", "0:1.2e4:3"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("# 3 equilibria at 3 axial forces; w_c = w(1.5 m)")
    energies = [float(line.split("energy")[1].split()[0]) for line in out[1:]]
    expected = [solve(scene.with_overrides({"load.axial": P})).energy for P in (0, 6e3, 1.2e4)]
    assert energies == pytest.approx(expected, rel=1e-5)   # (printed to 6 digits)
    assert main(["path", str(eb_file), "--axial", "5e3:5e3:1"]) == 0
    assert capsys.readouterr().out.startswith("# 1 equilibrium at 1 axial force; ")


def test_cli_path_with_skipped_forces_prints_the_rest_and_exits_2(eb_file, capsys):
    code = main(["path", str(eb_file), "--axial", "0:4.5e4:4"])   # two above 1.535e4 N
    out, err = capsys.readouterr()
    assert code == 2
    assert out.splitlines()[0].startswith("# 2 equilibria at 4 axial forces (2 skipped); ")
    lines = out.splitlines()
    assert len(lines) == 1 + 4   # a row per force, the skipped ones say why
    assert [line.split()[1] for line in lines[1:]] == ["0", "15000", "30000", "45000"]
    assert ["skipped: load.axial: " in line for line in lines[1:]] == [False, False, True, True]
    errors = err.splitlines()
    assert len(errors) == 2 and all("there is no minimiser" in e for e in errors)
    assert errors[0].startswith("error: P = 30000 N: load.axial: ")


def _spoil(monkeypatch, statuses):
    """Make the path's equilibria inaccurate where ``statuses`` says (the exit status's input)."""
    import gaocvx.nonconvex.path as path_module
    real = path_module.equilibrium_path

    def spoiled(*args, **kwargs):
        path = real(*args, **kwargs)
        for point, status in zip(path.points, statuses):
            point["status"] = status
        return path

    monkeypatch.setattr(path_module, "equilibrium_path", spoiled)


def test_cli_path_exit_status_ranks_input_over_accuracy(eb_file, capsys, monkeypatch):
    _spoil(monkeypatch, ["inaccurate"])
    assert main(["path", str(eb_file), "--axial", "0:1e4:2"]) == 1     # a solver's failure
    assert main(["path", str(eb_file), "--axial", f"0:{2 * EULER}:2"]) == 2   # and a refusal
    capsys.readouterr()


def test_cli_equilibria_counts_in_words(eb_file, capsys, monkeypatch):
    import gaocvx.nonconvex.stationary as stationary
    real = stationary.equilibria

    def spoiled(*args, **kwargs):
        eqs = real(*args, **kwargs)
        eqs[0].status = "inaccurate"
        return eqs

    monkeypatch.setattr(stationary, "equilibria", spoiled)
    assert main(["equilibria", str(eb_file)]) == 1
    assert capsys.readouterr().err.endswith(": 1 equilibrium not found accurately\n")


def test_cli_negative_axial_range_says_how_to_write_it(eb_file, capsys):
    assert main(["path", str(eb_file), "--axial", "-1e4:1e4:3"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: arguments: argument --axial: expected one argument")
    assert "--axial=START:STOP:NUM, e.g. --axial=-1e9:2e9:4" in err
    assert main(["path", str(eb_file), "--axial=-1e4:1e4:3"]) == 0   # the form that parses
    assert capsys.readouterr().out.startswith("# 3 equilibria at 3 axial forces; ")


def test_an_axial_range_takes_num_written_as_a_whole_float(eb_file, capsys):
    """3.0 is a whole number (a review: "0:3e9:3.0" was refused as not one)."""
    from gaocvx.nonconvex.cli import parse_range
    from gaocvx.sweep import parse_range as sweep_range

    assert parse_range("0:2e9:3.0").tolist() == parse_range("0:2e9:3").tolist() == [0.0, 1e9, 2e9]
    assert sweep_range("0:2:3.0").tolist() == sweep_range("0:2:3e0").tolist() == [0.0, 1.0, 2.0]
    for bad in ("0:2:2.5", "0:2:inf", "0:2:nan", "0:2:x", "0:2:3.0000000000000001"):
        with pytest.raises(SceneError, match="NUM a whole number"):
            sweep_range(bad)
        with pytest.raises(SceneError, match="NUM a whole number"):
            parse_range(bad)
    # a whole number far beyond the limits is refused as such, at once (not its
    # billion-digit int)
    with pytest.raises(SceneError, match="NUM must be between 1 and"):
        sweep_range("0:2:1e1000000000")
    with pytest.raises(SceneError, match="1 <= NUM <="):
        parse_range("0:2:1e1000000000")


@pytest.mark.parametrize("text, says", [
    ("1e9:2e9:2.5", "NUM a whole number"),
    ("1e9:2e9:1", "NUM = 1 traces START only"),    # (STOP was dropped without a word)
])
def test_cli_axial_range_errors_say_what_is_wrong(eb_file, capsys, text, says):
    assert main(["path", str(eb_file), "--axial", text]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --axial: ") and says in err and text in err
