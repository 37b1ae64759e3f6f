"""A one-mode zero of F' refined and measured in its beam's own scale (zero_step).

The stand-in problems here have one DOF, the deflection equal to the amplitude
(``w = s`` m), so the Newton step's change of the deflection is the amplitude's,
known in closed form from the F' each test writes down.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from gaocvx.nonconvex.roundoff import EPS, LABEL_NOISE
from gaocvx.nonconvex.zero_step import STEP_TOL, own_step
from gaocvx.tolerances import ZERO_ANSWER


# A loaded stand-in's floor under |w| [m] (own_step's zero_floor): far below the
# beams here.
FLOOR = 1e-26


def _problem(own=1.0):
    """A stand-in whose energy scale is ``own``."""
    return SimpleNamespace(G=np.eye(1), energy_size=lambda u: own,
                           to_physical=lambda u: (np.asarray(u, float), np.zeros(1)))


def _reduced(fprime, admissible=lambda t: True):
    def dF(t):
        if not admissible(t):
            return math.inf, math.nan, None, False
        return 0.0, fprime(t), np.array([t]), True
    return dF


def test_a_zero_located_to_the_scenes_tolerance_is_refined_in_its_own():
    """F' = 5.3 (s - s0), s0 = -7.6e-9, S = 314 (the campaign scene's numbers):
    Brent's tolerance 1e-13 S leaves s 5.6e-14 off, 7.4e-6 of |s|; one Newton step
    lands on s0 to round-off and the step measured is far below STEP_TOL."""
    s0 = -7.6e-9
    dF = _reduced(lambda t: 5.3 * (t - s0))
    r = s0 + 5.6e-14
    assert abs(r - s0) / abs(s0) > 7 * STEP_TOL
    s, step = own_step(_problem(own=1e-15), dF, r, 314.0, zero_floor=FLOOR)
    assert abs(s - s0) <= 1e-12 * abs(s0)
    assert step <= 1e-9


def test_an_edge_within_the_difference_step_leaves_the_other_side():
    """F' = s - 1, no admissible beam beyond s = 1 + 1e-4 (an obstacle's edge): the
    right-hand probe at 1 + 1e-3 is inadmissible, and F'' comes from the left one."""
    dF = _reduced(lambda t: t - 1.0, admissible=lambda t: t <= 1.0 + 1e-4)
    s, step = own_step(_problem(), dF, 1.0 + 1e-12, 10.0, zero_floor=FLOOR)
    assert abs(s - 1.0) <= 1e-15 and step <= 1e-9


def test_no_admissible_probe_is_no_certificate():
    dF = _reduced(lambda t: t - 1.0, admissible=lambda t: abs(t - 1.0) <= 1e-6)
    assert own_step(_problem(), dF, 1.0 + 1e-12, 10.0, zero_floor=FLOOR)[1] == math.inf


def test_f_prime_counts_at_least_its_round_off():
    """F' = 1e-9 (s - 1) at s = 1 + 1e-20 (F' = 1e-29, far below its round-off,
    LABEL_NOISE eps own / |s| = 4.4e-15 with own = 1): the zero is known only to
    4.4e-15 / 1e-9 = 4.4e-6 of |s|, more than STEP_TOL, whatever F' says."""
    dF = _reduced(lambda t: 1e-9 * (t - 1.0) + (1e-29 if t == 1.0 else 0.0))
    _, step = own_step(_problem(), dF, 1.0, 10.0, zero_floor=FLOOR)
    assert step == pytest.approx(LABEL_NOISE * EPS / 1e-9, rel=1e-6)
    assert step > STEP_TOL


def test_an_exact_zero_is_one():
    dF = _reduced(lambda t: 0.0)
    assert own_step(_problem(), dF, 0.25, 1.0, zero_floor=FLOOR) == (0.25, 0.0)


def test_the_slices_accuracy_counts_as_the_probes_take_it():
    """With ``error`` (the dense programs' F' is known to their accuracy, here
    1e-8): F' = 1e-3 (s - 1) at s = 1 + 1e-20 is known only to 1e-8 / 1e-3 = 1e-5
    of |s|."""
    dF = _reduced(lambda t: 1e-3 * (t - 1.0) + (1e-29 if t == 1.0 else 0.0))
    _, step = own_step(_problem(), dF, 1.0, 10.0, zero_floor=FLOOR, error=lambda t, u: 1e-8)
    assert step == pytest.approx(1e-5, rel=1e-6)
    assert own_step(_problem(), dF, 1.0, 10.0, zero_floor=FLOOR)[1] <= 1e-9


