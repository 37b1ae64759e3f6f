"""A seeded random campaign above P_bar_h in the test suite (issue 10).

Scenes from tests/nonconvex_campaign_support.py's generator, solved by
``solve(scene, "global")`` and checked against the independent energy of
tests/nonconvex_independent.py by the rules of that module: a multi-start
local search (± each buckling mode, mixtures, the answer and its mirror image;
trust-region Newton, SLSQP with an obstacle) finds nothing below the certified
lower bound; an optimal minimiser is a KKT point and, without an obstacle, a
local minimum of the independent energy; reported mirror minimisers agree in
energy; refusals are justified; nothing crashes.  The larger campaign is
benchmarks/nonconvex_campaign.py (docs/nonconvex-campaign.md).

The seeded set was picked to cover every support, every contact model, load
tables, point forces, profiles, k = 1 and 2, and forces from just above the
limit to several times it, at under 20 s in all.  8:7, a bonded bed with k = 4,
was its refusal while the global method took three modes; solved now (optimal,
0 violations, about 90 s) it left the set to keep the suite's time: four and five
modes are tested in tests/test_nonconvex.py and tests/test_nonconvex_fast.py (and
the refusal of more than five), and campaigned in docs/nonconvex-campaign.md.
"""

import json
import logging

import numpy as np
import pytest

from nonconvex_campaign_support import MAX_MODES, random_scene, run_case

from gaocvx import Scene, solve
from gaocvx.nonconvex import minimum, obstacle_scale
from gaocvx.nonconvex.obstacle_scale import linear_on_obstacle

# (seed, index) of the generator, each on 8 or 12 elements as it draws them.
SEEDED = [(7, 0), (7, 1), (7, 2), (7, 4), (7, 6), (7, 8), (7, 9), (7, 10),
          (8, 2), (8, 5), (8, 8), (8, 23), (9, 13)]


def _case(seed, index):
    rng = np.random.default_rng([seed, index])
    case = random_scene(rng, elements=int(rng.choice([8, 12])))
    case.id = f"{seed}:{index}"
    return case


@pytest.mark.parametrize("seed, index", SEEDED, ids=[f"{s}:{i}" for s, i in SEEDED])
def test_seeded_scene_above_the_limit(seed, index):
    case = _case(seed, index)
    rec = run_case(case, starts=12, seed=index)
    assert not rec["violations"], (rec["violations"], json.dumps(case.data))
    # a Gao scene with at most MAX_MODES unstable modes is answered, and certified
    # (8:7, a bonded bed with k = 4, was refused while the limit was 3)
    if case.data["beam"]["model"] == "gao" and rec["k"] <= MAX_MODES:
        assert rec["status"] == "optimal", (rec.get("message"), json.dumps(case.data))


def test_seeded_set_covers_the_scene_space():
    tags = set()
    for seed, index in SEEDED:
        tags |= set(_case(seed, index).tags)
    assert tags >= {"P1", "P2", "P3", "P4", "none", "foundation", "bonded", "obstacle", "channel",
                    "table", "points", "profile", "near-limit", "far-above", "euler-bernoulli"}


def test_default_mesh():
    """32 elements (the default mesh): P2 with one unstable mode, P1 with two."""
    for index in (2, 4):
        rng = np.random.default_rng([7, index])
        case = random_scene(rng, elements=32)
        rec = run_case(case, starts=12, seed=index)
        assert not rec["violations"], (rec["violations"], json.dumps(case.data))
        assert rec["status"] == "optimal", rec.get("message")


# ---------------------------------------------------------------- found by the campaign
@pytest.mark.slow
def test_a_bound_above_the_answer_is_no_certificate():
    """A random campaign (seed 8802, draw 73): P2 held by an obstacle 3.7e-5 m below,
    24 elements.  The dense node programs bounded the energy 1.2e-6 J above the
    answer -- 3.2e-10 of the scene's energy, within the gap tolerance measured
    against it, but 2.4e-8 of the answer's own -- and the answer was `optimal`;
    the independent multi-start found an energy below that bound by 2.4e-8 of the
    answer's.  A bound above the answer is now measured against the answer's own
    energy: not certified there, the answer goes to the fast node programs, whose
    bound lies below it, and the checks pass."""
    from campaign import Case
    data = {"beam": {"model": "gao", "supports": "P2", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"q": -1468997.8173065952, "points": [[0.016409182718512105,
                                                          -883487.4131731392]],
                     "axial": 2408798787.9883056},
            "mesh": {"elements": 24}, "obstacle": {"gap": 3.67401197650048e-05}}
    rec = run_case(Case(data, ("P2", "obstacle", "points"), "8802:73"), starts=12)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")


