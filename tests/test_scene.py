"""Scene validation: every bad value is a SceneError that names its key."""

import copy
import math

import pytest
from hypothesis import assume, given, settings, strategies as st

from conftest import scene_dict
from gaocvx import Scene, SceneError, load_scene
from gaocvx.scene import parse_set


def mutate(d, path, value):
    d = copy.deepcopy(d)
    section, key = path.split(".")
    d.setdefault(section, {})[key] = value
    return d


BAD = [
    ("beam.model", "timoshenko"),
    ("beam.supports", "P5"),
    ("beam.supports", 1),
    ("beam.length", 0.0),
    ("beam.length", -1.0),
    ("beam.length", math.inf),
    ("beam.E", math.nan),
    ("beam.E", "2.1e11"),
    ("beam.nu", 0.5),
    ("beam.nu", -0.1),
    ("beam.half_thickness", 0),
    ("beam.width", True),
    ("beam.EI", -1.0),
    ("beam.mu", 0.0),
    ("beam.E_alpha", -2.0),
    ("beam.colour", "red"),
    ("load.q", "heavy"),
    ("load.q", [[0.0, 1.0]]),
    ("load.q", [[0.0, 1.0], [0.0, 2.0]]),
    ("load.q", [[0.5, 1.0], [0.2, 2.0]]),
    ("load.q", [[0.0, 1.0], [1.5, 2.0]]),
    ("load.q", [[0.0, 1.0], [1.0]]),
    ("load.points", [[1.2, -5.0]]),
    ("load.points", [[-0.1, -5.0]]),
    ("load.points", [[0.5, math.nan]]),
    ("load.points", 5.0),
    ("load.axial", math.inf),
    ("load.torque", 1.0),
    ("foundation.gap", -0.001),
    ("foundation.stiffness", 0.0),
    ("obstacle.gap", -1.0),
    ("mesh.elements", 0),
    ("mesh.elements", 2.5),
    ("mesh.elements", "32"),
    ("solve.method", "magic"),
    ("solve.solver", "gurobi"),
]


@pytest.mark.parametrize("path, value", BAD)
def test_bad_value_names_its_key(path, value):
    d = mutate(scene_dict(foundation=(0.01, 1e9)) if path.startswith("foundation")
               else scene_dict(), path, value)
    with pytest.raises(SceneError) as info:
        Scene.from_dict(d)
    # The key named is the offending one (or an element of it, e.g. load.q[1][0]).
    assert info.value.key.startswith(path), (info.value.key, path)
    assert str(info.value).startswith(info.value.key + ": ")


def test_missing_and_conflicting():
    with pytest.raises(SceneError, match="^beam: missing"):
        Scene.from_dict({"load": {"q": 1.0}})
    d = scene_dict()
    del d["beam"]["supports"]
    with pytest.raises(SceneError, match="^beam.supports"):
        Scene.from_dict(d)
    d = scene_dict()
    del d["beam"]["nu"]
    with pytest.raises(SceneError, match="^beam.nu: missing"):
        Scene.from_dict(d)
    with pytest.raises(SceneError, match="^obstacle: a scene has either"):
        Scene.from_dict(scene_dict(foundation=(0.01, 1e9), obstacle=0.01))
    with pytest.raises(SceneError, match="^foundation.stiffness: missing"):
        Scene.from_dict({**scene_dict(), "foundation": {"gap": 0.01}})
    # the table as given is shown: what the missing key was to go with
    with pytest.raises(SceneError, match=r"^foundation.gap: missing \(got .*'stiffness'"):
        Scene.from_dict({**scene_dict(), "foundation": {"stiffness": 1e9}})
    with pytest.raises(SceneError, match="^beam.E_alpha: is not used"):
        Scene.from_dict(scene_dict(model="euler-bernoulli", E_alpha=1.0))
    with pytest.raises(SceneError, match="^extras: unknown key"):
        Scene.from_dict({**scene_dict(), "extras": {}})
    # a misspelt key is named with the key it was meant to be
    d = scene_dict()
    d["beam"]["lenght"] = d["beam"].pop("length")
    with pytest.raises(SceneError, match=r"^beam.lenght: unknown key \(did you mean 'length'\? "):
        Scene.from_dict(d)
    with pytest.raises(SceneError, match=r"^beam.colour: unknown key \(known: "):
        Scene.from_dict({**scene_dict(), "beam": {**scene_dict()["beam"], "colour": 1}})


@pytest.mark.parametrize("h", [5.6e102, 1e-120])
def test_derived_coefficients_must_be_representable(h):
    with pytest.raises(SceneError, match="^beam.EI: cannot be computed"):
        Scene.from_dict(mutate(scene_dict(), "beam.half_thickness", h))


def test_eb_needs_no_nu_and_overrides_work():
    d = scene_dict(model="euler-bernoulli")
    del d["beam"]["nu"]
    scene = Scene.from_dict(d)
    assert scene.beam.mu_eff == 1.0 and scene.beam.load_factor == 1.0
    assert scene.beam.E_alpha_eff == 0.0
    d = {"beam": {"model": "euler-bernoulli", "supports": "P4", "length": 2.0, "EI": 3.0e6}}
    assert Scene.from_dict(d).beam.EI_eff == 3.0e6


