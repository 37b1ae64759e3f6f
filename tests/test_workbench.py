"""Plots, the EB-vs-Gao comparison and sweeps, from Python and the command line."""

import csv
import io
import json
import logging

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from conftest import FOUNDATION_TOML, scene_dict  # noqa: E402
from gaocvx import Scene, SceneError, solve  # noqa: E402
from gaocvx.cli import main  # noqa: E402
from gaocvx.plot import plot  # noqa: E402
from gaocvx.sweep import ProgressBar, parse_range, sweep  # noqa: E402

SCENE = FOUNDATION_TOML + "[mesh]\nelements = 16\n"


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


def test_plot_returns_axes_and_draws_the_curve():
    r = solve(Scene.from_dict(scene_dict(foundation=(0.007, 5e8), q=-5e8)))
    ax = plot(r)
    ys = ax.lines[1].get_ydata()
    assert ax.get_xlabel() == "x [m]"
    assert min(ys) == pytest.approx(r.min["w"], rel=1e-3)
    matplotlib.pyplot.close(ax.figure)


@pytest.mark.parametrize("suffix", [".png", ".svg"])
def test_cli_plot_files(tmp_path, scene_file, capsys, suffix):
    out = tmp_path / f"a{suffix}"
    assert main(["solve", str(scene_file), "--plot", str(out), "--panels",
                 "slope,moment,shear,reaction"]) == 0
    assert out.stat().st_size > 1000
    head = out.read_bytes()[:8]
    assert head.startswith(b"\x89PNG") if suffix == ".png" else b"<?xml" in head or b"<svg" in head


def test_cli_plot_bad_suffix_and_panel(tmp_path, scene_file, capsys):
    assert main(["solve", str(scene_file), "--plot", str(tmp_path / "a.jpg")]) == 2
    assert capsys.readouterr().err.startswith("error: --plot: ")
    assert main(["solve", str(scene_file), "--plot", str(tmp_path / "a.png"),
                 "--panels", "torque"]) == 2
    assert capsys.readouterr().err.startswith("error: --panels: ")


def test_compare(tmp_path, scene_file, capsys):
    assert main(["compare", str(scene_file), "--json", "--plot", str(tmp_path / "c.png")]) == 0
    data = json.loads(capsys.readouterr().out)
    eb, gao = data["euler-bernoulli"], data["gao"]
    assert eb["model"] == "euler-bernoulli" and gao["model"] == "gao"
    # The Gao model scales the load by (1 - nu^2) and stiffens: it sinks less.
    assert gao["min"]["w"] > eb["min"]["w"]
    assert data["comparison"]["min_w_ratio"] == pytest.approx(gao["min"]["w"] / eb["min"]["w"])
    assert (tmp_path / "c.png").exists()


