"""MixedForm.directional, the line search's derivative, against the gradient it stands for."""

import numpy as np
import pytest

from conftest import scene_dict
from gaocvx import DiscreteProblem, Scene
from gaocvx.mixed import MixedForm


@pytest.mark.parametrize("kind", ["plain", "foundation", "bonded", "obstacle", "channel"])
@pytest.mark.parametrize("model", ["gao", "euler-bernoulli"])
def test_directional_derivative_is_the_gradient_along_d(kind, model):
    contact = {"plain": {}, "foundation": {"foundation": (0.002, 5e10)},
               "bonded": {"foundation": (0.002, 5e10)}, "obstacle": {"obstacle": 0.002},
               "channel": {"obstacle": 0.002}}[kind]
    data = scene_dict(q=-5e8, elements=24, model=model, axial=2e8, **contact)
    if kind == "bonded":
        data["foundation"]["kind"] = "bilateral"
    if kind == "channel":
        data["obstacle"]["gap_above"] = 0.001
    mf = MixedForm(DiscreteProblem(Scene.from_dict(data)))
    rng = np.random.default_rng(7)
    for trial in range(5):
        z, d = rng.normal(size=mf.n), rng.normal(size=mf.n)
        al = {}
        if mf.dp.contact == "obstacle":
            al = {"shift": np.abs(rng.normal(size=mf.A.shape[0])), "rho": 10.0 ** trial}
        dphi = mf.directional(z, d, **al)
        for t in (0.0, 0.3, 1.0, -0.7):
            want = float(mf.gradient(z + t * d, **al) @ d)
            scale = float(np.abs(mf.gradient(z + t * d, **al)) @ np.abs(d))
            assert dphi(t) == pytest.approx(want, abs=1e-12 * scale), (kind, trial, t)
