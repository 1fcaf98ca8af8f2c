"""The DP readings of park §4 selectable by ``DPOptions`` (issue 17 item 4).

Every reading is checked against an independent DP written here with plain loops: its own
inverse kinematics of park's arm (§5.1: hand x = -0.8 + 0.5 r, y = 1.732, elbow q2 > 0), f' from
the Jacobian and f'' by central differences, park's closed-form M and h (uniform rods, l = 1 m,
m = 1 kg, PAPER_NOTES), the step time of the reading (Eq. (26) literally for ``euler``), the
start rule t >= 0 and, for ``wait_cost``, Eq. (18) over the wait integrated by scipy's quad.
The solver and the loop DP must give the same t_a, start time, peak torques and cost.

Values typed from issue 17 (item 4, "an independent oracle"): torque-only t_a 0.90 s
(trapezoid) and 0.85 s (euler) at 50 x 100; with the wait costed, unconstrained peaks about
-2.80 / -0.61 N m. The paper (§5.3) prints 0.8 s and -1.342 / -0.406 N m.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from mechkin.errors import ConfigError
from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics
from mechkin.solvers.track.dpct import (
    ConveyorReference,
    DPOptions,
    TrackLimits,
    TrackResult,
    TrackStatus,
    limit_curve,
    solve_conveyor_tracking,
    step_arrays,
    wait_cost,
)
from mechkin.solvers.track.path import PlanarTwoLinkLinePath, phase_coefficients

PATH = PlanarTwoLinkLinePath([-0.8, 1.732], [-0.3, 1.732])  # park §5.1
REF = ConveyorReference(part_start=[-0.9, 1.732], belt_velocity=[0.2, 0.0])  # park §5.1
TORQUE = (0.5, 0.2)  # park Eq. (36)
FULL = TrackLimits.symmetric(torque=TORQUE, qd=[0.2, 0.2], qdd=[0.3, 0.3], jerk=[2.3, 2.0])


def solve(limits: TrackLimits, N1: int, N2: int, dp: DPOptions | None = None,
          objective: str = "tracking", **kw: object) -> TrackResult:
    res = solve_conveyor_tracking(dynamics=PlanarTwoLinkDynamics(), path=PATH, reference=REF,
                                  limits=limits, N1=N1, N2=N2, dp=dp,
                                  objective=objective, **kw)  # type: ignore[arg-type]
    assert res.status is TrackStatus.OK, res.message
    return res


# ---- the independent loop DP ----------------------------------------------------------------


def _ik(r: float) -> tuple[float, float]:
    x, y = -0.8 + 0.5 * r, 1.732
    c2 = (x * x + y * y - 2.0) / 2.0
    q2 = math.acos(c2)
    return math.atan2(y, x) - math.atan2(math.sin(q2), 1.0 + c2), q2


def _dq(r: float) -> np.ndarray:
    q1, q2 = _ik(r)
    s1, c1, s12, c12 = math.sin(q1), math.cos(q1), math.sin(q1 + q2), math.cos(q1 + q2)
    return np.linalg.solve(np.array([[-s1 - s12, -s12], [c1 + c12, c12]]), [0.5, 0.0])


def _coeffs(r: float) -> tuple[np.ndarray, np.ndarray]:
    """U = A r'' + B r'^2 from park's M, h (Eq. (8), (12)); f'' by central differences."""
    _, q2 = _ik(r)
    f1 = _dq(r)
    f2 = (_dq(r + 1e-6) - _dq(r - 1e-6)) / 2e-6
    c2, s2 = math.cos(q2), math.sin(q2)
    M = np.array([[5 / 3 + c2, 1 / 3 + c2 / 2], [1 / 3 + c2 / 2, 1 / 3]])
    h = np.array([-s2 * (f1[0] * f1[1] + f1[1] ** 2 / 2), s2 * f1[0] ** 2 / 2])
    return M @ f1, M @ f2 + h


def loop_dp(N1: int, N2: int, torque: tuple[float, float] | None, step_time: str,
            costed_wait: bool) -> tuple[float, float, list[float], float]:
    """(t_a, t(0, 0), peak torques, J*) of park §4 with loops (Eq. (23)-(30))."""
    r0, rd = -0.2, 0.4  # x~1 = 0.4 t - 0.2, x~2 = 0.4 /s (PAPER_NOTES)
    Nt = round(0.8 * N2)
    x2 = [j * rd / Nt for j in range(N2 + 1)]
    x2[Nt] = rd
    dx1 = 1.0 / N1
    x1 = [i / N1 for i in range(N1 + 1)]
    AB = [_coeffs(x) for x in x1]

    def step(a: float, b: float) -> tuple[float, float]:
        if step_time == "euler" and a > 0:
            dt = dx1 / a  # park Eq. (26)
            return dt, (b - a) / dt  # park Eq. (21)
        return 2 * dx1 / (a + b), (b * b - a * a) / (2 * dx1)

    def torque_ok(U: np.ndarray) -> bool:
        return torque is None or all(abs(U[k]) <= torque[k] * (1 + 1e-9) for k in range(2))

    V = [[math.inf] * (N2 + 1) for _ in range(N1 + 1)]
    T = [[0.0] * (N2 + 1) for _ in range(N1 + 1)]
    NP = [[0] * (N2 + 1) for _ in range(N1)]
    V[N1][Nt], T[N1][Nt] = 0.0, (1 - r0) / rd
    for i in range(N1 - 1, -1, -1):
        A, B = AB[i]
        for j in range(N2 + 1) if i else [0]:
            best, bl, bt = math.inf, 0, 0.0
            for m in range(N2 + 1):  # the next state l of park §4.2
                if V[i + 1][m] == math.inf or j == m == 0:
                    continue
                dt, rdd = step(x2[j], x2[m])
                t = T[i + 1][m] - dt
                if not torque_ok(A * rdd + B * x2[j] ** 2) or t < -1e-9:
                    continue
                c = dt * ((x1[i] - (r0 + rd * t)) ** 2 + (x2[j] - rd) ** 2) + V[i + 1][m]
                if i == 0 and costed_wait:  # park Eq. (18) from t_0 = 0
                    c += quad(lambda s: (r0 + rd * s) ** 2 + rd * rd, 0.0, max(t, 0.0))[0]
                if c < best:
                    best, bl, bt = c, m, t
            V[i][j], NP[i][j], T[i][j] = best, bl, bt
    js = [0]
    for i in range(N1):
        js.append(NP[i][js[-1]])
    ts = [T[i][js[i]] for i in range(N1 + 1)]
    k = N1
    while k > 0 and abs(x1[k - 1] - (r0 + rd * ts[k - 1])) <= 1e-9 and js[k - 1] == Nt:
        k -= 1
    peak = [0.0, 0.0]
    for i in range(N1 + 1):
        A, B = AB[i]
        a = x2[js[i]]
        rdd = 0.0 if i == N1 else step(a, x2[js[i + 1]])[1]
        U = A * rdd + B * a * a
        peak = [U[m] if abs(U[m]) > abs(peak[m]) else peak[m] for m in range(2)]
    return ts[k], ts[0], peak, V[0][0]


# ---- the readings against the loop DP ----------------------------------------------------------


@pytest.mark.parametrize("torque", [None, TORQUE], ids=["none", "torque"])
@pytest.mark.parametrize("wait", [False, True], ids=["free-wait", "costed-wait"])
@pytest.mark.parametrize("step_time", ["trapezoid", "euler"])
def test_every_reading_equals_the_loop_dp(step_time: str, wait: bool, torque) -> None:
    limits = TrackLimits() if torque is None else TrackLimits.symmetric(torque=torque)
    res = solve(limits, 25, 50, DPOptions(step_time=step_time, wait_cost=wait))  # type: ignore
    t_a, t0, peak, cost = loop_dp(25, 50, torque, step_time, wait)
    assert res.t_a_s == pytest.approx(t_a, abs=1e-12)
    assert res.t_start_s == pytest.approx(t0, abs=1e-12)
    assert res.peak_torque == pytest.approx(peak, abs=1e-7)
    assert res.cost == pytest.approx(cost, rel=1e-9)
    assert res.time_penalty == 0.0 and res.limits_ok


def test_euler_reaches_the_part_earlier_than_trapezoid_on_a_small_grid() -> None:
    """15 x 20, torque only: the loop DP gives t_a 1.0 s (trapezoid) and 0.833 s (euler)."""
    lim = TrackLimits.symmetric(torque=TORQUE)
    for st in ("trapezoid", "euler"):
        t_a, t0, peak, _ = loop_dp(15, 20, TORQUE, st, False)
        res = solve(lim, 15, 20, DPOptions(step_time=st))  # type: ignore[arg-type]
        assert res.t_a_s == pytest.approx(t_a, abs=1e-12)
        assert res.peak_torque == pytest.approx(peak, abs=1e-7)
    assert loop_dp(15, 20, TORQUE, "trapezoid", False)[0] == pytest.approx(1.0, abs=1e-12)
    assert loop_dp(15, 20, TORQUE, "euler", False)[0] == pytest.approx(5 / 6, abs=1e-12)


def test_issue17_values_at_50x100() -> None:
    """issue 17 item 4: torque-only t_a 0.90 s (trapezoid), 0.85 s (euler, Eq. (26) literal);
    wait costed, no limits: peaks about -2.80 / -0.61 N m (paper -1.342 / -0.406)."""
    lim = TrackLimits.symmetric(torque=TORQUE)
    assert solve(lim, 50, 100).t_a_s == pytest.approx(0.90, abs=1e-9)
    assert solve(lim, 50, 100, DPOptions(step_time="euler")).t_a_s == pytest.approx(0.85, abs=1e-9)
    peak = solve(TrackLimits(), 50, 100, DPOptions(wait_cost=True)).peak_torque
    assert peak[0] == pytest.approx(-2.80, abs=0.005)
    assert peak[1] == pytest.approx(-0.61, abs=0.005)


def test_defaults_are_todays_readings() -> None:
    """DPOptions() and dp=None give the same plan (bit for bit) and the park §5 values."""
    lim = TrackLimits.symmetric(torque=TORQUE)
    a, b = solve(lim, 50, 100), solve(lim, 50, 100, DPOptions())
    assert a.trajectory is not None and b.trajectory is not None
    for name in ("t", "r", "rd", "rdd", "q", "qd", "torque"):
        assert np.array_equal(getattr(a.trajectory, name), getattr(b.trajectory, name))
    assert a.cost == b.cost and a.summary()["dp"] == {"step_time": "trapezoid",
                                                      "wait_cost": False, "jerk_ends": False}
    no = solve(TrackLimits(), 50, 100).peak_torque  # park §5.3 case 1 as mechkin reads it
    assert no == pytest.approx([-5.881, -1.2726], abs=5e-4)


def test_step_arrays_readings() -> None:
    """Eq. (26): dt = dx1 / x2[j]; Eq. (21): r'' = (x2[l] - x2[j]) / dt; from rest both readings
    take the constant-acceleration step 2 dx1 / x2[l]; at j = l they agree."""
    dx1 = 0.02
    a, b = np.array([0.1, 0.0, 0.3]), np.array([0.2, 0.4, 0.3])
    dt, inv, rdd = step_arrays(a, b, dx1, "euler")
    assert dt == pytest.approx([0.2, 0.1, 0.02 / 0.3])
    assert rdd == pytest.approx([0.1 * 0.1 / 0.02, 0.16 / 0.04, 0.0])
    assert inv == pytest.approx(1 / dt)
    dt_t, _, rdd_t = step_arrays(a, b, dx1, "trapezoid")
    assert dt_t == pytest.approx([0.04 / 0.3, 0.1, 0.02 / 0.3])
    assert rdd_t == pytest.approx([(0.04 - 0.01) / 0.04, 4.0, 0.0])


def test_wait_cost_is_the_integral_of_eq18() -> None:
    r0, rd = -0.2, 0.4
    for ts in (0.0, 0.3, 0.5, 1.7):
        ref = quad(lambda s: (r0 + rd * s) ** 2 + rd * rd, 0.0, ts)[0]
        assert float(wait_cost(np.array(ts), r0, rd)) == pytest.approx(ref, rel=1e-12, abs=1e-15)
    assert float(wait_cost(np.array(-1.0), r0, rd)) == 0.0


def test_wait_cost_starts_earlier_and_lowers_the_peaks() -> None:
    """Costing the wait (0.16 /s at least, from x~2^2) makes the hand leave rest earlier."""
    free = solve(TrackLimits(), 50, 100)
    paid = solve(TrackLimits(), 50, 100, DPOptions(wait_cost=True))
    assert paid.t_start_s < free.t_start_s
    assert np.all(np.abs(paid.peak_torque) < np.abs(free.peak_torque))
    with pytest.raises(ConfigError, match="wait_cost"):
        solve_conveyor_tracking(dynamics=PlanarTwoLinkDynamics(), path=PATH, reference=REF,
                                N1=10, N2=20, objective="time", dp=DPOptions(wait_cost=True))


def test_jerk_ends_checks_the_step_from_rest() -> None:
    """Minimum time with |jerk| <= 0.6: today's plan leaves rest with a jerk of 0.98 rad/s^3
    on joint 2 (unchecked, yet limits_ok); with jerk_ends the first step keeps the limit, and
    the plan is slower."""
    lim = TrackLimits.symmetric(torque=TORQUE, qd=[0.2, 0.2], qdd=[0.3, 0.3], jerk=[0.6, 0.6])

    def start_jerk(res: TrackResult) -> np.ndarray:
        tr = res.trajectory
        assert tr is not None
        return tr.qdd[0] / (tr.t[1] - tr.t[0])  # (qdd_0 - 0) / dt_0, Eq. (33) from rest

    free = solve(lim, 50, 100, objective="time")
    checked = solve(lim, 50, 100, DPOptions(jerk_ends=True), objective="time")
    assert np.max(np.abs(start_jerk(free))) > 0.6
    assert np.all(np.abs(start_jerk(checked)) <= 0.6 * (1 + 1e-9))
    assert checked.duration_s > free.duration_s
    assert checked.limits_ok and checked.limit_usage["jerk_2"] <= 1.0 + 1e-9
    tr, tr_free = checked.trajectory, free.trajectory
    assert tr is not None and tr_free is not None
    assert np.isfinite(tr.jerk[-2]).all() and np.isnan(tr_free.jerk[-2]).all()


def test_jerk_ends_leave_park_full_case_unchanged() -> None:
    """park Eq. (37) jerks (2.3 / 2.0): the end steps use under half of them at 50 x 100, so the
    option changes nothing there (measured: first step 0.79 / 0.93 rad/s^3)."""
    a, b = solve(FULL, 50, 100), solve(FULL, 50, 100, DPOptions(jerk_ends=True))
    assert a.t_a_s == b.t_a_s and a.cost == b.cost


def test_limit_curve_is_the_torque_and_velocity_boundary() -> None:
    """At each r the curve's r' admits an r'' within the torque limits and a slightly larger r'
    admits none (each joint's r'' interval at that r', intersected directly)."""
    lim = TrackLimits.symmetric(torque=TORQUE).families()
    pc = phase_coefficients(PlanarTwoLinkDynamics(), PATH, np.linspace(0, 1, 11))
    top = limit_curve(pc, lim)
    assert np.all(np.isfinite(top)) and np.all(top > 0)
    def admissible(i: int, x: float) -> bool:
        c = pc.b[i] * x * x + pc.g[i]  # U = a r'' + c, |U| <= TORQUE
        ends = np.sort(np.stack([(-np.array(TORQUE) - c) / pc.a[i],
                                 (np.array(TORQUE) - c) / pc.a[i]]), axis=0)
        return bool(np.max(ends[0]) <= np.min(ends[1]))

    for i, s in enumerate(top):
        assert admissible(i, s * (1 - 1e-6)) and not admissible(i, s * (1 + 1e-6))
    vel = limit_curve(pc, TrackLimits.symmetric(qd=[0.2, 0.2]).families())
    assert np.max(np.abs(pc.dq * vel[:, None]), axis=1) == pytest.approx(0.2)
    assert np.all(np.isinf(limit_curve(pc, {})))
