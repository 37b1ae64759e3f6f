"""What the mixed form of a mesh depends on only: quadrature maps, KKT layout, the cache."""


from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp

from .. import fem
from ..cache import LRU
from ..discrete import DiscreteProblem
from ..hermite import CONTACT_POINTS, GAO_POINTS
from ..linalg import VectorCSR


__all__ = ["MixedStructure", "structure_of", "structure_key", "clear_cache"]


def _rows(x, pts, elem, kind):
    """Sparse rows giving w (kind 0), w' (1) or w'' (2) at ``pts`` from the full z vector."""
    h = np.diff(x)[elem]
    t = (pts - x[elem]) / h
    w_i, th_i, d_i, th_j = 3 * elem, 3 * elem + 1, 3 * elem + 2, 3 * elem + 4
    if kind == 0:
        cols = [w_i, d_i, th_i, th_j]
        vals = [np.ones_like(t), h * (3 * t**2 - 2 * t**3), h * (t - 2 * t**2 + t**3),
                h * (t**3 - t**2)]
    elif kind == 1:
        cols = [d_i, th_i, th_j]
        vals = [6 * t - 6 * t**2, 1 - 4 * t + 3 * t**2, 3 * t**2 - 2 * t]
    else:
        cols = [d_i, th_i, th_j]
        vals = [(6 - 12 * t) / h, (6 * t - 4) / h, (6 * t - 2) / h]
    n = len(pts)
    rows = np.tile(np.arange(n), len(cols))
    return rows, np.concatenate(cols), np.concatenate(vals), n


