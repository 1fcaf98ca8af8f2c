"""The DPCT limit model (park §4.3, readings 3, 6 and 8 of :mod:`mechkin.solvers.track.dpct`).

Which transitions of a DP stage the torque (Eq. (3), (12), (21)), joint velocity,
acceleration and jerk limits (Eq. (4)'-(6)', (31)-(35)) and joint positions (Eq. (9)) admit
(:func:`_transition_checks`), the reachability bound of the time-optimal grid, the diagnosis
of a blocked stage, the usage of every limit by a realised plan (:func:`limit_usage`) and the
phase plane's limit curve (:func:`limit_curve`). Split out of ``dpct.py`` (issue 23).

Design
------
Part of the track room :mod:`mechkin.solvers.track`; may import
:mod:`mechkin.solvers.track.dp_problem` and :mod:`mechkin.solvers.track.path`; never ``io/``,
``cli/`` or ``tasks/``.

References
----------
park_conveyor_tracking_dp, §4.3, Eq. (3)-(6), (9)-(12), (21), (31)-(35).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mechkin.errors import ConfigError
from mechkin.solvers.track.dp_problem import (
    _REACH_MARGIN,
    _REACH_SAMPLES,
    ACTIVE_FRACTION,
    LIMIT_RTOL,
)
from mechkin.solvers.track.path import JointPath, PhaseCoefficients


def _slack(b: np.ndarray) -> np.ndarray:
    """Round-off slack of a bound (``LIMIT_RTOL``, absolute below 1)."""
    return LIMIT_RTOL * np.maximum(np.abs(b), 1.0)


def _within(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``lo <= x <= hi`` per joint (last axis) with round-off slack; NaN counts as inside."""
    return ~((x < lo - _slack(lo)) | (x > hi + _slack(hi)))


@dataclass
class _Stage:
    """Stage-independent arrays of all ``(j, l)`` transitions (module docstring, reading 2)."""

    x2: np.ndarray  # (N2+1,)
    dt: np.ndarray  # (N2+1, N2+1) 2 dx1 / (x2[j] + x2[l]); inf between two rest states
    inv_dt: np.ndarray  # (N2+1, N2+1)
    rdd: np.ndarray  # (N2+1, N2+1) (x2[l]^2 - x2[j]^2) / (2 dx1)
    rdd_sorted: bool = False  # every row of rdd non-decreasing (the compiled stage's window)
    x2_to: np.ndarray | None = None  # the successor states l when they differ from x2 (band)

    @property
    def x2c(self) -> np.ndarray:
        """The states ``l`` of stage i+1 (columns): ``x2`` unless a band grid says otherwise."""
        return self.x2 if self.x2_to is None else self.x2_to


