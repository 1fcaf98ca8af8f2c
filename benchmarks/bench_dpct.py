"""Time the DPCT solver on park's §5 problem: python benchmarks/bench_dpct.py [repeats].

Prints, per case and grid, the best wall time of ``repeats`` solves (default 5) with t_a or the
duration, so the numbers can go in a closing note. park ran 50x100 in 7 minutes on a microVAX II;
the aim here is <= 0.05 s at 50x100 and <= 0.5 s at 100x200.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from mechkin.solvers.dynamics.open_chain import PlanarTwoLinkDynamics
from mechkin.solvers.track.dpct import (
    ConveyorReference,
    TrackLimits,
    TrackResult,
    solve_conveyor_tracking,
)
from mechkin.solvers.track.path import PlanarTwoLinkLinePath

PATH = PlanarTwoLinkLinePath([-0.8, 1.732], [-0.3, 1.732])
DYN = PlanarTwoLinkDynamics()
REF = ConveyorReference(part_start=[-0.9, 1.732], belt_velocity=[0.2, 0.0])
CASES = {
    "none": TrackLimits(),
    "torque": TrackLimits.symmetric(torque=[0.5, 0.2]),
    "full": TrackLimits.symmetric(
        torque=[0.5, 0.2], qd=[0.2, 0.2], qdd=[0.3, 0.3], jerk=[2.3, 2.0]
    ),
    "tva": TrackLimits.symmetric(torque=[0.5, 0.2], qd=[0.2, 0.2], qdd=[0.3, 0.3]),
}
RUNS = [
    ("tracking", "none", 50, 100),
    ("tracking", "torque", 50, 100),
    ("tracking", "full", 30, 50),
    ("tracking", "full", 50, 100),
    ("tracking", "full", 100, 200),
    ("tracking", "none", 100, 200),
    ("tracking", "torque", 100, 200),
    ("time", "torque", 50, 500),
    ("time", "tva", 50, 500),
    ("time", "full", 50, 500),
    ("time", "torque", 100, 1000),
    ("time", "tva", 100, 1000),
]


def best_of(repeats: int, objective: str, case: str, N1: int, N2: int) -> tuple[float, TrackResult]:
    times = []
    res = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = solve_conveyor_tracking(
            dynamics=DYN,
            path=PATH,
            reference=REF,
            limits=CASES[case],
            N1=N1,
            N2=N2,
            objective=objective,  # type: ignore[arg-type]
        )
        times.append(time.perf_counter() - t0)
    assert res is not None
    return min(times), res


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    print(
        f"{'objective':9} {'limits':6} {'grid':>9} {'best_s':>8} {'t_a_s':>7} {'duration_s':>10}"
        "  peak_torque_Nm"
    )
    for objective, case, N1, N2 in RUNS:
        reps = repeats if N2 <= 500 else 1
        best, res = best_of(reps, objective, case, N1, N2)
        peak = np.round(res.peak_torque, 4).tolist() if res.peak_torque is not None else None
        t_a = f"{res.t_a_s:7.4f}" if res.t_a_s is not None else f"{'-':>7}"
        print(
            f"{objective:9} {case:6} {f'{N1}x{N2}':>9} {best:8.4f} {t_a} "
            f"{res.duration_s:10.4f}  {peak}  {res.status.value}"
        )


if __name__ == "__main__":
    main()
