"""mechkin's TOPP-RA vs toppra vs the phase-plane DP: python benchmarks/bench_topp.py [repeats].

Problem: park's 2-link arm along its hand line (-0.8, 1.732) -> (-0.3, 1.732) m, rest to rest,
torque limits (0.5, 0.2) N m alone and with |qd| <= 0.2 rad/s, |qdd| <= 0.3 rad/s^2. The path is
a toppra ``SplineInterpolator`` through 41 samples of q(s), and both planners read q, q', q''
from that spline, so they solve the same problem on the same grid with the same discretisation
(first-order interpolation, toppra's default for acceleration; its torque constraint is set to
the same).

Timed, same process, interleaved repeats, medians:

* ``mk_full``: spline evaluation, ``torque_coefficients`` (three batched inverse-dynamics
  calls) and ``plan_time_optimal``;
* ``mk_core``: ``solve_topp`` on prebuilt canonical rows (the planner alone);
* ``tp_full``: toppra's ``JointTorqueConstraint`` / ``JointVelocityConstraint`` /
  ``JointAccelerationConstraint``, ``TOPPRA(..., solver_wrapper="seidel")`` and
  ``compute_trajectory`` (the usual call);
* ``tp_core``: toppra on the same precomputed canonical arrays (a ``LinearConstraint`` that
  returns them) with ``compute_parameterization`` (toppra's planner alone).

Durations are compared with toppra's converged value (N = 4000). The DP of
:mod:`mechkin.solvers.track.dpct` (``objective="time"``, analytic path, its own transition model) is
run once per grid for reference. toppra is the ``bench`` extra (``pip install -e ".[bench]"``);
without it only mechkin's numbers are printed.
"""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable

import numpy as np

from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics
from mechkin.solvers.track.dpct import TrackLimits, solve_conveyor_tracking
from mechkin.solvers.track.path import PlanarTwoLinkLinePath
from mechkin.solvers.track.topp import (
    constraint_rows,
    plan_time_optimal,
    solve_topp,
    torque_coefficients,
    velocity_bounds,
)

try:
    import toppra
    import toppra.algorithm
    import toppra.constraint as tc
    from toppra.constraint.linear_constraint import canlinear_colloc_to_interpolate
except ImportError:  # the bench extra is optional
    toppra = None

PATH = PlanarTwoLinkLinePath([-0.8, 1.732], [-0.3, 1.732])  # park §5.1
DYN = PlanarTwoLinkDynamics()
TORQUE, QD, QDD = np.array([0.5, 0.2]), np.array([0.2, 0.2]), np.array([0.3, 0.3])
GRIDS = (100, 500, 1000)
N_CONVERGED = 4000
DP_GRIDS = ((50, 200), (100, 500))


class SplinePath:
    """q(s) as a cubic spline through 41 samples (toppra's, or scipy's with the same knots)."""

    def __init__(self) -> None:
        knots = np.linspace(0.0, 1.0, 41)
        if toppra is not None:
            self.spline = toppra.SplineInterpolator(knots, PATH.q(knots))
            self.eval = lambda s, k: self.spline(s, k)
        else:
            from scipy.interpolate import CubicSpline

            cs = CubicSpline(knots, PATH.q(knots), bc_type="not-a-knot")
            self.eval = lambda s, k: cs(s, k)


SP = SplinePath()


def inv_dyn_1(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """One-sample inverse dynamics for toppra."""
    return DYN.inverse_dynamics(q[None], qd[None], qdd[None])[0]


def mk_full(N: int, with_va: bool) -> float:
    s = np.linspace(0.0, 1.0, N + 1)
    q, dq, ddq = SP.eval(s, 0), SP.eval(s, 1), SP.eval(s, 2)
    res = plan_time_optimal(
        s,
        dq,
        ddq,
        q=q,
        torque=TORQUE,
        inverse_dynamics=DYN.inverse_dynamics,
        qd=QD if with_va else None,
        qdd=QDD if with_va else None,
    )
    assert res.duration_s is not None, res.message
    return res.duration_s


def canonical(N: int, with_va: bool) -> dict[str, np.ndarray]:
    """Precomputed arrays of the problem (outside the timed core calls)."""
    s = np.linspace(0.0, 1.0, N + 1)
    q, dq, ddq = SP.eval(s, 0), SP.eval(s, 1), SP.eval(s, 2)
    A, B, C = torque_coefficients(DYN.inverse_dynamics, q, dq, ddq)
    rows = constraint_rows(
        dq, ddq, torque=TORQUE, torque_coeffs=(A, B, C), qdd=QDD if with_va else None
    )
    x_lo, x_hi, _, _ = velocity_bounds(dq, QD if with_va else None)
    return {"s": s, "rows": rows, "x_lo": x_lo, "x_hi": x_hi}


def mk_core(case: dict) -> float:
    res = solve_topp(case["s"], case["rows"], x_lo=case["x_lo"], x_hi=case["x_hi"])
    assert res.duration_s is not None, res.message
    return res.duration_s


if toppra is not None:

    class Precomputed(tc.LinearConstraint):  # type: ignore[misc]
        """The canonical rows ``lo <= a u + b x + c <= hi`` and x bounds as one toppra
        constraint, interpolated like toppra's own."""

        def __init__(self, case: dict) -> None:
            super().__init__()
            rows = case["rows"]
            m = rows.a.shape[1]
            self.F = np.vstack([np.eye(m), -np.eye(m)])
            self.g = np.concatenate([rows.hi[0], -rows.lo[0]])
            self.abc = (rows.a, rows.b, rows.c)
            self.xbound = np.stack([case["x_lo"], np.minimum(case["x_hi"], 1e8)], axis=1)
            self.s = case["s"]
            self.identical = True
            self.dof = 2
            self._format_string = "precomputed"
            self.discretization_type = tc.DiscretizationType.Interpolation

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):  # type: ignore[no-untyped-def]
            a, b, c = self.abc
            out = canlinear_colloc_to_interpolate(
                a, b, c, self.F, self.g, None, None, gridpoints, identical=True
            )
            return (*out[:5], None, self.xbound)


