r"""Time-optimal path parametrisation by reachability analysis (TOPP-RA, Pham & Pham 2018).

DESIGN: a stand-alone planner for a fixed joint path ``q(s)``, ``s`` in ``[s_0, s_N]``, that
finds the fastest ``s(t)`` under torque, joint-velocity and joint-acceleration limits in
O(N) (one backward and one forward pass over the grid), for ``objective: time`` (rest to rest)
and for an intercept (rest to a moving end state ``s_dot_end``). It takes plain arrays, not
mechkin objects: the grid ``s (N+1,)``, ``q'(s)``, ``q''(s) (N+1, n)``, the torque coefficients
``A, B, C (N+1, n)`` (or an inverse dynamics to build them, :func:`torque_coefficients`) and
limit vectors. The phase-plane DP of :mod:`mechkin.solvers.track.dpct` stays for tracking and for
jerk limits, which this planner cannot express.

Formulation (Pham & Pham 2018, §III). With ``x = s_dot^2`` and ``u = s_ddot``, ``qd = q' s_dot``
and ``qdd = q' u + q'' x``, so every limit is a linear constraint in ``(u, x)`` at a grid
point,

.. math:: \mathrm{lo} \le a(s) u + b(s) x + c(s) \le \mathrm{hi},

torque ``tau = A u + B x + C`` (rows ``a = A, b = B, c = C``), acceleration ``a = q'``,
``b = q''``, ``c = 0``; velocity ``|q'_j| s_dot <= qd_max_j`` bounds ``x`` directly. Between
grid points ``u`` is constant, so ``x_{i+1} = x_i + 2 Δ_i u_i`` (§III, the discrete phase-plane
dynamics) and the segment time is exactly ``2 Δ_i / (s_dot_i + s_dot_{i+1})``.

Discretisation (§VI). ``"collocation"`` imposes stage i's rows at ``s_i`` only; the default
``"interpolation"`` adds the rows of ``s_{i+1}`` evaluated at ``(u_i, x_i + 2 Δ_i u_i)``, which
is how toppra's ``DiscretizationType.Interpolation`` builds them: each segment's constant ``u``
then meets the limits at both of its ends, where collocation may exceed them slightly at
``s_{i+1}`` (both converge to the same duration as N grows).

Algorithm (§IV, Algorithm 1). Backward pass: the controllable sets ``K_N = {s_dot_end^2}``,
``K_i = {x in X_i : exists u, (u, x) admissible at i, x + 2 Δ_i u in K_{i+1}}``; forward pass:
from ``x_0 = s_dot_start^2``, the largest admissible ``u_i`` that keeps ``x_{i+1}`` in
``K_{i+1}``. Each stage LP has two variables and is solved in closed form: the rows give
``u >= p_r x + q_r`` (lower pieces) and ``u <= P_r x + Q_r`` (upper pieces), so

* ``X_i`` (the admissible x of stage i, independent of K) is the intersection of the half-lines
  ``p_r x + q_r <= P_k x + Q_k`` over all pairs, computed for all stages at once (vectorised);
* ``K_i`` adds, per piece, ``x + 2 Δ (p_r x + q_r) <= max K_{i+1}`` and
  ``x + 2 Δ (P_k x + Q_k) >= min K_{i+1}``: half-lines again, a few scalar operations per piece;
* the forward step is ``u_i = min(min_k P_k x_i + Q_k, (max K_{i+1} - x_i) / (2 Δ))``.

The two passes are sequential scalar loops over stages (each stage depends on its neighbour);
everything else is vectorised over the grid. Cost O(N m^2) for m rows per stage, i.e. O(N).

Infeasibility is a status, not an exception: an empty ``X_i`` (the limits cannot hold the path
at ``s_i`` at any speed), an empty ``K_i`` (the end state cannot be reached from there), or a
start speed outside ``K_0``; the message names the limits that block and where.

Imports: numpy, mechkin.errors, mechkin.solvers.result.

References
----------
H. Pham, Q.-C. Pham, "A new approach to time-optimal path parameterization based on
reachability analysis", IEEE Trans. Robotics 34(3), 645-659, 2018: §III (formulation, the
``x_{i+1} = x_i + 2 Δ_i u_i`` dynamics), §IV (controllable sets, Algorithm 1), §VI (collocation
vs first-order interpolation).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from mechkin.errors import ConfigError
from mechkin.solvers.result import Status

Discretization = Literal["interpolation", "collocation"]
#: A limit: symmetric magnitudes ``v (n,)`` (``-v <= . <= v``) or a pair ``(lo (n,), hi (n,))``.
LimitLike = np.ndarray | Sequence[float] | tuple[np.ndarray, np.ndarray]

#: Relative size below which a row's u-coefficient counts as zero (the row bounds x only).
A_ZERO_RTOL = 1e-12
#: Relative slack when comparing interval ends and checking the realised limits (round-off).
SET_RTOL = 1e-9
#: A limit is reported active when the plan uses at least this fraction of it.
ACTIVE_FRACTION = 0.98


@dataclass(frozen=True)
class ConstraintRows:
    """Canonical stage constraints ``lo <= a u + b x + c <= hi`` per grid point (§III).

    Attributes
    ----------
    a, b, c : array, shape (N+1, m)
    lo, hi : array, shape (N+1, m)
        Bounds; ``-inf`` / ``inf`` allowed.
    names : tuple of str, length m
        ``"torque_1"``, ``"qdd_2"``, ... (joint numbers from 1), for diagnostics.
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    names: tuple[str, ...]