# A random campaign's scene (seed 8801, draw 133): P1 in a channel at gap 0, pressed by
# 2.6e6 N/m at 1.0000017 P_bar_h, 8 elements.
_PRESSED_IN_A_CHANNEL = {
    "beam": {"model": "gao", "supports": "P1", "length": 1.3163345518075953, "E": 2.1e11,
             "nu": 0.37017998938920277, "half_thickness": 0.03175511362843908, "width": 1.0},
    "load": {"q": -2557368.130017543, "axial": 86426639.68894446},
    "mesh": {"elements": 8},
    "obstacle": {"gap": 0.0, "gap_above": 0.047757134097864994}}


def test_a_beam_pressed_flat_just_above_the_limit_is_certified_as_w_0():
    """A random campaign (seed 8801, draw 133): P1 in a channel at gap 0, pressed by
    2.6e6 N/m at 1.0000017 P_bar_h, 8 elements.  Both node programs' answers were
    zero to round-off and failed their certificate, whose metric has the margin
    p - lambda_1 along the first mode (the dense one 4e-13 m inside the obstacle,
    its energy -5.7e-7 J below its own bound): `inaccurate`.  The flat beam w = 0,
    admissible and certified, is now the answer; the independent checker finds a
    KKT point and nothing lower."""
    from campaign import Case
    rec = run_case(Case(_PRESSED_IN_A_CHANNEL, ("P1", "channel", "near-limit"), "8801:133"),
                   starts=12)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")
    assert rec["energy"] == 0.0


def test_a_point_inside_the_near_surface_is_no_other_minimiser():
    """The scene above (8801:133): a channel's far surface, 4.8 cm above, set the
    size against which a point's violation of the near one was judged, so a point
    3e-13 m inside it counted as admissible and was reported as another minimiser
    (4.2e-7 J below the certified lower bound on one machine, within the gap on
    another).  The flat beam w = 0 is the one minimiser."""
    r = solve(Scene.from_dict(_PRESSED_IN_A_CHANNEL), "global")
    glob = r.extra["global"]
    assert r.status == "optimal" and r.energy == 0.0, r.message
    assert glob["unique"] and glob["alternatives"] == []


def test_untouched_channel_is_certified():
    data = {"beam": {"model": "gao", "supports": "P2", "length": 2.8216664003911887, "E": 2.1e11,
                     "nu": 0.21420910778984964, "half_thickness": 0.06217198969486908,
                     "width": 1.0},
            "load": {"axial": 287711319.42105836}, "mesh": {"elements": 8},
            "obstacle": {"gap": 0.020691100899755382, "gap_above": 0.16335120955167207}}
    r = solve(Scene.from_dict(data), "global")
    assert r.status == "optimal", r.message


def test_beam_pressed_flat_onto_an_obstacle_above_the_limit(monkeypatch):
    import gaocvx.nonconvex.bnb as bnb
    # the time limit cut to 5 s to keep the suite fast; 44 s do not certify it either
    monkeypatch.setattr(bnb, "TIME_LIMIT", 5.0)
    data = {"beam": {"model": "gao", "supports": "P3", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"q": -1e8, "axial": 438001097.6873237}, "mesh": {"elements": 8},
            "obstacle": {"gap": 0.0}}
    r = solve(Scene.from_dict(data), "global")
    assert r.status == "optimal", r.message


def test_stiff_bonded_bed_just_above_its_limit_is_certified():
    """Campaign scene 1:29: the branch and bound took 0 as the energy of w = 0, which a
    bonded bed with a gap does not have (1/2 c g^2 L = 2.4e9 J here), and pruned every
    box on that bound (5 nodes, gap 1.9e-3 of the scale, inaccurate); the independent
    multi-start's minimum is the answer."""
    data = {"beam": {"model": "gao", "supports": "P1", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"q": [[0.0, -2471021.7017371245], [1.0, -3749977.869407841]],
                     "axial": 28580722437.07982},
            "mesh": {"elements": 12},
            "foundation": {"gap": 0.056006019735536025, "stiffness": 1652534719446.669,
                           "kind": "bilateral"}}
    from campaign import Case
    rec = run_case(Case(data, ("P1", "bonded", "table"), "1:29"), starts=12, seed=29)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")


