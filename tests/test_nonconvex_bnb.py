"""The branch and bound's closing rules, on a one-dimensional toy with exact node bounds.

F(s) = s^4 - s^2 on [-2, 2] (c = 1: the concave part -s^2, replaced on a box by its
chord); its minimum is -1/4 at s = +-1/sqrt 2 (the reference: calculus).
"""

import math
from types import SimpleNamespace

import numpy as np

from gaocvx.nonconvex.bnb import branch_and_bound


class Toy:
    """Exact node programs ``min s^4 + chord`` on a grid, except that the first solve of
    the box ``stalled`` returns a loose bound and a value far above it (a node program
    that stopped short: its bound valid, 5 below the box's true minimum)."""

    modes = SimpleNamespace(c=np.array([1.0]))

    def __init__(self, stalled=None):
        self.stalled = stalled

    def solve_box(self, lo, hi):
        grid = np.linspace(lo[0], hi[0], 4001)
        val = grid**4 - (lo[0] + hi[0]) * grid + lo[0] * hi[0]
        i = int(np.argmin(val))
        lower = float(val[i]) - 1e-9
        if self.stalled is not None and (lo[0], hi[0]) == self.stalled:
            self.stalled = None
            return SimpleNamespace(lower=lower - 5.0, value=lower + 5.0, s=lo.copy(),
                                   u=lo.copy(), lam=None, ok=True)
        return SimpleNamespace(lower=lower, value=float(val[i]), s=grid[i:i + 1],
                               u=grid[i:i + 1], lam=None, ok=True)


def energy(u):
    return float(u[0] ** 4 - u[0] ** 2)


def test_exact_nodes_certify_the_minimum():
    out = branch_and_bound(Toy(), energy, [-2.0], [2.0], tol=1e-6)
    assert out.converged and 0.0 <= out.gap <= 1e-6
    assert abs(out.upper + 0.25) <= 1e-6
    assert abs(abs(out.s[0]) - 1 / math.sqrt(2)) <= 1e-3


def test_a_node_that_stopped_short_is_split_not_closed():
    """The box [-2, 0] first gets a bound 5 below its minimum and a value 5 above it:
    its "accuracy" 10 exceeds ten times its chord error (1), which closed it, and the
    gap stayed 3.75 (the root's bound).  Split, its children are solved afresh and the gap closes."""
    out = branch_and_bound(Toy(stalled=(-2.0, 0.0)), energy, [-2.0], [2.0], tol=1e-6)
    assert 0.0 <= out.gap <= 1e-6, out.gap
    assert abs(out.upper + 0.25) <= 1e-6


def test_a_box_at_its_programs_accuracy_closes_within_accept_and_the_gap_says_so():
    """With ``accept`` 10 the caller certifies gaps up to 10: the noisy box is closed
    (what is left of its gap is its program's accuracy), and the reported gap is what
    the leaves prove: the root's bound -4 (min s^4 - 4 on [-2, 2]) holds in the box,
    above its own -6.19, so 3.75: honest, not hidden."""
    out = branch_and_bound(Toy(stalled=(-2.0, 0.0)), energy, [-2.0], [2.0], tol=1e-6,
                           accept=10.0)
    true_min = -0.25
    assert out.lower <= true_min <= out.upper + 1e-12
    assert abs(out.gap - 3.75) <= 1e-6


class Counting(Toy):
    """The exact toy, counting the node programs and the boxes they were asked for."""

    def __init__(self):
        super().__init__()
        self.boxes = []

    def solve_box(self, lo, hi):
        self.boxes.append((float(lo[0]), float(hi[0])))
        return super().solve_box(lo, hi)


def basins_of_the_toy(u, s, lam):
    """The toy's basins by calculus: F'' = 12 s^2 - 2 > 0 for |s| > 1/sqrt 6, so F is
    convex on [1/sqrt 6, 2] (and its mirror), where its minimum is -1/4."""
    from gaocvx.nonconvex.basin import Basin
    sign = 1.0 if s[0] > 0 else -1.0
    m = sign / math.sqrt(2.0)
    lo, hi = sorted((sign * 0.45, sign * 2.0))
    return Basin(np.array([lo]), np.array([hi]), -0.25 - 1e-12, np.array([m]), np.array([m]),
                 1.0, np.zeros(1))


