"""The one-dimensional root searches of ``gaocvx.nonconvex.contours`` on functions
with known zeros (closed forms), independent of any beam."""

import math

import numpy as np
import pytest

from gaocvx.nonconvex.contours import line_zeros, sampled_roots


def test_sampled_roots_sign_changes_and_a_close_pair():
    """Zeros at sign changes, at a sample, and a pair 0.02 apart between two samples
    (f = (x - 0.5)^2 - 1e-4 on samples 0.3 apart: no sign change at the samples)."""
    f = lambda x: (x - 0.5) ** 2 - 1e-4         # noqa: E731
    s = np.array([0.0, 0.3, 0.6, 0.9])
    roots = sorted(sampled_roots(f, s, [f(x) for x in s], 1.0))
    assert roots == pytest.approx([0.49, 0.51], abs=1e-12)
    g = lambda x: x * (x * x - 1) * (x * x - 4)   # noqa: E731  zeros at -2 .. 2
    s = np.array([-2.5, -2.0, -1.3, -0.4, 0.5, 1.4, 2.0])   # -2, 2 samples, the rest between
    roots = sorted(sampled_roots(g, s, [g(x) for x in s], 1.0))
    assert roots == pytest.approx([-2, -1, 0, 1, 2], abs=1e-12)


def test_sampled_roots_drops_a_search_that_meets_an_inadmissible_point():
    f = lambda x: x if x < 0.1 else math.nan    # noqa: E731
    assert sampled_roots(f, [-1.0, 1.0], [-1.0, 1.0], 1.0) == []


def _grad(even, noise=1e-17):
    """``F = (s1^2 - 1)^2 / 4 - s2^2 + s2^4`` (even in s2: zeros of ∇F on the line
    s2 = 0 at s1 = -1, 0, 1), with round-off of alternating sign in ``∂F/∂s2`` on
    that line; ``even=False`` adds ``0.3 s2 s1``, after which the line is none of
    symmetry."""
    count = [0]

    def grad(s):
        s1, s2 = s
        count[0] += 1
        d2 = -2 * s2 + 4 * s2 ** 3 + (0.0 if even else 0.3 * s1)
        if s2 == 0.0 and even:
            d2 = noise * (-1) ** count[0]
        F = 0.25 * (s1 ** 2 - 1) ** 2 - s2 ** 2 + s2 ** 4 + (0.0 if even else 0.3 * s1 * s2)
        return F, np.array([s1 ** 3 - s1 + (0.0 if even else 0.3 * s2), d2]), None, True
    return grad


def test_line_zeros_on_a_line_of_symmetry():
    axes = [np.linspace(-1.7, 1.3, 11), np.r_[np.linspace(-1.5, 1.5, 7)]]
    assert 0.0 in axes[1]
    zeros = line_zeros(_grad(True), axes, 2.0)
    got = sorted(float(z[0]) for z in zeros)
    assert got == pytest.approx([-1.0, 0.0, 1.0], abs=1e-12)
    assert all(z[1] == 0.0 for z in zeros)
    # F is even in s1 too: on the line s1 = 0 the zeros of dF/ds2 = -2 s2 + 4 s2^3
    axes = [np.r_[np.linspace(-1.5, 1.5, 7)], np.linspace(-0.9, 0.9, 11)]
    got = sorted(float(z[1]) for z in line_zeros(_grad(True, 0.0), axes, 2.0) if z[0] == 0.0)
    assert got == pytest.approx([-2 ** -0.5, 0.0, 2 ** -0.5], abs=1e-12)


def test_line_zeros_not_on_a_line_of_no_symmetry():
    axes = [np.linspace(-1.7, 1.3, 11), np.linspace(-1.5, 1.5, 7)]
    assert line_zeros(_grad(False), axes, 2.0) == []
