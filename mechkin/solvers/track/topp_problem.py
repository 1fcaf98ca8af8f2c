"""The TOPP-RA problem (Pham & Pham 2018 §III, §VI): limits as linear rows in ``(u, x)``.

What :func:`mechkin.solvers.track.topp.solve_topp` is given and returns: the torque
coefficients of a joint path (:func:`torque_coefficients`), the rows
``lo <= a u + b x + c <= hi`` of every limit (:class:`ConstraintRows`, :func:`constraint_rows`;
collocation or first-order interpolation, :func:`_stage_rows`), the velocity bounds on ``x``
(:func:`velocity_bounds`) and the result record (:class:`ToppResult`). Split out of
``topp.py`` (issue 23: modules that fit in a head); the formulation is described there.

Design
------
Part of the track room :mod:`mechkin.solvers.track`; numpy, :mod:`mechkin.errors` and
:mod:`mechkin.solvers.result` only.

References
----------
H. Pham, Q.-C. Pham, IEEE Trans. Robotics 34(3), 645-659, 2018: §III, §VI.
"""

from __future__ import annotations

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