def _transition_checks(
    limits: dict[str, tuple[np.ndarray, np.ndarray]],
    pc: PhaseCoefficients,
    i: int,
    rows: slice,
    st: _Stage,
    qdd_next: np.ndarray,
    per_family: bool,
    qdd_prev: np.ndarray | None = None,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Limit checks of all transitions ``(i, j) -> (i+1, l)``, ``j`` in ``rows``.

    Returns ``ok (J, L)``, true where every limit holds, and (with ``per_family``) per-joint
    masks ``"torque_1" -> (J, L)`` for the diagnosis of a blocked stage. Torque (Eq. (3), (12))
    is checked as an interval of r'', velocity (Eq. (4)') per row, acceleration (Eq. (32),
    (5)') and jerk (Eq. (33), (6)', with the successor's stored ``qdd_next``) per pair;
    ``qdd_prev (n,)`` (the departure from rest, ``DPOptions.jerk_ends``) adds the jerk
    ``(qdd - qdd_prev) / dt`` of the step itself.
    """
    x2j = st.x2[rows]
    inv_dt = st.inv_dt[rows]
    rdd = st.rdd[rows]
    ok = np.ones(inv_dt.shape, dtype=bool)
    masks: dict[str, np.ndarray] = {}

    def keep(name: str, m: np.ndarray) -> None:
        ok[...] &= m
        if per_family:
            masks[name] = np.broadcast_to(m, ok.shape)

    for k in range(pc.a.shape[1]):
        if "torque" in limits:
            lo, hi = limits["torque"][0][k], limits["torque"][1][k]
            c = pc.b[i, k] * x2j**2 + pc.g[i, k]  # park Eq. (12) without the r'' term
            a = pc.a[i, k]
            if a == 0.0:
                keep(f"torque_{k + 1}", ((c >= lo - _slack(lo)) & (c <= hi + _slack(hi)))[:, None])
            else:
                b1 = (lo - _slack(lo) - c) / a
                b2 = (hi + _slack(hi) - c) / a
                r_lo, r_hi = np.minimum(b1, b2), np.maximum(b1, b2)
                keep(f"torque_{k + 1}", (rdd >= r_lo[:, None]) & (rdd <= r_hi[:, None]))
        qd_j = pc.dq[i, k] * x2j  # park Eq. (10), (4)'
        if "qd" in limits:
            lo, hi = limits["qd"][0][k], limits["qd"][1][k]
            keep(f"qd_{k + 1}", ((qd_j >= lo - _slack(lo)) & (qd_j <= hi + _slack(hi)))[:, None])
        if "qdd" in limits or "jerk" in limits:
            qdd = (pc.dq[i + 1, k] * st.x2c[None, :] - qd_j[:, None]) * inv_dt  # park Eq. (32)
            if "qdd" in limits:
                lo, hi = limits["qdd"][0][k], limits["qdd"][1][k]
                keep(f"qdd_{k + 1}", (qdd >= lo - _slack(lo)) & (qdd <= hi + _slack(hi)))
            if "jerk" in limits:
                lo, hi = limits["jerk"][0][k], limits["jerk"][1][k]
                jerk = (qdd_next[None, :, k] - qdd) * inv_dt  # park Eq. (33)
                keep(f"jerk_{k + 1}", ~((jerk < lo - _slack(lo)) | (jerk > hi + _slack(hi))))
                if qdd_prev is not None:  # the step from rest (DPOptions.jerk_ends)
                    jerk = (qdd - qdd_prev[k]) * inv_dt
                    keep(f"jerk_{k + 1}", (jerk >= lo - _slack(lo)) & (jerk <= hi + _slack(hi)))
    return ok, masks


def _reachable_x2_max(
    pc: PhaseCoefficients, limits: dict[str, tuple[np.ndarray, np.ndarray]], dx1: float
) -> float:
    """Largest r' reachable from rest that can still stop at r = 1 (time-optimal grid top).

    A sampled forward/backward reachability pass on ``x = r'^2`` with the collocated torque and
    node-velocity limits (``x_{i+1} = x_i + 2 dx1 r''_i``); acceleration and jerk limits only
    shrink the true set, so the bound stays an upper bound of every feasible DP path.
    """
    K = pc.r.shape[0]
    x_cap = np.full(K, np.inf)
    if "qd" in limits:
        lo, hi = limits["qd"]
        f1 = pc.dq
        with np.errstate(divide="ignore", invalid="ignore"):
            cap = np.where(f1 > 0, hi / f1, np.where(f1 < 0, lo / f1, np.inf))
        x_cap = np.minimum(x_cap, np.min(cap, axis=1) ** 2)

    def u_range(i: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        u_lo = np.full(x.shape, -np.inf)
        u_hi = np.full(x.shape, np.inf)
        if "torque" in limits:
            lo, hi = limits["torque"]
            for k in range(pc.a.shape[1]):
                c = pc.b[i, k] * x + pc.g[i, k]
                a = pc.a[i, k]
                if a == 0.0:
                    bad = (c < lo[k]) | (c > hi[k])
                    u_lo = np.where(bad, np.inf, u_lo)
                    continue
                b1, b2 = (lo[k] - c) / a, (hi[k] - c) / a
                u_lo = np.maximum(u_lo, np.minimum(b1, b2))
                u_hi = np.minimum(u_hi, np.maximum(b1, b2))
        return u_lo, u_hi

    fwd = np.zeros(K)  # largest x reachable from rest
    for i in range(K - 1):
        top_i = min(fwd[i], x_cap[i])
        if not np.isfinite(top_i):
            fwd[i + 1] = np.inf
            continue
        x = np.linspace(0.0, top_i, _REACH_SAMPLES)
        u_lo, u_hi = u_range(i, x)
        ok = u_lo <= u_hi
        nxt = x[ok] + 2.0 * dx1 * u_hi[ok] if np.any(ok) else np.zeros(1)
        fwd[i + 1] = min(max(float(np.max(nxt)), 0.0), x_cap[i + 1])
    bwd = np.zeros(K)  # largest reachable x that can still come to rest at r = 1
    for i in range(K - 2, -1, -1):
        top_i = min(fwd[i], x_cap[i])
        if not np.isfinite(top_i):
            raise ConfigError(
                "objective time: the limits do not bound the path speed; "
                "give torque or velocity limits, or x2_max"
            )
        x = np.linspace(0.0, top_i, _REACH_SAMPLES)
        u_lo, u_hi = u_range(i, x)
        u_min = np.maximum(u_lo, -x / (2.0 * dx1))  # x_{i+1} = x + 2 dx1 u >= 0
        ok = (u_min <= u_hi) & (x + 2.0 * dx1 * u_min <= bwd[i + 1])
        bwd[i] = float(np.max(x[ok])) if np.any(ok) else 0.0
    top = float(np.max(bwd)) * (1.0 + _REACH_MARGIN) ** 2
    if not np.isfinite(top) or top <= 0.0:
        raise ConfigError(
            "objective time: the limits do not bound the path speed; "
            "give torque or velocity limits, or x2_max"
        )
    return float(np.sqrt(top))


def _joint_names(mask_fail: np.ndarray, family: str) -> list[str]:
    return [f"{family}_{k + 1}" for k in np.flatnonzero(mask_fail)]


def _diagnose(masks: dict[str, np.ndarray], base: np.ndarray) -> list[str]:
    """Which limits block a dead stage: those whose removal re-opens a transition.

    ``masks`` maps ``"torque_1"``-style names (and ``"start"``) to ``(J, L)`` masks; ``base``
    marks the transitions that reach a live state. Each limit is relaxed alone, and each family
    (all joints of one kind) together; the limits that fail on the re-opened transitions are
    named. If nothing re-opens, every limit that fails somewhere on ``base`` is named.
    """
    groups: dict[str, list[str]] = {}
    for name in masks:
        groups.setdefault(name.partition("_")[0], []).append(name)
    candidates = [[name] for name in masks] + [g for g in groups.values() if len(g) > 1]
    found: set[str] = set()
    for group in candidates:
        reopened = base.copy()
        for other, m in masks.items():
            if other not in group:
                reopened &= m
        if np.any(reopened):
            found.update(name for name in group if not np.all(masks[name][reopened]))
    if not found:
        found = {name for name, m in masks.items() if not np.all(m[base])}
    return [name for name in masks if name in found]


def _describe(names: list[str]) -> str:
    """``["torque_1", "jerk_1", "jerk_2"]`` -> a phrase naming the limits and joints."""
    words = {
        "torque": "torque limit",
        "qd": "joint velocity limit",
        "qdd": "joint acceleration limit",
        "jerk": "joint jerk limit",
        "start": "start no earlier than t_0 = 0",
        "q": "joint position limit",
    }
    joints: dict[str, list[str]] = {}
    for nm in names:
        fam, _, joint = nm.partition("_")
        joints.setdefault(fam, [])
        if joint:
            joints[fam].append(joint)
    out = []
    for fam, js in joints.items():
        w = words.get(fam, fam)
        if js:
            w += f" (joint{'s' if len(js) > 1 else ''} {', '.join(js)})"
        out.append(w)
    return ", ".join(out)


def _usage(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Largest fraction of each joint's limit used, ``(n,)``; NaN samples ignored."""
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(hi > 0, x / hi, np.where(x > 0, np.inf, 0.0))
        dn = np.where(lo < 0, x / lo, np.where(x < 0, np.inf, 0.0))
    both = np.fmax(up, dn)
    both = np.where(np.isnan(x), -np.inf, both)
    return np.max(both, axis=0)


def _usage_interval(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Largest distance from the middle of ``[lo, hi]`` per joint as a fraction of the half
    width ``(n,)`` (1 at a bound; joint positions, whose interval need not contain 0); an
    unbounded side counts 0."""
    finite = np.isfinite(lo) & np.isfinite(hi)
    mid = np.where(finite, 0.5 * (lo + hi), 0.0)
    half = np.where(finite, 0.5 * (hi - lo), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(half > 0, np.abs(x - mid) / half, np.where(x == mid, 0.0, np.inf))
    one_side = ~finite & (np.isfinite(lo) | np.isfinite(hi))  # only one bound: 0 inside
    if np.any(one_side):
        out = (x < lo) | (x > hi)
        u = np.where(one_side, np.where(out, np.inf, 0.0), u)
    return np.max(np.where(np.isnan(x), -np.inf, u), axis=0)


def limit_usage(values: dict[str, np.ndarray], lim: dict[str, tuple[np.ndarray, np.ndarray]],
                extra: dict[str, float] | None = None
                ) -> tuple[dict[str, float], bool, tuple[str, ...]]:
    """Usage of every limit by the realised values (``values[name] (K, n)``; families without
    values are skipped): ``{"torque_1": u, ...}`` (1 = at the limit; joint positions by
    :func:`_usage_interval`, the others by :func:`_usage`), merged by maximum with ``extra``
    (another planner's own usage), whether all hold (within ``LIMIT_RTOL``) and the active
    ones (used to at least ``ACTIVE_FRACTION``)."""
    extra = extra or {}
    usage: dict[str, float] = {}
    for name, (lo, hi) in lim.items():
        if name not in values:
            continue
        use = _usage_interval if name == "q" else _usage
        for k, u in enumerate(use(values[name], lo, hi)):
            key = f"{name}_{k + 1}"
            usage[key] = max(float(u), extra.get(key, 0.0))
    ok = all(u <= 1.0 + LIMIT_RTOL for u in usage.values())
    active = tuple(k for k, u in usage.items() if u >= ACTIVE_FRACTION)
    return usage, ok, active


def _position_block(
    pc: PhaseCoefficients, q_lim: tuple[np.ndarray, np.ndarray]
) -> tuple[int, list[int]] | None:
    """First stage whose ``q(x1[i])`` leaves the joint position limits, and its joints (a node
    state ``(x1[i], x2[j])`` is infeasible for every ``j``: q depends on r alone, Eq. (9))."""
    lo, hi = q_lim
    bad = (pc.q < lo - _slack(lo)) | (pc.q > hi + _slack(hi))
    rows = np.flatnonzero(np.any(bad, axis=1))
    if rows.size == 0:
        return None
    i = int(rows[0])
    return i, [int(k) for k in np.flatnonzero(bad[i])]


def limit_curve(
    pc: PhaseCoefficients, limits: dict[str, tuple[np.ndarray, np.ndarray]]
) -> np.ndarray:
    r"""The phase plane's limit curve: the largest ``r'`` at each grid point ``r`` for which the
    torque limits (Eq. (3), (12)) admit some ``r''`` and the velocity limits (Eq. (4)') hold,
    ``(K,)`` [1/s]; inf where nothing bounds it, NaN where no ``r'`` is admissible.

    With ``s = r'^2`` every joint's torque interval ``lo <= a r'' + b s + g <= hi`` is an
    interval of ``r''`` whose ends are linear in ``s``; they intersect iff every lower end is at
    most every upper end, a set of linear inequalities ``c0 + c1 s <= 0``, so the admissible
    ``s`` form one interval and the curve is the square root of its top. Acceleration and jerk
    limits depend on the neighbouring nodes and are not part of it.
    """
    K, n = pc.a.shape
    c0: list[np.ndarray] = []
    c1: list[np.ndarray] = []
    if "torque" in limits:
        lo, hi = limits["torque"]
        with np.errstate(divide="ignore", invalid="ignore"):
            ends = []  # per joint: (lower r'' end, upper r'' end) as (const, slope in s)
            for k in range(n):
                a, b, g = pc.a[:, k], pc.b[:, k], pc.g[:, k]
                if np.all(a == 0.0):
                    c0 += [g - hi[k], lo[k] - g]  # b s + g <= hi, lo <= b s + g
                    c1 += [b, -b]
                    continue
                e_lo = ((lo[k] - g) / a, -b / a)
                e_hi = ((hi[k] - g) / a, -b / a)
                pos = a > 0
                ends.append(((np.where(pos, e_lo[0], e_hi[0]), np.where(pos, e_lo[1], e_hi[1])),
                             (np.where(pos, e_hi[0], e_lo[0]), np.where(pos, e_hi[1], e_lo[1]))))
            for (lk, _) in ends:
                for (_, um) in ends:
                    c0.append(lk[0] - um[0])
                    c1.append(lk[1] - um[1])
    s_hi = np.full(K, np.inf)
    s_lo = np.zeros(K)
    empty = np.zeros(K, dtype=bool)
    for a0, a1 in zip(c0, c1, strict=True):
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = -a0 / a1
        s_hi = np.where((a1 > 0) & ~np.isnan(bound), np.minimum(s_hi, bound), s_hi)
        s_lo = np.where((a1 < 0) & ~np.isnan(bound), np.maximum(s_lo, bound), s_lo)
        empty |= (a1 == 0) & (a0 > 0)
    if "qd" in limits:
        lo, hi = limits["qd"]
        with np.errstate(divide="ignore", invalid="ignore"):
            cap = np.where(pc.dq > 0, hi / pc.dq, np.where(pc.dq < 0, lo / pc.dq, np.inf))
        s_hi = np.minimum(s_hi, np.min(cap, axis=1) ** 2)
    top = np.sqrt(np.maximum(s_hi, 0.0))
    return np.where(empty | (s_lo > s_hi) | (s_hi < 0), np.nan, top)
def position_limit_message(
    pc: PhaseCoefficients,
    path: JointPath,
    q_lim: tuple[np.ndarray, np.ndarray],
    blocked: tuple[int, list[int]],
    joint_names: Sequence[str] | None,
) -> tuple[str, list[str]]:
    """The message of a joint position limit that blocks stage ``blocked[0]`` (reading 8),
    naming the joints, r and the hand point; and the limit names ``q_k``."""
    i_b, js = blocked
    lo, hi = q_lim
    n = pc.q.shape[1]
    names = [f"q_{k + 1}" for k in js]
    hand = np.round(path.hand(pc.r[i_b:i_b + 1])[0], 4).tolist()
    jn = list(joint_names) if joint_names is not None else [f"q{k + 1}" for k in range(n)]
    detail = "; ".join(f"{jn[k]} = {pc.q[i_b, k]:.4g} outside [{lo[k]:.4g}, {hi[k]:.4g}]"
                       for k in js)
    message = (f"infeasible: joint position limit (joint{'s' if len(js) > 1 else ''} "
               f"{', '.join(f'{k + 1} = {jn[k]}' for k in js)}) blocks the motion at r = "
               f"{pc.r[i_b]:.4g} (hand at {hand} m; {detail}, SI units): the path's inverse "
               "kinematics leaves the joint limits there")
    return message, names
