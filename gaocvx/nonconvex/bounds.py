"""A box in the mode amplitudes that contains every global minimiser.

With ``t = u'G u = ∫ (w')^2`` (non-dimensional, L = 1) the 5-point Gauss rule
integrates ``(w')^4`` exactly, so by Cauchy-Schwarz the Gao term is at least
``a/12 t^2``; the bending and load terms are at least ``-c0``,
``c0 = f'K^-1 f / 2``, and a foundation costs nothing negative.  Hence
(nonconvex.md)::

    Pi(u) >= a/12 t^2 - p/2 t - c0,

and a minimiser has ``Pi <= U`` for any feasible energy ``U`` (that of w = 0,
admissible since gaps are >= 0: 0, or a bonded bed's 1/2 c g^2 L).  That bounds ``t``, and the amplitudes
``s = Phi'G u`` satisfy ``|s|^2 <= t`` (G-orthogonal split).

Without the quartic term (Euler-Bernoulli, or ``E_alpha = 0``) nothing bounds
the energy from below above ``P_bar_h``: the beam can buckle away from a
unilateral foundation or an obstacle without limit.  Such a scene has no
minimiser and is refused.

Examples
--------
>>> t_max(a=12.0, p=2.0, c0=0.0, upper=0.0)      # t^2 - t <= 0
1.0
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError, apart

__all__ = ["t_max", "amplitude_box", "equilibrium_box", "check_bounded", "zoom_boxes",
           "mode_amplitudes", "estimate_boxes"]


def t_max(a: float, p: float, c0: float, upper: float) -> float:
    """The largest ``t >= 0`` with ``a/12 t^2 - p/2 t - c0 <= upper`` (``a > 0``)."""
    A, B, C = a / 12.0, p / 2.0, c0 + upper
    if C < 0:  # the upper bound lies below the energy's lower bound at every t >= 0 ...
        C = 0.0  # ... only through round-off; the larger root then still bounds t
    return float((B + math.sqrt(B * B + 4.0 * A * C)) / (2.0 * A))


def check_bounded(dp) -> None:
    """Refuse a scene whose energy is unbounded below above ``P_bar_h``.

    Raises
    ------
    SceneError
        On ``load.axial`` when the quartic Gao term is absent (``a == 0``).
    """
    if dp.a > 0:
        return
    model = dp.scene.beam.model
    why = ("the Euler-Bernoulli energy" if model != "gao" else "this Gao beam (E_alpha = 0)")
    P, value = apart(dp.P, dp.P_bar_h)
    limit = f"the convexity limit P_bar_h = {value} N"
    if dp.contact == "foundation" and getattr(dp, "bilateral", False):
        held = "its bonded foundation holds it only up to P_hat_h"
        P, value = apart(dp.P, dp.P_hat_h)
        limit = f"the bonded beam's convexity limit P_hat_h = {value} N"
    elif dp.contact == "foundation":
        held = "a unilateral foundation cannot stop the beam buckling upwards"
    elif dp.contact == "obstacle" and getattr(dp, "g_above", None) is None:
        held = "an obstacle below cannot stop the beam buckling upwards"
    elif dp.contact == "obstacle":
        # A channel does bound the energy: with |w| <= g, ∫(w')^2 <= g ∫|w''| (by
        # parts), so bending, quadratic in w'', outgrows the axial term (short
        # waves cost EI k^4 against P k^2).  A minimiser exists; but the box of
        # mode amplitudes, the scale of the certified gap and the one-mode
        # estimate all come from the quartic term (a trial without it certified a
        # gap of 867 J as 0 of the scale): refused, for what it is.
        raise SceneError("load.axial", f"P = {P} N is at or above {limit}, where "
                         f"{why} has no quartic term; a channel bounds it from below (a "
                         "minimiser exists), but the global method bounds the buckling "
                         "amplitudes by the quartic term and does not take this scene", dp.P)
    else:
        held = "nothing stops the buckling amplitude"
    raise SceneError("load.axial", f"P = {P} N is at or above {limit}, where {why} has "
                     f"no quartic term and is unbounded below ({held}): there is no minimiser",
                     dp.P)


def load_constant(dp) -> float:
    """``c0 = f'K^-1 f / 2`` (non-dimensional): minus the minimum of the bending-plus-load energy."""
    if dp.n == 0 or not np.any(dp.f):
        return 0.0
    return 0.5 * float(dp.f @ dp._K_chol.solve(dp.f))


