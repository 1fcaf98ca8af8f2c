"""The two TOPP-RA passes (Pham & Pham 2018 §IV, Algorithm 1), one closed-form LP per stage.

The rows of a stage as lower and upper pieces ``u >= p x + q``, ``u <= P x + Q``
(:func:`_pieces`), the admissible sets ``X_i`` of all stages at once (:func:`_admissible_x`),
the backward pass over the controllable sets ``K_i`` (:func:`_backward`), the forward pass of
the largest admissible ``u_i`` (:func:`_forward`), and the names of the limits that block an
empty set (:func:`_blocking`). Split out of ``topp.py`` (issue 23); the algorithm is described
there.

Design
------
Part of the track room :mod:`mechkin.solvers.track`; numpy and
:mod:`mechkin.solvers.track.topp_problem` only.

References
----------
H. Pham, Q.-C. Pham, IEEE Trans. Robotics 34(3), 645-659, 2018: §IV (controllable sets,
Algorithm 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mechkin.solvers.track.topp_problem import A_ZERO_RTOL, SET_RTOL, ConstraintRows


@dataclass
class _Pieces:
    """Per-stage u-bounds ``u >= p x + q`` (lower) and ``u <= P x + Q`` (upper) (§IV)."""

    p: np.ndarray  # (K, m) lower slopes (0 where the piece is absent)
    q: np.ndarray  # (K, m) lower offsets (-inf where absent)
    P: np.ndarray  # (K, m) upper slopes
    Q: np.ndarray  # (K, m) upper offsets (+inf where absent)
    xl: np.ndarray  # (K,) lower x bound from x-only rows, velocity and x >= 0
    xh: np.ndarray  # (K,) upper x bound from x-only rows and velocity
    names: tuple[str, ...]
    xd_r: np.ndarray | None = None  # (K, m) x-only rows' lower bounds (-inf where none)
    xu_r: np.ndarray | None = None  # (K, m) x-only rows' upper bounds (+inf where none)
    x_lo: np.ndarray | None = None  # (K,) the velocity bounds alone
    x_hi: np.ndarray | None = None

    def without(self, keep: np.ndarray, rows: slice = slice(None)) -> _Pieces:
        """The pieces of the rows ``keep`` only (stages ``rows``), for the diagnostics."""
        assert self.xd_r is not None and self.xu_r is not None
        assert self.x_lo is not None and self.x_hi is not None
        xl = np.maximum(np.max(self.xd_r[rows][:, keep], axis=1, initial=0.0), self.x_lo[rows])
        xh = np.minimum(np.min(self.xu_r[rows][:, keep], axis=1, initial=np.inf), self.x_hi[rows])
        return _Pieces(
            self.p[rows][:, keep],
            self.q[rows][:, keep],
            self.P[rows][:, keep],
            self.Q[rows][:, keep],
            xl,
            xh,
            (),
        )


def _pieces(rows: ConstraintRows, x_lo: np.ndarray, x_hi: np.ndarray) -> _Pieces:
    """Split every row into a lower and an upper u-bound linear in x, or an x-only bound."""
    a, b, c = rows.a, rows.b, rows.c
    lo = np.broadcast_to(rows.lo, a.shape)
    hi = np.broadcast_to(rows.hi, a.shape)
    scale = np.max(np.abs(a), axis=0, initial=0.0)
    zero = np.abs(a) <= A_ZERO_RTOL * scale
    pos = a > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(zero, 0.0, 1.0 / np.where(zero, 1.0, a))
        slope = -b * inv
        q_lo = np.where(pos, (lo - c) * inv, (hi - c) * inv)  # u >= slope x + q_lo
        q_hi = np.where(pos, (hi - c) * inv, (lo - c) * inv)  # u <= slope x + q_hi
    q_lo = np.where(zero | np.isnan(q_lo), -np.inf, q_lo)
    q_hi = np.where(zero | np.isnan(q_hi), np.inf, q_hi)
    p = np.where(np.isfinite(q_lo), slope, 0.0)
    P = np.where(np.isfinite(q_hi), slope, 0.0)
    # x-only rows: lo - c <= b x <= hi - c
    with np.errstate(divide="ignore", invalid="ignore"):
        r_lo, r_hi = lo - c, hi - c
        xu = np.where(b > 0, r_hi / b, np.where(b < 0, r_lo / b, np.inf))
        xd = np.where(b > 0, r_lo / b, np.where(b < 0, r_hi / b, -np.inf))
    bad0 = (b == 0) & ((r_lo > 0) | (r_hi < 0))
    xu = np.where(bad0, -np.inf, np.where(np.isnan(xu), np.inf, xu))
    xd = np.where(bad0, np.inf, np.where(np.isnan(xd), -np.inf, xd))
    xu_r = np.where(zero, xu, np.inf)
    xd_r = np.where(zero, xd, -np.inf)
    xh = np.min(xu_r, axis=1, initial=np.inf)
    xl = np.max(xd_r, axis=1, initial=0.0)
    return _Pieces(
        p=p,
        q=q_lo,
        P=P,
        Q=q_hi,
        xl=np.maximum(xl, x_lo),
        xh=np.minimum(xh, x_hi),
        names=rows.names,
        xd_r=xd_r,
        xu_r=xu_r,
        x_lo=x_lo,
        x_hi=x_hi,
    )


def _admissible_x(pc: _Pieces) -> tuple[np.ndarray, np.ndarray]:
    """``X_i = [xl_i, xh_i]``: the x for which some u meets every row of stage i, all stages
    at once. ``max_r (p_r x + q_r) <= min_k (P_k x + Q_k)`` iff every pair's half-line holds."""
    xl, xh = pc.xl.copy(), pc.xh.copy()
    if pc.p.shape[1] == 0:
        return xl, xh
    k = pc.p[:, :, None] - pc.P[:, None, :]  # (K, m, m): k x <= rhs
    rhs = pc.Q[:, None, :] - pc.q[:, :, None]  # in (-inf, inf]; never inf - inf
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = rhs / k
    up = np.where(k > 0, bound, np.inf)
    dn = np.where(k < 0, bound, -np.inf)
    dead = np.any((k == 0) & (rhs < 0), axis=(1, 2))
    xh = np.minimum(xh, np.min(up, axis=(1, 2)))
    xl = np.maximum(xl, np.max(dn, axis=(1, 2)))
    xh = np.where(dead, -np.inf, xh)
    return xl, xh