def test_stiff_unilateral_bed_just_above_the_limit_is_certified():
    """Campaign scene 8:3: the fast path's bounds stall (gap 0.71 of the energy scale);
    the dense programs, which take this mesh, certify it."""
    data = {"beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"q": -1244127.210043124, "axial": 1170097187.073016},
            "mesh": {"elements": 12},
            "foundation": {"gap": 0.00017160256483458907, "stiffness": 5315663276928.432}}
    r = solve(Scene.from_dict(data), "global")
    assert r.status == "optimal", r.message


_HELD_BY_BED = {"beam": {"model": "gao", "supports": "P2", "length": 0.5, "E": 2.1e11, "nu": 0.3,
                         "half_thickness": 0.15, "width": 1.0},
                "load": {"q": -106894.74334576636, "axial": 32260606462.571064},
                "mesh": {"elements": 12},
                "foundation": {"gap": 0.0001880089266298119, "stiffness": 5734715457074.611}}


def test_answer_held_by_a_stiff_bed_against_its_buckling_is_certified():
    """Hidden-scene campaign seed 8901: just above the limit the bed, not the Gao
    term, holds the beam (0.19 mm below it, 5.7e12 N/m^2), and the answer's own
    energy norm is negative (bending minus axial -1.0e-4 against Gao 4.2e-6 and the
    bed's 1.5e-6 on its penetration): the certificate measured a Newton step of
    round-off (|d| 9e-16 of |z| 0.47) against the zero floor, 4.3e-11, and failed
    (stationarity 1.8e-4, inaccurate) although the gap was 9.4e-16 of the scale.
    The independent energy's checks (a KKT point, a local minimum, a multi-start
    finding nothing below the bound) hold."""
    from campaign import Case
    rec = run_case(Case(_HELD_BY_BED, ("P2", "foundation", "near-limit"), "8901"), starts=12, seed=1)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")


@pytest.mark.slow
def test_fast_slices_on_a_stiff_bed_reach_their_slice():
    """A helper's scene (g125 at four times its mesh, 152 elements): P2 just above the
    limit (1.00012 P_bar_h) on a unilateral bed 0.9 mm below, 1.1e12 N/m^2.  The fast
    path's slice solves never counted as on their slice: the banded solve's
    round-off left the linking constraint 2.5e-12 of |z| from it, above the test's
    1e-12, step after step; every node failed, the gap was infinite, `inaccurate`
    after 4000 nodes.  The independent energy's checks hold for the answer."""
    from campaign import Case
    data = {"beam": {"model": "gao", "supports": "P2", "length": 2.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.2, "width": 1.0},
            "load": {"q": -231824.9712141209, "axial": 4779464585.558983},
            "mesh": {"elements": 152},
            "foundation": {"gap": 0.0009079588370858053, "stiffness": 1080088813151.4681}}
    rec = run_case(Case(data, ("P2", "foundation", "near-limit"), "g125"), starts=6, seed=2)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")


def _certified_answer(data):
    """``solve(scene, "global")``'s answer as free DOFs ``u`` of its own problem, the
    first mode's shape and the global method's certificate of any ``u``."""
    from types import SimpleNamespace

    from gaocvx.mixed import MixedForm
    from gaocvx.nonconvex.certificate import certify_answer
    from gaocvx.nonconvex.modes import unstable_modes
    from gaocvx.nonconvex.polish import to_mixed

    r = solve(Scene.from_dict(data), "global")
    dp = r.problem
    full = np.empty(2 * len(r.x))
    full[0::2], full[1::2] = r.w / dp.W, r.slope * dp.L / dp.W
    mf, prog = MixedForm(dp), SimpleNamespace(modes=unstable_modes(dp))

    def certificate(u):
        return certify_answer(dp, prog, mf, mf.on_manifold(to_mixed(mf, u)), None)[0]

    return dp, full[dp.free], prog.modes.phi[:, 0], certificate


