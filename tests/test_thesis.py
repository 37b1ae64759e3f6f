"""Reproduce the thesis's published cases (tests/data/thesis_cases.json).

Tolerances are those reference-cases.md reports for an independent convex
implementation; the few places where the thesis disagrees with its own model
are listed in KNOWN with the reason, and are asserted to *disagree* (so the
list cannot hide a regression either way).
"""

import pytest

from conftest import THESIS, scene_dict
from gaocvx import Scene, solve

ELEMENT = 1.0 / 32
PRINT = 5e-4  # positions and zone ends are printed with three decimals

# (table, model, quantity) -> why the thesis's printed number is not reproduced.
KNOWN = {
    ("4.7b", "gao", "energy"): "printed -1.167e6 J; the energy of the printed deflection is -1.289e6 J",
    ("4.13b", "euler-bernoulli", "energy"): "printed -1.202e6 J while its deflection and contact "
                                            "zone match ours exactly; our energy is -1.2138e6 J",
    ("4.13b", "gao", "zone"): "printed zone [0.375; 0.594] is asymmetric for a symmetric problem",
    # The printed deflections of 4.2a/b are those of mu = 1 (like every P != 0 case on
    # supports P1, P2, P4), but the printed energies are those of mu = 1.183: see
    # test_thesis_mixed_mu_in_table_4_2.
    ("4.2a", "gao", "energy"): "energy of mu = 1.183 printed beside a deflection of mu = 1",
    ("4.2b", "gao", "energy"): "energy of mu = 1.183 printed beside a deflection of mu = 1",
}


def _cases():
    for case in THESIS["cases"]:
        for model in ("euler-bernoulli", "gao"):
            yield pytest.param(case, model, id=f"{case['table']}-{model}")


def build(case, model, mu=None):
    sc = case["scene"]
    load = sc["load"]
    found = sc.get("foundation")
    extra = {} if mu is None else {"mu": mu}
    d = scene_dict(sc["supports"], model, q=load["q"], points=load["points"],
                   axial=load["axial"],
                   foundation=None if found is None else (found["gap"], found["stiffness"]),
                   **extra)
    return Scene.from_dict(d)


def tolerances(case, model):
    """Relative tolerance on extrema and energies, per reference-cases.md."""
    sc = case["scene"]
    if model == "euler-bernoulli":
        return 6e-3, 1.5e-3    # "within 0.1 %": measured up to 0.11 % (4.21a)
    if "foundation" in sc:
        return 1e-2, 5e-3      # "agree less well (up to a few %)": measured <= 0.7 %
    if sc["load"]["axial"] and sc["supports"] != "P3":
        return 1.5e-3, 1e-3    # with mu = 1 ("within 0.1 %"; measured up to 0.12 %)
    return 5e-3, 5e-3          # "every extremum within 0.5 %"


def thesis_mu(case, model):
    """The thesis's computations used mu = 1 for P != 0 with supports P1, P2, P4."""
    sc = case["scene"]
    if model == "gao" and sc["load"]["axial"] and sc["supports"] != "P3":
        return 1.0
    return None


@pytest.mark.parametrize("case, model", list(_cases()))
def test_reproduces_thesis(case, model):
    published = case["thesis"][model]
    result = solve(build(case, model, thesis_mu(case, model)), "convex")
    assert result.success, result.message
    rel_w, rel_e = tolerances(case, model)
    table = case["table"]
    for key in ("min", "max"):
        if key in published:
            ours = getattr(result, key)
            assert ours["w"] == pytest.approx(published[key]["w"], rel=rel_w), key
            same_node = abs(ours["x"] - published[key]["x"]) <= PRINT
            assert same_node or model == "gao" and abs(ours["x"] - published[key]["x"]) <= ELEMENT
    energy_ok = result.energy == pytest.approx(published["energy"], rel=rel_e)
    assert energy_ok != ((table, model, "energy") in KNOWN), (result.energy, published["energy"])
    if "contact_zone" in published:
        assert len(result.zones) == 1
        slack = PRINT if model == "euler-bernoulli" else ELEMENT + PRINT
        zone_ok = all(abs(a - b) <= slack for a, b in zip(result.zones[0], published["contact_zone"]))
        if (table, model, "zone") in KNOWN:
            a, b = result.zones[0]
            assert a + b == pytest.approx(1.0)  # ours is symmetric
        else:
            assert zone_ok, (result.zones, published["contact_zone"])


@pytest.mark.parametrize("case", [c for c in THESIS["cases"] if c["scene"]["load"]["axial"]
                                  and c["scene"]["supports"] != "P3"],
                         ids=lambda c: c["table"])
def test_thesis_used_mu_one(case):
    """The finding of reference-cases.md: mu = 1 reproduces the Gao numbers, the model's mu does not."""
    published = case["thesis"]["gao"]["min"]["w"]
    model_mu = solve(build(case, "gao"), "convex").min["w"]
    unit_mu = solve(build(case, "gao", mu=1.0), "convex").min["w"]
    assert abs(unit_mu / published - 1) < 1.5e-3
    assert abs(model_mu / published - 1) > 2.5e-3


@pytest.mark.parametrize("table", ["4.2a", "4.2b"])
def test_thesis_mixed_mu_in_table_4_2(table):
    """Table 4.2's Gao deflection is reproduced with mu = 1, its energy with mu = 1.183."""
    case = next(c for c in THESIS["cases"] if c["table"] == table)
    published = case["thesis"]["gao"]
    unit_mu = solve(build(case, "gao", mu=1.0), "convex")
    model_mu = solve(build(case, "gao"), "convex")
    assert unit_mu.min["w"] == pytest.approx(published["min"]["w"], rel=1e-3)
    assert model_mu.energy == pytest.approx(published["energy"], rel=1e-3)
    assert unit_mu.energy != pytest.approx(published["energy"], rel=2.5e-3)