def test_the_step_is_measured_against_the_larger_of_the_beam_and_its_floor():
    """F' = 5.3 (s - s0) (1e-29 at s0), s0 = -7.6e-9 m, known only to 1e-8
    (``error``): the step is 1e-8 / 5.3 m, over |w| = 7.6e-9 m under a loaded floor
    below it, over the floor above it, and without load (no floor given) over
    ``ZERO_ANSWER`` of the deflection the range S = 314 makes (dw/ds = 1)."""
    s0 = -7.6e-9
    dF = _reduced(lambda t: 5.3 * (t - s0) + (1e-29 if t == s0 else 0.0))
    move = 1e-8 / 5.3

    def step(floor):
        return own_step(_problem(own=1e-15), dF, s0, 314.0, error=lambda t, u: 1e-8,
                        zero_floor=floor)[1]

    assert step(FLOOR) == pytest.approx(move / abs(s0), rel=1e-6)
    assert step(1e-3) == pytest.approx(move / 1e-3, rel=1e-6)
    assert step(None) == pytest.approx(move / (ZERO_ANSWER * 314.0), rel=1e-6)


def _saddle(eps, own):
    """Two modes: ∇F = (-5.7 s1, -eps s2 + s2^3), a saddle at s = (0, sqrt(eps))
    along a nearly flat second mode (just above its load); the deflection is the
    amplitudes, and the energy's parts ``own |s|^2`` (the bending and axial parts
    that cancel there)."""
    def grad(s):
        s = np.asarray(s, float)
        d = np.array([-5.7 * s[0], -eps * s[1] + s[1] ** 3])
        return float(-5.7 * s[0] ** 2 / 2 - eps * s[1] ** 2 / 2 + s[1] ** 4 / 4), d, s, True

    def hessian(s, h=1e-6):
        H = np.empty((2, 2))
        for j in range(2):
            e = np.zeros(2)
            e[j] = h
            H[:, j] = (grad(s + e)[1] - grad(s - e)[1]) / (2 * h)
        return 0.5 * (H + H.T)

    dp = SimpleNamespace(G=np.eye(2), E0=1.0, P=0.0, W=1.0, x=np.zeros(2),
                         energy=lambda u: grad(u)[0],
                         energy_size=lambda u: own * float(np.asarray(u) @ np.asarray(u)),
                         to_physical=lambda u: (np.asarray(u, float), np.zeros(2)))
    return dp, grad, hessian


@pytest.mark.parametrize("eps, own, optimal", [(1e-6, 300.0, True), (2e-12, 1.0, False)])
def test_a_two_mode_zero_is_refined_and_measured_in_its_own_scale(eps, own, optimal):
    """The saddle found at 1.8 times its own amplitude z = sqrt(eps) (the plane's
    Newton method's Hessian 1e-6 S wide there; a campaign's P4 beam, 4 elements,
    1e-13 above lambda_2, was listed `optimal` 2.1 times the size of its saddle):
    its residual, |∇F| 1e-3 S against its energy's parts, passes ROOT_TOL, but the
    entry is `optimal` only once refined onto the saddle, and `inaccurate` where
    ∇F's round-off (20 eps_mach own |s|) over the flat mode's curvature 2 eps
    leaves the zero known only to 1e-3 of itself (eps = 2e-12)."""
    from gaocvx.nonconvex.plane_newton import at_roots
    from gaocvx.nonconvex.stationary1 import ROOT_TOL
    dp, grad, hessian = _saddle(eps, own)
    z = math.sqrt(eps)
    r = np.array([0.0, 1.8 * z])
    d = grad(r)[1]
    assert np.linalg.norm(d) * 1e-3 / dp.energy_size(r) <= ROOT_TOL   # (passes the residual)
    (e,) = at_roots(dp, grad, hessian, [r], 1.0, zero_floor=FLOOR)
    assert not e.stable
    if optimal:
        assert e.status == "optimal" and e.amplitudes[1] == pytest.approx(z, rel=1e-9)
    else:
        assert e.status == "inaccurate"