def test_compare_above_the_euler_bernoulli_limit_gives_gao_and_the_refusal(tmp_path, capsys):
    """Between the two limits both models solve (Gao by the global method); above the
    Euler-Bernoulli one (pi^2 EI / L^2 = 1.382e9 N here, no quartic term) that model has
    no minimiser: the Gao answer is still given, the refusal in its place, exit 2."""
    scene = tmp_path / "s.toml"
    scene.write_text('[beam]\nmodel = "gao"\nsupports = "P4"\nlength = 1.0\nE = 2.1e11\n'
                     'nu = 0.3\nhalf_thickness = 0.1\nwidth = 1.0\n[load]\nq = -1e7\n'
                     'axial = 3e9\n[mesh]\nelements = 16\n')
    assert main(["compare", str(scene), "--json", "--plot", str(tmp_path / "c.png")]) == 2
    out, err = capsys.readouterr()
    data = json.loads(out)
    assert data["euler-bernoulli"]["status"] == "error"
    assert "there is no minimiser" in data["euler-bernoulli"]["error"]
    assert data["gao"]["status"] == "optimal" and data["gao"]["method"] == "global"
    assert data["comparison"] == {"min_w_ratio": None, "energy_ratio": None}
    assert err.startswith("error: euler-bernoulli: load.axial: ") and err.count("\n") == 1
    assert (tmp_path / "c.png").exists()
    from gaocvx.plot import compare_figure
    from gaocvx.solve import solve as solve_scene
    from gaocvx.scene import load_scene
    fig = compare_figure({"gao": solve_scene(load_scene(scene))})
    assert fig.axes[0].get_title().startswith("Gao, supports P4")
    # The Gao answer is the one `solve` gives for the scene.
    assert main(["solve", str(scene), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["energy"] == pytest.approx(data["gao"]["energy"],
                                                                          rel=1e-12)


def test_sweep_penetration_falls_as_stiffness_rises(tmp_path, scene_file, capsys):
    csv_path = tmp_path / "s.csv"
    code = main(["sweep", str(scene_file), "--vary", "foundation.stiffness=1e8:1e13:8:log",
                 "--json", "--csv", str(csv_path), "--plot", str(tmp_path / "s.png")])
    out, err = capsys.readouterr()
    assert code == 0
    lines = [json.loads(line) for line in out.strip().splitlines()]
    assert [round(r["value"]) for r in lines] == [round(v) for v in
                                                  parse_range("1e8:1e13:8:log")]
    assert all(r["status"] == "optimal" and r["key"] == "foundation.stiffness" for r in lines)
    depth = [-0.007 - r["min"]["w"] for r in lines]
    assert all(a > b for a, b in zip(depth, depth[1:])) and depth[-1] > 0
    assert "\r" not in err   # stderr is no terminal here: no progress-bar frames
    rows = list(csv.DictReader(csv_path.open()))
    assert len(rows) == 8 and float(rows[0]["penetration"]) == pytest.approx(depth[0])
    assert (tmp_path / "s.png").exists()


def test_sweep_without_contact_has_no_contact_numbers(tmp_path, capsys):
    """No foundation or obstacle: the contact columns are empty ("-" in the table),
    as solve's contact is null; a new user's trial saw contact 0 and 0 zones."""
    path = tmp_path / "free.toml"
    d = scene_dict("P1", "gao", q=-1e6, elements=8)
    beam = "\n".join(f"{k} = {json.dumps(v)}" for k, v in d["beam"].items())
    path.write_text(f"[beam]\n{beam}\n[load]\nq = -1e6\n[mesh]\nelements = 8\n")
    csv_path = tmp_path / "s.csv"
    assert main(["sweep", str(path), "--vary", "load.q=-1e6:-2e6:2", "--csv", str(csv_path)]) == 0
    table = capsys.readouterr().out.strip().splitlines()
    assert len(table) == 3 and all(line.split()[-2:] == ["-", "-"] for line in table[1:])
    rows = list(csv.DictReader(csv_path.open()))
    assert [(r["contact_length"], r["contact_zones"], r["penetration"]) for r in rows] == [
        ("", "", "")] * 2
    # the table has max w beside min w (a beam buckled upwards has min w 0)
    assert table[0].split()[:10] == ["value", "status", "min", "w", "[m]", "at", "x", "max",
                                     "w", "[m]"]
    for line, r in zip(table[1:], rows):
        cells = line.split()
        assert float(cells[2]) == pytest.approx(float(r["min_w"]), rel=1e-5)
        assert float(cells[4]) == pytest.approx(float(r["max_w"]), rel=1e-5, abs=1e-300)
    assert main(["solve", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["contact"] == {"zones": None, "reaction": None}


def test_sweep_approaches_the_rigid_obstacle():
    base = Scene.from_dict(scene_dict(foundation=(0.007, 1e10), q=-5e8, elements=16))
    obstacle = solve(Scene.from_dict(scene_dict(obstacle=0.007, q=-5e8, elements=16)))
    results = [r for _, r in sweep(base, "foundation.stiffness", [1e10, 1e12, 1e14, 1e16])]
    dist = [np.abs(r.w - obstacle.w).max() for r in results]
    assert all(a > b for a, b in zip(dist, dist[1:])) and dist[-1] < 1e-3 * 0.007


@pytest.mark.parametrize("key, spec", [("load.scale", "0.5:1.5:3"), ("foundation.gap", "0:0.01:3"),
                                       ("load.axial", "-1e9:1e9:3"), ("beam.nu", "0:0.4:3")])
def test_sweep_keys(key, spec):
    base = Scene.from_dict(scene_dict(foundation=(0.007, 5e8), q=-5e8, elements=8))
    items = list(sweep(base, key, parse_range(spec)))
    assert len(items) == 3 and all(r.success for _, r in items)
    if key == "load.scale":
        a, b, c = (r.min["w"] for _, r in items)
        assert a > b > c  # more load, more deflection


def test_sweep_parallel_matches_serial():
    base = Scene.from_dict(scene_dict(foundation=(0.007, 5e8), q=-5e8, elements=16))
    values = parse_range("1e8:1e12:6:log")
    serial = [r.min["w"] for _, r in sweep(base, "foundation.stiffness", values)]
    parallel = [r.min["w"] for _, r in sweep(base, "foundation.stiffness", values, jobs=2)]
    assert serial == pytest.approx(parallel, rel=1e-9)


def test_sweep_bad_arguments(scene_file, capsys):
    for argv, key in [(["--vary", "foundation.stiffness=1:2"], "--vary"),
                      (["--vary", "foundation.stifness=1:2:3"], "foundation.stifness"),
                      (["--vary", "obstacle.gap=0:1:3"], "obstacle.gap"),
                      (["--vary", "foundation.gap=a:b:3"], "--vary"),
                      (["--vary", "foundation.gap=0:1:3:lin"], "--vary"),
                      (["--vary", "foundation.gap=-1:1:3:log"], "--vary"),
                      (["--vary", "foundation.gap=0:1:1"], "--vary"),   # (it dropped STOP)
                      (["--vary", "foundation.gap=0:1:3", "--jobs", "0"], "--jobs")]:
        assert main(["sweep", str(scene_file), *argv]) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].startswith(f"error: {key}: "), (argv, err)


def test_sweep_reports_bad_values_and_goes_on(scene_file, capsys):
    code = main(["sweep", str(scene_file), "--vary", "foundation.gap=-0.01:0.01:3", "--json"])
    lines = [json.loads(line) for line in capsys.readouterr().out.strip().splitlines()]
    assert code == 2
    assert lines[0]["status"] == "error" and lines[0]["error"].startswith("foundation.gap: ")
    assert lines[1]["status"] == lines[2]["status"] == "optimal"


@pytest.mark.slow
def test_dask_missing_or_unreachable_is_a_clear_error():
    base = Scene.from_dict(scene_dict(foundation=(0.007, 5e8), q=-5e8, elements=8))
    with pytest.raises(SceneError, match="^--dask"):
        list(sweep(base, "foundation.stiffness", [1e8, 1e9], dask="tcp://127.0.0.1:9"))


def test_sweep_on_a_local_dask_cluster():
    """The same sweep through a Dask scheduler gives the serial answers, in order."""
    distributed = pytest.importorskip("dask.distributed")
    base = Scene.from_dict(scene_dict(foundation=(0.007, 5e8), q=-5e8, elements=16))
    values = parse_range("1e8:1e12:5:log")
    serial = [r.min["w"] for _, r in sweep(base, "foundation.stiffness", values)]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        remote = [(v, r) for v, r in sweep(base, "foundation.stiffness", values,
                                           dask=cluster.scheduler_address)]
    assert [v for v, _ in remote] == pytest.approx(list(values))
    assert [r.min["w"] for _, r in remote] == pytest.approx(serial, rel=1e-9)


def test_plot_without_matplotlib_is_a_clear_error(tmp_path, scene_file, capsys, monkeypatch):
    import builtins
    real_import = builtins.__import__

    def no_matplotlib(name, *args, **kwargs):
        if name == "matplotlib" or name.startswith("matplotlib."):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_matplotlib)
    assert main(["solve", str(scene_file), "--plot", str(tmp_path / "a.png")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --plot: pictures need matplotlib") and "Traceback" not in err


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_only_on_a_terminal():
    """A redirected stream gets no carriage-return frames; a terminal gets one line, redrawn."""
    redirected, terminal = io.StringIO(), _Terminal()
    for stream in (redirected, terminal):
        bar = ProgressBar("sweep k", stream)
        for done in (1, 2, 3):
            bar(done, 3)
    assert redirected.getvalue() == ""
    frames = terminal.getvalue()
    assert frames.count("\r") == 3 and frames.endswith("\n") and "3/3" in frames


def test_verbose_logs_phases_and_sweep_progress(scene_file, capsys, caplog):
    """-v before or after the subcommand logs what is done (INFO); without it, nothing."""
    with caplog.at_level(logging.WARNING):
        assert main(["solve", str(scene_file)]) == 0
    assert not [r for r in caplog.records if r.levelno < logging.WARNING]
    caplog.clear()
    for argv in (["-v", "solve", str(scene_file)], ["solve", str(scene_file), "-v"]):
        with caplog.at_level(logging.INFO):
            assert main(argv) == 0, argv
        text = caplog.text
        assert "solving (gao, supports P1, 16 elements" in text, argv
        assert "newton: optimal" in text, argv
        caplog.clear()
    with caplog.at_level(logging.INFO):
        assert main(["sweep", str(scene_file), "--vary", "foundation.gap=0:0.01:3", "-v"]) == 0
    progress = [r.getMessage() for r in caplog.records if r.getMessage().startswith("sweep ")]
    assert [m.split("[")[1].split(",")[0] for m in progress] == ["1/3", "2/3", "3/3"]


def test_verbose_after_the_subcommand_is_accepted(scene_file, capsys):
    assert main(["solve", str(scene_file), "-vv"]) == 0
    assert main(["sweep", str(scene_file), "--vary", "foundation.gap=0:0.01:2", "-v"]) == 0
    assert main(["compare", str(scene_file), "--verbose"]) == 0


@pytest.mark.parametrize("spec, expected", [
    ("0:1.6:5", [0.0, 0.4, 0.8, 1.2, 1.6]),
    ("0:1:6", [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]),
    ("0.1:0.3:3", [0.1, 0.2, 0.3]),
    ("-1e9:1e9:5", [-1e9, -5e8, 0.0, 5e8, 1e9]),
    ("1e8:1e12:5:log", [1e8, 1e9, 1e10, 1e11, 1e12]),
    ("1:100:3:log", [1.0, 10.0, 100.0]),
    ("0:1:3", [0.0, 0.5, 1.0]),
])
def test_sweep_values_are_the_exact_grid(spec, expected):
    """Each value is the double nearest the exact grid point (the literal one would type)."""
    assert parse_range(spec).tolist() == expected


def test_sweep_json_values_without_float_noise(scene_file, capsys):
    assert main(["sweep", str(scene_file), "--vary", "load.scale=0:1.6:5", "--json"]) == 0
    values = [json.loads(line)["value"] for line in capsys.readouterr().out.splitlines()]
    assert values == [0.0, 0.4, 0.8, 1.2, 1.6]


def test_solve_docstring_lists_every_method():
    """help(gaocvx.solve) names each method a scene accepts (it once omitted "cvm")."""
    import gaocvx
    from gaocvx.scene import METHODS

    doc = gaocvx.solve.__doc__
    section = doc[doc.index("method :"):doc.index("elements :")]
    for method in METHODS:
        assert f'"{method}"' in section, method


def test_verbose_logs_the_progress_of_a_long_solve(caplog):
    """-v (INFO) shows the method of multipliers' updates inside one Newton solve."""
    import logging

    from gaocvx import load_scene, solve
    with caplog.at_level(logging.INFO, logger="gaocvx"):
        from pathlib import Path
        examples = Path(__file__).parent.parent / "examples"
        solve(load_scene(examples / "pinned_obstacle_point.toml"), "newton")
    updates = [r for r in caplog.records if "multiplier update" in r.getMessage()]
    assert len(updates) >= 2 and "feasibility" in updates[-1].getMessage()
