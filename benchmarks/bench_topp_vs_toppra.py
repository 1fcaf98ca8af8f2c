"""Time-optimal mode vs toppra on park's path: python benchmarks/bench_topp_vs_toppra.py [repeats].

Same path (the analytic q(r), f', f'' of park's 2-link arm, handed to toppra as a geometric path),
same dynamics and limits, rest to rest. Prints durations and best-of-``repeats`` runtimes of both
and their ratios (DP / toppra). toppra is a benchmark-only dependency (``pip install toppra``);
mechkin never imports it. toppra cannot take jerk limits; its acceleration limit is collocated
(``qdd = f'' s'^2 + f' s''`` at each grid point) where the DP uses Eq. (32) differences.
"""

from __future__ import annotations

import sys
import time

import numpy as np
import toppra
import toppra.algorithm
import toppra.constraint as tc
from toppra.interpolator import AbstractGeometricPath

from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics
from mechkin.solvers.track.dpct import TrackLimits, solve_conveyor_tracking
from mechkin.solvers.track.path import PlanarTwoLinkLinePath

PATH = PlanarTwoLinkLinePath([-0.8, 1.732], [-0.3, 1.732])
DYN = PlanarTwoLinkDynamics()
TORQUE = np.array([0.5, 0.2])
QD = np.array([0.2, 0.2])
QDD = np.array([0.3, 0.3])


class ParkPath(AbstractGeometricPath):  # type: ignore[misc]
    """park's hand line as a toppra geometric path, r in [0, 1]."""

    def __call__(self, s: float | np.ndarray, order: int = 0) -> np.ndarray:
        r = np.atleast_1d(np.asarray(s, dtype=np.float64))
        out = (PATH.q, PATH.dq, PATH.ddq)[order](r)
        return out[0] if np.ndim(s) == 0 else out

    @property
    def dof(self) -> int:
        return 2

    @property
    def path_interval(self) -> np.ndarray:
        return np.array([0.0, 1.0])


def inverse_dynamics(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    return DYN.inverse_dynamics(q[None], qd[None], qdd[None])[0]


def run_toppra(n_grid: int, with_vel_acc: bool) -> tuple[float, float]:
    colloc = tc.DiscretizationType.Collocation
    cons = [
        tc.JointTorqueConstraint(
            inverse_dynamics,
            np.stack([-TORQUE, TORQUE], 1),
            np.zeros(2),
            discretization_scheme=colloc,
        )
    ]
    if with_vel_acc:
        cons.append(tc.JointVelocityConstraint(np.stack([-QD, QD], 1)))
        cons.append(
            tc.JointAccelerationConstraint(np.stack([-QDD, QDD], 1), discretization_scheme=colloc)
        )
    t0 = time.perf_counter()
    algo = toppra.algorithm.TOPPRA(
        cons, ParkPath(), gridpoints=np.linspace(0.0, 1.0, n_grid + 1), solver_wrapper="seidel"
    )
    traj = algo.compute_trajectory(0.0, 0.0)
    return float(traj.duration), time.perf_counter() - t0


def run_dp(N1: int, N2: int, with_vel_acc: bool) -> tuple[float, float]:
    limits = (
        TrackLimits.symmetric(torque=TORQUE, qd=QD, qdd=QDD)
        if with_vel_acc
        else TrackLimits.symmetric(torque=TORQUE)
    )
    t0 = time.perf_counter()
    res = solve_conveyor_tracking(
        dynamics=DYN, path=PATH, limits=limits, N1=N1, N2=N2, objective="time"
    )
    assert res.duration_s is not None
    return res.duration_s, time.perf_counter() - t0


def best(fn, repeats: int, *args):  # type: ignore[no-untyped-def]
    runs = [fn(*args) for _ in range(repeats)]
    return runs[0][0], min(r[1] for r in runs)


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    toppra.setup_logging("WARNING")
    print(
        f"{'limits':14} {'DP grid':>9} {'DP_s':>8} {'DP_run_s':>9} {'toppra N':>8} "
        f"{'toppra_s':>9} {'toppra_run_s':>12} {'dur_ratio':>9} {'run_ratio':>9}"
    )
    for with_va in (False, True):
        label = "torque+qd+qdd" if with_va else "torque"
        for (N1, N2), n_grid in (((50, 500), 50), ((50, 500), 1000), ((100, 1000), 1000)):
            reps = repeats if N2 <= 500 else 1
            d_dp, t_dp = best(run_dp, reps, N1, N2, with_va)
            d_tp, t_tp = best(run_toppra, repeats, n_grid, with_va)
            print(
                f"{label:14} {f'{N1}x{N2}':>9} {d_dp:8.4f} {t_dp:9.4f} {n_grid:8d} {d_tp:9.4f} "
                f"{t_tp:12.4f} {d_dp / d_tp:9.4f} {t_dp / t_tp:9.1f}"
            )


if __name__ == "__main__":
    main()