def _tol(x: float) -> float:
    return SET_RTOL * max(abs(x), 1.0) if math.isfinite(x) else 0.0


def _dominated(v_lo: np.ndarray, v_hi: np.ndarray) -> np.ndarray:
    """``(K, m)`` mask of lower pieces that another piece of the same stage bounds from above
    at both ends of ``X_i`` (so on all of it: the pieces are linear); ties keep the first."""
    a_lo, b_lo = v_lo[:, None, :], v_lo[:, :, None]  # [i, r', r]: candidate r' vs piece r
    a_hi, b_hi = v_hi[:, None, :], v_hi[:, :, None]
    m = v_lo.shape[1]
    first = np.tri(m, m, -1, dtype=bool).T  # [r', r]: r' < r
    dom = (b_lo >= a_lo) & (b_hi >= a_hi) & ((b_lo > a_lo) | (b_hi > a_hi) | first[None])
    return np.any(dom, axis=1)


def _pruned(vals: tuple[np.ndarray, ...], keep: np.ndarray) -> tuple[list[list[float]], ...]:
    """Per-stage Python lists of the kept entries of each ``(K, m)`` array in ``vals``: the
    kept ones first, cut to the widest stage (the extra entries of narrower stages are
    dominated pieces: redundant, still valid)."""
    order = np.argsort(~keep, axis=1, kind="stable")
    width = int(np.max(keep.sum(axis=1), initial=0))
    order = order[:, :width]
    return tuple(np.take_along_axis(v, order, axis=1).tolist() for v in vals)


@dataclass
class _StageLists:
    """The non-dominated pieces of stages ``0..N-1`` as Python lists for the scalar passes:
    backward ``c x <= max K + e`` (lower pieces) and ``c x >= min K + e`` (upper pieces),
    forward ``u <= P x + Q``."""

    cL: list[list[float]]
    dL: list[list[float]]
    cU: list[list[float]]
    dU: list[list[float]]
    P: list[list[float]]
    Q: list[list[float]]


