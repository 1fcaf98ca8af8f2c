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

Imports: numpy, mechkin.errors, mechkin.solvers.result, topp_problem and topp_passes.

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
from collections.abc import Callable

import numpy as np

from mechkin.errors import ConfigError
from mechkin.solvers.result import Status
from mechkin.solvers.track.topp_passes import (
    _admissible_x,
    _backward,
    _blocking,
    _blocking_start,
    _forward,
    _pieces,
    _tol,
)
from mechkin.solvers.track.topp_problem import (
    ACTIVE_FRACTION,
    SET_RTOL,
    ConstraintRows,
    Discretization,
    LimitLike,
    ToppResult,
    _stage_rows,
    constraint_rows,
    torque_coefficients,
    velocity_bounds,
)

# the problem (rows, result) and the two passes live in topp_problem and topp_passes (split by
# pass); the public names stay importable from here
__all__ = ["ConstraintRows", "ToppResult", "constraint_rows", "plan_time_optimal", "solve_topp",
           "torque_coefficients", "velocity_bounds"]

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
