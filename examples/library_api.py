"""gaocvx from Python: solve, evaluate, compare methods, sweep, verify and plot.

Run: python examples/library_api.py   (writes library_api.png beside it)
"""

from pathlib import Path

import numpy as np

from gaocvx import Scene, solve
from gaocvx.sweep import parse_range, sweep
from gaocvx.verify import verify

HERE = Path(__file__).parent

# A clamped Gao beam on a unilateral foundation (thesis table 4.13a).
scene = Scene.from_dict({
    "beam": {"model": "gao", "supports": "P1", "length": 1.0, "E": 2.1e11, "nu": 0.3,
             "half_thickness": 0.1, "width": 1.0},
    "load": {"q": -5e8},
    "foundation": {"gap": 0.007, "stiffness": 5e8},
})

result = solve(scene)                      # "auto": Newton, certified optimal
print(result.summary())
x = np.array([0.1, 0.5, 0.9])
print("w(x) =", result.deflection(x), "M(x) =", result.moment(x))

# The convex ground truth and the thesis's control variational method agree.
truth = solve(scene, "convex")
cvm = solve(scene.with_overrides({"solve.method": "cvm"}))
print("convex - newton:", np.abs(truth.w - result.w).max(), "m;",
      "cvm energy gap:", cvm.extra["cvm"]["energy_gap"], "J")

# How the penetration falls as the foundation stiffens.
for k, r in sweep(scene, "foundation.stiffness", parse_range("1e8:1e13:6:log")):
    print(f"k_F = {k:9.3g} N/m^2: penetration {max(-0.007 - r.min['w'], 0):.3e} m, "
          f"contact {r.zones}")

# Score a coarse result against the fine-mesh ground truth.
coarse = solve(scene, elements=8)
report = verify(scene, coarse.x, coarse.w, coarse.slope)
print(f"8 elements: energy gap {report['energy_gap']:.3g} J, "
      f"max deflection error {report['max_error_rel']:.2e} (relative)")

try:  # plotting needs matplotlib (pip install 'gaocvx[plot]')
    import matplotlib
    matplotlib.use("Agg")
    from gaocvx.plot import plot
    ax = plot(result)
    ax.figure.savefig(HERE / "library_api.png")
    print("wrote", HERE / "library_api.png")
except ImportError:
    pass
