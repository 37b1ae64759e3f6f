"""Support reactions: closed forms, and global force and moment equilibrium.

Sign convention (Result.support_reactions): the force and moment a support
exerts on the beam, force positive up, moment counter-clockwise.  The
expected values come from statics (closed forms of textbooks, or the balance
of every force acting on the beam), never from the code's output.
"""

import json

import numpy as np
import pytest

from conftest import EI_THESIS, scene_dict
from gaocvx import Scene, solve
from gaocvx.cli import main

L = 2.0  # not 1: a missing length in a moment or a scale shows


def reactions(result):
    """{x: (force, moment)} of a result's supports."""
    return {s["x"]: (s["force"], s["moment"]) for s in result.support_reactions}


def _fixed_fixed_point(F, a):
    b = L - a
    return {0.0: (-F * b**2 * (3 * a + b) / L**3, -F * a * b**2 / L**2),
            L: (-F * a**2 * (a + 3 * b) / L**3, F * a**2 * b / L**2)}


def _propped_point(F, a):
    RL = -F * a**2 * (3 * L - a) / (2 * L**3)
    return {0.0: (-F - RL, -a * F - L * RL), L: (RL, 0.0)}


q, F, A = -5e7, -3e7, 0.7
CLOSED = {
    # supports, load: {x: (force, moment)}
    ("P4", "uniform"): {0.0: (-q * L / 2, 0.0), L: (-q * L / 2, 0.0)},
    ("P1", "uniform"): {0.0: (-q * L / 2, -q * L**2 / 12), L: (-q * L / 2, q * L**2 / 12)},
    ("P2", "uniform"): {0.0: (-5 * q * L / 8, -q * L**2 / 8), L: (-3 * q * L / 8, 0.0)},
    ("P3", "uniform"): {0.0: (-q * L, -q * L**2 / 2)},
    ("P4", "point"): {0.0: (-F * (L - A) / L, 0.0), L: (-F * A / L, 0.0)},
    ("P1", "point"): _fixed_fixed_point(F, A),
    ("P2", "point"): _propped_point(F, A),
    ("P3", "point"): {0.0: (-F, -F * A)},
}


@pytest.mark.parametrize("supports, load", sorted(CLOSED))
@pytest.mark.parametrize("method", ["newton", "convex"])
def test_closed_forms(supports, load, method):
    kw = dict(q=q) if load == "uniform" else dict(q=None, points=[(A, F)])
    r = solve(Scene.from_dict(scene_dict(supports, "euler-bernoulli", length=L, elements=8,
                                         **kw)), method)
    assert r.success, r.message
    expected = CLOSED[(supports, load)]
    got = reactions(r)
    assert sorted(got) == sorted(expected)
    scale = abs(q * L) if load == "uniform" else abs(F)
    tol = 1e-10 if method == "newton" else 1e-6   # Clarabel's tolerance, not round-off
    for x, (force, moment) in expected.items():
        assert got[x][0] == pytest.approx(force, abs=tol * scale), x
        assert got[x][1] == pytest.approx(moment, abs=tol * scale * L), x


def test_pinned_end_carries_no_moment_and_free_end_no_reaction():
    r = solve(Scene.from_dict(scene_dict("P2", "euler-bernoulli", elements=8)))
    assert r.support_reactions[1]["moment"] == 0.0 and r.support_reactions[1]["x"] == 1.0
    r = solve(Scene.from_dict(scene_dict("P3", "euler-bernoulli", elements=8)))
    assert [s["x"] for s in r.support_reactions] == [0.0]


@pytest.mark.parametrize("elements", [1, 3, 16])
def test_shear_is_linear_and_moment_parabolic_under_uniform_load(elements):
    """Simply supported EB beam under q: V = q (x - L/2) and M = -q x (L - x) / 2 at any x.

    The cubic's own third derivative would be a staircase (constant per
    element); element equilibrium gives the exact line on any mesh, to round-off.
    """
    r = solve(Scene.from_dict(scene_dict("P4", "euler-bernoulli", length=L, q=q,
                                         elements=elements)))
    xs = np.r_[0.0, np.random.default_rng(1).uniform(0, L, 200), L]
    V, M = q * (xs - L / 2), -q * xs * (L - xs) / 2
    assert np.abs(r.shear(xs) - V).max() <= 1e-10 * abs(q * L / 2)
    assert np.abs(r.moment(xs) - M).max() <= 1e-10 * abs(q * L**2 / 8)


# ------------------------------------------------------------------ equilibrium
def _gauss(x, n=5):
    t, wt = np.polynomial.legendre.leggauss(n)
    h = np.diff(x)
    xq = (x[:-1, None] + h[:, None] * (t + 1) / 2).ravel()
    return xq, (h[:, None] * wt / 2).ravel()