def amplitude_box(dp, k: int, upper: float = 0.0, lam1: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The box ``[-S, S]^k`` of mode amplitudes containing every point with ``Pi <= upper``.

    Besides the bound of the module's notes, part of the bending energy can pay
    for the axial term: for ``0 <= theta < 1``,
    ``1/2 u'K u - f'u >= theta/2 u'K u - c0/(1 - theta)`` and
    ``u'K u >= lambda_1 t``, so ``Pi >= a/12 t^2 - (p - theta lambda_1)/2 t -
    c0/(1 - theta)``.  Near ``lambda_1`` without load this shrinks the box by
    ``sqrt(p / (p - lambda_1))`` (measured: 122 to 4 at P = 1.001 lambda_1);
    the smallest ``t`` over a few ``theta`` is taken.

    Parameters
    ----------
    dp : DiscreteProblem
        With ``a > 0`` (see :func:`check_bounded`).
    k : int
        Number of unstable modes.
    upper : float
        A feasible energy (non-dimensional); 0, the energy of w = 0, by default.
    lam1 : float
        A lower bound of the smallest eigenvalue of ``(K, G)`` (0: not used).

    Returns
    -------
    lo, hi : ndarray
    """
    c0 = load_constant(dp)
    thetas = [0.0] if lam1 <= 0 else [0.0] + [1.0 - 10.0**-j for j in range(1, 13)]
    S = math.sqrt(min(t_max(dp.a, dp.p - th * lam1, c0 / (1.0 - th), upper) for th in thetas))
    # A relative margin: the bound is exact, but its inputs carry round-off.
    S *= 1.0 + 1e-9
    return -S * np.ones(k), S * np.ones(k)


def equilibrium_box(dp, lam1: float) -> float:
    """A bound ``S`` on the amplitude ``|s|`` of every equilibrium (non-dimensional).

    At an equilibrium ``grad Pi(u) . u = 0`` (an obstacle's multipliers make it
    ``lam' levels <= 0``), i.e.
    ``a/3 ∫(w')^4 + u'K u - p t - f'u + grad F . u <= 0``.  With
    ``∫(w')^4 >= t^2``, ``u'K u >= lambda_1 t``, ``f'u <= eps/2 u'K u + c0/eps``
    (``0 < eps < 2``) and ``grad F . u >= 0`` for a unilateral foundation
    (``>= -Σ c w_q g^2 / 4`` for a bonded one), ``t`` is at most the larger root
    of ``a/3 t^2 - (p - (1 - eps/2) lambda_1) t - c0/eps - c_F``, and
    ``|s|^2 <= t``.  The smallest over a few ``eps`` is taken.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> dp = SimpleNamespace(a=3.0, p=2.0, f=np.zeros(1), n=1, contact=None)
    >>> round(equilibrium_box(dp, 1.0), 6)      # t^2 - (2 - (1 - eps/2)) t <= 0, eps -> 0
    1.0
    """
    c0 = load_constant(dp)
    cf = 0.0
    if dp.contact == "foundation" and getattr(dp, "bilateral", False):
        cf = float(np.sum(np.broadcast_to(dp.c * dp.wq_c, dp.wq_c.shape)
                          * np.broadcast_to(dp.g, dp.wq_c.shape) ** 2)) / 4.0
    best = math.inf
    for eps in ([1e-12] if c0 == 0 else [10.0**-j for j in range(0, 13)] + [1.5, 1.9]):
        A, B, C = dp.a / 3.0, dp.p - (1.0 - eps / 2.0) * lam1, c0 / eps + cf
        t = (B + math.sqrt(B * B + 4.0 * A * C)) / (2.0 * A)
        best = min(best, max(t, 0.0))
    return math.sqrt(best) * (1.0 + 1e-9)


def zoom_boxes(dp, modes, lo, hi) -> list:
    """Boxes of amplitudes in which the unstable modes reach the obstacle.

    A beam held by an obstacle 1.6 cm below, buckled 21 cm by itself, has its
    equilibria on the obstacle within 8 % of the amplitudes' range: the 25 x 25
    grid's step.  A trial found stable equilibria missed in 19 of 40 scenes with
    two modes and an obstacle or channel (P2 resting on an obstacle, P1 in
    channels, P4 on obstacles 0.05-0.2 mm below).  For each distance of the
    obstacle's surfaces from the beam (the nearest and the farthest point of
    each), the box of half-width three times the amplitude at which a mode
    alone reaches it, when that is less than a quarter of the grid's range.
    Used by both searches (:mod:`.stationary`, one mode; :mod:`.stationary2`).
    """
    peak = np.max(np.abs(modes.phi[dp._w_rows()]), axis=0)
    dist = [float(np.min(np.abs(dp.g))), float(np.max(np.abs(dp.g)))]
    if dp.g_above is not None:
        dist.append(float(np.min(dp.g_above)))
        dist.append(float(np.max(dp.g_above)))
    boxes, sizes = [], []
    for d in sorted(set(x for x in dist if x > 0)):
        half = 3.0 * d / np.maximum(peak, 1e-300)
        a, b = np.maximum(lo, -half), np.minimum(hi, half)
        if np.all(half < 0.25 * (hi - lo)) and np.all(b > a) and \
                not any(np.all(half <= 2.0 * h) for h in sizes):
            boxes.append((a, b))
            sizes.append(half)
    return boxes


def mode_amplitudes(dp, modes, count: int | None = None) -> np.ndarray:
    """The one-mode estimates ``A_j = sqrt(3 (p - lambda_j) / (a int phi_j'^4))`` of
    the first ``count`` (default: the unstable) modes' buckled amplitudes
    (non-dimensional, G-normalised; 0 where ``p <= lambda_j``): nonconvex.md."""
    k = modes.k if count is None else count
    slopes = dp.B1 @ modes.phi[:, :k]
    quartic = np.asarray(dp.wq_gao @ slopes**4, float)
    return np.sqrt(np.maximum(3.0 * (dp.p - np.asarray(modes.lam[:k], float))
                              / (dp.a * quartic), 0.0))


def estimate_boxes(dp, modes, lo, hi) -> list:
    """The box of amplitudes where the one-mode estimates put the buckled beam:
    half-width four times the largest :func:`mode_amplitudes`, when that is less
    than a quarter of the grid's range (else none).

    The equilibrium box bounds the amplitudes, and can be far wider than the
    equilibria: with a bonded foundation it has no lambda_1 to use, and a P4 beam
    on one, 1e-4 above its limit under a symmetric load table (one mode, 10
    elements), had all three equilibria (s = -4.5, 0, 4.5) within one step of a
    121-point grid over S = 754; one was found, and not its mirror image, the
    certified global minimiser.  Used by both searches, as :func:`zoom_boxes`.
    """
    half = 4.0 * float(np.max(mode_amplitudes(dp, modes), initial=0.0))
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    a, b = np.maximum(lo, -half), np.minimum(hi, half)
    if half > 0.0 and np.all(half < 0.25 * (hi - lo)) and np.all(b > a):
        return [(a, b)]
    return []