def tp_full(N: int, with_va: bool) -> float:
    kind = tc.DiscretizationType.Interpolation
    cons = [
        tc.JointTorqueConstraint(
            inv_dyn_1, np.stack([-TORQUE, TORQUE], 1), np.zeros(2), discretization_scheme=kind
        )
    ]
    if with_va:
        cons.append(tc.JointVelocityConstraint(np.stack([-QD, QD], 1)))
        cons.append(tc.JointAccelerationConstraint(np.stack([-QDD, QDD], 1), kind))
    algo = toppra.algorithm.TOPPRA(
        cons, SP.spline, gridpoints=np.linspace(0.0, 1.0, N + 1), solver_wrapper="seidel"
    )
    traj = algo.compute_trajectory(0.0, 0.0)
    return float(traj.duration)


def tp_core(case: dict) -> float:
    algo = toppra.algorithm.TOPPRA(
        [Precomputed(case)], SP.spline, gridpoints=case["s"], solver_wrapper="seidel"
    )
    _, sd, _ = algo.compute_parameterization(0.0, 0.0)
    return float(np.sum(2.0 * np.diff(case["s"]) / (sd[:-1] + sd[1:])))


def timed(fn: Callable[[], float]) -> tuple[float, float]:
    t0 = time.perf_counter()
    d = fn()
    return d, time.perf_counter() - t0


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    if toppra is not None:
        toppra.setup_logging("WARNING")
    else:
        print("toppra is not installed (pip install -e '.[bench]'): mechkin only")
    for with_va in (False, True):
        label = "torque+qd+qdd" if with_va else "torque"
        ref = tp_full(N_CONVERGED, with_va) if toppra is not None else mk_full(20000, with_va)
        src = f"toppra N={N_CONVERGED}" if toppra is not None else "mechkin N=20000"
        print(f"\n{label}: converged duration {ref:.6f} s ({src})")
        print(
            f"{'N':>5} {'mk_s':>9} {'mk_err%':>8} {'tp_s':>9} {'tp_err%':>8} "
            f"{'mk_full_ms':>10} {'tp_full_ms':>10} {'full_ratio':>10} "
            f"{'mk_core_ms':>10} {'tp_core_ms':>10} {'core_ratio':>10}"
        )
        for N in GRIDS:
            case = canonical(N, with_va)
            fns: dict[str, Callable[[], float]] = {
                "mk_full": lambda N=N, va=with_va: mk_full(N, va),
                "mk_core": lambda case=case: mk_core(case),
            }
            if toppra is not None:
                fns["tp_full"] = lambda N=N, va=with_va: tp_full(N, va)
                fns["tp_core"] = lambda case=case: tp_core(case)
            for fn in fns.values():  # warm-up
                fn()
            times: dict[str, list[float]] = {k: [] for k in fns}
            durs: dict[str, float] = {}
            for _ in range(repeats):  # interleaved
                for k, fn in fns.items():
                    durs[k], dt = timed(fn)
                    times[k].append(dt)
            med = {k: 1e3 * statistics.median(v) for k, v in times.items()}
            d_mk = durs["mk_full"]
            d_tp = durs.get("tp_full", float("nan"))
            print(
                f"{N:5d} {d_mk:9.5f} {100 * (d_mk - ref) / ref:8.4f} {d_tp:9.5f} "
                f"{100 * (d_tp - ref) / ref:8.4f} {med['mk_full']:10.2f} "
                f"{med.get('tp_full', float('nan')):10.2f} "
                f"{med['mk_full'] / med.get('tp_full', float('nan')):10.4f} "
                f"{med['mk_core']:10.2f} {med.get('tp_core', float('nan')):10.2f} "
                f"{med['mk_core'] / med.get('tp_core', float('nan')):10.4f}"
            )
            if toppra is not None:
                assert abs(durs["tp_core"] - d_tp) <= 1e-6 * d_tp, (durs["tp_core"], d_tp)
        lim = (
            TrackLimits.symmetric(torque=TORQUE, qd=QD, qdd=QDD)
            if with_va
            else TrackLimits.symmetric(torque=TORQUE)
        )
        for N1, N2 in DP_GRIDS:
            t0 = time.perf_counter()
            res = solve_conveyor_tracking(
                dynamics=DYN, path=PATH, limits=lim, N1=N1, N2=N2, objective="time"
            )
            dt = time.perf_counter() - t0
            d = res.duration_s if res.duration_s is not None else float("nan")
            print(
                f"  DP {N1}x{N2}: {d:.5f} s ({100 * (d - ref) / ref:+.3f} %), "
                f"{1e3 * dt:.0f} ms (one run)"
            )


if __name__ == "__main__":
    main()
