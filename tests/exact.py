"""Independent exact solutions of the Euler-Bernoulli beam (no FEM involved).

``EI w'''' + P w'' = q(x) + sum_k F_k delta(x - a_k)`` on (0, L), with q
piecewise linear, solved as a piecewise function: on every segment between
breakpoints (load-table rows, point forces) the general solution is a
homogeneous part plus a polynomial particular part, and the 4 * segments
unknown coefficients come from the support conditions and the continuity and
jump conditions, as in a textbook.  P = 0 uses the homogeneous basis
1, s, s^2, s^3; P != 0 uses 1, s, cos(ks), sin(ks) (compression) or
1, s, cosh(ks), sinh(ks) (tension).
"""

import numpy as np

BC = {  # (derivative orders fixed at x = 0), (at x = L)
    "P1": ((0, 1), (0, 1)),
    "P2": ((0, 1), (0, 2)),
    "P3": ((0, 1), (2, 3)),
    "P4": ((0, 2), (0, 2)),
}


class ExactBeam:
    def __init__(self, supports, L, EI, q=0.0, points=(), P=0.0):
        self.L, self.EI, self.P = L, EI, P
        if np.isscalar(q):
            table = np.array([[0.0, q], [L, q]])
        else:
            table = np.asarray(q, float)
        self.table = table
        cuts = {0.0, L, *[float(a) for a, _ in points]}
        cuts |= {float(t) for t in table[:, 0] if 0 < t < L}
        self.x = np.array(sorted(cuts))
        self.k = np.sqrt(abs(P) / EI)
        nseg = len(self.x) - 1
        n = 4 * nseg
        A, b = [], []

        def row(seg, s, d):
            r = np.zeros(n)
            r[4 * seg:4 * seg + 4] = self._basis(s, d)
            return r

        def part(seg, s, d):
            return self._particular(seg, s, d)

        left, right = BC[supports]
        for d in left:  # homogeneous support conditions: w^(d) = 0
            A.append(row(0, 0.0, d)); b.append(-part(0, 0.0, d))
        hl = self.x[-1] - self.x[-2]
        for d in right:
            r = row(nseg - 1, hl, d)
            rhs = -part(nseg - 1, hl, d)
            if supports == "P3" and d == 3 and P != 0:
                # free end: EI w''' + P w' = 0 (shear with the axial force)
                r = r + (P / EI) * row(nseg - 1, hl, 1)
                rhs = rhs - (P / EI) * part(nseg - 1, hl, 1)
            A.append(r); b.append(rhs)
        forces = {float(a): 0.0 for a, _ in points}
        for a, F in points:
            forces[float(a)] += F
        for j in range(1, nseg):
            h = self.x[j] - self.x[j - 1]
            for d in range(4):
                r = row(j - 1, h, d) - row(j, 0.0, d)
                rhs = part(j, 0.0, d) - part(j - 1, h, d)
                if d == 3:  # EI (w'''(a+) - w'''(a-)) = F, and the row is (left - right)
                    rhs -= forces.get(float(self.x[j]), 0.0) / EI
                A.append(r); b.append(rhs)
        # A force exactly at the free end enters its shear condition:
        # EI w'''(L) + P w'(L) = -F.  Forces at supported ends are carried by the supports.
        if supports == "P3":
            b[len(left) + 1] -= forces.get(float(L), 0.0) / EI
        self.c = np.linalg.solve(np.array(A), np.array(b)).reshape(nseg, 4)

    def _basis(self, s, d):
        if self.P == 0:
            pw = [np.polyder(np.poly1d([1] + [0] * m), d) if d <= m else np.poly1d([0])
                  for m in range(4)]
            return np.array([p(s) for p in pw])
        k = self.k
        poly = [1.0 if d == 0 else 0.0, s if d == 0 else (1.0 if d == 1 else 0.0)]
        if self.P > 0:
            c = [np.cos, lambda t: -np.sin(t), lambda t: -np.cos(t), np.sin][d % 4]
            sn = [np.sin, np.cos, lambda t: -np.sin(t), lambda t: -np.cos(t)][d % 4]
        else:
            c = [np.cosh, np.sinh][d % 2]
            sn = [np.sinh, np.cosh][d % 2]
        return np.array(poly + [k**d * c(k * s), k**d * sn(k * s)])

    def _load_coeffs(self, seg):
        # q on the segment as q0 + q1 s (s local coordinate)
        x0, x1 = self.x[seg], self.x[seg + 1]
        qa = np.interp(x0 + 1e-14 * self.L, self.table[:, 0], self.table[:, 1], left=0, right=0)
        qb = np.interp(x1 - 1e-14 * self.L, self.table[:, 0], self.table[:, 1], left=0, right=0)
        return qa, (qb - qa) / (x1 - x0)

    def _particular(self, seg, s, d):
        q0, q1 = self._load_coeffs(seg)
        EI, P = self.EI, self.P
        if P == 0:
            p = np.poly1d([q1 / 120, q0 / 24, 0, 0, 0, 0]) / EI
        else:
            # EI w'''' + P w'' = q0 + q1 s  ->  w = q0 s^2/(2P) + q1 s^3/(6P)
            p = np.poly1d([q1 / (6 * P), q0 / (2 * P), 0, 0])
        return np.polyder(p, d)(s) if d else p(s)

    def __call__(self, x, d=0):
        x = np.atleast_1d(np.asarray(x, float))
        seg = np.clip(np.searchsorted(self.x, x, side="right") - 1, 0, len(self.x) - 2)
        out = np.empty_like(x)
        for i, (xi, j) in enumerate(zip(x, seg)):
            s = xi - self.x[j]
            out[i] = self.c[j] @ self._basis(s, d) + self._particular(j, s, d)
        return out
