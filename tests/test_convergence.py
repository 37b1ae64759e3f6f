"""Mesh convergence of the Gao solution, with fitted orders (no closed form exists).

The references are fine-mesh solutions; the coarse meshes are kept where
their error is far above the reference's own round-off floor.
"""

import numpy as np
import pytest

from conftest import scene_dict
from gaocvx import Scene, solve

XS = np.linspace(0.0, 1.0, 4001)


def sup_errors(base, sizes, ref_n, nodal):
    ref = solve(Scene.from_dict(scene_dict(**base, elements=ref_n)))
    assert ref.success
    out = []
    for n in sizes:
        r = solve(Scene.from_dict(scene_dict(**base, elements=n)))
        xs = r.x if nodal else XS
        out.append(np.abs(r.deflection(xs) - ref.deflection(xs)).max() / np.abs(ref.w).max())
    return np.array(out)


def order(sizes, errs):
    return -np.polyfit(np.log(sizes), np.log(errs), 1)[0]


@pytest.mark.parametrize("supports", ["P1", "P2", "P3", "P4"])
def test_gao_bending_nodal_order_four(supports):
    """Smooth Gao problem with an axial force: nodal error of cubic elements ~ h^4."""
    base = dict(supports=supports, model="gao", q=-1e8, axial=1e8 if supports != "P3" else 5e7)
    sizes = [4, 8, 16]
    errs = sup_errors(base, sizes, 256, nodal=True)
    assert order(sizes, errs) > 3.7, errs
    assert errs[-1] < 2e-7


def test_gao_bending_sup_norm_order_four():
    base = dict(supports="P2", model="gao", q=[[0.0, 0.0], [0.4, -2e8], [1.0, -5e7]])
    sizes = [4, 8, 16, 32]
    errs = sup_errors(base, sizes, 256, nodal=False)
    assert order(sizes, errs) > 3.7, errs


def test_foundation_converges():
    """With a foundation the solution's 4th derivative jumps at the contact ends,
    inside elements: the sup-norm error falls irregularly, about like h^2
    (measured 2.6e-4 at 8 elements to 8.9e-7 at 128)."""
    base = dict(supports="P1", model="gao", q=-5e8, foundation=(0.007, 5e10))
    sizes = [8, 16, 32, 64, 128]
    errs = sup_errors(base, sizes, 1024, nodal=False)
    assert order(sizes, errs) > 1.8, errs
    assert errs[-1] < 1e-2 * errs[0]