def _stage_lists(pc: _Pieces, X_lo: np.ndarray, X_hi: np.ndarray, d: np.ndarray) -> _StageLists:
    """Prune the pieces dominated on ``X_i`` (they cannot bind for any ``x`` in ``X_i``, and
    ``K_i`` and the forward states lie in ``X_i``) and build the coefficient lists, all
    stages at once. With an unbounded ``X_i`` the slopes stand in for the far end."""
    N = d.shape[0]
    xl, xh = X_lo[:N, None], X_hi[:N, None]
    fin = np.isfinite(xh)
    xh0 = np.where(fin, xh, 0.0)
    p, q, P, Q = pc.p[:N], pc.q[:N], pc.P[:N], pc.Q[:N]
    with np.errstate(invalid="ignore"):
        lo_l = p * xl + q
        hi_l = np.where(np.isfinite(q), np.where(fin, p * xh0 + q, p), -np.inf)
        lo_u = -(P * xl + Q)
        hi_u = np.where(np.isfinite(Q), np.where(fin, -(P * xh0 + Q), -P), -np.inf)
    keep_l = ~_dominated(lo_l, hi_l)
    keep_u = ~_dominated(lo_u, hi_u)
    dd = 2.0 * d[:, None]
    with np.errstate(invalid="ignore"):
        cL, dL = _pruned((1.0 + dd * p, -dd * q), keep_l)  # dL = +inf: absent, vacuous
        cU, dU, Pl, Ql = _pruned((1.0 + dd * P, -dd * Q, P, Q), keep_u)  # dU = -inf: absent
    return _StageLists(cL, dL, cU, dU, Pl, Ql)


def _backward(
    pc: _Pieces, X_lo: np.ndarray, X_hi: np.ndarray, d: np.ndarray, x_end: float
) -> tuple[np.ndarray, int | None, _StageLists]:
    """Controllable sets ``K_i`` (§IV, Algorithm 1, backward pass); returns ``(K, dead,
    lists)`` with ``dead`` the first stage (from the end) whose set is empty, or None.

    Per piece: ``(1 + 2 Δ p_r) x <= max K_{i+1} - 2 Δ q_r`` and
    ``(1 + 2 Δ P_k) x >= min K_{i+1} - 2 Δ Q_k``; the coefficient lists are built for all
    stages at once (:func:`_stage_lists`), the recursion is a scalar loop.
    """
    N = d.shape[0]
    K = np.full((N + 1, 2), np.nan)
    sl = _stage_lists(pc, X_lo, X_hi, d)
    lo, hi = max(X_lo[N], x_end), min(X_hi[N], x_end)
    if lo > hi + _tol(hi):
        return K, N, sl
    Xl, Xh = X_lo.tolist(), X_hi.tolist()
    Kl, Kh = x_end, x_end
    out_lo = [0.0] * (N + 1)
    out_hi = [0.0] * (N + 1)
    out_lo[N] = out_hi[N] = x_end
    cL, dL, cU, dU = sl.cL, sl.dL, sl.cU, sl.dU
    for i in range(N - 1, -1, -1):
        lo, hi = Xl[i], Xh[i]
        for c, e in zip(cL[i], dL[i], strict=True):  # c x <= Kh + e
            r = Kh + e
            if c > 0.0:
                v = r / c
                if v < hi:
                    hi = v
            elif c < 0.0:
                v = r / c
                if v > lo:
                    lo = v
            elif r < 0.0:
                hi = -math.inf
        for c, e in zip(cU[i], dU[i], strict=True):  # c x >= Kl + e
            r = Kl + e
            if c > 0.0:
                v = r / c
                if v > lo:
                    lo = v
            elif c < 0.0:
                v = r / c
                if v < hi:
                    hi = v
            elif r > 0.0:
                hi = -math.inf
        if lo > hi:
            if lo > hi + _tol(hi) or not math.isfinite(hi):
                K[i + 1 :, 0] = out_lo[i + 1 :]
                K[i + 1 :, 1] = out_hi[i + 1 :]
                return K, i, sl
            lo = hi
        Kl, Kh = lo, hi
        out_lo[i] = lo
        out_hi[i] = hi
    K[:, 0] = out_lo
    K[:, 1] = out_hi
    return K, None, sl