def _q_resultants(table):
    """∫ q and ∫ x q of a piecewise-linear table (zero outside it), by the trapezoid rule's exact form."""
    t = np.asarray(table, float)
    x0, x1, q0, q1 = t[:-1, 0], t[1:, 0], t[:-1, 1], t[1:, 1]
    d = x1 - x0
    force = np.sum(d * (q0 + q1) / 2)
    moment = np.sum(d / 6 * (q0 * (2 * x0 + x1) + q1 * (x0 + 2 * x1)))
    return force, moment


def _table_at(value, x):
    """A number, or a piecewise-linear table [[x, v], ...] (constant beyond its ends)."""
    if np.ndim(value) == 0:
        return value
    t = np.asarray(value, float)
    return np.interp(x, t[:, 0], t[:, 1])


def applied(result):
    """Resultant force and moment about x = 0 of everything but the supports (physical units).

    The foundation's pressure is integrated with the discrete problem's own
    rule (5 Gauss points per element), the obstacle's forces are the reported
    contact forces.
    """
    scene = result.scene
    load = scene.load
    force = moment = 0.0
    if load.q is not None:
        table = load.q if load.is_table else [(0.0, load.q), (scene.beam.length, load.q)]
        force, moment = _q_resultants(table)
    for xk, Fk in load.points:
        force, moment = force + Fk, moment + xk * Fk
    if scene.contact == "foundation":
        xq, wq = _gauss(result.x)
        fd = scene.foundation
        depth = -_table_at(fd.gap, xq) - result.deflection(xq)
        p = _table_at(fd.stiffness, xq) * (depth if fd.kind == "bilateral" else np.maximum(depth, 0))
        force, moment = force + wq @ p, moment + wq @ (xq * p)
    elif scene.contact == "obstacle":
        cf = result.contact_forces
        force, moment = force + cf[:, 1].sum(), moment + cf[:, 0] @ cf[:, 1]
    return force, moment


def support_resultant(result):
    s = result.support_reactions
    return sum(r["force"] for r in s), sum(r["x"] * r["force"] + r["moment"] for r in s)


def scale_of(result):
    """The size of the forces acting: sum of |loads| and |contact forces|."""
    load = result.scene.load
    total = sum(abs(Fk) for _, Fk in load.points)
    if load.q is not None:
        t = np.asarray(load.q if load.is_table else [(0, load.q), (L, load.q)], float)
        total += np.sum(np.diff(t[:, 0]) * (np.abs(t[:-1, 1]) + np.abs(t[1:, 1])) / 2)
    if result.contact_forces is not None:
        total += np.abs(result.contact_forces[:, 1]).sum()
    if result.reaction is not None and result.scene.contact == "foundation":
        total += np.abs(result.reaction).max() * L
    return total


# Every load kind at once: a partial table, point forces at a node, between nodes
# (two forces 1e-4 apart share one node, so the second acts inside an element),
# on a support and at the free end.
MIXED = dict(q=[[0.1, -2e7], [0.9, -6e7], [1.6, -1e7]],
             points=[(0.5, -2e7), (1.3, -1e7), (1.3001, -1.5e7), (0.0, -4e6), (L, -3e6)])
CONTACTS = {"none": {}, "foundation": {"foundation": (0.004, 5e9)}, "obstacle": {"obstacle": 0.004}}


@pytest.mark.parametrize("contact", sorted(CONTACTS))
@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
def test_equilibrium_euler_bernoulli(supports, contact):
    """EB, P = 0: supports + loads + foundation/obstacle forces balance exactly."""
    r = solve(Scene.from_dict(scene_dict(supports, "euler-bernoulli", length=L, elements=16,
                                         **MIXED, **CONTACTS[contact])))
    assert r.success, r.message
    if contact != "none":
        assert r.zones, "the scene should touch its foundation or obstacle"
    f_app, m_app = applied(r)
    f_sup, m_sup = support_resultant(r)
    scale = scale_of(r)
    assert abs(f_sup + f_app) <= 1e-10 * scale
    assert abs(m_sup + m_app) <= 1e-10 * scale * L


@pytest.mark.parametrize("supports", ["P1", "P3", "P4"])
def test_equilibrium_on_a_bonded_foundation(supports):
    """A bonded foundation pulls where the beam is above its surface: that counts too."""
    d = scene_dict(supports, "euler-bernoulli", length=L, elements=16, **MIXED)
    d["foundation"] = {"gap": 0.0005, "stiffness": 5e9, "kind": "bilateral"}
    r = solve(Scene.from_dict(d))
    assert r.success, r.message
    xq = _gauss(r.x)[0]
    assert (r.deflection(xq) > -0.0005).any() and (r.deflection(xq) < -0.0005).any()
    f_app, m_app = applied(r)
    f_sup, m_sup = support_resultant(r)
    assert abs(f_sup + f_app) <= 1e-10 * scale_of(r)
    assert abs(m_sup + m_app) <= 1e-10 * scale_of(r) * L