@dataclass(frozen=True)
class ToppResult:
    """Result of :func:`solve_topp` / :func:`plan_time_optimal`.

    Attributes
    ----------
    status : Status
        OK or INFEASIBLE.
    message : str
        One line; for an infeasible problem it names the blocking limits and where.
    s : array, shape (N+1,)
        The grid.
    sd : array, shape (N+1,) or None
        ``s_dot(s_i)`` [1/s].
    sdd : array, shape (N,) or None
        ``u_i = s_ddot`` on segment ``[s_i, s_{i+1}]`` (constant there) [1/s^2].
    t : array, shape (N+1,) or None
        Time at each grid point, ``t_0 = 0`` [s].
    duration_s : float or None
    controllable : array, shape (N+1, 2)
        ``[min, max]`` of ``K_i`` in ``x = s_dot^2`` (NaN past a dead stage).
    discretization : str
    limit_usage : dict
        Largest fraction of each limit used on the realised plan where the scheme imposes it
        (rows of ``s_i`` at ``(u_i, x_i)``; with interpolation also rows of ``s_{i+1}`` at
        ``(u_i, x_{i+1})``; velocity at every grid point), by name.
    limits_ok : bool
        Every limit holds on the realised plan (``SET_RTOL`` slack).
    active_limits : tuple of str
    solve_time_s : float
    blocked_at_s : tuple of float or None
        For an infeasible problem, the s interval where the planner dies.
    blocking_limits : tuple of str
    """

    status: Status
    message: str
    s: np.ndarray
    sd: np.ndarray | None
    sdd: np.ndarray | None
    t: np.ndarray | None
    duration_s: float | None
    controllable: np.ndarray = field(repr=False)
    discretization: str = "interpolation"
    limit_usage: dict[str, float] = field(default_factory=dict)
    limits_ok: bool = False
    active_limits: tuple[str, ...] = ()
    solve_time_s: float = 0.0
    blocked_at_s: tuple[float, float] | None = None
    blocking_limits: tuple[str, ...] = ()

    def summary(self) -> dict[str, object]:
        """JSON-ready key figures (no arrays) for ``summary.json``."""
        return {
            "status": self.status.value,
            "message": self.message,
            "duration_s": self.duration_s,
            "grid_points": int(self.s.shape[0]),
            "discretization": self.discretization,
            "limits_ok": self.limits_ok,
            "active_limits": list(self.active_limits),
            "limit_usage": dict(self.limit_usage),
            "solve_time_s": self.solve_time_s,
            "blocked_at_s": None if self.blocked_at_s is None else list(self.blocked_at_s),
            "blocking_limits": list(self.blocking_limits),
        }