def _displaced(dp, u, d, eps):
    """``u`` moved along ``d`` by ``eps`` of its largest nodal deflection."""
    size = np.max(np.abs(dp.full(u)[0::2]))
    return u + eps * size * d / np.max(np.abs(dp.full(d)[0::2]))


@pytest.mark.parametrize("shape", ["mode", "smooth", "random"])
def test_the_certificate_of_an_answer_held_by_a_bed_still_rejects_a_displaced_one(shape):
    """The size the certificate measures against grew for the answer above (the modes'
    part of the H_psi metric); a deflection displaced by 1e-6 of its size still fails
    it, along the buckling mode, a smooth shape or a random one."""
    from gaocvx.certificate import passes

    dp, u, mode, certificate = _certified_answer(_HELD_BY_BED)
    assert passes(certificate(u))
    if shape == "mode":
        d = mode
    elif shape == "smooth":
        d = np.empty(2 * len(dp.xi))
        d[0::2], d[1::2] = np.sin(3 * np.pi * dp.xi), 3 * np.pi * np.cos(3 * np.pi * dp.xi)
        d = d[dp.free]
    else:
        d = np.random.default_rng(0).standard_normal(len(u))
    assert not passes(certificate(_displaced(dp, u, d, 1e-6)))


def test_an_unloaded_answer_smaller_than_its_unit_is_certified_in_its_own_scale():
    """A helper's probe (scene r71): P2 without load 2.6e-6 above the limit buckles to
    0.18 of the unit W = 1e-3 L, and the certificate, whose floor is 1 without load
    (below the limit the answer is w = 0 exactly), accepted the answer displaced
    along its mode by 4.6e-6 of itself.  It is now re-solved in its own scale: a
    displacement of 2e-6 fails (stationarity 2e-6: the measure is the displacement)."""
    from gaocvx.certificate import passes

    data = {"beam": {"model": "gao", "supports": "P2", "length": 0.6030130675465574,
                     "E": 2.1e11, "nu": 0.053807547469329906,
                     "half_thickness": 0.05627659413422082, "width": 1.0},
            "load": {"axial": 1318766679.2396605}, "mesh": {"elements": 8}}
    dp, u, mode, certificate = _certified_answer(data)
    assert passes(certificate(u))
    assert not passes(certificate(_displaced(dp, u, mode, 2e-6)))


def test_a_flat_minimum_the_search_stopped_short_of_is_no_alternative():
    """A helper's campaign (seed 9301, scene A30): P3 on a unilateral bed at gap 0
    without load, 4.5e-8 above the limit.  The multi-start's trust region stopped
    1.5e-3 of the size from the answer, 2e-14 J above it (inside the gap), where
    the energy is flat along the mode, and the rule called ``unique: true`` a missed
    alternative; one Newton step on the independent energy takes that point onto
    the answer (3.6e-6 of the size), so it is none.  The rule still sees a true
    second minimiser: the mirror image of an unloaded free beam stays distinct."""
    from campaign import Case
    from nonconvex_campaign_support import _distinct, _newton
    from nonconvex_independent import Discrete

    from gaocvx.discrete import DiscreteProblem

    beam = {"model": "gao", "length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1,
            "width": 1.0}
    data = {"beam": {**beam, "supports": "P3"}, "load": {"q": 0.0, "axial": 292000150.74523586},
            "mesh": {"elements": 24},
            "foundation": {"gap": 0.0, "stiffness": 186617815428.13553}}
    rec = run_case(Case(data, ("P3", "foundation", "near-limit"), "A30"), starts=12, seed=30)
    assert rec["status"] == "optimal" and rec["unique"] and not rec["violations"], rec
    free = {"beam": {**beam, "supports": "P1"}, "mesh": {"elements": 8}}
    limit = DiscreteProblem(Scene.from_dict(free), check_convexity=False).P_bar_h
    scene = Scene.from_dict({**free, "load": {"axial": 1.3 * limit}})
    r = solve(scene, "global")
    en = Discrete(scene, float(np.max(np.abs(r.w))))
    x = en.from_nodal(r.w, r.slope)
    assert _distinct(en, _newton(en, -x), x)
    near = x * (1 + 1e-2)     # distinct as it stands, not after Newton's steps
    assert _distinct(en, near, x) and not _distinct(en, _newton(en, near), x)