@pytest.mark.parametrize("supports", ["P2", "P3"])
def test_equilibrium_with_profiles_and_a_channel(supports):
    """A foundation with a gap and a stiffness table, and an obstacle channel pushing down too."""
    d = scene_dict(supports, "euler-bernoulli", length=L, elements=16, **MIXED)
    d["foundation"] = {"gap": [[0.0, 0.001], [1.0, 0.0002], [L, 0.003]],
                       "stiffness": [[0.2, 1e9], [1.5, 8e9]]}
    r = solve(Scene.from_dict(d))
    assert r.success and r.zones, r.message
    f_app, m_app = applied(r)
    f_sup, m_sup = support_resultant(r)
    assert abs(f_sup + f_app) <= 1e-10 * scale_of(r)
    assert abs(m_sup + m_app) <= 1e-10 * scale_of(r) * L
    d = scene_dict(supports, "euler-bernoulli", length=L, q=None, elements=16,
                   points=[(0.6, -6e7), (1.4, 6e7)])
    d["obstacle"] = {"gap": 0.001, "gap_above": 0.0005}
    r = solve(Scene.from_dict(d))
    assert r.success, r.message
    assert (r.contact_forces[:, 1] < 0).any()   # the upper surface pushes down
    f_app, m_app = applied(r)
    f_sup, m_sup = support_resultant(r)
    assert abs(f_sup + f_app) <= 1e-10 * scale_of(r)
    assert abs(m_sup + m_app) <= 1e-10 * scale_of(r) * L


def test_equilibrium_is_not_vacuous():
    """The check above sees a wrong reaction: a support force off by 1e-8 of the load fails it."""
    r = solve(Scene.from_dict(scene_dict("P1", "euler-bernoulli", length=L, elements=16, **MIXED)))
    f_app, _ = applied(r)
    f_sup, _ = support_resultant(r)
    assert abs(f_sup + 1e-8 * scale_of(r) + f_app) > 1e-10 * scale_of(r)


def gao_moment_terms(result):
    """[(E_alpha/3) ∫ w'^3 - P mu (w(L) - w(0))] / (1 - nu^2): what the moment balance leaves (docs/model.md)."""
    beam = result.scene.beam
    xq, wq = _gauss(result.x)
    cubes = wq @ result.slope_at(xq) ** 3   # exact: w'^3 is a polynomial of degree 6
    dw = result.deflection(beam.length) - result.deflection(0.0)
    return (beam.E_alpha_eff / 3 * cubes - result.scene.load.axial * beam.mu_eff * dw) / beam.load_factor


@pytest.mark.parametrize("model, supports, fraction, contact, gap", [
    ("gao", "P1", 0.0, "none", None), ("gao", "P3", 0.0, "foundation", 0.05),
    ("gao", "P3", 0.6, "none", None), ("euler-bernoulli", "P3", 0.6, "none", None),
    ("euler-bernoulli", "P3", -2.0, "obstacle", 0.005), ("gao", "P2", 0.5, "obstacle", 0.05),
    ("gao", "P4", -1.0, "foundation", 0.05),
])
def test_equilibrium_with_axial_force_and_gao_term(model, supports, fraction, contact, gap):
    """Force balance holds as for EB; the moment balance gains (E_alpha/3)∫w'^3 - P mu [w]_0^L.

    Loads are big enough that the Gao term matters (slopes 0.2-0.5); P is a
    fraction of the beam's own P_bar_h (negative: tension).
    """
    from gaocvx import DiscreteProblem

    kw = dict(length=L, elements=16, q=-2e9 if model == "gao" else -5e6,
              points=[(1.3, -5e8 if model == "gao" else -1e6)])
    if contact == "foundation":
        kw["foundation"] = (gap, 5e9)
    elif contact == "obstacle":
        kw["obstacle"] = gap
    probe = DiscreteProblem(Scene.from_dict(scene_dict(supports, model, **kw)))
    r = solve(Scene.from_dict(scene_dict(supports, model, axial=fraction * probe.P_bar_h, **kw)))
    assert r.success, r.message
    if contact != "none":
        assert r.zones, "the scene should touch its foundation or obstacle"
    f_app, m_app = applied(r)
    f_sup, m_sup = support_resultant(r)
    scale = scale_of(r)
    extra = gao_moment_terms(r)
    assert abs(f_sup + f_app) <= 1e-10 * scale
    assert abs(m_sup + m_app - extra) <= 1e-10 * scale * L
    # The extra terms are real (1e-4 to 0.5 of the scale here): without them the balance fails.
    assert abs(extra) > 1e-4 * scale * L