# ------------------------------------------------------------------------------------------
# Building the rows
# ------------------------------------------------------------------------------------------


def torque_coefficients(
    inverse_dynamics: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Torque along the path as ``tau = A u + B x + C`` from any inverse dynamics (§III).

    ``tau(q, qd, qdd)`` is affine in ``qdd`` and quadratic in ``qd``; with ``qd = q' s_dot`` and
    ``qdd = q' u + q'' x``, ``tau = A u + B x + C`` for

    .. math::

        C = \tau(q, 0, 0), \quad A = \tau(q, 0, q') - C, \quad B = \tau(q, q', q'') - C.

    (Friction that is not quadratic in ``qd``, e.g. Coulomb, does not fit this form.)

    Parameters
    ----------
    inverse_dynamics : callable
        ``tau = inverse_dynamics(q, qd, qdd)``, batched over the first axis: ``(K, n)`` arrays
        in, ``(K, n)`` out (e.g. ``InverseDynamics.inverse_dynamics`` of
        :mod:`mechkin.solvers.dynamics.open_chain`).
    q, dq, ddq : array, shape (K, n)
        ``q(s)``, ``q'(s)``, ``q''(s)`` at the grid points.

    Returns
    -------
    A, B, C : array, shape (K, n)
    """
    q = np.asarray(q, dtype=np.float64)
    dq = np.asarray(dq, dtype=np.float64)
    ddq = np.asarray(ddq, dtype=np.float64)
    zero = np.zeros_like(q)
    C = np.asarray(inverse_dynamics(q, zero, zero), dtype=np.float64)
    A = np.asarray(inverse_dynamics(q, zero, dq), dtype=np.float64) - C
    B = np.asarray(inverse_dynamics(q, dq, ddq), dtype=np.float64) - C
    return A, B, C


def _limit(lim: LimitLike | None, n: int, name: str) -> tuple[np.ndarray, np.ndarray] | None:
    """``(lo (n,), hi (n,))`` from a magnitude vector or a pair; ConfigError if malformed."""
    if lim is None:
        return None
    if isinstance(lim, tuple) and len(lim) == 2 and np.ndim(lim[0]) == 1:
        lo = np.asarray(lim[0], dtype=np.float64)
        hi = np.asarray(lim[1], dtype=np.float64)
    else:
        hi = np.asarray(lim, dtype=np.float64)
        if np.any(hi < 0):
            raise ConfigError(f"limits.{name}: expected magnitudes >= 0, got {hi.tolist()}")
        lo = -hi
    if lo.shape != (n,) or hi.shape != (n,):
        raise ConfigError(
            f"limits.{name}: expected {n} values per bound, got {lo.shape} and {hi.shape}"
        )
    if np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo > hi):
        raise ConfigError(f"limits.{name}: expected lo <= hi, got {lo.tolist()}, {hi.tolist()}")
    return lo, hi


def constraint_rows(
    dq: np.ndarray,
    ddq: np.ndarray,
    *,
    torque: LimitLike | None = None,
    torque_coeffs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    qdd: LimitLike | None = None,
) -> ConstraintRows:
    """Torque and joint-acceleration limits as canonical rows (§III).

    Torque rows ``lo <= A u + B x + C <= hi``; acceleration rows
    ``-qdd_max <= q' u + q'' x <= qdd_max`` (``qdd = q' s_ddot + q'' s_dot^2``).

    Parameters
    ----------
    dq, ddq : array, shape (N+1, n)
    torque : magnitudes (n,) or (lo, hi), optional
        Requires ``torque_coeffs``.
    torque_coeffs : (A, B, C), each (N+1, n), optional
        From :func:`torque_coefficients`.
    qdd : magnitudes (n,) or (lo, hi), optional
    """
    dq = np.asarray(dq, dtype=np.float64)
    ddq = np.asarray(ddq, dtype=np.float64)
    K, n = dq.shape
    cols: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[str]]] = []
    tl = _limit(torque, n, "torque")
    if tl is not None:
        if torque_coeffs is None:
            raise ConfigError("limits.torque: torque limits need the torque coefficients A, B, C")
        A, B, C = (np.asarray(x, dtype=np.float64) for x in torque_coeffs)
        for nm, x in (("A", A), ("B", B), ("C", C)):
            if x.shape != (K, n):
                raise ConfigError(f"torque_coeffs.{nm}: expected shape {(K, n)}, got {x.shape}")
        lo = np.broadcast_to(tl[0], (K, n))
        hi = np.broadcast_to(tl[1], (K, n))
        cols.append((A, B, C, lo, hi, [f"torque_{k + 1}" for k in range(n)]))
    al = _limit(qdd, n, "qdd")
    if al is not None:
        lo = np.broadcast_to(al[0], (K, n))
        hi = np.broadcast_to(al[1], (K, n))
        cols.append((dq, ddq, np.zeros((K, n)), lo, hi, [f"qdd_{k + 1}" for k in range(n)]))
    if not cols:
        z = np.zeros((K, 0))
        return ConstraintRows(z, z, z, z, z, ())
    a, b, c, lo, hi = (np.concatenate([col[j] for col in cols], axis=1) for j in range(5))
    names = tuple(nm for col in cols for nm in col[5])
    return ConstraintRows(a, b, c, lo, hi, names)


def velocity_bounds(
    dq: np.ndarray, qd: LimitLike | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Joint-velocity limits ``lo <= q' s_dot <= hi`` as bounds on ``x = s_dot^2`` (§III).

    Returns ``x_lo, x_hi (N+1,)`` and, per joint, ``(N+1, n)`` arrays ``x_lo_j, x_hi_j`` for
    the diagnostics (``s_dot >= 0``: ``q'_j > 0`` gives ``s_dot <= hi / q'_j`` and
    ``s_dot >= lo / q'_j``; ``q'_j = 0`` needs ``lo <= 0 <= hi``).
    """
    dq = np.asarray(dq, dtype=np.float64)
    K, n = dq.shape
    vl = _limit(qd, n, "qd")
    if vl is None:
        return np.zeros(K), np.full(K, np.inf), np.zeros((K, n)), np.full((K, n), np.inf)
    lo, hi = vl
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(dq > 0, hi / dq, np.where(dq < 0, lo / dq, np.inf))
        dn = np.where(dq > 0, lo / dq, np.where(dq < 0, hi / dq, -np.inf))
    zero_bad = (dq == 0) & ((lo > 0) | (hi < 0))
    up = np.where(zero_bad, -np.inf, up)  # s_dot can be no value at all
    xh_j = np.where(up < 0, -1.0, np.square(np.where(np.isfinite(up), up, 0.0)))
    xh_j = np.where(np.isinf(up) & (up > 0), np.inf, xh_j)
    xl_j = np.square(np.maximum(np.where(np.isfinite(dn), dn, 0.0), 0.0))
    return np.max(xl_j, axis=1), np.min(xh_j, axis=1), xl_j, xh_j