@pytest.mark.slow
def test_a_node_program_stopped_short_is_split_not_closed():
    """P1 at 3 P_bar_h on a unilateral bed, 256 elements (k = 2): one fast-path node's
    line search stalled at a box corner, its value 815 above its (valid, loose) bound.
    The branch and bound closed that box as at its program's accuracy, and the answer
    came out `inaccurate` with a gap of 0.062 of the energy scale; the box is now
    split and the answer certified.  The independent multi-start checks it."""
    from campaign import Case
    from conftest import bed_scene_above_the_limit
    data = bed_scene_above_the_limit()
    rec = run_case(Case(data, ("P1", "foundation", "uniform"), "P1-3x-bed-256"), starts=6,
                   seed=3)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")
    assert rec["k"] == 2 and rec["unique"]


@pytest.mark.slow
def test_channel_near_the_limit_re_solved_in_its_own_scale():
    """Campaign scene 5:42: certified in 39 nodes, then re-solved in the answer's own
    scale (0.078 of the first), where boxes of amplitudes 100 times the answer's have
    values 1e7 times it and Clarabel stops with "insufficient progress": their bound
    was the parent's, no box could be pruned, and 2569 nodes in 124 s ended
    `inaccurate`.  The re-solve now goes on from the first search's leaves (their
    bounds hold in any units); the independent multi-start checks the answer."""
    data = {"beam": {"model": "gao", "supports": "P2", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"points": [[0.05746882921631635, -1044263.0084396844]],
                     "axial": 2389476042.461332},
            "mesh": {"elements": 32},
            "obstacle": {"gap": 4.016015124277481e-05, "gap_above": 0.00925599043843643}}
    from campaign import Case
    rec = run_case(Case(data, ("P2", "channel", "points"), "5:42"), starts=12, seed=42)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")
    assert rec["nodes"] < 1000, rec["nodes"]   # it stopped at 2569 (the 120 s clock)


@pytest.mark.slow
def test_a_stalled_gap_far_from_the_answers_scale_goes_to_its_own_scale_early(caplog):
    """Campaign scene 131:39 (P3, 1 + 2.3e-5 times the limit, an obstacle 5.3e-5 m
    below, 24 elements): the answer is 20 times the first search's unit, where the
    gap stood at 6.1e-7 of the scale from node 201 on, and the search ran to its
    120 s limit (2617 node programs) before the re-solve in the answer's own scale
    certified it (854 more).  The stalled search now ends after bnb.STALL_NODES
    node programs without progress, the re-solve going on from its leaves; the
    independent multi-start checks the answer (-308.5874738 J)."""
    import re
    caplog.set_level(logging.INFO, logger="gaocvx.nonconvex")
    case = random_scene(np.random.default_rng([131, 39]))
    assert case.data["beam"]["supports"] == "P3" and "obstacle" in case.data
    rec = run_case(case, starts=12, seed=39)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")
    searches = [int(m.group(1)) for r in caplog.records
                if (m := re.search(r"branch and bound: (\d+) nodes, upper", r.getMessage()))]
    assert len(searches) == 2 and any("stalled" in r.getMessage() for r in caplog.records)
    assert sum(searches) < 1500, searches


def test_a_channel_far_narrower_than_the_free_buckle_is_searched_in_its_own_units():
    """A hidden-scene trial's P3 beam in a channel (1.18 cm below, 0.84 cm above, table
    load, 1.4 P_bar_h, 16 elements): its free one-mode amplitude is 18 times the channel,
    and in those units the dense node programs stalled at a gap of 0.077 for their
    whole 120 s (629 nodes) before the search in the answer's own scale certified it.
    The search now starts in the channel's units; the independent multi-start checks it."""
    data = {"beam": {"model": "gao", "supports": "P3", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"q": [[0.35, -489819.7733347663], [0.55, -874806.7477696814],
                           [0.65, 1284838.1922734468], [0.9, -2747513.1296138694]],
                     "axial": 1645982998.9259477},
            "obstacle": {"gap": 0.01176280463872833, "gap_above": 0.008358813324271557},
            "mesh": {"elements": 16}}
    from campaign import Case
    rec = run_case(Case(data, ("P3", "channel", "table"), "trial-p3-channel"), starts=8,
                   seed=7)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")
    assert rec["nodes"] < 100, rec["nodes"]   # 629 + 24 before