class MixedStructure:
    """The parts of the mixed form that depend only on the mesh and the supports.

    Parameters
    ----------
    xi : ndarray
        Non-dimensional node positions.
    supports : str
        "P1" ... "P4".
    slope : bool
        Build the slope quadrature (Gao term or axial force).
    contact : {None, "foundation", "obstacle"}
        Build the contact quadrature (and for an obstacle its constraint rows).

    Notes
    -----
    The KKT matrix ``[[H, C'], [C, 0]]`` is stored in LAPACK band form in the
    interleaved order.  Its entries are linear in the weights of the
    Hessian's quadrature terms: ``B' diag(d) B`` adds ``d_q b_qi b_qj`` to entry
    (i, j).  :meth:`weight_map` precomputes, for a quadrature matrix B, the
    sparse matrix that maps ``d`` to those band entries.
    """

    def __init__(self, xi, supports: str, slope: bool, contact: str | None):
        x = np.asarray(xi, float)
        self.xi = x
        N = len(x) - 1
        self.N = N
        self.nz = 3 * N + 2
        fw0, ft0, fwN, ftN = fem.FIXED_ENDS[supports]
        fixed = [i for i, f in zip((0, 1, 3 * N, 3 * N + 1), (fw0, ft0, fwN, ftN)) if f]
        mask = np.ones(self.nz, dtype=bool)
        mask[fixed] = False
        self.free = np.flatnonzero(mask)
        self.n = len(self.free)
        self.w_index = np.flatnonzero(self.free % 3 == 0)  # the free deflections w_i within z
        self.d_index = np.flatnonzero(self.free % 3 == 2)  # the chord slopes D_e (never fixed)
        self.has_slope = slope
        self.contact = contact

        def matrix(pts, elem, kind):
            r, c, v, n = _rows(x, pts, elem, kind)
            return sp.csr_matrix((v, (r, c)), shape=(n, self.nz))[:, self.free].tocsr()

        xq, self.wq2, e = fem.gauss_points(x, 2)
        self.B2 = matrix(xq, e, 2)
        self.B2T = self.B2.T.tocsr()
        if slope:
            xq, self.wq5, e = fem.gauss_points(x, GAO_POINTS)
            self.B1 = matrix(xq, e, 1)
            self.B1T = self.B1.T.tocsr()
        if contact is not None:
            xq, self.wqc, e = fem.gauss_points(x, CONTACT_POINTS)
            self.Nq = matrix(xq, e, 0)
            self.NqT = self.Nq.T.tocsr()
        if contact in ("obstacle", "channel"):
            # w >= g at the nodes (the variables w_i themselves) and at the Gauss
            # points, as the convex program; rows that touch no free DOF are dropped.
            # A channel adds w <= g_above on the same points: the rows again, negated
            # (multipliers >= 0 each; the force on the beam is lam_below - lam_above).
            nodes = sp.csr_matrix((np.ones(N + 1), (np.arange(N + 1), 3 * np.arange(N + 1))),
                                  shape=(N + 1, self.nz))[:, self.free]
            A = sp.vstack([nodes, self.Nq]).tocsr()
            keep = np.flatnonzero(np.diff(A.indptr) > 0)
            pts = np.concatenate([x, xq])
            self.A = A[keep]
            self.AT = self.A.T.tocsr()
            self.con_points = pts[keep]
            # The same rows on the full Hermite DOFs: multipliers -> consistent nodal forces.
            self.A_hermite = sp.vstack([fem.eval_matrix(x, x, 0),
                                        fem.eval_matrix(x, xq, 0, e)]).tocsr()[keep]
            self.n_below = len(keep)   # rows of the surface below; the rest: above
            if contact == "channel":
                self.A = sp.vstack([self.A, -self.A]).tocsr()
                self.AT = self.A.T.tocsr()
                self.A_hermite = sp.vstack([self.A_hermite, -self.A_hermite]).tocsr()
                self.con_points = np.r_[self.con_points, self.con_points]
        # Linking constraint rows: w_{e+1} - w_e - h_e D_e = 0.
        h = np.diff(x)
        e = np.arange(N)
        rows = np.repeat(e, 3)
        cols = np.stack([3 * e + 3, 3 * e, 3 * e + 2], 1).ravel()
        vals = np.stack([np.ones(N), -np.ones(N), -h], 1).ravel()
        self.C = sp.csr_matrix((vals, (rows, cols)), shape=(N, self.nz))[:, self.free].tocsr()
        self.CT = self.C.T.tocsr()   # (a transpose per refinement step cost a sixth of a search)
        # Products with vectors are the solvers' inner loop: scipy's kernel called directly.
        for name in ("B2", "B2T", "B1", "B1T", "Nq", "NqT", "A", "AT", "C", "CT"):
            if hasattr(self, name):
                setattr(self, name, VectorCSR(getattr(self, name)))
        self._layout()
        self.base_factors = LRU(4)  # KKT factors of H0, by p (see MixedForm.quadratic_factor)
        self._stacked = {}  # stacked weight maps, by the terms present (see stacked_map)

    # ---------------------------------------------------------------- band layout
    def _layout(self):
        """Interleaved KKT order (multiplier e right after D_e) and its bandwidths."""
        keys = np.concatenate([self.free.astype(float), 3 * np.arange(self.N) + 2.5])
        self.order = np.argsort(keys, kind="stable")
        self.position = np.empty_like(self.order)
        self.position[self.order] = np.arange(len(self.order))
        self.nk = len(self.order)
        # Every term couples only the variables of one element (and C its two
        # nodes), so the union of their patterns bounds the band.
        quads = [self.B2] + ([self.B1] if self.has_slope else []) \
            + ([self.Nq] if self.contact else []) \
            + ([self.A] if self.contact in ("obstacle", "channel") else [])
        bw = 0
        for B in quads:
            B = B.tocsr()
            pos = self.position[B.indices]
            starts = B.indptr[:-1][np.diff(B.indptr) > 0]
            spread = np.maximum.reduceat(pos, starts) - np.minimum.reduceat(pos, starts)
            bw = max(bw, int(np.max(spread, initial=0)))
        Cc = self.C.tocoo()
        d = self.position[self.n + Cc.row] - self.position[Cc.col]
        # The matrix is symmetric: one bandwidth below and above.
        self.lo = self.up = max(bw, int(np.max(np.abs(d), initial=0)))
        self.band_shape = (2 * self.lo + self.up + 1, self.nk)

    def _index(self, r, c):
        """Flat index in the gbtrf band array of KKT entries (r, c) (KKT positions)."""
        return (self.lo + self.up + r - c) * self.nk + c

    def weight_map(self, B) -> sp.csc_matrix:
        """Sparse M with ``band += M @ d`` adding ``B' diag(d) B`` to the KKT band.

        Column q of M holds ``b_qi b_qj`` at the band entry of every pair (i, j)
        of row q of B (short rows are padded with zero entries).
        """
        B = B.tocsr()
        size = self.band_shape[0] * self.nk
        if B.nnz == 0:
            return sp.csc_matrix((size, B.shape[0]))
        counts = np.diff(B.indptr)
        k = int(np.max(counts, initial=0))
        nq = B.shape[0]
        slot = np.arange(B.nnz) - np.repeat(B.indptr[:-1], counts)
        row = np.repeat(np.arange(nq), counts)
        # Padding repeats a column of the row, so every index stays inside the band.
        first = self.position[B.indices[np.minimum(B.indptr[:-1], B.nnz - 1)]]
        cols = np.repeat(first[:, None], k, axis=1)
        vals = np.zeros((nq, k))
        cols[row, slot] = self.position[B.indices]
        vals[row, slot] = B.data
        index = self._index(cols[:, :, None], cols[:, None, :]).reshape(nq, k * k)
        data = (vals[:, :, None] * vals[:, None, :]).reshape(nq, k * k)
        if not (np.all(index >= 0) and np.all(index < size)):  # scipy would not check
            raise AssertionError("a quadrature row reaches outside the KKT band")
        return sp.csc_matrix((data.ravel(), index.ravel(), np.arange(0, nq * k * k + 1, k * k)),
                             shape=(size, nq))

    def band_of(self, S) -> np.ndarray:
        """Flat band array of a sparse matrix on the z variables (KKT order)."""
        S = sp.coo_matrix(S)
        ab = np.zeros(self.band_shape[0] * self.nk)
        np.add.at(ab, self._index(self.position[S.row], self.position[S.col]), S.data)
        return ab

    @functools.cached_property
    def link_band(self) -> np.ndarray:
        """The constraint blocks C and C' of the KKT matrix, flat band array."""
        Cc = self.C.tocoo()
        ab = np.zeros(self.band_shape[0] * self.nk)
        r, c = self.position[self.n + Cc.row], self.position[Cc.col]
        np.add.at(ab, self._index(r, c), Cc.data)
        np.add.at(ab, self._index(c, r), Cc.data)
        return ab

    @functools.cached_property
    def bending(self) -> sp.csr_matrix:
        """Bending Hessian B2' diag(w) B2 (constant)."""
        return (self.B2T @ sp.diags(self.wq2) @ self.B2).tocsr()

    @functools.cached_property
    def axial(self) -> sp.csr_matrix:
        """Geometric (axial) Hessian B1' diag(w) B1: the axial energy is -p/2 z' axial z."""
        return (self.B1T @ sp.diags(self.wq5) @ self.B1).tocsr()

    @functools.cached_property
    def bending_band(self) -> np.ndarray:
        """KKT band of the bending Hessian with the constraint blocks (flat)."""
        return self.band_of(self.bending) + self.link_band

    @functools.cached_property
    def axial_band(self) -> np.ndarray:
        """KKT band of the axial Hessian (flat; enters with the factor -p)."""
        return self.band_of(self.axial)

    @functools.cached_property
    def slope_map(self) -> sp.csc_matrix:
        """Weights at the slope points -> band entries (Gao term)."""
        return self.weight_map(self.B1)

    @functools.cached_property
    def contact_map(self) -> sp.csc_matrix:
        """Weights at the contact points -> band entries (foundation)."""
        return self.weight_map(self.Nq)

    @functools.cached_property
    def obstacle_map(self) -> sp.csc_matrix:
        """Weights at the obstacle's constraint points -> band entries (penalty)."""
        return self.weight_map(self.A)

    def stacked_map(self, terms: tuple) -> sp.csc_matrix:
        """The maps of ``terms`` (names among slope, contact, obstacle) side by side."""
        stacked = self._stacked.get(terms)
        if stacked is None:
            maps = [getattr(self, name + "_map") for name in terms]
            stacked = self._stacked[terms] = (maps[0] if len(maps) == 1
                                              else sp.hstack(maps, format="csc"))
        return stacked


