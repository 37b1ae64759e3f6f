import copy
import json
import math
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))  # for tests/exact.py

# A copy of the thesis's published tables (reference-cases.md), shipped with the package.
THESIS = json.loads((HERE.parent / "gaocvx" / "data" / "thesis_cases.json").read_text())

# The thesis's beam (reference-cases.md): L = 1, h = 0.1, b = 1, nu = 0.3, E = 2.1e11.
THESIS_BEAM = {"length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1, "width": 1.0}
EI_THESIS = 2.1e11 * (2.0 / 3.0) * 0.1**3 * 1.0


def scene_dict(supports="P1", model="gao", q=-5e7, points=(), axial=0.0, foundation=None,
               obstacle=None, elements=32, **beam):
    """A scene dict on the thesis's beam."""
    d = {
        "beam": {"model": model, "supports": supports, **THESIS_BEAM, **beam},
        "load": {"axial": axial, "points": [list(p) for p in points]},
        "mesh": {"elements": elements},
    }
    if q is not None:
        d["load"]["q"] = q
    if foundation is not None:
        d["foundation"] = dict(zip(("gap", "stiffness"), foundation))
    if obstacle is not None:
        d["obstacle"] = {"gap": obstacle}
    return d


def compressed_scene(fraction, supports="P1", model="gao", **kw):
    """The scene of ``scene_dict`` under an axial force of ``fraction`` times its P_bar_h."""
    from gaocvx import DiscreteProblem, Scene

    probe = DiscreteProblem(Scene.from_dict(scene_dict(supports, model, **kw)))
    return Scene.from_dict(scene_dict(supports, model, axial=fraction * probe.P_bar_h, **kw))


def contact(kind, gap, stiffness=5e9) -> dict:
    """``scene_dict`` arguments for no contact (None), a foundation or a rigid obstacle."""
    if kind == "foundation":
        return {"foundation": (gap, stiffness)}
    return {"obstacle": gap} if kind == "obstacle" else {}


@pytest.fixture
def thesis_scene():
    return copy.deepcopy(scene_dict())


# A scene file of the thesis's beam on a foundation (table 4.13a), for CLI tests.
# A new-user trial's Euler-Bernoulli P4 beam: EI = 2.1e11 * 0.1 * 0.02^3 / 12 =
# 1.4e4 N m^2, L = 3 m, Euler load pi^2 EI / L^2 = 1.535e4 N (above it no minimiser).
TRIAL_EULER = math.pi**2 * (2.1e11 * 0.1 * 0.02**3 / 12) / 3.0**2


def trial_eb_toml(q: str) -> str:
    """The trial beam's scene file on 16 elements, with ``q`` as written in TOML."""
    return f"""[beam]
model = "euler-bernoulli"
supports = "P4"
length = 3.0
E = 2.1e11
nu = 0.3
half_thickness = 0.01
width = 0.1
[load]
q = {q}
[mesh]
elements = 16
"""


FOUNDATION_TOML = """
[beam]
model = "gao"
supports = "P1"
length = 1.0
E = 2.1e11
nu = 0.3
half_thickness = 0.1
width = 1.0

[load]
q = -5e8

[foundation]
gap = 0.007
stiffness = 5e8
"""


def bed_scene_above_the_limit(ratio=3.0, elements=256):
    """P1 under q = -1e7 N/m on a unilateral bed 5 mm below (1e10 N/m^2), at ``ratio``
    times its P_bar_h (k = 2 at 3): a node of its search once stalled at a box corner."""
    from gaocvx import DiscreteProblem, Scene
    data = {"beam": {"model": "gao", "supports": "P1", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"q": -1e7}, "mesh": {"elements": elements},
            "foundation": {"kind": "unilateral", "gap": 0.005, "stiffness": 1e10}}
    data["load"]["axial"] = ratio * DiscreteProblem(Scene.from_dict(data),
                                                    check_convexity=False).P_bar_h
    return data


@pytest.hookimpl(tryfirst=True)  # before ``-m`` selects by marker
def pytest_collection_modifyitems(items):
    """A test marked ``heavy`` is slow too: ``-m "not slow"`` leaves it out."""
    for item in items:
        if item.get_closest_marker("heavy") is not None:
            item.add_marker(pytest.mark.slow)