def test_an_image_within_the_gap_that_is_no_equilibrium_is_not_reported():
    """Campaign scene 1:66: a P1 beam buckled 0.2 m under a small table load is 2e-7 m
    from symmetric, so its image in x -> L - x lay within the certified gap and was
    reported as a second minimiser, which is no KKT point of the independent energy.
    Polished, the image falls back onto the answer: unique, and the checker agrees."""
    data = {"beam": {"model": "gao", "supports": "P1", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"q": [[0.0, -106916.88645913731], [0.6349848627588336, 16655.745810179797],
                           [1.0, 27777.750251439138]], "axial": 9193998558.694605},
            "mesh": {"elements": 12}, "obstacle": {"gap": 0.003575828581718178}}
    from campaign import Case
    rec = run_case(Case(data, ("P1", "obstacle", "table"), "1:66"), starts=12, seed=66)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal" and rec["unique"], rec.get("message")


@pytest.mark.slow
def test_a_candidate_inside_the_obstacle_is_not_taken_by_the_polish():
    """Campaign scene 11:31 (96 elements): a P1 beam held at w = 0 by an obstacle at
    gap 0, just above the limit.  The search's best point was w = 0; the polish took a
    reduced minimiser 3.4e-12 inside the obstacle (1e-5 of its own size, energy
    -1.5e-12) as lower, and the answer failed its certificate (`inaccurate`).
    Candidates are now judged by their admissible energy: w = 0, certified, and the
    independent checker agrees."""
    data = {"beam": {"model": "gao", "supports": "P1", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"points": [[0.3088462454748173, -11944517.970276581],
                                [0.9657011133088972, -4360499.741007901]],
                     "axial": 4676963613.00729},
            "mesh": {"elements": 96}, "obstacle": {"gap": 0.0}}
    from campaign import Case
    rec = run_case(Case(data, ("P1", "obstacle", "points"), "11:31"), starts=4, seed=31)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")


@pytest.mark.parametrize("name, data", [
    ("7603:52", {"beam": {"model": "gao", "supports": "P3", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                          "half_thickness": 0.1, "width": 1.0},
                 "load": {"points": [[0.26276092977061927, -170483414.87701002],
                                     [0.7372390702293807, -170483414.87701002]],
                          "axial": 567446798.7653025},
                 "mesh": {"elements": 10}, "obstacle": {"gap": 0.0}}),
    ("8601:5162", {"beam": {"model": "gao", "supports": "P2", "length": 1.0, "E": 2.1e11,
                            "nu": 0.3, "half_thickness": 0.1, "width": 1.0},
                   "load": {"q": -212534461.4832823, "axial": 2389674895.110637},
                   "mesh": {"elements": 38}, "obstacle": {"gap": [[0.0, 0.0], [0.7205, 0.0]]}}),
])
def test_a_polished_point_that_fails_its_certificate_gives_way_to_the_search_s_best(name, data):
    """Two campaigns' beams pressed flat at gap 0 (two forces of 1.7e8 N; 2.1e8 N/m): the
    search's best was w = 0, the polish took a point up to its slack higher (2.9e-4 J
    with no contact force, 4e-8 m off the obstacle) that is no minimiser, and the
    answer was `inaccurate`.  w = 0 is admissible with energy 0, so the certified
    energy is at most 0 (to the gap); the independent checker confirms a KKT point
    and finds nothing lower."""
    from campaign import Case
    case = Case(data, (data["beam"]["supports"], "obstacle", "pressed"), name)
    rec = run_case(case, starts=8, seed=3)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")
    assert rec["energy"] <= rec["gap"], (rec["energy"], rec["gap"])