@pytest.mark.parametrize("supports, fraction", [("P4", 1.3), ("P3", 1.5)])
def test_equilibrium_of_a_buckled_beam(supports, fraction):
    """Above P_bar_h (the global method): the same two balances hold for the buckled answer."""
    from gaocvx import DiscreteProblem

    kw = dict(length=L, elements=16, q=-2e7, points=[(1.3, -5e6)])
    probe = DiscreteProblem(Scene.from_dict(scene_dict(supports, "gao", **kw)))
    r = solve(Scene.from_dict(scene_dict(supports, "gao", axial=fraction * probe.P_bar_h, **kw)))
    assert r.success and r.method == "global", (r.method, r.message)
    f_app, m_app = applied(r)
    f_sup, m_sup = support_resultant(r)
    extra = gao_moment_terms(r)
    assert abs(f_sup + f_app) <= 1e-10 * scale_of(r)
    assert abs(m_sup + m_app - extra) <= 1e-10 * scale_of(r) * L
    assert abs(extra) > 1e-3 * scale_of(r) * L


def test_gao_reactions_balance_the_loads_as_given():
    """The Gao model scales loads by (1 - nu^2); its reactions are divided back (cantilever: R = -q L)."""
    r = solve(Scene.from_dict(scene_dict("P3", "gao", length=L, q=-5e7, elements=16)))
    assert r.support_reactions[0]["force"] == pytest.approx(5e7 * L, rel=1e-10)


# ------------------------------------------------------------------ output
def test_json_and_summary(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(f"""
[beam]
model = "euler-bernoulli"
supports = "P1"
length = {L}
EI = {EI_THESIS}
[load]
q = {q}
[mesh]
elements = 8
""")
    assert main(["solve", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    sr = data["support_reactions"]
    assert [s["x"] for s in sr] == [0.0, L]
    assert sr[0]["force"] == pytest.approx(-q * L / 2, rel=1e-10)
    assert sr[1]["moment"] == pytest.approx(q * L**2 / 12, rel=1e-10)
    assert main(["solve", str(path)]) == 0
    out = capsys.readouterr().out
    line = next(s for s in out.splitlines() if s.startswith("supports"))
    assert f"{-q * L / 2:.6g} N" in line and f"{-q * L**2 / 12:.6g} N m" in line


def test_json_has_no_negative_zero(tmp_path, capsys):
    """An unloaded beam's energy parts include -0.0 (the load term -f'u); the JSON says 0.0."""
    path = tmp_path / "s.toml"
    path.write_text("""
[beam]
model = "euler-bernoulli"
supports = "P4"
length = 1.0
EI = 1.0
[load]
q = -0.0
points = [[0.5, 0.0]]
[mesh]
elements = 4
""")
    from gaocvx import load_scene

    raw = json.dumps(solve(load_scene(path)).to_dict(), default=lambda v: v.tolist())
    assert "-0.0" in raw   # the case exists ...
    assert main(["solve", str(path), "--json"]) == 0
    text = capsys.readouterr().out
    assert "-0.0" not in text   # ... and the command line writes it as 0.0
    assert json.loads(text)["energy_parts"]["load"] == 0.0


def test_example_states_its_elements_and_exact_reactions():
    """examples/clamped_pinned_table_points.toml: 33 elements (a node inserted at x = 0.8) and
    the reactions of the exact beam, R = EI w'''(0), M = -EI w''(0), R_L = -EI w'''(L)."""
    from pathlib import Path

    from exact import ExactBeam
    from gaocvx import load_scene

    path = Path(__file__).parent.parent / "examples" / "clamped_pinned_table_points.toml"
    comment = path.read_text()
    r = solve(load_scene(path))
    assert len(r.x) - 1 == 33 and "33\n# elements" in comment and 0.8 in r.x
    ex = ExactBeam("P2", 1.0, EI_THESIS, [[0.0, 0.0], [0.5, -6e7], [1.0, 0.0]],
                   [(0.25, -2e7), (0.8, 1e7)])
    exact = {0.0: (EI_THESIS * ex(0.0, 3)[0], -EI_THESIS * ex(0.0, 2)[0]),
             1.0: (-EI_THESIS * ex(1.0, 3)[0], 0.0)}
    for x, (force, moment) in exact.items():
        got = reactions(r)[x]
        assert got[0] == pytest.approx(force, rel=1e-10)
        assert got[1] == pytest.approx(moment, rel=1e-10, abs=1e-10 * abs(force))
    for text in ("3.50087e7 N", "7.00875e6 N m", "4.99125e6 N"):
        assert text in comment