def _forward(sl: _StageLists, K: np.ndarray, d: np.ndarray, x0: float) -> np.ndarray:
    """Greedy forward pass (§IV, Algorithm 1): the largest admissible ``u_i`` that keeps
    ``x_{i+1}`` in ``K_{i+1}``; ``x_{i+1}`` is clipped to ``K_{i+1}`` against round-off."""
    N = d.shape[0]
    x = [x0] * (N + 1)
    P, Q = sl.P, sl.Q
    Kl, Kh = K[:, 0].tolist(), K[:, 1].tolist()
    dl = (2.0 * d).tolist()
    xi = x0
    for i in range(N):
        two_d = dl[i]
        kh = Kh[i + 1]
        u = (kh - xi) / two_d
        for sl_, off in zip(P[i], Q[i], strict=True):
            v = sl_ * xi + off
            if v < u:
                u = v
        xn = xi + two_d * u
        if xn > kh:
            xn = kh
        elif xn < Kl[i + 1]:
            xn = Kl[i + 1]
        x[i + 1] = xn
        xi = xn
    return np.array(x)


def _one_step(
    pc: _Pieces, i: int, keep: np.ndarray, step: tuple[float, float, float] | None
) -> tuple[float, float]:
    """Stage i's admissible x interval with only the rows ``keep``; with ``step = (Δ_i,
    min K_{i+1}, max K_{i+1})`` the controllable interval ``K_i`` instead (vectorised over
    the pieces; used by the diagnostics)."""
    sub = pc.without(keep, slice(i, i + 1))
    lo_a, hi_a = _admissible_x(sub)
    lo, hi = float(lo_a[0]), float(hi_a[0])
    if step is None:
        return lo, hi
    dlt, kl, kh = step
    for c, r in (
        (1.0 + 2.0 * dlt * sub.p[0], kh - 2.0 * dlt * sub.q[0]),
        (-(1.0 + 2.0 * dlt * sub.P[0]), 2.0 * dlt * sub.Q[0] - kl),
    ):
        with np.errstate(divide="ignore", invalid="ignore"):
            v = r / c
        hi = min(hi, float(np.min(np.where(c > 0, v, np.inf), initial=np.inf)))
        lo = max(lo, float(np.max(np.where(c < 0, v, -np.inf), initial=-np.inf)))
        if np.any((c == 0) & (r < 0)):
            hi = -math.inf
    return lo, hi


def _blocking(
    pc: _Pieces, i: int, step: tuple[float, float, float] | None, x_in: float | None = None
) -> list[str]:
    """The rows that block stage i: those whose removal alone re-opens its admissible set
    (``step`` None), its controllable set (``step`` given), or lets it contain ``x_in``."""
    base = [nm.removesuffix("@next") for nm in pc.names]
    names: list[str] = []
    for nm in dict.fromkeys(base):  # a limit and its interpolated copy go together
        keep = np.array([b != nm for b in base], dtype=bool)
        lo, hi = _one_step(pc, i, keep, step)
        ok = lo <= hi + _tol(hi)
        if x_in is not None:
            ok = lo - _tol(lo) <= x_in <= hi + _tol(hi)
        if ok:
            names.append(nm)
    return sorted(set(names))


def _blocking_start(pc: _Pieces, d: np.ndarray, x_start: float, x_end: float) -> list[str]:
    """The limits whose removal alone makes ``x_start`` controllable (a backward pass each)."""
    base = [nm.removesuffix("@next") for nm in pc.names]
    names: list[str] = []
    for nm in dict.fromkeys(base):
        keep = np.array([b != nm for b in base], dtype=bool)
        sub = pc.without(keep)
        K, dead, _ = _backward(sub, *_admissible_x(sub), d, x_end)
        if dead is None and K[0, 0] - _tol(K[0, 0]) <= x_start <= K[0, 1] + _tol(K[0, 1]):
            names.append(nm)
    return names