# Structures of recent meshes, shared by the scenes solved on them (sweeps).
_STRUCTURES = LRU(4, per_thread=True)


def clear_cache() -> None:
    """Forget this thread's cached mesh structures (benchmarks of first solves use it)."""
    _STRUCTURES.clear()


def structure_key(dp: DiscreteProblem) -> tuple:
    """What a :class:`MixedStructure` depends on: supports, mesh, and the terms present."""
    contact = "channel" if dp.contact == "obstacle" and dp.g_above is not None else dp.contact
    return (dp.scene.beam.supports, dp.xi.tobytes(), bool(dp.needs_gao or dp.p != 0), contact)


def structure_of(dp: DiscreteProblem, slope: bool = False) -> MixedStructure:
    """The (cached) :class:`MixedStructure` of a problem's mesh, supports and terms.

    ``slope``: with the slope rows even where the energy has no slope term (the
    buckling pencil's ``G`` is that term's form, whatever the energy holds).
    """
    supports, xi, has_slope, contact = structure_key(dp)
    key = (supports, xi, has_slope or slope, contact)
    s = _STRUCTURES.get(key)
    if s is None:
        supports, _, slope, contact = key
        s = _STRUCTURES.put(key, MixedStructure(dp.xi, supports, slope, contact))
    return s