def test_boxes_inside_a_basin_close_on_its_bound_without_a_node_program():
    plain, with_basins = Counting(), Counting()
    out0 = branch_and_bound(plain, energy, [-2.0], [2.0], tol=1e-8)
    out1 = branch_and_bound(with_basins, energy, [-2.0], [2.0], tol=1e-8,
                            start=(energy(np.array([0.7])), np.array([0.7]), np.array([0.7]), None),
                            basin=basins_of_the_toy)
    assert abs(out1.upper + 0.25) <= 1e-12 and 0.0 <= out1.gap <= 1e-8
    assert out0.lower <= out1.upper and out1.lower <= out0.upper
    assert len(out1.basins) == 2          # both minimisers' basins were found
    assert len(with_basins.boxes) < len(plain.boxes) / 2
    # no node program was asked for a box inside the start's basin (proved first)
    first = out1.basins[0]
    assert first.s[0] > 0
    for lo, hi in with_basins.boxes:
        assert not first.contains(np.array([lo]), np.array([hi]))


def test_a_basin_whose_bound_would_not_close_its_boxes_is_not_used():
    """A basin's bound 1 below its minimum (a polish that stopped short): boxes inside
    it would keep that bound and be split without end.  It is not taken; the search
    certifies the minimum by its node programs as without basins."""
    def loose(u, s, lam):
        b = basins_of_the_toy(u, s, lam)
        return type(b)(b.lo, b.hi, b.lower - 1.0, b.s, b.u, b.margin, b.eta)

    out = branch_and_bound(Counting(), energy, [-2.0], [2.0], tol=1e-8, basin=loose,
                           start=(energy(np.array([0.7])), np.array([0.7]), np.array([0.7]), None))
    assert out.converged and 0.0 <= out.gap <= 1e-8 and abs(out.upper + 0.25) <= 1e-12
    assert out.basins == []


class Noisy(Toy):
    """Node bounds 1e-3 below the box's minimum, always: the gap cannot fall below
    1e-3, and splitting the boxes near the minima does not halve it (a stalled gap)."""

    def solve_box(self, lo, hi):
        sol = super().solve_box(lo, hi)
        sol.lower -= 1e-3
        return sol


def test_a_stalled_gap_asks_the_caller_and_ends_only_when_told():
    """``stalled`` is asked only after the gap stopped halving (bnb.STALL_NODES node
    programs), with the best beam; True ends the search uncertified, its bounds
    still valid; False leaves the search as it was without the argument."""
    from gaocvx.nonconvex import bnb

    asked = []

    def stop(u):
        asked.append(np.array(u))
        return True

    def go_on(u):
        asked.append(np.array(u))
        return False

    plain = branch_and_bound(Noisy(), energy, [-2.0], [2.0], tol=1e-6)
    assert plain.nodes > 2 * bnb.STALL_NODES   # (else this test would test nothing)
    ended = branch_and_bound(Noisy(), energy, [-2.0], [2.0], tol=1e-6, stalled=stop)
    assert not ended.converged and ended.stalled and len(asked) == 1
    assert bnb.STALL_NODES <= ended.nodes < plain.nodes
    assert abs(abs(asked[0][0]) - 1 / math.sqrt(2)) <= 1e-3   # the best beam
    assert ended.lower <= -0.25 <= ended.upper + 1e-12        # the bound still holds
    asked.clear()
    kept = branch_and_bound(Noisy(), energy, [-2.0], [2.0], tol=1e-6, stalled=go_on)
    assert len(asked) >= 1 and kept.nodes == plain.nodes and kept.lower == plain.lower
    assert not kept.stalled and not plain.stalled
    asked.clear()
    exact = branch_and_bound(Toy(), energy, [-2.0], [2.0], tol=1e-6, stalled=stop)
    assert exact.converged and not asked