def test_a_search_stopped_as_stalled_whose_answer_is_within_its_units_goes_on(
        monkeypatch, caplog):
    """Where the first search ends as stalled but its polished answer lies within
    the units after all, and no other node programs follow (``give_up`` false),
    no re-solve in another scale follows: the search goes on in the same units
    from its leaves (else the answer would stay uncertified).  Forced here: the
    stall asked after two node programs and always answered yes, on a P4 beam
    above an obstacle whose answer is within its units."""
    from gaocvx.discrete import DiscreteProblem
    from gaocvx.nonconvex import bnb, minimum, search
    scene = Scene.from_dict({
        "beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                 "half_thickness": 0.1, "width": 1.0},
        "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 16},
        "obstacle": {"gap": 0.01}})
    plain = solve(scene, "global")
    real = search.branch_and_bound

    def forced(*args, stalled=None, **kw):
        return real(*args, stalled=None if stalled is None else (lambda u: True), **kw)

    monkeypatch.setattr(search, "branch_and_bound", forced)
    monkeypatch.setattr(bnb, "STALL_NODES", 2)
    caplog.set_level(logging.INFO, logger="gaocvx.nonconvex")
    dp, raw, info = minimum.solve_global(DiscreteProblem(scene, check_convexity=False))
    messages = [rec.getMessage() for rec in caplog.records]
    assert any("stalled" in m for m in messages)
    assert any("goes on in the same units" in m for m in messages)
    assert plain.status == raw["status"] == "optimal", raw["message"]
    energy = sum(raw["mixed"].energy_parts(raw["z"]).values()) * dp.E0
    gaps = abs(plain.extra["global"]["bound_gap"]) + abs(info["bound_gap"])
    assert abs(energy - plain.energy) <= gaps + 1e-12 * abs(plain.energy)


@pytest.mark.slow
def test_a_stalled_dense_search_gives_way_to_the_fast_path_early(caplog):
    """A hidden-scene trial's P4 beam on an obstacle 2 mm below at 4 P_bar_h (32
    elements, q = -1e7 N/m): the dense node programs' gap stood at 2.8e-5 of the
    scale from node 101 to their 120 s limit (3591 nodes); the fast path then
    certified it in 37.  The dense search now ends once its gap has stalled for
    bnb.STALL_NODES node programs, as the fast path follows; the independent
    multi-start checks the answer."""
    import re
    data = {"beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                     "half_thickness": 0.1, "width": 1.0},
            "load": {"q": -1e7, "axial": 4672002685.847446},
            "mesh": {"elements": 32}, "obstacle": {"gap": 0.002}}
    caplog.set_level(logging.INFO, logger="gaocvx.nonconvex")
    from campaign import Case
    rec = run_case(Case(data, ("P4", "obstacle"), "trial-p4-obstacle-4x"), starts=8, seed=4)
    assert not rec["violations"], rec["violations"]
    assert rec["status"] == "optimal", rec.get("message")
    searches = [int(m.group(1)) for r in caplog.records
                if (m := re.search(r"branch and bound: (\d+) nodes, upper", r.getMessage()))]
    assert any("the gap had not halved" in r.getMessage() for r in caplog.records)
    assert sum(searches) < 1000, searches


def test_a_first_search_given_up_runs_again_where_the_other_fails_too(monkeypatch):
    """``solve_certified``: the first search, given up as stalled, is run again to its
    own limits when the other node programs do not certify either (as it ran before
    it could give up), and the certified one of them is returned."""
    from gaocvx.discrete import DiscreteProblem
    from gaocvx.nonconvex import minimum
    from gaocvx.nonconvex.modes import unstable_modes
    dp = DiscreteProblem(Scene.from_dict({
        "beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                 "half_thickness": 0.1, "width": 1.0},
        "load": {"q": -1e7, "axial": 1.3e9}, "mesh": {"elements": 8},
        "obstacle": {"gap": 0.01}}), check_convexity=False)
    modes = unstable_modes(dp)
    calls = []

    def fake(dp_, modes_, fast=None, give_up=False):
        calls.append((fast, give_up))
        if len(calls) == 1:
            return dp_, {"status": "inaccurate", "stalled": True, "message": "-"}, {"call": 1}
        if len(calls) == 2:
            return dp_, {"status": "inaccurate", "stalled": False, "message": "-"}, {"call": 2}
        return dp_, {"status": "optimal", "stalled": False, "message": "-"}, {"call": 3}

    monkeypatch.setattr(minimum, "solve_global", fake)
    out = minimum.solve_certified(dp, modes)
    # dense first (an obstacle on 8 elements), then the fast path, then dense again
    assert calls == [(None, True), (True, False), (None, False)]
    assert out[2] == {"call": 3}
    calls.clear()

    def certified_second(dp_, modes_, fast=None, give_up=False):
        calls.append((fast, give_up))
        status = "optimal" if len(calls) == 2 else "inaccurate"
        return dp_, {"status": status, "stalled": True, "message": "-"}, {"call": len(calls)}

    monkeypatch.setattr(minimum, "solve_global", certified_second)
    assert minimum.solve_certified(dp, modes)[2] == {"call": 2} and len(calls) == 2