def test_gao_coefficients():
    beam = Scene.from_dict(scene_dict()).beam
    assert beam.EI_eff == pytest.approx(1.4e8)
    assert beam.E_alpha_eff == pytest.approx(2.1e11 * 3 * 0.1 * 1.0 * 0.91)
    assert beam.mu_eff == pytest.approx(1.3 * 0.91)
    assert beam.load_factor == pytest.approx(0.91)
    # physics.md: P_bar with the thesis data
    expected = {"P1": 4.672e9, "P2": 2.389e9, "P3": 2.920e8, "P4": 1.168e9}
    for supports, value in expected.items():
        b = Scene.from_dict(scene_dict(supports)).beam
        assert b.P_bar() == pytest.approx(value, rel=1e-3)


def test_round_trip_and_overrides(tmp_path):
    d = scene_dict(q=[[0.0, 0.0], [0.5, -1e7], [1.0, 0.0]], points=[(0.3, -1e6)],
                   foundation=(0.01, 1e9))
    scene = Scene.from_dict(d)
    assert Scene.from_dict(scene.to_dict()) == scene
    changed = scene.with_overrides({"foundation.stiffness": 5e12, "beam.supports": "P3"})
    assert changed.foundation.stiffness == 5e12 and changed.beam.supports == "P3"
    assert scene.foundation.stiffness == 1e9  # immutable original
    with pytest.raises(SceneError, match="^beam.nu"):
        scene.with_overrides({"beam.nu": 0.6})
    with pytest.raises(SceneError, match="^wing.span"):
        scene.with_overrides({"wing.span": 1.0})
    path = tmp_path / "s.toml"
    path.write_text('[beam]\nsupports = "P4"\nlength = 1.0\nE = 2.1e11\nnu = 0.3\n'
                    'half_thickness = 0.1\nwidth = 1.0\n[load]\nq = -5e7\n')
    s = load_scene(path, {"load.axial": 1e8})
    assert s.load.axial == 1e8 and s.beam.supports == "P4"
    path.write_text("[beam\n")
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(path)
    with pytest.raises(SceneError, match="cannot read"):
        load_scene(tmp_path / "missing.toml")


def test_parse_set():
    assert parse_set("beam.nu=0.25") == ("beam.nu", 0.25)
    assert parse_set("beam.model=euler-bernoulli") == ("beam.model", "euler-bernoulli")
    assert parse_set('beam.model="gao"') == ("beam.model", "gao")
    assert parse_set("load.points=[[0.5, -1e6]]") == ("load.points", [[0.5, -1e6]])
    with pytest.raises(SceneError):
        parse_set("beam.nu")
    with pytest.raises(SceneError):
        parse_set("load.q=[1,")


values = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6),
                   st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=5),
                   st.lists(st.lists(st.floats(allow_nan=True), max_size=3), max_size=3),
                   st.dictionaries(st.text(max_size=3), st.integers(), max_size=2))
keys = st.sampled_from(["beam.model", "beam.supports", "beam.length", "beam.E", "beam.nu",
                        "beam.half_thickness", "beam.width", "beam.EI", "beam.E_alpha",
                        "beam.mu", "load.q", "load.points", "load.axial", "foundation.gap",
                        "foundation.stiffness", "obstacle.gap", "mesh.elements", "solve.method",
                        "solve.solver", "beam.bogus", "load.bogus"])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(keys, values), min_size=1, max_size=4))
def test_random_input_never_crashes(changes):
    """Any mutation either validates or raises SceneError naming a real key."""
    d = scene_dict(elements=4)
    for path, value in changes:
        d = mutate(d, path, value)
    try:
        Scene.from_dict(d)
    except SceneError as exc:
        assert exc.key.split(".")[0].split("[")[0] in ("beam", "load", "foundation",
                                                       "obstacle", "mesh", "solve")


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(keys, values), min_size=1, max_size=3))
def test_random_input_never_crashes_the_cli(tmp_path_factory, changes):
    from gaocvx.cli import main
    d = scene_dict(elements=4)
    for path, value in changes:
        d = mutate(d, path, value)
    sets = [f"--set={p}={v!r}" for p, v in changes if isinstance(v, (int, float, str))
            and not isinstance(v, bool)]
    # (a valid mesh of up to 1e6 elements is solved, not refused: a draw of
    # mesh.elements = 999999 took over 10 min and 14 GB in the fast suite; the
    # cost of fine meshes is the benchmarks' concern, not this test's)
    assume(not any(p == "mesh.elements" and isinstance(v, (int, float)) and v > 2000
                   for p, v in changes))
    f = tmp_path_factory.mktemp("s") / "scene.toml"
    f.write_text('[beam]\nsupports = "P4"\nlength = 1.0\nE = 2.1e11\nnu = 0.3\n'
                 'half_thickness = 0.1\nwidth = 1.0\n[load]\nq = -5e7\n[mesh]\nelements = 4\n')
    assert main(["solve", str(f), "--json", *sets]) in (0, 1, 2)