# ------------------------------------------------------------------------------------------
# The solver
# ------------------------------------------------------------------------------------------


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


def _stage_rows(rows: ConstraintRows, s: np.ndarray, scheme: str) -> ConstraintRows:
    """Rows of each stage i (§VI): collocation as given; interpolation appends the rows of
    ``s_{i+1}`` at ``(u, x + 2 Δ_i u)``, i.e. ``a' = a_{i+1} + 2 Δ_i b_{i+1}``; the end point
    keeps its own rows."""
    if scheme == "collocation" or rows.a.shape[1] == 0:
        return rows
    d = np.diff(s)[:, None]

    def nxt(x: np.ndarray, fix: np.ndarray | None = None) -> np.ndarray:
        out = np.empty_like(x)
        out[:-1] = x[1:] if fix is None else fix
        out[-1] = x[-1]
        return out

    a2 = nxt(rows.a, rows.a[1:] + 2.0 * d * rows.b[1:])
    return ConstraintRows(
        np.concatenate([rows.a, a2], axis=1),
        np.concatenate([rows.b, nxt(rows.b)], axis=1),
        np.concatenate([rows.c, nxt(rows.c)], axis=1),
        np.concatenate([rows.lo, nxt(np.asarray(rows.lo))], axis=1),
        np.concatenate([rows.hi, nxt(np.asarray(rows.hi))], axis=1),
        rows.names + tuple(f"{nm}@next" for nm in rows.names),
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


def solve_topp(
    s: np.ndarray,
    rows: ConstraintRows,
    *,
    x_lo: np.ndarray | None = None,
    x_hi: np.ndarray | None = None,
    sd_start: float = 0.0,
    sd_end: float = 0.0,
    discretization: Discretization = "interpolation",
    x_names: tuple[str, ...] = (),
    x_bounds_j: tuple[np.ndarray, np.ndarray] | None = None,
    diagnose: bool = True,
) -> ToppResult:
    r"""Time-optimal ``s_dot(s)`` under canonical rows and x bounds (§IV, Algorithm 1).

    Parameters
    ----------
    s : array, shape (N+1,)
        Strictly increasing grid of the path parameter.
    rows : ConstraintRows
        ``lo <= a u + b x + c <= hi`` at every grid point (collocated; the interpolation
        scheme is built here).
    x_lo, x_hi : array, shape (N+1,), optional
        Direct bounds on ``x = s_dot^2`` (joint velocity, :func:`velocity_bounds`).
    sd_start, sd_end : float
        ``s_dot`` at ``s_0`` and ``s_N`` (``>= 0``): rest to rest is ``0, 0``; an intercept
        ends at the target's path speed.
    discretization : {"interpolation", "collocation"}
        §VI; see the module docstring.
    x_names, x_bounds_j :
        Names and per-joint ``(x_lo_j, x_hi_j) (N+1, n)`` of the velocity bounds, for the
        diagnostics and the limit usage.
    diagnose : bool
        Name the blocking limits of an infeasible problem (one extra pass per limit for an
        uncontrollable start); False skips that (a root-finder's feasibility probes).

    Returns
    -------
    ToppResult
        ``status`` INFEASIBLE (with the blocking limits and s interval) when no admissible
        parametrisation exists on the grid.

    Raises
    ------
    ConfigError
        Malformed input (shapes, a grid that does not increase, negative speeds) or limits that
        do not bound the path speed.
    """
    t0 = time.perf_counter()
    s = np.asarray(s, dtype=np.float64)
    if s.ndim != 1 or s.shape[0] < 2 or not np.all(np.isfinite(s)):
        raise ConfigError(f"grid.s: expected a finite vector of >= 2 points, got shape {s.shape}")
    d = np.diff(s)
    if np.any(d <= 0):
        raise ConfigError("grid.s: expected strictly increasing path parameters")
    if discretization not in ("interpolation", "collocation"):
        raise ConfigError(
            f"discretization: expected 'interpolation' or 'collocation', got {discretization!r}"
        )
    K1 = s.shape[0]
    shape = np.shape(rows.a)
    for nm in ("a", "b", "c", "lo", "hi"):
        arr = np.asarray(getattr(rows, nm), dtype=np.float64)
        try:
            ok = (
                arr.shape if nm in ("a", "b", "c") else np.broadcast_shapes(arr.shape, shape)
            ) == shape
        except ValueError:  # not broadcastable
            ok = False
        if len(shape) != 2 or shape[0] != K1 or not ok:
            raise ConfigError(f"rows.{nm}: expected shape ({K1}, m), got {arr.shape}")
    if len(rows.names) != shape[1]:
        raise ConfigError(f"rows.names: expected {shape[1]} names, got {len(rows.names)}")
    rows = ConstraintRows(
        *(np.asarray(getattr(rows, nm), dtype=np.float64) for nm in ("a", "b", "c")),
        *(np.broadcast_to(np.asarray(getattr(rows, nm), dtype=np.float64), shape)
          for nm in ("lo", "hi")),
        names=tuple(rows.names),
    )  # fmt: skip
    for nm, v in (("sd_start", sd_start), ("sd_end", sd_end)):
        if not (math.isfinite(v) and v >= 0.0):
            raise ConfigError(f"{nm}: expected a path speed >= 0, got {v}")
    x_lo = np.zeros(K1) if x_lo is None else np.maximum(np.asarray(x_lo, dtype=np.float64), 0.0)
    x_hi = np.full(K1, np.inf) if x_hi is None else np.asarray(x_hi, dtype=np.float64)
    N = K1 - 1

    srows = _stage_rows(rows, s, discretization)
    pc = _pieces(srows, x_lo, x_hi)
    X_lo, X_hi = _admissible_x(pc)

    def fail(msg: str, i: int, names: list[str], K: np.ndarray) -> ToppResult:
        if not diagnose:
            names = []
        where = (float(s[i]), float(s[min(i + 1, N)]))
        what = ", ".join(names) if names else "the limits"
        return ToppResult(
            status=Status.INFEASIBLE,
            message=f"infeasible: {msg} ({what})",
            s=s,
            sd=None,
            sdd=None,
            t=None,
            duration_s=None,
            controllable=K,
            discretization=discretization,
            solve_time_s=time.perf_counter() - t0,
            blocked_at_s=where,
            blocking_limits=tuple(names),
        )

    def vel_names(i: int, x_out: float | None = None) -> list[str]:
        """Velocity limits that exclude ``x_out`` at s_i, or (None) that bound X_i."""
        if x_bounds_j is None or not x_names:
            return []
        lo_j, hi_j = x_bounds_j[0][i], x_bounds_j[1][i]
        if x_out is not None:
            bad = (hi_j < x_out - _tol(x_out)) | (lo_j > x_out + _tol(x_out))
        else:
            bad = (np.isfinite(hi_j) & (hi_j <= X_hi[i] * (1 + SET_RTOL))) | (
                (lo_j > 0) & (lo_j >= X_lo[i] * (1 - SET_RTOL))
            )
        return [x_names[j] for j in np.flatnonzero(bad)]

    slack = np.where(np.isfinite(X_hi), SET_RTOL * np.maximum(np.abs(X_hi), 1.0), 0.0)
    empty = X_lo > X_hi + slack
    if np.any(empty):
        i = int(np.flatnonzero(empty)[0])
        names = _blocking(pc, i, None) or vel_names(i)
        return fail(
            f"no admissible path speed at s = {s[i]:.6g} (grid point {i} of {N})",
            i,
            names,
            np.full((K1, 2), np.nan),
        )
    x_end, x_start = sd_end**2, sd_start**2
    K, dead, lists = _backward(pc, X_lo, X_hi, d, x_end)
    if dead is not None:
        if dead == N:
            return fail(
                f"the end speed s_dot = {sd_end:.6g} is not admissible at s = {s[N]:.6g} "
                f"(admissible s_dot^2 in [{X_lo[N]:.6g}, {X_hi[N]:.6g}])",
                N,
                vel_names(N, x_end) + _blocking(pc, N, None, x_end),
                K,
            )
        nxt = (float(K[dead + 1, 0]), float(K[dead + 1, 1]))
        return fail(
            f"the end state cannot be reached from s in [{s[dead]:.6g}, {s[dead + 1]:.6g}]: "
            f"no speed there leads into the controllable set s_dot^2 in "
            f"[{nxt[0]:.6g}, {nxt[1]:.6g}] at the next grid point",
            dead,
            _blocking(pc, dead, (float(d[dead]), *nxt)) or vel_names(dead),
            K,
        )
    if not np.all(np.isfinite(K)):
        raise ConfigError(
            "limits: the limits do not bound the path speed (give torque, velocity or "
            "acceleration limits that act on every joint that moves)"
        )
    if x_start < K[0, 0] - _tol(K[0, 0]) or x_start > K[0, 1] + _tol(K[0, 1]):
        return fail(
            f"the start speed s_dot = {sd_start:.6g} is not controllable: from s = {s[0]:.6g} "
            f"only s_dot^2 in [{K[0, 0]:.6g}, {K[0, 1]:.6g}] reaches the end state",
            0,
            (_blocking_start(pc, d, x_start, x_end) or vel_names(0)) if diagnose else [],
            K,
        )
    x = _forward(lists, K, d, min(max(x_start, K[0, 0]), K[0, 1]))
    x[0] = x_start
    sd = np.sqrt(np.maximum(x, 0.0))
    u = (x[1:] - x[:-1]) / (2.0 * d)
    vsum = sd[:-1] + sd[1:]
    if np.any(vsum <= 0.0):
        i = int(np.flatnonzero(vsum <= 0.0)[0])
        return fail(
            f"the path speed must vanish on the whole segment s in [{s[i]:.6g}, {s[i + 1]:.6g}]",
            i,
            vel_names(i) + vel_names(i + 1),
            K,
        )
    dt = 2.0 * d / vsum  # exact for constant u on the segment
    t = np.concatenate([[0.0], np.cumsum(dt)])
    usage, ok = _usage(rows, u, x, x_bounds_j, x_names, discretization)
    active = tuple(k for k, v in usage.items() if v >= ACTIVE_FRACTION)
    duration = float(t[-1])
    kind = "rest-to-rest" if sd_start == 0.0 and sd_end == 0.0 else "time-optimal"
    return ToppResult(
        status=Status.OK,
        message=f"ok: {kind} time {duration:.6g} s on {N + 1} grid points ({discretization})"
        + ("" if ok else " (a limit is exceeded on the realised plan)"),
        s=s,
        sd=sd,
        sdd=u,
        t=t,
        duration_s=duration,
        controllable=K,
        discretization=discretization,
        limit_usage=usage,
        limits_ok=ok,
        active_limits=active,
        solve_time_s=time.perf_counter() - t0,
    )


def _usage(
    rows: ConstraintRows,
    u: np.ndarray,
    x: np.ndarray,
    x_bounds_j: tuple[np.ndarray, np.ndarray] | None,
    x_names: tuple[str, ...],
    scheme: str,
) -> tuple[dict[str, float], bool]:
    """Largest fraction of each limit used where the scheme imposes it: rows of ``s_i`` at
    ``(u_i, x_i)``, i < N, and, with interpolation, rows of ``s_{i+1}`` at ``(u_i, x_{i+1})``;
    velocity ``sqrt(x / x_hi_j)`` at every grid point. ``ok``: none exceeds 1 (round-off)."""

    def at(k: slice, xx: np.ndarray) -> tuple[np.ndarray, ...]:
        lo_k = np.broadcast_to(rows.lo, rows.a.shape)[k]
        hi_k = np.broadcast_to(rows.hi, rows.a.shape)[k]
        return rows.a[k] * u[:, None] + rows.b[k] * xx[:, None] + rows.c[k], lo_k, hi_k

    parts = [at(slice(0, -1), x[:-1])]
    if scheme == "interpolation":
        parts.append(at(slice(1, None), x[1:]))
    val, lo, hi = (np.concatenate([pt[j] for pt in parts]) for j in range(3))
    usage: dict[str, float] = {}
    with np.errstate(divide="ignore", invalid="ignore"):
        fr = np.maximum(
            np.where(hi > 0, val / hi, np.where(val > hi, np.inf, 0.0)),
            np.where(lo < 0, val / lo, np.where(val < lo, np.inf, 0.0)),
        )
    slack = SET_RTOL * np.maximum(np.maximum(np.abs(lo), np.abs(hi)), 1.0)
    viol = (val > hi + slack) | (val < lo - slack)
    ok = not bool(np.any(viol))
    for j, nm in enumerate(rows.names):
        usage[nm] = float(np.max(fr[:, j]))
    if x_bounds_j is not None and x_names:
        _, hi_j = x_bounds_j
        with np.errstate(divide="ignore", invalid="ignore"):
            fv = np.where(np.isfinite(hi_j) & (hi_j > 0), np.sqrt(x[:, None] / hi_j), 0.0)
        for j, nm in enumerate(x_names):
            usage[nm] = float(np.max(fv[:, j]))
            ok = ok and usage[nm] <= 1.0 + SET_RTOL
    return usage, ok


def plan_time_optimal(
    s: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    *,
    q: np.ndarray | None = None,
    torque: LimitLike | None = None,
    torque_coeffs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    inverse_dynamics: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
    qd: LimitLike | None = None,
    qdd: LimitLike | None = None,
    sd_start: float = 0.0,
    sd_end: float = 0.0,
    discretization: Discretization = "interpolation",
    diagnose: bool = True,
) -> ToppResult:
    """Time-optimal parametrisation of a joint path under torque, velocity and acceleration
    limits (Pham & Pham 2018, Algorithm 1), from arrays.

    Parameters
    ----------
    s : array, shape (N+1,)
        Strictly increasing grid of the path parameter.
    dq, ddq : array, shape (N+1, n)
        ``q'(s)``, ``q''(s)`` at the grid.
    q : array, shape (N+1, n), optional
        ``q(s)``; needed only with ``inverse_dynamics``.
    torque : magnitudes (n,) or (lo (n,), hi (n,)), optional
        Torque limits [N m | N]; need ``torque_coeffs`` or ``inverse_dynamics`` (and ``q``).
    torque_coeffs : (A, B, C), each (N+1, n), optional
        ``tau = A u + B x + C`` (:func:`torque_coefficients`).
    inverse_dynamics : callable, optional
        Batched ``tau(q, qd, qdd)``; used to build ``torque_coeffs`` when not given.
    qd, qdd : magnitudes (n,) or (lo, hi), optional
        Joint velocity [rad/s | m/s] and acceleration [rad/s^2 | m/s^2] limits.
    sd_start, sd_end : float
        Path speeds at the ends (``0, 0``: rest to rest; ``sd_end > 0``: an intercept).
    discretization : {"interpolation", "collocation"}
    diagnose : bool
        See :func:`solve_topp`.

    Returns
    -------
    ToppResult
    """
    dq = np.asarray(dq, dtype=np.float64)
    ddq = np.asarray(ddq, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    if dq.ndim != 2 or dq.shape[0] != s.shape[0] or ddq.shape != dq.shape:
        raise ConfigError(
            f"path: expected q'(s), q''(s) of shape ({s.shape[0]}, n), got {dq.shape}, {ddq.shape}"
        )
    if torque is not None and torque_coeffs is None:
        if inverse_dynamics is None or q is None:
            raise ConfigError(
                "limits.torque: torque limits need torque_coeffs or inverse_dynamics and q"
            )
        torque_coeffs = torque_coefficients(inverse_dynamics, q, dq, ddq)
    rows = constraint_rows(dq, ddq, torque=torque, torque_coeffs=torque_coeffs, qdd=qdd)
    x_lo, x_hi, xl_j, xh_j = velocity_bounds(dq, qd)
    n = dq.shape[1]
    names = tuple(f"qd_{k + 1}" for k in range(n)) if qd is not None else ()
    return solve_topp(
        s,
        rows,
        x_lo=x_lo,
        x_hi=x_hi,
        sd_start=sd_start,
        sd_end=sd_end,
        discretization=discretization,
        x_names=names,
        x_bounds_j=(xl_j, xh_j) if qd is not None else None,
        diagnose=diagnose,
    )
