"""Sweeps of several keys over a grid (a stiffness-gap map), from Python and the command line."""

import csv
import functools
import json

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from conftest import FOUNDATION_TOML, scene_dict  # noqa: E402
from gaocvx import Scene, SceneError, solve  # noqa: E402
from gaocvx.cli import main  # noqa: E402
from gaocvx.sweep import grid, parse_range, scene_at, summary_row, sweep  # noqa: E402
from gaocvx.sweep_plot import sweep_map_figure  # noqa: E402

KEYS = ("foundation.stiffness", "foundation.gap")


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(FOUNDATION_TOML + "[mesh]\nelements = 16\n")
    return path


@pytest.fixture(scope="module")
def base():
    return Scene.from_dict(scene_dict(foundation=(0.007, 5e8), q=-5e8, elements=16))


def test_grid_points_every_combination_first_axis_outermost():
    a, b = [1.0, 2.0, 3.0], [10.0, 20.0]
    points = grid(a, b)
    assert points.shape == (6, 2)
    assert [tuple(p) for p in points] == [(x, y) for x in a for y in b]
    assert grid([5.0]).tolist() == [[5.0]]
    with pytest.raises(ValueError):
        grid()


def test_map_physics(base):
    """Stiffer beds let the beam sink less; a deeper bed is touched over a shorter length."""
    stiff, gaps = parse_range("1e8:1e13:5:log"), parse_range("0.001:0.006:4")
    rows = [summary_row(v, r, KEYS) for v, r in sweep(base, KEYS, grid(stiff, gaps))]
    assert all(r["status"] == "optimal" for r in rows)
    pen = np.array([r["penetration"] for r in rows]).reshape(len(stiff), len(gaps))
    length = np.array([r["contact_length"] for r in rows]).reshape(len(stiff), len(gaps))
    assert np.all(np.diff(pen, axis=0) < 0)      # along the stiffness, at every gap
    assert np.all(np.diff(length, axis=1) <= 0)  # along the gap, at every stiffness
    assert np.all(length[:, 0] > 0)


def test_grid_values_are_the_points_and_each_answer_the_scene_at_it(base):
    points = grid(parse_range("1e9:1e11:2:log"), parse_range("0.002:0.006:3"))
    items = list(sweep(base, KEYS, points))
    assert [v for v, _ in items] == [tuple(p) for p in points]
    for (k, g), r in items:
        assert r.scene.foundation.stiffness == k and r.scene.foundation.gap == g
        alone = solve(scene_at(base, KEYS, (k, g)))   # a cold solve of the same scene
        assert np.max(np.abs(r.w - alone.w)) <= 1e-8 * np.max(np.abs(alone.w))


def test_load_scale_in_a_grid_scales_the_loads_of_the_point(base):
    (value, r), = sweep(base, ("load.scale", "foundation.gap"), [[2.0, 0.004]])
    assert value == (2.0, 0.004)
    assert r.scene.load.q == 2.0 * base.load.q and r.scene.foundation.gap == 0.004
    # with load.q varied too, the scale applies to the point's q, whatever the order
    for keys, point in ((("load.scale", "load.q"), (2.0, -1e7)), (("load.q", "load.scale"),
                                                                 (-1e7, 2.0))):
        assert scene_at(base, keys, point).load.q == -2e7, keys


def test_bad_jobs_and_too_large_grids_are_refused(base, scene_file, capsys):
    for jobs in (0, -1, 1.5):
        with pytest.raises(SceneError, match="^--jobs"):
            list(sweep(base, "foundation.gap", [0.002], jobs=jobs))
    big = ["--vary", "foundation.stiffness=1e8:1e9:100000", "--vary", "foundation.gap=0:0.01:100"]
    assert main(["sweep", str(scene_file), *big]) == 2    # refused before 10^7 points are made
    assert capsys.readouterr().err.strip().startswith("error: --vary: a grid of at most 10^6")


def test_parallel_reduced_grid_matches_serial(base):
    points = grid(parse_range("1e8:1e12:3:log"), parse_range("0.002:0.006:3"))
    reduce = functools.partial(summary_row, keys=KEYS)
    serial = [row for _, row in sweep(base, KEYS, points, reduce=reduce)]
    parallel = [row for _, row in sweep(base, KEYS, points, jobs=2, reduce=reduce)]
    assert [r[KEYS[0]] for r in parallel] == [r[KEYS[0]] for r in serial]
    assert [r["min_w"] for r in parallel] == pytest.approx([r["min_w"] for r in serial],
                                                           rel=1e-9)


@pytest.mark.parametrize("keys, points, bad", [
    (("foundation.gap", "foundation.gap"), [[0.001, 0.002]], "foundation.gap"),
    (("foundation.gap", "mesh.elements"), [[0.001, 8]], "mesh.elements"),
    (KEYS, [[1e9, 0.001, 3.0]], "--vary"),
    (KEYS, [1e9, 0.001], "--vary"),
])
def test_bad_grids_name_the_key(base, keys, points, bad):
    with pytest.raises(SceneError, match=f"^{bad}"):
        list(sweep(base, keys, points))


