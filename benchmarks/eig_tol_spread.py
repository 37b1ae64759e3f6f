#!/usr/bin/env python
"""How far apart do three ways of computing the least eigenvalue of (H, K) lie?

``gaocvx.nonconvex.probes.hessian_stability`` labels an equilibrium stable when
``H - t K`` is positive definite and unstable when ``H + t K`` is not, with the
threshold ``t = whole_beam.eig_tol(N)`` (``1e-17 N^4`` beyond 178 elements: K's
condition grows as N^4).  The threshold must exceed the round-off of the least
``mu`` of the pencil (H, K), which this script estimates by its spread over
three computations: scipy's dense generalized ``eigh``, the same on the
Jacobi-scaled pencil, and shift-invert Lanczos (``eigsh``) on the sparse pencil.

The equilibria are those of the P1 beam on a unilateral bed at gap 0 of
docs/nonconvex.md's near-flat section (1 m, E = 2.1e11, nu = 0.3, h = 0.1 m,
b = 1 m, bed 5.837e10 N/m^2, q = -2.66e-3 N/m, P = 6e9 N): the buckled beam, the
beam pressed 1e-13 m into the bed and its lifted twin (``mu`` 0.55, 0.39 and
-0.28).  A row whose spread comes near ``eig_tol`` means the label's threshold
no longer covers the round-off at that size: probes.HESSIAN_ELEMENTS is where
it was last measured.

Usage::

    python benchmarks/eig_tol_spread.py 480 1024 2048

(dense solves of 2N unknowns: 11 s a pencil at 2048 elements).
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gaocvx import Scene  # noqa: E402
from gaocvx.discrete import DiscreteProblem  # noqa: E402
from gaocvx.nonconvex.stationary import equilibria  # noqa: E402
from gaocvx.nonconvex.whole_beam import eig_tol  # noqa: E402


def scene(elements):
    return Scene.from_dict({
        "beam": {"model": "gao", "supports": "P1", "length": 1.0, "E": 2.1e11, "nu": 0.3,
                 "half_thickness": 0.1, "width": 1.0},
        "load": {"q": -0.0026624409517740765, "axial": 6e9},
        "mesh": {"elements": elements},
        "foundation": {"gap": 0.0, "stiffness": 58370133953.11117}})


def least_mu(H, K):
    """The least eigenvalue of (H, K) three ways."""
    Hd, Kd = H.toarray(), K.toarray()
    dense = sla.eigh(Hd, Kd, eigvals_only=True, subset_by_index=[0, 0])[0]
    d = 1.0 / np.sqrt(np.diag(Kd))
    scaled = sla.eigh(d[:, None] * Hd * d, d[:, None] * Kd * d, eigvals_only=True,
                      subset_by_index=[0, 0])[0]
    # (shift below every eigenvalue: the least is the largest of (H + K)^-1 K)
    lanczos = spla.eigsh(sp.csc_matrix(H), k=1, M=sp.csc_matrix(K), sigma=-1.0,
                         which="LM", return_eigenvectors=False)[0]
    return float(dense), float(scaled), float(lanczos)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("elements", type=int, nargs="+")
    args = ap.parse_args(argv)
    print(f"{'N':>6} {'energy [J]':>12} {'mu dense':>12} {'mu scaled':>12} {'mu Lanczos':>12} "
          f"{'spread':>9} {'eig_tol':>9} {'s':>4}")
    for n in args.elements:
        sc = scene(n)
        dp = DiscreteProblem(sc, check_convexity=False)
        for e in equilibria(sc):
            u = dp.from_physical(e.w, e.slope)
            t = time.perf_counter()
            mus = least_mu(dp.hessian(u), dp.K)
            print(f"{n:>6} {e.energy:>12.4g} {mus[0]:>12.8f} {mus[1]:>12.8f} {mus[2]:>12.8f} "
                  f"{max(mus) - min(mus):>9.2e} {eig_tol(n):>9.2e} "
                  f"{time.perf_counter() - t:>4.0f}", flush=True)


if __name__ == "__main__":
    main()