# A campaign's scene (global minima, extreme loads on an obstacle): P4 at gap 0 under
# a point force of 6.04e12 N, which the obstacle absorbs (1 mm by 1e6 m section).
_ABSORBED = {
    "beam": {"model": "gao", "supports": "P4", "length": 1.0, "E": 2.1e11, "nu": 0.3,
             "half_thickness": 0.001, "width": 999999.9999999999},
    "load": {"points": [[0.20604621722478078, -6043844830610.414]],
             "axial": 5287475799.418158},
    "mesh": {"elements": 8},
    "obstacle": {"gap": 0.0}}


@pytest.mark.slow
def test_a_force_the_obstacle_absorbs_does_not_hide_the_buckled_minimum(monkeypatch):
    """It was answered flat, 0 J, `optimal` and unique, its gap 8127 J certified
    against the unsupported beam's energy (1e15 J), where a buckled minimum lies
    at -1891 J.  The reference is an exact rescaling: h x100, width x1e-6 and the
    force x100 scale every energy by 1e4 (answered buckled before too); each
    answer's energy is the independent energy's at its deflection.  The linear
    beam on the obstacle (a QP) is solved once by each global search, though it
    searches twice (it was solved on every search and for the second one's units)."""
    from nonconvex_independent import Discrete

    calls, searches = [], []
    real_search = minimum.solve_global

    def counted(dp):
        calls.append(dp.n)
        return linear_on_obstacle(dp)

    def search(*args, **kwargs):
        searches.append(1)
        return real_search(*args, **kwargs)

    monkeypatch.setattr(minimum, "linear_on_obstacle", counted)
    monkeypatch.setattr(obstacle_scale, "linear_on_obstacle", counted)
    monkeypatch.setattr(minimum, "solve_global", search)

    scaled = {**_ABSORBED,
              "beam": {**_ABSORBED["beam"], "half_thickness": 0.1, "width": 1.0},
              "load": {**_ABSORBED["load"], "points": [[0.20604621722478078,
                                                        -604384483061041.4]]}}
    answers = []
    for data in (_ABSORBED, scaled):
        scene = Scene.from_dict(data)
        calls.clear()
        searches.clear()
        r = solve(scene, "global")
        assert r.status == "optimal", r.message
        assert len(calls) == len(searches) >= 1
        en = Discrete(scene, W=1e-3)
        assert en.energy(en.from_nodal(r.w, r.slope)) == pytest.approx(r.energy, rel=1e-8)
        assert np.min(r.w) >= -1e-9 * np.max(np.abs(r.w))     # (on the obstacle)
        answers.append((r.energy, r.extra["global"]["bound_gap"]))
    (e, gap), (e_big, gap_big) = answers
    assert abs(e - 1e-4 * e_big) <= gap + 1e-4 * gap_big + 1e-9 * abs(e)
    assert e < -1000.0          # (not the flat beam)


@pytest.mark.slow
def test_where_the_obstacles_qp_fails_its_floor_is_zero_not_the_unsupported_beams(monkeypatch):
    """Clarabel fails the linear beam's QP on some fine meshes; the gap's test then
    fell back to the unsupported beam's floor, and the scene above was again flat,
    0 J, `optimal`.  With c0 = 0 (w = 0 is admissible: a floor from below) the
    buckled minimum of the test above is found and certified."""
    from nonconvex_independent import Discrete

    monkeypatch.setattr(minimum, "linear_on_obstacle", lambda dp: None)
    scene = Scene.from_dict(_ABSORBED)
    r = solve(scene, "global")
    assert r.status == "optimal", r.message
    assert r.energy < -1000.0          # (not the flat beam)
    en = Discrete(scene, W=1e-3)
    assert en.energy(en.from_nodal(r.w, r.slope)) == pytest.approx(r.energy, rel=1e-8)