def test_cli_map_csv_json_and_picture(tmp_path, scene_file, capsys):
    csv_path, png = tmp_path / "m.csv", tmp_path / "m.png"
    argv = ["sweep", str(scene_file), "--vary", "foundation.stiffness=1e8:1e12:3:log",
            "--vary", "foundation.gap=0.002:0.006:2"]
    assert main([*argv, "--csv", str(csv_path), "--plot", str(png)]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[0].split()[:3] == ["foundation.stiffness", "foundation.gap", "status"]
    assert len(table) == 1 + 6
    rows = list(csv.DictReader(csv_path.open()))
    assert list(rows[0])[:3] == ["foundation.stiffness", "foundation.gap", "status"]
    assert [(float(r["foundation.stiffness"]), float(r["foundation.gap"])) for r in rows] == \
        [(k, g) for k in (1e8, 1e10, 1e12) for g in (0.002, 0.006)]
    assert all(r["status"] == "optimal" for r in rows)
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert main([*argv, "--json"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [line["key"] for line in lines] == [list(KEYS)] * 6
    assert lines[1]["value"] == [1e8, 0.006] and lines[1]["status"] == "optimal"
    assert lines[1]["min"]["w"] == pytest.approx(float(rows[1]["min_w"]), rel=1e-12)


def test_cli_map_needs_two_keys_and_distinct_ones(tmp_path, scene_file, capsys):
    three = ["--vary", "foundation.stiffness=1e8:1e9:2", "--vary", "foundation.gap=0:0.01:2",
             "--vary", "load.scale=1:2:2"]
    assert main(["sweep", str(scene_file), *three, "--plot", str(tmp_path / "m.png")]) == 2
    assert capsys.readouterr().err.strip().startswith("error: --plot: a map needs exactly two")
    assert main(["sweep", str(scene_file), *three]) == 0    # without a picture: fine
    capsys.readouterr()
    assert main(["sweep", str(scene_file), "--vary", "foundation.gap=0:0.01:2",
                 "--vary", "foundation.gap=0:0.02:2"]) == 2
    assert capsys.readouterr().err.strip().startswith("error: foundation.gap: is varied twice")


def test_map_leaves_points_not_certified_blank_and_marks_them():
    rows = [{KEYS[0]: k, KEYS[1]: g, "status": "optimal", "min_w": -0.01 * k, "max_w": 0.0,
             "energy": -k, "contact_length": g} for k in (1.0, 2.0) for g in (3.0, 4.0)]
    rows[3]["status"] = "inaccurate"
    fig = sweep_map_figure(rows, KEYS)
    ax = fig.axes[0]
    cells = ax.collections[0].get_array()
    assert np.ma.count_masked(cells) + int(np.isnan(np.ma.filled(cells, 0.0)).sum()) == 1
    marked = [line for line in ax.lines if line.get_label() == "not optimal"]
    assert marked and list(marked[0].get_xdata()) == [2.0] and list(marked[0].get_ydata()) == [4.0]
    matplotlib.pyplot.close(fig)


def _blas_threads():
    from threadpoolctl import threadpool_info
    return {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}


def _threads_in_solve(value, item):
    return item.extra["blas_threads"]


@pytest.mark.parametrize("jobs", [1, 2])
def test_values_are_solved_on_one_blas_thread(base, monkeypatch, jobs):
    """BLAS threads only contend with the solvers' O(N) work: each value is solved on
    one, and the limit does not outlive the solve (it once spanned the generator's
    yields, and interleaved sweeps left BLAS on one thread for good; found by a review)."""
    import gaocvx.sweep as sweep_module
    for variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.delenv(variable, raising=False)
    real = sweep_module.solve

    def recording(*args, **kwargs):
        result = real(*args, **kwargs)
        result.extra["blas_threads"] = _blas_threads()
        return result

    monkeypatch.setattr(sweep_module, "solve", recording)   # inherited by forked workers
    before = _blas_threads()
    seen = [t for _, t in sweep(base, "foundation.gap", [0.002, 0.004], jobs=jobs,
                                reduce=_threads_in_solve)]
    assert seen and all(t == {1} for t in seen), seen
    one, two = (sweep(base, "foundation.gap", [0.002, 0.004]) for _ in range(2))
    next(one), next(two)
    assert _blas_threads() == before        # between values: the user's own setting
    list(one), list(two)
    assert _blas_threads() == before


def test_map_cells_are_centred_on_their_values_and_one_value_axes_are_drawn():
    """Found by a new-user trial: on a log axis the cells were centred on the linear
    midpoints (the first column cut off), and a one-value axis drew no cells at all."""
    def rows(ks, gs):
        return [{KEYS[0]: k, KEYS[1]: g, "status": "optimal", "min_w": -g, "max_w": 0.0,
                 "energy": -k, "contact_length": g} for k in ks for g in gs]

    ks = [1e8, 1e9, 1e10]
    fig = sweep_map_figure(rows(ks, [0.002, 0.004]), KEYS, log=(True, False))
    ax = fig.axes[0]
    x_edges = np.unique(ax.collections[0].get_coordinates()[..., 0])
    centres = np.sqrt(x_edges[1:] * x_edges[:-1])        # geometric centres of the cells
    assert centres.tolist() == pytest.approx(ks, rel=1e-9)
    assert ax.get_xlim()[0] < 1e8 < ax.get_xlim()[1]
    matplotlib.pyplot.close(fig)
    fig = sweep_map_figure(rows(ks, [0.003]), KEYS, log=(True, False))
    cells = fig.axes[0].collections[0].get_array()
    assert np.ma.count(cells) == 3 and np.all(np.isfinite(np.ma.compressed(cells)))
    matplotlib.pyplot.close(fig)


def test_an_axial_sweep_goes_through_the_convexity_limit():
    """Values at or above P_bar_h are solved by the global method, as solve() does (a
    new-user trial found them refused); below, as before."""
    scene = Scene.from_dict(scene_dict("P4", foundation=(0.005, 1e10), q=-3e7, elements=12))
    items = list(sweep(scene, "load.axial", [5e8, 1.5e9]))
    (_, below), (_, above) = items
    assert below.status == above.status == "optimal"
    assert below.method == "newton" and above.method == "global"
    assert above.problem.P_bar_h < 1.5e9 and above.extra["global"]["unstable_modes"] == 1
    # buckled: below the straight beam's energy and the convex answer's just below the limit
    assert above.energy < below.energy
