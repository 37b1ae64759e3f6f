"""How far the thesis's CVM (piecewise-linear control) is from the convex minimiser,
as the mesh is refined, for every support and transform.

    python benchmarks/cvm_convergence.py [--output docs/cvm-convergence.md]

The piecewise-linear control reaches only a subspace of the Hermite states, so
the CVM optimum is a different discretisation; the table shows the relative
max nodal difference |w_cvm - w_convex| / max |w_convex| and the relative energy
gap, with the order fitted over the meshes where the difference is above 1e-12.
"""

import argparse
import sys

import numpy as np

from gaocvx import Scene, solve

BEAM = {"model": "gao", "length": 1.0, "E": 2.1e11, "nu": 0.3, "half_thickness": 0.1,
        "width": 1.0}
SIZES = [4, 8, 16, 32, 64, 128]
FLOOR = 1e-9  # differences below this are the solvers' own tolerance, not discretisation
CASES = [
    ("P1", "T1", "bending", {"q": -1e8, "axial": 1e9}, None),
    ("P2", "T1", "bending", {"q": -1e8, "axial": 5e8}, None),
    ("P3", "T1", "bending", {"q": -1e8, "axial": 5e7}, None),
    ("P3", "T2", "bending", {"q": -1e8, "axial": 5e7}, None),
    ("P4", "T1", "bending", {"q": -1e8, "axial": 5e8}, None),
    ("P4", "T3", "bending", {"q": -1e8, "axial": 5e8}, None),
    ("P1", "T1", "foundation", {"q": -5e8}, {"gap": 0.007, "stiffness": 5e10}),
    ("P2", "T1", "foundation", {"q": -5e8}, {"gap": 0.007, "stiffness": 5e10}),
    ("P3", "T2", "foundation", {"q": -5e7}, {"gap": 0.02, "stiffness": 5e8}),
    ("P4", "T3", "foundation", {"q": -1e8}, {"gap": 0.007, "stiffness": 5e10}),
]


def run():
    rows = []
    for supports, transform, kind, load, found in CASES:
        errs, gaps = [], []
        for n in SIZES:
            data = {"beam": {**BEAM, "supports": supports}, "load": load, "mesh": {"elements": n},
                    "solve": {"method": "cvm", "transform": transform, "control": "P1"}}
            if found:
                data["foundation"] = found
            scene = Scene.from_dict(data)
            cvm = solve(scene)
            truth = solve(scene, "newton")
            if not (cvm.success and truth.success):
                raise SystemExit(f"not certified: {supports} {transform} {n}: {cvm.message}")
            errs.append(np.abs(cvm.w - truth.w).max() / np.abs(truth.w).max())
            gaps.append(cvm.extra["cvm"]["energy_gap"] / abs(truth.energy))
        errs = np.array(errs)
        # Fit over the leading run of meshes above the solvers' accuracy floor.
        k = 1 if errs[0] < FLOOR else 0
        start = k
        while k < len(errs) and errs[k] > FLOOR:
            k += 1
        order = (-np.polyfit(np.log(SIZES[start:k]), np.log(errs[start:k]), 1)[0]
                 if k - start >= 2 else float("nan"))
        rows.append((supports, transform, kind, errs, gaps, order))
        print(supports, transform, kind, " ".join(f"{e:.1e}" for e in errs), f"order {order:.1f}",
              file=sys.stderr)
    return rows


def markdown(rows, command):
    head = "| supports | transform | scene | " + " | ".join(f"N={n}" for n in SIZES) + \
        " | fitted order | energy gap at N=128 |"
    out = ["# CVM with the piecewise-linear control: convergence to the convex minimiser", "",
           f"Made by `{command}`. Gao beam (L = 1 m, h = 0.1 m, b = 1 m, nu = 0.3, E = 2.1e11 Pa); "
           "'bending' is q = -1e8 N/m with a compressive axial force, 'foundation' a loaded beam "
           "on a unilateral foundation. Entries: max |w_cvm - w_convex| / max |w_convex| at the "
           f"nodes. The order is fitted (log-log least squares) over the leading run of meshes "
           f"whose difference is above {FLOOR:g}; below that it is the solvers' tolerance, not "
           "the discretisation (P1 with 4 elements has almost as many controls as states and is "
           "left out of the fit for that reason too). The energy gap "
           "Pi_T(w_cvm) - Pi_T(w_convex) is relative to |Pi_T(w_convex)|.", "",
           head, "|" + "---|" * (len(SIZES) + 5)]
    for supports, transform, kind, errs, gaps, order in rows:
        out.append(f"| {supports} | {transform} | {kind} | " + " | ".join(f"{e:.1e}" for e in errs)
                   + f" | {order:.1f} | {gaps[-1]:.1e} |")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--output")
    args = ap.parse_args()
    command = "python benchmarks/cvm_convergence.py" + (f" --output {args.output}" if args.output else "")
    text = markdown(run(), command)
    if args.output:
        open(args.output, "w").write(text)
    print(text)
